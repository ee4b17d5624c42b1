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

Least-squares kinds (more end points than the primitive needs)
--------------------------------------------------------------
``"sphere_fit"`` (k ≥ 4 points) and ``"plane_fit"`` (k ≥ 3) are the CGA least-squares primitives of
k points: the dual (IPNS) vector S minimising ``Σ_i (P_i · S)²`` under the metric normalisation
``S² = 1`` (a real sphere of unit "weight").  With s, p_i the coefficients of S, P_i on e0, e1, e2, e3,
e∞ and G the metric of G(4,1) on vectors (e0·e∞ = −1, e_i·e_i = 1), ``P_i·S = p_iᵀ G s``, so this is the
eigenvector of the smallest *non-negative* eigenvalue η of the symmetric pencil ``(G M G, G)``,
``M = Σ p_i p_iᵀ`` (5 × 5) — equivalently of ``M G s = η s`` (:func:`fit_parameters`).

Why the metric matters: G is indefinite (signature 4, 1), so the pencil has one negative eigenvalue,
whose eigenvector has S² < 0 (an imaginary sphere: ``η = Σ (P_i·S)² / S²`` has the sign of S²); the
plain smallest eigenvalue of M G picks it, and the smallest eigenvector of M (the Euclidean norm of the
coefficients, not even similarity-invariant) a biased sphere.  With
``S = e0 + c + ½(|c|² − r²) e∞`` (scaled by 1/r to S² = 1), ``P·S = −(|x − c|² − r²)/(2r) ≈ −(|x − c| − r)``:
the objective is the sum of squared geometric distances to first order — the Pratt fit.  For a plane
(S = n + d e∞, no e0 part, |n| = 1) ``P·S = n·x − d`` is the signed distance exactly, so the plane fit
is the orthogonal (total) least-squares plane: normal = the smallest eigenvector of the scatter
matrix of the points about their centroid.

``"line_fit"`` (k ≥ 2) and ``"circle_fit"`` (k ≥ 3), the other flat and the other round of dimension one:

* line: the principal axis of the points through their centroid — the eigenvector of the *largest* eigenvalue
  λ₃ of the scatter matrix C, the orthogonal least-squares line (Σ squared distances to it = tr C − λ₃, minimal);
  oriented along ``Σ_i (i − (k−1)/2) p_i`` (the points' order: p₂ − p₁ for k = 2, the exact line's rule).
  Guard: the largest :func:`coop_ga.well_definedness` of any 2 points (not all coincident), capped by the
  eigen-gap ``(λ₃ − λ₁)(λ₃ − λ₂)/λ₃²`` (1 for collinear points, 0 when λ₂ = λ₃): points spread evenly across a
  plane (an equilateral triangle, a square) have no principal axis.
* circle: the best plane (the plane fit: normal, Newell-oriented as the exact circle's) and then the Pratt fit
  of the points' projections in that plane (the sphere fit's secular equation in two dimensions).  Why not one
  algebraic fit in CGA: a circle is a grade-3 blade (a sphere ∧ a plane, dually), so ``Σ (P_i·X)²`` over circles
  is a constrained problem on a 10-dimensional blade manifold with no eigenvector solution, while the two
  stages are each the smallest-eigenvalue solution of their own linear problem; the stages are exact whenever
  the points lie on a circle (the plane fit is then their plane, the in-plane fit their circle), and for
  coplanar points the circle is the 2-D Pratt fit, the geometric fit to first order.  For noisy 3-D points it
  weights out-of-plane and in-plane residuals separately (the plane first), which is not the joint geometric
  fit; the tests measure the difference against scipy's least squares on the 3-D distance to a circle.  Two
  roots (λ₁, η) fix it; their implicit derivative is lower triangular (the plane does not see η).  Guard: the
  plane fit's (the largest circle measure of any 3 points — far from collinear — capped by the plane's eigen-gap).
* point pair: no fit.  A point pair *is* its two points (a 0-sphere); more than two points have no "best two
  points" that is a primitive of them — their principal axis is ``"line_fit"``, their centroid a point.

How it is computed (the same source on floats, numpy arrays and CasADi SX, so the task graph
differentiates it like every other kind):

* points relative to their centroid (the task graph's local origin);
* plane: λ₁ = the smallest eigenvalue of the 3 × 3 scatter matrix C by Newton's method on its
  characteristic cubic from λ = 0 — the cubic is decreasing and convex on [0, λ₁], so the iterates
  increase monotonically to λ₁ and never overshoot; the normal is the largest column of adj(C − λ₁ I)
  (= (λ₂ − λ₁)(λ₃ − λ₁) n nᵀ), oriented along the points' Newell normal Σ q_i × q_{i+1} (for k = 3 that
  is (p2 − p1) × (p3 − p1), the orientation rule of the exact plane);
* sphere: with e0-coefficient 1 (a = 1) the eigen-condition reduces, for centred points, to one scalar
  secular equation ``s(η) = M_zz − m_xzᵀ (C − η I)⁻¹ m_xz − (M_z + 2η)²/k = 0`` (z_i = |q_i|²,
  m_xz = Σ q_i z_i, M_z = Σ z_i, M_zz = Σ z_i²): s is decreasing and concave on [0, λ₁(C)) and s(0) ≥ 0,
  so its root there is the smallest non-negative eigenvalue.  η = 0 is exactly the Kåsa fit (the
  closed-form start); Newton steps from it, each capped at half the distance to a lower bound of the
  pole λ₁(C) (which a concave function's Newton step could otherwise jump over), converge to the Pratt
  fit; then centre c = ½ (C − η I)⁻¹ m_xz and r² = |c|² + (M_z + 2η)/k.

Why Newton iterations (and not inverse or power iteration on the 5 × 5 pencil, or a closed form):
there is no closed form of the 5 × 5 eigenproblem; inverse iteration needs (M − σ G)⁻¹ and M is
singular exactly when the fit is exact (k = 4 points, or noise-free points); power iteration has a
fixed-point map whose derivative with respect to the iterate is the eigenvalue ratio, so its
derivative converges only linearly with the value.  Newton's map Φ(η) = η − s/s' has ∂Φ/∂η = s s''/s'² = 0
at the root, so the derivative of the last iterate with respect to the points *is* the implicit-function
derivative of the exact fit (to O(|η_K − η*|)): AD of the fixed number of iterations gives the exact
Jacobian (the reference route :attr:`~coop_ga.cooperative.graph.TaskGraph.ad_function`), and so does what
the task graph does, the closed form at the root plus the implicit derivative of the root
(:func:`fit_at`); the tests compare the two (to 1e-12) and central differences.  The root is a simple
root wherever the fit is well defined; at the (guarded) degeneracies it is not.  With exactly 4 (sphere) or 3 (plane) points η ≡ 0 and the fit is the exact primitive, the
same as the ``"sphere"`` / ``"plane"`` kinds (tests compare both, values and Jacobians).

Well-definedness of the fits (:func:`fit_well_definedness`): the existing measure of
:func:`coop_ga.well_definedness` reused on subsets — for ``sphere_fit`` the largest sphere measure of any
4 of the points (the points are far from coplanar iff some 4 of them are), for ``plane_fit`` the
largest plane measure of any 3 (far from collinear), capped by the eigen-gap ``(λ₂ − λ₁)/(λ₂ + λ₁)`` of
the scatter matrix (an isotropic cloud, e.g. a regular tetrahedron, has no best plane).  For k = 4
resp. 3 both equal the exact kinds' measures.
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import combinations
from typing import Any

import numpy as np

from .. import validation
from ..algebra import backend as B
from ..algebra.basis import blade_index
from ..algebra.multivector import Multivector
from ..errors import DegeneratePrimitiveError, InvalidInputError
from ..geometry.kinds import COOPERATIVE_KINDS, FIT_KINDS, FLAT_KINDS, KIND_SPECS, FitKind, Kind, KindSpec, kind_spec
from ..geometry.primitives import Primitive, _check_kind, well_definedness
from ..geometry.primitives import circle as _circle_from_points
from ..geometry.primitives import line as _line_from_points
from ..geometry.primitives import plane as _plane_from_points

__all__ = [
    "COOPERATIVE_KINDS",
    "FIT_KINDS",
    "FIT_ROOTS",
    "FLAT_KINDS",
    "cooperative_primitive",
    "fit_at",
    "fit_parameters",
    "fit_primitive",
    "fit_root",
    "fit_well_definedness",
    "primitive_jacobian",
]

_CUBIC_ITERS = 40  # Newton steps for λ₁ of the scatter matrix (plane fit: its accuracy is the normal's)
_BOUND_ITERS = 8  # the same, as the sphere fit's lower bound of its pole (any iterate is a lower bound)
_PRATT_ITERS = 20  # Newton steps on the sphere fit's secular equation from the Kåsa fit


# ---------------------------------------------------------------------- least-squares fits
def _where(c: Any, a: Any, b: Any) -> Any:
    return B.where(c, a, b)


def _fmax(a: Any, b: Any) -> Any:
    return _where(a >= b, a, b)


def _scatter(q: Sequence[Sequence[Any]]) -> tuple[Any, Any, Any, Any, Any, Any]:
    """(c00, c01, c02, c11, c12, c22) of C = Σ q_i q_iᵀ."""
    return tuple(sum(p[a] * p[b] for p in q) for a, b in ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)))


def _adjugate(c: tuple[Any, ...], lam: Any) -> tuple[Any, ...]:
    """(adj00, adj01, adj02, adj11, adj12, adj22) of the symmetric C − λI."""
    a00, a01, a02, a11, a12, a22 = c[0] - lam, c[1], c[2], c[3] - lam, c[4], c[5] - lam
    return (
        a11 * a22 - a12 * a12,
        a02 * a12 - a01 * a22,
        a01 * a12 - a02 * a11,
        a00 * a22 - a02 * a02,
        a01 * a02 - a00 * a12,
        a00 * a11 - a01 * a01,
    )


def _char_coeffs(c: tuple[Any, ...]) -> tuple[Any, Any, Any]:
    """(c2, c1, c0) with det(C − λI) = −λ³ + c2 λ² − c1 λ + c0."""
    c00, c01, c02, c11, c12, c22 = c
    c2 = c00 + c11 + c22
    c1 = c00 * c11 - c01 * c01 + c00 * c22 - c02 * c02 + c11 * c22 - c12 * c12
    c0 = c00 * (c11 * c22 - c12 * c12) - c01 * (c01 * c22 - c12 * c02) + c02 * (c01 * c12 - c11 * c02)
    return c2, c1, c0


def _smallest_eigenvalue(c: tuple[Any, ...], iters: int) -> Any:
    """λ₁ of C by Newton on det(C − λI) from λ = 0 (module docstring: monotone from below)."""
    c2, c1, c0 = _char_coeffs(c)
    lam: Any = 0.0 * c2
    for _ in range(iters):
        p = c0 + lam * (-c1 + lam * (c2 - lam))
        dp = -c1 + lam * (2.0 * c2 - 3.0 * lam)
        neg = dp < 0
        lam = lam - _where(neg, p / _where(neg, dp, -1.0), 0.0 * p)
    return lam


def _centred(pts: Sequence[Sequence[Any]]) -> tuple[list[Any], list[list[Any]]]:
    k = len(pts)
    bar = [sum(p[j] for p in pts) / k for j in range(3)]
    return bar, [[p[j] - bar[j] for j in range(3)] for p in pts]


def _eigenvector(c: tuple[Any, ...], lam: Any) -> list[Any]:
    """Unit eigenvector of the symmetric C for its simple eigenvalue λ: the largest column of adj(C − λI)
    (= Π_{j≠i}(λ_j − λ) v vᵀ), sign unspecified."""
    adj = _adjugate(c, lam)
    cols = ((adj[0], adj[1], adj[2]), (adj[1], adj[3], adj[4]), (adj[2], adj[4], adj[5]))
    d0, d1, d2 = adj[0], adj[3], adj[5]  # ≥ 0: Π_{j≠i}(λ_j − λ) > 0 for the smallest and the largest λ
    pick1 = d1 >= d2
    col = [_where(d0 >= _fmax(d1, d2), cols[0][j], _where(pick1, cols[1][j], cols[2][j])) for j in range(3)]
    nn = B.sqrt(col[0] * col[0] + col[1] * col[1] + col[2] * col[2])
    pos = nn > 0
    return [col[j] / _where(pos, nn, 1.0) for j in range(3)]


def _other_two(c: tuple[Any, ...], lam: Any) -> tuple[Any, Any]:
    """(sum, product) of the two eigenvalues of C other than λ."""
    c2, c1, _ = _char_coeffs(c)
    s2 = c2 - lam
    return s2, c1 - lam * s2


def _gap(a: Any, b: Any) -> Any:
    """(b − a)/(b + a) for 0 ≤ a ≤ b, 0 when both vanish (the scale-free eigen-gap)."""
    gs = a + b
    gpos = gs > 0
    return _where(gpos, (b - a) / _where(gpos, gs, 1.0), 0.0 * gs)


def _plane_at(q: list[list[Any]], lam: Any) -> tuple[list[Any], Any, Any]:
    """(unit normal n, eigen-gap, det(C − λI)) of the centred points q at the eigenvalue estimate λ."""
    c = _scatter(q)
    c2, c1, c0 = _char_coeffs(c)
    n = _eigenvector(c, lam)
    k = len(q)
    newell: list[Any] = [0.0, 0.0, 0.0]
    for i in range(k):
        a, b = q[i], q[(i + 1) % k]
        newell = [
            newell[0] + a[1] * b[2] - a[2] * b[1],
            newell[1] + a[2] * b[0] - a[0] * b[2],
            newell[2] + a[0] * b[1] - a[1] * b[0],
        ]
    flip = n[0] * newell[0] + n[1] * newell[1] + n[2] * newell[2] < 0
    n = [_where(flip, -n[j], n[j]) for j in range(3)]
    s2, pr = _other_two(c, lam)  # λ₂ + λ₃, λ₂ λ₃
    disc = s2 * s2 / 4.0 - pr
    den = s2 / 2.0 + B.sqrt(_where(disc > 0, disc, 0.0 * disc))
    dpos = den > 0
    lam2 = _where(dpos, pr / _where(dpos, den, 1.0), 0.0 * pr)
    res = c0 + lam * (-c1 + lam * (c2 - lam))
    return n, _gap(lam, lam2), res


def _largest_eigenvalue(c: tuple[Any, ...], iters: int) -> Any:
    """λ₃ of C by Newton on det(C − λI) from λ = tr C ≥ λ₃: right of λ₃ the cubic is negative, decreasing and
    concave, so the iterates decrease monotonically to λ₃ and never overshoot."""
    c2, c1, c0 = _char_coeffs(c)
    lam: Any = c2
    for _ in range(iters):
        p = c0 + lam * (-c1 + lam * (c2 - lam))
        dp = -c1 + lam * (2.0 * c2 - 3.0 * lam)
        neg = dp < 0
        lam = lam - _where(neg, p / _where(neg, dp, -1.0), 0.0 * p)
    return lam


def _line_at(q: list[list[Any]], lam: Any) -> tuple[list[Any], Any, Any]:
    """(unit direction d, eigen-gap (λ₃ − λ₁)(λ₃ − λ₂)/λ₃², det(C − λI)) of the centred points q at the estimate λ
    of λ₃: the principal axis, oriented along ``Σ_i (i − (k−1)/2) q_i`` (the points' order; p₂ − p₁ for k = 2)."""
    c = _scatter(q)
    c2, c1, c0 = _char_coeffs(c)
    d = _eigenvector(c, lam)
    k = len(q)
    order = [sum((i - 0.5 * (k - 1)) * q[i][j] for i in range(k)) for j in range(3)]
    flip = d[0] * order[0] + d[1] * order[1] + d[2] * order[2] < 0
    d = [_where(flip, -d[j], d[j]) for j in range(3)]
    s2, pr = _other_two(c, lam)  # λ₁ + λ₂, λ₁ λ₂
    # (λ₃ − λ₁)(λ₃ − λ₂)/λ₃², free of the square root that resolves the double root λ₁ = λ₂ (two points) to √ε only
    f3 = lam * lam - s2 * lam + pr
    pos = lam > 0
    gap = _where(pos, f3 / _where(pos, lam * lam, 1.0), 0.0 * lam)
    res = c0 + lam * (-c1 + lam * (c2 - lam))
    return d, gap, res


def _sphere_moments(q: list[list[Any]]) -> tuple[tuple[Any, ...], list[Any], Any, Any]:
    z = [p[0] * p[0] + p[1] * p[1] + p[2] * p[2] for p in q]
    mxz = [sum(p[j] * zi for p, zi in zip(q, z)) for j in range(3)]
    return _scatter(q), mxz, sum(z), sum(zi * zi for zi in z)


def _sphere_secular(q: list[list[Any]], eta: Any) -> tuple[list[Any], Any, Any, Any]:
    """(y = (C − ηI)⁻¹ m_xz, s(η), s'(η), M_z) of the centred points q (module docstring)."""
    k = len(q)
    c, mxz, mz, mzz = _sphere_moments(q)
    a = _adjugate(c, eta)
    det = (c[0] - eta) * a[0] + c[1] * a[1] + c[2] * a[2]
    det = _where(B.fabs(det) > 0, det, 1.0)
    y = [
        (a[0] * mxz[0] + a[1] * mxz[1] + a[2] * mxz[2]) / det,
        (a[1] * mxz[0] + a[3] * mxz[1] + a[4] * mxz[2]) / det,
        (a[2] * mxz[0] + a[4] * mxz[1] + a[5] * mxz[2]) / det,
    ]
    s = mzz - (mxz[0] * y[0] + mxz[1] * y[1] + mxz[2] * y[2]) - (mz + 2.0 * eta) ** 2 / k
    ds = -(y[0] * y[0] + y[1] * y[1] + y[2] * y[2]) - 4.0 * (mz + 2.0 * eta) / k
    return y, s, ds, mz


def _sphere_root(q: list[list[Any]]) -> Any:
    """η of the Pratt fit: safeguarded Newton on the secular equation from the Kåsa fit η = 0."""
    lo = _smallest_eigenvalue(_scatter(q), _BOUND_ITERS)  # a lower bound of the secular equation's pole
    return _pratt_newton(lambda eta: _sphere_secular(q, eta), lo)


def _pratt_newton(secular: Any, lo: Any) -> Any:
    """The root η of a Pratt secular equation s(η) = 0 (``secular(η)`` returns ``(y, s, s', M_z)``) below its pole,
    bounded below by ``lo``: :data:`_PRATT_ITERS` Newton steps from the Kåsa fit η = 0, each kept above the midpoint
    of η and ``lo`` (branch-free, so that the graph differentiates through it)."""
    eta: Any = 0.0 * lo
    for _ in range(_PRATT_ITERS):
        _, s, ds, _ = secular(eta)
        neg = ds < 0
        step = eta - _where(neg, s / _where(neg, ds, -1.0), 0.0 * s)
        half = 0.5 * (eta + lo)
        eta = _where(step < half, step, half)
    return eta


def _sphere_at(q: list[list[Any]], eta: Any) -> tuple[list[Any], Any, Any]:
    """(centre relative to the centroid, radius, s(η)) of the centred points q at the root estimate η."""
    k = len(q)
    y, s, _, mz = _sphere_secular(q, eta)
    centre = [0.5 * y[j] for j in range(3)]
    r2 = centre[0] * centre[0] + centre[1] * centre[1] + centre[2] * centre[2] + (mz + 2.0 * eta) / k
    r = B.sqrt(_where(r2 > 0, r2, 0.0 * r2))
    return centre, r, s


def _in_plane(q: list[list[Any]], n: list[Any]) -> tuple[list[tuple[Any, Any]], list[Any], list[Any]]:
    """Coordinates of the centred points q on an orthonormal basis (u, v) of the plane ⟂ n, u × v = n.  The basis
    switches with n (u ⟂ e1, or ⟂ e2 when n is near e1), which the circle fit does not see: the in-plane Pratt fit
    is rotation invariant."""
    near_e1 = B.fabs(n[0]) > 0.9
    a = [_where(near_e1, 0.0 * n[0], 1.0 + 0.0 * n[0]), _where(near_e1, 1.0 + 0.0 * n[0], 0.0 * n[0]), 0.0 * n[0]]
    u = [n[1] * a[2] - n[2] * a[1], n[2] * a[0] - n[0] * a[2], n[0] * a[1] - n[1] * a[0]]  # n × a
    nu = B.sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2])
    u = [u[j] / _where(nu > 0, nu, 1.0) for j in range(3)]
    v = [n[1] * u[2] - n[2] * u[1], n[2] * u[0] - n[0] * u[2], n[0] * u[1] - n[1] * u[0]]  # n × u
    return [(p[0] * u[0] + p[1] * u[1] + p[2] * u[2], p[0] * v[0] + p[1] * v[1] + p[2] * v[2]) for p in q], u, v


def _circle_secular(x: list[tuple[Any, Any]], eta: Any) -> tuple[list[Any], Any, Any, Any]:
    """(y = (C − ηI)⁻¹ m_xz, s(η), s'(η), M_z) of centred in-plane points x (2-D: the sphere's secular equation)."""
    k = len(x)
    z = [p[0] * p[0] + p[1] * p[1] for p in x]
    c00 = sum(p[0] * p[0] for p in x) - eta
    c01 = sum(p[0] * p[1] for p in x)
    c11 = sum(p[1] * p[1] for p in x) - eta
    m = [sum(p[j] * zi for p, zi in zip(x, z)) for j in range(2)]
    mz, mzz = sum(z), sum(zi * zi for zi in z)
    det = c00 * c11 - c01 * c01
    det = _where(B.fabs(det) > 0, det, 1.0)
    y = [(c11 * m[0] - c01 * m[1]) / det, (c00 * m[1] - c01 * m[0]) / det]
    s = mzz - (m[0] * y[0] + m[1] * y[1]) - (mz + 2.0 * eta) ** 2 / k
    ds = -(y[0] * y[0] + y[1] * y[1]) - 4.0 * (mz + 2.0 * eta) / k
    return y, s, ds, mz


def _circle_root(x: list[tuple[Any, Any]]) -> Any:
    """η of the in-plane Pratt fit: the sphere's safeguarded Newton (:func:`_sphere_root`) on the 2-D secular
    equation, its pole bounded below by the smallest eigenvalue of the 2 × 2 scatter matrix (closed form)."""
    a00 = sum(p[0] * p[0] for p in x)
    a01 = sum(p[0] * p[1] for p in x)
    a11 = sum(p[1] * p[1] for p in x)
    lo = 0.5 * (a00 + a11) - B.sqrt(0.25 * (a00 - a11) * (a00 - a11) + a01 * a01)
    return _pratt_newton(lambda eta: _circle_secular(x, eta), lo)


def _circle_at(q: list[list[Any]], lam: Any, eta: Any) -> tuple[list[Any], Any, list[Any], Any, Any]:
    """(centre relative to the centroid, radius, unit normal, det(C − λI), s(η)) of the circle fit of the centred
    points q at the root estimates λ (the plane's) and η (the in-plane Pratt fit's)."""
    n, _, res_plane = _plane_at(q, lam)
    x, u, v = _in_plane(q, n)
    k = len(x)
    y, s, _, mz = _circle_secular(x, eta)
    c2 = [0.5 * y[0], 0.5 * y[1]]
    r2 = c2[0] * c2[0] + c2[1] * c2[1] + (mz + 2.0 * eta) / k
    r = B.sqrt(_where(r2 > 0, r2, 0.0 * r2))
    centre = [c2[0] * u[j] + c2[1] * v[j] for j in range(3)]
    return centre, r, n, res_plane, s


def _fit_spec(kind: str, k: int | None, what: str = "this function") -> KindSpec:
    """The spec of a least-squares kind used with k points (None: not checked)."""
    spec = kind_spec(kind)
    if not spec.least_squares:
        raise InvalidInputError(f"{what} is for the least-squares kinds {tuple(FIT_KINDS)}, got {kind!r}")
    if k is not None:
        spec.points_used(k)
    return spec


#: how many scalars fix each least-squares primitive (:func:`fit_root`): the circle fit has two, the plane's λ₁
#: and the in-plane Pratt η
FIT_ROOTS: dict[str, int] = {"sphere_fit": 1, "plane_fit": 1, "line_fit": 1, "circle_fit": 2}


def fit_root(kind: FitKind, pts: Sequence[Sequence[Any]]) -> Any:
    """The scalar(s) that fix the least-squares primitive of ``pts`` (k 3-vectors, numeric or CasADi): the
    Pratt eigenvalue η of a ``sphere_fit``, the smallest eigenvalue λ₁ of the scatter matrix of a
    ``plane_fit``, its largest λ₃ of a ``line_fit`` [m²]; for a ``circle_fit`` the list ``[λ₁, η]`` (the plane's
    and the in-plane Pratt fit's) — by the Newton iterations of the module docstring (:data:`FIT_ROOTS` of them)."""
    _fit_spec(kind, len(pts))
    _, q = _centred(pts)
    c = _scatter(q)
    if kind == "plane_fit":
        return _smallest_eigenvalue(c, _CUBIC_ITERS)
    if kind == "line_fit":
        return _largest_eigenvalue(c, _CUBIC_ITERS)
    if kind == "circle_fit":
        lam = _smallest_eigenvalue(c, _CUBIC_ITERS)
        n, _, _ = _plane_at(q, lam)
        return [lam, _circle_root(_in_plane(q, n)[0])]
    return _sphere_root(q)


def fit_at(kind: FitKind, pts: Sequence[Sequence[Any]], root: Any) -> tuple[list[Any], list[Any], Any, Any, Any]:
    """``(centroid, c, r, o, residual)`` of the least-squares primitive of ``pts`` *given* its root
    (:func:`fit_root`) in closed form; ``residual`` (the secular function s(η), resp. det(C − λI); for a circle
    the pair of both) vanishes at the exact root, so the implicit-function theorem gives the derivative of the
    fit: ``d/dp = ∂/∂p − ∂/∂root · (∂res/∂root)⁻¹ (∂res/∂p)`` (used by the task graph)."""
    _fit_spec(kind, len(pts))
    bar, q = _centred(pts)
    zero = [0.0 * bar[0]] * 3
    if kind == "plane_fit":
        n, _, res = _plane_at(q, root)
        return bar, zero, None, n, res
    if kind == "line_fit":
        d, _, res = _line_at(q, root)
        return bar, zero, None, d, res
    if kind == "circle_fit":
        centre, r, n, res_plane, s = _circle_at(q, root[0], root[1])
        return bar, centre, r, n, [res_plane, s]
    centre, r, res = _sphere_at(q, root)
    return bar, centre, r, None, res


def fit_parameters(kind: FitKind, pts: Sequence[Sequence[Any]]) -> tuple[list[Any], list[Any], Any, Any]:
    """``(centroid, c, r, o)`` of the least-squares primitive of ``pts`` (k 3-vectors; floats, numpy arrays of
    one shape (a batch) or CasADi SX scalars): ``c`` the centre (sphere) or the centroid, a point of the
    plane (plane), *relative to the centroid* [m]; ``r`` the radius [m] (sphere; None for a plane); ``o``
    the unit normal (plane; None for a sphere).  No validation and no degeneracy check (see
    :func:`fit_well_definedness`); never NaN for finite input.  Module docstring for the method."""
    bar, c, r, o, _ = fit_at(kind, pts, fit_root(kind, pts))
    return bar, c, r, o


def fit_well_definedness(kind: FitKind, pts: Any) -> Any:
    """Scale-free well-definedness of a least-squares kind's points (1 best, 0 degenerate; module docstring):
    the largest :func:`coop_ga.well_definedness` of any 4 (sphere) or 3 (plane) of them, for the plane also
    capped by the scatter matrix's eigen-gap.  ``pts``: (k, 3) numeric, or k CasADi/float 3-vectors.

    The eigen-gap of an exactly isotropic cloud (λ₁ = λ₂ = λ₃, e.g. a regular tetrahedron) is resolved only
    to ~ε^(1/3) ≈ 4e-6 (a triple root of the cubic): such points get a :class:`~coop_ga.errors.DegeneracyWarning`
    from the task, not the error."""
    rows = [tuple(p[j] for j in range(3)) for p in pts] if not isinstance(pts, np.ndarray) else list(pts)
    spec = _fit_spec(kind, len(rows))
    m = spec.n_points
    symbolic = any(B.is_symbolic(v) for p in rows for v in p)
    base = spec.primitive_kind
    w: Any = None
    for sub in combinations(range(len(rows)), m):
        if symbolic:
            wi = well_definedness(base, [rows[i] for i in sub])
        else:
            wi = well_definedness(base, np.array([rows[i] for i in sub], dtype=float))
        w = wi if w is None else _fmax(w, wi)
    if kind != "sphere_fit":  # also capped by the eigen-gap that makes the normal (the direction) unique
        _, q = _centred(rows)
        c = _scatter(q)
        if kind == "line_fit":
            _, gap, _ = _line_at(q, _largest_eigenvalue(c, _CUBIC_ITERS))
        else:
            _, gap, _ = _plane_at(q, _smallest_eigenvalue(c, _CUBIC_ITERS))
        w = _where(gap < w, gap, w)
    return w if symbolic else float(w)


def fit_primitive(kind: FitKind, points: Any, *, raise_below: float = 1e-6) -> Primitive:
    """The least-squares primitive (a ``"sphere"``, ``"plane"``, ``"line"`` or ``"circle"``
    :class:`~coop_ga.geometry.primitives.Primitive`)
    of numeric ``points`` (k, 3) [m]; :class:`~coop_ga.errors.DegeneratePrimitiveError` when their
    :func:`fit_well_definedness` is ≤ ``raise_below``."""
    from ..geometry.primitives import sphere as _sphere_from_points

    spec = _fit_spec(kind, None, "fit_primitive")
    P = validation.array(points, "points")
    if P.ndim != 2 or P.shape[1] != 3:
        raise InvalidInputError(f"points must have shape (k, 3), got {P.shape}")
    spec.points_used(P.shape[0])
    w = fit_well_definedness(kind, P)
    if not w > raise_below:
        raise DegeneratePrimitiveError(
            f"{kind} of {P.shape[0]} points: {spec.degeneracy} (well-definedness {w:.3g} ≤ {raise_below:g})"
        )
    bar, c, r, o = fit_parameters(kind, [tuple(p) for p in P.tolist()])
    cb = np.array([float(c[j]) + bar[j] for j in range(3)])
    if o is not None:
        n = np.array([float(v) for v in o])
        u = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
        u /= np.linalg.norm(u)
        v = np.cross(n, u)
        scale = float(np.max(np.abs(P - cb)))  # points of the flat about the points' own size
        if kind == "line_fit":
            return Primitive.tag(_line_from_points(cb, cb + scale * n), "line")  # direction first → second = n
        if kind == "circle_fit":  # three points of the fitted circle, counter-clockwise about n
            rr = float(r)
            X = _circle_from_points(cb + rr * u, cb + rr * v, cb - rr * u)
            return Primitive.tag(X, "circle")
        X = _plane_from_points(cb, cb + scale * u, cb + scale * v)  # normal u × v = n
        return Primitive.tag(X, "plane")
    rr = float(r)
    # a regular tetrahedron inscribed in the fitted sphere: the exact sphere through it is the fit
    tet = np.array([[1.0, 1.0, 1.0], [1.0, -1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, 1.0]]) / np.sqrt(3.0)
    S = _sphere_from_points(*(cb + rr * t for t in tet))
    return Primitive.tag(S, "sphere")


_EI = Multivector((blade_index("einf")[0],), (1.0,))


def _wedge(vs: Sequence[Multivector]) -> Multivector:
    X = vs[0]
    for v in vs[1:]:
        X = X ^ v
    return X


def cooperative_primitive(kind: Kind, points: Sequence[Multivector]) -> Primitive:
    """X_c = P_1 ∧ … ∧ P_n (Eq 14), with ``∧ e∞`` appended for lines and planes.

    ``points`` are conformal points (numpy or CasADi coefficients), as many as the kind
    needs (:attr:`~coop_ga.geometry.kinds.KindSpec.n_points`).  No degeneracy check here: the cooperative task checks the
    well-definedness measure of the Euclidean points (see :mod:`coop_ga.cooperative.task`).
    """
    spec = KIND_SPECS[_check_kind(kind)]
    n = spec.n_points
    if len(points) != n:
        raise InvalidInputError(f"a cooperative {kind} needs {n} end points, got {len(points)}")
    vs = list(points) + ([_EI] if spec.flat else [])
    X = _wedge(vs)
    return Primitive.tag(X.grade(len(vs)), kind)


def primitive_jacobian(
    kind: Kind, points: Sequence[Multivector], dpoints: Sequence[Sequence[Any]]
) -> list[Multivector]:
    """Columns ∂X_c/∂q_j = Σ_i P_1 ∧ … ∧ ∂P_i/∂q_j ∧ … ∧ P_n (Eq 15).

    ``dpoints[i][j]`` is ∂P_i/∂q_j (a vector multivector, Eq 17) or None when joint j
    does not move point i.  Returns one multivector per joint (zero where no point moves).
    """
    spec = KIND_SPECS[_check_kind(kind)]
    n = spec.n_points
    tail = [_EI] if spec.flat else []
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
