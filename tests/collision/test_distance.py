"""Closed-form clearances of coop_ga.collision.distance against independent Euclidean formulas,
on numpy and CasADi, and seed 002's Eq 28–29."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from coop_ga.collision import distance as D
from coop_ga.errors import CoopGAError, InvalidInputError
from coop_ga.geometry import line as gline
from coop_ga.geometry import plane as gplane
from coop_ga.geometry import sphere as gsphere

N = 300


# ---------------------------------------------------------------- independent references
def _pt_seg(c, a, b):
    """Euclidean distance of point c from segment [a, b] (projection, clamped)."""
    d = b - a
    L2 = d @ d
    t = 0.0 if L2 < 1e-30 else min(max((c - a) @ d / L2, 0.0), 1.0)
    return float(np.linalg.norm(c - (a + t * d)))


def _seg_seg(p0, p1, q0, q1):
    """Segment–segment distance as the minimum over the four end-point cases and the interior
    critical point of the two lines (when it lies inside both segments)."""
    cands = [_pt_seg(p0, q0, q1), _pt_seg(p1, q0, q1), _pt_seg(q0, p0, p1), _pt_seg(q1, p0, p1)]
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    M = np.array([[d1 @ d1, -(d1 @ d2)], [-(d1 @ d2), d2 @ d2]])
    if abs(np.linalg.det(M)) > 1e-12 * (d1 @ d1) * (d2 @ d2) and d1 @ d1 > 0 and d2 @ d2 > 0:
        s, t = np.linalg.solve(M, [-(d1 @ r), d2 @ r])
        if 0 <= s <= 1 and 0 <= t <= 1:
            cands.append(float(np.linalg.norm(p0 + s * d1 - q0 - t * d2)))
    return min(cands)


def _pt_line(c, a, b):
    u = (b - a) / np.linalg.norm(b - a)
    w = c - a
    return float(np.linalg.norm(w - (w @ u) * u))


# ---------------------------------------------------------------- obstacles
def test_sphere_plane_duals_measure_distance():
    rng = np.random.default_rng(0)
    for _ in range(50):
        c, r, x = rng.normal(size=3), rng.uniform(0.05, 1.0), rng.normal(size=3)
        S = D.Sphere(c, r)
        assert float(D.point_sphere_product(x, S)) == pytest.approx(0.5 * (r * r - (x - c) @ (x - c)), abs=1e-12)
        assert float(D.point_sphere_distance(x, S)) == pytest.approx(np.linalg.norm(x - c) - r, abs=1e-12)
        n, off = rng.normal(size=3), rng.normal()
        P = D.Plane(n, off)
        assert float(D.point_plane_distance(x, P)) == pytest.approx((n @ x - off) / np.linalg.norm(n), abs=1e-12)


def test_as_obstacle_from_primitives_and_dicts():
    rng = np.random.default_rng(1)
    c, r = rng.normal(size=3), 0.4
    u = rng.normal(size=(4, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    S = D.as_obstacle(gsphere(*(c + r * u)))
    assert isinstance(S, D.Sphere)
    np.testing.assert_allclose(S.center, c, atol=1e-9)
    assert S.radius == pytest.approx(r, abs=1e-9)
    a, b, cc = rng.normal(size=(3, 3))
    P = D.as_obstacle(gplane(a, b, cc))
    assert isinstance(P, D.Plane)
    n = np.cross(b - a, cc - a)
    n /= np.linalg.norm(n)
    np.testing.assert_allclose(P.normal, n, atol=1e-9)  # the free side is the right-hand normal's
    for x in (a, b, cc):
        assert float(D.point_plane_distance(x, P)) == pytest.approx(0.0, abs=1e-9)
    assert D.as_obstacle({"center": [0, 0, 1], "radius": 0.2}) == D.Sphere(np.array([0, 0, 1.0]), 0.2)
    assert D.as_obstacle({"normal": [0, 0, 2], "offset": 1.0}).offset == pytest.approx(0.5)
    assert D.Sphere([1, 2, 3], 0.5).as_dict() == {"center": [1.0, 2.0, 3.0], "radius": 0.5}


@pytest.mark.parametrize(
    "bad",
    [
        lambda: D.Sphere([0, 0], 1.0),
        lambda: D.Sphere([0, 0, 0], -1.0),
        lambda: D.Sphere([0, 0, np.nan], 1.0),
        lambda: D.Plane([0, 0, 0], 1.0),
        lambda: D.as_obstacle("sphere"),
        lambda: D.as_obstacle({"centre": [0, 0, 0]}),
        lambda: D.as_obstacle(gline([0, 0, 0], [1, 0, 0])),  # a line is no obstacle
    ],
)
def test_bad_obstacles_raise(bad):
    with pytest.raises(CoopGAError):
        bad()


# ---------------------------------------------------------------- capsule distances, numpy
def test_capsule_sphere_against_euclid_random():
    rng = np.random.default_rng(2)
    for _ in range(N):
        a, b, c = rng.normal(size=(3, 3))
        if rng.random() < 0.1:
            b = a.copy()  # degenerate: a ball
        rc, rs = rng.uniform(0, 0.3), rng.uniform(0.01, 0.5)
        d, t = D.capsule_sphere_distance(a, b, rc, D.Sphere(c, rs))
        assert float(d) == pytest.approx(_pt_seg(c, a, b) - rc - rs, abs=1e-10)
        x = a + float(t) * (b - a)
        assert np.linalg.norm(x - c) == pytest.approx(_pt_seg(c, a, b), abs=1e-10)


def test_capsule_plane_against_euclid_random():
    rng = np.random.default_rng(3)
    for _ in range(N):
        a, b, n = rng.normal(size=(3, 3))
        off, rc = rng.normal(), rng.uniform(0, 0.3)
        P = D.Plane(n, off)
        d, t = D.capsule_plane_distance(a, b, rc, P)
        ts = np.linspace(0, 1, 101)
        brute = min((a + s * (b - a)) @ P.normal - P.offset for s in ts)  # linear along the segment
        assert float(d) == pytest.approx(brute - rc, abs=1e-10)
        assert float(t) in (0.0, 1.0)


def test_capsule_capsule_against_euclid_random():
    rng = np.random.default_rng(4)
    for k in range(N):
        p0, p1, q0, q1 = rng.normal(size=(4, 3))
        if k % 10 == 1:
            p1 = p0.copy()  # a point
        if k % 10 == 2:
            q1 = q0.copy()
        if k % 10 == 3:
            p1, q1 = p0.copy(), q0.copy()  # two balls
        if k % 10 == 4:
            q1 = q0 + rng.uniform(-2, 2) * (p1 - p0)  # parallel
        if k % 10 == 5:
            q0 = p0 + rng.uniform(-1, 2) * (p1 - p0)  # collinear
            q1 = p0 + rng.uniform(-1, 2) * (p1 - p0)
        ra, rb = rng.uniform(0, 0.2, size=2)
        d, (s, t), (x, y) = D.capsule_capsule_distance(p0, p1, ra, q0, q1, rb)
        ref = _seg_seg(p0, p1, q0, q1)
        assert float(d) == pytest.approx(ref - ra - rb, abs=1e-9), k
        assert 0.0 <= float(s) <= 1.0 and 0.0 <= float(t) <= 1.0
        np.testing.assert_allclose(np.array(x, float), p0 + float(s) * (p1 - p0), atol=1e-12)
        assert np.linalg.norm(np.array(x, float) - np.array(y, float)) == pytest.approx(ref, abs=1e-9)


def test_capsule_capsule_special_cases():
    z = np.zeros(3)
    ex, ey, ez = np.eye(3)
    # crossing segments: distance 0 − radii
    d, _, _ = D.capsule_capsule_distance(-ex, ex, 0.1, -ey, ey, 0.2)
    assert float(d) == pytest.approx(-0.3, abs=1e-15)
    # skew, perpendicular, 0.5 apart
    d, (s, t), _ = D.capsule_capsule_distance(-ex, ex, 0.0, -ey + 0.5 * ez, ey + 0.5 * ez, 0.0)
    assert (float(d), float(s), float(t)) == pytest.approx((0.5, 0.5, 0.5), abs=1e-15)
    # parallel, overlapping in projection, 0.3 apart
    d, _, _ = D.capsule_capsule_distance(z, 2 * ex, 0.05, ex + 0.3 * ey, 3 * ex + 0.3 * ey, 0.05)
    assert float(d) == pytest.approx(0.2, abs=1e-15)
    # parallel, disjoint in projection: end to end
    d, (s, t), _ = D.capsule_capsule_distance(z, ex, 0.0, 3 * ex + 4 * ey, 2 * ex + 4 * ey, 0.0)
    assert float(d) == pytest.approx(np.hypot(1.0, 4.0), abs=1e-14)
    assert (float(s), float(t)) == (1.0, 1.0)
    # a point against a segment, a point against a point
    d, _, _ = D.capsule_capsule_distance(ey, ey, 0.1, -ex, ex, 0.0)
    assert float(d) == pytest.approx(0.9, abs=1e-15)
    d, _, _ = D.capsule_capsule_distance(ey, ey, 0.0, ez, ez, 0.0)
    assert float(d) == pytest.approx(np.sqrt(2.0), abs=1e-15)


def test_batched_arrays_match_scalar_calls():
    rng = np.random.default_rng(5)
    P0, P1, Q0, Q1 = rng.normal(size=(4, 50, 3))
    cols = [tuple(X.T) for X in (P0, P1, Q0, Q1)]
    d, _, _ = D.capsule_capsule_distance(cols[0], cols[1], 0.1, cols[2], cols[3], 0.05)
    for k in range(50):
        assert float(d[k]) == pytest.approx(_seg_seg(P0[k], P1[k], Q0[k], Q1[k]) - 0.15, abs=1e-10)
    S = D.Sphere([0.1, 0.2, 0.3], 0.2)
    ds, _ = D.capsule_sphere_distance(cols[0], cols[1], 0.1, S)
    for k in range(50):
        assert float(ds[k]) == pytest.approx(_pt_seg(S.center, P0[k], P1[k]) - 0.3, abs=1e-10)


def test_wrong_shapes_raise():
    with pytest.raises(InvalidInputError):
        D.capsule_capsule_distance([0, 0], [1, 0, 0], 0.1, [0, 1, 0], [1, 1, 0], 0.1)
    with pytest.raises(InvalidInputError):
        D.capsule_sphere_distance(ca.SX.sym("a", 2), [1, 0, 0], 0.1, D.Sphere([0, 0, 0], 1.0))


# ---------------------------------------------------------------- the same code on CasADi
def _sx_fun():
    x = ca.SX.sym("x", 12)
    p0, p1, q0, q1 = (x[3 * i : 3 * i + 3] for i in range(4))
    d, _, _ = D.capsule_capsule_distance(p0, p1, 0.1, q0, q1, 0.05)
    S = D.Sphere([0.2, -0.1, 0.3], 0.25)
    ds, _ = D.capsule_sphere_distance(p0, p1, 0.1, S)
    P = D.Plane([0.3, 0.2, 1.0], -0.2)
    dp, _ = D.capsule_plane_distance(p0, p1, 0.1, P)
    out = ca.vertcat(d, ds, dp, D.point_sphere_distance(q0, S))
    return ca.Function("f", [x], [out, ca.jacobian(out, x)]), S, P


def test_casadi_values_and_gradients():
    f, S, P = _sx_fun()
    rng = np.random.default_rng(6)
    h = 1e-6
    for k in range(60):
        x = rng.normal(size=12)
        if k % 6 == 1:
            x[9:12] = x[6:9] + rng.uniform(0.2, 2) * (x[3:6] - x[0:3])  # parallel
        p0, p1, q0, q1 = x.reshape(4, 3)
        val, J = (np.array(v, float) for v in f(x))
        ref = [
            _seg_seg(p0, p1, q0, q1) - 0.15,
            _pt_seg(S.center, p0, p1) - 0.35,
            min(p0 @ P.normal, p1 @ P.normal) - P.offset - 0.1,
            np.linalg.norm(q0 - S.center) - 0.25,
        ]
        np.testing.assert_allclose(val.ravel(), ref, atol=1e-10)
        # central finite differences of the numeric reference (generic points: differentiable)
        Jn = np.zeros((4, 12))
        for i in range(12):
            e = np.zeros(12)
            e[i] = h
            Jn[:, i] = (np.array(f(x + e)[0]).ravel() - np.array(f(x - e)[0]).ravel()) / (2 * h)
        np.testing.assert_allclose(J, Jn, atol=2e-6)


def test_gradient_is_finite_on_the_nonsmooth_set():
    f, _, _ = _sx_fun()
    x = np.array([-1, 0, 0, 1, 0, 0, 0, -1, 0, 0, 1, 0], float)  # crossing cores
    val, J = (np.array(v, float) for v in f(x))
    assert val[0, 0] == pytest.approx(-0.15)
    assert np.all(np.isfinite(J))
    x2 = x.copy()
    x2[3:6] = x2[0:3]  # capsule A a ball
    assert np.all(np.isfinite(np.array(f(x2)[1], float)))


# ---------------------------------------------------------------- seed 002, Eq 28–29
def test_seed002_eq28_29_is_the_infinite_cylinder_distance():
    """Eq 29's ρ² is the squared distance of the sphere centre from the link's *line*: Eq 28 is exact
    for the infinite cylinder (to 1e-12 on random cases).  Seed discrepancy: for a finite link it is
    exact only while the foot of the perpendicular lies on the link; beyond an end it underestimates
    the clearance (a sphere beside the axis extension is reported as touching)."""
    rng = np.random.default_rng(7)
    for _ in range(100):
        pi, pj, c = rng.normal(size=(3, 3))
        R, r2 = rng.uniform(0.05, 0.5), rng.uniform(0.01, 0.1)
        S = D.Sphere(c, R)
        d28 = D.seed002_link_sphere_distance(pi, pj, r2, S)
        assert d28 == pytest.approx(_pt_line(c, pi, pj) - R - r2, abs=1e-12)
        dcap, t = D.capsule_sphere_distance(pi, pj, r2, S)
        if 0.0 < float(t) < 1.0:  # foot on the link: Eq 28 = the finite link's clearance
            assert d28 == pytest.approx(float(dcap), abs=1e-12)
        else:
            assert d28 <= float(dcap) + 1e-12
    # the discrepancy, measured: a sphere on the link's axis extension, 1 m beyond its end
    S = D.Sphere([2.0, 0.0, 0.0], 0.1)
    d28 = D.seed002_link_sphere_distance([0, 0, 0], [1, 0, 0], 0.05, S)
    dcap, _ = D.capsule_sphere_distance(np.zeros(3), np.array([1.0, 0, 0]), 0.05, S)
    assert d28 == pytest.approx(-0.15, abs=1e-12)  # Eq 28: "colliding"
    assert float(dcap) == pytest.approx(0.85, abs=1e-12)  # the true clearance of the capsule


def test_capsule_capsule_and_sphere_against_coal():
    """A second, independent reference: coal's (hpp-fcl) GJK distance between capsule shapes."""
    coal = pytest.importorskip("coal")

    def shape(a, b, r):
        ax = b - a
        L = float(np.linalg.norm(ax))
        z = ax / L
        x = np.cross(z, [1.0, 0, 0] if abs(z[0]) < 0.9 else [0, 1.0, 0])
        x /= np.linalg.norm(x)
        R = np.column_stack([x, np.cross(z, x), z])
        return coal.Capsule(r, L), coal.Transform3s(R, 0.5 * (a + b))  # coal: (radius, full length)

    rng = np.random.default_rng(8)
    checked = 0
    for _ in range(200):
        p0, p1, q0, q1 = rng.normal(size=(4, 3))
        ra, rb = rng.uniform(0.01, 0.1, size=2)
        d, _, _ = D.capsule_capsule_distance(p0, p1, ra, q0, q1, rb)
        if float(d) <= 1e-3:
            continue  # coal reports penetration only approximately
        sa, ta = shape(p0, p1, ra)
        sb, tb = shape(q0, q1, rb)
        ref = coal.distance(sa, ta, sb, tb, coal.DistanceRequest(), coal.DistanceResult())
        assert float(d) == pytest.approx(ref, abs=1e-6)
        S = D.Sphere(q0, rb)
        ds, _ = D.capsule_sphere_distance(p0, p1, ra, S)
        if float(ds) > 1e-3:
            refs = coal.distance(
                sa, ta, coal.Sphere(rb), coal.Transform3s(np.eye(3), q0), coal.DistanceRequest(), coal.DistanceResult()
            )
            assert float(ds) == pytest.approx(refs, abs=1e-6)
        checked += 1
    assert checked > 150


def _eq28_29_as_printed(s, p_i, p_j, r2):
    """Eq 28–29 step by step from a dual sphere vector s (not necessarily normalised); returns
    (d, Y²) with Y = [l*·(s + ½s² e∞)] [l*·(s + ½s² e∞)·e∞]⁻¹."""
    from coop_ga.algebra.basis import blade_index
    from coop_ga.algebra.multivector import Multivector
    from coop_ga.geometry.primitives import line

    ei = blade_index("einf")[0]
    L = line(np.asarray(p_i, float), np.asarray(p_j, float))
    s2 = float((s * s).get(0))
    B = (s + Multivector((ei,), (0.5 * s2,))).lc(L)
    Y = B * Multivector((ei,), (1.0,)).lc(B).inverse()
    YY = Y * Y
    return float(np.sqrt(max(float(YY.get(0)), 0.0)) - np.sqrt(s2) - r2), YY


def test_seed002_eq29_square_is_a_scalar_and_needs_a_normalised_sphere():
    """Y² in Eq 29 is a pure scalar (its grade-2 and grade-4 parts vanish), so ρ² is well defined.
    Seed discrepancy 2: Eq 28–29 hold only for the *normalised* dual sphere (e0 coefficient 1,
    s·e∞ = −1): s + ½s² e∞ is the centre point only then.  For λs (the same sphere in IPNS)
    the printed formula gives another number — measured here for λ = 2."""
    rng = np.random.default_rng(9)
    for _ in range(20):
        pi, pj, c = rng.normal(size=(3, 3))
        S = D.Sphere(c, rng.uniform(0.05, 0.5))
        d, YY = _eq28_29_as_printed(S.dual, pi, pj, 0.03)
        dense = YY.to_dense()
        dense[0] = 0.0
        assert np.abs(dense).max() < 1e-10
        assert d == pytest.approx(D.seed002_link_sphere_distance(pi, pj, 0.03, S), abs=1e-12)
    S = D.Sphere([0.3, 0.4, 0.2], 0.1)
    d1, _ = _eq28_29_as_printed(S.dual, [0, 0, 0], [1, 0, 0], 0.0)
    d2, _ = _eq28_29_as_printed(S.dual.scale(2.0), [0, 0, 0], [1, 0, 0], 0.0)
    assert d1 == pytest.approx(np.sqrt(0.2) - 0.1, abs=1e-12)  # the true clearance of the line
    assert d2 == pytest.approx(np.sqrt(0.21) - 0.2, abs=1e-12)  # λ = 2: ρ² = 0.21, sqrt(s²) = 2R
