"""Scene objects of :func:`coop_ga.sim.build_scene`: :class:`Box`, :class:`Ball`, :class:`Cylinder`.

An object is a rigid body with one collision geometry (its shape, which is also what is drawn).
By default it is **free**: a MuJoCo body with a ``freejoint`` (7 qpos: position [m] then unit
quaternion (w, x, y, z); 6 qvel: linear velocity of the body origin in the world frame [m/s], then
angular velocity in the body frame [rad/s], MuJoCo's convention).  It is never welded or
equality-constrained to a robot: it moves only by gravity, contacts and the disturbances a
:class:`~coop_ga.sim.Simulation` applies.  With ``static=True`` it is part of the world instead (a
table, a step): no joint, no mass, it only collides.  With ``mocap=True`` it is a MuJoCo **mocap
body**: no joint and no mass either, but its pose is ``data.mocap_pos`` / ``data.mocap_quat``, set
from outside each step (a measured human hand, :class:`~coop_ga.sim.Simulation`'s ``mocap=``): it
pushes what it touches and nothing pushes it back.

Common fields (keywords):

* ``name`` — the MuJoCo body name (the geom is ``name + "_geom"``); unique in the scene;
* ``pos`` (3,) [m], ``quat`` (4,) unit quaternion (w, x, y, z) — the initial world pose of the body
  frame, at the centre of the shape (a cylinder's axis is its z axis);
* ``mass`` [kg] (> 0; ignored for a static object);
* ``inertia`` — ``None`` (default): the uniform solid's inertia about its centre (below); a (3,)
  principal diagonal or a (3, 3) symmetric tensor [kg m²] about the centre, in the body frame;
* ``friction`` — MuJoCo's (sliding, torsional, rolling) coefficients, or one number (sliding;
  torsional 0.005 and rolling 0.0001, MuJoCo's defaults);
* ``condim`` — contact dimensionality (1 frictionless, 3 sliding friction (default), 4 adds
  torsional, 6 adds rolling friction);
* ``rgba`` (4,) colour.

Uniform solids (about the centre): box of edges (a, b, c): m/12 (b² + c², a² + c², a² + b²);
ball of radius r: 2/5 m r²; cylinder of radius r and length h (axis z): m (3r² + h²)/12 about x
and y, m r²/2 about z.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from .. import validation
from ..errors import InvalidInputError

__all__ = ["Ball", "Box", "Cylinder", "SceneObject", "friction"]

#: MuJoCo's default torsional and rolling friction coefficients (used when one number is given).
_DEFAULT_FRICTION = (1.0, 0.005, 0.0001)


def friction(x: Any, what: str = "friction") -> np.ndarray:
    """MuJoCo's (sliding, torsional, rolling) friction (3,) from one number (sliding; MuJoCo's default
    torsional and rolling coefficients) or three numbers ≥ 0."""
    fr = validation.array(x, what)
    if fr.ndim == 0:
        fr = np.array([float(fr), *_DEFAULT_FRICTION[1:]])
    if fr.shape != (3,) or np.any(fr < 0.0):
        raise InvalidInputError(f"{what} must be one number or (sliding, torsional, rolling) ≥ 0, got {x!r}")
    return fr


def _quat(x: Any, what: str) -> np.ndarray:
    q = validation.vector(x, 4, what)
    n = float(np.linalg.norm(q))
    if abs(n - 1.0) > 1e-6:
        raise InvalidInputError(f"{what} must be a unit quaternion (w, x, y, z), got norm {n:.6g}")
    return q / n


def _inertia(x: Any, what: str) -> np.ndarray:
    a = validation.array(x, what)
    if a.shape == (3,):
        a = np.diag(a)
    if a.shape != (3, 3):
        raise InvalidInputError(f"{what} must be a (3,) diagonal or a (3, 3) tensor [kg m²], got shape {a.shape}")
    if not np.allclose(a, a.T, rtol=0.0, atol=1e-12 * max(1.0, float(np.abs(a).max()))):
        raise InvalidInputError(f"{what} must be symmetric")
    a = 0.5 * (a + a.T)
    ev = np.linalg.eigvalsh(a)
    if ev[0] <= 0.0 or ev[0] + ev[1] < ev[2] * (1.0 - 1e-12):
        raise InvalidInputError(
            f"{what} is not a rigid body's inertia (principal moments {ev.tolist()} must be > 0 and satisfy "
            "A + B ≥ C); give the tensor about the object's centre in its body frame"
        )
    return a


@dataclass(frozen=True, eq=False, kw_only=True)
class SceneObject:
    """Common fields of a scene object (module docstring); use :class:`Box`, :class:`Ball` or :class:`Cylinder`."""

    name: str
    pos: Any = field(default=(0.0, 0.0, 0.0))
    quat: Any = field(default=(1.0, 0.0, 0.0, 0.0))
    mass: float = 1.0
    inertia: Any = None
    friction: Any = 1.0
    condim: int = 3
    rgba: Any = (0.85, 0.55, 0.2, 1.0)
    static: bool = False
    mocap: bool = False

    #: MuJoCo geom type name (``mjtGeom`` member without the prefix)
    geom_type: ClassVar[str] = ""

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise InvalidInputError(f"{type(self).__name__}.name must be a non-empty string, got {self.name!r}")
        object.__setattr__(self, "pos", validation.vector(self.pos, 3, f"{self.name}.pos"))
        object.__setattr__(self, "quat", _quat(self.quat, f"{self.name}.quat"))
        if not isinstance(self.static, bool):
            raise InvalidInputError(f"{self.name}.static must be True or False, got {self.static!r}")
        if not isinstance(self.mocap, bool) or (self.mocap and self.static):
            raise InvalidInputError(f"{self.name}.mocap must be True or False, and not both static and mocap")
        object.__setattr__(self, "mass", validation.positive(self.mass, f"{self.name}.mass"))
        object.__setattr__(self, "friction", friction(self.friction, f"{self.name}.friction"))
        if self.condim not in (1, 3, 4, 6):
            raise InvalidInputError(f"{self.name}.condim must be 1, 3, 4 or 6, got {self.condim!r}")
        rgba = validation.vector(self.rgba, 4, f"{self.name}.rgba")
        if np.any((rgba < 0.0) | (rgba > 1.0)):
            raise InvalidInputError(f"{self.name}.rgba must be 4 numbers in [0, 1], got {self.rgba!r}")
        object.__setattr__(self, "rgba", rgba)
        self._check_size()
        I = self.solid_inertia() if self.inertia is None else _inertia(self.inertia, f"{self.name}.inertia")
        object.__setattr__(self, "inertia", I)

    @property
    def free(self) -> bool:
        """Whether the object is a free body (a ``freejoint``; neither static nor mocap)."""
        return not (self.static or self.mocap)

    def _check_size(self) -> None:  # pragma: no cover - every subclass overrides it
        raise NotImplementedError

    def solid_inertia(self) -> np.ndarray:
        """(3, 3) inertia [kg m²] of the uniform solid of this shape and mass about its centre (body frame)."""
        raise NotImplementedError  # pragma: no cover

    def geom_size(self) -> np.ndarray:
        """MuJoCo's ``geom size`` (3,) of the shape (half sizes; unused entries 0)."""
        raise NotImplementedError  # pragma: no cover


@dataclass(frozen=True, eq=False, kw_only=True)
class Box(SceneObject):
    """A box of edge lengths ``size`` = (a, b, c) [m] along its body x, y, z axes (module docstring)."""

    size: Any = (0.1, 0.1, 0.1)
    geom_type: ClassVar[str] = "BOX"

    def _check_size(self) -> None:
        s = validation.vector(self.size, 3, f"{self.name}.size")
        if np.any(s <= 0.0):
            raise InvalidInputError(f"{self.name}.size must be 3 edge lengths > 0 [m], got {self.size!r}")
        object.__setattr__(self, "size", s)

    def solid_inertia(self) -> np.ndarray:
        a, b, c = self.size
        return self.mass / 12.0 * np.diag([b * b + c * c, a * a + c * c, a * a + b * b])

    def geom_size(self) -> np.ndarray:
        return 0.5 * np.asarray(self.size, float)


@dataclass(frozen=True, eq=False, kw_only=True)
class Ball(SceneObject):
    """A ball of ``radius`` [m] (module docstring)."""

    radius: float = 0.05
    geom_type: ClassVar[str] = "SPHERE"

    def _check_size(self) -> None:
        object.__setattr__(self, "radius", validation.positive(self.radius, f"{self.name}.radius"))

    def solid_inertia(self) -> np.ndarray:
        return 0.4 * self.mass * self.radius**2 * np.eye(3)

    def geom_size(self) -> np.ndarray:
        return np.array([self.radius, 0.0, 0.0])


@dataclass(frozen=True, eq=False, kw_only=True)
class Cylinder(SceneObject):
    """A solid cylinder of ``radius`` and ``length`` [m] along its body z axis (module docstring)."""

    radius: float = 0.05
    length: float = 0.1
    geom_type: ClassVar[str] = "CYLINDER"

    def _check_size(self) -> None:
        object.__setattr__(self, "radius", validation.positive(self.radius, f"{self.name}.radius"))
        object.__setattr__(self, "length", validation.positive(self.length, f"{self.name}.length"))

    def solid_inertia(self) -> np.ndarray:
        r, h, m = self.radius, self.length, self.mass
        ixx = m * (3.0 * r * r + h * h) / 12.0
        return np.diag([ixx, ixx, 0.5 * m * r * r])

    def geom_size(self) -> np.ndarray:
        return np.array([self.radius, 0.5 * self.length, 0.0])
