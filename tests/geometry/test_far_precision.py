"""The similarity between primitives far from the origin, against an exact-rational reference.

A round of radius r whose center is ρ from the origin stores r in its coefficients only to
~ε(ρ/r)² relative (r enters through ρ² + r²).  The old ``similarity()`` read r from the
coefficients, so its scale and translation carried that error silently up to ρ/r ≈ 7e4
(3.5e-8 for circles at ρ/r = 1e4) and warned only beyond.  Primitives built from points now
keep their local form and give the similarity to a few ε; the others warn with an estimate
that bounds the error.

The reference parameters (center or closest point, r², axis) are computed in exact rational
arithmetic from the very float coordinates the primitives are built from; only the final
rounding to float (and the axis normalisation, sqrt) is inexact, ~ε.
"""

from __future__ import annotations

import importlib
import re
import warnings
from fractions import Fraction as F

import numpy as np
import pytest

import coop_ga as cg
from coop_ga.errors import PrecisionWarning
from coop_ga.geometry import KIND_SPECS, KINDS, N_POINTS
from coop_ga.geometry.groups import Similarity, rotor_matrix

sim = importlib.import_module("coop_ga.geometry.similarity")
EPS = float(np.finfo(float).eps)


def _q(p):
    return [F(float(x)) for x in p]


def _sub(a, b):
    return [x - y for x, y in zip(a, b)]


def _add(a, b):
    return [x + y for x, y in zip(a, b)]


def _dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def _mul(s, a):
    return [s * x for x in a]


def _cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _det3(a, b, c):
    return _dot(a, _cross(b, c))


def exact_parameters(kind, pts):
    """``(c, r², o)`` exactly: center (closest point to the origin for flats), squared radius and the
    (unnormalised) axis of the primitive through the float points ``pts``."""
    P = [_q(p) for p in pts]
    if kind == "point":
        return P[0], None, None
    if kind in ("point_pair", "line"):
        a, b = P
        o = _sub(b, a)
        if kind == "point_pair":
            return _mul(F(1, 2), _add(a, b)), _dot(o, o) / 4, o
        return _sub(a, _mul(_dot(a, o) / _dot(o, o), o)), None, o
    if kind in ("circle", "plane"):
        a, b, c = P
        u, v = _sub(b, a), _sub(c, a)
        w = _cross(u, v)
        if kind == "plane":
            return _mul(_dot(w, a) / _dot(w, w), w), None, w
        # circumcenter a + ((|u|² v − |v|² u) × w) / (2|w|²)
        cc = _add(a, _mul(1 / (2 * _dot(w, w)), _cross(_sub(_mul(_dot(u, u), v), _mul(_dot(v, v), u)), w)))
        return cc, _dot(_sub(cc, a), _sub(cc, a)), w
    a = P[0]
    rows = [_mul(2, _sub(q, a)) for q in P[1:]]  # 2(q − a)·x = |q|² − |a|²
    rhs = [_dot(q, q) - _dot(a, a) for q in P[1:]]
    cols = [[rows[i][j] for i in range(3)] for j in range(3)]
    det = _det3(*cols)
    x = [_det3(*[rhs if k == j else cols[k] for k in range(3)]) / det for j in range(3)]  # Cramer
    return x, _dot(_sub(x, a), _sub(x, a)), None


def _unit(o):
    v = np.array([float(x) for x in o])
    return v / np.linalg.norm(v)


def reference(kind, pts_from, pts_to):
    """``(t, R, s)`` of the similarity from the primitive through ``pts_from`` to the one through ``pts_to``."""
    c1, r21, o1 = exact_parameters(kind, pts_from)
    c2, r22, o2 = exact_parameters(kind, pts_to)
    s = float(np.sqrt(float(r22 / r21))) if r21 is not None else 1.0
    if o1 is None:
        R = np.eye(3)
    else:
        Rv = sim.rotor_between(_unit(o1), _unit(o2))
        R = np.array(rotor_matrix(tuple(float(Rv.get(b)) for b in Rv.blades)))
    t = np.array([float(x) for x in c2]) - s * R @ np.array([float(x) for x in c1])
    return t, R, s


def similarity_error(kind, pts_from, pts_to, V):
    """Relative error of V: scale relative, rotation absolute, translation relative to the coordinates'
    size ρ_to + s ρ_from (t = c_to − s R c_from is a difference of terms of that size)."""
    t, R, s = reference(kind, pts_from, pts_to)
    size = max(np.linalg.norm(p) for p in pts_to) + s * max(np.linalg.norm(p) for p in pts_from)
    S = Similarity(V)
    return max(
        float(np.linalg.norm(S.translation - t)) / size,
        abs(S.scale - s) / s,
        float(np.max(np.abs(S.rotation_matrix - R))),
    )


def scale_rounding(kind, pts_from, pts_to):
    """The rounding error a similarity of scale s carries whatever the primitives: its dilator stores
    cosh/sinh of ½ log s, whose difference e^{−|β|/2} is ~max(s, 1/s) times smaller than each (the
    library's own "similarity-scale" estimate ε·max(s, 1/s))."""
    s = reference(kind, pts_from, pts_to)[2]
    return EPS * max(s, 1.0 / s)


def far_points(kind, rng, rho, size):
    c = rng.normal(size=3)
    c *= rho / np.linalg.norm(c)
    return [c + size * rng.normal(size=3) for _ in range(N_POINTS[kind])]


def unit_points(kind):
    return [np.array(p) for p in KIND_SPECS[kind].unit_points]


def _run(f):
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        V = f()
    return V, [x for x in w if issubclass(x.category, PrecisionWarning)]


@pytest.mark.parametrize("kind", KINDS)
def test_similarity_of_far_primitives_built_from_points_is_exact_to_rounding(kind):
    """Old: circles 1e3, 1e4, 1e6 radii away gave relative errors 1e-10, 4e-8, 2e-4 (the last with a
    warning, the others silent)."""
    rng = np.random.default_rng(KINDS.index(kind))
    worst = 0.0
    for rho, size in [(1e2, 1.0), (1e3, 1.0), (1e4, 1.0), (1e6, 1.0), (1e3, 1e-3), (1.0, 1e-6), (1e9, 0.5)]:
        for _ in range(4):
            a, b = far_points(kind, rng, rho, size), far_points(kind, rng, rho * rng.uniform(0.1, 1.0), size * 3)
            Xa, Xb = cg.primitive_from_points(kind, a), cg.primitive_from_points(kind, b)
            for pts_from, pts_to, f in [
                (a, b, lambda: sim.similarity(Xa, Xb)),
                (unit_points(kind), b, lambda: sim.similarity_from_unit(Xb)),
                (unit_points(kind), a, lambda: sim.similarity(sim.unit_primitive(kind), Xa)),
            ]:
                V, precision = _run(f)
                assert not precision, str(precision[0].message)
                err = similarity_error(kind, pts_from, pts_to, V)
                worst = max(worst, err / max(1e-12, 2 * scale_rounding(kind, pts_from, pts_to)))
    assert worst <= 1.0, worst


def test_batched_far_primitives_keep_their_local_form():
    rng = np.random.default_rng(7)
    pts = [far_points("circle", rng, 1e5, 1.0) for _ in range(3)]
    P = np.stack([np.array(p) for p in pts], axis=1)  # (3 points, N = 3, 3)
    X = cg.primitive_from_points("circle", P)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r = cg.radius(X)
    r_exact = [float(np.sqrt(float(exact_parameters("circle", p)[1]))) for p in pts]
    np.testing.assert_allclose(r, r_exact, rtol=1e-14)


def test_the_local_form_is_dropped_by_every_operation():
    X = cg.circle([1e6, 0, 0], [1e6 + 1, 0, 0], [1e6, 1, 0])
    assert X.local is not None
    np.testing.assert_array_equal(X.local[0], np.mean([[1e6, 0, 0], [1e6 + 1, 0, 0], [1e6, 1, 0]], axis=0))
    assert not isinstance(X.scale(2.0), cg.Primitive)
    assert cg.geometry.apply(cg.geometry.exp(np.zeros(7)), X).local is None
    assert cg.circle([1, 0, 0], [0, 1, 0], [-1, 0, 0]).local is None  # near the origin: nothing to keep


_EST = re.compile(r"estimated relative error of ([0-9.e+-]+)")


@pytest.mark.parametrize("kind", ["point_pair", "circle", "sphere"])
def test_far_rounds_without_their_local_form_warn_with_an_estimate_that_bounds_the_error(kind):
    """The same coefficients without the local form (as after an untagged round trip): the similarity
    warns once with an estimate ≥ its error beyond PRECISION_WARN, and is within it otherwise."""
    rng = np.random.default_rng(11 + KINDS.index(kind))
    warned = 0
    for rho, size in [(1e2, 1.0), (1e4, 1.0), (3e4, 1.0), (1e5, 1.0), (1e6, 1.0), (1e3, 1e-3), (1.0, 1e-6)]:
        for _ in range(6):
            a, b = far_points(kind, rng, rho, size), far_points(kind, rng, rho * rng.uniform(0.1, 1.0), size * 3)
            Xa, Xb = (
                cg.Primitive(X.blades, X.coeffs, kind) for X in map(lambda p: cg.primitive_from_points(kind, p), (a, b))
            )
            for pts_from, pts_to, f in [
                (a, b, lambda: sim.similarity(Xa, Xb)),
                (unit_points(kind), b, lambda: sim.similarity_from_unit(Xb)),
            ]:
                V, precision = _run(f)
                err = similarity_error(kind, pts_from, pts_to, V)
                assert len(precision) <= 1  # one warning for the similarity, not one per radius
                if precision:
                    warned += 1
                    est = float(_EST.search(str(precision[0].message)).group(1))
                    assert est > cg.geometry.primitives.PRECISION_WARN and err <= est, (rho, size, err, est)
                else:
                    assert err <= cg.geometry.primitives.PRECISION_WARN, (rho, size, err)
    assert warned >= 30  # the far ones did warn


@pytest.mark.parametrize("kind", ["line", "plane"])
def test_far_flats_lose_nothing_without_a_local_form(kind):
    """Lines and planes have no radius: their closest point and axis are ε-accurate from the
    coefficients alone (so they never warn), also for flats nearly through the origin."""
    rng = np.random.default_rng(3)
    worst = 0.0
    for rho in (1e3, 1e6, 1e9):
        for _ in range(5):
            a, b = far_points(kind, rng, rho, 1.0), far_points(kind, rng, rho, 1.0)
            Xa, Xb = (
                cg.Primitive(X.blades, X.coeffs, kind) for X in map(lambda p: cg.primitive_from_points(kind, p), (a, b))
            )
            V, precision = _run(lambda: sim.similarity(Xa, Xb))
            assert not precision
            worst = max(worst, similarity_error(kind, a, b, V))
    assert worst <= 1e-12, worst
