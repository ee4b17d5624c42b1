#!/usr/bin/env python
"""Our addition, not a figure of the paper: three Frankas carry their circle past a sphere obstacle.

System ``three_franka`` (21 joints), cooperative circle through the three TCPs (Eq 14), start at
rest at q0 (circle centre (0, 0, 0.487) m, radius 0.493 m).  Target: the same circle carried
30 cm along +y (``displaced_target(translation=(0, 0.30, 0))``), so arm 0's gripper (at −y)
moves 0.3 m toward the ring's centre.

Obstacle: a sphere of radius 4 cm centred at (0.014, −0.346, 0.478) m.  How it was chosen: the
run *without* avoidance (plain differential IK) was computed first; the centre is the point of
arm 0's left-finger capsule path at half its path length, moved 3 cm down (below the TCP path,
so that the links above the gripper, which follow the same path, do not end on it); 4 cm
leaves the start and the goal configurations clear (8.5 and 3.6 cm; the goal was 4.7 cm before the
acceleration limits changed where the redundant arms end) while the straight motion passes through it.  The metrics verify all three facts (``clearance_start``, ``clearance_goal``,
``min_clearance_no_avoidance`` < 0).

Controllers (``coop_ga.control.avoidance``): differential IK (Eq 44, 48, 61) with the joint
position, velocity and acceleration limits (the Franka's, from rest) as a QP, commanded body velocity ``B = gain · log(Ṽ_Sc V_Sd)``, gain 3 /s, Δt = 0.01 s,
300 steps (3 s); clearances from ``coop_ga.collision.model.CollisionModel`` (the Franka's
capsules, the sphere, and every arm–arm and non-adjacent same-arm capsule pair):

* ``none``: plain differential IK (the "straight" path; the distances are only recorded);
* ``soft``: repulsive clearance rates (A2) for the pairs closer than 10 cm, realised in the
  nullspace of the cooperative Jacobian J^G (Eq 58, 60): the circle's motion is unchanged;
* ``hard``: velocity dampers (A1) ``d + Δt J_d q̇ ≥ d_s + (1 − ξ)(d − d_s)`` (d_s = 1 cm,
  ξ = 0.5) as rows of the QP, next to the joint limits, capped by the braking speed that the
  acceleration limits allow (:class:`coop_ga.control.limits.ClearanceLimit`);
* ``both`` (the avoidance run of the figure): soft and hard together.

iLQR (Eq 53–57, ``coop_ga.control.ilqr_reach``, its defaults; 100 knots × 0.03 s = 3 s) with and without
the clearance cost ``ClearanceCost(cm, weight 1e4, activation 5 cm)`` (``ILQROptions.clearance``: a
squared hinge on the same distances at every knot).  Its clearance is checked at 10 points per interval
of the exact piecewise-constant-acceleration motion, not only at the knots.

--fast: the same scene with Δt = 0.02 s and 150 steps (3 s), iLQR with 30 knots × 0.1 s, smaller renders.

Writes to ``--out``: ``metrics.json`` (``obstacles`` [{"center", "radius"}], ``min_clearance`` and
``min_clearance_no_avoidance`` [m] over every pair and step, their obstacle / arm–arm / same-arm
parts, terminal task errors of both runs, ``max_limit_violation`` [rad] (all published trajectories),
``max_acceleration_violation`` [rad/s²] (the differential-IK runs),
every mode's numbers, the ``ilqr`` block and the ``gallery`` block), ``trajectory.npz`` (``q`` (T, 21) with avoidance, ``q_no_avoidance`` (T, 21),
``t`` (T,), ``clearance``/``clearance_no_avoidance`` (T,)), ``timing.json``, ``scene.png`` (with
avoidance), ``scene_no_avoidance.png`` (each: initial configuration light, the configuration of
closest approach grey, the obstacle (orange sphere), initial (green) and target (dashed) circles,
TCP paths) and ``clearance.png`` (smallest clearance vs time: differential IK in every mode, d_s and 0
marked; iLQR with and without the clearance cost).

    python experiments/obstacle_circle.py --out results/obstacle_circle
"""

from __future__ import annotations

import sys
import time
from typing import Any

import numpy as np

from coop_ga.harness import Experiment

#: the target: the initial circle carried along +y [m]
TRANSLATION = (0.0, 0.30, 0.0)
#: the obstacle (module docstring: how it was placed) [m]
OBSTACLE_CENTER = (0.014, -0.346, 0.478)
OBSTACLE_RADIUS = 0.04
#: avoidance settings (coop_ga.control.AvoidanceOptions)
D_SAFE, D_INFLUENCE, DAMPER_GAIN, REPULSIVE_SPEED = 0.01, 0.10, 0.5, 0.3
GAIN = 3.0
DT, STEPS = 0.01, 300
FAST_DT, FAST_STEPS = 0.02, 150
#: iLQR (Eq 53–57, its defaults otherwise): knots × Δt = 3 s; the clearance cost (ClearanceCost)
ILQR_HORIZON, ILQR_DT = 100, 0.03
FAST_ILQR_HORIZON, FAST_ILQR_DT = 30, 0.1
CLEARANCE_WEIGHT, CLEARANCE_ACTIVATION = 1e4, 0.05
#: samples per iLQR interval at which the clearance is checked between the knots (exact ZOH motion)
SUBSAMPLES = 10
TOL = 1e-4
MODES = ("none", "soft", "hard", "both")
#: camera (elevation, azimuth) [deg]: from +x, arm 0 on the left with the obstacle in front of its gripper
VIEW = (35.0, 0.0)
CLAIM = (
    "Avoidance in the cooperative controllers: with link–obstacle distances as nullspace "
    "repulsion and as QP velocity dampers, three Frankas carry their circle past a sphere on the straight "
    "path with clearance > 0 for every link and no arm–arm collision, where plain differential IK collides."
)


def main(argv: list[str] | None = None) -> int:
    exp = Experiment(__file__, __doc__, seed=0)
    exp.add_fast("Δt = 0.02 s, 150 steps, small renders (CI)")
    args = exp.parse(argv)
    return run(exp, bool(args.fast))


def _groups(cm: Any) -> dict[str, np.ndarray]:
    """Masks (n,) of the obstacle rows, the arm–arm rows and the same-arm rows of the collision model."""
    kinds = np.array(cm.kinds)
    chains = np.array([c.chain for c in cm.capsules])
    P = np.asarray(cm.pairs)
    is_self = kinds == "self"
    ci = chains[P[:, 0]]
    cj = np.where(is_self, chains[np.where(is_self, P[:, 1], 0)], -2)
    arm_arm = is_self & (ci != cj)
    return {"obstacle": kinds == "obstacle", "arm_arm": arm_arm, "same_arm": is_self & ~arm_arm}


def _dense(res: Any, sub: int) -> np.ndarray:
    """An iLQR trajectory at ``sub`` points per interval: ``q_k + τ q̇_k + ½τ² u_k`` (the exact motion of
    Eq 54 with piecewise-constant q̈), τ ∈ [0, Δt); then q_n.  Returns (n·sub + 1, nq)."""
    tau = res.dt * np.arange(sub) / sub
    q, qd, u = res.trajectory[:-1], res.qd[:-1], res.u
    Q = q[:, None] + tau[None, :, None] * qd[:, None] + 0.5 * tau[None, :, None] ** 2 * u[:, None]
    return np.vstack([Q.reshape(-1, q.shape[1]), res.trajectory[-1:]])


def _pad(Q: np.ndarray, T: int) -> np.ndarray:
    """Q (t, n) extended to (T, n) by repeating its last row (the system at rest after convergence)."""
    return Q if Q.shape[0] >= T else np.vstack([Q, np.repeat(Q[-1:], T - Q.shape[0], axis=0)])


def _setup(exp: Experiment) -> tuple:
    """``(system, task, obstacle, collision model, q0, Vd)``: the scene and the target (the circle carried along
    :data:`TRANSLATION`)."""
    import coop_ga as cg
    from coop_ga.collision.distance import Sphere
    from coop_ga.collision.model import CollisionModel
    from coop_ga.control import displaced_target

    with exp.stage("loading three_franka and the collision model"):
        s = cg.systems.load("three_franka")
        task = cg.cooperative_task(s, "circle")
        obstacle = Sphere(np.array(OBSTACLE_CENTER), OBSTACLE_RADIUS)
        cm = CollisionModel(s, obstacles=[obstacle], self_collision=True)
    q0 = np.array(s.q0, dtype=float)
    Vd = displaced_target(task, q0, translation=TRANSLATION)
    return s, task, obstacle, cm, q0, Vd


def _solve_modes(
    exp: Experiment, task: Any, q0: np.ndarray, Vd: Any, cm: Any, dt: float, steps: int, times: dict
) -> dict[str, Any]:
    """Differential IK in every avoidance mode (:data:`MODES`)."""
    from coop_ga.control.avoidance import AvoidanceOptions, avoidance_reach

    opts = AvoidanceOptions(
        d_safe=D_SAFE,
        d_influence=D_INFLUENCE,
        damper_gain=DAMPER_GAIN,
        repulsive_speed=REPULSIVE_SPEED,
        gain=GAIN,
        dt=dt,
        steps=steps,
        tol=TOL,
    )
    res: dict[str, Any] = {}
    for mode in MODES:
        with exp.stage(f"differential IK, avoidance '{mode}'"):
            t0 = time.perf_counter()
            res[mode] = avoidance_reach(task, q0, Vd, opts, collision_model=cm, mode=mode)
            times[f"{mode}_s"] = time.perf_counter() - t0
    return res


def _solve_ilqr(
    exp: Experiment, task: Any, q0: np.ndarray, Vd: Any, cm: Any, horizon: int, idt: float, times: dict
) -> dict[str, Any]:
    """iLQR without (``plain``) and with (``clearance``) the clearance cost."""
    from coop_ga.control import ilqr_reach
    from coop_ga.control.avoidance import ClearanceCost

    ilqr: dict[str, Any] = {}
    for key, cost in (("plain", None), ("clearance", ClearanceCost(cm, CLEARANCE_WEIGHT, CLEARANCE_ACTIVATION))):
        with exp.stage(f"iLQR ({'with' if cost else 'without'} the clearance cost)"):
            t0 = time.perf_counter()
            ilqr[key] = ilqr_reach(task, q0, Vd, horizon=horizon, dt=idt, clearance=cost)
            times[f"ilqr_{key}_s"] = time.perf_counter() - t0
    return ilqr


def _part(r: Any, groups: dict[str, np.ndarray], key: str) -> float:
    """The smallest clearance [m] of run ``r`` over the rows of group ``key`` (inf if the group is empty)."""
    m = groups[key]
    return float(r.clearances[:, m].min()) if m.any() else float("inf")


def _mode_block(r: Any, groups: dict[str, np.ndarray]) -> dict[str, Any]:
    """The metrics of one differential-IK run."""
    return {
        "min_clearance": r.min_clearance,
        "min_obstacle_clearance": _part(r, groups, "obstacle"),
        "min_arm_arm_clearance": _part(r, groups, "arm_arm"),
        "min_same_arm_clearance": _part(r, groups, "same_arm"),
        "closest_pair": r.closest,
        "terminal_error": r.error,
        "converged": r.converged,
        "steps": r.iterations,
        "max_task_velocity_deviation": float(r.task_velocity_deviation.max(initial=0.0)),
        "max_damper_residual": r.constraint_residual,
        "active_steps": r.active_steps,
        "max_limit_violation": r.limit_violation,
        "max_velocity_violation": r.velocity_violation,
        "max_acceleration_violation": r.max_acceleration_violation,
        "relaxed_steps": r.relaxed_steps,
        "fallback_steps": r.fallback_steps,
    }


def _ilqr_block(ilqr: dict[str, Any], ilqr_clear: dict[str, np.ndarray], horizon: int, idt: float) -> dict[str, Any]:
    """The metrics of the two iLQR runs (clearances checked between the knots)."""
    return {
        "horizon": horizon,
        "dt": idt,
        "clearance_weight": CLEARANCE_WEIGHT,
        "clearance_activation": CLEARANCE_ACTIVATION,
        "subsamples_per_interval": SUBSAMPLES,
        "min_clearance": float(ilqr_clear["clearance"].min()),
        "min_clearance_knots": ilqr["clearance"].min_clearance,
        "min_clearance_no_clearance_cost": float(ilqr_clear["plain"].min()),
        "terminal_error": ilqr["clearance"].error,
        "terminal_error_no_clearance_cost": ilqr["plain"].error,
        "converged": ilqr["clearance"].converged,
        "converged_no_clearance_cost": ilqr["plain"].converged,
        "iterations": ilqr["clearance"].iterations,
        "iterations_no_clearance_cost": ilqr["plain"].iterations,
        "joint_limit_violation": max(r.joint_limit_violation for r in ilqr.values()),
        "velocity_violation": max(r.velocity_violation for r in ilqr.values()),
    }


def _metrics(
    s: Any, obstacle: Any, cm: Any, groups: dict, res: dict, ilqr_block: dict, dims: dict, max_violation: float
) -> dict[str, Any]:
    """metrics.json without its gallery block (``dims``: dt, steps and T)."""
    av, na = res["both"], res["none"]
    modes = {m: _mode_block(r, groups) for m, r in res.items()}
    d_start, d_goal = float(na.clearances[0].min()), float(na.clearances[-1].min())
    return {
        "system": s.name,
        "dof": s.nq,
        "kind": "circle",
        "translation": list(TRANSLATION),
        "obstacles": [obstacle.as_dict()],
        "n_distances": cm.n,
        "n_obstacle_distances": int(groups["obstacle"].sum()),
        "n_arm_arm_distances": int(groups["arm_arm"].sum()),
        "n_same_arm_distances": int(groups["same_arm"].sum()),
        "d_safe": D_SAFE,
        "d_influence": D_INFLUENCE,
        "damper_gain": DAMPER_GAIN,
        "repulsive_speed": REPULSIVE_SPEED,
        "gain_per_s": GAIN,
        **dims,
        "tol": TOL,
        "avoidance_mode": "both",
        "min_clearance": av.min_clearance,
        "min_clearance_no_avoidance": na.min_clearance,
        "min_obstacle_clearance": _part(av, groups, "obstacle"),
        "min_obstacle_clearance_no_avoidance": _part(na, groups, "obstacle"),
        "min_arm_arm_clearance": _part(av, groups, "arm_arm"),
        "min_arm_arm_clearance_no_avoidance": _part(na, groups, "arm_arm"),
        "closest_pair": av.closest,
        "closest_pair_no_avoidance": na.closest,
        "clearance_start": d_start,
        "clearance_goal": d_goal,
        "terminal_error": av.error,
        "terminal_error_no_avoidance": na.error,
        "converged": av.converged,
        "converged_no_avoidance": na.converged,
        "max_task_velocity_deviation": modes["both"]["max_task_velocity_deviation"],
        "max_damper_residual": av.constraint_residual,
        "max_limit_violation": max_violation,
        # the Franka's acceleration limits (from rest), imposed by every differential-IK run and measured on it
        "max_acceleration_violation": max(r.max_acceleration_violation for r in res.values()),
        "modes": modes,
        "ilqr": ilqr_block,
    }


def _draw_scenes(exp: Experiment, s: Any, task: Any, q0: np.ndarray, Vd: Any, res: dict, dt: float, fast: bool) -> dict:
    """``scene.png`` and ``scene_no_avoidance.png``: start, closest approach, circles, obstacle and TCP paths."""
    from coop_ga import viz
    from coop_ga.geometry import sphere

    av, na = res["both"], res["none"]
    size, dpi = ((5.0, 4.5), 80) if fast else ((7.0, 6.0), 150)
    c, r = np.array(OBSTACLE_CENTER), OBSTACLE_RADIUS
    X_obs = sphere(c + [r, 0, 0], c + [0, r, 0], c + [0, 0, r], c - [r, 0, 0])
    X0, Xd = task.primitive(q0), Vd.apply(task.unit)
    pngs = {}
    P_na = np.array([task.points(q) for q in na.trajectory])
    for name, rr, label in (("scene.png", av, "with avoidance"), ("scene_no_avoidance.png", na, "no avoidance")):
        k = int(np.argmin(rr.clearance))
        P = np.array([task.points(q) for q in rr.trajectory])
        scene = viz.Scene()
        scene.robot(s, q0, "initial", "initial configuration")
        scene.robot(s, rr.trajectory[k], "final", f"closest approach (t = {k * dt:.2f} s)")
        scene.primitive(X0, "initial", "initial circle")
        scene.primitive(task.primitive(rr.trajectory[k]), "final", "circle at closest approach")
        scene.primitive(Xd, "target", "target circle")
        scene.primitive(X_obs, "neutral", "obstacle", style={"color": "#ff7f0e"})
        for i in range(P.shape[1]):
            scene.curve(P[:, i], "trajectory", "TCP paths" if i == 0 else None)
        if rr is av:  # the straight path of the run without avoidance, for comparison
            scene.curve(P_na[:, 0], "neutral", "TCP 0 path without avoidance")
        pngs[name] = viz.render_scene(
            scene,
            exp.out / name,
            view=VIEW,
            size=size,
            dpi=dpi,
            title=f"three_franka, circle carried past a sphere: {label}\n"
            f"min clearance {rr.min_clearance * 100:.1f} cm, final ‖e‖ = {rr.error:.1e}",
        )
    return pngs


def _plot_ik_clearances(ax: Any, t: np.ndarray, c_av: np.ndarray, c_na: np.ndarray, res: dict, dt: float) -> None:
    """The differential-IK panel of ``clearance.png``: every mode's smallest clearance over time."""
    av, na = res["both"], res["none"]
    ax.plot(
        t,
        c_av * 100,
        color="C0",
        lw=2.5,
        label=f"with avoidance (soft + hard), min {av.min_clearance * 100:.1f} cm",
    )
    ax.plot(t, c_na * 100, color="C3", ls="--", label=f"no avoidance, min {na.min_clearance * 100:.1f} cm")
    for mode, col, ls in (("soft", "C2", "-."), ("hard", "C1", "-")):
        rm = res[mode]
        ax.plot(
            dt * np.arange(rm.clearance.shape[0]),
            rm.clearance * 100,
            color=col,
            ls=ls,
            lw=1.0,
            label=f"{mode} only, min {rm.min_clearance * 100:.1f} cm",
        )
    ax.axhline(D_SAFE * 100, color="0.4", ls=":", lw=1.0, label=f"$d_s$ = {D_SAFE * 100:g} cm")
    ax.axhline(0.0, color="k", lw=0.8)
    ax.set_ylabel("smallest clearance [cm]")
    ax.set_title("differential IK: smallest signed clearance over all link–obstacle and link–link pairs")
    ax.legend(fontsize=8)


def _plot_ilqr_clearances(ax2: Any, ilqr_clear: dict[str, np.ndarray], horizon: int, idt: float) -> None:
    """The iLQR panel of ``clearance.png``: with and without the clearance cost, between the knots too."""
    for key, col, ls, lab in (("clearance", "C0", "-", "with clearance cost"), ("plain", "C3", "--", "without")):
        td = np.arange(ilqr_clear[key].shape[0]) * (idt / SUBSAMPLES)
        ax2.plot(td, ilqr_clear[key] * 100, color=col, ls=ls, label=f"{lab}, min {ilqr_clear[key].min() * 100:.1f} cm")
    ax2.axhline(
        CLEARANCE_ACTIVATION * 100,
        color="0.4",
        ls=":",
        lw=1.0,
        label=f"activation $d_a$ = {CLEARANCE_ACTIVATION * 100:g} cm",
    )
    ax2.axhline(0.0, color="k", lw=0.8)
    ax2.set_xlabel("t [s]")
    ax2.set_ylabel("smallest clearance [cm]")
    ax2.set_title(f"iLQR ({horizon} knots × {idt:g} s; clearance checked {SUBSAMPLES}× per interval)")
    ax2.legend(fontsize=8)


def _gallery(metrics: dict, res: dict, ilqr: dict, cm: Any, pngs: dict) -> tuple[dict[str, Any], str]:
    """``(gallery block, evidence)``: the claim and the numbers that back or contradict it."""
    av, na = res["both"], res["none"]
    modes, max_violation, T = metrics["modes"], metrics["max_limit_violation"], metrics["T"]
    ok = (
        av.min_clearance > 0.0
        and metrics["min_arm_arm_clearance"] > 0.0
        and na.min_clearance < 0.0
        and av.converged
        and max_violation == 0.0
        and metrics["max_acceleration_violation"] == 0.0
        and metrics["ilqr"]["min_clearance"] > metrics["ilqr"]["min_clearance_no_clearance_cost"]
    )
    evidence = (
        f"With avoidance (nullspace repulsion + velocity dampers, d_s = {D_SAFE * 100:g} cm) the smallest clearance "
        f"over all {cm.n} pairs and {T} steps is {av.min_clearance * 100:.2f} cm (arm–arm "
        f"{metrics['min_arm_arm_clearance'] * 100:.1f} cm) and the circle reaches its target (‖e‖ = {av.error:.1e}, "
        f"task velocity disturbed by at most {metrics['max_task_velocity_deviation']:.1e}); without avoidance "
        f"the gripper enters the sphere by {-na.min_clearance * 100:.1f} cm (min clearance "
        f"{na.min_clearance * 100:.2f} cm, {na.closest}). Nullspace repulsion alone: min clearance "
        f"{res['soft'].min_clearance * 100:.2f} cm; dampers alone: {res['hard'].min_clearance * 100:.2f} cm "
        f"but disturb the task velocity by up to {modes['hard']['max_task_velocity_deviation']:.2f}. iLQR with the "
        f"clearance cost: min clearance {metrics['ilqr']['min_clearance'] * 100:.2f} cm (without it "
        f"{metrics['ilqr']['min_clearance_no_clearance_cost'] * 100:.2f} cm), ‖e‖ = {ilqr['clearance'].error:.1e}. "
        f"Joint-limit violation {max_violation:.3g} rad; acceleration-limit violation of the differential-IK runs "
        f"{metrics['max_acceleration_violation']:.3g} rad/s² (from rest)."
    )
    gallery = {
        "title": "Obstacle avoidance: three Frankas carry a circle past a sphere (our addition)",
        "claim": CLAIM,
        "evidence": evidence,
        "agrees": bool(ok),
        "figures": [pngs["scene.png"].name, "clearance.png", pngs["scene_no_avoidance.png"].name],
    }
    return gallery, evidence


def run(exp: Experiment, fast: bool) -> int:
    """Solve the four modes, measure, draw and write (module docstring)."""
    plt = exp.pyplot()
    t_total = time.perf_counter()
    dt, steps = (FAST_DT, FAST_STEPS) if fast else (DT, STEPS)
    s, task, obstacle, cm, q0, Vd = _setup(exp)
    times: dict[str, float] = {}
    res = _solve_modes(exp, task, q0, Vd, cm, dt, steps, times)
    av, na = res["both"], res["none"]
    groups = _groups(cm)
    horizon, idt = (FAST_ILQR_HORIZON, FAST_ILQR_DT) if fast else (ILQR_HORIZON, ILQR_DT)
    ilqr = _solve_ilqr(exp, task, q0, Vd, cm, horizon, idt, times)
    ilqr_dense = {k: _dense(r, SUBSAMPLES) for k, r in ilqr.items()}
    ilqr_clear = {k: np.array([cm.min_clearance(q) for q in Q]) for k, Q in ilqr_dense.items()}

    T = max(av.trajectory.shape[0], na.trajectory.shape[0])
    q_av, q_na = _pad(av.trajectory, T), _pad(na.trajectory, T)
    c_av = np.concatenate([av.clearance, np.repeat(av.clearance[-1:], T - av.clearance.shape[0])])
    c_na = np.concatenate([na.clearance, np.repeat(na.clearance[-1:], T - na.clearance.shape[0])])
    t = dt * np.arange(T)
    lim = s.limits
    max_violation = max(
        lim.position_violation(q_av),
        lim.position_violation(q_na),
        *(lim.position_violation(Q) for Q in ilqr_dense.values()),
    )
    dims = {"dt": dt, "steps": steps, "T": T}
    metrics = _metrics(s, obstacle, cm, groups, res, _ilqr_block(ilqr, ilqr_clear, horizon, idt), dims, max_violation)

    with exp.stage("rendering the scenes") as st_r:
        pngs = _draw_scenes(exp, s, task, q0, Vd, res, dt, fast)
    with exp.stage("plotting the clearances"):
        fig, (ax, ax2) = plt.subplots(2, 1, figsize=(7.5, 7.0), sharex=True)
        _plot_ik_clearances(ax, t, c_av, c_na, res, dt)
        _plot_ilqr_clearances(ax2, ilqr_clear, horizon, idt)
        fig.tight_layout()
        clr_png = exp.save(fig, "clearance.png")
        plt.close(fig)

    metrics["gallery"], evidence = _gallery(metrics, res, ilqr, cm, pngs)
    exp.write_json("metrics.json", metrics)
    exp.write_npz(
        "trajectory.npz",
        q=q_av,
        q_no_avoidance=q_na,
        t=t,
        clearance=c_av,
        clearance_no_avoidance=c_na,
    )
    times["render_s"] = st_r.seconds
    times["total_s"] = time.perf_counter() - t_total
    exp.write_timing(times)
    if not exp.quiet:
        print(evidence)
        print(f"  wrote {exp.out}/{{metrics.json, trajectory.npz, scene.png, scene_no_avoidance.png, {clr_png.name}}}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
