"""Task-space dynamics (Eq 32–38) and similarity impedance control (Eq 49–52, §4.1)."""

from __future__ import annotations

import warnings

import numpy as np
import pinocchio as pin
import pytest

import coop_ga as cg
from coop_ga.control import PAPER_GAINS, joint_dynamics, simulate_impedance, task_space_dynamics
from coop_ga.control.dynamics import dynamically_consistent_projector
from coop_ga.control.impedance import error_rate, impedance_torque

IIWA_Q0 = np.array([0, -0.7854, 0, 1.3962, 0, 0.6109, 0])


def _load(name):
    return cg.systems.load(name)


@pytest.fixture(scope="module", params=["three_franka", "three_iiwa14"])
def circle(request):
    s = _load(request.param)
    return s, cg.cooperative_task(s, "circle")


def _state(s, seed):
    rng = np.random.default_rng(seed)
    return s.q0 + rng.uniform(-0.2, 0.2, s.nq), rng.normal(size=s.nq)


# ---------------------------------------------------------------- dynamics (Eq 32–38)
def test_jdot_qdot_matches_finite_differences(circle):
    s, t = circle
    for seed in range(3):
        q, qd = _state(s, seed)
        h = 1e-5
        fd = (t.jacobian(q + h * qd) @ qd - t.jacobian(q - h * qd) @ qd) / (2 * h)
        ad = t.jdot_qdot(q, qd)
        assert np.linalg.norm(ad - fd) <= 1e-6 * np.linalg.norm(ad) + 1e-9


def test_joint_dynamics_match_pinocchio(circle):
    s, t = circle
    q, qd = _state(s, 1)
    M, C, g = joint_dynamics(t, q, qd)
    d = s.model.createData()
    assert np.array_equal(M, M.T)
    assert np.min(np.linalg.eigvalsh(M)) > 0
    np.testing.assert_allclose(g, pin.rnea(s.model, d, q, np.zeros(s.nq), np.zeros(s.nq)), atol=1e-10)
    np.testing.assert_allclose(C @ qd + g, pin.rnea(s.model, d, q, qd, np.zeros(s.nq)), atol=1e-9)
    qdd = np.random.default_rng(2).normal(size=s.nq)
    np.testing.assert_allclose(M @ qdd + C @ qd + g, pin.rnea(s.model, d, q, qd, qdd), atol=1e-9)


def test_task_inertia_is_pseudo_inverse(circle):
    s, t = circle
    q, qd = _state(s, 2)
    td = task_space_dynamics(t, q, qd)
    Lam, mu, gS, J, Jdqd = td  # documented unpacking
    A = J @ td.Minv @ J.T
    assert np.allclose(Lam, Lam.T)
    assert np.linalg.matrix_rank(Lam, tol=1e-8 * np.abs(Lam).max()) == 6  # circle: rank 6 of 7 (Table 1)
    np.testing.assert_allclose(A @ Lam @ A, A, atol=1e-9 * np.abs(A).max())
    np.testing.assert_allclose(Lam @ A @ Lam, Lam, atol=1e-9 * np.abs(Lam).max())
    np.testing.assert_allclose(gS, Lam @ J @ td.Minv @ td.g_joint)
    np.testing.assert_allclose(mu, Lam @ (J @ td.Minv @ td.C @ qd - Jdqd))


def test_operational_space_law_realises_task_acceleration(circle):
    """τ = Jᵀ(Λ a + μ + g_S) + N̄ᵀ h gives 𝒱̇ = J q̈ + J̇ q̇ = P a (P: projector onto range J)."""
    s, t = circle
    q, qd = _state(s, 3)
    td = task_space_dynamics(t, q, qd)
    a = np.random.default_rng(4).normal(size=7)
    h = td.C @ qd + td.g_joint
    Nt = dynamically_consistent_projector(td.J, td.Minv, td.Lambda)
    tau = td.J.T @ (td.Lambda @ a + td.mu + td.g) + Nt @ h
    np.testing.assert_allclose(tau, h + td.J.T @ td.Lambda @ (a - td.Jdot_qd), atol=1e-8)
    qdd = pin.aba(s.model, s.model.createData(), q, qd, tau)
    U, _, _ = np.linalg.svd(td.J)
    P = U[:, :6] @ U[:, :6].T
    acc = td.J @ qdd + td.Jdot_qd
    np.testing.assert_allclose(P @ acc, P @ a, atol=1e-6 * np.linalg.norm(a))
    np.testing.assert_allclose(td.J @ td.Minv @ Nt, 0, atol=1e-8)  # dynamically consistent


# ---------------------------------------------------------------- error rate (Eq 49)
def test_error_rate_matches_finite_differences():
    s = cg.systems.load("three_franka")
    t = cg.cooperative_task(s, "circle")
    rng = np.random.default_rng(5)
    Vd = t.similarity(s.q0 + rng.uniform(-0.15, 0.15, s.nq))
    q, qd = s.q0 + rng.uniform(-0.15, 0.15, s.nq), rng.normal(size=s.nq)
    h = 1e-6
    fd = (t.error(q + h * qd, Vd) - t.error(q - h * qd, Vd)) / (2 * h)
    e, de_exact = error_rate(t, q, qd, Vd, "exact")
    _, de_approx = error_rate(t, q, qd, Vd, "approx")
    assert np.linalg.norm(de_exact - fd) < 1e-6 * np.linalg.norm(fd)
    # −J^G q̇ is the first-order rate: relative deviation O(‖e‖) (factor 1, not the paper's ½)
    assert np.linalg.norm(de_approx - fd) < 1.0 * np.linalg.norm(e) * np.linalg.norm(fd)
    # and it becomes exact at e = 0
    Vd0 = t.similarity(q)
    fd0 = (t.error(q + h * qd, Vd0) - t.error(q - h * qd, Vd0)) / (2 * h)
    assert np.linalg.norm(-t.jacobian(q) @ qd - fd0) < 1e-6 * np.linalg.norm(fd0)
    assert np.linalg.norm(-0.5 * t.jacobian(q) @ qd - fd0) > 0.4 * np.linalg.norm(fd0)


# ---------------------------------------------------------------- §4.1 experiment
@pytest.fixture(scope="module")
def iiwa_runs():
    s = _load("three_iiwa14")
    t = cg.cooperative_task(s, "circle")
    q0 = np.tile(IIWA_Q0, 3)
    Vd = t.similarity(q0)  # regulate to the nominal circle (Fig. 6)
    rng = np.random.default_rng(2024)
    # four random starts (the experiment's count, Figs. 5–6): 20 runs of 4 s cost ~1 min of the suite's time
    starts = [q0 + rng.uniform(-0.1, 0.1, s.nq) for _ in range(4)]
    out = {}
    for label, (K, D) in {"paper": PAPER_GAINS, "stiff": (25.0 * np.eye(7), 10.0 * np.eye(7))}.items():
        out[label] = [simulate_impedance(t, qi, Vd, K=K, D=D, duration=4.0, dt=1e-3) for qi in starts]
    return out


def test_impedance_paper_gains(iiwa_runs):
    runs = iiwa_runs["paper"]
    ratios = [r.ratio for r in runs]
    print("paper gains: final/initial error", np.round(ratios, 4))
    assert len(runs) == 4 and all(r.t[-1] == pytest.approx(4.0) for r in runs)
    assert all(r.error_norm[0] > 0.02 for r in runs)
    assert max(ratios) < 0.5
    assert max(r.max_rise for r in runs) < 0.05


def test_impedance_stiff_gains(iiwa_runs):
    runs = iiwa_runs["stiff"]
    ratios = [r.ratio for r in runs]
    print("K=25, D=10: final/initial error", np.array(ratios))
    assert max(ratios) < 0.05
    assert max(r.max_rise for r in runs) < 0.05


def test_impedance_bad_input():
    s = cg.systems.load("three_franka")
    t = cg.cooperative_task(s, "circle")
    with pytest.raises(cg.InvalidInputError):
        simulate_impedance(t, s.q0, t.similarity(s.q0), K=np.eye(6), D=1.0, duration=0.01)
    with pytest.raises(cg.InvalidInputError):
        simulate_impedance(t, s.q0, t.similarity(s.q0), K=1.0, D=1.0, dt=0.0)
    with pytest.raises(cg.InvalidInputError):
        simulate_impedance(t, s.q0, t.similarity(s.q0), K=1.0, D=1.0, duration=0.01, nullspace="none")


def test_impedance_holds_still_at_target():
    """At the target with zero velocity the (gravity-compensated) robot does not move."""
    s = cg.systems.load("three_franka")
    t = cg.cooperative_task(s, "circle")
    r = simulate_impedance(t, s.q0, t.similarity(s.q0), K=PAPER_GAINS[0], D=PAPER_GAINS[1], duration=0.2)
    assert r.error_norm.max() < 1e-9
    assert np.abs(r.q - s.q0).max() < 1e-9 and np.abs(r.trajectory[-1] - s.q0).max() < 1e-9


# ---------------------------------------------------------------- limits (torque saturation, position/velocity counts)
def _recount(r, lim):
    """The limit statistics of an ImpedanceResult recomputed from its arrays (independently of the module)."""
    n = len(r.t) - 1
    fin = np.isfinite(lim.effort)
    ratio = np.abs(r.tau_command[:n][:, fin]) / lim.effort[fin]
    below = r.trajectory < lim.lower
    above = r.trajectory > lim.upper
    exc = np.concatenate([(lim.lower - r.trajectory)[below], (r.trajectory - lim.upper)[above], [0.0]])
    pos = np.array([np.any(below[k] | above[k]) for k in range(n + 1)])
    vel = np.array([any(abs(r.qd[k, j]) > lim.velocity[j] for j in range(lim.nq)) for k in range(n + 1)])
    return {
        "saturated_steps": int(sum(np.any(row > 1.0) for row in ratio)),
        "effort_ratio": float(ratio.max()),
        "position_violation": float(exc.max()),
        "velocity_ratio": float(np.max(np.abs(r.qd) / lim.velocity)),
        "position_violation_steps": int(pos.sum()),
        "velocity_violation_steps": int(vel.sum()),
        "limit_violation_steps": int((pos | vel).sum()),
    }


def _assert_counts_match(r, lim):
    ref = _recount(r, lim)
    for name, value in ref.items():
        assert getattr(r, name) == pytest.approx(value, rel=1e-12, abs=0.0), name
    assert r.within_limits == (ref["limit_violation_steps"] == 0)


def test_nominal_runs_respect_every_limit(iiwa_runs):
    """§4.1 (three_iiwa14 from IIWA_Q0 + U(±0.1), 4 s): no saturation, no limit violated, no warning."""
    lim = _load("three_iiwa14").limits
    ratios = []
    for runs in iiwa_runs.values():
        for r in runs:
            assert r.torque_limits == "saturate"
            assert r.saturated_steps == 0 and 0.0 < r.effort_ratio < 0.3  # measured 0.19–0.20
            np.testing.assert_array_equal(r.tau, r.tau_command)
            assert r.within_limits and r.position_violation == 0.0 and r.velocity_ratio < 1.0  # measured ≤ 0.65
            assert not any(k.startswith("JointLimitWarning") for k in r.warnings)
            _assert_counts_match(r, lim)
            ratios.append((r.velocity_ratio, r.effort_ratio))
    print("nominal runs: (max |q̇|/limit, max |τ|/effort)", np.round(ratios, 3).tolist())


@pytest.fixture(scope="module")
def stiff_runs():
    """three_iiwa14 from IIWA_Q0 + U(±0.1) with K = 1e4 I, D = 200 I for 0.3 s: the command exceeds the
    wrist efforts (40 N m) by ~2.7× in the first steps."""
    s = _load("three_iiwa14")
    t = cg.cooperative_task(s, "circle")
    q0 = np.tile(IIWA_Q0, 3)
    qi = q0 + np.random.default_rng(2024).uniform(-0.1, 0.1, s.nq)
    out = {}
    for mode in ("saturate", "none"):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            r = simulate_impedance(t, qi, t.similarity(q0), K=1e4, D=200.0, duration=0.3, torque_limits=mode)
        out[mode] = (r, [w for w in caught if issubclass(w.category, cg.JointLimitWarning)])
    return s, t, out


def test_large_gains_saturate_and_report(stiff_runs):
    s, _, out = stiff_runs
    lim = s.limits
    r, caught = out["saturate"]
    n = len(r.t) - 1
    print(
        f"K=1e4: saturated {r.saturated_steps} of {n} steps, max |τ|/effort {r.effort_ratio:.3f}, "
        f"max |q̇|/limit {r.velocity_ratio:.3f}"
    )
    assert 5 <= r.saturated_steps <= 40 and 2.0 < r.effort_ratio < 4.0  # measured 11 steps, 2.70×
    assert np.all(np.abs(r.tau) <= lim.effort)  # what was applied respects the ratings …
    clipped = np.abs(r.tau_command) > lim.effort
    np.testing.assert_array_equal(np.abs(r.tau)[clipped], np.broadcast_to(lim.effort, r.tau.shape)[clipped])
    np.testing.assert_array_equal(r.tau[~clipped], r.tau_command[~clipped])  # … and nothing else was touched
    assert "saturated in" in r.message
    _assert_counts_match(r, lim)
    # the velocity limit is exceeded (up to ~8×): reported, counted, warned about once, and not "converged"
    assert r.velocity_ratio > 2.0 and r.velocity_violation_steps > 10 and not r.within_limits
    assert r.error < r.error_norm[0] * 1e-3 and not r.converged
    assert len(caught) == 1 and "left the joint limits" in str(caught[0].message)
    assert sum(v for k, v in r.warnings.items() if k.startswith("JointLimitWarning")) == 1


def test_torque_limits_none_applies_the_raw_command(stiff_runs):
    s, t, out = stiff_runs
    lim = s.limits
    r, caught = out["none"]
    n = len(r.t) - 1
    np.testing.assert_array_equal(r.tau, r.tau_command)
    assert r.saturated_steps > 0 and r.effort_ratio > 2.0
    assert np.any(np.abs(r.tau[:n]) > lim.effort)
    _assert_counts_match(r, lim)
    msgs = [str(w.message) for w in caught]
    assert len(caught) == 2 and any("above the effort limits" in m for m in msgs)
    # impedance_torque returns what simulate_impedance applies
    k = int(np.flatnonzero(np.any(np.abs(r.tau_command) > lim.effort, axis=1))[0])
    Vd = t.similarity(np.tile(IIWA_Q0, 3))
    opts = {"K": 1e4, "D": 200.0}
    raw = impedance_torque(t, r.trajectory[k], r.qd[k], Vd, torque_limits="none", **opts)
    np.testing.assert_allclose(raw, r.tau_command[k], rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(
        impedance_torque(t, r.trajectory[k], r.qd[k], Vd, **opts),
        np.clip(raw, -lim.effort, lim.effort),
        rtol=1e-12,
        atol=1e-9,
    )


def test_violation_counts_match_a_recount():
    """±0.3 rad start, a tightened joint range and a tightened velocity limit: every count is what the
    returned arrays say."""
    s0 = _load("three_iiwa14")
    q0 = np.tile(IIWA_Q0, 3)
    names = s0.limits.joint_names
    s = s0.with_limits(position={names[3]: (q0[3] - 0.05, q0[3] + 0.05)}, velocity={names[1]: 0.1})
    t = cg.cooperative_task(s, "circle")
    qi = q0 + np.random.default_rng(1).uniform(-0.3, 0.3, s.nq)
    qi[3] = q0[3]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        r = simulate_impedance(t, qi, t.similarity(q0), duration=1.0)
    print(
        f"tightened limits: position excursion {r.position_violation:.3g} rad in {r.position_violation_steps} "
        f"states, |q̇|/limit {r.velocity_ratio:.3g} in {r.velocity_violation_steps} states"
    )
    assert r.position_violation_steps > 0 and r.velocity_violation_steps > 0
    assert r.position_violation > 0 and r.velocity_ratio > 1
    _assert_counts_match(r, s.limits)
    assert len([w for w in caught if issubclass(w.category, cg.JointLimitWarning)]) == 1
    assert not r.converged


def test_torque_limits_option_is_validated():
    with pytest.raises(cg.InvalidInputError):
        cg.control.ImpedanceOptions(torque_limits="clip")
    with pytest.raises(cg.InvalidInputError):
        cg.control.ImpedanceOptions(warn_limits=1)
