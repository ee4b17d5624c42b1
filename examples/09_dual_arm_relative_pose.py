"""Two hands keep their relative orientation while the line between them moves (the cooperative dual task space).

The Unitree G1's two hands (``g1_arms``: waist + two arms, 17 DOF) follow a moving point pair: hand → hand is
carried 6 cm forward, 10 cm up and turned 40° about a tilted vertical over the run (a similarity target of scale 1,
so the distance between the hands is kept).  A point pair fixes the two end *points* only: each hand is free to
turn about its own point, and a controller that tracks the pair alone lets the hands turn against each other.  The
**relative motor** of the dual task space, ``M_r = M̃_2 M_1`` (:class:`coop_ga.control.tasks.DualTaskSpace`), has
the relative orientation in its rotation rows; a :class:`~coop_ga.control.tasks.DualTask` on those rows, stacked
with the similarity task in one QP step per 10 ms (:func:`coop_ga.control.solve_step`, inside the joint limits),
holds it.  The script runs both controllers on the same moving target and prints the relative-orientation error
(the angle of ``R_r(q0)ᵀ R_r(q)``) over the run, and the tracking error of the point pair.

Writes ``trajectory.npz`` (``pair_only``, ``pair_and_orientation`` (T, 17), ``time`` (T,)), ``metrics.json``
and ``relative_orientation.png`` (the error over time).

Run::

    python examples/09_dual_arm_relative_pose.py --out /tmp/ex09
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

import coop_ga as cg
from coop_ga.control import Configuration, SimilarityTask, default_limits, displaced_target, solve_step
from coop_ga.control.tasks import DualTask, DualTaskSpace

#: Files this example writes into --out (the examples' test checks them).
OUTPUTS = ("trajectory.npz", "metrics.json", "relative_orientation.png")

DT = 0.01  # s, the control step


def moving_target(task: cg.CooperativeTask, q0: np.ndarray, s: float) -> cg.Similarity:
    """The point pair's target at progress s ∈ [0, 1] (smooth start and stop)."""
    a = 0.5 - 0.5 * np.cos(np.pi * min(max(s, 0.0), 1.0))
    return displaced_target(
        task, q0, translation=(0.06 * a, 0.0, 0.10 * a), axis=(0.3, 0.0, 1.0), angle=np.deg2rad(40.0) * a, scale=1.0
    )


def track(task: cg.CooperativeTask, space: DualTaskSpace, motion: int, rest: int, hold: bool) -> dict[str, np.ndarray]:
    """Follow the target moving for ``motion`` steps, then at rest for ``rest`` steps; with ``hold`` the relative
    orientation of the hands is a second task of the same step."""
    q0 = np.asarray(task.system.q0, dtype=float)
    relative = DualTask(space, "relative", space.relative(q0), components="orientation", gain=10.0)
    limits = default_limits(task.system.limits)
    cfg = Configuration(task, q0)
    Q, orient, pair = [q0.copy()], [0.0], [0.0]
    for k in range(motion + rest):
        target = moving_target(task, q0, (k + 1) / motion)
        tasks = [SimilarityTask(target, gain=10.0)] + ([relative] if hold else [])
        qd = solve_step(cfg, tasks, limits, DT, damping=1e-3).velocity
        q = cfg.q + DT * qd
        cfg.update(q, qd)
        Q.append(q.copy())
        orient.append(float(np.linalg.norm(relative.error(cfg))))
        pair.append(float(np.linalg.norm(task.error(q, target))))
    return {"trajectory": np.array(Q), "orientation_error": np.array(orient), "pair_error": np.array(pair)}


def plot(time: np.ndarray, runs: dict[str, dict[str, np.ndarray]], path: Path) -> None:
    """The relative-orientation error [deg] of both runs over time."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5, 3), dpi=80)
    for name, run in runs.items():
        ax.plot(time, np.rad2deg(run["orientation_error"]), label=name.replace("_", " "))
    ax.set_xlabel("time [s]")
    ax.set_ylabel("relative orientation error [deg]")
    ax.set_yscale("symlog", linthresh=1e-3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    """Track the moving pair with and without the relative orientation; returns 0 when the orientation is held."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path(tempfile.gettempdir()) / "coop_ga_examples" / "09")
    ap.add_argument("--fast", action="store_true", help="a 1.2 s motion instead of 3.2 s")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)

    task = cg.cooperative_task("g1_arms", "point_pair")
    space = DualTaskSpace(task)  # the two hands, M_r = M̃_left M_right
    motion, rest = (120, 60) if args.fast else (320, 80)
    steps = motion + rest
    runs = {
        name: track(task, space, motion, rest, hold)
        for name, hold in (("pair_only", False), ("pair_and_orientation", True))
    }
    time = DT * np.arange(steps + 1)
    metrics: dict[str, object] = {"system": "g1_arms", "kind": "point_pair", "steps": steps, "dt_s": DT}
    for name, run in runs.items():
        o, p = np.rad2deg(run["orientation_error"]), run["pair_error"]
        metrics[name] = {
            "orientation_error_max_deg": float(o.max()),
            "orientation_error_final_deg": float(o[-1]),
            "pair_error_max": float(p.max()),
            "pair_error_final": float(p[-1]),
        }
        print(
            f"{name:21s} relative orientation error: max {o.max():.4f}°, final {o[-1]:.2e}°; "
            f"point-pair error ‖e‖: max {p.max():.3f} (tracking lag), final {p[-1]:.1e}"
        )
    print("relative orientation error [deg] over the run (every 0.25 s):")
    for k in range(0, steps + 1, 25):
        cols = "  ".join(f"{name} {np.rad2deg(run['orientation_error'][k]):8.4f}" for name, run in runs.items())
        print(f"  t = {time[k]:4.2f} s  {cols}")

    np.savez(args.out / "trajectory.npz", time=time, **{name: run["trajectory"] for name, run in runs.items()})
    (args.out / "metrics.json").write_text(json.dumps(metrics, indent=2))
    plot(time, runs, args.out / "relative_orientation.png")
    print(f"wrote {', '.join(OUTPUTS)} to {args.out}")
    held = runs["pair_and_orientation"]
    ok = held["orientation_error"].max() < np.deg2rad(0.05) and held["pair_error"][-1] < 1e-3
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
