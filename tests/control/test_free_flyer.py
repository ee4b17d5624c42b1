"""Controllers on a free-flyer system (nq ≠ nv): a floating-base G1's two hands reach cooperative targets.

The targets move the hands' line / point pair 0.6 m forward, 0.2 m left, 0.3 m up and turn it 0.4 rad about z:
out of reach of the fixed-pelvis ``g1_arms`` (checked), reached with the floating base, which moves.  The final
hands are checked with Pinocchio's own forward kinematics, the trajectory against the joint limits (position and
velocity, in q̇ coordinates), and the quaternion stays unit.  The iLQR on a free flyer: test_ilqr_free_flyer.py.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import coop_ga as cg
from coop_ga.control import (
    Configuration,
    ConfigurationLimit,
    PositionTask,
    VelocityLimit,
    constrained_point_reach,
    diff_ik_reach,
    gauss_newton_ik,
    impedance_torque,
    nullspace_point_reach,
    run_ik,
    simulate_impedance,
)
from coop_ga.control.tasks import DualTask, DualTaskSpace
from coop_ga.cooperative.targets import displaced_target
from coop_ga.systems.library import g1_floating

MOVE = {"translation": (0.6, 0.2, 0.3), "axis": (0.0, 0.0, 1.0), "angle": 0.4}


@pytest.fixture(scope="module")
def system():
    return g1_floating()


def _hands(s, q) -> np.ndarray:
    """The end points by Pinocchio's forward kinematics (independent of coop_ga's motors)."""
    d = s.model.createData()
    pin.framesForwardKinematics(s.model, d, q)
    return np.array([d.oMf[s.model.getFrameId(f)].translation for f in s.end_frames])


def _moved(s, q) -> tuple[np.ndarray, np.ndarray]:
    """The hands at q moved by MOVE about their centroid (the target by construction) and its rotation."""
    p = _hands(s, q)
    c = p.mean(axis=0)
    R = pin.AngleAxis(MOVE["angle"], np.array(MOVE["axis"])).toRotationMatrix()
    return (p - c) @ R.T + c + np.array(MOVE["translation"]), R


def _check_run(s, q_final, traj) -> None:
    assert abs(np.linalg.norm(q_final[3:7]) - 1.0) < 1e-12
    assert np.linalg.norm(q_final[:3]) > 0.1  # the base moved
    x = s.tangent_trajectory(traj)
    assert s.limits.position_violation(x) == 0.0


@pytest.mark.parametrize("solver", ["diffik", "gauss_newton"])
def test_point_pair_reached_with_the_floating_base(system, solver) -> None:
    task = cg.cooperative_task(system, "point_pair")
    Vd = displaced_target(task, system.q0, **MOVE)
    if solver == "diffik":
        r = diff_ik_reach(task, system.q0, Vd, steps=400)
        tol, traj = 1e-4, r.trajectory
        assert r.limit_violation == 0.0 and r.velocity_violation <= 1e-9
    else:
        r = gauss_newton_ik(task, system.q0, Vd)
        tol, traj = 1e-10, np.array([system.q0, r.q])
    assert r.converged and r.error <= tol, r.message
    _check_run(system, r.q, traj)
    expected, _ = _moved(system, system.q0)
    assert np.abs(_hands(system, r.q) - expected).max() <= 10 * tol


@pytest.mark.parametrize("solver", [diff_ik_reach, gauss_newton_ik], ids=["diffik", "gauss_newton"])
def test_a_start_with_a_non_unit_quaternion_is_refused(system, solver) -> None:
    """Old: diff_ik_reach started from a quaternion of norm 2 and reported converged (Pinocchio normalised it)."""
    task = cg.cooperative_task(system, "point_pair")
    q = system.q0.copy()
    q[3:7] *= 2.0
    with pytest.raises(cg.errors.InvalidInputError, match=r"quaternion.*norm 2"):
        solver(task, q, displaced_target(task, system.q0, **MOVE))
    assert np.linalg.norm(q[3:7]) == 2.0  # the input is not modified


def test_line_reached_with_the_floating_base_and_not_without(system) -> None:
    task = cg.cooperative_task(system, "line")
    Vd = displaced_target(task, system.q0, **MOVE)
    r = diff_ik_reach(task, system.q0, Vd, steps=400)
    assert r.converged and r.error <= 1e-4, r.message
    _check_run(system, r.q, r.trajectory)
    expected, _ = _moved(system, system.q0)
    d = (expected[1] - expected[0]) / np.linalg.norm(expected[1] - expected[0])
    for p in _hands(system, r.q):  # both hands on the target line (Pinocchio FK)
        off = (p - expected[0]) - d * ((p - expected[0]) @ d)
        assert np.linalg.norm(off) <= 1e-3
    fixed = cg.cooperative_task(cg.systems.load("g1_arms"), "point_pair")
    rf = diff_ik_reach(fixed, fixed.system.q0, displaced_target(fixed, fixed.system.q0, **MOVE), steps=400)
    assert not rf.converged and rf.error > 0.1  # out of reach from a fixed pelvis


def test_point_task_with_position_and_velocity_limits(system) -> None:
    task = cg.cooperative_task(system, "point_pair")
    goal = _hands(system, system.q0)[0] + np.array([0.5, -0.3, 0.2])
    cfg = Configuration(task, system.q0)
    run = run_ik(
        cfg,
        [PositionTask(0, goal, gain=10.0, max_speed=1.0)],
        [ConfigurationLimit(), VelocityLimit()],
        dt=0.01,
        steps=300,
        tol=1e-5,
        hooks=cg.control.RunHooks(error=lambda c: float(np.linalg.norm(c.kinematics().points[0] - goal))),
    )
    assert run.converged, run.message
    assert np.linalg.norm(_hands(system, run.trajectory[-1])[0] - goal) <= 1e-5
    assert run.max_position_violation == 0.0 and run.max_velocity_violation <= 1e-9
    assert run.velocities.shape == (run.iterations, system.nv)


def test_a_step_moves_q_on_the_manifold_and_refuses_non_finite(system) -> None:
    from coop_ga.control.solve import advance
    from coop_ga.errors import InvalidInputError

    v = np.linspace(-1.0, 1.0, system.nv)
    np.testing.assert_array_equal(advance(system.q0, v, 0.01, system), pin.integrate(system.model, system.q0, 0.01 * v))
    with pytest.raises(InvalidInputError, match="not finite"):
        advance(system.q0, np.full(system.nv, np.inf), 0.01, system)


def test_cooperative_error_jacobian_equals_differences_through_integrate(system) -> None:
    task = cg.cooperative_task(system, "line")
    q = system.random_q(np.random.default_rng(0), 0.3)
    Vd = displaced_target(task, q, translation=(0.05, 0.0, 0.02))
    h, J = 1e-6, task.error_jacobian(q, Vd)
    assert J.shape == (7, system.nv)
    for k in range(system.nv):
        dv = np.zeros(system.nv)
        dv[k] = h
        fd = (task.error(system.integrate(q, dv), Vd) - task.error(system.integrate(q, -dv), Vd)) / (2 * h)
        assert np.abs(fd - J[:, k]).max() <= 1e-8
    _, _, Jb = task.evaluate_batch(np.array([q, system.q0]))
    np.testing.assert_array_equal(Jb[0], task.jacobian(q))


def test_task_second_derivatives_along_integrate(system) -> None:
    """J̇q̇, ∇²(wᵀe) and the AD Jacobian of a floating G1's line task equal central differences of the
    task's own Jacobian / error through pinocchio.integrate (tangent coordinates, nv columns)."""
    task = cg.cooperative_task(system, "line")
    rng = np.random.default_rng(3)
    q = system.random_q(rng, 0.3)
    Vd = displaced_target(task, q, translation=(0.05, 0.0, 0.02), axis=(0.0, 1.0, 0.0), angle=0.2)
    nv = system.nv
    qd = rng.standard_normal(nv)
    h = 1e-5
    jq = lambda x: task.jacobian(x) @ qd  # noqa: E731
    fd = (jq(pin.integrate(system.model, q, h * qd)) - jq(pin.integrate(system.model, q, -h * qd))) / (2 * h)
    jd = task.jdot_qdot(q, qd)
    assert jd.shape == (7,) and np.abs(jd).max() > 0.1
    assert np.abs(jd - fd).max() <= 1e-7 * max(1.0, np.abs(fd).max())
    np.testing.assert_allclose(task.jacobian_ad(q), task.jacobian(q), atol=1e-12)
    w = rng.standard_normal(7)
    H = task.error_hessian(q, Vd, w)
    assert H.shape == (nv, nv) and np.abs(H - H.T).max() == 0.0
    E = lambda dv: w @ task.error(pin.integrate(system.model, q, dv), Vd)  # noqa: E731
    h2, worst = 1e-4, 0.0
    for i in range(nv):
        for j in range(nv):
            a, b = np.zeros(nv), np.zeros(nv)
            a[i], b[j] = h2, h2
            fd2 = (E(a + b) - E(a - b) - E(b - a) + E(-a - b)) / (4 * h2 * h2)
            worst = max(worst, abs(fd2 - H[i, j]))
    assert np.abs(H[:6, :6]).max() > 0.1 and worst <= 1e-6 * np.abs(H).max()


def test_nullspace_slides_a_hand_along_the_held_line(system) -> None:
    task = cg.cooperative_task(system, "line")
    p0 = _hands(system, system.q0)
    d = (p0[1] - p0[0]) / np.linalg.norm(p0[1] - p0[0])
    goal = p0[0] + 0.1 * d
    r = nullspace_point_reach(task, system.q0, 0, goal)
    assert r.converged and r.error <= 1e-4, r.message
    assert r.similarity_distance.max() <= 1e-5  # the line is held while the hand slides along it
    assert np.linalg.norm(_hands(system, r.q)[0] - goal) <= 1e-4  # Pinocchio FK
    assert r.limit_violation == 0.0 and r.velocity_violation == 0.0
    assert abs(np.linalg.norm(r.q[3:7]) - 1.0) < 1e-12 and np.linalg.norm(r.q[:3] - system.q0[:3]) > 0.01


def test_constrained_reach_holds_the_other_hand(system) -> None:
    from coop_ga.control.constrained import point_constraint

    task = cg.cooperative_task(system, "line")
    p0 = _hands(system, system.q0)
    goal = p0[0] + np.array([0.3, 0.1, 0.2])
    r = constrained_point_reach(task, system.q0, 0, goal, constraints=point_constraint(task, 1, p0[1]))
    assert r.converged and r.error <= 1e-4, r.message
    assert r.constraint_deviation.max() <= 1e-12
    final = _hands(system, r.q)
    assert np.linalg.norm(final[0] - goal) <= 1e-4 and np.abs(final[1] - p0[1]).max() <= 1e-12
    assert r.limit_violation == 0.0 and r.velocity_violation == 0.0
    _check_run(system, r.q, r.trajectory)


def test_teleoperator_moves_both_hands_with_the_base(system) -> None:
    from coop_ga.control.teleop import ScriptedInput

    task = cg.cooperative_task(system, "point_pair")
    tel = cg.control.Teleoperator(task, system.q0)
    qf = tel.run(ScriptedInput([(1.0, [1, 0, 0, 0, 0, 0])], tel.dt))
    dp = _hands(system, qf) - _hands(system, system.q0)
    assert tel.velocity.shape == (system.nv,) and len(tel.log.q) == 101
    assert dp[0, 0] > 5e-3 and abs(dp[0, 0] - dp[1, 0]) <= 1e-9 and np.abs(dp[:, 1:]).max() <= 1e-6
    assert abs(np.linalg.norm(qf[3:7]) - 1.0) < 1e-12 and np.linalg.norm(qf[:3]) > 1e-3


def test_dual_task_space_with_the_floating_base(system) -> None:
    from coop_ga.control import SimilarityTask, default_limits

    task = cg.cooperative_task(system, "point_pair")
    space = DualTaskSpace(task)
    q = system.random_q(np.random.default_rng(5), 0.3)
    st = space.evaluate(q)
    d = system.model.createData()
    pin.framesForwardKinematics(system.model, d, q)
    X = [d.oMf[system.model.getFrameId(n)] for n in space.frames]
    S = st.relative.as_similarity()
    H = np.eye(4)
    H[:3, :3], H[:3, 3] = S.rotation_matrix, S.translation
    assert np.abs(H - (X[1].inverse() * X[0]).homogeneous).max() <= 1e-12
    h = 1e-6
    for which, J in (("relative", st.relative_jacobian), ("absolute", st.absolute_jacobian)):
        M0 = getattr(st, which)
        target = M0 @ cg.Motor.exp([0.4, -0.3, 0.5, 0.1, -0.05, 0.08])
        _, E, _ = space.error_and_jacobian(q, which, target)
        assert J.shape == E.shape == (6, system.nv)
        for k in range(system.nv):
            dv = np.zeros(system.nv)
            dv[k] = h
            qp, qm = pin.integrate(system.model, q, dv), pin.integrate(system.model, q, -dv)
            log = lambda x: np.asarray((M0.inverse() @ getattr(space.evaluate(x), which)).log())  # noqa: E731
            assert np.abs((log(qp) - log(qm)) / (2 * h) - J[:, k]).max() <= 1e-8
            err = lambda x: space.error_and_jacobian(x, which, target)[0]  # noqa: E731
            assert np.abs((err(qp) - err(qm)) / (2 * h) - E[:, k]).max() <= 1e-8
    # the base does not change the relative motor; it moves the absolute one
    assert np.abs(st.relative_jacobian[:, :6]).max() <= 1e-14 and np.abs(st.absolute_jacobian[:, :6]).max() > 0.5
    # a reach that needs the base, with the hands' relative orientation held
    target = displaced_target(task, system.q0, translation=(0.3, 0.1, 0.2), axis=(0, 0, 1), angle=0.5, scale=1.0)
    rel = DualTask(space, "relative", space.relative(system.q0), components="orientation")
    run = run_ik(
        Configuration(task, system.q0), [SimilarityTask(target), rel], default_limits(system.limits), steps=300
    )
    qf = run.trajectory[-1]
    assert np.linalg.norm(task.error(qf, target)) <= 1e-10
    assert max(np.linalg.norm(rel.error(Configuration(task, x))) for x in run.trajectory) <= 1e-3
    assert np.linalg.norm(rel.error(Configuration(task, qf))) <= 1e-12
    assert run.max_position_violation == 0.0 and np.linalg.norm(qf[:3] - system.q0[:3]) > 0.1


def test_impedance_torque_equals_pinocchios_dynamics(system) -> None:
    """The impedance law on the floating G1 (nv torques, the first six a base wrench) against the same law
    written with Pinocchio's crba / nonLinearEffects, Jacobians of its frames and J̇q̇ by differences through
    pin.integrate: τ = h + JᵀΛ(K e + D ė − J̇q̇ + J d q̇) − M d q̇, Λ = (J M⁻¹ Jᵀ)⁺."""
    from coop_ga.control.dynamics import task_space_dynamics
    from coop_ga.control.impedance import ImpedanceOptions

    task = cg.cooperative_task(system, "point_pair")
    rng = np.random.default_rng(2)
    q = system.random_q(rng, 0.3)
    qd = 0.3 * rng.standard_normal(system.nv)
    Vd = displaced_target(task, q, translation=(0.05, 0.02, -0.03))
    tau = impedance_torque(task, q, qd, Vd, torque_limits="none")
    m, d = system.model, system.model.createData()
    M = pin.crba(m, d, q)
    M = np.triu(M) + np.triu(M, 1).T
    h = pin.nonLinearEffects(m, d, q, qd)
    J = task.jacobian(q)
    eps = 1e-6
    Jdqd = (task.jacobian(pin.integrate(m, q, eps * qd)) @ qd - task.jacobian(pin.integrate(m, q, -eps * qd)) @ qd) / (
        2 * eps
    )
    e, Je = task.error_and_jacobian(q, Vd)
    o = ImpedanceOptions()
    Lam = np.linalg.pinv(J @ np.linalg.inv(M) @ J.T, rcond=1e-8, hermitian=True)
    dn = o.D_null * qd
    ref = h + J.T @ (Lam @ (o.K @ e + o.D @ (Je @ qd) - Jdqd + J @ dn)) - M @ dn
    assert tau.shape == (system.nv,) and np.abs(tau[:6]).max() > 1.0
    assert np.abs(tau - ref).max() <= 1e-6 * np.abs(ref).max()
    dyn = task_space_dynamics(task, q, qd)
    assert dyn.M.shape == (system.nv, system.nv) and np.abs(dyn.M - M).max() == 0.0
    np.testing.assert_allclose(dyn.C @ qd + dyn.g_joint, h, atol=1e-9)
    # saturated (the default): the joints at ±effort, the base wrench unbounded
    sat = impedance_torque(task, q, qd, Vd)
    np.testing.assert_array_equal(sat[:6], tau[:6])
    assert np.all(np.abs(sat[6:]) <= system.limits.effort[6:])


def test_impedance_closed_loop_on_pinocchios_floating_dynamics(system) -> None:
    """Pinocchio's ABA of the floating G1 with the base wrench applied (a fully actuated free flyer, gravity
    on): the hands' point pair reaches a target 5.8 cm away within tol, the quaternion stays unit."""
    task = cg.cooperative_task(system, "point_pair")
    Vd = displaced_target(task, system.q0, translation=(0.05, 0.0, 0.03))
    r = simulate_impedance(task, system.q0, Vd, duration=4.0)
    assert r.converged and r.error <= 1e-4 and r.error_norm[0] > 0.1, r.message
    assert r.qd.shape == (4001, system.nv) and r.tau.shape == (4001, system.nv)
    assert abs(np.linalg.norm(r.q[3:7]) - 1.0) < 1e-12 and np.linalg.norm(r.q[:3]) > 1e-3
    assert r.position_violation == 0.0 and r.saturated_steps == 0
    assert np.linalg.norm(task.error(r.q, Vd)) <= 1e-4
