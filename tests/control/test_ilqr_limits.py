"""iLQR under joint limits: every trajectory inside the bounds, binding bounds handled,
infeasible targets reported honestly, no run-away steps on the cases of the robustness study."""

from __future__ import annotations

import zlib

import example_robot_data as erd
import numpy as np
import pytest
from scipy.optimize import least_squares

import coop_ga as cg
from coop_ga.control import displaced_target, ilqr_reach


def _random_target(task, q0, rng, translation, angle_deg, scale):
    d = rng.normal(size=3)
    d /= np.linalg.norm(d)
    return displaced_target(
        task,
        q0,
        translation=translation * d,
        axis=rng.normal(size=3),
        angle=np.deg2rad(angle_deg),
        scale=1.0 + scale * rng.choice([-1.0, 1.0]),
    )


def _within(res, system, tol=1e-9):
    lim = system.limits
    assert lim.position_violation(res.trajectory) <= tol
    assert lim.velocity_violation(res.qd) <= tol
    assert lim.acceleration_violation(res.u) <= tol
    assert res.joint_limit_violation <= tol and res.velocity_violation <= tol and res.acceleration_violation <= tol


@pytest.fixture(scope="module")
def flagship(load_system):
    s = load_system("three_franka")
    task = cg.cooperative_task(s, "circle")
    q0 = np.array(s.q0)
    V = displaced_target(task, q0, translation=(0.1, -0.05, 0.1), axis=(1, 0, 0), angle=np.deg2rad(25), scale=1.25)
    return s, task, q0, V


def _certified(task, q0, V) -> bool:
    """Reachable inside the position limits: an independent bounded least-squares solve reaches ‖e‖ < 1e-6."""
    s = task.system
    res = least_squares(
        lambda q: task.error(q, V),
        q0,
        jac=lambda q: task.error_jacobian(q, V),
        bounds=(s.q_lower, s.q_upper),
        xtol=1e-14,
        ftol=1e-14,
        gtol=1e-14,
        max_nfev=300,
    )
    return bool(np.linalg.norm(res.fun) < 1e-6)


@pytest.mark.parametrize(
    ("name", "kind", "level"),
    [
        ("three_franka", "circle", (0.15, 35.0, 0.3)),
        ("hexapod", "circle", (0.05, 15.0, 0.15)),
        ("allegro", "sphere", (0.02, 10.0, 0.1)),
        ("g1_arms", "line", (0.15, 35.0, 0.3)),
    ],
)
def test_targets_converge_inside_the_limits(load_system, name, kind, level):
    """Certified targets (the study's levels; smaller ones for the hand and the legs) converge, from rest
    and moving (q̇₀ ~ U(±0.2) rad/s), inside every bound; uncertified ones are reported, inside the bounds."""
    s = load_system(name)
    task = cg.cooperative_task(s, kind)
    q0 = np.array(s.q0)
    rng = np.random.default_rng(zlib.crc32(f"{name}-{kind}".encode()))
    travel, certified = [], 0
    for k in range(3):
        V = _random_target(task, q0, rng, *level)
        ok = _certified(task, q0, V)
        certified += ok
        for qd0 in (None, rng.uniform(-0.2, 0.2, s.nq)):
            res = ilqr_reach(task, q0, V, qd_init=qd0)
            _within(res, s)
            travel.append(float(np.max(np.abs(res.trajectory - q0))))
            if ok:
                assert res.converged, (k, res.message)
                assert res.error < 1e-5
            elif not res.converged:
                assert "not converged" in res.message
    print(f"{name} {kind}: {certified}/3 certified, max joint travel {max(travel):.3f} rad")
    assert certified >= 1
    assert max(travel) < np.pi  # no run-away (the study saw 118 rad)


def test_binding_velocity_limit(flagship):
    """|q̇| ≤ 0.2 rad/s binds on the flagship (its free optimum peaks at 0.24 rad/s): reached, exactly inside."""
    s, _, q0, V = flagship
    free = ilqr_reach(cg.cooperative_task(s, "circle"), q0, V)
    assert np.abs(free.qd).max() > 0.22
    slow = s.with_limits(velocity=0.2)
    res = ilqr_reach(cg.cooperative_task(slow, "circle"), q0, V)
    assert res.converged, res.message
    _within(res, slow)
    assert np.abs(res.qd).max() == pytest.approx(0.2, abs=2e-3)  # the bound is active
    assert res.cost > free.cost  # and costs something
    assert any("velocity" in a for a in res.active_constraints)
    assert any(st.backward == "riccati" for st in res.stats)  # the AL/box-DDP pass did the work


def test_binding_acceleration_limit_box_ddp(flagship):
    s, _, q0, V = flagship
    slow = s.with_limits(acceleration=0.3)
    res = ilqr_reach(cg.cooperative_task(slow, "circle"), q0, V)
    assert res.converged, res.message
    _within(res, slow)
    assert np.abs(res.u).max() == pytest.approx(0.3, abs=1e-9)


def test_binding_position_limit_at_the_end(flagship):
    """A joint range that excludes the free optimum's final angle: the closed-form step over the bounded
    terminal state reaches the target with that joint on its limit."""
    s, task, q0, V = flagship
    free = ilqr_reach(task, q0, V)
    i = int(np.argmax(np.abs(free.q - q0)))
    j = s.joint_names[i]
    lo, hi = s.q_lower[i], s.q_upper[i]
    half = q0[i] + 0.5 * (free.q[i] - q0[i])
    narrow = s.with_limits(position={j: (lo, half) if free.q[i] > q0[i] else (half, hi)})
    res = ilqr_reach(cg.cooperative_task(narrow, "circle"), q0, V)
    assert res.converged, res.message
    _within(res, narrow)
    assert res.q[i] == pytest.approx(half, abs=1e-6)
    assert res.iterations <= 10


def test_infeasible_target_is_reported_not_hidden(load_system):
    """Three Allegro joints limited to half their free motion: the target is not reachable inside the limits
    (a bounded least-squares solve stops at ‖e‖ = 0.026); iLQR says so, inside the limits."""
    s = load_system("allegro")
    task = cg.cooperative_task(s, "sphere")
    q0 = np.array(s.q0)
    V = displaced_target(task, q0, translation=(0.005, 0.01, 0.0), axis=(1, 0, 0), angle=np.deg2rad(10), scale=1.1)
    free = ilqr_reach(task, q0, V)
    d = free.q - q0
    pos = {}
    for i in np.argsort(-np.abs(d))[:3]:
        lo, hi = s.q_lower[i], s.q_upper[i]
        pos[s.joint_names[i]] = (lo, q0[i] + 0.5 * d[i]) if d[i] > 0 else (q0[i] + 0.5 * d[i], hi)
    narrow = s.with_limits(position=pos)
    res = ilqr_reach(cg.cooperative_task(narrow, "sphere"), q0, V)
    assert not res.converged
    assert res.error > 0.02
    _within(res, narrow)
    assert "not converged" in res.message and "‖e‖" in res.message


def test_unreachable_target_is_reported(flagship):
    s, task, q0, _ = flagship
    far = displaced_target(task, q0, scale=10.0)  # a circle of radius 4 m
    res = ilqr_reach(task, q0, far, max_iter=15)
    assert not res.converged and res.error > 0.1
    _within(res, s)


def test_allegro_left_hand_from_neutral_does_not_run_away():
    """The newcomer's case of the study: Allegro left hand from neutral toward a random target (|q| = 407 rad before)."""
    r = erd.load("allegro_left_hand")
    hand = cg.systems.from_model(
        r.model, ["link_3.0_tip", "link_7.0_tip", "link_11.0_tip", "link_15.0_tip"], name="allegro_left"
    )
    task = cg.cooperative_task(hand, "sphere")
    q0 = np.array(hand.q0)
    rng = np.random.default_rng(407)
    for _ in range(3):
        V = _random_target(task, q0, rng, 0.01, 10.0, 0.05)
        res = ilqr_reach(task, q0, V)
        _within(res, hand)
        assert np.abs(res.trajectory).max() < 2.0  # the hand's joint ranges are within ±1.8 rad
        if not res.converged:
            assert "not converged" in res.message


def test_limits_none_keeps_the_unconstrained_solver(flagship):
    _, task, q0, V = flagship
    a = ilqr_reach(task, q0, V, limit_mode="none")
    b = ilqr_reach(task, q0, V)
    assert a.converged and b.converged
    np.testing.assert_allclose(a.q, b.q, atol=1e-9)  # no bound is active on the flagship: the same iterates


def test_soft_terminal_is_eq57(flagship):
    """terminal='soft' solves Eq 57 exactly: it keeps the penalty's bias e* ≈ λ*/(2Q) (here ~1e-6)."""
    _, task, q0, V = flagship
    res = ilqr_reach(task, q0, V, terminal="soft", tol=0.0, max_iter=30)
    assert 1e-8 < res.error < 1e-5
    hard = ilqr_reach(task, q0, V, tol=1e-9, max_iter=30)
    assert hard.error < 1e-9  # the multiplier shift removes the bias


def test_restart_from_the_bounded_ik_configuration(load_system):
    """Allegro plane, 11 cm / 35° / ×1.3 (robustness benchmark, seed 0, large #5): the first solve stalls with joint 4
    on its upper limit at ‖e‖ = 0.023; the restart from the minimum-energy controls to the bounded Gauss–Newton
    configuration reaches the target inside the limits, and the result says so."""
    s = load_system("allegro")
    task = cg.cooperative_task(s, "plane")
    q0 = np.array(s.q0)
    V = displaced_target(
        task,
        q0,
        translation=(-0.1106214767677044, 0.10114961658422042, -0.0056252948898201155),
        axis=(0.5729264816812533, -0.3647019089074783, 0.7339943897793646),
        angle=0.6108652381980153,
        scale=1.3,
    )
    first = ilqr_reach(task, q0, V, restart=False)
    assert not first.converged and first.error > 1e-3
    res = ilqr_reach(task, q0, V)
    assert res.converged and "restarted" in res.message, res.message
    _within(res, s)
    assert res.iterations == len(res.stats) == len(res.error_history) - 1


@pytest.fixture(scope="module")
def talos_arms():
    """Talos (example-robot-data) with its torso and arms: at q = 0 four arm joints sit exactly on a position bound
    (arm_left_2 and arm_right_2 on one bound, arm_left_4 and arm_right_4 on their upper bound)."""
    m = erd.load("talos").model
    locked = [n for n in list(m.names)[1:] if not n.startswith(("torso", "arm_"))]
    s = cg.systems.from_model(
        m, ["gripper_left_base_link", "gripper_right_base_link"], name="talos", locked_joints=locked
    )
    q = np.zeros(s.nq)  # the neutral configuration, built explicitly (not the system's default q0)
    on = (q <= s.q_lower) | (q >= s.q_upper)
    assert on.sum() == 4
    return s, q


@pytest.mark.parametrize("max_iter", [5, 20])
def test_start_on_a_position_bound_stays_inside(talos_arms, max_iter):
    """Rest on a bound is feasible, not strictly: the feasibility blend used to give up ("no strictly feasible
    reference") and return the AL iterate, 0.116 rad outside after 5 iterations.  Joint by joint, the joints on a
    bound blend with a reference that moves inward, so every returned trajectory is inside."""
    s, q = talos_arms
    task = cg.cooperative_task(s, "line")
    V = displaced_target(task, q, translation=(0.0, 0.0, -0.1))
    res = ilqr_reach(task, q, V, max_iter=max_iter)
    lim = s.limits
    assert lim.position_violation(res.trajectory) <= 1e-12
    assert lim.velocity_violation(res.qd) <= 1e-12 and lim.acceleration_violation(res.u) == 0.0
    assert res.joint_limit_violation <= 1e-12 and res.within_limits
    assert np.array_equal(res.trajectory[0], q)
    assert 0.0 < res.restoration < 1.0 and "blended joint by joint" in res.message
    assert not res.converged and "not converged" in res.message  # 0.1 m in 5 or 20 iterations from a bound: honest


def test_start_moving_out_through_a_bound(talos_arms):
    """A joint on its bound moving outward: with Talos' unbounded accelerations the reference reverses it in one knot,
    so the trajectory stays inside; with 10 rad/s² it cannot be stopped (0.2 rad/s needs 42 rad/s² in one knot of
    10 ms) and the result says so."""
    s, q = talos_arms
    i = s.joint_names.index("arm_left_4_joint")  # on its upper bound at q = 0
    qd = np.zeros(s.nq)
    qd[i] = 0.2
    task = cg.cooperative_task(s, "line")
    V = displaced_target(task, q, translation=(0.0, 0.0, -0.1))
    res = ilqr_reach(task, q, V, qd_init=qd, max_iter=5)
    assert s.limits.position_violation(res.trajectory) <= 1e-12 and res.within_limits
    stiff = s.with_limits(acceleration=10.0)
    res = ilqr_reach(cg.cooperative_task(stiff, "line"), q, V, qd_init=qd, max_iter=2)
    assert not res.converged and "cannot be kept inside the limits" in res.message
    assert res.joint_limit_violation > 0.0  # reported, not hidden
