"""Free-flyer roots (nq ≠ nv) in the motor kinematics, against Pinocchio and finite differences.

* FK: the motor of each end frame equals ``data.oMf`` of a free-flyer G1 (both hands) and Solo12 (four feet),
  loaded by example-robot-data with their free flyer, at random configurations, to 1e-12;
* the body Jacobian (7, nv) equals ``LOCAL_TO_TANGENT @ J_LOCAL`` and the end-point Jacobian (3, nv) the linear
  rows of ``J_LOCAL_WORLD_ALIGNED``, to 1e-12; the CasADi SX path equals the numpy path;
* finite differences through ``pinocchio.integrate`` (a velocity moves q on the manifold): the end points, and
  the body twists ``log6(M(q)⁻¹ M(q ⊕ h e_k))`` of our own motors;
* the Kinova Gen2 unedited (continuous joints as angles): Jacobians equal Pinocchio's on the original model;
* a quaternion far from unit norm raises, rounding drift is normalised away.
"""

from __future__ import annotations

import os

import casadi as ca
import numpy as np
import pinocchio as pin
import pytest

from coop_ga.errors import InvalidInputError
from coop_ga.geometry.groups import motor_rotor_translation, rotor_matrix
from coop_ga.kinematics import LOCAL_TO_TANGENT, KinematicTree
from coop_ga.systems.joints import angles_to_configuration, continuous_as_revolute

ROBOTS = {
    "g1": ("left_rubber_hand", "right_rubber_hand"),
    "solo12": ("FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT"),
}


def _se3(M) -> pin.SE3:
    R, t = motor_rotor_translation(M)
    return pin.SE3(np.array(rotor_matrix(R), dtype=float), np.array(t, dtype=float))


def _random_q(model, rng) -> np.ndarray:
    """A random configuration: base anywhere near the origin with any orientation, joints inside their limits."""
    lo = np.where(np.isfinite(model.lowerPositionLimit), model.lowerPositionLimit, -1.0)
    hi = np.where(np.isfinite(model.upperPositionLimit), model.upperPositionLimit, 1.0)
    lo, hi = np.maximum(lo, -1.0), np.minimum(hi, 1.0)
    return _rng_q(model, rng, lo, hi)


def _rng_q(model, rng, lo, hi) -> np.ndarray:
    q = rng.uniform(lo, hi)
    quat = rng.normal(size=4)
    q[3:7] = quat / np.linalg.norm(quat)
    return q


@pytest.fixture(scope="module", params=sorted(ROBOTS))
def robot(request):
    import example_robot_data as erd

    model = erd.load(request.param).model
    assert model.joints[1].shortname() == "JointModelFreeFlyer" and model.nq == model.nv + 1
    return model, ROBOTS[request.param]


def test_motors_and_jacobians_equal_pinocchio(robot) -> None:
    model, frames = robot
    tree = KinematicTree(model, frames)
    assert (tree.nq, tree.nv) == (model.nq, model.nv)
    data = model.createData()
    rng = np.random.default_rng(7)
    worst = 0.0
    for _ in range(10):
        q = _random_q(model, rng)
        pin.computeJointJacobians(model, data, q)
        pin.framesForwardKinematics(model, data, q)
        Jg, Jp = tree.geometric_jacobians(q), tree.euclidean_point_jacobians(q)
        for i, (f, M) in enumerate(zip(frames, tree.frame_motors(q))):
            fid = model.getFrameId(f)
            oMf = _se3(M)
            JL = pin.getFrameJacobian(model, data, fid, pin.LOCAL)
            JW = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
            assert Jg[i].shape == (7, model.nv) and Jp[i].shape == (3, model.nv)
            worst = max(
                worst,
                np.abs(oMf.rotation - data.oMf[fid].rotation).max(),
                np.abs(oMf.translation - data.oMf[fid].translation).max(),
                np.abs(Jg[i] - LOCAL_TO_TANGENT @ JL).max(),
                np.abs(Jp[i] - JW[:3]).max(),
            )
    assert worst <= 1e-12, worst


def test_casadi_path_equals_numpy(robot) -> None:
    model, frames = robot
    tree = KinematicTree(model, frames)
    qs = ca.SX.sym("q", model.nq)
    f = ca.Function("f", [qs], [*tree.geometric_jacobians(qs), *tree.euclidean_point_jacobians(qs)])
    q = _random_q(model, np.random.default_rng(3))
    num = [*tree.geometric_jacobians(q), *tree.euclidean_point_jacobians(q)]
    for a, b in zip(f(q), num):
        assert np.abs(np.array(a) - b).max() <= 1e-12


def test_jacobians_equal_differences_through_integrate(robot) -> None:
    model, frames = robot
    tree = KinematicTree(model, frames)
    q = _random_q(model, np.random.default_rng(11))
    Jg, Jp = tree.geometric_jacobians(q), tree.euclidean_point_jacobians(q)
    M0 = [_se3(M) for M in tree.frame_motors(q)]
    h = 1e-6
    for k in range(model.nv):
        dv = np.zeros(model.nv)
        dv[k] = h
        qp, qm = pin.integrate(model, q, dv), pin.integrate(model, q, -dv)
        Mp, Mm = tree.frame_motors(qp), tree.frame_motors(qm)
        for i in range(len(frames)):
            twist = (pin.log6(M0[i].actInv(_se3(Mp[i]))).vector - pin.log6(M0[i].actInv(_se3(Mm[i]))).vector) / (2 * h)
            assert np.abs(LOCAL_TO_TANGENT @ twist - Jg[i][:, k]).max() <= 1e-8
            dp = (_se3(Mp[i]).translation - _se3(Mm[i]).translation) / (2 * h)
            assert np.abs(dp - Jp[i][:, k]).max() <= 1e-8


def test_kinova_unedited_jacobians_equal_pinocchio_on_the_original() -> None:
    import example_robot_data as erd

    L = erd.robots_loader.KinovaLoader
    rel = os.path.join(L.path, L.urdf_subpath, L.urdf_filename)
    orig = pin.buildModelFromUrdf(os.path.join(erd.getModelPath(rel), rel))
    assert (orig.nq, orig.nv) == (9, 6)
    model = continuous_as_revolute(orig)  # as today: the angle is the continuous joint's coordinate
    frame = "j2s6s200_end_effector"
    tree = KinematicTree(model, [frame])
    data = orig.createData()
    rng = np.random.default_rng(5)
    for _ in range(5):
        q = rng.uniform(-2.0, 2.0, model.nq)
        qo = angles_to_configuration(orig, model, q)
        pin.computeJointJacobians(orig, data, qo)
        pin.framesForwardKinematics(orig, data, qo)
        fid = orig.getFrameId(frame)
        J = tree.geometric_jacobians(q)[0]
        assert np.abs(J - LOCAL_TO_TANGENT @ pin.getFrameJacobian(orig, data, fid, pin.LOCAL)).max() <= 1e-12
        assert np.abs(_se3(tree.frame_motors(q)[0]).homogeneous - data.oMf[fid].homogeneous).max() <= 1e-12


def test_non_unit_quaternion_is_refused_and_drift_normalised() -> None:
    import example_robot_data as erd

    model = erd.load("solo12").model
    tree = KinematicTree(model, ["FL_FOOT"])
    q = np.array(pin.neutral(model))
    q[3:7] = [0.0, 0.0, 0.0, 2.0]
    with pytest.raises(InvalidInputError, match=r"quaternion.*norm 2.*normalise"):
        tree.frame_motors(q)
    q[3:7] = [0.0, 0.0, 0.0, 0.0]
    with pytest.raises(InvalidInputError, match="norm 0"):
        tree.end_points_array(q)
    q[3:7] = [0.0, 0.0, 0.6, 0.8 * (1 + 1e-9)]  # rounding drift: the same pose as the unit quaternion
    drift = tree.end_points_array(q)
    q[3:7] = [0.0, 0.0, 0.6, 0.8]
    q[3:7] /= np.linalg.norm(q[3:7])
    assert np.abs(drift - tree.end_points_array(q)).max() <= 1e-9
