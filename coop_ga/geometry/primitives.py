"""Geometric primitives of CGA built from Euclidean points, and their read-outs.

Paper §2.1.1 (Eq 1–5) and §3.3 (Eq 24, 25, 27).  All primitives are in *direct*
(outer-product, OPNS) form: ``X = P1 ∧ … ∧ Pk (∧ e∞)``.

=============  ==========================  =====  ===================================
kind           construction                grade  orientation from the point order
=============  ==========================  =====  ===================================
point          P(a)                        1      —
point_pair     P(a)∧P(b)                   2      direction a → b
line           P(a)∧P(b)∧e∞                3      direction a → b
circle         P(a)∧P(b)∧P(c)              3      normal (b−a)×(c−a) (right hand)
plane          P(a)∧P(b)∧P(c)∧e∞           4      normal (b−a)×(c−a) (right hand)
sphere         P(a)∧P(b)∧P(c)∧P(d)         4      sign of det[b−a, c−a, d−a]
=============  ==========================  =====  ===================================

Every function here runs unchanged on numpy floats and on CasADi SX coefficients.
Numeric inputs are validated (shape, NaN/inf, degeneracy); symbolic inputs cannot be,
so the cooperative layer guards them with its well-definedness measures.

Seed discrepancies (checked numerically in ``tests/geometry/test_primitives.py``):

* Eq 24, ``r = ‖(X·e∞) X⁻¹‖``, evaluates to ``1/r``, not ``r``.  We use the
  scale-invariant ``r² = −⟨X X̃⟩₀ / ⟨(e∞⌋X)(e∞⌋X)~⟩₀`` (valid for point pairs,
  circles and spheres).
* Eq 25, ``N = E* − ½(E*·e0)e∞``: with ``E* = E I = w(n + δ e∞)`` the e∞ part is
  removed by ``+ (E*·e0) e∞``; the printed ``−½`` leaves ``1.5 δ e∞`` behind.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..algebra import backend as B
from ..algebra.basis import blade_index
from ..algebra.multivector import Multivector
from ..errors import DegeneratePrimitiveError, InvalidInputError, NonFiniteError, UnknownNameError

__all__ = [
    "KINDS",
    "Primitive",
    "point",
    "point_pair",
    "line",
    "circle",
    "plane",
    "sphere",
    "primitive_from_points",
    "to_euclidean",
    "center",
    "radius",
    "normal",
    "direction",
    "closest_point_to_origin",
    "endpoints",
    "project",
    "meet",
    "kind_of",
    "well_definedness",
    "N_POINTS",
]

KINDS = ("point", "point_pair", "line", "circle", "plane", "sphere")
N_POINTS = {"point": 1, "point_pair": 2, "line": 2, "circle": 3, "plane": 3, "sphere": 4}
_FLAT = {"line", "plane"}

_E0 = Multivector.blade("e0")
_EINF = Multivector.blade("einf")
_I5 = Multivector.blade("e0123inf")
_B = {n: blade_index(n)[0] for n in ("e0", "e1", "e2", "e3", "einf", "e12", "e13", "e23")}
_B_E0IINF = tuple(blade_index(n)[0] for n in ("e01inf", "e02inf", "e03inf"))  # line direction blades
_B_EIJINF = tuple(blade_index(n)[0] for n in ("e23inf", "e13inf", "e12inf"))  # line moment blades


class Primitive(Multivector):
    """A multivector tagged with its primitive ``kind`` (one of :data:`KINDS`).

    Algebraic operations return plain :class:`Multivector`; :func:`coop_ga.apply`
    keeps the tag because similarities map primitives onto primitives of the same kind.
    """

    __slots__ = ("kind",)

    def __init__(self, blades: tuple[int, ...], coeffs: tuple[Any, ...], kind: str):
        super().__init__(blades, coeffs)
        self.kind = kind

    @classmethod
    def tag(cls, X: Multivector, kind: str) -> Primitive:
        return cls(X.blades, X.coeffs, kind)

    def __repr__(self) -> str:
        return f"{self.kind}:" + super().__repr__()


# ---------------------------------------------------------------------- input handling
def _vec3(x: Any, name: str) -> tuple[Any, Any, Any]:
    """Return the three coordinates of a point; validates numeric input (shape (3,) or (N, 3))."""
    if B.is_symbolic(x):
        if x.numel() != 3:
            raise InvalidInputError(f"{name} must have 3 entries, got a CasADi expression of shape {x.shape}")
        return x[0], x[1], x[2]
    if isinstance(x, (list, tuple)) and len(x) == 3 and any(B.is_symbolic(v) for v in x):
        return tuple(x)  # type: ignore[return-value]
    a = np.asarray(x, dtype=float)
    if a.shape[-1:] != (3,) or a.ndim > 2:
        raise InvalidInputError(f"{name} must be a Euclidean 3-vector of shape (3,) (or (N, 3)), got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise NonFiniteError(f"{name} contains NaN or inf: {a.tolist()}")
    if a.ndim == 1:
        return float(a[0]), float(a[1]), float(a[2])
    return a[:, 0].copy(), a[:, 1].copy(), a[:, 2].copy()


def _embed(x: tuple[Any, Any, Any]) -> Multivector:
    """Conformal embedding P(x) = e0 + x + ½|x|² e∞ (Eq 1)."""
    x1, x2, x3 = x
    h = 0.5 * (x1 * x1 + x2 * x2 + x3 * x3)
    return Multivector((_B["e0"], _B["e1"], _B["e2"], _B["e3"], _B["einf"]), (1.0 + 0.0 * x1, x1, x2, x3, h))


def _num(x: tuple[Any, ...]) -> np.ndarray | None:
    if any(B.is_symbolic(v) for v in x):
        return None
    return np.stack(np.broadcast_arrays(*[np.asarray(v, dtype=float) for v in x]), axis=-1)


def _edge_stats(pts: list[np.ndarray]):
    edges = [np.linalg.norm(pts[j] - pts[i], axis=-1) for i in range(len(pts)) for j in range(i + 1, len(pts))]
    return np.max(np.stack(edges), axis=0)


def well_definedness(kind: str, points: Any) -> Any:
    """Scale-free measure of how far points are from degenerating the primitive ``kind``.

    ``points`` is an (n, 3) array (or a list of n coordinate triples, numpy or CasADi).
    The measure is 1 for the best-conditioned arrangement and 0 at degeneracy:

    * point pair / line: ``|b − a|`` in metres (the only scale there is; > 0 is fine);
    * circle / plane: smallest triangle altitude / longest edge, divided by √3/2 (the
      equilateral value) — i.e. the *distance from collinear* relative to the size;
    * sphere: smallest tetrahedron altitude / longest edge, divided by √(2/3) (regular
      tetrahedron) — the *distance from coplanar* relative to the size;
    * point: always 1.
    """
    kind = _check_kind(kind)
    if isinstance(points, np.ndarray) or not any(
        B.is_symbolic(c) for p in points for c in (p if isinstance(p, (list, tuple)) else [p])
    ):
        P = np.asarray(points, dtype=float)
        pts = [P[i] for i in range(P.shape[0])]
        lib_sqrt, cross = np.sqrt, lambda u, v: np.cross(u, v)
        dot = lambda u, v: np.sum(u * v, axis=-1)  # noqa: E731
    else:
        pts = [_as_sx3(p) for p in points]
        import casadi as ca

        lib_sqrt, cross, dot = ca.sqrt, ca.cross, ca.dot
    return _measure(kind, pts, lib_sqrt, cross, dot)


def _as_sx3(p):
    import casadi as ca

    if B.is_symbolic(p):
        return p
    return ca.vertcat(*p)


def _measure(kind, pts, sqrt, cross, dot):
    if kind == "point":
        return 1.0
    if kind in ("point_pair", "line"):
        d = pts[1] - pts[0]
        return sqrt(dot(d, d))
    if kind in ("circle", "plane"):
        a, b, c = pts
        n = cross(b - a, c - a)
        area2 = sqrt(dot(n, n))
        e2 = [dot(b - a, b - a), dot(c - b, c - b), dot(a - c, a - c)]
        lmax2 = _max(_max(e2[0], e2[1]), e2[2])
        # smallest altitude = 2A / longest edge; normalise by longest edge and by √3/2
        return area2 / lmax2 / (np.sqrt(3.0) / 2.0)
    a, b, c, d = pts
    vol6 = _abs(dot(cross(b - a, c - a), d - a))
    faces = [cross(b - a, c - a), cross(b - a, d - a), cross(c - a, d - a), cross(c - b, d - b)]
    fmax = _max(_max(dot(faces[0], faces[0]), dot(faces[1], faces[1])), _max(dot(faces[2], faces[2]), dot(faces[3], faces[3])))
    ed = [b - a, c - a, d - a, c - b, d - b, d - c]
    lmax2 = ed[0]
    lmax2 = dot(ed[0], ed[0])
    for e in ed[1:]:
        lmax2 = _max(lmax2, dot(e, e))
    # smallest altitude = 3V / largest face area = vol6 / |largest face cross|
    return vol6 / sqrt(fmax) / sqrt(lmax2) / np.sqrt(2.0 / 3.0)


def _max(a, b):
    if B.any_symbolic(a, b):
        import casadi as ca

        return ca.fmax(a, b)
    return np.maximum(a, b)


def _abs(a):
    return B.fabs(a)


def _check_kind(kind: str) -> str:
    if kind not in KINDS:
        raise UnknownNameError(f"unknown primitive kind {kind!r}; choose one of {', '.join(KINDS)}")
    return kind


def _check_degenerate(kind: str, coords: list[tuple[Any, Any, Any]], tol: float) -> None:
    pts = [_num(c) for c in coords]
    if any(p is None for p in pts):
        return  # symbolic: guarded elsewhere
    w = np.asarray(_measure(kind, pts, np.sqrt, np.cross, lambda u, v: np.sum(u * v, axis=-1)))
    if np.all(w > tol):
        return
    names = "abcd"[: len(pts)]
    shown = ", ".join(f"{n}={np.round(p, 6).tolist()}" for n, p in zip(names, pts))
    why = {
        "point_pair": f"points a and b coincide (distance {float(np.min(w)):.3g} m ≤ tol={tol:g})",
        "line": f"points a and b coincide (distance {float(np.min(w)):.3g} m ≤ tol={tol:g}); a line needs two distinct points",
        "circle": f"points are collinear (well-definedness {float(np.min(w)):.3g} ≤ tol={tol:g}); a circle through collinear points is a line — use line() or move a point off the line",
        "plane": f"points are collinear (well-definedness {float(np.min(w)):.3g} ≤ tol={tol:g}); they do not fix a plane — move one point off the line",
        "sphere": f"points are coplanar (well-definedness {float(np.min(w)):.3g} ≤ tol={tol:g}); four coplanar points span a plane, not a sphere — use plane()/circle() or move a point off the plane",
    }[kind]
    raise DegeneratePrimitiveError(f"{kind}({shown}): {why}")


# ---------------------------------------------------------------------- constructors
def point(x: Any) -> Primitive:
    """Conformal point P(x) = e0 + x + ½|x|² e∞ (Eq 1).

    ``x``: Euclidean position, shape (3,) [m] (or (N, 3) for a batch; or CasADi SX (3, 1)).
    """
    return Primitive.tag(_embed(_vec3(x, "x")), "point")


def primitive_from_points(kind: str, pts: Any, tol: float = 1e-9) -> Primitive:
    """Build a primitive of ``kind`` from its defining points (Eq 2/14).

    ``pts``: sequence of ``N_POINTS[kind]`` Euclidean points (each shape (3,)).
    ``tol``: degeneracy threshold on :func:`well_definedness` (metres for point pairs
    and lines, dimensionless otherwise); numeric input at or below it raises
    :class:`DegeneratePrimitiveError`.
    """
    kind = _check_kind(kind)
    n = N_POINTS[kind]
    if len(pts) != n:
        raise InvalidInputError(f"a {kind} is defined by {n} points, got {len(pts)}")
    coords = [_vec3(p, "abcd"[i]) for i, p in enumerate(pts)]
    if kind != "point":
        _check_degenerate(kind, coords, tol)
    X = _embed(coords[0])
    for c in coords[1:]:
        X = X ^ _embed(c)
    if kind in _FLAT:
        X = X ^ _EINF
    return Primitive.tag(X.grade(len(coords) + (kind in _FLAT)), kind)


def point_pair(a: Any, b: Any, tol: float = 1e-9) -> Primitive:
    """Point pair P(a)∧P(b), oriented a → b.  Raises if ``|b − a| ≤ tol`` [m]."""
    return primitive_from_points("point_pair", [a, b], tol)


def line(a: Any, b: Any, tol: float = 1e-9) -> Primitive:
    """Line P(a)∧P(b)∧e∞ through a and b, direction a → b.  Raises if ``|b − a| ≤ tol``."""
    return primitive_from_points("line", [a, b], tol)


def circle(a: Any, b: Any, c: Any, tol: float = 1e-9) -> Primitive:
    """Circle P(a)∧P(b)∧P(c) through three points; normal (b−a)×(c−a).  Raises if collinear."""
    return primitive_from_points("circle", [a, b, c], tol)


def plane(a: Any, b: Any, c: Any, tol: float = 1e-9) -> Primitive:
    """Plane P(a)∧P(b)∧P(c)∧e∞; normal (b−a)×(c−a).  Raises if the points are collinear."""
    return primitive_from_points("plane", [a, b, c], tol)


def sphere(a: Any, b: Any, c: Any, d: Any, tol: float = 1e-9) -> Primitive:
    """Sphere P(a)∧P(b)∧P(c)∧P(d) through four points.  Raises if they are coplanar."""
    return primitive_from_points("sphere", [a, b, c, d], tol)


# ---------------------------------------------------------------------- classification
def kind_of(X: Multivector, tol: float = 1e-10) -> str:
    """The primitive kind of X: its tag if it is a :class:`Primitive`, else inferred from
    its grade and whether it contains e∞ as a factor (``X ∧ e∞ = 0`` for flats)."""
    if isinstance(X, Primitive):
        return X.kind
    grades = set(X.prune(0.0).grades)
    if len(grades) != 1:
        raise InvalidInputError(f"not a primitive: a blade has a single grade, this multivector has grades {sorted(grades)}")
    g = grades.pop()
    if g == 1:
        return "point"
    if g == 2:
        return "point_pair"
    if g in (3, 4):
        flat = X ^ _EINF
        if X.is_symbolic:
            is_flat = len(flat.prune().blades) == 0
        else:
            scale = max(float(np.max(np.abs(c))) for c in X.coeffs)
            is_flat = all(float(np.max(np.abs(c))) <= tol * scale for c in flat.coeffs)
        return ("line" if g == 3 else "plane") if is_flat else ("circle" if g == 3 else "sphere")
    raise InvalidInputError(f"grade-{g} multivectors are not primitives of coop_ga (grades 1-4)")


# ---------------------------------------------------------------------- read-outs
def _euclid(P: Multivector) -> Any:
    return P.get(_B["e1"]), P.get(_B["e2"]), P.get(_B["e3"])


def _stack3(c: tuple[Any, Any, Any]) -> Any:
    if any(B.is_symbolic(v) for v in c):
        import casadi as ca

        return ca.vertcat(*c)
    return np.stack(np.broadcast_arrays(*[np.asarray(v, dtype=float) for v in c]), axis=-1)


def _guard_nonzero(value: Any, scale: Any, what: str, fix: str) -> None:
    if B.is_symbolic(value):
        return
    v = np.abs(np.asarray(value, dtype=float))
    if not np.all(np.isfinite(v)):
        raise NonFiniteError(f"{what}: non-finite intermediate value; the input multivector contains NaN/inf")
    if np.any(v <= 1e-12 * np.maximum(np.abs(np.asarray(scale, dtype=float)), 1e-300)):
        raise DegeneratePrimitiveError(f"{what}; {fix}")


def to_euclidean(P: Multivector) -> Any:
    """Euclidean position x of a (possibly scaled) conformal point ``λ P(x)``: shape (3,).

    Normalises by the e0 weight (``−P·e∞``).  Raises for points at infinity (zero weight).
    """
    w = P.get(_B["e0"])
    if not B.is_symbolic(w):
        P.check_finite("point")
    _guard_nonzero(w, 1.0, "this point has zero e0 weight (a point at infinity or a direction)", "pass a finite conformal point")
    x = _euclid(P)
    return _stack3(tuple(xi / w for xi in x))


def endpoints(X: Multivector) -> tuple[Any, Any]:
    """The two Euclidean points (a, b) of a point pair X = P(a)∧P(b), in their original order."""
    c = center(X)
    r = radius(X)
    d = direction(X)
    return c - r * d, c + r * d


def center(X: Multivector) -> Any:
    """Center (3,) [m] of a point, point pair, circle or sphere: P_c ∝ X e∞ X (Eq 27).

    For a line or plane, returns the point closest to the origin instead.
    """
    kind = kind_of(X)
    if kind == "point":
        return to_euclidean(X)
    if kind in _FLAT:
        return closest_point_to_origin(X)
    if not X.is_symbolic:
        X.check_finite(kind)
    Pc = (X * _EINF * X).project((_B["e0"], _B["e1"], _B["e2"], _B["e3"], _B["einf"]))
    w = Pc.get(_B["e0"])
    _guard_nonzero(w, X.norm_squared(), f"the {kind} has no finite center (it is flat or zero)", "check the defining points")
    return _stack3(tuple(xi / w for xi in _euclid(Pc)))


def radius_squared(X: Multivector) -> Any:
    """r² = −⟨X X̃⟩₀ / ⟨(e∞⌋X)(e∞⌋X)~⟩₀ for point pairs, circles and spheres (corrects Eq 24)."""
    num = X.norm_squared()
    D = _EINF | X
    den = D.norm_squared()
    _guard_nonzero(den, num, f"the {kind_of(X)} is flat (e∞⌋X = 0): infinite radius", "a line/plane has no radius")
    return -num / den


def radius(X: Multivector) -> Any:
    """Radius [m] of a point pair (half the distance), circle or sphere (0 for a point)."""
    kind = kind_of(X)
    if kind == "point":
        return 0.0
    if kind in _FLAT:
        raise InvalidInputError(f"a {kind} has no radius (it is flat); use closest_point_to_origin()/normal()/direction()")
    if not X.is_symbolic:
        X.check_finite(kind)
    r2 = radius_squared(X)
    if not B.is_symbolic(r2) and np.any(np.asarray(r2) < 0):
        raise DegeneratePrimitiveError(f"the {kind} is imaginary (r² = {float(np.min(r2)):.3g} < 0); it cannot come from real points")
    return B.sqrt(r2)


def _dual_flat_plane(X: Multivector) -> tuple[tuple[Any, Any, Any], Any]:
    """For a plane or the carrier plane of a circle: (w n, w δ) from E I = w (n + δ e∞)."""
    E = X if kind_of(X) == "plane" else (X ^ _EINF)
    Ed = E * _I5
    wn = _euclid(Ed)
    return wn, Ed.get(_B["einf"])


def _normalize3(v: tuple[Any, Any, Any], what: str) -> tuple[tuple[Any, Any, Any], Any]:
    n2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2]
    _guard_nonzero(n2, 1.0, what, "the primitive is degenerate")
    n = B.sqrt(n2)
    return (v[0] / n, v[1] / n, v[2] / n), n


def normal(X: Multivector) -> Any:
    """Unit normal (3,) of a plane or of a circle's carrier plane (Eq 25, corrected).

    Orientation: for X built from points a, b, c it is (b−a)×(c−a)/|…| (right hand).
    """
    kind = kind_of(X)
    if kind not in ("plane", "circle"):
        raise InvalidInputError(f"normal() is defined for planes and circles, not for a {kind}")
    wn, _ = _dual_flat_plane(X)
    n, _ = _normalize3(wn, f"the {kind} has no normal (degenerate)")
    return _stack3(n)


def direction(X: Multivector) -> Any:
    """Unit direction (3,) of a line or point pair, oriented from its first point to its second."""
    kind = kind_of(X)
    if kind not in ("line", "point_pair"):
        raise InvalidInputError(f"direction() is defined for lines and point pairs, not for a {kind}")
    L = X if kind == "line" else (X ^ _EINF)
    d = tuple(L.get(b) for b in _B_E0IINF)
    u, _ = _normalize3(d, f"the {kind} has no direction (its points coincide)")
    return _stack3(u)


def _line_moment(L: Multivector) -> tuple[Any, Any, Any]:
    return L.get(_B_EIJINF[0]), -L.get(_B_EIJINF[1]), L.get(_B_EIJINF[2])


def closest_point_to_origin(X: Multivector) -> Any:
    """Point (3,) of a line or plane closest to the origin [m]."""
    kind = kind_of(X)
    if kind == "line":
        d = tuple(X.get(b) for b in _B_E0IINF)
        m = _line_moment(X)
        d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
        _guard_nonzero(d2, 1.0, "the line has zero direction", "its points coincide")
        p = (d[1] * m[2] - d[2] * m[1], d[2] * m[0] - d[0] * m[2], d[0] * m[1] - d[1] * m[0])
        return _stack3(tuple(pi / d2 for pi in p))
    if kind == "plane":
        wn, wd = _dual_flat_plane(X)
        n2 = wn[0] * wn[0] + wn[1] * wn[1] + wn[2] * wn[2]
        _guard_nonzero(n2, 1.0, "the plane has zero normal", "its points are collinear")
        return _stack3(tuple(wd * v / n2 for v in wn))
    raise InvalidInputError(f"closest_point_to_origin() is defined for lines and planes, not for a {kind}")


def project(P: Multivector, X: Multivector) -> Multivector:
    """Projection (P⌋X) X⁻¹ of a point (or any blade) onto the primitive X (Eq 4).

    For a point and a line or plane the result is a vector centred at the foot point —
    an imaginary sphere with squared radius −d², d the distance — so
    :func:`to_euclidean` of it is the projected point.
    """
    return (P | X) * X.inverse()


def meet(X1: Multivector, X2: Multivector) -> Multivector:
    """Intersection of two primitives, ``(X1* ∧ X2*)`` undualised (Eq 5), up to scale and sign.

    It always returns a meaningful blade: two spheres meet in a (possibly imaginary)
    circle, a line and a plane in a flat point ``∝ P(x)∧e∞``, etc.
    """
    return ((X1 * _I5) ^ (X2 * _I5)) * _I5.scale(-1.0)
