"""Continuous joints as angles (``continuous_as_revolute``): the Kinova Gen2 (three continuous joints, Pinocchio
nq = 9, nv = 6) loads from its unedited URDF with nq = nv = 6, and its FK, frame Jacobians, mass matrix and
inverse dynamics equal Pinocchio's on the original model at the matching (cos θ, sin θ) configuration."""

from __future__ import annotations

import os

import numpy as np
import pinocchio as pin

import coop_ga as cg
from coop_ga.systems import ROBOTS_DIR, EndPoint, continuous_as_revolute, from_urdf
from coop_ga.systems.joints import angles_to_configuration

EE = "j2s6s200_end_effector"


def _kinova_urdf() -> str:
    import example_robot_data as erd

    L = erd.robots_loader.KinovaLoader
    rel = os.path.join(L.path, L.urdf_subpath, L.urdf_filename)
    return os.path.join(erd.getModelPath(rel), rel)


def test_kinova_angles_model_equals_pinocchio_on_the_original() -> None:
    m = pin.buildModelFromUrdf(_kinova_urdf())
    assert (m.nq, m.nv) == (9, 6)
    n = continuous_as_revolute(m)
    assert (n.nq, n.nv) == (6, 6) and [f.name for f in n.frames] == [f.name for f in m.frames]
    d0, d1 = m.createData(), n.createData()
    rng = np.random.default_rng(2)
    worst = {"oMf": 0.0, "J": 0.0, "M": 0.0, "rnea": 0.0}
    for _ in range(20):
        q = rng.uniform(-4.0, 4.0, 6)  # beyond ±π too: the angle is not wrapped
        q = np.clip(q, n.lowerPositionLimit, n.upperPositionLimit)
        qm = angles_to_configuration(m, n, q)
        pin.framesForwardKinematics(m, d0, qm)
        pin.framesForwardKinematics(n, d1, q)
        worst["oMf"] = max(
            worst["oMf"], max(np.abs(d0.oMf[i].homogeneous - d1.oMf[i].homogeneous).max() for i in range(m.nframes))
        )
        fid = m.getFrameId(EE)
        J0 = pin.computeFrameJacobian(m, d0, qm, fid, pin.LOCAL_WORLD_ALIGNED)
        worst["J"] = max(
            worst["J"], np.abs(J0 - pin.computeFrameJacobian(n, d1, q, fid, pin.LOCAL_WORLD_ALIGNED)).max()
        )
        worst["M"] = max(worst["M"], np.abs(pin.crba(m, d0, qm) - pin.crba(n, d1, q)).max())
        v, a = rng.normal(size=6), rng.normal(size=6)
        worst["rnea"] = max(worst["rnea"], np.abs(pin.rnea(m, d0, qm, v, a) - pin.rnea(n, d1, q, v, a)).max())
    assert max(worst.values()) < 1e-12, worst
    continuous = [n.getJointId(f"j2s6s200_joint_{i}") for i in (1, 4, 6)]
    assert all(n.joints[j].shortname() == "JointModelRZ" for j in continuous)
    assert all(n.upperPositionLimit[n.joints[j].idx_q] > 1e300 for j in continuous)
    np.testing.assert_array_equal(n.effortLimit, m.effortLimit)
    np.testing.assert_array_equal(n.velocityLimit, m.velocityLimit)
    hexapod = pin.buildModelFromUrdf(str(ROBOTS_DIR / "hexapod" / "hexapod.urdf"))
    assert continuous_as_revolute(hexapod) is hexapod  # nothing to replace


def test_kinova_from_urdf_runs_the_stack() -> None:
    elbow = EndPoint("j2s6s200_link_4", (0.0, 0.0, -0.1), name="elbow_point")
    s = from_urdf(_kinova_urdf(), [elbow, EE], name="kinova")
    assert s.nq == 6 and s.joint_names == [f"j2s6s200_joint_{i}" for i in range(1, 7)]
    m = pin.buildModelFromUrdf(_kinova_urdf())
    d = m.createData()
    lw = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
    rng = np.random.default_rng(5)
    for _ in range(5):
        q = s.random_q(rng)
        qm = angles_to_configuration(m, s.model, q)
        pin.framesForwardKinematics(m, d, qm)
        np.testing.assert_allclose(s.end_points(q)[1], d.oMf[m.getFrameId(EE)].translation, atol=1e-12)
        J = np.asarray(s.tree.euclidean_point_jacobians(q)[1], dtype=float)
        np.testing.assert_allclose(J, pin.computeFrameJacobian(m, d, qm, m.getFrameId(EE), lw)[:3], atol=1e-12)
    # a cooperative point pair (elbow point → end effector): its body Jacobian (Eq 30) against central differences
    task = cg.cooperative_task(s, "point_pair")
    q = np.array([0.3, 2.9, 1.3, -2.07, 1.4, 0.5])
    h, V0r = 1e-6, ~task.similarity(q)
    log = cg.geometry.log
    fd = np.column_stack([(log(V0r * task.similarity(q + h * e)) - log(V0r * task.similarity(q - h * e))) / (2 * h)
                          for e in np.eye(6)])  # fmt: skip
    assert np.abs(task.jacobian(q) - fd).max() < 1e-7
