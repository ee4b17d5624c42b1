"""What runs inside a worker: a job spec → a plain record.  Errors are data, never raised.

Per process, systems and compiled tasks are built once (:func:`init_worker`, the pool initialiser, or lazily on
first use) and each (task, controller) pair is warmed up once before its first timed job, so ``seconds`` never
includes a build or compile.  BLAS threads are pinned to one (:data:`BLAS_ENV`; set in a worker's environment
before numpy is imported).

**Record** (a flat dict; every float finite or ``None``):

* ``job`` (index in the sweep), ``job_hash``, ``system`` (the name), ``kind``, ``controller`` and the job's tags;
* ``status``: ``"ok"`` (the controller returned), ``"failed"`` (an exception: ``exception_type``,
  ``exception`` = its message) or ``"skipped"`` (the case cannot run — too few end points, a degenerate
  primitive at q0 — or the target was not certified; ``reason``);
* ``converged`` (False unless ``ok``), ``error`` (final ‖e‖ of the controller, the result's ``error``),
  ``iterations``, ``message``, ``seconds`` (wall time around the controller call [s]);
* every scalar field of the controller's result (``limit_violation``, ``cost``, ``solve_time_s``,
  ``saturated_steps``, …) and ``warnings`` {condition: count};
* ``violation`` (largest position-limit excess over the returned trajectory and q [rad or m]), ``max_speed``,
  ``final_speed`` (max |q̇| over the run / at its end [rad/s], from ``qd`` or the trajectory's differences),
  ``speed_violation`` (largest velocity-limit excess [rad/s]);
* ``nq``; the target: ``target_translation`` (3,) [m], ``target_axis`` (3,), ``target_angle`` [rad],
  ``target_scale``; ``certified`` and ``certify_error`` (None unless the job certifies); for diff IK
  ``t_reach_1e-4_s`` (first time ‖e‖ < 1e-4 [s]);
* for impedance ``settle_time_s`` (the time from which ‖B_e‖ < tol to the end [s]; None if it never settles);
* ``seed_entropy``, ``seed_spawn_key``.

Timing fields (:data:`TIME_FIELDS`) are the only ones that differ between two runs of one sweep.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import signal
import time
import warnings
from collections import OrderedDict
from collections.abc import Mapping, Sequence
from dataclasses import fields, is_dataclass
from typing import Any

import numpy as np

from ..geometry.groups import SimilarityLike
from .spec import CONTROLLERS, MOVING_ILQR, job_hash
from .targets import LEVELS, Level, certify, draw_displacement, seed_sequence

__all__ = ["BLAS_ENV", "FAULTS_ENV", "TIME_FIELDS", "RayWorker", "base_record", "init_worker", "run_job", "serve"]

#: environment variables that pin BLAS/OpenMP to one thread (set before numpy loads)
BLAS_ENV = {
    "OMP_NUM_THREADS": "1",
    "OPENBLAS_NUM_THREADS": "1",
    "MKL_NUM_THREADS": "1",
    "BLIS_NUM_THREADS": "1",
    "VECLIB_MAXIMUM_THREADS": "1",
    "NUMEXPR_NUM_THREADS": "1",
}
#: record fields that are wall-clock times (excluded when records of two runs are compared)
TIME_FIELDS = ("seconds", "solve_time_s", "certify_seconds", "warmup_seconds")
MESSAGE_CHARS = 300
DIFFIK_TOL = 1e-4
# fixed, seed-independent displacement that warms a (task, controller) up before its first timed job
_WARMUP: dict[str, Any] = {
    "translation": (0.01, -0.005, 0.004),
    "axis": (0.3, 0.5, 0.8),
    "angle": math.radians(3.0),
    "scale": 1.02,
}
_CERT_CACHE_SIZE = 512


class _Context:
    """Per-process caches: systems, tasks, case checks, warm-ups, certificates."""

    def __init__(self) -> None:
        self.systems: dict[str, Any] = {}
        self.tasks: dict[str, Any] = {}
        self.cases: dict[str, str | None] = {}  # task key → reason it cannot run (None: runs)
        self.warm: dict[tuple[str, str], float] = {}
        self.certs: OrderedDict[str, dict[str, Any]] = OrderedDict()
        self.warmup = True


_CTX = _Context()


def _key(x: Any) -> str:
    return json.dumps(x, sort_keys=True, separators=(",", ":"))


def _system_spec(job: Mapping[str, Any]) -> Any:
    """The job's system as :func:`_system` takes it: the name or recipe, or ``[name, "free_flyer"]``."""
    return [job["system"], "free_flyer"] if job.get("free_flyer") else job["system"]


def _system(spec: Any) -> Any:
    from .. import systems

    k = _key(spec)
    s = _CTX.systems.get(k)
    if s is None:
        if isinstance(spec, list):  # a registry name's free-flyer variant
            s = systems.load(spec[0], free_flyer=True)
        elif isinstance(spec, str):
            s = systems.load(spec)
        else:
            r = dict(spec)
            s = systems.from_urdf(
                r.pop("urdf"),
                r.pop("end_frames"),
                r.pop("locked_joints", ()),
                **r,
            )
        _CTX.systems[k] = s
    return s


def _task_key(job: Mapping[str, Any]) -> str:
    return _key([_system_spec(job), job["kind"], job.get("points")])


def _task(job: Mapping[str, Any]) -> Any:
    from ..cooperative import cooperative_task

    k = _task_key(job)
    t = _CTX.tasks.get(k)
    if t is None:
        t = _CTX.tasks[k] = cooperative_task(_system(_system_spec(job)), job["kind"], job.get("points"))
    return t


def _case_problem(job: Mapping[str, Any]) -> str | None:
    """Why the job's (system, kind, points) cannot run at all (the robustness study's plan), or None.

    Too few end points for the kind; or the primitive degenerate at q0.  Any other failure is left to the job
    (recorded as ``failed``).
    """
    from ..control import displaced_target
    from ..errors import DegeneratePrimitiveError
    from ..geometry import N_POINTS

    k = _task_key(job)
    if k in _CTX.cases:
        return _CTX.cases[k]
    reason: str | None = None
    sysobj = _system(_system_spec(job))
    need = N_POINTS.get(job["kind"])
    have = len(job["points"]) if job.get("points") is not None else len(sysobj.end_frames)
    if need is not None and have < need:
        reason = f"needs {need} end points, the system has {have}"
    else:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                task = _task(job)
                q0 = np.asarray(task.system.q0, dtype=float)
                task.error(q0, displaced_target(task, q0))
        except DegeneratePrimitiveError as exc:
            reason = f"degenerate primitive at q0: {str(exc)[:MESSAGE_CHARS]}"
        except Exception:
            reason = None  # the job itself will fail and record why
    _CTX.cases[k] = reason
    return reason


def init_worker(jobs: Sequence[Mapping[str, Any]] = (), warmup: bool = True, worker: bool = True) -> None:
    """Pool initialiser: pin BLAS threads, build every distinct task of ``jobs`` once, warm up its controllers.

    ``worker=False`` (the serial executor, in the caller's process) leaves the environment and the warning filters
    alone.  Failures are ignored here (the jobs record them).  Safe to call several times.
    """
    if worker:
        for k, v in BLAS_ENV.items():
            os.environ.setdefault(k, v)  # for subprocesses; this process's BLAS was pinned by its parent's env
        warnings.simplefilter("ignore")  # counts are in every result's ``warnings``; no console noise
    _CTX.warmup = bool(warmup)
    seen: set[tuple[str, str]] = set()
    for job in jobs:
        tk = (_task_key(job), CONTROLLERS.get(job["controller"], job["controller"]))
        if tk in seen:
            continue
        seen.add(tk)
        with contextlib.suppress(Exception):
            if _case_problem(job) is None:
                _task(job)
                if warmup:
                    _warm_up(job)


def _options(job: Mapping[str, Any]) -> dict[str, Any]:
    opts = dict(job.get("options") or {})
    if CONTROLLERS[job["controller"]] == "simulate_impedance":
        for g in ("K", "D"):
            if isinstance(opts.get(g), list):
                opts[g] = np.asarray(opts[g], dtype=float)
    return opts


def _call(job: Mapping[str, Any], task: Any, q: np.ndarray, target: SimilarityLike, qd: np.ndarray | None) -> Any:
    """Run the job's controller through the solver registry (:func:`coop_ga.control.get_solver`)."""
    from ..control import get_solver

    name = CONTROLLERS[job["controller"]]
    entry = get_solver("ilqr" if name == MOVING_ILQR else name)
    opts = _options(job)
    if entry.initial_velocity:
        opts["qd_init"] = qd
    return entry.solve(task, q, target, **opts)


def _warm_up(job: Mapping[str, Any]) -> None:
    """One untimed call of the job's controller on a fixed target (builds what it compiles lazily)."""
    from ..control import displaced_target

    name = CONTROLLERS[job["controller"]]
    k = (_task_key(job), name)
    if k in _CTX.warm or not _CTX.warmup:
        return
    t0 = time.perf_counter()
    with contextlib.suppress(Exception), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        task = _task(job)
        q0 = np.asarray(task.system.q0, dtype=float)
        tgt = displaced_target(task, q0, **_WARMUP)
        wjob = dict(job)
        if name == "simulate_impedance":  # a few steps build everything a long simulation uses
            wjob["options"] = {**(job.get("options") or {}), "duration": 0.005}
        _call(wjob, task, q0, tgt, np.zeros(task.nq))
    _CTX.warm[k] = time.perf_counter() - t0


def _finite(x: Any) -> float | None:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def _scalar(v: Any) -> Any:
    """A result field as a record value (None if it is not a finite scalar, string or a tuple of strings)."""
    if isinstance(v, (bool, np.bool_)):
        return bool(v)
    if isinstance(v, (int, np.integer)):
        return int(v)
    if isinstance(v, (float, np.floating)):
        return _finite(v)
    if isinstance(v, str):
        return v[:MESSAGE_CHARS]
    if isinstance(v, tuple) and all(isinstance(x, str) for x in v):
        return list(v)
    return _SKIP


_SKIP = object()


def _result_fields(job: Mapping[str, Any], task: Any, res: Any) -> dict[str, Any]:
    out: dict[str, Any] = {}
    if is_dataclass(res):
        for f in fields(res):
            v = _scalar(getattr(res, f.name))
            if v is not _SKIP:
                out[f.name] = v
    out["converged"] = bool(res.converged)
    out["error"] = _finite(res.error)
    out["iterations"] = int(res.iterations)
    out["message"] = str(getattr(res, "message", ""))[:MESSAGE_CHARS]
    out["warnings"] = {str(k): int(v) for k, v in dict(getattr(res, "warnings", {}) or {}).items()}
    # limit measures read from the public fields (the same as benchmarks/robustness.py)
    lim = task.system.limits
    traj = getattr(res, "trajectory", None)
    traj = None if traj is None else np.asarray(traj, dtype=float)
    qf = np.asarray(res.q, dtype=float)
    qs = qf[None, :] if traj is None else np.vstack([traj, qf[None, :]])
    system = task.system  # with a free flyer the limits bound q̇ coordinates: compare those (limit_coordinates)
    out["violation"] = _finite(lim.position_violation(system.limit_coordinates(qs)))
    qd = getattr(res, "qd", None)
    name = CONTROLLERS[job["controller"]]
    dt = getattr(res, "dt", None)
    if name == "diff_ik_reach" and dt is None:
        from ..control import DiffIKOptions

        dt = float(job["options"].get("dt", DiffIKOptions().dt))
    if qd is not None:
        qd = np.asarray(qd, dtype=float)
    elif traj is not None and len(traj) > 1 and dt is not None:
        qd = np.diff(system.tangent_trajectory(traj), axis=0) / float(dt)  # q_{t+1} = q_t ⊕ Δt q̇
    out["max_speed"] = out["final_speed"] = out["speed_violation"] = None
    if qd is not None and qd.size:
        out["max_speed"] = _finite(np.max(np.abs(qd)))
        out["final_speed"] = _finite(np.max(np.abs(qd[-1])))
        out["speed_violation"] = _finite(lim.velocity_violation(qd))
    if name == "diff_ik_reach":
        errs = getattr(res, "errors", None)
        t_reach = None
        if errs is not None and dt is not None:
            below = np.flatnonzero(np.asarray(errs, dtype=float) < DIFFIK_TOL)
            if below.size:
                t_reach = float(below[0]) * float(dt)
        out["t_reach_1e-4_s"] = t_reach
    en, tt = getattr(res, "error_norm", None), getattr(res, "t", None)
    if name == "impedance" and en is not None and tt is not None:  # settling time: ‖B_e‖ < tol from then on
        tol = float(job["options"].get("tol", 1e-3))
        above = np.flatnonzero(~(np.asarray(en, dtype=float) < tol))
        n = len(en)
        out["settle_time_s"] = (
            None if n == 0 or (above.size and above[-1] == n - 1) else float(tt[above[-1] + 1] if above.size else tt[0])
        )
    bad = [k for k in ("error", "violation") if out[k] is None]
    if bad:  # a non-finite result is a failure, recorded as such
        out["status"] = "failed"
        out["exception_type"] = "NonFiniteResult"
        out["exception"] = f"non-finite result field(s) {bad}"
        out["solver_converged"], out["converged"] = out["converged"], False
    return out


def _target(job: Mapping[str, Any], task: Any, rng: np.random.Generator, rec: dict[str, Any]) -> tuple[Any, Any]:
    """The job's target Similarity and its drawn displacement (or None)."""
    from ..control import displaced_target
    from ..geometry import Similarity

    t = job.get("target") or {}
    q0 = np.asarray(task.system.q0, dtype=float)
    draw = None
    if t.get("sampler") == "displacement":
        level = (
            LEVELS[t["level"]]
            if "level" in t
            else Level(float(t["translation"]), float(t["angle_deg"]), float(t["scale"]))
        )
        draw = draw_displacement(rng, level, task.system.nv, float(t.get("qd_max", 0.2)))  # q̇ has nv entries
        parts: dict[str, Any] = {
            "translation": draw.translation,
            "axis": draw.axis,
            "angle": draw.angle,
            "scale": draw.scale,
        }
    elif "coeffs" in t:
        rec["target_coeffs"] = [float(x) for x in t["coeffs"]]
        return Similarity.from_coeffs(np.asarray(t["coeffs"], dtype=float)), None
    else:
        parts = {k: t[k] for k in ("translation", "axis", "angle", "scale") if k in t}
    rec["target_translation"] = [float(x) for x in parts.get("translation", (0.0, 0.0, 0.0))]
    rec["target_axis"] = [float(x) for x in parts.get("axis", (1.0, 0.0, 0.0))]
    rec["target_angle"] = float(parts.get("angle", 0.0))
    rec["target_scale"] = float(parts.get("scale", 1.0))
    return displaced_target(task, q0, **parts), draw


def _start(job: Mapping[str, Any], task: Any, rng: np.random.Generator, draw: Any) -> tuple[np.ndarray, Any]:
    """Initial (q, q̇): q0 (or ``start.q``) plus U(±spread), clipped to the limits; q̇ U(±qd_max) or from the draw.
    With a free flyer (nq ≠ nv) the spread is a velocity (nv) applied by the system's integrate."""
    q = np.asarray(task.system.q0, dtype=float).copy()
    qd = None
    st = job.get("start") or {}
    if "q" in st:
        q = np.asarray(st["q"], dtype=float)
    system = task.system
    if st.get("spread") and system.nq != system.nv:
        q = system.clip(system.integrate(q, rng.uniform(-float(st["spread"]), float(st["spread"]), size=system.nv)))
    elif st.get("spread"):
        q = q + rng.uniform(-float(st["spread"]), float(st["spread"]), size=task.nq)
        lim = task.system.limits
        q = np.clip(q, np.asarray(lim.lower, dtype=float), np.asarray(lim.upper, dtype=float))
    if st.get("qd_max"):
        qd = rng.uniform(-float(st["qd_max"]), float(st["qd_max"]), size=system.nv)
    if CONTROLLERS[job["controller"]] == MOVING_ILQR and draw is not None:
        qd = np.asarray(draw.qd_init, dtype=float)
    return q, qd


def base_record(index: int, job: Mapping[str, Any]) -> dict[str, Any]:
    """The fields every record of a normalized job has, before it runs (``status="ok"``, no result yet)."""
    sys_name = job["system"] if isinstance(job["system"], str) else job["system"].get("name") or job["system"]["urdf"]
    ss = seed_sequence(job["seed"])
    rec: dict[str, Any] = {
        "job": int(index),
        "job_hash": job_hash(job),
        "system": sys_name,
        "kind": job["kind"],
        "controller": job["controller"],
    }
    if job.get("free_flyer"):
        rec["free_flyer"] = True
    rec.update(job.get("tags") or {})
    rec.update(
        {
            "status": "ok",
            "converged": False,
            "error": None,
            "iterations": None,
            "seconds": 0.0,
            "message": None,
            "exception_type": None,
            "exception": None,
            "reason": None,
            "certified": None,
            "seed_entropy": int(ss.entropy),  # type: ignore[arg-type]
            "seed_spawn_key": [int(k) for k in ss.spawn_key],
        }
    )
    return rec


def run_job(index: int, job: Mapping[str, Any]) -> dict[str, Any]:
    """Run one job → its record (module docstring).  A job that fails is a record, never an exception.

    Args:
        index: the job's index in its sweep (an integer ≥ 0; the record's ``job``).
        job: a job dict (:func:`coop_ga.sweep.normalize_job` is applied; a normalized job is unchanged by it).

    Raises:
        InvalidInputError: a bad ``index``.  InvalidJobError: a malformed job (nothing ran).
    """
    from .. import validation
    from .spec import normalize_job

    index = validation.integer(index, "index (the job's index in the sweep)", minimum=0)
    job = normalize_job(job)
    try:
        rec = base_record(index, job)
    except Exception as exc:  # pragma: no cover - normalize_job checked the structure
        return {"job": int(index), "status": "failed", "converged": False, "error": None, "iterations": None,
                "seconds": 0.0, "exception_type": type(exc).__name__, "exception": str(exc)[:MESSAGE_CHARS]}  # fmt: skip
    t0 = time.perf_counter()
    stage = "setup"
    try:
        _test_fault(job)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            reason = _case_problem(job)
            if reason is not None:
                rec.update(status="skipped", reason=reason)
                return rec
            task = _task(job)
            rec["nq"] = int(task.nq)
            _warm_up(job)
            rng = np.random.default_rng(seed_sequence(job["seed"]))
            stage = "target"
            target, draw = _target(job, task, rng, rec)
            q, qd = _start(job, task, rng, draw)
            if job.get("certify"):
                stage = "certify"
                cert = _certificate(job, task, target)
                rec["certified"] = bool(cert["certified"])
                rec["certify_error"] = cert["error"]
                rec["certify_seconds"] = cert["time_s"]
                if not cert["certified"]:
                    rec.update(status="skipped", reason=f"target not certified: {cert['reason']}")
                    return rec
            stage = "controller"
            t0 = time.perf_counter()
            res = _call(job, task, q, target, qd)
            rec["seconds"] = time.perf_counter() - t0
            stage = "result"
            rec.update(_result_fields(job, task, res))
    except Exception as exc:  # a failing job is data
        if stage in ("controller", "setup", "target", "certify"):
            rec["seconds"] = time.perf_counter() - t0 if stage == "controller" else 0.0
        rec.update(
            status="failed",
            converged=False,
            exception_type=type(exc).__name__ if stage != "result" else f"ResultError({type(exc).__name__})",
            exception=f"{stage}: {str(exc)[:MESSAGE_CHARS]}",
        )
    return rec


def _certificate(job: Mapping[str, Any], task: Any, target: SimilarityLike) -> dict[str, Any]:
    """Certify (cached per process: jobs of one target with several controllers certify it once)."""
    k = _key([_task_key(job), [float(x) for x in np.asarray(target.coeffs, dtype=float)]])
    c = _CTX.certs.get(k)
    if c is None:
        c = certify(task, np.asarray(task.system.q0, dtype=float), target)
        _CTX.certs[k] = c
        while len(_CTX.certs) > _CERT_CACHE_SIZE:
            _CTX.certs.popitem(last=False)
    else:
        _CTX.certs.move_to_end(k)
    return c


# ============================================================================ running in a worker process
#: with this variable set to 1 in a worker's environment, a job whose tags hold ``"fault"`` does not run but
#: provokes that fault (the tests of the executors' fault handling; without the variable the tag is a tag)
FAULTS_ENV = "COOP_GA_SWEEP_TEST_FAULTS"
_FAULTS = ("exit", "kill", "segfault", "hang", "raise")


def _test_fault(job: Mapping[str, Any]) -> None:
    """Test hook (:data:`FAULTS_ENV`): ``tags.fault`` in exit | kill | segfault | hang | raise; with
    ``tags.fault_once`` (a file path) only while that file does not exist (it is created first), so a retry runs."""
    tags = job.get("tags") or {}
    fault = tags.get("fault")
    if fault is None or os.environ.get(FAULTS_ENV) != "1":
        return
    once = tags.get("fault_once")
    if once is not None:
        try:
            with open(once, "x"):
                pass
        except FileExistsError:
            return
    if fault == "exit":
        os._exit(3)
    if fault == "kill":
        os.kill(os.getpid(), signal.SIGKILL)
    if fault == "segfault":
        import ctypes

        ctypes.string_at(0)  # reads address 0: SIGSEGV
    if fault == "hang":
        time.sleep(1e6)
    raise RuntimeError(f"test fault {fault!r} (one of {_FAULTS})")


def serve(conn: Any, setup: Sequence[Mapping[str, Any]], warmup: bool, env: Mapping[str, str] | None = None) -> None:
    """A process-pool worker: take the parent's environment ``env`` (a forked worker has the fork server's),
    initialise (:func:`init_worker`), say ``("ready", pid)``, then for every ``(index, job)`` received send
    ``("done", record)``; return on ``None`` or when the parent has gone.

    Ctrl-C is ignored here: the parent decides when workers stop.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if env is not None:
        os.environ.clear()
        os.environ.update(env)
    init_worker(setup, warmup)
    try:
        conn.send(("ready", os.getpid()))
        while True:
            item = conn.recv()
            if item is None:
                return
            conn.send(("done", run_job(*item)))
    except (EOFError, OSError, BrokenPipeError):  # the parent has gone
        return


class RayWorker:
    """The Ray actor of a sweep (wrapped with ``ray.remote`` by the executor): one per worker slot."""

    def __init__(self, setup: Sequence[Mapping[str, Any]], warmup: bool):
        init_worker(setup, warmup)

    def ready(self) -> int:
        """The actor's process id, once it has initialised."""
        return os.getpid()

    def run(self, index: int, job: Mapping[str, Any]) -> dict[str, Any]:
        """:func:`run_job` in the actor."""
        return run_job(index, job)


def dask_job(index: int, job: Mapping[str, Any], topic: str) -> dict[str, Any]:
    """:func:`run_job` as a Dask task that first logs ``{"job", "worker"}`` to ``topic`` (its start, for timeouts)."""
    from distributed import get_worker

    w = get_worker()
    w.log_event(topic, {"job": int(index), "worker": w.address})
    return run_job(index, job)
