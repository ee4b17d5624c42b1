"""coop_ga's cooperative similarity error as a crocoddyl residual: its derivatives against finite differences, and
crocoddyl's BoxFDDP on the robot's dynamics reaching the primitive coop_ga's iLQR reaches, on the three Frankas'
circle.  crocoddyl 3.2.1 needs Pinocchio 4.0 (the ``crocoddyl`` extra); skipped where it is not installed."""

from __future__ import annotations

import numpy as np
import pytest

crocoddyl = pytest.importorskip("crocoddyl")

import pinocchio as pin  # noqa: E402

import coop_ga as cg  # noqa: E402
from coop_ga.adapters.crocoddyl import SimilarityResidual, double_integrator_problem, reach_problem  # noqa: E402
from coop_ga.control import displaced_target, ilqr_reach  # noqa: E402
from coop_ga.control.ilqr import ReachingOCP  # noqa: E402
from coop_ga.errors import InvalidInputError  # noqa: E402
from coop_ga.geometry.similarity import primitive_parameters  # noqa: E402

TARGET = {"translation": (0.05, -0.03, 0.04), "axis": (1, 1, 0), "angle": 0.3, "scale": 1.15}


@pytest.fixture(scope="module")
def circle(load_system):
    task = cg.cooperative_task(load_system("three_franka"), "circle")
    q0 = np.asarray(task.system.q0, dtype=float)
    return task, q0, displaced_target(task, q0, **TARGET)


def _residual(task, target):
    state = crocoddyl.StateMultibody(pin.Model(task.system.model))
    res = SimilarityResidual(state, task, target)
    return state, res, res.createData(crocoddyl.DataCollectorAbstract())


def test_the_residual_is_the_error_and_its_derivatives_match_finite_differences(circle):
    task, q0, target = circle
    nq = task.nq
    _, res, data = _residual(task, target)
    x = np.concatenate([q0 + np.random.default_rng(3).uniform(-0.2, 0.2, nq), np.ones(nq)])
    res.calc(data, x)
    res.calcDiff(data, x)
    np.testing.assert_array_equal(data.r, task.error(x[:nq], target))
    assert data.Rx.shape == (7, 2 * nq) and data.Ru.shape == (7, nq)
    assert np.all(data.Rx[:, nq:] == 0.0) and np.all(data.Ru == 0.0)  # q only
    h, fd = 1e-6, np.zeros((7, nq))
    for i in range(nq):
        dq = np.zeros(nq)
        dq[i] = h
        fd[:, i] = (task.error(x[:nq] + dq, target) - task.error(x[:nq] - dq, target)) / (2 * h)
    assert np.abs(data.Rx[:, :nq] - fd).max() < 1e-8 * max(1.0, np.abs(fd).max())
    # calcDiff at another x than the last calc recomputes (no stale Jacobian)
    res.calcDiff(data, x + 0.1)
    np.testing.assert_allclose(data.Rx[:, :nq], task.error_jacobian(x[:nq] + 0.1, target), rtol=0, atol=1e-14)


def test_the_terminal_cost_gradient_matches_crocoddyls_numdiff(circle):
    """The whole terminal node (similarity + rest costs) through crocoddyl: Lx against DifferentialActionModelNumDiff."""
    task, q0, target = circle
    problem = reach_problem(task, q0, target, horizon=2)
    dam = problem.terminalModel.differential
    nd = crocoddyl.DifferentialActionModelNumDiff(dam, False)
    x = np.concatenate([q0 + 0.05, 0.1 * np.ones(task.nq)])
    u = np.zeros(task.nq)
    d, dnd = dam.createData(), nd.createData()
    dam.calc(d, x, u)
    dam.calcDiff(d, x, u)
    nd.calc(dnd, x, u)
    nd.calcDiff(dnd, x, u)
    assert d.cost > 1.0 and abs(d.cost - dnd.cost) < 1e-12 * d.cost
    assert np.abs(d.Lx - dnd.Lx).max() < 1e-5 * np.abs(d.Lx).max()


def test_box_fddp_reaches_the_primitive_of_coop_ga_ilqr(circle):
    task, q0, target = circle
    problem = reach_problem(task, q0, target)
    solver = crocoddyl.SolverBoxFDDP(problem)
    assert solver.solve([problem.x0] * (problem.T + 1), problem.quasiStatic([problem.x0] * problem.T), 200)
    xn = np.asarray(solver.xs[-1])
    ilqr = ilqr_reach(task, q0, target)
    e0 = np.linalg.norm(task.error(q0, target))
    e_croc = np.linalg.norm(task.error(xn[: task.nq], target))
    assert ilqr.converged and e0 > 0.2
    assert e_croc < 1e-4 and ilqr.error < 1e-4, (e_croc, ilqr.error)  # 1.5e-5 (39 iterations) and 8e-8 (5)
    assert np.linalg.norm(xn[task.nq :]) < 1e-2  # at rest
    tau = np.asarray(solver.us)
    assert np.all(np.abs(tau) <= task.system.model.effortLimit + 1e-9)  # BoxFDDP's torque bounds
    # the same circle: center, radius [m] and normal to 1e-4 (the joints differ: other dynamics, redundancy)
    _, c1, r1, n1 = primitive_parameters(task.primitive(xn[: task.nq]))
    _, c2, r2, n2 = primitive_parameters(task.primitive(ilqr.q))
    assert np.abs(np.asarray(c1) - np.asarray(c2)).max() < 1e-4
    assert abs(float(r1) - float(r2)) < 1e-4
    assert np.abs(np.asarray(n1) - np.asarray(n2)).max() < 1e-4


def test_bad_input_is_refused(circle, load_system):
    task, q0, target = circle
    other = crocoddyl.StateMultibody(pin.Model(load_system("g1_arms").model))
    with pytest.raises(InvalidInputError, match="nq"):
        SimilarityResidual(other, task, target)
    state = crocoddyl.StateMultibody(pin.Model(task.system.model))
    with pytest.raises(InvalidInputError, match="target"):
        SimilarityResidual(state, task, np.ones(3))
    with pytest.raises(InvalidInputError, match="horizon"):
        reach_problem(task, q0, target, horizon=0)
    with pytest.raises(InvalidInputError, match="w_error"):
        reach_problem(task, q0, target, w_error=-1.0)
    with pytest.raises(InvalidInputError, match="q_init"):
        reach_problem(task, q0[:3], target)


def test_double_integrator_problem_is_coop_gas_ocp(circle):
    """The crocoddyl problem of the iLQR's own OCP: its cost is J(u) of ReachingOCP for any controls (to round-off),
    and BoxFDDP from rest ends at the iLQR's optimum (tol = 0) to 1e-4 of the cost, inside the acceleration box."""
    task, q0, target = circle
    ocp = ReachingOCP(task, q0, target, horizon=30, dt=0.05)
    problem = double_integrator_problem(ocp, state_bounds=1e6)
    u = 0.3 * np.random.default_rng(1).standard_normal((30, task.nq))
    xs = problem.rollout(list(u))
    assert problem.calc(xs, list(u)) == pytest.approx(ocp.cost(u), rel=1e-12)
    np.testing.assert_allclose(np.asarray(xs)[:, : task.nq], ocp.rollout(u)[0], atol=1e-12)
    solver = crocoddyl.SolverBoxFDDP(problem)
    solver.solve([problem.x0] * 31, [np.zeros(task.nq)] * 30, 500, False)
    ilqr = ilqr_reach(task, q0, target, horizon=30, dt=0.05, terminal="soft", tol=0.0)
    U = np.asarray(solver.us)
    assert ocp.cost(U) == pytest.approx(ilqr.cost, rel=1e-4), (ocp.cost(U), ilqr.cost)
    assert np.all(np.abs(U) <= ocp.a_max + 1e-12)
    with pytest.raises(InvalidInputError):
        double_integrator_problem(ReachingOCP(task, q0, target, horizon=5, Q=np.ones((7, 7)) + np.eye(7)))
