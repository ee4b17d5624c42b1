"""Every fact of the kind table (:data:`coop_ga.geometry.KIND_SPECS`) checked against computation, kind by kind.

A new row of the table is tested here without a new line of test: its number of points against
:class:`~coop_ga.cooperative.CooperativeTask`, its grade and flatness against the blade it builds, its unit
primitive and axis against the geometry read-outs, its DOF against the rank of J^G at random configurations,
its Table 1 blades against the measured span of J^G (exact at X_u; elsewhere only where the table says so —
docs/table1.md measured where the paper's column holds), its degeneracy wording against the errors that
degenerate points raise, its coefficient degree against how the coefficients scale, and its least-squares
partner against the fit.
"""

from __future__ import annotations

import numpy as np
import pytest

import coop_ga as cg
from coop_ga.cooperative import CooperativeTask
from coop_ga.cooperative.primitive import fit_primitive
from coop_ga.geometry import (
    COOPERATIVE_KINDS,
    FIT_KINDS,
    KIND_SPECS,
    KINDS,
    TANGENT_BASIS,
    KindSpec,
    kind_of,
    kind_spec,
    primitive_parameters,
    unit_primitive,
)
from coop_ga.geometry.similarity import similarity, similarity_from_unit
from coop_ga.systems import cartesian_points

# six chain bases spread in 3-D (the end point of chain i is bases[i] + q[3i:3i+3])
BASES6 = np.array(
    [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.3], [0.5, 0.5, -0.7]]
)
#: a least-squares kind is also checked with more points than it needs
FIT_POINTS = 6
RANK_RTOL = 1e-8


def _task(spec: KindSpec, k: int | None = None) -> CooperativeTask:
    k = spec.n_points if k is None else k
    return CooperativeTask(cartesian_points(k, BASES6[:k]), spec.name, codegen=False)


def _q(points: np.ndarray) -> np.ndarray:
    return (np.asarray(points, float) - BASES6[: len(points)]).reshape(-1)


def _rank(J: np.ndarray) -> int:
    s = np.linalg.svd(J, compute_uv=False)
    return int(np.sum(s > RANK_RTOL * s[0]))


def _blade_rows(spec: KindSpec) -> tuple[list[int], list[int]]:
    allowed = [TANGENT_BASIS.index(b) for b in spec.controllable_blades]
    return allowed, [i for i in range(7) if i not in allowed]


def _degenerate_points(spec: KindSpec, k: int, rng: np.random.Generator) -> np.ndarray:
    """k points in an affine subspace of dimension n_points − 2 (coincident, collinear, coplanar); dyadic, so
    that ``base + (p − base)`` is p exactly (two points one ulp apart are well defined, w ≈ ½)."""
    d = spec.n_points - 2
    P = np.zeros((k, 3))
    P[:, :d] = rng.integers(-8, 9, size=(k, d)) / 16.0
    return P + np.array([0.25, -0.125, 0.375])


@pytest.mark.parametrize("kind", COOPERATIVE_KINDS)
def test_number_of_points_is_what_the_task_uses(kind: str) -> None:
    spec = KIND_SPECS[kind]
    six = CooperativeTask(cartesian_points(FIT_POINTS, BASES6), kind, codegen=False)
    assert len(six.end_frames) == (FIT_POINTS if spec.least_squares else spec.n_points)
    assert len(_task(spec).end_frames) == spec.n_points
    if spec.n_points > 1:
        with pytest.raises(cg.InvalidInputError, match=f"{spec.n_points}"):
            CooperativeTask(cartesian_points(spec.n_points - 1, BASES6), kind, codegen=False)
    assert six.primitive_kind == spec.primitive_kind and six.spec is spec


@pytest.mark.parametrize("kind", KINDS)
def test_grade_flatness_and_unit_primitive_against_the_geometry(kind: str) -> None:
    spec = KIND_SPECS[kind]
    X = unit_primitive(kind)
    assert X.kind == kind and X.spec is spec
    untagged = cg.Multivector(X.blades, X.coeffs)
    assert kind_of(untagged) == kind  # grade and flatness decide the kind
    assert set(untagged.prune(1e-14).grades) == {spec.grade}
    W = (untagged ^ cg.Multivector.blade("einf")).prune(1e-14)  # X ∧ e∞ = 0 exactly for the flats
    assert (len(W.blades) == 0) == spec.flat
    _, c, r, o = primitive_parameters(X)
    np.testing.assert_allclose(c, 0.0, atol=1e-15)  # X_u is centred at (or passes through) the origin
    if spec.has_radius:
        assert r == pytest.approx(1.0, abs=1e-15)
    else:
        assert r is None
    if spec.axis is None:
        assert o is None and spec.axis_role is None and spec.half_turn_axis is None
    else:
        read = cg.direction if spec.axis_role == "direction" else cg.normal
        np.testing.assert_allclose(read(X), spec.axis, atol=1e-15)
        np.testing.assert_allclose(o, spec.axis, atol=1e-15)
        assert float(np.dot(spec.half_turn_axis, spec.axis)) == 0.0
    np.testing.assert_allclose(
        cg.Similarity(similarity_from_unit(X)).coeffs, cg.Similarity.identity().coeffs, atol=1e-15
    )
    assert spec.dimension == _set_dimension(X, np.array(spec.unit_points[0]))


def _set_dimension(X: cg.Multivector, x0: np.ndarray) -> int:
    """Dimension of the point set {x : P(x) ∧ X = 0} at its point x0: 3 − rank of x ↦ P(x) ∧ X there."""
    einf = cg.Multivector.blade("einf")
    cols = [(cg.Multivector.blade(f"e{i + 1}") + einf.scale(float(x0[i]))) ^ X for i in range(3)]
    blades = sorted({b for c in cols for b in c.blades})
    J = np.array([[float(c.get(b)) for b in blades] for c in cols])
    return 3 - int(np.linalg.matrix_rank(J, tol=1e-12))


@pytest.mark.parametrize("kind", [k for k in KINDS if KIND_SPECS[k].axis is not None])
def test_half_turn_axis_is_the_rotation_axis_to_the_opposite_primitive(kind: str) -> None:
    """Reversing the unit points flips the axis; the similarity is then the half-turn about half_turn_axis."""
    spec = KIND_SPECS[kind]
    pts = [np.array(p) for p in spec.unit_points]
    flipped = cg.primitive_from_points(kind, pts[::-1] if spec.axis_role == "direction" else [pts[0], pts[2], pts[1]])
    V = cg.Similarity(similarity(unit_primitive(kind), flipped))
    Rm = V.rotation_matrix
    np.testing.assert_allclose(Rm @ np.array(spec.axis), -np.array(spec.axis), atol=1e-15)
    np.testing.assert_allclose(Rm @ np.array(spec.half_turn_axis), spec.half_turn_axis, atol=1e-15)


@pytest.mark.parametrize("kind", COOPERATIVE_KINDS)
def test_dof_is_the_rank_of_the_similarity_jacobian(kind: str) -> None:
    spec = KIND_SPECS[kind]
    rng = np.random.default_rng(COOPERATIVE_KINDS.index(kind))
    for k in sorted({spec.n_points, FIT_POINTS if spec.least_squares else spec.n_points}):
        task = _task(spec, k)
        for _ in range(10):
            assert _rank(task.jacobian(rng.uniform(-0.4, 0.4, task.nq))) == spec.dof, (kind, k)
    assert spec.dof == len(spec.controllable_blades)  # Table 1's dimension column


@pytest.mark.parametrize("kind", COOPERATIVE_KINDS)
def test_table1_blades_against_the_measured_span(kind: str) -> None:
    """At X_c = X_u the paper's blades span the range of J^G exactly; elsewhere only where the table says so
    (docs/table1.md: the minimal-rotation chart couples roll into excluded rows for the kinds with an axis)."""
    spec = KIND_SPECS[kind]
    task = _task(spec)
    allowed, excluded = _blade_rows(spec)
    q = _q(np.array(spec.unit_points))
    np.testing.assert_allclose(task.log(q), 0.0, atol=1e-12)  # V_Sc = 1
    J = task.jacobian(q)
    assert np.abs(J[excluded]).max(initial=0.0) < 1e-12
    assert np.linalg.matrix_rank(J[allowed], tol=1e-9) == len(allowed)
    rng = np.random.default_rng(7)
    off = []
    for _ in range(20):
        U, s, _ = np.linalg.svd(task.jacobian(rng.uniform(-0.4, 0.4, task.nq)), full_matrices=False)
        Ur = U[:, : int(np.sum(s > RANK_RTOL * s[0]))]
        off.append(float(np.linalg.norm(Ur[excluded], 2)) if excluded else 0.0)
    if spec.blades_hold_everywhere:
        assert max(off) < 1e-9
    else:
        assert max(off) > 1e-2  # measured median 0.15 … 0.60 (docs/table1.md)


@pytest.mark.parametrize("kind", [k for k in COOPERATIVE_KINDS if KIND_SPECS[k].n_points > 1])
def test_degeneracy_wording_is_what_degenerate_points_raise(kind: str) -> None:
    spec = KIND_SPECS[kind]
    rng = np.random.default_rng(3)
    k = FIT_POINTS if spec.least_squares else spec.n_points
    P = _degenerate_points(spec, k, rng)
    task = CooperativeTask(cartesian_points(k, BASES6[:k]), kind, codegen=False)
    with pytest.raises(cg.DegeneratePrimitiveError) as err:
        task.evaluate(_q(P))
    assert spec.degeneracy in str(err.value)
    if spec.least_squares:
        with pytest.raises(cg.DegeneratePrimitiveError) as err:
            fit_primitive(kind, P)
        assert spec.degeneracy in str(err.value)
    else:
        with pytest.raises(cg.DegeneratePrimitiveError) as err:
            cg.primitive_from_points(kind, list(P))
        assert spec.degenerate in str(err.value) and spec.advice in str(err.value)
        assert cg.well_definedness(kind, P) == 0.0
        Q = P.copy()
        Q[-1, spec.n_points - 2] += 0.5  # out of the subspace: well defined
        assert cg.well_definedness(kind, Q) > 0.1


@pytest.mark.parametrize("kind", KINDS)
def test_max_degree_is_how_the_coefficients_scale(kind: str) -> None:
    """max_degree is the largest length degree of the kind's blades (Euclidean generators + 2 for e∞); a round's
    coefficients are homogeneous polynomials of the point coordinates of that degree (scaling the points by 2^s
    scales the largest by 2^(s·max_degree)), a flat's of two degrees less: its e∞ factor is exact, so the bound
    on its coordinates is conservative."""
    from coop_ga.geometry.primitives import _degree

    spec = KIND_SPECS[kind]
    P = np.random.default_rng(5).normal(size=(spec.n_points, 3))
    assert max(_degree(b) for b in cg.primitive_from_points(kind, list(P)).prune(0.0).blades) == spec.max_degree
    s = 20  # between 2^20 and 2^40 the top degree dominates
    big, small = (cg.primitive_from_points(kind, list(P * 2.0**e)) for e in (2 * s, s))
    ratio = max(abs(float(c)) for c in big.coeffs) / max(abs(float(c)) for c in small.coeffs)
    assert np.log2(ratio) / s == pytest.approx(spec.max_degree - 2 * spec.flat, abs=0.1)
    with pytest.raises(cg.InvalidInputError, match="representable"):
        cg.primitive_from_points(kind, list(P / np.abs(P).max() * 2.0 ** (1000 // spec.max_degree + 1)))


@pytest.mark.parametrize("kind", COOPERATIVE_KINDS)
def test_least_squares_partner_fits_its_kind(kind: str) -> None:
    """A least-squares kind fits its primitive_kind; with n_points points the fit is that exact primitive."""
    spec = KIND_SPECS[kind]
    assert spec.fit_name == (kind if spec.least_squares else None)
    if not spec.least_squares:
        assert spec.primitive_kind == kind
        if spec.fit_kind is not None:
            assert KIND_SPECS[spec.fit_kind].primitive_kind == kind and KIND_SPECS[spec.fit_kind].least_squares
        return
    base = KIND_SPECS[spec.primitive_kind]
    assert FIT_KINDS[kind] == base.name and base.fit_kind in (kind, None)  # line_fit, circle_fit: by name only
    assert (base.n_points, base.flat, base.dof) == (spec.n_points, spec.flat, spec.dof)
    P = np.random.default_rng(11).normal(size=(spec.n_points, 3))
    F = fit_primitive(kind, P)
    X = cg.primitive_from_points(spec.primitive_kind, list(P))
    assert F.kind == spec.primitive_kind
    np.testing.assert_allclose(cg.Similarity.from_unit(F).log(), cg.Similarity.from_unit(X).log(), atol=1e-9)


def test_kind_spec_names_the_accepted_kinds() -> None:
    assert kind_spec("circle") is KIND_SPECS["circle"]
    with pytest.raises(cg.UnknownNameError, match="sphere_fit"):
        kind_spec("ellipse")
    with pytest.raises(cg.UnknownNameError, match=r"choose one of point, point_pair, line, circle, plane, sphere$"):
        kind_spec("sphere_fit", least_squares=False)
    with pytest.raises(cg.InvalidInputError, match="must be a string"):
        kind_spec(3)  # type: ignore[arg-type]
    assert COOPERATIVE_KINDS == (*KINDS, "sphere_fit", "plane_fit", "line_fit", "circle_fit")
