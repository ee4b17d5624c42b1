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

Joint limits (``limit_mode='enforce'``, the default): a two-level QP per step
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
stops there while V_Sc stays held.  ``limit_mode='clamp'`` (Eq 60, then q clipped) and
``'none'`` remain for comparison; ``project=False`` applies q̇₂ alone (clipped into the
velocity box with ``'enforce'``).

The step is one :func:`~coop_ga.control.solve_step`: the primary
:class:`~coop_ga.control.tasks.SimilarityTask` (hold V_hold, gain k_p, Jacobian J^G) at level 1, the
secondary task at level 2 (``levels=[[...]]``), the limits of
:func:`~coop_ga.control.limits.default_limits` — with the system's acceleration limits
(``acceleration_limit=True``, default; the robot starts at rest) — and the user rows.

Secondary task provided here (Eq 60): end point ``i`` of the task reaches a Euclidean
target ``p*`` [m] by ``q̇_{i,d} = J_{p,i}⁺ k_s (p* − p_i(q))`` with the 3×nq world-frame
point Jacobian of that chain only (its other columns are zero), i.e. ``[q̇_{0,d}; 0; 0]``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import validation
from ..diagnostics import collect_warnings
from ..errors import InvalidInputError
from ..geometry.groups import SimilarityLike
from ..geometry.primitives import center, normal
from .base import SolverResult, check_q, check_v, resolve_options
from .configuration import Configuration
from .diffik import step_limits
from .qp import DEFAULT_LIMIT_GAIN, project_into_limits
from .solve import RunHooks, StepSolution, advance, run_ik, solve_step
from .tasks import JointVelocityTask, PositionTask, SimilarityTask
from .tasks.points import end_index

#: ``'enforce'`` (two-level QP with position, velocity and acceleration limits, default), ``'clamp'``, ``'none'``
LIMIT_MODES = ("enforce", "clamp", "none")

__all__ = [
    "NullspaceOptions",
    "NullspaceResult",
    "nullspace_point_reach",
    "nullspace_step",
    "point_on_circle",
    "point_reaching_velocity",
]

_index = end_index


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
    """Secondary joint velocity ``[0 … q̇_{i,d} … 0]`` (nv,) moving end point ``index`` to ``target_point``.

    ``q̇ = J_p⁺ v`` with ``v = gain · (p* − p_i(q))`` [m/s] (capped at ``max_speed`` m/s),
    ``J_p`` the 3×nv world point Jacobian of end point ``index`` of ``task`` (only its own
    chain's columns are non-zero), damped pseudo-inverse with ``damping`` λ: the joint-space rows of a
    :class:`~coop_ga.control.tasks.PositionTask` with ``form='joint'``.
    """
    q = check_q(task, q)
    index = _index(task, index)
    pt = PositionTask(index, target_point, gain=gain, max_speed=max_speed, form="joint", damping=damping)
    return pt.qp_rows(Configuration(task, q))[1]


def _step(
    cfg: Any, hold: Any, secondary: Any, dt: float, primary_gain: float, damping: float, project: bool, lims: list
) -> StepSolution:
    """One step (module docstring): the primary task held at level 1 and the secondary one below it, or
    (``project=False``) the secondary velocity alone."""
    if not project:
        return solve_step(cfg, [secondary], lims, dt, damping=0.0)
    primary = SimilarityTask(hold, gain=primary_gain)
    return solve_step(cfg, [primary], lims, dt, damping=damping, levels=[[secondary]])


def nullspace_step(
    task: Any,
    q: Any,
    V_hold: SimilarityLike,
    qd_secondary: Any,
    *,
    dt: float = 0.01,
    primary_gain: float = 10.0,
    damping: float = 0.0,
    project: bool = True,
    limit_mode: str = "enforce",
    limit_gain: float = DEFAULT_LIMIT_GAIN,
    constraints: Any = None,
    velocity: Any = None,
    acceleration_limit: bool = True,
) -> np.ndarray:
    """One step ``q + Δt q̇`` with ``q̇ = J⁺ k_p log(Ṽ_Sc V_hold) + N q̇_2`` (Eq 58, 60, 61), within
    the joint limits by the two-level QP of the module docstring; returns q_next (nq,).

    Args:
        task: a :class:`coop_ga.CooperativeTask`.
        q: (nq,) [rad or m] (projected onto the limits, with a :class:`~coop_ga.errors.JointLimitWarning`,
            if outside and limit_mode ≠ 'none').
        V_hold: the similarity versor to keep (primary task).
        qd_secondary: (nv,) secondary joint velocity q̇_2 [rad/s] (nv = nq without a free flyer).
        dt: step [s].  primary_gain: k_p [1/s] of the primary error feedback (0 disables it).
        damping: λ of the pseudo-inverse in J⁺ and N (0 = exact projector, ``J N = 0``).
        project: False applies q̇_2 directly, without projection and without primary term.
        limit_mode: ``'enforce'`` (default: position, velocity and acceleration limits, two-level QP),
            ``'clamp'`` (Eq 60, then clip q; may break ``J N = 0``) or ``'none'``.
        limit_gain: safety gain γ ∈ (0, 1] of the position bounds.
        constraints: user rows ``G q̇ ≤ h`` on the joint velocity [rad/s], imposed on both levels.
        velocity: (nv,) the previous step's q̇ [rad/s] for the acceleration limit (None: at rest).
        acceleration_limit: impose the system's acceleration limits (``'enforce'`` only).

    With a free flyer (nq ≠ nv) q moves by ``system.integrate`` (``pinocchio.integrate``).

    Raises:
        InfeasibleConstraintsError: the constraints cannot be met with the limits.
    """
    validation.choice(limit_mode, LIMIT_MODES, "limit_mode")
    dt = validation.positive(dt, "dt")
    primary_gain = validation.nonnegative(primary_gain, "primary_gain")
    damping = validation.nonnegative(damping, "damping")
    limit_gain = validation.scalar(limit_gain, "limit_gain", low=0.0, high=1.0, low_open=True)
    if not isinstance(project, bool):
        raise InvalidInputError(f"project must be True or False, got {project!r}")
    q = check_q(task, q)
    qd2 = check_v(task, qd_secondary, "qd_secondary")
    hold = validation.target(V_hold, "V_hold")
    if limit_mode != "none":
        q = project_into_limits(task, q)
    cfg = Configuration(task, q, None if velocity is None else check_v(task, velocity, "velocity"))
    lims = step_limits(
        task, "none" if limit_mode == "clamp" else limit_mode, limit_gain, acceleration_limit, constraints
    )
    st = _step(cfg, hold, JointVelocityTask(qd2), dt, primary_gain, damping, project, lims)
    system = task.system
    if system.nq == system.nv:
        q_next = advance(q, st.velocity, dt)
        if limit_mode != "none":  # 'enforce': rounding only; 'clamp': the ablation
            np.clip(q_next, system.limits.lower, system.limits.upper, out=q_next)
    else:  # a free flyer: q moves by the system's integrate, the limits bound its velocity coordinates
        q_next = advance(q, st.velocity, dt, system)
        if limit_mode != "none":
            system.clip(q_next, out=q_next)
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
    limit_mode: ``'enforce'`` (default, two-level QP with the joint limits), ``'clamp'`` or ``'none'``.
    limit_gain: safety gain γ ∈ (0, 1] of the position bounds.
    acceleration_limit: with ``'enforce'``, the system's acceleration limits too (from rest).
    """

    duration: float = 4.0
    dt: float = 0.01
    secondary_gain: float = 2.0
    primary_gain: float = 10.0
    max_speed: float | None = 0.2
    damping: float = 0.0
    project: bool = True
    tol: float = 1e-3
    limit_mode: str = "enforce"
    limit_gain: float = DEFAULT_LIMIT_GAIN
    acceleration_limit: bool = True

    def __post_init__(self) -> None:
        if not isinstance(self.acceleration_limit, bool):
            raise InvalidInputError(f"acceleration_limit must be True or False, got {self.acceleration_limit!r}")
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
        validation.choice(self.limit_mode, LIMIT_MODES, "limit_mode")
        validation.scalar(self.limit_gain, "limit_gain", low=0.0, high=1.0, low_open=True)


@dataclass(frozen=True, kw_only=True)
class NullspaceResult(SolverResult):
    """Result of :func:`nullspace_point_reach` (T = steps + 1; ``error`` = final point error [m],
    ``converged`` iff it is < ``tol``, ``iterations`` = steps, ``q`` = final configuration):

    t (T,) [s]; trajectory (T, nq); points (T, 3) the controlled end point [m];
    point_error (T,) ‖p_i − p*‖ [m]; similarity_distance (T,) ‖log(Ṽ_Sc(q_0) V_Sc(q_t))‖;
    target_point (3,); projected: whether Eq 60 was used.
    limit_mode: the limit mode; limit_violation: largest excursion of the trajectory outside the
    position limits [rad or m]; velocity_violation: largest excess of |Δq/Δt| over the velocity
    limits [rad/s]; active_steps: steps at which a bound or constraint was active (the QP of
    the module docstring was solved); active_limits: bounds active at the last step;
    max_acceleration_violation: largest excess of the finite-difference acceleration (from rest) over the
    acceleration limits [rad/s²]; relaxed_steps: steps on which the acceleration bounds had to be dropped.
    ``converged`` also requires the imposed limits to hold (position; acceleration when imposed).
    """

    t: np.ndarray
    trajectory: np.ndarray
    points: np.ndarray
    point_error: np.ndarray
    similarity_distance: np.ndarray
    target_point: np.ndarray
    projected: bool
    limit_mode: str = "enforce"
    limit_violation: float = 0.0
    velocity_violation: float = 0.0
    active_steps: int = 0
    active_limits: tuple[str, ...] = ()
    max_acceleration_violation: float = 0.0
    relaxed_steps: int = 0


def nullspace_point_reach(
    task: Any,
    q_init: Any,
    index: int,
    target_point: Any,
    options: NullspaceOptions | None = None,
    *,
    V_hold: SimilarityLike | None = None,
    constraints: Any = None,
    **overrides: Any,
) -> NullspaceResult:
    """§4.3 experiment: end point ``index`` reaches ``target_point`` [m] while V_Sc is held (Eq 60).

    The primary task holds ``V_hold`` (a :class:`~coop_ga.Similarity`; default V_Sc(q_init)); the
    secondary task is a :class:`~coop_ga.control.tasks.PositionTask` in joint-space form
    (:func:`point_reaching_velocity`); every step is the two-level :func:`~coop_ga.control.solve_step`
    of :func:`nullspace_step`, iterated by :func:`~coop_ga.control.run_ik` for ``duration``.
    ``options``: :class:`NullspaceOptions` (keyword ``overrides`` replace its fields); ``project=False``
    reproduces Fig. 16.  ``constraints``: user rows ``G q̇ ≤ h`` [rad/s] imposed at every step (an
    incompatible set stops the run, ``message`` says where).
    """
    o = resolve_options(NullspaceOptions, options, overrides, "nullspace_point_reach")
    q = check_q(task, q_init, "q_init")
    index = _index(task, index)
    p_star = validation.vector(target_point, 3, "target_point [m]")
    n = round(o.duration / o.dt)
    secondary = PositionTask(index, p_star, gain=o.secondary_gain, max_speed=o.max_speed, form="joint")
    lims = step_limits(
        task, "none" if o.limit_mode == "clamp" else o.limit_mode, o.limit_gain, o.acceleration_limit, constraints
    )
    with collect_warnings() as caught:
        if o.limit_mode != "none":
            q = project_into_limits(task, q, "q_init")
        hold = task.similarity(q) if V_hold is None else validation.target(V_hold, "V_hold")
        V0 = task.similarity(q)

        def step(cfg: Any) -> StepSolution:
            return _step(cfg, hold, secondary, o.dt, o.primary_gain, o.damping, o.project, lims)

        hooks = RunHooks(step=step, clip=o.limit_mode != "none")
        run = run_ik(Configuration(task, q), [secondary], lims, dt=o.dt, steps=n, hooks=hooks)
        Qa = run.trajectory
        P = np.array([task.points(qk)[index] for qk in Qa])
        V0i = V0.inverse()
        dist = np.array([np.linalg.norm((V0i @ task.similarity(qk)).log()) for qk in Qa])
    err = np.linalg.norm(P - p_star, axis=1)
    converged = bool(err[-1] < o.tol and (run.converged or o.limit_mode == "none"))
    msg = f"end point {index} is {err[-1]:.3g} m from the target after {o.duration:g} s"
    if run.infeasible:
        msg += f"; {run.message}"
    elif not run.converged and o.limit_mode != "none":
        msg += f"; {run.message}"
    if not converged and run.active_limits:
        msg += f"; bounds active at the last step: {', '.join(run.active_limits)}"
    return NullspaceResult(
        converged=converged,
        error=float(err[-1]),
        iterations=run.iterations,
        message=msg,
        q=Qa[-1].copy(),
        warnings=dict(caught.counts),
        t=np.arange(len(Qa)) * o.dt,
        trajectory=Qa,
        points=P,
        point_error=err,
        similarity_distance=dist,
        target_point=p_star,
        projected=o.project,
        limit_mode=o.limit_mode,
        limit_violation=run.max_position_violation,
        velocity_violation=run.max_velocity_violation,
        active_steps=run.active_steps,
        active_limits=run.active_limits,
        max_acceleration_violation=run.max_acceleration_violation,
        relaxed_steps=run.relaxed_steps,
    )
