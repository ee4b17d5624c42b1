"""Limit-aware IK (paper Eq 53).

Differential IK as a QP (Eq 48, 61 with position and velocity limits and user rows G q̇ ≤ h),
Gauss–Newton with bounded steps (Eq 43–47), nullspace secondary tasks that stop at a bound
(Eq 58, 60), the QP layer itself, and a small success-rate check.  Fixed integer seeds; the
numbers quoted in the asserts were measured on this code.
"""

from __future__ import annotations

import time
import warnings

import numpy as np
import pytest

import coop_ga as cg
from coop_ga.control import diff_ik_reach, diff_ik_step, displaced_target, gauss_newton_ik
from coop_ga.control.diffik import DiffIKOptions, diff_ik_velocity
from coop_ga.control.nullspace import nullspace_point_reach, point_on_circle
from coop_ga.control.qp import (
    InfeasibleConstraintsError,
    LinearConstraint,
    _conic,
    solve_qp,
    stack_constraints,
    velocity_bounds,
)

BOUND_CASES = [
    ("three_franka", "circle"),
    ("allegro", "sphere"),
    ("g1_arms", "line"),
    ("hexapod", "point_pair"),
    ("hexapod", "circle"),
]


def _unit(rng: np.random.Generator) -> np.ndarray:
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def _targets(task, q0, rng, n, translation, angle_deg, scale):
    """``n`` realisable targets: the primitive at q0 moved by a random similarity of the given size."""
    out = []
    while len(out) < n:
        s = (1 + scale) if rng.random() < 0.5 else 1 / (1 + scale)
        try:
            out.append(
                displaced_target(
                    task,
                    q0,
                    translation=translation * _unit(rng),
                    axis=_unit(rng),
                    angle=np.deg2rad(angle_deg),
                    scale=s,
                )
            )
        except cg.CoopGAError:
            continue
    return out


def _inside(limits, Q, tol=0.0):
    Q = np.atleast_2d(Q)
    return bool(np.all(Q >= limits.lower - tol) and np.all(Q <= limits.upper + tol))


#: the tests of position/velocity limits and user rows below hold with the acceleration limits off: a step from
#: rest under the Franka's acceleration limits moves at most a·Δt (tests/control/test_acceleration_limits.py)
NO_ACC = dict(acceleration_limit=False)


# ----------------------------------------------------------------------------- bounds on random targets
@pytest.mark.parametrize("name,kind", BOUND_CASES)
def test_positions_and_velocities_stay_within_limits(load_system, name, kind):
    """Large random displacements (15 cm, 35°, ±30 %): every configuration of every diff-IK trajectory
    and every Gauss–Newton result lies within the position limits, every diff-IK velocity within
    the velocity limits — whether or not the target is reached."""
    s = load_system(name)
    task = cg.cooperative_task(s, kind)
    lim = s.limits
    q0 = np.array(s.q0)
    rng = np.random.default_rng(2024)
    active = conv = 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cg.DegeneracyWarning)
        for V in _targets(task, q0, rng, 3, 0.15, 35.0, 0.30):
            r = diff_ik_reach(task, q0, V, steps=120)
            assert _inside(lim, r.trajectory), lim.describe(
                r.trajectory[np.argmax(lim.position_violation(r.trajectory))]
            )
            assert r.limit_violation == 0.0
            qd = np.diff(r.trajectory, axis=0) / DiffIKOptions().dt
            assert np.all(np.abs(qd) <= lim.velocity * (1 + 1e-9)), np.max(np.abs(qd) / lim.velocity)
            assert r.velocity_violation <= 1e-9
            assert r.converged == (r.error < DiffIKOptions().tol)
            active += r.active_steps
            g = gauss_newton_ik(task, q0, V)
            assert _inside(lim, g.q) and g.limit_violation == 0.0
            assert not g.converged or g.error < 1e-10
            conv += g.converged
    print(f"{name}/{kind}: diff-IK steps with an active bound {active}, GN converged {conv}/3")


def test_velocity_limit_is_respected_by_a_single_step(load_system):
    """A huge command (β = 50 /s) saturates the velocity limits; the step stays inside them and the
    position limits, and the same step without limits exceeds both."""
    s = load_system("three_franka")
    task = cg.cooperative_task(s, "circle")
    lim = s.limits
    q = np.array(s.q0)
    b = np.array([0, 0, 0, 50.0, 0, 0, 0])
    sol = diff_ik_velocity(task, q, b, dt=0.01, **NO_ACC)
    assert sol.used_qp and sol.n_active >= 6
    assert np.all(np.abs(sol.x) <= lim.velocity + 1e-12)
    free = diff_ik_velocity(task, q, b, dt=0.01, limit_mode="none", **NO_ACC)
    assert not free.used_qp and np.max(np.abs(free.x) / lim.velocity) > 5.0
    q1 = diff_ik_step(task, q, b, dt=0.01, **NO_ACC)
    np.testing.assert_allclose(q1, q + 0.01 * sol.x, atol=1e-15)
    # the QP realises the command better than the Eq 48 velocity scaled down uniformly into the limits
    J = task.jacobian(q)
    scaled = free.x * np.min(lim.velocity / np.abs(free.x))
    assert _inside(lim, q + 0.01 * scaled)
    assert np.linalg.norm(J @ sol.x - b) < np.linalg.norm(J @ scaled - b)  # 47.66 vs 48.05
    assert (J @ sol.x)[3] > 2.2 > (J @ scaled)[3]  # realised dilation rate 2.36 /s vs 1.95 /s


# ----------------------------------------------------------------------------- QP vs clamping
def test_qp_redistributes_motion_where_clamping_fails(load_system):
    """arm0's elbow (panda_joint4) starts on its lower limit; the target is the circle of that
    configuration with the elbow 0.3 rad further out — realisable inside the limits by the other
    joints.  Clamping loses the elbow's share of every step and stalls at ‖e‖ = 7.8e-3 after
    2.5 s; the QP gives it to the nullspace and converges in 80 steps (0.8 s)."""
    s = load_system("three_franka")
    task = cg.cooperative_task(s, "circle")
    lim = s.limits
    j = lim.joint_names.index("arm0_panda_joint4")
    q = np.array(s.q0)
    q[j] = lim.lower[j]
    q_out = q.copy()
    q_out[j] -= 0.3
    V = task.similarity(q_out)
    clamp = diff_ik_reach(task, q, V, limit_mode="clamp", **NO_ACC)
    qp = diff_ik_reach(task, q, V, **NO_ACC)
    print(
        f"clamp: ‖e‖ = {clamp.error:.3g} after {clamp.iterations} steps; QP: ‖e‖ = {qp.error:.3g} after "
        f"{qp.iterations} steps, {qp.active_steps} with an active bound"
    )
    assert not clamp.converged and clamp.error > 5e-3 and clamp.iterations == 250
    assert qp.converged and qp.error < 1e-4 and qp.iterations <= 90
    assert qp.active_steps >= 70 and qp.limit_violation == 0.0
    assert np.all(qp.trajectory[:, j] >= lim.lower[j])
    assert abs(qp.q[j] - lim.lower[j]) < 1e-9  # the elbow stays on its limit throughout
    # the QP does the work, not the final rounding clip: every unclipped step already lies inside
    for qt in qp.trajectory[:-1]:
        nxt = qt + 0.01 * diff_ik_velocity(task, qt, 10.0 * task.error(qt, V), **NO_ACC).x
        assert _inside(lim, nxt, tol=1e-12)
    g = gauss_newton_ik(task, q, V)
    assert g.converged and _inside(lim, g.q)


# ----------------------------------------------------------------------------- user constraints
@pytest.fixture(scope="module")
def franka(load_system):
    s = load_system("three_franka")
    task = cg.cooperative_task(s, "circle")
    q0 = np.array(s.q0)
    V = displaced_target(task, q0, translation=(0.05, -0.03, 0.04), axis=(1, 0, 0), angle=0.2, scale=1.1)
    return s, task, q0, V


def test_joint_velocity_constraint_is_respected(franka):
    s, task, q0, V = franka
    b = 2.0 * task.error(q0, V)  # slow enough for no limit to be active
    free = diff_ik_velocity(task, q0, b, **NO_ACC)
    assert not free.used_qp
    j = int(np.argmax(np.abs(free.x)))
    sign = np.sign(free.x[j])
    cap = 0.1 * abs(free.x[j])
    row = LinearConstraint(sign * np.eye(s.nq)[j], [cap], name="joint cap")
    sol = diff_ik_velocity(task, q0, b, constraints=[row], **NO_ACC)
    assert sign * sol.x[j] <= cap + 1e-9 and sol.active_rows.tolist() == [True]
    J = task.jacobian(q0)
    # the other 20 joints make up for it: the task velocity is still realised (9.4e-6 relative, 4.2e-6 without the cap)
    assert np.linalg.norm(J @ sol.x - b) < 2e-5 * np.linalg.norm(b)
    # over a whole run the joint never moves faster than the cap in that direction, the target is reached
    r = diff_ik_reach(task, q0, V, constraints=row, **NO_ACC)
    assert r.converged and r.active_steps > 0
    assert np.all(sign * np.diff(r.trajectory[:, j]) / 0.01 <= cap + 1e-9)


def test_end_point_half_space_constraint(franka):
    """``nᵀ ṗ_0 ≤ 0``: end point 0 may not move along n (G = nᵀ J_p, world frame, h in m/s)."""
    _, task, q0, V = franka
    b = 10.0 * task.error(q0, V)
    Jp = task.tree.euclidean_point_jacobians(q0)[0]
    free = diff_ik_velocity(task, q0, b, **NO_ACC)
    n = Jp @ free.x
    n /= np.linalg.norm(n)  # the direction end point 0 would move in
    sol = diff_ik_velocity(task, q0, b, constraints=(n @ Jp, [0.0]), **NO_ACC)
    assert n @ (Jp @ free.x) > 0.01
    assert n @ (Jp @ sol.x) <= 1e-9

    def no_descent(q):  # a configuration-dependent constraint: end point 0 may not move down (−ż ≤ 0)
        return [
            LinearConstraint(
                np.array([0.0, 0.0, -1.0]) @ task.tree.euclidean_point_jacobians(q)[0], [0.0], "no descent"
            )
        ]

    r = diff_ik_reach(task, q0, V, constraints=no_descent, steps=60, **NO_ACC)
    z = np.array([task.points(q)[0][2] for q in r.trajectory])
    free_run = diff_ik_reach(task, q0, V, steps=60, **NO_ACC)
    z_free = np.array([task.points(q)[0][2] for q in free_run.trajectory])
    print(
        f"end point 0 descends by {z[0] - z.min():.2e} m with the constraint, {z_free[0] - z_free.min():.2e} m without"
    )
    assert z_free[0] - z_free.min() > 0.05  # 6.7e-2 m
    # the constraint holds exactly on every commanded velocity (first order) …
    for qa, qb in zip(r.trajectory[:-1], r.trajectory[1:]):
        assert -(task.tree.euclidean_point_jacobians(qa)[0] @ ((qb - qa) / 0.01))[2] <= 1e-9
    assert z[0] - z.min() < 1e-3  # … so only the discretisation drift remains (8.2e-4 m over 60 steps)
    assert r.active_steps > 0 and "no descent[0]" in r.active_limits


def test_infeasible_constraints_are_reported(franka):
    s, task, q0, V = franka
    e3 = np.eye(s.nq)[3]
    contradictory = [LinearConstraint(e3, [-0.1], "q̇3 ≤ −0.1"), LinearConstraint(-e3, [-0.1], "q̇3 ≥ 0.1")]
    with pytest.raises(InfeasibleConstraintsError, match="no common point"):
        diff_ik_step(task, q0, np.zeros(7), constraints=contradictory)
    assert issubclass(InfeasibleConstraintsError, cg.CoopGAError)
    beyond = LinearConstraint(-e3, [-2.0 * s.limits.velocity[3]], "q̇3 ≥ 2 v")  # beyond the velocity limit
    with pytest.raises(InfeasibleConstraintsError, match="no common point"):
        diff_ik_step(task, q0, np.zeros(7), constraints=beyond)
    diff_ik_step(task, q0, np.zeros(7), constraints=beyond, limit_mode="none")  # fine without the limits
    r = diff_ik_reach(task, q0, V, constraints=contradictory)
    assert r.infeasible and not r.converged and r.iterations == 0
    assert "stopped at step 0" in r.message and "no common point" in r.message
    np.testing.assert_array_equal(r.q, q0)  # the last feasible configuration, never garbage


def test_constraint_input_is_checked(franka):
    s, task, q0, _ = franka
    with pytest.raises(cg.InvalidInputError, match="columns"):
        diff_ik_step(task, q0, np.zeros(7), constraints=(np.ones((1, 5)), [0.0]))
    with pytest.raises(cg.InvalidInputError, match="one per row"):
        LinearConstraint(np.ones((2, s.nq)), [0.0])
    with pytest.raises(cg.NonFiniteError):
        LinearConstraint(np.ones(s.nq), [np.nan])
    with pytest.raises(cg.InvalidInputError):
        diff_ik_step(task, q0, np.zeros(7), constraints="G <= h")
    G, h, labels = stack_constraints([LinearConstraint(np.ones(s.nq), 1.0, "a"), (np.eye(s.nq)[:2], [1.0, 2.0])], s.nq)
    assert (
        G.shape == (3, s.nq)
        and h.tolist() == [1.0, 1.0, 2.0]
        and labels == ("a[0]", "constraint 1[0]", "constraint 1[1]")
    )
    with pytest.raises(cg.InvalidInputError):
        diff_ik_step(task, q0, np.zeros(7), limit_gain=1.5)


# ----------------------------------------------------------------------------- Gauss–Newton
def test_gauss_newton_reports_a_target_reachable_only_outside_the_limits(load_system):
    """arm0's joints limited to q0 ± 0.05 rad: a point 10 cm away is reachable only outside them.
    Unconstrained GN 'converges' 0.082 rad outside the limits (and now warns); the bounded GN stays
    inside, reports converged=False and names the joint limits it is pressed against."""
    s0 = load_system("three_franka")
    q0 = np.array(s0.q0)
    names = s0.limits.joint_names
    s = s0.with_limits(position={n: (q0[i] - 0.05, q0[i] + 0.05) for i, n in enumerate(names) if n.startswith("arm0")})
    task = cg.cooperative_task(s, "point")
    V = displaced_target(task, q0, translation=(0.1, 0.0, 0.0))
    with pytest.warns(cg.JointLimitWarning, match="outside the joint limits"):
        free = gauss_newton_ik(task, q0, V, limit_mode="none")
    assert free.converged and free.limit_violation > 0.05
    r = gauss_newton_ik(task, q0, V)
    print(r.message)
    assert not r.converged and r.error > 0.05 and r.limit_violation == 0.0 and _inside(s.limits, r.q)
    assert "joint limits active at the final configuration" in r.message
    assert r.active_limits and all(a.startswith("arm0_panda_joint") and "position limit" in a for a in r.active_limits)
    for a in r.active_limits:
        assert a.split(" ")[0] in r.message
    assert r.active_iterations >= 1


def test_gauss_newton_is_unchanged_when_no_limit_is_touched(franka):
    _, task, q0, V = franka
    a = gauss_newton_ik(task, q0, V)
    b = gauss_newton_ik(task, q0, V, limit_mode="none")
    assert a.active_iterations == 0 and a.converged
    np.testing.assert_array_equal(a.history, b.history)
    np.testing.assert_array_equal(a.q, b.q)


def test_start_outside_the_limits_is_projected_and_reported(franka):
    s, task, q0, V = franka
    q = q0.copy()
    q[3] = s.limits.upper[3] + 0.2
    with pytest.warns(cg.JointLimitWarning, match="projected onto the limits"):
        r = gauss_newton_ik(task, q, V)
    assert r.warnings.get("JointLimitWarning:three_franka") == 1
    assert r.converged and _inside(s.limits, r.q)
    with pytest.warns(cg.JointLimitWarning):
        d = diff_ik_reach(task, q, V, steps=5)
    assert d.trajectory[0][3] == s.limits.upper[3] and d.limit_violation == 0.0


# ----------------------------------------------------------------------------- nullspace
def test_nullspace_secondary_task_stops_at_a_bound_and_keeps_the_primary(load_system):
    """§4.3 with arm0's panda_joint6 limited to 30 % of the motion the reach needs (q0 + 0.092 rad):
    with the two-level QP the joint stops on that limit, the other joints take over what they can
    (point error 7.6 mm after 3 s; 0.13 mm after 4 s without the limit) and the circle is held as
    without limits (max drift 1.7e-4); clamping instead breaks the circle (drift 1.0e-2)."""
    s0 = load_system("three_franka")
    q0 = np.array(s0.q0)
    t0 = cg.cooperative_task(s0, "circle")
    target = point_on_circle(t0, q0, 0, np.deg2rad(30.0))
    names = s0.limits.joint_names
    j = names.index("arm0_panda_joint6")
    hi = q0[j] + 0.3 * 0.3056
    s = s0.with_limits(position={names[j]: (s0.limits.lower[j], hi)})
    task = cg.cooperative_task(s, "circle")
    r = nullspace_point_reach(task, q0, 0, target, duration=3.0)
    c = nullspace_point_reach(task, q0, 0, target, duration=3.0, limit_mode="clamp")
    print(
        f"QP: drift {r.similarity_distance.max():.3g}, point error {r.point_error[-1]:.3g} m, active steps "
        f"{r.active_steps}; clamp: drift {c.similarity_distance.max():.3g}"
    )
    assert _inside(s.limits, r.trajectory) and r.limit_violation == 0.0 and r.velocity_violation <= 1e-9
    assert abs(r.q[j] - hi) < 1e-9  # stopped on the bound …
    assert r.similarity_distance.max() < 3e-4  # … while V_Sc is held (1.7e-4, as without limits)
    assert r.point_error[-1] < 0.01 and r.point_error[-1] > 1e-3
    assert r.active_steps > 100 and any("arm0_panda_joint6 (upper position limit" in a for a in r.active_limits)
    assert c.similarity_distance.max() > 10 * r.similarity_distance.max()


# ----------------------------------------------------------------------------- the QP layer
def test_qp_matches_bounded_least_squares_reference():
    """DAQP (with its verification and BVLS fallback) against scipy's BVLS on random damped,
    rank-deficient box problems, including λ = 3e-5 (Gauss–Newton's) and zero columns."""
    from scipy.optimize import lsq_linear

    rng = np.random.default_rng(7)
    used = 0
    for k in range(60):
        n, r = int(rng.integers(8, 25)), int(rng.integers(2, 8))
        A = rng.normal(size=(7, r)) @ rng.normal(size=(r, n)) * 10.0 ** rng.uniform(-1, 1)
        A[:, rng.random(n) < 0.2] = 0.0
        b = rng.normal(size=7)
        lam = [3e-5, 1e-3, 0.1][k % 3]
        lb, ub = -rng.uniform(0, 0.5, n), rng.uniform(0, 0.5, n)
        sol = solve_qp(A, b, lam, lb, ub)
        ref = lsq_linear(
            np.vstack([A, lam * np.eye(n)]), np.r_[b, np.zeros(n)], bounds=(lb, ub), method="bvls", tol=1e-14
        ).x

        def f(x, A=A, b=b, lam=lam):
            return 0.5 * np.sum((A @ x - b) ** 2) + 0.5 * lam**2 * x @ x

        assert np.all(sol.x >= lb) and np.all(sol.x <= ub)
        assert f(sol.x) <= f(ref) * (1 + 1e-6) + 1e-14, (k, f(sol.x), f(ref))
        used += sol.used_qp
    assert used > 40


def test_qp_equality_rows_and_solver_reuse():
    rng = np.random.default_rng(3)
    n = 12
    E = np.linalg.qr(rng.normal(size=(n, 4)))[0].T  # 4 orthonormal rows
    x1 = rng.uniform(-0.1, 0.1, n)
    x2 = rng.normal(size=n)
    lb, ub = np.full(n, -0.3), np.full(n, 0.3)
    sol = solve_qp(np.eye(n), x2, 0.0, lb, ub, E=E, f=E @ x1)
    np.testing.assert_allclose(E @ sol.x, E @ x1, atol=1e-9)
    assert np.all(sol.x >= lb) and np.all(sol.x <= ub) and sol.used_qp
    # without the box it is the projection x1 + N (x2 − x1)
    free = solve_qp(np.eye(n), x2, 0.0, None, None, E=E, f=E @ x1)
    np.testing.assert_allclose(free.x, E.T @ (E @ x1) + (np.eye(n) - E.T @ E) @ x2, atol=1e-9)
    assert _conic(n, 4) is _conic(n, 4)  # built once per (thread, n, rows)


def test_velocity_bounds_combine_position_and_velocity_limits():
    q = np.array([0.0, 0.95, -0.999])
    lo, hi, v = np.full(3, -1.0), np.full(3, 1.0), np.array([2.0, 2.0, 2.0])
    lb, ub = velocity_bounds(q, lo, hi, v, 0.1, gain=0.5)
    np.testing.assert_allclose(lb, [-2.0, -2.0, -0.005])
    np.testing.assert_allclose(ub, [2.0, 0.25, 2.0])


def test_qp_step_cost(load_system):
    """Per-step cost of the QP step against the damped pseudo-inverse step (printed; loose bound)."""
    s = load_system("three_franka")
    task = cg.cooperative_task(s, "circle")
    q = np.array(s.q0)
    free_b, sat_b = 0.01 * np.linalg.svd(task.jacobian(q))[0][:, 0], np.array([0, 0, 0, 50.0, 0, 0, 0])

    def per_call(f, n=300):
        f()
        t = time.perf_counter()
        for _ in range(n):
            f()
        return (time.perf_counter() - t) / n * 1e6

    t_none = per_call(lambda: diff_ik_velocity(task, q, free_b, limit_mode="none"))
    t_free = per_call(lambda: diff_ik_velocity(task, q, free_b))
    t_qp = per_call(lambda: diff_ik_velocity(task, q, sat_b))
    print(
        f"diff_ik_velocity: pseudo-inverse {t_none:.0f} µs, enforce (no bound active) {t_free:.0f} µs, "
        f"enforce (QP, 9 bounds active) {t_qp:.0f} µs"
    )
    assert t_qp < 20 * t_none + 2000  # generous: timing on shared CI machines


# ----------------------------------------------------------------------------- success rates with the defaults
@pytest.mark.parametrize("name,kind", [("three_franka", "circle"), ("hexapod", "plane")])
def test_default_success_rates(load_system, name, kind):
    """20 random medium targets (5 cm, 15°, ±15 %) from q0, certified reachable inside the limits by
    unconstrained Gauss–Newton ending inside them.  With the defaults, Gauss–Newton must reach ≥ 99 %
    (tol 1e-10) and differential IK ≥ 95 % (tol 1e-4 within 250 × 0.01 s = 2.5 s at gain 10 /s)."""
    s = load_system(name)
    task = cg.cooperative_task(s, kind)
    q0 = np.array(s.q0)
    rng = np.random.default_rng(11)
    certified = gn_ok = dik_ok = 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cg.CoopGAWarning)
        for V in _targets(task, q0, rng, 20, 0.05, 15.0, 0.15):
            ref = gauss_newton_ik(task, q0, V, limit_mode="none")
            if not (ref.converged and ref.limit_violation == 0.0):
                continue
            certified += 1
            g = gauss_newton_ik(task, q0, V)
            d = diff_ik_reach(task, q0, V)
            assert _inside(s.limits, g.q) and _inside(s.limits, d.trajectory)
            gn_ok += g.converged
            dik_ok += d.converged
    print(f"{name}/{kind}: {certified}/20 certified; Gauss–Newton {gn_ok}/{certified}, diff IK {dik_ok}/{certified}")
    assert certified >= 15
    assert gn_ok >= 0.99 * certified
    assert dik_ok >= 0.95 * certified
