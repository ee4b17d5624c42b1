#!/usr/bin/env python
"""Planar closed-loop linkages in CGA (seed 004): full crank cycles of a 4-bar, the seed's slider
4-bar, a Watt 6-bar and a 10-bar, solved by Newton steps in the Lie algebra of planar motors.

For each linkage the crank turns once (``--steps`` requested angles; the tracker refines them
where needed) and the script records the largest joint residual, Newton iterations per step
and how well the rigid links keep their lengths; the 4-bar is checked against Freudenstein's
closed form on both assembly branches, and a non-Grashof 4-bar shows the toggle position found
from the singular constraint Jacobian against its closed form.  Seed disagreements (the bar
constraint x_i ∧ x_j = 0, the Lie-algebra basis, the joint counts in the captions) are listed
in ``metrics.json`` and in :mod:`coop_ga.linkages`.

Writes ``<linkage>.gif`` (crank green, ground blue, as in the seed), ``coupler_curves.png``,
``metrics.json`` and ``timing.json`` (time per crank step).

    python experiments/linkages.py --out results/linkages
"""

from __future__ import annotations

import sys
import time
from typing import Any

import numpy as np

from coop_ga.harness import Experiment, int_at_least
from coop_ga.linkages import (
    Linkage,
    LinkageMotion,
    crank_limits,
    four_bar,
    freudenstein_output,
    slider_crank,
    ten_bar,
    watt_six_bar,
)

FOUR_BAR = (2.0, 0.5, 2.0, 1.5)  # ground, crank, coupler, rocker [m]: a crank-rocker
NON_GRASHOF = (1.0, 0.8, 0.5, 0.45)  # a triple rocker: the crank toggles at ±62.55°
#: the point whose path is drawn as each linkage's "coupler curve"
TRACED = {"four_bar": "coupler.P", "slider_crank": "slider.S", "watt_six_bar": "coupler2.E", "ten_bar": "link_FG.G"}
#: readable names of the linkages and of their traced points (the figure's titles and legends)
NAMES = {"four_bar": "four-bar", "slider_crank": "slider-crank", "watt_six_bar": "Watt six-bar", "ten_bar": "ten-bar"}
TRACED_NAMES = {
    "four_bar": "coupler point P",
    "slider_crank": "slider point S",
    "watt_six_bar": "point E of the second coupler",
    "ten_bar": "point G of link FG",
}
GREEN, BLUE, GREY = "#2e9e44", "#1f5fbf", "#555555"


def _length_error(lk: Linkage, motion: LinkageMotion) -> float:
    worst = 0.0
    for ln, link in lk.links.items():
        names = list(link.points)
        for i in range(len(names)):
            for j in range(i + 1, len(names)):
                d0 = float(np.linalg.norm(np.subtract(link.points[names[i]], link.points[names[j]])))
                a, b = motion.point(f"{ln}.{names[i]}"), motion.point(f"{ln}.{names[j]}")
                worst = max(worst, float(np.abs(np.linalg.norm(a - b, axis=1) - d0).max()))
    return worst


def _freudenstein_error(lengths: tuple[float, ...], motion: LinkageMotion) -> float:
    B, D = motion.point("rocker.B"), motion.point("rocker.D")
    th4 = np.arctan2(B[:, 1] - D[:, 1], B[:, 0] - D[:, 0])
    F = freudenstein_output(*lengths, motion.crank_angles)
    err = np.abs(np.angle(np.exp(1j * (F - th4[:, None]))))
    return float(err[:, int(np.argmin(err[0]))].max())


def _draw(ax: Any, lk: Linkage, motion: LinkageMotion, k: int, traced: str) -> None:
    for ln, link in lk.links.items():
        P = np.array([motion.point(f"{ln}.{p}")[k] for p in link.points])
        if ln == lk.ground:
            ax.plot(P[:, 0], P[:, 1], "^", color=BLUE, ms=9, zorder=3)
            order = np.argsort(P[:, 0])
            ax.plot(P[order, 0], P[order, 1], "-", color=BLUE, lw=3, alpha=0.6, zorder=1)
            continue
        color = GREEN if ln == lk.crank else GREY
        if len(P) > 2:
            ax.fill(P[:, 0], P[:, 1], color=color, alpha=0.25, zorder=1)
            P = np.vstack([P, P[:1]])
        ax.plot(P[:, 0], P[:, 1], "-o", color=color, lw=2.5, ms=4, zorder=2)
    curve = motion.point(traced)
    ax.plot(curve[: k + 1, 0], curve[: k + 1, 1], "-", color="#c0392b", lw=1.2, zorder=0)


def _limits(motion: LinkageMotion) -> tuple[np.ndarray, np.ndarray]:
    P = motion.points.reshape(-1, 2)
    lo, hi = P.min(0), P.max(0)
    pad = 0.08 * (hi - lo).max()
    return lo - pad, hi + pad


def _gif(exp: Experiment, plt: Any, name: str, lk: Linkage, motion: LinkageMotion, frames: int) -> str:
    from matplotlib.animation import PillowWriter

    fig, ax = plt.subplots(figsize=(4.0, 3.2), dpi=70)
    lo, hi = _limits(motion)
    idx = np.linspace(0, len(motion.crank_angles) - 1, frames).round().astype(int)
    writer = PillowWriter(fps=12)
    path = exp.out / f"{name}.gif"
    with writer.saving(fig, str(path), dpi=70):
        for k in idx:
            ax.clear()
            _draw(ax, lk, motion, int(k), TRACED[name])
            ax.set_xlim(lo[0], hi[0])
            ax.set_ylim(lo[1], hi[1])
            ax.set_aspect("equal")
            ax.set_title(f"{NAMES[name]}  φ = {np.rad2deg(motion.crank_angles[k]):5.1f}°", fontsize=9)
            ax.set_xticks([])
            ax.set_yticks([])
            writer.grab_frame()
    plt.close(fig)
    return path.name


def coupler_curves(
    exp: Experiment, plt: Any, linkages: dict[str, Linkage], motions: dict[str, LinkageMotion], results: dict[str, Any]
) -> None:
    """``coupler_curves.png``: each linkage at crank angle 0 with the full path of its traced point (axes in m)."""
    from matplotlib.lines import Line2D

    fig, axes = plt.subplots(1, 4, figsize=(13, 3.9))
    for ax, (name, lk) in zip(axes, linkages.items(), strict=True):
        m = motions[name]
        c = m.point(TRACED[name])
        _draw(ax, lk, m, 0, TRACED[name])
        ax.plot(c[:, 0], c[:, 1], "-", color="#c0392b", lw=1.5)
        ax.set_aspect("equal")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        r = results[name]
        ax.set_title(
            f"{NAMES[name]} ({r['links']} links, {r['joints']} joints)\npath of the {TRACED_NAMES[name]}", fontsize=9
        )
    handles = [
        Line2D([], [], color=GREEN, lw=2.5, marker="o", ms=4, label="crank"),
        Line2D([], [], color=BLUE, lw=3, alpha=0.6, marker="^", ms=8, label="ground (fixed pivots)"),
        Line2D([], [], color=GREY, lw=2.5, marker="o", ms=4, label="other links"),
        Line2D([], [], color="#c0392b", lw=1.5, label="path of the traced point over one crank turn"),
    ]
    fig.legend(handles=handles, loc="lower center", ncol=4, fontsize=8, frameon=False)
    fig.tight_layout(rect=(0.0, 0.08, 1.0, 1.0))
    exp.save(fig, "coupler_curves.png")
    plt.close(fig)


def _cycle(name: str, lk: Linkage, angles: np.ndarray, timing: dict[str, float]) -> tuple[LinkageMotion, dict]:
    """One crank cycle of linkage ``name``: its motion and its metrics (residuals, link lengths, closed forms)."""
    t0 = time.perf_counter()
    motion = lk.solve(angles) if hasattr(lk, "solve") else lk.track(angles)
    timing[f"{name}_seconds_per_step"] = (time.perf_counter() - t0) / len(angles)
    r: dict[str, Any] = {
        "links": len(lk.links),
        "joints": len(lk.joints) + 1,
        "grubler_dof": lk.grubler_dof,
        "complete": motion.complete,
        "steps": len(motion.crank_angles),
        "max_residual": float(motion.residual.max()),
        "iterations_per_step_mean": float(motion.iterations.mean()),
        "iterations_per_step_max": int(motion.iterations.max()),
        "substeps_max": int(motion.substeps.max()),
        "max_link_length_error": _length_error(lk, motion),
        "min_sigma": float(motion.sigma_min.min()),
    }
    if name == "four_bar":
        r["freudenstein_error_branch_plus"] = _freudenstein_error(FOUR_BAR, motion)
        r["freudenstein_error_branch_minus"] = _freudenstein_error(
            FOUR_BAR, four_bar(*FOUR_BAR, branch=-1).solve(angles)
        )
    if name == "slider_crank":
        S = motion.point("slider.S")
        r["slider_x_max_abs"] = float(np.abs(S[:, 0]).max())
        r["slider_y_range"] = [float(S[:, 1].min()), float(S[:, 1].max())]
    return motion, r


def _non_grashof() -> dict[str, Any]:
    """The non-Grashof 4-bar: where the crank stops, against the closed-form toggle angle."""
    ng = four_bar(*NON_GRASHOF)
    ng_motion = ng.solve(np.linspace(0.0, np.pi / 2, 46))
    (limit,) = crank_limits(*NON_GRASHOF)
    return {
        "lengths": list(NON_GRASHOF),
        "grashof": ng.kind,
        "complete": ng_motion.complete,
        "stop_angle_deg": float(np.rad2deg(ng_motion.stop_angle or np.nan)),
        "closed_form_toggle_deg": float(np.rad2deg(limit)),
        "stop_angle_error_rad": float(abs((ng_motion.stop_angle or np.nan) - limit)),
        "sigma_min_at_stop": float(ng_motion.stop_sigma_min or np.nan),
        "message": ng_motion.message,
    }


def _metrics(n_angles: int, linkages: dict[str, Linkage], results: dict[str, Any], gifs: list[str]) -> dict:
    """metrics.json: every linkage's results, the worst residuals, where we disagree with the seed, the gallery."""
    worst_res = max(results[n]["max_residual"] for n in linkages)
    worst_len = max(results[n]["max_link_length_error"] for n in linkages)
    all_complete = all(results[n]["complete"] for n in linkages)
    fb = results["four_bar"]
    ngr = results["non_grashof_four_bar"]
    return {
        "steps_requested": n_angles,
        "linkages": results,
        "all_complete": all_complete,
        "max_residual": worst_res,
        "max_link_length_error": worst_len,
        "seed_disagreements": [
            "§3.2: x_i ∧ x_j = 0 is a coincidence of two conformal points, not a bar of length L "
            "(that is x_i·x_j = −½L²); bar lengths are a link property here (the motor preserves them).",
            "§3.3: the Lie-algebra basis {e12, e1∧e0, e2∧e0} generates transversions; the translations are e1∞, e2∞.",
            "§3.4: exp(tθ e12) rotates about the origin by −2tθ, not about the crank pivot.",
            "Fig. 1c/1d: '6 bars, 5 revolute joints' and '10 bars, 7 revolute joints' are not 1-DOF by "
            "Grübler (7 and 13 joints are needed); we built 6 links/7 joints and 10 links/13 joints.",
        ],
        "gallery": {
            "title": "Planar linkages in CGA (our addition, seed 004)",
            "claim": "Planar closed-loop linkages can be simulated by Newton steps in the Lie algebra of CGA "
            "motors, with the constraints as CGA residuals and the Jacobian from automatic differentiation.",
            "evidence": (
                f"Over one crank cycle ({n_angles} angles) of a 4-bar, the seed's slider 4-bar, a Watt 6-bar "
                f"and a 10-bar the largest residual is {worst_res:.1e} m and link lengths hold to {worst_len:.1e} m "
                f"({'all cycles complete' if all_complete else 'NOT all cycles complete'}); the 4-bar matches "
                f"Freudenstein's closed form to {max(fb['freudenstein_error_branch_plus'], fb['freudenstein_error_branch_minus']):.1e} rad "
                f"on both branches, and the non-Grashof 4-bar stops at {ngr['stop_angle_deg']:.4f}° against the "
                f"closed-form toggle {ngr['closed_form_toggle_deg']:.4f}° (σ_min {ngr['sigma_min_at_stop']:.1e}). "
                "We disagree with the seed's bar constraint, Lie-algebra basis and joint counts (see metrics)."
            ),
            "agrees": bool(all_complete and worst_res < 1e-10),
            "figures": ["coupler_curves.png", *gifs],
        },
    }


def main(argv: list[str] | None = None) -> int:
    exp = Experiment(__file__, __doc__, seed=0)
    exp.add("--steps", type=int_at_least(8), default=360, help="requested crank angles per cycle")
    exp.add("--frames", type=int_at_least(2), default=48, help="frames per GIF")
    exp.add_fast("fewer crank steps and GIF frames (CI)", steps=72, frames=8)
    args = exp.parse(argv)
    steps, frames = args.steps, args.frames
    plt = exp.pyplot()
    angles = np.linspace(0.0, 2 * np.pi, steps + 1)
    linkages: dict[str, Linkage] = {
        "four_bar": four_bar(*FOUR_BAR),
        "slider_crank": slider_crank(),
        "watt_six_bar": watt_six_bar(),
        "ten_bar": ten_bar(),
    }
    results: dict[str, Any] = {}
    timing: dict[str, float] = {}
    motions: dict[str, LinkageMotion] = {}
    for name, lk in exp.progress(list(linkages.items()), "crank cycles"):
        motions[name], results[name] = _cycle(name, lk, angles, timing)
    results["non_grashof_four_bar"] = _non_grashof()
    gifs = [_gif(exp, plt, name, linkages[name], motions[name], frames) for name in linkages]
    coupler_curves(exp, plt, linkages, motions, results)
    metrics = _metrics(len(angles), linkages, results, gifs)
    exp.write_json("metrics.json", metrics)
    exp.write_timing(timing)
    print(
        f"max residual {metrics['max_residual']:.2e} m, link lengths {metrics['max_link_length_error']:.2e} m; wrote {exp.out}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
