"""Obstacle / self-collision avoidance in differential IK (nullspace repulsion, QP velocity dampers) and iLQR.

Scene (the one of experiments/obstacle_circle.py): three_franka's circle carried 30 cm along +y; a 4 cm
sphere sits on the straight path of arm 0's gripper, so plain differential IK runs through it.
Distances come from coop_ga.collision.model.CollisionModel (capsules of the Franka's collision meshes).
"""

from __future__ import annotations

import numpy as np
import pytest

import coop_ga as cg
from coop_ga.collision.distance import Sphere
from coop_ga.collision.model import CollisionModel
from coop_ga.control import (
    AvoidanceOptions,
    ClearanceCost,
    ClearanceLimit,
    avoidance_reach,
    avoidance_velocity,
    clearance_constraint,
    diff_ik_reach,
    displaced_target,
    ilqr_reach,
    repulsive_velocity,
)
from coop_ga.control.ilqr import ILQROptions, ReachingOCP
from coop_ga.errors import InvalidInputError

CENTER, RADIUS = np.array([0.014, -0.346, 0.478]), 0.04
D_SAFE = 0.01
#: the dampers are first order: the true clearance may undershoot d_s by the step's curvature term [m]
LINEARISATION_TOL = 2e-3
#: 4 s: from rest, under the Franka's acceleration limits (on by default), the hard dampers need 3.02 s here
KW = dict(gain=3.0, steps=400, dt=0.01)


@pytest.fixture(scope="module")
def scene():
    s = cg.systems.load("three_franka")
    task = cg.cooperative_task(s, "circle")
    q0 = np.array(s.q0, float)
    Vd = displaced_target(task, q0, translation=(0.0, 0.30, 0.0))
    cm = CollisionModel(s, obstacles=[Sphere(CENTER, RADIUS)], self_collision=True)
    return s, task, q0, Vd, cm


@pytest.fixture(scope="module")
def runs(scene):
    _, task, q0, Vd, cm = scene
    return {
        m: avoidance_reach(task, q0, Vd, collision_model=cm, mode=m, d_safe=D_SAFE, **KW)
        for m in ("none", "soft", "hard", "both")
    }


def test_plain_diff_ik_collides(scene, runs):
    _, task, q0, Vd, _cm = scene
    r = runs["none"]
    assert r.converged and r.min_clearance < -0.03, r.min_clearance  # the gripper enters the sphere by > 3 cm
    assert "sphere" in r.closest
    # mode 'none' is plain differential IK
    dik = diff_ik_reach(task, q0, Vd, **KW)
    np.testing.assert_allclose(r.trajectory, dik.trajectory, atol=1e-12)
    # start and goal are clear: the collision is on the way (the redundant arms end 3.6 cm from the sphere)
    assert r.clearance[0] > 0.04 and r.clearance[-1] > 0.03
    assert r.max_acceleration_violation == 0.0 and r.relaxed_steps == 0


@pytest.mark.parametrize("mode", ["hard", "both"])
def test_avoidance_keeps_clearance(runs, mode):
    r = runs[mode]
    assert r.converged and r.error < 1e-4, r.message
    assert r.min_clearance >= D_SAFE - LINEARISATION_TOL, (mode, r.min_clearance, r.closest)
    assert r.limit_violation == 0.0 and r.velocity_violation < 1e-9
    # the dampers' braking bound keeps the acceleration limits: no step had to drop them
    assert r.max_acceleration_violation == 0.0 and r.relaxed_steps == 0


def test_soft_avoidance_alone_gives_no_guarantee(runs):
    """The repulsion lives in the nullspace and under the acceleration limits it builds up too slowly for
    this sphere: it reduces the penetration (4.2 → 1.3 cm) but does not prevent it; 'both' adds the dampers."""
    soft, none = runs["soft"], runs["none"]
    assert soft.converged and soft.max_acceleration_violation == 0.0
    assert none.min_clearance + 0.02 < soft.min_clearance < 0.0


def test_hard_constraint_holds_at_every_step(scene, runs):
    """(A1) d + Δt J_d q̇ ≥ d_s + (1 − ξ)(d − d_s) for every pair within d_influence, at every step."""
    _, _, _, _, cm = scene
    r = runs["hard"]
    o = AvoidanceOptions()
    assert r.constraint_residual <= 1e-9
    Q = r.trajectory
    worst = np.inf
    worst_true = np.inf
    n_rows = 0
    for k in range(Q.shape[0] - 1):
        d, J = cm.distances_and_jacobian(Q[k])
        qd = (Q[k + 1] - Q[k]) / o.dt
        act = d < o.d_influence
        lhs = d[act] + o.dt * (J[act] @ qd)
        rhs = np.where(d[act] > D_SAFE, D_SAFE + (1 - o.damper_gain) * (d[act] - D_SAFE), d[act])
        n_rows += int(act.sum())
        if act.any():
            worst = min(worst, float(np.min(lhs - rhs)))
            worst_true = min(worst_true, float(np.min(cm.distances(Q[k + 1])[act] - lhs)))
    assert n_rows > 100  # the constraint was exercised
    assert worst >= -1e-9, worst
    # the linearisation error of one step (what separates (A1) from the true clearance) is sub-millimetre
    assert worst_true > -1e-3, worst_true
    # the dampers did bind: the task velocity was sacrificed for clearance
    assert r.task_velocity_deviation.max() > 0.1


def test_clearance_limit_plugs_into_diff_ik_reach(scene, runs):
    _, task, q0, Vd, cm = scene
    res = diff_ik_reach(task, q0, Vd, constraints=ClearanceLimit(cm, dt=0.01, d_safe=D_SAFE), **KW)
    assert res.converged
    np.testing.assert_allclose(res.trajectory, runs["hard"].trajectory, atol=1e-9)
    dmin = min(cm.min_clearance(q) for q in res.trajectory)
    assert dmin >= D_SAFE - LINEARISATION_TOL


def test_nullspace_repulsion_does_not_disturb_the_task(scene, runs):
    """Near the obstacle (soft mode active) J^G q̇ equals plain differential IK's task velocity (to the QP
    solver's tolerance where the acceleration bounds are active: measured 9.5e-7 for |J^G q̇| ~ 1)."""
    r = runs["soft"]
    assert r.task_velocity_deviation.max() < 1e-5
    # the nullspace motion is substantial (the gripper slid around the sphere): joints moved differently
    T = min(r.trajectory.shape[0], runs["none"].trajectory.shape[0])
    assert np.max(np.abs(r.trajectory[:T] - runs["none"].trajectory[:T])) > 0.05


def test_far_from_obstacles_soft_equals_diff_ik(scene):
    s, task, q0, Vd, _ = scene
    cm_far = CollisionModel(s, obstacles=[Sphere([0.0, 0.0, 3.0], 0.1)], self_collision=True)
    r = avoidance_reach(
        task, q0, Vd, collision_model=cm_far, mode="both", d_influence=0.05, **KW
    )  # same-arm pairs stay > 9 cm
    assert r.clearance.min() > 0.05
    dik = diff_ik_reach(task, q0, Vd, **KW)
    np.testing.assert_allclose(r.trajectory, dik.trajectory, atol=1e-12)
    assert r.task_velocity_deviation.max() <= 1e-12


def test_arm_arm_collision_avoided(scene):
    """Shrinking the circle to 8 % (radius 3.9 cm) drives the three hands into each other: plain differential
    IK ends with two hands interpenetrating (by 4.9 mm, measured);
    dampers and repulsion on the arm–arm pairs keep them apart."""
    s, task, q0, _, _ = scene
    cm = CollisionModel(s, obstacles=[], self_collision=True)
    Vd = displaced_target(task, q0, scale=0.08)
    plain = avoidance_reach(task, q0, Vd, collision_model=cm, mode="none", **KW)
    assert plain.min_clearance < -0.004 and " – arm" in plain.closest and "hand" in plain.closest
    for mode in ("hard", "both"):
        r = avoidance_reach(task, q0, Vd, collision_model=cm, mode=mode, d_safe=D_SAFE, **KW)
        assert not r.infeasible and r.constraint_residual <= 1e-9, r.message
        assert r.min_clearance >= D_SAFE - LINEARISATION_TOL, (mode, r.min_clearance, r.closest)
        assert r.limit_violation == 0.0
        assert r.error < 1e-3  # the circle still gets (almost) there: the hands turn about their TCPs


def test_step_functions(scene):
    _, task, q0, Vd, cm = scene
    q = q0.copy()
    # a configuration near the obstacle: run plain diff IK up to the step of closest approach
    dik = diff_ik_reach(task, q, Vd, **KW)
    dd = np.array([cm.min_clearance(x) for x in dik.trajectory[:40]])
    k = int(np.argmax(dd < 0.08))
    qk = dik.trajectory[k]
    d, Jd = cm.distances_and_jacobian(qk)
    c = clearance_constraint(cm, qk, dt=0.01, d_safe=D_SAFE, d_influence=0.1, damper_gain=0.5)
    act = d < 0.1
    assert c.G.shape == (int(act.sum()), task.nq) and np.all(c.h >= 0)
    np.testing.assert_allclose(c.G, -Jd[act])
    np.testing.assert_allclose(c.h, np.maximum(0.5 * (d[act] - D_SAFE) / 0.01, 0.0))
    # plain (A2): the active pairs' clearance rates are positive
    v = repulsive_velocity(cm, qk, d_safe=D_SAFE, d_influence=0.1, repulsive_speed=0.3, repulsive_damping=1e-3)
    assert np.all(Jd[act] @ v > 0)
    # one avoidance step: J^G q̇ is the differential-IK task velocity (soft), the rows hold (hard)
    b = 3.0 * task.error(qk, Vd)
    J = task.evaluate_views(qk)[2]
    qd_soft = avoidance_velocity(task, qk, b, collision_model=cm, mode="soft", d_safe=D_SAFE, gain=3.0)
    qd_none = avoidance_velocity(task, qk, b, collision_model=cm, mode="none", gain=3.0)
    assert np.linalg.norm(J @ (qd_soft - qd_none)) < 1e-10
    qd_hard = avoidance_velocity(task, qk, b, collision_model=cm, mode="hard", d_safe=D_SAFE, gain=3.0)
    assert np.all(c.G @ qd_hard <= c.h + 1e-9)


def test_bad_input(scene):
    _, task, q0, Vd, cm = scene
    with pytest.raises(InvalidInputError):
        AvoidanceOptions(d_safe=0.1, d_influence=0.05)
    with pytest.raises(InvalidInputError):
        AvoidanceOptions(mode="sometimes")
    with pytest.raises(InvalidInputError):
        AvoidanceOptions(damper_gain=1.5)
    with pytest.raises(InvalidInputError):
        avoidance_reach(task, q0, Vd, collision_model=object())
    with pytest.raises(InvalidInputError):
        ClearanceLimit(cm, dt=-1.0)
    with pytest.raises(InvalidInputError):
        ILQROptions(clearance="not a cost")
    with pytest.raises(InvalidInputError):
        ClearanceCost(cm, weight=0.0)


# ----------------------------------------------------------------------------- iLQR
ILQR = dict(horizon=60, dt=0.05)


def test_ilqr_clearance_cost_increases_min_clearance(scene):
    _, task, q0, Vd, cm = scene
    plain = ilqr_reach(task, q0, Vd, **ILQR)
    assert plain.clearance_cost == 0.0 and plain.min_clearance == np.inf  # off by default
    d_plain = min(cm.min_clearance(q) for q in plain.trajectory)
    res = ilqr_reach(task, q0, Vd, clearance=ClearanceCost(cm, weight=1e4, activation=0.05), **ILQR)
    assert plain.converged and res.converged, res.message
    assert d_plain < -0.01  # iLQR's own path also passes through the sphere
    assert res.min_clearance > 0.03, res.min_clearance
    assert res.min_clearance > d_plain + 0.04
    assert res.joint_limit_violation == 0.0 and res.velocity_violation == 0.0
    assert res.min_clearance == pytest.approx(min(cm.min_clearance(q) for q in res.trajectory))


def test_ilqr_clearance_gradient_matches_finite_differences(scene):
    """ReachingOCP.gradient's clearance part (adjoint sums of −w J_dᵀ max(0, d_a − d)) equals central differences."""
    _, task, q0, Vd, cm = scene
    ocp = ReachingOCP(task, q0, Vd, horizon=20, dt=0.1, clearance=ClearanceCost(cm, weight=1e4, activation=0.05))
    ocp0 = ReachingOCP(task, q0, Vd, horizon=20, dt=0.1)
    plain = ilqr_reach(task, q0, Vd, horizon=20, dt=0.1)  # its path runs through the sphere
    u = plain.u + 0.01 * np.random.default_rng(0).standard_normal(plain.u.shape)
    assert ocp.clearance_cost(ocp.rollout(u)[0]) > 1.0  # the hinge is active
    g_c = ocp.gradient(u) - ocp0.gradient(u)  # the clearance part
    np.testing.assert_allclose(ocp.gradient(u), ocp0.gradient(u) + g_c)
    h = 1e-6
    checked = 0
    for k in range(0, 20, 3):
        for j in range(7):  # arm 0's joints: the arm that meets the sphere
            du = np.zeros_like(u)
            du[k, j] = h
            fd = (ocp.clearance_cost(ocp.rollout(u + du)[0]) - ocp.clearance_cost(ocp.rollout(u - du)[0])) / (2 * h)
            assert fd == pytest.approx(g_c[k, j], rel=1e-5, abs=1e-5), (k, j)
            checked += abs(fd) > 1.0
    assert checked >= 10


def test_feasible_fraction_of_the_fallback_step():
    """The last-resort step α·x: inside the box and the rows, and α is the largest such fraction."""
    from coop_ga.control.avoidance import _feasible_fraction

    rng = np.random.default_rng(3)
    for _ in range(50):
        n, m = 7, 4
        x = rng.normal(size=n) * 3
        lb, ub = -rng.uniform(0.1, 2, n), rng.uniform(0.1, 2, n)
        G, h = rng.normal(size=(m, n)), rng.uniform(0.0, 1.0, m)
        a = _feasible_fraction(x, lb, ub, G, h)
        assert 0.0 <= a <= 1.0
        y = a * x
        assert np.all(y >= lb - 1e-12) and np.all(y <= ub + 1e-12) and np.all(G @ y <= h + 1e-12)
        if a < 1.0:
            z = min(1.0, a * (1 + 1e-6) + 1e-12) * x
            assert np.any(z < lb) or np.any(z > ub) or np.any(G @ z > h)


def test_ilqr_restart_never_reports_a_path_through_the_obstacle(scene):
    """The restart (bounded Gauss–Newton IK, which knows no obstacle) starts from the minimum-energy controls to the
    IK's configuration: a guess within tol whose path crosses the sphere by 3.5 cm.  It used to be returned at once
    as converged (min clearance −3.5 cm); now the solve iterates on until the path is clear.  A first solve cut
    after 3 iterations (still through the sphere, ‖e‖ 0.11) stands in for a stalled one."""
    import dataclasses

    from coop_ga.control.gauss_newton import gauss_newton_ik
    from coop_ga.control.ilqr.lq import controls_to
    from coop_ga.control.ilqr.solver import _problem, _restart, _Solve

    _, task, q0, Vd, cm = scene
    o = ILQROptions(clearance=ClearanceCost(cm, weight=1e4, activation=0.05), **ILQR)
    ocp = _problem(task, q0, Vd, None, o)
    first = _Solve(ocp, dataclasses.replace(o, max_iter=3), None).run({})
    assert not first.converged and first.min_clearance < 0.0
    ik = gauss_newton_ik(task, q0, Vd)
    guess = controls_to(ocp, ik.q)
    q_guess = ocp.rollout(guess)[0]
    assert np.linalg.norm(task.error(q_guess[-1], Vd)) < o.tol
    assert min(cm.min_clearance(q) for q in q_guess) < -0.03
    res = _restart(ocp, o, first, {})
    assert "restarted" in res.message
    assert res.converged and res.error < o.tol, res.message
    assert res.min_clearance > 0.03, res.min_clearance
    assert res.min_clearance == pytest.approx(min(cm.min_clearance(q) for q in res.trajectory))


def test_ilqr_result_through_the_obstacle_is_not_converged(scene):
    """The final check (results.finish): the minimum-energy controls to the obstacle-blind IK configuration reach
    the target (‖e‖ < tol, inside the limits) through the sphere — not converged, and the message says by how much."""
    import time

    from coop_ga.control.gauss_newton import gauss_newton_ik
    from coop_ga.control.ilqr.feasibility import reference_controls
    from coop_ga.control.ilqr.lq import controls_to
    from coop_ga.control.ilqr.results import Progress, finish
    from coop_ga.control.ilqr.solver import _problem

    _, task, q0, Vd, cm = scene
    o = ILQROptions(clearance=ClearanceCost(cm, weight=1e4, activation=0.05), **ILQR)
    ocp = _problem(task, q0, Vd, None, o)
    u = controls_to(ocp, gauss_newton_ik(task, q0, Vd).q)
    res = finish(ocp, o, u, reference_controls(ocp), Progress(t_start=time.perf_counter()), {})
    assert res.error < o.tol and res.joint_limit_violation == 0.0 and res.velocity_violation == 0.0
    assert res.min_clearance < -0.03
    assert not res.converged and "penetrates the collision model by 0.035" in res.message, res.message
    # without the clearance cost the same controls are a converged reach (the check is the clearance's only)
    plain = _problem(task, q0, Vd, None, ILQROptions(**ILQR))
    assert finish(plain, ILQROptions(**ILQR), u, reference_controls(plain), Progress(t_start=0.0), {}).converged
