"""The box-lift planning scene: three Franka arms lift a box 0.2 m past a shelf lip, the grasp held rigid.

Scene (:func:`box_lift_problem`), ``three_franka`` (arms 120° apart on a 0.8 m ring, facing the centre,
hands pointing down):

* the grasp: the three TCPs on a horizontal circle of radius ρ = 0.3 m at z = 0.45 m, at −90°, 30° and 150°
  (the arms' own directions), found by the bounded Gauss–Newton projection from ``q0``
  (:class:`EndPointTargets`);
* the box (0.52 × 0.48 × 0.20 m, :class:`~coop_ga.plan.carried.CarriedBox`) held at its upper rim: arm 0 on
  its −y face, arms 1 and 2 on its ±x faces by its +y edge; its top 3 cm above the TCPs;
* the table: the half-space z ≥ 0.279 m for the box (it rests 1 mm above it; the arms' bases stand below the
  table top, so it is not an obstacle for the arms);
* the shelf lip: five spheres (radius 4 cm) along x (|x| ≤ 8 cm, between the hands of arms 1 and 2) at
  z = 0.55 m, reaching 5 cm in over the box's +y
  edge — a straight lift hits it, so the box has to move towards −y before it rises;
* the goal region (:class:`~coop_ga.plan.regions.Region` of the cooperative circle): its centre 0.2 m higher
  (± 1 cm) and 8–14 cm towards −y (x ± 2 cm), its normal within 10° of vertical;
* the path: the rigid grasp (the three TCP distances, :class:`~coop_ga.plan.regions.RigidGrasp`) as the
  equality constraint, the box upright within 10° as the path region, the arms' capsules clear of the shelf
  and of each other (:class:`~coop_ga.collision.CollisionModel`), the box clear of the shelf and the table.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..collision import CollisionModel, Plane, Sphere
from ..errors import InvalidInputError
from .carried import CarriedBox
from .ompl import PlannerOptions, PlanningProblem
from .projection import project
from .regions import EndPoints, Region, RigidGrasp

__all__ = ["BOX_LIFT_OPTIONS", "BoxLift", "EndPointTargets", "box_lift_problem"]

SYSTEM = "three_franka"
GRASP_RADIUS, GRASP_HEIGHT = 0.3, 0.45  # [m] ρ and the TCPs' height
GRASP_ANGLES = (-0.5 * math.pi, math.pi / 6, 5 * math.pi / 6)
BOX_TOP_ABOVE_TCP, BOX_HEIGHT = 0.03, 0.20  # [m]
LIFT = 0.20  # [m]
TILT = math.radians(10.0)  # [rad] the box's largest tilt (path and goal)
SHELF_HEIGHT, SHELF_RADIUS, SHELF_OVERHANG = 0.55, 0.04, 0.05  # [m]
GOAL_SHIFT = (-0.14, -0.08)  # [m] the goal centre's y range relative to the start
GOAL_TOL_XY, GOAL_TOL_Z = 0.02, 0.01  # [m]

#: the planner settings of the scene: RRTConnect on the projected space, extensions of at most 0.5 rad, the
#: sampling box the start and goal configurations widened by 0.4 rad per joint (the lift moves each joint by
#: less than 0.5 rad; over the whole joint limits, 0 of 6 seeds planned within 10 s), a 10 s budget
BOX_LIFT_OPTIONS = PlannerOptions(range=0.5, window=0.4, time_limit=10.0)


class EndPointTargets:
    """Residual ``P(q) − P*`` (3n,) of the end points at given positions, with their Pinocchio Jacobians."""

    def __init__(self, system: Any, frames: Any, targets: Any) -> None:
        self.end = EndPoints(system, frames)
        self.targets = np.asarray(targets, float).reshape(-1, 3)
        self.nq, self.dim = int(system.model.nq), self.targets.size

    def evaluate(self, q: Any) -> tuple[np.ndarray, np.ndarray]:
        """``(r (3n,), J (3n, nq))``."""
        P, Js = self.end(np.asarray(q, float), True)
        return (P - self.targets).reshape(-1), np.vstack(Js)


@dataclass
class BoxLift:
    """The scene's pieces: the problem, the task, the box, the shelf spheres, the table plane, the grasp."""

    problem: PlanningProblem
    task: Any
    box: CarriedBox
    shelf: tuple[Sphere, ...]
    table: Plane
    grasp_points: np.ndarray
    box_centre: np.ndarray
    box_half: np.ndarray


def _grasp(system: Any, task: Any) -> tuple[np.ndarray, np.ndarray]:
    P = np.array([[GRASP_RADIUS * math.cos(a), GRASP_RADIUS * math.sin(a), GRASP_HEIGHT] for a in GRASP_ANGLES])
    p = project(EndPointTargets(system, task.end_frames, P), system, system.q0, tol=1e-10)
    if not p.converged:
        raise InvalidInputError(f"the box-lift grasp is out of reach: {p.message}")
    return p.q, P


def box_lift_problem(shelf: bool = True) -> BoxLift:
    """The box-lift scene (module docstring); ``shelf=False`` leaves the shelf lip out."""
    from .. import systems
    from ..cooperative import cooperative_task

    system = systems.load(SYSTEM)
    task = cooperative_task(system, "circle")
    q_grasp, P = _grasp(system, task)
    half = np.array([GRASP_RADIUS * math.cos(math.pi / 6), 0.8 * GRASP_RADIUS, 0.5 * BOX_HEIGHT])
    centre = np.array([0.0, -0.2 * GRASP_RADIUS, GRASP_HEIGHT + BOX_TOP_ABOVE_TCP - 0.5 * BOX_HEIGHT])
    table = Plane(np.array([0.0, 0.0, 1.0]), float(centre[2] - half[2] - 0.001), name="table")
    y_lip = centre[1] + half[1] - SHELF_OVERHANG + SHELF_RADIUS
    spheres = tuple(
        Sphere(np.array([x, y_lip, SHELF_HEIGHT]), SHELF_RADIUS, name=f"shelf {k}")
        for k, x in enumerate(np.linspace(-0.08, 0.08, 5))
    ) if shelf else ()  # fmt: skip
    box = CarriedBox(half, np.eye(3), centre, P, (*spheres, table))
    c0 = task.evaluate(q_grasp).log[4:7]
    lo = c0 + np.array([-GOAL_TOL_XY, GOAL_SHIFT[0], LIFT - GOAL_TOL_Z])
    hi = c0 + np.array([GOAL_TOL_XY, GOAL_SHIFT[1], LIFT + GOAL_TOL_Z])
    goal = Region(task, lo, hi, cone_axis=[0.0, 0.0, 1.0], cone_angle=TILT)
    upright = Region(task, cone_axis=[0.0, 0.0, 1.0], cone_angle=TILT)
    problem = PlanningProblem(
        system=system,
        q_start=q_grasp,
        path_constraint=RigidGrasp(task, q_grasp),
        goal=goal,
        collision=CollisionModel(system, spheres),
        carried=box,
        path_region=upright,
    )
    return BoxLift(problem, task, box, spheres, table, P, centre, half)
