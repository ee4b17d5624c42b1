"""Run a sweep spec: ``python -m coop_ga.sweep SPEC --executor serial|process|dask|ray --workers N --out DIR``.

SPEC is a ``.json`` file, a ``.yaml`` file (needs PyYAML) or the name of a ready spec (``--list``):
``robustness`` (every system × kind × level × 20 targets × 4 controllers, the study of
``benchmarks/robustness.py``) and ``impedance_gains`` (a stiffness × damping grid of impedance control on
``three_iiwa14`` from random starts).  Writes to DIR: the records (``records.jsonl`` or
``records/*.parquet``, streamed as they arrive; re-running the same command resumes, skipping finished jobs),
``summary.json`` (the summary table, grouped by ``--by`` or the spec's ``summary_by``) and ``sweep.png``
(success rates and iteration histograms); the table is printed.  Exit status 0 also when jobs fail (failures
are records); 2 for a bad spec or option, or an output directory in use by another sweep (it is locked while a
sweep writes it).

Faults: a worker that dies fails only its job (run ``--retries`` more times on a fresh worker, default 1, then
recorded as ``WorkerDied``); a job running longer than ``--timeout`` (seconds, ``auto`` = 10× the median job so
far, or ``none``; default: the spec's ``timeout``, else ``auto``) is killed and recorded as ``timeout``.  Specs
expanding to more than ``--max-jobs`` jobs (default 1 000 000) are refused before any job is made.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

from ..errors import CoopGAError
from .executors import EXECUTORS, run
from .spec import MAX_JOBS, InvalidJobError, expand, load_spec, ready_specs
from .store import FORMATS
from .summary import format_table, plot, summarize


def _positive_int(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer ≥ 1, got {text!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"expected an integer ≥ 1, got {text!r}")
    return v


def _timeout(text: str) -> float | str | None:
    if text in ("auto", "none"):
        return None if text == "none" else "auto"
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected seconds > 0, 'auto' or 'none', got {text!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"expected seconds > 0, 'auto' or 'none', got {text!r}")
    return v


def _count(text: str) -> int:
    """An integer ≥ 1, also written like 1e7."""
    try:
        v = int(text)
    except ValueError:
        try:
            f = float(text)
        except ValueError:
            f = math.nan
        v = int(f) if math.isfinite(f) and f.is_integer() else 0
    if v < 1:
        raise argparse.ArgumentTypeError(f"expected an integer ≥ 1 (e.g. 1000000 or 1e7), got {text!r}")
    return v


def build_parser() -> argparse.ArgumentParser:
    """The command-line interface."""
    ap = argparse.ArgumentParser(
        prog="python -m coop_ga.sweep",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("spec", nargs="?", help="spec file (.json/.yaml) or ready spec name")
    ap.add_argument("--executor", choices=EXECUTORS, default="process", help="where the jobs run (default process)")
    ap.add_argument("--workers", type=_positive_int, default=None, help="worker processes (default: CPU count)")
    ap.add_argument("--out", type=Path, default=None, help="output directory (default results/sweep_<spec name>)")
    ap.add_argument("--format", choices=FORMATS, default="jsonl", help="record format (parquet needs pyarrow)")
    ap.add_argument("--address", default=None, help="Dask scheduler or Ray cluster address (default: local)")
    ap.add_argument("--overwrite", action="store_true", help="discard records in --out instead of resuming")
    ap.add_argument("--fast", action="store_true", help="the spec's small variant (CI: a few jobs)")
    ap.add_argument("--limit", type=_positive_int, default=None, help="run only the first N jobs")
    ap.add_argument("--by", nargs="+", default=None, metavar="FIELD", help="summary grouping (record fields)")
    ap.add_argument(
        "--timeout",
        type=_timeout,
        default=argparse.SUPPRESS,
        help="per-job limit: seconds, 'auto' (10× the median job so far, ≥ 10 s) or 'none' (default: the spec's, else auto)",
    )
    ap.add_argument("--retries", type=int, default=1, help="runs of a job after its worker died (default 1)")
    ap.add_argument("--max-jobs", type=_count, default=MAX_JOBS, help="refuse specs of more jobs (default 1e6)")
    ap.add_argument("--no-figure", action="store_true", help="do not draw sweep.png")
    ap.add_argument("--quiet", action="store_true", help="no progress bar")
    ap.add_argument("--list", action="store_true", help="list the ready specs and exit")
    return ap


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns the exit status."""
    ap = build_parser()
    args = ap.parse_args(argv)
    if args.list:
        for name, path in ready_specs().items():
            spec = load_spec(path)
            print(f"{name:<18} {len(expand(path)):>6} jobs  {spec.get('description', '').splitlines()[0]}")
        return 0
    if not args.spec:
        ap.error("a spec is required (or --list)")
    try:
        spec = load_spec(args.spec, fast=args.fast)
        jobs = expand(spec, max_jobs=args.max_jobs)
    except InvalidJobError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    timeout = getattr(args, "timeout", spec.get("timeout", "auto"))
    if args.limit:
        jobs = jobs[: args.limit]
    name = spec.get("name") or Path(args.spec).stem
    out = args.out or Path("results") / f"sweep_{name}"
    by = args.by or spec.get("summary_by") or ["controller"]
    t0 = time.perf_counter()
    try:
        recs = run(
            jobs,
            executor=args.executor,
            workers=args.workers,
            out=out,
            format=args.format,
            resume=not args.overwrite,
            progress=not args.quiet,
            address=args.address,
            timeout=timeout,
            retries=args.retries,
            desc=name,
        )
    except CoopGAError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    wall = time.perf_counter() - t0
    fields = spec.get("summary_fields") or ["iterations", "seconds"]
    rows = summarize(recs, by, fields=fields)
    (out / "summary.json").write_text(json.dumps({"spec": name, "jobs": len(recs), "by": by, "rows": rows}, indent=1))
    print(f"{name}: {len(recs)} jobs, executor {args.executor}, {wall:.1f} s → {out}")
    print(format_table(rows))
    if not args.no_figure:
        plot(
            recs, out / "sweep.png", by, title=f"{name}: {len(recs)} jobs", field=spec.get("histogram") or "iterations"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
