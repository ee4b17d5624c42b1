"""Footholds and swing apexes from the map, with the planner's leg–terrain clearance (the walker's map mode).

With the terrain known (:class:`~coop_ga.sim.walking.WalkingOptions` ``blind=False``), :class:`MapFootholds`
places a swing leg's next foothold and raises its swing the way the kinematic planner
(:func:`coop_ga.legged.walk.walk`) does, with the same public pieces of :mod:`coop_ga.legged.contact`:

* the foothold is the foot ball resting on the terrain (:func:`~coop_ga.legged.contact.ball_on_terrain`) at the
  nominal foothold, its contact kept ``edge_clearance`` from the cell edges; if a leg capsule (coxa, femur, shin,
  :func:`~coop_ga.legged.contact.leg_clearance`) would come closer than ``clearance_margin`` to the terrain at
  the predicted body poses of touchdown, mid-stance and lift-off — a rear shin leaning over a riser, a shin
  over a taller tile — the nearest shifted foothold that keeps it is taken (:data:`SHIFTS`, nearest first);
* the swing's apex is ``lift_height`` above the highest terrain under it, raised (by at most
  :data:`MAX_EXTRA_LIFT`) until the moving ball and the leg's capsules stay ``clearance_margin`` off the terrain
  along :func:`~coop_ga.legged.gait.swing_arc` at the predicted body poses.

Poses are predicted in the world: the reference's horizontal pose (the walker's, through its localisation),
the height over the contact plane of the six nominal footholds there (``ride_height`` above their ball
centres), level (``tilt_follow`` toward that plane).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["MAX_EXTRA_LIFT", "RISE", "SHIFTS", "MapFootholds"]

#: foothold shifts (dx, dy) [m] in the world tried when a leg capsule would touch the terrain, nearest first
SHIFTS: tuple[tuple[float, float], ...] = tuple(
    sorted(
        {
            (round(dx, 3), round(dy, 3))
            for dx in np.arange(-0.05, 0.0501, 0.01)
            for dy in np.arange(-0.03, 0.0301, 0.01)
        },
        key=lambda d: (math.hypot(*d), d),
    )
)[1:]
#: [m] the most a swing apex is raised to clear the leg's capsules
MAX_EXTRA_LIFT = 0.05
#: [m] how far above its predicted height the body may stand at a foot's lift-off: the prediction stands the six
#: feet on their nominal footholds, the real ones lead them by up to half a stroke (on the 1 m wave walk up the
#: steps the body stood up to 14 mm above it, and a rear shin met the riser ahead of its foot at the end of stance)
RISE = 0.015
#: swing progress samples checked for clearance
_SWING_S = np.linspace(0.15, 0.85, 6)


class MapFootholds:
    """Map footholds and swing lifts (module docstring) for the walker's legs and terrain.

    Args:
        terrain: the :class:`~coop_ga.legged.Terrain`; legs: the :class:`~coop_ga.legged.legs.LegModel`;
        nominal: (6, 3) nominal ball centres in B; ride_height [m]; tilt_follow ∈ [0, 1];
        edge_clearance, clearance_margin, lift_height [m].
    """

    def __init__(
        self,
        terrain: Any,
        legs: Any,
        nominal: np.ndarray,
        *,
        ride_height: float,
        tilt_follow: float,
        edge_clearance: float,
        clearance_margin: float,
        lift_height: float,
    ):
        self.terrain, self.legs, self.nominal = terrain, legs, np.asarray(nominal, float)
        self.r = float(legs.foot_radius)
        self.ride, self.follow = float(ride_height), float(tilt_follow)
        self.edge, self.margin, self.lift = float(edge_clearance), float(clearance_margin), float(lift_height)
        self.shifts = 0
        self.raised = 0
        self._fl: Any = None

    # ------------------------------------------------------------------ geometry
    def centre(self, xy: np.ndarray) -> np.ndarray:
        """The ball centre (3,) resting on the terrain with its contact over ``xy``, kept off the cell edges."""
        from ..legged.contact import ball_on_terrain
        from ..legged.walk import _off_edges

        return np.asarray(ball_on_terrain(self.terrain, _off_edges(self.terrain, xy, self.edge), self.r), float)

    def body(self, pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The predicted body (position (3,), R_WB) at the horizontal pose ``(x, y, yaw)`` in the world."""
        from .walking import _fit_plane, _frame_with_z, _rot_z

        x, y, yaw = (float(v) for v in pose)
        feet = np.array([self.centre(v) for v in np.array([x, y]) + self.nominal[:, :2] @ _rot_z(yaw)[:2, :2].T])
        n, d = _fit_plane(feet)
        z = (1.0 - self.follow) * np.array([0.0, 0.0, 1.0]) + self.follow * n
        R = _frame_with_z(z / np.linalg.norm(z), yaw)
        zb = (d + self.ride * float(n @ R[:, 2]) - n[0] * x - n[1] * y) / n[2]  # ride_height along n over the plane
        return np.array([x, y, zb]), R

    def clearance(self, i: int, feet_w: np.ndarray, poses: list[tuple[np.ndarray, np.ndarray]]) -> float:
        """The smallest clearance [m] of leg i's capsules with its ball at ``feet_w`` (m, 3) at the body ``poses``
        (m); −inf where the leg cannot reach inside its limits."""
        from ..legged.contact import leg_clearance
        from .walking_kin import FastLegs

        if self._fl is None:
            self._fl = FastLegs(self.legs)
        fl = self._fl
        P = np.array([p for p, _ in poses])
        R = np.array([r for _, r in poses])
        qs = []
        for k in range(len(poses)):
            feet = self.nominal.copy()
            feet[i] = R[k].T @ (feet_w[k] - P[k])
            q, m = fl.ik(feet)
            if m[i] < 0.002 or fl.violation(q) > 1e-9:
                return -math.inf
            qs.append(q)
        return float(leg_clearance(self.terrain, self.legs, P, R, np.array(qs))[:, i].min())

    # ------------------------------------------------------------------ planning
    def foothold(self, i: int, xy: np.ndarray, stance_poses: list[np.ndarray]) -> np.ndarray:
        """Leg i's ball centre (3,) in the world for its next stance: over ``xy`` (2,), or the nearest shift that
        keeps its capsules ``clearance_margin`` off the terrain at the horizontal ``stance_poses`` (module
        docstring)."""
        poses = [self.body(p) for p in stance_poses]
        # the body may stand up to RISE above the predicted height at lift-off (the real feet lead the nominal
        # ones onto the next tread): its capsules must clear the terrain from there too
        p_lo, R_lo = poses[-1]
        poses.append((p_lo + np.array([0.0, 0.0, RISE]), R_lo))
        c0 = self.centre(xy)
        best, best_c = c0, self.clearance(i, np.repeat(c0[None], len(poses), axis=0), poses)
        if best_c >= self.margin:
            return c0
        for d in SHIFTS:
            c = self.centre(xy + np.asarray(d))
            cl = self.clearance(i, np.repeat(c[None], len(poses), axis=0), poses)
            if cl >= self.margin:
                self.shifts += 1
                return c
            if cl > best_c:
                best, best_c = c, cl
        self.shifts += int(best is not c0)
        return best

    def swing_lift(self, i: int, a: np.ndarray, b: np.ndarray, poses_ab: tuple[np.ndarray, np.ndarray]) -> float:
        """The apex lift [m] of leg i's swing a → b (world): ``lift_height`` above the highest terrain under it,
        raised until the ball (while it moves across) and the leg's capsules stay ``clearance_margin`` off the
        terrain; the body moves from the horizontal pose ``poses_ab[0]`` (lift-off) to ``poses_ab[1]``
        (touchdown) during the swing (interpolated between the two predicted bodies)."""
        from ..legged.gait import swing_arc
        from .walking import _expm_so3, _rotvec

        top = float(self.terrain.max_height(a[:2], b[:2])) + self.r
        lift = max(top, a[2], b[2]) - max(a[2], b[2]) + self.lift
        lift0 = lift
        (p0, R0), (p1, R1) = (self.body(p) for p in poses_ab)
        w = _rotvec(R0.T @ R1)
        poses = [(p0 + s * (p1 - p0), R0 @ _expm_so3(s * w)) for s in _SWING_S]
        moving = (_SWING_S > 0.15) & (_SWING_S < 0.85)
        for _ in range(6):
            pts = swing_arc(a, b, lift, _SWING_S)[0]
            ball = float(np.min(self.terrain.solid_distance(pts[moving]))) - self.r
            worst = min(self.clearance(i, pts, poses), ball)
            if worst >= self.margin or lift - lift0 >= MAX_EXTRA_LIFT or worst == -math.inf:
                break
            lift += self.margin - worst + 0.002
        self.raised += int(lift > lift0)
        return lift
