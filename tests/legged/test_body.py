"""The floating body (coop_ga.legged.body) and the floating hexapod (``load("hexapod", free_flyer=True)``)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import coop_ga as cg
from coop_ga.errors import InvalidInputError
from coop_ga.geometry.groups import Similarity, motor_rotor_translation, rotor_matrix
from coop_ga.geometry.primitives import point, to_euclidean
from coop_ga.legged.body import (
    LEG_ORDER,
    BodyState,
    body_tangent,
    free_flyer_hexapod,
    rotation_from_rpy,
    rpy_from_rotation,
    stance_indices,
)
from coop_ga.legged.legs import LEGS, hexapod_legs

L = hexapod_legs()
RNG_SEED = 13


def random_states(n: int, seed: int = RNG_SEED) -> list[BodyState]:
    rng = np.random.default_rng(seed)
    out = []
    lo, hi = L.q_lower.ravel(), L.q_upper.ravel()
    for _ in range(n):
        q = np.zeros(18)
        q[L.q_index.ravel()] = rng.uniform(lo, hi)
        rpy = rng.uniform([-np.pi, -0.49 * np.pi, -np.pi], [np.pi, 0.49 * np.pi, np.pi])
        out.append(BodyState.from_rpy(rng.uniform(-1.0, 1.0, 3), rpy, q))
    return out


def test_leg_order_is_the_package_order():
    assert LEG_ORDER == LEGS


def test_rpy_round_trip_and_gimbal_lock():
    for s in random_states(50):
        np.testing.assert_allclose(rotation_from_rpy(s.rpy()), s.rotation, atol=1e-12)
    R = rotation_from_rpy([0.3, np.pi / 2, 0.2])
    np.testing.assert_allclose(rotation_from_rpy(rpy_from_rotation(R)), R, atol=1e-12)
    # R = Rz(yaw) Ry(pitch) Rx(roll), the ZYX convention of the floating system's joints
    np.testing.assert_allclose(
        rotation_from_rpy([0.1, 0.2, 0.3]),
        pin.utils.rotate("z", 0.3) @ pin.utils.rotate("y", 0.2) @ pin.utils.rotate("x", 0.1),
    )


def test_motor_and_quaternion_round_trips():
    for s in random_states(30):
        Rr, t = motor_rotor_translation(s.motor())
        np.testing.assert_allclose(np.array(rotor_matrix(Rr), dtype=float), s.rotation, atol=1e-12)
        np.testing.assert_allclose(np.array(t, dtype=float), s.position, atol=1e-12)
        qu = s.quaternion_xyzw()
        assert qu[3] >= 0 and abs(np.linalg.norm(qu) - 1.0) < 1e-15
        back = BodyState.from_quaternion(s.position, qu, s.q)
        np.testing.assert_allclose(back.rotation, s.rotation, atol=1e-12)
        np.testing.assert_allclose(back.pose7(), s.pose7(), atol=1e-12)
        # the sandwich M P(p) M̃ of the conformal foot point gives feet_world
        M = Similarity(s.motor())
        fb = s.feet_body(L)
        fw = np.array([np.asarray(to_euclidean(M.apply(point(p))), dtype=float) for p in fb])
        np.testing.assert_allclose(fw, s.feet_world(L), atol=1e-12)
        np.testing.assert_allclose(s.to_body(s.feet_world(L)), fb, atol=1e-12)


def test_free_flyer_q_round_trip():
    """state → q (25,) → state → q is exact to 1e-15, and so is q → state → q from random q (unit quaternions
    with w ≥ 0, the sign free_flyer_q gives); the quaternion is R_WB's (scipy's, independent of BodyState)."""
    from scipy.spatial.transform import Rotation

    for s in random_states(30):
        q25 = s.free_flyer_q()
        assert q25.shape == (25,)
        np.testing.assert_allclose(Rotation.from_quat(q25[3:7]).as_matrix(), s.rotation, atol=1e-15)
        back = BodyState.from_free_flyer_q(q25)
        np.testing.assert_allclose(back.rotation, s.rotation, atol=1e-15)
        np.testing.assert_array_equal(back.position, s.position)
        np.testing.assert_array_equal(back.q, s.q)
        np.testing.assert_allclose(back.free_flyer_q(), q25, rtol=0, atol=1e-15)
    rng = np.random.default_rng(RNG_SEED)
    for _ in range(30):
        quat = Rotation.random(random_state=rng).as_quat()
        q25 = np.concatenate([rng.uniform(-1, 1, 3), quat if quat[3] >= 0 else -quat, rng.uniform(-1, 1, 18)])
        np.testing.assert_allclose(BodyState.from_free_flyer_q(q25).free_flyer_q(), q25, rtol=0, atol=1e-15)


def test_feet_world_equals_pinocchio_fk_of_the_free_flyer():
    sysf = free_flyer_hexapod()
    assert sysf is cg.systems.load("hexapod", free_flyer=True)
    assert (sysf.nq, sysf.nv, sysf.n_chains) == (25, 24, 6)
    m, d = sysf.model, sysf.model.createData()
    assert m.joints[1].shortname() == "JointModelFreeFlyer"
    fids = {f: m.getFrameId(f) for f in sysf.end_frames}
    worst = 0.0
    for s in random_states(60):
        pin.framesForwardKinematics(m, d, s.free_flyer_q())
        fw = s.feet_world(L)
        for i, leg in enumerate(LEG_ORDER):
            worst = max(worst, float(np.max(np.abs(d.oMf[fids[f"{leg}_foot"]].translation - fw[i]))))
        # the body frame too
        oMb = d.oMf[m.getFrameId("base_link")]
        np.testing.assert_allclose(oMb.rotation, s.rotation, atol=1e-12)
        np.testing.assert_allclose(oMb.translation, s.position, atol=1e-12)
    assert worst < 1e-12
    # and the system's own motor FK (coop_ga.kinematics) agrees
    s = random_states(1, seed=3)[0]
    P = sysf.tree.end_points_array(s.free_flyer_q())
    fw = s.feet_world(L)
    for k, f in enumerate(sysf.end_frames):
        np.testing.assert_allclose(P[k], fw[LEG_ORDER.index(f[: -len("_foot")])], atol=1e-12)


def test_free_flyer_q0_stands_on_the_ground():
    sysf = free_flyer_hexapod()
    s = BodyState.from_free_flyer_q(sysf.q0)
    f = s.feet_world(L)
    np.testing.assert_allclose(f[:, 2], 0.0, atol=1e-15)
    assert sysf.limits.position_violation(sysf.limit_coordinates(sysf.q0)) == 0.0


def test_moved_is_the_body_twist():
    s = random_states(1)[0]
    v, w, dt = np.array([0.1, -0.2, 0.05]), np.array([0.3, 0.1, -0.4]), 1e-3
    n = s.moved(v, w, dt)
    np.testing.assert_allclose(n.position, s.position + s.rotation @ v * dt, atol=1e-15)
    # M(t + Δt) = M(t) · exp(Δt ξ) to first order in Δt, ξ = body_tangent(v, ω)
    M1 = Similarity(s.motor()) @ Similarity.exp(dt * body_tangent(v, w))
    np.testing.assert_allclose(M1.rotation_matrix, n.rotation, atol=1e-6)
    np.testing.assert_allclose(M1.translation, n.position, atol=1e-6)
    assert np.array_equal(n.q, s.q)


def test_bad_input():
    q = np.zeros(18)
    with pytest.raises(InvalidInputError, match="rotation matrix"):
        BodyState([0, 0, 0], np.diag([1.0, 1.0, 2.0]), q)
    with pytest.raises(InvalidInputError, match="rotation matrix"):
        BodyState([0, 0, 0], np.diag([1.0, 1.0, -1.0]), q)
    with pytest.raises(InvalidInputError):
        BodyState([0, 0], np.eye(3), q)
    with pytest.raises(InvalidInputError):
        BodyState([0, 0, 0], np.eye(3), np.zeros(17))
    with pytest.raises(InvalidInputError, match="zero"):
        BodyState.from_quaternion([0, 0, 0], [0, 0, 0, 0], q)
    with pytest.raises(InvalidInputError, match="25"):
        BodyState.from_free_flyer_q(np.zeros(24))
    q25 = BodyState([0, 0, 0], np.eye(3), q).free_flyer_q()
    q25[6] = 0.9  # |quaternion| = 0.9
    with pytest.raises(InvalidInputError, match=r"quaternion \(x y z w\).*norm 0\.9.*normalise"):
        BodyState.from_free_flyer_q(q25)
    # a nearly orthonormal rotation is re-orthonormalised
    R = rotation_from_rpy([0.1, 0.2, 0.3]) + 1e-9
    s = BodyState([0, 0, 0], R, q)
    assert np.max(np.abs(s.rotation.T @ s.rotation - np.eye(3))) < 1e-15


def test_stance_indices():
    assert stance_indices(("rm", "lf", "lf")) == (0, 4)
    assert stance_indices(np.array([True, False, True, False, True, False])) == (0, 2, 4)
    assert stance_indices([5, 1]) == (1, 5)
    for bad in ("lf", ("xx",), [7], np.array([True, False]), 3.0, [True]):
        with pytest.raises(InvalidInputError):
            stance_indices(bad)
