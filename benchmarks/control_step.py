"""Time per differential-IK step: Configuration + solve_step against the former diff_ik_step and pink.

    python benchmarks/control_step.py [--steps 300] [--rounds 5] [--ci] [--out results/benchmarks/control_step]

On ``three_franka`` (21 joints, a cooperative circle), every candidate runs the same closed loop of
``--steps`` steps of Δt = 0.01 s towards a target 5 cm / 11° / 10 % away, from rest, and the time per
step is the median over ``--rounds`` interleaved rounds (the candidates alternate, so a slower or
busier machine affects them alike; only the ratios, all from one run, are reported as results):

* ``new``: one step of the control layer — ``Configuration.update(q, q̇)``, :func:`~coop_ga.control.solve_step`
  with a :class:`~coop_ga.control.tasks.SimilarityTask` (error and Jacobian from one compiled evaluation) and
  the position, velocity and acceleration limits of :func:`~coop_ga.control.limits.default_limits` (the
  default of :func:`~coop_ga.control.diff_ik_reach`), then ``q + Δt q̇`` (Eq 48, 53, 61);
* ``new_pv``: the same with the position and velocity limits only — the limits of ``old`` and ``pink``; its
  trajectory is ``old``'s to rounding, so the two solve the same number of QPs and their ratio is the cost of
  the layer itself (the acceptance ratio).  ``new`` solves more QPs than ``old`` (the acceleration bounds
  are active while the arms speed up: counted and printed), which is the price of the acceleration limits;
* ``old``: the anchor, a copy of the former ``coop_ga.control.diff_ik_step`` (``git show
  0f43cc0:coop_ga/control/diffik.py``, kept below as :func:`old_diff_ik_step`: input checks, projection
  into the limits, one compiled evaluation of J^G, the damped pseudo-inverse and the position ∩ velocity
  QP of the time) given the command ``B = gain · e`` — the error ``e`` is computed outside its timing, so the
  anchor does less work than ``new`` (which computes e in its one evaluation);
* ``old_reach``: the former reaching loop's step, ``task.error`` (a second compiled call) + the anchor;
* ``pink``: ``pink.solve_ik`` (stephane-caron/pink, ``pin-pink`` on PyPI) with three position-only
  ``FrameTask`` s on the three TCPs (targets 5 cm away), its ``ConfigurationLimit`` and ``VelocityLimit``
  and the QP solver DAQP through qpsolvers (the solver ``new`` uses through CasADi), then
  ``pinocchio.integrate`` and ``Configuration.update`` (pink's forward kinematics and Jacobians).

Acceptance: new_pv / old ≤ 1.0 and new_pv / pink ≤ 0.8 (same limits; new / old and new / pink are
printed too).  ``--ci``: fewer steps and rounds (the
test only checks that it runs and reports the ratios; no timing is asserted in tests).
``<out>/results.json`` holds the times and ratios.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable
from typing import Any

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from _timing import print_table

import coop_ga as cg
from coop_ga.control import Configuration, SimilarityTask, default_limits, displaced_target, solve_step
from coop_ga.control.qp import (
    DEFAULT_LIMIT_GAIN,
    QPSolution,
    limit_arrays,
    project_into_limits,
    solve_qp,
    stack_constraints,
    velocity_bounds,
)
from coop_ga.cooperative.manipulability import damped_pinv
from coop_ga.harness import Experiment, int_at_least
from coop_ga.validation import choice, nonnegative, positive, vector

DT = 0.01
GAIN = 10.0


# ----------------------------------------------------------------------------- the anchor (former code)
def _old_velocity(
    task: Any, q: np.ndarray, J: np.ndarray, b: np.ndarray, dt: float, damping: float, gain: float
) -> QPSolution:
    x_free = damped_pinv(J, damping) @ b
    lower, upper, vel = limit_arrays(task)
    lb, ub = velocity_bounds(q, lower, upper, vel, dt, gain)
    return solve_qp(J, b, damping, lb, ub, None, None, x_free=x_free, labels=(), what="differential IK step")


def old_diff_ik_step(
    task: Any, q: Any, command_bivector: Any, dt: float = 0.01, damping: float = 1e-3, limit_mode: str = "enforce"
) -> np.ndarray:
    """The former ``diff_ik_step`` (limit_mode='enforce', no constraints), as it was before the control layer."""
    choice(limit_mode, ("enforce", "clamp", "none"), "limit_mode")
    dt = positive(dt, "dt")
    damping = nonnegative(damping, "damping")
    q = cg.validation.configuration(q, task.nq, "q", owner=f"task '{task.name}'")
    b = vector(command_bivector, 7, "command_bivector")
    stack_constraints(None, task.nq)
    q = project_into_limits(task, q)
    J = task.evaluate_views(q)[2]
    sol = _old_velocity(task, q, J, b, dt, damping, DEFAULT_LIMIT_GAIN)
    q_next = q + dt * sol.x
    lower, upper, _ = limit_arrays(task)
    np.clip(q_next, lower, upper, out=q_next)
    return q_next


# ----------------------------------------------------------------------------- the candidates
def _loop_new(task: Any, q0: np.ndarray, target: Any, steps: int, accel: bool = True) -> Callable[[], np.ndarray]:
    limits = default_limits(task.system.limits, acceleration=accel)
    sim = SimilarityTask(target, gain=GAIN)
    cfg = Configuration(task, q0)
    lo, hi = task.system.limits.lower, task.system.limits.upper

    def run() -> np.ndarray:
        cfg.update(q0)
        q = q0
        for _ in range(steps):
            st = solve_step(cfg, [sim], limits, DT, damping=1e-3)
            q_next = np.clip(q + DT * st.velocity, lo, hi)
            cfg.update(q_next, (q_next - q) / DT)
            q = q_next
        return q

    return run


def _loop_old(task: Any, q0: np.ndarray, target: Any, steps: int, commands: list[np.ndarray]) -> Callable[[], Any]:
    def run() -> np.ndarray:
        q = q0
        for k in range(steps):
            q = old_diff_ik_step(task, q, commands[k], DT, 1e-3)
        return q

    return run


def _loop_old_reach(task: Any, q0: np.ndarray, target: Any, steps: int) -> Callable[[], np.ndarray]:
    def run() -> np.ndarray:
        q = q0
        for _ in range(steps):
            q = old_diff_ik_step(task, q, GAIN * task.error(q, target), DT, 1e-3)
        return q

    return run


def _loop_pink(system: Any, q0: np.ndarray, targets: np.ndarray, steps: int) -> Callable[[], np.ndarray] | None:
    try:
        import pink
        import pinocchio as pin
        from pink.limits import ConfigurationLimit, VelocityLimit
        from pink.tasks import FrameTask
    except ImportError as exc:  # pink is optional: the benchmark reports it
        print(f"pink is not available ({exc}): pip install pin-pink daqp")
        return None
    model = system.model
    cfg = pink.Configuration(model, model.createData(), q0)
    tasks = []
    for frame, p in zip(system.end_frames, targets):
        t = FrameTask(frame, position_cost=1.0, orientation_cost=0.0, gain=GAIN * DT)
        T = cfg.get_transform_frame_to_world(frame).copy()
        T.translation = p
        t.set_target(T)
        tasks.append(t)
    limits = [ConfigurationLimit(model, DEFAULT_LIMIT_GAIN), VelocityLimit(model)]

    def run() -> np.ndarray:
        q = q0.copy()
        cfg.update(q)
        for _ in range(steps):
            v = pink.solve_ik(cfg, tasks, DT, solver="daqp", limits=limits)
            q = pin.integrate(model, q, v * DT)
            cfg.update(q)
        return q

    return run


def _qp_steps(task: Any, q0: np.ndarray, target: Any, steps: int) -> dict[str, int]:
    """Steps on which a QP was solved (a bound active) along each candidate's loop (pink solves one every step)."""
    out: dict[str, int] = {}
    lo, hi = task.system.limits.lower, task.system.limits.upper
    for name, accel in (("new", True), ("new_pv", False)):
        limits = default_limits(task.system.limits, acceleration=accel)
        cfg, sim, q, n = Configuration(task, q0), SimilarityTask(target, gain=GAIN), q0, 0
        for _ in range(steps):
            st = solve_step(cfg, [sim], limits, DT, damping=1e-3)
            n += st.used_qp
            q_next = np.clip(q + DT * st.velocity, lo, hi)
            cfg.update(q_next, (q_next - q) / DT)
            q = q_next
        out[name] = n
    q, n = q0, 0
    for _ in range(steps):
        J = task.evaluate_views(q)[2]
        sol = _old_velocity(task, q, J, GAIN * task.error(q, target), DT, 1e-3, DEFAULT_LIMIT_GAIN)
        n += sol.used_qp
        q = np.clip(q + DT * sol.x, lo, hi)
    out["old"] = out["old_reach"] = n
    return out


def _time(fn: Callable[[], Any], steps: int) -> float:
    t0 = time.perf_counter()
    fn()
    return (time.perf_counter() - t0) / steps * 1e6


def main(argv: list[str] | None = None) -> int:
    exp = Experiment(__file__, __doc__, seed=0)
    exp.add("--steps", type=int_at_least(10), default=300, help="steps per closed loop")
    exp.add("--rounds", type=int_at_least(1), default=5, help="interleaved rounds (median)")
    exp.add("--ci", action="store_true", help="60 steps × 3 rounds (CI: runs, reports; asserts no timing)")
    args = exp.parse(argv)
    steps, rounds = (60, 3) if args.ci else (args.steps, args.rounds)
    s = cg.systems.load("three_franka")
    task = cg.cooperative_task(s, "circle")
    q0 = np.array(s.q0, dtype=float)
    target = displaced_target(task, q0, translation=(0.05, 0.0, 0.03), axis=(1, 0, 0), angle=0.2, scale=1.1)
    # the anchor's commands: those of the former reaching loop (computed outside its timing)
    commands, q = [], q0
    for _ in range(steps):
        commands.append(GAIN * task.error(q, target))
        q = old_diff_ik_step(task, q, commands[-1], DT, 1e-3)
    pts = task.points(q0) + np.array([0.05, 0.0, 0.03])
    loops = {
        "new": _loop_new(task, q0, target, steps),
        "new_pv": _loop_new(task, q0, target, steps, accel=False),
        "old": _loop_old(task, q0, target, steps, commands),
        "old_reach": _loop_old_reach(task, q0, target, steps),
    }
    pink_loop = _loop_pink(s, q0, pts, steps)
    if pink_loop is not None:
        loops["pink"] = pink_loop
    for fn in loops.values():
        fn()  # warm-up: compiled functions, solver instances
    times: dict[str, list[float]] = {k: [] for k in loops}
    for _ in range(rounds):
        for k, fn in loops.items():
            times[k].append(_time(fn, steps))
    med = {k: float(np.median(v)) for k, v in times.items()}
    q_new, q_old = loops["new"](), loops["old_reach"]()
    e_new = float(np.linalg.norm(task.error(q_new, target)))
    e_old = float(np.linalg.norm(task.error(q_old, target)))
    ratios = {f"new/{k}": med["new"] / med[k] for k in med if k != "new"}
    ratios.update({f"new_pv/{k}": med["new_pv"] / med[k] for k in ("old", "old_reach", "pink") if k in med})
    qps = _qp_steps(task, q0, target, steps)
    rows = [[k, f"{med[k]:.1f}", f"{med['new_pv'] / med[k]:.2f}", str(qps.get(k, "all"))] for k in med]
    print_table(
        f"µs per differential-IK step, three_franka (21 joints), {steps} steps × {rounds} rounds, median",
        ["candidate", "µs/step", "new_pv / candidate", "steps with a QP"],
        rows,
    )
    print(f"final ‖e‖ after {steps} steps: new {e_new:.3g} (with acceleration limits), old {e_old:.3g}")
    for k, r in ratios.items():
        bound = {"new_pv/old": 1.0, "new_pv/pink": 0.8}.get(k)
        verdict = "" if bound is None else (" PASS" if r <= bound else " MISS") + f" (≤ {bound})"
        print(f"ratio {k} = {r:.2f}{verdict}")
    exp.write_json(
        "results.json",
        {
            "us_per_step": med,
            "rounds": times,
            "ratios": ratios,
            "steps": steps,
            "qp_steps": qps,
            "final_error": {"new": e_new, "old": e_old},
        },
        digits=4,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
