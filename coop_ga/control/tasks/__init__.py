"""Tasks of the control layer (mink/pink shape): an error, its Jacobian, a gain and a weight.

Every task reads the step's :class:`~coop_ga.control.configuration.Configuration` (one compiled
evaluation per q, shared by all tasks and limits) and gives :func:`~coop_ga.control.solve_step` the
rows of its cost ``½‖W (J q̇ + α e)‖²`` (:mod:`~coop_ga.control.tasks.base`).

* :class:`SimilarityTask` — the cooperative similarity V_Sc(q) → V_Sd (Eq 44, 48);
* :class:`PositionTask` — an end point at p* [m] (``form='joint'``: Eq 60's secondary velocity, Figs. 16–17);
* :class:`LineParameterTask` — the direction/moment of the line of two end points (Fig. 15's horizontal line);
* :class:`PostureTask` — q → q*; :class:`JointVelocityTask` — a joint-velocity reference;
* :class:`DualTask` — the relative or absolute motor of two frames (the cooperative dual task space,
  :class:`DualTaskSpace`): e.g. the relative orientation of two grippers, stacked with a similarity task;
* :class:`PartnerPairTask` — a human partner (§5.5): the point pair of a measured point (a hand the controller
  cannot move, updated each step) and a robot end point keeps its direction and length.
"""

from .base import BaseTask, Task
from .dual import DUAL_COMPONENTS, DUAL_ROWS, DualState, DualTask, DualTaskSpace
from .joints import JointVelocityTask, PostureTask
from .partner import PARTNER_ROWS, PartnerPairTask
from .points import LINE_PARAMETERS, LineParameterTask, PositionTask, line_from_points
from .similarity import BodyVelocityTask, SimilarityTask

__all__ = [
    "DUAL_COMPONENTS",
    "DUAL_ROWS",
    "LINE_PARAMETERS",
    "PARTNER_ROWS",
    "BaseTask",
    "BodyVelocityTask",
    "DualState",
    "DualTask",
    "DualTaskSpace",
    "JointVelocityTask",
    "LineParameterTask",
    "PartnerPairTask",
    "PositionTask",
    "PostureTask",
    "SimilarityTask",
    "Task",
    "line_from_points",
]
