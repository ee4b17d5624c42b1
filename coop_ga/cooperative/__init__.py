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
from .wrench import CooperativeWrench, WrenchMap, cooperative_wrench, squeeze_capacity, wrench_map

__all__ = [
    "COOPERATIVE_KINDS",
    "FIT_KINDS",
    "FLAT_KINDS",
    "CooperativeTask",
    "CooperativeWrench",
    "TaskGraph",
    "TaskGuard",
    "TaskState",
    "WrenchMap",
    "cooperative_primitive",
    "cooperative_task",
    "cooperative_wrench",
    "damped_pinv",
    "displaced_target",
    "fit_primitive",
    "force_manipulability",
    "manipulability",
    "manipulability_ellipsoid",
    "manipulability_index",
    "nullspace_projector",
    "primitive_jacobian",
    "squeeze_capacity",
    "wrench_map",
]
