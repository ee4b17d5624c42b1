"""Coordinate frames drawn as axis triads (x red, y green, z blue)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..algebra import Multivector
from ..geometry import VersorGroup, apply, point, to_euclidean
from .axes import Drawn
from .style import PALETTE

__all__ = ["draw_frame", "frame_axes"]


def frame_axes(T: Any) -> tuple[np.ndarray, np.ndarray]:
    """Origin (3,) [m] and axes (3, 3) (column i = image of the unit vector e_i) of a frame.

    ``T`` may be a motor or similarity versor (:class:`coop_ga.Multivector` or a
    :class:`coop_ga.VersorGroup` element such as :class:`coop_ga.Motor` /
    :class:`coop_ga.Similarity`: the axes are the images of e1, e2, e3 under the sandwich,
    so a similarity's axes carry its scale), a ``pinocchio.SE3`` (``.rotation``,
    ``.translation``), a (4, 4) homogeneous matrix, or a pair ``(R (3, 3), p (3,))``.
    """
    if isinstance(T, VersorGroup):
        T = T.versor
    if isinstance(T, Multivector):
        o = np.asarray(to_euclidean(apply(T, point(np.zeros(3)))), float)
        A = np.column_stack([np.asarray(to_euclidean(apply(T, point(e))), float) - o for e in np.eye(3)])
        return o, A
    if hasattr(T, "rotation") and hasattr(T, "translation"):
        return np.array(T.translation, float).reshape(3), np.array(T.rotation, float).reshape(3, 3)
    if isinstance(T, tuple) and len(T) == 2:
        return np.asarray(T[1], float).reshape(3), np.asarray(T[0], float).reshape(3, 3)
    M = np.asarray(T, dtype=float)
    if M.shape == (4, 4):
        return M[:3, 3].copy(), M[:3, :3].copy()
    raise ValueError(
        f"cannot read a frame from {type(T).__name__} (shape {getattr(M, 'shape', None)}); pass a "
        "motor/similarity, a pinocchio.SE3, a 4×4 matrix or (R, p)"
    )


def draw_frame(
    ax: Any,
    T: Any,
    length: float = 0.1,
    *,
    colors: tuple[Any, Any, Any] | None = None,
    lw: float = 1.5,
    label: str | None = None,
) -> Drawn:
    """Draw the frame ``T`` (see :func:`frame_axes`) as three arrows of ``length`` [m] × the
    length of each axis (1 for rigid frames, the scale for a similarity), x/y/z in ``colors``.

    ``label`` is written at the origin.  Returns the artists and the points (origin, 3 tips).
    """
    o, A = frame_axes(T)
    cols = PALETTE.frame_axes if colors is None else colors
    out = Drawn()
    tips = [o]
    for i in range(3):
        v = float(length) * A[:, i]
        out.artists.append(ax.quiver(*o, *v, color=cols[i], lw=lw, arrow_length_ratio=0.2))
        tips.append(o + v)
    if label:
        out.artists.append(ax.text(*o, f" {label}", fontsize=7))
    out.points = np.array(tips)
    return out
