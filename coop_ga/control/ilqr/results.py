"""What a solve returns: per-iteration statistics, the result, and the final feasibility blend and verdict."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ...diagnostics import warn
from ...errors import JointLimitWarning
from ...geometry.groups import Similarity
from ..base import SolverResult
from .feasibility import restore, restore_joints
from .options import ILQROptions
from .problem import ReachingOCP

__all__ = ["ILQRIteration", "ILQRResult", "Progress", "active_constraints", "finish"]


@dataclass(frozen=True)
class ILQRIteration:
    """Statistics of one accepted iLQR iteration.

    cost: total cost (Eq 53) after the step.  error: ‖e(q_n)‖ after the step.
    merit: the augmented merit the line search decreased (cost + multiplier terms).
    alpha: accepted line-search step length (≤ the travel cap).
    mu: multiple of I added to the terminal Hessian model (Levenberg–Marquardt damping; 0 = none).
    expected_decrease, actual_decrease: model and true merit decrease of the step.
    line_search_trials: roll-outs of the line search.  backward_passes: LQ steps computed.
    time_s: wall time of the iteration [s].
    model: ``"newton"`` or ``"gauss_newton"`` — the terminal-Hessian model of the accepted step.
    outer: index of the outer (multiplier / penalty / terminal-shift) iteration.
    violation: largest bound violation after the step.
    travel: max |δq| of the step [rad].  backward: ``"condensed"`` or ``"riccati"``.

    """

    cost: float
    error: float
    alpha: float
    mu: float
    expected_decrease: float
    actual_decrease: float
    line_search_trials: int
    backward_passes: int
    time_s: float
    model: str = "gauss_newton"
    merit: float = 0.0
    outer: int = 0
    violation: float = 0.0
    travel: float = 0.0
    backward: str = "riccati"


@dataclass(frozen=True, kw_only=True)
class ILQRResult(SolverResult):
    """Result of :func:`ilqr_reach` (fields of :class:`~coop_ga.control.base.SolverResult` plus):

    q: (nq,) the terminal configuration q_n;  error: ‖e(q_n)‖, ``e = log(Ṽ_Sc(q_n) V_Sd)``
        (Eq 44; plain 7-vector norm, mixed units rad / log-scale / body length);
        converged: ``error < tol`` and the bounds hold and the last step was accepted, and (with a clearance
            cost) ``min_clearance ≥ 0`` (a trajectory through an obstacle is never reported as converged).
    trajectory: (n+1, nq) joint positions [rad] at the knots; qd: (n+1, nq) velocities [rad/s].
    u: (n, nq) joint accelerations [rad/s²] (piecewise constant over each Δt).
    t: (n+1,) knot times [s].
    error_vector: (7,) e(q_n) on ``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]``.
    terminal_speed: ‖q̇_n‖ [rad/s].
    cost: final total cost (Eq 53).  cost_history: (iterations+1,) costs, [0] = initial guess.
    error_history: (iterations+1,) ‖e(q_n)‖ per iterate.
    solve_time_s: wall time of the solve [s] (excludes building/compiling the task's
        functions, which happens once per task and process; see ``ilqr_reach``).
    stats: one :class:`ILQRIteration` per accepted iteration.
    joint_limit_violation, velocity_violation, acceleration_violation: largest excursion of
        q, |q̇|, |u| beyond their limits over the returned trajectory (0 with ``limit_mode="enforce"``).
    active_constraints: the bounds active at the end (joint, kind, first/last knot).
    outer_iterations: outer iterations (AL multipliers and penalty, terminal shift).
    restoration: the β of the final feasibility blend (0: none was needed).
    dt: the time step [s].  target: V_Sd.  hessian: the terminal-Hessian option.
    clearance_cost: ``Σ_{k≥1} c(q_k)`` of the clearance cost (included in ``cost``; 0 without one).
    min_clearance: smallest clearance of the collision model over the knots [m] (inf without a clearance cost).
    """

    trajectory: np.ndarray
    qd: np.ndarray
    u: np.ndarray
    t: np.ndarray
    error_vector: np.ndarray
    terminal_speed: float
    cost: float
    cost_history: np.ndarray
    error_history: np.ndarray
    solve_time_s: float
    target: Similarity
    stats: tuple[ILQRIteration, ...] = field(default_factory=tuple)
    joint_limit_violation: float = 0.0
    velocity_violation: float = 0.0
    acceleration_violation: float = 0.0
    active_constraints: tuple[str, ...] = ()
    outer_iterations: int = 0
    restoration: float = 0.0
    dt: float = 0.01
    hessian: str = "newton"
    clearance_cost: float = 0.0
    min_clearance: float = float("inf")

    @property
    def within_limits(self) -> bool:
        return (
            self.joint_limit_violation == 0.0 and self.velocity_violation == 0.0 and self.acceleration_violation == 0.0
        )


def active_constraints(
    ocp: ReachingOCP, q: np.ndarray, qd: np.ndarray, u: np.ndarray, tol: float = 1e-6
) -> tuple[str, ...]:
    """Human-readable list of the bounds active (within tol) along a trajectory."""
    out = []
    c = ocp.constraint_values(q, qd)  # (T, 4, n)
    kinds = ("upper position", "lower position", "velocity (+)", "velocity (−)")
    for j, name in enumerate(ocp.joint_names):
        for b, kind in enumerate(kinds):
            idx = np.flatnonzero(c[:, b, j] > -tol)
            if idx.size:
                out.append(f"{name} {kind} limit at knots {idx[0] + 1}–{idx[-1] + 1}")
        if not np.isfinite(ocp.a_max[j]):
            continue
        ia = np.flatnonzero(np.abs(u[:, j]) > ocp.a_max[j] - tol * max(1.0, ocp.a_max[j]))
        if ia.size:
            out.append(f"{name} acceleration limit at knots {ia[0]}–{ia[-1]}")
    return tuple(out)


@dataclass
class Progress:
    """What a solve reports besides its final controls: histories, counters, the reason it stopped."""

    t_start: float
    costs: list[float] = field(default_factory=list)
    errs: list[float] = field(default_factory=list)
    stats: list[ILQRIteration] = field(default_factory=list)
    iterations: int = 0
    outer: int = 0
    message: str = ""


def finish(
    ocp: ReachingOCP,
    o: ILQROptions,
    u: np.ndarray,
    u_ref: np.ndarray,
    progress: Progress,
    warning_counts: dict[str, int],
    describe: bool = True,
) -> ILQRResult:
    """The result of a solve that ended at ``u``: the feasibility blend with ``u_ref``, the re-evaluated terminal error
    and cost, the limit checks, the verdict and its message (``describe=False``: without the active bounds)."""
    task = ocp.task
    solve_time = time.perf_counter() - progress.t_start
    u, beta, message = _feasible(ocp, o, u, u_ref, progress.message or "stopped")
    q, qd = ocp.rollout(u)
    # the reported error is re-evaluated at the re-integrated terminal state (and re-checks degeneracy)
    lf, e, _ = ocp.terminal(q[-1], qd[-1])
    c_cost = ocp.clearance_cost(q)
    cost = ocp.running_cost(u) + lf + c_cost
    min_clear = ocp.min_clearance(q)
    # the last iterate's entries re-evaluated (an early exit has no history yet: its only entry)
    costs = [*progress.costs[:-1], cost]
    errs = [*progress.errs[:-1], float(np.linalg.norm(e))]
    lim = task.system.limits
    pviol = lim.position_violation(q)
    vviol = lim.velocity_violation(qd)
    aviol = lim.acceleration_violation(u)
    if o.limit_mode == "none" and pviol > 0 and o.warn_limits:
        warn(
            f"iLQR trajectory leaves the joint limits by up to {pviol:.3g} rad (limit_mode='none': not enforced)",
            JointLimitWarning,
            key=task.name,
        )
    feasible = o.limit_mode == "none" or (pviol <= 1e-9 and vviol <= 1e-9 and aviol <= 1e-9)
    # every iterate is the result of a step accepted on the true merit (or the initial guess); the clearance cost is
    # a penalty, so a trajectory that ends up through an obstacle (a restart, a low weight) is checked here
    penetration = ocp.clearance is not None and min_clear < 0.0
    if penetration:
        message = ("terminal error below tol" if progress.message == "" else message) + (
            f"; but the trajectory penetrates the collision model by {-min_clear:.3g} m (min clearance {min_clear:.3g} m "
            "< 0 at a knot; the clearance cost is a penalty: raise its weight or activation distance)"
        )
    converged = bool(errs[-1] < o.tol and feasible and not penetration)
    active = active_constraints(ocp, q, qd, u, tol=1e-3) if o.limit_mode == "enforce" and describe else ()
    return ILQRResult(
        converged=converged,
        error=errs[-1],
        iterations=progress.iterations,
        message=_verdict(o, converged, message, errs[-1], active),
        q=q[-1].copy(),
        warnings=warning_counts,
        trajectory=q,
        qd=qd,
        u=u,
        t=ocp.times,
        error_vector=e.copy(),
        terminal_speed=float(np.linalg.norm(qd[-1])),
        cost=cost,
        cost_history=np.array(costs),
        error_history=np.array(errs),
        solve_time_s=solve_time,
        stats=tuple(progress.stats),
        joint_limit_violation=pviol,
        velocity_violation=vviol,
        acceleration_violation=aviol,
        active_constraints=active,
        outer_iterations=progress.outer,
        restoration=beta,
        dt=ocp.dt,
        target=ocp.target,
        hessian=o.hessian,
        clearance_cost=c_cost,
        min_clearance=min_clear,
    )


def _feasible(
    ocp: ReachingOCP, o: ILQROptions, u: np.ndarray, u_ref: np.ndarray, message: str
) -> tuple[np.ndarray, float, str]:
    """The controls returned (``limit_mode="enforce"``: blended toward a strictly feasible reference, as a whole or joint
    by joint), the blend's β and the message with what was done."""
    if o.limit_mode != "enforce":
        return u, 0.0, message
    restored = restore(ocp, u, u_ref)
    if restored is not None:
        u, beta = restored
        if beta > 0:
            message += f"; blended with the feasible reference (β = {beta:.2e}) to satisfy the bounds exactly"
        return u, beta, message
    # the reference is not strictly feasible as a whole (e.g. at rest on a position bound)
    restored = restore_joints(ocp, u, u_ref)
    if restored is None:
        message += (
            "; the start state cannot be kept inside the limits (a joint moves out through a bound faster "
            "than its acceleration limit can stop it): the trajectory may violate them"
        )
        return u, 0.0, message
    u, beta = restored
    if beta > 0:
        message += (
            f"; blended joint by joint with feasible references (largest β = {beta:.2e}) to satisfy the bounds exactly"
        )
    return u, beta, message


def _verdict(o: ILQROptions, converged: bool, message: str, error: float, active: tuple[str, ...]) -> str:
    """The result's message: converged, or why not, with ‖e‖ and the active bounds."""
    if converged:
        return (
            "converged: terminal error below tol within the limits"
            if o.limit_mode == "enforce"
            else "converged: terminal error below tol (limits not enforced)"
        )
    return f"not converged: {message}; ‖e‖ = {error:.3g}" + (
        f"; bounds within 1e-3 of active: {'; '.join(active[:6])}{' …' if len(active) > 6 else ''}" if active else ""
    )
