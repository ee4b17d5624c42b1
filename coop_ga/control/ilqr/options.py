"""Settings of :func:`~coop_ga.control.ilqr.ilqr_reach` (:class:`ILQROptions`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ... import validation
from ...errors import InvalidInputError
from .problem import DEFAULT_Q, DEFAULT_QV, DEFAULT_R, check_clearance

__all__ = ["ILQROptions"]


@dataclass(frozen=True)
class ILQROptions:
    """Settings of :func:`ilqr_reach`: the problem (horizon, Δt, weights, limits) and the solver.

    Problem (Eq 53–57, :class:`ReachingOCP`):
        horizon: number of knots n (≥ 2; default 250).
        dt: Δt [s] (default 0.01 → 2.5 s; the paper's Δt = 0.001 s contradicts its 2.5 s
            horizon, see the package docstring of :mod:`coop_ga.control.ilqr`).
        R, Q, Qv: weights (scalar, diagonal or matrix; R ≻ 0, Q, Qv ⪰ 0).
        limit_mode: ``"enforce"`` (position, velocity and acceleration bounds of
            ``task.system.limits``) or ``"none"``.
        terminal: ``"constraint"`` (e(q_n) = 0 by multipliers, default) or ``"soft"`` (Eq 57).
    Solver:
        max_iter: maximum number of accepted iterations, all outer iterations together (≥ 0).
        max_outer: maximum outer iterations (AL multipliers and penalty, terminal shift) (≥ 1).
        tol: converged when ‖e(q_n)‖ < tol and the bounds hold.
        ftol: an inner solve ends when the relative merit decrease of an iteration is below it.
        hessian: ``"newton"`` (Gauss–Newton far from the target, Newton once
            ‖e‖ < ``newton_switch``) or ``"gauss_newton"`` (always).
        newton_switch: ‖e‖ below which the Newton terminal model is used.
        max_travel: trust region [rad]: the largest joint motion one iteration may add
            anywhere along the trajectory (the line search starts at α ≤ max_travel / travel).
        backward: ``"auto"`` (closed-form step when no constraint is active, else Riccati/box-QP),
            or ``"riccati"`` (always the backward pass).
        soc: try a second-order correction when a full closed-form step fails the Armijo test.
        armijo: sufficient-decrease constant c ∈ (0, 1).
        max_backtracks: halvings of α per model before the next (damped) model is tried.
        al_penalty, al_growth, al_max_penalty: initial AL penalty μ [1/rad², 1/(rad/s)²], its
            growth factor and its cap.
        al_inner_tol: while a bound is violated, the inner solve ends (and the multipliers are
            updated) once an iteration decreases the merit by less than this fraction.
        al_violation: the solve may stop once the bounds are violated by at most this much
            [rad, rad/s]; the final blend with the feasible reference removes it exactly.
        restart: if the solve from the default guess stalls short of tol (not when it runs out of
            ``max_iter``), restart once from the minimum-energy controls to the bounded Gauss–Newton IK
            solution; both solves count in ``iterations`` and the histories, and the message says so.
        warn_limits: with ``limit_mode="none"``, warn when the trajectory leaves the joint limits.
    Avoidance:
        clearance: a :class:`coop_ga.control.avoidance.ClearanceCost` — a running cost on the
            link–obstacle / link–link clearances of a collision model (:mod:`coop_ga.control.ilqr`) — or
            None (default: off; results identical to the solver without it).
    """

    horizon: int = 250
    dt: float = 0.01
    R: Any = DEFAULT_R
    Q: Any = DEFAULT_Q
    Qv: Any = DEFAULT_QV
    limit_mode: str = "enforce"
    terminal: str = "constraint"
    max_iter: int = 60
    max_outer: int = 30
    tol: float = 1e-5
    ftol: float = 1e-7
    hessian: str = "newton"
    newton_switch: float = float("inf")
    max_travel: float = 0.5
    backward: str = "auto"
    soc: bool = True
    armijo: float = 1e-4
    max_backtracks: int = 12
    al_penalty: float = 1e3
    al_growth: float = 10.0
    al_max_penalty: float = 1e9
    al_inner_tol: float = 1e-3
    al_violation: float = 1e-6
    restart: bool = True
    warn_limits: bool = True
    clearance: Any = None

    def __post_init__(self) -> None:
        check_clearance(self.clearance)
        validation.integer(self.horizon, "horizon", minimum=2)
        validation.positive(self.dt, "dt")
        validation.choice(self.limit_mode, ("enforce", "none"), "limit_mode")
        validation.choice(self.terminal, ("constraint", "soft"), "terminal")
        validation.integer(self.max_iter, "max_iter", minimum=0)
        validation.integer(self.max_outer, "max_outer", minimum=1)
        validation.nonnegative(self.tol, "tol")
        validation.nonnegative(self.ftol, "ftol")
        validation.choice(self.hessian, ("newton", "gauss_newton"), "hessian")
        validation.nonnegative(self.newton_switch, "newton_switch", allow_inf=True)
        validation.positive(self.max_travel, "max_travel", allow_inf=True)
        validation.choice(self.backward, ("auto", "riccati"), "backward")
        validation.scalar(self.armijo, "armijo", low=0.0, high=1.0, low_open=True)
        validation.integer(self.max_backtracks, "max_backtracks", minimum=0)
        validation.positive(self.al_penalty, "al_penalty")
        validation.scalar(self.al_growth, "al_growth", low=1.0)
        validation.positive(self.al_max_penalty, "al_max_penalty")
        validation.nonnegative(self.al_inner_tol, "al_inner_tol")
        validation.positive(self.al_violation, "al_violation")
        for name in ("soc", "warn_limits", "restart"):
            if not isinstance(getattr(self, name), bool):
                raise InvalidInputError(f"{name} must be True or False, got {getattr(self, name)!r}")
