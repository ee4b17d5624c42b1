"""Singularity classes by meets of the joint-axis lines, against the SVD of Pinocchio's Jacobian."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from scipy.optimize import brentq, minimize_scalar

import coop_ga as cg
from coop_ga.kinematics.chains import KinematicTree
from coop_ga.kinematics.singularities import (
    axis_relation,
    classify_singularities,
    joint_axis_lines,
    line_moment,
)
from coop_ga.systems.library import _iiwa_arm, _panda_arm

ROBOTS = {"iiwa14": "iiwa_flange", "panda": "panda_hand_tcp"}


@pytest.fixture(scope="module")
def arms():
    out = {}
    for name, frame in ROBOTS.items():
        m = _iiwa_arm() if name == "iiwa14" else _panda_arm()[0]
        out[name] = (m, m.createData(), m.getFrameId(frame), KinematicTree(m, [frame]))
    return out


def sigma_min(arm, q) -> float:
    """Smallest singular value of the 6×7 Jacobian (LOCAL_WORLD_ALIGNED at the end frame)."""
    m, d, fid, _ = arm
    J = pin.computeFrameJacobian(m, d, np.asarray(q, float), fid, pin.LOCAL_WORLD_ALIGNED)
    return float(np.linalg.svd(J, compute_uv=False)[-1])


def base_q(arm, seed: int) -> np.ndarray:
    m = arm[0]
    return np.random.default_rng(seed).uniform(0.6 * m.lowerPositionLimit, 0.6 * m.upperPositionLimit)


def test_lines_are_pinocchio_axes_and_meets_classify_pairs(arms):
    m, d, _, tree = arms["iiwa14"]
    q = base_q(arms["iiwa14"], 0)
    pin.forwardKinematics(m, d, q)
    for j, L in enumerate(joint_axis_lines(tree, q), start=1):
        o, a = d.oMi[j].translation, d.oMi[j].rotation[:, 2]  # iiwa joints rotate about their z
        np.testing.assert_allclose(cg.direction(L), a, atol=1e-12)
        assert abs(line_moment(L, cg.line(o, o + a))) < 1e-12
    # meets on textbook pairs
    x = cg.line([0, 0, 0], [1, 0, 0])
    assert abs(line_moment(x, cg.line([0, 0, 0.5], [0, 1, 0.5])) - 0.5) < 1e-15  # skew, 90°, d = 0.5
    assert axis_relation(x, cg.line([0, 0, 0.5], [0, 1, 0.5])) == "skew"
    assert axis_relation(x, cg.line([2, 0, 0], [2, 1, 0])) == "intersecting"
    assert axis_relation(x, cg.line([0, 1, 0], [1, 1, 0])) == "parallel"
    assert axis_relation(x, cg.line([3, 0, 0], [4, 0, 0])) == "coincident"
    # the iiwa's structure at any q: 1,2,3 meet (spherical shoulder), 5,6,7 meet (spherical wrist)
    r = classify_singularities(tree, q)
    assert all(r.relations[p] == "intersecting" for p in [(0, 1), (0, 2), (1, 2), (4, 5), (4, 6), (5, 6)])
    assert r.diagnostics["spherical_wrist"] < 1e-12


@pytest.mark.parametrize("name", list(ROBOTS))
def test_random_configurations_none_singular_both_agree(arms, name):
    arm = arms[name]
    m, tree = arm[0], arm[3]
    rng = np.random.default_rng(2024)
    smins, residuals = [], []
    for _ in range(150):
        q = rng.uniform(m.lowerPositionLimit, m.upperPositionLimit)
        r = classify_singularities(tree, q)
        assert r.classes == () and not r.singular
        smins.append(sigma_min(arm, q))
        residuals.append(min(r.residuals.values()))
    smins, residuals = np.array(smins), np.array(residuals)
    # measured: iiwa14 σ_min ≥ 1.6e-4, residual ≥ 2.0e-4 m, both smallest at the same sample (the
    # elbow nearly stretched); panda σ_min ≥ 1.8e-3, residual ≥ 8.5e-3 m
    assert smins.min() > 1e-5 and residuals.min() > 1e-5, (smins.min(), residuals.min())
    if name == "iiwa14":
        assert np.argmin(smins) == np.argmin(residuals)


def _iiwa_cases():
    return {
        "elbow": {3: 0.0},
        "shoulder": {1: 0.0, 2: np.pi / 2},
        "wrist": {5: 0.0, 4: -np.pi / 2},
        "double_alignment": {1: 0.0, 5: 0.0},
    }


@pytest.mark.parametrize("cls", list(_iiwa_cases()))
def test_iiwa_constructed_singularities(arms, cls):
    arm = arms["iiwa14"]
    for seed in range(3):
        q = base_q(arm, seed)
        for i, v in _iiwa_cases()[cls].items():
            q[i] = v
        r = classify_singularities(arm[3], q)
        assert r.classes == (cls,), (r.classes, r.residuals)
        assert r.residuals[cls] < 1e-12
        assert sigma_min(arm, q) < 1e-12  # rank 5 (measured ≤ 3e-16)


def test_iiwa_near_singular_residual_and_sigma_scale_together(arms):
    """Off the elbow singularity by ε (q4 = ε): both the meet residual and σ_min are O(ε)."""
    arm = arms["iiwa14"]
    q = base_q(arm, 5)
    ratios = []
    for eps in (1e-2, 1e-4, 1e-6):
        q[3] = eps
        r = classify_singularities(arm[3], q)
        assert r.classes == ()  # above tol = 1e-7 m
        ratios.append(r.residuals["elbow"] / sigma_min(arm, q))
    assert max(ratios) / min(ratios) < 1.05, ratios


def test_iiwa_seed_shoulder_condition_is_not_singular(arms):
    """The seed's shoulder singularity (wrist centre on the first axis) is one of 6R arms: the
    redundant iiwa with W on L1 (q2 solved for it, q2 ≠ 0) keeps full rank."""
    arm = arms["iiwa14"]
    q = np.array([0.3, 0.0, 0.0, 1.2, 0.4, -0.7, 0.2])

    def off_axis(q2: float) -> float:
        q[1] = q2
        return classify_singularities(arm[3], q).diagnostics["wrist_on_first_axis"]

    res = minimize_scalar(off_axis, bounds=(0.0, 1.5), method="bounded", options={"xatol": 1e-12})
    q[1] = res.x  # 0.5833 rad
    r = classify_singularities(arm[3], q)
    assert r.diagnostics["wrist_on_first_axis"] < 1e-8 and abs(q[1]) > 0.3
    assert r.classes == ()
    assert sigma_min(arm, q) > 0.1  # measured 0.18


def test_panda_elbow_singularity(arms):
    """Panda: L4 ∥ L6 (q5 = 0) and the shoulder centre S in their plane.  q4 solved from Pinocchio's
    placements alone (S·n = 0), then the CGA class and the SVD are checked; q4* = −0.46700 rad."""
    arm = arms["panda"]
    m, d, _, tree = arm
    for seed in range(3):
        q = base_q(arm, seed)
        q[4] = 0.0

        def s_off_plane(q4: float) -> float:
            q[3] = q4
            pin.forwardKinematics(m, d, q)
            S = d.oMi[2].translation  # joints 1, 2 axes meet at joint 2's origin
            o4, a4, o6 = d.oMi[4].translation, d.oMi[4].rotation[:, 2], d.oMi[6].translation
            n = np.cross(a4, o6 - o4)
            return float((S - o4) @ n / np.linalg.norm(n))

        q[3] = brentq(s_off_plane, -0.7, -0.3, xtol=1e-15)
        assert abs(q[3] + 0.46700242) < 1e-7
        r = classify_singularities(tree, q)
        assert r.relations[(3, 5)] == "parallel"
        assert r.classes == ("elbow",) and r.residuals["elbow"] < 1e-12, r.residuals
        assert sigma_min(arm, q) < 1e-12
        # and the SVD is not fooled by the class: off q4* by 1e-3 rad, no class and full rank
        q[3] += 1e-3
        r = classify_singularities(tree, q)
        assert r.classes == () and r.residuals["elbow"] > 1e-5 and sigma_min(arm, q) > 5e-5  # both O(1e-4)


def test_panda_q2_zero_family_is_a_rank_drop_without_transversal(arms):
    """Limitation (documented): the Panda with L1 ≡ L3 (q2 = 0) drops rank at some q3* (depending on
    q4..q7) through a reciprocal screw of non-zero pitch; our line constructions do not find it."""
    arm = arms["panda"]
    q = base_q(arm, 1)
    q[1] = 0.0
    res = minimize_scalar(
        lambda x: sigma_min(arm, np.r_[q[:2], x, q[3:]]), bounds=(0.5, 2.5), method="bounded", options={"xatol": 1e-12}
    )
    q[2] = res.x
    r = classify_singularities(arm[3], q)
    assert sigma_min(arm, q) < 1e-8
    assert r.relations[(0, 2)] == "coincident" and r.classes == ()
    assert min(r.residuals.values()) > 1e-3, r.residuals
    # and the Panda has no wrist class: L5 ∥ L7 at q6 = 0 (and π), but they never coincide
    q = base_q(arm, 2)
    q[5] = 0.0
    r = classify_singularities(arm[3], q)
    assert r.relations[(4, 6)] == "parallel" and r.diagnostics["coincidence_57"] > 0.08
    assert r.residuals["wrist"] == float("inf") and sigma_min(arm, q) > 1e-3


def test_bad_input(arms):
    tree = arms["iiwa14"][3]
    with pytest.raises(cg.CoopGAError):
        classify_singularities(tree, np.zeros(6))
    with pytest.raises(cg.CoopGAError):
        classify_singularities(tree, np.zeros(7), wrist=(4, 5, 5))
    with pytest.raises(cg.CoopGAError):
        classify_singularities(tree, np.full(7, np.nan))
    with pytest.raises(cg.CoopGAError):
        classify_singularities("iiwa", np.zeros(7))  # type: ignore[arg-type]
