"""Equality constraints on end points and on line parameters, and a differential-IK QP that keeps them (§4.2.5).

§4.2.5 of the paper (Figs. 14–15) uses the cooperative line of two wrists as a *constraint* for a
secondary, single-arm task: the right hand reaches a point while (Fig. 14) the left hand is held, or
(Fig. 15) the line stays horizontal — "the line parameter corresponding to the vertical component
remains constant".  The paper gives no equation for it; this module writes it as a differential-IK
QP with equality constraints.

Constraint functions
--------------------
An :class:`EqualityConstraint` is a function ``c(q)`` (m,) with its Jacobian ``∂c/∂q`` (m, nq) and
a target value ``c*`` (m,); the constraint is ``c(q) = c*``.  Two families are built here:

* :func:`point_constraint` — end point ``i`` of the task held at ``p*`` [m] (world frame):
  ``c(q) = p_i(q)``, ``∂c/∂q = J_{p,i}`` (3 × nq, the Euclidean part of Eq 17);
* :func:`line_parameter_constraint` — components of the unit line parameters of the task's first
  two end points (:func:`line_parameters`): direction and moment (Plücker coordinates)

      d = (p_2 − p_1)/ℓ,  ℓ = ‖p_2 − p_1‖,       m = p_1 × d,

  with ``∂d/∂q = (I − d dᵀ)(J_2 − J_1)/ℓ`` and ``∂m/∂q = −[d]_× J_1 + [p_1]_× ∂d/∂q``.  They
  are the coefficients of the cooperative line X_c = P_1 ∧ P_2 ∧ e∞ (Eq 14) divided by ℓ: d on
  ``e01∞, e02∞, e03∞`` (the paper's "e_{03i}" is d_z) and m on ``e23∞, −e13∞, e12∞``.  The
  line is oriented like the task (from the first end point to the second), and its direction is
  the rotation of V_Sc applied to the unit line's +e2 (Eq 28); tests check all three read-outs.

One step (``q̇`` a joint velocity [rad/s])
---------------------------------------
With an objective ``A q̇ ≈ b`` (here: end point ``i`` reaches ``p*``, ``A = J_{p,i}``,
``b = k (p* − p_i)`` capped at ``max_speed``), the constraints' residuals ``r = c(q) − c*`` and
Jacobians ``C = ∂c/∂q``, each step solves (:func:`~coop_ga.control.qp.solve_qp`, DAQP)

    min_q̇  ½‖A q̇ − b‖² + ½λ²‖q̇‖²
    s.t.   C q̇ = −k_c r                                          (the constraints, linearised; Eq 48 form)
           max(−v, γ (lower − q)/Δt) ≤ q̇ ≤ min(v, γ (upper − q)/Δt)   (Eq 53: position ∩ velocity limits)

and ``q_{t+1} = q_t + Δt q̇`` (Eq 61) — one :func:`~coop_ga.control.solve_step` with a
:class:`~coop_ga.control.tasks.PositionTask` objective, the constraints as ``equality`` tasks
(:class:`~coop_ga.control.tasks.PositionTask`, :class:`~coop_ga.control.tasks.LineParameterTask`, or a user
:class:`EqualityConstraint`) and the limits of :func:`~coop_ga.control.limits.default_limits` (with the
system's acceleration limits, ``acceleration_limit=True``).  When the equality-constrained minimiser
(closed form, by the nullspace of C) lies inside the box it is used as is, otherwise the QP is solved.

Projection onto the constraints (``project=True``, default)
-----------------------------------------------------------
The linearised step keeps ``c`` only to first order: after a step of Δq, ``c`` is off by
``O(‖Δq‖²)``, and the feedback ``−k_c r`` holds that drift at ``O(‖Δq‖²/(k_c Δt))`` — measured on
the horizontal line of Fig. 15 (``experiments/line_constraint.py``, k_c = 10/s): max |Δd_z| = 5.6e-5
at Δt = 0.01 s, 1.1e-4 at Δt = 0.02 s.  To keep the constraint to round-off, every step is followed by the projection of the DAE integrators
(Hairer, Lubich & Wanner, *Geometric Numerical Integration*, §IV.4): Gauss–Newton iterations

    Δq = argmin ‖Δq‖²  s.t.  C Δq = −r,  q + Δq inside the position limits and within v·Δt of q_t
                                       (and within Δt (q̇_{t−1} ± a Δt) of q_t with acceleration limits)

until ``‖r‖_∞ ≤ projection_tol`` (quadratic convergence: one or two iterations).  The velocity and
position limits still hold after the projection (its box is what the step left of them).  The
configurations returned satisfy the constraints to ``projection_tol`` (default 1e-12, units of c),
or the result says which steps did not (``projection_failures``).

Infeasibility: when the box and ``C q̇ = −k_c r`` have no common point (a joint limit blocks the
correction), the step is solved again with ``C q̇ = 0`` (q̇ = 0 is then feasible) and counted in
``feedback_dropped``; rank-deficient constraint rows raise
:class:`~coop_ga.errors.InfeasibleConstraintsError` (the reaching loop stops and reports it).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import validation
from ..diagnostics import collect_warnings
from ..errors import InfeasibleConstraintsError, InvalidInputError
from .base import SolverResult, check_q, resolve_options
from .configuration import Configuration
from .diffik import step_limits
from .limits import AccelerationLimit
from .qp import DEFAULT_LIMIT_GAIN, QPSolution, project_into_limits, solve_qp
from .solve import RunHooks, StepSolution, _check_rank, equality_minimiser, run_ik, solve_step
from .tasks import LINE_PARAMETERS, LineParameterTask, PositionTask
from .tasks.points import check_line_model, end_index, line_from_points

__all__ = [
    "LINE_PARAMETERS",
    "ConstrainedReachOptions",
    "ConstrainedReachResult",
    "EqualityConstraint",
    "constrained_point_reach",
    "constrained_velocity",
    "end_point_jacobians",
    "line_parameter_constraint",
    "line_parameters",
    "point_constraint",
    "point_task",
    "project_onto_constraints",
]

#: the CGA blade of each line parameter (the coefficient of X_c = P_1∧P_2∧e∞ divided by ℓ, sign included)
LINE_PARAMETER_BLADES = ("e01∞", "e02∞", "e03∞", "e23∞", "−e13∞", "e12∞")

#: ``'enforce'`` (position, velocity and acceleration limits in every QP, default) or ``'none'``
LIMIT_MODES = ("enforce", "none")


# ============================================================================ kinematics
def end_point_jacobians(task: Any, q: Any) -> tuple[np.ndarray, np.ndarray]:
    """End points ``p`` (n, 3) [m] and their world-frame Jacobians ``J`` (n, 3, nv) [m/rad] at q (nq,).

    The motor kinematics of the task (Eq 7, 16–17; the Euclidean part of ``∂P_i/∂q``), the same
    numbers as ``task.points(q)`` and ``task.tree.euclidean_point_jacobians(q)``, from one compiled
    evaluation (:class:`~coop_ga.control.configuration.Configuration`).
    """
    k = Configuration(task, check_q(task, q)).kinematics()
    n = k.points.shape[0]
    return k.points.copy(), k.point_jacobians.reshape(n, 3, task.nv).copy()


def line_parameters(task: Any, q: Any) -> tuple[np.ndarray, np.ndarray]:
    """Unit line parameters ``[d; m]`` (6,) of the task's line at q and their Jacobian (6, nq).

    ``d = (p_2 − p_1)/ℓ`` (unit direction, from the task's first end point to its second, world
    frame) and ``m = p_1 × d`` [m] (moment about the world origin; the same for every point of the
    line), with ``ℓ = ‖p_2 − p_1‖`` (module docstring).  They are X_c = P_1 ∧ P_2 ∧ e∞ (Eq 14) / ℓ
    on ``e01∞, e02∞, e03∞, e23∞, −e13∞, e12∞`` (:data:`LINE_PARAMETER_BLADES`).  Rows of the
    Jacobian: ``∂d/∂q = (I − d dᵀ)(J_2 − J_1)/ℓ`` [1/rad], ``∂m/∂q = −[d]_× J_1 + [p_1]_× ∂d/∂q``
    [m/rad] (:func:`~coop_ga.control.tasks.line_from_points`).  For a ``'line'`` or ``'point_pair'`` task;
    coincident end points (ℓ ≤ 1e-9 m) raise :class:`~coop_ga.errors.DegeneratePrimitiveError`.
    """
    check_line_model(task)
    P, J = end_point_jacobians(task, q)
    return line_from_points(P, J, task.end_frames, task.name)


# ============================================================================ constraints
@dataclass(frozen=True)
class EqualityConstraint:
    """The constraint ``c(q) = target`` (module docstring), usable as an ``equality`` task of
    :func:`~coop_ga.control.solve_step` (error ``c(q) − target``, Jacobian ``∂c/∂q``, gain k_c).

    function: ``q (nq,) → (c (m,), ∂c/∂q (m, nq))`` in the units of ``target`` (per rad).
    target: (m,) the value to keep.
    name: for messages and labels; labels: (m,) one name per row (default ``name[k]``).
    gain: k_c [1/s] of ``∂c/∂q q̇ = −k_c (c − target)`` (a runner's ``constraint_gain`` overrides it).
    task: a task computing the same c from a step's configuration (``value``/``jacobian``), so that it
        shares the step's one evaluation (:func:`point_constraint`, :func:`line_parameter_constraint`);
        None: ``function`` is called once per configuration.
    """

    function: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]
    target: np.ndarray
    name: str = "constraint"
    labels: tuple[str, ...] = ()
    gain: float = 10.0
    task: Any = None

    lm_damping = 0.0

    def __post_init__(self) -> None:
        if not callable(self.function):
            raise InvalidInputError(f"EqualityConstraint.function must be callable, got {type(self.function).__name__}")
        t = validation.array(self.target, f"target of constraint '{self.name}'")
        if t.ndim != 1 or t.size == 0:
            raise InvalidInputError(f"the target of constraint '{self.name}' must be a non-empty vector, got {t.shape}")
        t.setflags(write=False)
        object.__setattr__(self, "target", t)
        if not isinstance(self.name, str):
            raise InvalidInputError(f"constraint name must be a string, got {self.name!r}")
        labels = tuple(self.labels) or tuple(f"{self.name}[{k}]" for k in range(t.size))
        if len(labels) != t.size:
            raise InvalidInputError(f"constraint '{self.name}' needs {t.size} labels, got {len(labels)}")
        object.__setattr__(self, "labels", labels)
        validation.nonnegative(self.gain, "gain")

    @property
    def size(self) -> int:
        """Number of rows m."""
        return int(self.target.size)

    def evaluate(self, q: np.ndarray, nv: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``(c(q) (m,), ∂c/∂q (m, nv))``, checked for shape and finiteness (``nv``: the number of velocities,
        None: nq; a free flyer's Jacobian has nv < nq columns)."""
        c, C = self.function(q)
        c = np.asarray(c, dtype=float).reshape(-1)
        C = np.asarray(C, dtype=float)
        cols = q.shape[0] if nv is None else nv
        if c.shape != self.target.shape or C.shape != (self.size, cols):
            raise InvalidInputError(
                f"constraint '{self.name}' returned c of shape {c.shape} and ∂c/∂q of shape {C.shape}; expected "
                f"{self.target.shape} and ({self.size}, {cols})"
            )
        if not (np.all(np.isfinite(c)) and np.all(np.isfinite(C))):
            raise InvalidInputError(f"constraint '{self.name}' returned non-finite values at q = {q.tolist()}"[:300])
        return c, C

    def residual(self, q: np.ndarray, nv: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``(c(q) − target (m,), ∂c/∂q (m, nv))`` (``nv`` as :meth:`evaluate`)."""
        c, C = self.evaluate(q, nv)
        return c - self.target, C

    def _at(self, configuration: Any) -> tuple[np.ndarray, np.ndarray]:
        if self.task is not None:
            return self.task.value(configuration), self.task.jacobian(configuration)
        return configuration.cached(id(self), lambda cfg: self.evaluate(cfg.q.copy(), cfg.nv))

    def value(self, configuration: Any) -> np.ndarray:
        """c (m,) at the configuration."""
        return self._at(configuration)[0]

    def error(self, configuration: Any) -> np.ndarray:
        """``c − target`` (m,) at the configuration."""
        return self._at(configuration)[0] - self.target

    def jacobian(self, configuration: Any) -> np.ndarray:
        """∂c/∂q (m, nq) at the configuration."""
        return self._at(configuration)[1]


def point_constraint(task: Any, index: int, point: Any, name: str | None = None) -> EqualityConstraint:
    """End point ``index`` of ``task`` held at ``point`` (3,) [m], world frame: ``p_i(q) = p*``
    (3 rows, Jacobian ``J_{p,i}`` (3, nq) [m/rad] of Eq 17; a :class:`~coop_ga.control.tasks.PositionTask`)."""
    i = end_index(task, index)
    target = validation.vector(point, 3, "point [m]")
    label = name or f"{task.end_frames[i]} position"

    def f(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        P, J = end_point_jacobians(task, q)
        return P[i], J[i]

    pt = PositionTask(i, target, gain=10.0, max_speed=None)
    return EqualityConstraint(f, target, label, tuple(f"{label} {a}" for a in "xyz"), task=pt)


def line_parameter_constraint(task: Any, components: Any, value: Any, name: str | None = None) -> EqualityConstraint:
    """Components of the unit line parameters (:func:`line_parameters`) held at ``value``.

    ``components``: names from :data:`LINE_PARAMETERS` (``"d_z"`` is the vertical component of the
    direction, the paper's e_{03∞}: ``d_z = 0`` keeps the line horizontal) or indices 0..5;
    ``value``: (k,) (or a scalar for one component) [1 for d, m for m].  Note that the direction is
    a unit vector: holding all of d_x, d_y, d_z gives dependent rows (rank 2).  A
    :class:`~coop_ga.control.tasks.LineParameterTask` as an :class:`EqualityConstraint`.
    """
    lt = LineParameterTask(task, components, value, name=name)
    rows = lt.rows

    def f(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x, J = line_parameters(task, q)
        return x[rows], J[rows]

    return EqualityConstraint(f, lt.target, lt.name, lt.labels, task=lt)


def _check_constraints(constraints: Any) -> tuple[EqualityConstraint, ...]:
    if constraints is None:
        return ()
    if isinstance(constraints, EqualityConstraint):
        return (constraints,)
    if not isinstance(constraints, Sequence) or isinstance(constraints, (str, bytes)):
        raise InvalidInputError(f"constraints must be EqualityConstraints or a sequence of them, got {constraints!r}")
    out = tuple(constraints)
    for c in out:
        if not isinstance(c, EqualityConstraint):
            raise InvalidInputError(f"constraints must be EqualityConstraint objects, got {type(c).__name__}")
    return out


def _stack(constraints: Sequence[EqualityConstraint], cfg: Any) -> tuple[np.ndarray, np.ndarray]:
    """``(r (m,), C (m, nq))`` of all constraints at the configuration."""
    if not constraints:
        return np.zeros(0), np.zeros((0, cfg.nv))
    return np.concatenate([c.error(cfg) for c in constraints]), np.vstack([c.jacobian(cfg) for c in constraints])


def _labels(constraints: Sequence[EqualityConstraint]) -> tuple[str, ...]:
    return tuple(lab for c in constraints for lab in c.labels)


# ============================================================================ objective
def point_task(
    task: Any, q: Any, index: int, target_point: Any, *, gain: float = 5.0, max_speed: float | None = 0.2
) -> tuple[np.ndarray, np.ndarray, float]:
    """Objective rows of "end point ``index`` reaches ``target_point``": ``(A (3, nq), b (3,), error)``.

    ``A = J_{p,i}`` [m/rad] (world frame), ``b = gain · (p* − p_i(q))`` [m/s] capped at ``max_speed``
    [m/s] (None: no cap), ``error = ‖p* − p_i(q)‖`` [m]: the rows of a
    :class:`~coop_ga.control.tasks.PositionTask` (so the velocity can be shared with constraints and limits).
    """
    i = end_index(task, index)
    pt = PositionTask(i, target_point, gain=gain, max_speed=max_speed)
    cfg = Configuration(task, check_q(task, q))
    A, b = pt.qp_rows(cfg)
    assert A is not None  # the 'task' form
    return A.copy(), b, float(np.linalg.norm(pt.error(cfg)))


class _Rows:
    """Fixed objective rows ``(A, b)`` as a task (for :func:`constrained_velocity`)."""

    gain = 1.0
    lm_damping = 0.0

    def __init__(self, A: np.ndarray, b: np.ndarray):
        self.A, self.b = A, b

    def qp_rows(self, configuration: Any) -> tuple[np.ndarray, np.ndarray]:
        return self.A, self.b


def _check_rows(task: Any, A: Any, b: Any) -> tuple[np.ndarray, np.ndarray]:
    Am = validation.array(A, "A")
    bv = validation.array(b, "b")
    if Am.ndim != 2 or Am.shape[1] != task.nv or bv.shape != (Am.shape[0],):
        raise InvalidInputError(f"A must be (k, {task.nv}) and b (k,), got {Am.shape} and {bv.shape}")
    return Am, bv


def constrained_velocity(
    task: Any,
    q: Any,
    A: Any,
    b: Any,
    constraints: Any = None,
    *,
    dt: float = 0.01,
    damping: float = 1e-3,
    constraint_gain: float = 10.0,
    limit_mode: str = "enforce",
    limit_gain: float = DEFAULT_LIMIT_GAIN,
    velocity: Any = None,
    acceleration_limit: bool = True,
) -> tuple[QPSolution, bool]:
    """The joint velocity q̇ (nq,) [rad/s] of one constrained step (module docstring).

    ``min ½‖A q̇ − b‖² + ½λ²‖q̇‖²`` s.t. ``C q̇ = −k_c (c(q) − c*)`` for every constraint and the
    joint limits of :func:`~coop_ga.control.limits.default_limits` (``limit_mode='enforce'``).

    Args:
        task: a :class:`coop_ga.CooperativeTask`.  q: (nq,) [rad or m], inside the limits.
        A: (k, nq) objective Jacobian; b: (k,) objective velocity (e.g. :func:`point_task`).
        constraints: :class:`EqualityConstraint` or a sequence of them (their rows must be independent).
        dt: Δt [s] over which the position limits become velocity bounds.  damping: λ ≥ 0.
        constraint_gain: k_c [1/s] ≥ 0, feedback on the constraint residual.
        limit_mode: ``'enforce'`` or ``'none'``.  limit_gain: γ ∈ (0, 1].
        velocity: (nq,) the previous step's q̇ [rad/s] for the acceleration limit (None: at rest).
        acceleration_limit: impose the system's acceleration limits (``'enforce'`` only).

    Returns:
        ``(solution, feedback_dropped)``: the :class:`~coop_ga.control.qp.QPSolution` and whether the
        residual feedback had to be dropped (``C q̇ = 0``) because the box made it infeasible.

    Raises:
        InfeasibleConstraintsError: dependent constraint rows.
    """
    qv = check_q(task, q)
    validation.choice(limit_mode, LIMIT_MODES, "limit_mode")
    dt = validation.positive(dt, "dt")
    damping = validation.nonnegative(damping, "damping")
    constraint_gain = validation.nonnegative(constraint_gain, "constraint_gain")
    limit_gain = validation.scalar(limit_gain, "limit_gain", low=0.0, high=1.0, low_open=True)
    Am, bv = _check_rows(task, A, b)
    cons = _check_constraints(constraints)
    cfg = Configuration(task, qv, velocity)
    lims = step_limits(task, limit_mode, limit_gain, acceleration_limit)
    st = solve_step(cfg, [_Rows(Am, bv)], lims, dt, damping=damping, equality=cons, equality_gain=constraint_gain)
    return st.solution, st.feedback_dropped


# ============================================================================ projection
def project_onto_constraints(
    task: Any,
    q: Any,
    constraints: Any,
    *,
    lower: np.ndarray | None = None,
    upper: np.ndarray | None = None,
    tol: float = 1e-12,
    max_iter: int = 5,
) -> tuple[np.ndarray, int, float]:
    """Gauss–Newton projection of q (nq,) onto ``c(q) = c*`` (module docstring): minimum-norm steps
    ``C Δq = −r`` with ``lower ≤ q + Δq ≤ upper`` (each (nq,) or None: unbounded).

    Returns ``(q_projected, iterations, ‖r‖_∞)``; stops when ``‖r‖_∞ ≤ tol`` (units of c) or after
    ``max_iter`` iterations, or earlier when a bound makes a step infeasible (then the last q is
    returned and the residual says how far it is).  q itself must lie inside [lower, upper].
    """
    qv = check_q(task, q).copy()
    cons = _check_constraints(constraints)
    tol = validation.nonnegative(tol, "tol")
    max_iter = validation.integer(max_iter, "max_iter", minimum=0)
    return _project(Configuration(task, qv), cons, lower, upper, tol, max_iter)


def _project(
    cfg: Any,
    cons: Sequence[EqualityConstraint],
    lower: np.ndarray | None,
    upper: np.ndarray | None,
    tol: float,
    max_iter: int,
) -> tuple[np.ndarray, int, float]:
    """The projection from the configuration's q (the configuration is moved along the iterates)."""
    q = cfg.q.copy()
    system = cfg.system
    free = system.nq != system.nv  # a free flyer: steps are velocities, the bounds are on limit coordinates
    n = system.nv
    if not cons:
        return q, 0, 0.0
    r, C = _stack(cons, cfg)
    res = float(np.max(np.abs(r)))
    it = 0
    eye = np.eye(n)
    while res > tol and it < max_iter:
        _check_rank(C, _labels(cons))
        x = system.limit_coordinates(q) if free else q
        lb = None if lower is None else np.minimum(lower - x, 0.0)
        ub = None if upper is None else np.maximum(upper - x, 0.0)
        x_free = equality_minimiser(eye, np.zeros(n), 0.0, C, -r)
        try:
            dq = solve_qp(eye, np.zeros(n), 0.0, lb, ub, E=C, f=-r, x_free=x_free, what="projection").x
        except InfeasibleConstraintsError:
            break
        if not free:
            q_new = q + dq
            if lower is not None and upper is not None:
                np.clip(q_new, lower, upper, out=q_new)
        else:  # the step clipped to the box in q̇ coordinates, then q moved by integrate and kept in the limits
            if lb is not None and ub is not None:
                dq = np.clip(dq, lb, ub)
            q_new = system.clip(system.integrate(q, dq))
        cfg.update(q_new)
        r_new, C_new = _stack(cons, cfg)
        it += 1
        res_new = float(np.max(np.abs(r_new)))
        if not res_new < res:  # no progress (round-off floor or a blocking bound): keep the better point
            break
        q, r, C, res = q_new, r_new, C_new, res_new
    return q, it, res


# ============================================================================ the reaching loop
@dataclass(frozen=True)
class ConstrainedReachOptions:
    """Settings of :func:`constrained_point_reach`.

    dt: step Δt [s] (Eq 61); steps: maximum number of steps; the loop stops when the point error < tol.
    gain: k [1/s] of the point task; max_speed: its speed cap [m/s] (None: no cap).
    constraint_gain: k_c [1/s] of the feedback on the constraint residual.
    damping: λ of the objective's damped least squares.
    tol: the point error [m] below which the target is reached.
    constraint_tol: ``converged`` also needs max |c − c*| ≤ constraint_tol at the final configuration.
    project: Gauss–Newton projection onto the constraints after every step (module docstring).
    projection_tol: its stopping threshold on ‖r‖_∞ [units of c]; projection_iterations: its maximum.
    limit_mode: ``'enforce'`` (position and velocity limits, default) or ``'none'``.
    limit_gain: safety gain γ ∈ (0, 1] of the position bounds.
    acceleration_limit: with ``'enforce'``, the system's acceleration limits too (from rest).
    """

    dt: float = 0.01
    steps: int = 400
    gain: float = 5.0
    max_speed: float | None = 0.2
    constraint_gain: float = 10.0
    damping: float = 1e-3
    tol: float = 1e-4
    constraint_tol: float = 1e-9
    project: bool = True
    projection_tol: float = 1e-12
    projection_iterations: int = 5
    limit_mode: str = "enforce"
    limit_gain: float = DEFAULT_LIMIT_GAIN
    acceleration_limit: bool = True

    def __post_init__(self) -> None:
        if not isinstance(self.acceleration_limit, bool):
            raise InvalidInputError(f"acceleration_limit must be True or False, got {self.acceleration_limit!r}")
        validation.positive(self.dt, "dt")
        validation.integer(self.steps, "steps", minimum=0)
        validation.nonnegative(self.gain, "gain")
        if self.max_speed is not None:
            validation.positive(self.max_speed, "max_speed", allow_inf=True)
        validation.nonnegative(self.constraint_gain, "constraint_gain")
        validation.nonnegative(self.damping, "damping")
        validation.nonnegative(self.tol, "tol")
        validation.nonnegative(self.constraint_tol, "constraint_tol")
        if not isinstance(self.project, bool):
            raise InvalidInputError(f"project must be True or False, got {self.project!r}")
        validation.nonnegative(self.projection_tol, "projection_tol")
        validation.integer(self.projection_iterations, "projection_iterations", minimum=0)
        validation.choice(self.limit_mode, LIMIT_MODES, "limit_mode")
        validation.scalar(self.limit_gain, "limit_gain", low=0.0, high=1.0, low_open=True)


@dataclass(frozen=True, kw_only=True)
class ConstrainedReachResult(SolverResult):
    """Result of :func:`constrained_point_reach` (T = iterations + 1 configurations).

    ``error`` is the final point error [m]; ``converged`` iff it is < ``tol``, the final constraint
    deviation ≤ ``constraint_tol``, the trajectory is inside the limits and no step was infeasible.

    t: (T,) [s]; trajectory: (T, nq); points: (T, n, 3) every end point of the task [m, world];
    point_error: (T,) ‖p_i − p*‖ [m]; target_point: (3,) [m]; index: the reaching end point.
    constraint_labels: (m,) row names; constraint_targets: (m,) c*; constraint_values: (T, m) c(q_t);
    constraint_deviation: (T,) max_k |c_k(q_t) − c*_k| (0 without constraints).
    limit_violation: largest excursion outside the position limits [rad or m];
    velocity_violation: largest excess of |Δq/Δt| over the velocity limits [rad/s];
    active_steps: steps at which a bound was active (the QP was solved);
    feedback_dropped: steps whose residual feedback was dropped (module docstring);
    projection_iterations: (T − 1,) Gauss–Newton iterations of each step's projection;
    projection_failures: steps after which the projection left ‖r‖_∞ > projection_tol;
    infeasible: the loop stopped on rank-deficient constraint rows (``message`` says where);
    max_acceleration_violation: largest excess of the finite-difference acceleration (from rest) over the
    acceleration limits [rad/s²]; relaxed_steps: steps on which the acceleration bounds had to be dropped.
    """

    t: np.ndarray
    trajectory: np.ndarray
    points: np.ndarray
    point_error: np.ndarray
    target_point: np.ndarray
    index: int
    constraint_labels: tuple[str, ...]
    constraint_targets: np.ndarray
    constraint_values: np.ndarray
    constraint_deviation: np.ndarray
    limit_violation: float = 0.0
    velocity_violation: float = 0.0
    active_steps: int = 0
    feedback_dropped: int = 0
    projection_iterations: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    projection_failures: int = 0
    infeasible: bool = False
    max_acceleration_violation: float = 0.0
    relaxed_steps: int = 0


class _Projection:
    """The after-step hook of :func:`constrained_point_reach`: the Gauss–Newton projection onto the
    constraints within what the step left of the limits (module docstring)."""

    def __init__(self, task: Any, cons: tuple[EqualityConstraint, ...], o: ConstrainedReachOptions, accel: bool):
        self.cons, self.o, self.accel = cons, o, accel
        self.cfg = Configuration(task, task.system.clip(task.system.q0))
        self.iterations: list[int] = []
        self.failures = 0

    def box(self, cfg: Any, st: StepSolution) -> tuple[np.ndarray | None, np.ndarray | None]:
        if self.o.limit_mode != "enforce":
            return None, None
        lim, dt = cfg.limits, self.o.dt
        q = cfg.q if cfg.nq == cfg.nv else cfg.system.limit_coordinates(cfg.q)  # the coordinates the limits bound
        if self.accel and st.lower is not None and st.upper is not None:  # velocity, acceleration and braking
            return np.maximum(lim.lower, q + dt * st.lower), np.minimum(lim.upper, q + dt * st.upper)
        return np.maximum(lim.lower, q - lim.velocity * dt), np.minimum(lim.upper, q + lim.velocity * dt)

    def __call__(self, cfg: Any, st: StepSolution, q_next: np.ndarray) -> np.ndarray:
        if not (self.o.project and self.cons):
            self.iterations.append(0)
            return q_next
        lo, hi = self.box(cfg, st)
        self.cfg.update(q_next)
        q_next, its, res = _project(self.cfg, self.cons, lo, hi, self.o.projection_tol, self.o.projection_iterations)
        self.iterations.append(its)
        self.failures += res > self.o.projection_tol
        return q_next


def _trajectory_values(
    task: Any, traj: np.ndarray, cons: tuple[EqualityConstraint, ...]
) -> tuple[np.ndarray, np.ndarray]:
    """End points (T, n, 3) and constraint values (T, m) along a trajectory (one evaluation per q)."""
    cfg = Configuration(task, traj[0])
    pts, vals = [], []
    for qk in traj:
        cfg.update(qk)
        pts.append(cfg.kinematics().points.copy())
        vals.append(np.concatenate([c.value(cfg) for c in cons]) if cons else np.zeros(0))
    return np.array(pts), np.array(vals).reshape(len(traj), -1)


def constrained_point_reach(
    task: Any,
    q_init: Any,
    index: int,
    target_point: Any,
    options: ConstrainedReachOptions | None = None,
    *,
    constraints: Any = None,
    **overrides: Any,
) -> ConstrainedReachResult:
    """End point ``index`` reaches ``target_point`` (3,) [m, world] while ``constraints`` hold (§4.2.5, Figs. 14–15).

    Every step is a :func:`~coop_ga.control.solve_step` with a :class:`~coop_ga.control.tasks.PositionTask`
    objective and the constraints as equalities (:func:`constrained_velocity`), then ``q ← q + Δt q̇``
    (Eq 61) and, with ``project=True``, :func:`project_onto_constraints` within what the step left of the
    limits; iterated by :func:`~coop_ga.control.run_ik`.  Stops when the point error < ``tol`` or after
    ``steps`` steps.  ``constraints``: :class:`EqualityConstraint` s (e.g. :func:`point_constraint`,
    :func:`line_parameter_constraint`), problem data and not an option; ``options``:
    :class:`ConstrainedReachOptions` (keyword ``overrides`` replace its fields).
    """
    o = resolve_options(ConstrainedReachOptions, options, overrides, "constrained_point_reach")
    q = check_q(task, q_init, "q_init")
    i = end_index(task, index)
    p_star = validation.vector(target_point, 3, "target_point [m]")
    cons = _check_constraints(constraints)
    targets = np.concatenate([c.target for c in cons]) if cons else np.zeros(0)
    goal = PositionTask(i, p_star, gain=o.gain, max_speed=o.max_speed)
    lims = step_limits(task, o.limit_mode, o.limit_gain, o.acceleration_limit)
    proj = _Projection(task, cons, o, any(isinstance(lim, AccelerationLimit) for lim in lims))
    hooks = RunHooks(error=lambda c: float(np.linalg.norm(goal.error(c))), after=proj, clip=o.limit_mode == "enforce")
    with collect_warnings() as caught:
        if o.limit_mode == "enforce":
            q = project_into_limits(task, q, "q_init")
        run = run_ik(
            Configuration(task, q), [goal], lims, dt=o.dt, steps=o.steps, tol=o.tol, hooks=hooks,
            damping=o.damping, equality=cons, equality_gain=o.constraint_gain,
        )  # fmt: skip
        traj = run.trajectory
        pts, vals = _trajectory_values(task, traj, cons)
    dev = np.max(np.abs(vals - targets), axis=1) if cons else np.zeros(len(traj))
    errors = run.errors
    converged = bool(run.converged and dev[-1] <= o.constraint_tol)
    k = run.iterations
    if converged:
        message = f"converged: end point {i} within {errors[-1]:.3g} m of the target after {k} steps"
    elif run.infeasible or (errors[-1] < o.tol and dev[-1] <= o.constraint_tol):
        message = run.message
    else:
        message = (
            f"not converged after {k} steps: end point {i} is {errors[-1]:.3g} m from the target "
            f"(tol {o.tol:g}), constraint deviation {dev[-1]:.3g} (tol {o.constraint_tol:g})"
        )
    return ConstrainedReachResult(
        converged=converged,
        error=float(errors[-1]),
        iterations=k,
        message=message,
        q=traj[-1].copy(),
        warnings=dict(caught.counts),
        t=np.arange(len(traj)) * o.dt,
        trajectory=traj,
        points=pts,
        point_error=errors,
        target_point=p_star,
        index=i,
        constraint_labels=_labels(cons),
        constraint_targets=targets,
        constraint_values=vals,
        constraint_deviation=dev,
        limit_violation=run.max_position_violation,
        velocity_violation=run.max_velocity_violation,
        active_steps=run.active_steps,
        feedback_dropped=run.feedback_dropped,
        projection_iterations=np.array(proj.iterations[:k], dtype=int),
        projection_failures=int(proj.failures),
        infeasible=run.infeasible,
        max_acceleration_violation=run.max_acceleration_violation,
        relaxed_steps=run.relaxed_steps,
    )
