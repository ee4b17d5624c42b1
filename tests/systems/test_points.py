"""End points anywhere on the body (``EndPoint``, paper §5.4): Fig. 9's chest point three ways against Pinocchio,
a forearm point's Jacobian against finite differences and Pinocchio's frame Jacobian, points on locked links,
oriented points, and bad points refused."""

from __future__ import annotations

import os

import numpy as np
import pinocchio as pin
import pytest

import coop_ga as cg
from coop_ga import systems
from coop_ga.errors import InvalidInputError, NonFiniteError, UnknownNameError
from coop_ga.systems import ROBOTS_DIR, EndPoint, add_end_points, from_urdf
from coop_ga.systems.library import G1_CHEST_OFFSET, g1_model

HEXAPOD = ROBOTS_DIR / "hexapod" / "hexapod.urdf"
CHEST = EndPoint("torso_link", G1_CHEST_OFFSET, name="chest_point")
HANDS = ("right_rubber_hand", "left_rubber_hand")


def _g1_urdf() -> str:
    import example_robot_data as erd

    L = erd.robots_loader.G1Loader
    rel = os.path.join(L.path, L.urdf_subpath, L.urdf_filename)
    return os.path.join(erd.getModelPath(rel), rel)


def test_fig9_chest_point_three_ways_equals_pinocchio() -> None:
    ref = systems.load("g1_torso_arms")
    from_arms = systems.load("g1_arms").with_end_frames([CHEST, *HANDS], name="g1_chest")
    groups = {"waist": "waist_.*", "arms": r"(left|right)_(shoulder|elbow|wrist)_.*"}
    from_file = from_urdf(_g1_urdf(), [CHEST, *HANDS], groups=groups, active=["waist", "arms"], q0=ref.q0)
    assert from_arms.name == "g1_chest" and from_arms.labels == ("chest_point", *HANDS)
    assert from_file.joint_names == ref.joint_names
    model = g1_model()  # the plain waist + arms model: the chest is torso_link's pose applied to the offset
    data = model.createData()
    torso = model.getFrameId("torso_link", pin.FrameType.BODY)
    rng = np.random.default_rng(9)
    worst = 0.0
    for _ in range(20):
        q = ref.random_q(rng)
        pin.framesForwardKinematics(model, data, q)
        chest = data.oMf[torso].act(np.array(G1_CHEST_OFFSET))
        p = ref.end_points(q)
        worst = max(worst, np.abs(p[0] - chest).max())
        worst = max(worst, np.abs(from_arms.end_points(q) - p).max(), np.abs(from_file.end_points(q) - p).max())
    assert worst < 1e-12, worst


def test_forearm_point_jacobian_against_finite_differences_and_pinocchio() -> None:
    forearm = EndPoint("left_elbow_link", (0.08, 0.01, -0.02), name="left_forearm")
    s = systems.load("g1_arms").with_end_frames([forearm, "right_rubber_hand"])
    fid = s.model.getFrameId("left_forearm")
    data = s.model.createData()
    rng = np.random.default_rng(4)
    worst_fd = worst_pin = 0.0
    for _ in range(5):
        q = s.random_q(rng, 0.8)
        J = np.asarray(s.tree.euclidean_point_jacobians(q)[0], dtype=float)
        h = 1e-6
        fd = np.column_stack(
            [(s.end_points(q + h * e)[0] - s.end_points(q - h * e)[0]) / (2 * h) for e in np.eye(s.nq)]
        )
        Jp = pin.computeFrameJacobian(s.model, data, q, fid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)[:3]
        worst_fd, worst_pin = max(worst_fd, np.abs(J - fd).max()), max(worst_pin, np.abs(J - Jp).max())
        # the forearm point moves with the waist and the left shoulder and elbow only
        assert np.abs(J[:, [s.joint_names.index(f"left_wrist_{a}_joint") for a in ("roll", "pitch", "yaw")]]).max() == 0
    assert worst_pin < 1e-12 and worst_fd < 1e-8, (worst_pin, worst_fd)
    # the cooperative layer takes it like any end frame: a point pair forearm → right hand
    task = cg.cooperative_task(s, "point_pair")
    np.testing.assert_allclose(task.points(s.q0), s.end_points(s.q0), atol=1e-12)


def test_point_on_a_locked_link_and_oriented_point() -> None:
    # a point on the front-left tibia with that leg locked: it rides on the body, at Pinocchio's FK of q_lock
    tip = EndPoint("lf_tibia", (0.05, 0.0, -0.01), name="lf_shin")
    locked = ["lf_coxa_joint", "lf_femur_joint", "lf_tibia_joint"]
    q_lock = np.tile([0.2, 0.3, -1.4], 6)
    s = from_urdf(HEXAPOD, [tip, "rf_foot"], locked, q_lock=q_lock)
    full = pin.buildModelFromUrdf(str(HEXAPOD))
    d = full.createData()
    pin.framesForwardKinematics(full, d, q_lock)
    expected = d.oMf[full.getFrameId("lf_tibia", pin.FrameType.BODY)].act(np.array(tip.offset))
    rng = np.random.default_rng(1)
    for _ in range(3):
        np.testing.assert_allclose(s.end_points(s.random_q(rng))[0], expected, rtol=0, atol=1e-12)
    # an oriented point: its motor is the link's rotated by `rotation`
    R = pin.utils.rotate("z", 0.4) @ pin.utils.rotate("x", -0.3)
    g = systems.load("g1_arms").with_end_frames([EndPoint("torso_link", (0.1, 0, 0.3), name="badge", rotation=R)])
    q = g.random_q(rng)
    M = g.frame_motors(q)[0]
    gd = g.model.createData()
    pin.framesForwardKinematics(g.model, gd, q)
    torso = gd.oMf[g.model.getFrameId("torso_link", pin.FrameType.BODY)]
    np.testing.assert_allclose(gd.oMf[g.model.getFrameId("badge")].rotation, torso.rotation @ R, atol=1e-12)
    ref = cg.kinematics.motor_from_se3(gd.oMf[g.model.getFrameId("badge")])
    assert min((M - ref).norm(), (M + ref).norm()) < 1e-12  # a motor and its negative are one rigid motion


def test_bad_end_points_are_refused_and_the_model_is_not_modified() -> None:
    model = pin.buildModelFromUrdf(str(HEXAPOD))
    n = model.nframes
    with pytest.raises(UnknownNameError, match="EndPoint link 'lf_shin' is not a frame of the model"):
        add_end_points(model, [EndPoint("lf_shin", (0, 0, 0))])
    with pytest.raises(InvalidInputError, match="EndPoint name 'lf_foot' already names a frame"):
        add_end_points(model, [EndPoint("lf_tibia", (0, 0, 0), name="lf_foot")])
    with pytest.raises(InvalidInputError, match="EndPoint name 'p' already names a frame"):
        add_end_points(model, [EndPoint("lf_tibia", name="p"), EndPoint("rf_tibia", name="p")])
    assert model.nframes == n
    with pytest.raises(InvalidInputError, match="offset must be 3 numbers"):
        EndPoint("lf_tibia", (0.0, 0.1))
    with pytest.raises(NonFiniteError):
        EndPoint("lf_tibia", (0.0, np.nan, 0.0))
    with pytest.raises(InvalidInputError, match="3×3 rotation matrix"):
        EndPoint("lf_tibia", rotation=np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(InvalidInputError, match="link must be a frame name"):
        EndPoint("")  # type: ignore[call-arg]
    assert EndPoint("lf_tibia").name == "lf_tibia_point"
    with pytest.raises(InvalidInputError, match="end_frames must be a list"):
        systems.load("hexapod").with_end_frames(EndPoint("lf_tibia"))  # type: ignore[arg-type]
