"""Similarity between primitives (§3.3): ≥200 random pairs per kind, antiparallel cases, decomposition."""

from __future__ import annotations

import zlib

import numpy as np
import pytest

import coop_ga as cg
from coop_ga.geometry import N_POINTS
from tests.helpers import proportionality

ORIENTED = {"point", "point_pair", "line", "circle", "plane"}


@pytest.mark.parametrize("kind", cg.KINDS)
def test_similarity_maps_random_pairs(kind):
    rng = np.random.default_rng(zlib.crc32(kind.encode()))  # fixed per kind, never hash()
    n = N_POINTS[kind]
    for _ in range(200):
        X1 = cg.primitive_from_points(kind, list(rng.normal(size=(n, 3)) * 2))
        X2 = cg.primitive_from_points(kind, list(rng.normal(size=(n, 3)) * 2))
        V = cg.geometry.similarity(X1, X2)
        lam, res = proportionality(cg.geometry.apply(V, X1), X2)
        assert res < 1e-9, (kind, res)
        if kind in ORIENTED:
            assert lam > 0  # orientation kept: no sign flip
        np.testing.assert_allclose((V * ~V).to_dense()[0], 1.0, atol=1e-9)


@pytest.mark.parametrize(
    "kind, pts",
    [
        ("point_pair", [[0, 1, 0], [0, -1, 0]]),  # pointing along −e2
        ("point_pair", [[2, 5, 1], [2, 3, 1]]),
        ("line", [[1, 0, 0], [1, -1, 0]]),
        ("circle", [[1, 0, 0], [-1, 0, 0], [0, 1, 0]]),  # clockwise: normal −e3
        ("circle", [[0, 0, 3], [2, 0, 3], [0, 2, 3]][::-1]),
        ("plane", [[0, 0, 1], [0, 1, 1], [1, 0, 1]]),  # normal −e3
    ],
)
def test_antiparallel_to_unit_primitive(kind, pts):
    X = cg.primitive_from_points(kind, [np.array(p, float) for p in pts])
    Xu = cg.unit_primitive(kind)
    for V, A, B in (
        (cg.geometry.similarity_from_unit(X), Xu, X),
        (cg.geometry.similarity(Xu, X), Xu, X),
        (cg.geometry.similarity(X, Xu), X, Xu),
    ):
        lam, res = proportionality(cg.geometry.apply(V, A), B)
        assert res < 1e-12 and lam > 0
        # a half-turn: rotation angle π
        assert np.isclose(np.linalg.norm(cg.geometry.log(V)[:3]), np.pi)


def test_similarity_between_reversed_point_pairs():
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(2, 3))
    V = cg.geometry.similarity(cg.point_pair(a, b), cg.point_pair(b, a))
    lam, res = proportionality(cg.geometry.apply(V, cg.point_pair(a, b)), cg.point_pair(b, a))
    assert res < 1e-12 and lam > 0
    assert np.isclose(np.linalg.norm(cg.geometry.log(V)[:3]), np.pi)


def test_decomposition_of_similarity():
    rng = np.random.default_rng(1)
    X1 = cg.circle(*rng.normal(size=(3, 3)))
    X2 = cg.circle(*rng.normal(size=(3, 3)))
    V = cg.geometry.similarity(X1, X2)
    VT, VR, VD = cg.geometry.decompose(V)
    np.testing.assert_allclose((VT * VR * VD).to_dense(), V.to_dense(), atol=1e-12)
    # the dilation is the ratio of radii, the rotation maps normal to normal
    beta = cg.geometry.log(VD.with_blades(cg.geometry.groups.SIMILARITY_BLADES))[3]
    assert np.isclose(np.exp(beta), cg.radius(X2) / cg.radius(X1))
    n1 = cg.normal(X1)
    Rn1 = cg.to_euclidean(cg.geometry.apply(VR, cg.point(n1)))
    np.testing.assert_allclose(Rn1, cg.normal(X2), atol=1e-12)


def test_similarity_from_unit_reads_parameters():
    c, r = np.array([0.4, -0.2, 1.1]), 0.37
    pts = c + r * np.array([[1, 0, 0], [0, 1, 0], [-1, 0, 0]], float)
    V = cg.geometry.similarity_from_unit(cg.circle(*pts))
    np.testing.assert_allclose(cg.geometry.log(V), [0, 0, 0, np.log(r), *c], atol=1e-12)


def test_mismatched_kinds_raise():
    with pytest.raises(cg.InvalidInputError, match="same kind"):
        cg.geometry.similarity(cg.unit_primitive("circle"), cg.unit_primitive("sphere"))


def test_unit_primitives_match_table1():
    np.testing.assert_allclose(cg.center(cg.unit_primitive("sphere")), 0, atol=1e-15)
    assert np.isclose(cg.radius(cg.unit_primitive("sphere")), 1)
    assert np.isclose(cg.radius(cg.unit_primitive("circle")), 1)
    np.testing.assert_allclose(cg.normal(cg.unit_primitive("circle")), [0, 0, 1])
    np.testing.assert_allclose(cg.normal(cg.unit_primitive("plane")), [0, 0, 1])
    np.testing.assert_allclose(cg.direction(cg.unit_primitive("line")), [0, 1, 0])
    a, b = cg.endpoints(cg.unit_primitive("point_pair"))
    np.testing.assert_allclose(a, [0, -1, 0], atol=1e-15)
    np.testing.assert_allclose(b, [0, 1, 0], atol=1e-15)
    np.testing.assert_allclose(cg.to_euclidean(cg.unit_primitive("point")), 0)
