"""Cooperative task space layer: X_c(q), V_Sc(q), its Jacobians, manipulability, nullspace."""

from .graph import TaskGraph
from .guard import TaskGuard
from .manipulability import (
    damped_pinv,
    force_manipulability,
    manipulability,
    manipulability_ellipsoid,
    manipulability_index,
    nullspace_projector,
)
from .primitive import (
    COOPERATIVE_KINDS,
    FIT_KINDS,
    FLAT_KINDS,
    cooperative_primitive,
    fit_primitive,
    primitive_jacobian,
)
from .targets import displaced_target
from .task import CooperativeTask, TaskState, cooperative_task

__all__ = [
    "COOPERATIVE_KINDS",
    "FIT_KINDS",
    "FLAT_KINDS",
    "CooperativeTask",
    "TaskGraph",
    "TaskGuard",
    "TaskState",
    "cooperative_primitive",
    "cooperative_task",
    "damped_pinv",
    "displaced_target",
    "fit_primitive",
    "force_manipulability",
    "manipulability",
    "manipulability_ellipsoid",
    "manipulability_index",
    "nullspace_projector",
    "primitive_jacobian",
]
