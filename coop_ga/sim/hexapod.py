"""The hexapod in MuJoCo: a free-floating body, feet and shins that collide, terrain from :class:`~coop_ga.legged.Terrain`,
foot contact sensors and an IMU.

:func:`hexapod_scene` builds the MuJoCo scene of the registered ``hexapod`` system (18 leg joints, body frame
B = ``base_link``) with ``floating_base=True``: the body is a free body (``base_link_free``, a MuJoCo
``freejoint``) carrying ``base_link``'s inertia, so the robot stands on its feet, can be pushed and can fall.
The same robot as the floating hexapod ``load("hexapod", free_flyer=True)`` (Pinocchio's free flyer is here the
free joint: qpos (position, quaternion w x y z) ↔ q (position, quaternion x y z w); qvel [world linear velocity,
local angular velocity] ↔ v [local linear, local angular]): ``tests/sim/test_hexapod.py`` checks the feet, the
body, the feet's velocities and the mass matrix against Pinocchio's at random poses.

Collision geometry (what the robot touches the world with)
----------------------------------------------------------
The legs' capsules are the planner's contact model, :func:`coop_ga.legged.contact.leg_capsules` — the one
source of both the planner's leg–terrain clearance and this scene's contacts:

* **feet**: a ball of radius ``legs.foot_radius`` = 9 mm (the URDF's foot sphere) centred on each
  ``{leg}_foot`` frame: on a terrain patch with unit normal n it touches the plane at ``foot − r n``, where the
  planner puts the contact point;
* **shins**: the tibia capsule fitted to the URDF's geometry (radius 24.7 mm), shortened so that its end cap stays
  above the ball's lowest point for tibia tilts up to 60° (:func:`~coop_ga.legged.contact.shin_capsule`): a
  shin–terrain contact is a real shin collision (a riser, a tile edge), never the foot;
* **coxas, femurs**: capsules fitted along their links (joint to joint) around their servo boxes and horns
  (radius 31.3 and 26.9 mm);
* **body**: the URDF's body box, 0.24 × 0.16 × 0.04 m (the fitted body capsule, radius 82 mm, would hang 27 mm
  above the ground at the ride height; the planner does not use it).

The URDF has no ``<collision>`` geometry: its only body geometry is that box, its ``<visual>`` and the box of
its inertia (its README: a plate/electronics box with the six coxa servos at the corners of the hexagon of the
leg mounts), so the scene's body box is the robot description's body exactly.  Every robot geom touches the
terrain; contacts between the legs' links are off (the legs of these gaits do not meet; a self-collision check
would cost more than the rest of a step), but the body box is not excluded from them.  Within the joint limits
no femur reaches it (closest 0.2 mm, with the coxa at its limit toward the body and the femur at +90°;
``tests/sim/test_hexapod.py`` scans the range) — the femur capsule fitted across the link, along its servo
horn (radius 42.6 mm around a 40 × 32 mm servo), met it from ~1.2 rad of lift.  Contacts between the terrain and
anything but a foot ball are counted by :meth:`HexapodScene.terrain_contacts` (the walking metrics' "shin
contacts"), and the robot's contacts with itself (a femur on the body box) as ``self``.

Terrain (:func:`terrain_geoms`)
-------------------------------
A single-cell terrain (``flat``, ``slope``) is one MuJoCo plane with the cell's normal through the cell's plane
(exact everywhere).  A grid of horizontal cells (``steps``, ``random``) is one static box per cell (cells of
one height merged along y), clipped to the scene's ``region`` ((x0, x1), (y0, y1)) [m] — MuJoCo needs finite
boxes and the grid's outer cells reach infinity.  Each box's top face is its cell's plane, its vertical faces
the cell edges, so inside the region the surface height under any (x, y) equals ``Terrain.height`` to
round-off (checked with ``mujoco.mj_ray`` at random points, :meth:`HexapodScene.surface_height`); outside the
region there is no ground.  Grids of tilted cells are refused.

Servos
------
The URDF gives each joint its servo's stall torque (``effort``, 1.5 N m) and no-load speed (``velocity``,
6.18 rad/s) and no damping.  A voltage-driven DC servo (the AX-12A is one) delivers
``τ = τ_stall · u − (τ_stall / ω_0) q̇`` for a duty cycle u ∈ [−1, 1]: its back-EMF is a viscous damping
b = τ_stall / ω_0 = 0.243 N m s/rad at the joint, which is why it cannot turn faster than ω_0.  With
``servo_damping`` (default) every joint gets that damping (MuJoCo integrates it implicitly), and the actuator
is the ``τ_stall · u`` part: the controller's torque, clipped at ±effort by :class:`~coop_ga.sim.Simulation`.
Without it the leg joints are nearly massless (0.2–2 g m² of link inertia, no rotor inertia in the URDF) and a
joint PD at 1 kHz rings.

Friction
--------
MuJoCo's contacts are soft, and with its default pyramidal friction cone a loaded foot creeps: the robot
standing on the 5.7° slope slid downhill at 4.4 mm/s.  The scene uses elliptic cones with ``impratio`` = 100
(frictional constraints 100× stiffer than normal ones, MuJoCo's remedy): 0.02 mm/s.

Contact stiffness
-----------------
Every contact of the scene has MuJoCo's soft-constraint time constant ``HexapodGeometry.contact_timeconst``
(``solref`` = (τ, 1)), by default 0.01 s (MuJoCo's own default is 0.02 s).  The robot (1.87 kg) standing on
its six feet (3.06 N each) sinks its 9 mm balls 0.89 / 0.39 / 0.12 mm into flat ground at τ = 20 / 10 / 5 ms (a rubber tip would by
0.24 mm, Hertz with E = 5 MPa, ν = 0.5); walking a tripod (a loaded foot carries 4.8 N, at most 7.9 N) by
1.3 mm (2.1 mm at most) at 20 ms and 0.5 mm (0.7 mm) at 10 ms.  At 20 ms a stance foot whose tibia turns as the
body passes over it slides instead of rolling: the contact point moves as if the ball turned in place (tripod,
flat ground: the centre stays within 0.8 mm while the contact slides 3.3 mm over a 1.2 s stance, the tangential
force at 0.1–0.15 of the normal one, far inside the friction cone).  The slide is proportional to τ — the fast
tripod rows' worst slip per stance, τ = 20 / 10 / 5 ms: flat 3.32 / 1.54 / 0.72 mm, random tiles 5.44 / 2.72 /
1.20 mm (map), 6.63 / 3.51 / 3.15 mm (blind) — and does not change with ``impratio`` (1000) or MuJoCo's no-slip
solver.  The default is 10 ms: its sink under the walking loads (0.5 mm) is within 1.6× of the rubber tip's, 20
ms sinks 4–5× too deep.  Of the 24 short walks (gait × terrain × map/blind, the blind swing probing for risers
of :mod:`coop_ga.sim.walking_blind`) all 24 pass at 10 ms (worst: walked 97.3 %, slip 3.91 mm per stance, 0 shin
contacts, 0 clipped torques) and 22 at 20 ms (the tripod on random tiles, map 5.44 mm and blind 9.49 mm slip,
fails).

Sensors (MuJoCo's, read by :class:`~coop_ga.sim.Simulation` controllers through ``sensors.sensor(name)`` or the
addresses in :class:`HexapodScene`)
-------------------------------------------------------------------------------------------------------------
* ``imu_quat`` (``framequat`` of the site ``imu`` at the body origin): R_WB as a unit quaternion (w, x, y, z);
* ``imu_gyro`` (``gyro``): the body's angular velocity in B [rad/s];
* ``imu_acc`` (``accelerometer``): specific force in B [m/s²] (+9.81 along body z at rest);
* ``{leg}_touch`` (``touch``, one per leg): the normal force [N] of the contacts inside the sphere of radius
  r + 1 mm around the foot centre — the foot ball's contacts (MuJoCo puts a contact point between the two
  surfaces, so within r of the centre for the ball); the shin's end cap cannot touch the ground that close to
  the foot centre while the ball is on it (its lowest point is above the ball's for tilts ≤ 60°).

Values are those of the last physics step (MuJoCo computes sensors before it integrates).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import validation
from ..errors import InvalidInputError
from ._mujoco import mj
from .scene import GROUP_SCENE, GROUP_SITES, Scene, build_scene

__all__ = [
    "BODY_BOX",
    "HEXAPOD_LEGS",
    "IMU_SENSORS",
    "HexapodGeometry",
    "HexapodScene",
    "default_region",
    "hexapod_capsules",
    "hexapod_scene",
    "terrain_geoms",
]

#: the legs in the order of :mod:`coop_ga.legged` (URDF order); arrays over legs here use it.
HEXAPOD_LEGS: tuple[str, ...] = ("lf", "lm", "lr", "rf", "rm", "rr")
#: names of the IMU's sensors: orientation (framequat), angular velocity (gyro), specific force (accelerometer)
IMU_SENSORS: tuple[str, str, str] = ("imu_quat", "imu_gyro", "imu_acc")
#: the body box [m] (the URDF's body visual and inertia box)
BODY_BOX = (0.24, 0.16, 0.04)
#: the touch sensor's sphere reaches this far [m] beyond the foot ball (its contacts lie within the ball)
TOUCH_MARGIN = 0.001
#: thickness [m] of the terrain boxes below the lowest cell (no thin boxes: contacts stay well conditioned)
_BOX_DEPTH = 0.1


@dataclass(frozen=True)
class HexapodGeometry:
    """Physical options of the scene (module docstring): ``body_box`` edge lengths [m]; ``friction``: MuJoCo's
    (sliding, torsional, rolling) coefficients of every robot geom, or one number; ``servo_damping``: give
    every joint the back-EMF damping of its servo ("Servos"); ``contact_timeconst``: MuJoCo's soft-contact time
    constant [s] of every contact ("Contact stiffness"; ≥ 2 physics steps).  The legs' capsules and the foot
    radius are the planner's (:func:`coop_ga.legged.contact.leg_capsules`)."""

    body_box: tuple[float, float, float] = BODY_BOX
    friction: Any = 1.0
    servo_damping: bool = True
    contact_timeconst: float = 0.01

    def __post_init__(self) -> None:
        box = validation.vector(self.body_box, 3, "HexapodGeometry.body_box")
        if np.any(box <= 0):
            raise InvalidInputError(f"HexapodGeometry.body_box must be 3 edge lengths > 0 [m], got {self.body_box}")
        object.__setattr__(self, "body_box", tuple(float(x) for x in box))
        if not isinstance(self.servo_damping, (bool, np.bool_)):
            raise InvalidInputError(f"HexapodGeometry.servo_damping must be True or False, got {self.servo_damping!r}")
        object.__setattr__(
            self, "contact_timeconst", validation.positive(self.contact_timeconst, "HexapodGeometry.contact_timeconst")
        )


def hexapod_capsules(system: Any) -> tuple[Any, ...]:
    """The legs' capsules of ``system`` for :func:`~coop_ga.sim.build_scene` (module docstring):
    :func:`coop_ga.legged.contact.leg_capsules` without the body's capsule (the scene gives the body its box)."""
    from ..legged.contact import leg_capsules
    from ..legged.legs import hexapod_legs

    return tuple(c for c in leg_capsules(hexapod_legs(), system) if c.link != "base_link")


# ====================================================================== terrain
def default_region(terrain: Any, start: Any = (0.0, 0.0), length: float = 1.0, margin: float = 0.6) -> tuple:
    """A region ((x0, x1), (y0, y1)) [m] for a walk from ``start`` (2,) along +x over ``length`` [m], ``margin``
    [m] around it (the robot is 0.6 m across with its legs out)."""
    s = validation.vector(start, 2, "start")
    L = validation.nonnegative(length, "length")
    m = validation.positive(margin, "margin")
    return ((float(s[0] - m), float(s[0] + L + m)), (float(s[1] - m), float(s[1] + m)))


def _region(region: Any) -> tuple[tuple[float, float], tuple[float, float]]:
    a = validation.array(region, "region")
    if a.shape != (2, 2) or not (a[0, 0] < a[0, 1] and a[1, 0] < a[1, 1]):
        raise InvalidInputError(f"region must be ((x0, x1), (y0, y1)) [m] with x0 < x1 and y0 < y1, got {region!r}")
    return ((float(a[0, 0]), float(a[0, 1])), (float(a[1, 0]), float(a[1, 1])))


def _quat_z_to(n: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of the shortest rotation taking +z to the unit vector n."""
    c = float(n[2])
    axis = np.array([-n[1], n[0], 0.0])
    s = float(np.linalg.norm(axis))
    if s < 1e-15:
        return np.array([1.0, 0.0, 0.0, 0.0]) if c > 0 else np.array([0.0, 1.0, 0.0, 0.0])
    ang = math.atan2(s, c)
    return np.concatenate([[math.cos(0.5 * ang)], math.sin(0.5 * ang) * axis / s])


def _cells(edges: np.ndarray, lo: float, hi: float) -> list[tuple[int, float, float]]:
    """(cell index, start, end) of the cells of ``edges`` (module docstring of Terrain) overlapping [lo, hi]."""
    bounds = np.concatenate([[-math.inf], edges, [math.inf]])
    out = []
    for i in range(len(bounds) - 1):
        a, b = max(bounds[i], lo), min(bounds[i + 1], hi)
        if b > a:
            out.append((i, float(a), float(b)))
    return out


def terrain_geoms(terrain: Any, region: Any) -> list[dict[str, Any]]:
    """The static MuJoCo geoms of ``terrain`` in ``region`` (module docstring) as ``MjsBody.add_geom`` keyword
    dicts (``type``, ``size``, ``pos``, ``quat``, ``name``, ``rgba``): one plane for a single-cell terrain,
    else one box per run of equal-height cells along y."""
    from ..legged.terrain import Terrain

    if not isinstance(terrain, Terrain):
        raise InvalidInputError(f"terrain must be a coop_ga.legged.Terrain, got {type(terrain).__name__}")
    (x0, x1), (y0, y1) = _region(region)
    P = terrain.planes
    if P.shape[:2] == (1, 1):
        n, d = P[0, 0, :3], float(P[0, 0, 3])
        return [
            dict(
                name="terrain",
                type=mj().mjtGeom.mjGEOM_PLANE,
                size=[0.5 * (x1 - x0) + 0.5, 0.5 * (y1 - y0) + 0.5, 0.05],
                pos=np.array([0.0, 0.0, d / n[2]]),  # the point of the plane above the origin
                quat=_quat_z_to(n),
                rgba=[0.72, 0.74, 0.77, 1.0],
            )
        ]
    if np.any(np.abs(P[..., 0]) > 0) or np.any(np.abs(P[..., 1]) > 0):
        raise InvalidInputError(
            f"terrain_geoms builds grids of horizontal cells (steps, random tiles) as boxes; terrain '{terrain.kind}' "
            "has tilted cells in a grid"
        )
    heights = P[..., 3] / P[..., 2]  # (my + 1, mx + 1)
    xs, ys = _cells(terrain.x_edges, x0, x1), _cells(terrain.y_edges, y0, y1)
    bottom = float(min(heights[iy, ix] for iy, _, _ in ys for ix, _, _ in xs)) - _BOX_DEPTH
    span = float(np.ptp(heights)) or 1.0
    out: list[dict[str, Any]] = []
    for ix, a, b in xs:
        k = 0
        while k < len(ys):  # merge runs of equal height along y
            iy, c, _ = ys[k]
            h = float(heights[iy, ix])
            j = k
            while j + 1 < len(ys) and float(heights[ys[j + 1][0], ix]) == h:
                j += 1
            e = ys[j][2]
            shade = 0.62 + 0.25 * (h - heights.min()) / span
            out.append(
                dict(
                    name=f"terrain_{len(out)}",
                    type=mj().mjtGeom.mjGEOM_BOX,
                    size=[0.5 * (b - a), 0.5 * (e - c), 0.5 * (h - bottom)],
                    pos=np.array([0.5 * (a + b), 0.5 * (c + e), 0.5 * (h + bottom)]),
                    quat=np.array([1.0, 0.0, 0.0, 0.0]),
                    rgba=[shade, shade + 0.02, shade + 0.05, 1.0],
                )
            )
            k = j + 1
    return out


# ====================================================================== the scene
@dataclass
class HexapodScene:
    """The hexapod's MuJoCo scene (module docstring) and where to find things in it.

    Attributes:
        scene: the :class:`~coop_ga.sim.Scene` (its ``system`` is the registered ``hexapod``).
        terrain: the :class:`~coop_ga.legged.Terrain`; region: ((x0, x1), (y0, y1)) [m] where it exists.
        geometry: the :class:`HexapodGeometry`.
        foot_sites: (6,) site ids of ``{leg}_foot`` in :data:`HEXAPOD_LEGS` order.
        touch_adr: (6,) ``sensordata`` address of each ``{leg}_touch``; imu_adr: addresses of ``imu_quat`` (4),
            ``imu_gyro`` (3), ``imu_acc`` (3).
        foot_radius: [m] the foot balls' radius (``legs.foot_radius``).
        foot_geoms, tibia_geoms, femur_geoms, coxa_geoms: (6,) geom ids per leg; body_geom: the body box's geom.
        terrain_geom_ids: (m,) ids of the terrain geoms.
    """

    scene: Scene
    terrain: Any
    region: tuple[tuple[float, float], tuple[float, float]]
    geometry: HexapodGeometry
    foot_sites: np.ndarray = field(init=False)
    touch_adr: np.ndarray = field(init=False)
    imu_adr: tuple[int, int, int] = field(init=False)
    foot_geoms: np.ndarray = field(init=False)
    tibia_geoms: np.ndarray = field(init=False)
    femur_geoms: np.ndarray = field(init=False)
    coxa_geoms: np.ndarray = field(init=False)
    foot_radius: float = field(init=False)
    body_geom: int = field(init=False)
    terrain_geom_ids: np.ndarray = field(init=False)
    _kind: np.ndarray = field(init=False, repr=False)
    _foot_leg: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        s, m = self.scene, self.scene.model
        self.foot_sites = np.array([s.id_of("site", f"{leg}_foot") for leg in HEXAPOD_LEGS])
        self.touch_adr = np.array([m.sensor_adr[s.id_of("sensor", f"{leg}_touch")] for leg in HEXAPOD_LEGS])
        q, g, a = (int(m.sensor_adr[s.id_of("sensor", n)]) for n in IMU_SENSORS)
        self.imu_adr = (q, g, a)
        link = {c.link: int(g) for c, g in zip(s.capsules, s.capsule_geoms)}
        self.foot_geoms, self.tibia_geoms, self.femur_geoms, self.coxa_geoms = (
            np.array([link[f"{leg}_{part}"] for leg in HEXAPOD_LEGS]) for part in ("foot", "tibia", "femur", "coxa")
        )
        self.foot_radius = float(m.geom_size[self.foot_geoms[0], 0])
        self.body_geom = s.id_of("geom", "body_box")
        self.terrain_geom_ids = np.array(
            [i for i in range(m.ngeom) if (mj().mj_id2name(m, mj().mjtObj.mjOBJ_GEOM, i) or "").startswith("terrain")]
        )
        # geom class: 0 other, 1 terrain, 2 foot, 3 shin (tibia), 4 femur or coxa, 5 body
        kind = np.zeros(m.ngeom, dtype=np.int8)
        kind[self.terrain_geom_ids] = 1
        kind[self.foot_geoms], kind[self.tibia_geoms], kind[self.femur_geoms], kind[self.coxa_geoms] = 2, 3, 4, 4
        kind[self.body_geom] = 5
        self._kind = kind
        self._foot_leg = np.full(m.ngeom, -1, dtype=np.int64)
        self._foot_leg[self.foot_geoms] = np.arange(6)

    def __repr__(self) -> str:
        return f"HexapodScene({self.terrain!r}, region={self.region}, geoms={self.scene.model.ngeom})"

    @property
    def model(self) -> Any:
        return self.scene.model

    # ------------------------------------------------------------------ read-outs
    def feet_world(self, data: Any) -> np.ndarray:
        """(6, 3) foot-ball centres [m] in the world, :data:`HEXAPOD_LEGS` order (after ``mj_forward``/``mj_step``)."""
        return np.array(data.site_xpos[self.foot_sites])

    def touch(self, data: Any) -> np.ndarray:
        """(6,) foot contact normal forces [N] of the last physics step."""
        return np.array(data.sensordata[self.touch_adr])

    def foot_normals(self, data: Any) -> np.ndarray:
        """(6, 3) the direction of each foot ball's contact force's normal part, world frame, from the terrain into
        the foot (the normal forces' weighted sum over the ball's contacts, normalised; zeros without contact) —
        what a force sensor in the foot tells and a touch sensor does not: a level tread (≈ +z) from a riser's
        face (≈ horizontal).  From ``data.contact`` and ``mujoco.mj_contactForce`` of the last physics step."""
        out = np.zeros((6, 3))
        n = int(data.ncon)
        if n == 0:
            return out
        con = data.contact
        legs = self._foot_leg[con.geom[:n]]  # (n, 2): the leg of a foot geom, else −1
        f6 = np.zeros(6)
        m = self.scene.model
        for c in np.flatnonzero((legs >= 0).any(axis=1)).tolist():
            mj().mj_contactForce(m, data, c, f6)
            nrm = f6[0] * np.asarray(con.frame[c, :3])  # the frame's normal points from geom1 to geom2
            if legs[c, 1] >= 0:
                out[legs[c, 1]] += nrm
            else:
                out[legs[c, 0]] -= nrm
        norm = np.linalg.norm(out, axis=1)
        on = norm > 0
        out[on] /= norm[on, None]
        return out

    def imu(self, data: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(quaternion (w, x, y, z) of R_WB, gyro (3,) [rad/s] in B, accelerometer (3,) [m/s²] in B)."""
        q, g, a = self.imu_adr
        sd = data.sensordata
        return np.array(sd[q : q + 4]), np.array(sd[g : g + 3]), np.array(sd[a : a + 3])

    def terrain_contacts(self, data: Any) -> dict[str, int]:
        """Contacts in ``data`` between the terrain and the robot, counted by robot part: ``foot``, ``shin``
        (tibia capsules), ``femur`` (femur and coxa capsules), ``body``; and ``self``: the robot's contacts with
        itself (module docstring: a femur on the body box)."""
        n = int(data.ncon)
        out = {"foot": 0, "shin": 0, "femur": 0, "body": 0, "self": 0}
        if n == 0:
            return out
        k = self._kind[data.contact.geom[:n]]  # (n, 2) classes of the two geoms of every contact
        other = np.where(k[:, 0] == 1, k[:, 1], np.where(k[:, 1] == 1, k[:, 0], 0))
        counts = np.bincount(other, minlength=6)
        out["foot"], out["shin"], out["femur"], out["body"] = (int(counts[c]) for c in (2, 3, 4, 5))
        out["self"] = int(np.count_nonzero((k[:, 0] >= 2) & (k[:, 1] >= 2)))
        return out

    def surface_height(self, xy: Any) -> np.ndarray:
        """Height [m] of the MuJoCo terrain under each ``xy`` (..., 2) [m]: a ray cast down from 10 m above the
        highest terrain onto the terrain geoms only (``mj_ray``); NaN where it hits nothing (outside the
        region).  Equals ``terrain.height(xy)`` inside the region (module docstring)."""
        P = validation.array(xy, "xy")
        if P.ndim == 0 or P.shape[-1] != 2:
            raise InvalidInputError(f"xy must have shape (..., 2) [m], got {P.shape}")
        m = self.scene.model
        d = mj().MjData(m)
        mj().mj_forward(m, d)
        top = float(np.max(self.terrain.planes[..., 3] / self.terrain.planes[..., 2])) + 10.0
        groups = np.zeros(6, dtype=np.uint8)
        groups[GROUP_SCENE] = 1
        gid = np.zeros(1, dtype=np.int32)
        flat = P.reshape(-1, 2)
        out = np.empty(len(flat))
        terrain = set(self.terrain_geom_ids.tolist())
        for i, (x, y) in enumerate(flat):
            z0 = top + abs(float(x)) + abs(float(y))  # above any slope plane too
            dist = mj().mj_ray(m, d, np.array([x, y, z0]), np.array([0.0, 0.0, -1.0]), groups, 1, -1, gid)
            out[i] = z0 - dist if dist >= 0 and int(gid[0]) in terrain else math.nan
        return out.reshape(P.shape[:-1])


def hexapod_scene(
    terrain: Any = None,
    *,
    region: Any = None,
    geometry: HexapodGeometry | None = None,
    timestep: float = 1e-3,
    integrator: str = "implicitfast",
    impratio: float = 100.0,
    visuals: bool = True,
) -> HexapodScene:
    """The hexapod (registered ``hexapod``, free-floating body) on ``terrain`` in MuJoCo (module docstring).

    Args:
        terrain: a :class:`~coop_ga.legged.Terrain` (default flat z = 0).
        region: ((x0, x1), (y0, y1)) [m] of the terrain boxes of a grid terrain (default
            :func:`default_region` of a 1 m walk from the origin).
        geometry: the collision geometry (:class:`HexapodGeometry`).
        timestep: physics step Δt [s]; integrator: as :func:`~coop_ga.sim.build_scene`.
        impratio: MuJoCo's ratio of frictional to normal constraint impedance, with elliptic friction cones
            (module docstring, "Friction").
        visuals: add the URDF's visual geometry (for pictures; no effect on the physics).

    Returns:
        :class:`HexapodScene`.

    Raises:
        InvalidInputError: a terrain that is not a ``Terrain`` or a grid of tilted cells, a bad region, a
            ``contact_timeconst`` below two physics steps.
    """
    from .. import systems
    from ..legged.terrain import Terrain

    terrain = Terrain.flat() if terrain is None else terrain
    geoms = terrain_geoms(terrain, default_region(terrain) if region is None else region)
    reg = _region(default_region(terrain) if region is None else region)
    g = geometry or HexapodGeometry()
    if not isinstance(g, HexapodGeometry):
        raise InvalidInputError(f"geometry must be a HexapodGeometry, got {type(g).__name__}")
    system = systems.load("hexapod")
    lim = system.limits
    assert lim is not None  # a registered system has its URDF limits
    base = build_scene(
        system,
        floor=None,
        capsules=hexapod_capsules(system),
        self_collision=False,
        robot_friction=g.friction,
        visuals=visuals,
        floating_base=True,
        damping=np.asarray(lim.effort) / np.asarray(lim.velocity) if g.servo_damping else None,
        timestep=timestep,
        integrator=integrator,
        name="hexapod_walk",
    )
    _add_body_box(base.spec, base.base_body, g)
    _add_terrain(base.spec, geoms)
    _add_sensors(base.spec, base.base_body, base.system)
    _set_contact_timeconst(base.spec, g.contact_timeconst, timestep)
    base.spec.option.cone = mj().mjtCone.mjCONE_ELLIPTIC
    base.spec.option.impratio = validation.positive(impratio, "impratio")
    return HexapodScene(base.recompile(), terrain, reg, g)


def _foot_radius() -> float:
    from ..legged.legs import hexapod_legs

    return float(hexapod_legs().foot_radius)


def _add_body_box(spec: Any, base_body: str | None, g: HexapodGeometry) -> None:
    from .objects import friction

    body = spec.body(base_body)
    body.add_geom(
        name="body_box",
        type=mj().mjtGeom.mjGEOM_BOX,
        size=0.5 * np.asarray(g.body_box),
        contype=1,
        conaffinity=1,
        group=3,
        friction=friction(g.friction, "HexapodGeometry.friction"),
        rgba=[0.3, 0.6, 0.9, 0.4],
    )


def _set_contact_timeconst(spec: Any, tau: float, timestep: float) -> None:
    """Every colliding geom's ``solref`` = (τ, 1) (module docstring, "Contact stiffness"): its contacts then have
    that time constant whatever they touch (MuJoCo mixes the two geoms' solref)."""
    if tau < 2.0 * timestep:
        raise InvalidInputError(
            f"HexapodGeometry.contact_timeconst ({tau} s) must be at least two physics steps ({2.0 * timestep} s): "
            "MuJoCo's soft contacts are unstable below that; raise it or lower the timestep"
        )
    for geom in spec.geoms:
        if geom.contype or geom.conaffinity:
            geom.solref = [tau, 1.0]


def _add_terrain(spec: Any, geoms: Sequence[dict[str, Any]]) -> None:
    for kw in geoms:
        spec.worldbody.add_geom(contype=1, conaffinity=1, group=GROUP_SCENE, **kw)


def _add_sensors(spec: Any, base_body: str | None, system: Any) -> None:
    """The IMU at the body origin and a touch sphere at every foot (module docstring)."""
    m = mj()
    S, O = m.mjtSensor, m.mjtObj
    body = spec.body(base_body)
    body.add_site(name="imu", pos=[0, 0, 0], size=[0.01, 0, 0], group=GROUP_SITES, type=m.mjtGeom.mjGEOM_SPHERE)
    for name, kind in zip(IMU_SENSORS, (S.mjSENS_FRAMEQUAT, S.mjSENS_GYRO, S.mjSENS_ACCELEROMETER)):
        spec.add_sensor(name=name, type=kind, objtype=O.mjOBJ_SITE, objname="imu")
    for leg in HEXAPOD_LEGS:
        foot = spec.site(f"{leg}_foot")
        parent = foot.parent
        parent.add_site(
            name=f"{leg}_touch",
            pos=np.array(foot.pos),
            size=[_foot_radius() + TOUCH_MARGIN, 0, 0],
            group=GROUP_SITES,
            type=m.mjtGeom.mjGEOM_SPHERE,
        )
        spec.add_sensor(name=f"{leg}_touch", type=S.mjSENS_TOUCH, objtype=O.mjOBJ_SITE, objname=f"{leg}_touch")
