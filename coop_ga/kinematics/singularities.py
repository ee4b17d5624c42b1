"""Singularity analysis of serial arms by meets of the joint-axis lines in CGA (seed 001).

The joint axes of a revolute chain at q are lines ``L_j = P(o_j) ∧ P(o_j + a_j) ∧ e∞`` in
the world (OPNS, unit direction ``a_j``, through the joint origin ``o_j``).  The meet of two
unit lines (:func:`coop_ga.meet`, Eq 5) is ``m e∞`` with ``m = d sin α`` [m] (d their
distance, α their angle; Plücker's reciprocal product): ``m ≠ 0`` — skew; ``m = 0`` — the
lines are coplanar, then intersecting (directions not parallel), parallel, or coincident
(parallel with a point of one on the other: ``P ∧ L = 0``; ``|P ∧ L|`` is the distance).

Why meets detect rank drops.  The columns of the geometric Jacobian are the axis lines
themselves (as screws), so ``rank J < 6`` iff a wrench is reciprocal to every axis.  A
*force along a line N* is reciprocal to the axis L_j iff N and L_j are coplanar, i.e.
``meet(N, L_j) = 0``.  So: **if some line N meets every joint axis, J loses rank** (a force
along N does no work in any joint motion).  Each class below constructs its candidate N
from meets and reports ``max_j |meet(N, L_j)|`` [m] as its residual; a class is detected
when the residual is below ``tol``.  (The converse needs reciprocal screws of non-zero
pitch as well: a rank drop without a transversal line is *not* classified — see the
Panda shoulder family below.)

Classes, for 7R arms with shoulder axes (1, 2, 3), elbow axis 4, wrist axes (5, 6, 7)
(0-based ``shoulder=(0, 1, 2)``, ``elbow=3``, ``wrist=(4, 5, 6)``); S = L1 ∩ L2 (the
shoulder centre), W = L5 ∩ L6 (the wrist point; for the iiwa the three wrist axes meet
there, for the Panda L7 passes 0.088 m away from it):

* ``"elbow"`` (shoulder–wrist alignment): N = S ∧ W ∧ e∞ meets every axis.  iiwa: the
  elbow point lies on SW (q4 = 0, arm stretched).  Panda: L4 ∥ L6 (q5 ∈ {0, π}) with S in
  their plane (q4 = −0.46700 rad).
* ``"shoulder"``: L1 and L3 coincide (q2 = 0) and N = W ∧ meet(L4, Π12) ∧ e∞ meets every
  axis, Π12 the plane of L1, L2: the wrist point lies in Π12 (iiwa: q2 = 0, q3 = ±π/2).
* ``"wrist"``: L5 and L7 coincide (iiwa: q6 = 0) and N = S ∧ meet(L4, Π56) ∧ e∞ meets every
  axis: S lies in the plane Π56 of L5, L6 (iiwa: q6 = 0, q5 = ±π/2).  The seed's "three
  wrist axes meeting in a point" is true of the iiwa at *every* q (a spherical wrist): it is
  the structure that makes this construction work, not a singularity by itself.
* ``"double_alignment"``: L1 ≡ L3 and L5 ≡ L7: only five distinct axes, rank ≤ 5 (no
  transversal needed).

Measured (``tests/kinematics/test_singularities.py``, σ_min of Pinocchio's 6×7
``LOCAL_WORLD_ALIGNED`` Jacobian): on 150 random configurations per robot no class is
detected and J has full rank (iiwa14: σ_min ≥ 1.6e-4, smallest residual 2.0e-4 m, both at
the same sample; panda: σ_min ≥ 1.8e-3, residual ≥ 8.5e-3 m); on constructed ones the
class is detected with residual ≤ 1e-12 m and σ_min ≤ 1e-12 (iiwa: all four classes;
Panda: elbow); off a singularity by ε the residual and σ_min are both O(ε) (ratio constant
to 5 % over ε = 1e-2 … 1e-6).  Disagreements with the seed: its shoulder singularity
"wrist centre on the first axis" is a singularity of 6R arms; for the redundant iiwa a
configuration with W on L1 (q2 = 0.583) keeps full rank (σ_min = 0.18).  The Panda
also drops rank on a family with q2 = 0 (L1 ≡ L3, q3 ≈ 1.45–1.77 depending on q4..q7) that
has no transversal line among our constructions: there we report ``coincident`` axes only,
and the SVD is needed to decide.  The Panda has no wrist class: L5 ∥ L7 at q6 ∈ {0, π}, but
0.088–0.107 m apart (its wrist is not spherical), and those configurations keep full rank.

Numeric only.  Points are read from flat points ``P ∧ e∞`` (meets of lines with planes).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..algebra.basis import blade_index
from ..algebra.multivector import Multivector
from ..errors import InvalidInputError
from ..geometry.groups import motor_rotor_translation, rotor_matrix
from ..geometry.primitives import Primitive, line, meet, plane, point
from .chains import KinematicTree, _as_q

__all__ = [
    "SingularityReport",
    "axis_relation",
    "classify_singularities",
    "joint_axis_lines",
    "line_moment",
    "point_line_distance",
]

_E0I = blade_index("e0inf")[0]
_EII = tuple(blade_index(n)[0] for n in ("e1inf", "e2inf", "e3inf"))

#: relation names of :func:`axis_relation`
RELATIONS = ("skew", "intersecting", "parallel", "coincident")


def _norm(X: Multivector) -> float:
    return math.sqrt(sum(float(c) ** 2 for c in X.coeffs))


def line_moment(L1: Multivector, L2: Multivector) -> float:
    """|meet(L1, L2)| = d sin α [m] of two unit-direction lines (0 iff coplanar)."""
    return _norm(meet(L1, L2))


def point_line_distance(P: Multivector, L: Multivector) -> float:
    """|P ∧ L| [m]: the distance of a normalised point from a unit-direction line."""
    return _norm(P ^ L)


def _point_plane_distance(P: Multivector, Pi: Multivector) -> float:
    return _norm(P ^ Pi)


def _flat_point(X: Multivector) -> np.ndarray | None:
    """Euclidean position of a flat point ``w (P ∧ e∞)`` (None if at infinity)."""
    w = float(X.get(_E0I))
    scale = max(abs(float(X.get(b))) for b in (_E0I, *_EII)) or 1.0
    if abs(w) <= 1e-12 * scale:
        return None
    return np.array([float(X.get(b)) / w for b in _EII])


@dataclass(frozen=True)
class _Axis:
    origin: np.ndarray
    direction: np.ndarray
    line: Primitive


def _unit_line(o: np.ndarray, a: np.ndarray) -> Primitive:
    return line(o, o + a)


def _unit_plane(x: np.ndarray, u: np.ndarray, v: np.ndarray) -> Primitive:
    """Plane through x spanned by u, v (orthonormalised: unit weight)."""
    u = u / np.linalg.norm(u)
    v = v - (v @ u) * u
    v = v / np.linalg.norm(v)
    return plane(x, x + u, x + v)


def joint_axis_lines(tree: KinematicTree, q: Any, chain: int = 0) -> list[Primitive]:
    """World joint-axis lines (OPNS, unit direction) of the revolute joints of chain ``chain`` at q.

    ``q`` (nq,) [rad]; lines in the world frame, ordered root to tip; equal to the world axes
    of Pinocchio's ``oMi[j]`` (origin ``o_j`` [m], direction ``R_j a_j``).
    """
    return [a.line for a in _axes(tree, q, chain)]


def _axes(tree: KinematicTree, q: Any, chain: int) -> list[_Axis]:
    if not isinstance(tree, KinematicTree):
        raise InvalidInputError(f"tree must be a coop_ga KinematicTree, got {type(tree).__name__}")
    if not isinstance(chain, (int, np.integer)) or not 0 <= int(chain) < len(tree.chains):
        raise InvalidInputError(f"chain must be an index in [0, {len(tree.chains)}), got {chain!r}")
    qv = np.asarray(_as_q(q, tree.nq), dtype=float)
    C = tree.joint_motors(qv)
    out = []
    for j in tree.chains[int(chain)]:
        J = tree.joints[j]
        if J.kind != "revolute":
            raise InvalidInputError(f"joint '{J.name}' is {J.kind}: the analysis by axis lines needs revolute joints")
        R, t = motor_rotor_translation(C[j])
        Rm = np.array(rotor_matrix(R), dtype=float)
        o = np.array([float(x) for x in t])
        a = Rm @ np.asarray(J.axis, dtype=float)
        a = a / np.linalg.norm(a)
        out.append(_Axis(o, a, _unit_line(o, a)))
    return out


def axis_relation(L1: _Axis | Multivector, L2: _Axis | Multivector, tol: float = 1e-9) -> str:
    """``"skew"``, ``"intersecting"``, ``"parallel"`` or ``"coincident"`` by the meet (module docstring).

    Lines with unit direction; ``tol`` [m] on ``|meet|`` and on ``|P ∧ L|``, and on
    ``|a1 × a2|`` [rad] for parallelism.
    """
    A1 = L1 if isinstance(L1, _Axis) else _axis_of(L1)
    A2 = L2 if isinstance(L2, _Axis) else _axis_of(L2)
    if line_moment(A1.line, A2.line) > tol:
        return "skew"
    if np.linalg.norm(np.cross(A1.direction, A2.direction)) > tol:
        return "intersecting"
    if point_line_distance(point(A2.origin), A1.line) > tol:
        return "parallel"
    return "coincident"


def _axis_of(L: Multivector) -> _Axis:
    from ..geometry.primitives import closest_point_to_origin, direction

    a = np.asarray(direction(L), dtype=float)
    o = np.asarray(closest_point_to_origin(L), dtype=float)
    return _Axis(o, a, _unit_line(o, a))


def _intersection(A: _Axis, B: _Axis) -> np.ndarray | None:
    """Common point of two coplanar, non-parallel axes: meet of B with a plane through A."""
    n = np.cross(A.direction, B.direction)
    if np.linalg.norm(n) < 1e-12:
        return None
    Pi = _unit_plane(A.origin, A.direction, n)  # contains A, not B
    return _flat_point(meet(B.line, Pi))


def _transversal_residual(p1: np.ndarray | None, p2: np.ndarray | None, axes: Sequence[_Axis]) -> float:
    if p1 is None or p2 is None or np.linalg.norm(p2 - p1) < 1e-9:
        return math.inf
    d = (p2 - p1) / np.linalg.norm(p2 - p1)
    N = _unit_line(p1, d)
    return max(line_moment(N, A.line) for A in axes)


def _coincidence(A: _Axis, B: _Axis) -> float:
    """max(|a × b|, distance of B's origin from A) — 0 iff the axes coincide."""
    return max(float(np.linalg.norm(np.cross(A.direction, B.direction))), point_line_distance(point(B.origin), A.line))


@dataclass(frozen=True)
class SingularityReport:
    """Result of :func:`classify_singularities`.

    Attributes:
        q: the configuration (nq,) [rad].
        lines: the joint-axis lines (OPNS, unit direction, world frame).
        relations: ``{(i, j): relation}`` for every pair i < j (:func:`axis_relation`).
        moments: (n, n) ``|meet(L_i, L_j)| = d sin α`` [m].
        shoulder, wrist: S = L1 ∩ L2 and W = L5 ∩ L6 (else L6 ∩ L7) (3,) [m] (None if those axes do not meet).
        residuals: per class, the residual [m] of its construction (inf if its precondition fails:
            no coincident axes, no common point).
        classes: the classes whose residual is ≤ tol.
        diagnostics: ``wrist_on_first_axis`` (the seed's shoulder condition, |P_W ∧ L1| [m]),
            ``spherical_wrist`` (max distance of W from the three wrist axes [m]).
    """

    q: np.ndarray
    lines: tuple[Primitive, ...]
    relations: dict[tuple[int, int], str]
    moments: np.ndarray
    shoulder: np.ndarray | None
    wrist: np.ndarray | None
    residuals: dict[str, float]
    classes: tuple[str, ...]
    diagnostics: dict[str, float] = field(default_factory=dict)

    @property
    def singular(self) -> bool:
        """True if any class is detected."""
        return bool(self.classes)


def classify_singularities(
    tree: KinematicTree,
    q: Any,
    *,
    chain: int = 0,
    shoulder: tuple[int, int, int] = (0, 1, 2),
    elbow: int = 3,
    wrist: tuple[int, int, int] = (4, 5, 6),
    tol: float = 1e-7,
) -> SingularityReport:
    """Classify the singularities of a 7R arm at q by meets of its axis lines (module docstring).

    ``tree``: a :class:`KinematicTree`; ``chain``: which of its chains (root to tip, 7
    revolute joints); ``shoulder``/``elbow``/``wrist``: 0-based positions of those axes on the
    chain; ``tol`` [m] for residuals and relations.  Returns a :class:`SingularityReport`.
    """
    axes = _axes(tree, q, chain)
    n = len(axes)
    idx = (*shoulder, elbow, *wrist)
    if n != 7 or sorted(idx) != list(range(7)):
        raise InvalidInputError(
            f"classify_singularities needs a 7-joint chain and shoulder/elbow/wrist covering 0..6; got {n} joints, "
            f"indices {idx}"
        )
    if not tol > 0:
        raise InvalidInputError(f"tol must be > 0, got {tol}")
    moments = np.zeros((n, n))
    relations: dict[tuple[int, int], str] = {}
    for i in range(n):
        for j in range(i + 1, n):
            moments[i, j] = moments[j, i] = line_moment(axes[i].line, axes[j].line)
            relations[(i, j)] = axis_relation(axes[i], axes[j], tol)
    s1, s2, s3 = (axes[k] for k in shoulder)
    w1, w2, w3 = (axes[k] for k in wrist)
    E = axes[elbow]
    S = _intersection(s1, s2) if moments[shoulder[0], shoulder[1]] <= tol else None
    W = _intersection(w1, w2) if moments[wrist[0], wrist[1]] <= tol else None
    if W is None and moments[wrist[1], wrist[2]] <= tol:
        W = _intersection(w2, w3)
    res: dict[str, float] = {}
    res["elbow"] = _transversal_residual(S, W, axes)
    # shoulder: L1 ≡ L3, N through W and the point where the elbow axis pierces the plane of L1, L2
    res["shoulder"] = math.inf
    c13 = _coincidence(s1, s3)
    if c13 <= tol and S is not None and W is not None:
        Pi = _unit_plane(S, s1.direction, s2.direction)
        P4 = _flat_point(meet(E.line, Pi))
        res["shoulder"] = max(c13, _transversal_residual(W, P4, axes))
    res["wrist"] = math.inf
    c57 = _coincidence(w1, w3)
    if c57 <= tol and S is not None:
        X = _intersection(w1, w2)
        if X is not None:
            Pi = _unit_plane(X, w1.direction, w2.direction)
            P4 = _flat_point(meet(E.line, Pi))
            res["wrist"] = max(c57, _transversal_residual(S, P4, axes))
    res["double_alignment"] = max(c13, c57)
    diag: dict[str, float] = {
        "coincidence_13": c13,
        "coincidence_57": c57,
    }
    if W is not None:
        diag["wrist_on_first_axis"] = point_line_distance(point(W), s1.line)
        diag["spherical_wrist"] = max(point_line_distance(point(W), A.line) for A in (w1, w2, w3))
    classes = tuple(k for k, v in res.items() if v <= tol)
    return SingularityReport(
        q=np.asarray(_as_q(q, tree.nq), dtype=float).copy(),
        lines=tuple(a.line for a in axes),
        relations=relations,
        moments=moments,
        shoulder=S,
        wrist=W,
        residuals=res,
        classes=classes,
        diagnostics=diag,
    )
