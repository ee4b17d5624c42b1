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

Mixed primitives (§5.7): by default the task drives the configuration's own model (its cooperative task).  Given
``model=`` — another :class:`~coop_ga.CooperativeTask` of the same system, e.g. ``cooperative_task(system,
"circle", points=(0, 1, 2))`` over a *subset* of its end frames — it drives that primitive instead, evaluated at
the step's q by a configuration of its own (one compiled call per step, cached like every evaluation).  Several
such tasks stack in one :func:`~coop_ga.control.solve_step` (a circle of three end points and a line of two
others), or go to different priority ``levels``.
"""

from __future__ import annotations

import threading
from typing import Any

import numpy as np

from ... import validation
from ...errors import InvalidInputError
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
        model: the :class:`~coop_ga.CooperativeTask` whose V_Sc this task drives (None: the configuration's model);
            it must have the configuration's system (module docstring: mixed primitives).  The target is checked
            against its chart (``model.check_target``).
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
        model: Any = None,
    ):
        super().__init__(gain, weight, lm_damping, "similarity" if model is None else f"similarity of {model.name}")
        self.model = model
        self.target: Similarity = validation.target(target) if model is None else model.check_target(target)
        self.mode = validation.choice(jacobian, ("body", "exact"), "jacobian")
        self._own = threading.local()  # this thread's configuration of ``model``

    @property
    def similarity_target(self) -> Similarity | None:
        """V_Sd, which the configuration evaluates with the kinematics (one compiled call); None for a task with
        its own model (whose configuration is prepared here)."""
        return self.target if self.model is None else None

    def _configuration(self, configuration: Any) -> Any:
        """The configuration that evaluates this task's model at the step's q: the step's own, or one of
        :attr:`model` moved to the step's q (once per step: :meth:`Configuration.cached`)."""
        if self.model is None or self.model is configuration.model:
            return configuration
        return configuration.cached(("similarity model", id(self)), self._follow)

    def _follow(self, configuration: Any) -> Any:
        from ..configuration import Configuration

        base = configuration.model
        if self.model.nq != base.nq or getattr(self.model.system, "name", None) != getattr(base.system, "name", None):
            raise InvalidInputError(
                f"the similarity task of '{self.model.name}' (nq={self.model.nq}) cannot run in a step of "
                f"'{base.name}' (nq={base.nq}): build both cooperative tasks on the same system"
            )
        own = getattr(self._own, "configuration", None)
        if own is None:
            own = self._own.configuration = Configuration(self.model, configuration.q, configuration.velocity)
        else:
            own.update(configuration.q, configuration.velocity)
        own.prepare(self.target)
        return own

    def log_error(self, configuration: Any) -> np.ndarray:
        """``log(Ṽ_Sc(q) V_Sd)`` (7,) (Eq 44: the target seen from the current pose; = −error)."""
        return self._configuration(configuration).similarity_error(self.target)[0]

    def error(self, configuration: Any) -> np.ndarray:
        """``e = −log(Ṽ_Sc(q) V_Sd)`` (7,)."""
        return -self.log_error(configuration)

    def jacobian(self, configuration: Any) -> np.ndarray:
        """J^G (``'body'``) or ``−K J^G`` (``'exact'``), (7, nq)."""
        cfg = self._configuration(configuration)
        J = cfg.kinematics().jacobian
        if self.mode == "body":
            return J
        return -(cfg.similarity_error(self.target)[1] @ J)

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
