#!/usr/bin/env python
"""§4.2.5 / Figs. 14–15: the right hand of a G1 reaches a point, with the cooperative line of the two hands free or horizontal.

System ``g1_arms`` (17 joints: waist yaw/roll/pitch + 2 × 7 arm joints, pelvis fixed), task
``cooperative_task(system, "line")``: the line X_c = P_1 ∧ P_2 ∧ e∞ (Eq 14) through the right and
the left hand (end points 0 and 1, in that order: the line points from the right hand to the left
one, +y at q0 like the unit line, so V_Sc's chart is 0° from its reference; ``points=(1, 0)``
would start on the chart's antipode, 180°, which ``check_problem`` refuses with a ChartError
unless ``chart_axis="auto"`` re-centres it).  At q0 the hands are 0.36 m apart at the same
height: the line is horizontal, its direction d = (0, 1, 0).

Line parameters (``coop_ga.control.constrained.line_parameters``): unit direction
d = (p_l − p_r)/‖p_l − p_r‖ and moment m = p_r × d [m] — the coefficients of X_c/ℓ on
e01∞, e02∞, e03∞ and e23∞, −e13∞, e12∞.  The paper's "e_{03i}" (Fig. 15b) is d_z, the vertical
component of the direction; the metrics check d against ``coop_ga.direction(X_c)`` and against the
rotation of V_Sc applied to the unit line's +e2.

Controller (both scenarios, ``constrained_point_reach``): differential IK as a QP per step,

    min ½‖J_r q̇ − v_r‖² + ½λ²‖q̇‖²   s.t.  C q̇ = −k_c (c(q) − c*),  joint position/velocity box (Eq 53),

v_r = k (p* − p_r) capped at 0.2 m/s, q ← q + Δt q̇ (Eq 61), then a Gauss–Newton projection
back onto c(q) = c* inside the limits (so the constraint holds to round-off, not only to first order).

* Scenario 1 (Fig. 14): c = the left-hand position (3 rows), held at its initial value; the line
  is free.
* Scenario 2 (Fig. 15): c = d_z (1 row), held at its initial value (0: horizontal); the left hand
  is free and must follow.  The same run without the projection (linearised constraint + feedback
  only) is reported as ``scenario2.linearised_only`` to show what the projection buys.

Target: the initial right-hand position + ``--offset`` (default (0.06, −0.04, 0.10) m, 12.3 cm:
forward, outward and up, so that the horizontal line forces the left hand up too).

Where this differs from the paper's text: the paper forms the line from "the two wrist points"; the
registered end points of ``g1_arms`` are the hand mounts (``right/left_rubber_hand``), a few cm beyond
the wrists.  "e_{03i}" in the caption of Fig. 15b reads as e_{03∞} (d_z).  The paper gives neither the
target nor the controller's equations; both are ours (above).  Its Fig. 14a draws the line blue; here
it is green (initial) / turquoise (final) like every other figure.

Writes to ``--out``: ``metrics.json``, ``timing.json``, ``trajectories.npz``,
``fig14_scene.png``, ``fig14_line_parameters.png``, ``fig15_scene.png``, ``fig15_line_parameters.png``,
``fig14_animation.gif``, ``fig15_animation.gif`` (the motion, ``--frames`` frames).  In the scenes the right-hand
path is red, the left-hand one (or the held left hand, a square) purple, the target point an orange star.

    python experiments/line_constraint.py --out results/fig14_15_line_constraint
"""

from __future__ import annotations

import sys
import time
from typing import Any

import numpy as np

from coop_ga.harness import Experiment, finite_float, int_at_least, nonneg_float, positive_float, positive_int

#: view (elevation, azimuth) [deg] and size [in] of the two scenes
VIEW = (14.0, 28.0)
SIZE = (6.4, 6.0)


def _fd_jacobian(fun: Any, q: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """Central finite differences of ``fun(q)`` (m,) → (m, nq)."""
    cols = []
    for j in range(q.size):
        e = np.zeros_like(q)
        e[j] = h
        cols.append((fun(q + e) - fun(q - e)) / (2 * h))
    return np.array(cols).T


def _draw_scene(
    exp: Any, s: Any, task: Any, q0: np.ndarray, P0: np.ndarray, target: np.ndarray, r: Any, key: str, fig_no: str
) -> Any:
    """``fig<NN>_scene.png``: the arms and lines at the start and the end, the hands' paths and the target."""
    from coop_ga import viz

    right, left = viz.PALETTE.trajectories[:2]
    sc = viz.Scene()
    sc.robot(s, q0, "initial", "initial configuration")
    sc.robot(s, r.q, "final", "final configuration")
    sc.primitive(task.primitive(q0), "initial", "initial line")
    sc.primitive(task.primitive(r.q), "final", "final line")
    sc.curve(r.points[:, 0], "trajectory", "right-hand path", style={"color": right})
    if key == "scenario2":
        sc.curve(r.points[:, 1], "trajectory", "left-hand path", style={"color": left})
    else:
        held = {"color": left, "marker": "s", "marker_size": 50.0}
        sc.curve(P0[1][None], "neutral", "left hand (held)", markers=True, style=held)
    star = {"color": viz.PALETTE.target_point, "marker": "*", "marker_size": 160.0}
    sc.curve(target[None], "target", "target point", markers=True, style=star)
    title = (
        "Fig. 14: right hand reaches, left hand held, line free"
        if key == "scenario1"
        else "Fig. 15: right hand reaches, line kept horizontal"
    )
    return viz.render_scene(sc, exp.out / f"fig{fig_no}_scene.png", view=VIEW, size=SIZE, title=title)


def _draw_line_parameters(exp: Any, P0: np.ndarray, r: Any, X: np.ndarray, key: str, fig_no: str, ttl: str) -> Any:
    """``fig<NN>_line_parameters.png``: direction d, moment m and the errors over time."""
    from coop_ga import viz
    from coop_ga.control.constrained import LINE_PARAMETER_BLADES

    plt = exp.pyplot()
    fig, axs = plt.subplots(3, 1, figsize=(7.5, 7.8), sharex=True, height_ratios=[1.0, 1.0, 0.9])
    cols = viz.BIVECTOR_COLORS
    for j in range(3):
        lab = rf"$d_{'xyz'[j]}$ ({LINE_PARAMETER_BLADES[j]})"
        if j == 2:
            lab += " constrained" if key == "scenario2" else " free"
        axs[0].plot(r.t, X[:, j], color=cols[j], lw=3.2 if j == 2 else 1.5, label=lab, zorder=3 if j == 2 else 2)
    axs[0].set_ylabel("direction d [1]")
    viz.legend_outside(axs[0])
    axs[0].grid(True, alpha=0.3)
    for j in range(3):
        lab = rf"$m_{'xyz'[j]}$ ({LINE_PARAMETER_BLADES[3 + j]})"
        axs[1].plot(r.t, X[:, 3 + j], color=cols[3 + j], lw=1.5, label=lab)
    axs[1].set_ylabel(r"moment $m = p_r \times d$ [m]")
    viz.legend_outside(axs[1])
    axs[1].grid(True, alpha=0.3)
    dz_dev = np.abs(X[:, 2] - X[0, 2])
    left_disp = np.linalg.norm(r.points[:, 1] - P0[1], axis=1)
    axs[2].set_ylabel("error [m], deviation [1]")
    viz.plot_error(axs[2], r.t, r.point_error, floor=1e-16, color="0.1", label="right-hand error [m]")
    viz.plot_error(axs[2], r.t, left_disp, floor=1e-16, color="0.45", ls="--", label="left-hand\ndisplacement [m]")
    viz.plot_error(axs[2], r.t, dz_dev, floor=1e-16, color=cols[2], lw=2.5, label=r"$|d_z(t) - d_z(0)|$")
    axs[2].set_xlabel("t [s]")
    viz.legend_outside(axs[2])
    axs[0].set_title(f"Fig. {fig_no}b: line parameters, {ttl}")
    fig.tight_layout()
    png = exp.save(fig, f"fig{fig_no}_line_parameters.png")
    plt.close(fig)
    return png


def draw_scenario(
    exp: Any,
    s: Any,
    task: Any,
    q0: np.ndarray,
    P0: np.ndarray,
    target: np.ndarray,
    r: Any,
    X: np.ndarray,
    key: str,
    fig_no: str,
) -> list[Any]:
    """``fig<NN>_scene.png``, ``fig<NN>_line_parameters.png`` and ``fig<NN>_animation.gif`` of one scenario:
    the run ``r`` (its t (T,), trajectory (T, 17), points (T, 2, 3) [m]) and its line parameters X (T, 6)."""
    from coop_ga import viz

    exp.pyplot()
    out = [_draw_scene(exp, s, task, q0, P0, target, r, key, fig_no)]
    ttl = "free line, left hand held" if key == "scenario1" else r"horizontal line ($d_z$ = const)"
    out.append(_draw_line_parameters(exp, P0, r, X, key, fig_no, ttl))
    gif = viz.animate(
        s,
        r.trajectory,
        task.primitive,
        exp.out / f"fig{fig_no}_animation.gif",
        t=r.t,
        frames=exp.args.frames,
        fps=exp.args.frames / max(float(r.t[-1] - r.t[0]), 1e-9),
        view=VIEW,
        size=(4.8, 3.6),
        dpi=80,
        title=f"Fig. {fig_no}: {ttl}",
    )
    return [*out, gif]


def _parse(argv: list[str] | None) -> Experiment:
    """The command line."""
    exp = Experiment(__file__, __doc__, seed=0)
    exp.add(
        "--offset",
        type=finite_float,
        nargs=3,
        default=(0.06, -0.04, 0.10),
        metavar=("X", "Y", "Z"),
        help="right-hand target relative to its initial position [m], world frame",
    )
    exp.add("--dt", type=positive_float, default=0.01, help="time step [s] (Eq 61)")
    exp.add("--steps", type=positive_int, default=400, help="maximum number of steps")
    exp.add("--gain", type=positive_float, default=5.0, help="point-task gain k [1/s]")
    exp.add("--max-speed", type=positive_float, default=0.2, help="right-hand speed cap [m/s]")
    exp.add("--constraint-gain", type=nonneg_float, default=10.0, help="constraint feedback gain k_c [1/s]")
    exp.add("--tol", type=positive_float, default=1e-4, help="right-hand error [m] at which the target is reached")
    exp.add("--frames", type=int_at_least(2), default=24, help="frames of each animation GIF (--fast: 4)")
    exp.add_fast("CI run (every output file and metric still written)", dt=0.02, steps=150, tol=1e-3, frames=4)
    exp.parse(argv)
    return exp


def _run_scenarios(
    exp: Experiment, task: Any, q0: np.ndarray, P0: np.ndarray, target: np.ndarray, timing: dict
) -> dict:
    """The three runs: left hand held (scenario 1), line horizontal (scenario 2, projected and linearised only)."""
    from coop_ga.control.constrained import (
        constrained_point_reach,
        line_parameter_constraint,
        line_parameters,
        point_constraint,
    )

    args = exp.args
    x0, _ = line_parameters(task, q0)
    opts = dict(
        dt=args.dt, steps=args.steps, gain=args.gain, max_speed=args.max_speed, constraint_gain=args.constraint_gain
    )
    opts["tol"] = args.tol
    hold = point_constraint(task, 1, P0[1], name="left hand")
    horizontal = line_parameter_constraint(task, "d_z", x0[2], name="line d_z")
    runs = {}
    for key, cons, project in (
        ("scenario1", [hold], True),
        ("scenario2", [horizontal], True),
        ("scenario2_linearised", [horizontal], False),
    ):
        with exp.stage(f"{key}: constrained differential IK") as st:
            runs[key] = constrained_point_reach(task, q0, 0, target, constraints=cons, project=project, **opts)
        timing[f"{key}_s"] = st.seconds
    return runs


def _readouts(task: Any, res: Any) -> dict[str, Any]:
    """Line parameters X (T, 6) along a run, and the same direction from the CGA line and from the cooperative
    similarity (Eq 14, 28), and the chart angle [rad]."""
    import coop_ga as cg
    from coop_ga.control.constrained import line_parameters

    e2 = np.array([0.0, 1.0, 0.0])
    X = np.array([line_parameters(task, q)[0] for q in res.trajectory])  # (T, 6)
    d_cga = np.array([np.asarray(cg.direction(task.primitive(q)), float) for q in res.trajectory])
    d_sim = np.array([task.similarity(q).rotation_matrix @ e2 for q in res.trajectory])
    chart = np.array([task.chart_angle(q) for q in res.trajectory])
    return {"X": X, "d_cga": d_cga, "d_sim": d_sim, "chart": chart}


def _jacobian_checks(task: Any, q0: np.ndarray, runs: dict) -> dict[str, float]:
    """The d_z row of the line-parameter Jacobian against central finite differences, at q0 and both ends."""
    from coop_ga.control.constrained import line_parameters

    def dz_fun(q: np.ndarray) -> np.ndarray:
        return line_parameters(task, q)[0][2:3]

    jac_checks = {}
    for label, q in (("q0", q0), ("scenario1_final", runs["scenario1"].q), ("scenario2_final", runs["scenario2"].q)):
        J = line_parameters(task, q)[1][2:3]
        jac_checks[label] = float(np.max(np.abs(J - _fd_jacobian(dz_fun, q))))
    return jac_checks


def _block(s: Any, r: Any, ro: dict[str, Any], P0: np.ndarray, dt: float) -> dict[str, Any]:
    """The metrics of one run ``r`` with its read-outs ``ro``."""
    names = s.joint_names
    waist = [i for i, n in enumerate(names) if n.startswith("waist")]
    left = [i for i, n in enumerate(names) if n.startswith("left")]
    right = [i for i, n in enumerate(names) if n.startswith("right")]
    X = ro["X"]
    dz = X[:, 2]
    left_disp = np.linalg.norm(r.points[:, 1] - P0[1], axis=1)
    travel = np.abs(r.trajectory[-1] - r.trajectory[0])
    return {
        "converged": r.converged,
        "steps": r.iterations,
        "duration_s": r.iterations * dt,
        "message": r.message,
        "right_hand_initial_error_m": float(r.point_error[0]),
        "right_hand_final_error_m": r.error,
        "left_hand_displacement_m": float(left_disp[-1]),
        "left_hand_max_displacement_m": float(left_disp.max()),
        "direction_z_initial": float(dz[0]),
        "direction_z_final": float(dz[-1]),
        "direction_z_max_deviation": float(np.max(np.abs(dz - dz[0]))),
        "direction_initial": X[0, :3],
        "direction_final": X[-1, :3],
        "moment_initial_m": X[0, 3:],
        "moment_final_m": X[-1, 3:],
        "line_tilt_final_deg": float(np.degrees(np.arcsin(np.clip(abs(dz[-1]), 0.0, 1.0)))),
        "constraint": list(r.constraint_labels),
        "constraint_max_deviation": float(r.constraint_deviation.max()),
        "max_limit_violation": r.limit_violation,
        "max_velocity_violation_rad_s": r.velocity_violation,
        "active_limit_steps": r.active_steps,
        "feedback_dropped_steps": r.feedback_dropped,
        "projection_iterations_max": int(r.projection_iterations.max(initial=0)),
        "projection_failures": r.projection_failures,
        "joint_travel_rad": {
            "waist": float(travel[waist].max()),
            "left_arm": float(travel[left].max()),
            "right_arm": float(travel[right].max()),
        },
        "readout_mismatch": {
            "direction_vs_cga_line": float(np.abs(X[:, :3] - ro["d_cga"]).max()),
            "direction_vs_similarity_rotation": float(np.abs(X[:, :3] - ro["d_sim"]).max()),
        },
        "max_chart_angle_deg": float(np.degrees(ro["chart"].max())),
    }


def _scenario_metrics(s: Any, runs: dict, ro: dict, P0: np.ndarray, dt: float) -> tuple[dict, dict, dict]:
    """``(scenario 1, scenario 2, scenario 2 linearised)`` blocks; scenario 2 carries its linearised summary."""
    m1, m2, m2l = (_block(s, runs[k], ro[k], P0, dt) for k in ("scenario1", "scenario2", "scenario2_linearised"))
    m1["left_hand_hold_max_deviation_m"] = m1.pop("constraint_max_deviation")
    m2["max_constrained_deviation"] = m2.pop("constraint_max_deviation")
    m2["linearised_only"] = {
        "max_constrained_deviation": m2l["constraint_max_deviation"],
        "right_hand_final_error_m": m2l["right_hand_final_error_m"],
        "steps": m2l["steps"],
        "note": "the same QP without the Gauss-Newton projection: the linearised constraint drifts by O(|dq|^2) "
        "per step, held by the feedback k_c",
    }
    return m1, m2, m2l


def _gallery(args: Any, m1: dict, m2: dict, m2l: dict, max_violation: float) -> dict[str, Any]:
    """The gallery block: the paper's claim and the numbers that back or contradict it."""
    ok = bool(
        m1["converged"]
        and m2["converged"]
        and m2["max_constrained_deviation"] < 1e-9
        and m1["direction_z_max_deviation"] > 1e-3
        and m1["left_hand_max_displacement_m"] < 1e-9
        and m2["left_hand_displacement_m"] > 1e-2
        and max_violation == 0.0
    )
    figures = [
        "fig15_line_parameters.png",
        "fig15_scene.png",
        "fig15_animation.gif",
        "fig14_line_parameters.png",
        "fig14_scene.png",
        "fig14_animation.gif",
    ]
    return {
        "title": "Figs. 14–15: right-hand reaching with the cooperative line of a G1's hands, free and horizontal",
        "claim": "The cooperative line of the two wrists can constrain a single-arm task: with the left hand held "
        "the line changes freely as the right hand reaches its target, and when the line must stay horizontal its "
        "vertical direction component stays constant while both arms move in coordination.",
        "evidence": (
            f"Right hand reaches a point {np.linalg.norm(args.offset) * 100:.1f} cm away to "
            f"{m1['right_hand_final_error_m']:.1e} m (free line, {m1['steps']} steps) and "
            f"{m2['right_hand_final_error_m']:.1e} m (horizontal line, {m2['steps']} steps). Free: the left hand "
            f"stays within {m1['left_hand_max_displacement_m']:.1e} m and d_z goes {m1['direction_z_initial']:.2g} "
            f"-> {m1['direction_z_final']:.3f} (line tilted {m1['line_tilt_final_deg']:.1f} deg). Horizontal: d_z "
            f"deviates at most {m2['max_constrained_deviation']:.1e} (linearised QP alone: "
            f"{m2l['constraint_max_deviation']:.1e}) while the left hand moves "
            f"{m2['left_hand_displacement_m'] * 100:.1f} cm; joint limits never exceeded (max violation "
            f"{max_violation:g} rad)."
        ),
        "agrees": ok,
        "figures": figures,
    }


def _metrics(args: Any, s: Any, task: Any, P0: np.ndarray, target: np.ndarray, jac_checks: dict, blocks: tuple) -> dict:
    """metrics.json: the setup, both scenarios, the Jacobian check and the gallery block."""
    from coop_ga.control.constrained import LINE_PARAMETER_BLADES, LINE_PARAMETERS

    m1, m2, m2l = blocks
    max_violation = max(m1["max_limit_violation"], m2["max_limit_violation"])
    return {
        "system": "g1_arms",
        "kind": "line",
        "nq": s.nq,
        "end_points": list(task.end_frames),
        "line_orientation": "from end point 0 (right hand) to end point 1 (left hand)",
        "fast": bool(args.fast),
        "seed": args.seed,
        "dt_s": args.dt,
        "max_steps": args.steps,
        "tol_m": args.tol,
        "gain_per_s": args.gain,
        "max_speed_m_s": args.max_speed,
        "constraint_gain_per_s": args.constraint_gain,
        "right_hand_initial_m": P0[0],
        "left_hand_initial_m": P0[1],
        "target_point_m": target,
        "target_offset_m": list(args.offset),
        "target_distance_m": float(np.linalg.norm(args.offset)),
        "line_parameter_names": list(LINE_PARAMETERS),
        "line_parameter_blades": list(LINE_PARAMETER_BLADES),
        "direction_z_jacobian_vs_central_fd": jac_checks,
        "notes": [
            "line through the hand mounts right/left_rubber_hand (the paper: the wrist points)",
            "paper's e_{03i} (Fig. 15b) read as e_{03inf} = d_z, the vertical direction component",
            "target and controller are not given in the paper: QP differential IK with equality constraints "
            "and a Gauss-Newton projection (coop_ga.control.constrained)",
        ],
        "scenario1": m1,
        "scenario2": m2,
        "max_constrained_deviation": m2["max_constrained_deviation"],
        "max_limit_violation": max_violation,
        "gallery": _gallery(args, m1, m2, m2l, max_violation),
    }


def _print_summary(args: Any, m1: dict, m2: dict, m2l: dict) -> None:
    """One line per scenario on stdout."""
    dt, tol = args.dt, args.tol
    print(f"g1_arms line constraint ({'fast' if args.fast else 'full'}: Δt {dt:g} s, tol {tol:g} m)")
    for key, m in (("scenario 1 (free line)", m1), ("scenario 2 (horizontal)", m2)):
        print(
            f"  {key}: converged {m['converged']} in {m['steps']} steps, right-hand error "
            f"{m['right_hand_final_error_m']:.2e} m, left hand moved {m['left_hand_displacement_m']:.2e} m, "
            f"d_z {m['direction_z_initial']:.2e} -> {m['direction_z_final']:.2e} (max dev "
            f"{m['direction_z_max_deviation']:.2e}), limit violation {m['max_limit_violation']:g}"
        )
    print(f"  linearised only: max d_z deviation {m2l['constraint_max_deviation']:.2e}")


def main(argv: list[str] | None = None) -> int:
    exp = _parse(argv)
    args = exp.args
    exp.pyplot()  # the headless backend before anything draws

    import coop_ga as cg

    t_total = time.perf_counter()
    timing: dict[str, float] = {}
    with exp.stage("loading g1_arms and the line task") as st:
        s = cg.systems.load("g1_arms")
        task = cg.cooperative_task(s, "line")
        q0 = np.array(s.q0, dtype=float)
        task.evaluate(q0)
    timing["load_s"] = st.seconds
    P0 = task.points(q0)  # (2, 3): right hand, left hand
    target = P0[0] + np.asarray(args.offset, float)
    runs = _run_scenarios(exp, task, q0, P0, target, timing)
    with exp.stage("line parameters along the trajectories") as st:
        ro = {k: _readouts(task, r) for k, r in runs.items()}
    timing["readouts_s"] = st.seconds
    jac_checks = _jacobian_checks(task, q0, runs)
    m1, m2, m2l = _scenario_metrics(s, runs, ro, P0, args.dt)
    metrics = _metrics(args, s, task, P0, target, jac_checks, (m1, m2, m2l))

    with exp.stage("figures") as st:
        pngs = []
        for fig_no, key in (("14", "scenario1"), ("15", "scenario2")):
            pngs += draw_scenario(exp, s, task, q0, P0, target, runs[key], ro[key]["X"], key, fig_no)
    timing["figures_s"] = st.seconds

    arrays: dict[str, np.ndarray] = {"target": target}
    for key in ("scenario1", "scenario2"):
        r = runs[key]
        arrays |= {
            f"{key}_t": r.t,
            f"{key}_q": r.trajectory,
            f"{key}_points": r.points,
            f"{key}_line_parameters": ro[key]["X"],
            f"{key}_point_error": r.point_error,
        }
    exp.write_npz("trajectories.npz", **arrays)
    exp.write_json("metrics.json", metrics)
    timing["total_s"] = time.perf_counter() - t_total
    exp.write_timing(timing)
    _print_summary(args, m1, m2, m2l)
    print(f"  wrote {exp.out / 'metrics.json'}, {', '.join(p.name for p in pngs)} ({timing['total_s']:.1f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
