"""The constrained reaching OCP (Eq 53–57 with joint limits): coop_ga's iLQR vs CasADi Opti + IPOPT and FATROP, in one run.

Problem (the flagship of ``experiments/circle_reaching.py``): ``three_franka``, cooperative
circle, from rest at q0 to the initial circle moved by 25° about +x, scaled by 1.25 and
displaced by (0.10, −0.05, 0.10) m; 250 knots × Δt = 0.01 s; double integrator x = [q; q̇],
u = q̈ (exact ZOH); cost ``Σ uᵀRu + ‖log(Ṽ_Sc(q_n) V_Sd)‖²_Q + q̇_nᵀQ_v q̇_n`` with
R = 1e-3 I, Q = 1e5 I, Q_v = 1e2 I (``ReachingOCP``), subject at every knot to
``lower ≤ q_k ≤ upper``, ``|q̇_k| ≤ velocity`` (k = 1…n) and ``|u_k| ≤ acceleration``
(k = 0…n−1) from ``system.limits``.  Problems (``--problems``):

* ``flagship``: the system's own limits (Franka datasheet: velocity 2.175–2.61 rad/s,
  acceleration 7.5–20 rad/s², the URDF joint ranges) — none of them binds at the optimum;
* ``velocity``: the same with |q̇| ≤ 0.2 rad/s on every joint — binds (the unconstrained
  optimum reaches 0.24 rad/s; ~126 (knot, joint) entries active);
* ``position`` (not run by default: ``--problems flagship velocity position``): arm0 joint 4
  ≥ q0 − 0.1 rad — binds (the unconstrained optimum moves it by −0.32 rad); this problem
  has several local optima, and the solvers may end in different ones from the same
  initial guess (``tests/control/test_reference_ocp.py``).

Solvers (same problem data, same initial guess u = 0 with the system at rest at q0):

* ``iLQR``: :func:`coop_ga.control.ilqr_reach` through its public API, as it is when this
  runs, with the problem's parameters and — where its options have them — ``limit_mode="enforce"``
  and ``terminal="soft"`` (these select the problem above; everything else is its default,
  including its ``tol``).  ``iLQR (tol = 0)`` is the same run to stationarity.  Timed best of
  ``--repeat`` after a warm-up (its own ``solve_time_s``; CPU time by ``time.process_time``).
* ``IPOPT`` / ``FATROP``: :mod:`coop_ga.control.reference_ocp` — multiple shooting in
  CasADi ``Opti``, exact Hessian by AD, the terminal error from
  ``task.graph.error_expression``, tol 1e-10; FATROP with ``structure_detection="auto"``.
  Time = the solver's own ``t_wall_total`` / ``t_proc_total`` (best of ``--ref-repeat``);
  building the Opti problem and creating the nlpsol (expansion, FATROP's structure
  detection) are reported separately, not in the solve time.

Solver rows added where they run:

* ``BoxFDDP``: crocoddyl's box-FDDP (where crocoddyl imports: it needs pinocchio 4.0.0, the environment of
  ``.ci/run``'s crocoddyl step) on the same double integrator —
  :func:`coop_ga.adapters.crocoddyl.double_integrator_problem`: the same knots, exact-ZOH dynamics, cost (the
  terminal error through the adapter's ``SimilarityResidual``) and acceleration box (exact in box-FDDP); FDDP has
  no state constraints, so the position and velocity bounds are a quadratic-barrier penalty of weight
  ``CROC_BOUND_WEIGHT`` (its violation is in the table); same initial guess, its defaults, best of ``--repeat``
  after a warm-up.  Its action models are Python classes (one call per knot per pass), as a crocoddyl user of the
  residual writes them.

Every solver runs on one core: the benchmark sets ``OPENBLAS_NUM_THREADS`` (and OMP/MKL) to 1 unless set.

Item ratios printed at the end of the run (``ratios`` in the JSON):

* with active state bounds (``velocity``): the iLQR's time to the optimum against IPOPT's, FATROP's and
  BoxFDDP's solve time, by three definitions — ``iLQR (tol = 0)`` run to stationarity (its own end); the time its
  iteration history (feasible iterates) first comes within 1e-6 (relative) of the best feasible cost of the table
  (``time_to_optimum_s``, the sum of its iterations' times); and the time it first comes within 1e-6, 1e-8 and
  IPOPT's own tol (1e-10), relative, of IPOPT's cost (``time_to_ipopt_cost_s``) — and how far the iLQR at its
  default tol (``‖e‖ < 1e-5``, a test on the terminal error, not on optimality) stops from IPOPT's optimum;
* with the clearance cost of the obstacle scene (``--clearance``, on by default; the scene, target and
  clearance cost of ``experiments/obstacle_circle.py``: a 4 cm sphere in arm 0's straight path, the circle carried
  30 cm along +y, 100 knots × 0.03 s, ``ClearanceCost(weight 1e4, activation 5 cm)``): the reach's solve time with
  the clearance cost over the same reach without it (each best of ``--repeat`` after a warm-up that builds the
  compiled functions), with iterations and time per iteration, and the smallest clearance of both results at the
  knots and at 10 points per interval of the exact motion, by ``coop_ga.collision`` and independently by coal's
  GJK on the same capsules (``independent_clearance``).

Measured 2026-12-02 on the shared 2-core machine under load 10–13 (wall times 2–12× the CPU times): see
docs/performance.md ("The constrained reaching OCP") for the numbers of the last full run.  In the last run
(load 11): velocity problem, the iLQR within 1e-6 of IPOPT's cost after 0.244× IPOPT's solve time (0.138×
FATROP's), to its own end 1.23×; the clearance reach 11.2× the reach without the cost (200 ms, 12 iterations,
against 18 ms, 5); at load 2 (clearance part alone, ``--repeat 7``) 13.4–13.6× (78–79 ms against 6 ms), 8–22×
under load 7–9 (the plain reach's 6–24 ms decides it).  With the acceleration box inside the closed-form step
(14 iterations, all closed-form, J 0.02282, 50.0 mm clear): 9.8×, 11.5×, 12.4× under load 6–7 (104–148 ms),
alternated with the code before at 13.1×, 13.2×, 20.3× (126–178 ms).  With the Newton terminal model near
the rows, the rows' second-order correction and the semi-smooth Newton rows step (10 iterations, J 0.02027,
50.1 mm clear), ``--problems flagship --no-ipopt --no-fatrop --no-crocoddyl --repeat 7`` on one core under load
2.0–2.7: 9.3×, 9.3×, 7.4× (121–152 ms), alternated with the code before at 12.7×, 12.6×, 17.1× (189–209 ms); the
CI-size run (``--problems velocity --horizon 50 --dt 0.05 --repeat 1``, load 2.7–2.9) printed 7.7× and 9.3× — the
target of 5× is not met.

Columns: iterations; solve time [ms] (wall) and CPU [ms]; the cost J of Eq 53 of the
returned controls (re-integrated); ΔJ relative to the best feasible row; terminal ‖e‖;
the largest bound violation [rad, rad/s or rad/s²] and the number of active bound entries
(within 1e-6), both recomputed here from the returned trajectories; status; solve time
relative to iLQR's (wall).  On a loaded machine wall times exceed CPU times; compare both.

Run: ``python benchmarks/ocp.py`` (``--help`` for the options).  Every number goes to
``<--out>/results.json`` (default ``results/benchmarks/ocp``; strict JSON) and, with
``--json OUT``, to ``OUT`` as well.
"""

from __future__ import annotations

import os

# every solver on one core: multi-threaded BLAS on a loaded 2-core machine made single linear solves of the iLQR's
# clearance step 50× slower (6.5 ms → 307 ms measured) and the plain reach's times erratic; set before numpy loads
for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse
import dataclasses
import platform
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from _timing import print_table

import coop_ga as cg
from coop_ga.control.ilqr import ILQROptions, ReachingOCP, displaced_target, ilqr_reach
from coop_ga.control.reference_ocp import ReferenceProblem, check_trajectory
from coop_ga.harness import Experiment, int_at_least, positive_float, positive_int, write_json

TARGET = {"translation": (0.10, -0.05, 0.10), "axis": (1.0, 0.0, 0.0), "angle": np.deg2rad(25.0), "scale": 1.25}
PROBLEMS = ("flagship", "velocity", "position")
FEASIBLE = 1e-6  # bound violation below which a row counts as feasible
REF_TOL = 1e-10  # IPOPT's and FATROP's tol (ReferenceProblem's default)


def make_system(name: str) -> tuple[Any, str]:
    """The three_franka system with the limits of problem ``name`` and a one-line description."""
    s = cg.systems.load("three_franka")
    if name == "flagship":
        return s, "system limits (Franka datasheet)"
    if name == "velocity":
        return s.with_limits(velocity=0.2), "|q̇| ≤ 0.2 rad/s on every joint"
    q0 = np.array(s.q0)
    j = s.limits.joint_names[3]
    return s.with_limits(position={j: (float(q0[3]) - 0.1, float(s.limits.upper[3]))}), f"{j} ≥ q0 − 0.1 rad"


def ilqr_kwargs(terminal: str) -> tuple[dict[str, Any], str]:
    """Options that make ``ilqr_reach`` solve the benchmark's problem, as far as its options allow."""
    names = {f.name for f in dataclasses.fields(ILQROptions)}
    kw: dict[str, Any] = {}
    notes = []
    if "limit_mode" in names:
        kw["limit_mode"] = "enforce"
    else:
        notes.append("this iLQR has no 'limit_mode' option: it solves the problem WITHOUT the bounds")
    if "terminal" in names:
        kw["terminal"] = terminal
    elif terminal != "soft":
        notes.append("this iLQR has no 'terminal' option: it solves the soft-terminal problem")
    return kw, "; ".join(notes)


def _row(
    label: str,
    *,
    iterations: int,
    solve_s: float,
    cpu_s: float,
    u: np.ndarray,
    q: np.ndarray,
    qd: np.ndarray,
    ocp: ReachingOCP,
    lim: Any,
    status: str,
    success: bool,
    extra: dict[str, Any] | None = None,
) -> dict[str, Any]:
    chk = check_trajectory(ocp, lim, q, qd, u)
    err = float(np.linalg.norm(ocp.task.error(q[-1], ocp.target)))
    return {
        "solver": label,
        "iterations": int(iterations),
        "solve_time_s": float(solve_s),
        "cpu_time_s": float(cpu_s),
        "cost": float(ocp.cost(u)),
        "terminal_error": err,
        "max_violation": chk["max_violation"],
        "violations": chk["violations"],
        "active": chk["active"],
        "defect": chk["defect"],
        "status": status,
        "success": bool(success),
        **(extra or {}),
    }


def run_ilqr(
    task: Any,
    q0: np.ndarray,
    Vd: Any,
    ocp: ReachingOCP,
    lim: Any,
    args: argparse.Namespace,
    kw: dict[str, Any],
    label: str,
) -> dict[str, Any]:
    call = dict(horizon=args.horizon, dt=args.dt, **kw)
    ilqr_reach(task, q0, Vd, **call)  # warm-up: compile/build the task's functions once
    best, cpu = None, np.inf
    for _ in range(max(1, args.repeat)):
        c0 = time.process_time()
        r = ilqr_reach(task, q0, Vd, **call)
        c = time.process_time() - c0
        if best is None or r.solve_time_s < best.solve_time_s:
            best, cpu = r, c
    return _row(
        label,
        iterations=best.iterations,
        solve_s=best.solve_time_s,
        cpu_s=cpu,
        u=best.u,
        q=best.trajectory,
        qd=best.qd,
        ocp=ocp,
        lim=lim,
        status=best.message,
        success=best.converged,
        extra={"options": dict(call), "_result": best},
    )


def time_to_optimum(result: Any, j_best: float, rel: float = 1e-6) -> float | None:
    """Seconds of iterations (their ``time_s``) until the cost history first comes within ``rel`` of ``j_best``."""
    t = 0.0
    for it in result.stats:
        t += it.time_s
        if it.cost <= j_best + rel * abs(j_best) and it.violation <= FEASIBLE:
            return t
    return None


def _obstacle_scene() -> Any:
    """``experiments/obstacle_circle.py`` as a module (its scene's constants: one place)."""
    import importlib.util

    path = Path(__file__).resolve().parents[1] / "experiments" / "obstacle_circle.py"
    spec = importlib.util.spec_from_file_location("obstacle_circle", path)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def independent_clearance(cm: Any, Q: np.ndarray, rows: str = "all") -> float:
    """The smallest clearance [m] of the collision model's pairs at the configurations Q (K, nq), computed by coal's
    GJK on the same capsules and spheres (``coal.Capsule``/``coal.Sphere`` placed by Pinocchio's frame placements):
    an implementation independent of ``coop_ga.collision``'s closed forms and compiled kinematics.  ``rows``:
    ``"all"`` or ``"obstacle"``."""
    import coal
    import pinocchio as pin

    model = cm.system.model
    data = model.createData()
    caps = cm.capsules
    fids = [model.getFrameId(c.frame) for c in caps]
    shapes = [coal.Capsule(c.radius, float(np.linalg.norm(c.b - c.a))) for c in caps]
    req, res = coal.DistanceRequest(), coal.DistanceResult()
    pairs = [(int(i), int(k), kind) for (i, k), kind in zip(cm.pairs, cm.kinds) if rows == "all" or kind == "obstacle"]
    obst = [(coal.Sphere(ob.radius), coal.Transform3s(np.eye(3), np.asarray(ob.center, float))) for ob in cm.obstacles]
    best = np.inf
    for q in Q:
        pin.framesForwardKinematics(model, data, q)
        tf = []
        for c, f in zip(caps, fids):
            M = data.oMf[f]
            a, b = M.act(c.a), M.act(c.b)
            z = b - a
            L = float(np.linalg.norm(z))
            z = z / L if L > 0 else np.array([0.0, 0.0, 1.0])
            x = np.cross(z, [1.0, 0.0, 0.0] if abs(z[0]) < 0.9 else [0.0, 1.0, 0.0])
            x /= np.linalg.norm(x)
            tf.append(coal.Transform3s(np.column_stack([x, np.cross(z, x), z]), 0.5 * (a + b)))
        for i, k, kind in pairs:
            if kind == "obstacle":
                d = coal.distance(shapes[i], tf[i], obst[k][0], obst[k][1], req, res)
            else:
                d = coal.distance(shapes[i], tf[i], shapes[k], tf[k], req, res)
            best = min(best, d - cm.margin)
    return float(best)


def run_clearance(repeat: int) -> dict[str, Any]:
    """The obstacle scene's reach with and without the clearance cost (module docstring): each best of ``repeat``
    after a warm-up (which builds the task's and the collision model's compiled functions, outside the timed solve),
    and the clearance of the result: at the knots and at ``SUBSAMPLES`` points per interval of the exact motion by
    ``coop_ga.collision``, and at the knots (every pair) and the dense points (the obstacle pairs) by coal."""
    from coop_ga.collision.distance import Sphere
    from coop_ga.collision.model import CollisionModel
    from coop_ga.control.avoidance import ClearanceCost

    sc = _obstacle_scene()
    s = cg.systems.load("three_franka")
    task = cg.cooperative_task(s, "circle")
    cm = CollisionModel(s, obstacles=[Sphere(np.array(sc.OBSTACLE_CENTER), sc.OBSTACLE_RADIUS)], self_collision=True)
    q0 = np.array(s.q0, float)
    Vd = displaced_target(task, q0, translation=sc.TRANSLATION)
    out: dict[str, Any] = {"horizon": sc.ILQR_HORIZON, "dt": sc.ILQR_DT}
    for key, cost in (("plain", None), ("clearance", ClearanceCost(cm, sc.CLEARANCE_WEIGHT, sc.CLEARANCE_ACTIVATION))):
        call = dict(horizon=sc.ILQR_HORIZON, dt=sc.ILQR_DT, clearance=cost)
        ilqr_reach(task, q0, Vd, **call)  # warm-up
        best = min((ilqr_reach(task, q0, Vd, **call) for _ in range(repeat)), key=lambda r: r.solve_time_s)
        dense = sc._dense(best, sc.SUBSAMPLES)
        out[key] = {
            "solve_time_s": best.solve_time_s,
            "iterations": best.iterations,
            "per_iteration_s": best.solve_time_s / max(best.iterations, 1),
            "converged": best.converged,
            "error": best.error,
            "cost": best.cost,
            "backward": [it.backward for it in best.stats],
            "line_search_trials": int(sum(it.line_search_trials for it in best.stats)),
            "min_clearance_knots_m": float(cm.min_clearance(best.trajectory).min()),
            "min_clearance_dense_m": float(cm.min_clearance(dense).min()),
            "coal_min_clearance_knots_m": independent_clearance(cm, best.trajectory),
            "coal_min_clearance_dense_obstacle_m": independent_clearance(cm, dense, "obstacle"),
        }
    p, c = out["plain"], out["clearance"]
    out["time_ratio"] = c["solve_time_s"] / p["solve_time_s"]
    out["per_iteration_ratio"] = c["per_iteration_s"] / p["per_iteration_s"]
    return out


def _ratios(problems: dict[str, Any], clearance: dict[str, Any] | None, croc: bool = False) -> dict[str, Any]:
    """The ratios of the module docstring, and the lines that print them."""
    out: dict[str, Any] = {"lines": []}
    for name, pr in problems.items():
        rows = {r["solver"]: r for r in pr["rows"]}
        il, il0 = rows.get("iLQR"), rows.get("iLQR (tol = 0)")
        for ref in ("IPOPT", "FATROP", "BoxFDDP"):
            if ref not in rows or il0 is None or il is None:
                continue
            t_ref = rows[ref]["solve_time_s"]
            tto = il0.get("time_to_optimum_s")
            d = {
                "ilqr_tol0_over_ref": il0["solve_time_s"] / t_ref,
                "ilqr_time_to_optimum_over_ref": None if tto is None else tto / t_ref,
                "ilqr_tol_over_ref": il["solve_time_s"] / t_ref,
            }
            tip = il0.get("time_to_ipopt_cost_s") or {}
            d["ilqr_time_to_ipopt_cost_over_ref"] = {k: None if v is None else v / t_ref for k, v in tip.items()}
            out[f"{name}_vs_{ref.lower()}"] = d
            tto_s = (
                "never within 1e-6 of the best cost" if tto is None else f"{d['ilqr_time_to_optimum_over_ref']:.3g}×"
            )
            near = ", ".join(
                f"{k}: " + ("never" if v is None else f"{v:.3g}×")
                for k, v in d["ilqr_time_to_ipopt_cost_over_ref"].items()
            )
            out["lines"].append(
                f"[{name}] iLQR vs {ref}: to stationarity (tol = 0) {d['ilqr_tol0_over_ref']:.3g}×, to within 1e-6 of "
                f"the best cost {tto_s}, to its tol {d['ilqr_tol_over_ref']:.3g}× {ref}'s solve time"
                + (f"; to within (relative) {near} of IPOPT's cost" if near else "")
                + (" (target ≤ 1.0× with active state bounds)" if name == "velocity" else "")
            )
        if il is not None and "IPOPT" in rows:
            gap = (il["cost"] - rows["IPOPT"]["cost"]) / abs(rows["IPOPT"]["cost"])
            out[f"{name}_default_tol_gap"] = gap
            out["lines"].append(
                f"[{name}] the iLQR at its default tol stops {gap:+.2e} (relative cost) from IPOPT's optimum "
                f"(terminal ‖e‖ {il['terminal_error']:.1e})"
            )
    if clearance is not None:
        p, c = clearance["plain"], clearance["clearance"]
        out["clearance"] = {k: clearance[k] for k in ("time_ratio", "per_iteration_ratio")}
        out["lines"].append(
            f"[clearance] the obstacle scene's reach with the clearance cost takes {clearance['time_ratio']:.1f}× the "
            f"same reach without it (target ≤ 5×): {1e3 * c['solve_time_s']:.0f} ms, {c['iterations']} iterations "
            f"(converged {c['converged']}, ‖e‖ {c['error']:.1e}) vs {1e3 * p['solve_time_s']:.0f} ms, "
            f"{p['iterations']} iterations; per iteration {clearance['per_iteration_ratio']:.1f}×"
        )
        for key, what in (("clearance", "with the clearance cost"), ("plain", "without it")):
            r = clearance[key]
            if "coal_min_clearance_knots_m" not in r:
                continue
            out["lines"].append(
                f"[clearance] smallest clearance {what}: {1e3 * r['min_clearance_knots_m']:.1f} mm at the knots, "
                f"{1e3 * r['min_clearance_dense_m']:.1f} mm at 10 points per interval (coop_ga.collision); by coal: "
                f"{1e3 * r['coal_min_clearance_knots_m']:.1f} mm at the knots, "
                f"{1e3 * r['coal_min_clearance_dense_obstacle_m']:.1f} mm to the obstacle at 10 points per interval"
            )
    if not croc:
        out["lines"].append(crocoddyl_note())
    return out


#: BoxFDDP's weight of the quadratic-barrier penalty that stands for the position and velocity bounds (FDDP has no
#: state constraints): ½·weight·dist(x, box)² at every knot
CROC_BOUND_WEIGHT = 1e6


def crocoddyl_available() -> bool:
    """Whether crocoddyl imports here (it runs with pinocchio 4.0.0 only: the CI's second environment)."""
    import importlib.util

    if importlib.util.find_spec("crocoddyl") is None:
        return False
    try:
        import coop_ga.adapters.crocoddyl  # noqa: F401
    except Exception:  # a crocoddyl that does not load with this pinocchio
        return False
    return True


def crocoddyl_note() -> str:
    """Why crocoddyl's BoxFDDP is not in the table (module docstring)."""
    import importlib.util

    import pinocchio

    found = importlib.util.find_spec("crocoddyl") is not None
    return (
        f"[crocoddyl] BoxFDDP not run: crocoddyl 3.2.1 works only with pinocchio 4.0.0 (this one is "
        f"{pinocchio.__version__}; its wheel crashes with pinocchio 4.1 on frame costs); crocoddyl importable here: "
        f"{found}.  Run this benchmark in the environment with pin 4.0.0 and crocoddyl (.ci/run's croc step) for "
        "its row"
    )


def run_boxfddp(ocp: ReachingOCP, lim: Any, repeat: int) -> dict[str, Any]:
    """crocoddyl's BoxFDDP on the same double integrator (:func:`coop_ga.adapters.crocoddyl.double_integrator_problem`:
    same knots, cost, acceleration box; the position/velocity bounds as a quadratic-barrier penalty of weight
    ``CROC_BOUND_WEIGHT``), from the same initial guess (u = 0 at rest), its defaults (th_stop
    1e-9, at most 1000 iterations); best of ``repeat`` after a warm-up."""
    import crocoddyl

    from coop_ga.adapters.crocoddyl import double_integrator_problem

    problem = double_integrator_problem(ocp, state_bounds=CROC_BOUND_WEIGHT)
    x0 = np.concatenate([ocp.q_init, ocp.qd_init])
    xs0 = [x0] * (ocp.horizon + 1)
    us0 = [np.zeros(ocp.nq)] * ocp.horizon

    def solve() -> tuple[Any, float, float, bool]:
        solver = crocoddyl.SolverBoxFDDP(problem)
        c0, t0 = time.process_time(), time.perf_counter()
        ok = solver.solve(xs0, us0, 1000, False)
        return solver, time.perf_counter() - t0, time.process_time() - c0, bool(ok)

    solve()  # warm-up
    best = min((solve() for _ in range(max(1, repeat))), key=lambda r: r[1])
    solver, wall, cpu, ok = best
    u = np.array(solver.us)
    q, qd = ocp.rollout(u)
    return _row(
        "BoxFDDP",
        iterations=solver.iter,
        solve_s=wall,
        cpu_s=cpu,
        u=u,
        q=q,
        qd=qd,
        ocp=ocp,
        lim=lim,
        status=f"{'ok' if ok else 'not converged'} (stop {solver.stop:.1e}; q/q̇ bounds a penalty)",
        success=ok,
    )


def run_reference(P: ReferenceProblem, solver: str, repeat: int) -> dict[str, Any]:
    first = best = P.solve(solver)  # the first solve also creates the solver's nlpsol
    for _ in range(max(1, repeat) - 1):
        r = P.solve(solver)
        if r.solve_time_s < best.solve_time_s:
            best = r
    creation = first.wall_time_s - first.solve_time_s
    ocp = P.ocp
    row = _row(
        {"ipopt": "IPOPT", "fatrop": "FATROP"}[solver],
        iterations=best.iterations,
        solve_s=best.solve_time_s,
        cpu_s=best.solve_cpu_s,
        u=best.u,
        q=best.q,
        qd=best.qd,
        ocp=ocp,
        lim=P.limits,
        status=f"{'ok' if best.success else 'FAILED'} ({best.status})",
        success=best.success,
        extra={
            "nlp_cost": best.cost,
            "build_time_s": P.build_time_s,
            "nlpsol_creation_s": max(0.0, creation),
            "stats": {k: v for k, v in best.stats.items() if k.startswith(("t_", "fatrop.", "iter"))},
        },
    )
    return row


def _parser() -> Experiment:
    exp = Experiment(__file__, __doc__, seed=0, out=Path("results/benchmarks/ocp"))
    exp.add("--repeat", type=positive_int, default=3, metavar="N", help="timed iLQR solves per problem (best reported)")
    exp.add(
        "--ref-repeat",
        type=positive_int,
        default=1,
        metavar="N",
        help="timed IPOPT/FATROP solves per problem (best reported; each takes seconds)",
    )
    exp.add("--problems", nargs="+", choices=PROBLEMS, default=["flagship", "velocity"], help="problems to run")
    exp.add(
        "--terminal",
        choices=("soft", "constraint"),
        default="soft",
        help="terminal error in the cost (Eq 57) or as the constraint e(q_n) = 0",
    )
    exp.add("--horizon", type=int_at_least(2), default=250, help="knots")
    exp.add("--dt", type=positive_float, default=0.01, help="time step [s]")
    exp.add("--no-ipopt", action="store_true", help="skip IPOPT")
    exp.add("--no-clearance", action="store_true", help="skip the obstacle scene's reach with/without clearance")
    exp.add("--no-fatrop", action="store_true", help="skip FATROP")
    exp.add("--no-crocoddyl", action="store_true", help="skip crocoddyl's BoxFDDP (run only where it imports)")
    exp.add(
        "--json",
        type=Path,
        default=None,
        metavar="OUT",
        help="also write every number to this JSON file (results.json in --out is always written)",
    )
    return exp


def _meta(args: Any, kw: dict[str, Any], note: str | None, missing: list[str]) -> dict[str, Any]:
    """The run's settings and machine (``results.json``'s ``meta``)."""
    import casadi as ca

    return {
        "casadi": ca.__version__,
        "python": platform.python_version(),
        "machine": platform.machine(),
        "cpus": os.cpu_count(),
        "load_average": list(os.getloadavg()) if hasattr(os, "getloadavg") else None,
        "horizon": args.horizon,
        "dt": args.dt,
        "terminal": args.terminal,
        "ilqr_options": kw,
        "ilqr_note": note,
        "missing_solvers": missing,
    }


def _solve_problem(exp: Experiment, name: str, args: Any, kw: dict[str, Any], solvers: list[str], croc: bool):
    """Every solver on one problem: ``(description, rows)`` (rows[0]: iLQR, rows[1]: iLQR with tol = 0)."""
    s, desc = make_system(name)
    task = cg.cooperative_task(s, "circle")
    q0 = np.array(s.q0)
    Vd = displaced_target(task, q0, **TARGET)
    ocp = ReachingOCP(task, q0, Vd, horizon=args.horizon, dt=args.dt)
    lim = s.limits
    print(
        f"\n[{name}] three_franka circle, {desc}: nq = {task.nq}, {args.horizon} knots × {args.dt:g} s, "
        f"terminal {args.terminal}, initial ‖e‖ = {np.linalg.norm(task.error(q0, Vd)):.3f}",
        flush=True,
    )
    with exp.stage(f"[{name}] iLQR"):
        rows = [run_ilqr(task, q0, Vd, ocp, lim, args, kw, "iLQR")]
    with exp.stage(f"[{name}] iLQR (tol = 0)"):
        rows.append(run_ilqr(task, q0, Vd, ocp, lim, args, {**kw, "tol": 0.0}, "iLQR (tol = 0)"))
    if solvers:
        P = ReferenceProblem(ocp, lim, terminal=args.terminal)
        for solver in solvers:
            with exp.stage(f"[{name}] {solver}"):
                rows.append(run_reference(P, solver, args.ref_repeat))
            r = rows[-1]
            print(
                f"  {r['solver']}: Opti build {r['build_time_s']:.2f} s, nlpsol creation "
                f"{r['nlpsol_creation_s']:.2f} s (not in the solve time)",
                flush=True,
            )
    if croc:
        with exp.stage(f"[{name}] crocoddyl BoxFDDP"):
            rows.append(run_boxfddp(ocp, lim, args.repeat))
    return desc, rows


def _compare(rows: list[dict[str, Any]]) -> list[list[str]]:
    """Costs relative to the best feasible one, times relative to iLQR's, iLQR's time to the optimum (rows are
    completed in place); the printed table's rows."""
    ref_t = rows[0]["solve_time_s"]
    feasible = [r["cost"] for r in rows if r["max_violation"] <= FEASIBLE and r["success"]] or [
        r["cost"] for r in rows if r["max_violation"] <= FEASIBLE
    ]
    jmin = min(feasible) if feasible else np.nan
    res0 = rows[1].pop("_result")
    rows[1]["time_to_optimum_s"] = time_to_optimum(res0, jmin) if np.isfinite(jmin) else None
    ipopt = next((r for r in rows if r["solver"] == "IPOPT" and r["success"]), None)
    if ipopt is not None:  # within IPOPT's own tolerance (relative) of IPOPT's optimum, and looser levels
        rows[1]["time_to_ipopt_cost_s"] = {
            f"{rel:g}": time_to_optimum(res0, ipopt["cost"], rel) for rel in (1e-6, 1e-8, REF_TOL)
        }
    rows[0].pop("_result")
    table = []
    for r in rows:
        r["rel_cost"] = (r["cost"] - jmin) / abs(jmin) if np.isfinite(jmin) else np.nan
        r["time_ratio"] = r["solve_time_s"] / ref_t if ref_t > 0 else np.nan
        act = r["active"]
        table.append(
            [
                r["solver"],
                str(r["iterations"]),
                f"{r['solve_time_s'] * 1e3:.1f}",
                f"{r['cpu_time_s'] * 1e3:.1f}",
                f"{r['cost']:.10f}",
                f"{r['rel_cost']:+.1e}",
                f"{r['terminal_error']:.2e}",
                f"{r['max_violation']:.1e}",
                f"{act['position']}/{act['velocity']}/{act['acceleration']}",
                f"{r['time_ratio']:.1f}",
                r["status"][:60],
            ]
        )
    return table


#: the printed table's columns (:func:`_compare`)
_COLUMNS = [
    "solver",
    "iter",
    "solve [ms]",
    "CPU [ms]",
    "cost J",
    "ΔJ/J_best",
    "‖e(q_n)‖",
    "max viol",
    "active q/q̇/u",
    "t / iLQR",
    "status",
]


def main(argv: list[str] | None = None) -> int:
    exp = _parser()
    args = exp.parse(argv)
    problems = list(dict.fromkeys(args.problems))

    import casadi as ca

    solvers = [s for s, skip in (("ipopt", args.no_ipopt), ("fatrop", args.no_fatrop)) if not skip]
    missing = [s for s in solvers if not ca.has_nlpsol(s)]
    solvers = [s for s in solvers if s not in missing]
    croc = not args.no_crocoddyl and crocoddyl_available()
    kw, note = ilqr_kwargs(args.terminal)
    out: dict[str, Any] = {"meta": _meta(args, kw, note, missing), "problems": {}}
    if note:
        print(f"note: {note}", flush=True)
    for m in missing:
        print(f"note: this CasADi ({ca.__version__}) has no {m} plugin: skipped", flush=True)

    for name in problems:
        desc, rows = _solve_problem(exp, name, args, kw, solvers, croc)
        table = _compare(rows)
        print_table(f"[{name}] reaching OCP (Eq 53–57) with {desc}, three_franka circle", _COLUMNS, table)
        out["problems"][name] = {"description": desc, "rows": rows}

    clearance = None
    if not args.no_clearance:
        with exp.stage("[clearance] the obstacle scene's reach with and without the clearance cost"):
            clearance = run_clearance(args.repeat)
        out["clearance"] = clearance
    out["ratios"] = _ratios(out["problems"], clearance, croc)
    print("\nRatios (wall solve times of this run, load " + f"{os.getloadavg()[0]:.1f}):")
    for line in out["ratios"]["lines"]:
        print("  " + line)
    path = exp.write_json("results.json", out)
    print(f"\nwrote {path}" + (f" and {write_json(args.json, out)}" if args.json else ""))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
