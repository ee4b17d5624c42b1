"""Tasks and the configuration of the control layer: Jacobians against finite differences and CasADi AD, one
compiled evaluation per step shared by every task and limit."""

from __future__ import annotations

import numpy as np
import pytest

import coop_ga as cg
from coop_ga.control import (
    BodyVelocityTask,
    Configuration,
    JointVelocityTask,
    LineParameterTask,
    PositionTask,
    PostureTask,
    SimilarityTask,
    default_limits,
    diff_ik_reach,
    displaced_target,
    solve_step,
)

H = 1e-6


def _fd(model, q, f):
    """Central finite differences of ``f(configuration)`` (k,) along every joint: (k, nq)."""
    cfg = Configuration(model, q)
    cols = []
    for i in range(model.nq):
        dq = np.zeros(model.nq)
        dq[i] = H
        cfg.update(q + dq)
        fp = np.array(f(cfg), dtype=float)
        cfg.update(q - dq)
        fm = np.array(f(cfg), dtype=float)
        cols.append((fp - fm) / (2 * H))
    return np.array(cols).T


@pytest.fixture(scope="module")
def circle(load_system):
    s = load_system("three_franka")
    task = cg.cooperative_task(s, "circle")
    q = np.array(s.q0) + np.random.default_rng(4).uniform(-0.1, 0.1, s.nq)
    V = displaced_target(task, np.array(s.q0), translation=(0.05, -0.02, 0.03), axis=(1, 1, 0), angle=0.3, scale=1.2)
    return task, q, V


@pytest.fixture(scope="module")
def line(load_system):
    s = load_system("g1_arms")
    task = cg.cooperative_task(s, "line")
    q = np.array(s.q0) + np.random.default_rng(5).uniform(-0.1, 0.1, s.nq)
    return task, q


def test_similarity_task_exact_jacobian_is_the_derivative_of_its_error(circle):
    task, q, V = circle
    t = SimilarityTask(V, jacobian="exact")
    J = t.jacobian(Configuration(task, q))
    fd = _fd(task, q, t.error)
    assert np.linalg.norm(t.error(Configuration(task, q))) > 0.25  # far from the target: J_e ≠ −J^G
    np.testing.assert_allclose(J, fd, atol=1e-7 * max(1.0, np.abs(J).max()))
    # the error is e = −log(Ṽ_Sc V_Sd), the task graph's (Eq 44) with the sign of mink's tasks
    np.testing.assert_allclose(t.error(Configuration(task, q)), -task.error(q, V), atol=1e-14)
    np.testing.assert_allclose(J, -task.error_jacobian(q, V), atol=1e-12)


def test_similarity_task_body_jacobian(circle):
    """J^G is the derivative of the error at its zero (target = V_Sc(q)), and CasADi AD's J^G."""
    task, q, _ = circle
    t = SimilarityTask(task.similarity(q))
    J = t.jacobian(Configuration(task, q))
    np.testing.assert_allclose(J, _fd(task, q, t.error), atol=1e-7 * np.abs(J).max())
    np.testing.assert_allclose(J, task.jacobian_ad(q), atol=1e-12)
    b = BodyVelocityTask(np.arange(7.0))
    A, rhs = b.qp_rows(Configuration(task, q))
    np.testing.assert_array_equal(A, J)
    np.testing.assert_array_equal(rhs, np.arange(7.0))


@pytest.mark.parametrize("index", [0, 2])
def test_position_task_jacobian(circle, index):
    task, q, _ = circle
    p = task.points(q)[index] + [0.1, -0.05, 0.02]
    t = PositionTask(index, p, gain=5.0, max_speed=None)
    cfg = Configuration(task, q)
    J = t.jacobian(cfg)
    np.testing.assert_allclose(t.error(cfg), task.points(q)[index] - p, atol=1e-14)
    np.testing.assert_allclose(J, _fd(task, q, t.error), atol=1e-7)
    np.testing.assert_allclose(J, task.tree.euclidean_point_jacobians(q)[index], atol=1e-12)
    _A, b = t.qp_rows(cfg)
    np.testing.assert_allclose(b, -5.0 * t.error(cfg), atol=1e-15)
    # the capped velocity and the joint-space form (Eq 60's secondary velocity)
    capped = PositionTask(index, p, gain=5.0, max_speed=0.2)
    assert np.linalg.norm(capped.velocity(cfg)) == pytest.approx(0.2)
    joint = PositionTask(index, p, gain=5.0, max_speed=0.2, form="joint", damping=0.0)
    Aj, qd = joint.qp_rows(cfg)
    assert Aj is None
    np.testing.assert_allclose(J @ qd, capped.velocity(cfg), atol=1e-12)  # J_p J_p⁺ v = v (rank 3)


def test_line_parameter_task_jacobian(line):
    task, q = line
    t = LineParameterTask(task, ["d_x", "d_y", "d_z", "m_x", "m_y", "m_z"], np.zeros(6))
    cfg = Configuration(task, q)
    J = t.jacobian(cfg)
    np.testing.assert_allclose(J, _fd(task, q, t.error), atol=2e-7)
    P = task.points(q)
    d = (P[1] - P[0]) / np.linalg.norm(P[1] - P[0])
    np.testing.assert_allclose(t.value(cfg), np.concatenate([d, np.cross(P[0], d)]), atol=1e-14)
    with pytest.raises(cg.InvalidInputError, match="line"):
        LineParameterTask(cg.cooperative_task(cg.systems.load("three_franka"), "circle"), "d_z", 0.0)


def test_posture_and_joint_velocity_tasks(circle):
    task, q, _ = circle
    cfg = Configuration(task, q)
    t = PostureTask(np.zeros(task.nq), gain=2.0)
    np.testing.assert_array_equal(t.error(cfg), q)
    np.testing.assert_allclose(_fd(task, q, t.error), np.eye(task.nq), atol=1e-9)
    A, b = t.qp_rows(cfg)
    assert A is None and np.array_equal(b, -2.0 * q)
    w = PostureTask(np.zeros(task.nq), gain=2.0, weight=3.0)
    A, b = w.qp_rows(cfg)
    np.testing.assert_array_equal(A, 3.0 * np.eye(task.nq))
    v = np.linspace(-1, 1, task.nq)
    jv = JointVelocityTask(v)
    assert jv.qp_rows(cfg)[0] is None and np.array_equal(jv.qp_rows(cfg)[1], v)
    np.testing.assert_array_equal(jv.error(cfg), -v)


def test_one_compiled_evaluation_per_step(circle, monkeypatch):
    """Every task and limit of a step reads one evaluation; diff IK makes one per step (it made two: J^G and e)."""
    task, q, V = circle
    p0 = task.points(q)[0]
    counts = {"evaluations": 0, "task": 0}
    original = Configuration.kinematics

    def counted(self):
        counts["evaluations"] += not self._done
        return original(self)

    monkeypatch.setattr(Configuration, "kinematics", counted)
    for name in ("evaluate_views", "error_and_jacobian", "_run"):
        f = getattr(task, name)

        def call(*a, _f=f, **k):
            counts["task"] += 1
            return _f(*a, **k)

        monkeypatch.setattr(task, name, call)
    cfg = Configuration(task, q)
    tasks = [SimilarityTask(V), PositionTask(0, p0)]
    st = solve_step(cfg, tasks, default_limits(task.system.limits), 0.01, levels=[[PostureTask(q)]])
    assert counts == {"evaluations": 1, "task": 0} and st.velocity.shape == (task.nq,)
    counts["evaluations"] = 0
    r = diff_ik_reach(task, q, V, steps=20, tol=0.0)
    assert r.iterations == 20
    # the start, then one per step; the task's own entry points only for the chart check of the start
    assert counts == {"evaluations": 21, "task": 1}


def test_configuration_checks_its_input(circle):
    task, q, _ = circle
    with pytest.raises(cg.InvalidInputError):
        Configuration(task, q[:5])
    cfg = Configuration(task, q)
    with pytest.raises(cg.InvalidInputError):
        cfg.update(q, velocity=np.zeros(3))
    cfg.update(np.full(task.nq, np.nan))
    with pytest.raises(cg.NonFiniteError):
        cfg.kinematics()
