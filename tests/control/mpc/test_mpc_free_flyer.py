"""The receding-horizon controller on the floating G1 (nq = 24, nv = 23): a point pair carried forward and up past
the fixed pelvis' reach, in a kinematic loop (ticks, safety steps and pinocchio.integrate between them).

References: Pinocchio's forward kinematics (the hands on the moving target), Pinocchio's RNEA (the torque), the
joint limits in q̇ coordinates, and the fixed-pelvis G1 under the same controller (it falls behind)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import coop_ga as cg
from coop_ga.control.mpc import CooperativeMPC, MovingSphere, MPCInfeasibleError, MPCOptions
from coop_ga.cooperative.targets import displaced_target
from coop_ga.errors import InvalidInputError

OPTS = MPCOptions(horizon=10, dt=0.02, period=0.04, first_iter=10)
SPEED = np.array([0.5, 0.0, 0.25])  # [m/s] the target's velocity


def _target(task, q0):
    return lambda t: displaced_target(task, q0, translation=tuple(SPEED * t))


def _hands(s, q) -> np.ndarray:
    d = s.model.createData()
    pin.framesForwardKinematics(s.model, d, q)
    return np.array([d.oMf[s.model.getFrameId(f)].translation for f in s.end_frames])


def _run(task, ticks: int = 25):
    s = task.system
    mpc = CooperativeMPC(task, _target(task, s.q0), OPTS, time_budget=60.0)
    q, qd, t, errs, plans = s.q0.copy(), np.zeros(s.nv), 0.0, [], []
    for _ in range(ticks):  # 1 s
        tick = mpc.tick(t, q, qd)
        plans.append(tick)
        for _ in range(4):
            f = mpc.filter(t, q, qd)
            q, qd, t = s.integrate(q, 0.01 * 0.5 * (qd + f.velocity)), f.velocity, t + 0.01
        errs.append(tick.error)
    return mpc, q, qd, t, np.array(errs), plans


@pytest.fixture(scope="module")
def floating():
    return cg.cooperative_task(cg.systems.load("g1_arms", free_flyer=True), "point_pair")


def test_floating_g1_tracks_a_target_the_fixed_pelvis_cannot(floating) -> None:
    s = floating.system
    _, q, qd, t, errs, plans = _run(floating)
    hands = _hands(s, q)
    expected = _hands(s, s.q0) + SPEED * t
    # 0.56 m from the start the hands follow the target at a steady lag (~2 cm at 0.56 m/s: ‖e‖ ≈ 0.12 on a point
    # pair of radius ~0.2 m) and every plan ends on the target one horizon ahead
    assert np.abs(hands - expected).max() < 0.025
    assert errs[0] < 1e-9 and errs[-5:].max() < 0.13 and np.ptp(errs[-5:]) < 5e-3
    assert max(tick.terminal_error for tick in plans) < 1e-4
    assert np.linalg.norm(q[:3] - s.q0[:3]) > 0.2 and abs(np.linalg.norm(q[3:7]) - 1.0) <= 1e-12
    assert s.limits.position_violation(s.limit_coordinates(q)) == 0.0 and s.limits.velocity_violation(qd) <= 1e-9
    for tick in plans:
        assert tick.violation == 0.0 and tick.plan_q.shape == (11, 24) and tick.plan_u.shape == (10, 23)
        assert np.abs(np.linalg.norm(tick.plan_q[:, 3:7], axis=1) - 1.0).max() <= 1e-12
        tau = pin.rnea(s.model, s.model.createData(), tick.plan_q[0], tick.plan_qd[0], tick.acceleration)
        np.testing.assert_allclose(tick.torque, tau, rtol=0, atol=1e-9)
    fixed = cg.cooperative_task(cg.systems.load("g1_arms"), "point_pair")
    _, qf, _, tf, _, _ = _run(fixed)
    assert np.abs(_hands(fixed.system, qf) - (_hands(fixed.system, fixed.system.q0) + SPEED * tf)).max() > 0.1


def test_sampled_plan_starts_at_the_state_and_moves_on_the_manifold(floating) -> None:
    s = floating.system
    mpc = CooperativeMPC(floating, _target(floating, s.q0), OPTS, time_budget=60.0)
    tick = mpc.tick(0.0, s.q0, np.zeros(s.nv))
    q0, v0 = mpc.sample_plan(0.0)
    np.testing.assert_array_equal(q0, s.q0)
    assert np.abs(v0).max() == 0.0  # from rest
    for k in (1, 5):  # at the knots the sample is the plan's own knot, to the chart's second order in Δt
        qk, vk = mpc.sample_plan(k * OPTS.dt)
        assert np.abs(s.difference(tick.plan_q[k], qk)).max() <= 1e-6 and np.abs(vk - tick.plan_qd[k]).max() <= 1e-3


def test_bad_state_on_a_free_flyer(floating) -> None:
    s = floating.system
    mpc = CooperativeMPC(floating, _target(floating, s.q0), OPTS, time_budget=60.0)
    q = s.q0.copy()
    q[3:7] *= 2.0
    with pytest.raises(InvalidInputError, match=r"q of system.*quaternion.*norm 2"):
        mpc.tick(0.0, q, np.zeros(s.nv))
    with pytest.raises(InvalidInputError, match="qd"):
        mpc.tick(0.0, s.q0, np.zeros(s.nq))
    q = s.q0.copy()
    q[7] = s.limits.upper[6] + 0.1  # the first joint after the flyer, past its upper limit
    with pytest.raises(MPCInfeasibleError, match=rf"{s.limits.joint_names[6]} \(upper position limit\)"):
        mpc.tick(0.0, q, np.zeros(s.nv))


def test_safety_layer_keeps_a_moving_sphere_off_with_the_pelvis(floating) -> None:
    """A sphere runs at 0.3 m/s into the right hand, which holds its target: the safety layer's clearance rows
    (nv columns) keep it off by d_safe, and the floating pelvis gives way (it backs off)."""
    s = floating.system
    p = _hands(s, s.q0)[0]
    sphere = MovingSphere(0.05, lambda t: p + np.array([0.35 - 0.3 * t, 0.0, 0.0]))
    hold = displaced_target(floating, s.q0, translation=(0.0, 0.0, 0.0))  # the start's primitive, held
    mpc = CooperativeMPC(floating, lambda t: hold, OPTS, obstacles=[sphere], self_collision=False, time_budget=60.0)
    q, qd, t, d_min = s.q0.copy(), np.zeros(s.nv), 0.0, np.inf
    for _ in range(40):  # 1.6 s: the sphere passes where the hand was after ~1.2 s
        mpc.tick(t, q, qd)
        for _ in range(4):
            f = mpc.filter(t, q, qd)
            q, qd, t = s.integrate(q, 0.01 * 0.5 * (qd + f.velocity)), f.velocity, t + 0.01
            d_min = min(d_min, float(mpc.world.model.distances(q).min()))
    assert d_min >= OPTS.d_safe - 1e-3 and q[0] < -0.05
    assert abs(np.linalg.norm(q[3:7]) - 1.0) <= 1e-12
