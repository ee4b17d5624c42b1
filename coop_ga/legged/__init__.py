"""Legged robots — the hexapod's legs, terrain and contact, the stance feet as a cooperative
primitive, body posture control through it, gaits and walking.

* :mod:`~coop_ga.legged.legs` — per-leg motor FK, closed-form and DLS IK, vectorised over legs and batches;
* :mod:`~coop_ga.legged.terrain` — terrains as sets of CGA planes, contact by point–plane incidence, the terrain
  solid's distance and the clearance of capsules;
* :mod:`~coop_ga.legged.contact` — the foot ball and the leg capsules against the terrain (planner ↔ physics);
* :mod:`~coop_ga.legged.stance` — the stance primitives (sphere / plane / circle / point pair, LSQ fits for more
  feet) and what each carries with the feet fixed (seed 003 Table 1);
* :mod:`~coop_ga.legged.body`, :mod:`~coop_ga.legged.posture` — the floating body, posture control through one or
  several stance primitives, honest about what they cannot carry;
* :mod:`~coop_ga.legged.gait`, :mod:`~coop_ga.legged.walk` — phase-table gaits and walking.
"""

from .body import BodyState, free_flyer_hexapod
from .contact import leg_capsules, leg_clearance
from .dynamics import RolloutOptions, RolloutResult, contact_rollout
from .gait import GAITS, GaitTable, phase_table, swing_arc
from .legs import LEGS, DLSResult, LegModel, hexapod_legs
from .posture import (
    BodyMotion,
    PostureOptions,
    PostureResult,
    PostureStep,
    PrimitiveTask,
    posture_step,
    posture_to,
    stance_primitive_tasks,
)
from .stance import CARRIED, STANCE_KINDS, StancePrimitive, stance_primitive, stance_task
from .terrain import TERRAIN_KINDS, Terrain
from .walk import WalkOptions, WalkResult, check_command, static_stability_margin, static_torques, walk

__all__ = [
    "CARRIED",
    "GAITS",
    "LEGS",
    "STANCE_KINDS",
    "TERRAIN_KINDS",
    "BodyMotion",
    "BodyState",
    "DLSResult",
    "GaitTable",
    "LegModel",
    "PostureOptions",
    "PostureResult",
    "PostureStep",
    "PrimitiveTask",
    "RolloutOptions",
    "RolloutResult",
    "StancePrimitive",
    "Terrain",
    "WalkOptions",
    "WalkResult",
    "check_command",
    "contact_rollout",
    "free_flyer_hexapod",
    "hexapod_legs",
    "leg_capsules",
    "leg_clearance",
    "phase_table",
    "posture_step",
    "posture_to",
    "stance_primitive",
    "stance_primitive_tasks",
    "stance_task",
    "static_stability_margin",
    "static_torques",
    "swing_arc",
    "walk",
]
