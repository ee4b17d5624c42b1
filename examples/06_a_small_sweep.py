"""A small sweep: two controllers × a few sampled targets, one record per solve, a summary table.

``coop_ga.sweep.expand`` turns a sweep spec (a dict here; a JSON/YAML file works the same) into plain job
dicts: the grid is the controller (Gauss–Newton IK, iLQR) × the target level (small, medium displacements
of the three Frankas' circle, sampled per job from ``numpy.random.SeedSequence``) × samples, and
``seeding: {"by": [...]}`` gives both controllers the same random targets.  ``coop_ga.sweep.run`` with
the serial executor runs them in this process and streams one record per job to ``records.jsonl``
(re-running the script resumes: finished jobs are skipped); ``executor="process"`` (or ``"dask"``,
``"ray"``) runs the same jobs in parallel with identical records.  ``summarize`` / ``format_table`` /
``plot`` report the success rate and the iteration and time quantiles per group.

Writes ``records.jsonl``, ``summary.json`` and ``summary.png``.

Run::

    python examples/06_a_small_sweep.py --out /tmp/ex06 --samples 5
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

from coop_ga import sweep

#: Files this example writes into --out (the examples' test checks them).
OUTPUTS = ("records.jsonl", "summary.json", "summary.png")


def spec(samples: int) -> dict:
    """The sweep spec: controllers × levels × samples on the three Frankas' circle."""
    return {
        "name": "example",
        "seed": 0,
        "base": {"system": "three_franka", "kind": "circle", "target": {"sampler": "displacement"}},
        "grid": {
            "controller": ["gauss_newton", "ilqr"],
            "target.level": ["small", "medium"],
            "sample": samples,
        },
        "seeding": {"by": ["level", "sample"]},  # both controllers get the same targets
    }


def main(argv: list[str] | None = None) -> int:
    """Expand, run serially, summarise; returns 0 when no job failed."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path(tempfile.gettempdir()) / "coop_ga_examples" / "06")
    ap.add_argument("--samples", type=int, default=3, help="targets per level (default 3: 12 jobs)")
    ap.add_argument("--fast", action="store_true", help="2 targets per level (8 jobs)")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)

    jobs = sweep.expand(spec(2 if args.fast else args.samples))
    print(f"{len(jobs)} jobs, e.g. {jobs[0]}")
    records = sweep.run(jobs, executor="serial", out=args.out)  # streams records.jsonl, resumes on re-run
    for r in records[:4]:
        print(f"job {r['job']}: {r['controller']:12s} {r['level']:6s} converged={r['converged']} ‖e‖ {r['error']:.1e}")
    rows = sweep.summarize(records, by=["controller", "level"])
    print(sweep.format_table(rows))
    (args.out / "summary.json").write_text(json.dumps(rows, indent=2, default=str))
    sweep.plot(records, args.out / "summary.png", by=["controller", "level"], title="example sweep")
    failed = sum(row["failed"] for row in rows)
    print(f"failed jobs: {failed}; wrote {', '.join(OUTPUTS)} to {args.out}")
    return 0 if failed == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
