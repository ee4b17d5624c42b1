"""MJCF input (``systems.from_mjcf``): the Pinocchio model MuJoCo's compiled file gives, checked against MuJoCo.

A hand-written arm with what MJCF files do (degrees, Euler angles, joint anchors and ``ref``, two joints on one
body, a body without joints, an unaligned slide, sites, a keyframe) and the three Frankas exported by
``coop_ga.sim`` (``MjSpec.to_xml``) and read back: FK of every body and site against ``xpos``/``xmat``/``site_xpos``,
limits against ``jnt_range``, the joint-space inertia against ``mj_fullM``, and a cooperative circle on the
read-back Frankas equal to the registered system's; the visual geoms' poses against ``geom_xpos``/``geom_xmat``.
A free joint is a free flyer: FK against ``site_xpos`` and point velocities against ``mj_jacSite`` (through the
qpos/qvel conversions).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import coop_ga as cg
from coop_ga.errors import CoopGAError, InvalidInputError, UnknownNameError, UnsupportedJointError

mujoco = pytest.importorskip("mujoco")

ARM = """<mujoco model="arm">
  <compiler angle="degree"/>
  <default>
    <joint damping="0.1" armature="0.01"/>
    <default class="big"><joint range="-170 170"/></default>
  </default>
  <worldbody>
    <body name="base" pos="0.1 -0.2 0.1" euler="0 0 45">
      <geom type="cylinder" size="0.05 0.05"/>
      <body name="l1" pos="0 0 0.1" euler="10 0 30">
        <joint name="j1" type="hinge" axis="0 0 1" class="big" pos="0.01 0 0"/>
        <geom type="capsule" fromto="0 0 0 0 0 0.3" size="0.03"/>
        <body name="l2" pos="0 0 0.3" quat="0.9 0.1 0.2 0.3">
          <joint name="j2" type="hinge" axis="0 1 1" range="-90 90" ref="10" pos="0 0.02 0.03"/>
          <joint name="j2b" type="hinge" axis="1 0 0" pos="0.01 0 0.05" ref="-5"/>
          <geom type="box" size="0.02 0.02 0.1" pos="0 0 0.1"/>
          <body name="welded" pos="0 0 0.2" euler="0 30 0">
            <geom type="sphere" size="0.03" mass="0.2"/>
            <body name="l3" pos="0 0 0.1" axisangle="1 0 0 20">
              <joint name="j3" type="slide" axis="0.3 0 1" range="-0.1 0.1" ref="0.02"/>
              <inertial pos="0 0 0.05" quat="0.8 0.6 0 0" mass="0.5" diaginertia="0.001 0.002 0.003"/>
              <site name="tip" pos="0.01 0.02 0.1" euler="10 0 0"/>
            </body>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator><motor joint="j1" gear="2" forcerange="-5 5" forcelimited="true"/></actuator>
  <keyframe><key name="home" qpos="0.1 0.2 0.3 0.05"/></keyframe>
</mujoco>
"""
BODIES = ("base", "l1", "l2", "welded", "l3")


@pytest.fixture(scope="module")
def arm_xml(tmp_path_factory: pytest.TempPathFactory) -> Path:
    p = tmp_path_factory.mktemp("mjcf") / "arm.xml"
    p.write_text(ARM)
    return p


def _mj(xml: Path) -> tuple[object, object]:
    m = mujoco.MjModel.from_xml_path(str(xml))
    return m, mujoco.MjData(m)


def _visual_error(s: cg.systems.System, mm: object, d: object, q: np.ndarray) -> tuple[int, float]:
    """(number of visual objects, largest |Δ| of their world poses against MuJoCo's geom_xpos/geom_xmat) at q."""
    vm = s.visual_model()
    gd = vm.createData()
    pin.updateGeometryPlacements(s.model, s.model.createData(), vm, gd, q)
    names = [mm.geom(i).name or f"geom{i}" for i in range(mm.ngeom)]
    d.qpos[:] = q
    mujoco.mj_kinematics(mm, d)
    worst = 0.0
    for i, obj in enumerate(vm.geometryObjects):
        g = names.index(obj.name)
        worst = max(worst, np.abs(gd.oMg[i].translation - d.geom_xpos[g]).max())
        worst = max(worst, np.abs(gd.oMg[i].rotation - d.geom_xmat[g].reshape(3, 3)).max())
    return vm.ngeoms, worst


def test_model_from_mjcf_matches_mujoco_fk_limits_and_inertia(arm_xml: Path) -> None:
    model = cg.systems.model_from_mjcf(arm_xml)
    mm, d = _mj(arm_xml)
    assert list(model.names)[1:] == ["j1", "j2", "j2b", "j3"]
    assert model.nq == mm.nq == 4
    # limits: radians for hinges (degrees in the file), metres for the slide, the ref-ed hinge not shifted
    lo, hi = np.array(model.lowerPositionLimit), np.array(model.upperPositionLimit)
    limited = np.asarray(mm.jnt_limited, bool)
    np.testing.assert_allclose(lo[limited], mm.jnt_range[limited, 0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(hi[limited], mm.jnt_range[limited, 1], rtol=0, atol=1e-15)
    assert lo[2] < -1e300 and hi[2] > 1e300  # j2b has no range: unbounded
    np.testing.assert_allclose(model.armature, 0.01, atol=0)
    np.testing.assert_allclose(model.damping, 0.1, atol=0)
    data = model.createData()
    rng = np.random.default_rng(0)
    worst = {"pos": 0.0, "rot": 0.0, "site": 0.0, "M": 0.0}
    for _ in range(20):
        q = rng.uniform(-1.5, 1.5, 4) * np.array([1, 1, 1, 0.06])
        d.qpos[:] = q
        mujoco.mj_forward(mm, d)
        pin.framesForwardKinematics(model, data, q)
        for b in BODIES:
            f = data.oMf[model.getFrameId(b, pin.FrameType.BODY)]
            worst["pos"] = max(worst["pos"], np.abs(f.translation - d.xpos[mm.body(b).id]).max())
            worst["rot"] = max(worst["rot"], np.abs(f.rotation - d.xmat[mm.body(b).id].reshape(3, 3)).max())
        worst["site"] = max(worst["site"], np.abs(data.oMf[model.getFrameId("tip")].translation - d.site_xpos[0]).max())
        M = np.zeros((4, 4))
        mujoco.mj_fullM(mm, d, M)
        Mp = pin.crba(model, model.createData(), q)
        Mp = np.triu(Mp) + np.triu(Mp, 1).T
        worst["M"] = max(worst["M"], np.abs(M - Mp).max() / np.abs(M).max())
    assert max(worst.values()) < 1e-12, worst


def test_from_mjcf_system_q0_keyframe_locking_and_effort(arm_xml: Path) -> None:
    mm, _ = _mj(arm_xml)
    s = cg.systems.from_mjcf(arm_xml, ["tip", "l2"])
    assert s.name == "arm" and s.joint_names == ["j1", "j2", "j2b", "j3"]
    # q0 = qpos0 (each joint at its ref: the file's pose), inside the limits
    np.testing.assert_allclose(s.q0, mm.qpos0, atol=0)
    assert s.limits is not None
    assert s.limits.effort[0] == 10.0 and np.isinf(s.limits.effort[1:]).all()  # forcerange 5 × gear 2
    # the end points equal MuJoCo's at the file's pose
    _, d = _mj(arm_xml)
    mujoco.mj_kinematics(mm, d)
    np.testing.assert_allclose(s.end_points(s.q0), [d.site_xpos[0], d.xpos[mm.body("l2").id]], atol=1e-14)
    # a keyframe: q0 and the locked joint's value come from it
    k = cg.systems.from_mjcf(arm_xml, ["tip", "l2"], ["j2b"], keyframe="home", name="arm_home")
    assert k.name == "arm_home" and k.joint_names == ["j1", "j2", "j3"]
    np.testing.assert_allclose(k.q0, [0.1, 0.2, 0.05], atol=0)
    d.qpos[:] = mm.key_qpos[0]
    mujoco.mj_kinematics(mm, d)
    np.testing.assert_allclose(k.end_points(k.q0)[0], d.site_xpos[0], atol=1e-14)
    # the visual geometry: the four geoms (cylinder, capsule, box, sphere) where MuJoCo puts them
    n, err = _visual_error(s, mm, d, np.array([0.4, -0.3, 0.8, 0.05]))
    assert n == 4 and err < 1e-12, (n, err)
    assert cg.systems.from_mjcf(arm_xml, ["tip"], visuals=False).visual_model() is None
    # named control groups: the same locking
    g = cg.systems.from_mjcf(arm_xml, ["tip"], groups={"arm": "j[12]", "slide": ["j3"]}, active=["arm", "slide"])
    assert g.joint_names == ["j1", "j2", "j3"]


def _xml_with(tmp_path: Path, joint: str) -> Path:
    p = tmp_path / "bad.xml"
    p.write_text(
        "<mujoco><worldbody><body name='b' pos='0 0 1'>"
        f"{joint}<geom type='sphere' size='0.1'/></body></worldbody></mujoco>"
    )
    return p


FLOATING = """<mujoco><compiler angle="radian"/><worldbody>
  <body name="base" pos="0.1 0.2 0.5" quat="0.9 0.1 0.3 0.2"><freejoint name="float"/><geom size="0.1"/>
    <body name="l1" pos="0.2 0 0"><joint name="j1" type="hinge" axis="0 1 0" range="-2 2"/><geom size="0.05"/>
      <body name="l2" pos="0.3 0 0"><joint name="j2" type="slide" axis="0 0.6 0.8" range="-0.2 0.2"/>
        <geom size="0.03"/><site name="tip" pos="0.1 0 0.05"/></body></body></body>
</worldbody></mujoco>"""


def test_free_joint_is_a_free_flyer_matching_mujoco(tmp_path: Path) -> None:
    from coop_ga.systems.mjcf import q_from_qpos, qpos_from_q, v_from_qvel

    path = tmp_path / "floating.xml"
    path.write_text(FLOATING)
    s = cg.systems.from_mjcf(path, ["tip"])
    assert (s.nq, s.nv) == (9, 8) and s.model.joints[1].shortname() == "JointModelFreeFlyer"
    mm = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(mm)
    np.testing.assert_allclose(s.q0[:7], q_from_qpos(s.model, mm.qpos0)[:7], atol=0)  # the file's base pose
    rng = np.random.default_rng(4)
    for _ in range(10):
        qpos = np.concatenate([rng.normal(size=3), rng.normal(size=4), rng.uniform(-0.2, 0.2, 2)])
        qpos[3:7] /= np.linalg.norm(qpos[3:7])
        d.qpos[:], d.qvel[:] = qpos, rng.normal(size=mm.nv)
        mujoco.mj_forward(mm, d)
        q = q_from_qpos(s.model, qpos)
        np.testing.assert_array_equal(qpos_from_q(s.model, q), qpos)
        assert np.abs(s.end_points(q)[0] - d.site_xpos[0]).max() <= 1e-12
        jac = np.zeros((3, mm.nv))
        mujoco.mj_jacSite(mm, d, jac, None, 0)
        v = v_from_qvel(s.model, q, d.qvel)  # the same motion in Pinocchio's velocity convention
        assert np.abs(jac @ d.qvel - s.tree.euclidean_point_jacobians(q)[0] @ v).max() <= 1e-12


def test_from_mjcf_refuses_ball_joints_and_bad_input(arm_xml: Path, tmp_path: Path) -> None:
    with pytest.raises(UnsupportedJointError, match="'shoulder' is a ball joint"):
        cg.systems.from_mjcf(_xml_with(tmp_path, "<joint name='shoulder' type='ball'/>"), ["b"])
    with pytest.raises(InvalidInputError, match="MJCF file not found"):
        cg.systems.from_mjcf(tmp_path / "nothing.xml", ["b"])
    (tmp_path / "junk.xml").write_text("<mujoco><worldbody><body></mujoco>")
    with pytest.raises(InvalidInputError, match="not an MJCF file MuJoCo can compile"):
        cg.systems.from_mjcf(tmp_path / "junk.xml", ["b"])
    with pytest.raises(UnknownNameError, match=r"unknown keyframe 'away'.*'home'"):
        cg.systems.from_mjcf(arm_xml, ["tip"], keyframe="away")
    with pytest.raises(UnknownNameError, match=r"unknown frame\(s\) \['hand'\]"):
        cg.systems.from_mjcf(arm_xml, ["hand"])
    with pytest.raises(InvalidInputError, match="either keyframe= or q0="):
        cg.systems.from_mjcf(arm_xml, ["tip"], keyframe="home", q0=np.zeros(4))
    with pytest.raises(CoopGAError, match="unknown locked_joints"):
        cg.systems.from_mjcf(arm_xml, ["tip"], ["j9"])


def test_three_franka_exported_by_sim_reads_back(tmp_path: Path) -> None:
    from coop_ga.sim import build_scene

    s0 = cg.systems.load("three_franka")
    xml = tmp_path / "three_franka.xml"
    build_scene(s0, collision=False, floor=None).write_model(xml)
    s = cg.systems.from_mjcf(xml, s0.end_frames)
    assert s.joint_names == s0.joint_names
    assert s.limits is not None and s0.limits is not None
    np.testing.assert_array_equal(s.limits.lower, s0.limits.lower)
    np.testing.assert_array_equal(s.limits.effort, s0.limits.effort)
    mm, d = _mj(xml)
    sites = [mm.site(n).id for n in s.end_frames]
    rng = np.random.default_rng(3)
    worst_mj = worst_ours = 0.0
    for _ in range(30):
        q = s0.random_q(rng)
        d.qpos[:] = q
        mujoco.mj_kinematics(mm, d)
        p = s.end_points(q)
        worst_mj = max(worst_mj, np.abs(p - d.site_xpos[sites]).max())
        worst_ours = max(worst_ours, np.abs(p - s0.end_points(q)).max())
    assert worst_mj < 1e-9 and worst_ours < 1e-12, (worst_mj, worst_ours)
    # the visual meshes (inline in the file) come back on the right links
    n, err = _visual_error(s, mm, d, s0.random_q(rng))
    assert n == mm.ngeom == 33 and err < 1e-12, (n, err)
    # a cooperative circle on the read-back model is the registered system's circle
    task, task0 = cg.cooperative_task(s, "circle"), cg.cooperative_task(s0, "circle")
    for q in (s0.q0, s0.random_q(rng, 0.5)):
        np.testing.assert_allclose(task.log(q), task0.log(q), atol=1e-12)
        np.testing.assert_allclose(task.jacobian(q), task0.jacobian(q), atol=1e-11)
