"""Secondary tasks in the geometric nullspace of a cooperative primitive (§3.10, §4.3, Eq 58, 60).

Primary task: keep the cooperative similarity at ``V_hold`` (e.g. V_Sc(q_0): "stay on the
circle").  Secondary task: any joint velocity ``q̇_2`` (e.g. one arm reaching a point),
executed only through the nullspace projector of the geometric similarity Jacobian::

    N(q)  = I − J^G⁺ J^G                                         (Eq 58)
    q̇     = J^G⁺ (k_p · log(Ṽ_Sc(q) V_hold)) + N(q) q̇_2           (Eq 48 + Eq 60)
    q_{t+1} = q_t + Δt q̇                                          (Eq 61)

``N`` uses the exact (undamped, SVD rank-revealing) pseudo-inverse, so ``J^G N q̇_2 = 0``
and the secondary motion leaves V_Sc unchanged to first order; the primary feedback term
(gain ``k_p`` [1/s]) removes the second-order drift of the discrete steps.  With
``project=False`` the secondary velocity is applied unprojected and without the primary
term — the paper's Fig. 16 counter-example, where the similarity distance grows.

Joint limits (``limits='enforce'``, the default): a two-level QP per step
-----------------------------------------------------------------------
With the position and velocity limits of ``task.system.limits`` turned into the joint
velocity box ``lb ≤ q̇ ≤ ub`` of :func:`coop_ga.control.qp.velocity_bounds` (position limits
over Δt with the safety gain γ, ∩ |q̇| ≤ v), the step is the lexicographic solution

1. primary:   q̇₁ = argmin ½‖J^G q̇ − k_p e‖² + ½λ²‖q̇‖²  s.t. lb ≤ q̇ ≤ ub (and G q̇ ≤ h);
2. secondary: q̇  = argmin ½‖q̇ − q̇₂‖²  s.t. V_rᵀ q̇ = V_rᵀ q̇₁, lb ≤ q̇ ≤ ub (and G q̇ ≤ h),

with V_r the r right singular vectors of J^G with σ > 1e-10 σ_max (an orthonormal basis
of its row space), so ``J^G q̇ = J^G q̇₁``: the secondary task can use every direction the
limits leave free but never changes the primary's task velocity.  When no bound is
active this is exactly Eq 60, ``q̇ = q̇₁ + N q̇₂`` (and that formula is then used as is, so
the unconstrained numbers are unchanged); when the secondary task runs into a limit it
stops there while V_Sc stays held.  ``limits='clamp'`` (Eq 60, then q clipped) and
``'none'`` remain for comparison; ``project=False`` applies q̇₂ alone (clipped into the
velocity box with ``'enforce'``).

Secondary task provided here (Eq 60): end point ``i`` of the task reaches a Euclidean
target ``p*`` [m] by ``q̇_{i,d} = J_{p,i}⁺ k_s (p* − p_i(q))`` with the 3×nq world-frame
point Jacobian of that chain only (its other columns are zero), i.e. ``[q̇_{0,d}; 0; 0]``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import validation
from ..cooperative.manipulability import damped_pinv
from ..diagnostics import collect_warnings
from ..errors import InvalidInputError
from ..geometry.primitives import center, normal
from .base import SolverResult, bounds, check_q, resolve_options
from .qp import (
    DEFAULT_LIMIT_GAIN,
    InfeasibleConstraintsError,
    QPSolution,
    classify_velocity_box,
    describe_active,
    limit_arrays,
    project_into_limits,
    solve_qp,
    stack_constraints,
    velocity_bounds,
)

#: ``'enforce'`` (two-level QP with position and velocity limits, default), ``'clamp'``, ``'none'``
LIMIT_MODES = ("enforce", "clamp", "none")

__all__ = [
    "NullspaceOptions",
    "NullspaceResult",
    "nullspace_point_reach",
    "nullspace_step",
    "point_on_circle",
    "point_reaching_velocity",
]


def _index(task: Any, index: Any) -> int:
    n = len(task.end_frames)
    i = validation.integer(index, "index")
    if not 0 <= i < n:
        raise InvalidInputError(
            f"index must be an end point of the task, 0 ≤ index < {n} ({', '.join(task.end_frames)}); got {index!r}"
        )
    return i


def point_reaching_velocity(
    task: Any,
    q: Any,
    index: int,
    target_point: Any,
    *,
    gain: float = 1.0,
    damping: float = 1e-3,
    max_speed: float | None = 0.2,
) -> np.ndarray:
    """Secondary joint velocity ``[0 … q̇_{i,d} … 0]`` (nq,) moving end point ``index`` to ``target_point``.

    ``q̇ = J_p⁺ v`` with ``v = gain · (p* − p_i(q))`` [m/s] (capped at ``max_speed`` m/s),
    ``J_p`` the 3×nq world point Jacobian of end point ``index`` of ``task`` (only its own
    chain's columns are non-zero), damped pseudo-inverse with ``damping`` λ.
    """
    q = check_q(task, q)
    index = _index(task, index)
    p_star = validation.vector(target_point, 3, "target_point [m]")
    gain = validation.nonnegative(gain, "gain")
    damping = validation.nonnegative(damping, "damping")
    if max_speed is not None:
        max_speed = validation.positive(max_speed, "max_speed", allow_inf=True)
    p = task.tree.end_points_array(q)[index]
    Jp = task.tree.euclidean_point_jacobians(q)[index]
    v = gain * (p_star - p)
    if max_speed is not None:
        s = float(np.linalg.norm(v))
        if s > max_speed:
            v *= max_speed / s
    return damped_pinv(Jp, damping) @ v


def _hierarchical_velocity(
    task: Any,
    q: np.ndarray,
    e: np.ndarray | None,
    J: np.ndarray | None,
    qd2: np.ndarray,
    dt: float,
    primary_gain: float,
    damping: float,
    project: bool,
    limits: str,
    limit_gain: float,
    G: np.ndarray,
    h: np.ndarray,
    labels: tuple[str, ...],
) -> tuple[np.ndarray, bool, tuple[str, ...]]:
    """``(q̇, a bound or constraint was active, labels of the active bounds)`` of one step (module docstring)."""
    n = qd2.shape[0]
    m = G.shape[0]
    Gm, hm = (G, h) if m else (None, None)
    lb: np.ndarray | None
    ub: np.ndarray | None
    if limits == "enforce":
        lower, upper, vel = limit_arrays(task)
        lb, ub = velocity_bounds(q, lower, upper, vel, dt, limit_gain)
    else:
        lb = ub = None
    eye = np.eye(n)
    if not project:
        if m == 0:
            qd = qd2 if lb is None else np.clip(qd2, lb, ub)
            sol = QPSolution(
                qd,
                bool(np.any(qd != qd2)),
                qd <= lb if lb is not None else np.zeros(n, bool),
                qd >= ub if ub is not None else np.zeros(n, bool),
                np.zeros(0, bool),
                "clip",
            )
        else:
            sol = solve_qp(eye, qd2, 0.0, lb, ub, Gm, hm, x_free=qd2, labels=labels, what="nullspace step")
    else:
        assert e is not None and J is not None
        Jp = damped_pinv(J, damping)
        x1_free = Jp @ (primary_gain * e)
        x_free = x1_free + (qd2 - Jp @ (J @ qd2))  # Eq 58 + 60
        if (lb is None or (np.all(x_free >= lb) and np.all(x_free <= ub))) and (m == 0 or np.all(G @ x_free <= h)):
            return x_free, False, ()
        level1 = solve_qp(
            J,
            primary_gain * e,
            damping,
            lb,
            ub,
            Gm,
            hm,
            x_free=x1_free,
            labels=labels,
            what="nullspace step (primary task)",
        )
        x1 = level1.x
        _, sv, Vt = np.linalg.svd(J, full_matrices=False)
        Vr = Vt[sv > 1e-10 * sv[0]] if sv.size and sv[0] > 0 else Vt[:0]
        try:
            sol = solve_qp(
                eye,
                qd2,
                0.0,
                lb,
                ub,
                Gm,
                hm,
                E=Vr,
                f=Vr @ x1,
                x_free=None,
                labels=labels,
                what="nullspace step (secondary task)",
            )
        except InfeasibleConstraintsError:
            # cannot happen in exact arithmetic (q̇₁ is feasible); if the solver fails numerically the
            # step falls back to the primary solution q̇₁ — feasible, V_Sc held — and says so
            return x1, True, ("secondary task dropped at this step (QP solver failure)",)
    active: tuple[str, ...] = ()
    if lb is not None:
        lower, upper, vel = limit_arrays(task)
        lo_i, hi_i, v_i = classify_velocity_box(sol, q, lower, upper, vel, dt, limit_gain)
        active = describe_active(task, q, lo_i, hi_i, v_i)
    active += tuple(lab for lab, a in zip(labels, sol.active_rows) if a)
    return sol.x, bool(sol.used_qp or sol.n_active), active


def nullspace_step(
    task: Any,
    q: Any,
    V_hold: Any,
    qd_secondary: Any,
    *,
    dt: float = 0.01,
    primary_gain: float = 10.0,
    damping: float = 0.0,
    project: bool = True,
    limits: str = "enforce",
    limit_gain: float = DEFAULT_LIMIT_GAIN,
    constraints: Any = None,
) -> np.ndarray:
    """One step ``q + Δt q̇`` with ``q̇ = J⁺ k_p log(Ṽ_Sc V_hold) + N q̇_2`` (Eq 58, 60, 61), within
    the joint limits by the two-level QP of the module docstring; returns q_next (nq,).

    Parameters
    ----------
    task: a :class:`coop_ga.CooperativeTask`.   q: (nq,) [rad or m] (projected onto the
        limits, with a :class:`~coop_ga.errors.JointLimitWarning`, if outside and limits ≠ 'none').
    V_hold: the similarity versor to keep (primary task).
    qd_secondary: (nq,) secondary joint velocity q̇_2 [rad/s].
    dt: step [s].  primary_gain: k_p [1/s] of the primary error feedback (0 disables it).
    damping: λ of the pseudo-inverse in J⁺ and N (0 = exact projector, ``J N = 0``).
    project: False applies q̇_2 directly, without projection and without primary term.
    limits: ``'enforce'`` (default: position and velocity limits, two-level QP), ``'clamp'``
        (Eq 60, then clip q; may break ``J N = 0``) or ``'none'``.
    limit_gain: safety gain γ ∈ (0, 1] of the position bounds.
    constraints: user rows ``G q̇ ≤ h`` on the joint velocity [rad/s]
        (:class:`~coop_ga.control.qp.LinearConstraint`), imposed on both levels; an
        incompatible set raises :class:`~coop_ga.errors.InfeasibleConstraintsError`.
    """
    validation.choice(limits, LIMIT_MODES, "limits")
    dt = validation.positive(dt, "dt")
    primary_gain = validation.nonnegative(primary_gain, "primary_gain")
    damping = validation.nonnegative(damping, "damping")
    limit_gain = validation.scalar(limit_gain, "limit_gain", low=0.0, high=1.0, low_open=True)
    if not isinstance(project, bool):
        raise InvalidInputError(f"project must be True or False, got {project!r}")
    q = check_q(task, q)
    qd2 = check_q(task, qd_secondary, "qd_secondary")
    hold = validation.target(V_hold, "V_hold")
    G, h, labels = stack_constraints(constraints, task.nq)
    if limits != "none":
        q = project_into_limits(task, q)
    qd = _step_velocity(task, q, hold, qd2, dt, primary_gain, damping, project, limits, limit_gain, G, h, labels)[0]
    return _advance(task, q, qd, dt, limits)


def _step_velocity(
    task: Any,
    q: np.ndarray,
    hold: Any,
    qd2: np.ndarray,
    dt: float,
    primary_gain: float,
    damping: float,
    project: bool,
    limits: str,
    limit_gain: float,
    G: np.ndarray,
    h: np.ndarray,
    labels: tuple[str, ...],
) -> tuple[np.ndarray, bool, tuple[str, ...]]:
    if project:
        e = task.error(q, hold)
        J = task.evaluate_views(q)[2]
    else:
        e = J = None
    mode = "none" if limits == "clamp" else limits
    return _hierarchical_velocity(
        task, q, e, J, qd2, dt, primary_gain, damping, project, mode, limit_gain, G, h, labels
    )


def _advance(task: Any, q: np.ndarray, qd: np.ndarray, dt: float, limits: str) -> np.ndarray:
    q_next = q + dt * qd
    if limits != "none":  # 'enforce': rounding only; 'clamp': the ablation
        lo, hi = bounds(task)
        np.clip(q_next, lo, hi, out=q_next)
    return q_next


def point_on_circle(task: Any, q: Any, index: int, angle: float) -> np.ndarray:
    """End point ``index`` (of a circle task) rotated by ``angle`` [rad] along the cooperative
    circle: about its axis ``normal(X_c)`` through ``center(X_c)``, right-handed about the
    normal.  Returns (3,) [m], world frame."""
    X = task.primitive(q)
    c = np.asarray(center(X), float).reshape(3)
    n = np.asarray(normal(X), float).reshape(3)
    n = n / np.linalg.norm(n)
    index = _index(task, index)
    angle = validation.scalar(angle, "angle")
    p = task.points(q)[index] - c
    p_rot = p * np.cos(angle) + np.cross(n, p) * np.sin(angle) + n * (n @ p) * (1 - np.cos(angle))
    return c + p_rot


@dataclass(frozen=True)
class NullspaceOptions:
    """Settings of :func:`nullspace_point_reach`.

    duration: simulated time [s]; dt: step [s].
    secondary_gain: k_s [1/s] of the point-reaching task; max_speed: its speed cap [m/s] (None: no cap).
    primary_gain: k_p [1/s] of the primary error feedback (0 disables it).
    damping: λ of the pseudo-inverse in J⁺ and N (0 = exact projector, ``J N = 0``).
    project: False applies q̇_2 unprojected and without the primary term (Fig. 16).
    tol: the result is ``converged`` when the final point error < tol [m].
    limits: ``'enforce'`` (default, two-level QP with the joint limits), ``'clamp'`` or ``'none'``.
    limit_gain: safety gain γ ∈ (0, 1] of the position bounds.
    """

    duration: float = 4.0
    dt: float = 0.01
    secondary_gain: float = 2.0
    primary_gain: float = 10.0
    max_speed: float | None = 0.2
    damping: float = 0.0
    project: bool = True
    tol: float = 1e-3
    limits: str = "enforce"
    limit_gain: float = DEFAULT_LIMIT_GAIN

    def __post_init__(self) -> None:
        validation.nonnegative(self.duration, "duration")
        validation.positive(self.dt, "dt")
        validation.nonnegative(self.secondary_gain, "secondary_gain")
        validation.nonnegative(self.primary_gain, "primary_gain")
        if self.max_speed is not None:
            validation.positive(self.max_speed, "max_speed", allow_inf=True)
        validation.nonnegative(self.damping, "damping")
        if not isinstance(self.project, bool):
            raise InvalidInputError(f"project must be True or False, got {self.project!r}")
        validation.nonnegative(self.tol, "tol")
        validation.choice(self.limits, LIMIT_MODES, "limits")
        validation.scalar(self.limit_gain, "limit_gain", low=0.0, high=1.0, low_open=True)


@dataclass(frozen=True, kw_only=True)
class NullspaceResult(SolverResult):
    """Result of :func:`nullspace_point_reach` (T = steps + 1; ``error`` = final point error [m],
    ``converged`` iff it is < ``tol``, ``iterations`` = steps, ``q`` = final configuration):

    t (T,) [s]; trajectory (T, nq); points (T, 3) the controlled end point [m];
    point_error (T,) ‖p_i − p*‖ [m]; similarity_distance (T,) ‖log(Ṽ_Sc(q_0) V_Sc(q_t))‖;
    target_point (3,); projected: whether Eq 60 was used.
    limits: the limit mode; limit_violation: largest excursion of the trajectory outside the
    position limits [rad or m]; velocity_violation: largest excess of |Δq/Δt| over the velocity
    limits [rad/s]; active_steps: steps at which a bound or constraint was active (the QP of
    the module docstring was solved); active_limits: bounds active at the last step.
    """

    t: np.ndarray
    trajectory: np.ndarray
    points: np.ndarray
    point_error: np.ndarray
    similarity_distance: np.ndarray
    target_point: np.ndarray
    projected: bool
    limits: str = "enforce"
    limit_violation: float = 0.0
    velocity_violation: float = 0.0
    active_steps: int = 0
    active_limits: tuple[str, ...] = ()


def nullspace_point_reach(
    task: Any,
    q0: Any,
    index: int,
    target_point: Any,
    options: NullspaceOptions | None = None,
    *,
    V_hold: Any = None,
    constraints: Any = None,
    **overrides: Any,
) -> NullspaceResult:
    """§4.3 experiment: end point ``index`` reaches ``target_point`` [m] while V_Sc is held (Eq 60).

    The primary task holds ``V_hold`` (a :class:`~coop_ga.Similarity`; default V_Sc(q0)); the
    secondary task is :func:`point_reaching_velocity`; every step is :func:`nullspace_step`
    (the two-level QP with the joint limits by default).  ``options``:
    :class:`NullspaceOptions` (keyword ``overrides`` replace its fields); ``project=False``
    reproduces Fig. 16.  ``constraints``: user rows ``G q̇ ≤ h`` [rad/s] imposed at every
    step (an incompatible set raises :class:`~coop_ga.errors.InfeasibleConstraintsError`).
    """
    o = resolve_options(NullspaceOptions, options, overrides, "nullspace_point_reach")
    q = check_q(task, q0, "q0")
    index = _index(task, index)
    p_star = validation.vector(target_point, 3, "target_point [m]")
    n = round(o.duration / o.dt)
    G, h, labels = stack_constraints(constraints, task.nq)
    active_steps = 0
    active: tuple[str, ...] = ()
    with collect_warnings() as caught:
        if o.limits != "none":
            q = project_into_limits(task, q, "q0")
        hold = task.similarity(q) if V_hold is None else validation.target(V_hold, "V_hold")
        V0 = task.similarity(q)
        Q = [q.copy()]
        for _ in range(n):
            qd2 = point_reaching_velocity(task, q, index, p_star, gain=o.secondary_gain, max_speed=o.max_speed)
            qd, was_active, act = _step_velocity(
                task, q, hold, qd2, o.dt, o.primary_gain, o.damping, o.project, o.limits, o.limit_gain, G, h, labels
            )
            active_steps += was_active
            active = act
            q = _advance(task, q, qd, o.dt, o.limits)
            Q.append(q.copy())
        Qa = np.array(Q)
        P = np.array([task.points(qk)[index] for qk in Qa])
        V0i = V0.inverse()
        dist = np.array([np.linalg.norm((V0i @ task.similarity(qk)).log()) for qk in Qa])
    lim = task.system.limits
    err = np.linalg.norm(P - p_star, axis=1)
    converged = bool(err[-1] < o.tol)
    msg = f"end point {index} is {err[-1]:.3g} m from the target after {o.duration:g} s"
    if not converged and active:
        msg += f"; bounds active at the last step: {', '.join(active)}"
    return NullspaceResult(
        converged=converged,
        error=float(err[-1]),
        iterations=n,
        message=msg,
        q=Qa[-1].copy(),
        warnings=dict(caught.counts),
        t=np.arange(n + 1) * o.dt,
        trajectory=Qa,
        points=P,
        point_error=err,
        similarity_distance=dist,
        target_point=p_star,
        projected=o.project,
        limits=o.limits,
        limit_violation=lim.position_violation(Qa),
        velocity_violation=lim.trajectory_velocity_violation(Qa, o.dt) if n else 0.0,
        active_steps=int(active_steps),
        active_limits=active,
    )
