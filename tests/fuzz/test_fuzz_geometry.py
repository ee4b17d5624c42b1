"""Fuzz properties of the public geometry/algebra API (reliability campaign, item 9–11).

For arbitrary inputs — finite, extreme (1e±300, subnormal), NaN/inf, and wrongly typed
(None, strings, bools, complex, lists, dicts, ragged or wrongly shaped arrays, foreign
multivectors) — every public function of :mod:`coop_ga.geometry` / :mod:`coop_ga.algebra`

(a) never returns NaN or inf,
(b) raises only :class:`coop_ga.CoopGAError` subclasses, and
(c) never modifies its inputs.

Run with ``--hypothesis-profile=long`` for 10 000 examples per property (the default CI
profile uses 60, with fixed seeds).
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import coop_ga as cg
from coop_ga.algebra import Multivector, blade_index, blade_name, grade_blades, grade_of
from coop_ga.algebra import backend as B
from coop_ga.errors import CoopGAError, CoopGAWarning
from coop_ga.geometry import N_POINTS, primitive_parameters, rotor_between
from coop_ga.geometry.groups import SIMILARITY_BLADES
from coop_ga.geometry.similarity import similarity_from_parameters

# ---------------------------------------------------------------------- the three properties


def _snapshot(x: Any) -> Any:
    if isinstance(x, Multivector):
        return ("mv", type(x), tuple(x.blades), tuple(_snapshot(c) for c in x.coeffs), getattr(x, "kind", None))
    if isinstance(x, np.ndarray):
        return ("arr", x.dtype, x.shape, x.copy())
    if isinstance(x, (list, tuple)):
        return (type(x).__name__, tuple(_snapshot(v) for v in x))
    if isinstance(x, dict):
        return ("dict", tuple((k, _snapshot(v)) for k, v in x.items()))
    return ("val", x)


def _same(a: Any, b: Any) -> bool:
    if type(a) is not type(b):
        return False
    if isinstance(a, tuple):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, np.ndarray):
        if a.dtype != b.dtype or a.shape != b.shape:
            return False
        if a.dtype.kind in "fc":
            return bool(np.array_equal(a, b, equal_nan=True))
        return bool(np.array_equal(a, b))
    if isinstance(a, float) and math.isnan(a):
        return math.isnan(b)
    if isinstance(a, complex):
        return a == b or (math.isnan(abs(a)) and math.isnan(abs(b)))
    try:
        return bool(a == b) or a is b
    except Exception:
        return a is b


def _assert_finite(out: Any, where: str) -> None:
    if isinstance(out, Multivector):
        for k, c in zip(out.blades, out.coeffs):
            _assert_finite(c, f"{where} (coefficient on {blade_name(k)})")
    elif isinstance(out, (list, tuple)):
        for i, v in enumerate(out):
            _assert_finite(v, f"{where}[{i}]")
    elif isinstance(out, np.ndarray):
        if out.dtype.kind in "fc":
            assert np.all(np.isfinite(out)), f"{where} returned non-finite values {out}"
    elif isinstance(out, (float, np.floating)):
        assert math.isfinite(float(out)), f"{where} returned {out}"
    elif isinstance(out, (str, int, np.integer, type(None))) or B.is_symbolic(out):
        pass
    else:  # pragma: no cover - new return types should be added here
        raise AssertionError(f"{where} returned an unexpected {type(out).__name__}")


def call(f, *args, _finite_out: bool = True, **kwargs) -> Any:
    """Run f; check (a) finite output, (b) CoopGAError only, (c) arguments unchanged.

    ``_finite_out=False`` drops (a): the raw algebra (operators, the ``Multivector(blades,
    coeffs)`` container) follows IEEE semantics — NaN in, NaN out; 1e300·1e300 = inf — and
    is not validated on every product (it is the hot path); the geometry functions are.
    """
    before = [_snapshot(a) for a in args] + [_snapshot(v) for v in kwargs.values()]
    name = getattr(f, "__name__", repr(f))
    out = None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", CoopGAWarning)  # warnings are allowed (e.g. PrecisionWarning)
            out = f(*args, **kwargs)
    except CoopGAError as exc:
        assert str(exc), f"{name}: empty error message"
    except Exception as exc:  # the property under test
        raise AssertionError(f"{name} raised {type(exc).__name__} (not a CoopGAError): {exc}") from exc
    after = [_snapshot(a) for a in args] + [_snapshot(v) for v in kwargs.values()]
    for i, (b0, b1) in enumerate(zip(before, after)):
        assert _same(b0, b1), f"{name} modified its argument {i}"
    if out is not None and _finite_out:
        _assert_finite(out, name)
    return out


# ---------------------------------------------------------------------- strategies
EXTREME = [0.0, -0.0, 1e-300, -1e-300, 5e-324, 1e300, -1e300, 1.7976931348623157e308, 1e154, 1e-154, 1e60, 1e-60]
BAD_SCALARS = [
    None,
    "1.0",
    "x",
    b"1",
    True,
    False,
    np.bool_(True),
    1 + 2j,
    np.complex128(1j),
    [1.0],
    {"a": 1},
    float("nan"),
    float("inf"),
    -float("inf"),
    10**400,
    object(),
]

finite = st.floats(allow_nan=False, allow_infinity=False)
moderate = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)
number = st.one_of(moderate, finite, st.sampled_from(EXTREME), st.integers(-10, 10))
scalar = st.one_of(number, st.sampled_from(BAD_SCALARS), st.floats())


def _vec(n: int, elem=number):
    return st.one_of(
        st.lists(elem, min_size=n, max_size=n).map(np.array),
        st.lists(elem, min_size=n, max_size=n),
        st.lists(elem, min_size=n, max_size=n).map(tuple),
    )


def junk_for(n: int):
    """Wrongly typed or shaped stand-ins for an n-vector."""
    return st.one_of(
        st.sampled_from(BAD_SCALARS),
        st.lists(scalar, min_size=n, max_size=n),
        st.lists(number, min_size=0, max_size=n + 2).filter(lambda v: len(v) != n),
        st.lists(number, min_size=n, max_size=n).map(lambda v: np.array(v, dtype=complex)),
        st.lists(st.booleans(), min_size=n, max_size=n).map(np.array),
        st.lists(number, min_size=n, max_size=n).map(lambda v: np.array(v).astype(object)),
        st.lists(number, min_size=n * n, max_size=n * n).map(lambda v: np.array(v).reshape(n, n, 1)),
        st.just(np.zeros((0, n))),
        st.just([[1.0, 2.0], [3.0]]),
        st.lists(st.text(max_size=3), min_size=n, max_size=n),
    )


def vec3():
    return st.one_of(
        _vec(3, moderate),
        _vec(3),
        junk_for(3),
        st.lists(st.lists(moderate, min_size=3, max_size=3), min_size=1, max_size=4).map(np.array),  # a batch
    )


def points_for(n: int):
    return st.one_of(
        st.lists(vec3(), min_size=n, max_size=n),
        st.lists(_vec(3, moderate), min_size=n, max_size=n),
        st.lists(_vec(3, moderate), min_size=0, max_size=5),
        st.lists(st.lists(number, min_size=3, max_size=3), min_size=n, max_size=n).map(np.array),
        st.sampled_from(BAD_SCALARS),
    )


kinds = st.one_of(st.sampled_from(cg.KINDS), st.sampled_from(["ellipse", "", "Circle", None, 3, ["circle"]]))
tolerance = st.one_of(st.just(1e-9), st.floats(0, 1), st.sampled_from([0.0, -1.0, 1e-300, None, "1e-9", np.nan, 1j]))


@st.composite
def valid_primitive(draw, kind=None):
    kind = kind or draw(st.sampled_from(cg.KINDS))
    n = N_POINTS[kind]
    scale = draw(st.sampled_from([1e-6, 1e-3, 1.0, 1e3, 1e6]))
    offset = draw(st.sampled_from([0.0, 1.0, 1e3, 1e6]))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    pts = rng.normal(size=(n, 3)) * scale + offset * rng.normal(size=3)
    try:
        X = cg.primitive_from_points(kind, list(pts))
    except CoopGAError:
        X = cg.unit_primitive(kind)
    lam = draw(st.sampled_from([1.0, -2.5, 1e-300, 1e300, 1e-12, 1e12]))
    with np.errstate(over="ignore", under="ignore"):  # λX may overflow: the functions must then raise
        Y = X.scale(lam)
    return cg.geometry.Primitive.tag(Y, kind) if draw(st.booleans()) else Y


def _raw_multivector(blades, coeffs):
    """A Multivector whose coefficients bypass the constructor's type check (as if mutated)."""
    X = object.__new__(Multivector)
    X.blades, X.coeffs = blades, coeffs
    return X


@st.composite
def junk_multivector(draw):
    blades = tuple(sorted(draw(st.sets(st.integers(0, 31), min_size=0, max_size=8))))
    coeffs = tuple(draw(st.one_of(scalar, st.lists(moderate, min_size=2, max_size=2).map(np.array))) for _ in blades)
    try:
        return Multivector(blades, coeffs)
    except CoopGAError:
        return _raw_multivector(blades, coeffs)


@st.composite
def valid_versor(draw):
    b = np.array(draw(st.lists(st.floats(-3, 3), min_size=7, max_size=7)))
    b[4:] *= draw(st.sampled_from([1.0, 1e-9, 1e6, 1e12, 1e100]))
    try:
        V = cg.geometry.exp(b)
    except CoopGAError:
        V = cg.geometry.exp(np.zeros(7))
    with np.errstate(over="ignore", under="ignore"):
        return V.scale(draw(st.sampled_from([1.0, 1e-300, 1e300, 3.0, -1.0])))


multivector = st.one_of(
    valid_primitive(),
    junk_multivector(),
    valid_versor(),
    st.builds(lambda: Multivector.scalar(0.0)),
    st.sampled_from(BAD_SCALARS),
    vec3(),
)
versor = st.one_of(valid_versor(), junk_multivector(), valid_primitive(), st.sampled_from(BAD_SCALARS))
tangent7 = st.one_of(
    _vec(7),
    _vec(7, moderate),
    junk_for(7),
    st.lists(st.lists(moderate, min_size=7, max_size=7), min_size=1, max_size=3).map(np.array),
)


# ---------------------------------------------------------------------- properties
@given(x=vec3())
def test_point_and_readback(x):
    P = call(cg.point, x)
    if P is not None:
        call(cg.to_euclidean, P)
        call(cg.center, P)
        call(cg.kind_of, P)


@given(kind=kinds, pts=st.data(), tol=tolerance)
def test_constructors(kind, pts, tol):
    n = N_POINTS.get(kind, 3) if isinstance(kind, str) else 3
    p = pts.draw(points_for(n))
    X = call(cg.primitive_from_points, kind, p, tol)
    call(cg.primitive_from_points, kind, p)
    call(cg.well_definedness, kind, p)
    if isinstance(kind, str) and kind in N_POINTS and isinstance(p, list) and len(p) == n:
        ctor = {
            "point_pair": cg.point_pair,
            "line": cg.line,
            "circle": cg.circle,
            "plane": cg.plane,
            "sphere": cg.sphere,
            "point": cg.point,
        }[kind]
        call(ctor, *p)
    if X is not None:
        _readouts(X)


def _readouts(X):
    for f in (
        cg.center,
        cg.radius,
        cg.normal,
        cg.direction,
        cg.closest_point_to_origin,
        cg.endpoints,
        cg.kind_of,
        cg.to_euclidean,
        primitive_parameters,
        cg.geometry.similarity_from_unit,
    ):
        call(f, X)


@given(X=multivector, tol=tolerance)
def test_readouts_of_any_multivector(X, tol):
    _readouts(X)
    call(cg.kind_of, X, tol)


@given(X=valid_primitive())
def test_readouts_of_scaled_valid_primitives_are_scale_invariant(X):
    """Valid primitives scaled by λ (also 1e±300): the read-outs succeed or raise a CoopGAError, finitely."""
    _readouts(X)


@given(b=tangent7)
def test_exp_log(b):
    V = call(cg.geometry.exp, b)
    if V is not None:
        call(cg.geometry.log, V)
        call(cg.geometry.decompose, V)
        if not any(np.ndim(c) for c in V.coeffs):
            call(cg.geometry.log_jacobian, V)


@given(V=versor)
def test_log_family_on_any_versor(V):
    call(cg.geometry.log, V)
    call(cg.geometry.decompose, V)
    call(cg.geometry.log_jacobian, V)


@given(V=versor, X=multivector)
def test_apply(V, X):
    call(cg.geometry.apply, V, X)


@given(X1=multivector, X2=multivector)
def test_similarity_project_meet(X1, X2):
    call(cg.geometry.similarity, X1, X2)
    call(cg.project, X1, X2)
    call(cg.meet, X1, X2)


@given(kind=kinds)
def test_unit_primitive(kind):
    X = call(cg.unit_primitive, kind)
    if X is not None:
        _readouts(X)


@given(u=vec3(), v=vec3(), axis=st.one_of(st.none(), vec3()))
def test_rotor_between(u, v, axis):
    call(rotor_between, u, v)
    call(rotor_between, u, v, axis)


@given(kind=kinds, c=vec3(), r=scalar, o=st.one_of(st.none(), vec3()))
def test_similarity_from_parameters(kind, c, r, o):
    call(similarity_from_parameters, kind, c, r, o)


@given(A=multivector, Bm=multivector, s=scalar)
def test_multivector_algebra(A, Bm, s):
    import operator

    raw = {"_finite_out": False}
    for op in (operator.add, operator.sub, operator.mul, operator.xor, operator.or_, operator.truediv):
        for x, y in ((A, Bm), (A, s), (s, A)):
            if isinstance(x, Multivector) or isinstance(y, Multivector):
                call(op, x, y, **raw)
    if isinstance(A, Multivector):
        for m in ("reverse", "involute", "dual", "undual", "norm_squared", "norm", "to_dense", "prune"):
            call(getattr(A, m), **raw)
        call(A.inverse)  # validated: finite or a CoopGAError
        call(A.check_finite)
        call(A.scale, s, **raw)
        call(A.grade, 2, **raw)
        call(A.grade, s, **raw)
        call(A.prune, s, **raw)
        call(A.get, s, **raw)
        call(A.__getitem__, s, **raw)
        call(A.with_blades, SIMILARITY_BLADES, **raw)
        if isinstance(Bm, Multivector):
            call(A.allclose, Bm)
            call(A.scalar_product, Bm, **raw)


@given(
    name=st.one_of(
        st.text(max_size=6),
        st.sampled_from(["e12", "e1inf", "e0123inf", "1", "e21", "e11", "e"]),
        st.sampled_from(BAD_SCALARS),
    ),
    k=st.one_of(st.integers(-40, 40), st.sampled_from(BAD_SCALARS)),
    coeff=scalar,
)
def test_blade_names(name, k, coeff):
    call(blade_index, name)
    call(blade_name, k)
    call(grade_of, k)
    call(grade_blades, k)
    call(Multivector.blade, name, coeff)
    call(Multivector.from_names, {name: coeff} if isinstance(name, str) else name)
    call(Multivector.from_dict, {k: coeff} if isinstance(k, int) else k)
    call(Multivector.scalar, coeff)
    call(Multivector.from_dense, [coeff] * 32)
    call(Multivector, (k,), (coeff,), _finite_out=False)  # the raw container keeps NaN (IEEE), rejects types


@pytest.mark.parametrize("kind", cg.KINDS)
def test_symbolic_inputs_pass_through(kind):
    """CasADi inputs are not validated numerically and must keep working."""
    import casadi as ca

    n = N_POINTS[kind]
    x = ca.SX.sym("x", 3 * n)
    X = cg.primitive_from_points(kind, [x[3 * i : 3 * i + 3] for i in range(n)])
    V = cg.geometry.similarity_from_unit(X)
    b = cg.geometry.log(V)
    w = cg.well_definedness(kind, [x[3 * i : 3 * i + 3] for i in range(n)])
    f = ca.Function("f", [x], [b, w])
    pts = np.random.default_rng(3).normal(size=3 * n)
    out = [np.array(o) for o in f(pts)]
    assert all(np.all(np.isfinite(o)) for o in out)
