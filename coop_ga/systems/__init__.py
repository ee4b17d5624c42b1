"""Registered multi-chain systems: ``coop_ga.systems.load(name)``, ``from_urdf(...)``.

Run ``python -m coop_ga.systems`` to list them with their DOF and end points.
"""

from __future__ import annotations

from ..kinematics import library as _library  # noqa: F401  (registers the systems)
from ..kinematics.systems import (
    ROBOTS_DIR,
    System,
    append_robots,
    from_model,
    from_urdf,
    load,
    names,
    prefixed,
    register,
)

__all__ = ["System", "load", "names", "register", "from_urdf", "from_model", "append_robots", "prefixed", "ROBOTS_DIR"]
