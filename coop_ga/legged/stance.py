"""The stance feet as a cooperative primitive (issue 13, item 4; seed 003 §3, §5.3, §5.6).

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
import threading
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import validation
from ..cooperative.primitive import fit_parameters, fit_primitive, fit_well_definedness
from ..cooperative.task import CooperativeTask, cooperative_task
from ..errors import DegeneratePrimitiveError, InvalidInputError
from ..geometry.primitives import Primitive, center, circle, normal, plane, radius, sphere, well_definedness

__all__ = ["LEGS", "STANCE_KINDS", "STANCE_ORDER", "StancePrimitive", "stance_order", "stance_primitive", "stance_task"]

#: the legs of this package, in its order (URDF order)
LEGS: tuple[str, ...] = ("lf", "lm", "lr", "rf", "rm", "rr")
#: the legs counter-clockwise seen from above (+z of B), starting at the left front: the order of the stance
#: feet in :func:`stance_task` (so circles and planes of the stance feet have their normal up, +z)
STANCE_ORDER: tuple[str, ...] = ("lf", "lm", "lr", "rr", "rm", "rf")
#: the kinds :func:`stance_primitive` and :func:`stance_task` accept
STANCE_KINDS: tuple[str, ...] = ("sphere", "plane", "circle", "sphere_fit", "plane_fit")

#: well-definedness at or below which a stance plane or circle (collinear feet) raises
_RAISE_BELOW = 1e-6


@dataclass(frozen=True)
class StancePrimitive:
    """The primitive of the stance feet chosen by :func:`stance_primitive`.

    Attributes
    ----------
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

    kind: str
    task_kind: str
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
    return DegeneratePrimitiveError(
        f"stance {kind} of {P.shape[0]} feet (points) {np.round(P, 4).tolist()}: the feet are (nearly) "
        f"{'coplanar' if kind == 'sphere' else 'collinear'} (well-definedness {w:.3g}); no {kind} through them"
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
    if kind == "sphere" and k < 4:
        raise InvalidInputError(f"a stance sphere needs at least 4 feet, got {k} (use 'plane' or 'circle')")
    if kind == "circle":
        if k != 3:
            raise InvalidInputError(f"a stance circle goes through exactly 3 feet, got {k} (use 'plane' or 'sphere')")
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
    sw: float | None = None
    sr: float | None = None
    why = ""
    if k >= 4 and kind in (None, "sphere"):
        sw, c, r = _sphere_of(P)
        task_kind = "sphere" if k == 4 else "sphere_fit"
        what = "the sphere through the 4 feet" if k == 4 else f"the least-squares sphere of the {k} feet"
        if (sw >= w_min and r <= r_max) or (kind == "sphere" and sw > _RAISE_BELOW):
            sr = r
            X = sphere(*P) if k == 4 else fit_primitive("sphere_fit", P, raise_below=_RAISE_BELOW)
            why = (
                f"sphere: {what}, well-definedness {sw:.3g} ≥ w_min {w_min:g} and radius {r:.4g} m ≤ r_max {r_max:g} m"
                if kind is None
                else f"sphere requested: {what}, well-definedness {sw:.3g}, radius {r:.4g} m"
            )
            return StancePrimitive("sphere", task_kind, X, sw, idx, why, c, r, None, sw, r)
        if kind == "sphere":
            raise _degenerate("sphere", sw, P)
        if sw < w_min:
            why = f"{what} is ill-defined, the feet are (nearly) coplanar: well-definedness {sw:.3g} < w_min {w_min:g}"
        else:
            sr = r
            why = f"{what} is too large: radius {r:.4g} m > r_max {r_max:g} m (well-definedness {sw:.3g})"
    w, c, n = _plane_of(P)
    if not w > _RAISE_BELOW:
        raise _degenerate("plane", w, P)
    if k == 3:
        X = plane(*P)
        task_kind = "plane"
        what = "plane through the 3 feet"
    else:
        X = fit_primitive("plane_fit", P, raise_below=_RAISE_BELOW)
        task_kind = "plane_fit"
        what = f"least-squares plane of the {k} feet"
    reason = f"{what} (well-definedness {w:.3g})" + (f": {why}" if why else "")
    if kind == "plane":
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


def _task_kind(kind: str | None, k: int, legs: tuple[str, ...]) -> str:
    if kind is None:
        kind = "plane" if k == 3 else "sphere"
    validation.choice(kind, STANCE_KINDS, "kind")
    need = {"sphere": 4, "sphere_fit": 4, "plane": 3, "plane_fit": 3, "circle": 3}[kind]
    if k < need or (kind == "circle" and k != 3):
        raise InvalidInputError(
            f"a stance {kind} needs {'exactly 3' if kind == 'circle' else f'at least {need}'} stance feet, "
            f"got {k} in stance_legs ({', '.join(legs)})"
        )
    if kind == "sphere" and k > 4:
        return "sphere_fit"
    if kind == "plane" and k > 3:
        return "plane_fit"
    return kind


_CACHE: dict[tuple[Any, ...], CooperativeTask] = {}
_LOCK = threading.Lock()


def stance_task(
    system: Any, stance_legs: Sequence[str], kind: str | None = None, *, codegen: bool | str = "auto"
) -> CooperativeTask:
    """The :class:`~coop_ga.cooperative.CooperativeTask` of the stance primitive over the feet of
    ``stance_legs`` (names from :data:`LEGS`, indices, or a (6,) bool mask) of ``system`` (a System or a
    registered name, normally the fixed-base ``"hexapod"``: end frames ``{leg}_foot``, body frame B).

    The feet are taken in :data:`STANCE_ORDER` (counter-clockwise from above: plane and circle normals up,
    near the unit axis +e3, far from the chart's half-turn).  ``kind``: one of :data:`STANCE_KINDS` or None
    (3 feet → ``"plane"``, 4 → ``"sphere"``, more → ``"sphere_fit"``); ``"sphere"`` with more than 4 feet
    is the least-squares ``"sphere_fit"``, ``"plane"`` with more than 3 the ``"plane_fit"`` — so
    ``stance_task(sys, legs, stance_primitive(feet).task_kind)`` or ``… .kind`` give the task of the chosen
    primitive.  On flat ground the sphere tasks raise :class:`~coop_ga.errors.DegeneratePrimitiveError` when
    evaluated (coplanar feet): choose the kind with :func:`stance_primitive`.

    ``codegen``: as :class:`~coop_ga.cooperative.CooperativeTask` (``False``: the CasADi VM, no compilation).
    Cached per (system, legs, kind, codegen) and safe to share between threads (the cache is guarded by a
    lock; the task's compiled functions use per-thread buffers)."""
    from ..systems import System, load

    if isinstance(system, str):
        system = load(system)
    if not isinstance(system, System):
        raise InvalidInputError(f"system must be a coop_ga System or a registered name, got {type(system).__name__}")
    legs = stance_order(stance_legs)
    k = len(legs)
    tk = _task_kind(kind, k, legs)
    frames = tuple(system.end_frames)
    missing = [f"{leg}_foot" for leg in legs if f"{leg}_foot" not in frames]
    if missing:
        raise InvalidInputError(
            f"system '{getattr(system, 'name', '?')}' has no end frame {missing} (its end frames: {', '.join(frames)})"
        )
    pts = tuple(frames.index(f"{leg}_foot") for leg in legs)
    if codegen not in ("auto", True, False):
        raise InvalidInputError(f"codegen must be 'auto', True or False, got {codegen!r}")
    key = (id(system), legs, tk, codegen)
    with _LOCK:
        t = _CACHE.get(key)
        if t is None or t.system is not system:
            t = cooperative_task(system, tk, points=pts, codegen=codegen)
            _CACHE[key] = t
    return t
