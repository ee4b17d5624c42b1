"""A human partner (§5.5): the point pair of a measured point the controller cannot move and a robot end point.

One end of the primitive is an **external measured point** h (3,) [m] (a human hand from a recorded trajectory or a
MuJoCo mocap body), given anew each step (:meth:`PartnerPairTask.set_partner`); the other is end point ``index`` of
the step's model, p(q).  The task holds the point pair's direction d* and length ℓ* (the bar a human and a robot
carry: its rotation and scale; its position follows the human):

    d = (p − h)/ℓ,  ℓ = ‖p − h‖,   e = [d − d*; ℓ − ℓ*]  (4,) [1, m]

with the Jacobian w.r.t. q (4, nq) — the external point has zero columns, the robot cannot move it —

    ∂d/∂q = (I − d dᵀ) J_p / ℓ,   ∂ℓ/∂q = dᵀ J_p         (:func:`~coop_ga.control.tasks.points.line_from_points`)

and w.r.t. the measured point (4, 3), ``∂e/∂h = −[(I − d dᵀ)/ℓ; dᵀ]``.  The hand's motion is a disturbance: with its
velocity ḣ given (``set_partner(h, velocity=ḣ)``, e.g. a finite difference of the recording) the commanded task
velocity adds the feed-forward ``−(∂e/∂h) ḣ``, so ``J q̇ = −α e − (∂e/∂h) ḣ`` makes ė = −α e to first order.
The three direction rows have rank 2 (d is a unit vector): the task is a least-squares task, not an equality.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ... import validation
from ...errors import DegeneratePrimitiveError, InvalidInputError
from .base import BaseTask
from .points import end_index, line_from_points

__all__ = ["PARTNER_ROWS", "PartnerPairTask"]

#: the rows of the partner task's error: the direction d (unit) and the length ℓ [m]
PARTNER_ROWS = ("d_x", "d_y", "d_z", "length")


class PartnerPairTask(BaseTask):
    """The point pair (measured point h, end point ``index``) keeps direction d* and length ℓ* (module docstring).

    Args:
        model: the :class:`~coop_ga.CooperativeTask` of the steps this task runs in (its end points).
        index: the robot's end point (0 ≤ index < n) at the pair's far end.
        direction: d* (3,), from the measured point to the robot's point (normalised; must be non-zero).
        length: ℓ* [m] (> 0).
        partner: h (3,) [m], world frame, the first measurement (update it with :meth:`set_partner`).
        gain: α [1/s].  weight: per-row (4,) or scalar.  lm_damping: as :class:`BaseTask`.
    """

    labels = PARTNER_ROWS

    def __init__(
        self,
        model: Any,
        index: int,
        direction: Any,
        length: float,
        partner: Any,
        *,
        gain: float = 10.0,
        weight: Any = None,
        lm_damping: float = 0.0,
    ):
        super().__init__(gain, weight, lm_damping, f"partner pair of end point {index}")
        self.model = model
        self.index = end_index(model, index)
        d = validation.vector(direction, 3, "direction")
        n = float(np.linalg.norm(d))
        if not n > 0:
            raise InvalidInputError("direction must be a non-zero 3-vector (from the partner's point to the robot's)")
        self.direction = d / n
        self.length = validation.positive(length, "length [m]")
        self.partner = np.zeros(3)
        self.partner_velocity = np.zeros(3)
        self.set_partner(partner)

    def set_partner(self, point: Any, velocity: Any = None) -> None:
        """The new measurement h (3,) [m] and, for feed-forward, its velocity ḣ (3,) [m/s] (None: zero).

        Copied into the task's own buffers (the caller's arrays are not kept)."""
        self.partner[...] = validation.vector(point, 3, "partner point [m]")
        self.partner_velocity[...] = 0.0 if velocity is None else validation.vector(velocity, 3, "partner velocity")

    def state(self, configuration: Any) -> tuple[np.ndarray, float, np.ndarray]:
        """``(d (3,), ℓ [m], J_p (3, nq))`` of the pair at the configuration's q and the current measurement."""
        k = configuration.kinematics()
        i = self.index
        p = k.points[i]
        Jp = k.point_jacobians[3 * i : 3 * i + 3]
        ell = float(np.linalg.norm(p - self.partner))
        if not ell > 1e-9:
            raise DegeneratePrimitiveError(
                f"the partner's point {np.round(self.partner, 4).tolist()} and end point "
                f"{self.model.end_frames[i]} coincide (distance {ell:.3g} m): the pair has no direction"
            )
        return (p - self.partner) / ell, ell, Jp

    def error(self, configuration: Any) -> np.ndarray:
        """``[d − d*; ℓ − ℓ*]`` (4,)."""
        d, ell, _ = self.state(configuration)
        return np.concatenate([d - self.direction, [ell - self.length]])

    def jacobian(self, configuration: Any) -> np.ndarray:
        """∂e/∂q (4, nq) with the measured point held (zero columns for it)."""
        k = configuration.kinematics()
        i = self.index
        J = np.stack([np.zeros_like(k.point_jacobians[:3]), k.point_jacobians[3 * i : 3 * i + 3]])
        dm, Jdm = line_from_points(np.stack([self.partner, k.points[i]]), J, ("partner", self.model.end_frames[i]))
        return np.vstack([Jdm[:3], dm[:3] @ J[1]])

    def partner_jacobian(self, configuration: Any) -> np.ndarray:
        """∂e/∂h (4, 3) [1/m; 1]: how the error moves with the measured point (module docstring)."""
        d, ell, _ = self.state(configuration)
        return -np.vstack([(np.eye(3) - np.outer(d, d)) / ell, d])

    def velocity(self, configuration: Any) -> np.ndarray:
        """``−α e − (∂e/∂h) ḣ`` (4,): the feedback and the measured point's feed-forward."""
        v = -self.gain * self.error(configuration)
        if np.any(self.partner_velocity):
            v = v - self.partner_jacobian(configuration) @ self.partner_velocity
        return v
