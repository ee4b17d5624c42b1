"""Limits as data (limits issue, item 1): position, velocity, acceleration and effort limits, overrides by name."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import coop_ga as cg
from coop_ga.systems.limits import DEFAULT_VELOCITY_LIMIT, JointLimits


@pytest.mark.parametrize("name", cg.systems.names())
def test_limits_come_from_the_model(load_system, name):
    s = load_system(name)
    lim = s.limits
    assert lim.joint_names == tuple(s.joint_names)
    np.testing.assert_array_equal(lim.lower, s.model.lowerPositionLimit)
    np.testing.assert_array_equal(lim.upper, s.model.upperPositionLimit)
    np.testing.assert_array_equal(lim.velocity, s.model.velocityLimit)  # every shipped URDF has them
    assert not lim.velocity_defaulted.any()
    assert np.all(lim.velocity > 0) and np.all(lim.effort > 0)
    assert lim.position_violation(s.q0) == 0.0


def test_franka_acceleration_limits_are_the_datasheet_values(load_system):
    s = load_system("three_franka")
    np.testing.assert_array_equal(s.limits.acceleration, np.tile([15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0], 3))
    assert np.all(np.isinf(load_system("g1_arms").limits.acceleration))


def test_missing_velocity_limit_gets_the_documented_default():
    m = pin.Model()
    m.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "j0")
    m.addFrame(pin.Frame("tip", 1, pin.SE3(np.eye(3), np.array([1.0, 0, 0])), pin.FrameType.OP_FRAME))
    s = cg.systems.from_model(m, ["tip"], name="one_joint")
    assert s.limits.velocity[0] == DEFAULT_VELOCITY_LIMIT and s.limits.velocity_defaulted[0]
    assert np.isinf(s.limits.lower[0]) and np.isinf(s.limits.upper[0])  # Pinocchio's ±max double: unbounded
    assert np.isinf(s.limits.acceleration[0])


def test_overrides_by_joint_name_return_a_new_system(load_system):
    s = load_system("three_franka")
    j = "arm0_panda_joint4"
    i = s.joint_names.index(j)
    t = s.with_limits(position={j: (-2.5, -0.2)}, velocity={"arm1_panda_joint1": 1.0}, acceleration=5.0, effort=50.0)
    assert (t.q_lower[i], t.q_upper[i]) == (-2.5, -0.2)
    assert t.limits.velocity[s.joint_names.index("arm1_panda_joint1")] == 1.0
    assert np.all(t.limits.acceleration == 5.0) and np.all(t.limits.effort == 50.0)
    # the original is untouched, and so is the (shared) model
    assert s.q_upper[i] != -0.2 and s.limits.velocity[7] != 1.0
    assert float(s.model.upperPositionLimit[i]) == float(s.q_upper[i])
    # controllers read the new limits
    task = cg.cooperative_task(t, "circle")
    _lo, hi = cg.control.base.bounds(task)
    assert hi[i] == -0.2


def test_bad_limits_are_refused(load_system):
    s = load_system("three_franka")
    with pytest.raises(cg.UnknownNameError, match="no_such_joint"):
        s.with_limits(velocity={"no_such_joint": 1.0})
    with pytest.raises(cg.InvalidInputError):
        s.with_limits(position={"arm0_panda_joint1": (1.0, -1.0)})
    with pytest.raises(cg.InvalidInputError):
        s.with_limits(velocity=0.0)
    with pytest.raises(cg.InvalidInputError):
        s.with_limits(acceleration=np.nan)
    with pytest.raises(cg.InvalidInputError):
        JointLimits(("a",), [0.0], [1.0], [1.0], [np.inf], [np.nan], [False])


def test_violation_measures():
    lim = JointLimits(("a", "b"), [-1.0, 0.0], [1.0, 2.0], [1.0, 2.0], [3.0, np.inf], [10.0, 10.0], [False, False])
    assert lim.position_violation([[0.0, 1.0], [1.5, -0.25]]) == pytest.approx(0.5)
    assert lim.velocity_violation([0.5, -2.5]) == pytest.approx(0.5)
    assert lim.acceleration_violation([-3.5, 100.0]) == pytest.approx(0.5)
    assert lim.effort_violation([11.0, 0.0]) == pytest.approx(1.0)
    np.testing.assert_array_equal(lim.clip([2.0, -1.0]), [1.0, 0.0])
    assert "a=2.0000 not in" in lim.describe([2.0, 1.0])


def test_trajectory_velocity_violation_discounts_only_rounding():
    lim = cg.systems.load("three_franka").limits
    dt = 0.01
    v = lim.velocity
    q0 = 0.5 * (lim.lower + lim.upper) + 0.3
    # a step of exactly the limit speed on every joint: its finite difference may read ~1e-15 above it
    traj = np.stack([q0, q0 + v * dt, q0 + 2 * v * dt])
    assert lim.trajectory_velocity_violation(traj, dt) == 0.0
    # a real overshoot of 1e-6 rad/s on one joint is reported (to the rounding resolution)
    traj[2, 3] += 1e-6 * dt
    assert lim.trajectory_velocity_violation(traj, dt) == pytest.approx(1e-6, abs=1e-12)
    assert lim.trajectory_velocity_violation(traj[:1], dt) == 0.0
