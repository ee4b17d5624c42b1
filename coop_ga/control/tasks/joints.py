"""Joint-space tasks: a posture q* and a joint-velocity reference (the secondary motions of Eq 60)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ... import validation
from .base import BaseTask

__all__ = ["JointVelocityTask", "PostureTask"]


class PostureTask(BaseTask):
    """``q → q*``: error ``q − q*`` (nq,) [rad or m], Jacobian I (mink's ``PostureTask``); with a free flyer
    (nq ≠ nv) the error is ``difference(q*, q)`` (nv,) with the Jacobian I, pink's approximation.

    Args:
        target: q* (nq,).  gain: α [1/s].  weight: scalar or (nq,).  lm_damping: μ.
    """

    def __init__(self, target: Any, *, gain: float = 1.0, weight: Any = None, lm_damping: float = 0.0):
        super().__init__(gain, weight, lm_damping, "posture")
        self.target = validation.array(target, "posture target").reshape(-1)

    def error(self, configuration: Any) -> np.ndarray:
        if configuration.nq != configuration.nv:  # a free flyer: the velocity from q* to q (pink's approximation J = I)
            return configuration.system.difference(self.target, configuration.q)
        return configuration.q - self.target

    def jacobian(self, configuration: Any) -> np.ndarray:
        return np.eye(configuration.nv)

    def qp_rows(self, configuration: Any) -> tuple[np.ndarray | None, np.ndarray]:
        if isinstance(self.weight, float) and self.weight == 1.0:
            return None, self.velocity(configuration)
        return super().qp_rows(configuration)


class JointVelocityTask(BaseTask):
    """Track a joint velocity q̇_r (nq,) [rad/s]: the cost ½‖q̇ − q̇_r‖² (error ``−q̇_r``, gain 1, Jacobian I).

    The form of the secondary task of Eq 60 (``q̇ = J⁺ b + N q̇_2``) as a QP level: with the primary task
    held on the row space of J^G, its minimiser is ``q̇₁ + N q̇_r`` (:func:`~coop_ga.control.solve_step`).
    ``velocity`` may be a callable ``configuration → q̇_r`` evaluated at every step.
    """

    def __init__(self, velocity: Any, *, name: str = "joint velocity"):
        super().__init__(1.0, None, 0.0, name)
        self.reference = velocity if callable(velocity) else validation.array(velocity, "velocity").reshape(-1)

    def _reference(self, configuration: Any) -> np.ndarray:
        if callable(self.reference):
            return configuration.cached(id(self), self.reference)
        return self.reference

    def error(self, configuration: Any) -> np.ndarray:
        return -self._reference(configuration)

    def jacobian(self, configuration: Any) -> np.ndarray:
        return np.eye(configuration.nv)

    def qp_rows(self, configuration: Any) -> tuple[np.ndarray | None, np.ndarray]:
        return None, self._reference(configuration)
