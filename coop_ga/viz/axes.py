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


def set_equal_3d(
    ax: Any, points: Any, pad: float = 0.05, *, floor: bool = False, tight: bool = False
) -> tuple[np.ndarray, float]:
    """Give a 3-D axes equal scales on x, y, z around ``points``.

    Args:
        ax: a matplotlib ``Axes3D``.
        points: (N, 3) world points [m] (or several arrays, stacked) that must be visible.
        pad: margin [m] added on every side of the bounding box.
        floor: put the lowest point (minus ``pad``) at the bottom of the box instead of
            centring the box vertically (for robots standing on z = 0).
        tight: the box is the padded bounding box itself (each axis its own range, the box
            aspect proportional to them, so the scale is still equal); default: a cube.

    Returns the box centre (3,) [m] and its largest half side [m].
    """
    P = np.asarray(points, dtype=float).reshape(-1, 3)
    P = P[np.all(np.isfinite(P), axis=1)]
    if len(P) == 0:
        raise ValueError("set_equal_3d needs at least one finite point")
    lo, hi = P.min(axis=0) - pad, P.max(axis=0) + pad
    c = 0.5 * (lo + hi)
    half = np.maximum(0.5 * (hi - lo), 1e-3)
    h = float(half.max())
    if not tight:
        half = np.full(3, h)
    if floor:
        c[2] = lo[2] + half[2]
    ax.set_xlim(c[0] - half[0], c[0] + half[0])
    ax.set_ylim(c[1] - half[1], c[1] + half[1])
    ax.set_zlim(c[2] - half[2], c[2] + half[2])
    ax.set_box_aspect(tuple(half / h))
    return c, h


def label_axes_3d(ax: Any, unit: str = "m") -> None:
    """Label the axes ``x [m]``, ``y [m]``, ``z [m]`` (world frame)."""
    ax.set_xlabel(f"x [{unit}]")
    ax.set_ylabel(f"y [{unit}]")
    ax.set_zlabel(f"z [{unit}]")
