"""The cooperative dual task space of the G1's two hands (waist shared by both chains): the motors against
Pinocchio frame compositions, the Jacobians against Pinocchio and finite differences, the task in a step."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import coop_ga as cg
from coop_ga.control import Configuration, SimilarityTask, default_limits, displaced_target, run_ik
from coop_ga.control.tasks import DUAL_ROWS, DualTask, DualTaskSpace
from coop_ga.errors import InvalidInputError, UnknownNameError
from coop_ga.kinematics import LOCAL_TO_TANGENT
from tests.helpers import central_difference

MOTOR_ROWS = [0, 1, 2, 4, 5, 6]  # of the 7 tangent rows (no dilation)


@pytest.fixture(scope="module")
def pair(load_system):
    s = load_system("g1_arms")
    task = cg.cooperative_task(s, "point_pair")
    return task, DualTaskSpace(task)


def _configurations(s, n, seed):
    """n configurations around q0 inside the limits (relative rotations well away from π)."""
    rng = np.random.default_rng(seed)
    q0 = np.asarray(s.q0, dtype=float)
    return [np.clip(q0 + rng.uniform(-0.4, 0.4, s.nq), s.limits.lower, s.limits.upper) for _ in range(n)]


def _pin_frames(s, space, q):
    data = s.model.createData()
    pin.framesForwardKinematics(s.model, data, q)
    pin.computeJointJacobians(s.model, data, q)
    ids = [s.model.getFrameId(n) for n in space.frames]
    X = [data.oMf[i].copy() for i in ids]
    J = [pin.getFrameJacobian(s.model, data, i, pin.LOCAL) for i in ids]
    return X, J


def _homogeneous(M: cg.Motor) -> np.ndarray:
    S = M.as_similarity()
    H = np.eye(4)
    H[:3, :3], H[:3, 3] = S.rotation_matrix, S.translation
    return H


def test_motors_are_pinocchio_frame_compositions(pair):
    task, space = pair
    s = task.system
    for q in _configurations(s, 4, 1):
        X, _ = _pin_frames(s, space, q)
        st = space.evaluate(q)
        Xr = X[1].inverse() * X[0]  # frame 1 seen from frame 2
        # the half-way pose: the geodesic mean of the orientations at the midpoint of the end points
        Ha = np.eye(4)
        Ha[:3, :3] = X[1].rotation @ pin.exp3(0.5 * pin.log3(Xr.rotation))
        Ha[:3, 3] = 0.5 * (X[0].translation + X[1].translation)
        assert np.abs(_homogeneous(st.first) - X[0].homogeneous).max() <= 1e-12
        assert np.abs(_homogeneous(st.second) - X[1].homogeneous).max() <= 1e-12
        assert np.abs(_homogeneous(st.relative) - Xr.homogeneous).max() <= 1e-12
        assert np.abs(_homogeneous(st.absolute) - Ha).max() <= 1e-12
        assert st.relative_angle == pytest.approx(np.linalg.norm(pin.log3(Xr.rotation)), abs=1e-12)


def test_absolute_motor_is_symmetric_in_the_two_frames(pair):
    """M_2 exp(½ log(M̃_2 M_1)) = M_1 exp(½ log(M̃_1 M_2)) (either order of the literature gives one M_a)."""
    task, space = pair
    for q in _configurations(task.system, 3, 2):
        st = space.evaluate(q)
        other = st.first @ cg.Motor.exp(0.5 * np.asarray((st.first.inverse() @ st.second).log()))
        assert np.abs(_homogeneous(other) - _homogeneous(st.absolute)).max() <= 1e-12
    swapped = DualTaskSpace(task, (1, 0), codegen=False)  # the CasADi VM: no second compilation
    q = _configurations(task.system, 1, 3)[0]
    a, b = space.evaluate(q), swapped.evaluate(q)
    assert np.abs(_homogeneous(a.absolute) - _homogeneous(b.absolute)).max() <= 1e-12
    assert np.abs(_homogeneous(a.relative) @ _homogeneous(b.relative) - np.eye(4)).max() <= 1e-12


def test_relative_body_jacobian_is_pinocchios(pair):
    """J_r = J_1 − Ad(M̃_r) J_2 with Pinocchio's LOCAL frame Jacobians; the shared waist moves both hands as one
    body, so it leaves the relative motor alone and moves the absolute one."""
    task, space = pair
    s = task.system
    for q in _configurations(s, 3, 4):
        X, J = _pin_frames(s, space, q)
        Xr = X[1].inverse() * X[0]
        ref = (LOCAL_TO_TANGENT @ (J[0] - Xr.inverse().action @ J[1]))[MOTOR_ROWS]
        st = space.evaluate(q)
        Jr = st.relative_jacobian
        assert np.abs(Jr - ref).max() <= 1e-12
        assert np.abs(Jr[:, :3]).max() <= 1e-14 and np.abs(st.absolute_jacobian[:, :3]).max() > 0.1


@pytest.mark.parametrize("which", ["relative", "absolute"])
def test_jacobians_against_finite_differences(pair, which):
    task, space = pair
    q = _configurations(task.system, 1, 5)[0]
    M0 = getattr(space.evaluate(q), which)
    # the body Jacobian: d/dq of log(M̃(q0) M(q)) at q0
    body = central_difference(lambda x: np.asarray((M0.inverse() @ getattr(space.evaluate(x), which)).log()), q)
    J = space.evaluate(q).relative_jacobian if which == "relative" else space.evaluate(q).absolute_jacobian
    assert np.abs(J - body).max() <= 1e-8 * max(1.0, np.abs(J).max())
    # the exact Jacobian of the error far from the target
    target = M0 @ cg.Motor.exp([0.4, -0.3, 0.5, 0.1, -0.05, 0.08])
    e, E, Jb = space.error_and_jacobian(q, which, target)
    assert np.linalg.norm(e[:3]) > 0.5
    fd = central_difference(lambda x: space.error_and_jacobian(x, which, target)[0], q)
    assert np.abs(E - fd).max() <= 1e-8 * max(1.0, np.abs(E).max())
    np.testing.assert_array_equal(Jb, J)
    assert np.abs(E - J).max() > 1e-2  # far from the target the exact Jacobian is not the body one
    # e = −log(M̃ M*), zero at the target
    np.testing.assert_allclose(e, -np.asarray((getattr(space.evaluate(q), which).inverse() @ target).log()), atol=1e-12)
    assert np.abs(space.error_and_jacobian(q, which, M0)[0]).max() <= 1e-12


def test_task_rows_and_the_configuration(pair):
    task, space = pair
    q = _configurations(task.system, 1, 6)[0]
    cfg = Configuration(task, q)
    target = space.relative(q) @ cg.Motor.exp([0.1, 0.2, -0.1, 0.02, 0.0, -0.03])
    full = DualTask(space, "relative", target)
    ori = DualTask(space, "relative", target, components="orientation", jacobian="exact")
    pos = DualTask(space, "relative", target, components=["e1∞", 5])
    e, E, J = space.error_and_jacobian(q, "relative", target)
    np.testing.assert_array_equal(full.error(cfg), e)
    np.testing.assert_array_equal(full.jacobian(cfg), J)
    np.testing.assert_array_equal(ori.jacobian(cfg), E[:3])
    np.testing.assert_array_equal(pos.error(cfg), e[[3, 5]])
    assert ori.labels == tuple(f"relative motor {r}" for r in DUAL_ROWS[:3])
    A, b = full.qp_rows(cfg)  # the cost ½‖J q̇ + α e‖²
    np.testing.assert_array_equal(A, J)
    np.testing.assert_array_equal(b, -10.0 * e)


def test_relative_orientation_held_while_the_point_pair_moves(pair):
    """A point pair cannot hold the hands' relative orientation; stacked with the dual task it is held."""
    task, space = pair
    q0 = np.asarray(task.system.q0, dtype=float)
    target = displaced_target(task, q0, translation=(0.05, 0.0, 0.08), axis=(0, 0, 1), angle=0.5, scale=1.0)
    limits = default_limits(task.system.limits)
    drift, final = {}, {}
    for hold in (False, True):
        rel = DualTask(space, "relative", space.relative(q0), components="orientation")
        tasks = [SimilarityTask(target), rel] if hold else [SimilarityTask(target)]
        run = run_ik(Configuration(task, q0), tasks, limits, dt=0.01, steps=300, damping=1e-3)
        qf = run.trajectory[-1]
        assert np.linalg.norm(task.error(qf, target)) < 1e-5
        drift[hold] = max(np.linalg.norm(rel.error(Configuration(task, x))) for x in run.trajectory)
        final[hold] = np.linalg.norm(rel.error(Configuration(task, qf)))
    assert drift[False] > np.deg2rad(2.0) and final[False] > np.deg2rad(2.0)  # the hands turn against each other
    # held to the Euler steps' second-order drift while the step is large (0.2° here), then to rounding
    assert drift[True] < np.deg2rad(0.5) and drift[False] > 10 * drift[True]
    assert final[True] < 1e-8


def test_absolute_motor_alone_reaches_its_target(pair):
    task, space = pair
    q0 = np.asarray(task.system.q0, dtype=float)
    target = space.absolute(q0) @ cg.Motor.exp([0.0, 0.0, 0.2, 0.03, 0.0, 0.05])
    t = DualTask(space, "absolute", target, jacobian="exact")
    run = run_ik(Configuration(task, q0), [t], default_limits(task.system.limits), dt=0.01, steps=400, damping=1e-3)
    e = space.error_and_jacobian(run.trajectory[-1], "absolute", target)[0]
    assert np.linalg.norm(space.error_and_jacobian(q0, "absolute", target)[0]) > 0.2
    assert np.linalg.norm(e) < 1e-6
    assert run.max_position_violation <= 1e-9


def test_bad_input_is_refused(pair, load_system):
    task, space = pair
    with pytest.raises(InvalidInputError, match="must differ"):
        DualTaskSpace(task, (0, "right_rubber_hand"))
    with pytest.raises(InvalidInputError, match="not an end frame"):
        DualTaskSpace(task, (0, 2))
    with pytest.raises(UnknownNameError):
        DualTaskSpace(task, (0, "no_such_frame"))
    with pytest.raises(InvalidInputError, match="two frames"):
        DualTaskSpace(task, "right_rubber_hand")
    M = cg.Motor.identity()
    with pytest.raises(InvalidInputError, match="motor"):
        DualTask(space, "middle", M)
    with pytest.raises(InvalidInputError, match="unknown row"):
        DualTask(space, "relative", M, components="e0∞")
    with pytest.raises(InvalidInputError, match="distinct"):
        DualTask(space, "relative", M, components=[0, "e12"])
    with pytest.raises(InvalidInputError, match="Motor"):
        DualTask(space, "relative", np.zeros(3))
    with pytest.raises(InvalidInputError):
        DualTask(space, "relative", cg.Similarity.exp([0, 0, 0, 0.3, 0, 0, 0]))  # a dilation is no motor
    other = cg.cooperative_task(load_system("three_franka"), "circle")
    with pytest.raises(InvalidInputError, match="system"):
        DualTask(space, "relative", M).error(Configuration(other, other.system.q0))
