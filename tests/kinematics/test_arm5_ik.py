"""Geometric CGA IK of the 5-DOF arm (seed 002 §V; coop_ga/kinematics/arm5_ik.py), validated with Pinocchio
on coop_ga/systems/robots/arm5/arm5.urdf.

Seed typos recorded here and in the module docstring (each asserted below): Eq 19's l3 = p2∧p1∧e∞ (is l2
reversed: θ5 would always be π), θ3 uses l3 instead of l2, π3 is undefined (the plane l2*∧p_t), Step 2's
s1 is centred at e0 instead of p0, Step 3's π0 = e2 − h e∞ is the plane at −h, §III-A's e0 = ½(e4 − e5)
gives e∞·e0 = +1, and the Step 5 cosines carry no signs.  Step 1's odd-looking π_jld* = j_z*∧(l_d* E) is right.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import coop_ga.systems
from coop_ga.algebra.multivector import Multivector
from coop_ga.errors import CoopGAError, DegeneratePrimitiveError, InvalidInputError, UnreachableError
from coop_ga.geometry.primitives import plane, point
from coop_ga.kinematics.arm5_ik import (
    ARM5,
    ARM5_END_FRAME,
    Arm5Geometry,
    Arm5UnreachableError,
    arm5_fk_points,
    arm5_ik,
    line_cosine,
    pair_points,
)

URDF = coop_ga.systems.ROBOTS_DIR / "arm5" / "arm5.urdf"


def load_arm5() -> coop_ga.systems.System:
    """The arm as a coop_ga System (not registered in the library: another engineer owns it)."""
    return coop_ga.systems.from_urdf(URDF, [ARM5_END_FRAME], name="arm5")


@pytest.fixture(scope="module")
def arm():
    sys_ = load_arm5()
    m = sys_.model
    d = m.createData()
    fid = m.getFrameId(ARM5_END_FRAME)

    def fk(q):
        pin.framesForwardKinematics(m, d, np.asarray(q, dtype=float))
        M = d.oMf[fid]
        return M.translation.copy(), M.rotation[:, 2].copy()

    return sys_, fk


def test_urdf_matches_geometry(arm):
    sys_, fk = arm
    assert sys_.nq == 5 and sys_.joint_names == ["joint1", "joint2", "joint3", "joint4", "joint5"]
    np.testing.assert_allclose(sys_.q_lower, ARM5.lower)
    np.testing.assert_allclose(sys_.q_upper, ARM5.upper)
    p, a = fk(np.zeros(5))  # straight up
    np.testing.assert_allclose(p, [ARM5.a, 0, ARM5.h + ARM5.d1 + ARM5.d2 + ARM5.d3], atol=1e-15)
    rng = np.random.default_rng(2)
    for _ in range(50):  # the closed-form points equal Pinocchio's tool frame
        q = rng.uniform(sys_.q_lower, sys_.q_upper)
        P = arm5_fk_points(q)
        p, a = fk(q)
        np.testing.assert_allclose(P["pt"], p, atol=1e-14)
        np.testing.assert_allclose(P["approach"], a, atol=1e-14)


def test_random_reachable_targets(arm):
    """600 seeded targets from random in-limit configurations, the plane a random one containing the gripper:
    Pinocchio FK of the IK result puts the tool point on the target (< 1e-10 m) with the gripper parallel to
    the plane (|n·approach| < 1e-10), inside the joint limits.  Measured: all 600 solved; 501 (83.5 %) with the
    seed's Step 1 wrist position, the rest after rotating p2 about the circle axis (Eq 30–31)."""
    sys_, fk = arm
    rng = np.random.default_rng(0)
    n_seed, worst_p, worst_par = 0, 0.0, 0.0
    for _ in range(600):
        q = rng.uniform(sys_.q_lower, sys_.q_upper)
        p, a = fk(q)
        v = rng.normal(size=3)
        n = v - (v @ a) * a
        n /= np.linalg.norm(n)
        r = arm5_ik(p, n)
        p_ik, a_ik = fk(r.q)
        worst_p = max(worst_p, float(np.linalg.norm(p_ik - p)))
        worst_par = max(worst_par, abs(float(a_ik @ n)))
        assert np.all(r.q >= sys_.q_lower) and np.all(r.q <= sys_.q_upper)
        np.testing.assert_allclose(r.pt, p)
        np.testing.assert_allclose(fk(r.q)[0] - (r.p2 + ARM5.d3 * a_ik), 0.0, atol=1e-12)  # p2 is the wrist
        n_seed += r.p2_angle == 0.0
    assert worst_p < 1e-10 and worst_par < 1e-10
    assert n_seed == 501


def test_plane_given_as_cga_plane(arm):
    _, fk = arm
    pt = np.array([0.25, 0.1, 0.3])
    P = plane([0, 0, 1.0], [1, 0, 1.2], [0, 1, 1.0])  # normal ∝ (−0.2, 0, 1) (any point, only its direction)
    r = arm5_ik(pt, P)
    p, a = fk(r.q)
    n = np.array([-0.2, 0, 1.0]) / np.linalg.norm([-0.2, 0, 1.0])
    assert np.linalg.norm(p - pt) < 1e-12 and abs(a @ n) < 1e-12
    assert r.p2_angle == 0.0  # the seed's Step 1 choice works here
    # the seed's p2: on the plane through the circle axis and the radial direction, nearer the base
    d = np.array([pt[0], pt[1], 0.0])
    dd = d - (d @ n) * n
    np.testing.assert_allclose(r.p2, pt - ARM5.d3 * dd / np.linalg.norm(dd), atol=1e-12)


def test_step5_cosines_are_unsigned(arm):
    """The seed's Step 5 cosines (with l3 and θ3 corrected) equal cos q for θ2, θ3, θ5 and |cos q| for θ1, θ4
    (planes are unoriented there): the signs must come from elsewhere."""
    rng = np.random.default_rng(4)
    sys_, fk = arm
    neg = 0
    for _ in range(40):
        q = rng.uniform(sys_.q_lower, sys_.q_upper)
        p, a = fk(q)
        n = np.cross(a, rng.normal(size=3))
        r = arm5_ik(p, n)
        c = np.cos(r.q)
        np.testing.assert_allclose(r.cosines[[1, 2, 4]], c[[1, 2, 4]], atol=1e-10)
        np.testing.assert_allclose(np.abs(r.cosines[[0, 3]]), np.abs(c[[0, 3]]), atol=1e-10)
        neg += int(np.sum(r.q[[1, 2, 4]] < 0))
    assert neg > 10  # many negative angles whose cosines are the same as the positive ones


# ---------------------------------------------------------------------- unreachable targets
def test_unreachable_reports_by_how_much():
    """Straight out at shoulder height with a horizontal plane: the wrist centre is 5 cm beyond d1 + d2."""
    g = ARM5
    pt = np.array([g.a + g.d1 + g.d2 + g.d3 + 0.05, 0.0, g.h])
    with pytest.raises(Arm5UnreachableError) as ei:
        arm5_ik(pt, [0, 0, 1])
    e = ei.value
    assert isinstance(e, UnreachableError) and isinstance(e, CoopGAError)
    assert e.distance == pytest.approx(0.05, abs=1e-9) and e.violation == 0.0
    assert "50 mm" in str(e)
    # too close, for an arm with d1 = 0.3, d2 = 0.1 (inner radius 0.2 m): the wrist centre 5 cm in front of
    # the shoulder is 15 cm inside the hole, and with the base turned by π (shoulder at −a) 0.05 + 2a = 0.13 m
    # from it, 7 cm inside: the smaller is reported
    g2 = Arm5Geometry(d1=0.3, d2=0.1)
    pt2 = np.array([g2.a + 0.05 + g2.d3, 0.0, g2.h])
    with pytest.raises(Arm5UnreachableError) as ei2:
        arm5_ik(pt2, [0, 0, 1], g2, search=0)
    assert ei2.value.distance == pytest.approx(0.07, abs=1e-9)


def test_joint_limit_failure_reports_violation():
    tight = Arm5Geometry(lower=(-0.1, -0.1, -0.1, -0.1, -0.1), upper=(0.1, 0.1, 0.1, 0.1, 0.1))
    with pytest.raises(Arm5UnreachableError) as ei:
        arm5_ik([0.3, 0.2, 0.2], [0, 0, 1], tight)
    assert ei.value.violation > 0.0 and ei.value.distance == 0.0 and "joint limits" in str(ei.value)
    # without the limit check the same target is solved
    r = arm5_ik([0.3, 0.2, 0.2], [0, 0, 1], tight, limits=False)
    assert np.linalg.norm(arm5_fk_points(r.q)["pt"] - [0.3, 0.2, 0.2]) < 1e-12


def test_bad_input():
    with pytest.raises(InvalidInputError):
        arm5_ik([0.3, 0.0], [0, 0, 1])
    with pytest.raises(InvalidInputError):
        arm5_ik([0.3, 0.0, 0.2], [0, 0, 0])
    with pytest.raises(InvalidInputError):
        arm5_ik([0.3, 0.0, 0.2], [0, 0, 1], elbow="sideways")
    with pytest.raises(DegeneratePrimitiveError):  # on the base axis with a horizontal plane: Step 1 undefined
        arm5_ik([0.0, 0.0, 0.4], [0, 0, 1])
    with pytest.raises(DegeneratePrimitiveError):
        pair_points((point([0, 0, 0]) - Multivector.blade("einf").scale(0.02)) ^ Multivector.blade("e3"))


# ---------------------------------------------------------------------- the seed's typos, by computation
def test_seed_typo_eq19_l3_is_l2_reversed():
    P = arm5_fk_points([0.3, 0.4, 0.8, 0.5, 0.7])
    einf = Multivector.blade("einf")
    l2 = point(P["p1"]) ^ point(P["p2"]) ^ einf
    l3_printed = point(P["p2"]) ^ point(P["p1"]) ^ einf
    assert line_cosine(l3_printed, l2) == pytest.approx(-1.0)  # θ5 = π whatever the arm does
    l3 = point(P["p2"]) ^ point(P["pt"]) ^ einf
    assert line_cosine(l3, l2) == pytest.approx(np.cos(0.7))


def test_seed_typo_s1_centre_and_pi0_sign():
    g = ARM5
    einf = Multivector.blade("einf")
    # π0 = e2 − h e∞ (our e3) contains the points at height −h, not +h
    pi0_printed = Multivector.blade("e3") - einf.scale(g.h)
    assert float((point([0.1, 0.2, -g.h]) | pi0_printed).get(0)) == pytest.approx(0.0, abs=1e-15)
    assert float((point([0.1, 0.2, g.h]) | pi0_printed).get(0)) == pytest.approx(2 * g.h)
    # s1 = e0 − ½d1² e∞: the elbow of a real configuration is not on it, but on the sphere about p0
    P = arm5_fk_points([0.3, 0.4, 0.8, 0.5, 0.7])
    s1_printed = Multivector.blade("e0") - einf.scale(0.5 * g.d1**2)
    s1 = point(P["p0"]) - einf.scale(0.5 * g.d1**2)
    assert abs(float((point(P["p1"]) | s1_printed).get(0))) > 1e-3
    assert float((point(P["p1"]) | s1).get(0)) == pytest.approx(0.0, abs=1e-15)


def test_seed_typo_section3_e0_sign():
    """§III-A: with e∞ = e4 + e5, e0 = ½(e4 − e5) (e4² = 1, e5² = −1) one gets e∞·e0 = +1 and
    x_c·y_c = x·y + ½(x² + y²) ≠ −½|x − y|²; with e0 = ½(e5 − e4): e∞·e0 = −1 and the stated formulas hold."""
    G = np.diag([1.0, 1.0, 1.0, 1.0, -1.0])
    e4, e5 = np.eye(5)[3], np.eye(5)[4]
    einf = e4 + e5

    def ip(u, v):
        return float(u @ G @ v)

    for e0, sign in ((0.5 * (e4 - e5), +1.0), (0.5 * (e5 - e4), -1.0)):
        assert ip(einf, e0) == pytest.approx(sign)
        x, y = np.array([0.3, -0.2, 0.5]), np.array([-0.1, 0.4, 0.2])

        def up(v, e0=e0):
            return np.concatenate([v, [0.0, 0.0]]) + 0.5 * (v @ v) * einf + e0

        ok = ip(up(x), up(y)) == pytest.approx(-0.5 * np.sum((x - y) ** 2)) and ip(up(x), einf) == pytest.approx(-1)
        assert ok == (sign < 0)


def test_eq30_31_rotor_keeps_p2_on_the_circle(arm):
    """Rotating the wrist centre about the circle axis (Eq 30–31) keeps it at d3 from the target and in π_t."""
    pt, n = np.array([0.25, -0.15, 0.25]), np.array([0.3, 0.2, 1.0]) / np.linalg.norm([0.3, 0.2, 1.0])
    for th in (0.4, 1.5, -2.0):
        r = arm5_ik(pt, n, p2_angle=th, search=0)
        assert r.p2_angle == th
        assert np.linalg.norm(r.p2 - pt) == pytest.approx(ARM5.d3, abs=1e-12)
        assert abs((r.p2 - pt) @ n) < 1e-12
        assert np.linalg.norm(arm5_fk_points(r.q)["pt"] - pt) < 1e-12
    base = arm5_ik(pt, n, search=0).p2
    u, v = base - pt, arm5_ik(pt, n, p2_angle=0.4, search=0).p2 - pt
    assert np.arccos(np.clip(u @ v / ARM5.d3**2, -1, 1)) == pytest.approx(0.4, abs=1e-12)


def test_seed_step1_plane_formula_is_right():
    """π_jld* = j_z* ∧ (l_d* E): l_d* E has grades 1 and 3, and the wedge is the plane j_z* ∧ d (no typo)."""
    from coop_ga.geometry.primitives import kind_of, normal

    einf, e0 = Multivector.blade("einf"), Multivector.blade("e0")
    E = einf ^ e0
    rng = np.random.default_rng(9)
    for _ in range(5):
        p, n = rng.normal(size=3), rng.normal(size=3)
        d = Multivector.from_names({"e1": p[0], "e2": p[1]})
        l_d = d ^ point(p) ^ einf
        assert (l_d * E).prune(1e-12).grades == (1, 3)
        j_z = point(p) ^ point(p + n) ^ einf
        A, B = j_z ^ (l_d * E), j_z ^ d
        assert kind_of(A) == "plane" == kind_of(B)
        assert abs(float(np.asarray(normal(A)) @ np.asarray(normal(B)))) == pytest.approx(1.0, abs=1e-12)
