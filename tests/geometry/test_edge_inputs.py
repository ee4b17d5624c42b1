"""Valid inputs at the edges of the float range that were refused with wrong messages."""

from __future__ import annotations

import numpy as np
import pytest

import coop_ga as cg
from coop_ga.algebra import Multivector
from coop_ga.errors import DegeneratePrimitiveError, InvalidInputError
from tests.geometry.test_far_precision import exact_parameters

UNIT_SPHERE_PTS = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]


@pytest.mark.parametrize("tiny", [1e-308, 5e-324, 1e-200, 1e-160])
@pytest.mark.parametrize("kind", ["point_pair", "circle", "sphere"])
def test_rounds_with_a_tiny_coordinate_are_read_exactly(kind, tiny):
    """Old: a sphere through (1e-308, 0, 0), (0, 1, 0), (−1, 0, 0), (0, 0, 1) — it passes within 1e-308 m
    of the origin, so its e∞-part is 5e-309 — raised "the sphere's radius is beyond the float64 range":
    the exact rescaling read its size from that e∞-part alone and dilated it by 2^512."""
    n = cg.geometry.N_POINTS[kind]
    pts = np.array(UNIT_SPHERE_PTS[:n])
    pts[0, 0] = tiny
    X = cg.primitive_from_points(kind, list(pts))
    c, r2, _ = exact_parameters(kind, pts)
    for Y in (X, Multivector(X.blades, X.coeffs), X.scale(1e-300), X.scale(1e200)):
        assert cg.radius(Y) == pytest.approx(float(np.sqrt(float(r2))), rel=1e-15)
        np.testing.assert_allclose(cg.center(Y), [float(v) for v in c], rtol=0, atol=4e-16)
    S = cg.Similarity.from_unit(X)
    assert S.scale == pytest.approx(float(np.sqrt(float(r2))), rel=1e-15)
    np.testing.assert_allclose(S.translation, [float(v) for v in c], rtol=0, atol=4e-16)


def test_a_batch_of_points_with_different_weights_is_read_point_by_point():
    """Old: the weight of each point was compared with the largest coefficient of the whole batch, so the
    origin with weight 1e-20 next to a point of weight 1 was refused ("zero e0 weight")."""
    P = cg.point(np.array([[0.0, 0.0, 0.0], [1.0, 2.0, 3.0], [4.0, 0.0, -1.0]]))
    lam = np.array([1e-20, 1.0, 1e30])
    Q = Multivector(P.blades, tuple(c * lam for c in P.coeffs))
    np.testing.assert_array_equal(cg.to_euclidean(Q), [[0.0, 0.0, 0.0], [1.0, 2.0, 3.0], [4.0, 0.0, -1.0]])
    with pytest.raises(DegeneratePrimitiveError, match="zero e0 weight"):  # a direction in the batch still is one
        cg.to_euclidean(Multivector(P.blades, tuple(c * np.array([0.0, 1.0, 1.0]) for c in P.coeffs)))


@pytest.mark.parametrize("x", [[0.0, 0.0, 0.0], [1.0, 2.0, 3.0], [1e8, -2.0, 0.5]])
def test_the_flat_point_where_a_line_meets_a_plane_is_read(x):
    """Old: ``to_euclidean(meet(line, plane))`` — the flat point P(x)∧e∞ — raised "zero e0 weight"
    (its weight is on e0∞), also at the origin where meet gives −2 e0∞."""
    x = np.array(x)
    L = cg.line(x + [0.3, -0.2, -1.0], x + [-0.3, 0.2, 1.0])
    E = cg.plane(x, x + [1.0, 0.0, 0.1], x + [0.0, 1.0, 0.2])
    F = cg.meet(L, E)
    assert set(F.grades) == {2}
    np.testing.assert_allclose(cg.to_euclidean(F), x, rtol=0, atol=1e-15 * max(1.0, float(np.max(np.abs(x)))))
    np.testing.assert_allclose(cg.to_euclidean(F.scale(-1e-250)), cg.to_euclidean(F), rtol=1e-15, atol=1e-300)


def test_other_primitives_are_refused_with_a_message_naming_them():
    """Old: every non-point was refused as "zero e0 weight (a point at infinity or a direction)"."""
    with pytest.raises(InvalidInputError, match=r"not a flat point.*point_pair.*endpoints"):
        cg.to_euclidean(cg.point_pair([1.0, 2.0, -1.0], [1.0, 2.0, 1.0]))
    with pytest.raises(InvalidInputError, match=r"grades \[3\].*center\(\)"):
        cg.to_euclidean(cg.circle([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]))
    with pytest.raises(DegeneratePrimitiveError, match="zero e0 weight"):
        cg.to_euclidean(Multivector.zero())
