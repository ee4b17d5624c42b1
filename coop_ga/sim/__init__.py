"""Layer 10: physics in the loop on MuJoCo.

* :mod:`~coop_ga.sim.scene` — :func:`build_scene`: a MuJoCo model built in code (``MjSpec``) from a
  system's Pinocchio model, with collision capsules, visual meshes, motors, a floor and objects;
* :mod:`~coop_ga.sim.objects` — :class:`Box`, :class:`Ball`, :class:`Cylinder`;
* :mod:`~coop_ga.sim.mjcf` — full-precision MJCF text that reloads into the same model.
"""

from .objects import Ball, Box, Cylinder, SceneObject
from .scene import Scene, build_scene

__all__ = ["Ball", "Box", "Cylinder", "Scene", "SceneObject", "build_scene"]
