"""Cooperative geometric primitives X_c(q) = P_1 ∧ … ∧ P_k (∧ e∞) and their Jacobians (Eq 14–17).

Orientation from order
----------------------
The outer product is antisymmetric, so the order of the end points fixes the
primitive's orientation, and with it the rotation part of V_Sc:

* point pair / line: oriented from the first point to the second; the unit primitive's
  axis is +e2, so V_Sc rotates +e2 onto (p2 − p1)/|p2 − p1|;
* circle / plane: normal (p2 − p1) × (p3 − p1), i.e. counter-clockwise points seen from
  the tip of the normal; the unit primitive's normal is +e3;
* sphere: no orientation for the similarity (its sign is the handedness of the four
  points and only flips the sign of X).

Swapping two points rotates V_Sc by a half-turn (point pair/line) or flips the normal
(circle/plane), so choose the order that keeps the nominal primitive's axis far from
the antipode of the unit axis (−e2 resp. −e3), where the minimal rotation is
discontinuous.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from ..algebra.basis import blade_index
from ..algebra.multivector import Multivector
from ..errors import InvalidInputError
from ..geometry.primitives import N_POINTS, Primitive, _check_kind

__all__ = ["FLAT_KINDS", "N_POINTS", "cooperative_primitive", "primitive_jacobian"]

FLAT_KINDS = ("line", "plane")
_EI = Multivector((blade_index("einf")[0],), (1.0,))


def _wedge(vs: Sequence[Multivector]) -> Multivector:
    X = vs[0]
    for v in vs[1:]:
        X = X ^ v
    return X


def cooperative_primitive(kind: str, points: Sequence[Multivector]) -> Primitive:
    """X_c = P_1 ∧ … ∧ P_n (Eq 14), with ``∧ e∞`` appended for lines and planes.

    ``points`` are conformal points (numpy or CasADi coefficients), as many as the kind
    needs (:data:`N_POINTS`).  No degeneracy check here: the cooperative task checks the
    well-definedness measure of the Euclidean points (see :mod:`coop_ga.cooperative.task`).
    """
    kind = _check_kind(kind)
    n = N_POINTS[kind]
    if len(points) != n:
        raise InvalidInputError(f"a cooperative {kind} needs {n} end points, got {len(points)}")
    vs = list(points) + ([_EI] if kind in FLAT_KINDS else [])
    X = _wedge(vs)
    return Primitive.tag(X.grade(len(vs)), kind)


def primitive_jacobian(kind: str, points: Sequence[Multivector], dpoints: Sequence[Sequence[Any]]) -> list[Multivector]:
    """Columns ∂X_c/∂q_j = Σ_i P_1 ∧ … ∧ ∂P_i/∂q_j ∧ … ∧ P_n (Eq 15).

    ``dpoints[i][j]`` is ∂P_i/∂q_j (a vector multivector, Eq 17) or None when joint j
    does not move point i.  Returns one multivector per joint (zero where no point moves).
    """
    kind = _check_kind(kind)
    n = N_POINTS[kind]
    tail = [_EI] if kind in FLAT_KINDS else []
    m = len(dpoints[0])
    cols = []
    for j in range(m):
        acc: Multivector | None = None
        for i in range(n):
            d = dpoints[i][j]
            if d is None:
                continue
            vs = list(points[:i]) + [d] + list(points[i + 1 :]) + tail
            term = _wedge(vs)
            acc = term if acc is None else acc + term
        cols.append(acc.grade(n + len(tail)) if acc is not None else Multivector.zero())
    return cols
