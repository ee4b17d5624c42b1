"""Gauss–Newton IK with line search (Eq 43–47): convergence, rate, honest failure."""

from __future__ import annotations

import itertools
import warnings

import numpy as np
import pytest

import coop_ga as cg
from coop_ga.control import gauss_newton_ik


def _load(name):
    return cg.systems.load(name)


CASES = [("three_franka", "circle", 0.3), ("allegro", "sphere", 0.15), ("g1_arms", "line", 0.3)]


def _reachable_target(s, t, rng, scale):
    """A target V_Sd = V_Sc(q*) for a random q* near q0 (so it is reachable) and a start q."""
    for _ in range(20):
        q_star = np.clip(s.q0 + rng.uniform(-scale, scale, s.nq), s.q_lower, s.q_upper)
        q_init = np.clip(s.q0 + rng.uniform(-scale, scale, s.nq), s.q_lower, s.q_upper)
        if t.well_definedness(q_star) > 0.05 and t.well_definedness(q_init) > 0.05:
            return t.similarity(q_star), q_init
    raise AssertionError("no well-defined sample")


@pytest.mark.parametrize("name,kind,scale", CASES)
def test_converges_to_reachable_targets(name, kind, scale):
    s = _load(name)
    t = cg.cooperative_task(s, kind)
    rng = np.random.default_rng(7)
    iters = []
    for _ in range(4):
        Vd, q_init = _reachable_target(s, t, rng, scale)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", cg.DegeneracyWarning)
            r = gauss_newton_ik(t, q_init, Vd)
        assert r.converged, (r.message, r.history)
        assert r.error < 1e-9
        assert s.limits.position_violation(r.q) == 0.0 and r.limit_violation == 0.0  # limit_mode='enforce' (default)
        assert np.linalg.norm(t.error(r.q, Vd)) < 1e-9  # the reported error is the true one
        assert r.iterations <= 15
        assert r.history.shape == (r.iterations + 1,)
        assert np.all(np.diff(r.history) < 0)  # line search: monotone decrease
        iters.append(r.iterations)
    print(name, kind, "GN iterations", iters)


def test_quadratic_convergence():
    """Near the solution the error is roughly squared every step (zero-residual Gauss–Newton)."""
    s = cg.systems.load("three_franka")
    t = cg.cooperative_task(s, "circle")
    rng = np.random.default_rng(11)
    Vd = t.similarity(s.q0 + rng.uniform(-0.2, 0.2, s.nq))
    r = gauss_newton_ik(t, s.q0 + rng.uniform(-0.2, 0.2, s.nq), Vd, tol=1e-14)
    h = r.history
    assert r.converged and np.all(r.step_sizes == 1.0)
    # e_{k+1} ≤ C e_k² once e_k < 1e-2 (C ~ the curvature of the residual, a few units)
    pairs = [(a, b) for a, b in itertools.pairwise(h) if 1e-7 < a < 1e-2]
    assert len(pairs) >= 2
    for a, b in pairs:
        assert b < 10.0 * a * a, (a, b)


def test_unreachable_target_is_reported():
    s = cg.systems.load("three_franka")
    t = cg.cooperative_task(s, "circle")
    r0 = cg.radius(t.primitive(s.q0))
    Vd = t.similarity(s.q0) * cg.geometry.exp([0, 0, 0, np.log(10.0 / r0), 0, 0, 0])  # 10 m radius, same centre
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cg.DegeneracyWarning)
        r = gauss_newton_ik(t, s.q0, Vd)
    assert not r.converged
    assert np.isfinite(r.error) and r.error > 1.0
    assert r.error == pytest.approx(np.linalg.norm(t.error(r.q, Vd)), rel=1e-12)
    assert r.error < r.history[0]  # it did get as close as it could
    assert r.message != "converged"


def test_uncontrollable_direction_is_reported():
    """A target differing only by a rotation about the circle's own axis (the 7th,
    uncontrollable direction of Table 1) cannot be reached: stationary point, converged=False."""
    s = cg.systems.load("three_franka")
    t = cg.cooperative_task(s, "circle")
    J = t.jacobian(s.q0)
    U, sv, _ = np.linalg.svd(J)
    u = U[:, -1]  # left null direction of J at q0
    assert sv[-1] < 1e-9 * sv[0]
    Vd = t.similarity(s.q0) * cg.geometry.exp(0.3 * u)
    r = gauss_newton_ik(t, s.q0, Vd)
    assert not r.converged
    assert r.error == pytest.approx(0.3, rel=1e-6)
    assert r.iterations <= 2


def test_bad_input():
    s = cg.systems.load("three_franka")
    t = cg.cooperative_task(s, "circle")
    with pytest.raises(cg.InvalidInputError):
        gauss_newton_ik(t, s.q0[:3], t.similarity(s.q0))
    with pytest.raises(cg.InvalidInputError):
        gauss_newton_ik(t, s.q0, np.zeros(5))
    with pytest.raises(cg.InvalidInputError, match=r"Similarity\.from_coeffs"):
        gauss_newton_ik(t, s.q0, np.full(12, np.nan))  # raw coefficients are not a Similarity
    with pytest.raises(cg.NonFiniteError):
        cg.Similarity.from_coeffs(np.full(12, np.nan))
    with pytest.raises(cg.InvalidInputError):
        gauss_newton_ik(t, s.q0, t.similarity(s.q0), max_iter=-1)
