"""Versor groups: exp/log property tests on every group, behaviour conventions, log edge cases."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import coop_ga as cg
from coop_ga.algebra import Multivector
from coop_ga.geometry.groups import SIMILARITY_BLADES
from tests.helpers import central_difference

GROUPS = [cg.Rotor, cg.Translator, cg.Dilator, cg.Motor, cg.Similarity]


def tangent_strategy(group):
    """Tangents inside the principal range: rotation angle < π (log returns the shortest)."""
    n = len(group.tangent_slots)
    return arrays(np.float64, n, elements=st.floats(-2.0, 2.0, allow_nan=False)).filter(
        lambda v: _angle(group, v) < np.pi - 1e-3
    )


def _angle(group, v):
    slots = list(group.tangent_slots)
    th = [v[slots.index(i)] for i in (0, 1, 2) if i in slots]
    return float(np.linalg.norm(th)) if th else 0.0


def _same_versor_up_to_sign(A: Multivector, B: Multivector, atol=1e-9) -> bool:
    a, b = A.to_dense(), B.to_dense()
    return bool(np.allclose(a, b, atol=atol) or np.allclose(a, -b, atol=atol))


@pytest.mark.parametrize("group", GROUPS, ids=lambda g: g.__name__)
@given(data=st.data())
def test_log_exp_is_identity_in_principal_range(group, data):
    v = data.draw(tangent_strategy(group))
    g = group.exp(v)
    np.testing.assert_allclose(g.log(), v, atol=1e-9)


@pytest.mark.parametrize("group", GROUPS, ids=lambda g: g.__name__)
@given(data=st.data())
def test_exp_log_is_identity_and_unit_norm(group, data):
    v = data.draw(arrays(np.float64, len(group.tangent_slots), elements=st.floats(-6.0, 6.0, allow_nan=False)))
    g = group.exp(v)
    V = g.versor
    np.testing.assert_allclose((V * ~V).to_dense(), Multivector.scalar(1.0).to_dense(), atol=1e-9)
    back = group.exp(g.log()).versor
    assert _same_versor_up_to_sign(back, V)  # double cover: ±V is the same transformation


@pytest.mark.parametrize("group", GROUPS, ids=lambda g: g.__name__)
@given(data=st.data())
def test_composition_associative_and_inverse(group, data):
    vs = [
        data.draw(arrays(np.float64, len(group.tangent_slots), elements=st.floats(-2, 2, allow_nan=False)))
        for _ in range(3)
    ]
    a, b, c = (group.exp(v) for v in vs)
    lhs = ((a @ b) @ c).versor.to_dense()
    rhs = (a @ (b @ c)).versor.to_dense()
    np.testing.assert_allclose(lhs, rhs, atol=1e-9)
    ident = (a @ a.inverse()).versor.to_dense()
    np.testing.assert_allclose(ident, Multivector.scalar(1.0).with_blades(group.blades).to_dense(), atol=1e-9)


@given(
    arrays(np.float64, 7, elements=st.floats(-2, 2, allow_nan=False)),
    arrays(np.float64, 3, elements=st.floats(-3, 3, allow_nan=False)),
)
def test_similarity_acts_as_scale_rotate_translate(b, x):
    """exp(b) applied to a point equals t + e^β R x with R from scipy's rotation (independent)."""
    from scipy.spatial.transform import Rotation

    th12, th13, th23, beta, *t = b
    # e12 → +θ about z, e23 → +θ about x, e13 → −θ about y; the bivector generates one rotation
    rotvec = np.array([th23, -th13, th12])
    R = Rotation.from_rotvec(rotvec).as_matrix()
    want = np.array(t) + np.exp(beta) * R @ x
    got = cg.to_euclidean(cg.geometry.apply(cg.geometry.exp(b), cg.point(x)))
    np.testing.assert_allclose(got, want, atol=1e-9 * (1 + np.abs(want).max()))


def test_translation_rotation_conventions():
    x = np.array([1.0, 0.0, 0.0])
    got = cg.to_euclidean(cg.geometry.apply(cg.geometry.exp([0, 0, 0, 0, 0.1, 0.2, 0.3]), cg.point(x)))
    np.testing.assert_allclose(got, [1.1, 0.2, 0.3])
    got = cg.to_euclidean(cg.geometry.apply(cg.geometry.exp([np.pi / 2, 0, 0, 0, 0, 0, 0]), cg.point(x)))
    np.testing.assert_allclose(got, [0.0, 1.0, 0.0], atol=1e-15)  # +90° about +z


def test_dilation_scales_by_exp_beta():
    """Fig. 21: −1 on e0∞ gives d = 0.3679 and +1 gives d = 2.718 (Eq 67 literally is the inverse)."""
    x = np.array([0.3, -0.4, 1.2])
    for beta, d in [(-1.0, 0.3679), (1.0, 2.718)]:
        got = cg.to_euclidean(cg.geometry.apply(cg.geometry.exp([0, 0, 0, beta, 0, 0, 0]), cg.point(x)))
        np.testing.assert_allclose(got, d * x, rtol=2e-4)
    # Eq 67 as printed: cosh(β/2) − sinh(β/2) e0∞ scales by e^{−β}
    beta = 1.0
    eq67 = Multivector.from_names({"1": np.cosh(beta / 2), "e0inf": -np.sinh(beta / 2)})
    got = cg.to_euclidean(cg.geometry.apply(eq67, cg.point(x)))
    np.testing.assert_allclose(got, np.exp(-beta) * x)


@pytest.mark.parametrize("angle", [0.0, 1e-12, 1e-8, 1e-5, 1e-3, 0.5, 3.0, np.pi - 1e-9])
def test_rotor_log_exact_near_zero_and_up_to_pi(angle):
    axis = np.array([0.2, -0.7, 0.4])
    axis /= np.linalg.norm(axis)
    v = angle * axis
    got = cg.Rotor.exp(v).log()
    np.testing.assert_allclose(got, v, rtol=1e-12, atol=1e-15)


def test_rotor_log_at_pi_and_beyond_returns_shortest():
    v = np.array([np.pi, 0.0, 0.0])
    got = cg.Rotor.exp(v).log()
    assert np.isclose(np.linalg.norm(got), np.pi)
    v = np.array([0.0, 0.0, 1.5 * np.pi])
    got = cg.Rotor.exp(v).log()
    np.testing.assert_allclose(got, [0.0, 0.0, -0.5 * np.pi], atol=1e-12)


def test_log_rejects_invalid_versors_without_nan():
    with pytest.raises(cg.InvalidVersorError, match="zero"):
        cg.geometry.log(Multivector.scalar(0.0).with_blades(SIMILARITY_BLADES))
    with pytest.raises(cg.InvalidVersorError, match="not a similarity"):
        cg.geometry.log(Multivector.from_names({"1": 1.0, "e01": 0.5}))  # a transversion component
    with pytest.raises(cg.NonFiniteError):
        cg.geometry.log(Multivector.from_names({"1": np.nan}))
    with pytest.raises(cg.NonFiniteError):
        cg.geometry.exp([0, 0, np.inf, 0, 0, 0, 0])
    with pytest.raises(cg.InvalidInputError, match="shape"):
        cg.geometry.exp([0, 0, 0])
    with pytest.raises(cg.InvalidVersorError, match="not a Rotor"):
        cg.Rotor(cg.geometry.exp([0, 0, 0, 0, 1.0, 0, 0]))


def test_log_is_scale_invariant():
    b = np.array([0.3, 0.2, -0.1, 0.5, 1.0, 2.0, -1.0])
    np.testing.assert_allclose(cg.geometry.log(cg.geometry.exp(b).scale(3.5)), b, atol=1e-12)
    np.testing.assert_allclose(cg.geometry.log(cg.geometry.exp(b).scale(-3.5)), b, atol=1e-12)


def test_relative_log_in_v1_frame():
    b1 = np.array([0.3, 0.2, -0.1, 0.5, 1.0, 2.0, -1.0])
    d = np.array([0.0, 0.0, 0.0, 0.0, 0.1, 0.0, 0.0])  # body-frame translation along x
    V1 = cg.geometry.exp(b1)
    V2 = V1 * cg.geometry.exp(d)
    np.testing.assert_allclose(cg.geometry.log(~V1 * V2), d, atol=1e-12)


def test_log_jacobian_matches_finite_differences(rng):
    b = np.array([0.3, 0.2, -0.1, 0.5, 1.0, 2.0, -1.0])
    V = cg.geometry.exp(b)
    x0 = np.array([V.get(k) for k in SIMILARITY_BLADES])

    def f(x):
        return cg.geometry.log(Multivector(SIMILARITY_BLADES, tuple(x)))

    J = cg.geometry.log_jacobian(V)
    np.testing.assert_allclose(J, central_difference(f, x0, 1e-6), atol=1e-7)


def test_decomposition_reassembles():
    b = np.array([0.3, 0.2, -0.1, 0.5, 1.0, 2.0, -1.0])
    S = cg.Similarity.exp(b)
    T, R, D = S.decompose()
    np.testing.assert_allclose(T.log(), b[4:], atol=1e-12)
    np.testing.assert_allclose(R.log(), b[:3], atol=1e-12)
    np.testing.assert_allclose(D.log(), b[3:4], atol=1e-12)
    np.testing.assert_allclose((T @ R @ D).versor.to_dense(), S.versor.to_dense(), atol=1e-12)


def test_group_join_types():
    assert isinstance(cg.Rotor.exp([0.1, 0, 0]) @ cg.Translator.exp([1, 0, 0]), cg.Motor)
    assert isinstance(cg.Motor.identity() @ cg.Dilator.exp([0.2]), cg.Similarity)
