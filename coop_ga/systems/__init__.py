"""Multi-chain robot systems — ``coop_ga.systems.load(name)``, ``from_urdf(...)``.

* :mod:`~coop_ga.systems.system`: :class:`System` (a Pinocchio model, its end frames, q0 and
  limits), :func:`from_urdf`, :func:`from_model`, :func:`append_robots`, :func:`prefixed`,
  :func:`unique_frames`;
* :mod:`~coop_ga.systems.groups`: named control groups (``groups=``/``active=`` instead of ``locked_joints``),
  :func:`locked_joints`;
* :mod:`~coop_ga.systems.points`: :class:`EndPoint` (a point anywhere on a link as an end frame, §5.4),
  :func:`add_end_points`;
* :mod:`~coop_ga.systems.joints`: :func:`continuous_as_revolute` (continuous joints as angles, nq = nv);
* :mod:`~coop_ga.systems.mjcf`: :func:`from_mjcf`, :func:`model_from_mjcf` (MJCF files, compiled by MuJoCo);
* :mod:`~coop_ga.systems.limits`: :class:`JointLimits` (position, velocity, acceleration, effort);
* :mod:`~coop_ga.systems.registry`: :func:`register`, :func:`names`, :func:`load`;
* :mod:`~coop_ga.systems.library`: the paper's systems (registered on import);
* :mod:`~coop_ga.systems.synthetic`: :func:`cartesian_points` (free end points, ∂p/∂q = I);
* ``robots/``: the URDFs coop_ga ships (package data, :data:`ROBOTS_DIR`).

Run ``python -m coop_ga.systems`` to list the registered systems with their DOF and end points.
"""

from __future__ import annotations

from . import library as _library  # noqa: F401  (registers the paper's systems)
from .groups import group_joints, locked_joints
from .joints import continuous_as_revolute
from .limits import DEFAULT_VELOCITY_LIMIT, JointLimits
from .mjcf import from_mjcf, model_from_mjcf
from .points import EndPoint, add_end_points
from .registry import load, names, register, register_free_flyer
from .synthetic import CARTESIAN_BASES, cartesian_points
from .system import ROBOTS_DIR, System, VisualSource, append_robots, from_model, from_urdf, prefixed, unique_frames

__all__ = [
    "CARTESIAN_BASES",
    "DEFAULT_VELOCITY_LIMIT",
    "ROBOTS_DIR",
    "EndPoint",
    "JointLimits",
    "System",
    "VisualSource",
    "add_end_points",
    "append_robots",
    "cartesian_points",
    "continuous_as_revolute",
    "from_mjcf",
    "from_model",
    "from_urdf",
    "group_joints",
    "load",
    "locked_joints",
    "model_from_mjcf",
    "names",
    "prefixed",
    "register",
    "register_free_flyer",
    "unique_frames",
]
