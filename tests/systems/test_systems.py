"""The systems registry and library: layouts, shared/appended joints, bad input, from_urdf, CLI."""

from __future__ import annotations

import subprocess
import sys
import warnings

import numpy as np
import pinocchio as pin
import pytest

import coop_ga as cg
from coop_ga import systems
from coop_ga.errors import (
    InvalidInputError,
    JointLimitWarning,
    NonFiniteError,
    UnknownNameError,
    UnsupportedJointError,
)
from coop_ga.kinematics import KinematicTree
from coop_ga.systems import ROBOTS_DIR
from coop_ga.systems.library import IIWA_Q0

IIWA_URDF = ROBOTS_DIR / "iiwa14" / "iiwa14.urdf"
HEXAPOD_URDF = ROBOTS_DIR / "hexapod" / "hexapod.urdf"

#: DOF and end points of every paper system (the issue's table).
TABLE = {
    "three_franka": (21, 3),
    "three_iiwa14": (21, 3),
    "g1_arms": (17, 2),
    "g1_torso_arms": (17, 3),
    "franka_and_g1": (24, 3),
    "two_g1": (34, 4),
    "three_finger_hand": (12, 3),
    "allegro": (16, 4),
    "hexapod": (18, 6),
}


def _oMf(model, q, frame):
    d = model.createData()
    pin.framesForwardKinematics(model, d, q)
    return d.oMf[model.getFrameId(frame)]


@pytest.mark.parametrize("name", list(TABLE))
def test_table_dof_end_points_description(name):
    s = systems.load(name)
    nq, k = TABLE[name]
    assert (s.nq, s.n_chains) == (nq, k)
    assert s.model.nq == s.model.nv == nq
    assert len(s.labels) == k and len(set(s.labels)) == k
    assert len(s.description) > 40
    assert systems.load(name) is s  # cached


# ---------------------------------------------------------------------- layouts at q0
def test_three_iiwa14_layout():
    s = systems.load("three_iiwa14")
    np.testing.assert_array_equal(s.q0, np.tile(IIWA_Q0, 3))
    P = s.end_points(s.q0)
    X = cg.circle(*P)
    assert 0.35 <= cg.radius(X) <= 0.5
    np.testing.assert_allclose(np.asarray(cg.normal(X), float), [0, 0, 1], atol=1e-9)  # counter-clockwise
    np.testing.assert_allclose(np.asarray(cg.center(X), float)[:2], 0.0, atol=1e-9)
    assert cg.well_definedness("circle", P) > 0.99
    # each flange is between its base and the centre, tool axis pointing at the centre
    for i, f in enumerate(s.end_frames):
        base = _oMf(s.model, s.q0, f"arm{i}_iiwa_link_0").translation
        M = _oMf(s.model, s.q0, f)
        assert np.linalg.norm(M.translation[:2]) < np.linalg.norm(base[:2])
        tool = M.rotation[:, 2]
        assert tool[:2] @ (-M.translation[:2]) / np.linalg.norm(M.translation[:2]) > 0.99


@pytest.mark.parametrize(
    "name,kind,threshold",
    [
        ("three_franka", "circle", 0.9),
        ("three_iiwa14", "circle", 0.9),
        ("g1_arms", "line", 0.3),  # metres: hand distance
        ("g1_torso_arms", "circle", 0.5),
        ("franka_and_g1", "circle", 0.5),
        ("two_g1", "sphere", 0.3),
        ("three_finger_hand", "circle", 0.5),
        ("allegro", "sphere", 0.5),
        ("hexapod", "circle", 0.5),
    ],
)
def test_primitive_well_defined_at_q0(name, kind, threshold):
    s = systems.load(name)
    n = cg.geometry.primitives.N_POINTS[kind]
    P = s.end_points(s.q0)[:n]
    assert cg.well_definedness(kind, P) > threshold


def test_circle_orientations_documented():
    """The normals the system descriptions promise."""

    def normal(name):
        s = systems.load(name)
        return np.asarray(cg.normal(cg.circle(*s.end_points(s.q0)[:3])), float)

    assert normal("three_franka")[2] > 0.99
    n = normal("g1_torso_arms")  # forward and up
    assert n[0] > 0.5 and n[2] > 0.5 and abs(n[1]) < 1e-9
    n = normal("franka_and_g1")  # up, leaning toward the Franka (−x)
    assert n[0] < -0.3 and n[2] > 0.5
    assert normal("hexapod")[2] > 0.99


def test_hexapod_stand_pose_feet_coplanar():
    """Documented limitation: at the stand pose the 4-foot sphere is degenerate."""
    s = systems.load("hexapod")
    np.testing.assert_array_equal(s.q0, np.tile([0.0, 0.3, -1.4], 6))
    P = s.end_points(s.q0)
    np.testing.assert_allclose(P[:, 2], -0.0993, atol=1e-4)
    assert cg.well_definedness("sphere", P[:4]) < 1e-9
    assert "DEGENERATE" in s.description
    readme = (ROBOTS_DIR / "hexapod" / "README.md").read_text()
    assert "sphere" in readme.lower() and "coplanar" in readme.lower()
    # lifting one foot makes it well defined
    q = s.q0.copy()
    q[s.joint_names.index("rf_femur_joint")] += 0.6
    assert cg.well_definedness("sphere", s.end_points(q)[:4]) > 0.1


def test_g1_systems_face_each_other():
    s = systems.load("franka_and_g1")
    tcp, gl, gr = s.end_points(s.q0)
    assert 0.3 < tcp[0] < gl[0] < 1.0 and gl[0] == pytest.approx(gr[0])
    assert gl[1] < 0 < gr[1]  # the G1 faces −x: its left hand is on the world −y side
    s2 = systems.load("two_g1")
    al, ar, bl, br = s2.end_points(s2.q0)
    assert al[0] < 0 < bl[0] and ar[0] < 0 < br[0]
    assert al[1] > 0 > ar[1] and bl[1] < 0 < br[1]
    assert ar[2] > al[2] + 0.1 and br[2] > bl[2] + 0.1  # right hands raised, left hands lowered
    assert 0.15 < bl[0] - al[0] < 1.0


def test_three_finger_hand_follows_readme():
    s = systems.load("three_finger_hand")
    assert s.joint_names == [f"joint_{i}.0" for i in (0, 1, 2, 3, 12, 13, 14, 15, 8, 9, 10, 11)]
    assert s.q_lower[4] == pytest.approx(0.263) and s.q0[4] > 0.263
    assert s.end_frames == ("link_3.0_tip", "link_15.0_tip", "link_11.0_tip")


# ---------------------------------------------------------------------- shared / appended joints
def test_g1_wrist_chains_share_the_waist():
    s = systems.load("g1_arms")
    right, left = s.chain_joints()  # end points ordered right → left (line along +e2)
    waist = ["waist_yaw_joint", "waist_roll_joint", "waist_pitch_joint"]
    assert left[:3] == waist and right[:3] == waist
    assert len(left) == len(right) == 10
    assert set(left[3:]).isdisjoint(right[3:])
    assert s.nq == 17 and s.joint_names.count("waist_yaw_joint") == 1
    cols_r, cols_l = map(set, s.tree.joint_columns)
    assert cols_l & cols_r == {0, 1, 2} and cols_l | cols_r == set(range(17))
    # a waist motion moves both hands, an arm motion only its own hand
    q = s.q0.copy()
    q[0] += 0.1
    d = np.linalg.norm(s.end_points(q) - s.end_points(s.q0), axis=1)
    assert np.all(d > 1e-3)
    q = s.q0.copy()
    q[3] += 0.1  # left shoulder pitch
    d = np.linalg.norm(s.end_points(q) - s.end_points(s.q0), axis=1)
    assert d[1] > 1e-3 and d[0] == 0.0  # end point 1 is the left hand
    # the torso point of g1_torso_arms hangs on the waist only
    t = systems.load("g1_torso_arms")
    assert t.chain_joints()[0] == waist


@pytest.mark.parametrize(
    "name,robots",
    [
        ("three_franka", ["arm0_", "arm1_", "arm2_"]),
        ("three_iiwa14", ["arm0_", "arm1_", "arm2_"]),
        ("two_g1", ["a_", "a_", "b_", "b_"]),
        ("franka_and_g1", ["franka_", "g1_", "g1_"]),
    ],
)
def test_appended_copies_are_distinct(name, robots):
    s = systems.load(name)
    m = s.model
    jn = list(m.names)[1:]
    assert len(set(jn)) == len(jn)
    ids = [m.getJointId(n) for n in jn]
    assert len(set(ids)) == len(ids) == m.njoints - 1
    idx = [int(m.idx_qs[j]) for j in ids]
    assert sorted(idx) == list(range(s.nq))
    assert len({f.name for f in m.frames}) == len(m.frames)
    for chain, prefix, frame in zip(s.chain_joints(), robots, s.end_frames):
        assert frame.startswith(prefix)
        assert chain and all(j.startswith(prefix) for j in chain)
    # moving the joints of one chain alone moves only that chain's end point
    rng = np.random.default_rng(0)
    q = s.random_q(rng, 0.5)
    p0 = s.end_points(q)
    for i, cols in enumerate(s.tree.joint_columns):
        others = {c for k, cc in enumerate(s.tree.joint_columns) if k != i for c in cc}
        own = [c for c in cols if c not in others]
        assert own
        dq = np.zeros(s.nq)
        dq[own] = 0.05
        d = np.linalg.norm(s.end_points(q + dq) - p0, axis=1)
        assert d[i] > 1e-4
        assert np.all(np.delete(d, i) == 0.0)
    # joints of one robot never move another robot's end points
    for prefix in set(robots):
        dq = np.array([0.05 if n.startswith(prefix) else 0.0 for n in s.joint_names])
        d = np.linalg.norm(s.end_points(q + dq) - p0, axis=1)
        mine = np.array([r == prefix for r in robots])
        assert np.all(d[mine] > 1e-4) and np.all(d[~mine] == 0.0)


# ---------------------------------------------------------------------- bad input
def test_unknown_system_lists_available():
    with pytest.raises(UnknownNameError) as e:
        systems.load("three_frankas")
    for n in systems.names():
        assert n in str(e.value)


def test_unknown_frame_lists_frames():
    s = systems.load("g1_arms")
    with pytest.raises(UnknownNameError) as e:
        KinematicTree(s.model, ["left_hand"])
    assert "left_rubber_hand" in str(e.value) and "torso_link" in str(e.value)
    with pytest.raises(InvalidInputError):
        KinematicTree(s.model, [])


@pytest.mark.parametrize("name", ["g1_arms", "allegro"])
def test_wrong_size_and_nonfinite(name):
    s = systems.load(name)
    for bad in (np.zeros(s.nq + 1), np.zeros(s.nq - 1), np.zeros((s.nq, 1)), []):
        with pytest.raises(InvalidInputError, match=str(s.nq)):
            s.end_points(bad)
        with pytest.raises(InvalidInputError, match=str(s.nq)):
            s.tree.frame_motors(bad)
        with pytest.raises(InvalidInputError, match=str(s.nq)):
            s.tree.geometric_jacobians(bad)
    for v in (np.nan, np.inf, -np.inf):
        q = s.q0.copy()
        q[3] = v
        with pytest.raises(NonFiniteError, match="3"):
            s.end_points(q)
        with pytest.raises(NonFiniteError):
            s.tree.point_jacobians(q)
        with pytest.raises(NonFiniteError):
            s.frame_motors(q)


def test_outside_limits_warns_and_is_not_clipped():
    s = systems.load("three_iiwa14")
    q = s.q0.copy()
    q[1] = s.q_upper[1] + 0.4  # arm0 joint 2 beyond its limit
    with pytest.warns(JointLimitWarning, match="arm0_iiwa_joint_2"):
        p = s.end_points(q)
    np.testing.assert_allclose(p[0], _oMf(s.model, q, s.end_frames[0]).translation, atol=1e-12)
    np.testing.assert_array_equal(p, s.tree.end_points_array(q))
    clipped = s.tree.end_points_array(np.clip(q, s.q_lower, s.q_upper))
    assert np.linalg.norm(p[0] - clipped[0]) > 0.05
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        s.end_points(s.q0)  # no warning inside the limits


def test_free_flyer_model_is_accepted():
    import example_robot_data as erd

    model = erd.load("g1").model  # example-robot-data adds a FreeFlyer root
    assert model.nq == model.nv + 1
    assert KinematicTree(model, ["left_rubber_hand"]).geometric_jacobians(pin.neutral(model))[0].shape == (7, model.nv)
    s = systems.from_model(model, ["left_rubber_hand"])
    assert (s.nq, s.nv) == (model.nq, model.nv)


def test_unsupported_joint_type_is_rejected():
    m = pin.Model()
    j = m.addJoint(0, pin.JointModelSpherical(), pin.SE3.Identity(), "ball")
    m.addFrame(pin.Frame("tip", j, 0, pin.SE3(np.eye(3), np.array([0.0, 0.0, 1.0])), pin.FrameType.OP_FRAME))
    with pytest.raises(UnsupportedJointError):
        KinematicTree(m, ["tip"])


# ---------------------------------------------------------------------- from_urdf
def test_from_urdf_missing_path():
    with pytest.raises(InvalidInputError, match="not found"):
        systems.from_urdf(ROBOTS_DIR / "nope" / "nope.urdf", ["tip"])


def test_from_urdf_iiwa_matches_pinocchio():
    s = systems.from_urdf(IIWA_URDF, ["iiwa_flange"])
    assert s.name == "iiwa14" and s.nq == 7
    assert s.joint_names == [f"iiwa_joint_{i}" for i in range(1, 8)]
    ref = pin.buildModelFromUrdf(str(IIWA_URDF))
    np.testing.assert_allclose(s.end_points(IIWA_Q0)[0], [-0.7507, 0.0, 0.4276], atol=1e-4)
    rng = np.random.default_rng(1)
    for _ in range(20):
        q = s.random_q(rng)
        M = _oMf(ref, q, "iiwa_flange")
        np.testing.assert_allclose(s.end_points(q)[0], M.translation, atol=1e-12)
    with pytest.raises(UnknownNameError, match="iiwa_flange"):
        systems.from_urdf(IIWA_URDF, ["flange"])


def test_from_urdf_with_locked_joints():
    s = systems.from_urdf(
        IIWA_URDF, ["iiwa_flange"], locked_joints=["iiwa_joint_7", "iiwa_joint_3"], name="iiwa5", q_lock=IIWA_Q0
    )
    assert s.name == "iiwa5" and s.nq == 5
    assert "iiwa_joint_7" not in s.joint_names and "iiwa_joint_3" not in s.joint_names
    full = pin.buildModelFromUrdf(str(IIWA_URDF))
    q5 = IIWA_Q0[[0, 1, 3, 4, 5]] + 0.1
    qf = IIWA_Q0.copy()
    qf[[0, 1, 3, 4, 5]] = q5
    np.testing.assert_allclose(s.end_points(q5)[0], _oMf(full, qf, "iiwa_flange").translation, atol=1e-12)
    with pytest.raises(UnknownNameError, match="iiwa_joint_1"):
        systems.from_urdf(IIWA_URDF, ["iiwa_flange"], locked_joints=["joint_7"])


def test_from_urdf_hexapod_legs_and_default_q0():
    legs = ["lf", "lm", "lr", "rf", "rm", "rr"]
    locked = [f"{leg}_{j}_joint" for leg in ("lm", "rm") for j in ("coxa", "femur", "tibia")]
    s = systems.from_urdf(HEXAPOD_URDF, [f"{leg}_foot" for leg in legs if leg[1] != "m"], locked_joints=locked)
    assert s.nq == 12
    assert np.all(s.q0 >= s.q_lower) and np.all(s.q0 <= s.q_upper)
    P = s.end_points(s.q0)
    np.testing.assert_allclose(P[:, 2], 0.0, atol=1e-12)  # q = 0: straight horizontal legs
    np.testing.assert_allclose(np.linalg.norm(P[0, :2]), np.hypot(0.2968, 0.2368), atol=2e-4)


def test_from_model_default_q0_moves_into_limits():
    import example_robot_data as erd

    full = erd.load("allegro_right_hand").model
    s = systems.from_model(full, ["link_15.0_tip"], name="thumb")
    i = s.joint_names.index("joint_12.0")
    assert s.q_lower[i] < s.q0[i] < s.q_upper[i]  # neutral (0) is below the 0.263 lower limit


# ---------------------------------------------------------------------- CLI
def test_cli_lists_every_system_with_dof():
    out = subprocess.run(
        [sys.executable, "-m", "coop_ga.systems"], capture_output=True, text=True, timeout=120, check=True
    ).stdout
    lines = {ln.split()[0]: ln.split() for ln in out.splitlines()[1:] if ln.strip()}
    assert set(lines) == set(systems.names())
    for name, (nq, k) in TABLE.items():
        assert int(lines[name][1]) == nq
        assert len("".join(lines[name][2:]).split(",")) == k
