"""Planning over cooperative regions.

* :mod:`~coop_ga.plan.regions` — regions of a primitive's natural coordinates (centre, axis cone, log-scale) in
  a user frame, the rigid grasp, with exact Jacobians through the compiled J^G;
* :mod:`~coop_ga.plan.projection` — projection onto a residual's zero set by the bounded Gauss–Newton of
  :mod:`coop_ga.control`;
* :mod:`~coop_ga.plan.ompl` — constrained sampling-based planning with OMPL (the ``plan`` extra);
* :mod:`~coop_ga.plan.carried` — a box carried by the end points and its clearances;
* :mod:`~coop_ga.plan.timing` — TOPP-RA time parameterisation within the joint limits (the ``plan`` extra);
* :mod:`~coop_ga.plan.box_lift`, :mod:`~coop_ga.plan.scenes` — the benchmark scenes (box lift past a shelf lip,
  an Allegro sphere, a two-arm G1 line).
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
