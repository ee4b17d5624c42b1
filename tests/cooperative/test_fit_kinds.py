"""The least-squares kinds "sphere_fit" (≥ 4 points) and "plane_fit" (≥ 3 points) of the task graph.

Seed 003 §5.6: the CGA least-squares sphere is the smallest non-negative eigenvalue
solution S of Σ (P_i·S)² under S² = 1; its similarity and Jacobian come from the same task graph as every
other kind.  Checked here: the fit against scipy (generalized eigenproblem, SVD, geometric least squares),
exactness for 4 / 3 points against the "sphere" / "plane" kinds (values and Jacobians), J^G against
central finite differences and CasADi AD through the iterations, and the degeneracy guard.
"""

from __future__ import annotations

import itertools
import warnings

import casadi as ca
import numpy as np
import pytest
import scipy.linalg
import scipy.optimize

import coop_ga as cg
from coop_ga.cooperative import CooperativeTask, cooperative_task
from coop_ga.cooperative.primitive import (
    COOPERATIVE_KINDS,
    fit_parameters,
    fit_primitive,
    fit_root,
    fit_well_definedness,
)
from coop_ga.geometry.groups import Similarity
from coop_ga.geometry.primitives import center, normal, radius
from coop_ga.systems import cartesian_points

RNG = np.random.default_rng(20261201)
# six chain bases spread in 3-D (the end point of chain i is bases[i] + q[3i:3i+3])
BASES6 = np.array(
    [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.3], [0.5, 0.5, -0.7]]
)


def _system(k: int):
    return cartesian_points(k, BASES6[:k])


def _task(k: int, kind: str) -> CooperativeTask:
    return CooperativeTask(_system(k), kind, codegen=False)


def _q(points: np.ndarray) -> np.ndarray:
    return (np.asarray(points) - BASES6[: len(points)]).reshape(-1)


def _noisy_sphere(k: int, c, r, noise, cap=False):
    d = RNG.normal(size=(k, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    if cap:  # a spherical cap (the hard case for algebraic fits)
        d[:, 2] = 0.3 * np.abs(d[:, 2]) + 0.5
        d /= np.linalg.norm(d, axis=1, keepdims=True)
    return np.asarray(c) + r * d + RNG.normal(scale=noise * r, size=(k, 3))


def _pencil(P: np.ndarray):
    """M = Σ w_i w_iᵀ (w = (|x|², x, 1)) and N (the metric form S² = b² − 4 u0 u4 on u = (−a/2, b, −c))."""
    W = np.c_[(P**2).sum(1), P, np.ones(len(P))]
    N = np.zeros((5, 5))
    N[1:4, 1:4] = np.eye(3)
    N[0, 4] = N[4, 0] = -2.0
    return W.T @ W, N


def _u_of(c, r):
    """u = (−a/2, b, −c∞) of the dual sphere S = e0 + c + ½(|c|² − r²) e∞ (a = 1)."""
    c = np.asarray(c, float)
    return np.r_[-0.5, c, -0.5 * (c @ c - r * r)]


def _fit(P):
    bar, c, r, _ = fit_parameters("sphere_fit", [tuple(p) for p in P])
    return np.array(bar) + np.array(c, float), float(r)


# ---------------------------------------------------------------------- the fit itself
@pytest.mark.parametrize("k,noise,cap", [(5, 0.02, False), (6, 0.05, False), (8, 0.03, True), (12, 0.01, True)])
def test_sphere_fit_is_the_smallest_nonnegative_eigenvector_of_the_pencil(k, noise, cap):
    P = _noisy_sphere(k, RNG.normal(size=3), RNG.uniform(0.2, 2.0), noise, cap)
    c, r = _fit(P)
    M, N = _pencil(P)
    ev, V = scipy.linalg.eig(M, N)
    ev = ev.real
    assert np.sum(ev < 0) == 1  # the metric is indefinite: one negative eigenvalue, an imaginary sphere
    i = np.argmin(np.where(ev >= 0, ev, np.inf))
    u_ref = V[:, i].real
    assert u_ref @ N @ u_ref > 0  # the chosen eigenvector is a real sphere, S² > 0
    a = -2.0 * u_ref[0]
    c_ref = u_ref[1:4] / a
    r_ref = np.sqrt(u_ref[1:4] @ u_ref[1:4] - 4.0 * u_ref[0] * u_ref[4]) / abs(a)
    np.testing.assert_allclose(c, c_ref, atol=1e-11 * r_ref)
    assert r == pytest.approx(r_ref, rel=1e-11)
    # the eigen-equation M u = η N u holds with our η (fit_root) and our u
    u = _u_of(c, r)
    eta = float(fit_root("sphere_fit", [tuple(p) for p in P]))
    assert eta == pytest.approx(ev[i], rel=1e-9, abs=1e-14 * np.trace(M))
    assert np.linalg.norm(M @ u - eta * N @ u) < 1e-10 * np.linalg.norm(M) * np.linalg.norm(u)
    # the eigenvector of the negative eigenvalue (what an unsigned "smallest eigenvalue" would pick) differs
    j = np.argmin(ev)
    assert ev[j] < 0 and V[:, j].real @ N @ V[:, j].real < 0


def test_sphere_fit_minimises_the_normalised_objective():
    P = _noisy_sphere(7, [0.3, -0.2, 1.0], 0.5, 0.04)
    M, N = _pencil(P)

    def objective(c, r):  # Σ (P_i · S)² / S²
        u = _u_of(c, r)
        return (u @ M @ u) / (u @ N @ u)

    c, r = _fit(P)
    best = objective(c, r)
    for _ in range(200):
        assert objective(c + RNG.normal(scale=1e-3, size=3), r + RNG.normal(scale=1e-3)) > best
    # against the geometric least-squares sphere (scipy): close, and worse in the algebraic objective
    g = scipy.optimize.least_squares(lambda x: np.linalg.norm(P - x[:3], axis=1) - x[3], np.r_[c, r], xtol=1e-15).x
    assert objective(g[:3], g[3]) >= best
    np.testing.assert_allclose(c, g[:3], atol=0.01 * r)
    assert r == pytest.approx(g[3], rel=0.01)
    # and the Kåsa fit (η = 0, the iteration's start) is worse than the fit
    Wk = np.c_[P, np.ones(len(P))]
    sol = np.linalg.lstsq(Wk, 0.5 * (P**2).sum(1), rcond=None)[0]
    ck, rk = sol[:3], np.sqrt(sol[3] * 2.0 + sol[:3] @ sol[:3])
    assert objective(ck, rk) > best


def test_sphere_fit_exact_on_noise_free_points_far_from_the_origin():
    c0, r0 = np.array([300.0, -200.0, 50.0]), 0.25
    P = _noisy_sphere(6, c0, r0, 0.0)
    c, r = _fit(P)
    np.testing.assert_allclose(c, c0, atol=1e-9)
    assert r == pytest.approx(r0, rel=1e-9)


@pytest.mark.parametrize("k", [4, 5, 9])
def test_plane_fit_is_the_total_least_squares_plane(k):
    n0 = RNG.normal(size=3)
    n0 /= np.linalg.norm(n0)
    P = RNG.normal(size=(k, 3)) * [1.0, 0.7, 0.05] @ scipy.linalg.qr(RNG.normal(size=(3, 3)))[0] + [2.0, -1.0, 0.5]
    bar, _, _, o = fit_parameters("plane_fit", [tuple(p) for p in P])
    n = np.array(o, float)
    _, _, Vt = scipy.linalg.svd(P - P.mean(0))
    assert abs(n @ Vt[2]) == pytest.approx(1.0, abs=1e-13)
    np.testing.assert_allclose(bar, P.mean(0), atol=1e-14)
    # oriented along the Newell normal of the point order
    Q = P - P.mean(0)
    newell = np.sum(np.cross(Q, np.roll(Q, -1, axis=0)), axis=0)
    assert n @ newell > 0
    # the CGA reading: P·S with S = n + d e∞ is the signed distance; the sum of squares is minimal
    d = n @ bar
    res = P @ n - d
    for _ in range(100):
        m = n + RNG.normal(scale=1e-3, size=3)
        m /= np.linalg.norm(m)
        assert np.sum((P @ m - m @ bar) ** 2) >= np.sum(res**2)
    X = fit_primitive("plane_fit", P)
    assert X.kind == "plane"
    np.testing.assert_allclose(normal(X), n, atol=1e-14)


def test_fit_primitive_sphere_reads_back():
    P = _noisy_sphere(6, [0.1, 0.2, -0.3], 0.7, 0.02)
    c, r = _fit(P)
    X = fit_primitive("sphere_fit", P)
    assert X.kind == "sphere"
    np.testing.assert_allclose(center(X), c, atol=1e-13)
    assert float(radius(X)) == pytest.approx(r, rel=1e-13)


# ---------------------------------------------------------------------- exact for the minimal count
@pytest.mark.parametrize(
    "fit,exact,k",
    [("sphere_fit", "sphere", 4), ("plane_fit", "plane", 3), ("line_fit", "line", 2), ("circle_fit", "circle", 3)],
)
def test_minimal_count_equals_the_exact_kind(fit, exact, k):
    tf, te = _task(k, fit), _task(k, exact)
    for _ in range(5):
        q = RNG.normal(scale=0.3, size=3 * k)
        a, b = tf.evaluate(q), te.evaluate(q)
        np.testing.assert_allclose(a.coeffs, b.coeffs, atol=1e-13)
        np.testing.assert_allclose(a.log, b.log, atol=1e-13)
        np.testing.assert_allclose(a.jacobian, b.jacobian, atol=1e-12)
        assert a.well_definedness == pytest.approx(b.well_definedness, abs=1e-15)
        np.testing.assert_allclose(tf.similarity_numpy(q).coeffs, b.coeffs, atol=1e-13)


# ---------------------------------------------------------------------- Jacobian routes
def _fd_body_jacobian(task: CooperativeTask, q: np.ndarray, h: float = 1e-6) -> np.ndarray:
    V = task.similarity(q)
    cols = []
    for i in range(task.nq):
        e = np.zeros(task.nq)
        e[i] = h
        lp = (V.inverse() @ task.similarity(q + e)).log()
        lm = (V.inverse() @ task.similarity(q - e)).log()
        cols.append((lp - lm) / (2 * h))
    return np.array(cols).T


@pytest.mark.parametrize(
    "kind,k",
    [
        ("sphere_fit", 5),
        ("sphere_fit", 6),
        ("plane_fit", 4),
        ("plane_fit", 6),
        ("line_fit", 4),
        ("circle_fit", 4),
        ("circle_fit", 6),
    ],
)
def test_jacobian_vs_finite_differences_and_ad(kind, k):
    task = _task(k, kind)
    for _ in range(3):
        q = RNG.normal(scale=0.15, size=3 * k)
        J = task.jacobian(q)
        scale = np.max(np.abs(J))
        np.testing.assert_allclose(J, _fd_body_jacobian(task, q), atol=2e-7 * scale)
        # AD through the Newton iterations (ad_function) vs the implicit-function derivative of the graph
        np.testing.assert_allclose(J, task.jacobian_ad(q), atol=1e-12 * scale)


def test_error_jacobian_jdot_batch_and_primitive_of_a_fit_task():
    task = _task(6, "sphere_fit")
    q = RNG.normal(scale=0.1, size=18)
    target = task.similarity(q + 0.05)
    e, Je = task.error_and_jacobian(q, target)
    assert np.linalg.norm(e) > 0.01
    h = 1e-6
    fd = np.array([(task.error(q + h * ei, target) - task.error(q - h * ei, target)) / (2 * h) for ei in np.eye(18)]).T
    np.testing.assert_allclose(Je, fd, atol=1e-6 * np.max(np.abs(Je)))
    qd = RNG.normal(size=18)
    jd = task.jdot_qdot(q, qd)
    fdj = (task.jacobian(q + h * qd) @ qd - task.jacobian(q - h * qd) @ qd) / (2 * h)
    np.testing.assert_allclose(jd, fdj, atol=1e-5 * np.max(np.abs(jd)))
    V, B, J = task.evaluate_batch(np.stack([q, q + 0.01]))
    np.testing.assert_allclose(J[0], task.jacobian(q), atol=1e-15)
    np.testing.assert_allclose(V[1], task.similarity(q + 0.01).coeffs, atol=1e-15)
    np.testing.assert_allclose(B[1], task.log(q + 0.01), atol=1e-15)
    # second derivatives (the iLQR's error_hessian) through the same graph
    wv = RNG.normal(size=7)
    H = task.error_hessian(q, target, wv)
    fdh = np.array(
        [
            (wv @ task.error_jacobian(q + h * ei, target) - wv @ task.error_jacobian(q - h * ei, target)) / (2 * h)
            for ei in np.eye(18)
        ]
    )
    np.testing.assert_allclose(H, fdh, atol=1e-7 * np.max(np.abs(H)))
    np.testing.assert_allclose(task.similarity_numpy(q).coeffs, task.similarity(q).coeffs, atol=1e-14)
    X = task.primitive(q)
    assert X.kind == "sphere"
    V2 = task.target_from_primitive(X)
    np.testing.assert_allclose(V2.coeffs, task.similarity(q).coeffs, atol=1e-12)
    assert task.primitive_kind == "sphere" and task.kind == "sphere_fit"
    with pytest.raises(cg.InvalidInputError, match="sphere Primitive"):
        task.target_from_primitive(cg.plane([0, 0, 0], [1, 0, 0], [0, 1, 0]))
    with pytest.raises(cg.InvalidInputError, match="closed forms"):
        task.jacobian_closed_form(q)


def test_cooperative_task_with_fit_kinds_and_point_subsets():
    sys6 = _system(6)
    t = cooperative_task(sys6, "sphere_fit", points=[5, 0, 2, 3, 1], codegen=False)
    assert t.end_frames == ("tip5", "tip0", "tip2", "tip3", "tip1")
    assert cooperative_task(sys6, "sphere_fit", points=[5, 0, 2, 3, 1], codegen=False) is t
    assert CooperativeTask(sys6, "plane_fit", codegen=False).end_frames == sys6.end_frames  # default: all points
    with pytest.raises(cg.InvalidInputError, match="at least 4"):
        cooperative_task(sys6, "sphere_fit", points=[0, 1, 2])
    with pytest.raises(cg.InvalidInputError, match="distinct"):
        cooperative_task(sys6, "plane_fit", points=[0, 1, 1, 2])
    with pytest.raises(cg.UnknownNameError, match="sphere_fit"):
        cooperative_task(sys6, "ellipsoid")
    assert set(COOPERATIVE_KINDS) >= {"sphere", "plane", "sphere_fit", "plane_fit"}


# ---------------------------------------------------------------------- degeneracy
def test_coplanar_points_raise_the_degeneracy_error_everywhere():
    task = _task(6, "sphere_fit")
    P = np.c_[RNG.uniform(-1, 1, (6, 2)), np.full(6, 0.2)]  # coplanar
    q = _q(P)
    assert fit_well_definedness("sphere_fit", P) < 1e-12
    for call in (task.evaluate, task.jacobian, lambda q: task.error_and_jacobian(q, Similarity.identity())):
        with pytest.raises(cg.DegeneratePrimitiveError, match="coplanar"):
            call(q)
    with pytest.raises(cg.DegeneratePrimitiveError):
        fit_primitive("sphere_fit", P)
    # the fit itself never returns NaN, even there
    bar, c, r, _ = fit_parameters("sphere_fit", [tuple(p) for p in P])
    assert np.all(np.isfinite(np.r_[bar, np.array(c, float), float(r)]))
    # nearly coplanar: a warning, not an error
    P2 = P.copy()
    P2[0, 2] += 1e-3
    with pytest.warns(cg.DegeneracyWarning):
        task.evaluate(_q(P2))


def test_plane_fit_degeneracies():
    task = _task(5, "plane_fit")
    line = np.outer(np.linspace(-1, 1, 5), [0.3, 0.5, 0.8]) + [0.1, 0.0, 0.0]
    with pytest.raises(cg.DegeneratePrimitiveError, match="collinear"):
        task.evaluate(_q(line))
    # an isotropic cloud (a regular tetrahedron: λ₁ = λ₂ = λ₃) has no best plane; a triple root is resolved
    # to ~ε^(1/3) only, so its eigen-gap measure is ~4e-6: a warning at the default thresholds
    iso = np.array([[1.0, 1.0, 1.0], [1.0, -1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, 1.0]])
    assert fit_well_definedness("plane_fit", iso) < 1e-5
    with pytest.raises(cg.DegeneratePrimitiveError):
        fit_primitive("plane_fit", iso, raise_below=1e-5)
    with pytest.warns(cg.DegeneracyWarning, match="no best plane"):
        _task(4, "plane_fit").evaluate(_q(iso))
    # 4 points of an equilateral triangle + its centre: well defined (the measure is the triangle's)
    tri = np.array([[1.0, 0, 0], [-0.5, np.sqrt(3) / 2, 0], [-0.5, -np.sqrt(3) / 2, 0], [0, 0, 0]])
    assert fit_well_definedness("plane_fit", tri) == pytest.approx(1.0, abs=1e-12)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _task(4, "plane_fit").evaluate(_q(tri))


def test_fit_well_definedness_reuses_the_exact_measure():
    P = RNG.normal(size=(4, 3))
    assert fit_well_definedness("sphere_fit", P) == pytest.approx(float(cg.well_definedness("sphere", P)), abs=0)
    P6 = RNG.normal(size=(6, 3))
    subsets = [float(cg.well_definedness("sphere", P6[list(s)])) for s in itertools.combinations(range(6), 4)]
    assert fit_well_definedness("sphere_fit", P6) == pytest.approx(max(subsets), abs=0)
    # symbolic and numeric agree
    p = ca.SX.sym("p", 18)
    w = fit_well_definedness("sphere_fit", [tuple(p[3 * i + j] for j in range(3)) for i in range(6)])
    f = ca.Function("w", [p], [w])
    assert float(f(P6.reshape(-1))) == pytest.approx(max(subsets), rel=1e-14)
