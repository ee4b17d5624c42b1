"""Obstacle and self-collision avoidance in the cooperative controllers (issue 14, item 3).

Every method here uses the *same* distances: a collision model ``cm``
(:class:`coop_ga.collision.model.CollisionModel`, or any object with the same three members)
gives the signed clearances ``d(q)`` (n,) [m] of its pairs (link capsule – obstacle, link – link
of other chains or non-adjacent links of the same chain; negative = penetration depth), their
Jacobian ``J_d = ∂d/∂q`` (n, nq) [m/rad] and ``cm.labels`` (n,) naming the pairs.  No distance
is computed in this module (the geometry lives in :mod:`coop_ga.collision`).

Hard avoidance: velocity dampers as rows of the limit-aware QP
--------------------------------------------------------------
The differential-IK step is the QP of :mod:`coop_ga.control.diffik` (Eq 48 with the limits of
Eq 53); avoidance adds, for every pair closer than the influence distance ``d_i``
(``d_influence``), the linear inequality (velocity damper, Faverjon & Tournassoud 1987,
"A local based approach for path planning of manipulators with a high number of degrees of
freedom", ICRA; Kanoun, Lamiraux, Wieber 2011)

    d_k + Δt · J_{d,k} q̇  ≥  d_s + (1 − ξ)(d_k − d_s),   i.e.   −J_{d,k} q̇ ≤ ξ (d_k − d_s)/Δt     (A1)

with d_s = ``d_safe`` [m] and the damper gain ξ = ``damper_gain`` ∈ (0, 1] (ξ = 1 is the
plain first-order condition ``d_k + J_{d,k} q̇ Δt ≥ d_s``; smaller ξ lets the clearance approach
d_s geometrically, ``d_{t+1} − d_s ≥ (1 − ξ)(d_t − d_s)`` to first order, so it is only reached
asymptotically).  A pair already at or below d_s gets ``h = 0`` (its clearance may not
decrease).  This is the form of mink's ``CollisionAvoidanceLimit``
(kevinzakka/mink, ``mink/limits/collision_avoidance_limit.py``: rows ``−n̂ᵀ(J₂ − J₁) Δq ≤
gain · (d − d_min)/Δt`` for the pairs within ``collision_detection_distance``, ``bound_relaxation``
below d_min; gain 0.85 there), written on the joint velocity q̇ and with our exact capsule
Jacobians.  Since every h ≥ 0, q̇ = 0 always satisfies (A1) and the joint-limit box, so the QP
is never infeasible.  The rows enter :func:`coop_ga.control.qp.solve_qp` as user constraints
``G q̇ ≤ h`` next to the position/velocity box; :func:`clearance_constraint` builds them, and
:class:`ClearanceLimit` is the callable ``q → LinearConstraint`` that
:func:`coop_ga.control.diff_ik_reach` accepts as ``constraints=``.  (A1) is first order: the
true clearance after the step differs from its linearisation by O(Δt² |q̇|² · curvature); the
tests measure it.

Soft avoidance: repulsive velocities in the nullspace of the cooperative task
------------------------------------------------------------------------------
A secondary task (Eq 58, 60; :mod:`coop_ga.control.nullspace`): for the pairs closer than
d_i = ``d_influence`` the desired clearance rate follows the gain profile

    ḋ*_k = v_r · s_k²,      s_k = clamp((d_i − d_k)/(d_i − d_s), 0, 1)                          (A2)

(v_r = ``repulsive_speed`` [m/s]; zero with zero slope at d_i — the profile is C¹ — and
saturated at v_r from d_s inwards, like the bounded FIRAS potential of Khatib 1986 without its
1/d singularity).  The rates are realised *in the nullspace* of J^G, accounting for what the
primary motion already does to the distances (the task-priority solution of Nakamura, Hanafusa,
Yoshikawa 1987 / Maciejewski & Klein 1985, with the exact projector N = I − J^G⁺ J^G of Eq 58):

    q̇₁ = J^G⁺_λ B_S,     q̇₂ = N (J_A N)ᵀ ((J_A N)(J_A N)ᵀ + λ_r² I)⁻¹ (ḋ*_A − J_A q̇₁)              (A3)

(A: the pairs with d < d_i, J_A their rows of J_d, λ_r = ``repulsive_damping`` [m/rad]), and
``q̇ = q̇₁ + q̇₂`` is the step of the two-level QP of :mod:`coop_ga.control.nullspace` (Eq 58, 60)
with the joint limits.  Since ``J^G q̇₂ = 0`` exactly, the cooperative task velocity ``J^G q̇`` is
that of plain differential IK — the repulsion moves the elbows and wrists and slides the end
points along the primitive, but never disturbs the primitive (the result's
``task_velocity_deviation`` measures it: ~1e-12 on the demonstration) — and far from every
obstacle (all d ≥ d_i) q̇₂ = 0 and the step *is* the differential-IK step.
:func:`repulsive_velocity` gives the plain (A2) velocity ``J_Aᵀ(J_A J_Aᵀ + λ_r² I)⁻¹ ḋ*_A``
(no task) for other uses.  Soft avoidance alone cannot guarantee clearance (where the nullspace has no direction
that increases d, it does nothing); ``mode="both"`` (the default) adds the hard rows (A1) to both
levels of the QP: the repulsion keeps the arms away from the obstacles while the task allows it,
the dampers guarantee the clearance when it does not (then the task velocity is sacrificed — the
QP minimises its error subject to (A1)).

iLQR
----
:class:`ClearanceCost` is the running clearance cost of :func:`coop_ga.control.ilqr_reach`
(``ILQROptions(clearance=ClearanceCost(cm, ...))``, default None = off): at the knots
k = 1 … n, ``w Σ_i ½ max(0, d_a − d_i(q_k))²`` (a squared hinge: C¹, zero beyond the activation
distance d_a), with its exact gradient from J_d and its Gauss–Newton Hessian
``w J_Aᵀ J_A`` (module :mod:`coop_ga.control.ilqr`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import validation
from ..cooperative.manipulability import damped_pinv
from ..diagnostics import collect_warnings
from ..errors import InvalidInputError
from .base import check_problem, resolve_options
from .diffik import DiffIKResult, _advance, _velocity, reach_outcome
from .nullspace import _hierarchical_velocity
from .qp import (
    DEFAULT_LIMIT_GAIN,
    InfeasibleConstraintsError,
    LinearConstraint,
    limit_arrays,
    project_into_limits,
    velocity_bounds,
)

__all__ = [
    "AVOIDANCE_MODES",
    "AvoidanceOptions",
    "AvoidanceResult",
    "ClearanceCost",
    "ClearanceLimit",
    "avoidance_reach",
    "avoidance_velocity",
    "clearance_constraint",
    "repulsive_velocity",
]

#: ``'none'`` (plain differential IK), ``'soft'`` (nullspace repulsion), ``'hard'`` (QP rows), ``'both'``
AVOIDANCE_MODES = ("none", "soft", "hard", "both")


def check_collision_model(cm: Any, nq: int | None = None) -> Any:
    """``cm`` if it has ``distances_and_jacobian`` and ``labels`` (a collision model), else
    :class:`~coop_ga.errors.InvalidInputError`; with ``nq``, its system must have nq joints."""
    if not (callable(getattr(cm, "distances_and_jacobian", None)) and hasattr(cm, "labels")):
        raise InvalidInputError(
            "a collision model is needed (coop_ga.collision.model.CollisionModel: distances_and_jacobian(q), "
            f"labels), got {type(cm).__name__}"
        )
    sys_ = getattr(cm, "system", None)
    if nq is not None and sys_ is not None and int(sys_.nq) != nq:
        raise InvalidInputError(f"the collision model is for {sys_.nq} joints, the task has {nq}")
    return cm


def _distances(cm: Any, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    d, J = cm.distances_and_jacobian(q)
    d = np.asarray(d, dtype=float).reshape(-1)
    J = np.asarray(J, dtype=float).reshape(d.shape[0], q.shape[0])
    return d, J


def _check_distances(d_safe: Any, d_influence: Any) -> tuple[float, float]:
    ds = validation.scalar(d_safe, "d_safe [m]")
    di = validation.scalar(d_influence, "d_influence [m]")
    if not di > ds:
        raise InvalidInputError(f"d_influence ({di:g} m) must be larger than d_safe ({ds:g} m)")
    return ds, di


def _damper_rows(
    d: np.ndarray, Jd: np.ndarray, dt: float, d_safe: float, d_influence: float, gain: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(A1) for the pairs with d < d_influence: ``(G, h, indices)``."""
    idx = np.flatnonzero(d < d_influence)
    G = -Jd[idx]
    h = np.maximum(gain * (d[idx] - d_safe) / dt, 0.0)
    return G, h, idx


def clearance_constraint(
    cm: Any,
    q: Any,
    *,
    dt: float = 0.01,
    d_safe: float = 0.01,
    d_influence: float = 0.10,
    damper_gain: float = 0.5,
) -> LinearConstraint:
    """The velocity-damper rows (A1) at ``q`` as a :class:`~coop_ga.control.qp.LinearConstraint` on q̇.

    Parameters
    ----------
    cm: the collision model (``distances_and_jacobian(q) → d (n,) [m], J_d (n, nq) [m/rad]``).
    q: (nq,) configuration [rad].  dt: Δt [s] of the controller.
    d_safe: clearance d_s [m] that is kept.  d_influence: pairs with d ≥ d_influence [m] give no row.
    damper_gain: ξ ∈ (0, 1].

    Returns ``G (m, nq)``, ``h (m,)`` [m/s] with ``G q̇ ≤ h`` ⇔ (A1), one row per pair with
    d < d_influence in the model's order (``name`` ``"clearance"``: messages name row r ``clearance[r]``;
    m may be 0).
    """
    cm = check_collision_model(cm)
    dt = validation.positive(dt, "dt")
    ds, di = _check_distances(d_safe, d_influence)
    gain = validation.scalar(damper_gain, "damper_gain", low=0.0, high=1.0, low_open=True)
    qv = validation.array(q, "q").reshape(-1)
    d, Jd = _distances(cm, qv)
    G, h, _ = _damper_rows(d, Jd, dt, ds, di, gain)
    return LinearConstraint(G, h, "clearance")


@dataclass(frozen=True)
class ClearanceLimit:
    """The callable ``q → LinearConstraint`` of (A1) for :func:`coop_ga.control.diff_ik_reach`'s
    ``constraints=`` (evaluated at every step): ``diff_ik_reach(task, q0, V, constraints=ClearanceLimit(cm, dt=0.01))``.
    ``dt`` must be the controller's Δt [s]; the other fields as :func:`clearance_constraint`."""

    model: Any
    dt: float = 0.01
    d_safe: float = 0.01
    d_influence: float = 0.10
    damper_gain: float = 0.5

    def __post_init__(self) -> None:
        check_collision_model(self.model)
        validation.positive(self.dt, "dt")
        _check_distances(self.d_safe, self.d_influence)
        validation.scalar(self.damper_gain, "damper_gain", low=0.0, high=1.0, low_open=True)

    def __call__(self, q: Any) -> LinearConstraint:
        return clearance_constraint(
            self.model,
            q,
            dt=self.dt,
            d_safe=self.d_safe,
            d_influence=self.d_influence,
            damper_gain=self.damper_gain,
        )


def _rates(d: np.ndarray, d_safe: float, d_influence: float, speed: float) -> tuple[np.ndarray, np.ndarray]:
    """``(indices of the pairs with d < d_influence, their desired clearance rates (A2) [m/s])``."""
    idx = np.flatnonzero(d < d_influence)
    s = np.clip((d_influence - d[idx]) / (d_influence - d_safe), 0.0, 1.0)
    return idx, speed * s * s


def _repulsion(
    d: np.ndarray,
    Jd: np.ndarray,
    d_safe: float,
    d_influence: float,
    speed: float,
    damping: float,
    J: np.ndarray | None = None,
    x1: np.ndarray | None = None,
) -> np.ndarray:
    """q̇₂ of (A2); with the task Jacobian J and the primary velocity x1, (A3)."""
    nq = Jd.shape[1]
    idx, rate = _rates(d, d_safe, d_influence, speed)
    if idx.size == 0 or speed == 0.0:
        return np.zeros(nq)
    JA = Jd[idx]
    if J is None or x1 is None:
        M = JA @ JA.T + damping * damping * np.eye(idx.size)
        return JA.T @ np.linalg.solve(M, rate)
    N = np.eye(nq) - np.linalg.pinv(J, rcond=1e-10) @ J  # exact projector onto the nullspace of J^G (Eq 58)
    JAN = JA @ N
    M = JAN @ JAN.T + damping * damping * np.eye(idx.size)
    return N @ (JAN.T @ np.linalg.solve(M, rate - JA @ x1))  # (A3): in the nullspace, J^G q̇₂ = 0


def repulsive_velocity(
    cm: Any,
    q: Any,
    *,
    d_safe: float = 0.01,
    d_influence: float = 0.10,
    repulsive_speed: float = 0.3,
    repulsive_damping: float = 0.05,
) -> np.ndarray:
    """The secondary joint velocity q̇₂ (nq,) [rad/s] of (A2): the damped least-norm velocity giving the
    active pairs (d < d_influence) the clearance rates ``v_r s²`` [m/s] (module docstring)."""
    cm = check_collision_model(cm)
    ds, di = _check_distances(d_safe, d_influence)
    v = validation.nonnegative(repulsive_speed, "repulsive_speed [m/s]")
    lam = validation.nonnegative(repulsive_damping, "repulsive_damping")
    qv = validation.array(q, "q").reshape(-1)
    d, Jd = _distances(cm, qv)
    return _repulsion(d, Jd, ds, di, v, lam)


@dataclass(frozen=True)
class AvoidanceOptions:
    """Settings of :func:`avoidance_reach` (the differential-IK fields are those of
    :class:`~coop_ga.control.DiffIKOptions`, with the same defaults).

    mode: ``'both'`` (default: hard rows (A1) and nullspace repulsion (A2)), ``'hard'``, ``'soft'``
        or ``'none'`` (plain differential IK; the clearances are still recorded).
    d_safe: clearance d_s [m] kept by (A1) and at which (A2) saturates.
    d_influence: d_i [m] (> d_safe): pairs farther away give no row and no repulsion.
    damper_gain: ξ ∈ (0, 1] of (A1).
    repulsive_speed: v_r [m/s] of (A2) (0 disables the repulsion).
    repulsive_damping: λ_r [m/rad] of the least-norm repulsive velocity.
    gain [1/s], dt [s], steps, damping, tol, limits (``'enforce'`` or ``'none'``), limit_gain: as
        :class:`~coop_ga.control.DiffIKOptions`.
    """

    mode: str = "both"
    d_safe: float = 0.01
    d_influence: float = 0.10
    damper_gain: float = 0.5
    repulsive_speed: float = 0.3
    repulsive_damping: float = 0.05
    gain: float = 10.0
    dt: float = 0.01
    steps: int = 250
    damping: float = 1e-3
    tol: float = 1e-4
    limits: str = "enforce"
    limit_gain: float = DEFAULT_LIMIT_GAIN

    def __post_init__(self) -> None:
        validation.choice(self.mode, AVOIDANCE_MODES, "mode")
        _check_distances(self.d_safe, self.d_influence)
        validation.scalar(self.damper_gain, "damper_gain", low=0.0, high=1.0, low_open=True)
        validation.nonnegative(self.repulsive_speed, "repulsive_speed")
        validation.nonnegative(self.repulsive_damping, "repulsive_damping")
        validation.positive(self.gain, "gain")
        validation.positive(self.dt, "dt")
        validation.integer(self.steps, "steps", minimum=0)
        validation.nonnegative(self.damping, "damping")
        validation.nonnegative(self.tol, "tol")
        validation.choice(self.limits, ("enforce", "none"), "limits")
        validation.scalar(self.limit_gain, "limit_gain", low=0.0, high=1.0, low_open=True)


@dataclass(frozen=True, kw_only=True)
class AvoidanceResult(DiffIKResult):
    """Result of :func:`avoidance_reach`: the fields of :class:`~coop_ga.control.DiffIKResult` plus

    mode: the avoidance mode.
    clearance: (T,) smallest signed clearance over all pairs at each configuration [m].
    clearances: (T, n) every pair's clearance [m] (columns: ``labels``).
    labels: (n,) the collision model's pair labels.
    min_clearance: ``min(clearance)`` [m]; closest: the label of the pair that attains it.
    constraint_residual: largest violation of the linearised rows (A1) by the commanded q̇ over
        all steps, ``max(G q̇ − h)`` [m/s] (≤ 0 up to the QP tolerance; 0 without rows).
    task_velocity_deviation: (T−1,) ‖J^G q̇_t − J^G q̇_t^DIK‖ per step, with q̇^DIK the plain
        differential-IK velocity at the same q (same limits, no avoidance) [rad/s | 1/s | body length/s]:
        how much avoidance disturbed the cooperative task.
    active_rows: (T−1,) number of rows (A1) at each step.
    fallback_steps: steps at which the QP solver failed numerically and the step was re-solved with
        more damping and without the repulsion, or scaled into the feasible set (see ``_step``); the
        rows (A1) and the limits hold on those steps too.
    """

    mode: str = "both"
    clearance: np.ndarray = field(default_factory=lambda: np.zeros(0))
    clearances: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    labels: tuple[str, ...] = ()
    min_clearance: float = float("inf")
    closest: str = ""
    constraint_residual: float = 0.0
    task_velocity_deviation: np.ndarray = field(default_factory=lambda: np.zeros(0))
    active_rows: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    fallback_steps: int = 0


def avoidance_velocity(
    task: Any,
    q: Any,
    command_bivector: Any,
    cm: Any,
    options: AvoidanceOptions | None = None,
    **overrides: Any,
) -> np.ndarray:
    """The joint velocity q̇ (nq,) [rad/s] of one avoidance step for the body velocity command B_S (7,)
    (module docstring: (A1) rows in the QP for ``'hard'``/``'both'``, (A2) in the nullspace for
    ``'soft'``/``'both'``); ``q`` inside the limits (projected otherwise, with a warning)."""
    o = resolve_options(AvoidanceOptions, options, overrides, "avoidance_velocity")
    cm = check_collision_model(cm, task.nq)
    qv = validation.configuration(q, task.nq, "q")
    b = validation.vector(command_bivector, 7, "command_bivector")
    if o.limits != "none":
        qv = project_into_limits(task, qv)
    J = task.evaluate_views(qv)[2]
    d, Jd = _distances(cm, qv)
    return _step(task, qv, J, b, d, Jd, o, tuple(str(x) for x in cm.labels))[0]  # never infeasible: q̇ = 0 is


#: damping of the retry when the QP solver fails numerically on a step (q̇ = 0 is always feasible)
FALLBACK_DAMPING = 1e-2


def _feasible_fraction(
    x: np.ndarray, lb: np.ndarray | None, ub: np.ndarray | None, G: np.ndarray, h: np.ndarray
) -> float:
    """The largest α ∈ [0, 1] with α x in the box and ``G (α x) ≤ h`` (0 is feasible: lb ≤ 0 ≤ ub, h ≥ 0)."""
    alpha = 1.0
    with np.errstate(divide="ignore", invalid="ignore"):
        if ub is not None:
            over = x > ub
            alpha = min(alpha, float(np.min(np.maximum(ub[over], 0.0) / x[over], initial=1.0)))
        if lb is not None:
            under = x < lb
            alpha = min(alpha, float(np.min(np.minimum(lb[under], 0.0) / x[under], initial=1.0)))
        if G.shape[0]:
            gx = G @ x
            bad = gx > h
            alpha = min(alpha, float(np.min(np.maximum(h[bad], 0.0) / gx[bad], initial=1.0)))
    return max(0.0, alpha * (1.0 - 1e-12))


def _step(
    task: Any,
    q: np.ndarray,
    J: np.ndarray,
    b: np.ndarray,
    d: np.ndarray,
    Jd: np.ndarray,
    o: AvoidanceOptions,
    labels: tuple[str, ...] = (),
) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple[str, ...], bool, tuple[str, ...], int]:
    """``(q̇, G, h, row labels, a bound/row was active, active labels, fallback)`` of one step (labels: the
    model's).  ``fallback``: 0, or 1 when the QP solver failed numerically and the step was re-solved
    without the repulsion and with damping :data:`FALLBACK_DAMPING`, or 2 when that failed too and the
    step is the unconstrained one scaled into the feasible set (the largest α ∈ [0, 1]; q̇ = 0 is feasible)."""
    if o.mode in ("hard", "both"):
        G, h, idx = _damper_rows(d, Jd, o.dt, o.d_safe, o.d_influence, o.damper_gain)
    else:
        G, h, idx = np.zeros((0, q.shape[0])), np.zeros(0), np.zeros(0, int)
    row_labels = tuple(f"clearance of {labels[k] if k < len(labels) else k}" for k in idx)
    try:
        if o.mode in ("soft", "both"):
            x1 = damped_pinv(J, o.damping) @ b
            qd2 = _repulsion(d, Jd, o.d_safe, o.d_influence, o.repulsive_speed, o.repulsive_damping, J, x1)
            qd, was_active, act = _hierarchical_velocity(
                task, q, b / o.gain, J, qd2, o.dt, o.gain, o.damping, True, o.limits, o.limit_gain, G, h, row_labels
            )
            return qd, G, h, row_labels, was_active, act, 0
        sol = _velocity(task, q, J, b, o.dt, o.damping, o.limits, o.limit_gain, G, h, row_labels)
    except InfeasibleConstraintsError:
        # a numerical failure of the solver (every h ≥ 0 and the box contains 0, so q̇ = 0 is feasible)
        lam = max(o.damping, FALLBACK_DAMPING)
        try:
            sol = _velocity(task, q, J, b, o.dt, lam, o.limits, o.limit_gain, G, h, row_labels)
        except InfeasibleConstraintsError:
            x = damped_pinv(J, lam) @ b
            lb: np.ndarray | None
            ub: np.ndarray | None
            if o.limits == "enforce":
                lower, upper, vel = limit_arrays(task)
                lb, ub = velocity_bounds(q, lower, upper, vel, o.dt, o.limit_gain)
            else:
                lb = ub = None
            a = _feasible_fraction(x, lb, ub, G, h)
            return a * x, G, h, row_labels, True, (f"QP failed: unconstrained step scaled by {a:.3g}",), 2
        act = tuple(lab for lab, a in zip(row_labels, sol.active_rows) if a)
        return sol.x, G, h, row_labels, True, act, 1
    act = tuple(lab for lab, a in zip(row_labels, sol.active_rows) if a)
    return sol.x, G, h, row_labels, bool(sol.used_qp), act, 0


def avoidance_reach(
    task: Any,
    q0: Any,
    target: Any,
    cm: Any,
    options: AvoidanceOptions | None = None,
    **overrides: Any,
) -> AvoidanceResult:
    """Differential IK to ``target`` (Eq 44, 48, 61) with obstacle and self-collision avoidance (module docstring).

    Each step commands ``B_S = gain · log(Ṽ_Sc(q) V_Sd)`` as :func:`coop_ga.control.diff_ik_reach` does and
    takes the step of :func:`avoidance_velocity`; stops when ‖e‖ < ``tol`` or after ``steps`` steps.

    Parameters
    ----------
    task: a :class:`coop_ga.CooperativeTask`.  q0: (nq,) start [rad] (projected onto the limits
        with a warning if outside).  target: V_Sd, a :class:`~coop_ga.Similarity`.
    cm: the collision model of the task's system (pairs, d (n,) [m], J_d (n, nq)).
    options: :class:`AvoidanceOptions` (keyword ``overrides`` replace its fields).

    Returns an :class:`AvoidanceResult`; ``converged`` as for differential IK (‖e‖ < tol inside the
    limits) — clearance is reported, not part of ``converged``.
    """
    o = resolve_options(AvoidanceOptions, options, overrides, "avoidance_reach")
    cm = check_collision_model(cm, task.nq)
    q, Vd = check_problem(task, q0, target, "q0")
    labels = tuple(str(s) for s in cm.labels)
    residual = 0.0
    active_steps = 0
    active: tuple[str, ...] = ()
    infeasible = False
    message = ""
    devs: list[float] = []
    n_rows: list[int] = []
    fallbacks = 0
    with collect_warnings() as caught:
        if o.limits != "none":
            q = project_into_limits(task, q, "q0")
        qs = [q.copy()]
        e = task.error(q, Vd)
        errs = [float(np.linalg.norm(e))]
        d, Jd = _distances(cm, q)
        D = [d.copy()]
        k = 0
        while k < o.steps and errs[-1] >= o.tol:
            J = task.evaluate_views(q)[2]
            b = o.gain * e
            try:
                qd, G, h, _, was_active, act, fb = _step(task, q, J, b, d, Jd, o, labels)
            except InfeasibleConstraintsError as exc:  # not expected: _step falls back (q̇ = 0 is feasible)
                infeasible = True
                message = f"stopped at step {k}: {exc}"
                break
            fallbacks += fb > 0
            if G.shape[0]:
                residual = max(residual, float(np.max(G @ qd - h)))
            n_rows.append(int(G.shape[0]))
            if o.mode == "none" or not (was_active or np.any(qd)):
                devs.append(0.0)
            else:
                ref = _velocity(task, q, J, b, o.dt, o.damping, o.limits, o.limit_gain, G[:0], h[:0], ()).x
                devs.append(float(np.linalg.norm(J @ (qd - ref))))
            active_steps += bool(was_active)
            active = act
            q = _advance(task, q, qd, o.dt, o.limits)
            e = task.error(q, Vd)
            d, Jd = _distances(cm, q)
            qs.append(q.copy())
            errs.append(float(np.linalg.norm(e)))
            D.append(d.copy())
            k += 1
    traj = np.array(qs)
    errors = np.array(errs)
    Dm = np.array(D)
    clearance = Dm.min(axis=1) if Dm.shape[1] else np.full(len(D), np.inf)
    if Dm.size:
        t_min, i_min = np.unravel_index(int(np.argmin(Dm)), Dm.shape)
        closest = f"{labels[i_min] if i_min < len(labels) else i_min} at step {t_min}"
    else:
        closest = ""
    violation, vviol, converged, message = reach_outcome(
        task, traj, errors, o.dt, o.tol, o.limits, infeasible, message, k, tuple(active)[:6], "active at the last step"
    )
    return AvoidanceResult(
        converged=converged,
        error=float(errors[-1]),
        iterations=k,
        message=message,
        q=q.copy(),
        warnings=dict(caught.counts),
        trajectory=traj,
        errors=errors,
        limits=o.limits,
        limit_violation=violation,
        velocity_violation=vviol,
        active_steps=active_steps,
        active_limits=active,
        infeasible=infeasible,
        mode=o.mode,
        clearance=clearance,
        clearances=Dm,
        labels=labels,
        min_clearance=float(np.min(clearance)),
        closest=closest,
        constraint_residual=residual,
        task_velocity_deviation=np.array(devs),
        active_rows=np.array(n_rows, int),
        fallback_steps=fallbacks,
    )


# ============================================================================ iLQR
@dataclass(frozen=True)
class ClearanceCost:
    """Running clearance cost of :func:`coop_ga.control.ilqr_reach` (``ILQROptions(clearance=...)``).

    ``c(q) = weight · Σ_i ½ max(0, d_a − d_i(q))²`` at every knot k = 1 … n (d_a = ``activation``
    [m], ``weight`` [1/m²]); exact gradient ``−weight · Σ_i max(0, d_a − d_i) ∇d_i`` from the model's
    Jacobian, Gauss–Newton Hessian ``weight · J_Aᵀ J_A`` (A: the pairs with d_i < d_a).
    """

    model: Any
    weight: float = 1e4
    activation: float = 0.05

    def __post_init__(self) -> None:
        check_collision_model(self.model)
        validation.positive(self.weight, "clearance weight")
        validation.scalar(self.activation, "clearance activation [m]")

    def evaluate(self, q: np.ndarray, hessian: bool = True) -> tuple[float, np.ndarray, np.ndarray | None, float]:
        """``(c, ∇c (nq,), GN Hessian (nq, nq) or None, min clearance [m])`` at one configuration."""
        d, Jd = _distances(self.model, np.asarray(q, float))
        viol = np.maximum(0.0, self.activation - d)
        c = 0.5 * self.weight * float(viol @ viol)
        g = -self.weight * (Jd.T @ viol)
        H = None
        if hessian:
            A = viol > 0
            JA = Jd[A]
            H = self.weight * (JA.T @ JA)
        return c, g, H, float(d.min(initial=np.inf))

    def value(self, q: np.ndarray) -> float:
        """c(q) at one configuration."""
        qv = np.asarray(q, float)
        dist = getattr(self.model, "distances", None)
        d = np.asarray(dist(qv), float).reshape(-1) if callable(dist) else _distances(self.model, qv)[0]
        viol = np.maximum(0.0, self.activation - d)
        return 0.5 * self.weight * float(viol @ viol)
