"""Sweep executors: per-job overhead of the process pool, N iLQR solves serial vs 2 processes vs Dask(2).

    python benchmarks/sweep.py [--jobs 1000] [--workers 2] [--executors serial process dask ray] [--ci]

Jobs: ``--jobs`` iLQR solves (``coop_ga.control.ilqr_reach``, defaults) of ``three_franka``'s cooperative circle
to *medium* targets (5 cm, 15°, ±15 %, random direction and axis; ``coop_ga.sweep`` displacement sampler), seeds
``SeedSequence(--seed).spawn(N)``.  Every executor runs the same jobs and its records are checked to equal the
serial ones (timings excepted) before any time is reported.

Measured, each in this run:

* **start-up** per executor: wall time of a sweep of ``workers`` jobs minus those jobs' serial time — spawning
  the workers, importing coop_ga, loading the task from the compile cache and warming the controller up;
* **per-job overhead** of the process pool over serial: ``--overhead-jobs`` Gauss–Newton IK jobs (≈ 0.5 ms each)
  on one worker, ``(wall − start-up − serial wall) / jobs`` (the pool sends one job per message, so that a dead
  worker or a timeout costs one job), also with ``timeout=`` set (the driver then also tracks deadlines);
* **throughput** of the N iLQR solves: wall time, jobs/s, speed-up over serial, parallel efficiency
  (speed-up / workers);
* **extrapolation**: the throughput per core of the process pool measured here × cores, for a 64-core machine
  and a 10-node cluster of 64-core nodes (linear: assumes the per-core rate and the efficiency measured here
  hold — no shared-memory bandwidth, scheduler or network limits are modelled).

``--ci``: 24 solves, 40 overhead jobs, executors serial and process — the tables' shape, not their numbers.  Results (times in s) go to ``<out>/results.json``.
"""

from __future__ import annotations

import importlib.util
import os
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, os.path.dirname(__file__))
from _timing import print_table

import coop_ga.sweep as sw
from coop_ga.harness import Experiment, int_at_least

SYSTEM, KIND = "three_franka", "circle"
EXTRAPOLATE = (("this machine (measured)", None), ("64-core machine", 64), ("10 nodes × 64 cores", 640))


def ilqr_jobs(n: int, seed: int) -> list[dict[str, Any]]:
    """n iLQR jobs to medium displacement targets, one spawned seed each."""
    return [
        {
            "system": SYSTEM,
            "kind": KIND,
            "controller": "ilqr",
            "target": {"sampler": "displacement", "level": "medium"},
            "seed": s,
        }
        for s in sw.seeds(seed, n)
    ]


def gn_jobs(n: int, seed: int) -> list[dict[str, Any]]:
    """n Gauss–Newton IK jobs to small targets (cheap: the per-job overhead dominates)."""
    return [
        {**j, "controller": "gauss_newton", "target": {"sampler": "displacement", "level": "small"}}
        for j in ilqr_jobs(n, seed)
    ]


def timed(jobs: list[dict[str, Any]], executor: str, workers: int, **kw: Any) -> tuple[float, list[dict[str, Any]]]:
    """(wall time [s], records) of one sweep."""
    t0 = time.perf_counter()
    recs = sw.run(jobs, executor=executor, workers=workers, **kw)
    return time.perf_counter() - t0, recs


def _available(executors: list[str]) -> list[str]:
    """The executors whose package is installed (the others are skipped with the install line)."""
    available = []
    for e in executors:
        mod = {"dask": "distributed", "ray": "ray"}.get(e)
        if mod is None or importlib.util.find_spec(mod) is not None:
            available.append(e)
        else:
            print(f"skipping executor {e}: pip install 'coop_ga[{e}]'")
    return available


def _time_executors(exp: Experiment, jobs: list[dict[str, Any]], available: list[str], W: int, seed: int) -> tuple:
    """``(rows, ref)``: the serial reference sweep, then start-up and sweep of every other executor."""
    n = len(jobs)
    with exp.stage("warming up"):
        sw.run(ilqr_jobs(2, seed + 1))
        sw.run(gn_jobs(2, seed + 1))
    with exp.stage(f"{n} iLQR solves, serial"):
        wall_s, ref = timed(jobs, "serial", 1)
    rows: dict[str, dict[str, Any]] = {
        "serial": {"wall_s": wall_s, "startup_s": 0.0, "jobs_per_s": n / wall_s, "speedup": 1.0, "workers": 1}
    }
    for e in available[1:]:
        with exp.stage(f"{e}: start-up"):
            few = ilqr_jobs(W, seed + 2)
            t_few, recs_few = timed(few, e, W)
            startup = max(0.0, t_few - sum(r["seconds"] for r in recs_few))
        with exp.stage(f"{n} iLQR solves, {e} ({W} workers)"):
            wall, recs = timed(jobs, e, W)
        same = sw.records_equal(ref, recs)
        if not same:
            print(f"WARNING: {e} records differ from serial")
        steady = max(1e-9, wall - startup)
        rows[e] = {
            "wall_s": wall,
            "startup_s": startup,
            "jobs_per_s": n / wall,
            "jobs_per_s_steady": n / steady,
            "speedup": wall_s / wall,
            "speedup_steady": wall_s / steady,
            "workers": W,
            "records_equal_serial": same,
        }
    return rows, ref


def _pool_overhead(exp: Experiment, n_over: int, seed: int) -> dict[str, Any]:
    """Per-job overhead of the process pool over serial (one worker: no parallelism in the numbers)."""
    with exp.stage(f"overhead: {n_over} Gauss–Newton jobs, serial / 1-worker pool"):
        gj = gn_jobs(n_over, seed + 3)
        t_ser, g_ref = timed(gj, "serial", 1)
        t_one, _ = timed(gn_jobs(1, seed + 4), "process", 1)
        t_c1, g1 = timed(gj, "process", 1)
        t_cd, gd = timed(gj, "process", 1, timeout=60.0)
    start1 = t_one - t_ser / n_over  # the one job itself costs about a serial job
    return {
        "jobs": n_over,
        "serial_per_job_s": t_ser / n_over,
        "startup_1_worker_s": start1,
        "overhead_per_job_s": (t_c1 - start1 - t_ser) / n_over,
        "overhead_per_job_timeout_s": (t_cd - start1 - t_ser) / n_over,
        "records_equal_serial": sw.records_equal(g_ref, g1) and sw.records_equal(g_ref, gd),
    }


def _print_executors(rows: dict[str, dict[str, Any]], n: int, conv: int, job_s: float) -> None:
    """The table of the executors' sweeps."""
    table = []
    for e, r in rows.items():
        table.append(
            [
                e,
                str(r["workers"]),
                f"{r['wall_s']:.2f}",
                f"{r['startup_s']:.2f}",
                f"{r['jobs_per_s']:.1f}",
                f"{r['speedup']:.2f}",
                f"{r.get('speedup_steady', 1.0):.2f}",
                f"{r.get('speedup_steady', 1.0) / r['workers']:.2f}",
                "yes" if r.get("records_equal_serial", True) else "NO",
            ]
        )
    print_table(
        f"{n} iLQR solves, {SYSTEM} {KIND}, medium targets ({conv}/{n} converged; mean solve {1e3 * job_s / n:.1f} ms)"
        f" on {os.cpu_count()} cores",
        [
            "executor",
            "workers",
            "wall s",
            "start-up s",
            "jobs/s",
            "speed-up",
            "excl. start-up",
            "efficiency",
            "= serial",
        ],
        table,
    )
    print(
        "  start-up: wall of a sweep of `workers` jobs minus their serial time (spawn, import, task load, warm-up);"
        " excl. start-up = wall − start-up.\n  Ray's start-up (ray.init, 5–9 s here) varies by seconds between runs:"
        " its excl.-start-up speed-up is noisy (it can exceed the worker count)."
    )


def _print_overhead(overhead: dict[str, Any], n_over: int) -> None:
    """The table of the pool's per-job overhead."""
    print_table(
        f"per-job overhead of the process pool over serial ({n_over} Gauss–Newton jobs, 1 worker; target < 5 ms)",
        ["measure", "value"],
        [
            ["serial time per job", f"{1e3 * overhead['serial_per_job_s']:.3f} ms"],
            ["pool start-up (1 worker)", f"{overhead['startup_1_worker_s']:.2f} s"],
            ["overhead per job", f"{1e3 * overhead['overhead_per_job_s']:.3f} ms"],
            ["overhead per job, timeout=60 s", f"{1e3 * overhead['overhead_per_job_timeout_s']:.3f} ms"],
            ["records equal serial", "yes" if overhead["records_equal_serial"] else "NO"],
        ],
    )
    print("  a negative overhead is below the noise of this measurement (± ~0.1 ms per job)")


def _extrapolate(rows: dict[str, dict[str, Any]]) -> tuple[dict[str, Any], float]:
    """``(base row, solves/s per core)``, and the table of the linear extrapolation to bigger machines."""
    base = rows.get("process") or rows["serial"]
    per_core = base.get("jobs_per_s_steady", base["jobs_per_s"]) / base["workers"]
    eff = base.get("speedup_steady", 1.0) / base["workers"] if "process" in rows else 1.0
    ext = []
    for label, cores in EXTRAPOLATE:
        c = cores or base["workers"]
        rate = per_core * c
        ext.append([label, str(c), f"{rate:.0f}", f"{1000 / rate:.2f}", f"{10000 / rate:.1f}", f"{100000 / rate:.0f}"])
    print_table(
        f"extrapolation: {per_core:.1f} iLQR solves/s per core (process pool, start-up excluded; efficiency {eff:.2f}"
        " here) × cores, linear",
        ["machine", "cores", "solves/s", "1 000 solves s", "10 000 solves s", "100 000 solves s"],
        ext,
    )
    return base, per_core


def main(argv: list[str] | None = None) -> int:
    exp = Experiment(__file__, __doc__, seed=0, out=Path("results/benchmarks/sweep"))
    exp.add("--jobs", type=int_at_least(2), default=1000, help="iLQR solves per executor")
    exp.add("--overhead-jobs", type=int_at_least(2), default=400, help="cheap jobs of the overhead measurement")
    exp.add("--workers", type=int_at_least(1), default=2, help="workers of the parallel executors")
    exp.add(
        "--executors",
        nargs="+",
        choices=sw.EXECUTORS,
        default=["serial", "process", "dask"],
        help="executors to time (serial is always run: it is the reference)",
    )
    exp.add("--ci", action="store_true", help="small mode (24 solves, 40 overhead jobs)")
    args = exp.parse(argv)
    n = 24 if args.ci else args.jobs
    n_over = 40 if args.ci else args.overhead_jobs
    executors = ["serial"] + [e for e in args.executors if e != "serial"]
    if args.ci:
        executors = ["serial", "process"]  # Dask and Ray are tested in tests/sweep; their start-up is seconds
    available = _available(executors)
    W = args.workers
    jobs = ilqr_jobs(n, args.seed)
    out: dict[str, Any] = {"jobs": n, "workers": W, "system": SYSTEM, "kind": KIND, "cpu_count": os.cpu_count()}
    rows, ref = _time_executors(exp, jobs, available, W, args.seed)
    conv = sum(r["converged"] for r in ref)
    job_s = sum(r["seconds"] for r in ref)
    overhead = _pool_overhead(exp, n_over, args.seed) if "process" in available else {}
    _print_executors(rows, n, conv, job_s)
    if overhead:
        _print_overhead(overhead, n_over)
    base, per_core = _extrapolate(rows)
    out.update(
        serial_converged=conv,
        mean_solve_s=job_s / n,
        executors=rows,
        overhead=overhead,
        per_core_jobs_per_s=per_core,
        # the unrounded rates (the table's are rounded to whole jobs/s: their ratios drift when the rate is small)
        extrapolation=[
            {"machine": label, "cores": cores or base["workers"], "jobs_per_s": per_core * (cores or base["workers"])}
            for label, cores in EXTRAPOLATE
        ],
        ci=bool(args.ci),
    )
    exp.write_json("results.json", out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
