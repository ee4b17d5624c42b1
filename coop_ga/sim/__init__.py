"""Physics in the loop on MuJoCo (the layer above legged, below viewer and sweep).

* :mod:`~coop_ga.sim.scene` — :func:`build_scene`: a MuJoCo model built in code (``MjSpec``) from a
  system's Pinocchio model, with collision capsules, visual meshes, motors, a floor and objects;
* :mod:`~coop_ga.sim.objects` — :class:`Box`, :class:`Ball`, :class:`Cylinder`;
* :mod:`~coop_ga.sim.simulation` — :class:`Simulation`: a torque controller in the loop, contact forces
  per end point, objects' poses, disturbances, logs;
* :mod:`~coop_ga.sim.replay` — :func:`replay`: a saved run re-simulated with MuJoCo alone;
* :mod:`~coop_ga.sim.render` — offscreen MuJoCo pictures (EGL/OSMesa probed), overlays of the cooperative
  primitive and of forces, PNG/GIF/MP4;
* :mod:`~coop_ga.sim.mjcf` — full-precision MJCF text that reloads into the same model;
* :mod:`~coop_ga.sim.tools` — :func:`with_tool`, :func:`add_pads`: a stick with a rubber sphere pad on
  every end frame;
* :mod:`~coop_ga.sim.hold` — :class:`HoldController`: the similarity impedance law holding an object
  with a commanded e0∞ squeeze (admittance loop), an estimated weight feed-forward, a :class:`CarryPlan`;
* :mod:`~coop_ga.sim.carry` — three iiwa arms carry a box: the scenario, a run, its metrics;
* :mod:`~coop_ga.sim.ball` — :class:`SphereHoldController`, :class:`BallPlan`: the Allegro hand holds a
  ball through its cooperative sphere.
* :mod:`~coop_ga.sim.partner` — the G1 and a human palm on a recorded trajectory (a mocap target) carry a
  free bar held by the point pair's squeeze (:class:`~coop_ga.control.tasks.PartnerPairTask` in the loop).
"""

from . import render
from .ball import BallPlan, SphereHoldController
from .hold import PHASES, CarryPlan, HoldController, HoldGains, PhasedPlan, PlanPoint, circle_target
from .objects import Ball, Box, Cylinder, SceneObject
from .replay import replay
from .scene import Scene, build_scene
from .simulation import Disturbance, Sensors, Simulation, SimulationLog
from .tools import add_pads, with_tool

__all__ = [
    "PHASES",
    "Ball",
    "BallPlan",
    "Box",
    "CarryPlan",
    "Cylinder",
    "Disturbance",
    "HoldController",
    "HoldGains",
    "PhasedPlan",
    "PlanPoint",
    "Scene",
    "SceneObject",
    "Sensors",
    "Simulation",
    "SimulationLog",
    "SphereHoldController",
    "add_pads",
    "build_scene",
    "circle_target",
    "render",
    "replay",
    "with_tool",
]
