"""Limits of the control layer: each one's inequality holds on the q̇ of a QP step (a large command that the
unconstrained step would carry beyond it), the braking bound is the exact discrete one, and the joint
boxes stay non-empty along a run (recursive feasibility)."""

from __future__ import annotations

import numpy as np
import pytest

import coop_ga as cg
from coop_ga.collision.distance import Sphere
from coop_ga.collision.model import CollisionModel
from coop_ga.control import (
    AccelerationLimit,
    BodyVelocityTask,
    ClearanceLimit,
    Configuration,
    ConfigurationLimit,
    LinearConstraint,
    PositionTask,
    SimilarityTask,
    UserConstraints,
    VelocityLimit,
    default_limits,
    displaced_target,
    solve_step,
)
from coop_ga.control.limits import braking_speed

DT = 0.01
BIG = np.array([0.0, 0.0, 0.0, 50.0, 0.0, 0.0, 0.0])  # a dilation of 50 /s: far beyond every limit


@pytest.fixture(scope="module")
def franka(load_system):
    s = load_system("three_franka")
    return s, cg.cooperative_task(s, "circle")


def _free(task, q, command):
    return solve_step(Configuration(task, q), [BodyVelocityTask(command)], [], DT).velocity


def test_configuration_limit(franka):
    s, task = franka
    lim = s.limits
    q = np.array(s.q0)
    q[3] = lim.lower[3] + 1e-3  # an elbow 1 mrad from its limit
    free = _free(task, q, BIG)
    assert np.any(q + DT * free < lim.lower) or np.any(q + DT * free > lim.upper)
    st = solve_step(Configuration(task, q), [BodyVelocityTask(BIG)], [ConfigurationLimit(0.95)], DT)
    q1 = q + DT * st.velocity
    assert st.used_qp
    assert np.all(q1 - lim.lower >= 0.05 * (q - lim.lower) - 1e-15)  # at most γ = 95 % of the way per step
    assert np.all(lim.upper - q1 >= 0.05 * (lim.upper - q) - 1e-15)


def test_velocity_limit(franka):
    s, task = franka
    q = np.array(s.q0)
    assert np.max(np.abs(_free(task, q, BIG)) / s.limits.velocity) > 5
    st = solve_step(Configuration(task, q), [BodyVelocityTask(BIG)], [VelocityLimit()], DT)
    assert st.used_qp and np.all(np.abs(st.velocity) <= s.limits.velocity + 1e-12)
    assert np.sum(np.isclose(np.abs(st.velocity), s.limits.velocity)) >= 6


def test_acceleration_limit(franka):
    s, task = franka
    a = s.limits.acceleration
    assert np.all(np.isfinite(a))  # the Franka's datasheet values
    q = np.array(s.q0)
    v_prev = np.linspace(-0.5, 0.5, s.nq)
    cfg = Configuration(task, q, v_prev)
    st = solve_step(cfg, [BodyVelocityTask(BIG)], [AccelerationLimit()], DT)
    assert st.used_qp and not st.relaxed
    assert np.all(np.abs(st.velocity - v_prev) <= a * DT + 1e-12)
    assert np.sum(np.isclose(np.abs(st.velocity - v_prev), a * DT)) >= 6


def test_braking_speed_is_the_discrete_stopping_bound():
    rng = np.random.default_rng(1)
    x, a = rng.uniform(0.0, 2.0, 50), rng.uniform(1.0, 20.0, 50)
    v = braking_speed(x, a, DT)
    for xi, ai, vi in zip(x, a, v):
        k = np.arange(int(vi / (ai * DT)) + 2)
        stop = DT * np.sum(np.maximum(vi - k * ai * DT, 0.0))  # decelerating by a Δt per step
        assert stop == pytest.approx(xi, rel=1e-12, abs=1e-15)
        assert DT * np.sum(np.maximum(vi * 1.001 - k * ai * DT, 0.0)) > xi  # and no faster speed stops in time
    np.testing.assert_array_equal(braking_speed(np.array([np.inf, 1.0]), np.array([1.0, np.inf]), DT), [np.inf] * 2)
    assert braking_speed(np.array([0.0]), np.array([5.0]), DT)[0] == 0.0


@pytest.mark.filterwarnings("ignore::coop_ga.errors.ChartWarning", "ignore::coop_ga.errors.DegeneracyWarning")
def test_joint_boxes_stay_feasible_along_a_run(franka):
    """Driven hard against the limits for 2 s, a joint never gets a box that the acceleration bounds and the
    position limits leave empty: no step drops the acceleration limit, and nothing is violated."""
    s, task = franka
    lim = s.limits
    rng = np.random.default_rng(2)
    for trial in range(3):
        q = np.clip(np.array(s.q0) + rng.uniform(-0.5, 0.5, s.nq), lim.lower, lim.upper)
        cfg = Configuration(task, q)
        command = rng.normal(size=7) * 20.0
        command[:3] = 0.0  # no rotation: the circle's axis stays far from its chart's half-turn
        limits = default_limits(lim)
        Q = [q]
        for _ in range(200):
            st = solve_step(cfg, [BodyVelocityTask(command)], limits, DT)
            assert not st.relaxed, trial
            q_next = np.clip(Q[-1] + DT * st.velocity, lim.lower, lim.upper)
            cfg.update(q_next, (q_next - Q[-1]) / DT)
            Q.append(q_next)
        Q = np.array(Q)
        V = np.vstack([np.zeros(s.nq), np.diff(Q, axis=0) / DT])
        assert lim.position_violation(Q) == 0.0
        assert np.all(np.abs(np.diff(V, axis=0)) <= lim.acceleration * DT + 1e-9)
        assert np.all(np.abs(V) <= lim.velocity + 1e-9)
        assert np.min(np.minimum(Q - lim.lower, lim.upper - Q)) < 0.01, trial  # the limits were reached


def test_clearance_limit_rows_hold(franka):
    s, task = franka
    q = np.array(s.q0)
    p0 = task.points(q)[0]
    cm = CollisionModel(s, obstacles=[Sphere(p0 + [0.0, 0.0, -0.07], 0.03)], self_collision=False)
    lim = ClearanceLimit(cm, d_safe=0.01, d_influence=0.1)
    cfg = Configuration(task, q)
    ineq = lim.inequalities(cfg, DT)
    assert ineq.G.shape[0] >= 1 and np.all(ineq.h >= 0.0)
    down = PositionTask(0, p0 + [0.0, 0.0, -0.5], gain=50.0, max_speed=None)  # straight into the sphere
    free = solve_step(cfg, [down], [], DT).velocity
    assert np.max(ineq.G @ free - ineq.h) > 0.0
    st = solve_step(cfg, [down], [lim], DT)
    assert st.used_qp and np.all(st.G @ st.velocity <= st.h + 1e-9)
    d0 = cm.distances(q)
    d1 = cm.distances(q + DT * st.velocity)
    act = d0 < 0.1
    # (A1) to first order: d1 ≥ d_s + (1 − ξ)(d0 − d_s) up to the step's curvature
    assert np.all(d1[act] >= 0.01 + 0.5 * (d0[act] - 0.01) - 1e-4)


def test_user_constraints_and_relaxation(franka):
    s, task = franka
    q = np.array(s.q0)
    e3 = np.eye(s.nq)[3]
    sign = np.sign(_free(task, q, BIG)[3])
    cap = LinearConstraint(sign * e3, [0.01], "±q̇3 ≤ 0.01")
    st = solve_step(Configuration(task, q), [BodyVelocityTask(BIG)], [UserConstraints(cap, s.nq)], DT)
    assert sign * st.velocity[3] <= 0.01 + 1e-12 and st.solution.active_rows.tolist() == [True]
    # a row that asks for more than one step of acceleration from rest: the acceleration limit is dropped
    # on that step, and the step says so (never silently)
    push = LinearConstraint(-e3, [-1.0], "q̇3 ≥ 1")
    cfg = Configuration(task, q)
    st = solve_step(cfg, [BodyVelocityTask(np.zeros(7))], [*default_limits(s.limits), push], DT)
    assert st.relaxed == ("acceleration",) and st.velocity[3] >= 1.0 - 1e-9
    with pytest.raises(cg.InfeasibleConstraintsError, match="no common point"):
        solve_step(cfg, [BodyVelocityTask(np.zeros(7))], [VelocityLimit(), LinearConstraint(-e3, [-10.0])], DT)


def test_priority_levels_keep_the_higher_task_velocity(franka):
    s, task = franka
    q = np.array(s.q0)
    V = displaced_target(task, q, translation=(0.02, 0.0, 0.0))
    sim = SimilarityTask(V, gain=1.0)
    from coop_ga.control import point_on_circle

    low = PositionTask(0, point_on_circle(task, q, 0, 0.3), gain=5.0, form="joint")  # along the circle (Fig. 17)
    cfg = Configuration(task, q, np.zeros(s.nq))
    J = cfg.kinematics().jacobian
    for limits in (default_limits(s.limits, acceleration=False), default_limits(s.limits)):
        alone = solve_step(cfg, [sim], limits, DT)
        both = solve_step(cfg, [sim], limits, DT, levels=[[low]])
        # the circle's velocity kept, to the QP solver's tolerance (DAQP: ~1e-6 of the step, two solves)
        np.testing.assert_allclose(J @ both.velocity, J @ alone.velocity, atol=1e-5)
    # without acceleration bounds the lower level moves the arms in the nullspace (Eq 60); from rest under
    # them the first level already uses the whole box (a Δt per joint), so there is no room left for it
    free = default_limits(s.limits, acceleration=False)
    assert (
        np.linalg.norm(
            solve_step(cfg, [sim], free, DT, levels=[[low]]).velocity - solve_step(cfg, [sim], free, DT).velocity
        )
        > 1e-3
    )
    assert np.all(np.abs(both.velocity) <= s.limits.acceleration * DT + 1e-12)


def test_limit_protocol(franka):
    from coop_ga.control import Limit, Task

    s, task = franka
    cm = CollisionModel(s, obstacles=[], self_collision=True)
    for lim in (*default_limits(s.limits), ClearanceLimit(cm), LinearConstraint(np.eye(s.nq)[:1], [0.0])):
        assert isinstance(lim, Limit), lim
    for t in (SimilarityTask(task.similarity(s.q0)), PositionTask(0, np.zeros(3)), BodyVelocityTask(np.zeros(7))):
        assert isinstance(t, Task), t
