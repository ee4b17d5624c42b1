"""Cooperative task space layer: X_c(q), V_Sc(q), its Jacobians, manipulability, nullspace."""

from .manipulability import (
    damped_pinv,
    force_manipulability,
    manipulability,
    manipulability_ellipsoid,
    manipulability_index,
    nullspace_projector,
)
from .primitive import FLAT_KINDS, cooperative_primitive, primitive_jacobian
from .graph import TaskGraph
from .guard import TaskGuard
from .targets import displaced_target
from .task import CooperativeTask, TaskState, cooperative_task

__all__ = [
    "damped_pinv",
    "force_manipulability",
    "manipulability",
    "manipulability_ellipsoid",
    "manipulability_index",
    "nullspace_projector",
    "FLAT_KINDS",
    "cooperative_primitive",
    "primitive_jacobian",
    "CooperativeTask",
    "TaskState",
    "cooperative_task",
    "TaskGraph",
    "displaced_target",
    "TaskGuard",
]
