"""coop_ga.Similarity, the currency of the API: coefficients, parts, group operations, coercion."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import coop_ga as cg
from coop_ga.geometry.groups import SIMILARITY_BLADES

tangents = arrays(np.float64, 7, elements=st.floats(-2.0, 2.0, allow_nan=False))


@given(b=tangents)
def test_coeffs_round_trip_and_normalisation(b):
    S = cg.Similarity.exp(b)
    assert S.coeffs.shape == (12,) and not S.coeffs.flags.writeable
    T = cg.Similarity.from_coeffs(3.0 * S.coeffs)  # a positive multiple is the same element, stored unit
    np.testing.assert_allclose(T.coeffs, S.coeffs, atol=1e-14)
    VV = (T.versor * T.versor.reverse()).to_dense()
    np.testing.assert_allclose(VV, cg.Multivector.scalar(1.0).to_dense(), atol=1e-13)


@given(b1=tangents, b2=tangents)
def test_compose_inverse_apply(b1, b2):
    A, B = cg.Similarity.exp(b1), cg.Similarity.exp(b2)
    AB = A @ B
    assert isinstance(AB, cg.Similarity)
    np.testing.assert_allclose((A * B).coeffs, AB.coeffs, atol=1e-14)  # CGA notation: product = composition
    np.testing.assert_allclose(A.compose(B).coeffs, AB.coeffs, atol=1e-14)
    I = AB @ AB.inverse()
    np.testing.assert_allclose(I.log(), 0.0, atol=1e-12)
    np.testing.assert_allclose((~A).coeffs, A.inverse().coeffs, atol=1e-15)
    X = cg.circle([1.0, 0, 0], [0, 1.0, 0], [-1.0, 0.2, 0])
    Y = AB.apply(X)
    Z = A.apply(B.apply(X))
    np.testing.assert_allclose(Y.to_dense(), Z.to_dense(), atol=1e-10 * np.abs(Y.to_dense()).max())
    assert Y.kind == "circle"


def test_from_parts_read_outs():
    S = cg.Similarity.from_parts(translation=(0.1, -0.2, 0.3), axis=(0, 0, 2.0), angle=0.4, scale=1.5)
    np.testing.assert_allclose(S.translation, [0.1, -0.2, 0.3], atol=1e-14)
    c, s_ = np.cos(0.4), np.sin(0.4)
    np.testing.assert_allclose(S.rotation_matrix, [[c, -s_, 0], [s_, c, 0], [0, 0, 1]], atol=1e-14)
    assert S.scale == pytest.approx(1.5, rel=1e-14)
    p = np.array([0.3, 0.7, -0.2])
    moved = cg.to_euclidean(S.apply(cg.point(p)))
    np.testing.assert_allclose(
        np.asarray(moved, float).reshape(3), 1.5 * S.rotation_matrix @ p + S.translation, atol=1e-13
    )


def test_between_and_from_unit():
    X = cg.circle([1.0, 0.2, 0], [0, 1.3, 0.1], [-1.0, 0.0, 0.3])
    V = cg.Similarity.from_unit(X)
    np.testing.assert_allclose(V.coeffs, cg.Similarity(cg.geometry.similarity_from_unit(X)).coeffs, atol=1e-15)
    Y = cg.circle([2.0, 0.2, 0], [0, 1.0, 0.5], [-1.0, 0.5, 0.3])
    W = cg.Similarity.between(X, Y)
    Z = W.apply(X)
    lam = float(Z.to_dense() @ Y.to_dense() / (Y.to_dense() @ Y.to_dense()))
    assert lam > 0
    np.testing.assert_allclose(Z.to_dense(), lam * Y.to_dense(), atol=1e-10)


def test_log_jacobian_matches_the_function():
    S = cg.Similarity.exp([0.1, 0.2, -0.3, 0.2, 0.5, -1.0, 0.3])
    np.testing.assert_allclose(S.log_jacobian(), cg.geometry.log_jacobian(S.versor), atol=1e-15)
    assert S.log_jacobian().shape == (7, 12)


def test_subgroups_convert_to_similarity():
    M = cg.Motor.exp([0.1, 0.0, 0.2, 0.3, 0.0, -0.1])
    S = cg.Similarity.coerce(M)
    assert isinstance(S, cg.Similarity)
    np.testing.assert_allclose(S.log(), [0.1, 0.0, 0.2, 0.0, 0.3, 0.0, -0.1], atol=1e-14)
    assert cg.Similarity.coerce(S) is S


@pytest.mark.parametrize(
    ("bad", "match"),
    [
        (cg.point_pair([0, 0, 0], [1, 0, 0]), "Primitive"),
        ((cg.Similarity.identity(), None), "tuple"),
        (cg.Multivector.zero(), "zero"),
        (cg.Multivector.from_names({"e1": 1.0}), "not a similarity"),
        (np.ones(12), "from_coeffs"),
        ([1.0] * 12, "from_coeffs"),
        ("identity", "str"),
        (None, "NoneType"),
        (cg.Multivector(SIMILARITY_BLADES, tuple(ca.SX.sym("v", 12)[i] for i in range(12))), "symbolic"),
    ],
)
def test_coerce_refuses_everything_else(bad, match):
    with pytest.raises(cg.InvalidInputError, match=match):
        cg.Similarity.coerce(bad, "target")


@pytest.mark.parametrize(
    "bad", [np.ones(11), np.full(12, np.nan), "abc", None, np.ones(12, dtype=complex), [True] * 12]
)
def test_from_coeffs_refuses_bad_input(bad):
    with pytest.raises(cg.InvalidInputError):
        cg.Similarity.from_coeffs(bad)
    with pytest.raises(cg.InvalidInputError):
        cg.Similarity.from_coeffs(np.zeros(12))  # the zero versor
