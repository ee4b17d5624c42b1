"""Layer 10: physics in the loop on MuJoCo.

* :mod:`~coop_ga.sim.scene` — :func:`build_scene`: a MuJoCo model built in code (``MjSpec``) from a
  system's Pinocchio model, with collision capsules, visual meshes, motors, a floor and objects;
* :mod:`~coop_ga.sim.objects` — :class:`Box`, :class:`Ball`, :class:`Cylinder`;
* :mod:`~coop_ga.sim.simulation` — :class:`Simulation`: a torque controller in the loop, contact forces
  per end point, objects' poses, disturbances, logs;
* :mod:`~coop_ga.sim.replay` — :func:`replay`: a saved run re-simulated with MuJoCo alone;
* :mod:`~coop_ga.sim.render` — offscreen MuJoCo pictures (EGL/OSMesa probed), overlays of the cooperative
  primitive and of forces, PNG/GIF/MP4;
* :mod:`~coop_ga.sim.mjcf` — full-precision MJCF text that reloads into the same model.
"""

from . import render
from .objects import Ball, Box, Cylinder, SceneObject
from .replay import replay
from .scene import Scene, build_scene
from .simulation import Disturbance, Sensors, Simulation, SimulationLog

__all__ = [
    "Ball",
    "Box",
    "Cylinder",
    "Disturbance",
    "Scene",
    "SceneObject",
    "Sensors",
    "Simulation",
    "SimulationLog",
    "build_scene",
    "render",
    "replay",
]
