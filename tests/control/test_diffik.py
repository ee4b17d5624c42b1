"""Differential IK (Eq 48, 61): sign convention, reaching, limits, input errors."""

from __future__ import annotations

import numpy as np
import pytest

import coop_ga as cg
from coop_ga.control import diff_ik_reach, diff_ik_step


@pytest.fixture(scope="module")
def franka():
    s = cg.systems.load("three_franka")
    return s, cg.cooperative_task(s, "circle")


def test_step_realises_body_bivector(franka):
    """V(q_next) ≈ V(q) exp(Δt B) for a command in the controllable directions."""
    s, t = franka
    q = s.q0.copy()
    J = t.jacobian(q)
    U, _sv, _Vt = np.linalg.svd(J)
    rng = np.random.default_rng(3)
    b = U[:, :6] @ rng.normal(size=6)  # circle: rank 6, stay in the range of J
    b *= 0.2 / np.linalg.norm(b)
    dt = 1e-3
    q1 = diff_ik_step(t, q, b, dt=dt, damping=0.0, limit_mode="none")
    realised = cg.geometry.log(~t.similarity(q) * t.similarity(q1)) / dt
    assert np.linalg.norm(realised - b) < 1e-3 * np.linalg.norm(b)


def test_dilation_sign(franka):
    s, t = franka
    # one step from rest: the Franka's acceleration limits would cap |q̇| at a·Δt, so the sign convention
    # is checked without them
    q1 = diff_ik_step(t, s.q0, [0, 0, 0, 0.5, 0, 0, 0], dt=0.01, damping=1e-6, acceleration_limit=False)
    r0, r1 = cg.radius(t.primitive(s.q0)), cg.radius(t.primitive(q1))
    assert r1 / r0 == pytest.approx(np.exp(0.005), rel=1e-4)


def test_reach_converges(franka):
    s, t = franka
    rng = np.random.default_rng(0)
    Vd = t.similarity(s.q0 + rng.uniform(-0.2, 0.2, s.nq))
    q0 = s.q0 + rng.uniform(-0.2, 0.2, s.nq)
    r = diff_ik_reach(t, q0, Vd, gain=10.0, dt=0.01, steps=500, tol=1e-6)
    assert r.converged and r.error < 1e-6
    assert r.iterations < 200
    assert r.trajectory.shape == (r.iterations + 1, s.nq) and r.errors.shape == (r.iterations + 1,)
    assert np.linalg.norm(t.error(r.q, Vd)) == pytest.approx(r.error)
    # geometric decay (1 − gain Δt)^k on the controllable part
    assert r.errors[10] < 0.5 * r.errors[0]
    assert np.all(np.diff(r.errors) <= 1e-12)


def test_reach_reports_failure(franka):
    s, t = franka
    Vd = t.similarity(s.q0) * cg.geometry.exp([0, 0, 0, np.log(20.0), 0, 0, 0])  # 20× larger circle
    r = diff_ik_reach(t, s.q0, Vd, gain=5.0, steps=50)
    assert not r.converged and np.isfinite(r.error) and r.error > 0.1


def test_clamp_limits(franka):
    s, t = franka
    q = np.clip(s.q0.copy(), s.q_lower, s.q_upper)
    big = np.array([0, 0, 0, 50.0, 0, 0, 0])
    for _ in range(30):
        q = diff_ik_step(t, q, big, dt=0.05)  # default: limit_mode='enforce' (QP)
    assert np.all(q >= s.q_lower) and np.all(q <= s.q_upper)
    q3 = np.clip(s.q0.copy(), s.q_lower, s.q_upper)
    for _ in range(30):
        q3 = diff_ik_step(t, q3, big, dt=0.05, limit_mode="clamp")  # the ablation: clip after the step
    assert np.all(q3 >= s.q_lower) and np.all(q3 <= s.q_upper)
    q2 = s.q0.copy()
    for _ in range(30):
        q2 = diff_ik_step(t, q2, big, dt=0.05, limit_mode="none")
    assert np.any((q2 < s.q_lower) | (q2 > s.q_upper))


def test_defaults_and_the_tol_gain_time_relation(franka):
    """Defaults: gain 10 /s, Δt 0.01 s, 250 steps (2.5 s), tol 1e-4, limit_mode 'enforce'.  Away from the
    limits the error decays like (1 − gain Δt)^k, so tol is reached after
    k ≈ ln(‖e_0‖/tol) / −ln(1 − gain Δt) steps (≈ ln(‖e_0‖/tol)/gain seconds)."""
    from coop_ga.control import DiffIKOptions, displaced_target

    o = DiffIKOptions()
    assert (o.gain, o.dt, o.steps, o.tol, o.limit_mode) == (10.0, 0.01, 250, 1e-4, "enforce")
    s, t = franka
    V = displaced_target(t, s.q0, translation=(0.01, 0.0, 0.005), axis=(0, 1, 0), angle=0.03, scale=1.02)
    # the relation holds where no bound is active: without the acceleration limits, which shape the
    # first steps from rest (test_acceleration_limits.py)
    r = diff_ik_reach(t, s.q0, V, acceleration_limit=False)
    assert r.converged and r.active_steps == 0 and r.limit_mode == "enforce"
    k_pred = np.log(r.errors[0] / o.tol) / -np.log(1 - o.gain * o.dt)
    print("steps", r.iterations, "predicted", k_pred)
    assert abs(r.iterations - k_pred) <= 3
    # identical to the unconstrained controller when no bound is active
    r0 = diff_ik_reach(t, s.q0, V, limit_mode="none")
    assert r0.max_acceleration_violation > 0.0  # and then the first step jumps beyond them
    np.testing.assert_array_equal(r.trajectory, r0.trajectory)


def test_bad_input(franka):
    s, t = franka
    with pytest.raises(cg.InvalidInputError):
        diff_ik_step(t, s.q0, np.zeros(6))
    with pytest.raises(cg.InvalidInputError):
        diff_ik_step(t, s.q0[:5], np.zeros(7))
    with pytest.raises(cg.NonFiniteError):
        diff_ik_step(t, s.q0, [np.nan] + [0] * 6)
    with pytest.raises(cg.InvalidInputError):
        diff_ik_step(t, s.q0, np.zeros(7), limit_mode="wrap")
    with pytest.raises(cg.InvalidInputError):
        diff_ik_step(t, s.q0, np.zeros(7), dt=-1)
    with pytest.raises(cg.InvalidInputError):
        diff_ik_reach(t, s.q0, t.similarity(s.q0), steps=-3)
