"""Settings of :class:`~coop_ga.control.mpc.CooperativeMPC` (:class:`MPCOptions`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ... import validation
from ...errors import InvalidInputError
from ..ilqr import DEFAULT_Q, DEFAULT_R

__all__ = ["MPCOptions"]


@dataclass(frozen=True)
class MPCOptions:
    """Settings of the receding-horizon controller (:mod:`coop_ga.control.mpc`).

    Inner problem (the iLQR of :mod:`coop_ga.control.ilqr`, Eq 53–57, re-solved every tick):
        horizon: knots n of the plan (≥ 2).  dt: knot spacing [s]; the plan looks ``horizon · dt`` ahead
            (default 0.2 s: with the terminal cost only (Eq 57), re-planning toward V_d(t + T) is, for a
            double integrator, the closed loop ``q̈ = 3(x_d(t+T) − x − T ẋ)/T²`` — no lag on a ramp, and at
            ω = 2π/4 s an amplitude ratio of 0.98 for T = 0.2 s but 0.63 for T = 1 s).
        R, Q, Qv: control, terminal-error and terminal-velocity weights (Eq 56–57).  Qv is small by
            default: a moving target is not reached at rest.
        terminal: ``"soft"`` (Eq 57; default: a receding horizon needs no exact terminal equality) or
            ``"constraint"``.
        hessian: the iLQR's terminal model (:class:`~coop_ga.control.ilqr.ILQROptions`): ``"gauss_newton"``
            (default) or ``"newton"``.  Warm-started ticks take small steps, where the Newton model's extra
            curvature does not pay: on the tracking loop of ``benchmarks/mpc.py`` both give the same ‖e‖ (to
            four digits) and Gauss–Newton's tick is ~1.5–2.5× shorter (no error Hessian, no convexification).
        max_iter: compute budget per tick — iLQR iterations (≥ 1); the first tick (cold start) gets
            ``first_iter``.
        clearance_weight [1/m²], clearance_activation [m]: the clearance running cost of the plan (the
            iLQR's :class:`~coop_ga.control.avoidance.ClearanceCost`); 0 (default): none — the safety layer
            alone keeps the clearance.  Measured on three_franka (``benchmarks/mpc.py``): a weight of 1e4 makes
            a tick ~10× longer (one collision-model evaluation per knot and trial) for a larger margin.
    Rates:
        period: MPC tick period [s] (a whole number of knots: ``period = m · dt``, the warm start shifts
            the previous controls by m knots).
        time_budget: wall time [s] a tick may take (default: ``period``); a longer tick warns once per
            controller (:class:`~coop_ga.errors.RateWarning`, with the measured time) and is counted —
            it is never skipped.
    Safety layer (the clearance-limited QP of :mod:`coop_ga.control.solve`, between MPC ticks):
        filter_dt: its period [s].  d_safe, d_influence [m], damper_gain: the velocity dampers of
            :class:`~coop_ga.control.limits.ClearanceLimit`.  feedback: gain [1/s] pulling the state back
            onto the plan (``q̇_des = q̇_plan + k (q_plan − q)``).
        limit_gain: γ of the position limit (:func:`~coop_ga.control.limits.default_limits`).
        avoid: False drops the clearance rows and the clearance check of the state (the control case of an
            experiment: the same controller blind to obstacles and to the other arms).
    """

    horizon: int = 10
    dt: float = 0.02
    R: Any = DEFAULT_R
    Q: Any = DEFAULT_Q
    Qv: Any = 1.0
    terminal: str = "soft"
    hessian: str = "gauss_newton"
    max_iter: int = 2
    first_iter: int = 20
    clearance_weight: float = 0.0
    clearance_activation: float = 0.08
    period: float = 0.04
    time_budget: float | None = None
    filter_dt: float = 0.01
    d_safe: float = 0.03
    d_influence: float = 0.15
    damper_gain: float = 0.5
    feedback: float = 5.0
    limit_gain: float = 0.5
    avoid: bool = True

    def __post_init__(self) -> None:
        validation.integer(self.horizon, "horizon", minimum=2)
        validation.positive(self.dt, "dt")
        validation.choice(self.terminal, ("soft", "constraint"), "terminal")
        validation.choice(self.hessian, ("newton", "gauss_newton"), "hessian")
        validation.integer(self.max_iter, "max_iter", minimum=1)
        validation.integer(self.first_iter, "first_iter", minimum=1)
        validation.nonnegative(self.clearance_weight, "clearance_weight")
        validation.positive(self.clearance_activation, "clearance_activation")
        validation.positive(self.period, "period")
        if self.time_budget is not None:
            validation.positive(self.time_budget, "time_budget")
        validation.positive(self.filter_dt, "filter_dt")
        validation.nonnegative(self.feedback, "feedback")
        validation.scalar(self.limit_gain, "limit_gain", low=0.0, high=1.0, low_open=True)
        if not isinstance(self.avoid, bool):
            raise InvalidInputError(f"avoid must be True or False, got {self.avoid!r}")
        if not self.d_influence > self.d_safe:
            raise InvalidInputError(f"d_influence ({self.d_influence} m) must exceed d_safe ({self.d_safe} m)")
        m = self.period / self.dt
        if abs(m - round(m)) > 1e-9 * m or round(m) < 1 or round(m) >= self.horizon:
            raise InvalidInputError(
                f"period ({self.period} s) must be a whole number of knots dt ({self.dt} s), fewer than the horizon "
                f"({self.horizon}); e.g. period = dt"
            )

    @property
    def shift(self) -> int:
        """Knots the plan advances per tick (``period / dt``)."""
        return round(self.period / self.dt)

    @property
    def lookahead(self) -> float:
        """``horizon · dt`` [s]: how far ahead the plan's terminal target is taken."""
        return self.horizon * self.dt

    @property
    def budget(self) -> float:
        """The wall-time budget of one tick [s]."""
        return self.period if self.time_budget is None else float(self.time_budget)
