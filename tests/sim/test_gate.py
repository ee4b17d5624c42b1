"""The gate of coop_ga.sim: MuJoCo's scene has the kinematics and the inertia of the Pinocchio model.

At 100 random in-limit configurations of every registered system, of two ``from_urdf`` systems and
of a hand-built model with unaligned, prismatic and massless joints: every end-point site equals
Pinocchio's ``oMf`` (position to 1e-9 m, rotation matrix to 1e-9) and MuJoCo's joint-space inertia
(``mj_fullM``) equals Pinocchio's ``crba`` to 1e-8 relative — both with the model's armature (0 in
these URDFs), and once more with an armature of 0.05 kg m² given to both.
"""

from __future__ import annotations

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")
pin = pytest.importorskip("pinocchio")

from coop_ga import systems  # noqa: E402
from coop_ga.sim import build_scene  # noqa: E402
from coop_ga.systems import ROBOTS_DIR  # noqa: E402

N_CONFIGS = 100
POS_TOL, ROT_TOL, M_TOL = 1e-9, 1e-9, 1e-8


def gate_errors(system, scene, pin_model, n: int = N_CONFIGS, seed: int = 0) -> tuple[float, float, float]:
    """(max position error [m], max rotation-matrix entry error, max relative mass-matrix error) over
    ``n`` random configurations inside the limits."""
    m = scene.model
    d = mujoco.MjData(m)
    pd = pin_model.createData()
    fids = [pin_model.getFrameId(f) for f in system.end_frames]
    rng = np.random.default_rng(seed)
    M = np.zeros((m.nv, m.nv))
    ix = np.ix_(scene.qvel_index, scene.qvel_index)
    e_pos = e_rot = e_M = 0.0
    for _ in range(n):
        q = system.random_q(rng)
        scene.set_q(d, q)
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_crb(m, d)
        mujoco.mj_fullM(m, d, M)
        pin.framesForwardKinematics(pin_model, pd, q)
        Mp = pin.crba(pin_model, pd, q)
        Mp = np.triu(Mp) + np.triu(Mp, 1).T
        for k, f in enumerate(fids):
            e_pos = max(e_pos, float(np.abs(d.site_xpos[scene.site_ids[k]] - pd.oMf[f].translation).max()))
            R = d.site_xmat[scene.site_ids[k]].reshape(3, 3)
            e_rot = max(e_rot, float(np.abs(R - pd.oMf[f].rotation).max()))
        e_M = max(e_M, float(np.abs(M[ix] - Mp).max() / np.abs(Mp).max()))
    return e_pos, e_rot, e_M


@pytest.mark.parametrize("name", systems.names())
def test_registered_system(name: str, load_system) -> None:
    s = load_system(name)
    scene = build_scene(s, visuals=False)  # visual geoms carry no mass and no joint: not needed here
    assert scene.model.nu == s.nq and scene.model.nsite >= s.n_chains
    e_pos, e_rot, e_M = gate_errors(s, scene, s.model)
    print(f"{name}: site position {e_pos:.2e} m, rotation {e_rot:.2e}, mass matrix {e_M:.2e} (relative)")
    assert e_pos < POS_TOL and e_rot < ROT_TOL and e_M < M_TOL


def test_from_urdf_systems() -> None:
    iiwa = systems.from_urdf(ROBOTS_DIR / "iiwa14" / "iiwa14.urdf", ["iiwa_flange"], locked_joints=["iiwa_joint_3"])
    legs = [f"{leg}_foot" for leg in ("lf", "lr", "rf", "rr")]
    locked = [f"{leg}_{j}_joint" for leg in ("lm", "rm") for j in ("coxa", "femur", "tibia")]
    hexa = systems.from_urdf(ROBOTS_DIR / "hexapod" / "hexapod.urdf", legs, locked_joints=locked)
    for s in (iiwa, hexa):
        scene = build_scene(s, visuals=False)
        e_pos, e_rot, e_M = gate_errors(s, scene, s.model)
        assert e_pos < POS_TOL and e_rot < ROT_TOL and e_M < M_TOL, (s.name, e_pos, e_rot, e_M)


def _odd_model():
    """A chain with a massless unaligned revolute joint at a rotated, offset placement whose only child
    is an unaligned prismatic joint (merged into one MuJoCo body), then RY and RX joints, and a tip frame."""
    m = pin.Model()

    def joint(parent, jm, R, t, name, inertia=None):
        j = m.addJoint(parent, jm, pin.SE3(R, np.asarray(t, float)), name)
        fj = m.addJointFrame(j)
        if inertia is not None:
            m.appendBodyToJoint(j, inertia, pin.SE3.Identity())
        return j, m.addBodyFrame(f"link_{name}", j, pin.SE3.Identity(), fj)

    rpy = pin.utils.rpyToMatrix
    j1, _ = joint(
        0, pin.JointModelRevoluteUnaligned(np.array([0.0, 0.6, 0.8])), rpy(0.3, -0.2, 0.5), [0.1, 0, 0.3], "r1"
    )
    I2 = pin.Inertia(
        1.3, np.array([0.02, -0.01, 0.05]), np.array([[0.02, 0.001, 0], [0.001, 0.03, 0.002], [0, 0.002, 0.025]])
    )
    j2, _ = joint(
        j1, pin.JointModelPrismaticUnaligned(np.array([0.6, 0.0, 0.8])), rpy(-0.4, 0.1, 0.2), [0, 0.2, 0.1], "p2", I2
    )
    j3, _ = joint(j2, pin.JointModelRY(), np.eye(3), [0.3, 0, 0], "r3", pin.Inertia.FromBox(0.7, 0.3, 0.05, 0.05))
    j4, f4 = joint(
        j3, pin.JointModelRX(), pin.utils.rotate("z", 0.7), [0.3, 0, 0], "r4", pin.Inertia.FromSphere(0.2, 0.04)
    )
    tip = pin.SE3(pin.utils.rotate("y", 0.4), np.array([0.1, 0.02, 0.0]))
    m.addFrame(pin.Frame("tip", j4, f4, tip, pin.FrameType.OP_FRAME))
    m.lowerPositionLimit[:] = [-2.0, -0.2, -2.0, -2.0]
    m.upperPositionLimit[:] = [2.0, 0.3, 2.0, 2.0]
    return m


def test_merged_massless_joint_and_unaligned_axes() -> None:
    s = systems.from_model(_odd_model(), ["tip", "link_r3"], name="odd")
    scene = build_scene(s, collision=False, visuals=False)
    assert scene.model.nbody == 4  # world, {r1, p2} merged, r3, r4
    e_pos, e_rot, e_M = gate_errors(s, scene, s.model)
    assert e_pos < POS_TOL and e_rot < ROT_TOL and e_M < M_TOL, (e_pos, e_rot, e_M)


def test_armature_given_to_both(load_system) -> None:
    s = load_system("three_iiwa14")
    scene = build_scene(s, visuals=False, armature=0.05)
    ref = pin.Model(s.model)
    ref.armature[:] = 0.05
    e_pos, e_rot, e_M = gate_errors(s, scene, ref, n=20)
    assert e_pos < POS_TOL and e_rot < ROT_TOL and e_M < M_TOL
    # and the armature is really there: without it on the Pinocchio side the matrices differ by ~0.05
    _, _, e_off = gate_errors(s, scene, s.model, n=3)
    assert e_off > 1e-3
