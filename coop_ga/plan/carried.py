"""A box carried by the end points: its pose from the grasp and its clearance from obstacles.

While the grasp is rigid (:class:`~coop_ga.plan.regions.RigidGrasp`) the end points move as one rigid body,
so the carried box's pose follows from them: :class:`CarriedBox` stores the box's pose in the frame of the
first three end points at the grasp (origin p0, x along p1 − p0, z along (p1 − p0) × (p2 − p0)) and
places it again from the points at any q.  (The primitive's own rotation would not do: its roll about the
axis is the chart's choice, not the grasp's.)

Clearances are closed form (signed, [m], negative inside): from an obstacle sphere of centre s and radius ρ,
with p = Rᵀ(s − b) the centre in the box frame and h the half extents,
``|max(|p| − h, 0)| − ρ`` outside the box and ``−min(h − |p|) − ρ`` inside (the exact signed distance of a
box); from a half-space ``n·x ≥ δ``, ``n·b − δ − Σ_i h_i |n·R_i|`` (its lowest corner).  The obstacles are
those of :mod:`coop_ga.collision` (:class:`~coop_ga.collision.Sphere`, :class:`~coop_ga.collision.Plane`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from .. import validation
from ..collision import Plane, Sphere, as_obstacle
from ..errors import DegeneratePrimitiveError, InvalidInputError

__all__ = ["CarriedBox", "box_sphere_distance", "points_frame"]


def points_frame(P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(R (3, 3), p0 (3,))``: the frame of the first three points of P (n ≥ 3, 3) (module docstring).

    Raises:
        DegeneratePrimitiveError: the three points are (nearly) collinear (no frame).
    """
    x = P[1] - P[0]
    z = np.cross(x, P[2] - P[0])
    nx, nz = float(np.linalg.norm(x)), float(np.linalg.norm(z))
    if not nz > 1e-9 * max(nx * nx, 1e-30):
        raise DegeneratePrimitiveError("the first three end points are (nearly) collinear: they fix no box frame")
    x, z = x / nx, z / nz
    return np.column_stack((x, np.cross(z, x), z)), P[0].copy()


def box_sphere_distance(half: np.ndarray, R: np.ndarray, b: np.ndarray, centre: Any, radius: float) -> float:
    """Signed distance [m] of a box (half extents ``half`` (3,), rotation R, centre b) from a sphere."""
    p = np.abs(R.T @ (np.asarray(centre, float) - b))
    out = np.maximum(p - half, 0.0)
    if np.any(out > 0.0):
        return float(np.linalg.norm(out)) - radius
    return -float(np.min(half - p)) - radius


class CarriedBox:
    """A box held by the end points (module docstring).

    Args:
        half_extents: (3,) half sizes [m] in the box frame.
        rotation: (3, 3) the box's world orientation at the grasp.
        centre: (3,) the box's world centre at the grasp [m].
        grasp_points: (n ≥ 3, 3) the end points at the grasp [m] (world).
        obstacles: :class:`~coop_ga.collision.Sphere` / :class:`~coop_ga.collision.Plane` (or
            :func:`~coop_ga.collision.as_obstacle` inputs) the box must clear.
    """

    def __init__(
        self, half_extents: Any, rotation: Any, centre: Any, grasp_points: Any, obstacles: Sequence[Any] = ()
    ) -> None:
        self.half = validation.vector(half_extents, 3, "half_extents [m]")
        if not np.all(self.half > 0):
            raise InvalidInputError(f"half_extents must be positive, got {self.half.tolist()}")
        Rb = validation.array(rotation, "rotation", shape=(3, 3))
        b = validation.vector(centre, 3, "centre [m]")
        P = validation.array(grasp_points, "grasp_points")
        if P.ndim != 2 or P.shape[1] != 3 or P.shape[0] < 3:
            raise InvalidInputError(f"grasp_points must be (n ≥ 3, 3), got {P.shape}")
        Rg, pg = points_frame(P)
        self.local_rotation = Rg.T @ Rb
        self.local_centre = Rg.T @ (b - pg)
        self.obstacles: tuple[Sphere | Plane, ...] = tuple(as_obstacle(o) for o in obstacles)

    def pose(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(R (3, 3), centre (3,))`` of the box held at the end points ``points`` (n, 3)."""
        Rg, pg = points_frame(points)
        return Rg @ self.local_rotation, pg + Rg @ self.local_centre

    def clearances(self, points: np.ndarray) -> np.ndarray:
        """Signed clearances (n_obstacles,) [m] of the box held at ``points`` from each obstacle."""
        R, b = self.pose(points)
        out = np.empty(len(self.obstacles))
        for k, ob in enumerate(self.obstacles):
            if isinstance(ob, Sphere):
                out[k] = box_sphere_distance(self.half, R, b, ob.center, ob.radius)
            else:
                n = ob.normal
                out[k] = float(n @ b) - ob.offset - float(np.sum(self.half * np.abs(n @ R)))
        return out
