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
        q = configuration.limit_coordinates()  # q itself when nq = nv
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

    def __init__(self) -> None:
        self._box: tuple[Any, Inequalities] | None = None

    def inequalities(self, configuration: Any, dt: float) -> Inequalities:
        lim = configuration.limits
        box = self._box
        if box is None or box[0] is not lim:  # constant per system: built once
            v = lim.velocity
            box = self._box = (lim, Inequalities(-v, v))
        return box[1]

    def describe(self, limits: Any, i: int, upper: bool) -> str:
        return f"{limits.joint_names[i]} (velocity limit {limits.velocity[i]:.4g})"


def braking_speed(distance: np.ndarray, acceleration: np.ndarray, dt: float) -> np.ndarray:
    """``v_b(x)`` (module docstring) [rad/s] for distances x ≥ 0 [rad] and accelerations a > 0 [rad/s²] (arrays;
    an infinite x or a gives an infinite bound)."""
    x = np.asarray(distance, dtype=float)
    a = np.asarray(acceleration, dtype=float)
    bad = ~(np.isfinite(x) & np.isfinite(a))
    if np.any(bad):
        v = _braking(np.where(bad, 0.0, x), np.where(bad, 1.0, a), dt)
        v[np.broadcast_to(bad, v.shape)] = np.inf
        return v
    return _braking(x, a, dt)


def _braking(x: np.ndarray, a: np.ndarray, dt: float) -> np.ndarray:
    """:func:`braking_speed` for finite x and a > 0 (no checks: the hot path)."""
    u = a * dt  # the speed lost per step at full deceleration
    X = np.maximum(x, 0.0) / dt  # S(v)/Δt ≤ X
    K = np.floor((np.sqrt(1.0 + 8.0 * X / u) - 1.0) * 0.5)
    return X / (K + 1.0) + 0.5 * K * u


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
        self._data: tuple[Any, ...] | None = None

    @staticmethod
    def active(limits: Any) -> bool:
        """Whether ``limits`` bounds the acceleration of any joint."""
        return bool(np.any(np.isfinite(limits.acceleration)))

    def _constants(self, lim: Any) -> tuple[Any, ...]:
        """Per-system constants (cached for the last limits object): ``(limits, a, a for braking (2, n),
        bounded (2, n) mask of the joints with a finite acceleration and position bound, any bounded)``."""
        d = self._data
        if d is None or d[0] is not lim:
            a = lim.acceleration
            fa = np.isfinite(a)
            bounded = np.vstack([fa & np.isfinite(lim.upper), fa & np.isfinite(lim.lower)])
            a2 = np.where(bounded, np.vstack([a, a]), 1.0)
            d = self._data = (lim, a, a2, bounded, bool(bounded.all()), bool(fa.any()))
        return d

    def inequalities(self, configuration: Any, dt: float) -> Inequalities:
        lim = configuration.limits
        _, a, a2, bounded, all_bounded, any_finite = self._constants(lim)
        if not any_finite:
            return Inequalities()
        v = configuration.velocity
        lb = v - a * dt  # −inf for unbounded joints
        ub = v + a * dt
        if self.braking:
            q = configuration.limit_coordinates()
            dist = self.gain * np.vstack([lim.upper - q, q - lim.lower])
            if not all_bounded:
                dist[~bounded] = 0.0
            vb = _braking(dist, a2, dt)
            if not all_bounded:
                vb[~bounded] = np.inf
            np.minimum(ub, vb[0], out=ub)
            np.maximum(lb, -vb[1], out=lb)
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
