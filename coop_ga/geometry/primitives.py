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
Numeric inputs are validated (type, shape, NaN/inf, range, degeneracy) and every error
is a :class:`~coop_ga.CoopGAError` naming the argument; symbolic inputs cannot be, so the
cooperative layer guards them with its well-definedness measures.

Numerics (numeric inputs only; the symbolic formulas are unchanged)
-------------------------------------------------------------------
* **Scale-free guards.**  No threshold is absolute: degeneracy is decided by the
  dimensionless :func:`well_definedness`; read-outs test for exact zeros after an exact
  power-of-two rescaling of X (:func:`_balance`: an
  overall factor and a dilation), so X → λX and uniform scaling of the points give the
  same verdicts, and nothing overflows or underflows in between; :func:`kind_of` uses a
  scale-free roundness.
* **Local origin.**  A primitive of size r at distance ρ from the origin has coefficients
  that are sums of terms ρ/r times larger than themselves.  :func:`primitive_from_points`
  therefore wedges points that are far from the origin (ρ > 4·spread) about their
  centroid and translates the result back: every coefficient is then as accurate as the
  exactly rounded one (the plain outer product lost ~ε(ρ/r)² and read-outs of it ~ε(ρ/r)³:
  a unit circle 10⁶ m away reported radius 3.87).
* **What the coefficients lose, and the local form.**  Even an exactly rounded primitive
  stores its *radius* only to ~ε(ρ/r)² relative (centers to ~ε ρ, axes to ~ε): r enters
  only through ρ² + r².  :func:`primitive_from_points` therefore keeps the primitive built
  about the centroid, ``(m, X_m)`` (:attr:`Primitive.local`), and :func:`radius` reads r
  from it (to ~ε wherever the primitive is).  Without a local form (an untagged or
  transformed multivector) :func:`radius` estimates ``ε((ρ + r)/r)²`` and emits a
  :class:`~coop_ga.PrecisionWarning` above :data:`PRECISION_WARN` = 1e-6 (ρ/r ≳ 7e4), or
  raises when the radius is lost entirely.  Symbolic primitives are built about a nearby
  origin by their callers (the cooperative layer uses the end points' centroid and
  :func:`coop_ga.geometry.similarity.similarity_from_parameters`).
* **Range.**  Coefficients of a kind grow like |x|^k (k = 2 for points … 5 for planes and
  spheres); coordinates beyond 2^(1000//k) m (3e150 m for points, 1.6e60 m for spheres) or
  spreads below 2^(−1000//k) m raise :class:`~coop_ga.InvalidInputError` instead of
  returning inf/0.

Seed discrepancies (checked numerically in ``tests/geometry/test_primitives.py``):

* Eq 24, ``r = ‖(X·e∞) X⁻¹‖``, evaluates to ``1/r``, not ``r``.  We use the
  scale-invariant ``r² = −⟨X X̃⟩₀ / ⟨(e∞⌋X)(e∞⌋X)~⟩₀`` (valid for point pairs,
  circles and spheres).
* Eq 25, ``N = E* − ½(E*·e0)e∞``: with ``E* = E I = w(n + δ e∞)`` the e∞ part is
  removed by ``+ (E*·e0) e∞``; the printed ``−½`` leaves ``1.5 δ e∞`` behind.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .. import validation
from ..algebra import backend as B
from ..algebra.basis import blade_index
from ..algebra.multivector import OMEGA, Multivector, _exponents, safe_range
from ..diagnostics import warn
from ..errors import DegeneratePrimitiveError, InvalidInputError, PrecisionWarning
from .kinds import KIND_SPECS, KINDS, N_POINTS, Kind, KindSpec, kind_spec

__all__ = [
    "KINDS",
    "N_POINTS",
    "PRECISION_WARN",
    "Primitive",
    "center",
    "circle",
    "closest_point_to_origin",
    "direction",
    "endpoints",
    "kind_of",
    "line",
    "meet",
    "normal",
    "plane",
    "point",
    "point_pair",
    "primitive_from_points",
    "project",
    "radius",
    "sphere",
    "to_euclidean",
    "well_definedness",
]


EPS = float(np.finfo(float).eps)
#: estimated relative error of a read-out above which a :class:`~coop_ga.PrecisionWarning` is emitted
PRECISION_WARN = 1e-6

# The coefficient of a blade with j Euclidean generators (and e∞) is a homogeneous polynomial
# of degree j (+2) in the point coordinates; the largest degree of each kind (KindSpec.max_degree)
# bounds the range of coordinates whose primitive is representable in float64 (no overflow of the
# largest coefficients, no underflow of the smallest ones).
_R_MAX: dict[str, float] = {k: 2.0 ** (1000 // KIND_SPECS[k].max_degree) for k in KINDS}
_R_MIN: dict[str, float] = {k: 2.0 ** -(1000 // KIND_SPECS[k].max_degree) for k in KINDS}

_E0 = Multivector.blade("e0")
_EINF = Multivector.blade("einf")
_I5 = Multivector.blade("e0123inf")
_B = {n: blade_index(n)[0] for n in ("e0", "e1", "e2", "e3", "einf", "e12", "e13", "e23")}
_B_E0IINF = tuple(blade_index(n)[0] for n in ("e01inf", "e02inf", "e03inf"))  # line direction blades
_B_EIJINF = tuple(blade_index(n)[0] for n in ("e23inf", "e13inf", "e12inf"))  # line moment blades
_VEC = (_B["e0"], _B["e1"], _B["e2"], _B["e3"], _B["einf"])
_TRANSLATOR = tuple(sorted((0, blade_index("e1inf")[0], blade_index("e2inf")[0], blade_index("e3inf")[0])))


def _degree(b: int) -> int:
    """Length degree of blade b's coefficient: #Euclidean generators + 2·[e∞] (e0 counts 0)."""
    return (b & 0b01110).bit_count() + 2 * ((b >> 4) & 1)


class Primitive(Multivector):
    """A multivector tagged with its primitive ``kind`` (one of :data:`KINDS`).

    Algebraic operations return plain :class:`Multivector`; :func:`coop_ga.geometry.apply`
    keeps the tag because similarities map primitives onto primitives of the same kind.
    """

    __slots__ = ("kind", "local")

    kind: Kind

    def __init__(
        self, blades: tuple[int, ...], coeffs: tuple[Any, ...], kind: Kind, local: tuple[Any, Primitive] | None = None
    ):
        super().__init__(blades, coeffs)
        self.kind = _check_kind(kind)
        #: ``(m, X_m)`` or None: the same primitive built about the point m (shape (3,) or (N, 3) [m]),
        #: ``X = T(m) X_m T̃(m)``.  :func:`primitive_from_points` keeps it for points far from the origin;
        #: :func:`radius`, :func:`direction` and :func:`normal` read it, because X itself stores the radius
        #: only to ~ε(ρ/r)² relative and the axis to ~ε ρ/r (module docstring).
        #: Any operation on X returns a plain Multivector, so the local form never goes stale.
        self.local = local

    @classmethod
    def tag(cls, X: Multivector, kind: Kind) -> Primitive:
        """X tagged with ``kind`` (no local form)."""
        if not isinstance(X, Multivector):
            raise InvalidInputError(f"Primitive.tag(X, kind): X must be a coop_ga Multivector, got {type(X).__name__}")
        return cls(X.blades, X.coeffs, kind)

    @property
    def spec(self) -> KindSpec:
        """The facts of its kind (:data:`~coop_ga.geometry.kinds.KIND_SPECS`)."""
        return KIND_SPECS[self.kind]

    def __repr__(self) -> str:
        return f"{self.kind}:" + super().__repr__()


# ---------------------------------------------------------------------- input handling
_isfinite = math.isfinite


def _fast3(x: Any) -> tuple[float, float, float] | None:
    """The three floats of a finite float64 (3,) array or a list/tuple of 3 finite floats/ints, else None."""
    t = type(x)
    if t is np.ndarray:
        if x.shape != (3,) or x.dtype != np.float64:
            return None
        a, b, c = x.tolist()
    elif t is list or t is tuple:
        if len(x) != 3:
            return None
        a, b, c = x
        for v in (a, b, c):
            tv = type(v)
            if tv is not float and tv is not np.float64 and not (tv is int and -1e308 <= v <= 1e308):
                return None
        a, b, c = float(a), float(b), float(c)
    else:
        return None
    if _isfinite(a) and _isfinite(b) and _isfinite(c):
        return a, b, c
    return None


def _vec3(x: Any, name: str) -> tuple[Any, Any, Any]:
    """Return the three coordinates of a point; validates numeric input (shape (3,) or (N, 3)).

    Booleans, complex numbers, strings, None, ragged lists, NaN and inf raise a
    :class:`~coop_ga.CoopGAError` naming ``name``; the input is never modified.
    """
    f = _fast3(x)
    if f is not None:
        return f
    if B.is_symbolic(x):
        if x.numel() != 3:
            raise InvalidInputError(f"{name} must have 3 entries, got a CasADi expression of shape {x.shape}")
        return x[0], x[1], x[2]
    if isinstance(x, (list, tuple)) and len(x) == 3 and any(B.is_symbolic(v) for v in x):
        out = []
        for i, v in enumerate(x):
            if B.is_symbolic(v):
                if v.numel() != 1:
                    raise InvalidInputError(f"{name}[{i}] must be a scalar CasADi expression, got shape {v.shape}")
                out.append(v)
            else:
                out.append(_real(validation.scalar, v, f"{name}[{i}]"))
        return tuple(out)
    if isinstance(x, Multivector):
        raise InvalidInputError(
            f"{name} must be Euclidean coordinates of shape (3,), got a {type(x).__name__}; "
            "use coop_ga.to_euclidean(P) to read a conformal point"
        )
    a = validation.array(x, name)
    if a.shape[-1:] != (3,) or a.ndim > 2 or (a.ndim == 2 and a.shape[0] == 0):
        raise InvalidInputError(f"{name} must be a Euclidean 3-vector of shape (3,) (or (N, 3)), got shape {a.shape}")
    if a.ndim == 1:
        return float(a[0]), float(a[1]), float(a[2])
    return a[:, 0].copy(), a[:, 1].copy(), a[:, 2].copy()


def _embed(x: tuple[Any, Any, Any]) -> Multivector:
    """Conformal embedding P(x) = e0 + x + ½|x|² e∞ (Eq 1)."""
    x1, x2, x3 = x
    h = 0.5 * (x1 * x1 + x2 * x2 + x3 * x3)
    return Multivector(_VEC, (1.0 + 0.0 * x1, x1, x2, x3, h))


def _num(x: tuple[Any, ...]) -> np.ndarray | None:
    if any(B.is_symbolic(v) for v in x):
        return None
    return np.stack(np.broadcast_arrays(*[np.asarray(v, dtype=float) for v in x]), axis=-1)


def _fmt_point(p: np.ndarray) -> str:
    p = np.asarray(p, dtype=float)
    if p.ndim > 1:
        p = p.reshape(-1, 3)[0]
    return "[" + ", ".join(repr(float(v)) for v in p) + "]"


def _mv_arg(X: Any, name: str = "X") -> Multivector:
    """``X`` as a validated Multivector (numeric coefficients: real, finite, consistent shapes)."""
    if not isinstance(X, Multivector):
        raise InvalidInputError(f"{name} must be a coop_ga Multivector (e.g. a Primitive), got {type(X).__name__}")
    X.check_finite(name)
    return X


def _real(check: Any, x: Any, name: str) -> float:
    """``validation.<check>(x, name)``, with integers beyond the float range rejected first."""
    if type(x) is int and not -1e308 <= x <= 1e308:
        raise InvalidInputError(
            f"{name} must be a real number in the float range, got an integer of {len(str(x))} digits"
        )
    return check(x, name)


def _tol(tol: Any, name: str = "tol") -> float:
    return _real(validation.nonnegative, tol, name)


# ---------------------------------------------------------------------- well-definedness
def well_definedness(kind: Kind, points: Any) -> Any:
    """Scale-free measure of how far points are from degenerating the primitive ``kind``.

    ``points`` is an (n, 3) array (or (n, N, 3) for a batch, or a list of n coordinate
    triples, numpy or CasADi).  The measure is dimensionless — invariant under translating,
    rotating and uniformly scaling the points — 1 for the best-conditioned arrangement and 0
    at degeneracy (also for coincident points; never NaN):

    * point pair / line: ``d / (d + ε ρ)`` with ``d = |b − a|``, ``ρ = max(|a|, |b|)`` and
      ε the float64 machine epsilon: ≈ 1 for any two points whose distance is large compared
      with the resolution ``ε ρ`` of their coordinates, ½ when they are one ulp apart, 0 when
      they coincide.  ``1 − w ≈ ε ρ / d`` is the relative precision of the direction a → b.
      (The radius of a point pair far from the origin loses more, ~ε(ρ/d)²; its read-out
      :func:`radius` warns.)  Before this version the measure was ``d`` in metres;
    * circle / plane: smallest triangle altitude / longest edge, divided by √3/2 (the
      equilateral value) — i.e. the *distance from collinear* relative to the size;
    * sphere: smallest tetrahedron altitude / longest edge, divided by √(2/3) (regular
      tetrahedron) — the *distance from coplanar* relative to the size;
    * point: always 1.

    Numeric points are first translated to the first point and rescaled by a power of two,
    so coordinates anywhere in the float range give the same (exact-scale) answer.
    """
    kind = _check_kind(kind)
    n = N_POINTS[kind]
    pts_in = _points_arg(points, n, kind)
    if isinstance(pts_in, np.ndarray):
        return _numeric_measure(pts_in)
    import casadi as ca

    if n == 1:
        return 1.0
    return _measure(pts_in, ca.sqrt, ca.cross, ca.dot)


def _numeric_measure(P: np.ndarray) -> Any:
    """:func:`well_definedness` of validated numeric points P (n, 3) or (n, N, 3) of the kind they span
    (the measure depends on their number n only)."""
    n = P.shape[0]
    if n == 1:
        return 1.0 if P.ndim == 2 else np.ones(P.shape[1])
    with np.errstate(all="ignore"):
        zero = np.zeros(P.shape[1:-1])
        top = float(np.max(np.abs(P)))
        if top == 0.0:
            return float(zero) if zero.ndim == 0 else zero
        P = np.ldexp(P, -math.frexp(top)[1])  # |P| < 1: the differences cannot overflow
        Q = P - P[0]
        s = float(np.max(np.abs(Q)))
        if s == 0.0:
            return float(zero) if zero.ndim == 0 else zero
        e = math.frexp(s)[1]
        Q = np.ldexp(Q, -e)
        Rho = np.ldexp(P, -e) if n == 2 else None  # may be inf: then w = 0
        if Q.ndim == 2:  # one set of points: plain floats are much faster than numpy on 3-vectors
            w = _measure(
                [_V3(*q) for q in Q.tolist()],
                math.sqrt,
                _V3.cross,
                _V3.dot,
                rho_pts=None if Rho is None else [_V3(*q) for q in Rho.tolist()],
            )
        else:
            w = _measure(
                [Q[i] for i in range(n)],
                np.sqrt,
                np.cross,
                _dot_np,
                rho_pts=None if Rho is None else [Rho[i] for i in range(n)],
            )
    w = np.asarray(w, dtype=float)
    return float(w) if w.ndim == 0 else w


class _V3(tuple):
    """A 3-vector of python floats with the few operations :func:`_measure` needs."""

    def __new__(cls, x, y, z):
        return tuple.__new__(cls, (x, y, z))

    def __sub__(a, b):
        return _V3(a[0] - b[0], a[1] - b[1], a[2] - b[2])

    @staticmethod
    def cross(a, b):
        return _V3(a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])

    @staticmethod
    def dot(a, b):
        return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _dot_np(u, v):
    return np.sum(u * v, axis=-1)


def _points_arg(points: Any, n: int, kind: Kind) -> Any:
    """Validated points: a float array (n, 3) / (n, N, 3), or a list of n CasADi 3-vectors."""
    if B.is_symbolic(points):
        if points.numel() != 3 * n:
            raise InvalidInputError(f"points of a {kind} must be {n} points (3·{n} entries), got shape {points.shape}")
        return [points[3 * i : 3 * i + 3] for i in range(n)]
    if isinstance(points, (list, tuple)) and any(
        B.is_symbolic(c) for p in points for c in (p if isinstance(p, (list, tuple)) else [p])
    ):
        if len(points) != n:
            raise InvalidInputError(f"a {kind} is defined by {n} points, got {len(points)}")
        return [_as_sx3(p, f"points[{i}]") for i, p in enumerate(points)]
    P = validation.array(points, "points")
    if P.ndim not in (2, 3) or P.shape[0] != n or P.shape[-1] != 3 or (P.ndim == 3 and P.shape[1] == 0):
        raise InvalidInputError(f"points of a {kind} must have shape ({n}, 3) (or ({n}, N, 3)), got shape {P.shape}")
    return P


def _as_sx3(p, name):
    import casadi as ca

    if B.is_symbolic(p):
        if p.numel() != 3:
            raise InvalidInputError(f"{name} must have 3 entries, got a CasADi expression of shape {p.shape}")
        return p
    return ca.vertcat(*_vec3(p, name))


def _measure(pts, sqrt, cross, dot, rho_pts=None):
    """The well-definedness of 1 to 4 points (:func:`well_definedness`; the kinds spanned by equally many
    points degenerate alike)."""
    if len(pts) == 1:
        return 1.0
    if len(pts) == 2:
        a, b = pts
        d = b - a
        dn = sqrt(dot(d, d))
        ra, rb = rho_pts if rho_pts is not None else pts
        rho = _max(sqrt(dot(ra, ra)), sqrt(dot(rb, rb)))
        den = dn + EPS * rho
        pos = den > 0
        return B.where(pos, dn / B.where(pos, den, 1.0), 0.0 * dn)
    if len(pts) == 3:
        a, b, c = pts
        n = cross(b - a, c - a)
        area2 = sqrt(dot(n, n))
        e2 = [dot(b - a, b - a), dot(c - b, c - b), dot(a - c, a - c)]
        lmax2 = _max(_max(e2[0], e2[1]), e2[2])
        pos = lmax2 > 0
        # smallest altitude = 2A / longest edge; normalise by longest edge and by √3/2
        return B.where(pos, area2 / B.where(pos, lmax2, 1.0) / (np.sqrt(3.0) / 2.0), 0.0 * area2)
    a, b, c, d = pts
    vol6 = _abs(dot(cross(b - a, c - a), d - a))
    faces = [cross(b - a, c - a), cross(b - a, d - a), cross(c - a, d - a), cross(c - b, d - b)]
    fmax = _max(
        _max(dot(faces[0], faces[0]), dot(faces[1], faces[1])), _max(dot(faces[2], faces[2]), dot(faces[3], faces[3]))
    )
    ed = [b - a, c - a, d - a, c - b, d - b, d - c]
    lmax2 = dot(ed[0], ed[0])
    for e in ed[1:]:
        lmax2 = _max(lmax2, dot(e, e))
    pos = fmax > 0
    # smallest altitude = 3V / largest face area = vol6 / |largest face cross|
    # (fmax > 0 implies lmax2 > 0: a face of non-zero area has an edge of non-zero length)
    return B.where(
        pos, vol6 / sqrt(B.where(pos, fmax, 1.0)) / sqrt(B.where(pos, lmax2, 1.0)) / np.sqrt(2.0 / 3.0), 0.0 * vol6
    )


def _max(a, b):
    if type(a) is float and type(b) is float:
        return max(a, b)
    if B.any_symbolic(a, b):
        import casadi as ca

        return ca.fmax(a, b)
    return np.maximum(a, b)


def _abs(a):
    return B.fabs(a)


def _check_kind(kind: str) -> Kind:
    """``kind`` if it is one of the exact kinds :data:`KINDS` (the fast path of every primitive)."""
    if type(kind) is str and kind in N_POINTS:
        return kind  # type: ignore[return-value]  # checked: one of the Kind literals
    return kind_spec(kind, least_squares=False).name  # type: ignore[return-value]  # raises


def _check_degenerate(kind: Kind, P: np.ndarray, tol: float) -> None:
    w = np.asarray(_numeric_measure(P))
    if np.all(w > tol):
        return
    spec = KIND_SPECS[kind]
    names = "abcd"[: P.shape[0]]
    i = int(np.argmin(w.reshape(-1)))
    rows = [p if p.ndim == 1 else p[i] for p in P]
    shown = ", ".join(f"{n}={_fmt_point(p)}" for n, p in zip(names, rows))
    wmin = float(np.min(w))
    which = "points a and b" if spec.n_points == 2 else "points"
    raise DegeneratePrimitiveError(
        f"{kind}({shown}): {which} {spec.degenerate} (well-definedness {wmin:.3g} ≤ tol={tol:g}); {spec.advice}"
    )


def _check_range(kind: Kind, P: np.ndarray) -> None:
    rho = float(np.max(np.abs(P)))
    if rho > _R_MAX[kind]:
        raise InvalidInputError(
            f"pts: a {kind} is representable for coordinates up to {_R_MAX[kind]:.3g} m in magnitude (its "
            f"coefficients grow like |x|^{KIND_SPECS[kind].max_degree}); got {rho:.3g} — express the points in a nearer frame"
        )
    if KIND_SPECS[kind].n_points > 1:
        spread = float(np.max(np.abs(P - P[0])))
        if 0.0 < spread < _R_MIN[kind]:
            raise InvalidInputError(
                f"pts: the points of a {kind} must be at least {_R_MIN[kind]:.3g} m apart to be representable (its "
                f"coefficients shrink like size^{KIND_SPECS[kind].max_degree}); got a spread of {spread:.3g} m — express them in a "
                "smaller unit"
            )


# ---------------------------------------------------------------------- constructors
def point(x: Any) -> Primitive:
    """Conformal point P(x) = e0 + x + ½|x|² e∞ (Eq 1).

    ``x``: Euclidean position, shape (3,) [m] (or (N, 3) for a batch; or CasADi SX (3, 1)).
    Numeric coordinates must be below ~1e150 m in magnitude (½|x|² must be representable).
    """
    c = _vec3(x, "x")
    if not B.any_symbolic(*c):
        m = max(_absmax(v) for v in c)
        if m > _R_MAX["point"]:
            raise InvalidInputError(
                f"x: coordinates up to {_R_MAX['point']:.3g} m in magnitude are representable as a conformal point "
                f"(½|x|² must fit in float64); got {m:.3g}"
            )
    return Primitive.tag(_embed(c), "point")


def _absmax(v: Any) -> float:
    if type(v) is float:
        return abs(v)
    return float(np.max(np.abs(v)))


def _wedge(kind: Kind, coords: list[tuple[Any, Any, Any]]) -> Multivector:
    X = _embed(coords[0])
    for c in coords[1:]:
        X = X ^ _embed(c)
    if KIND_SPECS[kind].flat:
        X = X ^ _EINF
    return X


def _local_wedge(kind: Kind, P: np.ndarray) -> tuple[Multivector, tuple[np.ndarray, Multivector] | None]:
    """∧ P(p_i) (∧ e∞) computed about the centroid m of the points and translated back,
    with the local primitive ``(m, X_m)`` (None when the points are near the origin).

    The coefficients of a primitive of size r at distance ρ from the origin are
    polynomials whose terms are ρ/r times larger than their sum; the plain outer product
    of the conformal points rounds each term and so loses ~ε(ρ/r)² per coefficient.
    Built about m, the local primitive is accurate and the translation ``T(m) X T̃(m)``
    adds terms of the size of the result, so every coefficient is accurate to a few ε of
    its own degree group (measured: as good as rounding the exact coefficients).  Even
    exactly rounded, those coefficients hold a round's radius only to ~ε(ρ/r)² (module
    docstring); X_m holds it to ~ε, hence it is returned too.
    """
    rho = float(np.max(np.abs(P)))
    spread = float(np.max(np.abs(P - P[0])))
    if rho <= 4.0 * spread:  # near the origin: nothing to gain, keep the exact plain product
        if P.ndim == 2:
            return _wedge(kind, [tuple(p) for p in P.tolist()]), None
        return _wedge(kind, [tuple(p[..., j] for j in range(3)) for p in P]), None
    m = P.mean(axis=0)
    rel = [tuple((p - m)[..., j] for j in range(3)) for p in P]
    X = _wedge(kind, rel)
    m0, m1, m2 = (m[..., j] for j in range(3))
    T = Multivector(_TRANSLATOR, (1.0 + 0.0 * m0, -0.5 * m0, -0.5 * m1, -0.5 * m2))
    return (T * X * T.reverse()).grade(X.grades[0]), (m, X)


def primitive_from_points(
    kind: Kind, pts: Any, tol: float = 1e-9, *, _names: tuple[str, ...] | None = None
) -> Primitive:
    """Build a primitive of ``kind`` from its defining points (Eq 2/14).

    ``pts``: sequence of ``N_POINTS[kind]`` Euclidean points (each shape (3,), or (N, 3)).
    ``tol``: degeneracy threshold on :func:`well_definedness` (dimensionless for every
    kind); numeric input at or below it raises :class:`DegeneratePrimitiveError`.

    Numeric points far from the origin relative to their spread are wedged about their
    centroid m and translated back (see :func:`_local_wedge`), so the coefficients are
    accurate wherever the points are, and the primitive keeps its local form ``(m, X_m)``
    (:attr:`Primitive.local`) for the read-outs that the coefficients cannot give to full
    precision (the radius: module docstring); coordinates beyond the representable range of the
    kind (e.g. ~1e60 m for spheres, whose coefficients grow like |x|⁵) raise
    :class:`InvalidInputError`.  Symbolic points use the plain outer product.
    """
    kind = _check_kind(kind)
    n = N_POINTS[kind]
    tol = _tol(tol)
    if isinstance(pts, np.ndarray):
        if pts.ndim < 2 or pts.shape[0] != n:
            raise InvalidInputError(f"pts: a {kind} is defined by {n} points, got an array of shape {pts.shape}")
        seq = [pts[i] for i in range(n)]
    elif isinstance(pts, (list, tuple)):
        if len(pts) != n:
            raise InvalidInputError(f"pts: a {kind} is defined by {n} points, got {len(pts)}")
        seq = list(pts)
    else:
        raise InvalidInputError(f"pts must be a list of {n} points for a {kind}, got {type(pts).__name__}")
    names = list(_names) if _names is not None else [f"pts[{i}]" for i in range(n)]
    coords = [_vec3(p, names[i]) for i, p in enumerate(seq)]
    if not any(B.is_symbolic(v) for c in coords for v in c):
        if all(type(v) is float for c in coords for v in c):
            P = np.array(coords)
        else:
            maybe: list[np.ndarray] = []
            for c in coords:
                a = _num(c)
                assert a is not None  # no coordinate is symbolic (checked above)
                maybe.append(a)
            try:
                P = np.stack(np.broadcast_arrays(*maybe))
            except ValueError:
                raise InvalidInputError(
                    f"pts: the points' batch shapes {[p.shape for p in maybe]} do not match"
                ) from None
        if n > 1:
            _check_degenerate(kind, P, tol)
        _check_range(kind, P)
        X, local = _local_wedge(kind, P)
    else:
        X, local = _wedge(kind, coords), None
    g = KIND_SPECS[kind].grade
    Xg = X.grade(g)
    if local is None:
        return Primitive(Xg.blades, Xg.coeffs, kind)
    m, Xm = local
    Xm = Xm.grade(g)
    return Primitive(Xg.blades, Xg.coeffs, kind, local=(m, Primitive(Xm.blades, Xm.coeffs, kind)))


def point_pair(a: Any, b: Any, tol: float = 1e-9) -> Primitive:
    """Point pair P(a)∧P(b), oriented a → b.  Raises if :func:`well_definedness` ≤ tol (coincident points)."""
    return primitive_from_points(
        "point_pair",
        [a, b],
        tol,
        _names=(
            "a",
            "b",
        ),
    )


def line(a: Any, b: Any, tol: float = 1e-9) -> Primitive:
    """Line P(a)∧P(b)∧e∞ through a and b, direction a → b.  Raises if a and b coincide."""
    return primitive_from_points(
        "line",
        [a, b],
        tol,
        _names=(
            "a",
            "b",
        ),
    )


def circle(a: Any, b: Any, c: Any, tol: float = 1e-9) -> Primitive:
    """Circle P(a)∧P(b)∧P(c) through three points; normal (b−a)×(c−a).  Raises if collinear."""
    return primitive_from_points(
        "circle",
        [a, b, c],
        tol,
        _names=(
            "a",
            "b",
            "c",
        ),
    )


def plane(a: Any, b: Any, c: Any, tol: float = 1e-9) -> Primitive:
    """Plane P(a)∧P(b)∧P(c)∧e∞; normal (b−a)×(c−a).  Raises if the points are collinear."""
    return primitive_from_points(
        "plane",
        [a, b, c],
        tol,
        _names=(
            "a",
            "b",
            "c",
        ),
    )


def sphere(a: Any, b: Any, c: Any, d: Any, tol: float = 1e-9) -> Primitive:
    """Sphere P(a)∧P(b)∧P(c)∧P(d) through four points.  Raises if they are coplanar."""
    return primitive_from_points(
        "sphere",
        [a, b, c, d],
        tol,
        _names=(
            "a",
            "b",
            "c",
            "d",
        ),
    )


# ---------------------------------------------------------------------- classification
def _roundness(X: Multivector, g: int) -> tuple[float, float]:
    """``(q, e)`` of a numeric grade-3/4 blade: the scale-free roundness q and the relative size e
    of the e∞-free part (``X ∧ e∞ = 0`` for flats).

    With E_k, F_k the norms of the coefficients of length degree k without and with e∞
    (see :func:`_degree`), ``q = (E2 F4 + E3 F3)/(F3² + E2 F4 + E3 F3)`` for grade 3 and
    ``q = E3 F5/(F4² + E3 F5)`` for grade 4: invariant under X → λX and under dilations
    (uniform scaling of the points), O(1) for circles/spheres wherever they are, rounding
    noise for lines/planes.
    """
    m = max(_absmax(c) for c in X.coeffs)
    E: dict[int, float] = {}
    F: dict[int, float] = {}
    emax = 0.0
    for b, c in zip(X.blades, X.coeffs):
        a = _absmax(c) / m
        d = _degree(b)
        G = F if b & 16 else E
        G[d] = G.get(d, 0.0) + a * a
        if not b & 16:
            emax = max(emax, a)
    E = {k: math.sqrt(v) for k, v in E.items()}
    F = {k: math.sqrt(v) for k, v in F.items()}
    if g == 3:
        num = E.get(2, 0.0) * F.get(4, 0.0) + E.get(3, 0.0) * F.get(3, 0.0)
        den = F.get(3, 0.0) ** 2 + num
    else:
        num = E.get(3, 0.0) * F.get(5, 0.0)
        den = F.get(4, 0.0) ** 2 + num
    q = num / den if den > 0 else (1.0 if emax > 0 else 0.0)
    return q, emax


#: grade → {flat: kind} of the exact kinds (a grade-3 blade is a line or a circle, …)
_KINDS_OF_GRADE: dict[int, dict[bool, Kind]] = {}
for _k in KINDS:
    _KINDS_OF_GRADE.setdefault(KIND_SPECS[_k].grade, {})[KIND_SPECS[_k].flat] = _k


def kind_of(X: Multivector, tol: float = 1e-10) -> Kind:
    """The primitive kind of X: its tag if it is a :class:`Primitive`, else inferred from
    its grade and whether it contains e∞ as a factor (``X ∧ e∞ = 0`` for flats).

    For numeric untagged X of grade 3 or 4 the decision is scale-free: X is round if its
    roundness ``q`` (:func:`_roundness`; invariant under X → λX and uniform scaling of the
    points, ~1 for circles/spheres wherever they are) exceeds ``tol``.  Rounds that pass
    exactly through the origin have q = 0 — no scale-free quantity tells them from flats
    through the origin — so X is also round if its e∞-free part exceeds ``tol`` relative to
    its largest coefficient (i.e. such rounds of radius below ~1/tol metres).
    """
    if type(tol) is not float or tol != 1e-10:
        tol = _tol(tol)
    if isinstance(X, Primitive):
        return X.kind
    X = _mv_arg(X, "X")
    grades = set(X.prune(0.0).grades)
    if len(grades) != 1:
        raise InvalidInputError(
            f"not a primitive: a blade has a single grade, this multivector has grades {sorted(grades)}"
        )
    g = grades.pop()
    of_grade = _KINDS_OF_GRADE.get(g)
    if of_grade is None:
        raise InvalidInputError(f"grade-{g} multivectors are not primitives of coop_ga (grades 1-4)")
    if len(of_grade) == 1:
        return next(iter(of_grade.values()))
    if X.is_symbolic:
        is_flat = len((X ^ _EINF).prune().blades) == 0
    else:
        q, e = _roundness(X.prune(0.0), g)
        is_flat = not (q > tol or e > tol)
    return of_grade[is_flat]


# ---------------------------------------------------------------------- read-outs
def _euclid(P: Multivector) -> Any:
    return P.get(_B["e1"]), P.get(_B["e2"]), P.get(_B["e3"])


def _stack3(c: tuple[Any, Any, Any]) -> Any:
    if all(type(v) is float or type(v) is np.float64 for v in c):
        return np.array(c, dtype=float)
    if any(B.is_symbolic(v) for v in c):
        import casadi as ca

        return ca.vertcat(*c)
    return np.stack(np.broadcast_arrays(*[np.asarray(v, dtype=float) for v in c]), axis=-1)


def _balance(*Xs: Multivector) -> tuple[int, list[int]]:
    """:func:`~coop_ga.algebra.multivector.balance_exponents` with the dilation set by the *largest*
    length estimate.

    A round of weight w centred ρ from the origin has e0-, e0/e∞-free and e∞-parts of sizes ~w,
    ~wρ (or wr) and ~w|ρ² − r²|, i.e. two length estimates: (e0/e∞-free)/e0 and √(e∞/e0).
    ``balance_exponents`` uses only the second when both parts exist; for a round through (or
    within ~1e-150 m of) the origin the e∞-part is ~0 — a sphere with a 1e-308 coordinate has
    e∞-part 5e-309 — and the dilation it picked (2^512) made the radius overflow.  The larger
    estimate is always a true size; the other parts then shrink (they are smaller), never grow.
    """
    exps = [_exponents(X) for X in Xs]
    e: dict[int, int] = {}
    for ex in exps:
        for w, x in ex:
            e[w] = max(e.get(w, x), x)
    cands = []
    if -1 in e and 1 in e:
        cands.append((e[1] - e[-1]) // 2)
    if -1 in e and 0 in e:
        cands.append(e[0] - e[-1])
    if not cands and 1 in e and 0 in e:
        cands.append(e[1] - e[0])
    k = max(cands) if cands else 0
    return k, [-max(x - k * w for w, x in ex) if ex else 0 for ex in exps]


def _balanced(X: Multivector) -> tuple[Multivector, int]:
    """X rescaled exactly (powers of two) to unit size; positions/lengths of the result times
    ``2**k`` are those of X (see :func:`_balance`)."""
    if safe_range(X):
        return X, 0
    k, (lam,) = _balance(X)
    return X._rescaled(k, lam), k


def _unscale(v: Any, k: int, what: str) -> np.ndarray:
    if k == 0:
        out = np.asarray(v, dtype=float)
    else:
        with np.errstate(over="ignore"):
            out = np.ldexp(np.asarray(v, dtype=float), k)
    if not np.all(np.isfinite(out)):
        raise InvalidInputError(f"{what} is beyond the float64 range (|value| > 1.8e308)")
    return out


def to_euclidean(P: Multivector) -> Any:
    """Euclidean position x (3,) [m] (or (N, 3)) of a (possibly scaled) conformal point ``λ P(x)``, or
    of a flat point ``λ P(x)∧e∞`` (what :func:`meet` returns for a line and a plane).

    Normalises by the e0 weight (``−P·e∞``; the e0∞ coefficient of a flat point).  Raises
    :class:`DegeneratePrimitiveError` for points at infinity: zero weight, or a weight lost in
    rounding relative to the rest of P (tested per point after an exact rescaling, so the verdict
    depends neither on λ — which may differ between the points of a batch — nor on the length
    unit), and :class:`InvalidInputError` for other multivectors (e.g. a point pair: use
    :func:`center` or :func:`endpoints`).  A grade-1 vector that is not null (a dual sphere, as
    returned by :func:`project`) gives its center.
    """
    P = _mv_arg(P, "P")
    w = P.get(_B["e0"])
    x = _euclid(P)
    if B.any_symbolic(w, *x):
        return _stack3(tuple(xi / w for xi in x))
    grades = set(P.prune(0.0).grades)
    if 1 in grades or not grades:  # a point, or a vector with rounding noise in other grades (project())
        Pv = P.project(_VEC)
    elif 2 in grades:
        Pv = _flat_point_as_vector(P)
    else:
        raise InvalidInputError(
            f"to_euclidean(P) reads a conformal point (grade 1) or a flat point P∧e∞ (grade 2); got a multivector "
            f"of grades {sorted(grades)} — for a primitive use center(), closest_point_to_origin() or endpoints()"
        )
    k, (lam,) = _balance(Pv)  # always: the weight test below is relative to the balanced parts
    Pb = Pv._rescaled(k, lam)
    wv = np.asarray(Pb.get(_B["e0"]), dtype=float)
    big = np.max(np.stack(np.broadcast_arrays(0.0, *[np.abs(np.asarray(c, dtype=float)) for c in Pb.coeffs])), axis=0)
    if np.any(np.abs(wv) <= 64.0 * EPS * big) or np.any(big == 0.0):
        raise DegeneratePrimitiveError(
            "this point has zero e0 weight (a point at infinity or a direction); pass a finite conformal point"
        )
    xb = _euclid(Pb)
    with np.errstate(over="ignore"):
        x = _stack3(tuple(np.asarray(xi, dtype=float) / wv for xi in xb))
    return _unscale(x, k, "to_euclidean(P): the position")


_B_FLAT_POINT = tuple(blade_index(n)[0] for n in ("e0inf", "e1inf", "e2inf", "e3inf"))  # w, w x of P(x)∧e∞


def _flat_point_as_vector(F: Multivector) -> Multivector:
    """The vector ``w(e0 + x)`` of a numeric ``F = w P(x)∧e∞ = w(e0∞ + x∧e∞)`` (grade 2); raises when F
    is not a flat point (its other blades, relative to the rest after an exact rescaling, are not rounding)."""
    k, (lam,) = _balance(F)
    Fb = F._rescaled(k, lam)
    rest = max([_absmax(c) for b, c in zip(Fb.blades, Fb.coeffs) if b not in _B_FLAT_POINT] + [0.0])
    top = max(_absmax(c) for c in Fb.coeffs)
    if rest > 64.0 * EPS * top:
        grades = sorted(set(F.prune(0.0).grades))
        what = f"a {kind_of(F)}" if grades == [2] else f"grades {grades}"
        raise InvalidInputError(
            f"to_euclidean(P): this multivector is not a flat point P∧e∞ ({what}); use center() or endpoints() "
            "for a point pair"
        )
    return Multivector(_VEC[:4], tuple(F.get(b) for b in _B_FLAT_POINT))


def endpoints(X: Multivector) -> tuple[Any, Any]:
    """The two Euclidean points (a, b) of a point pair X = P(a)∧P(b), in their original order."""
    spec = KIND_SPECS[kind_of(X)]
    if not (spec.has_radius and spec.n_points == 2):
        raise InvalidInputError(f"endpoints() is defined for point pairs, not for a {spec.name}")
    c = center(X)
    r = radius(X)
    d = direction(X)
    if not B.any_symbolic(c, r, d):
        r = np.asarray(r, dtype=float)[..., None] if np.ndim(r) else r
    return c - r * d, c + r * d


def _center_of(X: Multivector) -> tuple[Any, Any]:
    Pc = (X * _EINF * X).project(_VEC)
    return Pc.get(_B["e0"]), _euclid(Pc)


def center(X: Multivector) -> Any:
    """Center (3,) [m] of a point, point pair, circle or sphere: P_c ∝ X e∞ X (Eq 27).

    For a line or plane, returns the point closest to the origin instead.  Numeric X is
    rescaled exactly first, so no intermediate overflows; the center is accurate to about
    ε·|c| if X is (e.g. built by :func:`primitive_from_points`).
    """
    kind = kind_of(X)
    X = _mv_arg(X, "X")
    if KIND_SPECS[kind].n_points == 1:
        return to_euclidean(X)
    if KIND_SPECS[kind].flat:
        return closest_point_to_origin(X)
    if X.is_symbolic:
        w, x = _center_of(X)
        return _stack3(tuple(xi / w for xi in x))
    Xb, k = _balanced(X)
    w, x = _center_of(Xb)
    w = np.asarray(w, dtype=float)
    if np.any(w == 0):
        raise DegeneratePrimitiveError(
            f"the {kind} has no finite center (it is flat or zero); check the defining points"
        )
    with np.errstate(over="ignore"):
        c = _stack3(tuple(np.asarray(xi, dtype=float) / w for xi in x))
    return _unscale(c, k, f"the {kind}'s center")


def _radius2_of(X: Multivector) -> tuple[Any, Any]:
    return X.norm_squared(), (_EINF | X).norm_squared()


def _local_form(X: Multivector) -> Multivector:
    """The primitive built about its local origin if X keeps one (:attr:`Primitive.local`), else X:
    for the translation-invariant read-outs, which it holds to ~ε relative: the radius (X itself to
    ~ε(ρ/r)²) and the axis (X itself to ~ε ρ/r: its e0-blades are the small differences of the
    translated ones)."""
    if isinstance(X, Primitive) and X.local is not None:
        return X.local[1]
    return X


def radius_squared(X: Multivector) -> Any:
    """r² = −⟨X X̃⟩₀ / ⟨(e∞⌋X)(e∞⌋X)~⟩₀ for point pairs, circles and spheres (corrects Eq 24)."""
    kind = kind_of(X)
    X = _mv_arg(X, "X")
    if X.is_symbolic:
        num, den = _radius2_of(X)
        return -num / den
    Xb, k = _balanced(_local_form(X))
    num, den = (np.asarray(v, dtype=float) for v in _radius2_of(Xb))
    if np.any(den == 0):
        raise DegeneratePrimitiveError(f"the {kind} is flat (e∞⌋X = 0): infinite radius; a line/plane has no radius")
    return _unscale(-num / den, 2 * k, f"the {kind}'s radius²")


def radius(X: Multivector) -> Any:
    """Radius [m] of a point pair (half the distance), circle or sphere (0 for a point).

    Precision: a primitive of radius r whose center is ρ from the origin stores r only to a
    relative precision of about ε(ρ/r)² (its coefficients mix ρ²r² and r⁴ terms), more
    (~ε(ρ/r)³) if it was built by plain outer products of far-away points.  A
    :class:`Primitive` built by :func:`primitive_from_points` keeps its local form
    (:attr:`Primitive.local`), from which r is read to ~ε wherever it is.  Other numeric
    read-outs estimate ``ε((ρ + r)/r)²`` and emit a :class:`~coop_ga.PrecisionWarning`
    above :data:`PRECISION_WARN` (1e-6); when the radius is lost entirely (r² within the
    rounding noise, possibly negative) they raise :class:`DegeneratePrimitiveError`.
    Build such primitives about a nearby origin (translate the points) to keep the digits.
    """
    kind = kind_of(X)
    if KIND_SPECS[kind].n_points == 1:
        return 0.0
    if KIND_SPECS[kind].flat:
        raise InvalidInputError(
            f"a {kind} has no radius (it is flat); use closest_point_to_origin()/normal()/direction()"
        )
    X = _mv_arg(X, "X")
    if X.is_symbolic:
        num, den = _radius2_of(X)
        return B.sqrt(-num / den)
    r, est, ratio = _radius_estimated(kind, X)
    if est > PRECISION_WARN:
        _warn_radius(kind, ratio, est)
    return r


def _radius_estimated(kind: Kind, X: Multivector) -> tuple[Any, float, float]:
    """``(r, est, ratio)`` of a numeric round X: its radius [m], the estimated relative error
    ``est = ε·ratio²`` of r and ``ratio = (ρ + r)/r`` (the largest over a batch); read from the local
    form when X keeps one.  Raises when the radius is lost in rounding or imaginary."""
    Xb, k = _balanced(_local_form(X))
    num, den = _radius2_of(Xb)
    if type(num) in (float, np.float64) and type(den) in (float, np.float64):  # one primitive: plain floats
        return _radius_scalar(kind, float(num), float(den), _length_scale(Xb), k)
    num, den = np.asarray(num, dtype=float), np.asarray(den, dtype=float)
    if np.any(den == 0):
        raise DegeneratePrimitiveError(f"the {kind} is flat (e∞⌋X = 0): infinite radius; a line/plane has no radius")
    r2 = -num / den
    ell = _length_scale(Xb)
    with np.errstate(all="ignore"):
        r = np.sqrt(np.abs(r2))
        ratio = np.where(r > 0, (ell + r) / np.where(r > 0, r, 1.0), np.inf)
        est = EPS * ratio * ratio
    est = np.where(r2 == 0, 0.0, est)
    if np.any(r2 < 0):
        lost = float(np.max(np.where(r2 < 0, est, 0.0)))
        if lost >= 0.1:
            raise DegeneratePrimitiveError(
                f"the {kind}'s radius is lost in rounding: it is ~{float(np.max(np.where(r2 < 0, ratio, 0))):.3g} radii "
                "from the origin, beyond the precision of its coefficients; build it about a nearer origin"
            )
        raise DegeneratePrimitiveError(
            f"the {kind} is imaginary (r² = {float(np.min(r2)):.3g} < 0); it cannot come from real points"
        )
    i = int(np.argmax(est.reshape(-1)))
    rr = float(np.asarray(ratio).reshape(-1)[i]) if np.ndim(ratio) else float(ratio)
    return _unscale(np.sqrt(r2), k, f"the {kind}'s radius"), float(est.reshape(-1)[i]), rr


def _length_scale(X: Multivector) -> float:
    """≈ the distance of a round's center from the origin, or its radius if larger (within a
    small factor), from the sizes of its e0-, e0/e∞-free and e∞-parts: for a round of radius r
    centred at ρ these scale like w, wρ and w(ρ² ± r²)·…, so no product is needed."""
    g = {-1: 0.0, 0: 0.0, 1: 0.0}
    for b, c in zip(X.blades, X.coeffs):
        g[OMEGA[b]] = max(g[OMEGA[b]], _absmax(c))
    if g[-1] == 0.0:
        return 0.0
    return max(g[0] / g[-1], math.sqrt(g[1] / g[-1]))


def _radius_scalar(kind: Kind, num: float, den: float, ell: float, k: int) -> tuple[float, float, float]:
    if den == 0.0:
        raise DegeneratePrimitiveError(f"the {kind} is flat (e∞⌋X = 0): infinite radius; a line/plane has no radius")
    r2 = -num / den
    if r2 == 0.0:
        return 0.0, 0.0, 1.0
    r = math.sqrt(abs(r2))
    ratio = (ell + r) / r
    est = EPS * ratio * ratio
    if r2 < 0:
        if est >= 0.1:
            raise DegeneratePrimitiveError(
                f"the {kind}'s radius is lost in rounding: it is ~{ratio:.3g} radii from the origin, beyond the "
                "precision of its coefficients; build it about a nearer origin"
            )
        raise DegeneratePrimitiveError(f"the {kind} is imaginary (r² = {r2:.3g} < 0); it cannot come from real points")
    out = math.ldexp(r, k) if k else r
    if not math.isfinite(out):
        raise InvalidInputError(f"the {kind}'s radius is beyond the float64 range (|value| > 1.8e308)")
    return out, est, ratio


def _warn_radius(kind: Kind, ratio: float, est: float) -> None:
    warn(
        f"radius(): the {kind} is {ratio:.3g} radii from the origin; its radius has an estimated relative error "
        f"of {est:.1g} (ε·(ρ/r)², ~ρ/r times more if it was built by plain outer products of far-away "
        "points); build it about a nearer origin (translate the points) for full precision",
        PrecisionWarning,
        key="radius",
    )


def _dual_flat_plane(X: Multivector) -> tuple[tuple[Any, Any, Any], Any]:
    """For a plane or the carrier plane of a circle: (w n, w δ) from E I = w (n + δ e∞)."""
    E = X if KIND_SPECS[kind_of(X)].flat else (X ^ _EINF)
    Ed = E * _I5
    wn = _euclid(Ed)
    return wn, Ed.get(_B["einf"])


def _unit3(v: tuple[Any, Any, Any], what: str) -> tuple[Any, Any, Any]:
    """v/|v| (numeric: rescaled first, so no overflow/underflow; zero raises)."""
    if B.any_symbolic(*v):
        n = B.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
        return (v[0] / n, v[1] / n, v[2] / n)
    if all(type(x) is float or type(x) is np.float64 for x in v):
        m = max(abs(v[0]), abs(v[1]), abs(v[2]))
        if m == 0.0:
            raise DegeneratePrimitiveError(f"{what}; the primitive is degenerate")
        a0, a1, a2 = v[0] / m, v[1] / m, v[2] / m
        n = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
        return (a0 / n, a1 / n, a2 / n)
    a = _stack3(v)
    m = np.max(np.abs(a), axis=-1, keepdims=True)
    if np.any(m == 0):
        raise DegeneratePrimitiveError(f"{what}; the primitive is degenerate")
    a = a / m
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    return a[..., 0], a[..., 1], a[..., 2]


def normal(X: Multivector) -> Any:
    """Unit normal (3,) of a plane or of a circle's carrier plane (Eq 25, corrected).

    Orientation: for X built from points a, b, c it is (b−a)×(c−a)/|…| (right hand).
    """
    kind = kind_of(X)
    if KIND_SPECS[kind].axis_role != "normal":
        raise InvalidInputError(f"normal() is defined for planes and circles, not for a {kind}")
    X = _local_form(_mv_arg(X, "X"))
    wn, _ = _dual_flat_plane(X)
    return _stack3(_unit3(wn, f"the {kind} has no normal (degenerate)"))


def direction(X: Multivector) -> Any:
    """Unit direction (3,) of a line or point pair, oriented from its first point to its second."""
    kind = kind_of(X)
    if KIND_SPECS[kind].axis_role != "direction":
        raise InvalidInputError(f"direction() is defined for lines and point pairs, not for a {kind}")
    X = _local_form(_mv_arg(X, "X"))
    L = X if KIND_SPECS[kind].flat else (X ^ _EINF)
    d = tuple(L.get(b) for b in _B_E0IINF)
    return _stack3(_unit3(d, f"the {kind} has no direction (its points coincide)"))


def _line_moment(L: Multivector) -> tuple[Any, Any, Any]:
    return L.get(_B_EIJINF[0]), -L.get(_B_EIJINF[1]), L.get(_B_EIJINF[2])


def _closest_point(X: Multivector, kind: Kind, numeric: bool) -> tuple[Any, Any, Any]:
    if KIND_SPECS[kind].axis_role == "direction":  # a line
        d = tuple(X.get(b) for b in _B_E0IINF)
        m = _line_moment(X)
        d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
        if numeric and np.any(np.asarray(d2) == 0):
            raise DegeneratePrimitiveError("the line has zero direction; its points coincide")
        p = (d[1] * m[2] - d[2] * m[1], d[2] * m[0] - d[0] * m[2], d[0] * m[1] - d[1] * m[0])
        return tuple(pi / d2 for pi in p)
    wn, wd = _dual_flat_plane(X)
    n2 = wn[0] * wn[0] + wn[1] * wn[1] + wn[2] * wn[2]
    if numeric and np.any(np.asarray(n2) == 0):
        raise DegeneratePrimitiveError("the plane has zero normal; its points are collinear")
    return tuple(wd * v / n2 for v in wn)


def closest_point_to_origin(X: Multivector) -> Any:
    """Point (3,) of a line or plane closest to the origin [m]."""
    kind = kind_of(X)
    if not KIND_SPECS[kind].flat:
        raise InvalidInputError(f"closest_point_to_origin() is defined for lines and planes, not for a {kind}")
    X = _mv_arg(X, "X")
    if X.is_symbolic:
        return _stack3(_closest_point(X, kind, False))
    Xb, k = _balanced(X)
    p = _closest_point(Xb, kind, True)
    return _unscale(_stack3(p), k, f"the {kind}'s closest point to the origin")


def project(P: Multivector, X: Multivector) -> Multivector:
    """Projection (P⌋X) X⁻¹ of a point (or any blade) onto the primitive X (Eq 4).

    For a point and a line or plane the result is a vector centred at the foot point —
    an imaginary sphere with squared radius −d², d the distance — so
    :func:`to_euclidean` of it is the projected point.  Numeric arguments are rescaled
    exactly (one dilation for both, powers of two) before multiplying, so nothing
    overflows; a result beyond the float range raises :class:`InvalidInputError`.
    """
    P = _mv_arg(P, "P")
    X = _mv_arg(X, "X")
    if P.is_symbolic or X.is_symbolic:
        return (P | X) * X.inverse()
    if safe_range(P, X):
        return _unscale_mv((P | X) * X.inverse(), 0, 0, "project(P, X)")
    k, (lp, lx) = _balance(P, X)
    Pb, Xb = P._rescaled(k, lp), X._rescaled(k, lx)
    Y = (Pb | Xb) * Xb.inverse()
    return _unscale_mv(Y, -k, -lp, "project(P, X)")


def _unscale_mv(Y: Multivector, k: int, lam: int, what: str) -> Multivector:
    with np.errstate(over="ignore"):
        Z = Y._rescaled(k, lam)
    for c in Z.coeffs:
        if not (math.isfinite(c) if type(c) is float or type(c) is np.float64 else np.all(np.isfinite(c))):
            raise InvalidInputError(
                f"{what}: the result's coefficients are beyond the float64 range (|value| > 1.8e308)"
            )
    return Z


def meet(X1: Multivector, X2: Multivector) -> Multivector:
    """Intersection of two primitives, ``(X1* ∧ X2*)`` undualised (Eq 5), up to scale and sign.

    It always returns a meaningful blade: two spheres meet in a (possibly imaginary)
    circle, a line and a plane in a flat point ``∝ P(x)∧e∞``, etc.  Numeric arguments are
    rescaled exactly first (see :func:`project`).
    """
    X1 = _mv_arg(X1, "X1")
    X2 = _mv_arg(X2, "X2")
    if X1.is_symbolic or X2.is_symbolic:
        return ((X1 * _I5) ^ (X2 * _I5)) * _I5.scale(-1.0)
    if safe_range(X1, X2):
        return _unscale_mv(((X1 * _I5) ^ (X2 * _I5)) * _I5.scale(-1.0), 0, 0, "meet(X1, X2)")
    k, (l1, l2) = _balance(X1, X2)
    Y = ((X1._rescaled(k, l1) * _I5) ^ (X2._rescaled(k, l2) * _I5)) * _I5.scale(-1.0)
    return _unscale_mv(Y, -k, -(l1 + l2), "meet(X1, X2)")
