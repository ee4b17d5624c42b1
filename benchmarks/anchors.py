"""coop_ga against the libraries around it, in one run: Pinocchio, pink, crocoddyl and pygafro (agreement and time ratios).

    python benchmarks/anchors.py [--ci] [--out results/benchmarks/anchors] [--quiet]

Every row compares one coop_ga computation with the same computation in another library, on the same input, and
prints the agreement (the largest difference, in the row's unit) and the time ratio coop_ga / other (< 1: coop_ga
is faster), both from this run (the project's rule: speed only as ratios to an anchor in the same run).  Calls are
timed in wall time (best of repeats, :func:`_timing.per_call_us`); whole solves in CPU time (``time.process_time``,
one solve each after a warm-up), which a loaded machine disturbs less.

* **Pinocchio** (FK anchor): the end points of ``three_franka`` (``task.points``, coop_ga's motor FK compiled with
  the cooperative task) against ``pin.framesForwardKinematics`` + the end frames' translations [m], over 20 random
  configurations; time per call of ``task.evaluate`` (points, V_Sc and its Jacobian) vs Pinocchio's FK alone.
* **pink** (``pin-pink``, differential IK): the three Frankas' cooperative circle moved 5 cm / 17° / ×1.15.
  *Step*: one differential-IK step from q0 by coop_ga's :func:`~coop_ga.control.solve_step`
  (:class:`~coop_ga.control.SimilarityTask`, position and velocity limits) and by ``pink.solve_ik`` with the
  same task through :mod:`coop_ga.adapters.pink` (pink's ``ConfigurationLimit`` and ``VelocityLimit``, DAQP), gains
  matched (pink's α = coop_ga's gain × Δt = 0.05: no limit binds), the exact Jacobian ∂e/∂q on both; agreement ``‖q̇_coop − q̇_pink‖∞`` [rad/s].  *Converge*: coop_ga's
  :func:`~coop_ga.control.gauss_newton_ik` against pink's loop (``solve_ik`` with the wrapped task at α = 1 and a
  posture task, ``‖e‖ < 1e-10``); steps, time, and the circles' agreement (center, radius, normal).
* **crocoddyl** (optimal control): the same reach by coop_ga's :func:`~coop_ga.control.ilqr_reach` (double
  integrator, Eq 53–57) and by crocoddyl's ``SolverBoxFDDP`` on the robot's dynamics
  (:func:`coop_ga.adapters.crocoddyl.reach_problem`); iterations, solve time, the circles' agreement.  crocoddyl
  3.2.1 works with Pinocchio 4.0 only (the ``crocoddyl`` extra); elsewhere the row says why it was skipped.
* **pygafro** (gafro's Python bindings): *primitive*: the circle through three points (``pygafro.Circle`` vs
  :func:`coop_ga.geometry.primitives.circle`; center and radius [m]) over 50 random triples; *motor FK*: the
  Franka's TCP motor (``FrankaEmikaRobot.getEEMotor``) against coop_ga's motor FK
  (``KinematicTree.frame_motors``) and Pinocchio's ``panda_hand_tcp`` [m, rotation entries]; gafro's cooperative
  Jacobian (``CooperativeDualTaskSpace``) is not in its Python bindings (the row says so).

``<out>/results.json`` holds every row; ``--ci`` times fewer calls (the test checks that it runs and what it
reports; no timing is asserted in tests).
"""

from __future__ import annotations

import importlib
import os
import sys
import time
from typing import Any

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from _timing import per_call_us, print_table

import coop_ga as cg
from coop_ga.control import Configuration, SimilarityTask, displaced_target, gauss_newton_ik, ilqr_reach, solve_step
from coop_ga.control.limits import default_limits
from coop_ga.geometry.similarity import primitive_parameters
from coop_ga.harness import Experiment, write_json

TARGET = {"translation": (0.05, -0.03, 0.04), "axis": (1, 1, 0), "angle": 0.3, "scale": 1.15}
DT = 0.01
GAIN = 5.0  # coop_ga's [1/s]; pink's α = GAIN · DT (no limit binds in the step at this gain)


def _row(anchor: str, what: str, agreement: float | None, unit: str, coop: Any, other: Any, note: str = "") -> dict:
    """One table row: ``coop``/``other`` are the two sides' times [µs] or ``(count, time_s)`` of a solve."""
    row: dict[str, Any] = {"anchor": anchor, "what": what, "agreement": agreement, "unit": unit, "note": note}
    if isinstance(coop, tuple):
        row.update(coop_steps=coop[0], other_steps=other[0], coop_s=coop[1], other_s=other[1], ratio=coop[1] / other[1])
    elif coop is not None:
        row.update(coop_us=coop, other_us=other, ratio=coop / other)
    return row


def _skip(anchor: str, what: str, reason: str) -> dict:
    return {"anchor": anchor, "what": what, "agreement": None, "unit": "", "note": f"skipped: {reason}"}


def circle_difference(task: Any, q1: Any, q2: Any) -> float:
    """The largest difference of the circles of ``task`` at q1 and q2: center [m], radius [m], normal."""
    _, c1, r1, n1 = primitive_parameters(task.primitive(q1))
    _, c2, r2, n2 = primitive_parameters(task.primitive(q2))
    diffs = (np.asarray(c1) - np.asarray(c2), [float(r1) - float(r2)], np.asarray(n1) - np.asarray(n2))
    return float(max(np.abs(d).max() for d in diffs))


def pinocchio_rows(task: Any, rng: np.random.Generator, min_time: float) -> list[dict]:
    """coop_ga's end points against Pinocchio's frame placements (FK anchor)."""
    import pinocchio as pin

    model = task.system.model
    data = model.createData()
    ids = [model.getFrameId(f) for f in task.end_frames]
    lim = task.system.limits
    worst = 0.0
    for _ in range(20):
        q = rng.uniform(lim.lower, lim.upper)
        pin.framesForwardKinematics(model, data, q)
        ref = np.array([data.oMf[i].translation for i in ids])
        worst = max(worst, float(np.abs(task.points(q) - ref).max()))
    q0 = np.asarray(task.system.q0, dtype=float)
    t_coop = per_call_us(lambda: task.evaluate(q0), min_time)
    t_pin = per_call_us(lambda: pin.framesForwardKinematics(model, data, q0), min_time)
    note = "coop_ga: points + V_Sc + J^G in one compiled call; Pinocchio: FK of every frame"
    return [_row("Pinocchio", "end points (FK)", worst, "m", t_coop, t_pin, note)]


def _pink_step(task: Any, q0: np.ndarray, target: Any, min_time: float) -> dict:
    import pink
    from pink.limits import ConfigurationLimit, VelocityLimit

    from coop_ga.adapters.pink import pink_configuration, similarity_task

    cfg = Configuration(task, q0)
    sim = SimilarityTask(target, gain=GAIN, jacobian="exact")  # the adapter's default
    limits = default_limits(task.system.limits, acceleration=False)
    pcfg = pink_configuration(task, q0)
    psim = similarity_task(task, target, gain=GAIN * DT)
    plimits = [ConfigurationLimit(pcfg.model), VelocityLimit(pcfg.model)]

    def coop() -> np.ndarray:
        cfg.update(q0)
        return solve_step(cfg, [sim], limits, DT, damping=1e-6).velocity

    def other() -> np.ndarray:
        pcfg.update(q0)
        return pink.solve_ik(pcfg, [psim], DT, solver="daqp", damping=1e-12, limits=plimits)

    agree = float(np.abs(coop() - other()).max())
    note = "same task (error, Jacobian), position and velocity limits; QP: coop_ga's vs pink's (DAQP)"
    return _row("pink", "diff-IK step", agree, "rad/s", per_call_us(coop, min_time), per_call_us(other, min_time), note)


def _pink_converge(task: Any, q0: np.ndarray, target: Any) -> dict:
    import pink
    from pink.limits import ConfigurationLimit, VelocityLimit
    from pink.tasks import PostureTask

    from coop_ga.adapters.pink import pink_configuration, similarity_task

    gauss_newton_ik(task, q0, target)  # warm-up
    t = time.process_time()
    gn = gauss_newton_ik(task, q0, target)
    t_gn = time.process_time() - t
    t = time.process_time()
    cfg = pink_configuration(task, q0)
    sim = similarity_task(task, target)
    posture = PostureTask(cost=1e-6)  # a small pull to q0 in the redundant directions
    posture.set_target(q0)
    limits = [ConfigurationLimit(cfg.model), VelocityLimit(cfg.model)]
    steps = 0
    while steps < 200 and np.linalg.norm(sim.compute_error(cfg)) >= 1e-10:
        v = pink.solve_ik(cfg, [sim, posture], DT, solver="daqp", damping=1e-12, limits=limits)
        cfg.update(cfg.integrate(v, DT))
        steps += 1
    t_pink = time.process_time() - t
    ok = gn.converged and np.linalg.norm(sim.compute_error(cfg)) < 1e-10
    note = f"coop_ga: gauss_newton_ik; pink: solve_ik loop (α = 1, posture task){'' if ok else ' — NOT CONVERGED'}"
    agree = circle_difference(task, cfg.q, gn.q)
    return _row("pink", "steps to converge", agree, "m", (gn.iterations, t_gn), (steps, t_pink), note)


def pink_rows(task: Any, q0: np.ndarray, target: Any, min_time: float) -> list[dict]:
    """coop_ga's differential IK against pink's (through coop_ga.adapters.pink)."""
    try:
        importlib.import_module("pink")
    except ImportError as exc:
        return [_skip("pink", "diff-IK", f"pink not installed ({exc}): pip install coop_ga[adapters]")]
    return [_pink_step(task, q0, target, min_time), _pink_converge(task, q0, target)]


def _crocoddyl_reason() -> str | None:
    """Why the crocoddyl row cannot run here, or None."""
    import pinocchio as pin

    try:
        importlib.import_module("crocoddyl")
    except ImportError:
        return f"not installed: needs pin 4.0.0 (this environment has pin {pin.__version__}); pip install coop_ga[crocoddyl]"
    if not pin.__version__.startswith("4.0."):
        return (
            f"crocoddyl 3.2.1 with pin {pin.__version__}: wrong free dynamics and crashing frame costs; needs pin 4.0.0"
        )
    return None


def crocoddyl_rows(task: Any, q0: np.ndarray, target: Any) -> list[dict]:
    """The same reach by coop_ga's iLQR and crocoddyl's BoxFDDP (through coop_ga.adapters.crocoddyl)."""
    reason = _crocoddyl_reason()
    if reason is not None:
        return [_skip("crocoddyl", "reach (OCP)", reason)]
    import crocoddyl

    from coop_ga.adapters.crocoddyl import reach_problem

    ilqr_reach(task, q0, target)  # warm-up (compiles the task's functions)
    t = time.process_time()
    r = ilqr_reach(task, q0, target)
    t_ilqr = time.process_time() - t
    problem = reach_problem(task, q0, target)
    solver = crocoddyl.SolverBoxFDDP(problem)
    xs, us = [problem.x0] * (problem.T + 1), problem.quasiStatic([problem.x0] * problem.T)
    t = time.process_time()
    solver.solve(xs, us, 200)
    t_croc = time.process_time() - t
    qn = np.asarray(solver.xs[-1])[: task.nq]
    e_croc = float(np.linalg.norm(task.error(qn, target)))
    note = (
        f"‖e‖: iLQR {r.error:.1e}, BoxFDDP {e_croc:.1e}; iLQR: double integrator 250 × 0.01 s; "
        f"BoxFDDP: rigid-body dynamics {problem.T} × {problem.runningModels[0].dt} s"
    )
    return [
        _row(
            "crocoddyl",
            "reach (OCP)",
            circle_difference(task, qn, r.q),
            "m",
            (r.iterations, t_ilqr),
            (solver.iter, t_croc),
            note,
        )
    ]


def _pygafro_circle(pg: Any, rng: np.random.Generator, min_time: float) -> dict:
    from coop_ga.geometry.primitives import circle

    worst = 0.0
    for _ in range(50):
        a, b, c = rng.uniform(-1.0, 1.0, (3, 3))
        C = pg.Circle(pg.Point(*a), pg.Point(*b), pg.Point(*c))
        P = C.getCenter()
        center = np.array([P.get_e1(), P.get_e2(), P.get_e3()]) / P.get_e0()
        _, c_ref, r_ref, _ = primitive_parameters(circle(a, b, c))
        worst = max(worst, float(np.abs(center - c_ref).max()), abs(C.getRadius() - float(r_ref)))
    a, b, c = rng.uniform(-1.0, 1.0, (3, 3))
    t_coop = per_call_us(lambda: primitive_parameters(circle(a, b, c)), min_time)
    t_gafro = per_call_us(lambda: pg.Circle(pg.Point(*a), pg.Point(*b), pg.Point(*c)).getRadius(), min_time)
    note = "circle through 3 points: center and radius (coop_ga: Python multivectors; gafro: C++)"
    return _row("pygafro", "circle primitive", worst, "m", t_coop, t_gafro, note)


def _pygafro_fk(pg: Any, rng: np.random.Generator, min_time: float) -> dict:
    import pinocchio as pin
    from motor_fk import motor_to_h

    from coop_ga.kinematics.chains import KinematicTree
    from coop_ga.systems.library import _panda_arm

    model = _panda_arm()[0]
    data, fid = model.createData(), model.getFrameId("panda_hand_tcp")
    tree, robot = KinematicTree(model, ["panda_hand_tcp"]), pg.FrankaEmikaRobot()
    worst = 0.0
    for _ in range(20):
        q = rng.uniform(model.lowerPositionLimit, model.upperPositionLimit)
        pin.framesForwardKinematics(model, data, q)
        ref = data.oMf[fid].homogeneous
        H_gafro = np.asarray(robot.getEEMotor(q).toTransformationMatrix())
        H_coop = motor_to_h(tree.frame_motors(q)[0])
        worst = max(worst, float(np.abs(H_gafro - ref).max()), float(np.abs(H_coop - ref).max()))
    q = np.asarray(model.lowerPositionLimit + model.upperPositionLimit) / 2
    t_coop = per_call_us(lambda: tree.frame_motors(q), min_time)
    t_gafro = per_call_us(lambda: robot.getEEMotor(q), min_time)
    note = "Franka TCP motor, both against Pinocchio's panda_hand_tcp (coop_ga: Python multivectors; gafro: C++)"
    return _row("pygafro", "motor FK (Franka)", worst, "m | 1", t_coop, t_gafro, note)


def pygafro_rows(rng: np.random.Generator, min_time: float) -> list[dict]:
    """coop_ga's primitives and motor FK against gafro's (pygafro, the authors' C++ library's bindings)."""
    try:
        pg = importlib.import_module("pygafro")
    except ImportError as exc:
        return [_skip("pygafro", "primitives, motor FK", f"pygafro not installed ({exc}): pip install pygafro")]
    rows = [_pygafro_circle(pg, rng, min_time), _pygafro_fk(pg, rng, min_time)]
    if not hasattr(pg, "CooperativeDualTaskSpace"):
        rows.append(_skip("pygafro", "cooperative Jacobian", "gafro's CooperativeDualTaskSpace is not in pygafro"))
    return rows


def _fmt(row: dict) -> list[str]:
    agree = "—" if row["agreement"] is None else f"{row['agreement']:.1e} {row['unit']}"
    if "coop_s" in row:
        cost = f"{row['coop_steps']} / {row['other_steps']} steps, {1e3 * row['coop_s']:.1f} / {1e3 * row['other_s']:.1f} ms CPU"
    elif "coop_us" in row:
        cost = f"{row['coop_us']:.1f} / {row['other_us']:.1f} µs"
    else:
        cost = "—"
    ratio = f"{row['ratio']:.2f}" if "ratio" in row else "—"
    return [row["anchor"], row["what"], agree, cost, ratio, row["note"]]


def main(argv: list[str] | None = None) -> int:
    """Run every anchor, print the table, write ``<out>/results.json``."""
    exp = Experiment(__file__, __doc__, seed=0, out="results/benchmarks/anchors")
    exp.add("--ci", action="store_true", help="time fewer calls (a quick check that every row runs)")
    args = exp.parse(argv)
    min_time = 0.02 if args.ci else 0.2
    import pinocchio as pin

    task = cg.cooperative_task(cg.systems.load("three_franka"), "circle")
    q0 = np.asarray(task.system.q0, dtype=float)
    target = displaced_target(task, q0, **TARGET)
    rng = exp.rng
    rows = pinocchio_rows(task, rng, min_time)
    rows += pink_rows(task, q0, target, min_time)
    rows += crocoddyl_rows(task, q0, target)
    rows += pygafro_rows(rng, min_time)
    if not exp.quiet:
        header = ["anchor", "what", "agreement", "coop_ga / other", "ratio", "note"]
        print_table(f"coop_ga against its anchors (pin {pin.__version__})", header, [_fmt(r) for r in rows])
    write_json(exp.out / "results.json", {"pin": pin.__version__, "rows": rows})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
