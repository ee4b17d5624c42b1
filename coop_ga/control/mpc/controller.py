"""The receding-horizon controller: :class:`CooperativeMPC` (its tick and its safety filter) and their outputs."""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ... import validation
from ...diagnostics import warn
from ...errors import InfeasibleConstraintsError, RateWarning
from ..avoidance import ClearanceCost
from ..base import resolve_options
from ..configuration import Configuration
from ..ilqr import RecedingReach
from ..limits import default_limits
from ..limits.clearance import distances
from ..solve import active_labels, solve_step
from ..tasks import JointVelocityTask
from .obstacles import MovingClearanceLimit, MovingSphere, ObstacleWorld
from .options import MPCOptions
from .target import TargetSchedule

__all__ = ["CooperativeMPC", "FilterStep", "MPCInfeasibleError", "MPCTick"]

#: a state this far outside a position or velocity limit [rad, rad/s] is infeasible (the iLQR refuses a start beyond 1e-9)
STATE_TOL = 1e-9


@dataclass(frozen=True)
class MPCTick:
    """One MPC tick at ``time`` [s] from the measured (q, q̇).

    acceleration: (nv,) the plan's first control u_0 [rad/s²]; torque: (nv,) RNEA(q, q̇, u_0) [N m] (Pinocchio).
    plan_t (n+1,) [s, absolute], plan_q (n+1, nq), plan_qd (n+1, nv), plan_u (n, nv): the plan (double integrator,
    Eq 54; nv = nq without a free flyer, else the plan of the iLQR's chart re-centred at the measured q,
    :mod:`coop_ga.control.ilqr.chart`: plan_qd the tangent velocities, plan_u the chart's accelerations, u_0 the
    flyer's twist rate).
    tick_time: wall time of the whole tick [s]; solve_time: the iLQR's own solve time [s]; iterations: iLQR
    iterations; violation: the plan's largest bound violation [rad, rad/s, rad/s²] (0 by construction of the
    iLQR's feasibility blend); min_clearance: the plan's smallest clearance by the collision model at the
    obstacles' current poses [m]; error: ‖e(q; V_d(t))‖ now (Eq 44, the 7-vector norm); terminal_error:
    ‖e(q_n; V_d(t + n·dt))‖ of the plan; overrun: tick_time exceeded the budget.
    """

    time: float
    acceleration: np.ndarray
    torque: np.ndarray
    plan_t: np.ndarray
    plan_q: np.ndarray
    plan_qd: np.ndarray
    plan_u: np.ndarray
    tick_time: float
    solve_time: float
    iterations: int
    violation: float
    min_clearance: float
    error: float
    terminal_error: float
    overrun: bool


@dataclass(frozen=True)
class FilterStep:
    """One step of the safety layer at ``time`` [s].

    velocity: (nq,) the safe joint velocity for the next ``filter_dt`` [rad/s]; acceleration: (nq,)
    ``(velocity − q̇)/filter_dt`` [rad/s²]; desired: (nq,) the plan's velocity with feedback [rad/s];
    active: the limits and clearance rows active in the QP; min_clearance: the smallest clearance now [m];
    step_time: wall time [s].
    """

    time: float
    velocity: np.ndarray
    acceleration: np.ndarray
    desired: np.ndarray
    active: tuple[str, ...]
    min_clearance: float
    step_time: float


class MPCInfeasibleError(InfeasibleConstraintsError):
    """No command satisfies the constraints at the current state (a joint outside its position or velocity
    limit, a penetrating pair, or a safety QP without a feasible point).

    Attributes: ``active`` (the violated / active constraints, by name), ``fallback_acceleration`` (nq,)
    [rad/s²] and ``fallback_torque`` (nq,) [N m]: braking to rest within the acceleration limits — the command
    to apply instead.
    """

    def __init__(self, message: str, active: Sequence[str], acceleration: np.ndarray, torque: np.ndarray):
        super().__init__(message)
        self.active = tuple(active)
        self.fallback_acceleration = acceleration
        self.fallback_torque = torque


class CooperativeMPC:
    """Receding-horizon control of a cooperative primitive with limits and clearance (:mod:`coop_ga.control.mpc`).

    Args:
        task: a :class:`~coop_ga.CooperativeTask`.
        target: V_d(t): a callable ``t -> Similarity`` or a reference ``(times, poses)`` (:class:`TargetSchedule`).
        options: :class:`MPCOptions`; keyword ``overrides`` replace its fields.
        obstacles: :class:`MovingSphere` s (world frame).
        self_collision: include the arm–arm (capsule–capsule) pairs of the collision model.

    Use: :meth:`tick` every ``period`` (the plan), :meth:`filter` every ``filter_dt`` (the safe velocity that
    follows the plan), and a joint-level tracking loop in between (e.g. :mod:`coop_ga.sim.mpc_track`).
    """

    def __init__(
        self,
        task: Any,
        target: Any,
        options: MPCOptions | None = None,
        *,
        obstacles: Sequence[MovingSphere] = (),
        self_collision: bool = True,
        **overrides: Any,
    ):
        self.o = o = resolve_options(MPCOptions, options, overrides, "CooperativeMPC")
        self.task = task
        self.nq = int(task.nq)
        #: velocities (nv = nq, or nq − 1 with a free flyer: q̇, the plan's velocities and accelerations have nv)
        self.nv = int(getattr(task, "nv", task.nq))
        self.system = task.system
        self.target = TargetSchedule(target, task)
        self.world = ObstacleWorld(task.system, obstacles, self_collision=self_collision)
        self.lim = task.system.limits
        clear = MovingClearanceLimit(
            self.world, o.filter_dt, d_safe=o.d_safe, d_influence=o.d_influence, damper_gain=o.damper_gain
        )
        self.limits = [*default_limits(self.lim, o.limit_gain), *([clear] if o.avoid else [])]
        self.clearance_cost = (
            ClearanceCost(self.world.model, o.clearance_weight, o.clearance_activation) if o.clearance_weight else None
        )
        self.configuration = Configuration(task, task.system.q0)
        # the inner problem, set up once: the cold (first) tick and the warm ones differ only in their budget
        common = dict(horizon=o.horizon, dt=o.dt, R=o.R, Q=o.Q, Qv=o.Qv, terminal=o.terminal, hessian=o.hessian,
                      restart=False, clearance=self.clearance_cost)  # fmt: skip
        self._cold = RecedingReach(task, max_iter=o.first_iter, **common)
        self._warm = RecedingReach(task, max_iter=o.max_iter, **common)
        self._pin_model = task.system.model
        self._pin_data = self._pin_model.createData()
        self.plan: MPCTick | None = None
        self._placed_at: float | None = None  # the time [s] of the configuration's (q, q̇) (_place)
        self.ticks = 0
        self.overruns = 0
        self._warned = False

    # ------------------------------------------------------------------ commands
    def torque(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """``τ = M(q) q̈ + C(q, q̇) q̇ + g(q)`` (nq,) [N m] by Pinocchio's RNEA (Eq 32)."""
        import pinocchio as pin

        return np.array(pin.rnea(self._pin_model, self._pin_data, q, qd, qdd))

    def brake(self, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The fallback: ``q̈ = clip(−q̇/filter_dt, ±a_max)`` (to rest as fast as the acceleration limits allow)
        and its torque."""
        a = np.clip(-qd / self.o.filter_dt, -self.lim.acceleration, self.lim.acceleration)
        return a, self.torque(q, qd, a)

    def _state(self, q: Any, qd: Any) -> tuple[np.ndarray, np.ndarray]:
        qv = validation.configuration(q, self.nq, "q", owner=f"task '{self.task.name}'")
        qdv = validation.configuration(qd, self.nv, "qd", owner=f"task '{self.task.name}'")
        if self.nq != self.nv:
            self.system.check_quaternions(qv, "q")
        return qv, qdv

    def _infeasible(self, q: np.ndarray, qd: np.ndarray, why: str, active: Sequence[str]) -> MPCInfeasibleError:
        a, tau = self.brake(q, qd)
        return MPCInfeasibleError(
            f"{why}: {', '.join(active) or 'no constraint named'}; apply the fallback (braking within the "
            "acceleration limits: error.fallback_torque) and restart the controller from a feasible state",
            active,
            a,
            tau,
        )

    def _place(self, t: float, q: np.ndarray, qd: np.ndarray) -> None:
        """Move the obstacles to t and the configuration to (q, q̇), unless they are there already: the
        configuration caches the collision model's distances and Jacobian, so the model is evaluated once per
        (t, q, q̇) — the state's check, the safety step's clearance rows and their obstacle rates share it, and so
        do a tick and the safety step at the same instant (the closed loop's tick instants)."""
        conf = self.configuration
        placed = self._placed_at == t == self.world.time
        if not (placed and np.array_equal(conf.q, q) and np.array_equal(conf.velocity, qd)):
            self.world.at(t)
            conf.update(q, qd)
            self._placed_at = float(t)

    def _distances(self) -> np.ndarray:
        """The collision model's distances (n,) [m] at the placed configuration (:meth:`_place`)."""
        return distances(self.world.model, self.configuration)[0]

    def check_state(self, q: np.ndarray, qd: np.ndarray, d: np.ndarray | None = None) -> None:
        """Raise :class:`MPCInfeasibleError` (with the violated constraints) if (q, q̇) is outside a position or
        velocity limit or (with ``avoid``) a pair of the collision model penetrates (clearance < 0); ``d`` (n,)
        [m]: the collision model's distances at q with the obstacles placed now, if already known."""
        lim, names = self.lim, self.lim.joint_names
        x = q if self.nq == self.nv else self.system.limit_coordinates(q)  # the bounded coordinates, in q̇ order
        active = [f"{names[i]} (lower position limit)" for i in np.flatnonzero(x < lim.lower - STATE_TOL)]
        active += [f"{names[i]} (upper position limit)" for i in np.flatnonzero(x > lim.upper + STATE_TOL)]
        active += [f"{names[i]} (velocity limit)" for i in np.flatnonzero(np.abs(qd) > lim.velocity + STATE_TOL)]
        if self.o.avoid:
            d = self.world.model.distances(q) if d is None else d
            active += [f"clearance of {self.world.model.labels[k]} ({d[k]:.4f} m)" for k in np.flatnonzero(d < 0.0)]
        if active:
            raise self._infeasible(q, qd, "infeasible constraints at the current state", active)

    # ------------------------------------------------------------------ the MPC tick
    def _warm_start(self) -> np.ndarray | None:
        """The previous plan's controls shifted by ``period / dt`` knots, the last one repeated (with a free flyer,
        accelerations of the previous plan's chart: a guess for the chart re-centred at the new state)."""
        if self.plan is None:
            return None
        m, u = self.o.shift, self.plan.plan_u
        return np.vstack([u[m:], np.repeat(u[-1:], m, axis=0)])

    def tick(self, t: float, q: Any, qd: Any) -> MPCTick:
        """Re-plan from the measured state at time t [s] (module docstring of :mod:`coop_ga.control.mpc`).

        Raises:
            MPCInfeasibleError: the state is infeasible (:meth:`check_state`), with the fallback command.
            InvalidInputError / NonFiniteError: a bad q, q̇ or target value (naming the time).
        """
        t0 = time.perf_counter()
        o = self.o
        qv, qdv = self._state(q, qd)
        t = validation.scalar(t, "t")
        self._place(t, qv, qdv)
        self.check_state(qv, qdv, self._distances() if o.avoid else None)
        V_now, V_end = self.target(t), self.target(t + o.lookahead)
        solver = self._warm if self.plan is not None else self._cold
        res = solver.solve(qv, V_end, qd_init=qdv, u_init=self._warm_start())
        u0 = np.array(res.u[0])
        tau = self.torque(qv, qdv, u0)
        err = float(np.linalg.norm(self.task.error(qv, V_now)))
        wall = time.perf_counter() - t0
        overrun = wall > o.budget
        self._count(wall, overrun)
        viol = max(res.joint_limit_violation, res.velocity_violation, res.acceleration_violation)
        self.plan = MPCTick(
            time=t,
            acceleration=u0,
            torque=tau,
            plan_t=t + np.asarray(res.t),
            plan_q=np.asarray(res.trajectory),
            plan_qd=np.asarray(res.qd),
            plan_u=np.asarray(res.u),
            tick_time=wall,
            solve_time=float(res.solve_time_s),
            iterations=int(res.iterations),
            violation=float(viol),
            min_clearance=float(res.min_clearance),
            error=err,
            terminal_error=float(res.error),
            overrun=overrun,
        )
        return self.plan

    def _count(self, wall: float, overrun: bool) -> None:
        self.ticks += 1
        if not overrun:
            return
        self.overruns += 1
        if not self._warned:
            self._warned = True
            warn(
                f"an MPC tick took {1e3 * wall:.1f} ms, more than its budget of {1e3 * self.o.budget:.1f} ms (period "
                f"{1e3 * self.o.period:.1f} ms): this horizon/rate is not sustained here; every tick is still solved "
                "(counted in .overruns) — lengthen the period, shorten the horizon or lower max_iter",
                RateWarning,
            )

    # ------------------------------------------------------------------ the safety layer
    def sample_plan(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(q (nq,), q̇ (nv,)) of the current plan at time t [s] (exact double-integrator between knots; held after
        the last knot at its velocity).  With a free flyer q moves from the knot by ``integrate(q_k, τ q̇_k + ½τ²u_k)``
        (the plan's own chart, :mod:`coop_ga.control.ilqr.chart`, agrees with it to second order in τ)."""
        p = self.plan
        if p is None:
            raise InfeasibleConstraintsError("no plan yet: call tick() before filter()")
        dt = self.o.dt
        s = max(0.0, t - p.plan_t[0])
        k = min(int(s // dt), len(p.plan_u) - 1)
        tau = s - k * dt
        u = p.plan_u[k]
        if self.nq != self.nv:
            return self.system.integrate(p.plan_q[k], tau * p.plan_qd[k] + 0.5 * tau * tau * u), p.plan_qd[k] + tau * u
        return p.plan_q[k] + tau * p.plan_qd[k] + 0.5 * tau * tau * u, p.plan_qd[k] + tau * u

    def filter(self, t: float, q: Any, qd: Any) -> FilterStep:
        """The safe joint velocity for the next ``filter_dt``: the plan's velocity at ``t + filter_dt`` plus
        feedback to the plan, through the QP of :func:`~coop_ga.control.solve.solve_step` with the position,
        velocity and acceleration limits and the clearance rows (A1') of the moving obstacles.

        Raises:
            MPCInfeasibleError: the state is infeasible, or the QP has no feasible point (the rows named).
        """
        t0 = time.perf_counter()
        o = self.o
        qv, qdv = self._state(q, qd)
        self._place(t, qv, qdv)
        conf, d = self.configuration, self._distances()
        self.check_state(qv, qdv, d)
        q_p, _ = self.sample_plan(t)
        _, qd_p = self.sample_plan(t + o.filter_dt)
        desired = qd_p + o.feedback * (q_p - qv if self.nq == self.nv else self.system.difference(qv, q_p))
        try:
            step = solve_step(conf, [JointVelocityTask(desired)], self.limits, o.filter_dt)
        except InfeasibleConstraintsError as exc:
            near = [f"clearance of {self.world.model.labels[k]}" for k in np.flatnonzero(d < o.d_influence)]
            raise self._infeasible(qv, qdv, f"the safety QP is infeasible ({exc})", near) from exc
        v = np.array(step.velocity)
        return FilterStep(
            float(t),
            v,
            (v - qdv) / o.filter_dt,
            desired,
            active_labels(step, conf),
            float(d.min(initial=np.inf)),
            time.perf_counter() - t0,
        )
