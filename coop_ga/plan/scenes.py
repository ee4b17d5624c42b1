"""Two more planning scenes over cooperative regions: a hand moving the sphere of its four fingertips, and two
arms carrying the line of a rod.

* :func:`hand_sphere_problem` — ``allegro`` (16 joints): the sphere through the four fingertips (a held ball)
  keeps its radius along the path (:class:`~coop_ga.plan.regions.RigidGrasp` ``mode="scale"``: one row,
  β = log r, through J^G); goal region: its centre 8 mm higher (± 2 mm); validity: the joint limits and the
  hand's capsules clear of each other.
* :func:`arms_line_problem` — ``g1_arms`` (two 7-joint arms of the G1 humanoid's torso): the line through the
  two wrists (a rod held in both hands) keeps the hands' distance (:class:`~coop_ga.plan.regions.RigidGrasp`:
  one distance); goal region in a frame at the hands' midpoint: the line's point closest to that frame's origin
  8 cm higher (± 2 cm in every direction), its direction within 10° of the start's; validity: the joint limits
  and the arms' capsules clear of each other and of the torso.

Both are :class:`~coop_ga.plan.ompl.PlanningProblem` s for :func:`~coop_ga.plan.ompl.plan` with
:data:`SCENE_OPTIONS`.
"""

from __future__ import annotations

import math

import numpy as np

from ..collision import CollisionModel
from .ompl import PlannerOptions, PlanningProblem
from .regions import Region, RigidGrasp, readout

__all__ = ["SCENE_OPTIONS", "arms_line_problem", "hand_sphere_problem"]

#: the planner settings of these scenes (as the box lift's: extensions ≤ 0.5 rad, a 0.4 rad sampling window)
SCENE_OPTIONS = PlannerOptions(range=0.5, window=0.4, time_limit=10.0)


def hand_sphere_problem() -> PlanningProblem:
    """The Allegro hand moves the sphere of its fingertips 8 mm up, its radius held (module docstring)."""
    from .. import systems
    from ..cooperative import cooperative_task

    s = systems.load("allegro")
    task = cooperative_task(s, "sphere")
    q0 = np.asarray(s.q0, float)
    c = readout(task, q0).centre + np.array([0.0, 0.0, 0.008])
    goal = Region(task, c - 0.002, c + 0.002)
    return PlanningProblem(s, q0, RigidGrasp(task, q0, mode="scale"), goal, collision=CollisionModel(s))


def arms_line_problem() -> PlanningProblem:
    """Two G1 arms lift the line through their wrists 8 cm, the hands' distance held (module docstring)."""
    from .. import systems
    from ..cooperative import cooperative_task

    s = systems.load("g1_arms")
    task = cooperative_task(s, "line")
    q0 = np.asarray(s.q0, float)
    H = np.eye(4)
    H[:3, 3] = task.points(q0).mean(axis=0)
    axis = readout(task, q0).axis
    goal = Region(
        task, [-0.02, -0.02, 0.06], [0.02, 0.02, 0.10], cone_axis=axis, cone_angle=math.radians(10.0), frame=H
    )
    return PlanningProblem(s, q0, RigidGrasp(task, q0), goal, collision=CollisionModel(s))
