"""The viewer's control logic without a browser: gizmo pose → target similarity → IK step → the primitive follows."""

from __future__ import annotations

import numpy as np
import pytest

import coop_ga as cg
from coop_ga.control import command_to_bivector
from coop_ga.cooperative.manipulability import manipulability
from coop_ga.viewer.session import TeleopSession, default_rz_mode, matrix_to_quaternion, quaternion_to_matrix

DT = 1.0 / 60.0


@pytest.fixture(scope="module")
def circle_task():
    return cg.cooperative_task("three_iiwa14", "circle")


def _rx(deg: float) -> np.ndarray:
    a = np.deg2rad(deg)
    return np.array([np.cos(a / 2), np.sin(a / 2), 0.0, 0.0])  # (w, x, y, z) about +x


def _compose(q1: np.ndarray, q2: np.ndarray) -> np.ndarray:
    return matrix_to_quaternion(quaternion_to_matrix(q1) @ quaternion_to_matrix(q2))


def test_quaternion_round_trip(rng):
    for _ in range(20):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        q = q if q[0] >= 0 else -q
        R = quaternion_to_matrix(q)
        assert np.allclose(R @ R.T, np.eye(3), atol=1e-12) and np.linalg.det(R) > 0
        assert np.allclose(matrix_to_quaternion(R), q, atol=1e-12)


@pytest.mark.parametrize("rz_mode", ["dilation", "rotation"])
def test_command_is_the_inverse_of_the_paper_mapping(circle_task, rz_mode, rng):
    """Unsaturated, command_to_bivector(command(e)) = servo_gain · e on the six device axes (Fig. 20); the
    seventh direction (e12 with a dilation axis, e0∞ with a rotation axis) is not commanded."""
    s = TeleopSession(circle_task, dt=DT, servo_gain=4.0, rz_mode=rz_mode)
    e = 1e-3 * rng.normal(size=7)
    u = s.command(e)
    assert np.all(np.abs(u) < 1.0)
    b = command_to_bivector(u, **s.teleop.gains)
    dropped = 0 if rz_mode == "dilation" else 3
    expected = 4.0 * e
    expected[dropped] = 0.0
    assert np.allclose(b, expected, rtol=0, atol=1e-15)


def test_command_saturates_at_the_device_range(circle_task):
    s = TeleopSession(circle_task, dt=DT)
    u = s.command([0.0, -3.0, 2.0, 5.0, 1.0, -1.0, 0.5])
    assert np.array_equal(u, [1.0, -1.0, 1.0, 1.0, 1.0, 1.0])


def test_default_sixth_axis_by_kind():
    assert [default_rz_mode(k) for k in ("point_pair", "circle", "sphere", "line", "plane")] == [
        "dilation",
        "dilation",
        "dilation",
        "rotation",
        "rotation",
    ]


def test_gizmo_pose_gives_the_target_primitive(circle_task):
    """The gizmo at (p, R) with the slider at s targets the circle of centre p, radius s·r0, normal R·n0; a
    twist about the normal (invisible to a circle) gives the same canonical target."""
    s = TeleopSession(circle_task, dt=DT)
    X0 = circle_task.primitive(s.q0)
    p, wxyz, scale = s.handle_pose()
    assert np.allclose(p, cg.center(X0), atol=1e-12) and scale == pytest.approx(1.0, abs=1e-12)
    dp = np.array([0.04, -0.03, 0.02])
    tilt = _compose(_rx(12.0), wxyz)
    V = s.target_from_pose(p + dp, tilt, 1.1)
    X = V.apply(circle_task.unit)
    assert np.allclose(cg.center(X), p + dp, atol=1e-12)
    assert cg.radius(X) == pytest.approx(1.1 * cg.radius(X0), abs=1e-12)
    n_expected = quaternion_to_matrix(_rx(12.0)) @ np.asarray(cg.normal(X0))
    assert np.allclose(cg.normal(X), n_expected, atol=1e-12)
    # the same pose twisted 40° about the circle's normal: the same target versor
    twist = np.concatenate([[np.cos(np.deg2rad(20))], np.sin(np.deg2rad(20)) * n_expected])
    V2 = s.target_from_pose(p + dp, _compose(twist, tilt), 1.1)
    assert np.allclose(V2.coeffs, V.coeffs, atol=1e-12)


def test_robots_follow_the_gizmo(circle_task):
    """The session converges to the gizmo's circle: centre, radius and normal within 0.1 mm / 1 mrad."""
    s = TeleopSession(circle_task, dt=DT)
    p, wxyz, _ = s.handle_pose()
    assert s.set_target_pose(p + [0.04, -0.03, 0.02], _compose(_rx(10.0), wxyz), 1.1)
    errors = [s.step().error_norm for _ in range(240)]  # 4 s at 60 Hz
    assert errors[5] < errors[0] and errors[-1] < 1e-5
    X = circle_task.primitive(s.q)
    T = s.target.apply(circle_task.unit)
    assert np.linalg.norm(np.asarray(cg.center(X)) - cg.center(T)) < 1e-4
    assert abs(cg.radius(X) - cg.radius(T)) < 1e-4
    assert np.arccos(np.clip(np.dot(cg.normal(X), cg.normal(T)), -1, 1)) < 1e-3
    lim = circle_task.system.limits
    assert np.all(s.q >= lim.lower) and np.all(s.q <= lim.upper)
    assert len(s.teleop.log.q) == 241  # the Teleoperator's log: one row per step, plus q0


def test_a_target_across_the_chart_is_refused(circle_task):
    s = TeleopSession(circle_task, dt=DT)
    p, wxyz, _ = s.handle_pose()
    before = s.target
    assert not s.set_target_pose(p, _compose(_rx(175.0), wxyz), 1.0)
    assert s.target is before
    assert "chart" in s.readout.error_message
    assert s.set_target_pose(p, _compose(_rx(30.0), wxyz), 1.0) and s.readout.error_message == ""


def test_bad_gizmo_input_is_refused_with_a_message(circle_task):
    s = TeleopSession(circle_task, dt=DT)
    p, wxyz, _ = s.handle_pose()
    assert not s.set_target_pose(p, [0.0, 0.0, 0.0, 0.0], 1.0)
    assert "quaternion" in s.readout.error_message
    assert not s.set_target_pose(p, wxyz, -1.0)
    assert "scale" in s.readout.error_message
    with pytest.raises(cg.InvalidInputError, match="servo_gain"):
        TeleopSession(circle_task, servo_gain=0.0)
    with pytest.raises(cg.InvalidInputError, match="rz_mode"):
        TeleopSession(circle_task, rz_mode="twist")


def test_readouts_are_the_task_numbers(circle_task):
    s = TeleopSession(circle_task, dt=DT)
    p, wxyz, _ = s.handle_pose()
    s.set_target_pose(p + [0.05, 0.0, 0.0], wxyz, 1.0)
    for _ in range(3):
        r = s.step()
    J = circle_task.jacobian(s.q)
    assert np.allclose(r.manipulability, np.sqrt(np.diag(manipulability(J))), rtol=1e-12)
    assert np.allclose(r.manipulability, np.linalg.norm(J, axis=1), rtol=1e-12)
    assert r.well_definedness == circle_task.well_definedness(s.q)
    assert np.allclose(r.error, circle_task.error(s.q, s.target), atol=0)
    assert r.error_norm == pytest.approx(np.linalg.norm(r.error))
    assert r.rate > 0 and r.step_ms > 0
    assert np.allclose(r.bivector, command_to_bivector(r.command, **s.teleop.gains))


def test_active_limits_are_reported(load_system):
    system = load_system("three_iiwa14")
    task = cg.cooperative_task(system, "circle")
    q0 = system.q0.copy()
    q0[3] = system.limits.upper[3]  # arm1 joint 4 at its upper limit
    s = TeleopSession(task, q0, dt=DT, translation_gain=5.0, servo_gain=20.0)
    assert system.joint_names[3] in s.readout.at_position_limit
    p, wxyz, _ = s.handle_pose()
    s.set_target_pose(p + [0.3, 0.0, 0.0], wxyz, 1.0)
    fast = set()
    for _ in range(20):
        fast |= set(s.step().at_velocity_limit)
    v = np.abs(s.teleop.velocity)
    assert fast, "a 30 cm jump at 5 body lengths/s saturates some joint velocities"
    assert all(
        v[system.joint_names.index(j)] <= system.limits.velocity[system.joint_names.index(j)] + 1e-9 for j in fast
    )


def test_warnings_reach_the_page(circle_task):
    from coop_ga.viewer.app import readout_markdown

    task = cg.cooperative_task("three_iiwa14", "circle", warn_below=0.9)
    s = TeleopSession(task, dt=DT)
    p, wxyz, _ = s.handle_pose()
    s.set_target_pose(p + [0.05, 0.0, 0.03], wxyz, 1.1)  # the arms reach out: well-definedness ≈ 0.80 < 0.9
    for _ in range(60):
        r = s.step()
    assert r.well_definedness < 0.9
    w = s.warnings["DegeneracyWarning:three_iiwa14"]
    assert w.count >= 1 and "well-definedness" in w.message
    assert "DegeneracyWarning" in readout_markdown(s)


def test_hold_and_reset(circle_task):
    s = TeleopSession(circle_task, dt=DT)
    p, wxyz, _ = s.handle_pose()
    s.set_target_pose(p + [0.05, 0.0, 0.0], wxyz, 1.0)
    for _ in range(10):
        s.step()
    s.hold()
    q = s.q
    for _ in range(5):
        s.step()
    assert np.max(np.abs(s.q - q)) < 0.02  # stops (braking from the last velocity within the limits)
    s.reset()
    assert np.array_equal(s.q, s.q0) and s.target is s.home and np.all(s.teleop.velocity == 0)


def test_session_on_a_free_flyer():
    """The floating G1 (nq = 24, nv = 23): the session steps (the Teleoperator moves q by integrate) and its
    read-out compares the joints, not the quaternion, with the limits (one name per velocity)."""
    system = cg.systems.load("g1_arms", free_flyer=True)
    task = cg.cooperative_task(system, "point_pair")
    s = TeleopSession(task, dt=DT)
    p, wxyz, _ = s.handle_pose()
    assert s.set_target_pose(p + [0.05, 0.0, 0.03], wxyz, 1.0)
    errors = [s.step().error_norm for _ in range(120)]
    assert errors[-1] < 1e-3 < errors[0]
    assert abs(np.linalg.norm(s.q[3:7]) - 1.0) < 1e-12 and np.linalg.norm(s.q[:3]) > 1e-3
    r = s.readout
    assert not any(n.startswith("root") for n in r.at_position_limit)
    # a joint put at its upper limit is named, with the free flyer's coordinates shifting nothing
    q = system.q0.copy()
    j = system.joint_names.index(system.joint_names[10])
    q[system.model.idx_qs[system.model.getJointId(system.joint_names[j])]] = system.limits.upper[j]
    s.teleop.q = q
    assert system.joint_names[j] in s._read(np.zeros(6), np.zeros(system.nv), 0.0).at_position_limit
