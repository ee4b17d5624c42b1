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

and ``q_{t+1} = q_t + Δt q̇`` (Eq 61).  When the equality-constrained minimiser (closed form, by
the nullspace of C) lies inside the box it is used as is, otherwise the QP is solved.

Projection onto the constraints (``project=True``, default)
-----------------------------------------------------------
The linearised step keeps ``c`` only to first order: after a step of Δq, ``c`` is off by
``O(‖Δq‖²)``, and the feedback ``−k_c r`` holds that drift at ``O(‖Δq‖²/(k_c Δt))`` — measured on
the horizontal line of Fig. 15 (``experiments/line_constraint.py``, k_c = 10/s): max |Δd_z| = 5.6e-5
at Δt = 0.01 s, 1.1e-4 at Δt = 0.02 s.  To keep the constraint to round-off, every step is followed by the projection of the DAE integrators
(Hairer, Lubich & Wanner, *Geometric Numerical Integration*, §IV.4): Gauss–Newton iterations

    Δq = argmin ‖Δq‖²  s.t.  C Δq = −r,  q + Δq inside the position limits and within v·Δt of q_t

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

import functools
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import validation
from ..codegen import CompiledFunction
from ..diagnostics import collect_warnings
from ..errors import DegeneratePrimitiveError, InfeasibleConstraintsError, InvalidInputError
from .base import SolverResult, check_q, resolve_options
from .qp import DEFAULT_LIMIT_GAIN, QPSolution, limit_arrays, project_into_limits, solve_qp, velocity_bounds

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

#: names of the six unit line parameters of :func:`line_parameters`: direction d, moment m = p_1 × d
LINE_PARAMETERS = ("d_x", "d_y", "d_z", "m_x", "m_y", "m_z")

#: the CGA blade of each line parameter (the coefficient of X_c = P_1∧P_2∧e∞ divided by ℓ, sign included)
LINE_PARAMETER_BLADES = ("e01∞", "e02∞", "e03∞", "e23∞", "−e13∞", "e12∞")

#: constraint rows whose singular values fall below this fraction of the largest are dependent
RANK_TOL = 1e-10

#: ``'enforce'`` (position and velocity limits in every QP, default) or ``'none'``
LIMIT_MODES = ("enforce", "none")


# ============================================================================ kinematics
@functools.cache
def _points_function(task: Any) -> CompiledFunction:
    """``q → (p (3n,), J_p (3n, nq))`` of the task's end points (CasADi VM, ≈ 6 µs for g1_arms)."""
    import casadi as ca

    q = ca.SX.sym("q", task.nq)
    p, Jp = task.graph.points(q)
    f = ca.Function(f"points_{task.name}", [q], [p, ca.densify(Jp)], ["q"], ["p", "Jp"])
    return CompiledFunction(f, codegen=False, check_finite=False)


def end_point_jacobians(task: Any, q: Any) -> tuple[np.ndarray, np.ndarray]:
    """End points ``p`` (n, 3) [m] and their world-frame Jacobians ``J`` (n, 3, nq) [m/rad] at q (nq,).

    The motor kinematics of the task (Eq 7, 16–17; the Euclidean part of ``∂P_i/∂q``), the same
    numbers as ``task.points(q)`` and ``task.tree.euclidean_point_jacobians(q)``, in one call.
    """
    qv = check_q(task, q)
    b = _points_function(task).binding()
    b.flat_inputs[0][...] = qv
    b.eval()
    n = len(task.end_frames)
    return b.outputs[0].reshape(n, 3).copy(), b.outputs[1].reshape(n, 3, task.nq).copy()


def _cross_matrix(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _check_line_task(task: Any) -> None:
    if task.kind not in ("line", "point_pair"):
        raise InvalidInputError(
            f"line parameters are defined for tasks of kind 'line' or 'point_pair', got a '{task.kind}' task "
            f"({task.name})"
        )


def line_parameters(task: Any, q: Any) -> tuple[np.ndarray, np.ndarray]:
    """Unit line parameters ``[d; m]`` (6,) of the task's line at q and their Jacobian (6, nq).

    ``d = (p_2 − p_1)/ℓ`` (unit direction, from the task's first end point to its second, world
    frame) and ``m = p_1 × d`` [m] (moment about the world origin; the same for every point of the
    line), with ``ℓ = ‖p_2 − p_1‖`` (module docstring).  They are X_c = P_1 ∧ P_2 ∧ e∞ (Eq 14) / ℓ
    on ``e01∞, e02∞, e03∞, e23∞, −e13∞, e12∞`` (:data:`LINE_PARAMETER_BLADES`).  Rows of the
    Jacobian: ``∂d/∂q = (I − d dᵀ)(J_2 − J_1)/ℓ`` [1/rad], ``∂m/∂q = −[d]_× J_1 + [p_1]_× ∂d/∂q``
    [m/rad].  For a ``'line'`` or ``'point_pair'`` task; coincident end points (ℓ ≤ 1e-9 m) raise
    :class:`~coop_ga.errors.DegeneratePrimitiveError`.
    """
    _check_line_task(task)
    P, J = end_point_jacobians(task, q)
    delta = P[1] - P[0]
    ell = float(np.linalg.norm(delta))
    if not ell > 1e-9:
        raise DegeneratePrimitiveError(
            f"the end points {task.end_frames[0]} and {task.end_frames[1]} of task '{task.name}' coincide "
            f"(distance {ell:.3g} m): the line has no direction"
        )
    d = delta / ell
    m = np.cross(P[0], d)
    Jd = (np.eye(3) - np.outer(d, d)) @ (J[1] - J[0]) / ell
    Jm = -_cross_matrix(d) @ J[0] + _cross_matrix(P[0]) @ Jd
    return np.concatenate([d, m]), np.vstack([Jd, Jm])


# ============================================================================ constraints
@dataclass(frozen=True)
class EqualityConstraint:
    """The constraint ``c(q) = target`` (module docstring).

    function: ``q (nq,) → (c (m,), ∂c/∂q (m, nq))`` in the units of ``target`` (per rad).
    target: (m,) the value to keep.
    name: for messages and labels; labels: (m,) one name per row (default ``name[k]``).
    """

    function: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]
    target: np.ndarray
    name: str = "constraint"
    labels: tuple[str, ...] = ()

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

    @property
    def size(self) -> int:
        """Number of rows m."""
        return int(self.target.size)

    def evaluate(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(c(q) (m,), ∂c/∂q (m, nq))``, checked for shape and finiteness."""
        c, C = self.function(q)
        c = np.asarray(c, dtype=float).reshape(-1)
        C = np.asarray(C, dtype=float)
        if c.shape != self.target.shape or C.shape != (self.size, q.shape[0]):
            raise InvalidInputError(
                f"constraint '{self.name}' returned c of shape {c.shape} and ∂c/∂q of shape {C.shape}; expected "
                f"{self.target.shape} and ({self.size}, {q.shape[0]})"
            )
        if not (np.all(np.isfinite(c)) and np.all(np.isfinite(C))):
            raise InvalidInputError(f"constraint '{self.name}' returned non-finite values at q = {q.tolist()}"[:300])
        return c, C

    def residual(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(c(q) − target (m,), ∂c/∂q (m, nq))``."""
        c, C = self.evaluate(q)
        return c - self.target, C


def _end_index(task: Any, index: Any) -> int:
    n = len(task.end_frames)
    i = validation.integer(index, "index")
    if not 0 <= i < n:
        raise InvalidInputError(
            f"index must be an end point of the task, 0 ≤ index < {n} ({', '.join(task.end_frames)}); got {index!r}"
        )
    return i


def point_constraint(task: Any, index: int, point: Any, name: str | None = None) -> EqualityConstraint:
    """End point ``index`` of ``task`` held at ``point`` (3,) [m], world frame: ``p_i(q) = p*``
    (3 rows, Jacobian ``J_{p,i}`` (3, nq) [m/rad] of Eq 17)."""
    i = _end_index(task, index)
    target = validation.vector(point, 3, "point [m]")
    label = name or f"{task.end_frames[i]} position"

    def f(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        P, J = end_point_jacobians(task, q)
        return P[i], J[i]

    return EqualityConstraint(f, target, label, tuple(f"{label} {a}" for a in "xyz"))


def _components(components: Any) -> tuple[int, ...]:
    if isinstance(components, (str, int, np.integer)):
        components = (components,)
    if not isinstance(components, Sequence) or not components:
        raise InvalidInputError(f"components must be a non-empty sequence of {LINE_PARAMETERS} names or indices")
    out: list[int] = []
    for c in components:
        if isinstance(c, str):
            if c not in LINE_PARAMETERS:
                raise InvalidInputError(f"unknown line parameter {c!r}; the names are {', '.join(LINE_PARAMETERS)}")
            out.append(LINE_PARAMETERS.index(c))
        else:
            k = validation.integer(c, "component")
            if not 0 <= k < 6:
                raise InvalidInputError(
                    f"a line parameter index must be in 0..5 ({', '.join(LINE_PARAMETERS)}), got {k}"
                )
            out.append(k)
    if len(set(out)) != len(out):
        raise InvalidInputError(f"components must be distinct, got {list(components)}")
    return tuple(out)


def line_parameter_constraint(task: Any, components: Any, value: Any, name: str | None = None) -> EqualityConstraint:
    """Components of the unit line parameters (:func:`line_parameters`) held at ``value``.

    ``components``: names from :data:`LINE_PARAMETERS` (``"d_z"`` is the vertical component of the
    direction, the paper's e_{03∞}: ``d_z = 0`` keeps the line horizontal) or indices 0..5;
    ``value``: (k,) (or a scalar for one component) [1 for d, m for m].  Note that the direction is
    a unit vector: holding all of d_x, d_y, d_z gives dependent rows (rank 2).
    """
    _check_line_task(task)
    idx = _components(components)
    target = np.atleast_1d(validation.array(value, "value"))
    if target.shape != (len(idx),):
        raise InvalidInputError(f"value must have one entry per component ({len(idx)}), got shape {target.shape}")
    names = tuple(LINE_PARAMETERS[k] for k in idx)
    label = name or f"line {', '.join(names)}"
    rows = list(idx)

    def f(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x, J = line_parameters(task, q)
        return x[rows], J[rows]

    return EqualityConstraint(f, target, label, names)


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


def _stack(constraints: Sequence[EqualityConstraint], q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(r (m,), C (m, nq))`` of all constraints at q."""
    if not constraints:
        return np.zeros(0), np.zeros((0, q.shape[0]))
    rs, Cs = zip(*(c.residual(q) for c in constraints))
    return np.concatenate(rs), np.vstack(Cs)


def _labels(constraints: Sequence[EqualityConstraint]) -> tuple[str, ...]:
    return tuple(lab for c in constraints for lab in c.labels)


# ============================================================================ objective
def point_task(
    task: Any, q: Any, index: int, target_point: Any, *, gain: float = 5.0, max_speed: float | None = 0.2
) -> tuple[np.ndarray, np.ndarray, float]:
    """Objective rows of "end point ``index`` reaches ``target_point``": ``(A (3, nq), b (3,), error)``.

    ``A = J_{p,i}`` [m/rad] (world frame), ``b = gain · (p* − p_i(q))`` [m/s] capped at ``max_speed``
    [m/s] (None: no cap), ``error = ‖p* − p_i(q)‖`` [m].  As :func:`~coop_ga.control.nullspace.point_reaching_velocity`,
    but as QP rows (so the velocity can be shared with constraints and limits).
    """
    i = _end_index(task, index)
    p_star = validation.vector(target_point, 3, "target_point [m]")
    gain = validation.nonnegative(gain, "gain")
    if max_speed is not None:
        max_speed = validation.positive(max_speed, "max_speed", allow_inf=True)
    P, J = end_point_jacobians(task, q)
    err = p_star - P[i]
    v = gain * err
    s = float(np.linalg.norm(v))
    if max_speed is not None and s > max_speed:
        v *= max_speed / s
    return J[i], v, float(np.linalg.norm(err))


# ============================================================================ one step
def _equality_minimiser(A: np.ndarray, b: np.ndarray, damping: float, E: np.ndarray, f: np.ndarray) -> np.ndarray:
    """``argmin ½‖A x − b‖² + ½λ²‖x‖²`` s.t. ``E x = f`` (E full row rank), by the nullspace of E."""
    if E.shape[0] == 0:
        from .qp import damped_lstsq

        return damped_lstsq(A, b, damping)
    U, s, Vt = np.linalg.svd(E, full_matrices=True)
    r = E.shape[0]
    xp = Vt[:r].T @ ((U.T @ f) / s)  # minimum-norm particular solution
    Z = Vt[r:].T  # (n, n − r) basis of the nullspace of E
    if Z.shape[1] == 0:
        return xp
    AZ = A @ Z
    H = AZ.T @ AZ + damping * damping * np.eye(Z.shape[1])
    g = AZ.T @ (b - A @ xp) - damping * damping * (Z.T @ xp)
    return xp + Z @ np.linalg.lstsq(H, g, rcond=None)[0]


def _check_rank(C: np.ndarray, labels: Sequence[str], what: str) -> None:
    if C.shape[0] == 0:
        return
    s = np.linalg.svd(C, compute_uv=False)
    if C.shape[0] > C.shape[1] or not (s[0] > 0 and s[-1] > RANK_TOL * s[0]):
        raise InfeasibleConstraintsError(
            f"{what}: the {C.shape[0]} equality constraint rows ({', '.join(labels)}) are linearly dependent at this "
            f"configuration (singular values {np.array2string(s, precision=3)}); drop a redundant row (e.g. of a "
            "unit direction only two components are independent) or move away from the singularity"
        )


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
    limits: str = "enforce",
    limit_gain: float = DEFAULT_LIMIT_GAIN,
) -> tuple[QPSolution, bool]:
    """The joint velocity q̇ (nq,) [rad/s] of one constrained step (module docstring).

    ``min ½‖A q̇ − b‖² + ½λ²‖q̇‖²`` s.t. ``C q̇ = −k_c (c(q) − c*)`` for every constraint and the
    joint box of :func:`~coop_ga.control.qp.velocity_bounds` (``limits='enforce'``).

    Parameters
    ----------
    task: a :class:`coop_ga.CooperativeTask`.  q: (nq,) [rad or m], inside the limits.
    A: (k, nq) objective Jacobian; b: (k,) objective velocity (e.g. :func:`point_task`).
    constraints: :class:`EqualityConstraint` or a sequence of them (their rows must be independent).
    dt: Δt [s] over which the position limits become velocity bounds.  damping: λ ≥ 0.
    constraint_gain: k_c [1/s] ≥ 0, feedback on the constraint residual.
    limits: ``'enforce'`` or ``'none'``.  limit_gain: γ ∈ (0, 1].

    Returns ``(solution, feedback_dropped)``: the :class:`~coop_ga.control.qp.QPSolution` and whether
    the residual feedback had to be dropped (``C q̇ = 0``) because the box made it infeasible.
    Raises :class:`~coop_ga.errors.InfeasibleConstraintsError` for dependent constraint rows.
    """
    qv = check_q(task, q)
    validation.choice(limits, LIMIT_MODES, "limits")
    dt = validation.positive(dt, "dt")
    damping = validation.nonnegative(damping, "damping")
    constraint_gain = validation.nonnegative(constraint_gain, "constraint_gain")
    limit_gain = validation.scalar(limit_gain, "limit_gain", low=0.0, high=1.0, low_open=True)
    Am = validation.array(A, "A")
    bv = validation.array(b, "b")
    if Am.ndim != 2 or Am.shape[1] != task.nq or bv.shape != (Am.shape[0],):
        raise InvalidInputError(f"A must be (k, {task.nq}) and b (k,), got {Am.shape} and {bv.shape}")
    cons = _check_constraints(constraints)
    r, C = _stack(cons, qv)
    return _velocity(task, qv, Am, bv, r, C, _labels(cons), dt, damping, constraint_gain, limits, limit_gain)


def _velocity(
    task: Any,
    q: np.ndarray,
    A: np.ndarray,
    b: np.ndarray,
    r: np.ndarray,
    C: np.ndarray,
    labels: tuple[str, ...],
    dt: float,
    damping: float,
    constraint_gain: float,
    limits: str,
    limit_gain: float,
) -> tuple[QPSolution, bool]:
    _check_rank(C, labels, "constrained differential-IK step")
    lb = ub = None
    if limits == "enforce":
        lower, upper, vel = limit_arrays(task)
        lb, ub = velocity_bounds(q, lower, upper, vel, dt, limit_gain)
    p = C.shape[0]
    for f, dropped in ((-constraint_gain * r, False), (np.zeros(p), True)):
        x_free = _equality_minimiser(A, b, damping, C, f)
        try:
            sol = solve_qp(
                A,
                b,
                damping,
                lb,
                ub,
                E=C if p else None,
                f=f if p else None,
                x_free=x_free,
                what="constrained differential-IK step",
            )
            return sol, dropped
        except InfeasibleConstraintsError:
            if dropped or not p:
                raise
    raise AssertionError("unreachable")  # pragma: no cover


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
    return _project(qv, cons, lower, upper, tol, max_iter)


def _project(
    q: np.ndarray,
    cons: Sequence[EqualityConstraint],
    lower: np.ndarray | None,
    upper: np.ndarray | None,
    tol: float,
    max_iter: int,
) -> tuple[np.ndarray, int, float]:
    n = q.shape[0]
    if not cons:
        return q, 0, 0.0
    r, C = _stack(cons, q)
    res = float(np.max(np.abs(r)))
    it = 0
    eye = np.eye(n)
    while res > tol and it < max_iter:
        _check_rank(C, _labels(cons), "projection onto the constraints")
        lb = None if lower is None else np.minimum(lower - q, 0.0)
        ub = None if upper is None else np.maximum(upper - q, 0.0)
        try:
            dq = solve_qp(
                eye,
                np.zeros(n),
                0.0,
                lb,
                ub,
                E=C,
                f=-r,
                x_free=_equality_minimiser(eye, np.zeros(n), 0.0, C, -r),
                what="projection onto the constraints",
            ).x
        except InfeasibleConstraintsError:
            break
        q_new = q + dq
        if lower is not None and upper is not None:
            np.clip(q_new, lower, upper, out=q_new)
        r_new, C_new = _stack(cons, q_new)
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
    limits: ``'enforce'`` (position and velocity limits, default) or ``'none'``.
    limit_gain: safety gain γ ∈ (0, 1] of the position bounds.
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
    limits: str = "enforce"
    limit_gain: float = DEFAULT_LIMIT_GAIN

    def __post_init__(self) -> None:
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
        validation.choice(self.limits, LIMIT_MODES, "limits")
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
    infeasible: the loop stopped on rank-deficient constraint rows (``message`` says where).
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


def constrained_point_reach(
    task: Any,
    q0: Any,
    index: int,
    target_point: Any,
    constraints: Any = None,
    options: ConstrainedReachOptions | None = None,
    **overrides: Any,
) -> ConstrainedReachResult:
    """End point ``index`` reaches ``target_point`` (3,) [m, world] while ``constraints`` hold (§4.2.5, Figs. 14–15).

    Every step is :func:`constrained_velocity` with the objective :func:`point_task`, then
    ``q ← q + Δt q̇`` (Eq 61) and, with ``project=True``, :func:`project_onto_constraints` within
    what the step left of the position and velocity limits.  Stops when the point error < ``tol`` or
    after ``steps`` steps.  ``constraints``: :class:`EqualityConstraint` s (e.g.
    :func:`point_constraint`, :func:`line_parameter_constraint`), problem data and not an option;
    ``options``: :class:`ConstrainedReachOptions` (keyword ``overrides`` replace its fields).
    """
    o = resolve_options(ConstrainedReachOptions, options, overrides, "constrained_point_reach")
    q = check_q(task, q0, "q0")
    i = _end_index(task, index)
    p_star = validation.vector(target_point, 3, "target_point [m]")
    cons = _check_constraints(constraints)
    labels = _labels(cons)
    targets = np.concatenate([c.target for c in cons]) if cons else np.zeros(0)
    lower, upper, vel = limit_arrays(task)
    enforce = o.limits == "enforce"
    active_steps = dropped = failures = 0
    proj_its: list[int] = []
    infeasible = False
    message = ""
    with collect_warnings() as caught:
        if enforce:
            q = project_into_limits(task, q, "q0")
        Q = [q.copy()]
        A, b, err = point_task(task, q, i, p_star, gain=o.gain, max_speed=o.max_speed)
        errs = [err]
        k = 0
        while k < o.steps and errs[-1] >= o.tol:
            r, C = _stack(cons, q)
            try:
                sol, drop = _velocity(
                    task, q, A, b, r, C, labels, o.dt, o.damping, o.constraint_gain, o.limits, o.limit_gain
                )
            except InfeasibleConstraintsError as exc:
                infeasible = True
                message = f"stopped at step {k}: {exc}"
                break
            active_steps += bool(sol.used_qp)
            dropped += drop
            q_next = q + o.dt * sol.x
            if enforce:
                np.clip(q_next, lower, upper, out=q_next)  # rounding only: the box keeps q̇ inside
            if o.project and cons:
                lo = hi = None
                if enforce:  # what the step left of the position and velocity limits
                    lo = np.maximum(lower, q - vel * o.dt)
                    hi = np.minimum(upper, q + vel * o.dt)
                try:
                    q_next, its, res = _project(q_next, cons, lo, hi, o.projection_tol, o.projection_iterations)
                except InfeasibleConstraintsError as exc:
                    infeasible = True
                    message = f"stopped at step {k} (projection): {exc}"
                    break
                proj_its.append(its)
                failures += res > o.projection_tol
            else:
                proj_its.append(0)
            q = q_next
            Q.append(q.copy())
            A, b, err = point_task(task, q, i, p_star, gain=o.gain, max_speed=o.max_speed)
            errs.append(err)
            k += 1
        traj = np.array(Q)
        pts = np.array([end_point_jacobians(task, qk)[0] for qk in traj])
        if cons:
            vals = np.array([np.concatenate([c.evaluate(qk)[0] for c in cons]) for qk in traj])
            dev = np.max(np.abs(vals - targets), axis=1)
        else:
            vals = np.zeros((len(traj), 0))
            dev = np.zeros(len(traj))
    lim = task.system.limits
    violation = lim.position_violation(traj)
    vviol = lim.trajectory_velocity_violation(traj, o.dt) if k else 0.0
    errors = np.array(errs)
    converged = bool(
        errors[-1] < o.tol and dev[-1] <= o.constraint_tol and (not enforce or violation <= 1e-9) and not infeasible
    )
    if converged:
        message = f"converged: end point {i} within {errors[-1]:.3g} m of the target after {k} steps"
    elif not message:
        message = (
            f"not converged after {k} steps: end point {i} is {errors[-1]:.3g} m from the target "
            f"(tol {o.tol:g}), constraint deviation {dev[-1]:.3g} (tol {o.constraint_tol:g})"
        )
    return ConstrainedReachResult(
        converged=converged,
        error=float(errors[-1]),
        iterations=k,
        message=message,
        q=q.copy(),
        warnings=dict(caught.counts),
        t=np.arange(len(traj)) * o.dt,
        trajectory=traj,
        points=pts,
        point_error=errors,
        target_point=p_star,
        index=i,
        constraint_labels=labels,
        constraint_targets=targets,
        constraint_values=vals,
        constraint_deviation=dev,
        limit_violation=violation,
        velocity_violation=vviol,
        active_steps=int(active_steps),
        feedback_dropped=int(dropped),
        projection_iterations=np.array(proj_its, dtype=int),
        projection_failures=int(failures),
        infeasible=infeasible,
    )
