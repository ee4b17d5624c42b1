"""Planning over cooperative regions: regions of a primitive's natural coordinates with exact Jacobians
(:mod:`~coop_ga.plan.regions`), projection onto their constraint manifolds (:mod:`~coop_ga.plan.projection`)
and constrained sampling-based planning with OMPL (:mod:`~coop_ga.plan.ompl`, optional: the ``plan`` extra).
"""

from .carried import CarriedBox, box_sphere_distance, points_frame
from .ompl import PLANNERS, PlannerOptions, PlanningProblem, PlanResult, Validity, plan, seed_ompl
from .projection import PROJECTION_OPTIONS, Projection, project
from .regions import (
    EndPoints,
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
    "PLANNERS",
    "PROJECTION_OPTIONS",
    "CarriedBox",
    "EndPoints",
    "PlanResult",
    "PlannerOptions",
    "PlanningProblem",
    "Projection",
    "Readout",
    "Region",
    "RegionSample",
    "RegionTarget",
    "Residual",
    "RigidGrasp",
    "Stack",
    "Validity",
    "box_sphere_distance",
    "finite_difference_jacobian",
    "plan",
    "points_frame",
    "project",
    "readout",
    "seed_ompl",
]
