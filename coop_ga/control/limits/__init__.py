"""Limits of the control layer (mink/pink shape): linear inequalities on the joint velocity of a step.

* :class:`ConfigurationLimit`, :class:`VelocityLimit`, :class:`AccelerationLimit` — the joint limits
  of ``system.limits`` (Eq 53; :mod:`~coop_ga.control.limits.joints`);
* :class:`ClearanceLimit` — velocity dampers of a collision model (:mod:`~coop_ga.control.limits.clearance`);
* :class:`~coop_ga.control.LinearConstraint` — user rows ``G q̇ ≤ h``; :class:`UserConstraints` — such rows, or
  a function of q that gives them at every step.
"""

from ..qp import LinearConstraint
from .base import Inequalities, Limit, UserConstraints
from .clearance import ClearanceLimit, clearance_constraint
from .joints import (
    DEFAULT_LIMIT_GAIN,
    AccelerationLimit,
    ConfigurationLimit,
    VelocityLimit,
    braking_speed,
    default_limits,
)

__all__ = [
    "DEFAULT_LIMIT_GAIN",
    "AccelerationLimit",
    "ClearanceLimit",
    "ConfigurationLimit",
    "Inequalities",
    "Limit",
    "LinearConstraint",
    "UserConstraints",
    "VelocityLimit",
    "braking_speed",
    "clearance_constraint",
    "default_limits",
]
