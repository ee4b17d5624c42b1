"""The legs' contact and collision geometry against the terrain: the foot ball and the leg capsules.

**The foot is a ball.**  The URDF puts a sphere of radius ``r = legs.foot_radius`` (9 mm) on each
``{leg}_foot`` frame, which is the ball's *centre*.  The planner's contact model is that ball's: a stance
foot has its centre one radius above the terrain along the plane normal (:func:`ball_on_terrain`), the
point on the ground is ``centre − r n`` (:meth:`~coop_ga.legged.legs.LegModel.contact_points`), and a
swing foot clears the terrain when the ball does (``Terrain.solid_distance(centre) − r``).  What the
planner keeps fixed in the world during a stance is the ball's centre.  A ball rigidly attached to a
tibia that turns by Δθ about its centre while the centre stays put must slide on the ground (or, with
friction, roll and carry its centre along) by ``r · |Δθ_⊥|`` (Δθ_⊥: the turn about axes in the ground
plane; a turn about the normal spins the ball in place): :func:`rolling_distance` measures it per stance,
and :class:`~coop_ga.legged.walk.WalkResult` reports it (``rolling``) — the error of treating the
contact as fixed, a few mm per stance for the hexapod.

**Leg capsules.**  The capsules of every leg link are those :func:`coop_ga.collision.fit_capsules` fits
to the URDF's geometry (the ones :func:`coop_ga.sim.build_scene` uses by default), with two changes.  The
coxa and femur capsules are fitted along their links (from the joint toward the next joint,
:func:`coop_ga.collision.fit_capsule` with ``axis``): the principal-axis fit follows the vertices of the
finely tessellated servo horn across the link, and gave the femur a capsule along its pitch axis of radius 42.6
mm around a 40 × 32 mm servo box (26.9 mm along the link), which reached back past the femur joint and met
the body.  And the fitted tibia capsule (radius 24.7 mm around the knee's servo horn and the tibia bracket) reaches
15.7 mm short of the foot centre, so its end cap hangs below the 9 mm ball whenever the tibia is not
vertical (by 1.7 mm at the stand pose's 27°, 3.3 mm at 38°): the tibia, not the ball, would touch the
ground.  :func:`leg_capsules` shortens it (the **shin**) so that its end cap stays above the ball's
lowest point for tibia tilts up to :data:`SHIN_TILT` from the ground normal, and adds the foot ball as
a capsule of length 0 on ``{leg}_foot`` — pass them to ``build_scene(system, capsules=leg_capsules(legs))``
so that physics touches the ground where the planner does.  The last ``shin_gap`` of the tibia (its
25 × 10 mm bracket end, within 12.5 mm of the axis) is then covered by the ball only.

:func:`leg_segments` gives every leg capsule in W for a batch of body poses and joint vectors, and
:func:`leg_clearance` their clearance above the terrain solid (a lower bound,
:meth:`~coop_ga.legged.terrain.Terrain.capsule_clearance`): the walk's footholds and swing arcs keep it
≥ 0 (``WalkResult.segment_clearance``).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import InvalidInputError
from ..validation import array, positive
from .legs import LEGS, check_legs

if TYPE_CHECKING:  # pragma: no cover
    from ..collision import Capsule
    from .legs import LegModel
    from .terrain import Terrain

__all__ = [
    "LINKS",
    "SHIN_TILT",
    "ball_on_terrain",
    "leg_capsules",
    "leg_clearance",
    "leg_segments",
    "rolling_distance",
    "shin_capsule",
]

#: the links of a leg, root to tip (their capsules: coxa, femur, shin)
LINKS: tuple[str, ...] = ("coxa", "femur", "tibia")
#: [rad] the largest tibia tilt from the ground normal at which the shin's end cap stays above the foot
#: ball's lowest point (60°; the walks reach 38°)
SHIN_TILT = math.radians(60.0)
#: [m] the shin's end cap stays at least this far above the ball's lowest point at SHIN_TILT
_SHIN_MARGIN = 0.001

_CAPS: dict[int, tuple[Any, tuple[Any, ...]]] = {}


def shin_capsule(legs: LegModel) -> tuple[np.ndarray, np.ndarray, float]:
    """``(a, b, radius)`` of the shin capsule in the tibia joint frame [m]: the fitted tibia capsule
    (:func:`coop_ga.collision.fit_capsules`) shortened at the foot end (module docstring).  The end ``b`` lies
    ``d = (ρ − r + 1 mm) / cos(SHIN_TILT)`` before the foot centre along the tibia, so the cap (radius ρ) is
    above the ball's (radius r) lowest point for every tilt ≤ :data:`SHIN_TILT`."""
    lm = check_legs(legs)
    cap = _leg_caps(lm)[1][2]
    a, b0, rho = np.asarray(cap.a, float), np.asarray(cap.b, float), float(cap.radius)
    foot = np.array([lm.tibia_link[0, 0], 0.0, lm.tibia_link[0, 1]])
    u = (foot - a) / np.linalg.norm(foot - a)
    d = (rho - lm.foot_radius + _SHIN_MARGIN) / math.cos(SHIN_TILT)
    t = min(float((b0 - a) @ u), float((foot - a) @ u) - d)  # never longer than the fitted capsule
    return a, a + max(t, 0.0) * u, rho


def _leg_caps(lm: LegModel) -> tuple[Any, tuple[Capsule, Capsule, Capsule]]:
    """The fitted (coxa, femur, tibia) capsules of the first leg (all legs are alike), cached per system: the
    coxa and femur along their links (:func:`_along_link`), the tibia as :func:`coop_ga.collision.fit_capsules`
    fits it (already along the tibia)."""
    hit = _CAPS.get(id(lm.system))
    if hit is None or hit[0] is not lm.system:
        from ..collision import fit_capsules

        leg = lm.legs[0]
        caps = {c.frame: c for c in fit_capsules(lm.system, links=[f"{leg}_{k}" for k in LINKS])}
        hit = (lm.system, tuple(_along_link(lm, caps[f"{leg}_{k}"], lm.system) for k in LINKS))
        _CAPS[id(lm.system)] = hit
    return hit


def _along_link(lm: LegModel, cap: Capsule, system: Any) -> Capsule:
    """``cap`` (fitted to a leg link of ``system``) refitted along its link — the coxa from the coxa axis to the
    femur joint, the femur from the femur joint to the tibia joint — enclosing the same vertices (module
    docstring, "Leg capsules"); other capsules unchanged."""
    from ..collision import Capsule, fit_capsule
    from ..collision.capsules import link_meshes

    leg = next((x for x in lm.legs if cap.frame in (f"{x}_coxa", f"{x}_femur")), None)
    if leg is None:
        return cap
    i = lm.legs.index(leg)
    x, z = lm.femur_joint[i] if cap.frame == f"{leg}_coxa" else lm.femur_link[i]
    a, b, r = fit_capsule(_link_vertices(system, link_meshes)[cap.frame], axis=(x, 0.0, z))
    return Capsule(cap.frame, a, b, r, cap.chain, cap.link)


_VERTICES: dict[int, tuple[Any, dict[str, np.ndarray]]] = {}


def _link_vertices(system: Any, link_meshes: Any) -> dict[str, np.ndarray]:
    """``link_meshes(system)`` read once per system."""
    hit = _VERTICES.get(id(system))
    if hit is None or hit[0] is not system:
        hit = _VERTICES[id(system)] = (system, link_meshes(system))
    return hit[1]


def leg_capsules(legs: LegModel, system: Any = None) -> tuple[Capsule, ...]:
    """The robot's collision capsules with the planner's contact model: :func:`coop_ga.collision.fit_capsules`
    of ``system`` (default ``legs.system``; e.g. ``load("hexapod", free_flyer=True)``) with every tibia
    capsule replaced by the shin (:func:`shin_capsule`) and a foot ball (a capsule of length 0, radius
    ``legs.foot_radius``) on every ``{leg}_foot`` frame.  For ``coop_ga.sim.build_scene(system,
    capsules=leg_capsules(legs, system))``: the ground then touches the balls, where the planner's feet are.
    Coordinates below 1e-12 m (the fit's round-off) are set to 0, so the scene's ``model.xml`` reloads bit for bit."""
    from ..collision import Capsule, fit_capsules

    lm = check_legs(legs)
    sysm = lm.system if system is None else system
    a, b, rho = shin_capsule(lm)
    a, b = _snap(a), _snap(b)
    out = []
    for c0 in fit_capsules(sysm):
        c = _along_link(lm, c0, sysm)
        leg = next((x for x in lm.legs if c.frame == f"{x}_tibia"), None)
        if leg is None:
            out.append(Capsule(c.frame, _snap(c.a), _snap(c.b), c.radius, c.chain, c.link))
            continue
        out.append(Capsule(c.frame, a, b, rho, c.chain, c.link))
        if lm.foot_radius > 0:
            out.append(Capsule(f"{leg}_foot", np.zeros(3), np.zeros(3), lm.foot_radius, c.chain, f"{leg}_foot"))
    return tuple(out)


def _snap(x: Any) -> np.ndarray:
    """Round-off of the capsule fit (|x| < 1e-12 m, e.g. 1e-18 off an axis) set to 0: MuJoCo's MJCF writer does
    not give such offsets back bit for bit, and ``coop_ga.sim`` refuses to save a model that does not reload."""
    v = np.array(x, dtype=float)
    v[np.abs(v) < 1e-12] = 0.0
    return v


def leg_segments(legs: LegModel, position: Any, rotation: Any, q: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every leg capsule (coxa, femur, shin) in W for a batch of states.

    Args:
        legs: the :class:`~coop_ga.legged.legs.LegModel`.
        position: (..., 3) body positions [m] in W.
        rotation: (..., 3, 3) body rotations R_WB.
        q: (..., 18) leg joints [rad].

    Returns:
        ``(a, b, radius)``: segment ends a, b (..., 6, 3, 3) [m] in W (legs in LEG ORDER, links in
        :data:`LINKS` order) and the radii (3,) [m].
    """
    lm = check_legs(legs)
    p = array(position, "position")
    R = array(rotation, "rotation")
    if p.shape[-1:] != (3,) or R.shape[-2:] != (3, 3) or R.shape[:-2] != p.shape[:-1]:
        raise InvalidInputError(f"position (..., 3) and rotation (..., 3, 3) must match, got {p.shape} and {R.shape}")
    frames = lm.link_frames(q)
    caps = _leg_caps(lm)[1]
    sa, sb, srho = shin_capsule(lm)
    ends = [(np.asarray(caps[0].a), np.asarray(caps[0].b)), (np.asarray(caps[1].a), np.asarray(caps[1].b)), (sa, sb)]
    A, B = [], []
    for name, (ca, cb) in zip(LINKS, ends):
        Rl, ol = frames[name]
        A.append(ol + Rl @ ca)
        B.append(ol + Rl @ cb)
    AB = np.stack(A, axis=-2), np.stack(B, axis=-2)  # (..., 6, 3 links, 3) in B
    to_w = [np.einsum("...ij,...lkj->...lki", R, X) + p[..., None, None, :] for X in AB]
    return to_w[0], to_w[1], np.array([caps[0].radius, caps[1].radius, srho])


def leg_clearance(
    terrain: Terrain, legs: LegModel, position: Any, rotation: Any, q: Any, spacing: float = 0.002
) -> np.ndarray:
    """(..., 6) [m]: per leg the smallest clearance of its capsules (coxa, femur, shin) above the terrain solid
    (a lower bound within ``spacing / 2``, :meth:`~coop_ga.legged.terrain.Terrain.capsule_clearance`), for
    body poses ``position`` (..., 3), ``rotation`` (..., 3, 3) and joints ``q`` (..., 18).  The foot ball is not
    part of it (a stance ball touches the ground: its clearance is the walk's ``contact_error``)."""
    a, b, rho = leg_segments(legs, position, rotation, q)
    c = terrain.capsule_clearance(a, b, np.broadcast_to(rho, a.shape[:-1]), positive(spacing, "spacing"))
    return c.min(axis=-1)


def ball_on_terrain(terrain: Terrain, xy: Any, radius: float) -> np.ndarray:
    """The centre (..., 3) [m] in W of a ball of ``radius`` resting on the terrain at the contact point over
    ``xy`` (..., 2): ``land(xy) + radius · n(xy)`` (for a horizontal cell: (x, y, h + r); on a slope the centre's
    xy is ``radius · n_xy`` off the contact's).  Keep the contact at least a radius from a riser (the walk's
    ``edge_clearance``) so that the ball rests on the tread, not on the edge."""
    return np.asarray(terrain.land(xy), float) + float(radius) * np.asarray(terrain.normal(xy), float)


def rolling_distance(legs: LegModel, rotation: Any, q: Any, normal: Any, stance: Any) -> np.ndarray:
    """(T, 6) [m]: how far each stance foot ball has turned since its touch-down, as a rolling distance
    ``r · |Δθ_⊥|`` (module docstring): the rotation of the tibia in W since the first knot of the current
    stance, its component about axes perpendicular to the ground ``normal`` (T, 6, 3), times the ball radius
    (0 in swing).  ``rotation`` (T, 3, 3) body rotations, ``q`` (T, 18), ``stance`` (T, 6) bool."""
    from scipy.spatial.transform import Rotation

    lm = check_legs(legs)
    Rb = array(rotation, "rotation")
    S = np.asarray(stance, dtype=bool)
    n = array(normal, "normal")
    Rt = np.einsum("tij,tljk->tlik", Rb, lm.link_frames(q)["tibia"][0])  # (T, 6, 3, 3) tibia in W
    out = np.zeros(S.shape)
    for i in range(len(LEGS)):
        ref = None
        for k in range(S.shape[0]):
            if not S[k, i]:
                ref = None
                continue
            if ref is None:
                ref = Rt[k, i]
            w = Rotation.from_matrix(Rt[k, i] @ ref.T).as_rotvec()
            w_perp = w - (w @ n[k, i]) * n[k, i]
            out[k, i] = lm.foot_radius * float(np.linalg.norm(w_perp))
    return out
