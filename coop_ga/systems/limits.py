"""Joint limits as data: position, velocity, acceleration and effort bounds of a system (paper Eq 53: 𝒳, 𝒰).

Sources and defaults
--------------------
* position ``[lower, upper]`` [rad or m] and velocity ``velocity`` [rad/s or m/s] and effort
  ``effort`` [N m or N]: from the model (URDF ``<limit lower upper velocity effort>``);
* a velocity limit the URDF does not give (0, negative, non-finite or > 1e10, as Pinocchio
  stores a missing value) is set to :data:`DEFAULT_VELOCITY_LIMIT` (2 rad/s — the order of the
  slowest joints of today's collaborative arms: Franka 2.175–2.61 rad/s, iiwa 14 1.31–2.36
  rad/s) and flagged in ``velocity_defaulted``; a missing effort is unbounded (inf);
* acceleration ``acceleration`` [rad/s² or m/s²]: URDF has none, so it is unbounded (inf)
  unless the system sets it (the Franka's datasheet values in :mod:`coop_ga.systems.library`)
  or the user does;
* joints without finite position limits (models built in code get ±1.8e308) stay unbounded.

Override by joint name with :meth:`JointLimits.replace` or :meth:`coop_ga.systems.System.with_limits`::

    sys2 = sys.with_limits(position={"arm0_panda_joint4": (-2.5, -0.2)}, velocity={"arm0_panda_joint1": 1.0},
                           acceleration=10.0)        # a scalar applies to every joint
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import validation
from ..errors import InvalidInputError, UnknownNameError

__all__ = ["DEFAULT_VELOCITY_LIMIT", "JointLimits", "position_limits"]

#: Velocity limit [rad/s or m/s] used where the model gives none (module docstring).
DEFAULT_VELOCITY_LIMIT = 2.0


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a


def position_limits(model: Any) -> tuple[np.ndarray, np.ndarray]:
    """``(lower, upper)`` position limits of a ``pinocchio.Model``, one per velocity (nv,), in q̇ order.

    When nq = nv they are the model's ``lowerPositionLimit``/``upperPositionLimit`` as they are.  Otherwise each
    1-DOF joint's bounds sit at its velocity index and a free flyer's six entries are unbounded (±inf): its
    position is free and its quaternion has no bound to violate (Pinocchio stores ±1 there).
    """
    if model.nq == model.nv:
        return np.array(model.lowerPositionLimit, dtype=float), np.array(model.upperPositionLimit, dtype=float)
    lo, hi = np.full(model.nv, -np.inf), np.full(model.nv, np.inf)
    for j in range(1, model.njoints):
        if model.nqs[j] == 1 and model.nvs[j] == 1:
            lo[model.idx_vs[j]] = model.lowerPositionLimit[model.idx_qs[j]]
            hi[model.idx_vs[j]] = model.upperPositionLimit[model.idx_qs[j]]
    return lo, hi


@dataclass(frozen=True, eq=False)
class JointLimits:
    """Per-joint bounds, all (nq,) arrays in q order (read-only).

    For a system with nq ≠ nv (a free flyer) every array has one entry per *velocity* (nv,), in q̇ order:
    a 1-DOF joint's position bounds apply to its coordinate, a free flyer's six entries have no position bound
    (:func:`position_limits`); positions are then compared through
    :meth:`coop_ga.systems.System.limit_coordinates` (q's bounded coordinates in q̇ order).

    Attributes:
        joint_names: names in q order (in q̇ order when nq ≠ nv: a free flyer ``root`` gives
            ``root:vx`` … ``root:wz``).
        lower, upper: position limits [rad or m] (±inf: unbounded).
        velocity: |q̇| ≤ velocity [rad/s or m/s] (> 0).
        acceleration: |q̈| ≤ acceleration [rad/s² or m/s²] (> 0, inf = unbounded).
        effort: |τ| ≤ effort [N m or N] (> 0, inf = unbounded).
        velocity_defaulted: True where the velocity limit is :data:`DEFAULT_VELOCITY_LIMIT`.
    """

    joint_names: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    effort: np.ndarray
    velocity_defaulted: np.ndarray

    def __post_init__(self) -> None:
        n = len(self.joint_names)
        for name in ("lower", "upper", "velocity", "acceleration", "effort"):
            a = validation.array(getattr(self, name), name, finite=False)
            if a.shape != (n,) or np.any(np.isnan(a)):
                raise InvalidInputError(f"joint limits '{name}' must be {n} numbers (no NaN), got shape {a.shape}")
            object.__setattr__(self, name, _frozen(a))
        object.__setattr__(self, "velocity_defaulted", np.array(self.velocity_defaulted, dtype=bool))
        if np.any(self.lower > self.upper):
            bad = [self.joint_names[i] for i in np.flatnonzero(self.lower > self.upper)]
            raise InvalidInputError(f"lower position limit above the upper one for joint(s) {bad}")
        for name in ("velocity", "acceleration", "effort"):
            if np.any(getattr(self, name) <= 0):
                bad = [self.joint_names[i] for i in np.flatnonzero(getattr(self, name) <= 0)]
                raise InvalidInputError(f"{name} limits must be > 0 (inf = unbounded); not so for {bad}")

    @classmethod
    def from_model(cls, model: Any, joint_names: Sequence[str]) -> JointLimits:
        """Limits read from a ``pinocchio.Model`` (module docstring for the defaults); ``joint_names`` (nq,)."""
        import pinocchio as pin

        if not isinstance(model, pin.Model):
            raise InvalidInputError(f"model must be a pinocchio.Model, got {type(model).__name__}")
        if isinstance(joint_names, str) or not isinstance(joint_names, Sequence) or len(joint_names) != model.nv:
            raise InvalidInputError(
                f"joint_names must be {model.nv} names (one per velocity of q̇, i.e. per coordinate of q when "
                f"nq = nv), got {joint_names!r}"
            )
        lo, hi = position_limits(model)
        big = 1e300  # Pinocchio's "no limit" is ±max double
        lo[lo < -big] = -np.inf
        hi[hi > big] = np.inf
        v = np.array(model.velocityLimit, dtype=float)
        missing = ~np.isfinite(v) | (v <= 0) | (v > 1e10)
        v[missing] = DEFAULT_VELOCITY_LIMIT
        eff = np.array(model.effortLimit, dtype=float)
        eff[~np.isfinite(eff) | (eff <= 0) | (eff > 1e10)] = np.inf
        return cls(tuple(joint_names), lo, hi, v, np.full(lo.shape, np.inf), eff, missing)

    @property
    def nq(self) -> int:
        return len(self.joint_names)

    def _index(self, name: str, what: str) -> int:
        try:
            return self.joint_names.index(name)
        except ValueError:
            raise UnknownNameError(f"{what}: unknown joint {name!r}; joints: {', '.join(self.joint_names)}") from None

    def replace(
        self,
        *,
        position: Mapping[str, tuple[float, float]] | None = None,
        velocity: Mapping[str, float] | float | None = None,
        acceleration: Mapping[str, float] | float | None = None,
        effort: Mapping[str, float] | float | None = None,
    ) -> JointLimits:
        """New limits with the given joints overridden (a scalar velocity/acceleration/effort applies to all)."""
        if position is not None and not isinstance(position, Mapping):
            raise InvalidInputError(f"position must be a dict {{joint: (lower, upper)}}, got {position!r}")
        lo, hi = self.lower.copy(), self.upper.copy()
        for name, pair in (position or {}).items():
            i = self._index(name, "position")
            b = validation.array(pair, f"position limits of {name}", finite=False)
            if b.shape != (2,) or np.any(np.isnan(b)):
                raise InvalidInputError(f"position limits of {name} must be (lower, upper), got {pair!r}")
            lo[i], hi[i] = b
        out: dict[str, np.ndarray] = {}
        vdef = self.velocity_defaulted.copy()
        for field_name, spec in (("velocity", velocity), ("acceleration", acceleration), ("effort", effort)):
            a = getattr(self, field_name).copy()
            if spec is None:
                pass
            elif isinstance(spec, Mapping):
                for name, val in spec.items():
                    i = self._index(name, field_name)
                    a[i] = validation.positive(val, f"{field_name} limit of {name}", allow_inf=True)
                    if field_name == "velocity":
                        vdef[i] = False
            else:
                a[:] = validation.positive(spec, f"{field_name} limit", allow_inf=True)
                if field_name == "velocity":
                    vdef[:] = False
            out[field_name] = a
        return JointLimits(self.joint_names, lo, hi, out["velocity"], out["acceleration"], out["effort"], vdef)

    # ------------------------------------------------------------------ checks
    def _rows(self, x: Any, what: str) -> np.ndarray:
        """A vector (nq,) or a trajectory (T, nq) of per-joint values, checked (a new array)."""
        a = validation.array(x, what)
        if a.ndim not in (1, 2) or a.shape[-1] != self.nq:
            raise InvalidInputError(f"{what} must have shape ({self.nq},) or (T, {self.nq}), got shape {a.shape}")
        return a

    def position_violation(self, q: Any) -> float:
        """Largest excursion [rad or m] of q (nq,) or (T, nq) outside [lower, upper]; 0 inside."""
        a = self._rows(q, "q")
        return float(max(np.max(self.lower - a, initial=0.0), np.max(a - self.upper, initial=0.0), 0.0))

    def velocity_violation(self, qd: Any) -> float:
        """Largest excess of |q̇| (nq,) or (T, nq) over the velocity limit [rad/s]; 0 inside."""
        return float(max(np.max(np.abs(self._rows(qd, "qd")) - self.velocity, initial=0.0), 0.0))

    def trajectory_velocity_violation(self, traj: Any, dt: float) -> float:
        """Largest excess of the finite-difference speed ``|q_{t+1} − q_t|/Δt`` over the velocity limit
        [rad/s] along ``traj`` (T, nq) sampled every ``dt`` [s]; 0 inside.

        The difference of two floats carries a rounding error up to ``2 eps max(|q_t|, |q_{t+1}|)``, i.e.
        ~1e-15 rad/s at Δt = 0.01 s: a step taken exactly at a velocity bound by the QP reads that much
        above it.  That resolution is discounted, so only a real overshoot is reported.
        """
        Q = self._rows(traj, "traj")
        dt = validation.positive(dt, "dt [s]")
        if Q.ndim != 2 or len(Q) < 2:
            return 0.0
        speed = np.abs(np.diff(Q, axis=0)) / dt
        if not np.all(np.isfinite(speed)):
            raise InvalidInputError(f"dt = {dt:g} s is too small: the finite-difference speeds overflow")
        resolution = 2.0 * np.finfo(float).eps * np.maximum(np.abs(Q[1:]), np.abs(Q[:-1])) / dt
        return float(max(np.max(speed - self.velocity - resolution, initial=0.0), 0.0))

    def acceleration_violation(self, qdd: Any) -> float:
        """Largest excess of |q̈| (nq,) or (T, nq) over the acceleration limit [rad/s²]; 0 inside."""
        return float(max(np.max(np.abs(self._rows(qdd, "qdd")) - self.acceleration, initial=0.0), 0.0))

    def effort_violation(self, tau: Any) -> float:
        """Largest excess of |τ| (nq,) or (T, nq) over the effort limit [N m]; 0 inside."""
        return float(max(np.max(np.abs(self._rows(tau, "tau")) - self.effort, initial=0.0), 0.0))

    def clip(self, q: Any) -> np.ndarray:
        """q (nq,) or (T, nq) clipped into [lower, upper] (a new array)."""
        return np.clip(self._rows(q, "q"), self.lower, self.upper)

    def describe(self, q: Any, tol: float = 0.0) -> str:
        """Human-readable list of the joints of q (nq,) outside their position limits by more than tol ≥ 0."""
        a = validation.vector(q, self.nq, "q")
        tol = validation.nonnegative(tol, "tol")
        bad = np.flatnonzero((a < self.lower - tol) | (a > self.upper + tol))
        return ", ".join(
            f"{self.joint_names[i]}={a[i]:.4f} not in [{self.lower[i]:.4f}, {self.upper[i]:.4f}]" for i in bad
        )
