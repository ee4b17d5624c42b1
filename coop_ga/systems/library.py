"""The registered systems of the paper (§4, Figs. 8–13, 20–21): builders for :func:`systems.load`.

=================  ===  ==========================================================  ==========================
name               DOF  robots                                                      end points
=================  ===  ==========================================================  ==========================
three_franka        21  three Franka Panda arms on a 0.8 m ring (Fig. 8)            3 × panda_hand_tcp
three_iiwa14        21  three KUKA LBR iiwa 14 on a 1.15 m ring (§4.1, Fig. 6)      3 × iiwa_flange
g1_arms             17  Unitree G1, waist + both arms, legs locked                  left/right rubber hand
g1_torso_arms       17  as g1_arms, plus a point in front of the chest (Fig. 9)     chest, right, left hand
franka_and_g1       24  a Franka facing a G1 1.0 m away (Fig. 10)                   Franka tcp, G1 hands
two_g1              34  two G1s facing each other 1.0 m apart                       4 hands (sphere)
three_finger_hand   12  Allegro right hand, middle finger locked                    index, thumb, ring tips
allegro             16  Allegro right hand                                          4 fingertips (sphere)
hexapod             18  PhantomX-like hexapod (robots/hexapod)                      6 feet
=================  ===  ==========================================================  ==========================

Free-flyer variants (``load(name, free_flyer=True)``, not names of their own): ``g1_arms`` (the G1 with a
floating pelvis, :func:`g1_floating`) and ``hexapod`` (the body on a free flyer, nq = 25, nv = 24,
:func:`hexapod_free_flyer`: the floating hexapod of :mod:`coop_ga.legged`).

Every ``q0`` lies strictly inside the joint limits and makes the primitive through the
end points well defined (except the hexapod's 4-foot sphere, see :func:`_hexapod`).

Conventions shared by the builders
----------------------------------
* World frame: z up.  Robots stand on the ground plane z = 0 unless stated otherwise.
* Humanoid (G1) hands are the ``{left,right}_rubber_hand`` frames: the fixed palm mount
  0.0415 m beyond the last wrist joint (``{left,right}_hand_palm_joint``), i.e. where the
  G1's rubber hand is attached.  The paper's "hand" end points are these.
* A G1 is modelled with a fixed pelvis; the 12 leg joints (and hand joints, if a G1
  variant has them) are locked at 0 (straight legs) with ``pinocchio.buildReducedModel``.
  With straight legs the foot soles are 0.792 m below the pelvis, so a G1 "standing" in
  a multi-robot scene has its pelvis at z = 0.792 m.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from .points import EndPoint, add_end_points
from .registry import register, register_free_flyer
from .system import ROBOTS_DIR, System, VisualSource, append_robots, prefixed

__all__: list[str] = ["G1_PELVIS_HEIGHT", "IIWA_Q0", "g1_floating", "g1_model", "hexapod_free_flyer"]

#: The paper's nominal iiwa configuration (§4.1) [rad].
IIWA_Q0 = np.array([0.0, -0.7854, 0.0, 1.3962, 0.0, 0.6109, 0.0])
#: Pelvis height of a G1 standing on straight legs (sole 0.792 m below the pelvis) [m].
G1_PELVIS_HEIGHT = 0.792


# ====================================================================== helpers
def _panda_arm():
    """example-robot-data ``panda`` with the two finger joints locked (7 DOF), and its q0."""
    import example_robot_data as erd
    import pinocchio as pin

    r = erd.load("panda")
    m = r.model
    locked = [m.getJointId(n) for n in ("panda_finger_joint1", "panda_finger_joint2")]
    arm = pin.buildReducedModel(m, locked, np.asarray(r.q0))
    return arm, np.asarray(r.q0)[:7].copy()


def _ring_placements(n: int, radius: float, start_deg: float = -90.0, facing_centre: bool = True):
    """Bases on a circle, ``360/n`` degrees apart counter-clockwise (seen from +z).

    ``facing_centre``: base x axes point at the centre (robots that reach along +x, e.g.
    the Franka); ``False``: x axes point away from it (robots that reach along −x at
    their q0, e.g. the iiwa at the paper's configuration).
    """
    import pinocchio as pin

    out = []
    for i in range(n):
        phi = np.deg2rad(start_deg + i * 360.0 / n)
        pos = radius * np.array([np.cos(phi), np.sin(phi), 0.0])
        out.append(pin.SE3(pin.utils.rotate("z", phi + (np.pi if facing_centre else 0.0)), pos))
    return out


def _placement(x: float, y: float, z: float, yaw: float = 0.0):
    import pinocchio as pin

    return pin.SE3(pin.utils.rotate("z", yaw), np.array([x, y, z], dtype=float))


def _erd_visual(loader: str, prefix: str = "") -> VisualSource:
    """Visual geometry of an example-robot-data robot (``loader``: a ``robots_loader`` class name):
    its URDF and the package folder that resolves ``package://example-robot-data/...``."""
    import os

    import example_robot_data as erd

    L = getattr(erd.robots_loader, loader)
    rel = os.path.join(L.path, L.urdf_subpath, L.urdf_filename)
    root = erd.getModelPath(rel)
    return VisualSource(
        urdf=os.path.join(root, rel), package_dirs=(os.path.normpath(os.path.join(root, "..", "..")),), prefix=prefix
    )


def _own_visual(robot: str, prefix: str = "") -> VisualSource:
    """Visual geometry of a URDF we ship (``robots/<robot>/<robot>.urdf``: boxes, cylinders, spheres)."""
    return VisualSource(urdf=ROBOTS_DIR / robot / f"{robot}.urdf", prefix=prefix)


# ---------------------------------------------------------------------- iiwa
def _iiwa_arm():
    import pinocchio as pin

    return pin.buildModelFromUrdf(str(ROBOTS_DIR / "iiwa14" / "iiwa14.urdf"))


# ---------------------------------------------------------------------- Unitree G1
#: G1 joints kept in the arm models (everything else is locked at 0).
_G1_KEEP = ("waist_", "_shoulder_", "_elbow_", "_wrist_")
#: One G1 arm at q0, left side, in joint order (shoulder pitch, roll, yaw, elbow, wrist roll,
#: pitch, yaw): arm reaching forward and slightly out, elbow 0.3 rad more open than the
#: URDF's right angle; the hand is then 0.30 m in front of the pelvis, 0.11 m above it.
_G1_ARM_Q0 = np.array([-0.3, 0.2, 0.0, 0.3, 0.0, 0.0, 0.0])


def _g1_mirror(a: np.ndarray) -> np.ndarray:
    """Right-arm angles mirroring left-arm angles ``a`` through the sagittal (xz) plane."""
    sp, sr, sy, el, wr, wp, wy = a
    return np.array([sp, -sr, -sy, el, -wr, wp, -wy])


def _g1_q0(left: np.ndarray = _G1_ARM_Q0, right: np.ndarray | None = None, waist=(0.0, 0.0, 0.0)) -> np.ndarray:
    """q of a waist + arms G1 (waist yaw/roll/pitch, left arm, right arm: Pinocchio's order)."""
    right = _g1_mirror(left) if right is None else right
    return np.concatenate([np.asarray(waist, float), left, right])


def g1_model():
    """Fixed-pelvis Unitree G1 (example-robot-data ``g1``) with waist + arms only: 17 DOF.

    example-robot-data's ``g1`` loader adds a free-flyer root; here the URDF it points to
    is loaded with ``pinocchio.buildModelFromUrdf`` (fixed base at the pelvis) and the 12
    leg joints (plus any hand joints) are locked at 0 (straight legs).
    q order: waist yaw, roll, pitch; left shoulder pitch, roll, yaw, elbow, wrist roll,
    pitch, yaw; the same for the right arm.
    """
    import os

    import example_robot_data as erd
    import pinocchio as pin

    L = erd.robots_loader.G1Loader
    rel = os.path.join(L.path, L.urdf_subpath, L.urdf_filename)
    full = pin.buildModelFromUrdf(os.path.join(erd.getModelPath(rel), rel))
    locked = [j for j in range(1, full.njoints) if not any(k in full.names[j] for k in _G1_KEEP)]
    m = pin.buildReducedModel(full, locked, pin.neutral(full))
    assert m.nq == 17, m.nq
    return m


# ---------------------------------------------------------------------- Allegro hand
#: Allegro tip frames: index, middle, ring, thumb.
_ALLEGRO_TIPS = ("link_3.0_tip", "link_7.0_tip", "link_11.0_tip", "link_15.0_tip")


def _allegro_model():
    import example_robot_data as erd

    return erd.load("allegro_right_hand").model


def _allegro_q(model, values: dict[str, float]) -> np.ndarray:
    """q from joint-name → angle (Pinocchio orders the hand's joints depth-first)."""
    q = np.zeros(model.nq)
    for name, v in values.items():
        q[model.idx_qs[model.getJointId(name)]] = v
    return q


def _named(indices: Iterable[int], values: Iterable[float]) -> dict[str, float]:
    return {f"joint_{i}.0": v for i, v in zip(indices, values)}


#: Franka Panda joint acceleration limits [rad/s²] (Franka Control Interface documentation,
#: "Limits for Panda": q̈_max = 15, 7.5, 10, 12.5, 15, 20, 20); URDFs carry no acceleration limits.
PANDA_ACCELERATION_LIMITS = (15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0)


def _with_panda_accelerations(system: System, prefixes: tuple[str, ...]) -> System:
    acc = {f"{p}panda_joint{j + 1}": a for p in prefixes for j, a in enumerate(PANDA_ACCELERATION_LIMITS)}
    return system.with_limits(acceleration=acc)


# ====================================================================== systems
@register("three_franka", "three Franka Panda arms 120° apart on a 0.8 m circle, facing the centre (Fig. 8)")
def _three_franka() -> System:
    arm, q0 = _panda_arm()
    parts = [(prefixed(arm, f"arm{i}_"), pl) for i, pl in enumerate(_ring_placements(3, 0.8))]
    model = append_robots(parts)
    system = System(
        name="three_franka",
        model=model,
        end_frames=tuple(f"arm{i}_panda_hand_tcp" for i in range(3)),
        q0=np.tile(q0, 3),
        description="three Franka Panda arms (fingers locked) 120° apart on a 0.8 m circle, facing the centre",
        labels=("arm0 tcp", "arm1 tcp", "arm2 tcp"),
        visuals=tuple(_erd_visual("PandaLoader", f"arm{i}_") for i in range(3)),
    )
    return _with_panda_accelerations(system, ("arm0_", "arm1_", "arm2_"))


#: Base ring radius of three_iiwa14: the flange at q0 is 0.7507 m in front of the base,
#: so the three flanges lie on a circle of radius 1.15 − 0.7507 = 0.399 m.
IIWA_RING_RADIUS = 1.15


@register("three_iiwa14", "three KUKA LBR iiwa 14 120° apart on a 1.15 m circle, flanges on a 0.40 m circle (§4.1)")
def _three_iiwa14() -> System:
    arm = _iiwa_arm()
    # At IIWA_Q0 the iiwa reaches toward −x of its base (flange at (−0.7507, 0, 0.4276)),
    # so the base x axes point away from the centre.  Counter-clockwise order from −90°:
    # the circle through the flanges (in end-frame order) has normal +z.
    placements = _ring_placements(3, IIWA_RING_RADIUS, facing_centre=False)
    parts = [(prefixed(arm, f"arm{i}_"), pl) for i, pl in enumerate(placements)]
    return System(
        name="three_iiwa14",
        model=append_robots(parts),
        end_frames=tuple(f"arm{i}_iiwa_flange" for i in range(3)),
        q0=np.tile(IIWA_Q0, 3),
        description=(
            "three KUKA LBR iiwa 14 R820 (robots/iiwa14) 120° apart on a 1.15 m circle, reaching to the centre; "
            "at q0 (the paper's [0, −0.7854, 0, 1.3962, 0, 0.6109, 0] per arm) the flanges lie on a horizontal "
            "0.40 m circle at z = 0.43 m, counter-clockwise (circle normal +z)"
        ),
        labels=("arm0 flange", "arm1 flange", "arm2 flange"),
        visuals=tuple(_own_visual("iiwa14", f"arm{i}_") for i in range(3)),
    )


@register("g1_arms", "Unitree G1 with fixed pelvis: waist (3) + two arms (7 each); end points the two hands")
def _g1_arms() -> System:
    return System(
        name="g1_arms",
        model=g1_model(),
        end_frames=("right_rubber_hand", "left_rubber_hand"),
        q0=_g1_q0(),
        description=(
            "Unitree G1 (example-robot-data g1) with a fixed pelvis at the origin and the legs locked straight: "
            "waist yaw/roll/pitch + 2 × 7 arm joints.  End points: the right and left hand mounts "
            "(right/left_rubber_hand), in that order, so the point pair/line points along +y like the unit "
            "primitive (left → right would be its antipode, where the minimal rotation jumps by a half-turn).  Both wrist chains contain the 3 waist joints.  q0: arms forward, "
            "hands 0.30 m in front of the pelvis and 0.36 m apart"
        ),
        labels=("right hand", "left hand"),
        visuals=(_erd_visual("G1Loader"),),
    )


@register_free_flyer("g1_arms")
def g1_floating() -> System:
    """Unitree G1 with a floating pelvis (a free flyer) + waist + arms, legs locked straight: nq = 24, nv = 23.

    The free-flyer version of ``load("g1_arms")``: the same URDF loaded with a ``JointModelFreeFlyer`` root
    (``root_joint``, the pelvis pose: q[0:3] position [m], q[3:7] quaternion x y z w; q̇[0:6] its LOCAL
    [v; ω]), the 12 leg joints (and any hand joints) locked at 0, then the 17 joints of ``g1_arms`` in the same
    order.  q0: the pelvis at the origin, unrotated, and ``g1_arms``' q0, so the hands start where they do
    there.  End frames: right and left hand, as in ``g1_arms``.  ``load("g1_arms", free_flyer=True)`` (not a
    registered name of its own: the registered systems are fixed-base).
    """
    import os

    import example_robot_data as erd
    import pinocchio as pin

    L = erd.robots_loader.G1Loader
    rel = os.path.join(L.path, L.urdf_subpath, L.urdf_filename)
    full = pin.buildModelFromUrdf(os.path.join(erd.getModelPath(rel), rel), pin.JointModelFreeFlyer())
    locked = [j for j in range(2, full.njoints) if not any(k in full.names[j] for k in _G1_KEEP)]
    m = pin.buildReducedModel(full, locked, pin.neutral(full))
    assert (m.nq, m.nv) == (24, 23), (m.nq, m.nv)
    return System(
        name="g1_floating",
        model=m,
        end_frames=("right_rubber_hand", "left_rubber_hand"),
        q0=np.concatenate([[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0], _g1_q0()]),
        description="Unitree G1 with a free-flyer pelvis (floating base), waist + 2 × 7 arm joints, legs locked",
        labels=("right hand", "left hand"),
        visuals=(_erd_visual("G1Loader"),),
    )


#: Offset of the chest point in the torso_link frame [m]: 0.15 m in front of the waist
#: pitch axis, 0.20 m above it (between the waist and the shoulders, 0.29 m above the pelvis).
G1_CHEST_OFFSET = (0.15, 0.0, 0.20)


@register("g1_torso_arms", "Unitree G1 waist + arms; end points a chest point, right hand, left hand (Fig. 9)")
def _g1_torso_arms() -> System:
    m = add_end_points(g1_model(), [EndPoint("torso_link", G1_CHEST_OFFSET, name="chest_point")])
    return System(
        name="g1_torso_arms",
        model=m,
        end_frames=("chest_point", "right_rubber_hand", "left_rubber_hand"),
        q0=_g1_q0(),
        description=(
            "as g1_arms plus a third end point 'chest_point', an added frame on torso_link (moved by the 3 "
            f"waist joints) at {G1_CHEST_OFFSET} m in the torso frame, i.e. in front of the chest.  Order chest, "
            "left hand, right hand: the circle through them faces forward and up (normal ≈ (+0.6, 0, +0.8) at q0)"
        ),
        labels=("chest", "right hand", "left hand"),
        visuals=(_erd_visual("G1Loader"),),
    )


#: Franka q0 in franka_and_g1: arm in its xz plane, tcp 0.47 m in front of the base and
#: 0.73 m high (just below the G1's hands), the tool axis horizontal toward the G1.
_FRANKA_TO_G1_Q0 = np.array([0.0, -0.7, 0.0, -2.4, 0.0, 3.2, 0.7854])


@register("franka_and_g1", "a Franka Panda facing a Unitree G1 1.0 m away (Fig. 10): Franka tcp + G1 hands")
def _franka_and_g1() -> System:
    arm, _ = _panda_arm()
    g1 = g1_model()
    model = append_robots(
        [
            (prefixed(arm, "franka_"), _placement(0.0, 0.0, 0.0)),
            (prefixed(g1, "g1_"), _placement(1.0, 0.0, G1_PELVIS_HEIGHT, yaw=np.pi)),
        ]
    )
    system = System(
        name="franka_and_g1",
        model=model,
        end_frames=("franka_panda_hand_tcp", "g1_left_rubber_hand", "g1_right_rubber_hand"),
        q0=np.concatenate([_FRANKA_TO_G1_Q0, _g1_q0()]),
        description=(
            "a Franka Panda (fingers locked) at the origin facing +x and a standing Unitree G1 (waist + arms, "
            f"pelvis at (1.0, 0, {G1_PELVIS_HEIGHT}) m) facing −x.  End points: Franka tcp, G1 left hand (world "
            "−y side), G1 right hand; the circle through them leans toward the Franka "
            "(normal ≈ (−0.6, 0, +0.8) at q0)"
        ),
        labels=("franka tcp", "g1 left hand", "g1 right hand"),
        visuals=(_erd_visual("PandaLoader", "franka_"), _erd_visual("G1Loader", "g1_")),
    )
    return _with_panda_accelerations(system, ("franka_",))


#: two_g1 arm postures: each G1 lowers its left hand and raises its right hand, so the four
#: hands span a tetrahedron (two G1s with level hands would put all four in one plane).
_G1_LEFT_LOW = np.array([0.05, 0.2, 0.0, 0.3, 0.0, 0.0, 0.0])
_G1_RIGHT_HIGH = _g1_mirror(np.array([-0.75, 0.2, 0.0, 0.3, 0.0, 0.0, 0.0]))


@register("two_g1", "two Unitree G1s (waist + arms) facing each other 1.0 m apart; the four hands span a sphere")
def _two_g1() -> System:
    g1 = g1_model()
    model = append_robots(
        [
            (prefixed(g1, "a_"), _placement(-0.5, 0.0, G1_PELVIS_HEIGHT)),
            (prefixed(g1, "b_"), _placement(0.5, 0.0, G1_PELVIS_HEIGHT, yaw=np.pi)),
        ]
    )
    qg = _g1_q0(_G1_LEFT_LOW, _G1_RIGHT_HIGH)
    return System(
        name="two_g1",
        model=model,
        end_frames=("a_left_rubber_hand", "a_right_rubber_hand", "b_left_rubber_hand", "b_right_rubber_hand"),
        q0=np.tile(qg, 2),
        description=(
            "two standing Unitree G1s (waist + arms each, legs locked), 'a' at x = −0.5 m facing +x and 'b' at "
            "x = +0.5 m facing −x.  End points: a's left and right hand, b's left and right hand.  At q0 each G1 "
            "lowers its left hand and raises its right one, so the four hands are far from coplanar (sphere)"
        ),
        labels=("a left hand", "a right hand", "b left hand", "b right hand"),
        visuals=(_erd_visual("G1Loader", "a_"), _erd_visual("G1Loader", "b_")),
    )


#: Allegro finger angles (joints 0–3 index, 4–7 middle, 8–11 ring, 12–15 thumb) of a ball
#: grasp: the four tips lie on a 4.4 cm sphere in front of the palm, far from coplanar.
_ALLEGRO_Q0 = {
    **_named((0, 1, 2, 3), (0.0, 0.98, 0.72, 0.6)),  # index
    **_named((4, 5, 6, 7), (-0.03, 0.42, 0.74, 0.75)),  # middle: less curled, its tip is the "top" of the ball
    **_named((8, 9, 10, 11), (0.11, 0.92, 0.82, 0.68)),  # ring
    **_named((12, 13, 14, 15), (0.95, 0.5, 1.2, 0.92)),  # thumb: opposing, below
}


@register(
    "three_finger_hand", "Allegro right hand with the middle finger locked straight (12 DOF): index, thumb, ring tips"
)
def _three_finger_hand() -> System:
    import pinocchio as pin

    full = _allegro_model()
    locked = [full.getJointId(f"joint_{i}.0") for i in (4, 5, 6, 7)]
    hand = pin.buildReducedModel(full, locked, pin.neutral(full))
    q0 = _allegro_q(hand, {k: v for k, v in _ALLEGRO_Q0.items() if k not in {f"joint_{i}.0" for i in (4, 5, 6, 7)}})
    return System(
        name="three_finger_hand",
        model=hand,
        end_frames=("link_3.0_tip", "link_15.0_tip", "link_11.0_tip"),
        q0=q0,
        description=(
            "Allegro right hand (example-robot-data allegro_right_hand) with the middle finger locked straight "
            "(robots/three_finger_hand/README.md): index, thumb, ring (12 DOF).  q0: the index, ring and thumb "
            "angles of the allegro ball grasp; the three tips face each other in front of the palm"
        ),
        labels=("index tip", "thumb tip", "ring tip"),
        visuals=(_erd_visual("AllegroRightHandLoader"),),
    )


@register("allegro", "Allegro right hand (16 DOF); the four fingertips span a sphere")
def _allegro() -> System:
    m = _allegro_model()
    return System(
        name="allegro",
        model=m,
        end_frames=_ALLEGRO_TIPS,
        q0=_allegro_q(m, _ALLEGRO_Q0),
        description=(
            "Allegro right hand (example-robot-data allegro_right_hand), 16 DOF, palm frame = world.  End points: "
            "index, middle, ring and thumb tips.  q0: a ball grasp, the four tips on a 4.4 cm sphere centred "
            "8 cm in front of the palm (far from coplanar)"
        ),
        labels=("index tip", "middle tip", "ring tip", "thumb tip"),
        visuals=(_erd_visual("AllegroRightHandLoader"),),
    )


#: hexapod stand pose per leg (coxa, femur, tibia) [rad] (robots/hexapod/README.md).
HEXAPOD_STAND = np.array([0.0, 0.3, -1.4])
#: feet as two tripods (lf, lr, rm) and (rf, lm, rr), each counter-clockwise seen from +z.
_HEXAPOD_FEET = ("lf", "lr", "rm", "rf", "lm", "rr")


@register("hexapod", "PhantomX-like hexapod (robots/hexapod), 18 DOF, fixed body; end points the six feet")
def _hexapod() -> System:
    """The hexapod at its stand pose.

    At the stand pose all six feet are on the ground plane z = −0.0993 m: any three feet
    give a well-defined (horizontal) circle or plane, but **four feet are coplanar, so the
    sphere through them is degenerate at q0** (it is well defined only when a foot is
    lifted, e.g. in swing).
    """
    import pinocchio as pin

    m = pin.buildModelFromUrdf(str(ROBOTS_DIR / "hexapod" / "hexapod.urdf"))
    return System(
        name="hexapod",
        model=m,
        end_frames=tuple(f"{leg}_foot" for leg in _HEXAPOD_FEET),
        q0=np.tile(HEXAPOD_STAND, 6),
        description=(
            "PhantomX-like hexapod (robots/hexapod/hexapod.urdf), body fixed at the origin, 18 DOF.  End points: "
            "the feet as the two tripods (lf, lr, rm) and (rf, lm, rr), each counter-clockwise from above (circle "
            "through the first three: normal +z).  q0 = stand pose (coxa 0, femur 0.3, tibia −1.4): all feet on "
            "the plane z = −0.0993 m, so a 4-foot sphere is DEGENERATE at q0 (lift a foot to define one)"
        ),
        labels=tuple(f"{leg} foot" for leg in _HEXAPOD_FEET),
        visuals=(_own_visual("hexapod"),),
    )


#: Body height [m] of the floating hexapod's q0 (``load("hexapod", free_flyer=True)``): the stand pose's feet on
#: z = 0 (0.133 sin 1.1 − 0.065 sin 0.3, the tibia's drop minus the femur's rise; :func:`hexapod_free_flyer`
#: checks it against Pinocchio's FK).
HEXAPOD_STAND_HEIGHT = 0.133 * np.sin(1.1) - 0.065 * np.sin(0.3)


@register_free_flyer("hexapod")
def hexapod_free_flyer() -> System:
    """The floating hexapod: its body on a real free flyer, nq = 25, nv = 24 (``load("hexapod", free_flyer=True)``,
    not a registered name of its own).

    The hexapod URDF loaded with a ``JointModelFreeFlyer`` root (``root_joint``: the body pose, q[0:3] position
    [m] of ``base_link`` in the world, q[3:7] unit quaternion x y z w (world ← body), no position limits;
    q̇[0:6] its LOCAL [v; ω] [m/s, rad/s] in the body frame), then the 18 leg joints in URDF order (lf, lm, lr, rf,
    rm, rr; coxa, femur, tibia).  End frames: the feet, as ``hexapod`` (the two tripods), world frame.  q0: the
    stand pose with the body at :data:`HEXAPOD_STAND_HEIGHT` (feet on z = 0; checked here against Pinocchio's FK,
    so a changed URDF cannot silently move the stand height).  The walking code (:mod:`coop_ga.legged`) converts
    with ``BodyState.free_flyer_q`` / ``BodyState.from_free_flyer_q``.  Kinematics only: nothing in the model
    keeps a foot on the ground (the contact roll-out ``coop_ga.legged.dynamics.contact_rollout`` and the MuJoCo
    scene ``coop_ga.sim.hexapod_scene`` do).
    """
    import pinocchio as pin

    legs = pin.buildModelFromUrdf(str(ROBOTS_DIR / "hexapod" / "hexapod.urdf"))
    d = legs.createData()
    pin.framesForwardKinematics(legs, d, np.tile(HEXAPOD_STAND, 6))
    drop = -float(d.oMf[legs.getFrameId("lf_foot")].translation[2])
    if abs(drop - HEXAPOD_STAND_HEIGHT) > 1e-12:  # the URDF changed: the stand height must follow it
        raise ValueError(
            f"hexapod stand pose: feet {drop} m below the body, HEXAPOD_STAND_HEIGHT says {HEXAPOD_STAND_HEIGHT}"
        )
    m = pin.buildModelFromUrdf(str(ROBOTS_DIR / "hexapod" / "hexapod.urdf"), pin.JointModelFreeFlyer())
    q0 = np.concatenate([[0.0, 0.0, HEXAPOD_STAND_HEIGHT, 0.0, 0.0, 0.0, 1.0], np.tile(HEXAPOD_STAND, 6)])
    return System(
        name="hexapod_free_flyer",
        model=m,
        end_frames=tuple(f"{leg}_foot" for leg in _HEXAPOD_FEET),
        q0=q0,
        description=(
            "the hexapod (robots/hexapod/hexapod.urdf) with its body on a free flyer (root_joint: position, "
            "quaternion x y z w) + 18 leg joints in URDF order, nq = 25, nv = 24.  End points: the six feet (two "
            f"tripods, as 'hexapod'), world frame.  q0: stand pose, body at z = {HEXAPOD_STAND_HEIGHT} m, feet on z = 0"
        ),
        labels=tuple(f"{leg} foot" for leg in _HEXAPOD_FEET),
        visuals=(_own_visual("hexapod"),),
    )
