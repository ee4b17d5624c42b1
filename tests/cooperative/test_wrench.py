"""The cooperative wrench (coop_ga.cooperative.wrench): closed-form cases, virtual work, finite differences.

The systems are the 'Cartesian' ones (end points = base + q), so the task's point-level map G is J^G itself.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import coop_ga as cg
from coop_ga.cooperative import cooperative_wrench, squeeze_capacity, wrench_map
from coop_ga.cooperative.wrench import BETA, WrenchMap
from coop_ga.errors import DegeneratePrimitiveError, InvalidInputError, NonFiniteError
from coop_ga.systems import cartesian_points

RNG = np.random.default_rng(21)


def _task(n: int, kind: str):
    system = cartesian_points(n)
    return cg.cooperative_task(system, kind, codegen=False)


@pytest.fixture(scope="module")
def circle():
    return _task(3, "circle")


def _pose(task, P):
    """(V (12,), B (7,), G (7, 3n)) of the task's pose function at points P (n, 3)."""
    V, B, G, _, _ = task.graph.pose_function(np.asarray(P, float).reshape(-1))
    return np.array(V).ravel(), np.array(B).ravel(), np.array(G)


def _rigid(P, c):
    """A (3n, 6): ṗ_i = v + ω × (p_i − c)."""
    rows = []
    for p in P:
        d = p - c
        S = np.array([[0.0, -d[2], d[1]], [d[2], 0.0, -d[0]], [-d[1], d[0], 0.0]])
        rows.append(np.hstack([np.eye(3), -S]))
    return np.vstack(rows)


def _circumcircle(P):
    a, b, c = P
    ab, ac = b - a, c - a
    n = np.cross(ab, ac)
    cc = a + (ac @ ac * np.cross(n, ab) + ab @ ab * np.cross(ac, n)) / (2 * n @ n)
    return cc, float(np.linalg.norm(a - cc)), n / np.linalg.norm(n)


def _even_circle(r=0.3, c=(0.1, -0.2, 0.5)):
    ang = np.radians([-90.0, 30.0, 150.0])
    return np.asarray(c) + np.stack([r * np.cos(ang), r * np.sin(ang), np.zeros(3)], axis=1)


UNEVEN = np.array([[0.3, -0.1, 0.5], [0.05, 0.25, 0.55], [-0.2, -0.15, 0.45]])


# ---------------------------------------------------------------------- closed form
def test_equal_inward_radial_forces_are_a_pure_squeeze(circle):
    P, f = _even_circle(), 12.5
    c = P.mean(axis=0)
    F = -f * (P - c) / np.linalg.norm(P - c, axis=1, keepdims=True)  # on the object, inward
    w = cooperative_wrench(circle, P, F)
    assert w.squeeze == pytest.approx(f, rel=1e-12)
    assert w.radius == pytest.approx(0.3, rel=1e-12) and np.allclose(w.centre, c, atol=1e-14)
    np.testing.assert_allclose(w.force, 0.0, atol=1e-12)
    np.testing.assert_allclose(w.torque, 0.0, atol=1e-12)
    np.testing.assert_allclose(w.external, 0.0, atol=1e-12)
    expected = np.zeros(7)
    expected[BETA] = -3 * 0.3 * f  # 𝒲_β = −s n r [J]
    np.testing.assert_allclose(w.wrench, expected, atol=1e-12)
    np.testing.assert_allclose(w.internal_forces, F, atol=1e-12)  # all of it is internal
    np.testing.assert_allclose(w.internal_rest, 0.0, atol=1e-12)  # and all of that is the squeeze
    # the squeeze direction is radial inward, unit over the stacked points
    np.testing.assert_allclose(w.direction, F / np.linalg.norm(F), atol=1e-12)


def test_pulling_outward_is_a_negative_squeeze(circle):
    P = _even_circle()
    F = 3.0 * (P - P.mean(axis=0)) / 0.3
    assert cooperative_wrench(circle, P, F).squeeze == pytest.approx(-3.0, rel=1e-12)


@pytest.mark.parametrize("points", [_even_circle(), UNEVEN], ids=["even", "uneven"])
def test_a_common_force_is_purely_external(circle, points):
    f = np.array([1.0, -2.0, 3.5])
    w = cooperative_wrench(circle, points, np.tile(f, (3, 1)))
    c = w.centre
    np.testing.assert_allclose(w.force, 3 * f, atol=1e-12)
    np.testing.assert_allclose(w.torque, np.cross(points - c, f).sum(axis=0), atol=1e-12)
    assert abs(w.squeeze) < 1e-12  # blind to external loads, even for unevenly spaced points
    assert abs(w.external[BETA]) < 1e-12 and abs(w.wrench[BETA]) < 1e-12
    np.testing.assert_allclose(w.internal_forces, 0.0, atol=1e-12)


def test_least_squares_dual_would_lose_half_the_load_and_see_a_false_squeeze(circle):
    """Why the module does not use 𝒲 = (Gᵀ)⁺ F (module docstring): a common in-plane force on three evenly
    spaced points maps back (Gᵀ 𝒲) to half its net force — its components along the circle lie in ker G —
    and on uneven points a common force reads as a squeeze."""
    f = np.array([0.0, 0.0, 10.0])
    _, _, G = _pose(circle, _even_circle())
    W = np.linalg.pinv(G.T) @ np.tile(f, 3)
    assert (G.T @ W).reshape(3, 3).sum(axis=0)[2] == pytest.approx(30.0, rel=1e-9)  # normal to the plane: kept
    fx = np.array([10.0, 0.0, 0.0])  # in the plane: half of the 30 N is lost
    W = np.linalg.pinv(G.T) @ np.tile(fx, 3)
    assert (G.T @ W).reshape(3, 3).sum(axis=0)[0] == pytest.approx(15.0, rel=1e-9)
    assert cooperative_wrench(circle, _even_circle(), np.tile(fx, (3, 1))).force[0] == pytest.approx(30.0)
    _, _, Gu = _pose(circle, UNEVEN)
    Wu = np.linalg.pinv(Gu.T) @ np.tile(f, 3)
    assert abs(Wu[BETA]) > 0.1  # a "squeeze" from a pure load
    assert abs(cooperative_wrench(circle, UNEVEN, np.tile(f, (3, 1))).squeeze) < 1e-12


# ---------------------------------------------------------------------- derivatives and virtual work
def test_beta_row_is_the_gradient_of_ln_r_by_central_differences(circle):
    _, B, G = _pose(circle, UNEVEN)
    h, g = 1e-6, np.zeros(9)
    for k in range(9):
        Pp, Pm = UNEVEN.reshape(-1).copy(), UNEVEN.reshape(-1).copy()
        Pp[k] += h
        Pm[k] -= h
        g[k] = (math.log(_circumcircle(Pp.reshape(3, 3))[1]) - math.log(_circumcircle(Pm.reshape(3, 3))[1])) / (2 * h)
    np.testing.assert_allclose(G[BETA], g, atol=1e-8)
    assert math.exp(B[BETA]) == pytest.approx(_circumcircle(UNEVEN)[1], rel=1e-12)
    # the squeeze direction is −g normalised
    w = cooperative_wrench(circle, UNEVEN, np.zeros((3, 3)))
    np.testing.assert_allclose(w.direction.reshape(-1), -g / np.linalg.norm(g), atol=1e-7)


def test_translation_rows_are_body_velocities_in_units_of_the_radius(circle):
    """b_t = Rᵀ ċ / r (docs/conventions.md): a common point velocity v moves the centre by v."""
    V, B, G = _pose(circle, UNEVEN)
    v = np.array([0.3, -0.2, 0.5])
    b = G @ np.tile(v, 3)
    R = cg.Similarity.from_coeffs(V).rotation_matrix
    np.testing.assert_allclose(b[4:7], R.T @ v / math.exp(B[BETA]), atol=1e-12)


def test_virtual_work_on_every_rigid_motion(circle):
    """(G A ξ)ᵀ 𝒲_ext = (w − unresolved)ᵀ ξ for random forces, torques and rigid twists ξ; G A by finite
    differences of the pose (log(Ṽ(p) V(p + h A ξ)) / h), not by the function under test."""
    P = UNEVEN
    F, T = RNG.normal(size=(3, 3)), RNG.normal(size=(3, 3))
    w = cooperative_wrench(circle, P, F, T)
    A = _rigid(P, w.centre)
    V0 = cg.Similarity.from_coeffs(_pose(circle, P)[0])
    for xi in RNG.normal(size=(5, 6)):
        h = 1e-7
        V1 = cg.Similarity.from_coeffs(_pose(circle, P + h * (A @ xi).reshape(3, 3))[0])
        b = np.asarray((V0.inverse() @ V1).log()) / h
        wobj = np.concatenate([w.force, w.torque])
        assert w.external @ b == pytest.approx((wobj - w.unresolved) @ xi, abs=2e-6)
    # the object wrench is Aᵀ F plus the point torques
    np.testing.assert_allclose(np.concatenate([w.force, w.torque]), A.T @ F.reshape(-1) + np.r_[0, 0, 0, T.sum(0)])
    # the unresolved part is the torque about the circle's axis
    n = _circumcircle(P)[2]
    np.testing.assert_allclose(w.unresolved, np.r_[0, 0, 0, (w.torque @ n) * n], atol=1e-10)


def test_internal_forces_exert_no_wrench_and_the_squeeze_ignores_rigid_fields(circle):
    P = UNEVEN
    F = RNG.normal(size=(3, 3))
    w = cooperative_wrench(circle, P, F)
    A = _rigid(P, w.centre)
    np.testing.assert_allclose(A.T @ w.internal_forces.reshape(-1), 0.0, atol=1e-12)
    np.testing.assert_allclose(A.T @ w.internal_rest.reshape(-1), 0.0, atol=1e-12)
    assert float(w.internal_rest.reshape(-1) @ w.direction.reshape(-1)) == pytest.approx(0.0, abs=1e-12)
    for xi in RNG.normal(size=(4, 6)):  # any rigid velocity field used as forces: zero squeeze
        assert abs(cooperative_wrench(circle, P, (A @ xi).reshape(3, 3)).squeeze) < 1e-12


def test_command_round_trip(circle):
    """F = Gᵀ 𝒲 of a commanded 𝒲 exerts the commanded object wrench (its resolvable part) and the commanded
    squeeze exactly, on evenly and on unevenly spaced points (where Gᵀ𝒲_ext alone also squeezes)."""
    wm = wrench_map(circle)
    for P in (_even_circle(), UNEVEN):
        force, torque = np.array([0.5, -1.0, 19.6]), np.array([0.2, -0.1, 0.3])
        W = wm.command(P, force, torque, squeeze=7.0)
        _, _, G = _pose(circle, P)
        w = wm(P, (G.T @ W).reshape(3, 3))
        n = _circumcircle(P)[2]
        np.testing.assert_allclose(w.force, force, atol=1e-10)
        np.testing.assert_allclose(w.torque, torque - (torque @ n) * n, atol=1e-10)
        assert w.squeeze == pytest.approx(7.0, rel=1e-10)
    # without the correction the uneven lift command would press on its own
    W0 = wm.command(UNEVEN, force=(0.0, 0.0, 19.6))
    _, _, G = _pose(circle, UNEVEN)
    assert abs(wm(UNEVEN, (G.T @ W0).reshape(3, 3)).squeeze) < 1e-10
    W_ext = W0.copy()
    W_ext[BETA] = 0.0
    assert abs(wm(UNEVEN, (G.T @ W_ext).reshape(3, 3)).squeeze) > 0.1
    # a pure squeeze command reads back exactly on any points
    W = wm.command(UNEVEN, squeeze=5.0)
    _, _, G = _pose(circle, UNEVEN)
    assert wm(UNEVEN, (G.T @ W).reshape(3, 3)).squeeze == pytest.approx(5.0, rel=1e-10)


# ---------------------------------------------------------------------- other kinds
def _tetrahedron(r=0.2, c=(0.0, 0.1, 0.4)):
    v = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], float) / math.sqrt(3)
    return np.asarray(c) + r * v


def test_sphere_and_point_pair_squeeze():
    P = _tetrahedron()
    sph = _task(4, "sphere")
    F = -4.0 * (P - P.mean(axis=0)) / 0.2
    w = cooperative_wrench(sph, P, F)
    assert w.squeeze == pytest.approx(4.0, rel=1e-10) and np.allclose(w.force, 0, atol=1e-12)
    # a sphere has no rotation: every torque about its centre is unresolved
    w = cooperative_wrench(sph, P, np.zeros((4, 3)), np.tile([0.1, 0.2, 0.3], (4, 1)))
    np.testing.assert_allclose(w.unresolved[3:], [0.4, 0.8, 1.2], atol=1e-12)
    np.testing.assert_allclose(w.external, 0.0, atol=1e-12)
    pair = _task(2, "point_pair")
    Q = np.array([[0.0, -0.1, 0.3], [0.0, 0.1, 0.3]])
    w = cooperative_wrench(pair, Q, np.array([[0, 6.0, 0], [0, -6.0, 0]]))
    assert w.squeeze == pytest.approx(6.0, rel=1e-12) and w.radius == pytest.approx(0.1)


@pytest.mark.parametrize("kind,n", [("line", 2), ("plane", 3), ("point", 1)])
def test_kinds_without_dilation_have_no_squeeze(kind, n):
    task = _task(n, kind)
    P = np.array([[0.1, 0.0, 0.3], [0.0, 0.2, 0.35], [-0.1, -0.1, 0.3]])[:n]
    F = RNG.normal(size=(n, 3))
    w = cooperative_wrench(task, P, F)
    assert w.squeeze == 0.0 and w.internal[BETA] == 0.0 and not w.direction.any()
    np.testing.assert_allclose(w.force, F.sum(axis=0), atol=1e-12)
    with pytest.raises(InvalidInputError, match="no dilation"):
        squeeze_capacity(task, task.system.q0, np.ones(task.nq))


# ---------------------------------------------------------------------- bad input, capacity, compiled route
def test_bad_input(circle):
    with pytest.raises(InvalidInputError, match="forces must have shape"):
        cooperative_wrench(circle, UNEVEN, np.zeros((2, 3)))
    bad = np.zeros((3, 3))
    bad[1, 2] = np.nan
    with pytest.raises(NonFiniteError):
        cooperative_wrench(circle, UNEVEN, bad)
    with pytest.raises(DegeneratePrimitiveError):
        cooperative_wrench(circle, np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0.0]]), np.zeros((3, 3)))
    with pytest.raises(InvalidInputError, match="CooperativeTask"):
        WrenchMap(object())


def test_squeeze_capacity_is_where_the_first_joint_saturates():
    system = cg.systems.load("three_iiwa14")
    task = cg.cooperative_task(system, "circle")
    q = system.q0
    eff = system.limits.effort
    g = np.linspace(-5.0, 5.0, task.nq)
    cap = squeeze_capacity(task, q, eff, bias=g)
    st = task.evaluate(q)
    W = np.zeros(7)
    W[BETA] = -cap["squeeze_max"] * 3 * cap["radius"]
    tau = g + st.jacobian.T @ W  # τ = J^Gᵀ 𝒲 of the squeeze, on top of the bias
    ratio = np.abs(tau) / eff
    assert ratio.max() <= 1.0 + 1e-12 and int(np.argmax(np.abs(st.jacobian[BETA]) / (eff - np.abs(g)))) == cap["joint"]
    assert cap["ellipsoid"] > 0
    with pytest.raises(InvalidInputError, match="bias exceeds"):
        squeeze_capacity(task, q, eff, bias=2 * eff)


def test_compiled_and_vm_agree():
    system = cartesian_points(3)
    P = UNEVEN
    F, T = RNG.normal(size=(3, 3)), RNG.normal(size=(3, 3))
    a = WrenchMap(cg.cooperative_task(system, "circle", codegen=False))(P, F, T)
    b = WrenchMap(cg.cooperative_task(system, "circle", codegen=True))(P, F, T)
    for name in ("wrench", "external", "force", "torque", "internal_forces", "direction"):
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), atol=1e-12, err_msg=name)
    assert a.squeeze == pytest.approx(b.squeeze, abs=1e-12)
