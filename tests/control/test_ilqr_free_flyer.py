"""The iLQR on a free flyer (nq ≠ nv): the chart q(x) = q_ref ⊕ (x − c) of :mod:`coop_ga.control.ilqr.chart`.

References: central differences through ``pinocchio.integrate`` (the chart's Jacobian and Hessian), Pinocchio's
forward kinematics (the hands on the target), the bounded Gauss–Newton IK and the reference OCP on the manifold
solved by IPOPT (the same primitive), and the fixed-pelvis G1 (which cannot reach the target).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from scipy.linalg import expm, logm

import coop_ga as cg
from coop_ga.control import gauss_newton_ik, ilqr_reach
from coop_ga.control.ilqr import RecedingReach
from coop_ga.control.ilqr.chart import ChartTask, FlyerChart, flyer_curvature, flyer_jacobian
from coop_ga.control.reference_ocp import TangentReachingOCP, solve_reference
from coop_ga.cooperative.targets import displaced_target
from coop_ga.errors import InvalidInputError
from coop_ga.systems.library import g1_floating

MOVE = {"translation": (0.6, 0.2, 0.3), "axis": (0.0, 0.0, 1.0), "angle": 0.4}


@pytest.fixture(scope="module")
def system():
    return g1_floating()


@pytest.fixture(scope="module")
def reach(system):
    """The floating G1's point pair moved out of the fixed pelvis' reach, and the iLQR's solve (30 knots, 1.5 s)."""
    task = cg.cooperative_task(system, "point_pair")
    Vd = displaced_target(task, system.q0, **MOVE)
    return task, Vd, ilqr_reach(task, system.q0, Vd, horizon=30, dt=0.05)


def _hands(s, q) -> np.ndarray:
    d = s.model.createData()
    pin.framesForwardKinematics(s.model, d, q)
    return np.array([d.oMf[s.model.getFrameId(f)].translation for f in s.end_frames])


def _chart_point(system, seed: int = 1) -> tuple[FlyerChart, np.ndarray]:
    """A chart about a random configuration and a point x of it 0.4 m / 0.6 rad away on the flyer."""
    rng = np.random.default_rng(seed)
    chart = FlyerChart(system, system.random_q(rng, 0.3))
    xi = np.zeros(system.nv)
    xi[:6] = np.concatenate([0.4 * rng.standard_normal(3), 0.6 * rng.standard_normal(3) / np.sqrt(3)])
    xi[6:] = 0.1 * rng.standard_normal(system.nv - 6)
    return chart, chart.c + xi


def test_chart_jacobian_equals_differences_through_integrate(system) -> None:
    task = cg.cooperative_task(system, "line")
    chart, x = _chart_point(system)
    ct = ChartTask(task, chart)
    Vd = displaced_target(task, chart.q_ref, translation=(0.05, 0.0, 0.02))
    e, J = ct.error_and_jacobian(x, Vd)
    assert J.shape == (7, system.nv) and ct.nq == ct.nv == system.nv
    np.testing.assert_array_equal(e, task.error(pin.integrate(system.model, chart.q_ref, x - chart.c), Vd))
    h, worst = 1e-6, 0.0
    for k in range(system.nv):
        dx = np.zeros(system.nv)
        dx[k] = h
        E = lambda y: task.error(pin.integrate(system.model, chart.q_ref, y - chart.c), Vd)  # noqa: E731
        worst = max(worst, float(np.abs((E(x + dx) - E(x - dx)) / (2 * h) - J[:, k]).max()))
    assert worst <= 1e-8
    # the chart is the identity on the joints and D ≠ I on the flyer away from its centre
    D = chart.dq(x)
    np.testing.assert_array_equal(D[6:, 6:], np.eye(system.nv - 6))
    assert np.abs(D[:6, :6] - np.eye(6)).max() > 0.1 and np.array_equal(chart.dq(chart.c), np.eye(system.nv))
    np.testing.assert_allclose(chart.from_q(chart.to_q(x)), x, atol=1e-12)
    # the flyer's block is Pinocchio's dIntegrate (the SE(3) right Jacobian) at a sizeable angle; near 1e-3 rad
    # Pinocchio's series lose ~1e-8 (Jexp6) to ~1e-7 (differences of exp6/log6), so the reference there is the
    # matrix exponential and logarithm of scipy (ours: within 1e-9 of it)
    np.testing.assert_allclose(D, pin.dIntegrate(system.model, chart.q_ref, x - chart.c, pin.ARG1), atol=1e-12)
    xi = np.array([0.4, 0.1, 0.2, 3e-4, 5e-4, 8e-4])  # |ω| ≈ 1e-3 rad
    Ti = np.linalg.inv(expm(_hat(xi)))
    m = lambda d: _vee(np.real(logm(Ti @ expm(_hat(xi + d)))))  # noqa: E731
    fd = np.array([(m(1e-6 * e) - m(-1e-6 * e)) / 2e-6 for e in np.eye(6)]).T
    assert np.abs(flyer_jacobian(xi) - fd).max() <= 1e-9


def _hat(v: np.ndarray) -> np.ndarray:
    """The 4 × 4 matrix of the twist v = [ν; ω] (LOCAL, Pinocchio's order)."""
    M = np.zeros((4, 4))
    M[:3, :3] = [[0.0, -v[5], v[4]], [v[5], 0.0, -v[3]], [-v[4], v[3], 0.0]]
    M[:3, 3] = v[:3]
    return M


def _vee(M: np.ndarray) -> np.ndarray:
    return np.array([M[0, 3], M[1, 3], M[2, 3], M[2, 1], M[0, 2], M[1, 0]])


def test_chart_hessian_equals_differences_of_the_chart_gradient(system) -> None:
    """∇²_x(wᵀe) of the chart (Dᵀ H D + the flyer's curvature) equals central differences of the chart gradient
    J_xᵀ w, itself checked above against pinocchio.integrate; without the curvature term it would not."""
    task = cg.cooperative_task(system, "line")
    chart, x = _chart_point(system, 2)
    ct = ChartTask(task, chart)
    Vd = displaced_target(task, chart.q_ref, translation=(0.05, 0.0, 0.02), axis=(0.0, 1.0, 0.0), angle=0.2)
    w = np.random.default_rng(4).standard_normal(7)
    H = ct.error_hessian(x, Vd, w)
    grad = lambda y: ct.error_and_jacobian(y, Vd)[1].T @ w  # noqa: E731
    h = 1e-6
    fd = np.array([(grad(x + h * e) - grad(x - h * e)) / (2 * h) for e in np.eye(system.nv)]).T
    scale = np.abs(H).max()
    assert np.abs(H - fd).max() <= 1e-6 * scale
    g = task.error_jacobian(chart.to_q(x), Vd).T @ w
    C = chart.curvature(x, g)
    assert np.abs(C).max() > 1e-2 * scale and np.abs(C[6:]).max() == 0.0  # the term matters, on the flyer only
    assert np.abs(flyer_curvature(np.zeros(6), g[:6])).max() == 0.0  # none at the chart's centre
    # near a small rotation too (Taylor branch of the exponential, |ω| = 1e-3 rad)
    x2 = chart.c.copy()
    x2[:6] = [0.4, 0.1, 0.2, 3e-4, 5e-4, 8e-4]
    H2 = ct.error_hessian(x2, Vd, w)
    fd2 = np.array([(grad(x2 + h * e) - grad(x2 - h * e)) / (2 * h) for e in np.eye(system.nv)]).T
    assert np.abs(H2 - fd2).max() <= 1e-6 * np.abs(H2).max()


def test_floating_g1_reach_converges_where_the_fixed_pelvis_cannot(system, reach) -> None:
    r = reach[2]
    assert r.converged and r.error < 1e-5, r.message
    assert r.trajectory.shape == (31, 24) and r.qd.shape == (31, 23) and r.u.shape == (30, 23)
    np.testing.assert_array_equal(r.trajectory[0], system.q0)
    assert np.array_equal(r.q, r.trajectory[-1]) and np.abs(r.qd[0]).max() == 0.0
    assert np.abs(np.linalg.norm(r.trajectory[:, 3:7], axis=1) - 1.0).max() <= 1e-12
    assert np.linalg.norm(r.q[:3] - system.q0[:3]) > 0.3  # the pelvis moved
    assert system.limits.position_violation(system.limit_coordinates(r.trajectory)) == 0.0
    assert r.velocity_violation <= 1e-9 and r.acceleration_violation <= 1e-9
    # qd is the tangent velocity: the trajectory's steps by pinocchio.difference are its trapezoidal integral
    steps = np.array([pin.difference(system.model, a, b) for a, b in zip(r.trajectory[:-1], r.trajectory[1:])])
    assert np.abs(steps / 0.05 - 0.5 * (r.qd[:-1] + r.qd[1:])).max() <= 2e-3 * np.abs(r.qd).max()
    fixed = cg.cooperative_task(cg.systems.load("g1_arms"), "point_pair")
    rf = ilqr_reach(fixed, fixed.system.q0, displaced_target(fixed, fixed.system.q0, **MOVE), horizon=30, dt=0.05)
    assert not rf.converged and rf.error > 0.1


def test_floating_reach_lands_on_the_primitive_of_gauss_newton_and_ipopt(system, reach) -> None:
    """The same target primitive (the hands' points of a point pair) by three solvers, checked by Pinocchio's FK."""
    task, Vd, r = reach
    gn = gauss_newton_ik(task, system.q0, Vd, tol=1e-10)
    ocp = TangentReachingOCP(task, system.q0, Vd, horizon=30, dt=0.05)
    ref = solve_reference(ocp, solver="ipopt", terminal="constraint")
    assert gn.converged and ref.success, (gn.message, ref.status)
    p0 = _hands(system, system.q0)
    c = p0.mean(axis=0)
    R = pin.AngleAxis(MOVE["angle"], np.array(MOVE["axis"])).toRotationMatrix()
    expected = (p0 - c) @ R.T + c + np.array(MOVE["translation"])
    for q, tol in ((r.q, 1e-5), (gn.q, 1e-9), (ref.q[-1], 1e-8)):
        assert np.abs(_hands(system, q) - expected).max() <= tol
    # the chart's double integrator is not the manifold's (IPOPT's), yet the optima nearly agree (measured: costs
    # 4e-4 apart relative, end configurations 1.3e-3 apart in the tangent norm)
    assert abs(r.cost - ref.cost) <= 2e-3 * ref.cost and system.distance(r.q, ref.q[-1]) <= 5e-3


def test_bad_input_on_a_free_flyer(system, reach) -> None:
    task, Vd, _ = reach
    q = system.q0.copy()
    q[3:7] *= 2.0
    with pytest.raises(InvalidInputError, match=r"q_init.*quaternion.*norm 2"):
        ilqr_reach(task, q, Vd, horizon=10)
    with pytest.raises(InvalidInputError, match="qd_init"):
        ilqr_reach(task, system.q0, Vd, horizon=10, qd_init=np.zeros(24))
    with pytest.raises(InvalidInputError, match="controls"):
        ilqr_reach(task, system.q0, Vd, horizon=10, u_init=np.zeros((10, 24)))
    rr = RecedingReach(task, horizon=10, dt=0.05)
    with pytest.raises(InvalidInputError, match=r"q_init.*quaternion"):
        rr.solve(q, Vd)


def test_receding_reach_recentres_its_chart(system, reach) -> None:
    """A RecedingReach from a moving start in the middle of the reach equals ilqr_reach from there (restart off):
    the chart is re-centred at each start."""
    task, Vd, r = reach
    rr = RecedingReach(task, horizon=30, dt=0.05, restart=False)
    first = rr.solve(system.q0, Vd)
    np.testing.assert_array_equal(first.u, ilqr_reach(task, system.q0, Vd, horizon=30, dt=0.05, restart=False).u)
    q1, v1 = r.trajectory[10], r.qd[10]
    again = rr.solve(q1, Vd, qd_init=v1, u_init=first.u)
    direct = ilqr_reach(task, q1, Vd, horizon=30, dt=0.05, restart=False, qd_init=v1, u_init=first.u)
    np.testing.assert_array_equal(again.u, direct.u)
    np.testing.assert_array_equal(again.trajectory, direct.trajectory)
    assert again.converged and np.array_equal(again.trajectory[0], q1)
