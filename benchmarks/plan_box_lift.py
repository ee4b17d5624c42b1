#!/usr/bin/env python
"""Box lift past a shelf lip with OMPL over a cooperative region: the exact constraint Jacobian against OMPL's
finite-difference one, in the same run.

    python benchmarks/plan_box_lift.py [--seeds 50] [--fd-seeds 50] [--scene-seeds 20] [--time-limit 10] [--ci]
                                       [--seed 0] [--out DIR] [--quiet]

Scene: :func:`coop_ga.plan.box_lift.box_lift_problem` — three_franka holds a 0.52 × 0.48 × 0.2 m box at its
upper rim; goal region: the cooperative circle's centre 0.2 m higher (± 1 cm), 8–14 cm towards −y, normal within
10° of vertical; path constraint: the rigid grasp (three TCP distances); path region: the box upright within
10°; validity: joint limits, arm capsules clear of each other and of the shelf lip (five 4 cm spheres), the box
clear of the lip and the table.  Planner: OMPL's RRTConnect on a ProjectedStateSpace (``BOX_LIFT_OPTIONS``:
range 0.5 rad, sampling window 0.4 rad around the start and goal configurations), one thread.

Two more scenes (:mod:`coop_ga.plan.scenes`, ``--scene-seeds`` plans each): ``hand_sphere`` — the Allegro hand
moves the sphere of its four fingertips 8 mm up, its radius held; ``arms_line`` — two G1 arms lift the line
through their wrists 8 cm (direction within 10°), the hands' distance held.  Both without obstacles (the
hands' and arms' own capsules only): they show the sphere and line regions, not a hard search.

Per seed (the numpy seed of the goal samples; OMPL's generator is seeded once per process, so a plan's tree
also depends on the plans before it), two plans, interleaved: ``exact`` (the constraint's ``jacobian`` is the
chain rule through the compiled J^G and Pinocchio's point Jacobians) and ``finite_difference`` (the Python
constraint leaves ``jacobian`` to OMPL's default central differences: 2·nq = 42 calls of the residual).
A plan succeeds when OMPL returns an exact solution within the time limit and the interpolated path (steps of
``delta`` = 0.05 rad, the collision-check resolution) passes every validity check with the constraint held to
10 × its tolerance.

Printed and written to ``<out>/plan_box_lift.json``: success rate (within the limit), median / 90th-percentile
planning time [s] (goal sampling + planning + simplification), median path length [rad], the worst constraint
violation along any interpolated path, constraint calls, the ratio finite-difference / exact of the median
times (the speed claim is this ratio; times are noisy on the shared machine, the load is recorded), and the
failures with their reasons.
"""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from _timing import print_table

VARIANTS = ("exact", "finite_difference")


def _record(r: Any, limit: float) -> dict[str, Any]:
    seg = float(np.max(np.linalg.norm(np.diff(r.path, axis=0), axis=1))) if len(r.path) > 1 else float("nan")
    return {
        "success": bool(r.success and r.time <= limit),
        "solved": bool(r.success),
        "status": r.status,
        "message": r.message,
        "time_s": r.time,
        "goal_time_s": r.goal_time,
        "plan_time_s": r.plan_time,
        "simplify_time_s": r.simplify_time,
        "length_rad": r.length,
        "max_violation": r.max_violation,
        "max_segment_rad": seg,
        "waypoints": len(r.path),
        "constraint_calls": r.constraint_calls,
    }


def _summary(recs: list[dict[str, Any]]) -> dict[str, Any]:
    t = np.array([r["time_s"] for r in recs])
    ok = [r for r in recs if r["success"]]
    return {
        "plans": len(recs),
        "successes": len(ok),
        "success_rate": len(ok) / max(len(recs), 1),
        "median_time_s": float(np.median(t)) if len(t) else float("nan"),
        "p90_time_s": float(np.percentile(t, 90)) if len(t) else float("nan"),
        "median_length_rad": float(np.median([r["length_rad"] for r in ok])) if ok else float("nan"),
        "worst_violation": float(max((r["max_violation"] for r in ok), default=float("nan"))),
        "max_segment_rad": float(max((r["max_segment_rad"] for r in ok), default=float("nan"))),
        "median_constraint_calls": float(np.median([r["constraint_calls"] for r in recs])) if recs else 0.0,
        "failures": [
            f"seed {r['seed']}: {r['message'] or r['status']} ({r['time_s']:.1f} s)" for r in recs if not r["success"]
        ],
    }


def _scenes() -> dict[str, tuple[Any, Any]]:
    """name → (problem, options) of the three scenes."""
    from coop_ga.plan.box_lift import BOX_LIFT_OPTIONS, box_lift_problem
    from coop_ga.plan.scenes import SCENE_OPTIONS, arms_line_problem, hand_sphere_problem

    return {
        "box_lift": (box_lift_problem().problem, BOX_LIFT_OPTIONS),
        "hand_sphere": (hand_sphere_problem(), SCENE_OPTIONS),
        "arms_line": (arms_line_problem(), SCENE_OPTIONS),
    }


def run_scene(
    name: str, problem: Any, options: Any, first: int, seeds: int, fd_seeds: int, limit: float, quiet: bool
) -> dict:
    """Both variants on the seeds ``first … first + seeds − 1`` (the finite-difference one on the first
    ``fd_seeds``), interleaved."""
    import dataclasses

    from tqdm import tqdm

    from coop_ga.plan import plan

    opts = {v: dataclasses.replace(options, jacobian=v, time_limit=limit) for v in VARIANTS}
    records: dict[str, list[dict[str, Any]]] = {v: [] for v in VARIANTS}
    load = [os.getloadavg()[0]]
    for seed in tqdm(range(first, first + seeds), desc=name, disable=quiet):
        for v in VARIANTS:
            if v == "finite_difference" and seed >= first + fd_seeds:
                continue
            r = plan(problem, opts[v], seed=seed)
            records[v].append({"seed": seed, **_record(r, limit)})
        load.append(os.getloadavg()[0])
    summary = {v: _summary(records[v]) for v in VARIANTS}
    return {
        "options": dataclasses.asdict(options),
        "load_1min": {"min": min(load), "max": max(load)},
        "summary": summary,
        "fd_over_exact_median_time": summary["finite_difference"]["median_time_s"] / summary["exact"]["median_time_s"],
        "records": records,
    }


def _print(doc: dict[str, Any], limit: float) -> None:
    for name, sc in doc["scenes"].items():
        rows = []
        for v in VARIANTS:
            s = sc["summary"][v]
            rows.append([v, f"{s['successes']}/{s['plans']}", f"{100 * s['success_rate']:.0f} %",
                         f"{s['median_time_s']:.2f}", f"{s['p90_time_s']:.2f}", f"{s['median_length_rad']:.3f}",
                         f"{s['worst_violation']:.2g}", f"{s['median_constraint_calls']:.0f}"])  # fmt: skip
        ld = sc["load_1min"]
        print_table(
            f"{name}, {limit:g} s per plan (load {ld['min']:.1f}–{ld['max']:.1f} on {doc['cpu_count']} cores)",
            ["jacobian", "solved", "rate", "median s", "p90 s", "length rad", "worst ‖r‖", "constraint calls"],
            rows,
        )
        capped = sc["summary"]["finite_difference"]["success_rate"] < 0.5
        print(
            f"finite-difference / exact median time: {sc['fd_over_exact_median_time']:.2f}×"
            + (" (a lower bound: most finite-difference plans ran into the time limit)" if capped else "")
        )
        for v in VARIANTS:
            for f in sc["summary"][v]["failures"]:
                print(f"  {v} failure: {f}")


def main(argv: list[str] | None = None) -> int:
    from coop_ga.harness import Experiment, int_at_least, positive_float

    exp = Experiment(__file__, __doc__, seed=0, out=Path("results/benchmarks/plan_box_lift"))
    exp.add("--seeds", type=int_at_least(1), default=50, help="box-lift plans per variant")
    exp.add("--fd-seeds", type=int_at_least(0), default=None, help="box-lift plans of the finite-difference variant "
            "(None: --seeds)")  # fmt: skip
    exp.add("--scene-seeds", type=int_at_least(1), default=20, help="plans per variant of the other scenes")
    exp.add("--time-limit", type=positive_float, default=10.0, help="seconds per plan")
    exp.add("--ci", action="store_true", help="2 seeds per variant and scene (the times mean nothing)")
    a = exp.parse(argv)
    seeds = 2 if a.ci else a.seeds
    fd = seeds if a.fd_seeds is None else min(a.fd_seeds, seeds)
    other = 2 if a.ci else a.scene_seeds
    t0 = time.perf_counter()
    doc: dict[str, Any] = {"time_limit_s": a.time_limit, "cpu_count": os.cpu_count(), "first_seed": a.seed,
                           "scenes": {}}  # fmt: skip
    for name, (problem, options) in _scenes().items():
        n, nfd = (seeds, fd) if name == "box_lift" else (other, other)
        doc["scenes"][name] = run_scene(name, problem, options, a.seed, n, nfd, a.time_limit, bool(a.quiet))
    doc["wall_s"] = time.perf_counter() - t0
    (exp.out / "plan_box_lift.json").write_text(json.dumps(_clean(doc), indent=1, allow_nan=False))
    if not a.quiet:
        _print(doc, a.time_limit)
    return 0


def _clean(x: Any) -> Any:
    """NaN / inf → None (strict JSON), recursively."""
    if isinstance(x, dict):
        return {k: _clean(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_clean(v) for v in x]
    if isinstance(x, float) and not np.isfinite(x):
        return None
    return x


if __name__ == "__main__":
    sys.exit(main())
