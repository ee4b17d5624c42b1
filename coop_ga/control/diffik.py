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

The step as a QP (``limits='enforce'``, the default)
---------------------------------------------------
Eq 48 is the minimiser of ``½‖J^G q̇ − B_S‖² + ½λ²‖q̇‖²`` (λ = ``damping``).  With the
state and control constraints of Eq 53 (𝒳: position limits, 𝒰: velocity limits of
``task.system.limits``) each step solves instead

    min_q̇  ½‖J^G q̇ − B_S‖² + ½λ²‖q̇‖²
    s.t.   max(−v, γ (lower − q)/Δt) ≤ q̇ ≤ min(v, γ (upper − q)/Δt)     (position over Δt ∩ velocity)
           G q̇ ≤ h                                                      (optional user constraints)

(:func:`coop_ga.control.qp.solve_qp`, DAQP; γ = ``limit_gain``, the safety gain of
pink/mink's ``ConfigurationLimit``).  So ``q_{t+1} = q_t + Δt q̇`` stays within the
position limits, ``|q̇| ≤ v``, and the task motion a blocked joint cannot make is
redistributed over the other joints (the nullspace of J^G) instead of being lost.  When the
unconstrained Eq 48 velocity already satisfies every bound it is used as is (no QP is
solved; results are then identical to ``limits='none'``).  ``limits='clamp'`` (the former
default, kept as an ablation) takes the Eq 48 step and clips q to the limits afterwards (a
blocked joint simply stops; no velocity limit); ``limits='none'`` imposes nothing.
A start outside the position limits is projected onto them first, with a
:class:`~coop_ga.errors.JointLimitWarning`.

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
Measured with these defaults on 2160 realisable targets (9 systems × every primitive kind
× 2/5/15 cm, 5/15/35°, 5/15/30 % displacements from q0): of the 1637 targets that some
solver reached inside the limits, ``'enforce'`` reaches 1e-4 within 2.5 s on all (median
73 steps, at most 181), ``'clamp'`` on 97.4 % (worst system/kind: 79 %).  In a smaller run
(918 targets, from q0 and from random starts) gain 1 /s (the former default) reached none
of the certified targets within 2.5 s, gains 4, 10 and 20 /s all of them.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import validation
from ..cooperative.manipulability import damped_pinv
from ..diagnostics import collect_warnings, warn
from ..errors import InvalidInputError, JointLimitWarning
from .base import SolverResult, check_problem, check_q, resolve_options
from .qp import (
    DEFAULT_LIMIT_GAIN,
    InfeasibleConstraintsError,
    LinearConstraint,
    QPSolution,
    classify_velocity_box,
    describe_active,
    limit_arrays,
    project_into_limits,
    solve_qp,
    stack_constraints,
    velocity_bounds,
)

__all__ = [
    "DiffIKOptions",
    "DiffIKResult",
    "LinearConstraint",
    "diff_ik_reach",
    "diff_ik_step",
    "diff_ik_velocity",
    "joint_velocity",
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


def _velocity(
    task: Any,
    q: np.ndarray,
    J: np.ndarray,
    b: np.ndarray,
    dt: float,
    damping: float,
    limits: str,
    limit_gain: float,
    G: np.ndarray,
    h: np.ndarray,
    labels: tuple[str, ...],
) -> QPSolution:
    """The joint velocity of one step (q inside the limits when ``limits='enforce'``)."""
    m = G.shape[0]
    x_free = damped_pinv(J, damping) @ b  # Eq 48: the QP's solution whenever no bound or row is active
    if limits == "enforce":
        lower, upper, vel = limit_arrays(task)
        lb, ub = velocity_bounds(q, lower, upper, vel, dt, limit_gain)
        return solve_qp(
            J,
            b,
            damping,
            lb,
            ub,
            G if m else None,
            h if m else None,
            x_free=x_free,
            labels=labels,
            what="differential IK step",
        )
    if m:  # constraints without limits
        return solve_qp(J, b, damping, None, None, G, h, x_free=x_free, labels=labels, what="differential IK step")
    n = J.shape[1]
    return QPSolution(x_free, False, np.zeros(n, bool), np.zeros(n, bool), np.zeros(0, bool), "unconstrained")


def _advance(task: Any, q: np.ndarray, qd: np.ndarray, dt: float, limits: str) -> np.ndarray:
    with np.errstate(over="ignore", invalid="ignore"):
        q_next = q + dt * qd
    if not np.all(np.isfinite(q_next)):  # never a NaN: a step of dt·q̇ beyond the float range is refused
        raise InvalidInputError(
            f"the differential-IK step is not finite (dt = {dt:.3g} s, max |q̇| = {float(np.max(np.abs(qd))):.3g}); "
            "use a time step of a control loop (e.g. 0.01 s) and a command of a sensible size"
        )
    if limits != "none":  # 'enforce': only rounding (γ(bound − q) reaches the bound at most); 'clamp': the ablation
        lower, upper, _ = limit_arrays(task)
        np.clip(q_next, lower, upper, out=q_next)
    return q_next


def diff_ik_velocity(
    task: Any,
    q: Any,
    command_bivector: Any,
    *,
    dt: float = 0.01,
    damping: float = 1e-3,
    limits: str = "enforce",
    limit_gain: float = DEFAULT_LIMIT_GAIN,
    constraints: Any = None,
) -> QPSolution:
    """The joint velocity of one differential-IK step (Eq 48 as a QP, module docstring).

    Parameters
    ----------
    task: a :class:`coop_ga.CooperativeTask`.
    q: (nq,) joint configuration [rad or m] (inside the position limits for ``'enforce'``;
        otherwise it is projected onto them with a :class:`~coop_ga.errors.JointLimitWarning`).
    command_bivector: (7,) body-frame similarity velocity B_S [rad/s, 1/s, body length/s].
    dt: Δt [s] (> 0), over which the position limits are turned into velocity bounds.
    damping: λ (≥ 0).  limits: ``'enforce'``, ``'clamp'`` or ``'none'`` (for ``'clamp'`` the
        velocity is the unconstrained one: clipping happens on q).
    limit_gain: γ ∈ (0, 1], the fraction of the remaining range a joint may cover per step.
    constraints: user rows ``G q̇ ≤ h`` (:class:`~coop_ga.control.qp.LinearConstraint`, a
        ``(G, h)`` pair or a list of them), or None.

    Returns
    -------
    A :class:`~coop_ga.control.qp.QPSolution`: ``x`` is q̇ (nq,) [rad/s]; ``used_qp`` whether a
    bound or constraint was active.  Raises :class:`~coop_ga.errors.InfeasibleConstraintsError`
    when the constraints and limits have no common point.
    """
    validation.choice(limits, LIMIT_MODES, "limits")
    dt = validation.positive(dt, "dt")
    damping = validation.nonnegative(damping, "damping")
    limit_gain = _check_gain(limit_gain)
    q = check_q(task, q)
    b = _check_bivector(command_bivector)
    G, h, labels = stack_constraints(constraints, task.nq)
    if limits == "enforce":
        q = project_into_limits(task, q)
    J = task.evaluate_views(q)[2]
    return _velocity(task, q, J, b, dt, damping, "none" if limits == "clamp" else limits, limit_gain, G, h, labels)


def diff_ik_step(
    task: Any,
    q: Any,
    command_bivector: Any,
    dt: float = 0.01,
    damping: float = 1e-3,
    limits: str = "enforce",
    *,
    limit_gain: float = DEFAULT_LIMIT_GAIN,
    constraints: Any = None,
) -> np.ndarray:
    """One differential-IK step (Eq 48, 61): ``q_next = q + Δt q̇`` with q̇ from :func:`diff_ik_velocity`.

    Parameters
    ----------
    task: a :class:`coop_ga.CooperativeTask`.
    q: (nq,) joint configuration [rad or m].
    command_bivector: (7,) body-frame similarity velocity B_S on
        ``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]`` [rad/s, 1/s, body length/s], expressed in the
        current cooperative frame V_Sc(q) (``V(q_next) ≈ V(q) exp(Δt B_S)``).
    dt: time step Δt [s] (> 0).
    damping: λ of the damped least squares (≥ 0; 0 = Moore–Penrose).
    limits: ``'enforce'`` (default: QP with the position and velocity limits of
        ``task.system.limits``, q_next inside the position limits), ``'clamp'`` (ablation:
        unconstrained step, then q_next clipped) or ``'none'``.
    limit_gain: γ ∈ (0, 1] of the position bounds (module docstring).
    constraints: user rows ``G q̇ ≤ h`` on the joint velocity [rad/s] (see
        :class:`~coop_ga.control.qp.LinearConstraint`), or None.

    Returns
    -------
    q_next: (nq,) new configuration (a new array).  Raises
    :class:`~coop_ga.errors.InfeasibleConstraintsError` for incompatible constraints.
    """
    validation.choice(limits, LIMIT_MODES, "limits")
    dt = validation.positive(dt, "dt")
    damping = validation.nonnegative(damping, "damping")
    limit_gain = _check_gain(limit_gain)
    q = check_q(task, q)
    b = _check_bivector(command_bivector)
    G, h, labels = stack_constraints(constraints, task.nq)
    if limits != "none":
        q = project_into_limits(task, q)
    J = task.evaluate_views(q)[2]
    sol = _velocity(task, q, J, b, dt, damping, "none" if limits == "clamp" else limits, limit_gain, G, h, labels)
    return _advance(task, q, sol.x, dt, limits)


def reach_outcome(
    task: Any,
    traj: np.ndarray,
    errors: np.ndarray,
    dt: float,
    tol: float,
    limits: str,
    infeasible: bool,
    message: str,
    steps: int,
    active: Sequence[str],
    active_label: str,
) -> tuple[float, float, bool, str]:
    """The verdict of a differential-IK run (shared by :func:`diff_ik_reach` and the avoidance runner).

    traj (T, nq) the configurations, errors (T,) ‖e‖ along it, dt [s], tol on ‖e‖.  Returns
    ``(position violation [rad], finite-difference speed violation [rad/s], converged, message)``:
    converged only if the last error is below tol, the run was not infeasible and — unless
    ``limits == 'none'`` — the trajectory stays inside the position limits (to 1e-9); a run outside
    them is never reported as a success.
    """
    lim = task.system.limits
    violation = lim.position_violation(traj)
    vviol = lim.trajectory_velocity_violation(traj, dt) if steps else 0.0
    inside = limits == "none" or violation <= 1e-9
    converged = bool(errors[-1] < tol and inside and not infeasible)
    if converged:
        message = "converged"
    elif not message:
        message = f"not converged after {steps} steps (‖e‖ = {errors[-1]:.3g} ≥ tol)"
        if active:
            message += f"; {active_label}: {', '.join(active)}"
    return violation, vviol, converged, message


@dataclass(frozen=True)
class DiffIKOptions:
    """Settings of :func:`diff_ik_reach` (module docstring: "Tolerance, gain and time").

    gain: proportional gain [1/s] (> 0); ``gain · dt = 1`` is a damped Gauss–Newton step.
    dt: time step [s] (> 0).
    steps: maximum number of steps (≥ 0); ``steps · dt`` is the time budget (default 2.5 s).
    damping: λ of the damped least squares (≥ 0).
    tol: converged when ‖e‖ < tol (≥ 0).
    limits: ``'enforce'`` (QP with position and velocity limits), ``'clamp'`` (ablation:
        clip q after an unconstrained step) or ``'none'``.
    limit_gain: safety gain γ ∈ (0, 1] of the position bounds (``'enforce'``).
    """

    gain: float = 10.0
    dt: float = 0.01
    steps: int = 250
    damping: float = 1e-3
    tol: float = 1e-4
    limits: str = "enforce"
    limit_gain: float = DEFAULT_LIMIT_GAIN

    def __post_init__(self) -> None:
        validation.positive(self.gain, "gain")
        validation.positive(self.dt, "dt")
        validation.integer(self.steps, "steps", minimum=0)
        validation.nonnegative(self.damping, "damping")
        validation.nonnegative(self.tol, "tol")
        validation.choice(self.limits, LIMIT_MODES, "limits")
        _check_gain(self.limit_gain)


@dataclass(frozen=True, kw_only=True)
class DiffIKResult(SolverResult):
    """Result of :func:`diff_ik_reach` (fields of :class:`~coop_ga.control.base.SolverResult` plus):

    trajectory: (T, nq) configurations, ``trajectory[0] = q0`` (projected onto the limits
        unless ``limits='none'``), T = iterations + 1.
    errors: (T,) ``‖log(Ṽ_Sc(q_t) V_Sd)‖`` at each configuration (mixed units: rad, log
        scale, m — the plain Euclidean norm of the 7-vector).
    limits: the limit mode used.
    limit_violation: largest excursion of any configuration of the trajectory outside the
        position limits [rad or m] (0 with ``'enforce'`` and ``'clamp'``).
    velocity_violation: largest excess of ``|q_{t+1} − q_t|/Δt`` over the velocity limits
        [rad/s] (0 with ``'enforce'``).
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
    limits: str = "enforce"
    limit_violation: float = 0.0
    velocity_violation: float = 0.0
    active_steps: int = 0
    active_limits: tuple[str, ...] = ()
    infeasible: bool = False


def diff_ik_reach(
    task: Any, q0: Any, target: Any, options: DiffIKOptions | None = None, *, constraints: Any = None, **overrides: Any
) -> DiffIKResult:
    """Drive V_Sc(q) to ``target`` (a :class:`~coop_ga.Similarity`) by differential IK (Eq 44, 48, 61).

    Each step commands the body velocity ``B_S = gain · log(Ṽ_Sc(q) V_Sd)`` (the error
    bivector in the current frame, 1/s × error units) and takes the step of
    :func:`diff_ik_step` (a QP with the joint limits by default).  Stops when ‖e‖ < ``tol``
    or after ``steps`` steps.  Non-convergence (unreachable target, joint limits,
    singularity) is reported as ``converged=False``; ``converged`` also requires every
    configuration inside the position limits unless ``limits='none'`` (then a final
    configuration outside them is reported by a :class:`~coop_ga.errors.JointLimitWarning`
    and ``limit_violation``).

    ``options``: :class:`DiffIKOptions` (keyword ``overrides`` replace its fields).
    ``constraints``: user rows ``G q̇ ≤ h`` on the joint velocity [rad/s]
    (:class:`~coop_ga.control.qp.LinearConstraint`, ``(G, h)`` pairs or a list), or a callable
    ``constraints(q) -> such rows`` evaluated at every step (e.g. obstacle half-spaces that
    depend on q).  Problem data, so an argument and not an option.
    """
    o = resolve_options(DiffIKOptions, options, overrides, "diff_ik_reach")
    q, Vd = check_problem(task, q0, target, "q0")
    dynamic = callable(constraints) and not isinstance(constraints, LinearConstraint)
    const_rows = None if dynamic else stack_constraints(constraints, task.nq)
    cfun: Callable[[np.ndarray], Any] | None = constraints if dynamic else None
    lower, upper, vel = limit_arrays(task)
    qp_mode = "none" if o.limits == "clamp" else o.limits
    active_steps = 0
    active: tuple[str, ...] = ()
    last: tuple[QPSolution, np.ndarray, tuple[str, ...]] | None = None
    infeasible = False
    message = ""
    with collect_warnings() as caught:
        if o.limits != "none":
            q = project_into_limits(task, q, "q0")
        qs = [q.copy()]
        e = task.error(q, Vd)
        errs = [float(np.linalg.norm(e))]
        k = 0
        while k < o.steps and errs[-1] >= o.tol:
            J = task.evaluate_views(q)[2]
            if cfun is None:
                assert const_rows is not None  # static constraints: stacked once, above
                G, h, labels = const_rows
            else:
                G, h, labels = stack_constraints(cfun(q.copy()), task.nq)
            try:
                sol = _velocity(task, q, J, o.gain * e, o.dt, o.damping, qp_mode, o.limit_gain, G, h, labels)
            except InfeasibleConstraintsError as exc:
                infeasible = True
                message = f"stopped at step {k}: {exc}"
                break
            last = (sol, q, labels)
            if o.limits == "clamp":  # the ablation: count the steps the clip changed q
                q_free = q + o.dt * sol.x
                q = _advance(task, q, sol.x, o.dt, o.limits)
                active_steps += bool(sol.used_qp or np.any(q != q_free))
            else:
                active_steps += sol.used_qp
                q = _advance(task, q, sol.x, o.dt, o.limits)
            e = task.error(q, Vd)
            qs.append(q.copy())
            errs.append(float(np.linalg.norm(e)))
            k += 1
        if last is not None and last[0].used_qp:  # the bounds active at the last step, labelled once
            sol, q_last, labels = last
            if qp_mode == "enforce":
                lo_i, hi_i, v_i = classify_velocity_box(sol, q_last, lower, upper, vel, o.dt, o.limit_gain)
                active = describe_active(task, q_last, lo_i, hi_i, v_i)
            active += tuple(lab for lab, a in zip(labels, sol.active_rows) if a)
        traj = np.array(qs)
        lim = task.system.limits
        if o.limits == "none" and lim.position_violation(q) > 0.0:
            warn(
                f"diff_ik_reach(limits='none'): the final configuration is outside the joint limits by up to "
                f"{lim.position_violation(q):.3g} ({lim.describe(q)})",
                JointLimitWarning,
                key=str(task.system.name),
            )
    errors = np.array(errs)
    violation, vviol, converged, message = reach_outcome(
        task, traj, errors, o.dt, o.tol, o.limits, infeasible, message, k, active, "bounds active at the last step"
    )
    return DiffIKResult(
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
    )
