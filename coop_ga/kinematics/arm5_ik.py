"""Geometric CGA inverse kinematics of a 5-DOF arm (seed 002, §V, Steps 1–5 and Eq 19, 30–31).

The arm (``coop_ga/systems/robots/arm5/arm5.urdf``, dimensions in :data:`ARM5`): base yaw
(joint 1, about the vertical axis ``l_y``), shoulder pitch (2), elbow pitch (3), wrist roll about
the forearm (4), wrist pitch (5), gripper of length d3.  Its points are the shoulder p0, the elbow
p1, the wrist centre p2 and the tool point p_t.  **Objective** (seed): the joint angles that put
the tool point at p_t with the gripper parallel to the plane φ_t, i.e. the gripper line
l3 = p2 ∧ p_t ∧ e∞ lies in the plane π_t through p_t parallel to φ_t.

Frames and units: world = ``base_link`` of the URDF, +z up (the seed's vertical axis is e2, ours
is e3: ``l_y*`` is the vertical line through the origin), metres and radians.  Joint zero = arm straight
up; positive joints 2, 3, 5 tilt the next link toward +x of the arm plane.

The steps, in IPNS (vectors s, π; their wedge is the intersection) and OPNS (``*``) form:

1. ``s_t = p_t − ½d3² e∞``, ``z_t = s_t ∧ π_t`` (the circle of possible wrist centres),
   ``j_z* = z_t ∧ e∞`` (its axis), ``d = d(p_t, l_y)`` (the horizontal vector from the base axis to
   p_t), ``l_d* = d ∧ p_t ∧ e∞``, ``π_jld* = j_z* ∧ (l_d* E)`` (the plane through the axis
   containing d); ``P_P2 = π_jld ∧ z_t``;
   p2 is the point of the pair nearer the base axis (gripper pointing outward).  Optionally p2 is
   rotated about the circle axis by the rotor ``R = exp(−½θ L̂)`` of Eq 30–31 (``p2_angle``).
2. ``π_1* = l_y* ∧ p2`` (the arm plane); step 3 before step 2 (p1 needs p0):
3. ``s0 = e0 − ½d0² e∞``, ``π0 = e3 + h e∞`` (the plane z = h), ``P_P0 = s0 ∧ π0 ∧ π1``; p0 is
   the point on the side of p2.
2'. ``s1 = p0 − ½d1² e∞``, ``s2 = p2 − ½d2² e∞``, ``P_P1 = s1 ∧ s2 ∧ π1``: the two elbows
   (imaginary pair, ``P_P1*·P_P1* < 0`` ⇔ out of reach).
4. ``l1* = p0∧p1∧e∞``, ``l2* = p1∧p2∧e∞``, ``l3* = p2∧p_t∧e∞`` (Eq 19).
5. The angles from normalised inner products of these lines and planes (the seed's cosines),
   with signs from the orientation in the arm plane (the cosines alone cannot give them).

A point pair T (OPNS, grade 2) gives its points as ``p± = (T ± √(T·T)) (e∞⌋T)⁻¹`` (seed's
formula, Step 1).

Seed typos and gaps found (each checked in ``tests/kinematics/test_arm5_ik.py``)
------------------------------------------------------------------------------
* **Eq 19**: ``l3* = p2 ∧ p1 ∧ e∞`` is l2 reversed; the gripper line is ``l3* = p2 ∧ p_t ∧ e∞``.
  As printed, θ5 = arccos(l3·l2/…) would always be π.
* **Step 5, θ3**: ``cos θ3 = l1·l3/…`` must be ``l1·l2/…`` (the elbow is between upper arm and
  forearm).
* **Step 5, θ4**: ``π3`` is never defined; it is the plane of forearm and gripper,
  ``π3* = l2* ∧ p_t`` (θ4 = wrist roll = angle between π1 and π3).
* **Step 2 before Step 3**: ``s1 = e0 − ½d1² e∞`` is centred at the origin, but the elbow is at
  distance d1 from the shoulder p0, computed only in Step 3; the sphere is ``s1 = p0 − ½d1² e∞``
  (identical only for a shoulder at the origin, where Step 3 would be void).
* **Step 3, π0**: ``π0 = e2 − h e∞`` is the plane y = −h with the seed's own x_c·e∞ = −1; the
  shoulder plane is y = +h (``e2 + h e∞``).
* **Step 1, π_jld* = j_z* ∧ (l_d* E)** is right, though it looks odd: l_d* E has grades 1 and 3,
  the grade-3 part vanishes in the wedge with the line j_z*, and the plane equals j_z* ∧ d, the
  plane through the circle axis containing the direction d of l_d (not a typo; checked).
* **Step 2, π2* = e3 I_c**: the reference plane of θ1; cos θ1 = π1*·π2*/… gives θ1 only up to
  sign (and up to π, as planes are unoriented lines here); the sign comes from the side of p2.
* **§III-A**: with e∞ = e4 + e5 and e0 = ½(e4 − e5), e∞·e0 = +1, contradicting x_c·e∞ = −1 and
  x_c·y_c = −½|x − y|² stated next to it (both need e0 = ½(e5 − e4), e∞·e0 = −1, our basis).
* Every cosine in Step 5 gives an unsigned angle in [0, π]; joint angles need signs.

Measured (``tests/kinematics/test_arm5_ik.py``): on 600 seeded random reachable targets (from
random in-limit configurations, the plane a random one containing the gripper) Pinocchio's FK of
the result is on the target to < 1e-10 m with |n·approach| < 1e-10; the seed's Step 1 wrist
position works for 501 of them (83.5 %), the other 99 need the Eq 30–31 rotation of p2.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import validation
from ..algebra.multivector import Multivector
from ..errors import DegeneratePrimitiveError, InvalidInputError, UnreachableError
from ..geometry.primitives import kind_of, normal, point, to_euclidean

__all__ = [
    "ARM5",
    "ARM5_END_FRAME",
    "Arm5Geometry",
    "Arm5IKResult",
    "Arm5UnreachableError",
    "arm5_fk_points",
    "arm5_ik",
    "line_cosine",
    "pair_points",
]

_EINF = Multivector.blade("einf")
_E0 = Multivector.blade("e0")
_EZ = Multivector.blade("e3")
#: E = e∞ ∧ e0 (the seed's E of the additive split, §VI; e4∧e5 of §III up to sign)
_E = _EINF ^ _E0

#: the frame of the tool point p_t in ``arm5.urdf`` (its z axis is the approach direction p2 → p_t).
ARM5_END_FRAME = "tcp"


@dataclass(frozen=True)
class Arm5Geometry:
    """Lengths of the 5-DOF arm [m] (seed §V symbols): shoulder height ``h`` and radial offset ``a``
    (so the seed's d0 = √(h² + a²)), upper arm ``d1``, forearm ``d2``, gripper ``d3``; and the joint
    limits ``lower``/``upper`` (5,) [rad] of ``arm5.urdf``."""

    h: float = 0.12
    a: float = 0.04
    d1: float = 0.22
    d2: float = 0.20
    d3: float = 0.10
    lower: tuple[float, ...] = (-np.pi, -1.9, -2.6, -np.pi, -2.2)
    upper: tuple[float, ...] = (np.pi, 1.9, 2.6, np.pi, 2.2)

    @property
    def d0(self) -> float:
        """Distance from the base origin to the shoulder p0 [m] (radius of the seed's s0)."""
        return float(np.hypot(self.h, self.a))


#: the dimensions of ``coop_ga/systems/robots/arm5/arm5.urdf`` (ours: the seed gives none).
ARM5 = Arm5Geometry()


class Arm5UnreachableError(UnreachableError):
    """The target has no solution: out of reach (``distance`` [m] > 0: how far the wrist centre p2 is
    outside the shoulder–elbow annulus |d1 − d2| ≤ |p2 − p0| ≤ d1 + d2, the smallest over the tried
    wrist positions) or only outside the joint limits (``violation`` [rad] > 0, the smallest)."""


@dataclass
class Arm5IKResult:
    """Result of :func:`arm5_ik`: ``q`` (5,) [rad] in URDF joint order; the points ``p0, p1, p2, pt``
    (3,) [m, world]; ``p2_angle`` [rad] the rotation of p2 about the circle axis (Eq 30–31) that was
    used; ``elbow`` "up" or "down"; ``cosines``: the seed's Step 5 cosines (θ1…θ5, unsigned) from the
    CGA inner products, for comparison with ``cos(q)``; ``tries``: wrist positions tried."""

    q: np.ndarray
    p0: np.ndarray
    p1: np.ndarray
    p2: np.ndarray
    pt: np.ndarray
    p2_angle: float
    elbow: str
    cosines: np.ndarray
    tries: int


# ---------------------------------------------------------------------- CGA helpers
def _vec(v: np.ndarray) -> Multivector:
    return Multivector.from_names({"e1": float(v[0]), "e2": float(v[1]), "e3": float(v[2])})


def _sphere(c: np.ndarray, r: float) -> Multivector:
    """IPNS sphere ``P(c) − ½r² e∞`` (seed Eq 4)."""
    return point(c) - _EINF.scale(0.5 * r * r)


def _plane(n: np.ndarray, d: float) -> Multivector:
    """IPNS plane ``n + d e∞``: the points with x·n = d (seed Eq 7, in our basis)."""
    return _vec(n) + _EINF.scale(d)


def pair_points(T: Multivector) -> tuple[np.ndarray, np.ndarray, float]:
    """The two points (3,) [m] of an OPNS point pair T (grade 2) by the seed's formula
    ``p± = (T ± √(T·T)) (e∞⌋T)⁻¹``, and ``T·T`` (> 0 real pair, < 0 imaginary, 0 tangent).

    Raises :class:`DegeneratePrimitiveError` for an imaginary pair (T·T < 0).
    """
    TT = float((T | T).get(0))
    if not TT >= 0.0:
        raise DegeneratePrimitiveError(f"the point pair is imaginary (T·T = {TT:.3g} < 0)")
    den = (_EINF | T).inverse()
    root = Multivector.scalar(float(np.sqrt(TT)))
    a = to_euclidean(((T + root) * den).grade(1))
    b = to_euclidean(((T - root) * den).grade(1))
    return np.asarray(a, dtype=float), np.asarray(b, dtype=float), TT


def line_cosine(L1: Multivector, L2: Multivector) -> float:
    """``L1·L2 / (|L1| |L2|)`` of two OPNS lines (or planes): the cosine of the angle between their
    directions (normals) as in the seed's Step 5."""
    n1 = float(np.sqrt(abs(float((L1 | L1).get(0)))))
    n2 = float(np.sqrt(abs(float((L2 | L2).get(0)))))
    return float((L1 | L2).get(0)) / (n1 * n2)


def _line(a: np.ndarray, b: np.ndarray) -> Multivector:
    return point(a) ^ point(b) ^ _EINF


def _rotate_about_line(p: np.ndarray, axis_line: Multivector, theta: float) -> np.ndarray:
    """Eq 30–31: ``p' = R p R̃`` with ``R = cos(θ/2) − sin(θ/2) L̂``, L̂ the unit IPNS line (dual of the
    OPNS axis ``j_z*``).  The sense is fixed by the orientation of ``j_z*``."""
    L = axis_line.dual()
    nrm = float(np.sqrt(abs(float((L * L).get(0)))))
    Lh = L.scale(1.0 / nrm)
    R = Multivector.scalar(float(np.cos(0.5 * theta))) - Lh.scale(float(np.sin(0.5 * theta)))
    P = (R * point(p) * R.reverse()).grade(1)
    return np.asarray(to_euclidean(P), dtype=float)


def _wrap(x: float) -> float:
    return float((x + np.pi) % (2.0 * np.pi) - np.pi)


# ---------------------------------------------------------------------- forward kinematics (closed form)
def arm5_fk_points(q: Any, geometry: Arm5Geometry = ARM5) -> dict[str, np.ndarray]:
    """Closed-form points of the arm at ``q`` (5,) [rad]: ``p0, p1, p2, pt`` (3,) [m, world] and the
    approach direction ``approach`` (unit, p2 → pt).  For cross-checks; the tests use Pinocchio."""
    qq = validation.vector(q, 5, "q")
    g = geometry
    c1, s1 = np.cos(qq[0]), np.sin(qq[0])
    r, zz = np.array([c1, s1, 0.0]), np.array([0.0, 0.0, 1.0])
    y1 = np.cross(zz, r)
    p0 = g.a * r + g.h * zz
    phi1 = qq[1]
    u1 = np.sin(phi1) * r + np.cos(phi1) * zz
    p1 = p0 + g.d1 * u1
    phi2 = qq[1] + qq[2]
    u2 = np.sin(phi2) * r + np.cos(phi2) * zz
    p2 = p1 + g.d2 * u2
    # roll about u2 by q4 moves the pitch axis y1 to y'; pitch about y' by q5 tilts u2 to u3
    yp = _rodrigues(y1, u2, qq[3])
    u3 = _rodrigues(u2, yp, qq[4])
    return {"p0": p0, "p1": p1, "p2": p2, "pt": p2 + g.d3 * u3, "approach": u3}


def _rodrigues(v: np.ndarray, k: np.ndarray, t: float) -> np.ndarray:
    return v * np.cos(t) + np.cross(k, v) * np.sin(t) + k * (k @ v) * (1.0 - np.cos(t))


# ---------------------------------------------------------------------- inverse kinematics
def _plane_normal(plane: Any) -> np.ndarray:
    if isinstance(plane, Multivector):
        if kind_of(plane) != "plane":
            raise InvalidInputError(f"the gripper plane must be a CGA plane, got a {kind_of(plane)}")
        n = np.asarray(normal(plane), dtype=float)
    else:
        n = validation.vector(plane, 3, "plane normal")
    nn = float(np.linalg.norm(n))
    if not nn > 0.0:
        raise InvalidInputError("the plane normal is zero")
    return n / nn


def _solve_from_p2(
    pt: np.ndarray, p2: np.ndarray, g: Arm5Geometry, elbow: str, front: bool = True
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float]:
    """Steps 2–5 for a given wrist centre: (q, p0, p1, cosines, reach excess [m] ≤ 0 if reachable).
    ``front``: the shoulder on the side of p2 (else the base turned by π, reaching over the back)."""
    ez = np.array([0.0, 0.0, 1.0])
    horiz = p2 - (p2 @ ez) * ez
    if not front:
        horiz = -horiz
    if float(np.linalg.norm(horiz)) < 1e-9:
        raise DegeneratePrimitiveError("the wrist centre p2 lies on the base axis: the arm plane (θ1) is undefined")
    l_y = point(np.zeros(3)) ^ point(ez) ^ _EINF  # OPNS line l_y* (the base axis)
    P2 = point(p2)
    pi1_star = l_y ^ P2  # Step 2: the arm plane π1* = l_y* ∧ p2
    pi1 = pi1_star.dual()
    # Step 3: the shoulder p0 = s0 ∧ π0 ∧ π1 (seed: π0 = e2 − h e∞, a sign typo; here z = +h)
    s0 = _E0 - _EINF.scale(0.5 * g.d0 * g.d0)
    pi0 = _EZ + _EINF.scale(g.h)
    a0, b0, _ = pair_points((s0 ^ pi0 ^ pi1).dual())
    p0 = a0 if a0 @ horiz >= b0 @ horiz else b0
    # Step 2 (corrected): the elbow p1 = s1 ∧ s2 ∧ π1 with s1 centred at p0
    d02 = float(np.sqrt(max(-2.0 * float((point(p0) | P2).get(0)), 0.0)))  # |p2 − p0| from P0·P2
    excess = max(d02 - (g.d1 + g.d2), abs(g.d1 - g.d2) - d02)
    T1 = (_sphere(p0, g.d1) ^ _sphere(p2, g.d2) ^ pi1).dual()
    if excess > 0.0 or float((T1 | T1).get(0)) < 0.0:
        return np.zeros(5), p0, p0, np.zeros(5), max(excess, 0.0)
    a1, b1, _ = pair_points(T1)
    r = horiz / float(np.linalg.norm(horiz))
    # "up": the elbow on the upper side of the shoulder–wrist line (larger z for a forward reach)
    side = np.cross(p2 - p0, a1 - p0) @ np.cross(ez, r)
    p1 = (a1 if side <= 0 else b1) if elbow == "up" else (b1 if side <= 0 else a1)
    # Step 4: the lines (Eq 19, l3 corrected)
    l1, l2, l3 = _line(p0, p1), _line(p1, p2), _line(p2, pt)
    pi3_star = l2 ^ point(pt)
    pi2_star = point(np.zeros(3)) ^ point(ez) ^ point(np.array([1.0, 0.0, 0.0])) ^ _EINF  # the x–z plane
    cos = np.array(
        [
            line_cosine(pi1_star, pi2_star),
            line_cosine(l1, l_y),
            line_cosine(l1, l2),
            line_cosine(pi1_star, pi3_star) if float(np.linalg.norm(np.cross(p2 - p1, pt - p2))) > 1e-12 else 1.0,
            line_cosine(l3, l2),
        ]
    )
    # Step 5 with signs: angles in the arm plane (coordinates along r and z)
    u1 = (p1 - p0) / g.d1
    u2 = (p2 - p1) / g.d2
    u3 = (pt - p2) / g.d3
    th1 = float(np.arctan2(r[1], r[0]))
    phi1 = float(np.arctan2(u1 @ r, u1 @ ez))
    phi2 = float(np.arctan2(u2 @ r, u2 @ ez))
    y1 = np.cross(ez, r)
    k = np.cross(u2, u3)
    nk = float(np.linalg.norm(k))
    if nk < 1e-12:  # gripper along the forearm: the roll is free, take 0
        th4, th5 = 0.0, float(np.arctan2(0.0, u2 @ u3))
    else:
        yp = k / nk
        th5 = float(np.arctan2(nk, u2 @ u3))
        th4 = float(np.arctan2(np.cross(y1, yp) @ u2, y1 @ yp))
        if abs(th4) > 0.5 * np.pi:  # the equivalent (θ4 ± π, −θ5) with the smaller roll
            th4, th5 = _wrap(th4 + np.pi), -th5
    q = np.array([th1, phi1, _wrap(phi2 - phi1), th4, th5])
    return q, p0, p1, cos, excess


def arm5_ik(
    target: Any,
    plane: Any,
    geometry: Arm5Geometry = ARM5,
    *,
    elbow: str = "up",
    p2_angle: float = 0.0,
    search: int = 72,
    limits: bool = True,
    q_ref: Any = None,
) -> Arm5IKResult:
    """Joint angles (5,) [rad] that put the tool point of the 5-DOF arm at ``target`` with the gripper
    parallel to ``plane`` (seed §V; the steps are in the module docstring).

    ``target``: p_t (3,) [m, world = base_link]; ``plane``: the plane φ_t the gripper must be parallel
    to, as a CGA plane (:func:`coop_ga.geometry.primitives.plane`) or its normal (3,);
    ``elbow``: "up" or "down" (the other, and the base turned by π, are tried too if this fails); ``p2_angle`` [rad]: the
    initial rotation of the wrist centre about the circle axis j_z (Eq 30–31; 0 = the seed's
    Step 1 choice); ``search``: if the first wrist position fails (reach or joint limits), rotate it
    by Δθ = 2π/search at a time (the seed's §VI-C iteration, Eq 30–31) and keep the first that
    works (0 disables it); ``limits``: require ``geometry.lower ≤ q ≤ geometry.upper``;
    ``q_ref`` (5,) [rad]: if given, of the solutions at the first wrist position that works (base
    front/back, elbow up/down, wrist roll θ4 or θ4 ± π with −θ5) the one nearest ``q_ref`` (for paths:
    pass the previous solution); else the first in that order, with |θ4| ≤ π/2.

    Raises :class:`Arm5UnreachableError` (a :class:`coop_ga.errors.UnreachableError`) with the
    distance out of reach [m] or the joint-limit violation [rad], and
    :class:`DegeneratePrimitiveError` if the target lies on the base axis with a horizontal plane
    (the seed's Step 1 plane is then undefined).
    """
    pt = validation.vector(target, 3, "target")
    n = _plane_normal(plane)
    elbow = validation.choice(elbow, ("up", "down"), "elbow")
    search = validation.integer(search, "search", minimum=0)
    theta0 = float(validation.scalar(p2_angle, "p2_angle"))
    qr = None if q_ref is None else validation.vector(q_ref, 5, "q_ref")
    p2_seed, j_z = _wrist_circle(pt, n, geometry)
    tally = _Tally()
    for th in _search_angles(theta0, search):
        p2 = p2_seed if th == 0.0 else _rotate_about_line(p2_seed, j_z, th)
        found = _solutions_at(pt, p2, th, geometry, elbow, limits, tally, first_only=qr is None)
        if found:
            return found[0] if qr is None else min(found, key=lambda r: float(np.linalg.norm(r.q - qr)))
    raise _unreachable(pt, geometry, tally)


def _wrist_circle(pt: np.ndarray, n: np.ndarray, g: Arm5Geometry) -> tuple[np.ndarray, Multivector]:
    """Step 1: the seed's wrist centre p2 (3,) [m] on the circle of wrist centres about the target, and the
    circle's axis line j_z (OPNS); raises when the seed's plane through the axis is undefined."""
    ez = np.array([0.0, 0.0, 1.0])
    pi_t = _plane(n, float(n @ pt))  # π_t ∥ φ_t through p_t
    z_t = _sphere(pt, g.d3) ^ pi_t
    j_z = z_t ^ _EINF  # OPNS axis line of the circle (seed j_z*)
    d = pt - (pt @ ez) * ez  # d(p_t, l_y): from the base axis to p_t
    dd = d - (d @ n) * n
    if float(np.linalg.norm(dd)) < 1e-9 * max(1.0, float(np.linalg.norm(pt))):
        raise DegeneratePrimitiveError(
            "Step 1 is undefined: the direction from the base axis to the target is normal to the plane "
            "(or the target is on the base axis); pass another plane or a p2_angle"
        )
    l_d = _vec(d) ^ point(pt) ^ _EINF  # l_d* = d(p_t, l_y) ∧ p_t ∧ e∞
    pi_jld = j_z ^ (l_d * _E)  # π_jld* = j_z* ∧ (l_d* E) = j_z* ∧ d up to scale
    a2, b2, _ = pair_points((pi_jld.dual() ^ z_t).dual())
    return (a2 if np.linalg.norm(a2[:2]) <= np.linalg.norm(b2[:2]) else b2), j_z


def _search_angles(theta0: float, search: int) -> list[float]:
    """The rotations [rad] of the wrist centre about j_z to try: θ0, then ±Δθ, ±2Δθ, … (Δθ = 2π/search)."""
    order = [theta0]
    if search:
        dth = 2.0 * np.pi / search
        for k in range(1, search // 2 + 1):  # alternate ±Δθ around the start angle
            order += [theta0 + k * dth, theta0 - k * dth]
        order = order[:search]
    return order


@dataclass
class _Tally:
    """What the search has tried: solves, and the smallest reach excess [m] and joint-limit violation [rad]."""

    tries: int = 0
    excess: float = np.inf
    violation: float = np.inf


def _solutions_at(
    pt: np.ndarray,
    p2: np.ndarray,
    th: float,
    g: Arm5Geometry,
    elbow: str,
    limits: bool,
    tally: _Tally,
    first_only: bool,
) -> list[Arm5IKResult]:
    """The solutions with the wrist centre at p2 (base front/back, elbow ``elbow`` then the other, wrist roll θ4
    or θ4 ± π with −θ5) inside the limits (if ``limits``); with ``first_only`` those of the first combination
    that has any."""
    lo, hi = np.asarray(g.lower), np.asarray(g.upper)
    found: list[Arm5IKResult] = []
    for front, elb in itertools.product((True, False), (elbow, "down" if elbow == "up" else "up")):
        tally.tries += 1
        try:
            q, p0, p1, cos, excess = _solve_from_p2(pt, p2, g, elb, front)
        except DegeneratePrimitiveError:
            continue
        if excess > 0.0:
            tally.excess = min(tally.excess, excess)
            continue
        # the same pose with the wrist roll turned by π and the pitch negated
        flip = np.array([q[0], q[1], q[2], _wrap(q[3] + np.pi), -q[4]])
        for qq in (q, flip):
            viol = float(np.max(np.concatenate([lo - qq, qq - hi, [0.0]]))) if limits else 0.0
            if viol > 0.0:
                tally.violation = min(tally.violation, viol)
                continue
            found.append(
                Arm5IKResult(
                    q=qq, p0=p0, p1=p1, p2=p2, pt=pt, p2_angle=float(th), elbow=elb, cosines=cos, tries=tally.tries
                )
            )
        if found and first_only:
            return found
    return found


def _unreachable(pt: np.ndarray, g: Arm5Geometry, tally: _Tally) -> Arm5UnreachableError:
    """The error of a search that found nothing: the joint-limit violation if some pose was reachable, else
    the distance out of reach."""
    if np.isfinite(tally.violation):
        return Arm5UnreachableError(
            f"target {pt.tolist()} is reachable only outside the joint limits (by at least {tally.violation:.4g} "
            f"rad over {tally.tries} wrist positions and elbows)",
            violation=tally.violation,
        )
    dist = float(tally.excess) if np.isfinite(tally.excess) else float("nan")
    return Arm5UnreachableError(
        f"target {pt.tolist()} is out of reach: the wrist centre is at least {dist * 1e3:.4g} mm outside the "
        f"shoulder–elbow annulus [{abs(g.d1 - g.d2):g}, {g.d1 + g.d2:g}] m (over {tally.tries} wrist positions on "
        f"the circle of radius d3 = {g.d3:g} m about the target)",
        distance=dist,
    )
