"""Constrained planning over cooperative regions with OMPL (the ``plan`` extra: ``pip install ompl``).

:func:`plan` plans a joint path from a start configuration to a goal :class:`~coop_ga.plan.regions.Region`
while an equality path constraint (e.g. the :class:`~coop_ga.plan.regions.RigidGrasp`) holds, inside the
joint limits, free of collisions — with OMPL's own pieces only:

* the path constraint is an ``ompl.base.Constraint`` whose ``function`` is the residual and whose
  ``jacobian`` is its exact Jacobian (:mod:`coop_ga.plan.regions`: the chain rule through the compiled J^G and
  Pinocchio's point Jacobians).  With ``jacobian="finite_difference"`` the Python subclass leaves
  ``jacobian`` to OMPL's default (central differences of ``function``, 2·nq calls) — the ablation;
* the state space is OMPL's ``ProjectedStateSpace`` (or ``AtlasStateSpace``) over a ``RealVectorStateSpace``
  whose bounds are the joint limits; OMPL projects samples and interpolates along the manifold (its discrete
  geodesic, steps of ``delta``), and its ``ConstrainedMotionValidator`` checks every step;
* the planner is OMPL's (``RRTConnect``, ``KPIECE1``, ``RRT``; the bindings of ``ompl`` 2.0.1 have no BiTRRT)
  through ``SimpleSetup``;
* validity (:class:`Validity`): the joint limits, :class:`~coop_ga.collision.CollisionModel` (self and obstacle
  clearances of the arms' capsules), the carried box's clearance (:class:`~coop_ga.plan.carried.CarriedBox`)
  and an optional inequality path region (e.g. the box upright within a cone);
* the goal: OMPL's ``GoalStates`` holding configurations sampled in the goal region and projected onto it
  together with the path constraint by the bounded Gauss–Newton of :func:`~coop_ga.plan.projection.project`
  (each checked valid).  The time they take counts in the planning time.  (``GoalLazySamples`` would sample
  in a second thread that calls back into Python; on the 2-core machine this only competes with the planner.)

Warnings of the library (a random state near a chart flip or a degeneracy) are silenced during the search:
such states are rejected, not news.  Every callback catches the library's errors: a degenerate primitive is an invalid state or a large residual,
never NaN and never an exception thrown through OMPL.  The returned path is interpolated at ``delta`` (the
collision-check resolution) and re-checked: ``max_violation`` is the worst residual along it and
``valid`` says every waypoint passed :class:`Validity`.

**A free flyer** (nq ≠ nv): OMPL's constrained spaces wrap a real-vector space only, so the quaternion is
embedded in the ambient R^nq and kept unit by one more equality row ``|quat|² − 1`` of the constraint
(:class:`_EmbeddedResidual`, its ambient Jacobian through ``pin.tangentMap``); the box of the ambient space is the
joints' limits, the flyer's position within ``window`` (at least 1 m) of the start and goals and [−1, 1] for the
quaternion; the kinematics, validity and the returned path see the quaternion normalised (OMPL keeps it unit
only to the constraint tolerance).  ``length`` sums the tangent steps (:meth:`~coop_ga.systems.System.distance`):
metres and radians of the flyer's LOCAL twist, never quaternion units.

OMPL's random generator is seeded once per process (``ompl.util.RNG.setSeed`` before its first use), and every
planner draws its own seed from that one sequence: a plan is reproducible given the plans made before it in the
process (OMPL cannot be re-seeded later), which is why ``python -m paper_figures`` runs each figure in its own
process.  The goal samples come from a numpy generator seeded per plan.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import validation
from ..diagnostics import collect_warnings
from ..errors import CoopGAError, InvalidInputError
from .projection import project

__all__ = ["PLANNERS", "PlanResult", "PlannerOptions", "PlanningProblem", "Validity", "plan", "seed_ompl"]

#: the OMPL geometric planners :func:`plan` accepts
PLANNERS = ("RRTConnect", "KPIECE1", "RRT")

#: residual reported by a constraint function where the primitive degenerates (a state far off the manifold)
_DEGENERATE_RESIDUAL = 1e3


def _ompl() -> tuple[Any, Any, Any]:
    """``(ompl.base, ompl.geometric, ompl.util)``, or a clear error naming the extra to install."""
    try:
        from ompl import base as ob  # type: ignore[import-untyped, import-not-found, unused-ignore]
        from ompl import geometric as og
        from ompl import util as ou
    except ImportError as exc:  # pragma: no cover - the extra is installed where this runs
        raise InvalidInputError(f"planning needs OMPL's Python bindings: pip install 'coop_ga[plan]' ({exc})") from None
    return ob, og, ou


_SEEDED: list[int] = []


def seed_ompl(seed: int) -> None:
    """Seed OMPL's random generators with ``seed + 1`` (OMPL refuses 0); effective once per process, before
    OMPL draws its first number."""
    _, _, ou = _ompl()
    if not _SEEDED:
        ou.setLogLevel(ou.LogLevel.LOG_WARN)
        ou.RNG.setSeed(int(seed) + 1)
        _SEEDED.append(int(seed))


@dataclass
class PlanningProblem:
    """What to plan (module docstring).

    Attributes:
        system: the :class:`~coop_ga.systems.System` (its limits bound q).
        q_start: (nq,) start configuration (on the path constraint, valid).
        path_constraint: an equality residual held along the path (``dim`` rows, e.g. a RigidGrasp).
        goal: the goal :class:`~coop_ga.plan.regions.Region`.
        collision: a :class:`~coop_ga.collision.CollisionModel` of the system (None: no arm clearance checks).
        carried: a :class:`~coop_ga.plan.carried.CarriedBox` held by the end points (None: nothing carried).
        path_region: an inequality :class:`~coop_ga.plan.regions.Region` held along the path (None: none).
        clearance: smallest clearance accepted [m] (arms and box).
    """

    system: Any
    q_start: np.ndarray
    path_constraint: Any
    goal: Any
    collision: Any = None
    carried: Any = None
    path_region: Any = None
    clearance: float = 0.0


@dataclass(frozen=True)
class PlannerOptions:
    """Settings of :func:`plan`.

    planner: one of :data:`PLANNERS`.  space: ``"projected"`` or ``"atlas"``.
    jacobian: ``"exact"`` or ``"finite_difference"`` (OMPL's default central differences; the ablation).
    time_limit: seconds for the whole plan (goal sampling + planning + simplification).
    delta: step of the manifold interpolation [rad] = the collision-check resolution.
    tolerance: the constraint's projection tolerance ‖r‖ (m, log-scale).
    goal_samples: goal configurations sampled before planning; goal_attempts: tries for them.
    simplify: shorten the path with OMPL's simplifier (``simplify_time`` seconds at most).
    range: the planner's maximum extension [rad] (0: OMPL's default).
    window: the state space's bounds are the joint limits intersected with the box spanned by the start and the
        goal configurations widened by ``window`` [rad] on every joint (inf: the joint limits).  Uniform samples
        of the whole joint box projected onto the manifold mostly land far from a local task (a 0.2 m lift moves
        each joint by < 0.5 rad of its 3–6 rad range); the window keeps OMPL's sampler where the task is.
        Validity still checks the joint limits themselves.
    seed: numpy seed of the goal samples.
    """

    planner: str = "RRTConnect"
    space: str = "projected"
    jacobian: str = "exact"
    time_limit: float = 10.0
    delta: float = 0.05
    tolerance: float = 1e-5
    goal_samples: int = 2
    goal_attempts: int = 30
    simplify: bool = True
    simplify_time: float = 2.0
    range: float = 0.0
    window: float = math.inf
    seed: int = 0

    def __post_init__(self) -> None:
        validation.choice(self.planner, PLANNERS, "planner")
        validation.choice(self.space, ("projected", "atlas"), "space")
        validation.choice(self.jacobian, ("exact", "finite_difference"), "jacobian")
        validation.positive(self.time_limit, "time_limit [s]")
        validation.positive(self.delta, "delta [rad]")
        validation.positive(self.tolerance, "tolerance")
        validation.integer(self.goal_samples, "goal_samples", minimum=1)
        validation.integer(self.goal_attempts, "goal_attempts", minimum=1)
        validation.nonnegative(self.simplify_time, "simplify_time [s]")
        validation.nonnegative(self.range, "range [rad]")
        validation.positive(self.window, "window [rad]", allow_inf=True)


@dataclass
class PlanResult:
    """Outcome of :func:`plan`.

    success: an exact solution was found and its interpolated path passed every check (``valid`` and
        ``max_violation`` ≤ 10 × tolerance).  status: OMPL's planner status.  message: why it failed.
    path: (N, nq) the solution interpolated at ``delta`` (empty on failure); waypoints: the planner's states.
    time: total seconds (goal sampling + planning + simplification); goal_time, plan_time, simplify_time.
    length: joint-space length of the path [rad] (a free flyer's tangent steps: its metres and radians too).
    max_violation: the worst ‖r‖ of the path constraint along ``path``.  valid: every waypoint of ``path``
    passed :class:`Validity`.  goal_states: goal samples found.
    constraint_calls: calls of the constraint function by OMPL (the finite-difference Jacobian makes 2·nq per
    Jacobian).
    """

    success: bool
    status: str
    message: str
    path: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    waypoints: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    time: float = 0.0
    goal_time: float = 0.0
    plan_time: float = 0.0
    simplify_time: float = 0.0
    length: float = math.nan
    max_violation: float = math.nan
    valid: bool = False
    goal_states: int = 0
    constraint_calls: int = 0


class Validity:
    """The state validity of a :class:`PlanningProblem`: limits, arm clearances, the carried box's clearance
    and the path region (module docstring).  ``__call__(q)`` → bool; :meth:`reason` says what failed."""

    def __init__(self, problem: PlanningProblem) -> None:
        self.problem = problem
        lim = problem.system.limits
        self.lower, self.upper = lim.lower, lim.upper
        s = problem.system
        # the limits bound the joints' coordinates (in q̇ order): q itself when nq = nv
        self.coordinates = (lambda q: q) if s.nq == s.nv else s.limit_coordinates
        self.grasp = _points_source(problem)
        self.checks = 0

    def reason(self, q: np.ndarray) -> str:
        """Empty if q is valid, else what fails (the first failing check)."""
        p = self.problem
        x = self.coordinates(q)
        if np.any(x < self.lower) or np.any(x > self.upper):
            return "outside the joint limits"
        try:  # the cheap checks first: the path region and the box take microseconds, the arms' capsules ~0.5 ms
            if p.path_region is not None and not p.path_region.contains(q, 1e-9):
                return "outside the path region"
            if p.carried is not None and p.carried.obstacles:
                pts = self.grasp(q)
                if float(np.min(p.carried.clearances(pts))) <= p.clearance:
                    return "carried box collision"
            if p.collision is not None and float(np.min(p.collision.distances(q), initial=np.inf)) <= p.clearance:
                return "arm collision"
        except CoopGAError as exc:  # a degenerate primitive or grasp frame: not a valid state
            return f"degenerate: {exc}"
        return ""

    def __call__(self, q: np.ndarray) -> bool:
        self.checks += 1
        return not self.reason(q)


def _points_source(problem: PlanningProblem) -> Any:
    """q → end points (n, 3) by Pinocchio (the goal task's end frames)."""
    from .regions import EndPoints

    task = problem.goal.task
    end = EndPoints(task.system, task.end_frames)
    return lambda q: end(q)[0]


def _value(residual: Any, q: np.ndarray) -> np.ndarray:
    """The residual at q, or a large one where the primitive degenerates (never NaN)."""
    try:
        return residual.value(q) if hasattr(residual, "value") else residual.evaluate(q)[0]
    except CoopGAError:
        return np.full(int(residual.dim), _DEGENERATE_RESIDUAL)


def _constraint_class(ob: Any, exact: bool) -> Any:
    """An ``ob.Constraint`` subclass over a residual: with ``jacobian`` (exact) or without (OMPL's default
    central differences)."""

    class _Residual(ob.Constraint):
        def __init__(self, residual: Any, tolerance: float) -> None:
            super().__init__(int(residual.nq), int(residual.dim), float(tolerance))
            self.residual = residual
            self.calls = 0

        def function(self, x: Any, out: Any) -> None:
            self.calls += 1
            out[:] = _value(self.residual, np.array(x, dtype=float))

    if not exact:
        return _Residual

    class _Exact(_Residual):
        def jacobian(self, x: Any, out: Any) -> None:
            try:
                out[:, :] = self.residual.evaluate(np.array(x, dtype=float))[1]
            except CoopGAError:
                out[:, :] = 0.0

    return _Exact


def _quaternion_slices(system: Any) -> list[slice]:
    """The q slices of every free flyer's quaternion (x y z w); empty when nq = nv."""
    m = system.model
    return [
        slice(int(m.idx_qs[j]) + 3, int(m.idx_qs[j]) + 7)
        for j in range(1, m.njoints)
        if m.joints[j].shortname() == "JointModelFreeFlyer"
    ]


def _unit(system: Any, q: np.ndarray) -> np.ndarray:
    """q with its free flyers' quaternions normalised (OMPL's projection keeps them unit only to its tolerance,
    and the kinematics refuse a norm off by 1e-6); q itself when nq = nv."""
    quats = _quaternion_slices(system)
    if not quats:
        return q
    out = np.array(q, dtype=float)
    for sl in quats:
        n = float(np.linalg.norm(out[sl]))
        if n > 0.0:
            out[sl] /= n
    return out


class _EmbeddedResidual:
    """A free flyer's path constraint in OMPL's ambient R^nq (its constrained spaces wrap a real-vector space
    only): the residual at the normalised q, then one row ``|quat|² − 1`` per free flyer, which makes the
    quaternion unit on the manifold.  Ambient Jacobian: ``J_v · pinv(pin.tangentMap(model, q))`` (the residual's
    nv columns along q ⊕ v mapped to coordinate changes; a radial change of a quaternion moves nothing) and
    ``2 quatᵀ`` for the norm rows."""

    def __init__(self, residual: Any, system: Any) -> None:
        self.residual, self.system = residual, system
        self.quats = _quaternion_slices(system)
        self.nq = int(system.nq)
        self.dim = int(residual.dim) + len(self.quats)

    def _norms(self, q: np.ndarray) -> np.ndarray:
        return np.array([float(q[sl] @ q[sl]) - 1.0 for sl in self.quats])

    def value(self, q: np.ndarray) -> np.ndarray:
        return np.concatenate([_value(self.residual, _unit(self.system, q)), self._norms(q)])

    def evaluate(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        import pinocchio as pin

        qu = _unit(self.system, q)
        r, Jv = self.residual.evaluate(qu)
        J = np.zeros((self.dim, self.nq))
        J[: len(r)] = Jv @ np.linalg.pinv(pin.tangentMap(self.system.model, qu))
        for k, sl in enumerate(self.quats):
            J[len(r) + k, sl] = 2.0 * q[sl]
        return np.concatenate([r, self._norms(q)]), J


def _ambient_bounds(system: Any, Q: np.ndarray, window: float) -> tuple[np.ndarray, np.ndarray]:
    """OMPL's box on q (nq,) for a free flyer: a joint's limits within ``window`` of the configurations Q, the
    flyer's position within ``window`` [m] of them (at least 1 m: its range is unbounded), its quaternion in
    [−1, 1]."""
    lim = system.limits
    lo, hi = np.full(system.nq, -1.0), np.full(system.nq, 1.0)
    m = system.model
    for j in range(1, m.njoints):
        iq, iv = int(m.idx_qs[j]), int(m.idx_vs[j])
        if m.nqs[j] == 1 and m.nvs[j] == 1:
            lo[iq] = max(lim.lower[iv], Q[:, iq].min() - window)
            hi[iq] = min(lim.upper[iv], Q[:, iq].max() + window)
        elif m.joints[j].shortname() == "JointModelFreeFlyer":
            w = min(max(window, 1.0), 1e3)
            lo[iq : iq + 3] = Q[:, iq : iq + 3].min(axis=0) - w
            hi[iq : iq + 3] = Q[:, iq : iq + 3].max(axis=0) + w
    return lo, hi


def _state_array(state: Any, nq: int) -> np.ndarray:
    return np.fromiter((state[i] for i in range(nq)), dtype=float, count=nq)


def _space(ob: Any, problem: PlanningProblem, o: PlannerOptions, configs: list) -> tuple[Any, Any, Any]:
    """``(constraint, constrained state space, space information)`` of the problem; bounds per ``o.window``
    around the configurations ``configs`` (start and goals)."""
    nq = int(problem.system.model.nq)
    lim = problem.system.limits
    Q = np.array(configs)
    residual = problem.path_constraint
    if problem.system.nq == problem.system.nv:
        lo = np.maximum(lim.lower, Q.min(axis=0) - o.window)
        hi = np.minimum(lim.upper, Q.max(axis=0) + o.window)
    else:  # a free flyer: the quaternion embedded in R^nq, kept unit by the constraint (_EmbeddedResidual)
        lo, hi = _ambient_bounds(problem.system, Q, o.window)
        residual = _EmbeddedResidual(residual, problem.system)
    rv = ob.RealVectorStateSpace(nq)
    b = ob.RealVectorBounds(nq)
    for i in range(nq):
        b.setLow(i, float(lo[i]))
        b.setHigh(i, float(hi[i]))
    rv.setBounds(b)
    con = _constraint_class(ob, o.jacobian == "exact")(residual, o.tolerance)
    css = ob.ProjectedStateSpace(rv, con) if o.space == "projected" else ob.AtlasStateSpace(rv, con)
    css.setDelta(o.delta)
    csi = ob.ConstrainedSpaceInformation(css)
    return con, css, csi


def _goal_configurations(problem: PlanningProblem, o: PlannerOptions, valid: Validity, deadline: float) -> list:
    """Up to ``goal_samples`` valid configurations in the goal region on the path constraint."""
    from .regions import Stack

    rng = np.random.default_rng(o.seed)
    out: list[np.ndarray] = []
    q_seed = np.asarray(problem.q_start, float)
    for _ in range(o.goal_attempts):
        if len(out) >= o.goal_samples or time.perf_counter() > deadline:
            break
        target = problem.goal.target(problem.goal.sample(rng))
        p = project(Stack([problem.path_constraint, target]), problem.system, q_seed)
        on = p.converged and np.max(np.abs(_value(problem.path_constraint, p.q))) <= o.tolerance
        if on and problem.goal.contains(p.q, 1e-6) and valid(p.q):
            out.append(p.q)
    return out


def plan(problem: PlanningProblem, options: PlannerOptions | None = None, **overrides: Any) -> PlanResult:
    """Plan from ``problem.q_start`` into ``problem.goal`` on the path constraint (module docstring).

    Raises:
        InvalidInputError: the start is invalid or off the path constraint (the message says which check).

    A free flyer (nq ≠ nv) is planned in OMPL's ambient R^nq with its quaternion kept unit by an extra equality
    row of the constraint (:class:`_EmbeddedResidual`); the path returned has unit quaternions (normalised from
    OMPL's states, which are unit to the constraint tolerance).
    """
    import dataclasses

    o = dataclasses.replace(options or PlannerOptions(), **overrides)
    ob, og, _ = _ompl()
    seed_ompl(o.seed)
    t0 = time.perf_counter()
    nq = int(problem.system.model.nq)
    q0 = validation.configuration(problem.q_start, nq, "q_start")
    valid = Validity(problem)
    why = valid.reason(q0)
    off = float(np.max(np.abs(_value(problem.path_constraint, q0)), initial=0.0))
    if why or off > o.tolerance:
        raise InvalidInputError(f"q_start is not a valid start: {why or f'off the path constraint by {off:.3g}'}")
    goals = _goal_configurations(problem, o, valid, t0 + 0.5 * o.time_limit)
    goal_time = time.perf_counter() - t0
    if not goals:
        return PlanResult(False, "INVALID_GOAL", "no valid goal configuration found in the goal region",
                          time=goal_time, goal_time=goal_time)  # fmt: skip
    con, css, csi = _space(ob, problem, o, [q0, *goals])
    ss = og.SimpleSetup(csi)
    ss.setStateValidityChecker(lambda s: valid(_unit(problem.system, _state_array(s, nq))))
    start = css.allocState()
    start.copy(q0.tolist())
    ss.setStartState(start)
    if o.space == "atlas":
        css.anchorChart(start)
    goal = ob.GoalStates(csi)
    for g in goals:
        st = css.allocState()
        st.copy(g.tolist())
        goal.addState(st)
        if o.space == "atlas":
            css.anchorChart(st)
    ss.setGoal(goal)
    planner = getattr(og, o.planner)(csi)
    if o.range > 0:
        planner.setRange(o.range)
    ss.setPlanner(planner)
    ss.setup()
    with collect_warnings(silent=True):  # random states near a chart flip or a degeneracy are rejected, not news
        status = ss.solve(max(o.time_limit - goal_time, 1e-3))
        plan_time = time.perf_counter() - t0 - goal_time
        res = _finish(ss, status, problem, o, valid, nq, goal_time, plan_time, t0)
    res.goal_states = len(goals)
    res.constraint_calls = int(con.calls)
    return res


#: checks of the simplifier's termination condition before it stops (OMPL's simplifier asks once per shortcut round):
#: a count, not a time, so that a path does not depend on the machine's load
SIMPLIFY_CHECKS = 200


def _simplify_condition(seconds: float) -> Any:
    """Stop OMPL's simplifier after :data:`SIMPLIFY_CHECKS` checks of its termination condition, or after
    ``seconds`` as a safety net (only this last case depends on the machine)."""
    ob, _, _ = _ompl()
    count = [0]
    deadline = time.perf_counter() + seconds

    def stop() -> bool:
        count[0] += 1
        return count[0] > SIMPLIFY_CHECKS or time.perf_counter() > deadline

    return ob.PlannerTerminationCondition(stop)


def _finish(ss: Any, status: Any, problem: PlanningProblem, o: PlannerOptions, valid: Validity, nq: int,
            goal_time: float, plan_time: float, t0: float) -> PlanResult:  # fmt: skip
    """Simplify, interpolate at delta and re-check the solution path."""
    name = str(status.asString()) if hasattr(status, "asString") else str(status)
    if not ss.haveExactSolutionPath():
        return PlanResult(False, name, f"no exact solution within {o.time_limit:g} s ({name})",
                          time=time.perf_counter() - t0, goal_time=goal_time, plan_time=plan_time)  # fmt: skip
    t1 = time.perf_counter()
    if o.simplify and o.simplify_time > 0:
        ss.simplifySolution(_simplify_condition(o.simplify_time))
    simplify_time = time.perf_counter() - t1
    path = ss.getSolutionPath()
    s = problem.system
    waypoints = np.array([_unit(s, _state_array(path.getState(i), nq)) for i in range(path.getStateCount())])
    path.interpolate()
    Q = np.array([_unit(s, _state_array(path.getState(i), nq)) for i in range(path.getStateCount())])
    length = (
        float(np.sum(np.linalg.norm(np.diff(Q, axis=0), axis=1)))
        if s.nq == s.nv
        else sum(map(s.distance, Q[:-1], Q[1:]))
    )
    viol = max(float(np.max(np.abs(_value(problem.path_constraint, q)))) for q in Q)
    ok = all(valid(q) for q in Q)
    success = ok and viol <= 10 * o.tolerance
    msg = "" if success else ("an interpolated waypoint is invalid" if not ok else f"constraint violated by {viol:.3g}")
    return PlanResult(success, name, msg, Q, waypoints, time.perf_counter() - t0, goal_time, plan_time,
                      simplify_time, length, viol, ok)  # fmt: skip
