"""build_scene: objects, limits, collision geometry and its exclusions, visuals, the MJCF text, the free base,
and the errors for bad input."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")
pin = pytest.importorskip("pinocchio")

from coop_ga import systems  # noqa: E402
from coop_ga.errors import CoopGAError, InvalidInputError, JointLimitWarning, UnknownNameError  # noqa: E402
from coop_ga.sim import Ball, Box, Cylinder, Simulation, build_scene  # noqa: E402
from coop_ga.sim import mjcf as mjcf_module  # noqa: E402
from coop_ga.sim.mjcf import check_reload  # noqa: E402


def _body_inertia_tensor(model, b: int) -> np.ndarray:
    R = np.empty(9)
    mujoco.mju_quat2Mat(R, model.body_iquat[b])
    R = R.reshape(3, 3)
    return R @ np.diag(model.body_inertia[b]) @ R.T


@pytest.fixture(scope="module")
def iiwa():
    return systems.load("three_iiwa14")


# ---------------------------------------------------------------------- objects
def test_object_inertias_and_poses(iiwa) -> None:
    I_given = np.array([[0.02, 0.003, 0.0], [0.003, 0.03, 0.001], [0.0, 0.001, 0.025]])
    objs = [
        Box(name="box", size=(0.3, 0.2, 0.1), mass=2.0, pos=(0.0, 0.0, 0.05)),
        Ball(name="ball", radius=0.04, mass=0.3, pos=(0.3, 0.0, 0.04)),
        Cylinder(name="can", radius=0.03, length=0.12, mass=0.4, pos=(-0.3, 0.0, 0.06), friction=0.7, condim=4),
        Box(name="odd", size=(0.1, 0.1, 0.1), mass=1.5, inertia=I_given, pos=(0.0, 0.3, 0.05), quat=(0.6, 0, 0, 0.8)),
        Box(name="table", size=(0.5, 0.5, 0.02), pos=(0.0, 0.0, -0.5), static=True),
    ]
    sc = build_scene(iiwa, objects=objs, visuals=False)
    m = sc.model
    expect = {
        "box": 2.0 / 12 * np.diag([0.04 + 0.01, 0.09 + 0.01, 0.09 + 0.04]),
        "ball": 0.4 * 0.3 * 0.04**2 * np.eye(3),
        "can": np.diag([0.4 * (3 * 0.03**2 + 0.12**2) / 12] * 2 + [0.5 * 0.4 * 0.03**2]),
        "odd": I_given,
    }
    for name, I in expect.items():
        b = sc.object_ids[name]
        np.testing.assert_allclose(_body_inertia_tensor(m, b), I, rtol=0, atol=1e-15)
        assert m.body_mass[b] == sc.object(name).mass
        np.testing.assert_array_equal(m.body_pos[b], sc.object(name).pos)
    assert set(sc.object_qpos) == {"box", "ball", "can", "odd"}  # the table is static: no joint
    assert m.body_mass[sc.object_ids["table"]] == 0.0 and m.body_jntnum[sc.object_ids["table"]] == 0
    can = m.geom("can_geom")
    assert can.condim[0] == 4 and can.friction[0] == 0.7
    np.testing.assert_allclose(m.geom("box_geom").size, [0.15, 0.1, 0.05])
    assert m.nv == iiwa.nq + 4 * 6 and m.neq == 0  # free bodies, nothing welded


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda: Box(name="b", size=(0.1, -0.1, 0.1)), "edge lengths"),
        (lambda: Box(name="b", quat=(1.0, 1.0, 0.0, 0.0)), "unit quaternion"),
        (lambda: Ball(name="b", radius=0.0), "must be >"),
        (lambda: Ball(name="b", mass=-1.0), "must be >"),
        (lambda: Box(name="b", inertia=(1.0, 1.0, 3.0)), "A \\+ B ≥ C"),
        (lambda: Box(name="b", inertia=np.ones((3, 3))), "inertia"),
        (lambda: Cylinder(name="c", friction=(1.0, -0.1, 0.0)), "friction"),
        (lambda: Ball(name="b", condim=2), "condim"),
        (lambda: Ball(name="", radius=0.1), "non-empty"),
        (lambda: Ball(name="b", pos=(0.0, np.nan, 0.0)), "NaN"),
    ],
)
def test_bad_objects(make, match) -> None:
    with pytest.raises(InvalidInputError, match=match):
        make()


def test_duplicate_and_clashing_object_names(iiwa) -> None:
    with pytest.raises(InvalidInputError, match="already used"):
        build_scene(iiwa, objects=[Ball(name="b"), Box(name="b")], visuals=False)
    with pytest.raises(InvalidInputError, match="already used"):
        build_scene(iiwa, objects=[Ball(name="arm0_iiwa_link_3")], visuals=False)
    with pytest.raises(InvalidInputError, match="Box, Ball or Cylinder"):
        build_scene(iiwa, objects=["box"], visuals=False)


def test_unknown_names(iiwa) -> None:
    sc = build_scene(iiwa, objects=[Ball(name="ball", pos=(0, 0, 0.1))], visuals=False)
    assert repr(sc).startswith("Scene('three_iiwa14', nq=21") and "ball" in repr(sc)
    with pytest.raises(UnknownNameError, match="ball"):
        sc.object("nope")
    sim = Simulation(sc)
    with pytest.raises(UnknownNameError, match="sensor"):
        sim.sensor("imu")
    with pytest.raises(UnknownNameError, match="nope"):
        sim.object_pose("nope")


# ---------------------------------------------------------------------- robot model
def test_limits_dynamics_and_motors() -> None:
    s = systems.load("allegro")  # the URDF has damping and friction
    sc = build_scene(s, visuals=False, floor=None)
    m = sc.model
    jid = [m.joint(n).id for n in s.joint_names]
    np.testing.assert_array_equal(m.jnt_range[jid, 0], s.q_lower)  # radians, not degrees
    np.testing.assert_array_equal(m.jnt_range[jid, 1], s.q_upper)
    np.testing.assert_array_equal(m.dof_damping[sc.qvel_index], s.model.damping)
    np.testing.assert_array_equal(m.dof_frictionloss[sc.qvel_index], s.model.friction)
    np.testing.assert_array_equal(m.actuator_ctrlrange[sc.actuator_index, 1], s.limits.effort)
    np.testing.assert_array_equal(m.actuator_forcerange[sc.actuator_index, 0], -s.limits.effort)
    assert np.all(m.actuator_trnid[sc.actuator_index, 0] == jid) and np.all(m.actuator_gear[:, 0] == 1.0)
    sc0 = build_scene(s, visuals=False, floor=None, damping=0.0, frictionloss=0.0, armature=[0.01] * s.nq)
    assert np.all(sc0.model.dof_damping == 0) and np.all(sc0.model.dof_frictionloss == 0)
    assert np.all(sc0.model.dof_armature == 0.01)
    with pytest.raises(InvalidInputError, match="damping"):
        build_scene(s, damping=[1.0, 2.0])
    with pytest.raises(InvalidInputError, match="integrator"):
        build_scene(s, integrator="verlet")
    # the system's limits, not the URDF's: with_limits reaches MuJoCo
    s2 = s.with_limits(position={"joint_1.0": (0.5, 1.2)}, effort=3.0)
    m2 = build_scene(s2, visuals=False, floor=None, collision=False).model
    np.testing.assert_array_equal(m2.joint("joint_1.0").range, [0.5, 1.2])
    assert np.all(m2.actuator_ctrlrange[:, 1] == 3.0)


def test_unbounded_effort_gives_an_unlimited_motor() -> None:
    lf = ("lf_coxa_joint", "lf_femur_joint", "lf_tibia_joint")
    s = systems.load("hexapod").with_limits(effort=dict.fromkeys(lf, math.inf))
    sc = build_scene(s, visuals=False, collision=False)
    unbounded = [s.joint_names.index(j) for j in lf]
    bounded = np.setdiff1d(np.arange(s.nv), unbounded)
    assert not np.any(sc.model.actuator_ctrllimited[sc.actuator_index[unbounded]]) and np.all(
        sc.model.actuator_ctrllimited[sc.actuator_index[bounded]]
    )


def test_massless_leaf_is_refused() -> None:
    m = pin.Model()
    j = m.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "j")
    f = m.addJointFrame(j)
    m.addFrame(pin.Frame("tip", j, f, pin.SE3.Identity(), pin.FrameType.OP_FRAME))
    s = systems.from_model(m, ["tip"], name="massless")
    with pytest.raises(InvalidInputError, match="without mass"):
        build_scene(s, collision=False)


# ---------------------------------------------------------------------- collision geometry
def test_collision_geometry_cannot_be_built() -> None:
    s = systems.from_model(systems.load("three_iiwa14").model, ["arm0_iiwa_flange"], name="bare")  # no visuals
    with pytest.raises(InvalidInputError, match=r"capsules=.*collision=False"):
        build_scene(s)
    sc = build_scene(s, collision=False)
    assert sc.model.ngeom == 1  # the floor


def test_self_collision_follows_the_collision_model(load_system) -> None:
    """The robot–robot contacts MuJoCo finds are exactly the self-distance rows of CollisionModel that are
    negative (three_franka: one capsule per body, so body-level exclusions are capsule-level)."""
    from coop_ga.collision import CollisionModel

    s = load_system("three_franka")
    sc = build_scene(s, visuals=False)
    cm = CollisionModel(s)
    m = sc.model
    d = sc.make_data()
    assert d.ncon == 0 and len(sc.excluded) > 0  # q0: overlapping neighbours are excluded, nothing touches
    geom_cap = {int(g): i for i, g in enumerate(sc.capsule_geoms)}
    self_rows = np.flatnonzero(np.array(cm.kinds) == "self")
    rng = np.random.default_rng(5)
    n_contacts = 0
    for _ in range(60):
        q = s.random_q(rng)
        dist = cm.distances(q)[self_rows]
        if np.any(np.abs(dist) < 1e-6):
            continue  # touching: either answer is right
        want = {tuple(sorted(cm.pairs[r])) for r, dd in zip(self_rows, dist) if dd < 0}
        sc.set_q(d, q)
        mujoco.mj_forward(m, d)
        got = set()
        for c in d.contact[: d.ncon]:
            if c.geom1 in geom_cap and c.geom2 in geom_cap:
                got.add(tuple(sorted((geom_cap[c.geom1], geom_cap[c.geom2]))))
        assert got == want
        n_contacts += len(got)
    assert n_contacts > 5  # the configurations did produce self-contacts
    # without self-collision every robot pair is excluded
    sc2 = build_scene(s, visuals=False, self_collision=False)
    assert len(sc2.excluded) > len(sc.excluded)


def test_object_inside_robot_is_refused_before_simulating(load_system) -> None:
    s = load_system("three_franka")
    tcp = s.end_points(s.q0)[0]
    sc = build_scene(s, objects=[Ball(name="ball", radius=0.05, pos=tcp)], visuals=False)
    with pytest.raises(InvalidInputError, match=r"ball.*mm.*move the object"):
        Simulation(sc)
    sunk = build_scene(s, objects=[Box(name="box", size=(0.2, 0.2, 0.2), pos=(0, 0, 0.05))], visuals=False)
    with pytest.raises(InvalidInputError, match=r"box – floor|floor – box"):
        Simulation(sunk)
    Simulation(sunk, penetration_tol=None)  # the check can be turned off
    q = s.q0.copy()
    q[3] = s.q_upper[3] + 0.1
    with pytest.warns(JointLimitWarning, match="arm0_panda_joint4"):
        sc.make_data(q)


# ---------------------------------------------------------------------- visuals and the MJCF text
def test_visuals_are_visual_only_and_the_text_reloads(load_system) -> None:
    s = load_system("allegro")
    sc = build_scene(s, floor=None)
    bare = build_scene(s, floor=None, visuals=False)
    m = sc.model
    vis = m.geom_group == 2
    assert vis.sum() == len(s.visual_model().geometryObjects) - sc.visual_skipped and m.nmesh > 0
    assert np.all(m.geom_contype[vis] == 0) and np.all(m.geom_conaffinity[vis] == 0)
    np.testing.assert_array_equal(m.body_mass, bare.model.body_mass)  # visuals carry no mass
    np.testing.assert_array_equal(m.body_inertia, bare.model.body_inertia)
    xml = sc.to_xml()
    assert "<mesh" in xml and "file=" not in xml  # meshes inline: the text is self-contained
    assert check_reload(m, xml) == []
    # the check can fail: a changed mass is found
    xml2 = re.sub(r'mass="([^"]+)"', lambda g: f'mass="{float(g.group(1)) * 1.001!r}"', xml, count=1)
    assert xml2 != xml and check_reload(m, xml2) == ["body_mass"]


def test_default_precision_would_not_reproduce_the_model(load_system, monkeypatch, tmp_path) -> None:
    sc = build_scene(load_system("three_iiwa14"), visuals=False)
    monkeypatch.setattr(mjcf_module, "_LIB", False)  # as if the precision setting did not exist
    short = sc.to_xml()
    assert {"body_pos", "body_ipos"} <= set(check_reload(sc.model, short))
    with pytest.raises(CoopGAError, match="does not reproduce"):
        sc.write_model(tmp_path / "model.xml")


# ---------------------------------------------------------------------- the free base
def test_floating_base_kinematics_and_fall(load_system) -> None:
    s = load_system("hexapod")
    sc = build_scene(s, floating_base=True, visuals=False)
    m = sc.model
    assert m.nq == 7 + s.nq and m.nv == 6 + s.nq and sc.base_qpos == 0
    b = m.body(sc.base_body)
    assert b.mass[0] == pytest.approx(s.model.inertias[0].mass, rel=1e-15)
    d = mujoco.MjData(m)
    pd = s.model.createData()
    rng = np.random.default_rng(3)
    for _ in range(20):
        q = s.random_q(rng)
        quat = rng.normal(size=4)
        quat /= np.linalg.norm(quat)
        pos = rng.uniform(-1, 1, 3)
        sc.set_base_pose(d, pos, quat)
        sc.set_q(d, q)
        mujoco.mj_kinematics(m, d)
        pin.framesForwardKinematics(s.model, pd, q)
        R = np.empty(9)
        mujoco.mju_quat2Mat(R, quat)
        for k, f in enumerate(s.end_frames):
            want = R.reshape(3, 3) @ pd.oMf[s.model.getFrameId(f)].translation + pos
            np.testing.assert_allclose(d.site_xpos[sc.site_ids[k]], want, atol=1e-12)
    # dropped from 0.2 m with its joints held by a PD: it falls onto its feet and stops
    with pytest.raises(InvalidInputError, match="floor"):
        Simulation(sc)  # at the origin its feet are 0.1 m in the floor
    d = Simulation(sc, base_pose=((0.0, 0.0, 0.2), (1.0, 0.0, 0.0, 0.0))).data
    for _ in range(1500):
        d.ctrl[sc.actuator_index] = 2.0 * (s.q0 - sc.q(d)) - 0.05 * sc.qd(d)
        mujoco.mj_step(m, d)
    pos, quat = sc.base_pose(d)
    assert 0.0 < pos[2] < 0.15 and abs(d.qvel[2]) < 0.05 and abs(quat[0]) > 0.99  # upright


def test_floating_base_needs_mass(load_system) -> None:
    m = pin.Model()  # a massless world-fixed part: a joint on the universe and nothing fixed to it
    j = m.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "j")
    m.appendBodyToJoint(j, pin.Inertia.FromSphere(1.0, 0.1), pin.SE3.Identity())
    m.addFrame(pin.Frame("tip", j, m.addJointFrame(j), pin.SE3.Identity(), pin.FrameType.OP_FRAME))
    with pytest.raises(InvalidInputError, match="no mass"):
        build_scene(systems.from_model(m, ["tip"], name="massless_base"), floating_base=True, collision=False)
    fixed = build_scene(load_system("hexapod"), visuals=False)
    with pytest.raises(InvalidInputError, match="floating_base=True"):
        fixed.set_base_pose(fixed.make_data(), (0, 0, 1))
