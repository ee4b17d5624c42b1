"""The cooperative similarity task: drive V_Sc(q) to a target V_Sd (Eq 44, 48; the task graph of §3.4).

Error (mink's convention, zero at the target): ``e(q) = log(Ṽ_Sd V_Sc(q)) = −log(Ṽ_Sc(q) V_Sd)`` (7,) on
``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]`` (the principal log: ``log(W⁻¹) = −log W``), so the step's
``J q̇ = −α e`` commands the body velocity ``B_S = α log(Ṽ_Sc V_Sd)`` of Eq 48.  Two Jacobians:

* ``jacobian='body'`` (default): J^G (7, nq), the body-frame Jacobian of Eq 30 — Eq 48 as the paper
  (and :func:`~coop_ga.control.diff_ik_reach`) writes it; it is ∂e/∂q where e = 0 (at the target) and
  the first-order map of q̇ to the body velocity everywhere;
* ``jacobian='exact'``: ``∂e/∂q = −K J^G = −J_e`` (Eq 47, the right Jacobian of the log), as mink's
  ``FrameTask`` uses ``jlog``: a Gauss–Newton step on e far from the target.

Both come from the step's one compiled evaluation (:class:`~coop_ga.control.configuration.Configuration`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ... import validation
from ...geometry.groups import Similarity, SimilarityLike
from .base import BaseTask

__all__ = ["SIMILARITY_ROWS", "BodyVelocityTask", "SimilarityTask"]

#: the rows of the similarity error and of J^G
SIMILARITY_ROWS = ("e12", "e13", "e23", "e0∞", "e1∞", "e2∞", "e3∞")


class SimilarityTask(BaseTask):
    """V_Sc(q) → ``target`` (module docstring).

    Args:
        target: V_Sd, a :class:`~coop_ga.Similarity` (in the model's chart: ``model.check_target``).
        gain: α [1/s] (default 10, :class:`~coop_ga.control.DiffIKOptions`).
        weight: per-row weights (7,) or a scalar.
        jacobian: ``'body'`` (J^G, Eq 48) or ``'exact'`` (−J_e, Eq 47).
        lm_damping: μ of the Levenberg–Marquardt term.
    """

    labels = SIMILARITY_ROWS

    def __init__(
        self,
        target: SimilarityLike,
        *,
        gain: float = 10.0,
        weight: Any = None,
        jacobian: str = "body",
        lm_damping: float = 0.0,
    ):
        super().__init__(gain, weight, lm_damping, "similarity")
        self.target: Similarity = validation.target(target)
        self.mode = validation.choice(jacobian, ("body", "exact"), "jacobian")

    @property
    def similarity_target(self) -> Similarity:
        """V_Sd, which the configuration evaluates with the kinematics (one compiled call)."""
        return self.target

    def log_error(self, configuration: Any) -> np.ndarray:
        """``log(Ṽ_Sc(q) V_Sd)`` (7,) (Eq 44: the target seen from the current pose; = −error)."""
        return configuration.similarity_error(self.target)[0]

    def error(self, configuration: Any) -> np.ndarray:
        """``e = −log(Ṽ_Sc(q) V_Sd)`` (7,)."""
        return -self.log_error(configuration)

    def jacobian(self, configuration: Any) -> np.ndarray:
        """J^G (``'body'``) or ``−K J^G`` (``'exact'``), (7, nq)."""
        J = configuration.kinematics().jacobian
        if self.mode == "body":
            return J
        return -(configuration.similarity_error(self.target)[1] @ J)

    def velocity(self, configuration: Any) -> np.ndarray:
        """``B_S = α log(Ṽ_Sc V_Sd)`` (7,), the commanded body velocity of Eq 48."""
        return self.gain * self.log_error(configuration)


class BodyVelocityTask(BaseTask):
    """A commanded body velocity B_S (7,) of V_Sc [rad/s, 1/s, body length/s] (Eq 48): the cost ½‖J^G q̇ − B_S‖²
    (error ``−B_S``, gain 1, Jacobian J^G) — the task of :func:`~coop_ga.control.diff_ik_step` and teleoperation."""

    labels = SIMILARITY_ROWS

    def __init__(self, command: Any):
        super().__init__(1.0, None, 0.0, "body velocity")
        self.command = validation.vector(command, 7, "command_bivector [e12, e13, e23, e0∞, e1∞, e2∞, e3∞]")

    def error(self, configuration: Any) -> np.ndarray:
        return -self.command

    def jacobian(self, configuration: Any) -> np.ndarray:
        return configuration.kinematics().jacobian

    def qp_rows(self, configuration: Any) -> tuple[np.ndarray | None, np.ndarray]:
        return configuration.kinematics().jacobian, self.command
