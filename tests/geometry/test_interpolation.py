"""Screw exp/log and interpolation of motors and similarities (seed 001), against Pinocchio."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import coop_ga as cg
from coop_ga.geometry.groups import motor_rotor_translation, rotor_matrix, tangent_to_bivector
from coop_ga.geometry.interpolation import interpolate, reference_trajectory, screw_axis, screw_exp, screw_log
from coop_ga.kinematics import LOCAL_TO_TANGENT, motor_from_se3

MOTOR = [0, 1, 2, 4, 5, 6]
# rotation angle |θ| < 3 (the log is shortest: < π); translations / log-scales moderate
motor_tangents = arrays(np.float64, 6, elements=st.floats(-1.7, 1.7, allow_nan=False))
sim_tangents = arrays(np.float64, 7, elements=st.floats(-1.7, 1.7, allow_nan=False))


def to_se3(M: cg.VersorGroup) -> pin.SE3:
    """Our motor M = T(t) R (body → world, like ``oMf``) as a pinocchio.SE3(R, t)."""
    R, t = motor_rotor_translation(M.versor)
    return pin.SE3(np.array(rotor_matrix(R), float), np.array(t, float))


def affine(S: cg.VersorGroup) -> np.ndarray:
    """4×4 matrix of x ↦ s R x + t of a similarity (scale, rotation, translation)."""
    S = S.as_similarity()
    A = np.eye(4)
    A[:3, :3] = S.scale * S.rotation_matrix
    A[:3, 3] = S.translation
    return A


def same_element(A: cg.VersorGroup, B: cg.VersorGroup, atol: float) -> None:
    """Equal up to the double cover (V and −V)."""
    a, b = A.coeffs, B.coeffs
    assert min(np.abs(a - b).max(), np.abs(a + b).max()) < atol, (a, b)


def series_exp(Bv: cg.Multivector, n: int = 40) -> cg.Multivector:
    """exp(X) by its power series in the geometric product."""
    term = cg.Multivector.scalar(1.0)
    out = term
    for k in range(1, n):
        term = (term * Bv).scale(1.0 / k)
        out = out + term
    return out


def random_se3(rng: np.random.Generator, max_angle: float = 3.0) -> pin.SE3:
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    ang = rng.uniform(0.0, max_angle)
    return pin.SE3(pin.exp3(ang * axis), rng.uniform(-1.0, 1.0, 3))


# ---------------------------------------------------------------------- vs Pinocchio
def test_motor_interpolation_equals_pinocchio_se3_interpolate():
    rng = np.random.default_rng(7)
    worst = worst_log = 0.0
    for _ in range(200):
        A, Bp = random_se3(rng), random_se3(rng)
        t = rng.uniform(-0.5, 1.5)
        # relative rotation angle below 3 rad (Pinocchio's log3 loses digits near π, see below)
        if np.linalg.norm(pin.log3(A.rotation.T @ Bp.rotation)) > 3.0:
            continue
        M0, M1 = cg.Motor(motor_from_se3(A)), cg.Motor(motor_from_se3(Bp))
        Mt = interpolate(M0, M1, t)
        assert isinstance(Mt, cg.Motor)
        ref = pin.SE3.Interpolate(A, Bp, t)
        worst = max(worst, np.abs(to_se3(Mt).homogeneous - ref.homogeneous).max())
        worst_log = max(worst_log, np.abs(screw_log(M1)[MOTOR] - LOCAL_TO_TANGENT[MOTOR] @ pin.log6(Bp).vector).max())
    assert worst < 1e-12 and worst_log < 1e-12, (worst, worst_log)  # measured 4.0e-15, 1.2e-14


def test_near_pi_pinocchio_loses_digits_we_do_not():
    # at 3.127 rad Pinocchio's own exp6(log6(X)) is off by ~1e-12; our exp(log(X)) by ~1e-15
    X = pin.SE3(pin.exp3(3.1273 * np.array([0.6, 0.0, 0.8])), np.array([0.3, -0.2, 0.5]))
    M = cg.Motor(motor_from_se3(X))
    ours = np.abs(to_se3(screw_exp(screw_log(M)[MOTOR])).homogeneous - X.homogeneous).max()
    assert ours < 2e-15
    np.testing.assert_allclose(screw_log(M)[MOTOR], LOCAL_TO_TANGENT[MOTOR] @ pin.log6(X).vector, atol=1e-10)


def test_decoupled_slerp_lerp_is_a_different_path():
    """M0 = identity, M1 = 90° about +z followed by 1 m along +x: at t = ½ the screw path is on
    the arc about the axis through (0.5, 0.5, 0): position (0.5, −0.2071, 0); the chart
    (lerp + slerp) passes through (0.5, 0, 0): 0.2071 m apart, and Pinocchio agrees with the screw."""
    A = pin.SE3.Identity()
    Bp = pin.SE3(pin.utils.rotate("z", np.pi / 2), np.array([1.0, 0.0, 0.0]))
    M0, M1 = cg.Motor(motor_from_se3(A)), cg.Motor(motor_from_se3(Bp))
    screw = to_se3(interpolate(M0, M1, 0.5))
    chart = to_se3(interpolate(M0, M1, 0.5, path="chart"))
    ref = pin.SE3.Interpolate(A, Bp, 0.5)
    np.testing.assert_allclose(screw.homogeneous, ref.homogeneous, atol=1e-15)
    np.testing.assert_allclose(screw.translation, [0.5, 0.5 - 0.5 * math.sqrt(2.0), 0.0], atol=1e-15)
    np.testing.assert_allclose(chart.translation, [0.5, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(chart.rotation, ref.rotation, atol=1e-15)  # same slerp of the rotation
    gap = float(np.linalg.norm(chart.translation - ref.translation))
    assert abs(gap - (math.sqrt(2.0) - 1.0) / 2.0) < 1e-15  # 0.20711 m
    # ... and over 50 random pairs the decoupled midpoint is off Pinocchio's by decimetres
    rng = np.random.default_rng(3)
    gaps = []
    for _ in range(50):
        A, Bp = random_se3(rng), random_se3(rng)
        M0, M1 = cg.Motor(motor_from_se3(A)), cg.Motor(motor_from_se3(Bp))
        c = to_se3(interpolate(M0, M1, 0.5, path="chart"))
        gaps.append(np.linalg.norm(c.translation - pin.SE3.Interpolate(A, Bp, 0.5).translation))
    assert max(gaps) > 0.5 and np.median(gaps) > 0.1, (max(gaps), np.median(gaps))  # measured 0.82, 0.25 m


def test_screw_exp_is_the_true_bivector_exponential():
    rng = np.random.default_rng(11)
    for _ in range(10):
        b = rng.uniform(-1.5, 1.5, 7)
        Ex = series_exp(tangent_to_bivector(b).scale(-0.5))
        S = screw_exp(b)
        np.testing.assert_allclose(Ex.to_dense(), S.versor.to_dense(), atol=1e-13)
        bm = b[MOTOR]
        M = screw_exp(bm)
        assert isinstance(M, cg.Motor)
        b7 = b.copy()
        b7[3] = 0.0
        Ex = series_exp(tangent_to_bivector(b7).scale(-0.5))
        np.testing.assert_allclose(Ex.to_dense(), M.versor.to_dense(), atol=1e-13)


# ---------------------------------------------------------------------- special cases
def test_pure_translation_small_angles_and_near_pi():
    T = cg.Motor.exp([0.0, 0.0, 0.0, 0.3, -0.4, 1.2])
    np.testing.assert_allclose(screw_log(T), [0, 0, 0, 0, 0.3, -0.4, 1.2], atol=1e-16)
    mid = to_se3(interpolate(cg.Motor.identity(), T, 0.25))
    np.testing.assert_allclose(mid.translation, [0.075, -0.1, 0.3], atol=1e-16)
    ax = screw_axis(T)
    assert ax["point"] is None and ax["pitch"] == math.inf and abs(ax["translation"] - 1.3) < 1e-15
    # θ ~ 1e-9 .. 0.1 across the series switch: log∘exp exact to 1e-15 relative
    for ang in (1e-12, 1e-9, 1e-4, 0.0999999, 0.1000001, 0.5):
        b = np.array([ang * 0.6, 0.0, ang * 0.8, 0.2, 0.1, -0.3])
        np.testing.assert_allclose(screw_log(screw_exp(b))[MOTOR], b, rtol=1e-14, atol=1e-16)
    # close to π from below: still the same tangent; beyond π the shortest (other) rotation
    for ang in (math.pi - 1e-6, math.pi - 1e-9):
        b = np.array([ang, 0.0, 0.0, 0.5, 0.2, -0.1])
        np.testing.assert_allclose(screw_log(screw_exp(b))[MOTOR], b, atol=1e-8)
    b = np.array([1.5 * math.pi, 0.0, 0.0, 0.0, 0.0, 0.0])  # 270° about z is −90° about z
    np.testing.assert_allclose(screw_log(screw_exp(b))[MOTOR], [-0.5 * math.pi, 0, 0, 0, 0, 0], atol=1e-15)


def test_double_cover_shortest_path():
    M0 = cg.Motor.exp([0.2, -0.1, 0.4, 0.1, 0.2, 0.3])
    M1 = cg.Motor.exp([2.5, 0.9, -0.3, -0.5, 0.7, 0.1])
    M1neg = cg.Motor(M1.versor.scale(-1.0), check=False)
    for t in (0.0, 0.3, 0.7, 1.0):
        same_element(interpolate(M0, M1, t), interpolate(M0, M1neg, t), 1e-14)
    same_element(interpolate(M0, M1, 1.0), M1, 1e-14)
    # the relative rotation of 270° about z is interpolated as −90°: at t = ½ it is −45°
    R = cg.Motor.exp([1.5 * math.pi, 0, 0, 0, 0, 0])
    mid = interpolate(cg.Motor.identity(), R, 0.5)
    np.testing.assert_allclose(mid.log(), [-0.25 * math.pi, 0, 0, 0, 0, 0], atol=1e-15)


def test_screw_axis_of_a_rotation_about_an_offset_axis():
    # 90° about +z through (0.5, 0.5, 0) with 0.2 m along +z
    c = np.array([0.5, 0.5, 0.0])
    Rz = pin.utils.rotate("z", np.pi / 2)
    X = pin.SE3(Rz, c - Rz @ c + np.array([0.0, 0.0, 0.2]))
    ax = screw_axis(cg.Motor(motor_from_se3(X)))
    assert abs(ax["angle"] - np.pi / 2) < 1e-15 and abs(ax["translation"] - 0.2) < 1e-15
    np.testing.assert_allclose(ax["direction"], [0, 0, 1], atol=1e-15)
    np.testing.assert_allclose(ax["point"], c, atol=1e-15)


def test_bad_input():
    M = cg.Motor.identity()
    for bad in (float("nan"), [[0.1]], "a", None, True):
        with pytest.raises(cg.CoopGAError):
            interpolate(M, M, bad)
    with pytest.raises(cg.CoopGAError):
        interpolate(M, np.zeros(8), 0.5)
    with pytest.raises(cg.CoopGAError):
        interpolate(M, M, 0.5, path="slerp")
    with pytest.raises(cg.CoopGAError):
        screw_exp(np.zeros(5))
    with pytest.raises(cg.CoopGAError):
        screw_axis(cg.Similarity.from_parts(scale=2.0))


# ---------------------------------------------------------------------- group properties
@given(b0=motor_tangents, b1=motor_tangents, s=st.floats(-1.0, 2.0), u=st.floats(-1.0, 2.0))
def test_motor_path_properties(b0, b1, s, u):
    M0, M1 = cg.Motor.exp(b0), cg.Motor.exp(b1)
    # exp∘log and log∘exp (|θ| < π)
    same_element(screw_exp(screw_log(M1)[MOTOR]), M1, 1e-13)
    if np.linalg.norm(b1[:3]) < 3.0:
        np.testing.assert_allclose(screw_log(screw_exp(b1))[MOTOR], b1, atol=1e-12)
    # endpoints
    same_element(interpolate(M0, M1, 0.0), M0, 1e-14)
    same_element(interpolate(M0, M1, 1.0), M1, 1e-13)
    # one-parameter subgroup: (M̃0 M(s)) (M̃0 M(u)) = M̃0 M(s + u)
    Ms, Mu, Msu = interpolate(M0, M1, [s, u, s + u])
    same_element((M0.inverse() @ Ms) @ (M0.inverse() @ Mu), M0.inverse() @ Msu, 1e-12)
    # constant screw velocity: log(M̃(s) M(s + h)) = h log(M̃0 M1) for every s
    h = 0.05
    b = screw_log(M0.inverse() @ M1)
    np.testing.assert_allclose(screw_log(Ms.inverse() @ interpolate(M0, M1, s + h)), h * b, atol=1e-12)


@given(b0=sim_tangents, b1=sim_tangents, s=st.floats(-1.0, 2.0), u=st.floats(-1.0, 2.0))
def test_similarity_path_properties(b0, b1, s, u):
    S0, S1 = cg.Similarity.exp(b0), cg.Similarity.exp(b1)
    same_element(screw_exp(screw_log(S1)), S1, 1e-12)
    if np.linalg.norm(b1[:3]) < 3.0:
        np.testing.assert_allclose(screw_log(screw_exp(b1)), b1, atol=1e-11)
    same_element(interpolate(S0, S1, 0.0), S0, 1e-13)
    same_element(interpolate(S0, S1, 1.0), S1, 1e-12)
    Ss, Su, Ssu = interpolate(S0, S1, [s, u, s + u])
    assert all(isinstance(x, cg.Similarity) for x in (Ss, Su, Ssu))
    same_element((S0.inverse() @ Ss) @ (S0.inverse() @ Su), S0.inverse() @ Ssu, 1e-11)
    h = 0.05
    b = screw_log(S0.inverse() @ S1)
    np.testing.assert_allclose(screw_log(Ss.inverse() @ interpolate(S0, S1, s + h)), h * b, atol=1e-11)
    # the scale is geometric: s(t) = s0^(1−t) s1^t
    assert abs(math.log(Ss.scale) - ((1 - s) * math.log(S0.scale) + s * math.log(S1.scale))) < 1e-11


def test_similarity_with_unit_scale_is_the_motor_screw():
    b0 = np.array([0.3, -0.2, 0.5, 0.0, 0.1, 0.2, -0.3])
    b1 = np.array([-1.1, 0.4, 0.9, 0.0, 0.8, -0.2, 0.5])
    S = interpolate(cg.Similarity.exp(b0), cg.Similarity.exp(b1), 0.37)
    M = interpolate(cg.Motor.exp(b0[MOTOR]), cg.Motor.exp(b1[MOTOR]), 0.37)
    np.testing.assert_allclose(affine(S), affine(M), atol=1e-14)
    # and a tiny scale (β = 1e-9, W by expm) is continuous with it
    b1[3] = 1e-9
    S = interpolate(cg.Similarity.exp(b0), cg.Similarity.exp(b1), 0.37)
    np.testing.assert_allclose(affine(S), affine(M), atol=1e-9)


def test_spiral_similarity_fixed_point_and_growing_sphere():
    """Sphere of radius 0.1 at (0.2, 0, 0.5) → radius 0.3 at (0.9, 0.4, 0.6), turned 60° about z.
    The path: radius geometric (0.1·3^t), a sphere all along, and the relative similarity fixes
    c = −(βI + [ω]×)⁻¹ v: its one-parameter subgroup maps c to itself for every t."""
    S0 = cg.Similarity.from_parts([0.2, 0.0, 0.5], scale=0.1)
    S1 = cg.Similarity.from_parts([0.9, 0.4, 0.6], axis=[0, 0, 1], angle=np.pi / 3, scale=0.3)
    unit = cg.sphere([1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, 0, 1])
    ts = np.linspace(0.0, 1.0, 11)
    path = interpolate(S0, S1, ts)
    assert isinstance(path, list) and len(path) == 11
    radii = [float(cg.radius(V.apply(unit))) for V in path]
    np.testing.assert_allclose(radii, 0.1 * 3.0**ts, rtol=1e-12)
    for V in path:
        assert cg.kind_of(V.apply(unit)) == "sphere"
    np.testing.assert_allclose(cg.center(path[-1].apply(unit)), [0.9, 0.4, 0.6], atol=1e-14)
    b = screw_log(S0.inverse() @ S1)
    w = np.array([b[2], -b[1], b[0]])
    K = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    c = -np.linalg.solve(b[3] * np.eye(3) + K, b[4:7])
    for t in (0.25, 0.5, 0.9):
        A = affine(screw_exp(t * b))
        np.testing.assert_allclose(A[:3, :3] @ c + A[:3, 3], c, atol=1e-14)
    # the decoupled chart path is a different curve for the centre (same radii)
    chart = interpolate(S0, S1, 0.5, path="chart")
    gap = float(np.linalg.norm(cg.center(chart.apply(unit)) - cg.center(path[5].apply(unit))))
    assert gap > 0.05, gap
    assert abs(float(cg.radius(chart.apply(unit))) - radii[5]) < 1e-12


def test_circle_interpolation_grows_while_it_moves():
    C0 = cg.circle([0.5, 0, 0.3], [0.4, 0.1, 0.3], [0.3, 0, 0.3])  # r = 0.1 in z = 0.3
    C1 = cg.circle([0.2, 0.5, 0.7], [0.2, 0.3, 0.9], [0.2, 0.1, 0.7])  # r = 0.2, tilted
    S0, S1 = cg.Similarity.from_unit(C0), cg.Similarity.from_unit(C1)
    unit = cg.unit_primitive("circle")
    path = interpolate(S0, S1, np.linspace(0, 1, 5))
    r = [float(cg.radius(V.apply(unit))) for V in path]
    np.testing.assert_allclose(r, 0.1 * 2.0 ** np.linspace(0, 1, 5), rtol=1e-12)
    np.testing.assert_allclose(cg.center(path[-1].apply(unit)), cg.center(C1), atol=1e-13)
    np.testing.assert_allclose(cg.normal(path[-1].apply(unit)), cg.normal(C1), atol=1e-13)
    assert all(cg.kind_of(V.apply(unit)) == "circle" for V in path)


@pytest.mark.parametrize("profile", ["minimum_jerk", "linear"])
def test_reference_trajectory_twists_are_the_path_velocity(profile):
    S0 = cg.Similarity.from_parts([0.1, 0.0, 0.4], axis=[1, 0, 0], angle=0.2, scale=0.15)
    S1 = cg.Similarity.from_parts([0.5, 0.3, 0.6], axis=[0, 0, 1], angle=1.0, scale=0.25)
    t, poses, twists = reference_trajectory(S0, S1, 2.0, 41, profile=profile)
    assert t.shape == (41,) and len(poses) == 41 and twists.shape == (41, 7)
    same_element(poses[0], S0, 1e-13)
    same_element(poses[-1], S1, 1e-12)

    def scaling(time: float) -> float:
        tau = time / 2.0
        return tau**3 * (10 - 15 * tau + 6 * tau * tau) if profile == "minimum_jerk" else tau

    h = 1e-5
    for k in (5, 20, 33):  # body velocity −2 Ṽ V̇ by central differences in time of the path itself
        Vm, Vp = interpolate(S0, S1, [scaling(t[k] - h), scaling(t[k] + h)])
        np.testing.assert_allclose(screw_log(Vm.inverse() @ Vp) / (2 * h), twists[k], atol=1e-8)
    if profile == "minimum_jerk":
        np.testing.assert_allclose(twists[[0, -1]], 0.0, atol=1e-15)
    with pytest.raises(cg.CoopGAError):
        reference_trajectory(S0, S1, 0.0, 10)
    with pytest.raises(cg.CoopGAError):
        reference_trajectory(S0, S1, 1.0, 1)
