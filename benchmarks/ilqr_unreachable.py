"""How fast iLQR gives up on an unreachable target, against the bounded Gauss–Newton IK on the same target.

    python benchmarks/ilqr_unreachable.py [--targets 3] [--distance 3.0] [--ci] [--out DIR] [--quiet]

For every registered system × every primitive kind it has end points for (exact kinds; a kind
degenerate at the system's q0 is skipped with its reason), ``--targets`` targets: the primitive at
q0 translated by ``--distance`` metres (default 3 m) in a random direction
(:func:`coop_ga.control.displaced_target`).  On each target, from q0 at rest, with defaults:

* ``gn``: :func:`coop_ga.control.gauss_newton_ik` (bounded, the anchor);
* ``ilqr``: :func:`coop_ga.control.ilqr_reach`.

Times are the best of ``--repeats`` calls, after one warm-up call of each solver per task (the
one-off compile is excluded).  ``ratio = t_ilqr / t_gn``.  A target that some solver reaches is
*reachable* (a plane moved within itself) and is listed but kept out of the ratio statistics; on the
others the goal is ``ratio ≤ 5`` with ``converged=False`` and a message saying the target is not
reachable inside the limits.  ``certified``: iLQR stopped before any iteration because the target
misses the reach of some end point (``iterations == 0`` and that message); ``stall``: it stopped at the
stall test (‖e‖ no longer decreasing at a stationary point of ‖e‖ within the limits, package docstring of
:mod:`coop_ga.control.ilqr`) with that message.

Output: a table, the PASS/MISS line and ``<out>/results.json`` (config, per-target records, summary).
``--ci``: three cases, one target each (seconds).
"""

from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import print_table

import coop_ga as cg
from coop_ga.control import displaced_target, gauss_newton_ik, ilqr_reach
from coop_ga.errors import CoopGAError
from coop_ga.geometry import N_POINTS
from coop_ga.harness import Experiment, int_at_least, positive_float

CI_CASES = (("three_franka", "circle"), ("g1_arms", "line"), ("allegro", "sphere"))
UNREACHABLE_PHRASE = "not reachable inside the limits from this start"  # the certificate's message
SAYS_UNREACHABLE = "not reachable inside the limits"  # also a solve that ends stationary says it
RATIO_GOAL = 5.0
KINDS = ("point", "point_pair", "line", "circle", "plane", "sphere")


def cases(ci: bool) -> tuple[list[tuple[str, str]], list[dict[str, str]]]:
    """(system, kind) pairs to run and the skipped ones with a reason."""
    if ci:
        return list(CI_CASES), []
    run, skipped = [], []
    for name in cg.systems.names():
        n_end = len(cg.systems.load(name).end_frames)
        for kind in KINDS:
            if N_POINTS[kind] > n_end:
                continue
            task = cg.cooperative_task(cg.systems.load(name), kind)
            q0 = np.asarray(task.system.q0, dtype=float)
            try:
                task.error(q0, task.similarity(q0))
            except CoopGAError as exc:
                skipped.append({"system": name, "kind": kind, "reason": str(exc)[:200]})
                continue
            run.append((name, kind))
    return run, skipped


def _best(fn: Any, repeats: int) -> tuple[Any, float]:
    best, out = np.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return out, best


def run_target(task: Any, target: Any, repeats: int) -> dict[str, Any]:
    """Both solvers on one target: results and best-of-``repeats`` wall times [s]."""
    q0 = np.asarray(task.system.q0, dtype=float)
    gn, t_gn = _best(lambda: gauss_newton_ik(task, q0, target), repeats)
    il, t_il = _best(lambda: ilqr_reach(task, q0, target), repeats)
    reachable = bool(gn.converged or il.converged)
    return {
        "gn": {"converged": gn.converged, "error": gn.error, "iterations": gn.iterations, "time_s": t_gn},
        "ilqr": {
            "converged": il.converged,
            "error": il.error,
            "iterations": il.iterations,
            "time_s": t_il,
            "within_limits": il.within_limits,
            "message": il.message[:400],
        },
        "ratio": t_il / t_gn,
        "reachable": reachable,
        "certified": il.iterations == 0 and UNREACHABLE_PHRASE in il.message,
        "says_unreachable": SAYS_UNREACHABLE in il.message,
        "stalled": il.message.startswith("not converged: stationary") and UNREACHABLE_PHRASE in il.message,
    }


def summarize(records: list[dict[str, Any]]) -> dict[str, Any]:
    """Ratio statistics over the targets no solver reached, and the goal's verdict."""
    unreach = [r for r in records if not r["reachable"]]
    ratios = [r["ratio"] for r in unreach]
    return {
        "targets": len(records),
        "reachable": len(records) - len(unreach),
        "unreachable": len(unreach),
        "certified": sum(r["certified"] for r in unreach),
        "stalled": sum(r["stalled"] for r in unreach),
        "says_unreachable": sum(r["says_unreachable"] for r in unreach),
        "ratio_median": float(np.median(ratios)) if ratios else None,
        "ratio_max": max(ratios) if ratios else None,
        "ratio_goal": RATIO_GOAL,
        "outside_limits": sum(not r["ilqr"]["within_limits"] for r in records),
        "goal_met": bool(ratios) and max(ratios) <= RATIO_GOAL and all(r["says_unreachable"] for r in unreach),
    }


def _note(r: dict[str, Any]) -> str:
    """The table's note on one target: reachable, certified, stall (the stall test), or - (none of these)."""
    if r["reachable"]:
        return "reachable"
    return "certified" if r["certified"] else ("stall" if r["stalled"] else "-")


def main(argv: list[str] | None = None) -> int:
    exp = Experiment(__file__, __doc__, seed=0)
    exp.add("--targets", type=int_at_least(1), default=3, help="targets per (system, kind) (default 3)")
    exp.add("--distance", type=positive_float, default=3.0, help="translation of the primitive [m] (default 3.0)")
    exp.add("--repeats", type=int_at_least(1), default=3, help="timed calls per solver, best kept (default 3)")
    exp.add("--ci", action="store_true", help=f"{len(CI_CASES)} cases, one target each (seconds)")
    args = exp.parse(argv)
    n_targets = 1 if args.ci else args.targets
    run, skipped = cases(args.ci)
    records: list[dict[str, Any]] = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # degeneracy warnings of far targets are expected here
        for system, kind in exp.progress(run, "cases"):
            task = cg.cooperative_task(cg.systems.load(system), kind)
            q0 = np.asarray(task.system.q0, dtype=float)
            warm = displaced_target(task, q0, translation=(0.01, 0.0, 0.0))
            gauss_newton_ik(task, q0, warm)
            ilqr_reach(task, q0, warm, max_iter=1)
            for i in range(n_targets):
                d = exp.rng.normal(size=3)
                t = args.distance * d / np.linalg.norm(d)
                target = displaced_target(task, q0, translation=t)
                rec = {"system": system, "kind": kind, "index": i, "translation_m": t.tolist()}
                rec.update(run_target(task, target, args.repeats))
                records.append(rec)
    summary = summarize(records)
    rows = [
        [
            r["system"],
            r["kind"],
            str(r["index"]),
            f"{r['gn']['time_s'] * 1e3:.1f}",
            f"{r['ilqr']['time_s'] * 1e3:.1f}",
            f"{r['ratio']:.2f}",
            str(r["ilqr"]["iterations"]),
            _note(r),
        ]
        for r in records
    ]
    if not exp.quiet:
        print_table(
            f"unreachable targets ({args.distance:g} m away): iLQR time / Gauss–Newton IK time",
            ["system", "kind", "#", "gn [ms]", "ilqr [ms]", "ratio", "ilqr it", "note"],
            rows,
        )
        s = summary
        med, top = (f"{x:.3g}" if x is not None else "-" for x in (s["ratio_median"], s["ratio_max"]))
        print(
            f"\n{s['unreachable']} unreachable targets ({s['certified']} certified before any iteration, "
            f"{s['stalled']} stopped at the stall test), "
            f"{s['reachable']} reachable ones left out; ratio median {med}, max {top}"
        )
        print(
            f"{'PASS' if s['goal_met'] else 'MISS'}  iLQR gives up within {RATIO_GOAL:g}× the Gauss–Newton IK time "
            "and says the target is not reachable"
        )
        for x in skipped:
            print(f"  skipped {x['system']}/{x['kind']}: {x['reason'][:100]}")
    config = {"ci": bool(args.ci), "seed": exp.seed, "targets": n_targets, "distance_m": args.distance}
    config["repeats"] = args.repeats
    exp.write_json("results.json", {"config": config, "skipped": skipped, "records": records, "summary": summary})
    return 0


if __name__ == "__main__":
    sys.exit(main())
