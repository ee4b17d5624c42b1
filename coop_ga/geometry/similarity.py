"""Similarity transformations between primitives of the same kind (paper §3.3, Eq 18–28).

For two primitives X1, X2 of one kind we build ``V = V_T V_R V_D`` with
``V X1 Ṽ = λ X2``.  Each primitive is read out as (center c, radius r, axis o):

============  ======================  ===========  =======================================
kind          c                       r            o (orientation axis)
============  ======================  ===========  =======================================
point         the point               —            —
point_pair    midpoint                half length  direction first → second point
line          closest point to origin —            direction
circle        center                  radius       normal (right hand from the point order)
plane         closest point to origin —            normal
sphere        center                  radius       —
============  ======================  ===========  =======================================

then (the paper's recipe, with its typos fixed)

* ``V_D = D(log(r2/r1))`` — Eq 23 as printed, ``exp(r2 r1⁻¹ e∞)``, is a translator-like
  element, not a dilator; the scale factor r2/r1 enters through its logarithm;
* ``V_R`` = the minimal rotation taking o1 to o2, ``∝ 1 + o2 o1`` (Eq 26; the printed
  ``N2 ∧ N2`` is zero — it must be ``o2 ∧ o1``), normalised explicitly and computed
  without cancellation also next to the antipode (:func:`rotor_between`).  When o2 = −o1
  (to within |o1 + o2| < 1e-15) that expression vanishes; we then rotate by π about a
  fixed axis perpendicular to o1 (about +z for
  point pairs/lines along ±e2, about +x for circles/planes with normal ±e3);
* ``V_T = T(c2 − (r2/r1) R c1)`` — the translation that puts the rotated and scaled
  center onto c2 (the paper's "apply V_R V_D first, then translate").

Orientation is respected: ``λ > 0`` for points, point pairs, lines, circles and planes,
so a circle with the opposite normal is reached by a half-turn, never by a sign flip.
A sphere's sign (the handedness of its four points) is not changed by any direct
similarity, so for spheres ``λ`` may be negative.

The rotation about o itself (roll about a circle's normal or a point pair's axis) is
not determined by the primitive; the minimal-rotation rule fixes it.  It is
discontinuous where o2 = −o1 (no continuous choice exists on the whole sphere), so
cooperative systems should order their end points such that the nominal primitive is
far from the antipode of the unit primitive's axis.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import validation
from ..algebra import backend as B
from ..algebra.multivector import Multivector
from ..diagnostics import warn
from ..errors import DegeneratePrimitiveError, InvalidInputError, PrecisionWarning
from .groups import ROTOR_BLADES
from .kinds import KIND_SPECS, KINDS, UNIT_AXIS, AxisRole, Kind
from .primitives import (
    EPS,
    PRECISION_WARN,
    Primitive,
    _check_kind,
    _radius_estimated,
    _vec3,
    _warn_radius,
    center,
    direction,
    kind_of,
    normal,
    primitive_from_points,
    radius,
)

__all__ = [
    "UNIT_AXIS",
    "chart_reference",
    "primitive_parameters",
    "rotor_between",
    "similarity",
    "similarity_from_parameters",
    "similarity_from_unit",
    "unit_primitive",
]

#: the read-out of each axis role: a point pair's / line's direction, a circle's / plane's normal
_AXIS_READOUT: dict[AxisRole, Any] = {"direction": direction, "normal": normal}


def unit_primitive(kind: Kind) -> Primitive:
    """The unit primitive X_u of ``kind`` (Table 1; :attr:`~coop_ga.geometry.kinds.KindSpec.unit_points`):
    origin; points (0,∓1,0); the e2 axis; the unit circle in z = 0 (normal +z); the plane z = 0 (normal +z);
    the unit sphere."""
    kind = _check_kind(kind)
    return primitive_from_points(kind, [np.array(p) for p in KIND_SPECS[kind].unit_points])


def primitive_parameters(X: Multivector) -> tuple[Kind, Any, Any, Any]:
    """``(kind, c, r, o)`` as in the module table; r and o are None where undefined.

    Warns (:class:`~coop_ga.PrecisionWarning`) as :func:`~coop_ga.geometry.primitives.radius` does when
    the radius of a far round is known only to more than :data:`PRECISION_WARN` relative.
    """
    kind, c, r, o, (est, ratio) = _read_parameters(X)
    if est > PRECISION_WARN:
        _warn_radius(kind, ratio, est)
    return kind, c, r, o


def _read_parameters(X: Multivector) -> tuple[Kind, Any, Any, Any, tuple[float, float]]:
    """:func:`primitive_parameters` plus ``(est, ratio)``: the estimated relative error of r (0 where r
    is exact to rounding: kinds without a radius, symbolic X, a primitive read from its local form) and
    the distance of the round from the origin in radii, ``(ρ + r)/r``.  Centers and closest points are
    accurate to ~ε ρ whatever the distance, axes to ~ε (~ε ρ/r without a local form: a turn that moves
    the primitive by ~ε ρ, as much as its center's rounding); only r degrades by more."""
    kind = kind_of(X)
    spec = KIND_SPECS[kind]
    o = None if spec.axis_role is None else _AXIS_READOUT[spec.axis_role](X)
    if not spec.has_radius:  # a point (its center), a line or a plane (the point closest to the origin)
        return kind, center(X), None, o, (0.0, 1.0)
    c = center(X)
    if X.is_symbolic:
        r, est, ratio = radius(X), 0.0, 1.0
    else:
        r, est, ratio = _radius_estimated(kind, X)
    return kind, c, r, o, (est, ratio)


#: factor from the radii's estimates ε((ρ + r)/r)² (summed over both primitives) to the bound the similarity
#: warns with: the measured error of the scale and the translation stayed below 1.8× the sum on 2 400 random
#: far circles and spheres stored without their local form
_FAR_BOUND = 4.0


def _warn_far(kind: Kind, losses: tuple[tuple[float, float], ...]) -> None:
    """One :class:`PrecisionWarning` for a similarity whose radii (hence scale and translation) are known
    only to the estimated relative errors ``losses[i][0]`` (:func:`_read_parameters`)."""
    est = _FAR_BOUND * sum(e for e, _ in losses)
    if est > PRECISION_WARN:
        ratio = max(r for _, r in losses)
        warn(
            f"similarity: a {kind} {ratio:.3g} radii from the origin stores its radius only to ~ε·{ratio:.3g}², so "
            f"the versor's scale and translation carry an estimated relative error of {est:.2g}; build the "
            "primitives from points (primitive_from_points keeps their local form) or about a nearer origin",
            PrecisionWarning,
            key="similarity-radius",
        )


def _tuple3(v: Any) -> tuple[Any, Any, Any]:
    if isinstance(v, np.ndarray) and v.ndim > 1:
        return v[..., 0], v[..., 1], v[..., 2]  # a batch (N, 3): components, not rows
    return v[0], v[1], v[2]


def _perp_axis(u: tuple[Any, Any, Any], kind_axis: tuple[float, float, float] | None = None):
    """Fixed half-turn axis perpendicular to u, used when the target axis is −u.

    For the unit primitives' axes it is a fixed basis vector (:attr:`~coop_ga.geometry.kinds.KindSpec.half_turn_axis`:
    +z for ±e2, +x for ±e3); otherwise ``u × e1`` (or ``u × e2`` when u is close to e1), normalised.
    """
    fixed = _HALF_TURN.get(kind_axis) if kind_axis is not None else None
    if fixed is not None:
        return fixed
    near_e1 = B.fabs(u[0]) > 0.9
    a = tuple(B.where(near_e1, x2, x1) for x1, x2 in zip((0.0 * u[0], u[2], -u[1]), (-u[2], 0.0 * u[0], u[0])))
    n = B.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])
    return (a[0] / n, a[1] / n, a[2] / n)


#: unit axis → the fixed half-turn axis ⟂ it (the kinds that share an axis share it)
_HALF_TURN = {s.axis: s.half_turn_axis for s in KIND_SPECS.values() if s.axis is not None}


def _is_unit_axis(o: tuple[Any, Any, Any], kind: Kind) -> bool:
    if B.any_symbolic(*o) or UNIT_AXIS[kind] is None or any(np.ndim(x) for x in o):
        return False
    return tuple(float(x) for x in o) == UNIT_AXIS[kind]


def _axis_arg(x: Any, name: str) -> tuple[Any, Any, Any]:
    """A direction: CasADi entries as given; numeric ones validated and normalised (rescaled first)."""
    c = _vec3(x, name)
    if B.any_symbolic(*c):
        return c
    a = np.stack(np.broadcast_arrays(*[np.asarray(v, dtype=float) for v in c]), axis=-1)
    m = np.max(np.abs(a), axis=-1, keepdims=True)
    if np.any(m == 0):
        raise InvalidInputError(f"{name} must be a non-zero 3-vector (a direction), got {a.tolist()}")
    with np.errstate(over="ignore", under="ignore"):
        n2 = np.sum(a * a, axis=-1)
    if not np.all(np.abs(n2 - 1.0) <= 4 * np.finfo(float).eps):  # unit vectors are used as given
        a = a / m
        a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    if a.ndim == 1:
        return float(a[0]), float(a[1]), float(a[2])
    return a[:, 0].copy(), a[:, 1].copy(), a[:, 2].copy()


#: ``|u + v|²`` below which u, v count as antiparallel and the fixed half-turn is used: |u + v| < 1e-15,
#: about 4 ulps of a unit vector — the fixed rotor then maps u to within 1e-15 of v
_ANTI_N2 = 1e-30


def rotor_between(u: Any, v: Any, half_turn_axis: tuple[float, float, float] | None = None) -> Multivector:
    """Minimal rotor R with R u R̃ = v for directions u, v (Eq 26, corrected).

    ``R = (1 + v u)/√(2(1 + u·v))`` with both parts computed without cancellation:
    ``v ∧ u = (v − u) ∧ u`` when u·v ≥ 0 and ``(v + u) ∧ u`` when u·v < 0 (the differences
    are exact for nearby vectors), and ``1 + u·v = |u ∧ v|²/(1 − u·v)`` on the antiparallel
    side.
    So ``R R̃ = 1`` to ~1e-16 and R maps u onto v to ~1e-16 for every angle, also 1e-6 rad
    (or 1e-12 rad) from antiparallel (the plain formula lost up to 3e-4 there).  Only when
    ``|u + v| < 1e-15`` (numerically antiparallel) is R the half-turn about
    ``half_turn_axis`` (default: a fixed axis ⟂ u); it then maps u to within 1e-15 of v.
    Numeric u, v are normalised (they must be non-zero); on CasADi they must be unit
    vectors and the result is one smooth ``if_else`` expression.
    """
    u, v = _axis_arg(u, "u"), _axis_arg(v, "v")
    if half_turn_axis is not None:
        half_turn_axis = _axis_arg(half_turn_axis, "half_turn_axis")
    _same_batch({"u": u, "v": v, "half_turn_axis": half_turn_axis})
    if half_turn_axis is not None:
        if not B.any_symbolic(*half_turn_axis, *u):
            d = np.abs(sum(np.asarray(a) * np.asarray(b) for a, b in zip(half_turn_axis, u)))
            if np.any(d > 1e-9):
                raise InvalidInputError(
                    f"half_turn_axis must be perpendicular to u (|axis·u| = {float(np.max(d)):.3g})"
                )
    return _rotor_between(u, v, half_turn_axis)


def _same_batch(args: dict[str, Any]) -> None:
    """Numeric batch shapes of the arguments must broadcast together."""
    shapes = {k: np.shape(v[0]) for k, v in args.items() if v is not None and not B.any_symbolic(*v)}
    try:
        np.broadcast_shapes(*shapes.values())
    except ValueError:
        raise InvalidInputError(
            f"the batch shapes of {', '.join(f'{k} {s}' for k, s in shapes.items())} do not match"
        ) from None


def _is_zero_const(x: Any) -> bool:
    return not B.is_symbolic(x) and np.ndim(x) == 0 and float(x) == 0.0


def _rotor_between(u: tuple[Any, Any, Any], v: tuple[Any, Any, Any], half_turn_axis=None) -> Multivector:
    dot = u[0] * v[0] + u[1] * v[1] + u[2] * v[2]
    par = dot >= 0
    # s = v ∓ u, the difference that does not cancel (exact for nearby vectors); v ∧ u = s ∧ u
    s = tuple(v[i] if _is_zero_const(u[i]) else B.where(par, v[i] - u[i], v[i] + u[i]) for i in range(3))
    w12 = s[0] * u[1] - s[1] * u[0]
    w13 = s[0] * u[2] - s[2] * u[0]
    w23 = s[1] * u[2] - s[2] * u[1]
    # 1 + u·v: directly where it does not cancel, else |u ∧ v|²/(1 − u·v) (equal for unit u, v); then
    # 2(1 + u·v) = |1 + v u|² to relative ~ε for every angle (also for |u|, |v| = 1 ± ε), so R is unit
    ww = w12 * w12 + w13 * w13 + w23 * w23
    one_plus = B.where(par, 1.0 + dot, ww / B.where(par, 1.0, 1.0 - dot))
    anti = one_plus < 0.5 * _ANTI_N2  # |u + v|² = 2(1 + u·v) < 1e-30
    den = B.sqrt(2.0 * B.where(anti, 1.0, one_plus))
    a = half_turn_axis if half_turn_axis is not None else _perp_axis(u)
    # half-turn about axis a: −(a1 e23 − a2 e13 + a3 e12)
    half = (0.0, -a[2], a[1], -a[0])
    gen = (one_plus / den, w12 / den, w13 / den, w23 / den)
    coeffs = tuple(B.where(anti, h, g) for h, g in zip(half, gen))
    return Multivector(ROTOR_BLADES, coeffs)


def _similarity_from_params(kind, c1, r1, o1, c2, r2, o2, reference=None) -> Multivector:
    zero = 0.0 * c2[0]
    if o1 is not None and reference is not None:
        # chart about a reference axis a (Eq 26 from a instead of from the unit axis): R = R_min(a → o) R_min(o1 → a)
        a, Ra = reference
        R = _rotor_between(a, o2, _perp_axis(a)) * Ra
    elif o1 is not None:
        R = _rotor_between(o1, o2, _perp_axis(o1, UNIT_AXIS[kind] if _is_unit_axis(o1, kind) else None))
    else:
        R = Multivector(ROTOR_BLADES, (1.0 + zero, zero, zero, zero))
    if r1 is not None:
        if not B.any_symbolic(r1, r2) and not (np.all(np.asarray(r1) > 0) and np.all(np.asarray(r2) > 0)):
            raise DegeneratePrimitiveError(
                "the similarity needs primitives of non-zero radius (a zero-radius point pair, circle or sphere "
                "has no scale)"
            )
        with np.errstate(over="ignore"):
            scale = r2 / r1
        if not B.any_symbolic(scale):
            sa = np.asarray(scale, dtype=float)
            if not np.all(np.isfinite(sa) & (sa > 0)):
                raise DegeneratePrimitiveError(
                    f"the similarity needs a finite positive ratio of radii, got r2/r1 = {float(np.min(sa)):.3g} "
                    "(a zero-radius or unresolvable primitive)"
                )
            with np.errstate(over="ignore"):
                big = float(np.max(np.maximum(sa, 1.0 / sa)))
            est = EPS * big
            if est > PRECISION_WARN:
                warn(
                    f"similarity: the scale factor r2/r1 = {big:.3g} (or its inverse) "
                    f"is stored as cosh/sinh of ½ log(r2/r1); the versor carries a relative rounding error of "
                    f"~{est:.1g}",
                    PrecisionWarning,
                    key="similarity-scale",
                )
        beta = B.log(scale)
    else:
        scale, beta = 1.0, zero
    # rotated, scaled c1:  R c1 R̃ (vector part)
    c1v = Multivector((2, 4, 8), c1)
    Rc1 = (R * c1v * R.reverse()).grade(1)
    rc = (Rc1.get(2), Rc1.get(4), Rc1.get(8))
    if B.any_symbolic(*c2, *rc, scale):
        return _compose_trd(tuple(c2[i] - scale * rc[i] for i in range(3)), R, beta)
    with np.errstate(over="ignore", invalid="ignore"):
        t = tuple(c2[i] - scale * rc[i] for i in range(3))
        V = _compose_trd(t, R, beta)
    for c in V.coeffs:
        if not np.all(np.isfinite(c)):
            raise InvalidInputError(
                "the similarity is beyond the float64 range: its translation (or dilation) is too large to be "
                "represented as a versor"
            )
    return V


def _compose_trd(t, Rc, beta) -> Multivector:
    """V_T(t) · R · V_D(β) built directly from rotor coefficients (no log/exp round trip)."""
    from .groups import DILATOR_BLADES, SIMILARITY_BLADES, TRANSLATOR_BLADES

    T = Multivector(TRANSLATOR_BLADES, (1.0 + 0.0 * t[0], -0.5 * t[0], -0.5 * t[1], -0.5 * t[2]))
    # Rc may be a Multivector's coeffs on fewer blades (a half-turn rotor built symbolically has a
    # structurally zero scalar, which the algebra drops): lay it out on the rotor blades first
    R = Rc.with_blades(ROTOR_BLADES) if isinstance(Rc, Multivector) else Multivector(ROTOR_BLADES, Rc)
    D = Multivector(DILATOR_BLADES, (B.cosh(0.5 * beta), B.sinh(0.5 * beta)))
    return (T * R * D).with_blades(SIMILARITY_BLADES)  # the similarity blades are closed under *


def _unit_params(kind: Kind):
    z = (0.0, 0.0, 0.0)
    r = 1.0 if KIND_SPECS[kind].has_radius else None
    return z, r, UNIT_AXIS[kind]


def chart_reference(kind: Kind, axis: Any) -> tuple[tuple[float, float, float], Multivector] | None:
    """The reference ``(a, R_min(o_u → a))`` of a chart about the unit axis ``a`` (3,), or None (the
    canonical chart).  With it, the minimal rotation of the similarity is measured from a instead of
    from the unit primitive's axis o_u, so its half-turn discontinuity sits at −a (see
    :func:`similarity_from_unit`)."""
    kind = _check_kind(kind)
    o1 = UNIT_AXIS[kind]
    if axis is None or o1 is None:
        return None
    a = np.asarray(validation.vector(axis, 3, "chart axis"), dtype=float)
    n = float(np.linalg.norm(a))
    if not n > 0:
        raise InvalidInputError("the chart axis must be a non-zero 3-vector")
    a = a / n
    au = (float(a[0]), float(a[1]), float(a[2]))
    Ra = _rotor_between(o1, au, _perp_axis(o1, o1))
    return au, Ra


def similarity_from_unit(X: Multivector, chart_axis: Any = None) -> Multivector:
    """V_S(X_u, X): the similarity that maps the unit primitive of X's kind onto X (Eq 28).

    ``V = T(c) R(o_u → o) D(log r)`` with (c, r, o) read from X (module table).  Works
    on numeric and CasADi coefficients; the result lies on the 12 similarity blades.

    ``chart_axis`` (3,): measure the minimal rotation from that axis instead of from o_u,
    ``R = R_min(a → o) · R_min(o_u → a)`` (:func:`chart_reference`), which moves the chart's
    half-turn discontinuity from o = −o_u to o = −a.  Both charts map X_u onto X; they differ by
    a roll about o that no primitive sees.
    """
    kind, c, r, o, loss = _read_parameters(X)
    _warn_far(kind, (loss,))
    c1, r1, o1 = _unit_params(kind)
    return _similarity_from_params(
        kind, c1, r1, o1, _tuple3(c), r, None if o is None else _tuple3(o), reference=chart_reference(kind, chart_axis)
    )


def similarity(X_from: Multivector, X_to: Multivector) -> Multivector:
    """Similarity versor V = V_T V_R V_D with ``X_to ∝ V X_from Ṽ`` (§3.3, Eq 20).

    Both primitives must be of the same kind.  Use :func:`coop_ga.geometry.decompose` to get
    the factors.  See the module docstring for the orientation and half-turn rules.

    Precision: the result is accurate to a few ε relative to the primitives' coordinates
    (translation relative to ``ρ_to + s ρ_from``) when the primitives come from
    :func:`~coop_ga.geometry.primitives.primitive_from_points` (their radii are read from
    their local form).  A round without a local form (an untagged or transformed multivector)
    ρ/r radii from the origin holds its radius only to ~ε(ρ/r)²; then the scale and
    translation carry that error and a :class:`~coop_ga.PrecisionWarning` giving the estimate
    is emitted above :data:`PRECISION_WARN`.
    """
    k1, k2 = kind_of(X_from), kind_of(X_to)
    if k1 != k2:
        raise InvalidInputError(
            f"similarity() maps primitives of the same kind; got a {k1} and a {k2}. "
            f"Build both as one of {', '.join(KINDS)}"
        )
    _, c1, r1, o1, loss1 = _read_parameters(X_from)
    _, c2, r2, o2, loss2 = _read_parameters(X_to)
    _warn_far(k1, (loss1, loss2))  # r2/r1 carries both radii's errors, and t = c2 − (r2/r1) R c1 too
    return _similarity_from_params(
        k1, _tuple3(c1), r1, None if o1 is None else _tuple3(o1), _tuple3(c2), r2, None if o2 is None else _tuple3(o2)
    )


def similarity_from_parameters(kind: Kind, c: Any, r: Any, o: Any, chart_axis: Any = None) -> Multivector:
    """V_S(X_u, X) from the read-outs ``(c, r, o)`` of X (module table) instead of X itself.

    The same versor as :func:`similarity_from_unit` for a primitive with center (or closest
    point) ``c`` (3,) [m], radius ``r`` (None where undefined) and axis ``o`` (3,, unit; None
    where undefined).  Lets callers read the parameters where they are accurate — e.g. the
    cooperative layer reads them from the primitive built about the end points' centroid and
    shifts c back (:mod:`coop_ga.cooperative.graph`).  Numeric or CasADi.  ``chart_axis``: see
    :func:`similarity_from_unit`.
    """
    kind = _check_kind(kind)
    c1, r1, o1 = _unit_params(kind)
    c = _vec3(c, "c")
    if r1 is not None:
        if r is None:
            raise InvalidInputError(f"similarity_from_parameters: a {kind} needs its radius r")
        if not B.is_symbolic(r):
            if type(r) is int and not -1e308 <= r <= 1e308:
                raise InvalidInputError("r must be a real number in the float range")
            r = validation.positive(r, "r") if np.ndim(r) == 0 else _positive_array(r, "r")
    if o1 is not None:
        if o is None:
            raise InvalidInputError(f"similarity_from_parameters: a {kind} needs its axis o")
        o = _axis_arg(o, "o")
    batch = {"c": c, "o": o if o1 is not None else None}
    if r1 is not None and not B.is_symbolic(r):
        batch["r"] = (r,)
    _same_batch(batch)
    return _similarity_from_params(
        kind, c1, r1, o1, c, r, None if o1 is None else o, reference=chart_reference(kind, chart_axis)
    )


def _positive_array(r: Any, name: str) -> np.ndarray:
    a = validation.array(r, name)
    if not np.all(a > 0):
        raise InvalidInputError(f"{name} must be > 0, got {a.tolist()}")
    return a
