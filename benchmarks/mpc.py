"""MPC rate on three_franka: solve time per tick for horizons 20, 50, 100, as ratios to anchors of the same run.

    python benchmarks/mpc.py [--horizons 20 50 100] [--ticks 40] [--ci] [--out DIR] [--quiet]

The loop (``coop_ga.control.mpc.CooperativeMPC``, its defaults but the horizon): three_franka's circle tracks the
moving target of the physics experiment (figure-eight of the centre ±10 cm, radius ±15 %, period 4 s) with a
6 cm sphere crossing the workspace (``coop_ga.sim.mpc_track.obstacle_path``, seed 0); knots of 20 ms, a tick
every 40 ms, 2 iLQR iterations per tick, warm-started.  Between ticks the state follows the plan exactly (the
double integrator, Eq 54: no physics here — the closed loop in MuJoCo is ``experiments/sim_mpc_track.py``).
The first (cold, 20-iteration) tick of every horizon is left out of the statistics.

For every horizon, with the clearance cost (``clearance``) and without it (``plain``): median / p95 / max of
the tick's wall time (everything: checks, target, the iLQR call and its set-up, RNEA), of its CPU time (what it
costs with the core to itself: the wall time on a loaded machine includes the other processes' turns) and of the
iLQR's own ``solve_time_s``, the sustained rate 1/median (wall and CPU) [Hz], the ratio of the median tick to two
anchors measured in the same run — one compiled task evaluation (``task.error_and_jacobian``, the unit of the iLQR's
line search) and one collision-model evaluation (``distances_and_jacobian``, 453 distances) — and the share of
the tick spent on the clearance cost (``1 − plain/clearance``).  Also the safety layer's QP step (median; one step after each tick).
Where the time goes: a cProfile (CPU time) of the default controller's warm ticks and of the safety steps between them, split
into iLQR, collision model, FK/task evaluation (compiled), QP, RNEA and the MPC's own code, each with the share
spent in Python bytecode (``PARTS``; cProfile's overhead inflates the Python shares).  The process is pinned to
one core (``sched_setaffinity``).
What limits the rate is printed from these numbers.  The inner solver's per-call set-up: the same recorded ticks
(start, target, warm start) solved alternately by ``RecedingReach.solve`` (the MPC's, set up once) and by
``ilqr_reach`` with the same options (checks, certificate and set-up every call), CPU time, median ratio.  Timings are wall clock on a shared machine: the load
average is recorded with them, and only the ratios are comparable between runs.

Output: a table, the summary lines and ``<out>/results.json``.  ``--ci``: horizon 20, 4 ticks (seconds).
"""

from __future__ import annotations

import math
import os
import sys
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import per_call_us, print_table

from coop_ga.harness import Experiment, int_at_least

HORIZONS = (20, 50, 100)


def _setup() -> tuple[Any, np.ndarray, Any, Any]:
    import coop_ga as cg
    from coop_ga.control.mpc import MovingSphere
    from coop_ga.geometry import primitives as P
    from coop_ga.sim.mpc_track import figure_eight_target, obstacle_path

    s = cg.systems.load("three_franka")
    task = cg.cooperative_task(s, "circle")
    q0 = np.array(s.q0, float)
    X0 = task.primitive(q0)
    c0 = np.asarray(P.center(X0), float)
    target = figure_eight_target(c0, float(P.radius(X0)))
    sphere = MovingSphere(0.06, obstacle_path(0, c0, 4.0))
    return task, q0, target, sphere


def _stats(x: list[float]) -> dict[str, float]:
    a = np.asarray(x, float)
    return {"median": float(np.median(a)), "p95": float(np.percentile(a, 95)), "max": float(a.max())}


def run_loop(task: Any, q0: np.ndarray, target: Any, sphere: Any, horizon: int, ticks: int, clearance: bool) -> dict:
    """``ticks`` warm ticks (after the cold one) of the kinematic loop: their tick / solve / filter times [s]."""
    from coop_ga.control.mpc import CooperativeMPC

    mpc = CooperativeMPC(
        task, target, obstacles=[sphere], horizon=horizon, clearance_weight=1e4 if clearance else 0.0, time_budget=1e9
    )
    q, qd, t = q0.copy(), np.zeros(task.nq), 0.0
    tick_s, cpu_s, solve_s, filt_s, iters = [], [], [], [], []
    for k in range(ticks + 1):
        c = time.process_time()
        tick = mpc.tick(t, q, qd)
        if k:
            cpu_s.append(time.process_time() - c)
            tick_s.append(tick.tick_time)
            solve_s.append(tick.solve_time)
            iters.append(tick.iterations)
            tf = t + mpc.o.filter_dt  # a safety step between ticks (at a tick's instant it shares its collision model)
            filt_s.append(mpc.filter(tf, *mpc.sample_plan(tf)).step_time)
        t += mpc.o.period
        q, qd = mpc.sample_plan(t)
    return {
        "tick_s": _stats(tick_s),
        "tick_cpu_s": _stats(cpu_s),
        "solve_s": _stats(solve_s),
        "filter_s": _stats(filt_s),
        "iterations": float(np.mean(iters)),
        "per_iteration_s": float(np.median(np.asarray(solve_s) / np.maximum(iters, 1))),
    }


def anchors(task: Any, q0: np.ndarray, target: Any, sphere: Any) -> dict[str, float]:
    """One compiled task evaluation and one collision-model evaluation [s] (best of repeats)."""
    from coop_ga.control.mpc import ObstacleWorld

    V = target(0.5)
    task.error_and_jacobian(q0, V)
    cm = ObstacleWorld(task.system, [sphere]).model
    return {
        "task_evaluate_s": per_call_us(lambda: task.error_and_jacobian(q0, V)) * 1e-6,
        "collision_evaluate_s": per_call_us(lambda: cm.distances_and_jacobian(q0)) * 1e-6,
    }


def setup_overhead(task: Any, q0: np.ndarray, target: Any, sphere: Any, horizon: int, ticks: int) -> dict[str, float]:
    """CPU time of the MPC's inner call (``RecedingReach.solve``) against ``ilqr_reach`` on the same recorded ticks,
    interleaved (module docstring)."""
    from coop_ga.control.ilqr import RecedingReach, ilqr_reach
    from coop_ga.control.mpc import CooperativeMPC

    mpc = CooperativeMPC(task, target, obstacles=[sphere], horizon=horizon, time_budget=1e9)
    o = mpc.o
    q, qd, t = q0.copy(), np.zeros(task.nq), 0.0
    rec = []
    for k in range(ticks + 1):
        u, V = mpc._warm_start(), mpc.target(t + o.lookahead)
        mpc.tick(t, q, qd)
        if k:
            rec.append((q.copy(), qd.copy(), V, u))
        t += o.period
        q, qd = mpc.sample_plan(t)
    kw = dict(horizon=o.horizon, dt=o.dt, R=o.R, Q=o.Q, Qv=o.Qv, terminal=o.terminal, hessian=o.hessian,
              restart=False, max_iter=o.max_iter)  # fmt: skip
    solver = RecedingReach(task, **kw)
    solver.solve(rec[0][0], rec[0][2], qd_init=rec[0][1], u_init=rec[0][3])
    old, new = [], []
    for q, qd, V, u in rec:
        c = time.process_time()
        ilqr_reach(task, q, V, qd_init=qd, u_init=u, **kw)
        old.append(time.process_time() - c)
        c = time.process_time()
        solver.solve(q, V, qd_init=qd, u_init=u)
        new.append(time.process_time() - c)
    return {
        "ilqr_reach_cpu_s": float(np.median(old)),
        "receding_reach_cpu_s": float(np.median(new)),
        "ratio": float(np.median(np.asarray(new) / np.asarray(old))),
    }


#: where a tick's time goes: the first part whose path fragment is in the file of the function the time is spent
#: in; library and generic code (numpy, the algebra, validation, built-ins) counts for its nearest caller that has a
#: part (split by the callers' shares)
PARTS = (
    ("iLQR", ("coop_ga/control/ilqr/",)),
    ("collision", ("coop_ga/collision/", "coop_ga/control/limits/clearance", "coop_ga/control/mpc/obstacles",
                   "coop_ga/control/avoidance")),
    ("FK/task", ("coop_ga/cooperative/", "coop_ga/kinematics/", "coop_ga/codegen", "casadi")),
    ("QP", ("coop_ga/control/qp", "coop_ga/control/solve", "coop_ga/control/limits/", "coop_ga/control/tasks",
            "coop_ga/control/configuration", "daqp", "qpsolvers")),
    ("RNEA", ("pinocchio",)),
    ("MPC", ("coop_ga/control/mpc/", "coop_ga/diagnostics")),
)  # fmt: skip


def _part(key: tuple[str, int, str]) -> str | None:
    where = f"{key[0]}:{key[2]}"
    return next((name for name, frags in PARTS if any(f in where for f in frags)), None)


def _shares(stats: Any) -> dict[str, dict[str, float]]:
    """``{part: {"share", "python"}}``: each part's share of the profiled time and the share of that spent in
    Python bytecode (functions with a source file) rather than in compiled code (built-ins, extensions)."""
    raw = stats.stats  # {func: (cc, nc, tottime, cumtime, callers)}
    memo: dict[Any, dict[str, float]] = {}

    def owner(f: Any, depth: int = 0) -> dict[str, float]:
        if f in memo:
            return memo[f]
        part = _part(f)
        if part is not None:
            return memo.setdefault(f, {part: 1.0})
        memo[f] = {"other": 1.0}  # a cycle or no caller
        callers = raw[f][4] if f in raw else {}
        total = sum(v[3] for v in callers.values())
        if depth > 40 or not total > 0:
            return memo[f]
        out: dict[str, float] = {}
        for c, v in callers.items():
            for k, w in owner(c, depth + 1).items():
                out[k] = out.get(k, 0.0) + w * v[3] / total
        memo[f] = out
        return out

    spent: dict[str, list[float]] = {}
    for f, (_, _, tt, _, _) in raw.items():
        python = f[0] not in ("~", "") and not f[2].startswith("<built-in") and not f[2].startswith("<method")
        for k, w in owner(f).items():
            acc = spent.setdefault(k, [0.0, 0.0])
            acc[0] += w * tt
            acc[1] += w * tt * python
    total = sum(v[0] for v in spent.values()) or 1.0
    return {k: {"share": v[0] / total, "python": v[1] / v[0] if v[0] else 0.0} for k, v in spent.items()}


def profile(task: Any, q0: np.ndarray, target: Any, sphere: Any, horizon: int, ticks: int) -> dict[str, Any]:
    """cProfile of ``ticks`` warm ticks and of the 4 safety steps after each (the closed loop's work per period),
    each split by :data:`PARTS` (:func:`_shares`); the profiler's own overhead inflates the Python shares."""
    import cProfile
    import pstats

    from coop_ga.control.mpc import CooperativeMPC

    mpc = CooperativeMPC(task, target, obstacles=[sphere], horizon=horizon, time_budget=1e9)
    q, qd, t = q0.copy(), np.zeros(task.nq), 0.0
    mpc.tick(t, q, qd)  # the cold tick: not profiled
    prof = {"tick": cProfile.Profile(time.process_time), "filter": cProfile.Profile(time.process_time)}  # CPU time
    for _ in range(ticks):
        t += mpc.o.period
        q, qd = mpc.sample_plan(t)
        prof["tick"].runcall(mpc.tick, t, q, qd)
        for j in range(round(mpc.o.period / mpc.o.filter_dt)):
            prof["filter"].runcall(mpc.filter, t + j * mpc.o.filter_dt, q, qd)
    return {k: _shares(pstats.Stats(p)) for k, p in prof.items()}


def _profile_text(name: str, shares: dict[str, dict[str, float]]) -> str:
    order = sorted(shares.items(), key=lambda kv: -kv[1]["share"])
    return f"{name}: " + ", ".join(
        f"{k} {100 * v['share']:.0f} % ({100 * v['python']:.0f} % of it Python)"
        for k, v in order
        if v["share"] >= 0.005
    )


def _limit_note(r: dict[str, Any], a: dict[str, float]) -> str:
    c, p = r["clearance"], r["plain"]
    share = 1.0 - p["tick_s"]["median"] / c["tick_s"]["median"]
    evals = c["per_iteration_s"] / a["collision_evaluate_s"]
    setup = 1.0 - p["solve_s"]["median"] / p["tick_s"]["median"]
    it_evals = p["per_iteration_s"] / a["task_evaluate_s"]
    return (
        f"H={r['horizon']}: with the clearance cost {c['sustained_rate_hz']:.1f} Hz (median tick), of which the cost "
        f"takes {100 * share:.0f} % (one iteration ≈ {evals:.0f} collision evaluations: its Gauss–Newton Hessian at "
        f"every knot and the line search's exact cost); without it {p['sustained_rate_hz']:.1f} Hz, of which "
        f"{100 * setup:.0f} % is outside the iLQR's own solve (checks, target, the feasibility blend and the result, "
        f"RNEA, the state's clearance) and one iLQR iteration ≈ {it_evals:.0f} task evaluations; the inner call set up "
        f"once (RecedingReach) takes {r['setup_overhead']['ratio']:.2f}× the CPU time of ilqr_reach on the same ticks "
        f"({1e3 * r['setup_overhead']['receding_reach_cpu_s']:.2f} vs {1e3 * r['setup_overhead']['ilqr_reach_cpu_s']:.2f} ms)."
        f"\n  profile, {_profile_text('tick', r['profile']['tick'])}"
        f"\n  profile, {_profile_text('safety step', r['profile']['filter'])}"
    )


def _one_core() -> int | None:
    """Pin this process (and the threads it starts) to one core: the rates are those of one core.  Returns the
    core (None where the OS has no affinity call)."""
    if not hasattr(os, "sched_setaffinity"):
        return None
    core = min(os.sched_getaffinity(0))
    os.sched_setaffinity(0, {core})
    return core


def main(argv: list[str] | None = None) -> int:
    exp = Experiment(__file__, __doc__, seed=0)
    exp.add("--horizons", type=int, nargs="+", default=list(HORIZONS), help="horizons in knots")
    exp.add("--ticks", type=int_at_least(1), default=40, help="warm ticks per horizon and variant")
    exp.add("--ci", action="store_true", help="horizon 20, 4 ticks")
    args = exp.parse(argv)
    horizons, ticks = ([20], 4) if args.ci else (list(args.horizons), int(args.ticks))
    core = _one_core()
    task, q0, target, sphere = _setup()
    warnings.simplefilter("ignore")  # rate warnings: the numbers are the point here
    t0 = time.perf_counter()
    a = anchors(task, q0, target, sphere)
    results = []
    for h in horizons:
        r: dict[str, Any] = {"horizon": h, "lookahead_s": h * 0.02}
        for variant in ("clearance", "plain"):
            with exp.stage(f"horizon {h}, {variant}"):
                r[variant] = run_loop(task, q0, target, sphere, h, ticks, variant == "clearance")
            r[variant]["tick_over_task_evaluate"] = r[variant]["tick_s"]["median"] / a["task_evaluate_s"]
            r[variant]["tick_over_collision_evaluate"] = r[variant]["tick_s"]["median"] / a["collision_evaluate_s"]
            r[variant]["sustained_rate_hz"] = 1.0 / r[variant]["tick_s"]["median"]
            r[variant]["cpu_rate_hz"] = 1.0 / r[variant]["tick_cpu_s"]["median"]  # the core to itself
        with exp.stage(f"horizon {h}, the inner call with and without its per-call set-up"):
            r["setup_overhead"] = setup_overhead(task, q0, target, sphere, h, ticks)
        with exp.stage(f"horizon {h}, profile of the tick and of the safety step (cProfile)"):
            r["profile"] = profile(task, q0, target, sphere, h, ticks)
        r["note"] = _limit_note(r, a)
        results.append(r)
    a["ilqr_iteration_h20_s"] = next(
        (r["clearance"]["per_iteration_s"] for r in results if r["horizon"] == 20), math.nan
    )
    _report(results, a, exp.quiet)
    doc = {
        "config": {"system": "three_franka", "kind": "circle", "dt": 0.02, "period": 0.04, "max_iter": 2,
                   "ticks": ticks, "horizons": horizons, "core": core},
        "load_average": list(os.getloadavg()),
        "anchors": a,
        "results": results,
        "wall_s": time.perf_counter() - t0,
    }  # fmt: skip
    exp.write_json("results.json", doc)
    return 0


def _report(results: list[dict[str, Any]], a: dict[str, float], quiet: bool) -> None:
    if quiet:
        return
    rows = []
    for r in results:
        for v in ("clearance", "plain"):
            x = r[v]
            rows.append([
                r["horizon"], v, f"{1e3 * x['tick_s']['median']:.1f}", f"{1e3 * x['tick_s']['p95']:.1f}",
                f"{1e3 * x['tick_s']['max']:.1f}", f"{1e3 * x['solve_s']['median']:.1f}",
                f"{x['sustained_rate_hz']:.1f}", f"{1e3 * x['tick_cpu_s']['median']:.1f}",
                f"{1e3 * x['tick_cpu_s']['p95']:.1f}", f"{x['cpu_rate_hz']:.1f}", f"{x['tick_over_task_evaluate']:.0f}",
                f"{1e3 * x['filter_s']['median']:.2f}",
            ])  # fmt: skip
    print_table(
        f"MPC tick on three_franka (load {os.getloadavg()[0]:.1f}; task evaluate {1e6 * a['task_evaluate_s']:.0f} µs, "
        f"collision evaluate {1e6 * a['collision_evaluate_s']:.0f} µs)",
        [
            "H",
            "variant",
            "tick med ms",
            "p95",
            "max",
            "iLQR solve med",
            "rate Hz",
            "CPU med ms",
            "CPU p95",
            "CPU rate Hz",
            "tick/task eval",
            "filter ms",
        ],
        rows,
    )
    for r in results:
        print(r["note"])


if __name__ == "__main__":
    sys.exit(main())
