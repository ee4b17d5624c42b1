"""Motor forward kinematics and Jacobians of every registered system against Pinocchio.

* FK: the motor of each end frame equals ``data.oMf`` (rotation via the rotor matrix, and
  translation) at 120 random configurations inside the joint limits, to 1e-10;
* the body-frame geometric Jacobian equals ``LOCAL_TO_TANGENT @ J_LOCAL`` and the
  Euclidean point Jacobian the linear rows of ``J_LOCAL_WORLD_ALIGNED``, to 1e-9;
* the CasADi SX path (the graph later layers compile) equals the numpy path to 1e-12;
* ∂M/∂q_j and the conformal point Jacobians (Eq 16–17) against central differences;
* every chain moves through exactly its own joints (a finger whose columns are silently
  zero, or a joint wrongly shared between chains, fails here);
* seed 001's worked example (2-link planar arm).
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pinocchio as pin
import pytest

import coop_ga as cg
from coop_ga import systems
from coop_ga.geometry.groups import MOTOR_BLADES, motor_rotor_translation, rotor_matrix
from coop_ga.kinematics import LOCAL_TO_TANGENT, KinematicTree
from tests.helpers import central_difference

NAMES = systems.names()
N_RANDOM = 120


def _motor_Rt(M):
    R, t = motor_rotor_translation(M)
    return np.array(rotor_matrix(R), dtype=float), np.array(t, dtype=float)


def test_every_paper_system_is_registered():
    expected = {
        "three_franka",
        "three_iiwa14",
        "g1_arms",
        "g1_torso_arms",
        "franka_and_g1",
        "two_g1",
        "three_finger_hand",
        "allegro",
        "hexapod",
    }
    assert expected <= set(NAMES)


# ---------------------------------------------------------------------- vs Pinocchio
@pytest.mark.parametrize("name", NAMES)
def test_fk_and_jacobians_match_pinocchio(name):
    s = systems.load(name)
    m, d = s.model, s.model.createData()
    fids = [m.getFrameId(f) for f in s.end_frames]
    rng = np.random.default_rng(2024)
    qs = [s.q0] + [s.random_q(rng) for _ in range(N_RANDOM)]
    worst = np.zeros(4)
    for q in qs:
        assert np.all((q >= s.q_lower) & (q <= s.q_upper))
        pin.computeJointJacobians(m, d, q)  # also runs forwardKinematics
        pin.updateFramePlacements(m, d)
        motors = s.tree.frame_motors(q)
        JG = s.tree.geometric_jacobians(q)
        JP = s.tree.euclidean_point_jacobians(q)
        for fid, M, Jg, Jp in zip(fids, motors, JG, JP):
            R, t = _motor_Rt(M)
            ref = d.oMf[fid]
            J_local = pin.getFrameJacobian(m, d, fid, pin.LOCAL)
            J_lwa = pin.getFrameJacobian(m, d, fid, pin.LOCAL_WORLD_ALIGNED)
            err = [
                np.abs(R - ref.rotation).max(),
                np.abs(t - ref.translation).max(),
                np.abs(Jg - LOCAL_TO_TANGENT @ J_local).max(),
                np.abs(Jp - J_lwa[:3]).max(),
            ]
            worst = np.maximum(worst, err)
    assert worst[0] < 1e-10 and worst[1] < 1e-10, f"FK rotation/translation error {worst[:2]}"
    assert worst[2] < 1e-9, f"geometric Jacobian error {worst[2]}"
    assert worst[3] < 1e-9, f"point Jacobian error {worst[3]}"


@pytest.mark.parametrize("name", NAMES)
def test_motors_are_unit_and_q0_is_inside_limits(name):
    s = systems.load(name)
    assert np.all(s.q0 > s.q_lower) and np.all(s.q0 < s.q_upper), "q0 must be strictly inside the limits"
    for M in s.tree.frame_motors(s.q0):
        assert (M * M.reverse()).allclose(cg.Multivector.scalar(1.0), atol=1e-12)


@pytest.mark.parametrize("name", NAMES)
def test_casadi_path_equals_numpy(name):
    s = systems.load(name)
    qs = ca.SX.sym("q", s.nq)
    motors = s.tree.frame_motors(qs)
    outs = [ca.vertcat(*M.with_blades(MOTOR_BLADES).coeffs) for M in motors]
    outs += s.tree.geometric_jacobians(qs)
    outs += s.tree.euclidean_point_jacobians(qs)
    f = ca.Function(f"kin_{name}", [qs], [ca.densify(o) for o in outs])
    k = s.n_chains
    rng = np.random.default_rng(5)
    for _ in range(10):
        q = s.random_q(rng)
        res = f(q)
        ref_m = [np.array(M.with_blades(MOTOR_BLADES).coeffs, dtype=float) for M in s.tree.frame_motors(q)]
        ref = ref_m + s.tree.geometric_jacobians(q) + s.tree.euclidean_point_jacobians(q)
        for i, (a, b) in enumerate(zip(res, ref)):
            np.testing.assert_allclose(
                np.asarray(a, float).reshape(np.shape(b)), b, atol=1e-12, rtol=0, err_msg=f"output {i} (chain {i % k})"
            )


# ---------------------------------------------------------------------- finite differences
FD_SYSTEMS = ["three_iiwa14", "two_g1", "allegro", "hexapod", "g1_torso_arms"]


@pytest.mark.parametrize("name", FD_SYSTEMS)
def test_analytic_motor_jacobian_matches_finite_differences(name):
    s = systems.load(name)
    rng = np.random.default_rng(11)
    for _ in range(2):
        q = s.random_q(rng, 0.8)
        cols = s.tree.analytic_jacobians(q)
        for i in range(s.n_chains):
            fd = central_difference(
                lambda x, i=i: np.array(s.tree.frame_motors(x)[i].with_blades(MOTOR_BLADES).coeffs, float), q
            )
            J = np.zeros((len(MOTOR_BLADES), s.nq))
            for j, c in enumerate(cols[i]):
                if c is not None:
                    J[:, j] = np.array(c.with_blades(MOTOR_BLADES).coeffs, float)
            np.testing.assert_allclose(J, fd, atol=1e-7, rtol=0)


@pytest.mark.parametrize("name", FD_SYSTEMS)
def test_conformal_point_jacobian_eq17(name):
    """∂P/∂q_j = P⌋L_j: Euclidean part = FD of the end point, e∞ part = p·∂p, e0 part 0."""
    s = systems.load(name)
    e0, e1, e2, e3, ei = (cg.algebra.basis.blade_index(b)[0] for b in ("e0", "e1", "e2", "e3", "einf"))
    rng = np.random.default_rng(12)
    for _ in range(2):
        q = s.random_q(rng, 0.8)
        P, cols = s.tree.point_jacobians(q)
        pts = s.tree.end_points_array(q)
        fd_all = central_difference(lambda x: s.tree.end_points_array(x).ravel(), q)
        blades = (e0, e1, e2, e3, ei)
        fd_conf = central_difference(
            lambda x: np.array([[float(Pi.get(b)) for b in blades] for Pi in s.tree.conformal_points(x)]).ravel(), q
        )
        for i in range(s.n_chains):
            assert float(P[i].get(e0)) == 1.0
            np.testing.assert_allclose([float(P[i].get(b)) for b in (e1, e2, e3)], pts[i], atol=1e-15)
            for j in range(s.nq):
                fd = fd_all[3 * i : 3 * i + 3, j]
                c = cols[i][j]
                if c is None:
                    assert np.all(fd == 0.0), f"joint {j} is off chain {i} but moves its end point"
                    continue
                dp = np.array([float(c.get(b)) for b in (e1, e2, e3)])
                np.testing.assert_allclose(dp, fd, atol=1e-7, rtol=0)
                assert float(c.get(e0)) == 0.0
                assert float(c.get(ei)) == pytest.approx(float(pts[i] @ dp), abs=1e-12)
                np.testing.assert_allclose(
                    [float(c.get(b)) for b in (e0, e1, e2, e3, ei)], fd_conf[5 * i : 5 * i + 5, j], atol=1e-7, rtol=0
                )
        # the cheap cross-product form is the Euclidean part of P⌋L_j
        for i, Jp in enumerate(s.tree.euclidean_point_jacobians(q)):
            for j in range(s.nq):
                ref = np.zeros(3) if cols[i][j] is None else [float(cols[i][j].get(b)) for b in (e1, e2, e3)]
                np.testing.assert_allclose(Jp[:, j], ref, atol=1e-14)


@pytest.mark.parametrize("name", NAMES)
def test_each_chain_moves_through_exactly_its_joints(name):
    """Columns are non-zero for every joint on the chain (= Pinocchio's support) and zero elsewhere."""
    s = systems.load(name)
    m = s.model
    rng = np.random.default_rng(3)
    q = s.random_q(rng, 0.8)
    JG = s.tree.geometric_jacobians(q)
    JP = s.tree.euclidean_point_jacobians(q)
    for i, f in enumerate(s.end_frames):
        parent = m.frames[m.getFrameId(f)].parentJoint
        support = [j for j in m.supports[parent] if j > 0]
        on_chain = sorted(int(m.idx_qs[j]) for j in support)
        assert sorted(s.tree.joint_columns[i]) == on_chain
        assert len(on_chain) >= 3, f"{f}: chain of {len(on_chain)} joints"
        off = [j for j in range(s.nq) if j not in on_chain]
        col_norms = np.linalg.norm(JG[i], axis=0)
        assert np.all(col_norms[on_chain] > 0.5), f"{f}: a joint on the chain has a zero column"
        assert np.all(JG[i][:, off] == 0.0) and np.all(JP[i][:, off] == 0.0)
        assert np.linalg.norm(JP[i][:, on_chain]) > 1e-2
        # the end point really moves when any chain joint moves (finite step)
        p0 = s.tree.end_points_array(q)[i]
        for j in on_chain:
            dq = np.zeros(s.nq)
            dq[j] = 1e-3
            moved = np.linalg.norm(s.tree.end_points_array(q + dq)[i] - p0)
            R0, _ = _motor_Rt(s.tree.frame_motors(q)[i])
            R1, _ = _motor_Rt(s.tree.frame_motors(q + dq)[i])
            assert moved > 0 or np.abs(R1 - R0).max() > 1e-5


# ---------------------------------------------------------------------- seed 001 worked example
def _planar_two_link() -> pin.Model:
    m = pin.Model()
    j1 = m.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "joint1")
    j2 = m.addJoint(j1, pin.JointModelRZ(), pin.SE3(np.eye(3), np.array([1.0, 0.0, 0.0])), "joint2")
    m.addFrame(pin.Frame("tip", j2, 0, pin.SE3(np.eye(3), np.array([1.0, 0.0, 0.0])), pin.FrameType.OP_FRAME))
    return m


def test_seed001_planar_arm_worked_example():
    """Seed 001 ("Worked Example: 2-DOF Planar Arm"): l1 = l2 = 1, θ1 = π/4, θ2 = π/3.

    The seed prints the end point as ``(0.793, 1.573)``, twice (motor result and its
    "traditional" check).  That number is wrong: its own check formula
    ``(0.707 + cos(π/4 + π/3), 0.707 + sin(π/4 + π/3))`` evaluates to (0.448, 1.673).
    The computation wins: the motor FK gives (cos θ1 + cos(θ1+θ2), sin θ1 + sin(θ1+θ2))
    = (0.4483, 1.6730).  The seed's first joint motor ``M1 = 0.924 − 0.383 e12`` (written
    ``exp(−\\frac{π/8} e12)``, a LaTeX typo for exp(−(π/8) e12)) is right.
    """
    t1, t2 = np.pi / 4, np.pi / 3
    tree = KinematicTree(_planar_two_link(), ["tip"])
    q = np.array([t1, t2])
    p = tree.end_points_array(q)[0]
    expected = np.array([np.cos(t1) + np.cos(t1 + t2), np.sin(t1) + np.sin(t1 + t2), 0.0])
    np.testing.assert_allclose(p, expected, atol=1e-15)
    np.testing.assert_allclose(p[:2], [0.4483, 1.6730], atol=5e-5)
    assert np.linalg.norm(p[:2] - [0.793, 1.573]) > 0.3  # the seed's printed value
    # the seed's first joint motor: cos(π/8) − sin(π/8) e12
    C1 = tree.joint_motors(q)[1]
    assert C1.allclose(cg.Multivector.from_names({"1": np.cos(np.pi / 8), "e12": -np.sin(np.pi / 8)}), atol=1e-15)
    # and the end frame's orientation is the total angle θ1 + θ2 about z
    R, _ = _motor_Rt(tree.frame_motors(q)[0])
    np.testing.assert_allclose(R, pin.utils.rotate("z", t1 + t2), atol=1e-15)


# ---------------------------------------------------------------------- every joint class
def test_prismatic_and_unaligned_joints_and_world_frames():
    """PX/PZ, RevoluteUnaligned, PrismaticUnaligned (random placements) and frames fixed to the world."""
    rng = np.random.default_rng(1)

    def rnd_se3():
        return pin.SE3(pin.exp3(rng.normal(size=3)), rng.normal(size=3))

    ax = rng.normal(size=3)
    ax /= np.linalg.norm(ax)
    m = pin.Model()
    j = m.addJoint(0, pin.JointModelPX(), rnd_se3(), "p1")
    j = m.addJoint(j, pin.JointModelRevoluteUnaligned(ax), rnd_se3(), "r2")
    j = m.addJoint(j, pin.JointModelPrismaticUnaligned(ax[[1, 2, 0]]), rnd_se3(), "p3")
    j = m.addJoint(j, pin.JointModelRY(), rnd_se3(), "r4")
    j = m.addJoint(j, pin.JointModelPZ(), rnd_se3(), "p5")
    m.addFrame(pin.Frame("tip", j, 0, rnd_se3(), pin.FrameType.OP_FRAME))
    m.addFrame(pin.Frame("fixed", 0, 0, rnd_se3(), pin.FrameType.OP_FRAME))
    tree = KinematicTree(m, ["tip", "fixed"])
    kinds = [tree.joints[i].kind for i in tree.chains[0]]
    assert kinds == ["prismatic", "revolute", "prismatic", "revolute", "prismatic"]
    assert tree.chains[1] == ()
    d = m.createData()
    for _ in range(10):
        q = rng.normal(size=5)
        pin.computeJointJacobians(m, d, q)
        pin.updateFramePlacements(m, d)
        for name, M, Jg, Jp in zip(
            tree.end_frames, tree.frame_motors(q), tree.geometric_jacobians(q), tree.euclidean_point_jacobians(q)
        ):
            fid = m.getFrameId(name)
            R, t = _motor_Rt(M)
            np.testing.assert_allclose(R, d.oMf[fid].rotation, atol=1e-12)
            np.testing.assert_allclose(t, d.oMf[fid].translation, atol=1e-12)
            np.testing.assert_allclose(Jg, LOCAL_TO_TANGENT @ pin.getFrameJacobian(m, d, fid, pin.LOCAL), atol=1e-12)
            np.testing.assert_allclose(Jp, pin.getFrameJacobian(m, d, fid, pin.LOCAL_WORLD_ALIGNED)[:3], atol=1e-12)
        fd = central_difference(lambda x: tree.end_points_array(x)[0], q)
        np.testing.assert_allclose(tree.euclidean_point_jacobians(q)[0], fd, atol=1e-7)
