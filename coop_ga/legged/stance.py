"""The stance feet as a cooperative primitive (seed 003 §3, §5.3, §5.6).

:func:`stance_primitive` turns the k stance feet into one CGA primitive, and :func:`stance_task` gives the
:class:`~coop_ga.cooperative.CooperativeTask` of that primitive over the named feet of the fixed-base
``hexapod`` system (body frame B), whose V_Sc, B_Sc and J^G come from the one task graph of
:mod:`coop_ga.cooperative.graph` — including the least-squares kinds ``"sphere_fit"`` / ``"plane_fit"``.

Decision rule of :func:`stance_primitive` (``kind=None``)
-------------------------------------------------------
1. **k ≥ 4 feet → sphere**, if it is well defined: the exact sphere through the feet for k = 4, the CGA
   least-squares sphere for k > 4 (the smallest non-negative eigenvalue solution S of Σ (P_i·S)² with
   S² = 1, :mod:`coop_ga.cooperative.primitive`).  Well defined means both
   * the well-definedness w ≥ ``w_min`` (default 1e-2): for k = 4 :func:`coop_ga.well_definedness` of the
     four feet (smallest tetrahedron altitude / longest edge, normalised; 0 = coplanar), for k > 4 the
     largest such measure of any 4 of the feet (the §5.3 measure the cooperative guard uses, on subsets);
   * its radius r ≤ ``r_max`` (default 5 m): nearly coplanar feet that pass the w test can still span a
     huge, physically meaningless sphere.
2. **Otherwise (and for k = 3) → plane**: the plane through the three feet (k = 3), the least-squares
   (orthogonal-distance) plane of all of them (k > 3, kind ``"plane_fit"`` in the task graph).  Its
   normal follows the order of the points (right hand; for the legs of :func:`stance_task`, ordered
   counter-clockwise seen from above, it points up).
3. ``kind="circle"`` asks for the circle through exactly three feet (a tripod); ``kind="plane"`` /
   ``"sphere"`` force that kind (the sphere raises when degenerate).

On flat ground every stance is coplanar: the 4-foot sphere has w = 0 (to round-off) and the rule
switches to the plane, so no NaN and no 1e9-metre radius is ever returned.  Feet that are collinear
(w of the plane ≤ 1e-6) raise :class:`~coop_ga.errors.DegeneratePrimitiveError`.

Measured on the random tiles (``Terrain.random``, 0–25 mm, seeds 0–39, the stand footprint moved by
(0.1, −0.05) m): the sphere was chosen for 70 % / 80 % / 85 % of the 4- / 5- / 6-foot stances, with radii
0.59–2.25 m / 0.71–4.85 m / 0.67–4.88 m (median 1.06 / 1.28 / 1.41 m) and sphere well-definedness up to
0.045 / 0.061 / 0.071 (median 0.016 / 0.033 / 0.040): these spheres are always close to the w_min
threshold, i.e. a posture controller driving them sees an ill-conditioned J^G (§5.3).  (For feet that
are nearly *cocircular* a vertical offset is tangent to the sphere with their circle as its equator, and
the least-squares sphere tends to that one, radius ≈ the circle's.)

Units: m.  Frames: whatever frame the points are given in (B for :func:`stance_task`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import validation
from ..cooperative.primitive import fit_parameters, fit_primitive, fit_well_definedness
from ..cooperative.task import CooperativeTask, cooperative_task
from ..errors import DegeneratePrimitiveError, InvalidInputError
from ..geometry.kinds import KIND_SPECS, CooperativeKind, Kind, KindSpec
from ..geometry.primitives import Primitive, center, circle, normal, plane, radius, sphere, well_definedness

__all__ = [
    "CARRIED",
    "LEGS",
    "ROWS",
    "STANCE_KINDS",
    "STANCE_ORDER",
    "StancePrimitive",
    "carried_rows",
    "stance_order",
    "stance_primitive",
    "stance_task",
    "uncarried",
]

#: the legs of this package, in its order (URDF order)
LEGS: tuple[str, ...] = ("lf", "lm", "lr", "rf", "rm", "rr")
#: the legs counter-clockwise seen from above (+z of B), starting at the left front: the order of the stance
#: feet in :func:`stance_task` (so circles and planes of the stance feet have their normal up, +z)
STANCE_ORDER: tuple[str, ...] = ("lf", "lm", "lr", "rr", "rm", "rf")
#: the kinds :func:`stance_task` accepts (:func:`stance_primitive` chooses among sphere, plane and circle; a point
#: pair of two stance feet carries the rotations about axes across it, e.g. the yaw)
STANCE_KINDS: tuple[str, ...] = ("sphere", "plane", "circle", "sphere_fit", "plane_fit", "point_pair")

#: the rows of a similarity twist, ``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]`` (the tangent convention of
#: :mod:`coop_ga.geometry`; e12 turns x toward y, i.e. about +z)
ROWS: tuple[str, ...] = ("e12", "e13", "e23", "e0∞", "e1∞", "e2∞", "e3∞")

_T, _F = True, False
#: What a stance primitive can carry when the body moves over **fixed** feet: the rows of a primitive-frame
#: twist (unit primitive of :func:`coop_ga.geometry.similarity.unit_primitive`: sphere and circle about the
#: origin, the circle and plane with normal +e3, the point pair along e2) that a rigid body motion changes.
#: Seed 003, Table 1 lists the controllable blades of each primitive; with the feet fixed the distances
#: between them are fixed too, so the e0∞ row (radius, length) is never carried.  The other rows leave the
#: unit primitive where it is (its stabiliser): a command along them cannot be seen by that primitive.
#:
#: ==========  =========================  ============================================================
#: kind        carries (feet fixed)       cannot carry
#: ==========  =========================  ============================================================
#: sphere      e1∞ e2∞ e3∞ (centre)       e12 e13 e23 (any rotation about its centre), e0∞ (radius)
#: circle      e13 e23 (tilt) e1∞–e3∞     e12 (rotation about its axis), e0∞ (radius)
#: plane       e13 e23 (tilt) e3∞         e12 (rotation about its normal), e1∞ e2∞ (in-plane
#:             (offset)                   translation), e0∞ (a plane has no scale)
#: point_pair  e12 e23 (turns across the  e13 (rotation about its own axis), e0∞ (length)
#:             pair) e1∞–e3∞ (midpoint)
#: ==========  =========================  ============================================================
CARRIED: dict[str, tuple[bool, ...]] = {
    "sphere": (_F, _F, _F, _F, _T, _T, _T),
    "circle": (_F, _T, _T, _F, _T, _T, _T),
    "plane": (_F, _T, _T, _F, _F, _F, _T),
    "point_pair": (_T, _F, _T, _F, _T, _T, _T),
}

_ROTATIONS = (
    "a circle or plane of 3 stance feet carries the tilt (e13, e23 about its normal), a point pair of 2 stance "
    "feet the rotation about the vertical (e12 across the pair)"
)
_NO_SCALE = (
    "no stance primitive: the distances between fixed feet cannot change (command a translation of the body "
    "instead, e.g. toward the primitive's centre to crouch)"
)
#: (kind, row) → (what the row is for that primitive, which stance primitive carries that motion instead)
_UNCARRIED: dict[tuple[str, int], tuple[str, str]] = {
    **{
        ("sphere", i): ("rotation about the sphere's centre (a sphere has no rotation rows)", _ROTATIONS)
        for i in range(3)
    },
    ("sphere", 3): ("a radius change", _NO_SCALE),
    ("circle", 0): (
        "rotation about the circle's axis",
        "a point pair of 2 stance feet (its e12 turns about an axis across the pair, e.g. the vertical)",
    ),
    ("circle", 3): ("a radius change", _NO_SCALE),
    ("plane", 0): (
        "rotation about the plane's normal (yaw)",
        "a point pair of 2 stance feet (its e12 turns about an axis across the pair, e.g. the vertical)",
    ),
    ("plane", 3): (
        "a dilation, which does not change a plane",
        "the plane's offset e3∞ (translation along its normal)",
    ),
    ("plane", 4): (
        "translation in the plane",
        "a circle of 3 stance feet or a sphere of 4 non-coplanar feet (their centre)",
    ),
    ("plane", 5): (
        "translation in the plane",
        "a circle of 3 stance feet or a sphere of 4 non-coplanar feet (their centre)",
    ),
    ("point_pair", 1): ("rotation about the pair's own axis", "a circle or plane of 3 stance feet (tilt, e13 / e23)"),
    ("point_pair", 3): ("a length change", _NO_SCALE),
}


def _primitive_kind(kind: str) -> Kind:
    """The exact kind (:attr:`~coop_ga.geometry.kinds.KindSpec.primitive_kind`) of a stance kind: a least-squares
    kind carries what the kind it fits carries (``"sphere_fit"`` → ``"sphere"``)."""
    spec = KIND_SPECS.get(kind) if isinstance(kind, str) else None
    if spec is None or spec.primitive_kind not in CARRIED:
        raise InvalidInputError(
            f"a stance primitive kind is one of {', '.join(CARRIED)} (or a _fit kind of those), got {kind!r}"
        )
    return spec.primitive_kind


def carried_rows(kind: str) -> np.ndarray:
    """(7,) bool: the rows of a primitive-frame twist that a stance primitive of ``kind`` (``"sphere"``,
    ``"circle"``, ``"plane"``, ``"point_pair"`` or a ``_fit`` kind) carries with the feet fixed (:data:`CARRIED`)."""
    return np.array(CARRIED[_primitive_kind(kind)], dtype=bool)


def uncarried(kind: str, row: int) -> tuple[str, str]:
    """``(meaning, alternative)`` of a row (index into :data:`ROWS`) that a stance primitive of ``kind`` cannot
    carry: what that row means for the primitive, and which stance primitive carries the motion instead.
    Raises :class:`~coop_ga.errors.InvalidInputError` for a carried row."""
    k = _primitive_kind(kind)
    if not 0 <= int(row) < 7 or CARRIED[k][int(row)]:
        raise InvalidInputError(f"row {row!r} is not an uncarried row of a {k} (uncarried: "
                                f"{[ROWS[i] for i in range(7) if not CARRIED[k][i]]})")  # fmt: skip
    return _UNCARRIED[(k, int(row))]


#: well-definedness at or below which a stance plane or circle (collinear feet) raises
_RAISE_BELOW = 1e-6


@dataclass(frozen=True)
class StancePrimitive:
    """The primitive of the stance feet chosen by :func:`stance_primitive`.

    Attributes:
        kind: ``"sphere"``, ``"plane"`` or ``"circle"`` (the primitive's kind, = ``X.kind``).
        task_kind: the task-graph kind that computes it: ``"sphere"`` (4 feet), ``"sphere_fit"`` (> 4),
            ``"plane"`` (3), ``"plane_fit"`` (> 3), ``"circle"`` — pass it to :func:`stance_task`.
        X: the CGA primitive (direct form), in the frame of the points.
        well_definedness: of the chosen primitive (1 best, 0 degenerate; module docstring).
        indices: (k,) the points used, in the order used (all of them: the fits use every foot).
        reason: why this kind (the numbers of the decision rule).
        center: (3,) [m] the sphere's / circle's centre, or the plane's point nearest the feet's centroid
            (the centroid's projection).
        radius: [m] the sphere's / circle's radius; None for a plane.
        normal: (3,) unit normal of a plane / circle (right hand from the point order); None for a sphere.
        sphere_well_definedness: the sphere measure of the feet (k ≥ 4; None for k = 3), also when the plane
            was chosen.
        sphere_radius: [m] the radius the sphere would have (None when k = 3 or the sphere was not tried
            because w < w_min).
    """

    kind: Kind
    task_kind: CooperativeKind
    X: Primitive
    well_definedness: float
    indices: tuple[int, ...]
    reason: str
    center: np.ndarray
    radius: float | None
    normal: np.ndarray | None
    sphere_well_definedness: float | None = None
    sphere_radius: float | None = None


def _points(points: Any) -> np.ndarray:
    P = validation.array(points, "points")
    if P.ndim != 2 or P.shape[1] != 3:
        raise InvalidInputError(f"points must be the stance feet as a (k, 3) array [m], got shape {P.shape}")
    if P.shape[0] < 3:
        raise InvalidInputError(
            f"points: a stance primitive needs at least 3 stance feet (plane or circle), got {P.shape[0]}; with "
            "fewer feet the robot does not stand"
        )
    return P


def _sphere_of(P: np.ndarray) -> tuple[float, np.ndarray, float]:
    """(w, centre, radius) of the exact (k = 4) or least-squares (k > 4) sphere; the radius only read for w > 0."""
    k = P.shape[0]
    w = float(well_definedness("sphere", P)) if k == 4 else float(fit_well_definedness("sphere_fit", P))
    if not w > 0.0:
        return w, np.full(3, np.nan), math.inf
    bar, c, r, _ = fit_parameters("sphere_fit", [tuple(p) for p in P.tolist()])
    return w, np.array(bar) + np.array([float(v) for v in c]), float(r)


def _plane_of(P: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """(w, point = centroid, unit normal) of the exact (k = 3) or least-squares (k > 3) plane."""
    k = P.shape[0]
    w = float(well_definedness("plane", P)) if k == 3 else float(fit_well_definedness("plane_fit", P))
    bar, _, _, o = fit_parameters("plane_fit", [tuple(p) for p in P.tolist()])
    return w, np.array(bar), np.array([float(v) for v in o])


def _degenerate(kind: str, w: float, P: np.ndarray) -> DegeneratePrimitiveError:
    how = KIND_SPECS[kind].degenerate.removeprefix("are ")  # "coplanar", "collinear" (KindSpec.degenerate)
    return DegeneratePrimitiveError(
        f"stance {kind} of {P.shape[0]} feet (points) {np.round(P, 4).tolist()}: the feet are (nearly) "
        f"{how} (well-definedness {w:.3g}); no {kind} through them"
    )


def _exact_or_fit(spec: KindSpec, k: int) -> CooperativeKind:
    """The task-graph kind of ``spec``'s primitive through ``k`` points: the exact kind for exactly
    :attr:`~KindSpec.n_points` of them, its least-squares :attr:`~KindSpec.fit_kind` for more."""
    return spec.name if k == spec.n_points or spec.fit_kind is None else spec.fit_kind


def _circle_of(P: np.ndarray, idx: tuple[int, ...]) -> StancePrimitive:
    """The stance circle through the 3 feet ``P`` (3, 3) [m] (asked for by name; collinear feet raise)."""
    w = float(well_definedness("circle", P))
    if not w > _RAISE_BELOW:
        raise _degenerate("circle", w, P)
    X = circle(*P)
    return StancePrimitive(
        "circle",
        "circle",
        X,
        w,
        idx,
        f"circle through the 3 feet requested (well-definedness {w:.3g})",
        np.asarray(center(X), float).reshape(3),
        float(radius(X)),
        np.asarray(normal(X), float).reshape(3),
    )


def stance_primitive(
    points: Any, *, w_min: float = 1e-2, r_max: float = 5.0, kind: str | None = None
) -> StancePrimitive:
    """The cooperative primitive of the stance feet ``points`` (k, 3) [m] (any frame), by the decision rule of
    the module docstring: ≥ 4 well-defined feet (w ≥ ``w_min``, radius ≤ ``r_max`` [m]) → sphere (exact for
    k = 4, least-squares for k > 4; seed 003 §5.6), otherwise a plane (exact for k = 3, least-squares for
    k > 3); ``kind="circle"`` for the circle through 3 feet, ``"plane"`` / ``"sphere"`` to force a kind.
    Never NaN: degenerate feet fall back to the plane, or raise
    :class:`~coop_ga.errors.DegeneratePrimitiveError` (collinear feet, or a forced degenerate sphere)."""
    P = _points(points)
    k = P.shape[0]
    w_min = validation.nonnegative(w_min, "w_min")
    r_max = validation.positive(r_max, "r_max", allow_inf=True)
    if kind is not None:
        validation.choice(kind, ("sphere", "plane", "circle"), "kind")
    idx = tuple(range(k))
    spec = KIND_SPECS[kind] if kind is not None else None
    if spec is not None and spec.fit_kind is not None and k < spec.n_points:
        raise InvalidInputError(
            f"a stance {kind} needs at least {spec.n_points} feet, got {k} (use 'plane' or 'circle')"
        )
    if spec is not None and spec.fit_kind is None:  # the circle: no least-squares kind, exactly its points
        if k != spec.n_points:
            raise InvalidInputError(
                f"a stance {kind} goes through exactly {spec.n_points} feet, got {k} (use 'plane' or 'sphere')"
            )
        return _circle_of(P, idx)
    sw: float | None = None
    sr: float | None = None
    why = ""
    sph = KIND_SPECS["sphere"]
    forced = spec is sph  # the sphere was asked for (None: the decision rule may choose it)
    if k >= sph.n_points and (spec is None or forced):
        sw, c, r = _sphere_of(P)
        task_kind = _exact_or_fit(sph, k)
        what = "the sphere through the 4 feet" if k == 4 else f"the least-squares sphere of the {k} feet"
        if (sw >= w_min and r <= r_max) or (forced and sw > _RAISE_BELOW):
            sr = r
            X = sphere(*P) if task_kind == sph.name else fit_primitive("sphere_fit", P, raise_below=_RAISE_BELOW)
            why = (
                f"sphere: {what}, well-definedness {sw:.3g} ≥ w_min {w_min:g} and radius {r:.4g} m ≤ r_max {r_max:g} m"
                if kind is None
                else f"sphere requested: {what}, well-definedness {sw:.3g}, radius {r:.4g} m"
            )
            return StancePrimitive("sphere", task_kind, X, sw, idx, why, c, r, None, sw, r)
        if forced:
            raise _degenerate("sphere", sw, P)
        if sw < w_min:
            why = f"{what} is ill-defined, the feet are (nearly) coplanar: well-definedness {sw:.3g} < w_min {w_min:g}"
        else:
            sr = r
            why = f"{what} is too large: radius {r:.4g} m > r_max {r_max:g} m (well-definedness {sw:.3g})"
    w, c, n = _plane_of(P)
    if not w > _RAISE_BELOW:
        raise _degenerate("plane", w, P)
    pl = KIND_SPECS["plane"]
    task_kind = _exact_or_fit(pl, k)
    if task_kind == pl.name:
        X = plane(*P)
        what = "plane through the 3 feet"
    else:
        X = fit_primitive("plane_fit", P, raise_below=_RAISE_BELOW)
        what = f"least-squares plane of the {k} feet"
    reason = f"{what} (well-definedness {w:.3g})" + (f": {why}" if why else "")
    if spec is pl:
        reason = "requested: " + reason
    return StancePrimitive("plane", task_kind, X, w, idx, reason, c, None, n, sw, sr)


# ---------------------------------------------------------------------- the task of the stance feet
def stance_order(stance_legs: Any) -> tuple[str, ...]:
    """The stance legs (names from :data:`LEGS`, indices into it, or a (6,) bool mask over it) as names in
    :data:`STANCE_ORDER` (counter-clockwise seen from above), without repeats."""
    if isinstance(stance_legs, str):
        raise InvalidInputError(
            f"stance_legs must be a sequence of leg names from {LEGS}, got the string {stance_legs!r}"
        )
    if isinstance(stance_legs, np.ndarray) and stance_legs.dtype == np.bool_:
        if stance_legs.shape != (len(LEGS),):
            raise InvalidInputError(f"stance_legs as a mask must have shape (6,) over {LEGS}, got {stance_legs.shape}")
        names = {LEGS[i] for i in np.flatnonzero(stance_legs)}
    elif isinstance(stance_legs, Sequence | np.ndarray):
        names = set()
        for leg in list(stance_legs):
            if isinstance(leg, str) and leg in LEGS:
                names.add(leg)
            elif isinstance(leg, int | np.integer) and not isinstance(leg, bool) and 0 <= int(leg) < len(LEGS):
                names.add(LEGS[int(leg)])
            else:
                raise InvalidInputError(f"stance_legs: {leg!r} is neither a leg name of {LEGS} nor an index 0..5")
    else:
        raise InvalidInputError(f"stance_legs must be a sequence of leg names from {LEGS}, got {stance_legs!r}")
    return tuple(leg for leg in STANCE_ORDER if leg in names)


def _task_kind(kind: str | None, k: int, legs: tuple[str, ...]) -> CooperativeKind:
    if kind is None:
        kind = "plane" if k == 3 else "sphere"
    validation.choice(kind, STANCE_KINDS, "kind")
    spec = KIND_SPECS[kind]
    need = spec.n_points
    exact = not spec.least_squares and spec.fit_kind is None  # through exactly its points (circle, point pair)
    if k < need or (exact and k != need):
        raise InvalidInputError(
            f"a stance {kind} needs {f'exactly {need}' if exact else f'at least {need}'} stance feet, "
            f"got {k} in stance_legs ({', '.join(legs)})"
        )
    return spec.name if spec.least_squares else _exact_or_fit(spec, k)


#: the order of a point pair's two feet in :func:`stance_task` (right side first, rear to front)
_PAIR_ORDER: tuple[str, ...] = ("rr", "rm", "rf", "lr", "lm", "lf")


def stance_task(
    system: Any, stance_legs: Sequence[str], kind: str | None = None, *, codegen: bool | str = "auto"
) -> CooperativeTask:
    """The :class:`~coop_ga.cooperative.CooperativeTask` of the stance primitive over the feet of
    ``stance_legs`` (names from :data:`LEGS`, indices, or a (6,) bool mask) of ``system`` (a System or a
    registered name, normally the fixed-base ``"hexapod"``: end frames ``{leg}_foot``, body frame B).

    The feet are taken in :data:`STANCE_ORDER` (counter-clockwise from above: plane and circle normals up,
    near the unit axis +e3, far from the chart's half-turn); the two feet of a ``"point_pair"`` right before
    left and rear before front (the pair points toward +y or +x of B, never near −e2, the cut of its chart).  ``kind``: one of :data:`STANCE_KINDS` or None
    (3 feet → ``"plane"``, 4 → ``"sphere"``, more → ``"sphere_fit"``); ``"sphere"`` with more than 4 feet
    is the least-squares ``"sphere_fit"``, ``"plane"`` with more than 3 the ``"plane_fit"`` — so
    ``stance_task(sys, legs, stance_primitive(feet).task_kind)`` or ``… .kind`` give the task of the chosen
    primitive.  On flat ground the sphere tasks raise :class:`~coop_ga.errors.DegeneratePrimitiveError` when
    evaluated (coplanar feet): choose the kind with :func:`stance_primitive`.

    ``codegen``: as :class:`~coop_ga.cooperative.CooperativeTask` (``False``: the CasADi VM, no compilation).
    Cached by :func:`~coop_ga.cooperative.cooperative_task` (per system, kind, feet and codegen, the
    :data:`~coop_ga.cooperative.task.TASK_CACHE_SIZE` most recently used) and safe to share between threads (the
    task's compiled functions use per-thread buffers)."""
    from ..systems import System, load

    if isinstance(system, str):
        system = load(system)
    if not isinstance(system, System):
        raise InvalidInputError(f"system must be a coop_ga System or a registered name, got {type(system).__name__}")
    legs = stance_order(stance_legs)
    k = len(legs)
    tk = _task_kind(kind, k, legs)
    if (
        KIND_SPECS[tk].axis_role == "direction"
    ):  # a point pair: right before left, rear before front: the pair points toward +y (or +x), far from
        legs = tuple(sorted(legs, key=_PAIR_ORDER.index))  # the −e2 antipode of the unit pair's axis (the chart's cut)
    frames = tuple(system.end_frames)
    missing = [f"{leg}_foot" for leg in legs if f"{leg}_foot" not in frames]
    if missing:
        raise InvalidInputError(
            f"system '{getattr(system, 'name', '?')}' has no end frame {missing} (its end frames: {', '.join(frames)})"
        )
    pts = tuple(frames.index(f"{leg}_foot") for leg in legs)
    if codegen not in ("auto", True, False):
        raise InvalidInputError(f"codegen must be 'auto', True or False, got {codegen!r}")
    # no cache of its own: cooperative_task keeps a bounded one keyed by the same (system, kind, points, codegen)
    return cooperative_task(system, tk, points=pts, codegen=codegen)
