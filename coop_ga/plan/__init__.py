"""Planning over cooperative regions: regions of a primitive's natural coordinates with exact Jacobians
(:mod:`~coop_ga.plan.regions`), projection onto their constraint manifolds (:mod:`~coop_ga.plan.projection`)
and constrained sampling-based planning with OMPL (:mod:`~coop_ga.plan.ompl`, optional: the ``plan`` extra).
"""

from .regions import (
    Readout,
    Region,
    RegionSample,
    RegionTarget,
    Residual,
    RigidGrasp,
    Stack,
    finite_difference_jacobian,
    readout,
)

__all__ = [
    "Readout",
    "Region",
    "RegionSample",
    "RegionTarget",
    "Residual",
    "RigidGrasp",
    "Stack",
    "finite_difference_jacobian",
    "readout",
]
