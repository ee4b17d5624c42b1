"""coop_ga.legged.legs: leg FK (closed form and the seed's motor product), Jacobians, both IK routes.

References are independent of the code under test: Pinocchio (``oMi``/``oMf`` and frame Jacobians of the
registered ``hexapod`` system, feet matched by frame name, never by position), central differences,
and reach distances computed from Pinocchio's joint origins.

Branch classification (``LegModel.branch_of``): with ψ_3 the knee angle of the leg plane (= the tibia
angle for this robot), ``knee_up`` ⇔ ψ_3 ≤ 0 (tibia folded down, the standing branch) and ``knee_down``
⇔ ψ_3 > 0 (tibia ∈ (0, 25.5°]).  IK∘FK recovers every configuration on its own branch.

Tolerances: angles 1e-8 rad after IK∘FK (the straight knee ψ_3 → 0 amplifies round-off by
~ε/ψ_3; the worst of 12 000 sampled legs is ~1e-12), feet 1e-12 m, Jacobians 1e-12 against Pinocchio
and 1e-8 against central differences (h = 1e-6).  DLS vs closed form: 1e-10 m in the feet and 1e-7 rad
in the angles on configurations with σ_min(J) ≥ 0.01 m/rad (away from the straight knee and from the
foot on the coxa axis, the two singularities, where both routes are ill-conditioned).
"""

from __future__ import annotations

import importlib
import json
import math
import re
import sys
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from coop_ga import systems
from coop_ga.errors import CoopGAError, InvalidInputError, NonFiniteError, UnknownNameError, UnreachableError
from coop_ga.geometry.groups import motor_rotor_translation, rotor_matrix
from coop_ga.legged.legs import BRANCHES, LEGS, DLSResult, LegModel, hexapod_legs
from tests.helpers import central_difference

N_CONFIGS = 2000  # random configurations (× 6 legs) for IK∘FK


@pytest.fixture(scope="module")
def legs() -> LegModel:
    return hexapod_legs()


@pytest.fixture(scope="module")
def pin_ref():
    s = systems.load("hexapod")
    m = s.model
    d = m.createData()
    feet = {leg: m.getFrameId(f"{leg}_foot") for leg in LEGS}
    joints = {(leg, j): m.getJointId(f"{leg}_{j}_joint") for leg in LEGS for j in ("coxa", "femur", "tibia")}
    return s, m, d, feet, joints


def _random_legs(legs: LegModel, rng: np.random.Generator, n: int) -> np.ndarray:
    """(n, 18) uniform inside the joint limits."""
    return legs.from_legs(rng.uniform(legs.q_lower, legs.q_upper, (n, legs.n_legs, 3)))


def _pin_feet(pin_ref, q: np.ndarray) -> np.ndarray:
    _, m, d, feet, _ = pin_ref
    pin.framesForwardKinematics(m, d, q)
    return np.array([d.oMf[feet[leg]].translation for leg in LEGS])


# ---------------------------------------------------------------------- geometry read from the model
def test_geometry_read_from_the_urdf_matches_the_readme(legs):
    assert legs.legs == LEGS
    np.testing.assert_allclose(legs.coxa_length, 0.052, atol=1e-12)
    np.testing.assert_allclose(legs.femur_length, 0.065, atol=1e-12)
    np.testing.assert_allclose(legs.tibia_length, 0.133, atol=1e-12)
    np.testing.assert_allclose(np.degrees(legs.mount_yaw), [45, 90, 135, -45, -90, -135], atol=1e-9)
    mounts = [(0.12, 0.06), (0.0, 0.1), (-0.12, 0.06), (0.12, -0.06), (0.0, -0.1), (-0.12, -0.06)]
    np.testing.assert_allclose(legs.mount_position[:, :2], mounts, atol=1e-12)
    np.testing.assert_allclose(legs.q_lower, np.tile([-1.2217, -1.5708, -2.5307], (6, 1)), atol=1e-4)
    np.testing.assert_allclose(legs.q_upper, np.tile([1.2217, 1.5708, 0.4451], (6, 1)), atol=1e-4)
    np.testing.assert_allclose(legs.effort_limit, 1.5)
    # the 18-vector is the URDF order: leg-major, (coxa, femur, tibia)
    np.testing.assert_array_equal(legs.q_index, np.arange(18).reshape(6, 3))
    # the system's end frames are the two tripods; end_frame_index maps by name
    s = systems.load("hexapod")
    assert [s.end_frames[k] for k in legs.end_frame_index] == [f"{leg}_foot" for leg in LEGS]
    assert hexapod_legs() is legs  # cached
    with pytest.raises(ValueError):
        legs.q_lower[0, 0] = 0.0  # read-only


def test_leg_model_cache_is_bounded(monkeypatch):
    """hexapod_legs keeps the LEGS_CACHE_SIZE most recently used models: a sweep over many systems does not keep
    every system alive; a model dropped from the cache stays valid and is rebuilt on the next call."""
    import coop_ga.legged.legs as legs_mod

    monkeypatch.setattr(legs_mod, "_CACHE", legs_mod.OrderedDict())
    monkeypatch.setattr(legs_mod, "LEGS_CACHE_SIZE", 1)
    fixed, flyer = systems.load("hexapod"), systems.load("hexapod", free_flyer=True)
    a = hexapod_legs(fixed)
    assert hexapod_legs(fixed) is a and len(legs_mod._CACHE) == 1
    b = hexapod_legs(flyer)
    assert len(legs_mod._CACHE) == 1 and hexapod_legs(flyer) is b
    a2 = hexapod_legs(fixed)  # evicted by the flyer's model: rebuilt, equal
    assert a2 is not a
    np.testing.assert_array_equal(a2.q_stand, a.q_stand)


def test_stand_pose_feet_height(legs, pin_ref):
    p = legs.fk(legs.q_stand)
    np.testing.assert_allclose(p[:, 2], -(0.133 * math.sin(1.1) - 0.065 * math.sin(0.3)), atol=1e-15)
    np.testing.assert_allclose(p[:, 2], -0.0993, atol=5e-5)
    np.testing.assert_allclose(p, _pin_feet(pin_ref, legs.q_stand), atol=1e-15)


def test_free_flyer_system_gives_the_same_legs(legs):
    """The legs read from the free-flyer hexapod (nq = 25, nv = 24: its limits are in q̇ order) are the fixed
    hexapod's, limits included."""
    fl = LegModel.from_system(systems.load("hexapod", free_flyer=True))
    assert fl.legs == legs.legs
    np.testing.assert_array_equal(fl.q_index, legs.q_index)
    np.testing.assert_array_equal(fl.model_q_index, legs.model_q_index + 7)  # after position + quaternion
    names = ("mount_position", "mount_rotation", "femur_joint", "femur_link", "tibia_link")
    for a in (*names, "q_lower", "q_upper", "effort_limit", "velocity_limit"):
        np.testing.assert_allclose(getattr(fl, a), getattr(legs, a), atol=1e-15, err_msg=a)


# ---------------------------------------------------------------------- forward kinematics
def test_fk_matches_pinocchio_by_frame_name(legs, pin_ref):
    rng = np.random.default_rng(11)
    q = _random_legs(legs, rng, 300)
    p = legs.fk(q)
    assert p.shape == (300, 6, 3)
    ref = np.array([_pin_feet(pin_ref, qk) for qk in q])
    assert np.abs(p - ref).max() < 1e-14
    # outside the limits too (the closed form has no range restriction)
    qw = rng.uniform(-math.pi, math.pi, (50, 18))
    refw = np.array([_pin_feet(pin_ref, qk) for qk in qw])
    assert np.abs(legs.fk(qw) - refw).max() < 1e-14


def _motor_Rt(M):
    R, t = motor_rotor_translation(M)
    return np.array(rotor_matrix(R), dtype=float), np.array(t, dtype=float)


def test_fk_motors_are_the_joint_placements_and_give_fk(legs, pin_ref):
    _, m, d, feet, joints = pin_ref
    rng = np.random.default_rng(12)
    q = _random_legs(legs, rng, 8)
    worst_R = worst_t = worst_fk = 0.0
    for qk in q:
        pin.framesForwardKinematics(m, d, qk)
        Q = legs.per_leg(qk)
        p = legs.fk(qk)
        for i, leg in enumerate(LEGS):
            Ms = legs.fk_motors(Q[i], leg)
            assert len(Ms) == 4
            refs = [d.oMi[joints[(leg, j)]] for j in ("coxa", "femur", "tibia")] + [d.oMf[feet[leg]]]
            for M, ref in zip(Ms, refs):
                R, t = _motor_Rt(M)
                worst_R = max(worst_R, np.abs(R - ref.rotation).max())
                worst_t = max(worst_t, np.abs(t - ref.translation).max())
            # the conformal foot point M e0 M~ = x + ½x² e∞ + e0
            P = legs.foot_point(Q[i], leg)
            x = np.array([float(P[b]) for b in ("e1", "e2", "e3")])
            assert float(P["e0"]) == pytest.approx(1.0, abs=1e-14)
            assert float(P["einf"]) == pytest.approx(0.5 * x @ x, abs=1e-14)
            worst_fk = max(worst_fk, np.abs(x - p[i]).max())
        np.testing.assert_allclose(legs.fk_via_motors(qk), p, atol=1e-14)
    assert worst_R < 1e-14 and worst_t < 1e-14 and worst_fk < 1e-14
    # batch coefficients: the same motors as one configuration at a time
    Qb = legs.per_leg(q)[:, 2]  # (8, 3) of leg lr
    Mb = legs.fk_motors(Qb, "lr")[-1]
    Rb, tb = motor_rotor_translation(Mb)
    np.testing.assert_allclose(np.stack([np.asarray(c, float) for c in tb], -1), legs.fk(q)[:, 2], atol=1e-14)
    assert np.asarray(Rb[0]).shape == (8,)


# ---------------------------------------------------------------------- Jacobians
def test_jacobians_vs_central_differences_and_pinocchio(legs, pin_ref):
    _, m, d, feet, _ = pin_ref
    rng = np.random.default_rng(13)
    q = _random_legs(legs, rng, 20)
    J = legs.jacobians(q)
    assert J.shape == (20, 6, 3, 3)
    worst_fd = worst_pin = 0.0
    for k, qk in enumerate(q):
        Jfd = central_difference(lambda x: legs.fk(x).ravel(), qk).reshape(6, 3, 18)
        pin.computeJointJacobians(m, d, qk)
        pin.updateFramePlacements(m, d)
        for i, leg in enumerate(LEGS):
            cols = legs.q_index[i]
            worst_fd = max(worst_fd, np.abs(Jfd[i][:, cols] - J[k, i]).max())
            others = np.setdiff1d(np.arange(18), cols)
            assert np.abs(Jfd[i][:, others]).max() == 0.0  # a foot moves with its own leg only
            Jp = pin.getFrameJacobian(m, d, feet[leg], pin.LOCAL_WORLD_ALIGNED)[:3]
            worst_pin = max(worst_pin, np.abs(Jp[:, legs.model_q_index[i]] - J[k, i]).max())
            assert np.abs(np.delete(Jp, legs.model_q_index[i], axis=1)).max() == 0.0
    assert worst_fd < 1e-8
    assert worst_pin < 1e-12


# ---------------------------------------------------------------------- closed-form IK
def test_ik_of_fk_is_identity_on_random_configurations(legs):
    rng = np.random.default_rng(14)
    q = _random_legs(legs, rng, N_CONFIGS)
    p = legs.fk(q)
    up = legs.branch_of(q)
    assert up.shape == (N_CONFIGS, 6)
    # both branches are well represented (tibia ∈ [−145°, 25.5°]: ~15 % knee_down)
    assert 0.8 < up.mean() < 0.9
    np.testing.assert_array_equal(up, legs.per_leg(q)[..., 2] <= 0.0)
    qi = legs.ik(p, branch=up)
    assert qi.shape == q.shape
    assert np.abs(qi - q).max() < 1e-8
    np.testing.assert_array_equal(legs.branch_of(qi), up)
    assert legs.within_limits(qi).all()
    assert np.abs(legs.fk(qi) - p).max() < 1e-12
    # the same via branch names
    names = np.where(up, "knee_up", "knee_down")
    np.testing.assert_array_equal(legs.ik(p, branch=names), qi)
    # the scalar branch on the configurations that are on it
    only_up = up.all(axis=1)
    np.testing.assert_allclose(legs.ik(p[only_up], branch="knee_up"), q[only_up], atol=1e-8)


def test_fk_of_ik_on_random_reachable_targets(legs):
    rng = np.random.default_rng(15)
    # targets in a box around each leg's mount, kept where the workspace margin says reachable
    P = legs.mount_position + rng.uniform(-0.26, 0.26, (8000, 6, 3))
    ok = legs.workspace_margin(P) > 1e-6
    n = int(ok.sum(axis=0).min())
    assert n > 1000  # ~18 % of the box is reachable by each leg
    P = np.stack([P[ok[:, i], i][:n] for i in range(6)], axis=1)  # (n, 6, 3), each leg its reachable ones
    for branch in BRANCHES:
        q = legs.ik(P, branch=branch, check_limits=False)
        assert np.abs(legs.fk(q) - P).max() < 1e-12, branch
        np.testing.assert_array_equal(legs.branch_of(q), branch == "knee_up")
    # the two branches mirror the knee about the femur-joint → foot line: tibia angles ±ψ_3
    qu, qd = legs.ik(P, "knee_up", check_limits=False), legs.ik(P, "knee_down", check_limits=False)
    # (where both branches take the same coxa yaw: without limits each takes the yaw least outside them)
    Qu, Qd = legs.per_leg(qu), legs.per_leg(qd)
    same_yaw = np.abs(Qu[..., 0] - Qd[..., 0]) < 1e-12
    assert same_yaw.mean() > 0.9
    np.testing.assert_allclose(Qd[..., 2][same_yaw], -Qu[..., 2][same_yaw], atol=1e-12)
    assert np.median(np.abs(legs.per_leg(qu)[..., 2])) > 0.5  # genuinely different solutions


def _sigma_min(J: np.ndarray) -> np.ndarray:
    return np.linalg.svd(J, compute_uv=False)[..., -1]


def test_closed_form_and_dls_agree(legs):
    rng = np.random.default_rng(16)
    q = _random_legs(legs, rng, 2000)
    regular = (_sigma_min(legs.jacobians(q)) >= 0.01).all(axis=1)
    q = q[regular]
    assert len(q) > 300
    p = legs.fk(q)
    res = legs.dls_ik(p, q + rng.normal(0.0, 0.05, q.shape))
    assert isinstance(res, DLSResult)
    assert res.all_converged, res.message
    assert res.error.max() <= 1e-10
    closed = legs.ik(p, branch=legs.branch_of(q))
    assert np.abs(res.q - closed).max() < 1e-7
    assert res.within_limits.all()
    # the walking workspace: targets within ±2 cm of the stand feet, DLS from the stand pose
    P = legs.fk(legs.q_stand) + rng.uniform(-0.02, 0.02, (500, 6, 3))
    res = legs.dls_ik(P, legs.q_stand)
    assert res.all_converged, res.message
    assert res.iterations.max() <= 10
    assert np.abs(res.q - legs.ik(P)).max() < 1e-7
    # a target 5 cm beyond the straight leg: DLS never raises; its error decreases monotonically
    # toward the reach distance (−margin, a lower bound it cannot beat), slowly: the nearest point
    # is the straight-leg singularity
    far = legs.fk(legs.q_stand)
    far[0] = legs.mount_position[0] + 0.30 * legs.mount_rotation[0][:, 0]
    dist = -legs.workspace_margin(far)[0]
    assert dist == pytest.approx(0.05, abs=1e-12)
    errs = [legs.dls_ik(far, legs.q_stand, max_iter=k).error[0] for k in (10, 100, 300)]
    assert np.all(np.diff(errs) <= 0.0)
    assert 0.0 <= errs[-1] - dist < 1e-4
    res = legs.dls_ik(far, legs.q_stand, max_iter=10)
    assert not res.converged[0] and res.converged[1:].all()


# ---------------------------------------------------------------------- unreachable targets
def _femur_joint_and_axis(pin_ref, leg: str, yaw: float):
    """Pinocchio: femur joint origin and coxa axis point in B at coxa angle ``yaw`` (other joints 0)."""
    _, m, d, _, joints = pin_ref
    q = np.zeros(m.nq)
    q[m.idx_qs[joints[(leg, "coxa")]]] = yaw
    pin.forwardKinematics(m, d, q)
    c = d.oMi[joints[(leg, "femur")]].translation.copy()
    o = d.oMi[joints[(leg, "coxa")]].translation.copy()
    t = d.oMi[joints[(leg, "tibia")]].translation.copy()
    pin.framesForwardKinematics(m, d, q)
    f = d.oMf[m.getFrameId(f"{leg}_foot")].translation.copy()
    return c, o, np.linalg.norm(t - c), np.linalg.norm(f - t)


def test_unreachable_beyond_the_straight_leg_says_by_how_much(legs, pin_ref):
    rng = np.random.default_rng(17)
    for _ in range(5):
        feet = legs.fk(legs.q_stand)
        expected = {}
        for i, leg in enumerate(LEGS):
            yaw = rng.uniform(-1.0, 1.0)
            c, o, Lf, Lt = _femur_joint_and_axis(pin_ref, leg, yaw)
            out = c - o
            out[2] = 0.0
            out /= np.linalg.norm(out)  # horizontal, away from the coxa axis
            beta = rng.uniform(-1.2, 1.2)  # elevation in the leg plane
            u = math.cos(beta) * out + math.sin(beta) * np.array([0.0, 0.0, 1.0])
            d_mm = rng.uniform(0.5, 40.0)
            feet[i] = c + (Lf + Lt + 1e-3 * d_mm) * u
            expected[leg] = np.linalg.norm(feet[i] - c) - (Lf + Lt)  # closed-form reach distance [m]
        np.testing.assert_allclose(-legs.workspace_margin(feet), [expected[leg] for leg in LEGS], atol=1e-12)
        with pytest.raises(UnreachableError) as info:
            legs.ik(feet)
        e = info.value
        assert e.legs == LEGS
        assert e.distance == pytest.approx(max(expected.values()), abs=1e-12)
        msg = str(e)
        for leg in LEGS:
            found = re.search(rf"leg {leg} out of reach by ([0-9.]+) mm", msg)
            assert found, msg
            assert float(found.group(1)) == pytest.approx(1e3 * expected[leg], abs=0.01)


def test_unreachable_inside_the_folded_knee_one_leg(legs, pin_ref):
    # on the coxa axis, close to the femur joint's height: both yaws are inside the inner hole
    c, o, Lf, Lt = _femur_joint_and_axis(pin_ref, "rm", 0.0)
    z = 0.02
    feet = legs.fk(legs.q_stand)
    feet[4] = o + np.array([0.0, 0.0, z])
    expected = (Lt - Lf) - math.hypot(np.linalg.norm(c - o), z)
    assert expected > 0
    with pytest.raises(UnreachableError, match=r"leg rm out of reach by ([0-9.]+) mm") as info:
        legs.ik(feet, check_limits=False)
    assert info.value.legs == ("rm",)
    got = float(re.search(r"out of reach by ([0-9.]+) mm", str(info.value)).group(1))
    assert got == pytest.approx(1e3 * expected, abs=0.01)
    assert info.value.distance == pytest.approx(expected, abs=1e-12)
    # in a batch the message says where
    batch = np.stack([legs.fk(legs.q_stand)] * 3 + [feet])
    with pytest.raises(UnreachableError, match=r"at 1 of 4 configurations; first at batch index \(3,\)"):
        legs.ik(batch)


def test_reachable_only_outside_the_limits_names_the_joint(legs):
    # coxa: the stand pose turned to 100° (limit 70°); the other yaw (−80°, reaching back) is out of reach
    Q = legs.per_leg(legs.q_stand)
    Q[0, 0] = math.radians(100.0)
    feet = legs.fk(legs.from_legs(Q))
    with pytest.raises(UnreachableError) as info:
        legs.ik(feet)
    e = info.value
    assert e.legs == ("lf",) and e.distance == 0.0
    assert e.violation == pytest.approx(math.radians(30.0), abs=1e-9)
    assert "lf_coxa_joint = 1.7453 rad, beyond its upper limit 1.2217 rad by 0.5236 rad (30.00°)" in str(e)
    # without the check: the solution itself
    np.testing.assert_allclose(legs.per_leg(legs.ik(feet, check_limits=False))[0], Q[0], atol=1e-12)
    # tibia: a knee_down foot with the tibia at 0.8 rad (limit 0.4451); the knee_up solution is fine
    Q = legs.per_leg(legs.q_stand)
    Q[3] = (0.2, 0.3, 0.8)
    feet = legs.fk(legs.from_legs(Q))
    with pytest.raises(UnreachableError) as info:
        legs.ik(feet, branch=np.array(LEGS) != "rf")  # knee_down for rf only
    e = info.value
    assert e.legs == ("rf",)
    assert e.violation == pytest.approx(0.8 - legs.q_upper[3, 2], abs=1e-9)
    assert "rf_tibia_joint = 0.8000 rad, beyond its upper limit 0.4451 rad" in str(e)
    assert "the knee_up solution is inside the limits" in str(e)
    q_up = legs.ik(feet, branch="knee_up")
    assert legs.within_limits(q_up).all()
    np.testing.assert_allclose(legs.fk(q_up), feet, atol=1e-12)
    assert isinstance(e, CoopGAError) and isinstance(e, ValueError)


# ---------------------------------------------------------------------- shapes, limits, inputs
def test_batch_shapes(legs):
    rng = np.random.default_rng(18)
    q = _random_legs(legs, rng, 20).reshape(4, 5, 18)
    p = legs.fk(q)
    assert p.shape == (4, 5, 6, 3)
    assert legs.jacobians(q).shape == (4, 5, 6, 3, 3)
    assert legs.within_limits(q).shape == (4, 5, 6)
    assert legs.workspace_margin(p).shape == (4, 5, 6)
    assert legs.branch_of(q).shape == (4, 5, 6)
    qi = legs.ik(p, branch=legs.branch_of(q))
    assert qi.shape == (4, 5, 18)
    np.testing.assert_allclose(qi, q, atol=1e-8)
    # a (6,) branch broadcasts over the batch
    br = np.array([True, False, True, True, False, True])
    assert legs.ik(p, branch=br, check_limits=False).shape == (4, 5, 18)
    res = legs.dls_ik(p, q + 0.01)
    assert res.q.shape == (4, 5, 18)
    assert res.converged.shape == res.error.shape == res.iterations.shape == res.within_limits.shape == (4, 5, 6)
    # one configuration
    assert legs.fk(legs.q_stand).shape == (6, 3)
    assert legs.ik(legs.fk(legs.q_stand)).shape == (18,)
    assert legs.dls_ik(legs.fk(legs.q_stand), legs.q_stand).q.shape == (18,)


def test_within_limits(legs):
    q = legs.q_stand.copy()
    assert legs.within_limits(q).all()
    q[7] = legs.q_upper[2, 1] + 1e-6  # lr femur
    np.testing.assert_array_equal(legs.within_limits(q), [True, True, False, True, True, True])
    assert legs.within_limits(q, tol=2e-6).all()


def test_inputs_are_not_mutated(legs):
    rng = np.random.default_rng(19)
    q = _random_legs(legs, rng, 10)
    p = legs.fk(q)
    q_init = q + 0.01
    br = legs.branch_of(q)
    copies = [a.copy() for a in (q, p, q_init, br)]
    for a in (q, p, q_init, br):
        a.setflags(write=False)
    legs.fk(q)
    legs.jacobians(q)
    legs.within_limits(q)
    legs.workspace_margin(p)
    legs.ik(p, branch=br)
    legs.dls_ik(p, q_init)
    legs.fk_motors(legs.per_leg(q)[:, 0], "lf")
    for a, c in zip((q, p, q_init, br), copies):
        np.testing.assert_array_equal(a, c)


def test_bad_input_raises_coopga_errors(legs):
    p = legs.fk(legs.q_stand)
    with pytest.raises(InvalidInputError, match=r"q must have shape \(\.\.\., 18\)"):
        legs.fk(np.zeros(17))
    with pytest.raises(NonFiniteError):
        legs.fk(np.full(18, np.nan))
    with pytest.raises(InvalidInputError, match=r"feet must have shape \(\.\.\., 6, 3\)"):
        legs.ik(np.zeros((5, 3)))
    bad = p.copy()
    bad[2, 1] = np.nan
    with pytest.raises(NonFiniteError):
        legs.ik(bad)
    with pytest.raises(NonFiniteError):
        legs.workspace_margin(bad)
    with pytest.raises(InvalidInputError, match="branch"):
        legs.ik(p, branch="up")
    with pytest.raises(InvalidInputError, match="branch entries"):
        legs.ik(p, branch=np.array(["knee_up"] * 5 + ["elbow"]))
    with pytest.raises(InvalidInputError, match="does not broadcast"):
        legs.ik(p, branch=np.ones(5, dtype=bool))
    with pytest.raises(InvalidInputError, match="bool array"):
        legs.ik(p, branch=np.ones(6))
    with pytest.raises(InvalidInputError, match="check_limits"):
        legs.ik(p, check_limits="yes")
    with pytest.raises(InvalidInputError, match="q_init"):
        legs.dls_ik(p, np.zeros(12))
    with pytest.raises(InvalidInputError):
        legs.dls_ik(p, legs.q_stand, damping=-1.0)
    with pytest.raises(InvalidInputError):
        legs.dls_ik(p, legs.q_stand, max_iter=0)
    with pytest.raises(UnknownNameError, match="unknown leg"):
        legs.fk_motors(np.zeros(3), "lx")
    with pytest.raises(InvalidInputError, match="q_leg"):
        legs.fk_motors(np.zeros(2), "lf")
    with pytest.raises(InvalidInputError):
        legs.within_limits(legs.q_stand, tol=-1.0)
    with pytest.raises(InvalidInputError, match="System"):
        LegModel.from_system("hexapod")
    with pytest.raises(UnknownNameError, match="no joint"):
        LegModel.from_system(systems.load("allegro"))


# ---------------------------------------------------------------------- the benchmark's CI mode
def test_benchmark_ci_mode_runs_and_checks_its_routes(tmp_path):
    bench = Path(__file__).resolve().parents[2] / "benchmarks"
    if str(bench) not in sys.path:
        sys.path.insert(0, str(bench))
    mod = importlib.import_module("legged")
    assert mod.main(["--ci", "--quiet", "--out", str(tmp_path)]) == 0
    data = json.loads((tmp_path / "results.json").read_text(), parse_constant=lambda c: pytest.fail(c))
    routes = {r["route"] for r in data["rows"]}
    assert {"pinocchio FK (anchor)", "closed-form FK", "closed-form IK", "DLS IK"} <= routes
    # accuracy is checked before timing: these are numbers, not times
    assert data["check"]["fk_vs_pinocchio_m"] < 1e-14
    assert data["check"]["ik_fk_rad"] < 1e-8
    assert data["check"]["dls_vs_closed_rad"] < 1e-7


# ---------------------------------------------------------------------- optional physics check (item 8)
def _floating():
    return systems.load("hexapod", free_flyer=True)


def test_plan_to_free_flyer_q_reproduces_the_body_pose():
    """The plan's body pose (position, quaternion xyzw; a non-unit one normalised) is the free flyer's root pose
    (Pinocchio FK against scipy's rotation matrix), legs in place."""
    from scipy.spatial.transform import Rotation

    from coop_ga.legged.dynamics import plan_to_free_flyer_q

    s = _floating()
    rng = np.random.default_rng(20)
    rot = Rotation.from_euler("ZYX", rng.uniform(-1.0, 1.0, (5, 3)))
    body = np.concatenate([rng.uniform(-1, 1, (5, 3)), 1.5 * rot.as_quat()], axis=1)
    legs18 = rng.uniform(-0.5, 0.5, (5, 18))
    q25 = plan_to_free_flyer_q(legs18, body)
    assert q25.shape == (5, 25)
    np.testing.assert_array_equal(q25[:, 7:], legs18)
    d = s.model.createData()
    base = s.model.getJointId("root_joint")
    for k in range(5):
        pin.forwardKinematics(s.model, d, q25[k])
        np.testing.assert_allclose(d.oMi[base].rotation, rot[k].as_matrix(), atol=1e-14)
        np.testing.assert_allclose(d.oMi[base].translation, body[k, :3], atol=1e-15)
    with pytest.raises(InvalidInputError, match="sample 1 is zero"):
        plan_to_free_flyer_q(legs18[:2], np.vstack([body[0], np.zeros(7)]))


def _standing_plan(legs, s, T=16, duration=0.3):
    t = np.linspace(0.0, duration, T)
    q = np.tile(legs.q_stand, (T, 1))
    body = np.tile([0.0, 0.0, s.q0[2], 0.0, 0.0, 0.0, 1.0], (T, 1))
    return t, q, body, np.ones((T, 6), dtype=bool)


def test_rollout_standing_still(legs):
    from coop_ga.legged.dynamics import RolloutOptions, contact_rollout

    s = _floating()
    mass = sum(inertia.mass for inertia in s.model.inertias)
    plan = _standing_plan(legs, s)
    r = contact_rollout(*plan)
    # with the static feed-forward (equal vertical load on six symmetric feet) nothing moves
    assert r.max_position_drift < 1e-9 and r.rotation_drift.max() < 1e-9
    np.testing.assert_allclose(r.contact_force.sum(axis=1)[:, 2], mass * 9.81, rtol=1e-9)
    assert r.max_friction_ratio < 1e-9
    assert r.saturation == 0.0
    # PD alone: the body sags under its weight (the compliance τ/K_p), straight down, < 1 mm
    r = contact_rollout(*plan, options=RolloutOptions(feedforward=False))
    sag = plan[2][-1, 2] - r.body[-1, 2]
    assert 1e-4 < sag < 1e-3
    assert np.abs(r.body[-1, :2]).max() < 1e-9 and r.rotation_drift.max() < 1e-9
    # stiffer PD, smaller sag (about ∝ 1/K_p)
    r4 = contact_rollout(*plan, options=RolloutOptions(feedforward=False, kp=80.0, kd=0.6))
    assert plan[2][-1, 2] - r4.body[-1, 2] == pytest.approx(sag / 4, rel=0.2)


def test_rollout_lift_and_place_one_leg(legs):
    from coop_ga.legged.dynamics import RolloutOptions, contact_rollout

    s = _floating()
    T = 41
    t = np.linspace(0.0, 0.8, T)
    feet = np.repeat(legs.fk(legs.q_stand)[None], T, axis=0)
    lift = np.where((t > 0.2) & (t < 0.6), 0.02 * np.sin(np.pi * (t - 0.2) / 0.4) ** 2, 0.0)
    feet[:, 0, 2] += lift
    q = legs.ik(feet)
    body = np.tile([0.0, 0.0, s.q0[2], 0.0, 0.0, 0.0, 1.0], (T, 1))
    stance = np.ones((T, 6), dtype=bool)
    stance[(t >= 0.2) & (t < 0.6), 0] = False
    r = contact_rollout(t, q, body, stance)
    assert r.touchdown_height_error.size == 7  # six initial contacts + the touch-down of lf
    np.testing.assert_array_equal(r.touchdown_height_error[:6], 0.0)
    # the body tilts toward the lifted corner (five feet, equal-load feed-forward no longer balances)
    # and the swing foot lags its PD: it lands ~2.3 mm low at K_p = 20 N·m/rad
    assert -3e-3 < r.touchdown_height_error[-1] < 0.0
    assert r.min_normal_force > 0.0  # five feet carry the body: no contact pulls
    assert np.all(r.contact_force[(t > 0.25) & (t < 0.55), 0] == 0.0)  # lf in the air
    assert r.max_position_drift < 1e-3 and r.rotation_drift.max() < math.radians(0.5)
    assert r.max_swing_foot_error < 5e-3
    assert r.joint_error.max() < 0.05
    # a 4× stiffer PD lands within a third of that
    r4 = contact_rollout(t, q, body, stance, RolloutOptions(kp=80.0, kd=0.6))
    assert abs(r4.touchdown_height_error[-1]) < abs(r.touchdown_height_error[-1]) / 3
    assert r4.max_position_drift < r.max_position_drift / 3


def test_rollout_free_fall_of_a_tilted_body(legs):
    """No stance foot: the robot, held in its stand pose by the PD, falls under gravity from rest.  Semi-implicit
    Euler gives the closed form z_n = z_0 − g h² n (n + 1) / 2 in the WORLD frame whatever the body's tilt (the
    free flyer's velocity is local: a wrong frame would make a tilted body fall sideways); x, y, the rotation
    and the legs stay put."""
    from scipy.spatial.transform import Rotation

    from coop_ga.legged.dynamics import RolloutOptions, contact_rollout

    s = _floating()
    T, h = 6, RolloutOptions().dt  # 0.2 ms (at 1 ms the light legs' explicit PD damping is unstable)
    t = np.linspace(0.0, 0.05, T)
    quat = Rotation.from_euler("ZYX", [0.7, 0.4, -0.5]).as_quat()
    body = np.tile(np.concatenate([[0.1, -0.2, 0.5], quat]), (T, 1))
    q = np.tile(legs.q_stand, (T, 1))
    r = contact_rollout(t, q, body, np.zeros((T, 6), dtype=bool))
    g = -float(s.model.gravity.linear[2])
    n = np.round(t / h)
    np.testing.assert_allclose(r.body[:, 2], 0.5 - g * h**2 * n * (n + 1) / 2, rtol=0, atol=1e-12)
    np.testing.assert_allclose(r.body[:, :2], body[:, :2], rtol=0, atol=1e-12)
    np.testing.assert_allclose(r.position_drift, g * h**2 * n * (n + 1) / 2, rtol=0, atol=1e-12)
    assert r.rotation_drift.max() < 1e-12 and r.joint_error.max() < 1e-12
    np.testing.assert_allclose(np.linalg.norm(r.body[:, 3:], axis=1), 1.0, atol=1e-15)


def test_rollout_bad_plans():
    from coop_ga.legged.dynamics import RolloutOptions, contact_rollout

    s = _floating()
    legs = hexapod_legs()
    t, q, body, st = _standing_plan(legs, s, T=4)
    with pytest.raises(InvalidInputError, match="stance"):
        contact_rollout(t, q, body, st.astype(int))
    with pytest.raises(InvalidInputError, match="increasing"):
        contact_rollout(t[::-1], q, body, st)
    bad = body.copy()
    bad[1, 6] = 2.0
    with pytest.raises(InvalidInputError, match="unit quaternions"):
        contact_rollout(t, q, bad, st)
    with pytest.raises(InvalidInputError, match="q must have shape"):
        contact_rollout(t, q[:, :17], body, st)
    with pytest.raises(InvalidInputError, match="options"):
        contact_rollout(t, q, body, st, options={"kp": 1.0})
    with pytest.raises(InvalidInputError):
        contact_rollout(t, q, body, st, options=RolloutOptions(dt=0.0))
    with pytest.raises(InvalidInputError, match=r"not a free-flyer body \+ 18 leg joints.*free_flyer=True"):
        contact_rollout(t, q, body, st, system=systems.load("hexapod"))
