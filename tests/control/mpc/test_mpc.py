"""The receding-horizon controller: its tick and safety layer on three_franka, and its bad inputs."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from coop_ga.control.mpc import CooperativeMPC, MovingSphere, MPCInfeasibleError, MPCOptions, TargetSchedule
from coop_ga.errors import InfeasibleConstraintsError, InvalidInputError, NonFiniteError, RateWarning

OPTS = MPCOptions(horizon=10, dt=0.02, period=0.04, first_iter=10)


@pytest.fixture(scope="module")
def setup(load_system):
    import coop_ga as cg
    from coop_ga.geometry import primitives as P
    from coop_ga.sim.mpc_track import figure_eight_target

    s = load_system("three_franka")
    task = cg.cooperative_task(s, "circle")
    q0 = np.array(s.q0, float)
    X0 = task.primitive(q0)
    target = figure_eight_target(np.asarray(P.center(X0), float), float(P.radius(X0)))
    return task, q0, target


def _far_sphere() -> MovingSphere:
    return MovingSphere(0.05, lambda t: np.array([2.0, 2.0, 1.0 + 0.1 * t]))


def test_kinematic_loop_tracks_within_limits(setup):
    """Ticks, safety steps and an exact double-integrator between them: the primitive follows V_d(t), the plan
    and the filtered motion stay inside the limits, and u_0's torque is the RNEA's."""
    task, q0, target = setup
    mpc = CooperativeMPC(task, target, OPTS, obstacles=[_far_sphere()], time_budget=60.0)
    q, qd, t = q0.copy(), np.zeros(task.nq), 0.0
    errs = []
    for _ in range(20):  # 0.8 s
        tick = mpc.tick(t, q, qd)
        assert tick.violation == 0.0
        for _ in range(4):
            f = mpc.filter(t, q, qd)
            q, qd, t = q + 0.01 * 0.5 * (qd + f.velocity), f.velocity, t + 0.01
        errs.append(tick.error)
    lim = task.system.limits
    assert lim.position_violation(q) == 0.0 and lim.velocity_violation(qd) == 0.0
    assert max(errs[5:]) < 0.03  # ‖e‖ (7-vector) while the target moves ±10 cm / ±15 % radius
    assert errs[0] < 1e-6  # the target starts on the primitive
    assert np.allclose(tick.torque, mpc.torque(tick.plan_q[0], tick.plan_qd[0], tick.acceleration))
    assert mpc.ticks == 20 and mpc.overruns == 0


def test_warm_start_is_the_shifted_plan(setup):
    task, q0, target = setup
    mpc = CooperativeMPC(task, target, OPTS, time_budget=60.0)
    tick = mpc.tick(0.0, q0, np.zeros(task.nq))
    u = mpc._warm_start()
    assert u is not None and u.shape == tick.plan_u.shape
    assert np.array_equal(u[:-2], tick.plan_u[2:]) and np.array_equal(u[-1], tick.plan_u[-1])


@pytest.mark.parametrize(
    ("bad", "error", "words"),
    [
        (lambda t: np.zeros(3), InvalidInputError, "not a coop_ga.Similarity"),
        (lambda t: "circle", InvalidInputError, "not a coop_ga.Similarity"),
        ("nan", NonFiniteError, "NaN"),
    ],
)
def test_bad_target(setup, bad, error, words):
    from coop_ga.sim import circle_target

    task, q0, _ = setup
    if bad == "nan":
        bad = lambda t: circle_target((math.nan, 0.0, 0.5), 0.4)  # noqa: E731
    mpc = CooperativeMPC(task, bad, OPTS)
    with pytest.raises(error, match=words) as info:
        mpc.tick(0.25, q0, np.zeros(task.nq))
    assert "t = 0.2500" in str(info.value) or "t = 0.6500" in str(info.value)


@pytest.mark.parametrize(
    ("coeffs", "words"), [(np.zeros(12), "no rotor part"), (np.random.default_rng(0).normal(size=12), "dilator")]
)
def test_target_similarity_with_non_versor_coefficients(setup, coeffs, words):
    """A Similarity built unchecked (``check=False``) around 12 numbers that are no similarity versor is refused,
    naming the time."""
    from coop_ga.algebra import Multivector
    from coop_ga.errors import InvalidVersorError
    from coop_ga.geometry.groups import SIMILARITY_BLADES, Similarity

    task, q0, _ = setup
    V = Similarity(Multivector(SIMILARITY_BLADES, tuple(coeffs.tolist())), check=False)
    mpc = CooperativeMPC(task, lambda t: V, OPTS)
    with pytest.raises(InvalidVersorError, match=words) as info:
        mpc.tick(0.25, q0, np.zeros(task.nq))
    assert "the target at t = 0.2500 s is not a similarity versor" in str(info.value)


def test_bad_target_forms(setup):
    task, _, _ = setup
    with pytest.raises(InvalidInputError, match="callable"):
        TargetSchedule(42, task)
    with pytest.raises(InvalidInputError, match="increasing"):
        TargetSchedule(([0.0, 0.0], [None, None]), task)


def test_reference_trajectory_target(setup):
    """A sampled reference (coop_ga.reference_trajectory) is interpolated and held at its ends."""
    from coop_ga import reference_trajectory
    from coop_ga.control import displaced_target

    task, q0, _ = setup
    V0 = task.similarity(q0)
    V1 = displaced_target(task, q0, translation=(0.05, 0.0, 0.0))
    ts, poses, _ = reference_trajectory(V0, V1, 1.0, 11)
    sched = TargetSchedule((ts, poses), task)
    assert np.allclose(sched(-1.0).coeffs, poses[0].coeffs) and np.allclose(sched(5.0).coeffs, poses[-1].coeffs)
    assert np.allclose(sched(0.3).coeffs, poses[3].coeffs, atol=1e-12)
    mid = sched(0.35)
    assert np.linalg.norm(task.error(q0, mid)) > np.linalg.norm(task.error(q0, poses[3]))


def test_rate_warning_once_and_counted(setup):
    task, q0, target = setup
    mpc = CooperativeMPC(task, target, OPTS, time_budget=1e-6)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ticks = [mpc.tick(0.04 * k, q0, np.zeros(task.nq)) for k in range(3)]
    rate = [w for w in caught if issubclass(w.category, RateWarning)]
    assert len(rate) == 1  # once per controller, with the first late tick's measured time and the budget
    assert f"took {1e3 * ticks[0].tick_time:.1f} ms, more than its budget of 0.0 ms" in str(rate[0].message)
    assert mpc.overruns == 3 and mpc.ticks == 3 and all(k.overrun for k in ticks)  # counted, none skipped
    assert [k.time for k in ticks] == [0.0, 0.04, 0.08]


def test_infeasible_state_gives_active_set_and_brake(setup):
    task, q0, target = setup
    mpc = CooperativeMPC(task, target, OPTS)
    lim = task.system.limits
    q = q0.copy()
    q[3] = lim.upper[3] + 0.01
    qd = np.zeros(task.nq)
    qd[0] = 1.5 * lim.velocity[0]
    with pytest.raises(InfeasibleConstraintsError) as info:
        mpc.tick(0.0, q, qd)
    err = info.value
    assert isinstance(err, MPCInfeasibleError)
    names = lim.joint_names
    assert f"{names[3]} (upper position limit)" in err.active and f"{names[0]} (velocity limit)" in err.active
    a = err.fallback_acceleration
    assert np.all(np.abs(a) <= lim.acceleration + 1e-12)
    assert a[0] == -lim.acceleration[0]  # braking the over-speed joint as hard as allowed
    assert np.allclose(err.fallback_torque, mpc.torque(q, qd, a))


def test_infeasible_safety_qp_gives_active_set_and_brake(setup):
    """A sphere 5.6 cm from arm 0's fingers closing in at 3 m/s: no joint velocity within the limits moves the
    arm away fast enough, so the safety QP has no feasible point — the error names the clearance rows within
    d_influence (the most violated one first in its message) and gives the braking command."""
    task, q0, target = setup
    tcp = task.points(q0)[0]
    path = lambda t: tcp + (0.13 - 3.0 * t) * np.array([0.0, -1.0, 0.0])  # noqa: E731
    mpc = CooperativeMPC(task, target, OPTS, obstacles=[MovingSphere(0.05, path)], time_budget=60.0)
    mpc.tick(0.0, q0, np.zeros(task.nq))
    qd = np.zeros(task.nq)
    qd[0] = 0.1  # [rad/s] moving: the brake is not zero
    d = mpc.world.model.distances(q0)
    assert 0.0 < d.min() < mpc.o.d_influence  # the state itself is feasible (no penetration)
    with pytest.raises(MPCInfeasibleError, match="the safety QP is infeasible") as info:
        mpc.filter(0.0, q0, qd)
    err = info.value
    assert "most violated: clearance of arm0_panda_leftfinger – obstacle" in str(err)
    assert len(err.active) == int(np.sum(d < mpc.o.d_influence))  # every pair within d_influence, by name
    near_sphere = [a for a in err.active if a.endswith("– obstacle")]
    assert "clearance of arm0_panda_leftfinger – obstacle" in near_sphere
    assert all(a.startswith("clearance of arm0_") for a in near_sphere)  # the sphere is at arm 0's hand
    lim = task.system.limits
    a = err.fallback_acceleration
    assert a[0] == pytest.approx(max(-0.1 / mpc.o.filter_dt, -lim.acceleration[0])) and np.all(a[1:] == 0.0)
    assert np.allclose(err.fallback_torque, mpc.torque(q0, qd, a))


def test_one_collision_evaluation_per_instant(setup):
    """A tick and the safety step at the same (t, q, q̇) share one evaluation of the collision model (distances and
    Jacobian: the state check, the clearance rows and the rows' obstacle rates); a step at a new instant makes one
    more, plus the one at the sphere's shifted position for ∂d/∂t — the filtered velocity is unchanged by it."""
    task, q0, target = setup
    tcp = task.points(q0)[0]
    sphere = MovingSphere(0.05, lambda t: tcp + (0.2 - 0.1 * t) * np.array([0.0, -1.0, 0.0]))  # within d_influence
    mpc = CooperativeMPC(task, target, OPTS, obstacles=[sphere], time_budget=60.0)
    model, calls = mpc.world.model, {"distances": 0, "distances_and_jacobian": 0}
    for name in calls:
        method = getattr(model, name)

        def counted(*args, _method=method, _name=name):
            calls[_name] += 1
            return _method(*args)

        setattr(model, name, counted)  # the instance attribute shadows the method
    qd = np.zeros(task.nq)
    mpc.tick(0.0, q0, qd)
    first = mpc.filter(0.0, q0, qd)
    assert calls == {"distances": 1, "distances_and_jacobian": 1}  # the shifted sphere's, and the shared one
    q1, qd1 = mpc.sample_plan(0.01)
    mpc.filter(0.01, q1, qd1)
    assert calls == {"distances": 2, "distances_and_jacobian": 2}
    fresh = CooperativeMPC(task, target, OPTS, obstacles=[sphere], time_budget=60.0)
    fresh.tick(0.0, q0, qd)
    fresh.world.at(0.5)  # the obstacles moved elsewhere in between: the step places them again
    np.testing.assert_array_equal(fresh.filter(0.0, q0, qd).velocity, first.velocity)


def test_penetrating_obstacle_is_infeasible(setup):
    task, q0, target = setup
    tcp = task.points(q0)[0]
    mpc = CooperativeMPC(task, target, OPTS, obstacles=[MovingSphere(0.05, lambda t: tcp)])
    with pytest.raises(MPCInfeasibleError, match="clearance of"):
        mpc.tick(0.0, q0, np.zeros(task.nq))


def test_moving_obstacle_dampers_account_for_its_motion(setup):
    """(A1'): the row bound drops by the sphere's approach speed; a sphere closing in inside d_safe forces a
    retreat (negative bound), and the filtered velocity obeys it."""
    task, q0, target = setup
    tcp = task.points(q0)[0]
    away = np.array([0.0, -1.0, 0.0])  # arm 0's TCP is at −y: the sphere comes from further out in −y
    gap = 0.02 + 0.05 + 0.06  # clearance 2 cm beyond a generous capsule radius estimate
    path = lambda t: tcp + (gap - 0.1 * t) * away  # noqa: E731  approaching at 0.1 m/s
    mpc = CooperativeMPC(task, target, OPTS, obstacles=[MovingSphere(0.05, path)], time_budget=60.0)
    mpc.tick(0.0, q0, np.zeros(task.nq))
    mpc.world.at(0.0)
    rate = mpc.world.obstacle_rate(q0)
    n_obs = mpc.world.model.n_obstacle_rows
    d = mpc.world.model.distances(q0)
    k = int(np.argmin(d[:n_obs]))
    assert rate[k] == pytest.approx(-0.1, abs=0.02) and np.all(rate[n_obs:] == 0.0)
    f = mpc.filter(0.0, q0, np.zeros(task.nq))
    _, J = mpc.world.model.distances_and_jacobian(q0)
    assert J[k] @ f.velocity + rate[k] >= -0.5 * (d[k] - mpc.o.d_safe) / mpc.o.filter_dt - 1e-6


def _shrinking_loop(task, q0, avoid: bool):
    """The circle's target radius shrinks from 0.49 m to 5 cm in 0.6 s: the hands would meet in the middle."""
    from coop_ga.sim import circle_target

    c0 = task.points(q0).mean(axis=0)
    r0 = float(np.linalg.norm(task.points(q0)[0] - c0))
    target = lambda t: circle_target(c0, r0 + (0.05 - r0) * min(t / 0.6, 1.0))  # noqa: E731
    mpc = CooperativeMPC(task, target, OPTS, avoid=avoid, time_budget=60.0)
    inter = mpc.world.model.inter_branch
    q, qd, t = q0.copy(), np.zeros(task.nq), 0.0
    arm_arm, active = [], False
    for _ in range(20):  # 0.8 s
        mpc.tick(t, q, qd)
        for _ in range(4):
            f = mpc.filter(t, q, qd)
            active |= any(a.startswith("clearance of") for a in f.active)
            q, qd, t = q + 0.01 * 0.5 * (qd + f.velocity), f.velocity, t + 0.01
            arm_arm.append(float(mpc.world.model.distances(q)[inter].min()))
    return min(arm_arm), active


def test_arm_arm_clearance_is_a_hard_constraint(setup):
    """Closing the circle drives the three hands together: the safety QP's self rows stop them at d_safe (to first
    order), while the same controller without them lets the arms interpenetrate."""
    task, q0, _ = setup
    d_min, active = _shrinking_loop(task, q0, avoid=True)
    assert active and d_min > 0.5 * OPTS.d_safe
    d_blind, _ = _shrinking_loop(task, q0, avoid=False)
    assert d_blind < 0.0
