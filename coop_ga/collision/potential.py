"""Potential-field path generation in CGA around sphere obstacles (seed 002, §VI, Eq 20–27).

An end point moves from ``start`` to ``goal`` along the unit field of Coulomb charges (Eq 27):
a unit negative charge at the goal, a positive point charge ``q_i`` at the centre of every
obstacle sphere (Eq 21–22 with n = 3), each charge set by the equilibrium-point rule
``q = R/(R + D)`` of the security radius R and the obstacle–goal distance D (Eq 23).  The path
is built as in §VI-B: the distance to the goal is the CGA ``sqrt(−2 P(x)·P(goal))``, the
Euclidean part of the conformal point comes from the additive split (Eq 24–26), and the next
point is ``x + ε E(x)/|E(x)|``.

Obstacles are CGA spheres (:class:`coop_ga.Primitive` of kind ``"sphere"``, e.g. from
:func:`obstacle`).  Their *safety spheres* have the security radius ``R = ρ + margin``.  A point
is inside a safety sphere S (IPNS vector ``s = P(c) − ½R² e∞``) iff ``P(x)·s = ½(R² − |x − c|²)``
is positive: the CGA signed squared distance (:func:`signed_squared_distance`).

Never entering a safety sphere — by construction
------------------------------------------------
The Coulomb field alone does not guarantee it (field lines cross the security sphere once
several charges are superposed, and Eq 23 is the planar rule, see below).  Every step is
therefore checked *as a segment*: along ``x(t) = x + tδ``, t ∈ [0, 1], the signed squared
distance is the concave quadratic ``f(t) = f0 + (f1 − f0 + a)t − a t²`` with ``f0 = P(x)·s``,
``f1 = P(x + δ)·s`` and ``a = ½|δ|²``, so its maximum over the segment is exact from two CGA
inner products.  A step whose segment would come within ``R(1 + 1e−10)`` is never taken: the
step is projected onto the tangent cone of the offending spheres (``δ·(x − c) ≥ 0``, along
which the distance cannot decrease) and kept at length ε (sliding along the safety sphere),
halved if that still fails, and the path stops as blocked if nothing is left.  So every
segment of every returned path stays outside every safety sphere (``min_clearance ≥ 0``,
asserted on 120 random scenes in ``tests/collision/test_potential.py``).

Where the method fails (measured in ``tests/collision/test_potential.py`` and
``experiments/potential_field.py``)
----------------------------------------------------------------------------------------
* **Random scenes** (:func:`random_scene`, 1–3 spheres, margin 5 cm, ε = 1 cm, seed 0): 118 of
  120 reach the goal; the 2 failures are **escapes** (Σq = 1.015 and 1.088).  Median path length
  2.3 × the straight line, worst 12 ×: Coulomb field lines make long detours with Eq 23.
* **Escape to infinity** (``status="escaped"``): every charge is set for its own obstacle alone
  (Eq 23), so several obstacles can sum to Σq ≥ 1; the far field then points *away* from the
  goal, and field lines starting behind the obstacles run off to infinity.  A 3 × 3 wall of
  spheres (ρ = 0.12 m) has Σq = 1.61 with Eq 23 and escapes; with the 3-D rule Σq = 0.29 and it
  reaches the goal.
* **Symmetric obstacle** directly between start and goal, the start on the goal–obstacle
  axis: the path runs down the axis into the field's equilibrium point behind the obstacle
  (where ``q/r² = 1/(r + D)²``), and stops there, reported as ``local_minimum``.  It is a
  saddle of U (a harmonic function has no local minima, the seed's point), but the saddle
  attracts the symmetric start; 1 mm off the axis the path escapes it.
* **Overlapping spheres** (two spheres whose safety spheres intersect), with the weaker 3-D
  charges: the field points into the concave crease of the union, the guard slides the path
  into it and the projected steps cancel: ``local_minimum`` (blocked by spheres 0 and 1) at the
  crease point, also from starts 2 cm off the symmetry plane.  With Eq 23 the symmetric start
  stalls earlier, at the pair's equilibrium point.
* **The guard is needed** with the 3-D rule: on 1 of 60 single-obstacle scenes the raw field
  step would have entered the safety sphere (the equilibrium point is then exactly on it).  With
  Eq 23 no single-obstacle path needed the guard (40 scenes): the seed's §VI claim holds there.

Seed discrepancies (checked in ``tests/collision/test_potential.py``)
---------------------------------------------------------------------
* **Eq 23 is the planar rule.**  With the 3-D field of Eq 22 (``|E| = q/r²``) the equilibrium
  point behind an obstacle is at ``r* = √q D/(1 − √q)`` from its centre; ``q = R/(R + D)``
  puts it at R only for the 2-D field ``q/r`` (Guldner & Utkin's planar setting).  In 3-D
  the rule placing it at R is ``q = (R/(R + D))²`` (``charge_rule="equilibrium"``).  With the
  seed's rule the equilibrium lies farther out (R = 0.1, D = 1: r* = 0.43 m), which is safe
  but stalls symmetric paths far from the obstacle and makes long detours (random scenes:
  median length ratio 2.3–3.4 with Eq 23 against 1.1 with the 3-D rule).
* **Eq 21** writes the planar potential as ``q ln(q/r)``; the harmonic one is ``q ln(1/r)``
  (the printed form only adds a constant).  Eq 22 is missing its ``=`` and its direction:
  ``E = −∇U = (n − 2) q (x − c)/r^n`` (n ≥ 3), ``q (x − c)/r²`` (n = 2).
* **Eq 20** defines r for n dimensions but writes ``x = (x1, x2, x3)``.
* **Eq 24–26**: with the seed's printed e0 = ½(e4 − e5) (§III-A, itself a sign typo: it gives
  e∞·e0 = +1), E = e∞∧e0 (§VI) is −e4∧e5 (§III); with the consistent e0 = ½(e5 − e4) the two
  coincide.  The sign cancels in ``(x·E)E`` and ``(x∧E)E``; with our null basis
  (``e0·e∞ = −1``) ``E² = 1`` and the split is exact (:func:`additive_split`).
* **§VI-B** uses the same ε as step length and as goal tolerance; here ``step`` and ``tol``
  are separate (``tol`` defaults to ``step``).  Its step 3 writes ``x + εE(x)`` although Eq 27
  calls the field "unitary": with the raw field the step is ε/r² near the goal (ε = 1 cm,
  5 cm from the goal: a 4 m step, overshooting 80-fold), so the unit field ``E/|E|`` is used.
  Step 1's CGA distance ``sqrt(−2 P(x)·P(goal))`` is the Euclidean distance (checked).
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import validation
from ..algebra.basis import blade_index
from ..algebra.multivector import Multivector
from ..errors import DegeneratePrimitiveError, InvalidInputError
from ..geometry.primitives import Primitive, kind_of, point, sphere
from .distance import MAX_COORDINATE

__all__ = [
    "CHARGE_RULES",
    "SCENE_DISTANCE",
    "PotentialPath",
    "additive_split",
    "charges",
    "coulomb_field",
    "coulomb_potential",
    "dual_sphere",
    "equilibrium_distance",
    "obstacle",
    "potential_path",
    "random_scene",
    "safety_sphere",
    "signed_squared_distance",
]

_E0 = Multivector.blade("e0")
_EINF = Multivector.blade("einf")
#: E = e∞ ∧ e0 of the additive split (Eq 24–26); E² = 1 in our null basis.
_E = _EINF ^ _E0
_B_E0 = blade_index("e0")[0]
_B_EINF = blade_index("einf")[0]
_B_E = tuple(blade_index(n)[0] for n in ("e1", "e2", "e3"))

#: charge rules: ``"seed"`` q = R/(R+D) (Eq 23, the planar rule); ``"equilibrium"`` q = (R/(R+D))²,
#: which puts the 3-D field's equilibrium point at distance R behind the obstacle.
CHARGE_RULES = ("seed", "equilibrium")

#: start–goal distance range [m] of :func:`random_scene`
SCENE_DISTANCE = (1.0, 2.0)
#: :func:`potential_path` refuses a larger ``max_iter`` (bounded work: each iteration is one step of the path)
MAX_ITERATIONS = 10_000_000
#: :func:`random_scene` gives up after this many rejected draws, and refuses more obstacles than this
MAX_SCENE_DRAWS = 1_000
MAX_SCENE_OBSTACLES = 100

#: a step whose segment reaches ``P·s > −_SAFETY·R²`` (i.e. comes within ≈ R(1 + ½·_SAFETY) of the
#: centre) is refused: a relative margin far above the rounding of P·s.
_SAFETY = 2e-10


# ---------------------------------------------------------------------- spheres
def obstacle(center_: Any, radius_: Any) -> Primitive:
    """The obstacle sphere of centre ``center_`` (3,) [m] and radius ``radius_`` > 0 [m] as a
    coop_ga OPNS primitive (kind ``"sphere"``, the wedge of four of its points, Eq 5)."""
    c = _bounded(validation.vector(center_, 3, "center"), "center")
    r = validation.positive(radius_, "radius")
    if r > MAX_COORDINATE:
        raise InvalidInputError(f"radius = {r:g} m is beyond {MAX_COORDINATE:g} m")
    pts = [c + r * np.array(d, dtype=float) for d in ((1, 0, 0), (0, 1, 0), (0, 0, 1), (-1, 0, 0))]
    return sphere(pts[0], pts[1], pts[2], pts[3])


def dual_sphere(S: Multivector, what: str = "S") -> Multivector:
    """The IPNS vector ``s = P(c) − ½ρ² e∞`` (e0 coefficient 1) of a sphere (seed Eq 4).

    ``S``: an OPNS sphere (grade 4, e.g. :func:`obstacle`) or an IPNS vector (grade 1) of a real
    sphere.  Raises :class:`InvalidInputError` for other kinds and :class:`DegeneratePrimitiveError`
    for planes (zero e0 weight) and imaginary spheres; the messages name the argument ``what``.
    """
    if not isinstance(S, Multivector):
        raise InvalidInputError(
            f"{what} must be a sphere as a coop_ga Multivector (e.g. collision.potential.obstacle(center, radius)), "
            f"got {type(S).__name__}"
        )
    S.check_finite(what)
    if S.is_symbolic:
        raise InvalidInputError(f"{what} must be a numeric sphere, got a symbolic (CasADi) one")
    grades = set(S.prune(0.0).grades)
    if grades == {4}:
        if kind_of(S) != "sphere":
            raise InvalidInputError(f"{what}: a grade-4 obstacle must be a sphere, got a plane")
        s = S.dual().grade(1)
    elif grades == {1}:
        s = S
    else:
        raise InvalidInputError(
            f"{what}: a sphere is a grade-4 OPNS primitive or a grade-1 IPNS vector; got grades {sorted(grades)}"
        )
    w = float(s.get(_B_E0))
    if w == 0.0:
        raise DegeneratePrimitiveError(
            f"{what} has zero e0 weight: it is a plane (a sphere through infinity), not a sphere"
        )
    with np.errstate(over="ignore", invalid="ignore"):
        s = s.scale(1.0 / w)
        c = np.array([float(s.get(b)) for b in _B_E])
        r2 = float(c @ c) - 2.0 * float(s.get(_B_EINF))
    if not np.isfinite(r2) or not np.all(np.isfinite(c)):
        raise InvalidInputError(f"{what}: its centre or radius overflows (e0 weight {w:.3g}); rescale the scene")
    if not r2 > 0.0:
        raise DegeneratePrimitiveError(f"{what} is imaginary or a point (ρ² = {r2:.3g} ≤ 0), not a real sphere")
    return s


def _center_radius(S: Multivector, what: str = "S") -> tuple[np.ndarray, float]:
    s = dual_sphere(S, what)
    c = np.array([float(s.get(b)) for b in _B_E])
    return c, float(np.sqrt(float(c @ c) - 2.0 * float(s.get(_B_EINF))))


def safety_sphere(S: Multivector, margin: float = 0.0) -> Multivector:
    """The safety sphere of obstacle S: same centre, security radius ``R = ρ + margin`` [m], as
    the IPNS vector ``P(c) − ½R² e∞`` (the seed's "security circle" of §VI, in 3-D)."""
    m = validation.nonnegative(margin, "margin")
    c, rho = _center_radius(S)
    R = rho + m
    if not np.isfinite(R * R):
        raise InvalidInputError(f"margin = {m:g} m makes the security radius overflow (R² = inf); rescale the scene")
    return point(c) - _EINF.scale(0.5 * R * R)


def signed_squared_distance(x: Any, S: Multivector) -> Any:
    """The CGA signed squared distance ``P(x)·s = ½(ρ² − |x − c|²)`` [m²] of point(s) x to sphere S.

    ``x``: (3,) or (N, 3) [m]; ``S``: a sphere (OPNS primitive or IPNS vector, :func:`dual_sphere`).
    Positive inside, zero on the sphere, negative outside.  Returns a float or an (N,) array.
    """
    s = dual_sphere(S)
    with np.errstate(over="ignore", invalid="ignore"):  # checked below
        v = (point(x) | s).get(0)
    if not np.all(np.isfinite(v)):
        raise InvalidInputError("x is too far from the sphere: P(x)·s overflows; express the scene in a nearer unit")
    return float(v) if np.ndim(v) == 0 else np.asarray(v, dtype=float)


# ---------------------------------------------------------------------- the Coulomb field
def charges(security_radii: Any, centers: Any, goal: Any, rule: str = "seed") -> np.ndarray:
    """Obstacle charges (k,) by the equilibrium-point placement rule (Eq 23).

    ``security_radii`` (k,) [m], ``centers`` (k, 3) [m], ``goal`` (3,) [m]; D is the distance
    between the obstacle charge and the goal charge.  ``rule="seed"``: q = R/(R + D) as printed
    (the planar rule); ``"equilibrium"``: q = (R/(R + D))², which places the equilibrium point of
    the 3-D field at distance R behind the obstacle (see :func:`equilibrium_distance`).
    """
    rule = validation.choice(rule, CHARGE_RULES, "rule")
    R = validation.array(security_radii, "security_radii").reshape(-1)
    if R.size and not float(R.min()) > 0.0:
        raise InvalidInputError(f"security_radii must be > 0 [m], got {float(R.min()):g}")
    C = _centers(centers, "centers")
    g = _bounded(validation.vector(goal, 3, "goal"), "goal")
    if C.shape[0] != R.shape[0]:
        raise InvalidInputError(f"{R.shape[0]} security_radii for {C.shape[0]} centers: give one radius per centre")
    D = np.linalg.norm(C - g, axis=1)
    q = R / (R + D)
    return q if rule == "seed" else q * q


def equilibrium_distance(q: float, D: float) -> float:
    """Distance r* [m] of the equilibrium point behind a charge q at distance D from the unit goal
    charge, on the goal–obstacle axis, for the 3-D field (Eq 22, n = 3): ``q/r*² = 1/(r* + D)²``,
    so ``r* = √q D/(1 − √q)`` (q < 1)."""
    q = validation.positive(q, "q")
    D = validation.positive(D, "D")
    if q >= 1.0:
        raise InvalidInputError(f"an obstacle charge q = {q:g} ≥ 1 has no equilibrium point behind it")
    sq = float(np.sqrt(q))
    with np.errstate(over="ignore"):
        return float(validation.finite_result(sq * D / (1.0 - sq), f"equilibrium_distance(q = {q:g}, D = {D:g} m)"))


def _bounded(P: np.ndarray, what: str) -> np.ndarray:
    if P.size and float(np.max(np.abs(P))) > MAX_COORDINATE:
        raise InvalidInputError(f"{what} reaches {float(np.max(np.abs(P))):.3g} m, beyond ±{MAX_COORDINATE:g} m")
    return P


def _centers(centers: Any, what: str) -> np.ndarray:
    C = validation.array(centers, what)
    if C.shape == (3,):
        C = C.reshape(1, 3)
    if C.ndim != 2 or C.shape[1] != 3:
        raise InvalidInputError(f"{what} must have shape (k, 3) [m], got shape {C.shape}")
    return _bounded(C, what)


def _charges_args(x: Any, centers: Any, q: Any, goal: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The checked arguments of the Coulomb potential and field: x (N, 3), centres (k, 3), charges (k,), goal (3,).

    A point on a charge (or on the goal) is refused: the potential and the field are singular there."""
    X = validation.array(x, "x")
    if X.shape[-1:] != (3,) or X.ndim > 2:
        raise InvalidInputError(f"x must have shape (3,) or (N, 3) [m], got shape {X.shape}")
    X = _bounded(X.reshape(-1, 3), "x")
    C = _centers(centers, "centers")
    Q = validation.array(q, "q").reshape(-1)
    if Q.shape[0] != C.shape[0]:
        raise InvalidInputError(f"{Q.shape[0]} charges q for {C.shape[0]} centers: give one charge per centre")
    g = _bounded(validation.vector(goal, 3, "goal"), "goal")
    for label, P in (("the goal", g[None]), *((f"charge {i} (centre {c.tolist()})", c[None]) for i, c in enumerate(C))):
        hit = np.flatnonzero(np.all(X == P, axis=1))
        if hit.size:
            raise InvalidInputError(
                f"x[{int(hit[0])}] = {X[hit[0]].tolist()} lies on {label}, where the Coulomb potential and field are "
                "singular; evaluate elsewhere"
            )
    return X, C, Q, g


def coulomb_potential(x: Any, centers: Any, q: Any, goal: Any) -> Any:
    """U(x) = Σ q_i/|x − c_i| − 1/|x − goal| (Eq 21, n = 3): positive charges at the obstacle
    centres, a unit negative charge at the goal.  ``x`` (3,) or (N, 3) [m]; returns float or (N,).

    Raises :class:`InvalidInputError` for a point on a charge or on the goal (U is singular there)."""
    X, C, Q, g = _charges_args(x, centers, q, goal)
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):  # checked below
        U = np.sum(Q[None, :] / np.linalg.norm(X[:, None, :] - C[None], axis=2), axis=1) - 1.0 / np.linalg.norm(
            X - g, axis=1
        )
    if not np.all(np.isfinite(U)):
        raise InvalidInputError("x lies too close to a charge: the Coulomb potential overflows there")
    return float(U[0]) if np.ndim(x) == 1 else U


def _over_cube(v: np.ndarray, n: float) -> np.ndarray:
    """v / n³ for a vector v of norm n [m] (the goal's pull, Eq 27); past n = 1e100, where n³ overflows (a float
    power raises OverflowError), as (v / n) / n²."""
    return v / n**3 if n < 1e100 else (v / n) / (n * n)


def _field(x: np.ndarray, C: np.ndarray, Q: np.ndarray, g: np.ndarray) -> np.ndarray:
    d = x - C
    r = np.sqrt(np.einsum("ij,ij->i", d, d))
    e_obs = (Q / r**3) @ d
    dg = x - g
    e_goal = _over_cube(dg, float(np.sqrt(dg @ dg)))
    return e_obs - e_goal


def coulomb_field(x: Any, centers: Any, q: Any, goal: Any) -> np.ndarray:
    """E(x) = E_obs − E_goal = −∇U (Eq 22 with n = 3, Eq 27): Σ q_i (x − c_i)/|x − c_i|³ −
    (x − goal)/|x − goal|³ [1/m²], shape (3,).

    Raises :class:`InvalidInputError` for a point on a charge or on the goal (E is singular there)."""
    validation.vector(x, 3, "x")
    X, C, Q, g = _charges_args(x, centers, q, goal)
    try:
        with np.errstate(divide="ignore", over="ignore", invalid="ignore"):  # checked below
            E = _field(X[0], C, Q, g)
    except OverflowError:  # |x − goal|³ beyond the doubles
        raise InvalidInputError("x is too far from the goal: the Coulomb field's |x − goal|³ overflows") from None
    if not np.all(np.isfinite(E)):
        raise InvalidInputError("x lies too close to a charge: the Coulomb field overflows there")
    return E


def additive_split(P: Multivector) -> tuple[Multivector, Multivector]:
    """The additive split of a conformal point (Eq 24–26) with ``E = e∞ ∧ e0`` (E² = 1):

    ``P_E = (P·E)E = α e0 + β e∞`` (the conformal part, in R^{1,1}) and
    ``P_E⊥ = (P∧E)E = x`` (the Euclidean part), with ``P = P_E + P_E⊥``.
    """
    if not isinstance(P, Multivector):
        raise InvalidInputError(f"P must be a coop_ga Multivector (a conformal point), got {type(P).__name__}")
    if set(P.prune(0.0).grades) - {1}:
        raise InvalidInputError(
            f"P must be a vector (grade 1; the additive split is of conformal points), got grades {sorted(P.grades)}"
        )
    return ((P | _E) * _E).grade(1), ((P ^ _E) * _E).grade(1)


# ---------------------------------------------------------------------- path generation
@dataclass
class PotentialPath:
    """Result of :func:`potential_path`.

    ``path`` (N, 3) [m] the end-point path (start first); ``reached``: within ``tol`` of the goal;
    ``status``: ``"reached"``, ``"escaped"`` (ran off to infinity), ``"local_minimum"`` (the net progress over ``window`` steps vanished
    far from the goal: a field equilibrium or a trap of the safety spheres), ``"blocked"`` (the
    guard left no safe step) or ``"max_iterations"``; ``message`` says why, with numbers.
    ``clearance`` (k,) [m]: the smallest distance of the path *polyline* to each safety sphere
    (distance to the centre − R; ≥ 0 by construction); ``charges`` (k,), ``security_radii`` (k,)
    [m], ``centers`` (k, 3) [m]; ``guard_steps``: steps the safety guard changed; ``stall_point``
    (3,) where the path stopped if it did not reach the goal.
    """

    path: np.ndarray
    reached: bool
    status: str
    message: str
    iterations: int
    final_distance: float
    clearance: np.ndarray
    charges: np.ndarray
    security_radii: np.ndarray
    centers: np.ndarray
    guard_steps: int
    stall_point: np.ndarray | None = None
    blocking: tuple[int, ...] = field(default=())

    @property
    def min_clearance(self) -> float:
        """Smallest clearance over all safety spheres [m] (inf without obstacles)."""
        return float(np.min(self.clearance)) if self.clearance.size else float("inf")

    @property
    def length(self) -> float:
        """Length of the path polyline [m]."""
        return float(np.sum(np.linalg.norm(np.diff(self.path, axis=0), axis=1)))


def _segment_clearance(path: np.ndarray, c: np.ndarray, R: float) -> float:
    """min over the polyline of |x − c| − R (exact per segment)."""
    if path.shape[0] == 1:
        return float(np.linalg.norm(path[0] - c) - R)
    a, b = path[:-1], path[1:]
    d = b - a
    dd = np.einsum("ij,ij->i", d, d)
    t = np.where(dd > 0, np.einsum("ij,ij->i", c - a, d) / np.where(dd > 0, dd, 1.0), 0.0)
    t = np.clip(t, 0.0, 1.0)
    p = a + t[:, None] * d
    return float(np.min(np.linalg.norm(p - c, axis=1)) - R)


class _Guard:
    """The segment test against the safety spheres with CGA inner products P·s (module docstring)."""

    def __init__(self, S: list[Multivector], C: np.ndarray, R: np.ndarray):
        self.S, self.C, self.R = S, C, R
        self.tol = _SAFETY * R * R

    def f(self, P: Multivector) -> np.ndarray:
        """P·s_i = ½(R_i² − d_i²) for every safety sphere (k,)."""
        return np.array([float((P | s).get(0)) for s in self.S])

    def unsafe(self, f0: np.ndarray, x: np.ndarray, delta: np.ndarray) -> tuple[np.ndarray, Multivector]:
        """Indices of spheres whose safety margin the segment x → x + δ violates, and P(x + δ)."""
        P1 = point(x + delta)
        f1 = self.f(P1)
        a = 0.5 * float(delta @ delta)
        # f(t) = f0 + (f1 − f0 + a) t − a t², maximal at t* = (f1 − f0 + a)/(2a), clipped to [0, 1]
        t = np.clip((f1 - f0 + a) / (2.0 * a), 0.0, 1.0) if a > 0 else np.zeros_like(f0)
        fmax = f0 + (f1 - f0 + a) * t - a * t * t
        return np.flatnonzero(fmax > -self.tol), P1


def _project_cone(delta: np.ndarray, normals: list[np.ndarray]) -> np.ndarray:
    """Closest vector to δ with δ·n_i ≥ 0 for the given outward unit normals (≤ 3 active, exact)."""
    if all(delta @ n >= 0 for n in normals):
        return delta
    best = None
    k = len(normals)
    for size in range(1, min(k, 3) + 1):
        for sub in itertools.combinations(range(k), size):
            N = np.array([normals[i] for i in sub])
            # project onto {δ : N δ = 0} (the active constraints as equalities)
            G = N @ N.T
            try:
                lam = np.linalg.solve(G, N @ delta)
            except np.linalg.LinAlgError:
                continue
            d = delta - N.T @ lam
            if all(d @ n >= -1e-15 for n in normals):
                if best is None or np.linalg.norm(d - delta) < np.linalg.norm(best - delta):
                    best = d
        if best is not None:
            return best
    return np.zeros(3)


def _path_ends(start: Any, goal: Any, step: Any, tol: Any) -> tuple[np.ndarray, np.ndarray, float, float]:
    """The checked start (3,), goal (3,) [m], step and goal tolerance (default: the step) [m] of a path.

    A tolerance not below the start–goal distance is refused: the start would count as reached."""
    x0 = validation.vector(start, 3, "start")
    g = validation.vector(goal, 3, "goal")
    for name, p in (("start", x0), ("goal", g)):
        if float(np.max(np.abs(p))) > MAX_COORDINATE:
            raise InvalidInputError(
                f"{name} = {p.tolist()} is beyond ±{MAX_COORDINATE:g} m (its conformal point overflows)"
            )
    h = validation.positive(step, "step")
    tol_ = h if tol is None else validation.positive(tol, "tol")
    d_start = float(np.linalg.norm(g - x0))
    if 0.0 < d_start <= tol_:
        which = "tol" if tol is not None else "step (the default goal tolerance tol)"
        raise InvalidInputError(
            f"{which} = {tol_:g} m is not smaller than the start–goal distance {d_start:.6g} m: the start would count "
            f"as reached without a step; pass a step (or tol) below {d_start:.6g} m"
        )
    return x0, g, h, tol_


def _security_spheres(obstacles: Any, margin: float) -> tuple[np.ndarray, np.ndarray]:
    """Centres (k, 3) [m] and security radii ρ + margin (k,) [m] of the obstacle spheres (one sphere or a list)."""
    if isinstance(obstacles, Multivector):
        obstacles = [obstacles]
    if isinstance(obstacles, str) or not isinstance(obstacles, Iterable):
        raise InvalidInputError(
            f"obstacles must be a list of spheres (collision.potential.obstacle), got {obstacles!r}"
        )
    cr = [_center_radius(S, f"obstacles[{i}]") for i, S in enumerate(obstacles)]
    return np.array([c for c, _ in cr]).reshape(-1, 3), np.array([r + margin for _, r in cr])


def _path_options(
    max_iter: Any, window: Any, escape: Any, charge_rule: Any, margin: Any
) -> tuple[int, int, float, str, float]:
    """The checked options of :func:`potential_path` (max_iter, window, escape, charge_rule, margin [m])."""
    max_iter = validation.integer(max_iter, "max_iter", minimum=1)
    if max_iter > MAX_ITERATIONS:
        raise InvalidInputError(
            f"max_iter = {max_iter} is above {MAX_ITERATIONS} (each iteration is a step of the path); "
            "take a larger step instead"
        )
    window = validation.integer(window, "window", minimum=2)
    escape = validation.positive(escape, "escape")
    charge_rule = validation.choice(charge_rule, CHARGE_RULES, "charge_rule")
    margin = validation.nonnegative(margin, "margin")
    return max_iter, window, escape, charge_rule, margin


def _check_outside(x0: np.ndarray, g: np.ndarray, C: np.ndarray, R: np.ndarray) -> None:
    """Refuse a start or goal (3,) [m] inside a safety sphere (centres C (k, 3), radii R (k,) [m])."""
    for name, p in (("start", x0), ("goal", g)):
        for i in range(len(C)):
            d = float(np.linalg.norm(p - C[i]))
            if d <= R[i] * (1.0 + _SAFETY):
                raise InvalidInputError(
                    f"{name} {p.tolist()} lies inside safety sphere {i} (centre {C[i].tolist()}, R = {R[i]:.6g} m, "
                    f"distance {d:.6g} m); move it out or reduce the margin"
                )


class _FieldWalk:
    """One :func:`potential_path` in progress: the conformal point, the path so far, the guard and the outcome
    (``status``, ``message``, ``blocking``); :meth:`step` is one iteration of §VI-B."""

    def __init__(
        self, x0: np.ndarray, g: np.ndarray, C: np.ndarray, R: np.ndarray, Q: np.ndarray, h: float, tol: float,
        window: int, escape: float,
    ) -> None:  # fmt: skip
        self.g, self.C, self.R, self.Q = g, C, R, Q
        self.h, self.tol, self.window, self.escape = h, tol, window, escape
        self.d_start = float(np.linalg.norm(g - x0))
        self.S = [point(c) - _EINF.scale(0.5 * r * r) for c, r in zip(C, R)]
        self.guard = _Guard(self.S, C, R)
        self.Pg = point(g)
        self.P: Multivector = point(x0)
        self.x = x0.copy()
        self.path = [self.x.copy()]
        self.f0 = self.guard.f(self.P)
        self.guard_steps = 0
        self.status, self.message = "max_iterations", ""
        self.blocking: tuple[int, ...] = ()

    def step(self, it: int) -> bool:
        """Iteration ``it`` (§VI-B, steps 1–4); True when the path stops (``status`` and ``message`` set)."""
        # 1) distance to the goal in CGA
        dist = float(np.sqrt(max(-2.0 * float((self.P | self.Pg).get(0)), 0.0)))
        if self._arrived(it, dist):
            return True
        if dist > self.escape * self.d_start:
            self.status, self.message = "escaped", self._escaped_message(it, dist)
            return True
        # 2) Euclidean part of the conformal point by the additive split (Eq 25)
        _, xe = additive_split(self.P)
        xe_ = np.array([float(xe.get(b)) for b in _B_E])
        delta = self._delta(xe_, dist)
        if delta is None:
            return True
        # 4) the new conformal point (Eq 3)
        self.x = xe_ + delta
        self.P = point(self.x)
        self.f0 = self.guard.f(self.P) if len(self.S) else self.f0
        self.path.append(self.x.copy())
        return self._stalled(dist)

    def _arrived(self, it: int, dist: float) -> bool:
        """Land on the goal once it is within a step and that segment is safe, or stop within ``tol`` of it."""
        if dist <= self.h:
            delta = self.g - self.x
            bad, P1 = self.guard.unsafe(self.f0, self.x, delta) if len(self.S) else (np.zeros(0, int), point(self.g))
            if bad.size == 0:
                self.x, self.P = self.g.copy(), P1
                self.path.append(self.x.copy())
                self.status, self.message = "reached", f"reached the goal in {it} steps"
                return True
        if dist <= self.tol:
            self.status = "reached"
            self.message = f"within tol = {self.tol:g} m of the goal after {it} steps (distance {dist:.3g} m)"
            return True
        return False

    def _escaped_message(self, it: int, dist: float) -> str:
        q = float(np.sum(self.Q))
        return (
            f"the path ran away: {dist:.4g} m from the goal after {it} steps (> {self.escape:g} × the start distance "
            f"{self.d_start:.4g} m); the obstacle charges sum to Σq = {q:.4g}"
            + (
                " ≥ 1: the far field points outward and field lines escape to infinity"
                if q >= 1.0
                else " < 1: the field line returns only after a very long detour"
            )
        )

    def _delta(self, xe_: np.ndarray, dist: float) -> np.ndarray | None:
        """3) the unitary field step (Eq 27) at ``xe_``, through the safety guard; None (and the outcome set) at a
        field equilibrium or when the guard leaves no step."""
        C, Q, g, h = self.C, self.Q, self.g, self.h
        E = _field(xe_, C, Q, g) if len(self.S) else -_over_cube(xe_ - g, float(np.linalg.norm(xe_ - g)))
        # scaled: np.linalg.norm squares the entries, and a pull of 1e-204 (a goal 1e102 m away) underflowed to 0,
        # reported as an equilibrium of the field
        scale = float(np.max(np.abs(E)))
        nE = scale * float(np.linalg.norm(E / scale)) if scale > 0.0 else 0.0
        if not nE > 1e-12 / max(dist, 1e-300) ** 2:
            self.status = "local_minimum"
            self.message = (
                f"the Coulomb field vanishes at {xe_.tolist()} ({dist:.4g} m from the goal): an equilibrium point"
            )
            return None
        delta = h * E / nE
        if len(self.S):
            delta, changed, self.blocking = _guarded(self.guard, self.f0, xe_, delta, h)
            self.guard_steps += changed
            if delta is None:
                self.status = "local_minimum"
                self.message = (
                    f"blocked at {xe_.tolist()} ({dist:.4g} m from the goal): the field points into safety "
                    f"sphere(s) {list(self.blocking)} and no tangent step is left (a concave trap)"
                )
        return delta

    def _stalled(self, dist: float) -> bool:
        """No net progress over the last ``window`` steps (a local minimum: the outcome set)."""
        path, window, h = self.path, self.window, self.h
        if not (len(path) > window and float(np.linalg.norm(path[-1] - path[-1 - window])) < 0.2 * window * h):
            return False
        self.status = "local_minimum"
        near = [i for i in range(len(self.S)) if -self.f0[i] < h * self.R[i] * 1.5]
        why = (
            f"oscillating against safety sphere(s) {near} (a trap of the guarded field)"
            if near
            else "oscillating about an equilibrium point of the Coulomb field (a saddle of U)"
        )
        self.blocking = tuple(near)
        self.message = (
            f"no net progress: {float(np.linalg.norm(path[-1] - path[-1 - window])):.3g} m over the last {window} "
            f"steps of {h:g} m, {dist:.4g} m from the goal — {why}"
        )
        return True

    def result(self, it: int) -> PotentialPath:
        """The :class:`PotentialPath` after ``it`` iterations."""
        arr = np.array(self.path)
        final = float(np.linalg.norm(arr[-1] - self.g))
        reached = self.status == "reached"
        clear = np.array([_segment_clearance(arr, self.C[i], self.R[i]) for i in range(len(self.S))])
        return PotentialPath(
            path=arr,
            reached=reached,
            status=self.status,
            message=self.message,
            iterations=it,
            final_distance=final,
            clearance=clear,
            charges=self.Q,
            security_radii=self.R,
            centers=self.C,
            guard_steps=self.guard_steps,
            stall_point=None if reached else arr[-1].copy(),
            blocking=tuple(int(b) for b in self.blocking),
        )


def potential_path(
    start: Any,
    goal: Any,
    obstacles: Any = (),
    *,
    margin: float = 0.0,
    step: float = 0.01,
    tol: float | None = None,
    max_iter: int = 5000,
    charge_rule: str = "seed",
    window: int = 25,
    escape: float = 10.0,
) -> PotentialPath:
    """End-point path from ``start`` to ``goal`` around sphere obstacles (seed §VI-B, Eq 20–27).

    ``start``, ``goal``: (3,) [m] (world frame); ``obstacles``: a sequence of CGA spheres
    (:func:`obstacle`, or any grade-4 OPNS sphere / grade-1 IPNS vector); ``margin`` [m]: added to
    each radius to give the security radius R (Eq 23); ``step`` ε [m]: the step length of
    ``x ← x + ε E/|E|``; ``tol`` [m]: goal tolerance (default ``step``); ``charge_rule``: see
    :func:`charges`; ``window``: steps over which a net progress below ``0.2·window·step``
    counts as a local minimum; ``escape``: a path farther than ``escape`` × the start–goal
    distance from the goal is stopped as ``"escaped"`` (the field line runs off to infinity,
    which happens when the obstacle charges sum to Σq ≥ 1: the far field then points outward).

    Each iteration (§VI-B, steps 1–4): ``dist = sqrt(−2 P(x)·P(goal))`` (stop if ≤ tol); the
    Euclidean part of P(x) by the additive split (Eq 25); the unit field step; the conformal
    point of the new position (Eq 3); the safety guard of the module docstring.  The last step
    lands on the goal exactly once it is within ``step`` and that segment is safe.

    Raises :class:`InvalidInputError` if start or goal lies inside a safety sphere, and if the goal
    tolerance (``tol``, default ``step``) is not smaller than the start–goal distance: the start would
    count as reached without a step (a path of length 0, whatever lies in between).
    Never raises for a failure of the method: see ``status`` and ``message`` of the result.
    """
    x0, g, h, tol_ = _path_ends(start, goal, step, tol)
    max_iter, window, escape, charge_rule, margin = _path_options(max_iter, window, escape, charge_rule, margin)
    C, R = _security_spheres(obstacles, margin)
    _check_outside(x0, g, C, R)
    Q = charges(R, C, g, charge_rule) if len(C) else np.zeros(0)
    walk = _FieldWalk(x0, g, C, R, Q, h, tol_, window, escape)
    it = 0
    for it in range(1, max_iter + 1):
        if walk.step(it):
            break
    else:
        walk.message = f"max_iter = {max_iter} steps without reaching the goal"
    return walk.result(it)


def _guarded(
    guard: _Guard, f0: np.ndarray, x: np.ndarray, delta: np.ndarray, h: float
) -> tuple[Any, int, tuple[int, ...]]:
    """A safe step near δ (same length h where possible), whether it changed, and the blocking spheres."""
    bad, _ = guard.unsafe(f0, x, delta)
    if bad.size == 0:
        return delta, 0, ()
    active: set[int] = set(int(b) for b in bad)
    d = delta
    for _ in range(4):
        normals = [(x - guard.C[i]) / float(np.linalg.norm(x - guard.C[i])) for i in sorted(active)]
        d = _project_cone(delta, normals)
        n = float(np.linalg.norm(d))
        if n < 1e-6 * h:
            return None, 1, tuple(sorted(active))
        d = d * (h / n)
        bad, _ = guard.unsafe(f0, x, d)
        if bad.size == 0:
            return d, 1, ()
        if set(int(b) for b in bad) <= active:
            break
        active |= set(int(b) for b in bad)
    for _ in range(40):  # rounding at the sphere surface: shorten the projected step
        d = 0.5 * d
        bad, _ = guard.unsafe(f0, x, d)
        if bad.size == 0:
            return d, 1, ()
    return None, 1, tuple(sorted(active))


# ---------------------------------------------------------------------- random scenes
def random_scene(
    rng: np.random.Generator, n_obstacles: int, *, margin: float = 0.0
) -> tuple[np.ndarray, np.ndarray, list[Primitive]]:
    """A random test scene: ``(start, goal, obstacles)`` with 1.0–2.0 m between start and goal and
    ``n_obstacles`` spheres (radius 0.08–0.25 m) centred near the start–goal segment (at 25–75 % of
    it, offset laterally by N(0, 0.1 m) per axis); start and goal are at least 5 cm outside every
    safety sphere (radius + margin).  Deterministic given ``rng``.

    Raises :class:`InvalidInputError` when no scene satisfies that in :data:`MAX_SCENE_DRAWS` draws
    (too many obstacles, or too large a margin)."""
    if not isinstance(rng, np.random.Generator):
        raise InvalidInputError(f"rng must be a numpy.random.Generator (numpy.random.default_rng(seed)), got {rng!r}")
    n = validation.integer(n_obstacles, "n_obstacles", minimum=0)
    if n > MAX_SCENE_OBSTACLES:
        raise InvalidInputError(f"n_obstacles = {n} is above {MAX_SCENE_OBSTACLES}: that many spheres do not fit")
    m = validation.nonnegative(margin, "margin")
    for _ in range(MAX_SCENE_DRAWS):
        s = rng.uniform(-1.0, 1.0, 3)
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        g = s + rng.uniform(*SCENE_DISTANCE) * u
        obs, ok = [], True
        for _ in range(n):
            c = s + rng.uniform(0.25, 0.75) * (g - s) + rng.normal(0.0, 0.1, 3)
            r = rng.uniform(0.08, 0.25)
            if min(np.linalg.norm(s - c), np.linalg.norm(g - c)) < r + m + 0.05:
                ok = False
                break
            obs.append((c, r))
        if ok:
            return s, g, [obstacle(c, r) for c, r in obs]
    raise InvalidInputError(
        f"random_scene: no scene with n_obstacles = {n} spheres at least 5 cm (+ margin = {m:g} m) from start and goal "
        f"in {MAX_SCENE_DRAWS} draws; ask for fewer obstacles or a smaller margin"
    )
