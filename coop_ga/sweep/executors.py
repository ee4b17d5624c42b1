"""Executors (serial, process pool, Dask, Ray) and :func:`run`, the entry point of a sweep.

Every executor runs :func:`coop_ga.sweep.worker.run_job` on (index, job) pairs and yields records as they
complete; :func:`run` streams them to disk, shows the progress, and returns them sorted by job index.  Records
depend only on the job (its seed included), never on the executor, the number of workers or the completion
order — up to the timing fields :data:`TIME_FIELDS`.

* ``"serial"``: this process, one job after the other.  With a ``timeout`` the jobs run one at a time in one
  spawned child process instead (a process cannot stop its own stuck C call; the child can be killed).
* ``"process"``: spawned worker processes, one job at a time each (:mod:`coop_ga.sweep.pool`); each worker
  builds every task of the sweep once and warms its controllers up (:func:`~coop_ga.sweep.worker.init_worker`),
  with BLAS/OpenMP pinned to one thread.  First-time compiles of one task by several workers at once are safe
  (:mod:`coop_ga.codegen` builds under a per-entry lock and publishes with an atomic ``os.replace``).
* ``"dask"``: :mod:`dask.distributed` — a ``LocalCluster`` of ``workers`` single-threaded worker processes, or
  the scheduler at ``address``; one task per job.  Extra: ``pip install 'coop_ga[dask]'``.
* ``"ray"``: one Ray actor per worker on a local Ray instance of ``workers`` CPUs, or the cluster at
  ``address``, scheduled like the process pool.  Extra: ``pip install 'coop_ga[ray]'``.

**Faults.**  A job that raises is a record (``status="failed"``).  A worker that *dies* while running a job
(``os._exit``, a signal, a segfault, the OOM killer) fails only that job: it is run again on a fresh worker
``retries`` times (default once), then recorded with ``exception_type="WorkerDied"``; every other job runs.  A
job running longer than ``timeout`` has its worker killed and is recorded with ``status="timeout"``.  How each
executor does it:

* process, serial with a timeout, ray: the driver gives each worker one job at a time, so it knows which job a
  dead worker ran and since when (:mod:`coop_ga.sweep.pool`); Ray's own task retries cannot tell when a task
  started, which a timeout needs, hence actors with the same rule;
* dask: Dask's own rule — the scheduler re-runs a task whose worker died until it has been on
  ``distributed.scheduler.allowed-failures`` + 1 dead workers, then fails it with ``KilledWorker`` (recorded as
  ``WorkerDied``); the local cluster is started with ``allowed-failures = retries`` and ``worker-saturation =
  1.0`` (a worker holds only the task it runs, so no queued task is charged with a death); with ``address`` the
  scheduler's own settings apply.  A timed-out task is cancelled and its worker restarted by its nanny.
"""

from __future__ import annotations

import contextlib
import os
import sys
import threading
import time
import uuid
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import InvalidInputError
from .pool import TIMEOUT, WORKER_DIED, ProcessSlots, RaySlots, TimeoutPolicy, fault_record, pinned_env, schedule
from .spec import Job, normalize_job, sweep_hash
from .store import FORMATS, RecordWriter, SweepError, clear, directory_lock, read_meta, read_records
from .worker import BLAS_ENV, FAULTS_ENV, TIME_FIELDS, dask_job, init_worker, run_job

__all__ = ["EXECUTORS", "MissingExtraError", "SweepArgumentError", "records_equal", "run", "strip_timing"]

EXECUTORS = ("serial", "process", "dask", "ray")

Item = tuple[int, dict[str, Any]]


class MissingExtraError(SweepError, ImportError):
    """An executor's optional dependency is not installed (the message names the extra)."""


class SweepArgumentError(SweepError, InvalidInputError):
    """An argument of :func:`run` is invalid (the message names it and what is expected)."""


def _need(module: str, extra: str, executor: str) -> Any:
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise MissingExtraError(
            f"executor={executor!r} needs {module.split('.')[0]} ({exc}): pip install 'coop_ga[{extra}]'"
        ) from None


@dataclass
class _Ctx:
    """What every executor gets besides the items."""

    workers: int
    address: str | None
    warmup: bool
    policy: TimeoutPolicy
    retries: int
    setup: list[dict[str, Any]]


def _setup_jobs(items: Sequence[Item]) -> list[dict[str, Any]]:
    """One job per distinct (task, controller): what a worker initialiser needs to build and warm up."""
    seen: dict[str, dict[str, Any]] = {}
    for _, j in items:
        k = repr((j["system"], j.get("free_flyer", False), j["kind"], j["points"], j["controller"]))
        seen.setdefault(k, j)
    return list(seen.values())


def _serial(items: list[Item], ctx: _Ctx) -> Iterator[dict[str, Any]]:
    if ctx.policy.active:  # this process cannot stop a stuck job; one child process can be killed
        yield from schedule(ProcessSlots(ctx.setup, ctx.warmup), items, 1, ctx.policy, ctx.retries)
        return
    init_worker((), ctx.warmup, worker=False)
    for i, j in items:
        yield run_job(i, j)


def _process(items: list[Item], ctx: _Ctx) -> Iterator[dict[str, Any]]:
    yield from schedule(ProcessSlots(ctx.setup, ctx.warmup), items, ctx.workers, ctx.policy, ctx.retries)


def _dask_init_plugin(dd: Any, setup: list[dict[str, Any]], warmup: bool) -> Any:
    """A worker plugin that runs :func:`init_worker` on every worker, also on one restarted after a death."""

    class SweepInit(dd.WorkerPlugin):
        def setup(self, worker: Any) -> None:
            init_worker(setup, warmup)

    return SweepInit()


def _dask_cluster(stack: contextlib.ExitStack, dd: Any, dask: Any, ctx: _Ctx) -> Any:
    """A client of the scheduler at ``address``, or of a local cluster configured for the fault rules."""
    if ctx.address:
        return stack.enter_context(dd.Client(ctx.address))
    stack.enter_context(pinned_env())
    # The nanny's default MALLOC_TRIM_THRESHOLD_=65536 makes these allocation-heavy solvers ~45 % slower
    # (measured: 300 iLQR solves 2.59 s → 3.72 s in one process); glibc's adaptive default is kept.
    env = {**dask.config.get("distributed.nanny.pre-spawn-environ"), **BLAS_ENV, "MALLOC_TRIM_THRESHOLD_": None}
    cfg = {
        "distributed.nanny.pre-spawn-environ": env,
        "distributed.scheduler.allowed-failures": ctx.retries,
        "distributed.scheduler.worker-saturation": 1.0,
    }
    stack.enter_context(dask.config.set(cfg))
    cluster = stack.enter_context(
        dd.LocalCluster(
            n_workers=ctx.workers, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=40
        )
    )
    return stack.enter_context(dd.Client(cluster))


def _dask_outcome(f: Any, item: Item, t0: float | None, ctx: _Ctx) -> dict[str, Any]:
    """The record of a finished Dask future (a lost task → ``WorkerDied``)."""
    from distributed.scheduler import KilledWorker

    try:
        rec = f.result()
    except KilledWorker as exc:
        return fault_record(
            item, "failed", WORKER_DIED, f"a worker died on each attempt (Dask KilledWorker: {exc})"[:300]
        )
    except Exception as exc:
        return fault_record(item, "failed", type(exc).__name__, str(exc)[:300])
    if t0 is not None:
        ctx.policy.observe(time.monotonic() - t0)
    return dict(rec)


def _dask(items: list[Item], ctx: _Ctx) -> Iterator[dict[str, Any]]:
    dd = _need("dask.distributed", "dask", "dask")
    dask = _need("dask", "dask", "dask")
    with contextlib.ExitStack() as stack:
        client = _dask_cluster(stack, dd, dask, ctx)
        plugin = f"coop_ga-sweep-init-{uuid.uuid4().hex[:8]}"
        client.register_plugin(_dask_init_plugin(dd, ctx.setup, ctx.warmup), name=plugin)
        stack.callback(_quiet, client.unregister_worker_plugin, plugin)
        yield from _dask_loop(dd, client, items, ctx)


def _quiet(fn: Any, *args: Any) -> None:
    with contextlib.suppress(Exception):
        fn(*args)


def _dask_loop(dd: Any, client: Any, items: list[Item], ctx: _Ctx) -> Iterator[dict[str, Any]]:
    """Submit one task per job; records as they finish; a task running longer than the limit is cancelled and its
    worker restarted.  A task's start is the event it logs when it starts (the scheduler cannot tell)."""
    topic = f"coop_ga-sweep-{uuid.uuid4().hex[:12]}"
    started: dict[int, tuple[float, str]] = {}
    lock = threading.Lock()

    def on_start(event: tuple[float, Mapping[str, Any]]) -> None:
        with lock:
            started[int(event[1]["job"])] = (time.monotonic(), str(event[1]["worker"]))

    client.subscribe_topic(topic, on_start)
    futs = {client.submit(dask_job, i, j, topic, key=f"{topic}-{i}"): (i, j) for i, j in items}
    pending = set(futs)
    try:
        while pending:
            running = {futs[f][0] for f in pending}
            done = _dask_wait(dd, pending, _dask_wait_time(started, running, lock, ctx.policy))
            for f in done:
                pending.discard(f)
                item = futs.pop(f)
                with lock:
                    t0 = started.pop(item[0], (None, ""))[0]
                rec = _dask_outcome(f, item, t0, ctx)
                f.release()  # else Dask recomputes it when the worker holding the result dies
                yield rec
            yield from _dask_timeouts(client, futs, pending, started, lock, ctx.policy)
    finally:
        _quiet(client.unsubscribe_topic, topic)
        _quiet(client.cancel, list(pending))


def _dask_wait(dd: Any, pending: set[Any], timeout: float | None) -> set[Any]:
    try:
        return set(dd.wait(list(pending), timeout=timeout, return_when="FIRST_COMPLETED").done)
    except (TimeoutError, dd.TimeoutError):
        return set()


def _dask_wait_time(
    started: dict[int, tuple[float, str]], running: set[int], lock: threading.Lock, policy: TimeoutPolicy
) -> float | None:
    limit = policy.limit()
    if limit is None:
        return None
    with lock:
        first = min((t for i, (t, _) in started.items() if i in running), default=None)
    # a task may start at any moment: look again within a second (events arrive in the client's thread)
    return 1.0 if first is None else min(1.0, max(0.0, first + limit - time.monotonic()) + 1e-3)


def _dask_timeouts(
    client: Any,
    futs: dict[Any, Item],
    pending: set[Any],
    started: dict[int, tuple[float, str]],
    lock: threading.Lock,
    policy: TimeoutPolicy,
) -> Iterator[dict[str, Any]]:
    limit = policy.limit()
    if limit is None:
        return
    now = time.monotonic()
    by_index = {futs[f][0]: f for f in pending}
    with lock:
        late = [(i, t0, w) for i, (t0, w) in started.items() if now - t0 > limit and i in by_index]
        for i, _, _ in late:
            del started[i]
    for i, t0, worker in late:
        f = by_index[i]
        f.cancel()  # released first: the restart below is then no death of this task
        pending.discard(f)
        item = futs.pop(f)
        # the nanny kills and restarts it; in the background, so that the other jobs' records keep coming
        threading.Thread(target=_quiet, args=(client.restart_workers, [worker]), daemon=True).start()
        msg = f"no record after {now - t0:.3g} s ({policy.describe(limit)}): its Dask worker was restarted"
        yield fault_record(item, "timeout", TIMEOUT, msg, now - t0)


def _ray(items: list[Item], ctx: _Ctx) -> Iterator[dict[str, Any]]:
    ray = _need("ray", "ray", "ray")
    started = False
    if not ray.is_initialized():
        kw: dict[str, Any] = {"address": ctx.address} if ctx.address else {"num_cpus": ctx.workers}
        env = dict(BLAS_ENV)
        if os.environ.get(FAULTS_ENV):
            env[FAULTS_ENV] = os.environ[FAULTS_ENV]
        ray.init(**kw, include_dashboard=False, log_to_driver=False, configure_logging=False,
                 runtime_env={"env_vars": env})  # fmt: skip
        started = True
    try:
        yield from schedule(RaySlots(ray, ctx.setup, ctx.warmup), items, ctx.workers, ctx.policy, ctx.retries)
    finally:
        if started:
            ray.shutdown()


_RUNNERS = {"serial": _serial, "process": _process, "dask": _dask, "ray": _ray}


def strip_timing(rec: Mapping[str, Any]) -> dict[str, Any]:
    """A record without its timing fields (:data:`TIME_FIELDS`): what must agree between runs.

    Raises:
        InvalidInputError: ``rec`` is not a mapping.
    """
    if not isinstance(rec, Mapping):
        raise InvalidInputError(f"a record is a dict, got {type(rec).__name__}")
    return {k: v for k, v in rec.items() if k not in TIME_FIELDS}


def records_equal(a: Sequence[Mapping[str, Any]], b: Sequence[Mapping[str, Any]]) -> bool:
    """Whether two sweeps' records agree exactly, timing fields excepted.

    Raises:
        InvalidInputError: ``a`` or ``b`` is not a sequence of record dicts.
    """
    for name, x in (("a", a), ("b", b)):
        if isinstance(x, (str, bytes, Mapping)) or not isinstance(x, Sequence):
            raise InvalidInputError(f"{name} must be a list of records, got {type(x).__name__}")
    return len(a) == len(b) and all(strip_timing(x) == strip_timing(y) for x, y in zip(a, b))


def _check_args(executor: Any, workers: Any, format: Any, retries: Any, address: Any, flags: Mapping[str, Any]) -> int:
    """Validate :func:`run`'s arguments → the number of workers."""
    if not isinstance(executor, str) or executor not in EXECUTORS:
        raise SweepArgumentError(f"unknown executor {executor!r}; choose one of {list(EXECUTORS)}")
    if not isinstance(format, str) or format not in FORMATS:
        raise SweepArgumentError(f"unknown format {format!r}; choose one of {list(FORMATS)}")
    if workers is None:
        nw = os.cpu_count() or 1
    elif isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise SweepArgumentError(f"workers must be an integer ≥ 1 (or None: the CPU count), got {workers!r}")
    else:
        nw = int(workers)
    if isinstance(retries, bool) or not isinstance(retries, int) or not 0 <= retries <= 10:
        raise SweepArgumentError(
            f"retries must be an integer in 0…10 (runs of a job after its worker died), got {retries!r}"
        )
    if address is not None and (not isinstance(address, str) or not address):
        raise SweepArgumentError(f"address must be a scheduler/cluster address string or None, got {address!r}")
    for name, v in flags.items():
        if not isinstance(v, bool):
            raise SweepArgumentError(f"{name} must be True or False, got {v!r}")
    if executor == "dask":
        _need("dask.distributed", "dask", "dask")  # fail before anything is written
    if executor == "ray":
        _need("ray", "ray", "ray")
    return nw


def _normalize_all(jobs: Any) -> list[dict[str, Any]]:
    if isinstance(jobs, (str, bytes, Mapping, Job)) or not isinstance(jobs, (Sequence, Iterator)):
        raise SweepArgumentError(
            f"jobs must be a list of jobs (dicts or coop_ga.sweep.Job; wrap a single job in a list), got "
            f"{type(jobs).__name__}"
        )
    return [normalize_job(j) for j in jobs]


def _open_out(
    out: str | Path, fmt: str, resume: bool, norm: list[dict[str, Any]], executor: str
) -> tuple[dict[int, dict[str, Any]], RecordWriter]:
    """The records already in ``out`` to keep (resume) and a writer appending to it (the caller holds the lock)."""
    shash = sweep_hash(norm)
    meta = read_meta(out)
    if meta is not None and resume and meta.get("sweep_hash") != shash:
        raise SweepError(
            f"{out} holds records of another sweep (hash {meta.get('sweep_hash')}, this one {shash}); "
            "choose another output directory or pass resume=False (--overwrite) to replace them"
        )
    if meta is not None and meta.get("format") not in (None, fmt) and resume:
        raise SweepError(f"{out} holds {meta.get('format')} records; resume with format={meta.get('format')!r}")
    done: dict[int, dict[str, Any]] = {}
    if not resume:
        clear(out)
    else:
        done = {r["job"]: r for r in read_records(out) if r.get("exception_type") != WORKER_DIED}
    meta = {"sweep_hash": shash, "n_jobs": len(norm), "format": fmt, "executor": executor}
    return done, RecordWriter(out, fmt, meta=meta)


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
    timeout: float | str | None = None,
    retries: int = 1,
    warmup: bool = True,
    desc: str = "sweep",
) -> list[dict[str, Any]]:
    """Run a sweep → one record per job (a list of dicts sorted by ``job``, the job's index).

    Args:
        jobs: job specs (plain dicts or :class:`~coop_ga.sweep.Job`; :mod:`coop_ga.sweep.spec`), e.g.
            ``coop_ga.sweep.expand("robustness")``.  Structural errors raise
            :class:`~coop_ga.sweep.InvalidJobError` before anything runs; a job that fails at run time is
            recorded (``status="failed"``), never raised.
        executor: ``"serial"``, ``"process"`` (spawned worker processes), ``"dask"`` or ``"ray"`` (module
            docstring).
        workers: worker processes (default: ``os.cpu_count()``; ignored by ``"serial"``).
        out: directory to stream the records to (``records.jsonl`` or ``records/*.parquet``, plus
            ``sweep.json``); None keeps them in memory only.  The directory is locked for the sweep's duration
            (``flock`` on ``DIR/.sweep.lock``): a second sweep on it raises
            :class:`~coop_ga.sweep.SweepLockedError` naming the process that holds it.
        format: ``"jsonl"`` or ``"parquet"`` (needs pyarrow).
        resume: with ``out`` holding records of *this* sweep, skip the jobs already recorded (except those whose
            worker died) and return the stored records with the new ones; ``False`` starts afresh.  Records of
            a different sweep in ``out`` raise :class:`~coop_ga.sweep.SweepError` (choose another directory or
            ``resume=False``).
        progress: a tqdm progress bar (rate and ETA) on stderr.
        address: Dask scheduler / Ray cluster address (default: a local cluster of ``workers``).
        timeout: per-job wall-time limit: seconds (> 0), ``"auto"`` (10× the median wall time of the jobs
            completed so far, at least 10 s; 600 s until 5 have completed) or None (no limit).  A job over it
            has its worker killed and is recorded with ``status="timeout"`` (``"serial"`` then runs the jobs in
            one child process).
        retries: how many more times a job whose worker *died* is run, each on a fresh worker, before it is
            recorded with ``exception_type="WorkerDied"`` (default 1).
        warmup: build and call every (task, controller) once per process before its first timed job.
        desc: the progress bar's label.

    Returns:
        The records (:mod:`coop_ga.sweep.worker`): ``job``, ``status`` (``ok``, ``failed``, ``skipped``,
        ``timeout``), ``converged``, ``error`` (final ‖e‖), ``iterations``, ``seconds`` (wall time of the
        controller call [s]), ``exception_type``/``exception``, the controller's result fields and the limit
        measures.

    Raises:
        InvalidJobError: a malformed job.  SweepArgumentError (an InvalidInputError): a bad argument.
        SweepLockedError: ``out`` is in use by another sweep.  SweepError: ``out`` holds another sweep, or the
        workers cannot start.  MissingExtraError: the executor's extra is not installed.
    """
    nw = _check_args(
        executor, workers, format, retries, address, {"resume": resume, "progress": progress, "warmup": warmup}
    )
    if out is not None and not isinstance(out, (str, os.PathLike)):
        raise SweepArgumentError(f"out must be a directory path (str or Path) or None, got {type(out).__name__}")
    policy = TimeoutPolicy.of(timeout)
    norm = _normalize_all(jobs)
    with contextlib.ExitStack() as stack:
        done, writer = _open_records(stack, out, format, resume, norm, executor)
        todo: list[Item] = [(i, j) for i, j in enumerate(norm) if i not in done]
        records = dict(done)
        bar = _progress_bar(stack, len(norm), len(done), desc) if progress else None
        if todo:
            ctx = _Ctx(nw, address, warmup, policy, retries, _setup_jobs(todo))
            for r in _RUNNERS[executor](todo, ctx):
                records[r["job"]] = r
                if writer is not None:
                    writer.write(r)
                if bar is not None:
                    bar.update(1)
    return [records[i] for i in sorted(records)]


def _open_records(
    stack: contextlib.ExitStack,
    out: str | Path | None,
    fmt: str,
    resume: bool,
    norm: list[dict[str, Any]],
    executor: str,
) -> tuple[dict[int, dict[str, Any]], RecordWriter | None]:
    """The records already in ``out`` and its writer (locked and closed with ``stack``); none without ``out``."""
    if out is None:
        return {}, None
    stack.enter_context(directory_lock(out))
    done, writer = _open_out(out, fmt, resume, norm, executor)
    stack.callback(writer.close)
    return done, writer


def _progress_bar(stack: contextlib.ExitStack, total: int, initial: int, desc: str) -> Any:
    """A tqdm bar on stderr of ``total`` jobs, ``initial`` of them already recorded, closed with ``stack``."""
    from tqdm.auto import tqdm

    bar = tqdm(total=total, initial=initial, desc=str(desc), unit="job", file=sys.stderr, dynamic_ncols=True)
    stack.callback(bar.close)
    return bar
