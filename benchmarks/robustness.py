"""Robustness of the reaching controllers over every system, primitive and displacement size.

For every registered system × every primitive kind × 3 displacement levels × N random
targets, a target is built with :func:`coop_ga.control.displaced_target` from the
system's ``q0`` (translation of the level's size in a random direction, rotation by the
level's angle about a random axis, scale ``1 ± level`` with a random sign):

    level    translation  rotation  scale
    small    2 cm         5°        ±5 %
    medium   5 cm         15°       ±15 %
    large    15 cm        35°       ±30 %

**Certification.**  A displaced target is reachable by construction *without* limits,
not necessarily inside them.  Each target is therefore certified by an independent solve
(``scipy.optimize.least_squares``, method ``"trf"``, bounds = the position limits, from
q0, Jacobian ``task.error_jacobian``; none of coop_ga's solvers): it is certified iff that
solve ends at ‖e‖ < 1e-6 inside (or on) the limits.  Uncertified targets are counted and
reported separately and never enter a rate.  The certificate is local (one start, q0): a
target reachable only far from q0 counts as uncertified, which is the conservative side.

**Jobs** on each certified target, every solver with its *defaults*:

* ``ilqr``: :func:`~coop_ga.control.ilqr_reach` from rest;
* ``ilqr_moving``: the same with an initial joint velocity ~ U(±0.2 rad/s) per joint;
* ``gn``: :func:`~coop_ga.control.gauss_newton_ik`;
* ``diffik``: :func:`~coop_ga.control.diff_ik_reach` (also: first time ‖e‖ < 1e-4, and
  whether that is within 2.5 s, the iLQR horizon).

Per job: converged, final error, iterations, wall time around the call, largest
position-limit violation over the returned trajectory (or configuration), largest |q̇|
(iLQR ``qd``; diff IK finite differences of ``trajectory``), velocity-limit excess.  Any
exception a solver raises is recorded (type, message) as a failed job; the benchmark goes on.
Wall times exclude the one-off build/compile of each task: every task is warmed up with
one call of each solver on a fixed target before its first timed job (per process).

Output: a table (rows solver × level), PASS/MISS lines for its targets, and
``<out>/robustness.json`` (config, per-target records, aggregates, versions, machine).

Reproducible under ``--seed``: target (system, kind, level, i) draws from its own stream
``SeedSequence(seed, spawn_key=(crc32(system), crc32(kind), crc32(level), i))`` — the key
:meth:`numpy.random.SeedSequence.spawn` would build, but from names instead of positions,
so a target does not depend on the order or the selection of systems/kinds/levels.
``--workers W`` gives the same records as a serial run (up to the timings).

Run: ``python benchmarks/robustness.py`` (full study), ``--ci`` (small, < 1 min).  The same jobs as a sweep
(the levels, draws and certificate are :mod:`coop_ga.sweep.targets`, shared):
``python -m coop_ga.sweep robustness --executor process --workers 2`` (records streamed, resumable; Dask/Ray).
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import platform
import subprocess
import sys
import time
import warnings
from collections.abc import Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _timing import print_table

import coop_ga as cg
from coop_ga.harness import experiment_parser, positive_int, progress, write_json
from coop_ga.sweep.targets import (
    CERT_TOL,
    LEVELS,
    QD_INIT_MAX,
    Displacement,
    Level,
    certify,
    draw_displacement,
    name_spawn_key,
)

# ============================================================================ constants

SCHEMA_VERSION = 1


def _short(entry: Any) -> str:
    """A solver's job name: its shortest alias (``gn``, ``diffik``, ``ilqr``, ``impedance``)."""
    return min((entry.name, *entry.aliases), key=len)


def job_solver(job: str) -> tuple[Any, bool]:
    """``(registry entry, moving start)`` of a job name: a registered solver's name or alias
    (:data:`coop_ga.control.SOLVERS`), or ``<that>_moving`` for a solver that starts from a joint velocity."""
    from coop_ga.control import get_solver

    moving = job.endswith("_moving")
    entry = get_solver(job.removesuffix("_moving") if moving else job)
    if moving and not entry.initial_velocity:
        raise ValueError(f"job {job!r}: solver {entry.name} takes no initial velocity")
    return entry, moving


def job_names() -> tuple[str, ...]:
    """Every job the registry offers: each 'reach' solver that needs no other problem data, from rest and
    (if it takes one) from a moving start."""
    from coop_ga.control import SOLVERS

    out: list[str] = []
    for e in SOLVERS.values():
        if e.signature == "reach" and not e.required:
            out += [_short(e), *([f"{_short(e)}_moving"] if e.initial_velocity else [])]
    return tuple(out)


#: the jobs run by default (a selection of :func:`job_names`: the impedance simulation is left out, its
#: time per target is that of a rigid-body simulation)
SOLVERS: tuple[str, ...] = ("ilqr", "ilqr_moving", "gn", "diffik")
ILQR_SOLVERS = tuple(j for j in job_names() if job_solver(j)[0].name == "ilqr_reach")

VIOLATION_TOL = 1e-6  # [rad or m] a run is "outside the limits" above this
DIFFIK_TOL = 1e-4  # diff IK: time to reach this error ...
DIFFIK_HORIZON_S = 2.5  # ... is compared with the iLQR horizon
FEW_ITERATIONS = 5  # "converged within 5 iterations" (iLQR)
MESSAGE_CHARS = 300  # messages are truncated in the JSON

DEFAULT_TARGETS = 20  # per (system, kind, level): 2700 candidates, ≈ 2030 certified (≈ 75 % certify)
DEFAULT_SEED = 0
DEFAULT_OUT = Path("results/robustness")

# The CI mode: cheap tasks (small graphs, fast to build), one target each, one level.
CI_SYSTEMS = ("three_franka", "allegro")
CI_KINDS = ("point", "circle", "sphere")
CI_LEVELS = ("small",)
CI_TARGETS = 1

# Fixed, seed-independent displacement used to warm up a task before its first timed job.
_WARMUP: dict[str, Any] = {
    "translation": (0.01, -0.005, 0.004),
    "axis": (0.3, 0.5, 0.8),
    "angle": math.radians(3.0),
    "scale": 1.02,
}

# Fields of a job record that are timings (they are all that may differ between runs).
TIME_FIELDS = ("time_s", "solver_time_s")


# ============================================================================ seeds and draws
# The levels, draws and the certificate live in coop_ga.sweep.targets (shared with the sweep's ready spec
# "robustness", which reproduces this study's jobs); the names of this module are kept.
def spawn_key(system: str, kind: str, level: str, index: int) -> tuple[int, ...]:
    """The ``SeedSequence`` spawn key of one target (module docstring)."""
    return name_spawn_key((system, kind, level, int(index)))


def target_rng(seed: int, system: str, kind: str, level: str, index: int) -> np.random.Generator:
    """The random stream of target ``index`` of (system, kind, level) under ``seed``."""
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=spawn_key(system, kind, level, index)))


Draw = Displacement


def draw_target(rng: np.random.Generator, level: Level, nq: int) -> Draw:
    """Draw a displacement of size ``level`` and an initial velocity U(±QD_INIT_MAX)^nq
    (:func:`coop_ga.sweep.targets.draw_displacement`: direction, axis, scale sign, velocity, in that order)."""
    return draw_displacement(rng, level, nq, QD_INIT_MAX)


# ============================================================================ per-process context
@dataclass
class _Context:
    tasks: dict[tuple[str, str], Any]
    warm: dict[tuple[str, str], dict[str, Any]]


_CTX = _Context(tasks={}, warm={})


def _task(system: str, kind: str) -> Any:
    """The (cached) task of (system, kind) in this process."""
    key = (system, kind)
    t = _CTX.tasks.get(key)
    if t is None:
        t = _CTX.tasks[key] = cg.cooperative_task(cg.systems.load(system), kind)
    return t


def _init_worker(cases: Sequence[tuple[str, str]]) -> None:
    """Pool initializer: load the systems and build the tasks once per worker process."""
    warnings.simplefilter("ignore")  # counts are in every result's ``warnings``; no console noise
    for system, kind in cases:
        with contextlib.suppress(Exception):  # the planner already skipped what fails; a job would re-raise
            _task(system, kind)


# ============================================================================ solvers
def _call_solver(name: str, task: Any, q0: np.ndarray, target: Any, qd_init: np.ndarray | None) -> Any:
    """Run job ``name`` (:func:`job_solver`) with the solver's defaults (the point of the benchmark)."""
    entry, moving = job_solver(name)
    return entry.solve(task, q0, target, **({"qd_init": qd_init} if moving else {}))


def _finite(x: Any) -> float | None:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def _diffik_dt(res: Any) -> float:
    dt = getattr(res, "dt", None)
    if dt is None:
        from coop_ga.control import DiffIKOptions

        dt = DiffIKOptions().dt
    return float(dt)


def _job_record(name: str, task: Any, target: Any, res: Any, wall: float) -> dict[str, Any]:
    """Metrics of one solver result, read through the public result fields only.

    The controllers are being rewritten: every field beyond SolverResult is optional here.
    """
    lim = task.system.limits
    traj = getattr(res, "trajectory", None)
    traj = None if traj is None else np.asarray(traj, dtype=float)
    qf = np.asarray(res.q, dtype=float)
    qs = qf[None, :] if traj is None else np.vstack([traj, qf[None, :]])
    viol = lim.position_violation(qs)
    qd = getattr(res, "qd", None)
    speed = vel_excess = final_speed = None
    dt = None
    if qd is not None:
        qd = np.asarray(qd, dtype=float)
    elif traj is not None and len(traj) > 1:
        # velocities implied by the returned trajectory (diff IK: q_{t+1} = q_t + Δt q̇)
        dt = _diffik_dt(res) if name == "diffik" else getattr(res, "dt", None)
        if dt is not None:
            qd = np.diff(traj, axis=0) / float(dt)
    if qd is not None and qd.size:
        speed = float(np.max(np.abs(qd)))
        vel_excess = lim.velocity_violation(qd)
        final_speed = float(np.max(np.abs(qd[-1])))  # arrival at rest (iLQR); last step (diff IK)
    rec: dict[str, Any] = {
        "solver": name,
        "exception": None,
        "converged": bool(res.converged),
        "error": _finite(res.error),
        "iterations": int(res.iterations),
        "time_s": wall,
        "solver_time_s": _finite(getattr(res, "solve_time_s", None)),
        "violation": _finite(viol),
        "max_speed": None if speed is None else _finite(speed),
        "velocity_violation": None if vel_excess is None else _finite(vel_excess),
        "final_speed": None if final_speed is None else _finite(final_speed),
        "message": str(getattr(res, "message", ""))[:MESSAGE_CHARS],
        "warnings": {str(k): int(v) for k, v in dict(getattr(res, "warnings", {}) or {}).items()},
    }
    if name == "diffik":
        errs = getattr(res, "errors", None)
        if errs is None and traj is not None:  # older/newer results without ``errors``: evaluate e along q_t
            errs = [float(np.linalg.norm(task.error(q, target))) for q in traj]
        t_reach = None
        if errs is not None:
            below = np.flatnonzero(np.asarray(errs, dtype=float) < DIFFIK_TOL)
            if below.size:
                t_reach = float(below[0]) * _diffik_dt(res)
        rec["t_reach_1e-4_s"] = t_reach
        rec["reached_1e-4_in_2.5s"] = bool(t_reach is not None and t_reach <= DIFFIK_HORIZON_S + 1e-12)
    # numbers that must be finite: anything else is recorded as an error of the job
    bad = [k for k in ("error", "violation") if rec[k] is None]
    bad += [k for k in ("max_speed", "velocity_violation") if rec[k] is None and qd is not None]
    if bad:
        rec["exception"] = {"type": "NonFiniteResult", "message": f"non-finite result field(s) {bad}"}
        rec["solver_converged"], rec["converged"] = rec["converged"], False  # a non-finite result is a failure
    return rec


def _exception_record(name: str, exc: BaseException, wall: float) -> dict[str, Any]:
    rec: dict[str, Any] = {
        "solver": name,
        "exception": {"type": type(exc).__name__, "message": str(exc)[:MESSAGE_CHARS]},
        "converged": False,
        "error": None,
        "iterations": None,
        "time_s": wall,
        "solver_time_s": None,
        "violation": None,
        "max_speed": None,
        "velocity_violation": None,
        "final_speed": None,
        "message": None,
        "warnings": {},
    }
    if name == "diffik":
        rec["t_reach_1e-4_s"] = None
        rec["reached_1e-4_in_2.5s"] = False
    return rec


def run_job(name: str, task: Any, q0: np.ndarray, target: Any, qd_init: np.ndarray | None = None) -> dict[str, Any]:
    """One timed solver call → its record; any exception is recorded, never raised."""
    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = _call_solver(name, task, q0, target, qd_init)
    except Exception as exc:  # a failing solver is data
        return _exception_record(name, exc, time.perf_counter() - t0)
    wall = time.perf_counter() - t0
    try:
        return _job_record(name, task, target, res, wall)
    except Exception as exc:  # a result without the public fields: recorded, labelled as such
        rec = _exception_record(name, exc, wall)
        rec["exception"]["type"] = f"ResultError({type(exc).__name__})"
        return rec


def _warm_up(system: str, kind: str, solvers: Sequence[str]) -> dict[str, Any]:
    """Build/compile everything a task's solvers need before the first timed call (once per process)."""
    key = (system, kind)
    if key in _CTX.warm:
        return _CTX.warm[key]
    task = _task(system, kind)
    q0 = np.asarray(task.system.q0, dtype=float)
    info: dict[str, Any] = {}
    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            tgt = cg.control.displaced_target(task, q0, **_WARMUP)
            for s in solvers:
                rec = run_job(s, task, q0, tgt, np.zeros(task.nq))
                if rec["exception"]:
                    info[s] = rec["exception"]
    except Exception as exc:
        info["target"] = {"type": type(exc).__name__, "message": str(exc)[:MESSAGE_CHARS]}
    info["time_s"] = time.perf_counter() - t0
    _CTX.warm[key] = info
    return info


# ============================================================================ certification
# certify(task, q_init, target): coop_ga.sweep.targets.certify (imported above; the same solve and record)


# ============================================================================ one target, one case
@dataclass(frozen=True)
class TargetSpec:
    """What identifies one target (picklable; everything else is derived from it)."""

    system: str
    kind: str
    level: str
    index: int
    seed: int
    solvers: tuple[str, ...]


def run_target(spec: TargetSpec) -> dict[str, Any]:
    """Draw, certify and (if certified) solve one target → its record."""
    task = _task(spec.system, spec.kind)
    _warm_up(spec.system, spec.kind, spec.solvers)
    q0 = np.asarray(task.system.q0, dtype=float)
    d = draw_target(target_rng(spec.seed, spec.system, spec.kind, spec.level, spec.index), LEVELS[spec.level], task.nq)
    rec: dict[str, Any] = {
        "system": spec.system,
        "kind": spec.kind,
        "level": spec.level,
        "index": spec.index,
        "nq": int(task.nq),
        "spawn_key": list(spawn_key(spec.system, spec.kind, spec.level, spec.index)),
        "displacement": {
            "translation_m": list(d.translation),
            "axis": list(d.axis),
            "angle_rad": d.angle,
            "scale": d.scale,
        },
        "qd_init": list(d.qd_init),
        "certification": None,
        "jobs": {},
    }
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            target = cg.control.displaced_target(
                task, q0, translation=d.translation, axis=d.axis, angle=d.angle, scale=d.scale
            )
    except Exception as exc:
        rec["certification"] = {
            "certified": False,
            "error": None,
            "violation": None,
            "nfev": None,
            "status": None,
            "reason": f"target construction failed: {type(exc).__name__}: {exc}"[:MESSAGE_CHARS],
            "time_s": 0.0,
        }
        return rec
    rec["certification"] = certify(task, q0, target)
    if not rec["certification"]["certified"]:
        return rec
    qd = np.asarray(d.qd_init, dtype=float)
    for s in spec.solvers:
        rec["jobs"][s] = run_job(s, task, q0, target, qd)
    return rec


def _setup_record(system: str, kind: str) -> dict[str, Any]:
    return {"system": system, "kind": kind, "pid": os.getpid(), "warmup": _CTX.warm.get((system, kind))}


def run_case(specs: Sequence[TargetSpec]) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """All targets of one (system, kind): the unit of work of a pool worker (one warm-up per task).

    Returns the target records and the case's setup record (warm-up time and failures, pid).
    """
    warnings.simplefilter("ignore")  # counts are in every result's ``warnings``; no console noise
    recs = [run_target(s) for s in specs]
    return recs, (_setup_record(specs[0].system, specs[0].kind) if specs else {})


# ============================================================================ planning
@dataclass(frozen=True)
class Config:
    """Everything a run depends on (written to the JSON)."""

    systems: tuple[str, ...]
    kinds: tuple[str, ...]
    levels: tuple[str, ...]
    solvers: tuple[str, ...]
    targets: int
    seed: int
    workers: int
    ci: bool


def plan(config: Config) -> tuple[list[tuple[str, str]], list[dict[str, str]]]:
    """Runnable (system, kind) cases and the skipped ones with their reasons.

    Skipped: too few end points for the kind, task construction failing, or the primitive
    degenerate (or otherwise failing) at q0 (e.g. hexapod's sphere of 4 coplanar feet).
    """
    cases: list[tuple[str, str]] = []
    skipped: list[dict[str, str]] = []
    for system in config.systems:
        sysobj = cg.systems.load(system)
        for kind in config.kinds:
            need = cg.geometry.N_POINTS[kind]
            if len(sysobj.end_frames) < need:
                skipped.append(
                    {
                        "system": system,
                        "kind": kind,
                        "reason": f"needs {need} end points, the system has {len(sysobj.end_frames)}",
                    }
                )
                continue
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    task = _task(system, kind)
                    q0 = np.asarray(sysobj.q0, dtype=float)
                    task.error(q0, cg.control.displaced_target(task, q0))
            except cg.DegeneratePrimitiveError as exc:
                skipped.append(
                    {
                        "system": system,
                        "kind": kind,
                        "reason": f"degenerate primitive at q0: {str(exc)[:MESSAGE_CHARS]}",
                    }
                )
                continue
            except Exception as exc:
                skipped.append(
                    {
                        "system": system,
                        "kind": kind,
                        "reason": f"{type(exc).__name__} at q0: {str(exc)[:MESSAGE_CHARS]}",
                    }
                )
                continue
            cases.append((system, kind))
    return cases, skipped


def _specs(config: Config, system: str, kind: str) -> list[TargetSpec]:
    return [
        TargetSpec(system, kind, lv, i, config.seed, config.solvers)
        for lv in config.levels
        for i in range(config.targets)
    ]


def run_all(
    config: Config, cases: Sequence[tuple[str, str]], quiet: bool = False
) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """Every target of every case, serially or in ``config.workers`` spawned processes.

    Returns (target records, per-case setup records), in the canonical order (case, level,
    index) whatever the scheduling.
    """
    by_case: dict[tuple[str, str], tuple[list[dict[str, Any]], dict[str, Any]]] = {}
    if config.workers <= 1:
        specs = [sp for case in cases for sp in _specs(config, *case)]
        recs: dict[tuple[str, str], list[dict[str, Any]]] = {case: [] for case in cases}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # counts are in every result's ``warnings``
            for sp in progress(specs, "targets", quiet=quiet):
                recs[(sp.system, sp.kind)].append(run_target(sp))
        by_case = {case: (recs[case], _setup_record(*case)) for case in cases}
    else:
        import multiprocessing as mp

        with ProcessPoolExecutor(
            max_workers=config.workers,
            mp_context=mp.get_context("spawn"),
            initializer=_init_worker,
            initargs=(list(cases),),
        ) as pool:
            # largest systems first (slowest cases): fewer stragglers at the end
            order = sorted(cases, key=lambda c: -_task(*c).nq)
            futs = {pool.submit(run_case, _specs(config, *case)): case for case in order}
            for fut in progress(as_completed(futs), f"cases ({config.workers} workers)", total=len(futs), quiet=quiet):
                case = futs[fut]
                try:
                    by_case[case] = fut.result()
                except Exception as exc:  # a crashed worker (jobs' own exceptions never get here): the case is lost
                    by_case[case] = (
                        [],
                        {
                            "system": case[0],
                            "kind": case[1],
                            "pid": None,
                            "warmup": None,
                            "error": f"{type(exc).__name__}: {str(exc)[:MESSAGE_CHARS]}",
                        },
                    )
    return [r for case in cases for r in by_case[case][0]], [by_case[case][1] for case in cases]


# ============================================================================ aggregates
def _median(xs: Sequence[float]) -> float | None:
    return float(np.median(xs)) if len(xs) else None


def _max(xs: Sequence[float]) -> float | None:
    return float(np.max(xs)) if len(xs) else None


def summarize(jobs: Sequence[dict[str, Any]], solver: str) -> dict[str, Any]:
    """Aggregates of job records of one solver (any grouping).

    Iterations and times are over the runs without exception (converged or not); rates
    are over all runs on certified targets (an exception is a failed run).
    """
    n = len(jobs)
    ok = [j for j in jobs if j["exception"] is None]
    conv = [j for j in ok if j["converged"]]
    its = [j["iterations"] for j in ok]
    times = [j["time_s"] for j in ok]
    viols = [j["violation"] for j in ok]
    speeds = [j["max_speed"] for j in ok if j["max_speed"] is not None]
    out: dict[str, Any] = {
        "runs": n,
        "exceptions": n - len(ok),
        "exception_types": _count(j["exception"]["type"] for j in jobs if j["exception"] is not None),
        "converged": len(conv),
        "convergence_rate": len(conv) / n if n else None,
        "iterations_median": _median(its),
        "iterations_max": None if not its else int(max(its)),
        "time_median_s": _median(times),
        "time_max_s": _max(times),
        "max_violation": _max(viols),
        "outside_limits": sum(v > VIOLATION_TOL for v in viols),
        "converged_outside_limits": sum(j["violation"] > VIOLATION_TOL for j in conv),
        "max_speed": _max(speeds),
        "max_velocity_violation": _max([j["velocity_violation"] for j in ok if j["velocity_violation"] is not None]),
        "within_5_iterations_rate": None,
        "diffik_1e-4_in_2.5s_rate": None,
    }
    if solver in ILQR_SOLVERS and n:
        out["within_5_iterations_rate"] = sum(j["iterations"] <= FEW_ITERATIONS for j in conv) / n
    if solver == "diffik" and n:
        out["diffik_1e-4_in_2.5s_rate"] = sum(bool(j.get("reached_1e-4_in_2.5s")) for j in jobs) / n
    return out


def _count(items: Iterable[str]) -> dict[str, int]:
    c: dict[str, int] = {}
    for x in items:
        c[x] = c.get(x, 0) + 1
    return dict(sorted(c.items()))


def _cert_summary(recs: Sequence[dict[str, Any]]) -> dict[str, Any]:
    cert = [r for r in recs if r["certification"]["certified"]]
    times = [r["certification"]["time_s"] for r in cert]
    return {
        "candidates": len(recs),
        "certified": len(cert),
        "uncertified": len(recs) - len(cert),
        "certification_time_median_s": _median(times),
    }


def aggregate(records: Sequence[dict[str, Any]], config: Config) -> dict[str, Any]:
    """Aggregates per solver × level, per solver (all levels), per system × kind × solver, and certification counts."""

    def jobs_of(recs: Iterable[dict[str, Any]], s: str) -> list[dict[str, Any]]:
        return [r["jobs"][s] for r in recs if s in r["jobs"]]

    by_level = {lv: [r for r in records if r["level"] == lv] for lv in config.levels}
    cases = list(dict.fromkeys((r["system"], r["kind"]) for r in records))
    return {
        "by_solver_level": [
            {"solver": s, "level": lv, **summarize(jobs_of(by_level[lv], s), s)}
            for s in config.solvers
            for lv in config.levels
        ],
        "by_solver": [{"solver": s, **summarize(jobs_of(records, s), s)} for s in config.solvers],
        "by_case": [
            {
                "system": sy,
                "kind": k,
                "solver": s,
                **summarize(jobs_of((r for r in records if (r["system"], r["kind"]) == (sy, k)), s), s),
            }
            for sy, k in cases
            for s in config.solvers
        ],
        "certification_by_level": [{"level": lv, **_cert_summary(by_level[lv])} for lv in config.levels],
        "certification_by_case": [
            {
                "system": sy,
                "kind": k,
                "level": lv,
                **_cert_summary([r for r in by_level[lv] if (r["system"], r["kind"]) == (sy, k)]),
            }
            for sy, k in cases
            for lv in config.levels
        ],
        "certification": _cert_summary(records),
        "nq21_ilqr_time_median_s": _median(
            [
                r["jobs"]["ilqr"]["time_s"]
                for r in records
                if r["nq"] == 21 and "ilqr" in r["jobs"] and r["jobs"]["ilqr"]["exception"] is None
            ]
        ),
    }


# ============================================================================ issue targets
def issue_targets(agg: dict[str, Any], config: Config) -> list[dict[str, Any]]:
    """The robustness targets as ``{"target", "status" (PASS/MISS/N/A), "value"}`` rows."""
    rows: list[dict[str, Any]] = []
    sl = {(a["solver"], a["level"]): a for a in agg["by_solver_level"]}
    so = {a["solver"]: a for a in agg["by_solver"]}

    def add(text: str, ok: bool | None, value: str) -> None:
        rows.append({"target": text, "status": "N/A" if ok is None else ("PASS" if ok else "MISS"), "value": value})

    def rate(a: dict[str, Any] | None, key: str = "convergence_rate") -> float | None:
        return None if a is None or not a["runs"] else a[key]

    def pct(x: float | None) -> str:
        return "n/a" if x is None else f"{100 * x:.1f} %"

    rates = {lv: rate(sl.get(("ilqr", lv))) for lv in config.levels}
    have = [r for r in rates.values() if r is not None]
    add(
        "constrained iLQR converged ≥ 99.5 % at every level",
        all(r >= 0.995 for r in have) if have else None,
        ", ".join(f"{lv} {pct(r)}" for lv, r in rates.items()),
    )
    a = so.get("ilqr")
    add(
        "0 iLQR trajectories outside limits",
        None if not a or not a["runs"] else a["outside_limits"] == 0,
        "n/a" if not a else f"{a['outside_limits']} of {a['runs']} (max {_fmt(a['max_violation'])})",
    )
    few = [x for lv in ("small", "medium") if (x := sl.get(("ilqr", lv))) is not None and x["runs"]]
    share = sum(x["within_5_iterations_rate"] * x["runs"] for x in few) / sum(x["runs"] for x in few) if few else None
    add(
        "≥ 95 % of small/medium iLQR runs converged in ≤ 5 iterations",
        None if share is None else share >= 0.95,
        pct(share),
    )
    t21 = agg["nq21_ilqr_time_median_s"]
    add(
        "median iLQR solve ≤ 100 ms for the 21-DOF systems",
        None if t21 is None else t21 <= 0.100,
        "n/a" if t21 is None else f"{1e3 * t21:.1f} ms",
    )
    a = so.get("ilqr_moving")
    add(
        "moving start ≥ 99 % converged, 0 outside",
        None if not a or not a["runs"] else (a["convergence_rate"] >= 0.99 and a["outside_limits"] == 0),
        "n/a" if not a or not a["runs"] else f"{pct(a['convergence_rate'])}, {a['outside_limits']} outside",
    )
    a = so.get("gn")
    add(
        "GN ≥ 99 %, 0 outside",
        None if not a or not a["runs"] else (a["convergence_rate"] >= 0.99 and a["outside_limits"] == 0),
        "n/a" if not a or not a["runs"] else f"{pct(a['convergence_rate'])}, {a['outside_limits']} outside",
    )
    a = so.get("diffik")
    r = rate(a, "diffik_1e-4_in_2.5s_rate")
    add("diff IK ≥ 95 % within 1e-4 in 2.5 s", None if r is None else r >= 0.95, pct(r))
    conv_out = sum(x["converged_outside_limits"] for x in so.values())
    any_runs = any(x["runs"] for x in so.values())
    add("0 runs converged=True outside the limits (any solver)", conv_out == 0 if any_runs else None, str(conv_out))
    return rows


# ============================================================================ printing
def _fmt(x: Any, spec: str = ".2g") -> str:
    if x is None:
        return "-"
    if isinstance(x, float):
        return format(x, spec)
    return str(x)


def print_report(
    agg: dict[str, Any],
    targets: list[dict[str, Any]],
    skipped: Sequence[dict[str, str]],
    config: Config,
    wall_s: float,
    setup: Sequence[dict[str, Any]] = (),
) -> None:
    """The compact table (solver × level), certification counts, skipped cases and PASS/MISS lines."""
    cert = {c["level"]: c for c in agg["certification_by_level"]}
    rows = []
    for a in agg["by_solver_level"]:
        ct = cert[a["level"]]["certification_time_median_s"]
        ratio = a["time_median_s"] / ct if a["time_median_s"] is not None and ct else None
        rows.append(
            [
                a["solver"],
                a["level"],
                str(a["runs"]),
                "-" if a["convergence_rate"] is None else f"{100 * a['convergence_rate']:.1f}",
                _fmt(a["iterations_median"], ".0f"),
                _fmt(a["iterations_max"]),
                _fmt(None if a["time_median_s"] is None else 1e3 * a["time_median_s"], ".1f"),
                _fmt(None if a["time_max_s"] is None else 1e3 * a["time_max_s"], ".0f"),
                _fmt(ratio, ".1f"),
                _fmt(a["max_violation"], ".2g"),
                str(a["outside_limits"]),
                str(a["converged_outside_limits"]),
                _fmt(a["max_speed"], ".2f"),
                "-" if a["within_5_iterations_rate"] is None else f"{100 * a['within_5_iterations_rate']:.1f}",
                "-" if a["diffik_1e-4_in_2.5s_rate"] is None else f"{100 * a['diffik_1e-4_in_2.5s_rate']:.1f}",
                str(a["exceptions"]),
            ]
        )
    print_table(
        f"robustness: {agg['certification']['certified']} certified targets "
        f"({agg['certification']['uncertified']} uncertified), seed {config.seed}, {wall_s:.0f} s",
        [
            "solver",
            "level",
            "runs",
            "conv %",
            "it med",
            "it max",
            "t med ms",
            "t max ms",
            "t/cert",
            "max viol",
            "outside",
            "conv&out",
            "max|qd|",
            "≤5 it %",
            "1e-4@2.5s %",
            "exc",
        ],
        rows,
    )
    print("  t/cert: median solve time / median time of the certifying scipy least-squares solve (same run)")
    print(
        "  certification: "
        + ", ".join(f"{c['level']} {c['certified']}/{c['candidates']}" for c in agg["certification_by_level"])
    )
    if skipped:
        print("  skipped (system, kind): " + "; ".join(f"{s['system']}/{s['kind']}" for s in skipped))
    lost = [c for c in setup if c.get("error")]
    if lost:
        print("  LOST (worker died): " + "; ".join(f"{c['system']}/{c['kind']} ({c['error']})" for c in lost))
    print("\nissue targets")
    for t in targets:
        print(f"  {t['status']:<4}  {t['target']}: {t['value']}")


# ============================================================================ provenance
def _versions() -> dict[str, str | None]:
    import importlib.metadata as md

    out: dict[str, str | None] = {"python": platform.python_version(), "coop_ga_path": os.path.dirname(cg.__file__)}
    for pkg in ("coop_ga", "numpy", "scipy", "casadi", "pin", "tqdm"):
        try:
            out[pkg] = md.version(pkg)
        except md.PackageNotFoundError:
            out[pkg] = None
    try:  # read-only: the commit the run was made from (the tree may have local edits)
        out["git_commit"] = (
            subprocess.run(
                ["git", "rev-parse", "HEAD"],
                capture_output=True,
                text=True,
                timeout=10,
                check=False,
                cwd=os.path.dirname(os.path.abspath(__file__)),
            ).stdout.strip()
            or None
        )
    except (OSError, subprocess.SubprocessError):
        out["git_commit"] = None
    return out


def _machine() -> dict[str, Any]:
    cpu = platform.processor() or None
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next((ln.split(":", 1)[1].strip() for ln in f if ln.startswith("model name")), cpu)
    except OSError:
        pass
    return {
        "platform": platform.platform(),
        "machine": platform.machine(),
        "cpu": cpu,
        "cpu_count": os.cpu_count(),
        "python_implementation": platform.python_implementation(),
    }


# ============================================================================ CLI
def build_parser() -> argparse.ArgumentParser:
    """The command-line interface (``--help``): the harness's ``--out/--seed/--quiet`` plus ours."""
    names = list(cg.systems.names())
    ap = experiment_parser("robustness", __doc__, seed=DEFAULT_SEED, out=DEFAULT_OUT, prog="robustness.py")
    ap.add_argument(
        "--targets",
        type=positive_int,
        default=DEFAULT_TARGETS,
        metavar="N",
        help="random targets per (system, kind, level), before certification",
    )
    ap.add_argument("--systems", nargs="+", choices=names, default=names, metavar="NAME", help="systems to run")
    ap.add_argument(
        "--kinds", nargs="+", choices=list(cg.KINDS), default=list(cg.KINDS), metavar="KIND", help="primitive kinds"
    )
    ap.add_argument(
        "--levels",
        nargs="+",
        choices=list(LEVELS),
        default=list(LEVELS),
        metavar="LEVEL",
        help="displacement levels: "
        + "; ".join(
            f"{k} = {v.translation_m * 100:g} cm, {v.angle_deg:g} deg, scale 1 ± {v.scale:g}" for k, v in LEVELS.items()
        ),
    )
    ap.add_argument(
        "--solvers",
        nargs="+",
        choices=list(job_names()),
        default=list(SOLVERS),
        metavar="SOLVER",
        help="registered solvers (coop_ga.control.SOLVERS) by short name, from rest, and <name>_moving from an "
        "initial joint velocity ~ U(±0.2 rad/s) for those that take one; each with its default options",
    )
    ap.add_argument(
        "--ci",
        action="store_true",
        help=f"small mode: systems {', '.join(CI_SYSTEMS)}, kinds {', '.join(CI_KINDS)}, level "
        f"{', '.join(CI_LEVELS)}, {CI_TARGETS} target per case (replaces those four options)",
    )
    ap.add_argument(
        "--workers",
        type=positive_int,
        default=1,
        metavar="W",
        help="worker processes (spawn); same records as serial except timings (which are noisier)",
    )
    return ap


def _dedup(xs: Sequence[str], order: Sequence[str]) -> tuple[str, ...]:
    sel = set(xs)
    return tuple(x for x in order if x in sel)  # canonical order: results independent of CLI order


def config_from_args(args: argparse.Namespace) -> Config:
    """The run configuration; ``--ci`` replaces systems/kinds/levels/targets."""
    systems, kinds, levels, targets = args.systems, args.kinds, args.levels, args.targets
    if args.ci:
        systems = [s for s in CI_SYSTEMS if s in cg.systems.names()]
        kinds, levels, targets = list(CI_KINDS), list(CI_LEVELS), CI_TARGETS
    return Config(
        systems=_dedup(systems, cg.systems.names()),
        kinds=_dedup(kinds, cg.KINDS),
        levels=_dedup(levels, list(LEVELS)),
        solvers=_dedup(args.solvers, SOLVERS + tuple(j for j in job_names() if j not in SOLVERS)),
        targets=targets,
        seed=args.seed,
        workers=args.workers,
        ci=bool(args.ci),
    )


def run(config: Config, *, progress: bool = True) -> dict[str, Any]:
    """Plan, run and aggregate a configuration → the JSON document (a dict).

    Document (``robustness.json``, strict JSON, ``null`` = not applicable / not available):

    * ``schema_version`` int; ``config``: the :class:`Config` fields plus the level
      definitions and thresholds; ``wall_time_s``; ``versions`` (packages, coop_ga path,
      git commit); ``machine`` (platform, cpu, cpu_count);
    * ``cases``: [{system, kind}] run; ``skipped``: [{system, kind, reason}];
      ``setup``: [{system, kind, pid, warmup: {time_s, <solver>: exception}}] (plus ``error``
      if a worker process died: that case then has no records);
    * ``records``: one per target: ``system, kind, level, index, nq, spawn_key,
      displacement {translation_m (3), axis (3), angle_rad, scale}, qd_init (nq),
      certification {certified, error, violation, nfev, status, reason, time_s}`` and
      ``jobs`` {solver: job} (empty unless certified), a job being ``solver, exception
      (null | {type, message}), converged, error, iterations, time_s (wall, around the
      call), solver_time_s (the solver's own, iLQR), violation (max position-limit excess
      over trajectory and q), max_speed (max |q̇|; null for GN), velocity_violation,
      final_speed (max |q̇| at the end), message, warnings {condition: count}`` and for
      diff IK ``t_reach_1e-4_s, reached_1e-4_in_2.5s``;
    * ``aggregates``: ``by_solver_level``, ``by_solver``, ``by_case`` (system × kind ×
      solver) lists of :func:`summarize` dicts; ``certification_by_level``,
      ``certification_by_case``, ``certification`` counts; ``nq21_ilqr_time_median_s``;
    * ``issue_targets``: [{target, status PASS/MISS/N/A, value}].
    """
    t0 = time.perf_counter()
    versions = _versions()  # at the start: the commit the run was launched from
    cases, skipped = plan(config)
    records, setup = run_all(config, cases, quiet=not progress)
    wall = time.perf_counter() - t0
    agg = aggregate(records, config)
    return {
        "schema_version": SCHEMA_VERSION,
        "config": {
            **asdict(config),
            "level_definitions": {k: asdict(v) for k, v in LEVELS.items()},
            "qd_init_max_rad_s": QD_INIT_MAX,
            "certification_tol": CERT_TOL,
            "violation_tol": VIOLATION_TOL,
            "diffik_tol": DIFFIK_TOL,
            "diffik_horizon_s": DIFFIK_HORIZON_S,
            "few_iterations": FEW_ITERATIONS,
        },
        "cases": [{"system": s, "kind": k} for s, k in cases],
        "skipped": skipped,
        "setup": setup,
        "records": records,
        "aggregates": agg,
        "issue_targets": issue_targets(agg, config),
        "wall_time_s": wall,
        "versions": versions,
        "machine": _machine(),
    }


def main(argv: list[str] | None = None) -> int:
    """CLI entry point; returns 0 (solver failures are results, not errors)."""
    args = build_parser().parse_args(argv)
    config = config_from_args(args)
    doc = run(config, progress=not args.quiet)
    # strict JSON (non-finite → null); every non-finite solver number was already recorded as a job error
    path = write_json(Path(args.out) / "robustness.json", doc, indent=1)
    if not args.quiet:
        print_report(doc["aggregates"], doc["issue_targets"], doc["skipped"], config, doc["wall_time_s"], doc["setup"])
        print(f"\nwrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
