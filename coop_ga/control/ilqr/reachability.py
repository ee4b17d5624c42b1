"""Why a target is not reached (package docstring of :mod:`coop_ga.control.ilqr`, "Fast honest failure"): a certificate
that the target primitive misses the reach of an end point (:func:`unreachable`, before any iteration), and the
stationarity of ‖e‖ within the limits at the end configuration of an iterate (:func:`bounded_stationarity`, the stall
test of the solver)."""

from __future__ import annotations

import math

import numpy as np

from ...geometry.kinds import KIND_SPECS, Kind
from .problem import ReachingOCP

__all__ = ["BOUND_ACTIVE", "bounded_stationarity", "reach_balls", "unit_distance", "unreachable"]

#: [rad or m] a joint this close to a position limit counts as on it (as in the result messages)
BOUND_ACTIVE = 1e-3


def unit_distance(kind: Kind, y: np.ndarray) -> float:
    """Distance of the point y (3,) [m] from the unit primitive X_u of the exact ``kind``
    (:func:`coop_ga.geometry.unit_primitive`: the origin; the points (0, ∓1, 0); the e2 axis; the unit circle in
    z = 0; the plane z = 0; the unit sphere), from its :class:`~coop_ga.geometry.kinds.KindSpec`: X_u passes through
    the origin with its axis a (flats) or is centred there with radius 1 (rounds)."""
    spec = KIND_SPECS[kind]
    y = np.asarray(y, dtype=float)
    if spec.dimension == 0:  # a point or a point pair: its unit points themselves
        return min(float(np.linalg.norm(y - p)) for p in spec.unit_points)
    if spec.axis is None:  # the unit sphere
        return abs(float(np.linalg.norm(y)) - 1.0)
    a = np.asarray(spec.axis)
    along = float(y @ a)
    off = math.hypot(*(y - along * a))  # distance from the axis through the origin
    if spec.flat:  # the axis itself (a line) or the plane through the origin normal to it
        return off if spec.axis_role == "direction" else abs(along)
    return math.hypot(off - 1.0, along)  # the unit circle about the axis


def reach_balls(ocp: ReachingOCP) -> list[tuple[np.ndarray, float]] | None:
    """For each end point of the task, a ball (centre (3,) [m], radius [m]) that contains every position it can take
    within the position limits; None if the task has no kinematic tree.

    Centre: the origin of the chain's first joint (fixed in the world).  Radius: by the triangle inequality, the sum
    of the lengths of the later joint placements and of the end frame's offset (a revolute joint turns about an axis
    through its origin, so it does not move a point away from it by more than that), plus the largest travel of each
    prismatic joint (infinite without position limits).
    """
    tree = getattr(ocp.task, "tree", None)
    if tree is None or not hasattr(tree, "chains"):
        return None
    model = tree.model
    travel = np.maximum(np.abs(ocp.q_lower), np.abs(ocp.q_upper))
    balls = []
    for chain, fname in zip(tree.chains, tree.end_frames):
        offset = np.asarray(model.frames[model.getFrameId(fname)].placement.translation, dtype=float)
        if not chain:
            balls.append((offset, 0.0))
            continue
        radius = float(np.linalg.norm(offset))
        radius += sum(float(np.linalg.norm(model.jointPlacements[j].translation)) for j in chain[1:])
        radius += sum(float(travel[tree.joints[j].q_index]) for j in chain if tree.joints[j].kind == "prismatic")
        balls.append((np.asarray(model.jointPlacements[chain[0]].translation, dtype=float), radius))
    return balls


def unreachable(ocp: ReachingOCP, tol: float) -> str | None:
    """A certificate that no configuration within the limits reaches ‖e‖ < tol, or None.

    ‖e‖ = 0 puts every end point on the target primitive X_d = V_Sd X_u Ṽ_Sd (the cooperative primitive passes through
    them, and e = 0 makes it X_d).  If X_d does not meet the ball that contains every position of some end point
    (:func:`reach_balls`), no configuration reaches the target.  ‖e‖ < tol moves the end points off X_d by at most
    ~tol·(s + 2L) (s the target's scale, L their distance from its centre), so the certificate asks for a gap of ten
    times that; it is off for the least-squares kinds (their points need not lie on the primitive) and for tol > 0.1.
    Cost: microseconds (no task evaluation).
    """
    kind = getattr(ocp.task, "kind", None)
    spec = KIND_SPECS.get(kind) if isinstance(kind, str) else None
    if spec is None or spec.least_squares:
        return None
    balls = reach_balls(ocp)
    if balls is None or tol > 0.1:
        return None
    t, Rm, s = ocp.target.translation, ocp.target.rotation_matrix, float(ocp.target.scale)
    for i, (c, r) in enumerate(balls):
        if not np.isfinite(r):
            continue
        gap = s * unit_distance(spec.primitive_kind, Rm.T @ (c - t) / s) - r  # [m] between the ball and X_d
        margin = 10.0 * max(tol, 1e-3) * (s + 2.0 * (float(np.linalg.norm(c - t)) + r))
        if gap > margin:
            frame = ocp.task.tree.end_frames[i]
            return (
                f"unreachable: the target {kind} passes {gap:.3g} m outside the reach of end point {i} ('{frame}'), "
                f"a ball of radius {r:.3g} m about its chain's first joint that holds every position it can take, so "
                "the target is not reachable inside the limits from this start (nor from any other)"
            )
    return None


def bounded_stationarity(ocp: ReachingOCP, q: np.ndarray, e: np.ndarray, Je: np.ndarray) -> float:
    """How far the configuration q (nq,) is from a stationary point of f(q) = ½‖e(q)‖² within the position limits, as
    a fraction of the gradient's scale: ‖P ∇f‖ / (‖J_e‖₂ ‖e‖), where ∇f = J_eᵀ e (e (7,) and J_e (7, nq) at q, Eq 44
    and 47) and P drops the components that push a joint out through a limit it is on (within
    :data:`BOUND_ACTIVE`).  0 at a KKT point of min f over the limits (every descent direction of ‖e‖ blocked by a
    limit, or none left); ~1 far from one.  Bounds are those of ``ocp`` (none with ``limit_mode="none"``).
    """
    g = Je.T @ e
    blocked = ((q - ocp.q_lower <= BOUND_ACTIVE) & (g > 0.0)) | ((ocp.q_upper - q <= BOUND_ACTIVE) & (g < 0.0))
    scale = float(np.linalg.norm(Je, 2)) * float(np.linalg.norm(e))
    return float(np.linalg.norm(np.where(blocked, 0.0, g))) / max(scale, 1e-300)
