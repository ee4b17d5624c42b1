"""Joint limits on the velocity of one step: position (over Δt), velocity and acceleration (Eq 53: 𝒳, 𝒰).

With q the configuration, q̇_p its previous velocity, Δt the step and the bounds of
``system.limits`` (:class:`~coop_ga.systems.limits.JointLimits`):

* :class:`ConfigurationLimit` — ``γ (lower − q)/Δt ≤ q̇ ≤ γ (upper − q)/Δt`` (mink's
  ``ConfigurationLimit``, safety gain γ ∈ (0, 1]: a joint covers at most the fraction γ of its
  remaining range per step), widened to contain 0 (a q on a bound may read ±1e-17 outside);
* :class:`VelocityLimit` — ``|q̇| ≤ v``;
* :class:`AccelerationLimit` — ``|q̇ − q̇_p| ≤ a Δt`` (the finite-difference acceleration, pink's
  ``AccelerationLimit``), and the *braking* bound ``q̇ ≤ v_b(γ (upper − q))``,
  ``q̇ ≥ −v_b(γ (q − lower))``, where ``v_b(x)`` is the largest speed from which steps of Δt that
  decelerate by a Δt each stop within the distance x:

      S(v) = Δt Σ_{k ≥ 0} max(v − k a Δt, 0) ≤ x   ⇔   v ≤ v_b(x) = x/(Δt (K+1)) + K a Δt/2,
      K = ⌊(√(1 + 8x/(a Δt²)) − 1)/2⌋

  (pink and Flacco et al. 2015 use the continuous ``√(2 a x)``, which a discrete step can overshoot).
  Since ``S(v) = v Δt + S(v − a Δt)`` and γ ≤ 1, a step that satisfies it leaves ``max(q̇ − a Δt, 0)``
  feasible for the next step's position, velocity, acceleration and braking bounds: the joint boxes
  never become empty along a run (recursive feasibility), only user rows can conflict with them.
  Joints with an infinite acceleration limit are unbounded; a system without acceleration limits gives
  no inequality.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ... import validation
from ..qp import DEFAULT_LIMIT_GAIN
from .base import Inequalities

__all__ = ["DEFAULT_LIMIT_GAIN", "AccelerationLimit", "ConfigurationLimit", "VelocityLimit", "braking_speed"]

def _gain(gain: Any) -> float:
    return validation.scalar(gain, "limit_gain", low=0.0, high=1.0, low_open=True)


class ConfigurationLimit:
    """Position limits over one step with the safety gain γ (module docstring)."""

    name = "position"
    relaxable = False

    def __init__(self, gain: float = DEFAULT_LIMIT_GAIN):
        self.gain = _gain(gain)

    def inequalities(self, configuration: Any, dt: float) -> Inequalities:
        lim = configuration.limits
        q = configuration.q
        lb = self.gain * (lim.lower - q) / dt
        ub = self.gain * (lim.upper - q) / dt
        np.minimum(lb, 0.0, out=lb)
        np.maximum(ub, 0.0, out=ub)
        return Inequalities(lb, ub)

    def describe(self, limits: Any, i: int, upper: bool) -> str:
        """Label of joint i's active bound."""
        side, value = ("upper", limits.upper[i]) if upper else ("lower", limits.lower[i])
        return f"{limits.joint_names[i]} ({side} position limit {value:.4f})"


class VelocityLimit:
    """``|q̇| ≤ v`` of ``system.limits.velocity``."""

    name = "velocity"
    relaxable = False

    def inequalities(self, configuration: Any, dt: float) -> Inequalities:
        v = configuration.limits.velocity
        return Inequalities(-v, v)

    def describe(self, limits: Any, i: int, upper: bool) -> str:
        return f"{limits.joint_names[i]} (velocity limit {limits.velocity[i]:.4g})"


def braking_speed(distance: np.ndarray, acceleration: np.ndarray, dt: float) -> np.ndarray:
    """``v_b(x)`` (module docstring) [rad/s] for distances x ≥ 0 [rad] and accelerations a > 0 [rad/s²] (arrays)."""
    u = acceleration * dt  # the speed lost per step at full deceleration
    X = np.maximum(distance, 0.0) / dt  # S(v)/Δt ≤ X
    with np.errstate(invalid="ignore", over="ignore"):
        K = np.floor((np.sqrt(1.0 + 8.0 * X / u) - 1.0) / 2.0)
        v = X / (K + 1.0) + 0.5 * K * u
    return np.where(np.isfinite(v), v, np.inf)


class AccelerationLimit:
    """``|q̇ − q̇_p| ≤ a Δt`` and the braking bounds of the position limits (module docstring).

    Args:
        gain: γ of the braking distance (use the :class:`ConfigurationLimit`'s γ: recursive feasibility).
        braking: False drops the braking bounds (then a joint can arrive at a position bound too fast to
            stop, and the step's boxes may become empty: the step then relaxes this limit and says so).
    """

    name = "acceleration"
    relaxable = True

    def __init__(self, gain: float = DEFAULT_LIMIT_GAIN, braking: bool = True):
        self.gain = _gain(gain)
        self.braking = bool(braking)

    @staticmethod
    def active(limits: Any) -> bool:
        """Whether ``limits`` bounds the acceleration of any joint."""
        return bool(np.any(np.isfinite(limits.acceleration)))

    def inequalities(self, configuration: Any, dt: float) -> Inequalities:
        lim = configuration.limits
        a = lim.acceleration
        if not np.any(np.isfinite(a)):
            return Inequalities()
        v = configuration.velocity
        lb = v - a * dt  # −inf for unbounded joints
        ub = v + a * dt
        if self.braking:
            q = configuration.q
            finite = np.isfinite(a)
            up = np.where(finite & np.isfinite(lim.upper), braking_speed(self.gain * (lim.upper - q), a, dt), np.inf)
            lo = np.where(finite & np.isfinite(lim.lower), braking_speed(self.gain * (q - lim.lower), a, dt), np.inf)
            np.minimum(ub, up, out=ub)
            np.maximum(lb, -lo, out=lb)
        return Inequalities(lb, ub)

    def describe(self, limits: Any, i: int, upper: bool) -> str:
        return f"{limits.joint_names[i]} (acceleration limit {limits.acceleration[i]:.4g})"


def default_limits(system_limits: Any, gain: float = DEFAULT_LIMIT_GAIN, acceleration: bool = True) -> list[Any]:
    """``[ConfigurationLimit(γ), VelocityLimit()]`` plus an :class:`AccelerationLimit` when ``acceleration``
    and the system bounds the acceleration of some joint."""
    out: list[Any] = [ConfigurationLimit(gain), VelocityLimit()]
    if acceleration and AccelerationLimit.active(system_limits):
        out.append(AccelerationLimit(gain))
    return out
