"""Fault-tolerant scheduling of sweep jobs on worker slots: a worker that dies or a job that hangs costs one job.

The driver hands **one job at a time** to each worker slot (a spawned process, or a Ray actor) and keeps, per
busy slot, the job and the time it was sent (the slot had finished starting, so that is when the job started).
Hence it always knows which job a dead worker was running and how long a job has run:

* a **worker that dies** (``os._exit``, a signal, a segfault, the OOM killer) fails only its job: the job is
  run again on another worker process (the dead one is replaced by a new one), up to ``retries`` more times
  (default once), then recorded with ``status="failed"``, ``exception_type="WorkerDied"`` and the exit code;
  the other jobs never notice;
* a job running longer than the **timeout** (:class:`TimeoutPolicy`: a fixed number of seconds, or ``"auto"``,
  10× the median wall time of the jobs completed so far) has its worker killed and is recorded with
  ``status="timeout"``; it is not retried (it would most likely hang again).

Why not a pool library.  The rules above are the contract; the well-kept pools were run against it (two
workers, forkserver, 20 jobs of which one SIGKILLs its own process; pebble 5.2.3, loky 3.7.0, CPython 3.11):

* :class:`concurrent.futures.ProcessPoolExecutor` marks the whole pool broken when one worker dies: 17 of the 20
  jobs failed with ``BrokenProcessPool``; loky's executor (built on it) failed 18 with ``TerminatedWorkerError``.
  Neither can stop one running job (``Future.cancel`` only cancels a job that has not started).
* :class:`multiprocessing.pool.Pool` replaces the dead worker but never completes its job (``get`` waits forever,
  a known CPython limitation), and ``get(timeout)`` only stops waiting: the hung job keeps its worker.
* pebble's ``ProcessPool.schedule(fn, timeout=)`` does attribute a death to the job that ran
  (``ProcessExpired`` on that future only) and kills a timed-out job alone; but a worker that dies while *no*
  job runs breaks the pool for every job: an idle worker SIGKILLed from outside (the OOM killer's choice) made
  every later ``schedule`` raise ``RuntimeError: Unexpected error within the Pool`` (3 of 3 runs), and a worker
  dying in its initializer before the first job started failed all 10 queued jobs with ``BrokenProcessPool``
  (2 of 4 runs): ``find_expired_task`` raises "All workers expired" when it finds no running job to charge.
  Its workers also share one pipe under inter-process locks; a worker killed while holding them stalls the
  others until the lock's 60 s timeout (a known upstream bug of ``WorkerChannel.lock()``).
* Ray's task retries cannot tell when a task started, which a timeout needs; Dask's own rule is used for Dask
  (:mod:`coop_ga.sweep.executors`).

Hence this small driver: every worker has its own pipe, the parent waits on the pipes and the process sentinels
at once (:func:`multiprocessing.connection.wait`), a death between jobs or at start-up charges no job (the worker
is replaced; start-up deaths are counted, :data:`START_FAILURES`), and a dead or killed worker affects nothing but
its own job.  The same driver schedules Ray actors (:class:`RaySlots`).
"""

from __future__ import annotations

import contextlib
import math
import multiprocessing as mp
import os
import signal
import statistics
import time
from collections import deque
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from multiprocessing.connection import wait as mp_wait
from typing import Any, Protocol

from ..errors import InvalidInputError
from .worker import BLAS_ENV, base_record, serve

__all__ = [
    "AUTO_FACTOR",
    "AUTO_FLOOR_S",
    "AUTO_INITIAL_S",
    "AUTO_MIN_JOBS",
    "TIMEOUT",
    "WORKER_DIED",
    "ProcessSlots",
    "RaySlots",
    "TimeoutPolicy",
    "fault_record",
    "pinned_env",
    "schedule",
]

WORKER_DIED = "WorkerDied"
TIMEOUT = "Timeout"
AUTO_FACTOR = 10.0  # "auto": the limit is AUTO_FACTOR × the median wall time of the completed jobs ...
AUTO_MIN_JOBS = 5  # ... once this many have completed ...
AUTO_FLOOR_S = 10.0  # ... and never below this (scheduling noise, a lazy build) [s] ...
AUTO_INITIAL_S = 600.0  # ... and this until then [s]
START_FAILURES = 3  # consecutive worker start-up deaths (per worker slot) before the sweep gives up

Item = tuple[int, dict[str, Any]]


@dataclass
class TimeoutPolicy:
    """Per-job wall-time limit [s]: ``fixed`` seconds, or ``auto`` (module docstring), or none."""

    fixed: float | None = None
    auto: bool = False
    _seconds: list[float] = field(default_factory=list)

    @classmethod
    def of(cls, timeout: Any) -> TimeoutPolicy:
        """From ``run``'s ``timeout=``: None (no limit), a number of seconds > 0, or ``"auto"``."""
        if timeout is None:
            return cls()
        if isinstance(timeout, str):
            if timeout != "auto":
                raise InvalidInputError(f"timeout must be None, a number of seconds > 0 or 'auto', got {timeout!r}")
            return cls(auto=True)
        if isinstance(timeout, bool) or not isinstance(timeout, (int, float)):
            raise InvalidInputError(
                f"timeout must be None, a number of seconds > 0 or 'auto', got {type(timeout).__name__} {timeout!r}"
            )
        t = float(timeout)
        if not (math.isfinite(t) and t > 0.0):
            raise InvalidInputError(f"timeout must be a finite number of seconds > 0 (or None for no limit), got {t}")
        return cls(fixed=t)

    @property
    def active(self) -> bool:
        """Whether jobs can time out at all."""
        return self.fixed is not None or self.auto

    def limit(self) -> float | None:
        """The current limit [s] (None: no limit)."""
        if self.fixed is not None:
            return self.fixed
        if not self.auto:
            return None
        if len(self._seconds) < AUTO_MIN_JOBS:
            return AUTO_INITIAL_S
        return max(AUTO_FLOOR_S, AUTO_FACTOR * statistics.median(self._seconds))

    def observe(self, seconds: float) -> None:
        """Record the wall time [s] of a completed job (for ``auto``)."""
        if self.auto:
            self._seconds.append(float(seconds))

    def describe(self, limit: float) -> str:
        """The limit as a message fragment."""
        if self.fixed is not None:
            return f"timeout={limit:.6g} s"
        return (
            f"timeout='auto' ({limit:.3g} s = max({AUTO_FLOOR_S:g} s, {AUTO_FACTOR:g}× the median of the jobs so far))"
        )


def fault_record(item: Item, status: str, exception_type: str, message: str, seconds: float = 0.0) -> dict[str, Any]:
    """The record of a job that produced none (its worker died, or it timed out): the job's fields and the fault."""
    index, job = item
    rec = base_record(index, job)
    rec.update(status=status, converged=False, seconds=float(seconds), exception_type=exception_type, exception=message)
    return rec


def exit_description(code: int | None) -> str:
    """A process exit code in words (a negative code is the signal that killed it)."""
    if code is None:
        return "exit code unknown"
    if code < 0:
        with contextlib.suppress(ValueError):
            return f"killed by {signal.Signals(-code).name}"
        return f"killed by signal {-code}"
    return f"exit code {code}"


@contextlib.contextmanager
def pinned_env() -> Iterator[None]:
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


class Slots(Protocol):
    """A kind of worker: start one, send it a job, wait for events, kill one, close all."""

    def start(self) -> Any: ...

    def send(self, slot: Any, item: Item) -> None: ...

    def wait(self, slots: Sequence[Any], timeout: float | None) -> list[tuple[Any, str, Any]]: ...

    def kill(self, slot: Any) -> None: ...

    def close(self) -> None: ...


@dataclass(eq=False)
class _Proc:
    proc: Any
    conn: Any


def _context() -> Any:
    """The *forkserver* context, its server preloading coop_ga (started with BLAS pinned to one thread): a worker is
    a fork of it, so starting one (also a replacement) costs its initialisation, not an import of coop_ga and
    its libraries (seconds).  *spawn* where there is no forkserver."""
    if "forkserver" not in mp.get_all_start_methods():
        return mp.get_context("spawn")
    ctx = mp.get_context("forkserver")
    ctx.set_forkserver_preload(["coop_ga.sweep.worker"])
    return ctx


class ProcessSlots:
    """Worker processes, one pipe each (:func:`coop_ga.sweep.worker.serve` runs in them), forked from a server that
    has imported coop_ga (:func:`_context`); each gets this process's current environment (``os.environ``).

    ``wait`` returns ``(slot, "ready", pid)`` when a worker has started, ``(slot, "done", record)`` for a result,
    ``(slot, "died", message)`` when a worker ended (its pipe closed, or its process sentinel fired).
    """

    def __init__(self, setup: Sequence[Mapping[str, Any]], warmup: bool):
        self.setup = list(setup)
        self.warmup = bool(warmup)
        self.ctx = _context()
        self.live: set[_Proc] = set()

    def start(self) -> _Proc:
        parent, child = self.ctx.Pipe(duplex=True)
        with pinned_env():  # the server (started by the first start) and the workers' environment
            env = dict(os.environ)
            p = self.ctx.Process(
                target=serve, args=(child, self.setup, self.warmup, env), daemon=True, name="coop_ga-sweep"
            )
            p.start()
        child.close()  # the parent keeps one end: EOF on it when the worker dies
        s = _Proc(p, parent)
        self.live.add(s)
        return s

    def send(self, slot: _Proc, item: Item) -> None:
        with contextlib.suppress(OSError):  # a dead worker is reported by wait()
            slot.conn.send(item)

    def wait(self, slots: Sequence[_Proc], timeout: float | None) -> list[tuple[Any, str, Any]]:
        objs: list[Any] = [s.conn for s in slots] + [s.proc.sentinel for s in slots]
        ready = set(mp_wait(objs, timeout))
        out: list[tuple[Any, str, Any]] = []
        for s in slots:
            if s.conn in ready:
                try:
                    kind, payload = s.conn.recv()
                except (EOFError, OSError):
                    out.append((s, "died", self._death(s)))
                    continue
                out.append((s, kind, payload))
            elif s.proc.sentinel in ready:
                out.append((s, "died", self._death(s)))
        return out

    def _death(self, s: _Proc) -> str:
        s.proc.join(5.0)
        self._drop(s)
        return f"the worker process died ({exit_description(s.proc.exitcode)})"

    def _drop(self, s: _Proc) -> None:
        self.live.discard(s)
        s.conn.close()

    def kill(self, slot: _Proc) -> None:
        slot.proc.kill()
        slot.proc.join(5.0)
        self._drop(slot)

    def close(self) -> None:
        for s in list(self.live):
            with contextlib.suppress(OSError):
                s.conn.send(None)  # the worker returns from serve()
        deadline = time.monotonic() + 5.0
        for s in list(self.live):
            s.proc.join(max(0.0, deadline - time.monotonic()))
            if s.proc.is_alive():  # busy (Ctrl-C or an error downstream): no reason to wait for its job
                s.proc.kill()
                s.proc.join(5.0)
            self._drop(s)


@dataclass
class _State:
    queue: deque[Item]
    workers: int
    starting: set[Any] = field(default_factory=set)
    idle: list[Any] = field(default_factory=list)
    busy: dict[Any, tuple[Item, float]] = field(default_factory=dict)
    attempts: dict[int, int] = field(default_factory=dict)
    start_deaths: int = 0

    def wanted(self) -> int:
        """Slots to start so that min(workers, jobs left) are starting, idle or busy."""
        left = len(self.queue) + len(self.busy)
        return min(self.workers, left) - len(self.starting) - len(self.idle) - len(self.busy)


def _on_death(st: _State, slot: Any, message: str, retries: int) -> dict[str, Any] | None:
    """A slot died: a start-up death is counted; a job's death re-queues it or gives its record."""
    if slot in st.idle:  # between jobs (e.g. the OOM killer): no job to charge
        st.idle.remove(slot)
        return None
    if slot in st.starting:
        st.starting.discard(slot)
        st.start_deaths += 1
        if st.start_deaths > START_FAILURES * st.workers:
            from .store import SweepError

            raise SweepError(f"sweep workers keep dying while they start ({message}); run one job with "
                             "executor='serial' to see the error")  # fmt: skip
        return None
    item, t0 = st.busy.pop(slot)
    n = st.attempts[item[0]] = st.attempts.get(item[0], 0) + 1
    if n <= retries:
        st.queue.appendleft(item)  # on the next free worker: another process (the dead one is replaced)
        return None
    return fault_record(item, "failed", WORKER_DIED, f"{message}, on each of {n} attempts", time.monotonic() - t0)


def _timeouts(st: _State, slots: Slots, policy: TimeoutPolicy) -> list[dict[str, Any]]:
    limit = policy.limit()
    if limit is None:
        return []
    out = []
    now = time.monotonic()
    for slot, (item, t0) in list(st.busy.items()):
        if now - t0 > limit:
            del st.busy[slot]
            slots.kill(slot)
            msg = f"no record after {now - t0:.3g} s ({policy.describe(limit)}): its worker was killed"
            out.append(fault_record(item, "timeout", TIMEOUT, msg, now - t0))
    return out


def _wait_time(st: _State, policy: TimeoutPolicy) -> float | None:
    limit = policy.limit()
    if limit is None or not st.busy:
        return None
    first = min(t0 for _, t0 in st.busy.values())
    return max(0.0, first + limit - time.monotonic()) + 1e-3


def schedule(
    slots: Slots, items: Sequence[Item], workers: int, policy: TimeoutPolicy, retries: int = 1
) -> Iterator[dict[str, Any]]:
    """Run ``items`` on up to ``workers`` slots → their records as they complete (module docstring).

    Raises :class:`~coop_ga.sweep.SweepError` if the workers keep dying while they start (nothing can run).
    """
    st = _State(deque(items), max(1, int(workers)))
    try:
        while st.queue or st.busy:
            for _ in range(st.wanted()):
                st.starting.add(slots.start())
            while st.idle and st.queue:
                slot, item = st.idle.pop(), st.queue.popleft()
                slots.send(slot, item)
                st.busy[slot] = (item, time.monotonic())
            for slot, kind, payload in slots.wait([*st.starting, *st.idle, *st.busy], _wait_time(st, policy)):
                if kind == "ready":
                    st.starting.discard(slot)
                    st.idle.append(slot)
                    st.start_deaths = 0
                elif kind == "done":
                    _item, t0 = st.busy.pop(slot)
                    policy.observe(time.monotonic() - t0)
                    st.idle.append(slot)
                    yield payload
                else:
                    rec = _on_death(st, slot, str(payload), retries)
                    if rec is not None:
                        yield rec
            yield from _timeouts(st, slots, policy)
    finally:  # also on Ctrl-C or an error downstream
        slots.close()


@dataclass(eq=False)
class _Actor:
    actor: Any
    ref: Any  # the pending call: ready() while starting, run() while busy, None when idle
    kind: str


class RaySlots:
    """Ray actors (:class:`coop_ga.sweep.worker.RayWorker`, one CPU each, never restarted by Ray): the same events
    as :class:`ProcessSlots`; an actor that died (``RayActorError``) is reported as ``"died"``."""

    def __init__(self, ray: Any, setup: Sequence[Mapping[str, Any]], warmup: bool):
        from .worker import RayWorker

        self.ray = ray
        self.cls = ray.remote(num_cpus=1, max_restarts=0, max_task_retries=0)(RayWorker)
        self.setup = list(setup)
        self.warmup = bool(warmup)
        self.live: set[_Actor] = set()

    def start(self) -> _Actor:
        a = self.cls.remote(self.setup, self.warmup)
        s = _Actor(a, a.ready.remote(), "ready")
        self.live.add(s)
        return s

    def send(self, slot: _Actor, item: Item) -> None:
        slot.ref, slot.kind = slot.actor.run.remote(*item), "done"

    def wait(self, slots: Sequence[_Actor], timeout: float | None) -> list[tuple[Any, str, Any]]:
        refs = {s.ref: s for s in slots if s.ref is not None}
        if not refs:
            return []
        ready, _ = self.ray.wait(list(refs), num_returns=1, timeout=timeout)
        if ready:
            ready, _ = self.ray.wait(list(refs), num_returns=len(refs), timeout=0)
        out: list[tuple[Any, str, Any]] = []
        for ref in ready:
            s = refs[ref]
            s.ref = None
            try:
                out.append((s, s.kind, self.ray.get(ref)))
            except self.ray.exceptions.RayError as exc:  # the actor's process died (or its object is lost)
                self.live.discard(s)
                first = (str(exc).strip().splitlines() or [""])[0][:200]
                out.append((s, "died", f"the Ray worker died ({type(exc).__name__}: {first})"))
        return out

    def kill(self, slot: _Actor) -> None:
        with contextlib.suppress(Exception):
            self.ray.kill(slot.actor)
        self.live.discard(slot)

    def close(self) -> None:
        for s in list(self.live):
            self.kill(s)
