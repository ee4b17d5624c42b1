"""The algebra against an independent matrix representation of Cl(4,1), plus the paper's identities."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from coop_ga.algebra import Multivector, blade_index, grade_of
from coop_ga.algebra.multivector import _plan
from coop_ga.errors import InvalidVersorError
from coop_ga.geometry.groups import MOTOR_BLADES, SIMILARITY_BLADES
from tests.algebra import reference as ref

finite = st.floats(-3, 3, allow_nan=False, allow_infinity=False)
dense32 = arrays(np.float64, 32, elements=finite)


def mv(d: np.ndarray) -> Multivector:
    return Multivector(tuple(range(32)), tuple(float(x) for x in d))


def dense(X: Multivector) -> np.ndarray:
    return X.to_dense()


def test_null_basis_metric_matches_paper():
    e0, einf = Multivector.blade("e0"), Multivector.blade("einf")
    assert (e0 | einf).get(0) == -1.0  # e0·e∞ = −1
    assert (e0 * e0).prune().blades == ()
    assert (einf * einf).prune().blades == ()
    for k in ("e1", "e2", "e3"):
        b = Multivector.blade(k)
        assert (b * b).get(0) == 1.0
    # e4 = ½e∞ − e0 squares to +1 and e5 = e0 + ½e∞ to −1
    e4 = einf.scale(0.5) - e0
    e5 = e0 + einf.scale(0.5)
    assert np.isclose((e4 * e4).get(0), 1.0) and np.isclose((e5 * e5).get(0), -1.0)
    I = Multivector.blade("e0123inf")
    assert (I * I).get(0) == -1.0


@given(dense32, dense32)
def test_geometric_product_is_the_matrix_product(a, b):
    got = dense(mv(a) * mv(b))
    want = ref.from_matrix(ref.to_matrix(a) @ ref.to_matrix(b))
    np.testing.assert_allclose(got, want, atol=1e-9 * (1 + np.abs(want).max()))


@given(arrays(np.float64, (3, 5), elements=finite))
def test_outer_product_of_vectors_is_antisymmetrised_product(vs):
    # vectors in the null basis: blades e0, e1, e2, e3, e∞ are bits 0..4
    vec = [Multivector((1, 2, 4, 8, 16), tuple(v)) for v in vs]
    M = [ref.to_matrix(dense(x)) for x in vec]
    got = dense(vec[0] ^ vec[1] ^ vec[2])
    from itertools import permutations

    acc = np.zeros((4, 4), dtype=complex)
    for p in permutations(range(3)):
        acc += ref._perm_sign(p) * M[p[0]] @ M[p[1]] @ M[p[2]]
    want = ref.from_matrix(acc / 6)
    np.testing.assert_allclose(got, want, atol=1e-9 * (1 + np.abs(want).max()))


@given(arrays(np.float64, 5, elements=finite), dense32)
def test_left_contraction_of_a_vector(v, b):
    # for a vector a: a⌋B = ½(aB − B̂a)
    a = Multivector((1, 2, 4, 8, 16), tuple(v))
    B = mv(b)
    got = dense(a | B)
    want = 0.5 * dense(a * B - B.involute() * a)
    np.testing.assert_allclose(got, want, atol=1e-9 * (1 + np.abs(want).max()))


@given(dense32, dense32, dense32)
def test_associative_and_reverse_antihomomorphism(a, b, c):
    A, Bm, C = mv(a), mv(b), mv(c)
    lhs, rhs = dense((A * Bm) * C), dense(A * (Bm * C))
    np.testing.assert_allclose(lhs, rhs, atol=1e-8 * (1 + np.abs(lhs).max()))
    np.testing.assert_allclose(dense(~(A * Bm)), dense(~Bm * ~A), atol=1e-8 * (1 + np.abs(lhs).max()))


@given(arrays(np.float64, 3, elements=finite), arrays(np.float64, 3, elements=finite))
def test_conformal_points_inner_product_is_minus_half_squared_distance(x, y):
    from coop_ga import point

    got = (point(x) | point(y)).get(0)
    assert np.isclose(got, -0.5 * np.sum((x - y) ** 2), atol=1e-9)
    assert np.allclose(dense(point(x) * point(x)), 0.0, atol=1e-9)  # null vectors


def test_dual_undual_roundtrip_and_grade():
    rng = np.random.default_rng(0)
    X = mv(rng.normal(size=32)).grade(2)
    assert set(X.dual().prune().grades) == {3}
    np.testing.assert_allclose(dense(X.dual().undual()), dense(X), atol=1e-12)


def test_inverse_eq80_for_versor_and_error_for_non_invertible():
    from coop_ga.geometry import exp

    V = exp(np.array([0.3, -0.2, 0.1, 0.4, 1.0, -2.0, 0.5]))
    np.testing.assert_allclose(dense(V * V.inverse()), dense(Multivector.scalar(1.0)), atol=1e-12)
    with pytest.raises(InvalidVersorError, match="zero norm"):
        Multivector.blade("e0").inverse()  # null vector


def test_sparse_products_never_go_dense():
    # a motor×motor product touches 8×8 blade pairs, similarity×similarity 12×12
    blades, fn = _plan("gp", MOTOR_BLADES, MOTOR_BLADES)
    assert set(blades) == set(MOTOR_BLADES)
    n_mults = fn.__code__.co_consts  # generated straight-line code
    src_terms = sum(1 for _ in blades)
    assert src_terms == 8
    blades, _ = _plan("gp", SIMILARITY_BLADES, SIMILARITY_BLADES)
    assert set(blades) == set(SIMILARITY_BLADES)
    assert n_mults is not None


def test_symbolic_coefficients_same_numbers():
    rng = np.random.default_rng(3)
    a, b = rng.normal(size=32), rng.normal(size=32)
    x = ca.SX.sym("x", 32)
    y = ca.SX.sym("y", 32)
    Xs = Multivector(tuple(range(32)), tuple(x[i] for i in range(32)))
    Ys = Multivector(tuple(range(32)), tuple(y[i] for i in range(32)))
    Z = Xs * Ys
    f = ca.Function("f", [x, y], [ca.vertcat(*Z.coeffs)])
    got = np.zeros(32)
    got[list(Z.blades)] = np.array(f(a, b)).ravel()
    np.testing.assert_allclose(got, dense(mv(a) * mv(b)), atol=1e-12)


def test_blade_names_and_signs():
    assert blade_index("e21") == (blade_index("e12")[0], -1)
    assert blade_index("e1inf") == blade_index("e1∞")
    assert grade_of(blade_index("e0123inf")[0]) == 5
    X = Multivector.from_names({"e21": 2.0})
    assert X["e12"] == -2.0


def test_batched_numpy_coefficients():
    from coop_ga import point

    xs = np.random.default_rng(1).normal(size=(10, 3))
    P = point(xs)
    single = np.stack([dense(point(x)) for x in xs], axis=1)
    np.testing.assert_allclose(dense(P), single)
