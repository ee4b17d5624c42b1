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
from ..errors import DegeneratePrimitiveError, InvalidInputError

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
#: coordinates and radii [m] are refused beyond this: the conformal point's ½|x|² (and |x − c|², r²) must not
#: overflow a double (1.8e308)
MAX_COORDINATE = 1e150


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
        if max(float(np.max(np.abs(c))), r) > MAX_COORDINATE:
            raise InvalidInputError(
                f"sphere center {c.tolist()} / radius {r:g} [m] beyond ±{MAX_COORDINATE:g} m, where the dual "
                "sphere's ½(|c|² − r²) overflows; express the scene in a unit nearer to its size"
            )
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
        big = float(np.max(np.abs(n)))
        ln = big * float(np.linalg.norm(n / big)) if big > 0.0 else 0.0  # |n| without overflow
        if not ln > 1e-12:
            raise InvalidInputError(f"plane normal must be a non-zero 3-vector, got {n.tolist()}")
        if abs(d) / ln > MAX_COORDINATE:
            raise InvalidInputError(f"plane offset {d / ln:.3g} m is beyond ±{MAX_COORDINATE:g} m")
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
    if not isinstance(name, str):
        raise InvalidInputError(f"obstacle name must be a string, got {type(name).__name__} {name!r}")
    if isinstance(x, (Sphere, Plane)):
        return x
    if isinstance(x, dict):
        if set(x) >= {"center", "radius"}:
            return Sphere(x["center"], x["radius"], name=x.get("name", name))
        if set(x) >= {"normal", "offset"}:
            return Plane(x["normal"], x["offset"], name=x.get("name", name))
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


# ====================================================================== argument checks
def _symbolic(x: Any) -> bool:
    """A CasADi expression, or a 3-sequence holding one."""
    return Bk.is_symbolic(x) or (isinstance(x, (tuple, list)) and any(Bk.is_symbolic(v) for v in x))


def _vec3(x: Any, what: str) -> Vec3:
    """The three coordinates of a point argument [m]: a (3,) vector, a (..., 3) or (3, ...) batch, a tuple of
    three floats / equally shaped arrays / CasADi scalars, or an SX of 3 entries.  Numeric input is checked
    (:func:`coop_ga.validation.array`: no NaN/inf, strings, bools, complex or ragged lists) and must stay
    within ±:data:`MAX_COORDINATE` m."""
    if _symbolic(x):
        if isinstance(x, (tuple, list)):
            if len(x) != 3:
                raise InvalidInputError(f"{what} must have 3 coordinates, got {len(x)}")
            return (x[0], x[1], x[2])
        if x.numel() != 3:
            raise InvalidInputError(f"{what} must have 3 entries, got a CasADi expression of shape {x.shape}")
        return (x[0], x[1], x[2])
    a = validation.array(x, what)
    if a.size and float(np.max(np.abs(a))) > MAX_COORDINATE:
        raise InvalidInputError(
            f"{what} has a coordinate of {float(np.max(np.abs(a))):.3g} m, beyond ±{MAX_COORDINATE:g} m where the "
            "conformal point's ½|x|² overflows; express the scene in a unit nearer to its size"
        )
    if a.ndim >= 1 and a.shape[0] == 3:
        return (a[0], a[1], a[2])
    if a.ndim >= 2 and a.shape[-1] == 3:
        return (a[..., 0], a[..., 1], a[..., 2])
    raise InvalidInputError(
        f"{what} must be a 3-vector [m] (shape (3,), a (..., 3) or (3, ...) batch, or a tuple of 3 coordinates), "
        f"got shape {a.shape}"
    )


def _radius(r: Any, what: str) -> Any:
    """A capsule radius [m]: ≥ 0 and finite, a float, an array (one per pair of a batch) or a CasADi scalar."""
    if Bk.is_symbolic(r):
        return r
    a = validation.array(r, what)
    if a.size and float(np.min(a)) < 0.0:
        raise InvalidInputError(f"{what} must be ≥ 0 [m] (a capsule radius), got {float(np.min(a)):g}")
    if a.size and float(np.max(a)) > MAX_COORDINATE:
        raise InvalidInputError(f"{what} = {float(np.max(a)):.3g} m is beyond ±{MAX_COORDINATE:g} m")
    return float(a) if a.ndim == 0 else a


def _obstacle(x: Any, kind: type, what: str) -> Any:
    if not isinstance(x, kind):
        raise InvalidInputError(
            f"{what} must be a collision.{kind.__name__} (collision.as_obstacle builds one from a primitive or a "
            f"dict), got {type(x).__name__}"
        )
    return x


def _batch(points: dict[str, Vec3], radii: dict[str, Any] | None = None) -> None:
    """The points' numeric coordinates broadcast to one batch shape (one entry per pair), and each radius is a
    scalar or fits that shape (a radius never adds a batch dimension)."""
    shapes = [np.shape(c) for v in points.values() for c in v if not Bk.is_symbolic(c)]
    try:
        batch = np.broadcast_shapes(*shapes)
    except ValueError:
        raise InvalidInputError(
            f"the batches of {', '.join(points)} do not broadcast to one shape "
            f"(shapes {', '.join(str(s) for s in shapes)}): pass one entry per pair, or a single point"
        ) from None
    for name, r in (radii or {}).items():
        if not Bk.is_symbolic(r) and np.ndim(r):
            try:
                ok = np.broadcast_shapes(batch, np.shape(r)) == batch
            except ValueError:
                ok = False
            if not ok:
                raise InvalidInputError(
                    f"{name} has shape {np.shape(r)}, which does not fit the batch of points {batch}: give one "
                    "radius (a float) or one per pair"
                )


def _quiet() -> Any:
    """numpy's floating-point warnings off: the public functions check their results (:func:`_finite_result`)."""
    return np.errstate(over="ignore", invalid="ignore", divide="ignore", under="ignore")


def _finite_result(value: Any, what: str) -> Any:
    """Numeric results are finite (the inputs are bounded, so this only fires on an overflow)."""
    if not Bk.is_symbolic(value) and not np.all(np.isfinite(value)):
        raise InvalidInputError(f"{what} overflows for these arguments; express the scene in a unit nearer its size")
    return value


# ====================================================================== CGA point measures
def conformal_point(x: Any) -> Multivector:
    """``P(x) = e0 + x + ½|x|² e∞`` (Eq 2) with float, numpy-array or SX coordinates ``x`` (3,) [m].

    Raises :class:`~coop_ga.errors.InvalidInputError` (:class:`~coop_ga.errors.NonFiniteError` for NaN/inf)
    for a bad ``x``.
    """
    v = _vec3(x, "x")
    return Multivector(_VEC, (1.0 + 0.0 * v[0], v[0], v[1], v[2], 0.5 * _dot(v, v)))


def _point_sphere_product(v: Vec3, sphere: Sphere) -> Any:
    if type(v[0]) is np.ndarray and v[0].ndim:
        # a numpy batch (the collision model's trajectories): the same inner product expanded,
        # P(x)·S = x·c − ½|x|² − ½(|c|² − r²) = ½(r² − |x − c|²) — the Multivector product costs ~1 ms per call
        c = sphere.center
        w = (v[0] - c[0], v[1] - c[1], v[2] - c[2])
        return 0.5 * (sphere.radius * sphere.radius - _dot(w, w))
    P = Multivector(_VEC, (1.0 + 0.0 * v[0], v[0], v[1], v[2], 0.5 * _dot(v, v)))
    return P.lc(sphere.dual).get(0)


def _point_sphere_distance(v: Vec3, sphere: Sphere) -> Any:
    r = sphere.radius
    return _safe_sqrt(r * r - 2.0 * _point_sphere_product(v, sphere)) - r


def _point_plane_distance(v: Vec3, plane: Plane) -> Any:
    P = Multivector(_VEC, (1.0 + 0.0 * v[0], v[0], v[1], v[2], 0.5 * _dot(v, v)))
    return P.lc(plane.dual).get(0)


def point_sphere_product(x: Any, sphere: Sphere) -> Any:
    """``P(x) · S = ½ (r² − |x − c|²)`` [m²] — the CGA inner product (left contraction of two vectors) of the
    point ``x`` (3,) [m] (or a batch) and the dual ``sphere`` (a :class:`Sphere`)."""
    v = _vec3(x, "x")
    with _quiet():
        return _finite_result(_point_sphere_product(v, _obstacle(sphere, Sphere, "sphere")), "P(x)·S")


def point_sphere_distance(x: Any, sphere: Sphere) -> Any:
    """Clearance ``|x − c| − r`` [m] of point x (3,) [m] from the :class:`Sphere`, as ``sqrt(r² − 2 P(x)·S) − r``
    (Eq 1); a (..., 3) batch of points gives one per point."""
    v = _vec3(x, "x")
    with _quiet():
        return _finite_result(_point_sphere_distance(v, _obstacle(sphere, Sphere, "sphere")), "the clearance")


def point_plane_distance(x: Any, plane: Plane) -> Any:
    """Signed distance ``n·x − δ`` [m] of point x (3,) [m] from the :class:`Plane`, as ``P(x)·π`` (Eq 2)."""
    v = _vec3(x, "x")
    with _quiet():
        return _finite_result(_point_plane_distance(v, _obstacle(plane, Plane, "plane")), "the distance")


# ====================================================================== segments and capsules
def _segment_point_parameter(a3: Vec3, b3: Vec3, c3: Vec3) -> Any:
    d = _sub(b3, a3)
    L2 = _dot(d, d)
    return _clamp01(_safe_div(_dot(_sub(c3, a3), d), L2, L2 > _TINY2))


def segment_point_parameter(a: Any, b: Any, c: Any) -> Any:
    """``t* = clamp((c − a)·(b − a)/|b − a|², 0, 1)``: the closest point ``a + t*(b − a)`` of segment
    [a, b] to point c (all (3,) [m] or batches; t* = 0 for a degenerate segment)."""
    a3, b3, c3 = _vec3(a, "a"), _vec3(b, "b"), _vec3(c, "c")
    _batch({"a": a3, "b": b3, "c": c3})
    with _quiet():
        return _finite_result(_segment_point_parameter(a3, b3, c3), "t*")


def _capsule_sphere_distance(a3: Vec3, b3: Vec3, radius: Any, sphere: Sphere) -> tuple[Any, Any]:
    t = _segment_point_parameter(a3, b3, (float(sphere.center[0]), float(sphere.center[1]), float(sphere.center[2])))
    x = _add(a3, _scale(_sub(b3, a3), t))
    return _point_sphere_distance(x, sphere) - radius, t


def capsule_sphere_distance(a: Any, b: Any, radius: Any, sphere: Sphere) -> tuple[Any, Any]:
    """``(clearance [m], t*)`` of the capsule (segment [a, b] (3,) [m], ``radius`` ≥ 0 [m]) from the
    :class:`Sphere` (module docstring).

    clearance = ``sqrt(r_s² − 2 P(x*)·S) − r_s − radius`` with ``x* = a + t*(b − a)`` the closest
    point of the segment to the centre (Eq 1 at x*).
    """
    a3, b3, r = _vec3(a, "a"), _vec3(b, "b"), _radius(radius, "radius")
    _batch({"a": a3, "b": b3}, {"radius": r})
    with _quiet():
        d, t = _capsule_sphere_distance(a3, b3, r, _obstacle(sphere, Sphere, "sphere"))
        return _finite_result(d, "the clearance"), _finite_result(t, "t*")


def _capsule_plane_distance(a3: Vec3, b3: Vec3, radius: Any, plane: Plane) -> tuple[Any, Any]:
    da, db = _point_plane_distance(a3, plane), _point_plane_distance(b3, plane)
    first = da <= db
    return _where(first, da, db) - radius, _where(first, 0.0 * da, 1.0 + 0.0 * da)


def capsule_plane_distance(a: Any, b: Any, radius: Any, plane: Plane) -> tuple[Any, Any]:
    """``(clearance [m], t*)`` of the capsule (segment [a, b] (3,) [m], ``radius`` ≥ 0 [m]) from the
    :class:`Plane`: ``min(P(a)·π, P(b)·π) − radius``, t* ∈ {0, 1} the end that is closer (Eq 2)."""
    a3, b3, r = _vec3(a, "a"), _vec3(b, "b"), _radius(radius, "radius")
    _batch({"a": a3, "b": b3}, {"radius": r})
    with _quiet():
        d, t = _capsule_plane_distance(a3, b3, r, _obstacle(plane, Plane, "plane"))
        return _finite_result(d, "the clearance"), t


def _segment_segment_closest(P0: Vec3, P1: Vec3, Q0: Vec3, Q1: Vec3) -> tuple[Any, Any]:
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


def segment_segment_closest(p0: Any, p1: Any, q0: Any, q1: Any) -> tuple[Any, Any]:
    """``(s*, t*)`` ∈ [0, 1]²: a closest pair ``p0 + s*(p1 − p0)``, ``q0 + t*(q1 − q0)`` of two segments
    (end points (3,) [m] or batches; Lumelsky's algorithm, clamped form; parallel and degenerate segments
    handled — module docstring)."""
    P0, P1, Q0, Q1 = (_vec3(v, n) for v, n in ((p0, "p0"), (p1, "p1"), (q0, "q0"), (q1, "q1")))
    _batch({"p0": P0, "p1": P1, "q0": Q0, "q1": Q1})
    with _quiet():
        s, t = _segment_segment_closest(P0, P1, Q0, Q1)
        return _finite_result(s, "s*"), _finite_result(t, "t*")


def _capsule_capsule_distance(
    A0: Vec3, A1: Vec3, ra: Any, B0: Vec3, B1: Vec3, rb: Any
) -> tuple[Any, tuple[Any, Any], tuple[Vec3, Vec3]]:
    s, t = _segment_segment_closest(A0, A1, B0, B1)
    x = _add(A0, _scale(_sub(A1, A0), s))
    y = _add(B0, _scale(_sub(B1, B0), t))
    w = _sub(x, y)
    return _safe_sqrt(_dot(w, w)) - ra - rb, (s, t), (x, y)


def capsule_capsule_distance(
    a0: Any, a1: Any, ra: Any, b0: Any, b1: Any, rb: Any
) -> tuple[Any, tuple[Any, Any], tuple[Vec3, Vec3]]:
    """``(clearance [m], (s*, t*), (x, y))`` of capsule A (segment [a0, a1] (3,) [m], radius ``ra`` ≥ 0 [m]) and
    capsule B: ``|x − y| − ra − rb`` with x, y the closest points of the two segments
    (:func:`segment_segment_closest`)."""
    A0, A1, B0, B1 = (_vec3(v, n) for v, n in ((a0, "a0"), (a1, "a1"), (b0, "b0"), (b1, "b1")))
    ra_, rb_ = _radius(ra, "ra"), _radius(rb, "rb")
    _batch({"a0": A0, "a1": A1, "b0": B0, "b1": B1}, {"ra": ra_, "rb": rb_})
    with _quiet():
        d, st, xy = _capsule_capsule_distance(A0, A1, ra_, B0, B1, rb_)
        return _finite_result(d, "the clearance"), st, xy


# ====================================================================== seed 002, Eq 28–29
def seed002_link_sphere_distance(p_i: Any, p_j: Any, r2: float, sphere: Sphere) -> float:
    """Eq 28–29 of seed 002 evaluated as printed (module docstring; numeric only).

    ``l* = P_i ∧ P_j ∧ e∞`` (Eq 19, the link's line through p_i, p_j [m]); ``s`` the dual sphere
    (:attr:`Sphere.dual`), ``s² = R²``; ``B = (s + ½s² e∞)⌋l*``; ``Y = B (e∞⌋B)⁻¹``;
    ``ρ² = Y²`` (a scalar); ``d = sqrt(ρ²) − sqrt(s²) − r₂`` [m] — the clearance of the sphere from
    the *infinite* cylinder of radius r₂ about the line.

    Raises :class:`~coop_ga.errors.DegeneratePrimitiveError` when p_i and p_j coincide (no line).
    """
    from ..geometry.primitives import line

    a, b = validation.vector(p_i, 3, "p_i [m]"), validation.vector(p_j, 3, "p_j [m]")
    r2 = validation.nonnegative(r2, "r2 (the link radius) [m]")
    _obstacle(sphere, Sphere, "sphere")
    try:
        L = line(a, b)
    except DegeneratePrimitiveError as exc:
        raise DegeneratePrimitiveError(f"p_i and p_j span no line: {exc}") from None
    except InvalidInputError as exc:  # e.g. coordinates whose line coefficients overflow
        raise type(exc)(f"p_i, p_j: {exc}") from None
    s = sphere.dual
    s2 = float((s * s).get(0))  # s² = R² (s ∧ s = 0)
    C = s + Multivector((_EI,), (0.5 * s2,))  # s + ½ s² e∞: the centre point
    B = C.lc(L)
    v = Multivector((_EI,), (1.0,)).lc(B)  # (l*·C)·e∞ up to a sign that cancels in the square
    Y = B * v.inverse()
    rho2 = float((Y * Y).get(0))
    return float(_finite_result(np.sqrt(max(rho2, 0.0)) - np.sqrt(s2) - r2, "the clearance"))
