"""Sweeps at scale: thousands of IK / iLQR / impedance runs from one description.

A sweep is a list of plain, picklable job specs (:mod:`coop_ga.sweep.spec`); :func:`run` maps each to a plain
record (:mod:`coop_ga.sweep.worker`) on an executor (:mod:`coop_ga.sweep.executors`: serial, a spawned process
pool, Dask or Ray), streams the records to disk (:mod:`coop_ga.sweep.store`) and resumes an interrupted sweep;
:func:`summarize` / :func:`plot` (:mod:`coop_ga.sweep.summary`) report them.  Seeds come from
``numpy.random.SeedSequence(root).spawn(n)`` (or from names), so records are the same serial or parallel and in
any order.  ::

    import coop_ga.sweep as sw

    jobs = [{"system": "three_franka", "kind": "circle", "controller": "gauss_newton",
             "target": {"translation": [0.05, 0, 0], "angle": 0.2, "axis": [0, 0, 1], "scale": 1.1}, "seed": k}
            for k in range(4)]
    recs = sw.run(jobs, executor="process", workers=2, out="results/my_sweep")
    print(sw.format_table(sw.summarize(recs, by="controller")))

    jobs = sw.expand("robustness")              # a ready spec (coop_ga/sweep/specs), or a JSON/YAML file

A worker that dies fails only its job (retried once on a fresh worker, then recorded as ``WorkerDied``), a job
over ``timeout=`` is killed and recorded as ``timeout``, specs are read safely and limited to ``max_jobs``, and
an output directory is locked by the sweep writing it (:mod:`coop_ga.sweep.executors`, :mod:`.pool`, :mod:`.spec`,
:mod:`.store`).

Command line: ``python -m coop_ga.sweep SPEC --executor serial|process|dask|ray --workers N --out DIR``.
"""

from __future__ import annotations

from .executors import EXECUTORS, MissingExtraError, SweepArgumentError, records_equal, run, strip_timing
from .pool import TimeoutPolicy
from .spec import (
    CONTROLLERS,
    MAX_JOBS,
    InvalidJobError,
    Job,
    count_jobs,
    expand,
    job_hash,
    load_spec,
    normalize_job,
    ready_specs,
)
from .store import FORMATS, RecordWriter, SweepError, SweepLockedError, read_records
from .summary import format_table, plot, summarize
from .targets import LEVELS, Level, certify, draw_displacement, name_spawn_key, seed_sequence, seeds
from .worker import TIME_FIELDS, run_job

__all__ = [
    "CONTROLLERS",
    "EXECUTORS",
    "FORMATS",
    "LEVELS",
    "MAX_JOBS",
    "TIME_FIELDS",
    "InvalidJobError",
    "Job",
    "Level",
    "MissingExtraError",
    "RecordWriter",
    "SweepArgumentError",
    "SweepError",
    "SweepLockedError",
    "TimeoutPolicy",
    "certify",
    "count_jobs",
    "draw_displacement",
    "expand",
    "format_table",
    "job_hash",
    "load_spec",
    "name_spawn_key",
    "normalize_job",
    "plot",
    "read_records",
    "ready_specs",
    "records_equal",
    "run",
    "run_job",
    "seed_sequence",
    "seeds",
    "strip_timing",
    "summarize",
]
