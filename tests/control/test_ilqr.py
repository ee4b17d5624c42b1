"""iLQR reaching (Eq 53–57): convergence on the paper's systems, monotone cost, dynamics,
exact gradients, Riccati = condensed step, Newton term, honest failures, input errors."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import coop_ga as cg
from coop_ga.control.ilqr import ReachingOCP, displaced_target, ilqr_reach
from coop_ga.control.ilqr.lq import backward, condensed_step, forward_deviation, gramian
from coop_ga.errors import InvalidInputError, JointLimitWarning, NonFiniteError

# (system, kind, end-point order, displacement of the primitive at q0)
CASES = {
    # the flagship of experiments/circle_reaching.py: larger, displaced, tilted circle
    "three_franka_circle": (
        "three_franka",
        "circle",
        None,
        dict(translation=(0.1, -0.05, 0.1), axis=(1, 0, 0), angle=np.deg2rad(25), scale=1.25),
    ),
    "allegro_sphere": (
        "allegro",
        "sphere",
        None,
        dict(translation=(0.005, 0.01, 0.0), axis=(1, 0, 0), angle=np.deg2rad(10), scale=1.1),
    ),
    # g1_arms' order (right, left) gives a line along +e2 like the unit line, far from the
    # antipode where the canonical versor is discontinuous
    "g1_arms_line": (
        "g1_arms",
        "line",
        None,
        dict(translation=(0.05, 0.05, 0.08), axis=(0, 0, 1), angle=np.deg2rad(20)),
    ),
}


def _setup(name: str):
    sysname, kind, pts, disp = CASES[name]
    s = cg.systems.load(sysname)
    task = cg.cooperative_task(s, kind, points=pts)
    q0 = np.array(s.q0)
    Vd = displaced_target(task, q0, **disp)
    return task, q0, Vd


@pytest.fixture(scope="module")
def franka():
    return _setup("three_franka_circle")


@pytest.fixture(scope="module")
def franka_result(franka):
    task, q0, Vd = franka
    return ilqr_reach(task, q0, Vd)


# ----------------------------------------------------------------------------- convergence
@pytest.mark.parametrize("name", list(CASES))
def test_reaching_converges(name):
    task, q0, Vd = _setup(name)
    e0 = np.linalg.norm(task.error(q0, Vd))
    assert e0 > 0.2  # a real reaching problem
    res = ilqr_reach(task, q0, Vd)
    assert res.converged, res.message
    assert res.error < 1e-4
    assert res.error < 1e-5  # default tol
    assert 1 <= res.iterations <= 10
    assert res.iterations == len(res.stats) == len(res.cost_history) - 1
    # reported error is the true error of the re-integrated terminal configuration
    assert res.error == pytest.approx(np.linalg.norm(task.error(res.q, Vd)), abs=1e-12)
    np.testing.assert_allclose(res.error_vector, task.error(res.q, Vd), atol=1e-12)
    assert res.terminal_speed < 1e-2  # arrives (nearly) at rest
    assert res.within_limits
    assert res.solve_time_s < 5.0  # generous; see benchmarks/ocp.py for the real numbers
    assert res.trajectory.shape == (251, task.nq) and res.q.shape == (task.nq,) and res.u.shape == (250, task.nq)
    assert res.t[-1] == pytest.approx(2.5)


def test_merit_decreases_monotonically(franka_result):
    """Every accepted step decreases the merit it was computed for (the terminal shift between iterations
    changes the merit, so compare each step's own decrease)."""
    assert all(st.actual_decrease > 0 for st in franka_result.stats)
    c = franka_result.cost_history
    assert c[-1] < 1e-3 * c[0], c
    assert franka_result.error_history[-1] < 1e-3 * franka_result.error_history[0]


def test_gauss_newton_model_also_descends(franka):
    task, q0, Vd = franka
    res = ilqr_reach(task, q0, Vd, hessian="gauss_newton", max_iter=4, tol=0.0)
    assert res.hessian == "gauss_newton" and all(st.model == "gauss_newton" for st in res.stats)
    assert np.all(np.diff(res.cost_history) < 0)
    assert res.error < 0.05 * res.error_history[0]


def test_riccati_backward_gives_the_same_solution(franka, franka_result):
    """The closed-form LQ step (default while no bound is active) and the Riccati pass are the same step."""
    task, q0, Vd = franka
    res = ilqr_reach(task, q0, Vd, backward="riccati")
    assert res.converged and res.iterations <= 10
    assert all(st.backward == "riccati" for st in res.stats)
    assert all(st.backward == "condensed" for st in franka_result.stats)
    np.testing.assert_allclose(res.q, franka_result.q, atol=1e-4)


# ----------------------------------------------------------------------------- dynamics, costs
def test_dynamics_consistency(franka, franka_result):
    task, q0, Vd = franka
    r = franka_result
    dt = r.dt
    np.testing.assert_allclose(r.trajectory[0], q0)
    np.testing.assert_allclose(r.qd[0], 0.0)
    np.testing.assert_allclose(r.trajectory[1:], r.trajectory[:-1] + dt * r.qd[:-1] + 0.5 * dt * dt * r.u, atol=1e-12)
    np.testing.assert_allclose(r.qd[1:], r.qd[:-1] + dt * r.u, atol=1e-12)
    ocp = ReachingOCP(task, q0, Vd)
    x = np.hstack([r.trajectory, r.qd])
    np.testing.assert_allclose(x[1:], x[:-1] @ ocp.A.T + r.u @ ocp.B.T, atol=1e-12)
    # the reported cost is Eq 56 + Eq 57 + rest term, recomputed independently
    e = task.error(r.q, Vd)
    J = 1e-3 * np.sum(r.u**2) + 1e5 * e @ e + 1e2 * r.qd[-1] @ r.qd[-1]
    assert r.cost == pytest.approx(J, rel=1e-10)
    assert ocp.cost(r.u) == pytest.approx(J, rel=1e-10)


def test_gradient_matches_finite_differences(franka):
    task, q0, Vd = franka
    rng = np.random.default_rng(0)
    ocp = ReachingOCP(
        task,
        q0,
        Vd,
        horizon=6,
        dt=0.05,
        R=1e-2,
        Q=np.diag([1, 2, 3, 4, 5, 6, 7.0]),
        Qv=0.5,
        qd_init=0.1 * rng.standard_normal(task.nq),
    )
    u = rng.standard_normal((6, task.nq))
    g = ocp.gradient(u)
    h = 1e-6
    fd = np.zeros_like(u)
    for k in range(u.shape[0]):
        for i in range(u.shape[1]):
            up, um = u.copy(), u.copy()
            up[k, i] += h
            um[k, i] -= h
            fd[k, i] = (ocp.cost(up) - ocp.cost(um)) / (2 * h)
    np.testing.assert_allclose(g, fd, rtol=1e-6, atol=1e-6 * np.abs(fd).max())


def test_riccati_step_equals_condensed_gauss_newton_step(franka):
    """With linear dynamics the backward + forward pass is the (GN/Newton) step of the problem
    condensed onto u: same terminal deviation and same predicted decrease."""
    task, q0, Vd = franka
    rng = np.random.default_rng(1)
    ocp = ReachingOCP(task, q0, Vd, horizon=40, Q=1e2, Qv=1.0)
    u = 0.3 * rng.standard_normal((40, task.nq))
    q, qd = ocp.rollout(u)
    e, Je = task.error_and_jacobian(q[-1], Vd)
    n = task.nq
    H = np.zeros((2 * n, 2 * n))
    H[:n, :n] = 2 * Je.T @ ocp.Q @ Je
    H[n:, n:] = 2 * ocp.Qv
    g = np.concatenate([2 * Je.T @ ocp.Q @ e, 2 * ocp.Qv @ qd[-1]])
    k, K, d1 = backward(ocp, u, H, g)
    du, dq, dqd = forward_deviation(ocp, k, K)
    du2, dq2, dqd2, d12 = condensed_step(ocp, u, H, g, *gramian(ocp))
    np.testing.assert_allclose(dq, dq2, atol=1e-9)
    np.testing.assert_allclose(dqd, dqd2, atol=1e-9)
    np.testing.assert_allclose(du, du2, atol=1e-7)
    assert d1 == pytest.approx(d12, rel=1e-8)
    # and it is the minimiser of the quadratic model: its gradient in u vanishes
    ck = gramian(ocp)[0]
    m = g + H @ np.concatenate([dq2, dqd2])
    grad = (u + du2) @ ocp.R2.T + np.outer(ck, m[:n]) + ocp.dt * m[n:][None, :]
    assert np.abs(grad).max() < 1e-9 * max(1.0, np.abs(u @ ocp.R2.T).max())


def test_second_order_term_matches_finite_differences(franka):
    task, q0, Vd = franka
    vd = Vd
    q = q0 + 0.05 * np.random.default_rng(2).standard_normal(task.nq)
    w = np.arange(1.0, 8.0)
    H = task.error_hessian(q, Vd, w)
    h = 1e-6
    fd = np.zeros_like(H)
    for i in range(task.nq):
        dq = np.zeros(task.nq)
        dq[i] = h
        fd[:, i] = (w @ task.error_and_jacobian(q + dq, vd)[1] - w @ task.error_and_jacobian(q - dq, vd)[1]) / (2 * h)
    np.testing.assert_allclose(H, H.T, atol=1e-12)
    np.testing.assert_allclose(H, fd, atol=1e-6 * np.abs(H).max())


def test_displaced_target_identity_and_parameters(franka):
    task, q0, _ = franka
    V0 = displaced_target(task, q0)
    assert isinstance(V0, cg.Similarity)
    assert np.linalg.norm(task.error(q0, V0)) < 1e-12
    Vd = displaced_target(task, q0, translation=(0.1, -0.05, 0.1), axis=(1, 0, 0), angle=np.deg2rad(25), scale=1.25)
    Xd = Vd.apply(task.unit)
    X0 = task.primitive(q0)
    np.testing.assert_allclose(
        np.asarray(cg.center(Xd), float), np.asarray(cg.center(X0), float) + [0.1, -0.05, 0.1], atol=1e-12
    )
    assert float(cg.radius(Xd)) == pytest.approx(1.25 * float(cg.radius(X0)))
    n = np.asarray(cg.normal(Xd), float)
    assert np.degrees(np.arccos(n @ np.asarray(cg.normal(X0), float))) == pytest.approx(25.0)
    # the canonical versor maps the unit circle onto the target circle
    np.testing.assert_allclose(Vd.coeffs, cg.Similarity.from_unit(Xd).coeffs, atol=1e-12)


# ----------------------------------------------------------------------------- honesty
def test_non_convergence_is_reported(franka):
    task, q0, Vd = franka
    res = ilqr_reach(task, q0, Vd, max_iter=1)
    assert res.iterations == 1 and not res.converged
    assert res.error > 1e-5 and "max_iter" in res.message
    # an unreachable target (a circle of radius 5 m): never reported as converged
    Vfar = displaced_target(task, q0, scale=10.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        far = ilqr_reach(task, q0, Vfar, max_iter=10)
    assert not far.converged and far.error > 0.1
    assert np.all(np.diff(far.cost_history) < 0)


def test_zero_iterations_and_already_at_target(franka):
    task, q0, Vd = franka
    r0 = ilqr_reach(task, q0, Vd, max_iter=0)
    assert r0.iterations == 0 and not r0.converged and np.all(r0.u == 0)
    V0 = task.similarity(q0)
    r1 = ilqr_reach(task, q0, V0)
    assert r1.converged and r1.iterations == 0 and r1.error < 1e-12


def test_start_outside_the_limits(franka):
    """Enforced limits refuse a start outside them (physically impossible); limit_mode='none' reports, never clips."""
    task, q0, Vd = franka
    q = q0.copy()
    hi = task.system.limits.upper
    q[3] = hi[3] + 0.05  # start outside the limit of arm0's elbow
    with pytest.raises(InvalidInputError, match=r"outside the joint limits.*arm0_panda_joint4"):
        ilqr_reach(task, q, Vd)
    with pytest.warns(JointLimitWarning):
        res = ilqr_reach(task, q, Vd, limit_mode="none")
    assert res.joint_limit_violation >= 0.05 - 1e-12 and not res.within_limits
    assert res.trajectory[0, 3] == q[3]  # nothing clipped


# ----------------------------------------------------------------------------- errors
def test_bad_inputs_raise(franka):
    task, q0, Vd = franka
    with pytest.raises(InvalidInputError, match="21 entries"):
        ilqr_reach(task, q0[:-1], Vd)
    bad = Vd.coeffs.copy()
    bad[3] = np.nan
    with pytest.raises(NonFiniteError):
        ilqr_reach(task, q0, cg.Similarity.from_coeffs(bad))
    with pytest.raises(InvalidInputError, match="Similarity"):
        ilqr_reach(task, q0, bad)
    qn = q0.copy()
    qn[0] = np.inf
    with pytest.raises(NonFiniteError):
        ilqr_reach(task, qn, Vd)
    with pytest.raises(InvalidInputError):
        ilqr_reach(task, q0, np.ones(5))
    with pytest.raises(InvalidInputError, match="positive definite"):
        ilqr_reach(task, q0, Vd, R=0.0)
    with pytest.raises(InvalidInputError, match="semi-definite"):
        ilqr_reach(task, q0, Vd, Q=-np.ones(7))
    with pytest.raises(InvalidInputError):
        ilqr_reach(task, q0, Vd, horizon=0)
    with pytest.raises(InvalidInputError):
        ilqr_reach(task, q0, Vd, dt=-0.01)
    with pytest.raises(InvalidInputError):
        ilqr_reach(task, q0, Vd, hessian="bfgs")
    with pytest.raises(InvalidInputError):
        ilqr_reach(task, q0, Vd, u_init=np.zeros((3, 21)))
    with pytest.raises(cg.CoopGAError):
        ilqr_reach(task, q0, Vd, max_iter=-1)
