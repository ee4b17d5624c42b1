"""The iLQR's clearance cost on trajectories: the batched cost and rows, and the closed-form LQ step on the rows."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import coop_ga as cg
from coop_ga.collision.distance import Sphere
from coop_ga.collision.model import CollisionModel
from coop_ga.control.avoidance import ClearanceCost
from coop_ga.control.ilqr import ReachingOCP, displaced_target, ilqr_reach
from coop_ga.control.ilqr.lq import (
    Condensation,
    _rows_newton,
    _rows_solve,
    _segment_minimiser,
    condensed_rows_step,
)
from coop_ga.control.ilqr.merit import Merit, gauss_newton_hessian, terminal_model

CENTER, RADIUS = np.array([0.014, -0.346, 0.478]), 0.04  # the sphere of tests/control/test_avoidance.py


@pytest.fixture(scope="module")
def problem():
    """A 20-knot reach whose controls (the plain iLQR's, perturbed) run arm 0 through the sphere."""
    s = cg.systems.load("three_franka")
    task = cg.cooperative_task(s, "circle")
    q0 = np.array(s.q0, float)
    Vd = displaced_target(task, q0, translation=(0.0, 0.30, 0.0))
    cm = CollisionModel(s, obstacles=[Sphere(CENTER, RADIUS)], self_collision=True)
    cost = ClearanceCost(cm, weight=1e4, activation=0.05)
    ocp = ReachingOCP(task, q0, Vd, horizon=20, dt=0.1, clearance=cost)
    plain = ilqr_reach(task, q0, Vd, horizon=20, dt=0.1)
    u = plain.u + 0.01 * np.random.default_rng(0).standard_normal(plain.u.shape)
    return ocp, cost, u


def test_trajectory_cost_and_rows_equal_the_knot_by_knot_evaluation(problem):
    ocp, cost, u = problem
    q, _ = ocp.rollout(u)
    per_knot = [cost.evaluate(qk) for qk in q[1:]]
    assert cost.trajectory_value(q[1:]) == pytest.approx(sum(c[0] for c in per_knot), rel=1e-12)
    assert ocp.clearance_cost(q) > 1.0  # the hinge is active
    rows = ocp.clearance_rows(q, 0.02)
    assert rows is not None and np.any(rows.v > 0) and np.any(rows.v <= 0)  # active rows and look-ahead rows
    g = rows.gradient(ocp.horizon, ocp.nq)
    H = rows.hessians(ocp.horizon, ocp.nq)
    for k in range(1, ocp.horizon + 1):
        np.testing.assert_allclose(g[k], per_knot[k - 1][1], atol=1e-9)
        np.testing.assert_allclose(H[k], per_knot[k - 1][2], atol=1e-6)


def _model(ocp: ReachingOCP, u: np.ndarray):
    merit = Merit(ocp, 0.0)
    ev = merit.evaluate(u)
    gf, _ = terminal_model(ocp, ev, None)
    Vxx = gauss_newton_hessian(ocp, ev, np.zeros(2 * ocp.nq))
    return ev, gf, Vxx


def test_rows_solve_is_the_dense_lq_minimiser(problem):
    """_rows_solve (Woodbury on the observations) equals the minimiser of the same quadratic model over the whole
    control sequence, formed and solved densely (T·nq = 420 unknowns)."""
    ocp, _, u = problem
    ev, vx, Vxx = _model(ocp, u)
    cond = Condensation.of(ocp)
    rows = ocp.clearance_rows(ev.q, 0.02)
    act = rows.v > 0
    du, _ = _rows_solve(ocp, cond, u, Vxx, vx, rows, act)
    T, n = ocp.horizon, ocp.nq
    H0, g0, Gy = _dense_terms(ocp, cond, u, Vxx, vx, rows)
    H = H0 + rows.w * Gy[act].T @ Gy[act]
    g = g0 - rows.w * Gy[act].T @ rows.v[act]
    x = -np.linalg.solve(H, g)

    def f(v: np.ndarray) -> float:
        return float(0.5 * v @ H @ v + g @ v)

    # the stiff terminal model (Q = 1e5) makes H ill-conditioned: compare the model's values and the step's size
    print(f"condition {np.linalg.cond(H):.1e}, f {f(du.ravel()):.10e} (Woodbury) {f(x):.10e} (dense)")
    assert f(du.ravel()) == pytest.approx(f(x), rel=1e-9)
    assert np.linalg.norm(du.ravel() - x) < 1e-3 * np.linalg.norm(x)

    # with controls held at a bound (the acceleration box in the active set): the Woodbury correction of the
    # clamped columns equals the dense minimiser over the free controls
    rng = np.random.default_rng(3)
    hi = rng.random(u.shape) < 0.05
    lo = (rng.random(u.shape) < 0.05) & ~hi
    bounds = (u - 1.0 - rng.random(u.shape), u + 1.0 + rng.random(u.shape))  # the new controls' box
    du_c, GTm = _rows_solve(ocp, cond, u, Vxx, vx, rows, act, (hi, lo), bounds)
    fixed = (hi | lo).ravel()
    d_fixed = (np.where(hi, bounds[1], bounds[0]) - u).ravel()[fixed]
    x_c = np.zeros(T * n)
    x_c[fixed] = d_fixed
    free = ~fixed
    x_c[free] = -np.linalg.solve(H[np.ix_(free, free)], g[free] + H[np.ix_(free, fixed)] @ d_fixed)
    assert hi.sum() + lo.sum() > 10
    np.testing.assert_array_equal(du_c.ravel()[fixed], d_fixed)  # held exactly
    assert f(du_c.ravel()) == pytest.approx(f(x_c), rel=1e-9)
    assert f(du_c.ravel()) > f(x)  # the clamps cost something
    assert np.linalg.norm(du_c.ravel() - x_c) < 1e-3 * np.linalg.norm(x_c)
    # the returned Gᵀm makes 2R(u + δu) + Gᵀm the model's gradient, zero on the free controls
    grad = (u + du_c) * np.diag(ocp.R2) + GTm
    np.testing.assert_allclose(grad.ravel(), H @ du_c.ravel() + g, rtol=1e-6, atol=1e-6 * np.abs(g).max())
    assert np.abs(grad.ravel()[free]).max() < 1e-6 * np.abs(g).max()


def _dense_terms(ocp: ReachingOCP, cond: Condensation, u: np.ndarray, Vxx: np.ndarray, vx: np.ndarray, rows):
    """The rows step's model over the whole control sequence x = δu (T·nq), formed densely: the smooth part
    ``½xᵀH₀x + g₀ᵀx`` (controls and terminal model through G: x → [δq_n; δq̇_n]) and the rows' observations
    ``a_rᵀx = y_r`` (m, T·nq), as ``(H₀, g₀, a)``."""
    T, n, dt = ocp.horizon, ocp.nq, ocp.dt
    Gx = np.zeros((2 * n, T * n))
    for j in range(T):
        Gx[:n, j * n : (j + 1) * n] = cond.ck[j] * np.eye(n)
        Gx[n:, j * n : (j + 1) * n] = dt * np.eye(n)
    a = np.zeros((rows.v.size, T * n))
    for r in range(rows.v.size):
        for j in range(T):
            a[r, j * n : (j + 1) * n] = cond.C[rows.knots[r], j] * rows.J[r]
    H0 = np.kron(np.eye(T), ocp.R2) + Gx.T @ Vxx @ Gx
    g0 = (u @ ocp.R2.T).ravel() + Gx.T @ vx
    return H0, g0, a


def _dense_model(ocp: ReachingOCP, cond: Condensation, u: np.ndarray, Vxx: np.ndarray, vx: np.ndarray, rows):
    """The rows step's piecewise-quadratic model ``½xᵀH₀x + g₀ᵀx + ½w Σ max(0, v_r − a_rᵀx)²`` (:func:`_dense_terms`)
    as ``(f, ∇f, g₀)``."""
    H0, g0, a = _dense_terms(ocp, cond, u, Vxx, vx, rows)

    def f(x: np.ndarray) -> float:
        h = np.maximum(rows.v - a @ x, 0.0)
        return float(0.5 * x @ H0 @ x + g0 @ x + 0.5 * rows.w * h @ h)

    def grad(x: np.ndarray) -> np.ndarray:
        return H0 @ x + g0 - rows.w * a.T @ np.maximum(rows.v - a @ x, 0.0)

    return f, grad, g0


def test_rows_newton_reaches_the_minimiser_of_the_piecewise_quadratic_model(problem):
    """The semi-smooth Newton iteration ends at a stationary point of the model (C¹ and convex: the minimiser),
    checked by the dense gradient; its rows are those active there; with fewer solves its model value is never
    above the one-solve step's (the iteration decreases the model).  (Each active set's solve is _rows_solve's,
    checked against the dense minimiser above.)"""
    ocp, _, u = problem
    ev, vx, Vxx = _model(ocp, u)
    cond = Condensation.of(ocp)
    rows = ocp.clearance_rows(ev.q, 0.02)
    act0 = rows.v > 0
    f, grad, g0 = _dense_model(ocp, cond, u, Vxx, vx, rows)
    du, _, y, act = _rows_newton(ocp, cond, u, Vxx, vx, rows, 50, np.inf)
    x = du.ravel()
    print(
        f"rows {rows.v.size}, active at start {act0.sum()}, at the end {act.sum()}; |grad| {np.linalg.norm(grad(x)):.2e}"
    )
    assert np.linalg.norm(grad(x)) < 1e-6 * np.linalg.norm(g0)
    assert not np.array_equal(act, act0)  # the step moved rows in or out of activation: the test is not trivial
    np.testing.assert_array_equal(act, rows.v - y > 0)
    values = [f(_rows_newton(ocp, cond, u, Vxx, vx, rows, k, np.inf)[0].ravel()) for k in (1, 2, 3, 50)]
    assert all(b <= a + 1e-9 * abs(a) for a, b in itertools.pairwise(values))
    assert values[-1] < values[0]


def test_segment_minimiser_equals_a_dense_search():
    """The exact minimiser on [0, 1] of the convex piecewise quadratic along a segment equals the best of a dense
    grid refined by a golden-section search (independent of the breakpoint bracketing)."""
    rng = np.random.default_rng(5)
    for trial in range(200):
        m = int(rng.integers(1, 30))
        r, s = rng.normal(size=m), rng.normal(size=m)
        w, a2 = 10.0 ** rng.uniform(-1, 3), 10.0 ** rng.uniform(-3, 1)
        b = -abs(rng.normal()) * 10.0 ** rng.uniform(-1, 2)

        def phi(t: float) -> float:
            return b * t + 0.5 * a2 * t * t + 0.5 * w * float(np.sum(np.maximum(r - t * s, 0.0) ** 2))

        t = _segment_minimiser(b, a2, w, r, s)
        grid = np.linspace(0.0, 1.0, 2001)
        k = int(np.argmin([phi(g) for g in grid]))
        lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, 2000)]
        for _ in range(100):  # golden section on the bracket (φ convex)
            c, d = hi - 0.618 * (hi - lo), lo + 0.618 * (hi - lo)
            lo, hi = (lo, d) if phi(c) < phi(d) else (c, hi)
        assert 0.0 <= t <= 1.0
        assert phi(t) <= phi(0.5 * (lo + hi)) + 1e-10 * (1.0 + abs(phi(0.0))), trial
        assert abs(t - 0.5 * (lo + hi)) < 1e-6 or phi(t) == pytest.approx(phi(0.5 * (lo + hi)), rel=1e-12)


def test_condensed_rows_step_is_a_descent_step_with_the_exact_slope(problem):
    """d1 is the exact directional derivative of J at u along the step (the adjoint gradient of ReachingOCP,
    terminal and clearance parts), negative; the active set ends with the rows the step leaves within d_a."""
    ocp, _, u = problem
    ev, vx, Vxx = _model(ocp, u)
    rows = ocp.clearance_rows(ev.q, 0.02)
    du, d1, d2 = condensed_rows_step(ocp, Condensation.of(ocp), u, Vxx, vx, rows)
    slope = float(np.sum(ocp.gradient(u) * du))
    assert d1 == pytest.approx(slope, rel=1e-8)
    assert d1 < 0
    # the model's prediction of a short step matches the true change to first order
    a = 1e-4
    change = ocp.cost(u + a * du) - ocp.cost(u)
    assert change == pytest.approx(a * d1 + a * a * d2, rel=1e-2)


def test_clearance_reach_result_is_clear_of_the_sphere_by_an_independent_check(problem):
    """The 20-knot reach with the clearance cost ends clear of the sphere: coop_ga.collision and coal's GJK on
    the same capsules agree on the smallest obstacle clearance at the knots."""
    coal = pytest.importorskip("coal")
    import pinocchio as pin

    ocp, cost, _ = problem
    res = ilqr_reach(ocp.task, ocp.q_init, ocp.target, horizon=20, dt=0.1, clearance=cost)
    assert res.converged, res.message
    cm = cost.model
    d_ours = float(np.min(cm.min_clearance(res.trajectory, kind="obstacle")))
    assert d_ours > 0.03
    model, data = cm.system.model, cm.system.model.createData()
    sphere = coal.Sphere(RADIUS)
    tf_s = coal.Transform3s(np.eye(3), CENTER)
    best = np.inf
    for q in res.trajectory:
        pin.framesForwardKinematics(model, data, q)
        for c in cm.capsules:
            M = data.oMf[model.getFrameId(c.frame)]
            a, b = M.act(c.a), M.act(c.b)
            z = b - a
            L = float(np.linalg.norm(z))
            z = z / L if L > 0 else np.array([0.0, 0.0, 1.0])
            x = np.cross(z, [1.0, 0.0, 0.0] if abs(z[0]) < 0.9 else [0.0, 1.0, 0.0])
            x /= np.linalg.norm(x)
            tf = coal.Transform3s(np.column_stack([x, np.cross(z, x), z]), 0.5 * (a + b))
            d = coal.distance(
                coal.Capsule(c.radius, L), tf, sphere, tf_s, coal.DistanceRequest(), coal.DistanceResult()
            )
            best = min(best, d)
    assert best == pytest.approx(d_ours, abs=1e-6)


def test_condensed_rows_step_keeps_the_acceleration_box_in_its_active_set(problem):
    """When the rows' step leaves the acceleration box, the box joins the active set: the step returned stays inside
    |u| ≤ a_max with controls at the bound, and it is a descent step with the exact slope d1 and a model decrease."""
    ocp, cost, u = problem
    ev, vx, Vxx = _model(ocp, u)
    rows = ocp.clearance_rows(ev.q, 0.02)
    cond = Condensation.of(ocp)
    # the rows' iteration run to its end (its default of 8 solves stops short on this stiff model, where a box
    # between u and an unconverged step need not bind at the minimiser)
    du0, d10, d20 = condensed_rows_step(ocp, cond, u, Vxx, vx, rows, max_sets=50)
    a_max = 0.5 * (np.abs(u).max() + np.abs(u + du0).max())  # between the controls now and the free step's
    assert np.abs(u).max() < a_max < np.abs(u + du0).max()
    s = ocp.task.system.with_limits(acceleration=a_max)
    task = cg.cooperative_task(s, "circle")
    bounded = ReachingOCP(task, ocp.q_init, ocp.target, horizon=ocp.horizon, dt=ocp.dt, clearance=cost)
    assert bounded.u_bounded
    du, d1, d2 = condensed_rows_step(bounded, Condensation.of(bounded), u, Vxx, vx, rows, max_sets=50)
    assert np.abs(u + du).max() <= a_max + 1e-12
    assert np.isclose(np.abs(u + du).max(), a_max)  # some control at the bound
    slope = float(np.sum(bounded.gradient(u) * du))
    assert d1 == pytest.approx(slope, rel=1e-8)
    assert d1 < 0 and d1 + d2 < 0 and d10 + d20 < 0
    assert not np.allclose(du, du0)


def test_obstacle_reach_takes_its_late_steps_whole():
    """The obstacle scene of benchmarks/ocp.py (100 knots × 0.03 s): once ‖e‖ < 1e-2 the pairs sit at the activation
    distance and the steps are small, so the quadratic model holds and every step is taken whole (α = 1): the
    Newton terminal model while no row is active, and the second-order correction of a step whose rows or
    terminal error moved off their linearisation.  (With Gauss–Newton near the rows and no correction of the rows,
    three of the six late steps were cut to α = 1/4 … 1/8 and the reach took 14 iterations.)  The result is
    converged and clear of the sphere (checked independently by coal in benchmarks/ocp.py and, on a shorter reach,
    by test_clearance_reach_result_is_clear_of_the_sphere_by_an_independent_check)."""
    s = cg.systems.load("three_franka")
    task = cg.cooperative_task(s, "circle")
    q0 = np.array(s.q0, float)
    Vd = displaced_target(task, q0, translation=(0.0, 0.30, 0.0))
    cm = CollisionModel(s, obstacles=[Sphere(CENTER, RADIUS)], self_collision=True)
    res = ilqr_reach(task, q0, Vd, horizon=100, dt=0.03, clearance=ClearanceCost(cm, weight=1e4, activation=0.05))
    late = [it for it, e in zip(res.stats, res.error_history[:-1]) if e < 1e-2]
    print([(round(it.alpha, 4), it.line_search_trials, it.model) for it in res.stats])
    assert res.converged and res.min_clearance >= 0.0, res.message
    assert len(late) >= 2
    assert all(it.alpha == 1.0 for it in late), [it.alpha for it in late]
    assert res.iterations <= 12
