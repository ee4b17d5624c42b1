"""Axes helpers: equal scales on 3-D axes, metre labels."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["Drawn", "axes_box", "label_axes_3d", "set_equal_3d"]


@dataclass
class Drawn:
    """What a ``draw_*`` function added: its matplotlib ``artists`` and the world ``points``
    (N, 3) [m] it drew (for :func:`set_equal_3d`)."""

    artists: list[Any] = field(default_factory=list)
    points: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))


def axes_box(ax: Any) -> tuple[np.ndarray, np.ndarray]:
    """The current data box of a 3-D axes: (lower (3,), upper (3,)) corners [m]."""
    lims = np.array([ax.get_xlim3d(), ax.get_ylim3d(), ax.get_zlim3d()], dtype=float)
    return lims.min(axis=1), lims.max(axis=1)


def set_equal_3d(ax: Any, points: Any, pad: float = 0.05, *, floor: bool = False) -> tuple[np.ndarray, float]:
    """Give a 3-D axes equal scales on x, y, z: a cube that contains ``points``.

    Parameters
    ----------
    ax: a matplotlib ``Axes3D``.
    points: (N, 3) world points [m] (or several arrays, stacked) that must be visible.
    pad: margin [m] added on every side of the bounding box before it is made a cube.
    floor: put the lowest point (minus ``pad``) at the bottom of the cube instead of
        centring the box vertically (for robots standing on z = 0).

    Returns the cube's centre (3,) [m] and half side [m].  The box aspect is set to 1:1:1.
    """
    P = np.asarray(points, dtype=float).reshape(-1, 3)
    P = P[np.all(np.isfinite(P), axis=1)]
    if len(P) == 0:
        raise ValueError("set_equal_3d needs at least one finite point")
    lo, hi = P.min(axis=0) - pad, P.max(axis=0) + pad
    c = 0.5 * (lo + hi)
    h = max(0.5 * float(np.max(hi - lo)), 1e-3)
    if floor:
        c[2] = lo[2] + h
    ax.set_xlim(c[0] - h, c[0] + h)
    ax.set_ylim(c[1] - h, c[1] + h)
    ax.set_zlim(c[2] - h, c[2] + h)
    ax.set_box_aspect((1, 1, 1))
    return c, h


def label_axes_3d(ax: Any, unit: str = "m") -> None:
    """Label the axes ``x [m]``, ``y [m]``, ``z [m]`` (world frame)."""
    ax.set_xlabel(f"x [{unit}]")
    ax.set_ylabel(f"y [{unit}]")
    ax.set_zlabel(f"z [{unit}]")
