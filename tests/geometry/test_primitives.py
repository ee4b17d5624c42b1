"""Primitives against closed-form Euclidean geometry (circumcircle, circumsphere, …)."""

from __future__ import annotations

import numpy as np
import pytest

import coop_ga as cg
from coop_ga.algebra import Multivector
from tests.helpers import proportionality


def circumcircle(a, b, c):
    """Closed form: center, radius, unit normal of the circle through a, b, c."""
    ab, ac = b - a, c - a
    n = np.cross(ab, ac)
    cc = a + (np.dot(ac, ac) * np.cross(n, ab) + np.dot(ab, ab) * np.cross(ac, n)) / (2 * np.dot(n, n))
    return cc, np.linalg.norm(cc - a), n / np.linalg.norm(n)


def circumsphere(a, b, c, d):
    A = np.array([b - a, c - a, d - a])
    rhs = 0.5 * np.array([b @ b - a @ a, c @ c - a @ a, d @ d - a @ a])
    cs = np.linalg.solve(A, rhs)
    return cs, np.linalg.norm(cs - a)


def test_point_roundtrip(rng):
    for x in rng.normal(size=(50, 3)) * 5:
        np.testing.assert_allclose(cg.to_euclidean(cg.point(x)), x, atol=1e-12)
        # any positive or negative weight
        np.testing.assert_allclose(cg.to_euclidean(cg.point(x).scale(-3.7)), x, atol=1e-12)


def test_circle_center_radius_normal_match_circumcircle(rng):
    for _ in range(200):
        a, b, c = rng.normal(size=(3, 3)) * 2
        C = cg.circle(a, b, c)
        cc, r, n = circumcircle(a, b, c)
        np.testing.assert_allclose(cg.center(C), cc, atol=1e-8 * (1 + np.abs(cc).max()))
        assert np.isclose(cg.radius(C), r, rtol=1e-8)
        np.testing.assert_allclose(cg.normal(C), n, atol=1e-9)


def test_sphere_center_radius_match_circumsphere(rng):
    for _ in range(200):
        pts = rng.normal(size=(4, 3)) * 2
        S = cg.sphere(*pts)
        cs, r = circumsphere(*pts)
        np.testing.assert_allclose(cg.center(S), cs, atol=1e-7 * (1 + np.abs(cs).max()))
        assert np.isclose(cg.radius(S), r, rtol=1e-7)


def test_point_pair_line_plane_readouts(rng):
    for _ in range(100):
        a, b, c = rng.normal(size=(3, 3))
        pp = cg.point_pair(a, b)
        np.testing.assert_allclose(cg.center(pp), (a + b) / 2, atol=1e-10)
        assert np.isclose(cg.radius(pp), np.linalg.norm(b - a) / 2)
        d = (b - a) / np.linalg.norm(b - a)
        np.testing.assert_allclose(cg.direction(pp), d, atol=1e-10)
        ea, eb = cg.endpoints(pp)
        np.testing.assert_allclose(ea, a, atol=1e-9)
        np.testing.assert_allclose(eb, b, atol=1e-9)
        L = cg.line(a, b)
        np.testing.assert_allclose(cg.direction(L), d, atol=1e-10)
        p = a - np.dot(a, d) * d  # closest point to the origin
        np.testing.assert_allclose(cg.closest_point_to_origin(L), p, atol=1e-10)
        E = cg.plane(a, b, c)
        n = np.cross(b - a, c - a)
        n /= np.linalg.norm(n)
        np.testing.assert_allclose(cg.normal(E), n, atol=1e-10)
        np.testing.assert_allclose(cg.closest_point_to_origin(E), np.dot(a, n) * n, atol=1e-10)


def test_points_lie_on_their_primitive(rng):
    # outer-product null space, Eq 3: P(x) ∧ X = 0 for every defining point
    pts = rng.normal(size=(4, 3))
    for kind, n in cg.geometry.N_POINTS.items():
        X = cg.primitive_from_points(kind, list(pts[:n]))
        for x in pts[:n]:
            Z = cg.point(x) ^ X
            assert all(abs(c) < 1e-12 for c in Z.coeffs)
        # and a random other point does not
        Z = cg.point(rng.normal(size=3) * 3) ^ X
        assert max(abs(c) for c in Z.coeffs) > 1e-6


def test_kind_inference_without_tag(rng):
    pts = rng.normal(size=(4, 3))
    for kind, n in cg.geometry.N_POINTS.items():
        X = cg.primitive_from_points(kind, list(pts[:n]))
        plain = Multivector(X.blades, X.coeffs)
        assert cg.kind_of(plain) == kind


def test_projection_of_point_onto_plane_and_line(rng):
    """Eq 4 maps a point onto a flat: the result is a vector centred at the foot point,
    an imaginary sphere whose squared radius is −(distance)² (so it also carries the distance)."""
    for _ in range(20):
        a, b, c, x = rng.normal(size=(4, 3))
        E = cg.plane(a, b, c)
        n = np.cross(b - a, c - a)
        n /= np.linalg.norm(n)
        foot = x - np.dot(x - a, n) * n
        Pp = cg.project(cg.point(x), E)
        assert Pp.prune(1e-12).grades == (1,)
        np.testing.assert_allclose(cg.to_euclidean(Pp), foot, atol=1e-10)
        assert np.isclose((Pp * Pp).get(0) / Pp["e0"] ** 2, -(np.dot(x - a, n) ** 2))
        L = cg.line(a, b)
        d = (b - a) / np.linalg.norm(b - a)
        foot = a + np.dot(x - a, d) * d
        Pl = cg.project(cg.point(x), L)
        np.testing.assert_allclose(cg.to_euclidean(Pl), foot, atol=1e-10)


def test_meet_line_plane_and_two_spheres(rng):
    # line ∩ plane: flat point ∝ P(x) ∧ e∞ with x the closed-form intersection
    a, b, c = rng.normal(size=(3, 3))
    p, q = rng.normal(size=(2, 3))
    E, L = cg.plane(a, b, c), cg.line(p, q)
    n = np.cross(b - a, c - a)
    s = np.dot(a - p, n) / np.dot(q - p, n)
    x = p + s * (q - p)
    Y = cg.meet(L, E)
    _lam, res = proportionality(Y, cg.point(x) ^ Multivector.blade("einf"))
    assert res < 1e-8
    # sphere ∩ sphere: a circle whose center and radius match the closed form
    c1, c2 = np.zeros(3), np.array([1.0, 0.5, -0.2])
    r1, r2 = 1.0, 0.8
    S1 = cg.sphere(*(c1 + r1 * np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [-1, 0, 0]], float)))
    S2 = cg.sphere(*(c2 + r2 * np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [-1, 0, 0]], float)))
    C = cg.meet(S1, S2)
    dd = np.linalg.norm(c2 - c1)
    h = (dd**2 + r1**2 - r2**2) / (2 * dd)
    want_c = c1 + h * (c2 - c1) / dd
    want_r = np.sqrt(r1**2 - h**2)
    from coop_ga.geometry.primitives import Primitive

    Ct = Primitive.tag(C.grade(3), "circle")
    np.testing.assert_allclose(cg.center(Ct), want_c, atol=1e-9)
    assert np.isclose(cg.radius(Ct), want_r, rtol=1e-9)


def test_paper_eq24_gives_inverse_radius(rng):
    """Seed discrepancy: Eq 24, r = ‖(X·e∞)X⁻¹‖, evaluates to 1/r (checked against closed form)."""
    a, b, c = rng.normal(size=(3, 3))
    C = cg.circle(a, b, c)
    _, r, _ = circumcircle(a, b, c)
    Y = (Multivector.blade("einf") | C) * C.inverse()
    eq24 = np.sqrt(abs(Y.norm_squared()))
    assert np.isclose(eq24, 1.0 / r, rtol=1e-9)
    assert not np.isclose(eq24, r, rtol=1e-3)


@pytest.mark.parametrize(
    "kind, pts, words",
    [
        ("point_pair", [[1, 2, 3], [1, 2, 3]], "coincide"),
        ("line", [[0, 0, 1e-12], [0, 0, 1e-12]], "coincide"),  # 1e-12 m apart is a fine line now (item 7)
        ("circle", [[0, 0, 0], [1, 1, 1], [2, 2, 2]], "collinear"),
        ("plane", [[0, 0, 0], [1, 0, 0], [3, 0, 0]], "collinear"),
        ("sphere", [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], "coplanar"),
    ],
)
def test_degenerate_points_raise_named_error(kind, pts, words):
    with pytest.raises(cg.DegeneratePrimitiveError, match=words) as ei:
        cg.primitive_from_points(kind, [np.array(p, float) for p in pts])
    assert "a=" in str(ei.value)  # the message names the points
    assert isinstance(ei.value, cg.CoopGAError)


def test_nearly_degenerate_is_decided_by_tol():
    pts = [np.zeros(3), np.array([1.0, 0, 0]), np.array([2.0, 1e-6, 0])]
    cg.circle(*pts)  # default tol 1e-9: fine
    with pytest.raises(cg.DegeneratePrimitiveError):
        cg.circle(*pts, tol=1e-5)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_nonfinite_input_raises(bad):
    with pytest.raises(cg.NonFiniteError):
        cg.point([0.0, bad, 1.0])
    with pytest.raises(cg.NonFiniteError):
        cg.circle([0, 0, 0], [1, 0, 0], [0, 1, bad])


def test_wrong_shape_raises():
    with pytest.raises(cg.InvalidInputError, match="shape"):
        cg.point([1.0, 2.0])
    with pytest.raises(cg.UnknownNameError, match="choose one of"):
        cg.primitive_from_points("ellipse", [])


def test_inputs_are_not_modified():
    a = np.array([1.0, 2.0, 3.0])
    b = np.array([0.0, -1.0, 2.0])
    a0, b0 = a.copy(), b.copy()
    cg.point_pair(a, b)
    np.testing.assert_array_equal(a, a0)
    np.testing.assert_array_equal(b, b0)


def test_well_definedness_measure():
    eq = np.array([[1, 0, 0], [-0.5, np.sqrt(3) / 2, 0], [-0.5, -np.sqrt(3) / 2, 0]])
    assert np.isclose(cg.well_definedness("circle", eq), 1.0)
    reg = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], float)
    assert np.isclose(cg.well_definedness("sphere", reg), 1.0)
    flat = eq.copy()
    flat[2] = [2.0, 0, 0]
    assert cg.well_definedness("circle", np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0]], float)) == 0.0
    # scale invariant
    assert np.isclose(cg.well_definedness("circle", 7 * eq), 1.0)
