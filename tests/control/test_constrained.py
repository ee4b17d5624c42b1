"""Equality constraints on end points and line parameters, and the constrained differential-IK QP (§4.2.5)."""

from __future__ import annotations

import numpy as np
import pytest

import coop_ga as cg
from coop_ga.control.constrained import (
    LINE_PARAMETERS,
    ConstrainedReachOptions,
    EqualityConstraint,
    constrained_point_reach,
    constrained_velocity,
    end_point_jacobians,
    line_parameter_constraint,
    line_parameters,
    point_constraint,
    point_task,
    project_onto_constraints,
)
from coop_ga.errors import CoopGAError, DegeneratePrimitiveError, InfeasibleConstraintsError, InvalidInputError

OFFSET = np.array([0.06, -0.04, 0.10])  # the right-hand target of Figs. 14-15 [m]


@pytest.fixture(scope="module")
def g1():
    s = cg.systems.load("g1_arms")
    return s, cg.cooperative_task(s, "line")


@pytest.fixture(scope="module")
def configs(g1):
    """q0 and four seeded random configurations around it, inside the limits."""
    s, _ = g1
    rng = np.random.default_rng(7)
    qs = [s.q0.copy()]
    for _ in range(4):
        qs.append(np.clip(s.q0 + rng.uniform(-0.4, 0.4, s.nq), s.q_lower, s.q_upper))
    return qs


def _fd(fun, q, h=1e-6):
    return np.array([(fun(q + h * e) - fun(q - h * e)) / (2 * h) for e in np.eye(q.size)]).T


# ---------------------------------------------------------------------------- kinematics and read-outs
def test_end_point_jacobians_match_the_task_and_the_tree(g1, configs):
    _, t = g1
    for q in configs:
        P, J = end_point_jacobians(t, q)
        np.testing.assert_allclose(P, t.points(q), atol=1e-15)
        np.testing.assert_allclose(J, np.array(t.tree.euclidean_point_jacobians(q)), atol=1e-14)


def test_line_parameters_are_the_cga_line_and_the_similarity(g1, configs):
    """d and m are X_c = P1∧P2∧e∞ (Eq 14) / ℓ, d is V_Sc's rotation of +e2 (Eq 28), m = p × d for any p."""
    _, t = g1
    from coop_ga.algebra.basis import blade_index

    for q in configs:
        x, _ = line_parameters(t, q)
        d, m = x[:3], x[3:]
        P = t.points(q)
        X = t.primitive(q)
        ell = np.linalg.norm(P[1] - P[0])
        coeff = {n: float(X.get(blade_index(n)[0])) / ell for n in ("e01inf", "e02inf", "e03inf")}
        coeff |= {n: float(X.get(blade_index(n)[0])) / ell for n in ("e23inf", "e13inf", "e12inf")}
        np.testing.assert_allclose(d, [coeff["e01inf"], coeff["e02inf"], coeff["e03inf"]], atol=1e-12)
        np.testing.assert_allclose(m, [coeff["e23inf"], -coeff["e13inf"], coeff["e12inf"]], atol=1e-12)
        np.testing.assert_allclose(d, np.asarray(cg.direction(X), float), atol=1e-12)
        np.testing.assert_allclose(d, t.similarity(q).rotation_matrix @ [0.0, 1.0, 0.0], atol=1e-12)
        np.testing.assert_allclose(np.linalg.norm(d), 1.0, atol=1e-15)
        np.testing.assert_allclose(m, np.cross(P[1], d), atol=1e-12)  # the moment of either end point
        c = np.asarray(cg.closest_point_to_origin(X), float)
        np.testing.assert_allclose(m, np.cross(c, d), atol=1e-12)


def test_line_parameter_jacobian_matches_central_differences(g1, configs):
    _, t = g1
    for q in configs:
        _, J = line_parameters(t, q)
        J_fd = _fd(lambda x: line_parameters(t, x)[0], q)
        assert np.max(np.abs(J - J_fd)) < 1e-8, np.max(np.abs(J - J_fd))
        assert np.max(np.abs(J[2])) > 0.1  # d_z really depends on q (the check is not vacuous)


def test_point_constraint_jacobian_matches_central_differences(g1, configs):
    _, t = g1
    c = point_constraint(t, 1, [0.0, 0.0, 0.0])
    for q in configs[:2]:
        val, J = c.evaluate(q)
        np.testing.assert_allclose(val, t.points(q)[1], atol=1e-15)
        assert np.max(np.abs(J - _fd(lambda x: c.evaluate(x)[0], q))) < 1e-8


def test_point_pair_tasks_have_line_parameters_too(g1):
    s, t = g1
    pp = cg.cooperative_task(s, "point_pair")
    np.testing.assert_allclose(line_parameters(pp, s.q0)[0], line_parameters(t, s.q0)[0], atol=1e-15)


# ---------------------------------------------------------------------------- one step
def test_step_meets_the_linearised_constraint_exactly(g1, configs):
    _, t = g1
    q = configs[1]
    P = t.points(q)
    A, b, err = point_task(t, q, 0, P[0] + OFFSET, gain=5.0, max_speed=0.2)
    assert err == pytest.approx(np.linalg.norm(OFFSET))
    assert np.linalg.norm(b) == pytest.approx(0.2)  # capped at max_speed
    x0 = line_parameters(t, q)[0]
    con = line_parameter_constraint(t, "d_z", x0[2] + 0.01)  # a residual of −0.01 to remove
    sol, dropped = constrained_velocity(t, q, A, b, con, dt=0.01, constraint_gain=10.0)
    _, C = con.residual(q)
    assert not dropped
    np.testing.assert_allclose(C @ sol.x, 10.0 * 0.01, atol=1e-12)  # C q̇ = −k_c r
    # the point task is met too (17 joints: redundant), up to the damping
    np.testing.assert_allclose(A @ sol.x, b, atol=1e-5)


def test_step_inside_tight_velocity_limits_uses_the_qp(g1, configs):
    s, _ = g1
    slow = s.with_limits(velocity=0.05)
    t = cg.cooperative_task(slow, "line")
    q = configs[0]
    A, b, _ = point_task(t, q, 0, t.points(q)[0] + OFFSET)
    con = line_parameter_constraint(t, "d_z", line_parameters(t, q)[0][2])
    sol, dropped = constrained_velocity(t, q, A, b, con, dt=0.01)
    assert sol.used_qp and sol.n_active > 0 and not dropped
    assert np.max(np.abs(sol.x)) <= 0.05 + 1e-12
    np.testing.assert_allclose(con.residual(q)[1] @ sol.x, 0.0, atol=1e-9)
    # a residual that the box cannot remove in one step: the feedback is dropped, the constraint still holds
    far = line_parameter_constraint(t, "d_z", 0.5)
    sol, dropped = constrained_velocity(t, q, A, b, far, dt=0.01, constraint_gain=100.0)
    assert dropped
    np.testing.assert_allclose(far.residual(q)[1] @ sol.x, 0.0, atol=1e-9)


def test_dependent_rows_are_refused(g1):
    s, t = g1
    d0 = line_parameters(t, s.q0)[0][:3]
    unit = line_parameter_constraint(t, ("d_x", "d_y", "d_z"), d0)  # a unit vector has 2 free components
    A, b, _ = point_task(t, s.q0, 0, t.points(s.q0)[0] + OFFSET)
    with pytest.raises(InfeasibleConstraintsError, match="linearly dependent"):
        constrained_velocity(t, s.q0, A, b, unit)
    r = constrained_point_reach(t, s.q0, 0, t.points(s.q0)[0] + OFFSET, constraints=unit, steps=5)
    assert r.infeasible and not r.converged and "linearly dependent" in r.message and r.iterations == 0


def test_projection_reaches_round_off_inside_the_limits(g1, configs):
    s, t = g1
    q = configs[2]
    con = [
        line_parameter_constraint(t, "d_z", 0.0),
        point_constraint(t, 1, t.points(q)[1] + [0.0, 0.0, 0.01]),
    ]
    r0 = max(np.max(np.abs(c.residual(q)[0])) for c in con)
    assert r0 > 1e-3
    qp, its, res = project_onto_constraints(t, q, con, lower=s.q_lower, upper=s.q_upper)
    assert res <= 1e-12 and 1 <= its <= 5
    assert max(np.max(np.abs(c.residual(qp)[0])) for c in con) <= 1e-12
    assert s.limits.position_violation(qp) == 0.0
    # a minimum-norm correction: close to the first Gauss-Newton step ‖C⁺ r‖ (the constraints are smooth)
    r, C = np.concatenate([c.residual(q)[0] for c in con]), np.vstack([c.residual(q)[1] for c in con])
    step = np.linalg.norm(np.linalg.pinv(C) @ r)
    print("projection:", its, "iterations, |dq| =", np.linalg.norm(qp - q), "first GN step", step)
    assert np.linalg.norm(qp - q) < 1.2 * step


# ---------------------------------------------------------------------------- the reaching loop
@pytest.fixture(scope="module")
def reaches(g1):
    s, t = g1
    q0 = s.q0
    P0 = t.points(q0)
    target = P0[0] + OFFSET
    horiz = line_parameter_constraint(t, "d_z", line_parameters(t, q0)[0][2])
    return {
        "hold": constrained_point_reach(t, q0, 0, target, constraints=point_constraint(t, 1, P0[1])),
        "horizontal": constrained_point_reach(t, q0, 0, target, constraints=horiz),
        "linearised": constrained_point_reach(t, q0, 0, target, constraints=horiz, project=False),
        "free": constrained_point_reach(t, q0, 0, target),
    }


def test_reach_with_the_left_hand_held(g1, reaches):
    s, t = g1
    r = reaches["hold"]
    assert r.converged and r.error < 1e-4 and r.iterations < 400
    assert r.constraint_deviation.max() < 1e-12  # left hand held to round-off [m]
    assert np.abs(r.points[:, 1] - t.points(s.q0)[1]).max() < 1e-12
    assert r.limit_violation == 0.0 and r.velocity_violation == 0.0
    dz = np.array([line_parameters(t, q)[0][2] for q in r.trajectory])
    assert np.ptp(dz) > 0.1  # the line is free: it tilts


def test_reach_with_a_horizontal_line(g1, reaches):
    s, t = g1
    r = reaches["horizontal"]
    assert r.converged and r.error < 1e-4
    assert r.constraint_deviation.max() < 1e-12
    assert r.projection_failures == 0 and r.projection_iterations.max() <= 2 and r.feedback_dropped == 0
    left = np.linalg.norm(r.points[-1, 1] - t.points(s.q0)[1])
    assert left > 0.09  # the left hand follows the 0.10 m rise of the right hand
    np.testing.assert_allclose(r.points[-1, 1, 2] - r.points[0, 1, 2], OFFSET[2], atol=1e-3)
    assert r.limit_violation == 0.0


def test_projection_is_what_keeps_the_constraint_to_round_off(reaches):
    lin, proj = reaches["linearised"], reaches["horizontal"]
    assert lin.error < 1e-4  # the linearised QP reaches too …
    assert 1e-7 < lin.constraint_deviation.max() < 1e-3  # … but its constraint drifts by O(|Δq|²)
    assert lin.constraint_deviation.max() > 1e6 * proj.constraint_deviation.max()
    assert not lin.converged  # final deviation above constraint_tol = 1e-9


def test_unconstrained_reach_moves_only_the_right_chain_min_norm(g1, reaches):
    s, _ = g1
    r = reaches["free"]
    assert r.converged and r.constraint_values.shape == (len(r.trajectory), 0)
    left = [i for i, n in enumerate(s.joint_names) if n.startswith("left")]
    assert np.abs(r.trajectory[:, left] - r.trajectory[0, left]).max() == 0.0  # their columns of J_p,0 are 0


def test_reach_result_shapes(reaches):
    r = reaches["horizontal"]
    T = r.iterations + 1
    assert r.trajectory.shape == (T, 17) and r.points.shape == (T, 2, 3) and r.t.shape == (T,)
    assert r.constraint_values.shape == (T, 1) and r.constraint_labels == ("d_z",)
    assert r.projection_iterations.shape == (T - 1,)
    assert r.t[1] == pytest.approx(0.01)


# ---------------------------------------------------------------------------- bad input
def test_bad_input_raises_coop_ga_errors(g1):
    s, t = g1
    q0 = s.q0
    point_task_ = cg.cooperative_task(s, "point")
    with pytest.raises(InvalidInputError, match="'line' or 'point_pair'"):
        line_parameters(point_task_, q0)
    with pytest.raises(InvalidInputError, match="unknown line parameter"):
        line_parameter_constraint(t, "d_w", 0.0)
    with pytest.raises(InvalidInputError, match="one entry per component"):
        line_parameter_constraint(t, ("d_z", "m_x"), 0.0)
    with pytest.raises(InvalidInputError, match="distinct"):
        line_parameter_constraint(t, ("d_z", 2), (0.0, 0.0))
    with pytest.raises(InvalidInputError, match="index"):
        point_constraint(t, 2, [0, 0, 0])
    with pytest.raises(InvalidInputError):
        point_constraint(t, 1, [0, 0])
    with pytest.raises(InvalidInputError, match="unknown option"):
        constrained_point_reach(t, q0, 0, [0.3, 0, 0.2], horizon=3)
    with pytest.raises(InvalidInputError):
        ConstrainedReachOptions(dt=-1.0)
    with pytest.raises(InvalidInputError, match="EqualityConstraint"):
        constrained_point_reach(t, q0, 0, [0.3, 0, 0.2], constraints=[(np.zeros((1, 17)), np.zeros(1))])
    bad = EqualityConstraint(lambda q: (np.zeros(2), np.zeros((2, 17))), np.zeros(1), "bad")
    with pytest.raises(InvalidInputError, match="returned c of shape"):
        bad.evaluate(q0)
    with pytest.raises(InvalidInputError):
        EqualityConstraint(lambda q: (q, q), np.zeros(2), "two", labels=("a",))
    with pytest.raises(CoopGAError):
        constrained_velocity(t, q0, np.zeros((3, 16)), np.zeros(3))
    with pytest.raises(CoopGAError):
        constrained_point_reach(t, np.full(17, np.nan), 0, [0.3, 0, 0.2])
    assert LINE_PARAMETERS[2] == "d_z"


def test_coincident_end_points_are_degenerate(g1, monkeypatch):
    s, t = g1
    import coop_ga.control.constrained as mod

    P, J = end_point_jacobians(t, s.q0)
    # both end points at the right hand (no configuration of the G1 brings the hands together)
    monkeypatch.setattr(mod, "end_point_jacobians", lambda task, q: (np.array([P[0], P[0]]), np.array([J[0], J[0]])))
    with pytest.raises(DegeneratePrimitiveError, match="coincide"):
        mod.line_parameters(t, s.q0)
