"""Systems with a free-flyer root (nq ≠ nv): integrate/difference, limits, loading with the free flyer."""

from __future__ import annotations

import os
import warnings

import numpy as np
import pinocchio as pin
import pytest

from coop_ga import systems
from coop_ga.errors import InvalidInputError
from coop_ga.systems.library import g1_floating


def _g1_urdf() -> str:
    import example_robot_data as erd

    L = erd.robots_loader.G1Loader
    rel = os.path.join(L.path, L.urdf_subpath, L.urdf_filename)
    return os.path.join(erd.getModelPath(rel), rel)


@pytest.fixture(scope="module")
def floating():
    return g1_floating()


def test_sizes_names_and_q0(floating) -> None:
    s = floating
    assert (s.nq, s.nv) == (24, 23)
    assert s.joint_names[:7] == [f"root_joint:{c}" for c in ("vx", "vy", "vz", "wx", "wy", "wz")] + ["waist_yaw_joint"]
    assert len(s.joint_names) == s.nv == s.limits.velocity.shape[0]
    fixed = systems.load("g1_arms")
    np.testing.assert_allclose(s.end_points(s.q0), fixed.end_points(fixed.q0), atol=1e-12)
    np.testing.assert_array_equal(s.neutral(), pin.neutral(s.model))


def test_integrate_and_difference_are_pinocchios(floating) -> None:
    s = floating
    rng = np.random.default_rng(1)
    q0, v = s.random_q(rng), rng.normal(size=s.nv)
    q1 = s.integrate(q0, v)
    np.testing.assert_array_equal(q1, pin.integrate(s.model, q0, v))
    assert abs(np.linalg.norm(q1[3:7]) - 1.0) < 1e-14
    np.testing.assert_allclose(s.difference(q0, q1), v, atol=1e-12)
    fixed = systems.load("g1_arms")  # nq = nv: plain + and −
    qf, vf = fixed.q0, rng.normal(size=fixed.nv)
    np.testing.assert_array_equal(fixed.integrate(qf, vf), qf + vf)
    np.testing.assert_array_equal(fixed.difference(qf, qf + vf), (qf + vf) - qf)
    assert fixed.limit_coordinates(qf) is not None and np.array_equal(fixed.limit_coordinates(qf), qf)


def test_limits_bound_the_joints_only(floating) -> None:
    s = floating
    assert np.all(np.isinf(s.limits.lower[:6])) and np.all(np.isinf(s.limits.upper[:6]))
    np.testing.assert_array_equal(s.limits.lower[6:], s.model.lowerPositionLimit[7:])
    q = s.q0.copy()
    q[:3] = [5.0, -7.0, 3.0]  # far away: the base has no position limit
    q[3:7] = [0.0, 0.0, 1.0, 0.0]  # w = 0: outside the ±1 Pinocchio stores, yet a valid quaternion
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        s.check_q(q)
    lc = s.limit_coordinates(q)
    assert lc.shape == (s.nv,) and np.all(lc[:6] == 0.0) and np.array_equal(lc[6:], q[7:])
    assert s.limits.position_violation(lc) == 0.0
    q[7] = 10.0  # waist yaw far outside its limits: reported by name
    assert "waist_yaw_joint=10.0000" in s.limits.describe(s.limit_coordinates(q))
    for _ in range(5):
        r = s.random_q(np.random.default_rng(_))
        assert abs(np.linalg.norm(r[3:7]) - 1.0) < 1e-12 and s.limits.position_violation(s.limit_coordinates(r)) == 0


def test_non_unit_quaternion_is_refused(floating) -> None:
    q = floating.q0.copy()
    q[3:7] = [0.0, 0.0, 0.0, 0.5]
    with pytest.raises(InvalidInputError, match=r"free flyer 'root_joint'.*norm 0\.5.*normalise"):
        floating.check_q(q)
    with pytest.raises(InvalidInputError, match=r"norm 0\.5"):
        systems.System("bad", floating.model, floating.end_frames, q)


def test_public_quaternion_check_limit_index_and_distance(floating) -> None:
    s = floating
    q = s.q0.copy()
    q[3:7] *= 3.0
    with pytest.raises(InvalidInputError, match=r"^q_init of system 'g1_floating'.*norm 3"):
        s.check_quaternions(q, "q_init")
    s.check_quaternions(s.q0, "q0")  # unit: nothing raised
    idx = s.limit_index
    assert idx.shape == (s.nv,) and np.all(idx[:6] == -1) and np.array_equal(idx[6:], np.arange(7, s.nq))
    # distance: the norm of the tangent step by Pinocchio's difference (LOCAL translation [m], rotation angle [rad])
    rng = np.random.default_rng(2)
    a, v = s.random_q(rng), 0.3 * rng.normal(size=s.nv)  # |ω| < π: the step is the shortest one
    b = pin.integrate(s.model, a, v)
    assert s.distance(a, b) == pytest.approx(float(np.linalg.norm(v)), rel=1e-12)
    turned = s.q0.copy()
    turned[3:7] = [0.0, 0.0, np.sin(0.25), np.cos(0.25)]  # the pelvis turned 0.5 rad about z, nothing else
    assert s.distance(s.q0, turned) == pytest.approx(0.5, rel=1e-12)
    flipped = turned.copy()
    flipped[3:7] *= -1.0  # the same rotation: zero distance, where ‖q1 − q0‖ adds quaternion units (≈ 2)
    assert s.distance(turned, flipped) <= 1e-12 and np.linalg.norm(flipped - turned) > 1.9
    fixed = systems.load("g1_arms")
    qf = fixed.q0 + 0.1
    assert fixed.distance(fixed.q0, qf) == float(np.linalg.norm(qf - fixed.q0))


def test_from_urdf_with_its_free_flyer() -> None:
    groups = {"base": "root_joint", "arms": [".*_(shoulder|elbow|wrist)_.*", "waist_.*"]}
    s = systems.from_urdf(
        _g1_urdf(), ["left_rubber_hand", "right_rubber_hand"], free_flyer=True, groups=groups, active=["base", "arms"]
    )
    assert (s.nq, s.nv) == (24, 23) and s.model.joints[1].shortname() == "JointModelFreeFlyer"
    np.testing.assert_array_equal(s.q0[:7], [0, 0, 0, 0, 0, 0, 1])  # the default q0 leaves the quaternion alone
    fixed = systems.from_urdf(
        _g1_urdf(), ["left_rubber_hand"], groups=groups | {"base": "waist_yaw_joint"}, active=["arms"]
    )
    assert fixed.nq == fixed.nv == 17
    with pytest.raises(InvalidInputError, match="free_flyer must be True or False"):
        systems.from_urdf(_g1_urdf(), ["left_rubber_hand"], free_flyer="yes")


def test_hexapod_free_flyer_is_the_fixed_hexapod_moved_by_the_body_pose() -> None:
    """At random body poses (position, quaternion x y z w) and leg joints the free flyer's feet are the fixed
    hexapod's feet moved by the pose (p + R f, R from scipy's quaternion); at q0 they stand on z = 0."""
    from scipy.spatial.transform import Rotation

    from coop_ga.systems.library import HEXAPOD_STAND_HEIGHT, hexapod_free_flyer

    free, fixed = hexapod_free_flyer(), systems.load("hexapod")
    assert (free.nq, free.nv) == (25, 24) and free.end_frames == fixed.end_frames
    np.testing.assert_allclose(free.end_points(free.q0)[:, 2], 0.0, atol=1e-12)
    assert free.q0[2] == HEXAPOD_STAND_HEIGHT
    rng = np.random.default_rng(2)
    for _ in range(10):
        legs = fixed.random_q(rng, scale=0.3)
        p, quat = rng.uniform(-2.0, 2.0, 3), Rotation.random(random_state=rng).as_quat()  # x y z w
        qf = np.concatenate([p, quat, legs])
        expected = fixed.end_points(legs) @ Rotation.from_quat(quat).as_matrix().T + p
        np.testing.assert_allclose(free.end_points(qf), expected, atol=1e-12)


def test_hexapod_free_flyer_reaches_a_far_target_by_flying() -> None:
    """What a kinematic free flyer tells: the circle of three feet moved 3 m (1.65 m of it up) is reached —
    converged, and the feet lie on the target circle by Pinocchio's FK — by lifting the whole robot off the ground
    (the virtual body joints did the same within their ±100 m).  Nothing keeps a foot on the ground here."""
    import warnings

    from coop_ga import cooperative_task
    from coop_ga.control import displaced_target, gauss_newton_ik
    from coop_ga.control.ilqr.reachability import unit_distance

    s = systems.load("hexapod", free_flyer=True)
    task = cooperative_task(s, "circle")
    target = displaced_target(task, s.q0, translation=(0.5, -2.45, 1.65))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # degeneracy warnings of trial points far away
        res = gauss_newton_ik(task, s.q0, target)
    assert res.converged and res.error < 1e-9
    d = s.model.createData()
    pin.framesForwardKinematics(s.model, d, res.q)
    t, R, sc = target.translation, target.rotation_matrix, target.scale
    for f in task.end_frames:
        p = d.oMf[s.model.getFrameId(f)].translation
        assert sc * unit_distance("circle", R.T @ (p - t) / sc) < 1e-9
    feet_z = np.array([d.oMf[s.model.getFrameId(f)].translation[2] for f in s.end_frames])
    assert res.q[2] - s.q0[2] > 1.5 and feet_z.min() > 1.4  # the body flew up, every foot in the air


def test_registry_loads_the_free_flyer_variants() -> None:
    from coop_ga.errors import UnsupportedJointError

    assert systems.names(free_flyer=True) == ["g1_arms", "hexapod"]
    assert "g1_floating" not in systems.names() and len(systems.names(free_flyer=True)) < len(systems.names())
    g1 = systems.load("g1_arms", free_flyer=True)
    assert (g1.nq, g1.nv) == (24, 23) and g1 is systems.load("g1_arms", free_flyer=True)
    fixed = systems.load("g1_arms")
    assert (fixed.nq, fixed.nv) == (17, 17) and g1.end_frames == fixed.end_frames
    np.testing.assert_array_equal(g1.q0, g1_floating().q0)
    hexa = systems.load("hexapod", free_flyer=True)
    assert (hexa.nq, hexa.nv) == (25, 24) and hexa.end_frames == systems.load("hexapod").end_frames
    with pytest.raises(UnsupportedJointError, match=r"'three_franka' has no free-flyer variant.*g1_arms, hexapod"):
        systems.load("three_franka", free_flyer=True)
    with pytest.raises(InvalidInputError, match="free_flyer must be True or False"):
        systems.load("g1_arms", free_flyer="yes")
