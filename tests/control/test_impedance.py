"""Task-space dynamics (Eq 32–38) and similarity impedance control (Eq 49–52, §4.1)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import coop_ga as cg
from coop_ga.control import PAPER_GAINS, joint_dynamics, simulate_impedance, task_space_dynamics
from coop_ga.control.dynamics import dynamically_consistent_projector
from coop_ga.control.impedance import error_rate

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
    U, sv, _ = np.linalg.svd(td.J)
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
    starts = [q0 + rng.uniform(-0.1, 0.1, s.nq) for _ in range(10)]
    out = {}
    for label, (K, D) in {"paper": PAPER_GAINS, "stiff": (25.0 * np.eye(7), 10.0 * np.eye(7))}.items():
        out[label] = [simulate_impedance(t, qi, Vd, K=K, D=D, duration=4.0, dt=1e-3) for qi in starts]
    return out


def test_impedance_paper_gains(iiwa_runs):
    runs = iiwa_runs["paper"]
    ratios = [r.ratio for r in runs]
    print("paper gains: final/initial error", np.round(ratios, 4))
    assert len(runs) == 10 and all(r.t[-1] == pytest.approx(4.0) for r in runs)
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
