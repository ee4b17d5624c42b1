"""Differential inverse kinematics in the cooperative similarity space (Eq 48, 61), as a QP.

Convention (the one every controller in :mod:`coop_ga.control` uses)
-------------------------------------------------------------------
``J^G`` (7×nq, rows ``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]``) is a *body-frame*
Jacobian: for a joint velocity ``q̇`` the 7-vector ``b = J^G q̇`` satisfies, to first
order in Δt,

    V_Sc(q + Δt q̇) ≈ V_Sc(q) · exp(Δt b).

So a commanded body velocity bivector ``B_S`` (7,) [rad/s for the rotation rows, 1/s
(log of scale per second) for e0∞, body length units per second for the translation
rows, all expressed in the current cooperative frame V_Sc(q)] is realised by the damped
least-squares joint velocity (Eq 48, 61).  Note that the body frame of V_Sc is *scaled*:
V_Sc = V_T V_R V_D contains the primitive's dilation (radius r of a circle or sphere), so
a body translation t moves the primitive by ``r · R t`` metres in the world.

    q̇ = J^G⁺ B_S,        q_{t+1} = q_t + Δt q̇.

The step as a QP (``limit_mode='enforce'``, the default)
---------------------------------------------------
Eq 48 is the minimiser of ``½‖J^G q̇ − B_S‖² + ½λ²‖q̇‖²`` (λ = ``damping``).  With the
state and control constraints of Eq 53 (𝒳: position limits, 𝒰: velocity limits of
``task.system.limits``) each step solves instead

    min_q̇  ½‖J^G q̇ − B_S‖² + ½λ²‖q̇‖²
    s.t.   max(−v, γ (lower − q)/Δt) ≤ q̇ ≤ min(v, γ (upper − q)/Δt)     (position over Δt ∩ velocity)
           G q̇ ≤ h                                                      (optional user constraints)

(one :func:`~coop_ga.control.solve_step` with a :class:`~coop_ga.control.tasks.SimilarityTask` and the
limits of :func:`~coop_ga.control.limits.default_limits`: DAQP through
:func:`coop_ga.control.qp.solve_qp`; γ = ``limit_gain``, the safety gain of pink/mink's
``ConfigurationLimit``).  So ``q_{t+1} = q_t + Δt q̇`` stays within the
position limits, ``|q̇| ≤ v``, and the task motion a blocked joint cannot make is
redistributed over the other joints (the nullspace of J^G) instead of being lost.  When the
unconstrained Eq 48 velocity already satisfies every bound it is used as is (no QP is
solved; results are then identical to ``limit_mode='none'``).  ``limit_mode='clamp'`` (the former
default, kept as an ablation) takes the Eq 48 step and clips q to the limits afterwards (a
blocked joint simply stops; no velocity limit); ``limit_mode='none'`` imposes nothing.
A start outside the position limits is projected onto them first, with a
:class:`~coop_ga.errors.JointLimitWarning`.

Acceleration limits (on by default when the system has them)
-------------------------------------------------------------
With ``acceleration_limit=True`` (default) and a system that bounds joint accelerations (the Franka
systems: :data:`~coop_ga.systems.library.PANDA_ACCELERATION_LIMITS`), the box also holds
``|q̇ − q̇_prev| ≤ a Δt`` and the braking bounds of :class:`~coop_ga.control.limits.AccelerationLimit`
(the robot starts at rest).  Without them the velocity of the first step jumped from 0 to its
limit within one 10 ms step (up to 58× the Franka's acceleration limits); the result reports
``max_acceleration_violation`` either way.

User constraints (``constraints=``) are rows ``G q̇ ≤ h`` on the joint velocity
[rad/s] — see :class:`~coop_ga.control.qp.LinearConstraint` for units and frames (e.g. a
half-space on an end-point velocity, ``G = nᵀ J_p``).  When they cannot be met together
with the limits, :func:`diff_ik_step` raises
:class:`~coop_ga.errors.InfeasibleConstraintsError`; :func:`diff_ik_reach` stops there
and reports it (``infeasible=True``), returning the last feasible configuration.

Reaching a target ``V_Sd``: the error ``e = log(Ṽ_Sc(q) V_Sd)`` (Eq 44) is the target
seen from the current pose; after a step ``Ṽ_Sc(q_{t+1}) V_Sd ≈ exp(−Δt b) exp(e)``, so
commanding ``b = gain · e`` decreases the error like ``e_{t+1} ≈ (1 − gain Δt) e_t``
(exactly on the controllable directions; the uncontrollable ones of Table 1 — e.g. the
seventh direction of a circle — cannot be reduced, see :class:`DiffIKResult`).

Tolerance, gain and time
------------------------
From ``‖e_k‖ ≈ (1 − gain Δt)^k ‖e_0‖`` the time to reach ``tol`` is

    T(tol) ≈ Δt · ln(‖e_0‖/tol) / −ln(1 − gain Δt)  ≈  ln(‖e_0‖/tol) / gain.

The defaults (gain 10 1/s, Δt 0.01 s, 250 steps = 2.5 s, tol 1e-4) give T ≈ 0.9 s for
‖e_0‖ = 1 (a 15 cm / 35° / 30 % displacement is ‖e_0‖ ≈ 0.3–1), so 2.5 s leaves room
for the slow-down where velocity limits saturate (the decay is then linear, not
geometric, until they release) and for bound-active steps.  ``gain · Δt`` must stay
well below 1 (``= 1`` is one damped Gauss–Newton step per Δt; larger overshoots).
Measured with these defaults, before the acceleration limits (they slow the first steps from rest
on the Franka systems), on 2160 realisable targets (9 systems × every primitive kind
× 2/5/15 cm, 5/15/35°, 5/15/30 % displacements from q0): of the 1637 targets that some
solver reached inside the limits, ``'enforce'`` reaches 1e-4 within 2.5 s on all (median
73 steps, at most 181), ``'clamp'`` on 97.4 % (worst system/kind: 79 %).  In a smaller run
(918 targets, from q0 and from random starts) gain 1 /s (the former default) reached none
of the certified targets within 2.5 s, gains 4, 10 and 20 /s all of them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import validation
from ..cooperative.manipulability import damped_pinv
from ..diagnostics import collect_warnings, warn
from ..errors import InvalidInputError, JointLimitWarning
from ..geometry.groups import SimilarityLike
from .base import SolverResult, check_problem, check_q, check_v, resolve_options
from .configuration import Configuration
from .limits import Limit, UserConstraints, default_limits
from .qp import DEFAULT_LIMIT_GAIN, LinearConstraint, QPSolution, project_into_limits
from .solve import IKRun, RunHooks, advance, run_ik, solve_step
from .tasks import SimilarityTask
from .tasks.similarity import BodyVelocityTask

__all__ = [
    "DiffIKOptions",
    "DiffIKResult",
    "LinearConstraint",
    "diff_ik_reach",
    "diff_ik_step",
    "diff_ik_velocity",
    "joint_velocity",
    "step_limits",
]

#: ``'enforce'`` (QP with position and velocity limits, default), ``'clamp'`` (ablation), ``'none'``
LIMIT_MODES = ("enforce", "clamp", "none")


def _check_bivector(b: Any, what: str = "command_bivector") -> np.ndarray:
    """A 7-vector (7,) — or a (7, 1) column, as the task's ``evaluate_views`` returns B."""
    if isinstance(b, np.ndarray) and b.shape == (7, 1):
        b = b.reshape(7)
    return validation.vector(b, 7, f"{what} [e12, e13, e23, e0∞, e1∞, e2∞, e3∞]")


def _check_gain(limit_gain: Any) -> float:
    return validation.scalar(limit_gain, "limit_gain", low=0.0, high=1.0, low_open=True)


def joint_velocity(J: Any, command_bivector: Any, damping: float = 1e-3) -> np.ndarray:
    """``q̇ = J⁺ B`` (nq,) with the damped pseudo-inverse ``Jᵀ(J Jᵀ + λ² I)⁻¹`` (Eq 48), no limits.

    ``J`` is the 7×nq body-frame Jacobian, ``command_bivector`` the 7-vector B_S,
    ``damping`` λ (same units as J's singular values).
    """
    return damped_pinv(J, validation.nonnegative(damping, "damping")) @ _check_bivector(command_bivector)


def step_limits(task: Any, mode: str, limit_gain: float, acceleration: bool, constraints: Any = None) -> list[Any]:
    """The limits of a differential-IK step: :func:`~coop_ga.control.limits.default_limits` for ``'enforce'``
    (none for ``'clamp'``/``'none'``), then the user ``constraints``: rows, a function of q giving rows, or
    :class:`~coop_ga.control.limits.Limit` objects (e.g. a :class:`~coop_ga.control.limits.ClearanceLimit`)."""
    lims: list[Any] = default_limits(task.system.limits, limit_gain, acceleration) if mode == "enforce" else []
    if constraints is None:
        return lims
    items = constraints if isinstance(constraints, list) else [constraints]
    if all(isinstance(c, Limit) and not isinstance(c, LinearConstraint) for c in items):
        return lims + list(items)  # limits (e.g. a ClearanceLimit): evaluated on the step's configuration and Δt
    return lims + [UserConstraints(constraints, getattr(task, "nv", task.nq))]


def _step(
    task: Any, q: Any, command_bivector: Any, dt: Any, damping: Any, limit_mode: Any, limit_gain: Any, constraints: Any,
    velocity: Any, acceleration_limit: bool,
) -> tuple[np.ndarray, QPSolution]:  # fmt: skip
    validation.choice(limit_mode, LIMIT_MODES, "limit_mode")
    dt = validation.positive(dt, "dt")
    damping = validation.nonnegative(damping, "damping")
    gain = _check_gain(limit_gain)
    qv = check_q(task, q)
    b = _check_bivector(command_bivector)
    if limit_mode != "none":
        qv = project_into_limits(task, qv)
    cfg = Configuration(task, qv, None if velocity is None else check_v(task, velocity, "velocity"))
    lims = step_limits(task, limit_mode, gain, acceleration_limit, constraints)
    return qv, solve_step(cfg, [BodyVelocityTask(b)], lims, dt, damping=damping).solution


def diff_ik_velocity(
    task: Any,
    q: Any,
    command_bivector: Any,
    *,
    dt: float = 0.01,
    damping: float = 1e-3,
    limit_mode: str = "enforce",
    limit_gain: float = DEFAULT_LIMIT_GAIN,
    constraints: Any = None,
    velocity: Any = None,
    acceleration_limit: bool = True,
) -> QPSolution:
    """The joint velocity of one differential-IK step (Eq 48 as a QP, module docstring).

    Args:
        task: a :class:`coop_ga.CooperativeTask`.
        q: (nq,) joint configuration [rad or m] (inside the position limits for ``'enforce'``;
            otherwise it is projected onto them with a :class:`~coop_ga.errors.JointLimitWarning`).
        command_bivector: (7,) body-frame similarity velocity B_S [rad/s, 1/s, body length/s].
        dt: Δt [s] (> 0), over which the position limits are turned into velocity bounds.
        damping: λ (≥ 0).
        limit_mode: ``'enforce'``, ``'clamp'`` or ``'none'`` (for ``'clamp'`` the velocity is the
            unconstrained one: clipping happens on q).
        limit_gain: γ ∈ (0, 1], the fraction of the remaining range a joint may cover per step.
        constraints: user rows ``G q̇ ≤ h`` (:class:`~coop_ga.control.qp.LinearConstraint`, a
            ``(G, h)`` pair or a list of them), or None.
        velocity: (nq,) the previous step's q̇ [rad/s] for the acceleration limit (None: at rest).
        acceleration_limit: impose the system's acceleration limits (``'enforce'`` only).

    Returns:
        A :class:`~coop_ga.control.qp.QPSolution`: ``x`` is q̇ (nq,) [rad/s]; ``used_qp`` whether a
        bound or constraint was active.

    Raises:
        InfeasibleConstraintsError: the constraints and limits have no common point.
    """
    mode = "none" if limit_mode == "clamp" else limit_mode
    return _step(task, q, command_bivector, dt, damping, mode, limit_gain, constraints, velocity, acceleration_limit)[1]


def diff_ik_step(
    task: Any,
    q: Any,
    command_bivector: Any,
    dt: float = 0.01,
    damping: float = 1e-3,
    limit_mode: str = "enforce",
    *,
    limit_gain: float = DEFAULT_LIMIT_GAIN,
    constraints: Any = None,
    velocity: Any = None,
    acceleration_limit: bool = True,
) -> np.ndarray:
    """One differential-IK step (Eq 48, 61): ``q_next = q + Δt q̇`` with q̇ from :func:`diff_ik_velocity`.

    Args:
        task: a :class:`coop_ga.CooperativeTask`.
        q: (nq,) joint configuration [rad or m].
        command_bivector: (7,) body-frame similarity velocity B_S on ``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]``
            [rad/s, 1/s, body length/s], in the current cooperative frame (``V(q_next) ≈ V(q) exp(Δt B_S)``).
        dt: time step Δt [s] (> 0).  damping: λ of the damped least squares (≥ 0; 0 = Moore–Penrose).
        limit_mode: ``'enforce'`` (default: QP with the limits of ``task.system.limits``, q_next inside the
            position limits), ``'clamp'`` (ablation: unconstrained step, then q_next clipped) or ``'none'``.
        limit_gain: γ ∈ (0, 1] of the position bounds (module docstring).
        constraints: user rows ``G q̇ ≤ h`` on the joint velocity [rad/s], or None.
        velocity: (nq,) the previous step's q̇ [rad/s] (None: at rest), for the acceleration limit: pass the
            last step's ``(q_next − q)/dt`` when stepping in a loop.
        acceleration_limit: impose the system's acceleration limits (``'enforce'`` only).

    Returns:
        q_next: (nq,) new configuration (a new array).

    Raises:
        InfeasibleConstraintsError: incompatible constraints.
    """
    mode = "none" if limit_mode == "clamp" else limit_mode
    qv, sol = _step(task, q, command_bivector, dt, damping, mode, limit_gain, constraints, velocity, acceleration_limit)
    q_next = advance(qv, sol.x, dt, task.system)
    if limit_mode != "none":  # 'enforce': only rounding (γ(bound − q) reaches the bound at most); 'clamp': the ablation
        lim = task.system.limits
        if task.nq == task.nv:
            np.clip(q_next, lim.lower, lim.upper, out=q_next)
        else:
            task.system.clip(q_next, out=q_next)
    return q_next


@dataclass(frozen=True)
class DiffIKOptions:
    """Settings of :func:`diff_ik_reach` (module docstring: "Tolerance, gain and time").

    gain: proportional gain [1/s] (> 0); ``gain · dt = 1`` is a damped Gauss–Newton step.
    dt: time step [s] (> 0).
    steps: maximum number of steps (≥ 0); ``steps · dt`` is the time budget (default 2.5 s).
    damping: λ of the damped least squares (≥ 0).
    tol: converged when ‖e‖ < tol (≥ 0).
    limit_mode: ``'enforce'`` (QP with position, velocity and acceleration limits), ``'clamp'`` (ablation:
        clip q after an unconstrained step) or ``'none'``.
    limit_gain: safety gain γ ∈ (0, 1] of the position bounds (``'enforce'``).
    acceleration_limit: with ``'enforce'``, also the system's acceleration limits (if it has any; the
        robot starts at rest).
    """

    gain: float = 10.0
    dt: float = 0.01
    steps: int = 250
    damping: float = 1e-3
    tol: float = 1e-4
    limit_mode: str = "enforce"
    limit_gain: float = DEFAULT_LIMIT_GAIN
    acceleration_limit: bool = True

    def __post_init__(self) -> None:
        validation.positive(self.gain, "gain")
        validation.positive(self.dt, "dt")
        validation.integer(self.steps, "steps", minimum=0)
        validation.nonnegative(self.damping, "damping")
        validation.nonnegative(self.tol, "tol")
        validation.choice(self.limit_mode, LIMIT_MODES, "limit_mode")
        _check_gain(self.limit_gain)
        if not isinstance(self.acceleration_limit, bool):
            raise InvalidInputError(f"acceleration_limit must be True or False, got {self.acceleration_limit!r}")


@dataclass(frozen=True, kw_only=True)
class DiffIKResult(SolverResult):
    """Result of :func:`diff_ik_reach` (fields of :class:`~coop_ga.control.base.SolverResult` plus):

    trajectory: (T, nq) configurations, ``trajectory[0] = q_init`` (projected onto the limits
        unless ``limit_mode='none'``), T = iterations + 1.
    errors: (T,) ``‖log(Ṽ_Sc(q_t) V_Sd)‖`` at each configuration (mixed units: rad, log
        scale, m — the plain Euclidean norm of the 7-vector).
    limit_mode: the limit mode used.
    limit_violation: largest excursion of any configuration of the trajectory outside the
        position limits [rad or m] (0 with ``'enforce'`` and ``'clamp'``).
    velocity_violation: largest excess of ``|q_{t+1} − q_t|/Δt`` over the velocity limits
        [rad/s] (0 with ``'enforce'``).
    max_acceleration_violation: largest excess of the finite-difference acceleration (from rest) over the
        acceleration limits [rad/s²] (0 with ``'enforce'`` and ``acceleration_limit``, unless
        ``relaxed_steps`` > 0).
    relaxed_steps: steps on which user rows left no room for the acceleration bounds, which were dropped
        (``converged`` is then False if the acceleration limits were exceeded).
    active_steps: number of steps at which a bound or user constraint was active (a QP
        was solved because the unconstrained Eq 48 velocity violated it; for ``'clamp'``: the
        steps whose q was clipped).
    active_limits: the bounds active at the last step, e.g.
        ``('arm0_panda_joint4 (upper position limit -0.0698)',)``.
    infeasible: the run stopped because the user constraints and the limits had no common
        point (``message`` says where).
    """

    trajectory: np.ndarray
    errors: np.ndarray = field(default_factory=lambda: np.zeros(0))
    limit_mode: str = "enforce"
    limit_violation: float = 0.0
    velocity_violation: float = 0.0
    max_acceleration_violation: float = 0.0
    relaxed_steps: int = 0
    active_steps: int = 0
    active_limits: tuple[str, ...] = ()
    infeasible: bool = False


def similarity_error_norm(task: SimilarityTask) -> Any:
    """The stop criterion ``configuration → ‖log(Ṽ_Sc V_Sd)‖`` of a similarity task."""

    def f(c: Any) -> float:
        e = task.log_error(c)
        return float(np.sqrt(e @ e))

    return f


def clamp_hooks(dt: float, counter: list[int]) -> RunHooks:
    """The hooks of the ``'clamp'`` ablation: count the steps whose q the clip changed."""

    def after(c: Any, st: Any, q_next: np.ndarray) -> np.ndarray:
        counter[0] += bool(not st.used_qp and np.any(q_next != advance(c.q, st.velocity, dt, c.system)))
        return q_next

    return RunHooks(after=after, clip=True)


def run_result(task: Any, run: IKRun, mode: str, caught: Any, extra: int = 0) -> dict[str, Any]:
    """The fields of a :class:`DiffIKResult` from a run (``extra``: active steps counted by a hook)."""
    return dict(
        converged=run.converged,
        error=float(run.errors[-1]),
        iterations=run.iterations,
        message=run.message,
        q=run.trajectory[-1].copy(),
        warnings=dict(caught.counts),
        trajectory=run.trajectory,
        errors=run.errors,
        limit_mode=mode,
        limit_violation=run.max_position_violation,
        velocity_violation=run.max_velocity_violation,
        max_acceleration_violation=run.max_acceleration_violation,
        relaxed_steps=run.relaxed_steps,
        active_steps=run.active_steps + extra,
        active_limits=run.active_limits,
        infeasible=run.infeasible,
    )


def _warn_outside(task: Any, q: np.ndarray) -> None:
    lim = task.system.limits
    q = task.system.limit_coordinates(q)
    if lim.position_violation(q) > 0.0:
        warn(
            f"diff_ik_reach(limit_mode='none'): the final configuration is outside the joint limits by up to "
            f"{lim.position_violation(q):.3g} ({lim.describe(q)})",
            JointLimitWarning,
            key=str(task.system.name),
        )


def diff_ik_reach(
    task: Any,
    q_init: Any,
    target: SimilarityLike,
    options: DiffIKOptions | None = None,
    *,
    constraints: Any = None,
    **overrides: Any,
) -> DiffIKResult:
    """Drive V_Sc(q) to ``target`` (a :class:`~coop_ga.Similarity`) by differential IK (Eq 44, 48, 61).

    A :class:`~coop_ga.control.tasks.SimilarityTask` (``B_S = gain · log(Ṽ_Sc(q) V_Sd)``) with the limits of
    :func:`step_limits`, iterated by :func:`~coop_ga.control.run_ik` (one compiled evaluation per step).
    Stops when ‖e‖ < ``tol`` or after ``steps`` steps.  Non-convergence (unreachable target, joint
    limits, singularity) is reported as ``converged=False``; ``converged`` also requires every
    configuration inside the position limits unless ``limit_mode='none'`` (then a final configuration outside
    them is reported by a :class:`~coop_ga.errors.JointLimitWarning` and ``limit_violation``), and within
    the acceleration limits when they were imposed.

    Args:
        task: a :class:`coop_ga.CooperativeTask`.  q_init: (nq,) start [rad or m] (at rest).
        target: V_Sd, a :class:`~coop_ga.Similarity`.
        options: :class:`DiffIKOptions` (keyword ``overrides`` replace its fields).
        constraints: user rows ``G q̇ ≤ h`` on the joint velocity [rad/s]
            (:class:`~coop_ga.control.qp.LinearConstraint`, ``(G, h)`` pairs or a list), or a callable
            ``constraints(q) -> such rows`` evaluated at every step (e.g. obstacle half-spaces).

    Returns:
        A :class:`DiffIKResult`.
    """
    o = resolve_options(DiffIKOptions, options, overrides, "diff_ik_reach")
    q, Vd = check_problem(task, q_init, target, "q_init")
    sim = SimilarityTask(Vd, gain=o.gain)
    mode = "none" if o.limit_mode == "clamp" else o.limit_mode
    lims = step_limits(task, mode, o.limit_gain, o.acceleration_limit, constraints)
    clipped = [0]
    hooks = clamp_hooks(o.dt, clipped) if o.limit_mode == "clamp" else RunHooks(clip=o.limit_mode == "enforce")
    hooks.error = similarity_error_norm(sim)
    with collect_warnings() as caught:
        if o.limit_mode != "none":
            q = project_into_limits(task, q, "q_init")
        cfg = Configuration(task, q)
        run = run_ik(cfg, [sim], lims, dt=o.dt, steps=o.steps, tol=o.tol, hooks=hooks, damping=o.damping)
        if o.limit_mode == "none":
            _warn_outside(task, run.trajectory[-1])
    return DiffIKResult(**run_result(task, run, o.limit_mode, caught, clipped[0]))
