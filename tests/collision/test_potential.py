"""Potential-field path generation (seed 002 §VI, Eq 20–27; coop_ga/collision/potential.py)."""

from __future__ import annotations

import collections

import numpy as np
import pytest

from coop_ga.algebra.multivector import Multivector
from coop_ga.collision.potential import (
    additive_split,
    charges,
    coulomb_field,
    coulomb_potential,
    dual_sphere,
    equilibrium_distance,
    obstacle,
    potential_path,
    random_scene,
    safety_sphere,
    signed_squared_distance,
)
from coop_ga.errors import CoopGAError, DegeneratePrimitiveError, InvalidInputError
from coop_ga.geometry.primitives import plane, point

ORIGIN = np.zeros(3)


# ---------------------------------------------------------------------- spheres and distances
def test_signed_squared_distance_is_half_r2_minus_d2():
    rng = np.random.default_rng(3)
    c, r = rng.normal(size=3), 0.3
    S = obstacle(c, r)
    X = rng.normal(size=(50, 3))
    expected = 0.5 * (r * r - np.sum((X - c) ** 2, axis=1))
    np.testing.assert_allclose(signed_squared_distance(X, S), expected, atol=1e-12)
    np.testing.assert_allclose(signed_squared_distance(X, dual_sphere(S)), expected, atol=1e-12)
    assert signed_squared_distance(c, S) == pytest.approx(0.5 * r * r)
    # the safety sphere grows by the margin
    np.testing.assert_allclose(
        signed_squared_distance(X, safety_sphere(S, 0.1)), 0.5 * (0.16 - np.sum((X - c) ** 2, axis=1)), atol=1e-12
    )


def test_bad_spheres_raise():
    with pytest.raises(InvalidInputError):
        dual_sphere(np.zeros(5))
    with pytest.raises(InvalidInputError):
        dual_sphere(plane([0, 0, 0], [1, 0, 0], [0, 1, 0]))
    with pytest.raises(DegeneratePrimitiveError):
        dual_sphere(Multivector.blade("e1"))  # a grade-1 vector with zero e0 weight: a plane
    with pytest.raises(InvalidInputError):
        obstacle([0, 0, 0], -1.0)
    with pytest.raises(InvalidInputError):  # the start inside a safety sphere
        potential_path([0.05, 0, 0], [1, 0, 0], [obstacle([0, 0, 0], 0.1)])
    with pytest.raises(InvalidInputError):
        potential_path([2, 0, 0], [1, 0, 0], [obstacle([1, 0, 0], 0.05)], margin=0.1)
    assert issubclass(InvalidInputError, CoopGAError)


# ---------------------------------------------------------------------- the seed's equations, checked
def test_field_is_minus_gradient_of_potential():
    """Eq 22 (n = 3) with its missing "=" and sign restored: E = −∇U = Σ q_i (x − c_i)/r_i³ − (x − g)/|x − g|³."""
    rng = np.random.default_rng(5)
    C, Q, g = rng.normal(size=(3, 3)), rng.uniform(0.1, 0.5, 3), rng.normal(size=3)
    x, h = rng.normal(size=3) + 2.0, 1e-6
    grad = np.array(
        [(coulomb_potential(x + h * e, C, Q, g) - coulomb_potential(x - h * e, C, Q, g)) / (2 * h) for e in np.eye(3)]
    )
    np.testing.assert_allclose(coulomb_field(x, C, Q, g), -grad, rtol=1e-6, atol=1e-9)


def test_eq21_planar_potential_differs_from_harmonic_by_a_constant():
    """Eq 21, n = 2: the printed q ln(q/r) is q ln(1/r) + q ln q — same field, not the harmonic form itself."""
    q, r = 0.3, np.linspace(0.2, 3.0, 9)
    printed, harmonic = q * np.log(q / r), q * np.log(1.0 / r)
    np.testing.assert_allclose(printed - harmonic, q * np.log(q), atol=1e-15)
    # the 2-D field q/r (Eq 22, n = 2) is −d/dr of both
    h = 1e-6
    dU = (q * np.log(q / (r + h)) - q * np.log(q / (r - h))) / (2 * h)
    np.testing.assert_allclose(-dU, q / r, rtol=1e-8)


@pytest.mark.parametrize("R, D", [(0.1, 1.0), (0.2, 0.5), (0.05, 2.0)])
def test_eq23_is_the_planar_rule(R, D):
    """Eq 23, q = R/(R + D), puts the equilibrium point behind the obstacle at distance R only for the
    2-D field q/r; for the 3-D field q/r² it is at √q D/(1 − √q) > R, and q = (R/(R+D))² puts it at R."""
    g, c = ORIGIN, np.array([D, 0.0, 0.0])
    q_seed = float(charges([R], [c], g, "seed")[0])
    q_eq = float(charges([R], [c], g, "equilibrium")[0])
    assert q_seed == pytest.approx(R / (R + D)) and q_eq == pytest.approx(q_seed**2)
    # 2-D field on the axis behind the obstacle: q/r − 1/(r + D) vanishes at r = R exactly
    assert q_seed / R - 1.0 / (R + D) == pytest.approx(0.0, abs=1e-12)

    def zero_3d(q):  # bisection on the axis for the 3-D field's x-component
        lo, hi = 1e-6, 100.0
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            if coulomb_field(c + [mid, 0, 0], [c], [q], g)[0] > 0:
                lo = mid
            else:
                hi = mid
        return 0.5 * (lo + hi)

    r_seed, r_eq = zero_3d(q_seed), zero_3d(q_eq)
    assert r_seed == pytest.approx(equilibrium_distance(q_seed, D), rel=1e-9)
    assert r_eq == pytest.approx(R, rel=1e-9)
    assert r_seed > 1.5 * R  # the seed's rule leaves the equilibrium far outside the security sphere
    if (R, D) == (0.1, 1.0):
        assert r_seed == pytest.approx(0.4317, abs=1e-4)  # the number quoted in the module docstring


def test_additive_split_eq24_26():
    """P = P_E + P_E⊥ with P_E⊥ = x; E = e∞∧e0 squares to 1 in our basis; the seed's two E's (§III e4∧e5, §VI
    e∞∧e0) differ by a sign, which cancels in (P·E)E and (P∧E)E."""
    E = Multivector.blade("einf") ^ Multivector.blade("e0")
    assert (E * E).prune(1e-15).grades == (0,) and float((E * E).get(0)) == pytest.approx(1.0)
    x = np.array([0.3, -1.2, 2.5])
    P = point(x)
    PE, Pperp = additive_split(P)
    names = ("e0", "e1", "e2", "e3", "einf")
    coef = {n: (float(PE.get(_idx(n))), float(Pperp.get(_idx(n))), float(P.get(_idx(n)))) for n in names}
    for n in names:
        assert coef[n][0] + coef[n][1] == pytest.approx(coef[n][2], abs=1e-12)  # Eq 26
    np.testing.assert_allclose([coef[n][1] for n in names], [0.0, *x, 0.0], atol=1e-12)  # Eq 25: x_e
    assert coef["e0"][0] == pytest.approx(1.0) and coef["einf"][0] == pytest.approx(0.5 * x @ x)  # Eq 24
    mE = E.scale(-1.0)  # the other sign of E gives the same split
    PE2 = ((P | mE) * mE).grade(1)
    np.testing.assert_allclose([float(PE2.get(_idx(n))) for n in names], [coef[n][0] for n in names], atol=1e-12)


def _idx(name: str) -> int:
    from coop_ga.algebra.basis import blade_index

    return blade_index(name)[0]


# ---------------------------------------------------------------------- paths
def test_free_path_is_the_straight_line():
    r = potential_path([0, 0, 0], [1, 0.5, 0], step=0.01)
    assert r.reached and r.status == "reached" and r.final_distance == 0.0
    assert r.length == pytest.approx(np.hypot(1, 0.5), rel=1e-9)


@pytest.mark.parametrize("far", [1e3, 1e20, 1e102, 1e140])
def test_far_goal_is_walked_toward_not_called_an_equilibrium(far):
    """A goal far away pulls with |E| = 1/d² (1e-204 at 1e102 m, whose square underflows): the path steps
    straight toward it until max_iter — never a "local_minimum" (an equilibrium the free field does not have)."""
    r = potential_path([0, 0, 0], [far, 0, 0], step=0.01, max_iter=50)
    assert r.status == "max_iterations" and not r.reached
    np.testing.assert_allclose(r.path[-1], [0.5, 0.0, 0.0], atol=1e-12)


def test_random_scenes_never_enter_and_reach():
    """120 seeded random scenes (1–3 spheres near the segment, margin 5 cm): the path never enters a safety
    sphere (exact polyline clearance ≥ 0), and when it reports "reached" it ends within tol of the goal.
    Measured (seed rule): 118/120 reached; 2 escaped (Σq ≥ 1: field lines run to infinity)."""
    rng = np.random.default_rng(0)
    kinds: collections.Counter[str] = collections.Counter()
    min_clear, ratios = np.inf, []
    for _ in range(120):
        s, g, obs = random_scene(rng, int(rng.integers(1, 4)), margin=0.05)
        r = potential_path(s, g, obs, margin=0.05, step=0.01)
        kinds[r.status] += 1
        min_clear = min(min_clear, r.min_clearance)
        assert r.min_clearance >= 0.0, r.message
        if r.reached:
            assert np.linalg.norm(r.path[-1] - g) <= 0.01
            ratios.append(r.length / np.linalg.norm(g - s))
        else:
            assert r.status == "escaped" and r.charges.sum() >= 1.0, r.message
    assert kinds["reached"] >= 115, kinds
    assert min_clear > 0.0
    assert 1.0 <= min(ratios) and np.median(ratios) > 2.0  # the seed's rule makes long detours (median ≈ 3)


def test_random_scenes_equilibrium_rule_shorter_paths():
    """The 3-D rule q = (R/(R+D))² gives much shorter paths than Eq 23 (same scenes), still never entering."""
    rng = np.random.default_rng(1)
    ratio = {"seed": [], "equilibrium": []}
    for _ in range(30):
        s, g, obs = random_scene(rng, int(rng.integers(1, 4)), margin=0.05)
        for rule in ratio:
            r = potential_path(s, g, obs, margin=0.05, step=0.01, charge_rule=rule)
            assert r.min_clearance >= 0.0
            if r.reached:
                ratio[rule].append(r.length / np.linalg.norm(g - s))
    assert len(ratio["equilibrium"]) == 30
    assert np.median(ratio["equilibrium"]) < 1.3 < np.median(ratio["seed"])


def test_single_obstacle_field_lines_do_not_cross_with_seed_rule():
    """The seed's claim (§VI: trajectories do not cross the security circle) holds for one obstacle with Eq 23
    in 3-D: the safety guard never had to change a step on 40 scenes."""
    rng = np.random.default_rng(7)
    for _ in range(40):
        s, g, obs = random_scene(rng, 1, margin=0.05)
        r = potential_path(s, g, obs, margin=0.05, step=0.01)
        assert r.reached and r.guard_steps == 0 and r.min_clearance > 0


def test_failure_symmetric_obstacle_stalls_at_equilibrium():
    """Start on the goal–obstacle axis: the path stops at the field's equilibrium point behind the obstacle
    (r* = √q D/(1 − √q) = 0.3449 m for R = 0.1, D = 0.5); 1 mm off the axis it escapes the saddle."""
    c, R = np.array([0.5, 0, 0]), 0.1
    r = potential_path([1.2, 0, 0], ORIGIN, [obstacle(c, R)], step=0.01)
    assert not r.reached and r.status == "local_minimum"
    r_star = equilibrium_distance(R / (R + 0.5), 0.5)
    assert r_star == pytest.approx(0.3449, abs=1e-4)
    assert np.linalg.norm(r.stall_point - (c + [r_star, 0, 0])) < 0.02
    off = potential_path([1.2, 1e-3, 0], ORIGIN, [obstacle(c, R)], step=0.01)
    assert off.reached and off.min_clearance > 0


def test_failure_overlapping_spheres_trap():
    """Two overlapping spheres (centres 0.18 m apart, radius 0.1) in front of the goal, 3-D rule: the path
    slides into the concave crease of their union and is blocked there (also 2 cm off the symmetry axis)."""
    obs = [obstacle([0.5, 0.09, 0], 0.1), obstacle([0.5, -0.09, 0], 0.1)]
    for s in ([1.2, 0, 0], [1.2, 0.02, 0]):
        r = potential_path(s, ORIGIN, obs, step=0.01, charge_rule="equilibrium")
        assert r.status == "local_minimum" and not r.reached, r.message
        assert set(r.blocking) == {0, 1}
        assert np.linalg.norm(r.stall_point - [0.55, 0, 0]) < 0.01  # the crease point behind the pair
        assert r.min_clearance >= 0.0
    # with the seed's (stronger) charges the symmetric start stalls earlier, at the pair's equilibrium point
    r = potential_path([1.2, 0, 0], ORIGIN, obs, step=0.01)
    assert r.status == "local_minimum" and r.stall_point[0] > 1.1


def test_failure_several_obstacles_escape():
    """A 3×3 wall of spheres: with Eq 23 the charges sum to Σq = 1.61 > 1 and the path runs off to infinity;
    with the 3-D rule (Σq = 0.29) it goes around and reaches the goal."""
    obs = [obstacle([0.5, y, z], 0.12) for y in (-0.2, 0, 0.2) for z in (-0.2, 0, 0.2)]
    r = potential_path([1.2, 0.05, 0.03], ORIGIN, obs, step=0.01)
    assert r.status == "escaped" and r.charges.sum() == pytest.approx(1.6136, abs=1e-3)
    assert r.min_clearance >= 0
    r2 = potential_path([1.2, 0.05, 0.03], ORIGIN, obs, step=0.01, charge_rule="equilibrium")
    assert r2.reached and r2.min_clearance > 0 and r2.charges.sum() == pytest.approx(0.2897, abs=1e-3)


def test_guard_keeps_path_outside_when_field_would_enter():
    """A case where the raw field step would enter a safety sphere: the guard changes steps, and still the
    exact polyline clearance is ≥ 0 (max_iter small so the test is quick)."""
    rng = np.random.default_rng(1)
    guarded = 0
    for _ in range(60):
        s, g, obs = random_scene(rng, 1, margin=0.05)
        r = potential_path(s, g, obs, margin=0.05, step=0.01, charge_rule="equilibrium")
        assert r.min_clearance >= 0.0
        guarded += r.guard_steps > 0
    assert guarded >= 1


def test_seed_E_sign():
    """§III E = e4∧e5 vs §VI E = e∞∧e0: −1 apart with the printed e0 = ½(e4 − e5), equal with e0 = ½(e5 − e4)."""
    e4, e5 = np.eye(5)[3], np.eye(5)[4]
    einf = e4 + e5

    def wedge(a, b):  # a∧b of two vectors as an antisymmetric matrix
        return np.outer(a, b) - np.outer(b, a)

    np.testing.assert_allclose(wedge(einf, 0.5 * (e4 - e5)), -wedge(e4, e5))
    np.testing.assert_allclose(wedge(einf, 0.5 * (e5 - e4)), wedge(e4, e5))


def test_section6b_distance_and_raw_step():
    """§VI-B step 1: sqrt(−2 P(x)·P(g)) = |x − g|; step 3's raw x + εE (no normalisation) near the goal is
    ε/r²: 5 cm from the goal with ε = 1 cm a 4 m step, 80 × the remaining distance."""
    rng = np.random.default_rng(11)
    x, g = rng.normal(size=3), rng.normal(size=3)
    assert np.sqrt(-2.0 * float((point(x) | point(g)).get(0))) == pytest.approx(np.linalg.norm(x - g), rel=1e-12)
    E = coulomb_field([0.05, 0, 0], np.zeros((0, 3)), np.zeros(0), ORIGIN)
    raw = 0.01 * np.linalg.norm(E)
    assert raw == pytest.approx(4.0) and raw / 0.05 == pytest.approx(80.0)
