"""Obstacles as CGA primitives and closed-form clearances, on numpy and CasADi alike (seed 002, Eq 28–29).

Obstacles
---------
An obstacle is a sphere or a plane, kept as its *dual* (inner-product, IPNS) vector, the form
in which CGA measures distances to it (Dorst, Fontijne, Mann §13; seed 002 §VI.C):

* sphere of centre c and radius r: ``S = e0 + c + ½(|c|² − r²) e∞``, and for a point
  ``P(x) = e0 + x + ½|x|² e∞`` (Eq 2)

      P(x) · S = ½ (r² − |x − c|²)                                          (1)

  a smooth signed squared distance: positive inside, 0 on the sphere, negative outside.
  The clearance of x is ``|x − c| − r = sqrt(r² − 2 P·S) − r`` [m];
* plane of unit normal n at signed offset δ from the origin: ``π = n + δ e∞`` and

      P(x) · π = n·x − δ                                                     (2)

  the signed distance [m], positive on the side the normal points to (the free side).

:class:`Sphere` and :class:`Plane` hold these vectors; :func:`as_obstacle` also accepts the
direct (outer-product) primitives of :mod:`coop_ga.geometry` — ``sphere(a, b, c, d)`` and
``plane(a, b, c)``, whose centre/radius and normal/offset are read off with
:func:`~coop_ga.geometry.center`, :func:`~coop_ga.geometry.radius`, :func:`~coop_ga.geometry.normal`
(the plane's free side is the side its right-hand normal ``(b − a) × (c − a)`` points to).

Distances (signed clearances, [m]; negative = penetration depth)
----------------------------------------------------------------
Every function takes 3-vectors as 3-tuples whose entries are floats, numpy arrays of one
common shape (a batch: one entry per pair, evaluated at once) or CasADi SX scalars, and runs
the *same* code on all three (branches through :func:`coop_ga.algebra.backend.where`), so a
CasADi graph of them differentiates exactly.  A capsule is a segment [a, b] plus a radius.

* :func:`point_sphere_distance` — Eq (1) through the CGA inner product;
* :func:`capsule_sphere_distance` — the closest point ``x* = a + t*(b − a)`` of the segment to
  the centre, ``t* = clamp((c − a)·(b − a)/|b − a|², 0, 1)``, then Eq (1) at x*, minus the
  capsule radius.  It is the exact signed distance of the two convex bodies (the capsule is
  the segment ⊕ a ball).  The distance to a segment is C¹ away from the segment itself (the
  clamp switches are C¹: the distance function of a convex set is continuously differentiable
  outside it), so the only non-smooth set is ``c`` on the segment (a sphere centre inside the
  capsule's core): there the derivative returned is 0;
* :func:`capsule_plane_distance` — ``min(P(a)·π, P(b)·π) − r_c`` (Eq 2 at both ends): exact;
  non-smooth (a kink) where both ends are equally far (the segment parallel to the plane);
* :func:`segment_segment_closest` / :func:`capsule_capsule_distance` — the closest points of two
  segments by Lumelsky's algorithm (Lumelsky 1985, "On fast computation of distance between line
  segments", IPL 21; in the clamped form of Ericson, *Real-Time Collision Detection* §5.1.9):
  the unconstrained minimiser of ``|p(s) − q(t)|²`` over the lines, s clamped to [0, 1], t
  recomputed for that s and clamped, s recomputed for a clamped t.  Parallel segments
  (``a e − b² ≤ 1e-12 a e``) have a whole set of closest pairs; s = 0 is chosen there and t
  follows, which is a valid closest pair.  Degenerate segments (a point: capsule = sphere) are
  handled.  The distance ``|p(s*) − q(t*)| − r₁ − r₂`` is exact; it is differentiable where the
  closest pair is unique and the segments do not intersect; on the non-smooth set (parallel
  overlapping segments, intersecting cores) the derivative returned is that of the chosen pair.

Jacobians (:mod:`coop_ga.collision.model`) follow from the witness points: with the closest
parameters held fixed (their derivative drops out at an interior minimiser — the envelope
theorem — and they are constant where clamped),
``∂d/∂q = nᵀ (J_x − J_y)`` with n the unit vector from the witness y to x and
``J_x = (1 − t) J_a + t J_b`` (a body-fixed point's Jacobian is affine in the point).

Seed 002, Eq 28–29 (link–sphere distance)
-----------------------------------------
The seed writes the distance from a sphere s (centre c, radius R) to a cylindrical link of
radius r₂ along the line ``l* = p_i ∧ p_j ∧ e∞`` (Eq 19) as

    d = sqrt(ρ²) − sqrt(s²) − r₂                                              (28)
    ρ² = [ l*·(s + ½s² e∞) / (l*·(s + ½s² e∞)·e∞) ]²                           (29)

With ``s = C − ½R² e∞`` (C the centre point), ``s² = s s = R²`` and ``s + ½s² e∞ = C``.  Eq 29
holds exactly when read as: ``B = C⌋l*`` (a bivector), ``v = B·e∞`` its contraction with e∞
(a vector; the sign of the contraction cancels in the square), the fraction ``Y = B v⁻¹`` (a
geometric product, Y of grades 1 and 3) and ``[Y]²`` its geometric square, which is the scalar
ρ² = (distance from c to the line)² (:func:`seed002_link_sphere_distance`; checked against the
Euclidean distance to 1e-12 in ``tests/collision/test_distance.py``).  The discrepancy is in
Eq 28's scope: ρ is the distance to the *infinite* line, so d is the clearance of an infinite
cylinder.  For a finite link it is exact only while the foot of the perpendicular lies between
the link's end points; beyond them it *underestimates* the clearance (a sphere beside the axis
extension of a link is reported as touching it).  :func:`capsule_sphere_distance` is the
finite-link version (the segment clamp; a capsule instead of a cylinder).

Two smaller points of the printed formula, also measured in ``tests/collision/test_distance.py``:
Y² has grades 0, 2 and 4 in general position, but its grade-2 and grade-4 parts vanish (to 1e-10),
so the square is a scalar as the seed implies; and Eq 28–29 hold only for the *normalised* dual
sphere (e0 coefficient 1, ``s·e∞ = −1``): for ``λs``, which is the same sphere in the IPNS,
``s + ½s² e∞`` is no longer the centre point and the formula returns another number (λ = 2,
c = (0.3, 0.4, 0.2), R = 0.1, the x axis: ρ² = 0.21 instead of 0.20 and sqrt(s²) = 2R).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import validation
from ..algebra import backend as Bk
from ..algebra.basis import blade_index
from ..algebra.multivector import Multivector
from ..errors import InvalidInputError

__all__ = [
    "Obstacle",
    "Plane",
    "Sphere",
    "as_obstacle",
    "capsule_capsule_distance",
    "capsule_plane_distance",
    "capsule_sphere_distance",
    "conformal_point",
    "point_plane_distance",
    "point_sphere_distance",
    "point_sphere_product",
    "seed002_link_sphere_distance",
    "segment_point_parameter",
    "segment_segment_closest",
]

Vec3 = tuple[Any, Any, Any]

_E0, _E1, _E2, _E3, _EI = (blade_index(n)[0] for n in ("e0", "e1", "e2", "e3", "einf"))
_VEC = (_E0, _E1, _E2, _E3, _EI)

#: a squared segment length [m²] below this counts as a point (the capsule is a sphere)
_TINY2 = 1e-24
#: ``a e − b²`` below this fraction of ``a e`` counts as parallel segments
_PARALLEL = 1e-12


# ====================================================================== obstacles
@dataclass(frozen=True, eq=False)
class Sphere:
    """A spherical obstacle: ``center`` (3,) [m] (world frame) and ``radius`` [m] (> 0).

    ``dual`` is its IPNS vector ``S = e0 + c + ½(|c|² − r²) e∞``, with ``P(x)·S = ½(r² − |x − c|²)``.
    """

    center: np.ndarray
    radius: float
    name: str = ""

    def __post_init__(self) -> None:
        c = validation.vector(self.center, 3, "sphere center [m]")
        r = validation.positive(self.radius, "sphere radius [m]")
        c.setflags(write=False)
        object.__setattr__(self, "center", c)
        object.__setattr__(self, "radius", float(r))
        if not isinstance(self.name, str):
            raise InvalidInputError(f"obstacle name must be a string, got {self.name!r}")

    def __eq__(self, other: object) -> bool:
        return (
            isinstance(other, Sphere)
            and bool(np.array_equal(self.center, other.center))
            and self.radius == other.radius
            and self.name == other.name
        )

    def __hash__(self) -> int:
        return hash(("Sphere", tuple(self.center.tolist()), self.radius, self.name))

    @property
    def dual(self) -> Multivector:
        """The IPNS vector ``S = e0 + c + ½(|c|² − r²) e∞`` (a Multivector of grade 1)."""
        c = self.center
        return Multivector(_VEC, (1.0, float(c[0]), float(c[1]), float(c[2]), 0.5 * (float(c @ c) - self.radius**2)))

    def as_dict(self) -> dict[str, Any]:
        """``{"center": [x, y, z], "radius": r}`` [m] (the obstacle format of metrics files)."""
        return {"center": [float(v) for v in self.center], "radius": float(self.radius)}


@dataclass(frozen=True, eq=False)
class Plane:
    """A half-space obstacle bounded by the plane ``n·x = offset``: unit ``normal`` (3,) pointing to
    the free side, ``offset`` δ [m] (world frame).  ``dual`` is ``π = n + δ e∞``, ``P(x)·π = n·x − δ``.
    A normal that is not unit length is normalised (the offset is then divided by its length)."""

    normal: np.ndarray
    offset: float
    name: str = ""

    def __post_init__(self) -> None:
        n = validation.vector(self.normal, 3, "plane normal")
        d = validation.scalar(self.offset, "plane offset [m]")
        ln = float(np.linalg.norm(n))
        if not ln > 1e-12:
            raise InvalidInputError(f"plane normal must be a non-zero 3-vector, got {n.tolist()}")
        n = n / ln
        n.setflags(write=False)
        object.__setattr__(self, "normal", n)
        object.__setattr__(self, "offset", float(d) / ln)
        if not isinstance(self.name, str):
            raise InvalidInputError(f"obstacle name must be a string, got {self.name!r}")

    def __eq__(self, other: object) -> bool:
        return (
            isinstance(other, Plane)
            and bool(np.array_equal(self.normal, other.normal))
            and self.offset == other.offset
            and self.name == other.name
        )

    def __hash__(self) -> int:
        return hash(("Plane", tuple(self.normal.tolist()), self.offset, self.name))

    @property
    def dual(self) -> Multivector:
        """The IPNS vector ``π = n + δ e∞``."""
        n = self.normal
        return Multivector((_E1, _E2, _E3, _EI), (float(n[0]), float(n[1]), float(n[2]), self.offset))

    def as_dict(self) -> dict[str, Any]:
        """``{"normal": [x, y, z], "offset": δ}``."""
        return {"normal": [float(v) for v in self.normal], "offset": float(self.offset)}


Obstacle = Sphere | Plane


def as_obstacle(x: Any, name: str = "") -> Sphere | Plane:
    """A :class:`Sphere` or :class:`Plane` from itself, or from a direct CGA primitive of kind
    ``"sphere"`` / ``"plane"`` (:func:`coop_ga.geometry.sphere`, :func:`coop_ga.geometry.plane`),
    or from a ``{"center": …, "radius": …}`` / ``{"normal": …, "offset": …}`` dict.
    Anything else raises :class:`~coop_ga.errors.InvalidInputError`."""
    if isinstance(x, (Sphere, Plane)):
        return x
    if isinstance(x, dict):
        if set(x) >= {"center", "radius"}:
            return Sphere(x["center"], x["radius"], name=str(x.get("name", name)))
        if set(x) >= {"normal", "offset"}:
            return Plane(x["normal"], x["offset"], name=str(x.get("name", name)))
        raise InvalidInputError(
            f"an obstacle dict needs 'center' and 'radius' (sphere) or 'normal' and 'offset' (plane), got {sorted(x)}"
        )
    from ..geometry import primitives as prim

    if isinstance(x, prim.Primitive):
        if x.is_symbolic:
            raise InvalidInputError("obstacles must be numeric primitives, got a symbolic one")
        if x.kind == "sphere":
            return Sphere(np.asarray(prim.center(x), float).reshape(3), float(prim.radius(x)), name=name)
        if x.kind == "plane":
            n = np.asarray(prim.normal(x), float).reshape(3)
            p0 = np.asarray(prim.closest_point_to_origin(x), float).reshape(3)
            return Plane(n, float(n @ p0), name=name)
        raise InvalidInputError(f"an obstacle primitive must be a sphere or a plane, got a {x.kind}")
    raise InvalidInputError(
        "an obstacle must be a collision.Sphere, a collision.Plane, a coop_ga sphere/plane primitive or a dict, "
        f"got {type(x).__name__}"
    )


# ====================================================================== generic vector helpers
def _sub(a: Vec3, b: Vec3) -> Vec3:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _add(a: Vec3, b: Vec3) -> Vec3:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def _scale(a: Vec3, s: Any) -> Vec3:
    return (a[0] * s, a[1] * s, a[2] * s)


def _dot(a: Vec3, b: Vec3) -> Any:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _where(cond: Any, a: Any, b: Any) -> Any:
    """:func:`coop_ga.algebra.backend.where`, with a fast path for numpy batches (a batch is never
    mixed with CasADi symbols)."""
    if type(cond) is np.ndarray and cond.ndim:
        return np.where(cond, a, b)
    return Bk.where(cond, a, b)


def _clamp01(x: Any) -> Any:
    return _where(x < 0.0, 0.0 * x, _where(x > 1.0, 1.0 + 0.0 * x, x))


def _and(a: Any, b: Any) -> Any:
    """Logical and of two conditions (python/numpy booleans or CasADi SX)."""
    if Bk.any_symbolic(a, b):
        import casadi as ca

        return ca.logic_and(a, b)
    return np.logical_and(a, b) if (np.ndim(a) or np.ndim(b)) else bool(a and b)


def _safe_div(num: Any, den: Any, ok: Any) -> Any:
    """``num/den`` where ``ok``, else 0 — with a safe denominator in the branch not taken (no NaN)."""
    d = _where(ok, den, 1.0 + 0.0 * den)
    return _where(ok, num / d, 0.0 * num)


def _safe_sqrt(x2: Any) -> Any:
    """``sqrt(max(x2, 0))`` with derivative 0 (not inf/NaN) at 0."""
    pos = x2 > 0.0
    return _where(pos, Bk.sqrt(_where(pos, x2, 1.0 + 0.0 * x2)), 0.0 * x2)


def _vec3(x: Any, what: str) -> Vec3:
    if isinstance(x, tuple) and len(x) == 3:
        return x
    if Bk.is_symbolic(x):
        if x.numel() != 3:
            raise InvalidInputError(f"{what} must have 3 entries, got a CasADi expression of shape {x.shape}")
        return (x[0], x[1], x[2])
    a = np.asarray(x, dtype=float)
    if a.shape[:1] != (3,) and a.shape[-1:] == (3,):
        return (a[..., 0], a[..., 1], a[..., 2])
    if a.shape[:1] != (3,):
        raise InvalidInputError(f"{what} must be a 3-vector (or (..., 3) batch), got shape {a.shape}")
    return (a[0], a[1], a[2])


# ====================================================================== CGA point measures
def conformal_point(x: Any) -> Multivector:
    """``P(x) = e0 + x + ½|x|² e∞`` (Eq 2) with float, numpy-array or SX coordinates."""
    v = _vec3(x, "x")
    return Multivector(_VEC, (1.0 + 0.0 * v[0], v[0], v[1], v[2], 0.5 * _dot(v, v)))


def point_sphere_product(x: Any, sphere: Sphere) -> Any:
    """``P(x) · S = ½ (r² − |x − c|²)`` [m²] — the CGA inner product (left contraction of two vectors)."""
    return conformal_point(x).lc(sphere.dual).get(0)


def point_sphere_distance(x: Any, sphere: Sphere) -> Any:
    """Clearance ``|x − c| − r`` [m] of point x from the sphere, as ``sqrt(r² − 2 P(x)·S) − r`` (Eq 1)."""
    r = sphere.radius
    return _safe_sqrt(r * r - 2.0 * point_sphere_product(x, sphere)) - r


def point_plane_distance(x: Any, plane: Plane) -> Any:
    """Signed distance ``n·x − δ`` [m] of point x from the plane, as ``P(x)·π`` (Eq 2)."""
    return conformal_point(x).lc(plane.dual).get(0)


# ====================================================================== segments and capsules
def segment_point_parameter(a: Any, b: Any, c: Any) -> Any:
    """``t* = clamp((c − a)·(b − a)/|b − a|², 0, 1)``: the closest point ``a + t*(b − a)`` of segment
    [a, b] to point c (t* = 0 for a degenerate segment)."""
    a3, b3, c3 = _vec3(a, "a"), _vec3(b, "b"), _vec3(c, "c")
    d = _sub(b3, a3)
    L2 = _dot(d, d)
    return _clamp01(_safe_div(_dot(_sub(c3, a3), d), L2, L2 > _TINY2))


def capsule_sphere_distance(a: Any, b: Any, radius: Any, sphere: Sphere) -> tuple[Any, Any]:
    """``(clearance [m], t*)`` of the capsule (segment [a, b], radius) from the sphere (module docstring).

    clearance = ``sqrt(r_s² − 2 P(x*)·S) − r_s − radius`` with ``x* = a + t*(b − a)`` the closest
    point of the segment to the centre (Eq 1 at x*).
    """
    a3, b3 = _vec3(a, "a"), _vec3(b, "b")
    t = segment_point_parameter(a3, b3, tuple(float(v) for v in sphere.center))
    x = _add(a3, _scale(_sub(b3, a3), t))
    return point_sphere_distance(x, sphere) - radius, t


def capsule_plane_distance(a: Any, b: Any, radius: Any, plane: Plane) -> tuple[Any, Any]:
    """``(clearance [m], t*)`` of the capsule from the plane: ``min(P(a)·π, P(b)·π) − radius``, t* ∈ {0, 1}
    the end that is closer (Eq 2)."""
    da, db = point_plane_distance(a, plane), point_plane_distance(b, plane)
    first = da <= db
    return _where(first, da, db) - radius, _where(first, 0.0 * da, 1.0 + 0.0 * da)


def segment_segment_closest(p0: Any, p1: Any, q0: Any, q1: Any) -> tuple[Any, Any]:
    """``(s*, t*)`` ∈ [0, 1]²: a closest pair ``p0 + s*(p1 − p0)``, ``q0 + t*(q1 − q0)`` of two segments
    (Lumelsky's algorithm, clamped form; parallel and degenerate segments handled — module docstring)."""
    P0, P1, Q0, Q1 = (_vec3(v, n) for v, n in ((p0, "p0"), (p1, "p1"), (q0, "q0"), (q1, "q1")))
    d1, d2, r = _sub(P1, P0), _sub(Q1, Q0), _sub(P0, Q0)
    a, e, f = _dot(d1, d1), _dot(d2, d2), _dot(d2, r)
    c, b = _dot(d1, r), _dot(d1, d2)
    pa, pe = a > _TINY2, e > _TINY2  # p / q is a proper segment (not a point)
    both = _and(pa, pe)
    denom = a * e - b * b
    general = denom > _PARALLEL * a * e
    s_line = _where(_and(both, general), _clamp01(_safe_div(b * f - c * e, denom, general)), 0.0 * a)
    t_line = _safe_div(b * s_line + f, e, pe)
    # t outside [0, 1]: clamp it and recompute s for the clamped t
    s_t0 = _clamp01(_safe_div(-c, a, pa))
    s_t1 = _clamp01(_safe_div(b - c, a, pa))
    s_both = _where(t_line < 0.0, s_t0, _where(t_line > 1.0, s_t1, s_line))
    t_both = _clamp01(t_line)
    # degenerate cases: p a point (s = 0, t = clamp(f/e)); q a point (t = 0, s = clamp(−c/a))
    s = _where(pa, _where(pe, s_both, s_t0), 0.0 * a)
    t = _where(pa, _where(pe, t_both, 0.0 * a), _where(pe, _clamp01(_safe_div(f, e, pe)), 0.0 * a))
    return s, t


def capsule_capsule_distance(
    a0: Any, a1: Any, ra: Any, b0: Any, b1: Any, rb: Any
) -> tuple[Any, tuple[Any, Any], tuple[Vec3, Vec3]]:
    """``(clearance [m], (s*, t*), (x, y))`` of capsule A (segment [a0, a1], radius ra) and capsule B:
    ``|x − y| − ra − rb`` with x, y the closest points of the two segments (:func:`segment_segment_closest`)."""
    A0, A1, B0, B1 = (_vec3(v, n) for v, n in ((a0, "a0"), (a1, "a1"), (b0, "b0"), (b1, "b1")))
    s, t = segment_segment_closest(A0, A1, B0, B1)
    x = _add(A0, _scale(_sub(A1, A0), s))
    y = _add(B0, _scale(_sub(B1, B0), t))
    w = _sub(x, y)
    return _safe_sqrt(_dot(w, w)) - ra - rb, (s, t), (x, y)


# ====================================================================== seed 002, Eq 28–29
def seed002_link_sphere_distance(p_i: Any, p_j: Any, r2: float, sphere: Sphere) -> float:
    """Eq 28–29 of seed 002 evaluated as printed (module docstring; numeric only).

    ``l* = P_i ∧ P_j ∧ e∞`` (Eq 19, the link's line through p_i, p_j [m]); ``s`` the dual sphere
    (:attr:`Sphere.dual`), ``s² = R²``; ``B = (s + ½s² e∞)⌋l*``; ``Y = B (e∞⌋B)⁻¹``;
    ``ρ² = Y²`` (a scalar); ``d = sqrt(ρ²) − sqrt(s²) − r₂`` [m] — the clearance of the sphere from
    the *infinite* cylinder of radius r₂ about the line.
    """
    from ..geometry.primitives import line

    L = line(np.asarray(p_i, float), np.asarray(p_j, float))
    s = sphere.dual
    s2 = float((s * s).get(0))  # s² = R² (s ∧ s = 0)
    C = s + Multivector((_EI,), (0.5 * s2,))  # s + ½ s² e∞: the centre point
    B = C.lc(L)
    v = Multivector((_EI,), (1.0,)).lc(B)  # (l*·C)·e∞ up to a sign that cancels in the square
    Y = B * v.inverse()
    rho2 = float((Y * Y).get(0))
    return float(np.sqrt(max(rho2, 0.0)) - np.sqrt(s2) - r2)
