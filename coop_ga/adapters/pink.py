"""coop_ga tasks inside pink (stephane-caron/pink): differential IK on a pink ``Configuration``.

:class:`CoopGATask` is a ``pink.tasks.Task`` whose error and Jacobian are those of a coop_ga task of the control
layer (:mod:`coop_ga.control.tasks`): the cooperative similarity (:class:`~coop_ga.control.tasks.SimilarityTask`,
Eq 44, 47–48), a dual task space motor (:class:`~coop_ga.control.tasks.DualTask`), an end-point position, …
They are read from a coop_ga :class:`~coop_ga.control.Configuration` kept at the pink configuration's q, so the
compiled evaluation of the cooperative task graph is made once per q and shared by every wrapped task.
``pink.solve_ik`` then stacks it with pink's own tasks (``FrameTask``, ``PostureTask``, …), limits
(``ConfigurationLimit``, ``VelocityLimit``) and barriers.

Conventions: pink's step is the displacement ``Δq = v Δt`` and its task dynamics ``J Δq = −α e`` with a
dimensionless gain α ∈ [0, 1] (coop_ga's is ``J q̇ = −α e`` with α in 1/s), and its cost weighs the rows as
coop_ga's ``weight`` does.  The wrapped task's own gain and weight are not used; pink's ``gain``, ``cost`` and
``lm_damping`` are the adapter's arguments.  The coop_ga error is ``e = −log(Ṽ_Sc V_Sd)`` and the Jacobian
``∂e/∂q`` (``jacobian='exact'``, the default for :func:`similarity_task`: pink takes full Gauss–Newton-like steps
with α = 1) or the body Jacobian J^G (``'body'``).

The systems of coop_ga have revolute and prismatic joints only (nq = nv), so pink's tangent space is q's.
:func:`pink_configuration` builds the pink configuration on a copy of the system's Pinocchio model with
coop_ga's joint limits (position and velocity), so pink's limits are the ones coop_ga's controllers impose.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pink
import pinocchio as pin

from .. import validation
from ..control.configuration import Configuration
from ..control.tasks import SimilarityTask
from ..errors import InvalidInputError

__all__ = ["CoopGATask", "pink_configuration", "similarity_task"]


def pink_configuration(model: Any, q: Any) -> pink.Configuration:
    """A ``pink.Configuration`` at q (nq,) on a copy of the system's Pinocchio model, with coop_ga's position
    and velocity limits (``model``: a :class:`~coop_ga.CooperativeTask` or a System)."""
    system = getattr(model, "system", model)
    limits = system.limits
    qv = validation.configuration(q, int(system.model.nq), "q", owner=getattr(system, "name", ""))
    m = pin.Model(system.model)  # pink adds attributes to the model: leave the system's own alone
    m.lowerPositionLimit = np.asarray(limits.lower, dtype=float).copy()
    m.upperPositionLimit = np.asarray(limits.upper, dtype=float).copy()
    m.velocityLimit = np.asarray(limits.velocity, dtype=float).copy()
    return pink.Configuration(m, m.createData(), qv)


class CoopGATask(pink.tasks.Task):
    """A coop_ga task (:mod:`coop_ga.control.tasks`) as a ``pink.tasks.Task`` (module docstring).

    Args:
        model: the :class:`~coop_ga.CooperativeTask` whose configuration the task reads (its system must be the
            pink configuration's robot: the same number of joints, in Pinocchio's order).
        task: a coop_ga task: ``error(configuration)`` (k,) and ``jacobian(configuration)`` (k, nq).
        cost: pink's per-row weights (k,) or a scalar (default 1).
        gain: pink's α ∈ [0, 1] of ``J Δq = −α e`` (default 1: dead-beat).
        lm_damping: pink's Levenberg–Marquardt scale (default 0).

    Raises:
        InvalidInputError: a task without error/Jacobian, a gain outside [0, 1]; at the first use, a pink
            configuration whose model does not have the system's nq.
    """

    def __init__(self, model: Any, task: Any, *, cost: Any = 1.0, gain: float = 1.0, lm_damping: float = 0.0):
        if not (callable(getattr(task, "error", None)) and callable(getattr(task, "jacobian", None))):
            raise InvalidInputError(
                f"task must be a coop_ga task with error(configuration) and jacobian(configuration), got {task!r}"
            )
        g = validation.nonnegative(gain, "gain")
        if g > 1.0:
            raise InvalidInputError(f"pink's task gain is dimensionless in [0, 1] (α of J Δq = −α e), got {gain!r}")
        c = float(cost) if np.ndim(cost) == 0 else validation.array(cost, "cost")
        super().__init__(cost=c, gain=g, lm_damping=validation.nonnegative(lm_damping, "lm_damping"))
        self.model = model
        self.task = task
        self._configuration: Configuration | None = None

    def coop_configuration(self, configuration: pink.Configuration) -> Configuration:
        """The coop_ga configuration at the pink configuration's q (moved only when q changed)."""
        q = np.asarray(configuration.q, dtype=float)
        nq = int(self.model.nq)
        if q.shape != (nq,):
            raise InvalidInputError(
                f"the pink configuration has nq = {q.shape[0]}, the coop_ga task '{self.model.name}' {nq}: build it "
                "with coop_ga.adapters.pink.pink_configuration(model, q) on the task's system"
            )
        c = self._configuration
        if c is None:
            c = self._configuration = Configuration(self.model, q)
        elif not np.array_equal(c.q, q):
            c.update(q)
        return c

    def compute_error(self, configuration: pink.Configuration) -> np.ndarray:
        """The coop_ga task's error e(q) (k,)."""
        return np.array(self.task.error(self.coop_configuration(configuration)), dtype=float)

    def compute_jacobian(self, configuration: pink.Configuration) -> np.ndarray:
        """The coop_ga task's Jacobian (k, nv) (nv = nq)."""
        return np.array(self.task.jacobian(self.coop_configuration(configuration)), dtype=float)

    def __repr__(self) -> str:
        return f"CoopGATask({self.task!r}, model={self.model.name!r}, cost={self.cost}, gain={self.gain})"


def similarity_task(
    model: Any,
    target: Any,
    *,
    cost: Any = 1.0,
    gain: float = 1.0,
    lm_damping: float = 0.0,
    jacobian: str = "exact",
) -> CoopGATask:
    """The cooperative similarity V_Sc(q) → ``target`` (a :class:`~coop_ga.Similarity`, in the model's chart) as a
    pink task: ``e = −log(Ṽ_Sc V_Sd)`` (7,) and ``∂e/∂q`` (``'exact'``) or J^G (``'body'``)."""
    return CoopGATask(
        model,
        SimilarityTask(model.check_target(target), jacobian=jacobian),
        cost=cost,
        gain=gain,
        lm_damping=lm_damping,
    )
