"""Reference solvers of the constrained reaching OCP (coop_ga.control.reference_ocp): IPOPT and FATROP agree,
the bounds hold, and without active bounds they find iLQR's optimum.

Small problems (three_franka circle, the flagship target, 20 knots × 0.05 s) so that every solve takes
about a second.
"""

from __future__ import annotations

import dataclasses

import casadi as ca
import numpy as np
import pytest

import coop_ga as cg
from coop_ga.control.ilqr import ILQROptions, ReachingOCP, displaced_target, ilqr_reach
from coop_ga.control.reference_ocp import ReferenceProblem, solve_reference

pytestmark = pytest.mark.skipif(
    not (ca.has_nlpsol("ipopt") and ca.has_nlpsol("fatrop")), reason="this CasADi lacks IPOPT or FATROP"
)

TARGET = {"translation": (0.10, -0.05, 0.10), "axis": (1.0, 0.0, 0.0), "angle": np.deg2rad(25.0), "scale": 1.25}
HORIZON, DT = 20, 0.05
BOUND_TOL = 1e-6


def _problem(system):
    task = cg.cooperative_task(system, "circle")
    q0 = np.array(system.q0)
    return task, q0, ReachingOCP(task, q0, displaced_target(task, q0, **TARGET), horizon=HORIZON, dt=DT)


@pytest.fixture(scope="module")
def franka():
    return cg.systems.load("three_franka")


def _check_solution(r, ocp, lim):
    """Success, dynamics, the terminal error and the bounds, recomputed from the returned arrays."""
    assert r.success, (r.solver, r.status)
    assert r.u.shape == (HORIZON, ocp.nq) and r.q.shape == r.qd.shape == (HORIZON + 1, ocp.nq)
    np.testing.assert_allclose(r.q[0], ocp.q_init, atol=1e-12)
    q, qd = ocp.rollout(r.u)
    np.testing.assert_allclose(r.q, q, atol=1e-9)
    np.testing.assert_allclose(r.qd, qd, atol=1e-9)
    assert r.defect < 1e-9
    e = ocp.task.error(r.q[-1], ocp.target)
    np.testing.assert_allclose(r.error_vector, e, atol=1e-10)
    assert r.cost_rollout == pytest.approx(r.cost, rel=1e-9)
    assert np.all(r.q[1:] >= lim.lower - BOUND_TOL) and np.all(r.q[1:] <= lim.upper + BOUND_TOL)
    assert np.all(np.abs(r.qd[1:]) <= lim.velocity + BOUND_TOL)
    assert np.all(np.abs(r.u) <= lim.acceleration + BOUND_TOL)
    assert r.max_violation <= BOUND_TOL
    assert r.solve_time_s > 0 and r.iterations > 0


def _ilqr_soft(task, q0, target):
    """``ilqr_reach`` on the same (soft-terminal) problem, run to stationarity (tol = 0)."""
    names = {f.name for f in dataclasses.fields(ILQROptions)}
    kw = {"terminal": "soft"} if "terminal" in names else {}
    return ilqr_reach(task, q0, target, horizon=HORIZON, dt=DT, tol=0.0, **kw)


def test_ipopt_and_fatrop_agree_with_an_active_velocity_bound(franka):
    """|q̇| ≤ 0.3 rad/s on every joint (the unconstrained optimum reaches 0.59 rad/s): the bound binds."""
    s = franka.with_limits(velocity=0.3)
    _, _, ocp = _problem(s)
    P = ReferenceProblem(ocp)
    ri, rf = P.solve("ipopt"), P.solve("fatrop")
    print(
        f"|q̇| ≤ 0.3: IPOPT {ri.iterations} it, J = {ri.cost:.12g}, {ri.solve_time_s:.2f} s; "
        f"FATROP {rf.iterations} it, J = {rf.cost:.12g}, {rf.solve_time_s:.2f} s; active {ri.active} {rf.active}"
    )
    for r in (ri, rf):
        _check_solution(r, ocp, s.limits)
        assert r.active["velocity"] > 50 and r.active["position"] == 0  # measured 120 (knot, joint) entries
    assert rf.cost == pytest.approx(ri.cost, rel=1e-6)  # measured 1.5e-8
    np.testing.assert_allclose(rf.u, ri.u, atol=1e-3 * np.abs(ri.u).max())
    assert ri.cost > 0.3  # measured 0.4358; the unconstrained optimum is 0.1435


def test_ipopt_and_fatrop_agree_with_an_active_one_sided_position_bound(franka):
    """arm1 joint 4 may not exceed q0 + 0.3 rad (lower bound removed: a one-sided bound); the unconstrained
    optimum moves it by +0.38 rad."""
    q0 = np.array(franka.q0)
    j = 10
    s = franka.with_limits(position={franka.limits.joint_names[j]: (-np.inf, q0[j] + 0.3)})
    _, _, ocp = _problem(s)
    ri = solve_reference(ocp, solver="ipopt")
    rf = solve_reference(ocp, solver="fatrop")
    print(
        f"q_10 ≤ q0_10 + 0.3: IPOPT {ri.iterations} it, J = {ri.cost:.12g}; FATROP {rf.iterations} it, "
        f"J = {rf.cost:.12g}; active {ri.active} {rf.active}"
    )
    for r in (ri, rf):
        _check_solution(r, ocp, s.limits)
        assert r.active["position"] >= 1
        assert r.q[1:, j].max() == pytest.approx(q0[j] + 0.3, abs=BOUND_TOL)
    assert rf.cost == pytest.approx(ri.cost, rel=1e-6)  # measured 1e-9


def test_a_tight_joint_range_has_several_local_optima(franka):
    """arm0 joint 4 ≥ q0 − 0.1 rad (the unconstrained optimum moves it by −0.32 rad): from u = 0 IPOPT
    stops in a worse local optimum than FATROP (J = 0.2092 vs 0.1674, both converged) — the problem is
    not convex.  Started from FATROP's solution IPOPT stays there: the same problem, another basin."""
    q0 = np.array(franka.q0)
    s = franka.with_limits(position={franka.limits.joint_names[3]: (q0[3] - 0.1, np.inf)})
    _, _, ocp = _problem(s)
    P = ReferenceProblem(ocp)
    ri, rf = P.solve("ipopt"), P.solve("fatrop")
    warm = P.solve("ipopt", u_init=rf.u)
    print(
        f"q_4 ≥ q0_4 − 0.1: IPOPT J = {ri.cost:.10g} ({ri.iterations} it), FATROP J = {rf.cost:.10g} "
        f"({rf.iterations} it), IPOPT from FATROP's solution J = {warm.cost:.10g} ({warm.iterations} it)"
    )
    for r in (ri, rf, warm):
        _check_solution(r, ocp, s.limits)
    assert warm.cost == pytest.approx(rf.cost, rel=1e-6)
    assert ri.cost >= rf.cost * (1 - 1e-6)  # FATROP's is the better of the two optima here


def test_without_active_bounds_the_references_match_ilqr(franka):
    """The system's own limits do not bind on this target: IPOPT, FATROP and iLQR find the same optimum."""
    task, q0, ocp = _problem(franka)
    P = ReferenceProblem(ocp)
    ri, rf = P.solve("ipopt"), P.solve("fatrop")
    il = _ilqr_soft(task, q0, ocp.target)
    print(
        f"no active bound: IPOPT {ri.iterations} it J = {ri.cost:.12g}; FATROP {rf.iterations} it "
        f"J = {rf.cost:.12g}; iLQR {il.iterations} it J = {ocp.cost(il.u):.12g}"
    )
    for r in (ri, rf):
        _check_solution(r, ocp, franka.limits)
        assert sum(r.active.values()) == 0
    assert rf.cost == pytest.approx(ri.cost, rel=1e-8)
    assert ocp.cost(il.u) == pytest.approx(ri.cost, rel=1e-6)  # measured 1e-13
    assert rf.terminal_error == pytest.approx(np.linalg.norm(task.error(il.q, ocp.target)), rel=1e-3)


def test_terminal_constraint_variant(franka):
    """``terminal="constraint"``: e(q_n) = 0 exactly, both solvers agree, and the cost is at least the soft optimum's
    running part."""
    _, _, ocp = _problem(franka)
    P = ReferenceProblem(ocp, terminal="constraint")
    ri, rf = P.solve("ipopt"), P.solve("fatrop")
    for r in (ri, rf):
        _check_solution(r, ocp, franka.limits)
        assert r.terminal == "constraint" and r.terminal_error < 1e-8
    assert rf.cost == pytest.approx(ri.cost, rel=1e-6)


def test_bounds_none_and_bad_input(franka):
    _, _, ocp = _problem(franka)
    assert ReferenceProblem(ocp, limit_mode="none").limits is None
    assert ReferenceProblem(ocp).limits is franka.limits
    with pytest.raises(cg.InvalidInputError):
        ReferenceProblem(ocp, limit_mode="all")
    with pytest.raises(cg.InvalidInputError, match="joints"):
        ReferenceProblem(ocp, cg.systems.load("three_iiwa14").limits)  # 21 joints too, other names
    with pytest.raises(cg.InvalidInputError):
        ReferenceProblem(ocp, terminal="hard")
    P = ReferenceProblem(ocp, limit_mode="none")
    with pytest.raises(cg.InvalidInputError):
        P.solve("snopt")
    with pytest.raises(cg.InvalidInputError, match="could not be started"):
        P.solve("fatrop", solver_options={"no_such_option": 1.0})
