"""Layer 8: legged robots — the hexapod's legs, terrain and contact, the stance feet as a cooperative
primitive, body posture control through it, gaits and walking.

* :mod:`~coop_ga.legged.legs` — per-leg motor FK, closed-form and DLS IK, vectorised over legs and batches;
* :mod:`~coop_ga.legged.terrain` — terrains as sets of CGA planes, contact by point–plane incidence;
* :mod:`~coop_ga.legged.stance` — the stance primitive (sphere / plane / circle, LSQ fits for more feet);
* :mod:`~coop_ga.legged.body`, :mod:`~coop_ga.legged.posture` — the floating body, posture control;
* :mod:`~coop_ga.legged.gait`, :mod:`~coop_ga.legged.walk` — phase-table gaits and walking.
"""

from .body import BodyState, floating_hexapod
from .dynamics import RolloutOptions, RolloutResult, contact_rollout
from .gait import GAITS, GaitTable, phase_table, swing_arc
from .legs import LEGS, DLSResult, LegModel, hexapod_legs
from .posture import PostureOptions, PostureResult, PostureStep, posture_step, posture_to
from .stance import STANCE_KINDS, StancePrimitive, stance_primitive, stance_task
from .terrain import TERRAIN_KINDS, Terrain
from .walk import WalkOptions, WalkResult, static_stability_margin, static_torques, walk

__all__ = [
    "GAITS",
    "LEGS",
    "STANCE_KINDS",
    "TERRAIN_KINDS",
    "BodyState",
    "DLSResult",
    "GaitTable",
    "LegModel",
    "PostureOptions",
    "PostureResult",
    "PostureStep",
    "RolloutOptions",
    "RolloutResult",
    "StancePrimitive",
    "Terrain",
    "WalkOptions",
    "WalkResult",
    "contact_rollout",
    "floating_hexapod",
    "hexapod_legs",
    "phase_table",
    "posture_step",
    "posture_to",
    "stance_primitive",
    "stance_task",
    "static_stability_margin",
    "static_torques",
    "swing_arc",
    "walk",
]
