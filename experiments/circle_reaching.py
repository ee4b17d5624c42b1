#!/usr/bin/env python
"""§4.2.2 / Fig. 8: three Franka Panda arms reach a larger, displaced and tilted cooperative circle.

System ``three_franka`` (21 joints; bases 120° apart on a 0.8 m circle, facing the centre),
cooperative circle through the three TCPs (Eq 14), starting at rest at the nominal q0
(initial circle: centre (0, 0, 0.487) m, radius 0.493 m, normal +z).

Target (defaults, see the options): the initial circle moved by the world similarity

    S = T(t) · [R(25° about +x) · D(1.25)] about the initial centre,   t = (0.10, −0.05, 0.10) m,

i.e. centre (0.10, −0.05, 0.587) m, radius 0.616 m, normal tilted 25° from +z toward −y.
The target versor is its canonical similarity ``V_Sd = V_S(X_u, X_d)`` (Eq 28).  A
Gauss–Newton IK solve checks that it is reachable.

Solvers:

* iLQR on Eq 53–57 (``coop_ga.control.ilqr_reach``): double integrator x = [q; q̇], u = q̈,
  250 knots × Δt = 0.01 s = 2.5 s (the paper's Δt = 0.001 s contradicts its 2.5 s
  horizon), R = 1e-3 I, Q = 1e5 I, terminal rest term 1e2 ‖q̇_n‖², tol 1e-5;
* differential IK for comparison (``coop_ga.control.diff_ik_reach``): commanded body
  velocity ``B = gain · log(Ṽ_Sc V_Sd)`` over the same 2.5 s (gain 4 /s, Δt = 0.01 s).

Writes to ``--out``: ``metrics.json``, ``trajectory.npz`` and ``circle_reaching.png``
(left: the arms at the initial (light) and final (dark) configuration, the initial (green),
intermediate (red), final (turquoise) and target (black, dashed) circles and the TCP paths;
right: the bivector command ``J^G(q_t) q̇_t`` — the body velocity of the cooperative
circle — and the error bivector ``log(Ṽ_Sc(q_t) V_Sd)`` over the horizon, and the error
norm of iLQR and differential IK).

    python experiments/circle_reaching.py --out results/circle_reaching
"""

from __future__ import annotations

import sys
import time

import numpy as np

from coop_ga.harness import Experiment, finite_float, nonneg_float, positive_float, positive_int


def _circle_params(X) -> dict:
    import coop_ga as cg

    return {
        "center_m": np.asarray(cg.center(X), float),
        "radius_m": float(cg.radius(X)),
        "normal": np.asarray(cg.normal(X), float),
    }


def main(argv: list[str] | None = None) -> int:
    exp = Experiment(__file__, __doc__, seed=0)
    exp.add(
        "--perturb",
        type=nonneg_float,
        default=0.0,
        help="half-width [rad] of a uniform perturbation U(±perturb) of the initial configuration, drawn with --seed",
    )
    exp.add(
        "--translation",
        type=finite_float,
        nargs=3,
        default=(0.10, -0.05, 0.10),
        metavar=("X", "Y", "Z"),
        help="target displacement of the circle centre [m]",
    )
    exp.add("--tilt-deg", type=finite_float, default=25.0, help="tilt of the target circle [deg]")
    exp.add(
        "--tilt-axis",
        type=finite_float,
        nargs=3,
        default=(1.0, 0.0, 0.0),
        metavar=("X", "Y", "Z"),
        help="world axis of the tilt through the circle centre",
    )
    exp.add("--scale", type=positive_float, default=1.25, help="radius scale factor of the target")
    exp.add("--horizon", type=positive_int, default=250, help="iLQR knots")
    exp.add("--dt", type=positive_float, default=0.01, help="time step [s] of iLQR and differential IK")
    exp.add("--max-iter", type=positive_int, default=40, help="iLQR iteration limit (all outer iterations together)")
    exp.add(
        "--backward",
        choices=("auto", "riccati"),
        default="auto",
        help="iLQR LQ step: auto = closed form while no constraint is active, riccati = always the box-DDP pass",
    )
    exp.add("--diffik-gain", type=positive_float, default=10.0, help="differential-IK gain [1/s] (its default)")
    args = exp.parse(argv)
    plt = exp.pyplot()

    import coop_ga as cg
    from coop_ga import viz
    from coop_ga.control import diff_ik_reach, displaced_target, gauss_newton_ik, ilqr_reach
    from coop_ga.control.ilqr import DEFAULT_Q, DEFAULT_QV, DEFAULT_R

    out = exp.out
    t_total = time.perf_counter()
    with exp.stage("loading three_franka"):
        s = cg.systems.load("three_franka")
        task = cg.cooperative_task(s, "circle")
    rng = exp.rng
    q0 = np.array(s.q0, dtype=float)
    if args.perturb > 0:
        q0 = np.clip(q0 + rng.uniform(-args.perturb, args.perturb, s.nq), s.q_lower, s.q_upper)
    with exp.stage("compiling/loading the cooperative task (V_Sc, J^G, e, J_e)") as st_c:
        task.evaluate(q0)
        task.error_and_jacobian(q0, task.similarity(q0))
    X0 = task.primitive(q0)
    Vd = displaced_target(
        task, q0, translation=args.translation, axis=args.tilt_axis, angle=np.deg2rad(args.tilt_deg), scale=args.scale
    )
    Xd = Vd.apply(task.unit)
    e0 = task.error(q0, Vd)

    with exp.stage("reachability check (Gauss–Newton IK)"):
        ik = gauss_newton_ik(task, q0, Vd)
    with exp.stage("iLQR") as st_i:
        res = ilqr_reach(task, q0, Vd, horizon=args.horizon, dt=args.dt, max_iter=args.max_iter, backward=args.backward)
    with exp.stage("differential IK"):
        t0 = time.perf_counter()
        dik = diff_ik_reach(task, q0, Vd, gain=args.diffik_gain, dt=args.dt, steps=args.horizon, tol=1e-6)
        dik_time = time.perf_counter() - t0

    # ---- trajectories in the task space
    T = res.trajectory.shape[0]
    E = np.empty((T, 7))
    Bcmd = np.empty((T, 7))
    P = np.empty((T, 3, 3))
    for k in exp.progress(range(T), "evaluating the iLQR trajectory"):
        E[k] = task.error(res.trajectory[k], Vd)
        st = task.evaluate(res.trajectory[k])
        Bcmd[k] = st.jacobian @ res.qd[k]
        P[k] = st.points
    Pd = np.array([task.points(q) for q in dik.trajectory])
    Xf = task.primitive(res.q)

    # ---- figure (Fig. 8)
    pal = viz.PALETTE
    with exp.stage("plotting"):
        fig = plt.figure(figsize=(15, 7.5))
        gs = fig.add_gridspec(3, 2, width_ratios=[1.25, 1.0], hspace=0.35, wspace=0.2)
        ax = fig.add_subplot(gs[:, 0], projection="3d", computed_zorder=False)  # layers by zorder
        drawn = [
            viz.draw_robot(ax, s, q0, color=pal.initial_robot, ends=False, label="initial configuration", zorder=1),
            viz.draw_robot(ax, s, res.q, color=pal.final_robot, ends=False, label="final configuration", zorder=2),
        ]
        knots = np.linspace(0, T - 1, 7).astype(int)[1:-1]
        for i, k in enumerate(knots):
            viz.draw_primitive(
                ax,
                task.primitive(res.trajectory[k]),
                color=pal.intermediate((i + 1) / (len(knots) + 1)),
                lw=viz.LINEWIDTH["intermediate"],
                label="intermediate circles" if i == 0 else None,
                zorder=3,
            )
        for X, col, ls, lab in (
            (X0, pal.initial_primitive, "-", "initial circle"),
            (Xf, pal.final_primitive, "-", "final circle"),
            (Xd, pal.target_primitive, "--", "target circle"),
        ):
            drawn.append(viz.draw_primitive(ax, X, color=col, ls=ls, lw=2.2, label=lab, zorder=4))
        for i in range(3):
            ax.plot(
                *P[:, i].T,
                color=pal.trajectory,
                lw=viz.LINEWIDTH["trajectory"],
                label="TCP paths (iLQR)" if i == 0 else None,
                zorder=5,
            )
        ax.scatter(*P[-1].T, color=pal.trajectory, s=25, depthshade=False, zorder=6)
        viz.set_equal_3d(ax, np.vstack([d.points for d in drawn]), tight=True)
        ax.view_init(elev=18, azim=-60)
        viz.label_axes_3d(ax)
        ax.set_title(f"three_franka reaching a cooperative circle (iLQR, {res.iterations} iterations)")
        ax.legend(loc="upper left", fontsize=8)

        t = res.t
        ax1 = fig.add_subplot(gs[0, 1])
        viz.plot_bivector(ax1, t, Bcmd)
        ax1.set_title(r"bivector command $\mathcal{J}^G(q_t)\,\dot q_t$ (body velocity of the circle)")
        ax1.set_ylabel("rad/s | 1/s | body length/s", fontsize=8)
        ax2 = fig.add_subplot(gs[1, 1], sharex=ax1)
        viz.plot_bivector(ax2, t, E, legend=False)
        ax2.set_title(r"error bivector $\log(\tilde V_{Sc}(q_t)\, V_{Sd})$ (Eq 44)")
        ax3 = fig.add_subplot(gs[2, 1], sharex=ax1)
        viz.plot_error(ax3, t, E, label=f"iLQR (final {res.error:.1e})")
        td = args.dt * np.arange(len(dik.errors))
        viz.plot_error(
            ax3, td, dik.errors, ls="--", label=f"differential IK, gain {args.diffik_gain:g}/s (final {dik.error:.1e})"
        )
        ax3.set_xlabel("t [s]")
        ax3.set_ylabel(r"$\|e\|$")
        ax3.legend(fontsize=8)
        png = exp.save(fig, "circle_reaching.png")

    # ---- outputs
    exp.write_npz(
        "trajectory.npz",
        t=res.t,
        q=res.trajectory,
        qd=res.qd,
        u=res.u,
        error_bivector=E,
        command_bivector=Bcmd,
        end_points=P,
        target_versor=Vd.coeffs,
        cost_history=res.cost_history,
        terminal_error_history=res.error_history,
        diffik_q=dik.trajectory,
        diffik_errors=dik.errors,
        diffik_end_points=Pd,
    )
    c0, cd, cf = _circle_params(X0), _circle_params(Xd), _circle_params(Xf)
    metrics = {
        "system": "three_franka",
        "kind": "circle",
        "nq": s.nq,
        "seed": args.seed,
        "perturb_rad": args.perturb,
        "target": {
            "translation_m": list(args.translation),
            "tilt_deg": args.tilt_deg,
            "tilt_axis": list(args.tilt_axis),
            "scale": args.scale,
            "circle": cd,
            "tilt_from_initial_deg": float(np.degrees(np.arccos(np.clip(cd["normal"] @ c0["normal"], -1, 1)))),
        },
        "initial_circle": c0,
        "final_circle": cf,
        "initial_error": float(np.linalg.norm(e0)),
        "reachable_by_gauss_newton_ik": bool(ik.converged),
        "gauss_newton_ik_error": ik.error,
        "ilqr_iterations": res.iterations,
        "ilqr_converged": res.converged,
        "terminal_error": res.error,
        "terminal_error_vector": res.error_vector,
        "terminal_speed_rad_s": res.terminal_speed,
        "solve_time_s": res.solve_time_s,
        "ilqr_wall_time_s": st_i.seconds,
        "task_compile_or_load_s": st_c.seconds,
        "ilqr_backward": args.backward,
        "ilqr_message": res.message,
        "cost_history": res.cost_history,
        "terminal_error_history": res.error_history,
        "ilqr_iteration_stats": [
            {
                "cost": x.cost,
                "terminal_error": x.error,
                "alpha": x.alpha,
                "model": x.model,
                "outer": x.outer,
                "violation": x.violation,
                "travel": x.travel,
                "backward_passes": x.backward_passes,
                "time_s": x.time_s,
            }
            for x in res.stats
        ],
        "horizon": args.horizon,
        "dt_s": args.dt,
        "horizon_s": args.horizon * args.dt,
        "weights": {"R": DEFAULT_R, "Q": DEFAULT_Q, "Qv": DEFAULT_QV},
        "joint_limit_violation_rad": res.joint_limit_violation,
        "max_joint_speed_rad_s": float(np.abs(res.qd).max()),
        "max_joint_accel_rad_s2": float(np.abs(res.u).max()),
        "final_centre_error_m": float(np.linalg.norm(cf["center_m"] - cd["center_m"])),
        "radius_error_m": abs(cf["radius_m"] - cd["radius_m"]),
        "diffik_final_error": dik.error,
        "diffik_converged": dik.converged,
        "diffik_steps": dik.iterations,
        "diffik_gain_per_s": args.diffik_gain,
        "diffik_time_s": dik_time,
        "diffik_error_at_horizon": float(dik.errors[min(len(dik.errors) - 1, args.horizon)]),
        "total_runtime_s": time.perf_counter() - t_total,
    }
    exp.write_json("metrics.json", metrics)

    print(f"three_franka circle reaching (21 joints, {args.horizon} knots × {args.dt:g} s)")

    def fmt(c: dict) -> str:
        return f"c = {np.round(c['center_m'], 3)}, r = {c['radius_m']:.3f} m, n = {np.round(c['normal'], 3)}"

    print(f"  initial circle: {fmt(c0)}")
    print(f"  target  circle: {fmt(cd)}  (reachable by GN-IK: {ik.converged})")
    print(f"  initial error ‖e‖ = {np.linalg.norm(e0):.3f}")
    print(
        f"  iLQR: {res.iterations} iterations, converged = {res.converged}, terminal error {res.error:.2e}, "
        f"solve {res.solve_time_s * 1e3:.1f} ms ({args.backward}), terminal speed {res.terminal_speed:.1e} rad/s, "
        f"joint-limit violation {res.joint_limit_violation:.2g} rad"
    )
    print(f"        ‖e‖ per iteration: {' '.join(f'{x:.1e}' for x in res.error_history)}")
    print(
        f"  diff-IK (gain {args.diffik_gain:g}/s, {dik.iterations} steps): final error {dik.error:.2e}, "
        f"converged (tol 1e-6) = {dik.converged}"
    )
    print(f"  wrote {out / 'metrics.json'}, {out / 'trajectory.npz'}, {png}  ({metrics['total_runtime_s']:.1f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
