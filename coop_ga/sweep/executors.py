"""Executors (serial, process pool, Dask, Ray) and :func:`run`, the entry point of a sweep.

Every executor runs the same function (:func:`coop_ga.sweep.worker.run_chunk`) on chunks of (index, job) pairs
and yields records as they complete; :func:`run` streams them to disk, shows the progress, and returns them
sorted by job index.  Records depend only on the job (its seed included), never on the executor, the number
of workers, the chunking or the completion order — up to the timing fields :data:`TIME_FIELDS`.

* ``"serial"``: this process.
* ``"process"``: :class:`concurrent.futures.ProcessPoolExecutor` with the *spawn* context; the initialiser
  (:func:`~coop_ga.sweep.worker.init_worker`) builds every task of the sweep once per worker and warms its
  controllers up.  Workers start with BLAS/OpenMP pinned to one thread.  First-time compiles of one task by
  several workers at once are safe: :mod:`coop_ga.codegen` builds under a per-entry ``flock`` and publishes with
  an atomic ``os.replace`` (issue 10), so N workers compile a new task once and never see a partial library.
* ``"dask"``: :mod:`dask.distributed` — a ``LocalCluster`` of ``workers`` single-threaded worker processes, or
  the scheduler at ``address``.  Extra: ``pip install 'coop_ga[dask]'``.
* ``"ray"``: :class:`ray.util.multiprocessing.Pool` on a local Ray instance of ``workers`` CPUs, or the cluster
  at ``address``.  Extra: ``pip install 'coop_ga[ray]'``.

A worker that dies (a crash, not an exception of a job, which is data) fails its chunk: those jobs are recorded
with ``exception_type = "WorkerDied"`` and are run again by a resumed sweep.
"""

from __future__ import annotations

import contextlib
import multiprocessing as mp
import os
import sys
from collections.abc import Iterator, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from pathlib import Path
from typing import Any

from .spec import Job, normalize_job, sweep_hash
from .store import FORMATS, RecordWriter, SweepError, clear, read_meta, read_records
from .worker import BLAS_ENV, TIME_FIELDS, init_worker, run_chunk

__all__ = ["EXECUTORS", "MissingExtraError", "records_equal", "run", "strip_timing"]

EXECUTORS = ("serial", "process", "dask", "ray")
WORKER_DIED = "WorkerDied"

Item = tuple[int, dict[str, Any]]


class MissingExtraError(SweepError, ImportError):
    """An executor's optional dependency is not installed (the message names the extra)."""


def _need(module: str, extra: str, executor: str) -> Any:
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise MissingExtraError(
            f"executor={executor!r} needs {module.split('.')[0]} ({exc}): pip install 'coop_ga[{extra}]'"
        ) from None


@contextlib.contextmanager
def _pinned_env() -> Iterator[None]:
    """BLAS/OpenMP pinned to one thread in this process's environment while workers are spawned."""
    old = {k: os.environ.get(k) for k in BLAS_ENV}
    os.environ.update(BLAS_ENV)
    try:
        yield
    finally:
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def _died(items: Sequence[Item], exc: BaseException) -> list[dict[str, Any]]:
    from .spec import job_hash

    return [
        {
            "job": i,
            "job_hash": job_hash(j),
            "system": j["system"] if isinstance(j["system"], str) else str(j["system"].get("name", "recipe")),
            "kind": j["kind"],
            "controller": j["controller"],
            **j["tags"],
            "status": "failed",
            "converged": False,
            "error": None,
            "iterations": None,
            "seconds": 0.0,
            "exception_type": WORKER_DIED,
            "exception": f"{type(exc).__name__}: {str(exc)[:300]}",
        }
        for i, j in items
    ]


def _setup_jobs(items: Sequence[Item]) -> list[dict[str, Any]]:
    """One job per distinct (task, controller): what a worker initialiser needs to build and warm up."""
    seen: dict[str, dict[str, Any]] = {}
    for _, j in items:
        k = repr((j["system"], j["kind"], j["points"], j["controller"]))
        seen.setdefault(k, j)
    return list(seen.values())


def _serial(chunks: list[list[Item]], workers: int, address: str | None, warmup: bool) -> Iterator[list[dict]]:
    init_worker((), warmup, worker=False)
    for c in chunks:
        yield run_chunk(c)


def _process(chunks: list[list[Item]], workers: int, address: str | None, warmup: bool) -> Iterator[list[dict]]:
    setup = _setup_jobs([it for c in chunks for it in c])
    with _pinned_env():  # the workers are spawned by the submits (up to ``workers`` of them)
        pool = ProcessPoolExecutor(
            max_workers=workers, mp_context=mp.get_context("spawn"), initializer=init_worker, initargs=(setup, warmup)
        )
        futs = {pool.submit(run_chunk, c): c for c in chunks}
    try:
        pending = set(futs)
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for f in done:
                try:
                    yield f.result()
                except Exception as exc:  # BrokenProcessPool: a worker died
                    yield _died(futs[f], exc)
    finally:  # also on Ctrl-C / an error downstream: drop the queued chunks, finish the running ones
        pool.shutdown(wait=True, cancel_futures=True)


def _dask(chunks: list[list[Item]], workers: int, address: str | None, warmup: bool) -> Iterator[list[dict]]:
    dd = _need("dask.distributed", "dask", "dask")
    dask = _need("dask", "dask", "dask")
    setup = _setup_jobs([it for c in chunks for it in c])
    with contextlib.ExitStack() as stack:
        if address:
            client = stack.enter_context(dd.Client(address))
        else:
            stack.enter_context(_pinned_env())
            # The nanny's default MALLOC_TRIM_THRESHOLD_=65536 makes these allocation-heavy solvers ~45 % slower
            # (measured: 300 iLQR solves 2.59 s → 3.72 s in one process); glibc's adaptive default is kept.
            env = {**dask.config.get("distributed.nanny.pre-spawn-environ"), **BLAS_ENV, "MALLOC_TRIM_THRESHOLD_": None}
            stack.enter_context(dask.config.set({"distributed.nanny.pre-spawn-environ": env}))
            cluster = stack.enter_context(
                dd.LocalCluster(
                    n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=40
                )
            )
            client = stack.enter_context(dd.Client(cluster))
        client.run(init_worker, setup, warmup)  # every current worker; a late one builds lazily
        futs = client.map(run_chunk, chunks, pure=False)
        index = {f.key: c for f, c in zip(futs, chunks)}
        for f in dd.as_completed(futs):
            try:
                yield f.result()
            except Exception as exc:  # a worker lost (KilledWorker)
                yield _died(index[f.key], exc)


def _ray(chunks: list[list[Item]], workers: int, address: str | None, warmup: bool) -> Iterator[list[dict]]:
    ray = _need("ray", "ray", "ray")
    rmp = _need("ray.util.multiprocessing", "ray", "ray")
    setup = _setup_jobs([it for c in chunks for it in c])
    started = False
    if not ray.is_initialized():
        kw: dict[str, Any] = {"address": address} if address else {"num_cpus": workers}
        ray.init(
            **kw,
            include_dashboard=False,
            log_to_driver=False,
            configure_logging=False,
            runtime_env={"env_vars": dict(BLAS_ENV)},
        )
        started = True
    pool = rmp.Pool(processes=workers, initializer=init_worker, initargs=(setup, warmup))
    try:
        yield from pool.imap_unordered(run_chunk, chunks, chunksize=1)
    finally:
        pool.terminate()
        if started:
            ray.shutdown()


_RUNNERS = {"serial": _serial, "process": _process, "dask": _dask, "ray": _ray}


def strip_timing(rec: Mapping[str, Any]) -> dict[str, Any]:
    """A record without its timing fields (:data:`TIME_FIELDS`): what must agree between runs."""
    return {k: v for k, v in rec.items() if k not in TIME_FIELDS}


def records_equal(a: Sequence[Mapping[str, Any]], b: Sequence[Mapping[str, Any]]) -> bool:
    """Whether two sweeps' records agree exactly, timing fields excepted."""
    return len(a) == len(b) and all(strip_timing(x) == strip_timing(y) for x, y in zip(a, b))


def _chunks(items: list[Item], workers: int, chunksize: int | None) -> list[list[Item]]:
    if chunksize is None:  # a few chunks per worker, so that the load balances and progress moves
        chunksize = max(1, min(16, len(items) // (8 * max(1, workers))))
    return [items[i : i + chunksize] for i in range(0, len(items), chunksize)]


def run(
    jobs: Sequence[Mapping[str, Any] | Job],
    executor: str = "serial",
    workers: int | None = None,
    out: str | Path | None = None,
    *,
    format: str = "jsonl",
    resume: bool = True,
    progress: bool = False,
    address: str | None = None,
    chunksize: int | None = None,
    warmup: bool = True,
    desc: str = "sweep",
) -> list[dict[str, Any]]:
    """Run a sweep → one record per job (a list of dicts sorted by ``job``, the job's index).

    Parameters
    ----------
    jobs: job specs (plain dicts or :class:`~coop_ga.sweep.Job`; :mod:`coop_ga.sweep.spec`), e.g.
        ``coop_ga.sweep.expand("robustness")``.  Structural errors raise :class:`~coop_ga.sweep.InvalidJobError`
        before anything runs; a job that fails at run time is recorded (``status="failed"``), never raised.
    executor: ``"serial"``, ``"process"`` (spawned process pool), ``"dask"`` or ``"ray"`` (module docstring).
    workers: worker processes (default: ``os.cpu_count()``; ignored by ``"serial"``).
    out: directory to stream the records to (``records.jsonl`` or ``records/*.parquet``, plus ``sweep.json``);
        None keeps them in memory only.
    format: ``"jsonl"`` or ``"parquet"`` (needs pyarrow).
    resume: with ``out`` holding records of *this* sweep, skip the jobs already recorded (except those whose
        worker died) and return the stored records with the new ones; ``False`` starts afresh.  Records of a
        different sweep in ``out`` raise :class:`~coop_ga.sweep.SweepError` (choose another directory or
        ``resume=False``).
    progress: a tqdm progress bar (rate and ETA) on stderr.
    address: Dask scheduler / Ray cluster address (default: a local cluster of ``workers``).
    chunksize: jobs per unit of work sent to a worker (default: a few chunks per worker, at most 16 jobs).
    warmup: build and call every (task, controller) once per process before its first timed job.

    Each record has ``job``, ``converged``, ``error`` (final ‖e‖), ``iterations``, ``seconds`` (wall time of the
    controller call [s]), ``status``, ``exception_type``/``exception``, the controller's result fields and the
    limit measures (:mod:`coop_ga.sweep.worker`).
    """
    if executor not in EXECUTORS:
        raise SweepError(f"unknown executor {executor!r}; choose one of {list(EXECUTORS)}")
    if format not in FORMATS:
        raise SweepError(f"unknown format {format!r}; choose one of {list(FORMATS)}")
    nw = int(workers) if workers is not None else (os.cpu_count() or 1)
    if nw < 1:
        raise SweepError(f"workers must be ≥ 1, got {workers!r}")
    if executor == "dask":
        _need("dask.distributed", "dask", "dask")  # fail before anything is written
    if executor == "ray":
        _need("ray", "ray", "ray")
    norm = [normalize_job(j) for j in jobs]
    shash = sweep_hash(norm)
    done: dict[int, dict[str, Any]] = {}
    writer: RecordWriter | None = None
    if out is not None:
        meta = read_meta(out)
        if meta is not None and resume and meta.get("sweep_hash") != shash:
            raise SweepError(
                f"{out} holds records of another sweep (hash {meta.get('sweep_hash')}, this one {shash}); "
                "choose another output directory or pass resume=False (--overwrite) to replace them"
            )
        if meta is not None and meta.get("format") not in (None, format) and resume:
            raise SweepError(f"{out} holds {meta.get('format')} records; resume with format={meta.get('format')!r}")
        if not resume:
            clear(out)
        else:
            done = {r["job"]: r for r in read_records(out) if r.get("exception_type") != WORKER_DIED}
        writer = RecordWriter(
            out, format, meta={"sweep_hash": shash, "n_jobs": len(norm), "format": format, "executor": executor}
        )
    todo: list[Item] = [(i, j) for i, j in enumerate(norm) if i not in done]
    records = dict(done)
    bar = None
    if progress:
        from tqdm.auto import tqdm

        bar = tqdm(total=len(norm), initial=len(done), desc=desc, unit="job", file=sys.stderr, dynamic_ncols=True)
    try:
        if todo:
            for recs in _RUNNERS[executor](_chunks(todo, nw, chunksize), nw, address, warmup):
                for r in recs:
                    records[r["job"]] = r
                    if writer is not None:
                        writer.write(r)
                if bar is not None:
                    bar.update(len(recs))
    finally:
        if writer is not None:
            writer.close()
        if bar is not None:
            bar.close()
    return [records[i] for i in sorted(records)]
