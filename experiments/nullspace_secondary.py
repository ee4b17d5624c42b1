#!/usr/bin/env python
"""§4.3 / Figs. 16–17: a secondary task in the geometric nullspace of a cooperative circle.

System ``three_franka`` (21 joints), cooperative circle through the three TCPs (Eq 14), at
the nominal q0 (``--perturb`` draws a uniform perturbation with ``--seed``).  Primary task:
hold the cooperative similarity ``V_Sc(q0)`` ("stay on the circle").  Secondary task: arm
``--arm`` moves its TCP to the point of the circle ``--angle`` degrees further along it,
``q̇_{0,d} = J_p⁺ k_s (p* − p)`` (point Jacobian of that arm only, speed capped at 0.2 m/s).
Both runs use first-order kinematics ``q_{t+1} = q_t + Δt q̇`` (Eq 61), Δt = 0.01 s, 4 s,
and stay inside the joint position, velocity and acceleration limits, starting at rest
(``coop_ga.control.nullspace_point_reach``, ``limit_mode='enforce'``):

* Fig. 16 (``direct``): ``q̇ = [q̇_{0,d}; 0; 0]`` applied as is;
* Fig. 17 (``nullspace``): ``q̇ = J^G⁺ k_p log(Ṽ_Sc(q) V_Sc(q0)) + N(q) [q̇_{0,d}; 0; 0]``
  with ``N = I − J^G⁺ J^G`` (Eq 58, 60).

Measured per run (``metrics.json``): the Euclidean distance ``‖p − p*‖`` of the moving TCP
to its target point and the similarity distance ``‖log(Ṽ_Sc(q0) V_Sc(q_t))‖`` (the curves
of Figs. 16b/17b), and the distance of the moving TCP from the held circle [m] (Figs.
16a/17a: "deviates from" / "stays on the circle"); ``max_limit_violation`` [rad],
``max_velocity_violation`` [rad/s] and ``max_acceleration_violation`` [rad/s²] are the largest
excursions of the trajectories outside the position, velocity and acceleration limits (0 = inside).

Where the paper is imprecise (and what this script does):

* Eq 60 is the projected secondary velocity alone.  Its discrete steps (Eq 61) leave V_Sc
  unchanged only to first order, so the similarity distance drifts; the primary feedback
  term ``J^G⁺ k_p e`` (k_p = ``--primary-gain`` = 10/s) removes the drift.  Without it
  (``primary_gain=0``, the ablation ``nullspace_without_primary_feedback``) the distance
  grows to ~1e-3 and stays; with it, it peaks at ~2e-4 while the arm moves at its speed cap
  and decays below 1e-9 — "zero" in Fig. 17 means this.
* the target point, the angle along the circle and the gains are not given; 30° (a 25.5 cm
  chord of the 0.49 m circle) and k_s = 2/s are used.
* "the similarity distance is non-zero while the robot is moving" (Fig. 16): it is, and it
  returns to ~0 at the end, since the target point lies on the circle and the other two arms
  do not move: the circle deviates during the motion (the TCP follows the chord), not at the end.

Writes to ``--out``: ``metrics.json`` (with the ``gallery`` block), ``trajectories.npz``,
``fig16_scene.png`` / ``fig17_scene.png`` (the arms at start, light, and end, grey; the held
circle dashed, intermediate circles thin, the target point green, the moving TCP's path
red; beside it a close-up of the TCP path and the held circle seen along the circle's normal, in cm,
in the same window for both figures, where the direct run's 1.7 cm deviation shows), ``fig16_distances.png`` / ``fig17_distances.png`` (Euclidean and similarity
distance over time, same axes) and ``fig16_animation.gif`` / ``fig17_animation.gif`` (the motion,
``--frames`` frames, the held circle dashed); wall-clock times go to ``timing.json``.

``--fast`` (CI): at most 2 s; every file and metric key is still written.

    python experiments/nullspace_secondary.py --out results/nullspace_secondary
"""

from __future__ import annotations

import sys
import time
from typing import Any

import numpy as np

from coop_ga.harness import Experiment, finite_float, int_at_least, nonneg_float, positive_float

FAST_DURATION = 2.0


def distance_from_circle(P: np.ndarray, center: np.ndarray, normal: np.ndarray, radius: float) -> np.ndarray:
    """Euclidean distance [m] of points P (T, 3) [m, world] from the circle (centre (3,) [m], unit
    normal (3,), radius [m]): ``sqrt(h² + (ρ − r)²)`` with h the height above the circle's plane and
    ρ the distance from its axis.  Returns (T,)."""
    d = np.asarray(P, float).reshape(-1, 3) - center
    h = d @ normal
    rho = np.linalg.norm(d - np.outer(h, normal), axis=1)
    return np.sqrt(h**2 + (rho - radius) ** 2)


def _in_plane(P: np.ndarray, circle: tuple[np.ndarray, np.ndarray, float]) -> np.ndarray:
    """Points (N, 3) [m] in the held circle's plane coordinates (N, 2) [cm], centre at the origin."""
    from coop_ga.viz import plane_basis

    c, n, _ = circle
    u, v, _ = plane_basis(n)
    Q = np.asarray(P, float).reshape(-1, 3) - c
    return 100.0 * np.column_stack([Q @ u, Q @ v])


def closeup_window(
    paths: list[np.ndarray], circle: tuple[np.ndarray, np.ndarray, float], target: np.ndarray
) -> tuple[tuple[float, float], tuple[float, float]]:
    """x and y limits [cm] (plane coordinates) around every TCP path and the target: one window for both figures."""
    Q = np.vstack([_in_plane(P, circle) for P in [*paths, target[None]]])
    lo, hi = Q.min(axis=0), Q.max(axis=0)
    m = 0.12 * float(np.max(hi - lo))
    return (float(lo[0] - m), float(hi[0] + m)), (float(lo[1] - m), float(hi[1] + m))


def add_closeup(
    exp: Experiment,
    png: Any,
    points: np.ndarray,
    circle: tuple[np.ndarray, np.ndarray, float],
    target: np.ndarray,
    dcirc: np.ndarray,
    window: tuple[tuple[float, float], tuple[float, float]],
) -> None:
    """Redraw the scene ``png`` with a second view beside it: the moving TCP's path (T, 3) [m] and the held circle
    seen along its normal, in centimetres, in the same window for Figs. 16 and 17 — at the scene's scale a
    deviation of a centimetre or two from a 0.49 m circle is invisible."""
    import matplotlib.image as mpimg

    from coop_ga import viz

    plt = exp.pyplot()
    img = mpimg.imread(png)
    h, w = img.shape[:2]
    fig = plt.figure(figsize=(w / viz.DPI + 3.6, h / viz.DPI))
    gs = fig.add_gridspec(1, 2, width_ratios=[w / viz.DPI, 3.0], wspace=0.08)
    ax0 = fig.add_subplot(gs[0])
    ax0.imshow(img)
    ax0.set_axis_off()
    ax = fig.add_subplot(gs[1])
    _, _, r = circle
    th = np.linspace(0.0, 2.0 * np.pi, 2000)
    ax.plot(100 * r * np.cos(th), 100 * r * np.sin(th), "k--", lw=1.4, label="held circle")
    P = _in_plane(points, circle)
    ax.plot(*P.T, color=viz.PALETTE.trajectory, lw=1.8, label="TCP path")
    t = _in_plane(target[None], circle)[0]
    ax.plot(*t, marker="o", ls="none", color=viz.PALETTE.initial_primitive, ms=7, label="target point")
    ax.set_xlim(*window[0])
    ax.set_ylim(*window[1])
    ax.set_aspect("equal", adjustable="box")  # the window is fixed (one for both figures): the box adapts
    ax.set_xlabel("in the circle's plane [cm]")
    ax.set_ylabel("[cm]")
    ax.set_title(
        f"close-up along the circle's normal\nTCP off the circle by up to {100 * dcirc.max():.2g} cm", fontsize=9
    )
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.16), fontsize=8, ncol=1)
    fig.savefig(png, dpi=viz.DPI, bbox_inches="tight")
    plt.close(fig)


def _parse(argv: list[str] | None) -> Experiment:
    """The command line."""
    exp = Experiment(__file__, __doc__, seed=0)
    exp.add("--perturb", type=nonneg_float, default=0.0, help="uniform perturbation [rad] of q0 (0: nominal q0)")
    exp.add("--angle", type=finite_float, default=30.0, help="how far along the circle the arm moves [deg]")
    exp.add("--arm", type=int, choices=(0, 1, 2), default=0, help="index of the moving arm / end point")
    exp.add("--duration", type=positive_float, default=4.0, help="duration [s]")
    exp.add("--dt", type=positive_float, default=0.01, help="time step [s] (Eq 61)")
    exp.add("--secondary-gain", type=positive_float, default=2.0, help="point-reaching gain k_s [1/s]")
    exp.add("--primary-gain", type=nonneg_float, default=10.0, help="primary (hold) feedback gain k_p [1/s]")
    exp.add("--frames", type=int_at_least(2), default=30, help="frames of each animation GIF (--fast: 4)")
    exp.add_fast("CI run (every output still written)", duration=FAST_DURATION, frames=4)
    exp.parse(argv)
    return exp


def _runs(exp: Experiment, task: Any, q0: np.ndarray, target: np.ndarray, timing: dict[str, float]) -> tuple:
    """``(res, ablation)``: the direct and the nullspace runs, and Eq 60 without the primary feedback."""
    from coop_ga.control.nullspace import nullspace_point_reach

    args = exp.args
    kw = dict(duration=args.duration, dt=args.dt, secondary_gain=args.secondary_gain, primary_gain=args.primary_gain)
    res = {}
    for name, project in (("direct", False), ("nullspace", True)):
        with exp.stage(f"{name}: arm {args.arm} to the point {args.angle:g}° along the circle") as st:
            res[name] = nullspace_point_reach(task, q0, args.arm, target, project=project, **kw)
        timing[f"{name}_s"] = st.seconds
    with exp.stage("ablation: Eq 60 without the primary feedback") as st:
        ab = nullspace_point_reach(task, q0, args.arm, target, project=True, **{**kw, "primary_gain": 0.0})
    timing["ablation_s"] = st.seconds
    return res, ab


def _run_entry(task: Any, q0: np.ndarray, v: Any, arm: int, dcirc: np.ndarray) -> dict[str, Any]:
    """The metrics of one run ``v`` (``dcirc`` (T,): its TCP's distance from the held circle [m])."""
    others = [i for i in range(3) if i != arm]
    moved = max(
        float(np.max(np.linalg.norm(np.array([task.points(q)[i] for q in v.trajectory]) - task.points(q0)[i], axis=1)))
        for i in others
    )
    return {
        "initial_point_error_m": float(v.point_error[0]),
        "final_point_error_m": float(v.point_error[-1]),
        "max_similarity_distance": float(v.similarity_distance.max()),
        "final_similarity_distance": float(v.similarity_distance[-1]),
        "max_distance_from_circle_m": float(dcirc.max()),
        "final_distance_from_circle_m": float(dcirc[-1]),
        "other_tcps_max_displacement_m": moved,
        "limit_violation_rad": v.limit_violation,
        "velocity_violation_rad_s": v.velocity_violation,
        "acceleration_violation_rad_s2": v.max_acceleration_violation,
        "limit_active_steps": v.active_steps,
    }


def _run_metrics(task: Any, q0: np.ndarray, res: dict, ab: Any, arm: int, circle: tuple, metrics: dict) -> dict:
    """Every run's block (and the limits over all of them) into ``metrics``; returns the distances from the circle."""
    c, n, r = circle
    dcirc = {}
    for k, v in {**res, "ablation": ab}.items():
        dcirc[k] = distance_from_circle(v.points, c, n, r)
        entry = _run_entry(task, q0, v, arm, dcirc[k])
        if k == "ablation":
            metrics["nullspace_without_primary_feedback"] = {
                "what": "Eq 60 alone (primary_gain = 0), not plotted",
                **{
                    key: entry[key]
                    for key in ("final_point_error_m", "max_similarity_distance", "final_similarity_distance")
                },
                "limit_violation_rad": v.limit_violation,
            }
        else:
            metrics[k] = entry
    metrics["max_limit_violation"] = max(v.limit_violation for v in (*res.values(), ab))
    metrics["max_velocity_violation"] = max(v.velocity_violation for v in (*res.values(), ab))
    # the Franka's acceleration limits, from rest (imposed by the runner, measured on the trajectories)
    metrics["max_acceleration_violation"] = max(v.max_acceleration_violation for v in (*res.values(), ab))
    metrics["similarity_distance_ratio_direct_over_nullspace"] = (
        metrics["direct"]["max_similarity_distance"] / metrics["nullspace"]["max_similarity_distance"]
    )
    return dcirc


def _draw_scene(
    exp: Experiment, s: Any, task: Any, q0: np.ndarray, v: Any, X: Any, target: np.ndarray, fig_no: int, title: str
) -> Any:
    """``fig<NN>_scene.png``: start and end, the circles during the motion, the target and the TCP path."""
    import coop_ga as cg
    from coop_ga import viz

    scene = viz.Scene()
    scene.robot(s, q0, "initial", label="start")
    scene.robot(s, v.q, "final", label=f"end (t = {exp.args.duration:g} s)")
    scene.primitive(X, "target", label=r"held circle $V_{Sc}(q_0)$")
    idx = np.linspace(0, len(v.t) - 1, 8).astype(int)[1:-1]
    for j, kk in enumerate(idx):
        scene.primitive(
            task.primitive(v.trajectory[kk]),
            "intermediate",
            fraction=(j + 1) / (len(idx) + 1),
            label="circles during the motion" if j == 0 else None,
        )
    scene.primitive(cg.point(target), "initial", label="target point")
    scene.curve(v.points, "trajectory", label=f"TCP path of arm {exp.args.arm}")
    return viz.render_scene(scene, exp.out / f"fig{fig_no}_scene.png", view=(35.0, -60.0), size=(7.0, 6.0), title=title)


def _draw_distances(exp: Experiment, plt: Any, v: Any, dcirc: np.ndarray, ymax: float, fig_no: int, title: str) -> Any:
    """``fig<NN>_distances.png``: point error, similarity distance and distance from the circle over time."""
    from coop_ga import viz

    fig, ax = plt.subplots(figsize=(6.4, 3.6))
    ax.plot(v.t, v.point_error, color="tab:blue", lw=1.6, label=r"Euclidean distance $\|p - p^*\|$ [m]")
    ax.plot(
        v.t,
        v.similarity_distance,
        color=viz.PALETTE.trajectory,
        lw=1.6,
        label=rf"similarity distance $\|\log(\tilde V_{{Sc}}(q_0) V_{{Sc}}(q_t))\|$ (max {v.similarity_distance.max():.1e})",
    )
    ax.plot(
        v.t,
        dcirc,
        color="0.4",
        ls="--",
        lw=1.2,
        label=f"TCP distance from the held circle [m] (max {dcirc.max():.1e})",
    )
    ax.set_xlim(0.0, exp.args.duration)
    ax.set_ylim(0.0, ymax)
    ax.grid(True, alpha=0.3)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("distance [m | 1]")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.2))
    dist_png = exp.save(fig, f"fig{fig_no}_distances.png")
    plt.close(fig)
    return dist_png


def _draw(
    exp: Experiment,
    plt: Any,
    s: Any,
    task: Any,
    q0: np.ndarray,
    res: dict,
    X: Any,
    target: np.ndarray,
    circle: tuple,
    dcirc: dict,
) -> dict[str, list[str]]:
    """Figs. 16 and 17: per run its scene (with the close-up), its distances and its animation."""
    from coop_ga import viz

    args = exp.args
    window = closeup_window([res[k].points for k in ("direct", "nullspace")], circle, target)
    ymax = 1.05 * max(max(float(v.point_error.max()), float(v.similarity_distance.max())) for v in res.values())
    figs: dict[str, list[str]] = {}
    for fig_no, k, title in (
        (16, "direct", "secondary task applied directly (Fig. 16)"),
        (17, "nullspace", "secondary task in the nullspace, Eq 60 (Fig. 17)"),
    ):
        v = res[k]
        scene_png = _draw_scene(exp, s, task, q0, v, X, target, fig_no, title)
        add_closeup(exp, scene_png, v.points, circle, target, dcirc[k], window)
        dist_png = _draw_distances(exp, plt, v, dcirc[k], ymax, fig_no, title)
        gif = viz.animate(
            s,
            v.trajectory,
            task.primitive,
            exp.out / f"fig{fig_no}_animation.gif",
            t=v.t,
            frames=args.frames,
            fps=args.frames / args.duration,
            target=X,
            view=(35.0, -60.0),
            size=(4.8, 3.6),
            dpi=80,
            title=title,
        )
        figs[k] = [dist_png.name, scene_png.name, gif.name]
    return figs


def _gallery(metrics: dict, duration: float, figs: dict[str, list[str]]) -> dict[str, Any]:
    """The gallery block: the paper's claim and the numbers that back or contradict it."""
    mn, md = metrics["nullspace"], metrics["direct"]
    agrees = (
        mn["final_point_error_m"] < 0.05 * mn["initial_point_error_m"]
        and md["final_point_error_m"] < 0.05 * md["initial_point_error_m"]
        and mn["max_similarity_distance"] < 1e-3
        and md["max_similarity_distance"] > 10 * mn["max_similarity_distance"]
        and md["max_distance_from_circle_m"] > 10 * mn["max_distance_from_circle_m"]
        and metrics["max_limit_violation"] == 0.0
        and metrics["max_acceleration_violation"] == 0.0
    )
    return {
        "title": "Figs. 16–17: a secondary task in the geometric nullspace of the circle",
        "claim": (
            "Projected by the nullspace projector of J^G (Eq 58, 60), the first arm reaches another point of the "
            "cooperative circle while staying on it and the similarity distance stays zero; applied directly, the "
            "arm deviates from the circle and the similarity distance is non-zero while it moves."
        ),
        "evidence": (
            f"Both runs reach the target point ({mn['initial_point_error_m'] * 100:.1f} cm away) to "
            f"{mn['final_point_error_m'] * 1e3:.2f} mm (nullspace) and {md['final_point_error_m'] * 1e3:.2f} mm "
            f"(direct) in {duration:g} s. The largest similarity distance is {mn['max_similarity_distance']:.1e} "
            f"with the projection against {md['max_similarity_distance']:.1e} without "
            f"({metrics['similarity_distance_ratio_direct_over_nullspace']:.0f}×); the TCP leaves the circle by at "
            f"most {mn['max_distance_from_circle_m'] * 1e3:.2f} mm against {md['max_distance_from_circle_m'] * 1e3:.1f} "
            f"mm. 'Zero' needs the primary feedback of our Eq 60: without it the distance drifts to "
            f"{metrics['nullspace_without_primary_feedback']['max_similarity_distance']:.1e}. Inside the joint "
            f"position, velocity and acceleration limits (max excursions {metrics['max_limit_violation']:.2g} rad, "
            f"{metrics['max_velocity_violation']:.2g} rad/s, {metrics['max_acceleration_violation']:.2g} rad/s²)."
        ),
        "agrees": bool(agrees),
        "figures": [*figs["nullspace"], *figs["direct"]],
    }


def main(argv: list[str] | None = None) -> int:
    exp = _parse(argv)
    args = exp.args
    plt = exp.pyplot()

    import coop_ga as cg
    from coop_ga.control.nullspace import point_on_circle

    duration = args.duration
    timing: dict[str, float] = {}
    t_total = time.perf_counter()
    with exp.stage("loading three_franka and compiling the circle task") as st:
        s = cg.systems.load("three_franka")
        task = cg.cooperative_task(s, "circle")
        q0 = np.clip(s.q0 + exp.rng.uniform(-args.perturb, args.perturb, s.nq), s.q_lower, s.q_upper)
        task.evaluate(q0)
    timing["load_and_compile_s"] = st.seconds
    target = point_on_circle(task, q0, args.arm, np.deg2rad(args.angle))
    X = task.primitive(q0)
    c, r, n = np.asarray(cg.center(X), float), float(cg.radius(X)), np.asarray(cg.normal(X), float)
    n = n / np.linalg.norm(n)
    res, ab = _runs(exp, task, q0, target, timing)

    metrics: dict = {
        "system": "three_franka",
        "kind": "circle",
        "nq": s.nq,
        "seed": args.seed,
        "fast": bool(args.fast),
        "perturb_rad": args.perturb,
        "arm": args.arm,
        "angle_deg": args.angle,
        "duration_s": duration,
        "dt_s": args.dt,
        "secondary_gain_per_s": args.secondary_gain,
        "primary_gain_per_s": args.primary_gain,
        "target_point_m": target,
        "circle": {"center_m": c, "radius_m": r, "normal": n},
        "chord_length_m": float(np.linalg.norm(target - task.points(q0)[args.arm])),
    }
    dcirc = _run_metrics(task, q0, res, ab, args.arm, (c, n, r), metrics)
    with exp.stage("rendering"):
        figs = _draw(exp, plt, s, task, q0, res, X, target, (c, n, r), dcirc)

    exp.write_npz(
        "trajectories.npz",
        t=res["nullspace"].t,
        target=target,
        **{
            f"{k}_{f}": getattr(v, f)
            for k, v in res.items()
            for f in ("trajectory", "points", "point_error", "similarity_distance")
        },
        **{f"{k}_distance_from_circle": dcirc[k] for k in res},
    )
    metrics["gallery"] = _gallery(metrics, duration, figs)
    exp.write_json("metrics.json", metrics)
    timing["total_s"] = time.perf_counter() - t_total
    exp.write_timing(timing)
    for k in res:
        print(
            f"{k:9s} final point error {metrics[k]['final_point_error_m']:.2e} m, max similarity distance "
            f"{metrics[k]['max_similarity_distance']:.2e}, max distance from the circle "
            f"{metrics[k]['max_distance_from_circle_m']:.2e} m"
        )
    print(f"wrote {exp.out}/metrics.json, trajectories.npz, {', '.join(metrics['gallery']['figures'])}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
