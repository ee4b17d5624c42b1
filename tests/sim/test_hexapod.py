"""The hexapod's MuJoCo scene: the gate against Pinocchio (the free-flyer hexapod), terrain heights against Terrain,
the planner's leg capsules, sensors and servo damping, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("mujoco")

import mujoco
import pinocchio as pin

from coop_ga import systems
from coop_ga.errors import InvalidInputError
from coop_ga.legged import Terrain
from coop_ga.legged.body import BodyState
from coop_ga.legged.contact import leg_capsules
from coop_ga.legged.legs import hexapod_legs
from coop_ga.sim.hexapod import HEXAPOD_LEGS, HexapodGeometry, hexapod_scene, terrain_geoms

_SCENES: dict[str, object] = {}


def scene(kind: str = "flat"):
    if kind not in _SCENES:
        _SCENES[kind] = hexapod_scene(Terrain.make(kind), visuals=False)
    return _SCENES[kind]


def _free_flyer_qpos(hs, data, q25: np.ndarray) -> None:
    """The free-flyer hexapod's q (25,) = [position, quaternion x y z w, legs] written into MuJoCo's qpos: the
    free joint holds position then quaternion w x y z, the legs go to their qpos addresses."""
    a = hs.scene.base_qpos
    data.qpos[a : a + 3] = q25[:3]
    data.qpos[a + 3 : a + 7] = q25[[6, 3, 4, 5]]
    data.qpos[hs.scene.qpos_index] = q25[7:]


def _velocity_map(hs, R: np.ndarray) -> np.ndarray:
    """S (nv_mj, 24) with MuJoCo's qvel = S v for the free flyer's v = [v_local, ω_local, q̇_legs]: the free joint's
    qvel is [world linear velocity of the body origin (R v_local), local angular velocity (ω)]."""
    b = hs.scene.base_qvel
    S = np.zeros((hs.model.nv, 24))
    S[b : b + 3, 0:3] = R
    S[b + 3 : b + 6, 3:6] = np.eye(3)
    S[hs.scene.qvel_index, 6 + np.arange(18)] = 1.0
    return S


def test_feet_body_and_mass_matrix_equal_pinocchio_of_the_free_flyer() -> None:
    """The gate: at random body poses and in-limit leg joints the MuJoCo feet, body and foot velocities equal
    Pinocchio's of the free-flyer hexapod (load("hexapod", free_flyer=True)), and so does the mass matrix after the
    velocity map: M_pin = Sᵀ M_mj S (_velocity_map)."""
    hs = scene()
    ff = systems.load("hexapod", free_flyer=True)
    m, d = ff.model, ff.model.createData()
    legs = hexapod_legs()
    rng = np.random.default_rng(3)
    data = mujoco.MjData(hs.model)
    err_feet = err_body = err_vel = err_M = 0.0
    for _ in range(25):
        q = np.empty(18)
        q[legs.q_index.ravel()] = rng.uniform(legs.q_lower, legs.q_upper).ravel()
        state = BodyState.from_rpy(rng.uniform(-1, 1, 3), rng.uniform(-0.6, 0.6, 3), q)
        q25 = state.free_flyer_q()
        v = rng.normal(size=24)
        pin.forwardKinematics(m, d, q25, v)
        pin.updateFramePlacements(m, d)
        M_pin = pin.crba(m, d, q25)
        M_pin = np.triu(M_pin) + np.triu(M_pin, 1).T  # crba fills the upper triangle
        _free_flyer_qpos(hs, data, q25)
        S = _velocity_map(hs, state.rotation)
        data.qvel[:] = S @ v
        mujoco.mj_forward(hs.model, data)
        M_mj = np.zeros((hs.model.nv, hs.model.nv))
        mujoco.mj_fullM(hs.model, data, M_mj)  # this MuJoCo: mj_fullM(model, data, dst)
        err_M = max(err_M, float(np.abs(S.T @ M_mj @ S - M_pin).max() / np.abs(M_pin).max()))
        vel6 = np.zeros(6)
        for i, leg in enumerate(HEXAPOD_LEGS):
            f = m.getFrameId(f"{leg}_foot")
            err_feet = max(err_feet, float(np.abs(data.site_xpos[hs.foot_sites[i]] - d.oMf[f].translation).max()))
            mujoco.mj_objectVelocity(hs.model, data, mujoco.mjtObj.mjOBJ_SITE, hs.foot_sites[i], vel6, 0)
            v_pin = pin.getFrameVelocity(m, d, f, pin.LOCAL_WORLD_ALIGNED).linear
            err_vel = max(err_vel, float(np.abs(vel6[3:] - v_pin).max()))
        b = hs.scene.id_of("body", hs.scene.base_body)
        M = d.oMf[m.getFrameId("base_link")]
        err_body = max(err_body, float(np.abs(data.xpos[b] - M.translation).max()))
        err_body = max(err_body, float(np.abs(data.xmat[b].reshape(3, 3) - M.rotation).max()))
        # set_base_pose takes the same quaternion in MuJoCo's order
        d2 = mujoco.MjData(hs.model)
        hs.scene.set_q(d2, q)
        hs.scene.set_base_pose(d2, state.position, np.roll(state.quaternion_xyzw(), 1))
        np.testing.assert_allclose(d2.qpos, data.qpos, rtol=0, atol=1e-15)
    assert err_feet < 1e-9 and err_body < 1e-9 and err_vel < 1e-9, (err_feet, err_body, err_vel)
    assert err_M < 1e-8, err_M


@pytest.mark.parametrize("kind", ["flat", "slope", "steps", "random"])
def test_terrain_surface_equals_terrain_height(kind: str) -> None:
    hs = scene(kind)
    (x0, x1), (y0, y1) = hs.region
    rng = np.random.default_rng(7)
    xy = np.column_stack([rng.uniform(x0 + 1e-3, x1 - 1e-3, 300), rng.uniform(y0 + 1e-3, y1 - 1e-3, 300)])
    err = np.abs(hs.surface_height(xy) - hs.terrain.height(xy))
    assert np.all(np.isfinite(err)) and float(err.max()) < 1e-9
    if kind in ("steps", "random"):  # grid terrains end at the region: no ground beyond it
        assert math.isnan(float(hs.surface_height(np.array([x1 + 0.5, 0.0]))))


def test_collision_geometry_is_the_planners_and_the_body_box() -> None:
    hs = scene()
    caps = {c.link: c for c in hs.scene.capsules}
    planner = {c.link: c for c in leg_capsules(hexapod_legs(), systems.load("hexapod"))}
    assert set(caps) == set(planner) - {"base_link"}
    for name, c in caps.items():
        p = planner[name]
        assert c.radius == p.radius and np.array_equal(c.a, p.a) and np.array_equal(c.b, p.b)
    assert hs.foot_radius == pytest.approx(0.009) == hexapod_legs().foot_radius
    assert np.allclose(2 * hs.model.geom_size[hs.body_geom], (0.24, 0.16, 0.04))
    # servo back-EMF damping: stall torque / no-load speed
    lim = hs.scene.system.limits
    assert np.allclose(hs.model.dof_damping[hs.scene.qvel_index], lim.effort / lim.velocity)


def test_no_femur_reaches_the_body_box_within_the_joint_limits() -> None:
    """Over the joint range (coxa ±70°, femur up to +90°, a grid), no femur capsule touches the body box: the
    robot cannot touch itself in the scene (the PCA-fitted femur, radius 42.6 mm, met it from ~1.2 rad of lift)."""
    hs = scene()
    m = hs.model
    d = mujoco.MjData(m)
    a, qi = hs.scene.base_qpos, hs.scene.qpos_index
    assert a is not None
    lim = hs.scene.system.limits
    closest = math.inf
    for leg in range(6):
        for c in np.linspace(lim.lower[3 * leg], lim.upper[3 * leg], 9):
            for f in np.linspace(0.0, lim.upper[3 * leg + 1], 17):
                q = np.tile([0.0, 0.3, -1.4], 6)
                q[3 * leg : 3 * leg + 2] = (c, f)
                d.qpos[:] = 0.0
                d.qpos[a : a + 4] = (0.0, 0.0, 0.5, 1.0)
                d.qpos[qi] = q
                mujoco.mj_forward(m, d)
                closest = min(closest, mujoco.mj_geomDistance(m, d, hs.femur_geoms[leg], hs.body_geom, 0.05, None))
                assert hs.terrain_contacts(d)["self"] == 0
    assert 0.0 < closest < 0.005  # it comes close at the corners of the range, never into the box


def test_contact_time_constant() -> None:
    """0.01 s by default (MuJoCo's own is 0.02 s; module docstring), or as asked, on every colliding geom (feet, legs, body, terrain), so that every
    contact has it; below two physics steps it is refused."""
    hs = scene("random")
    collide = (hs.model.geom_contype > 0) | (hs.model.geom_conaffinity > 0)
    assert np.all(hs.model.geom_solref[collide] == (0.01, 1.0))
    stiff = hexapod_scene(Terrain.random(seed=0), geometry=HexapodGeometry(contact_timeconst=0.005), visuals=False)
    m = stiff.model
    ids = [*stiff.foot_geoms, *stiff.tibia_geoms, *stiff.femur_geoms, stiff.body_geom, *stiff.terrain_geom_ids]
    assert np.all(m.geom_solref[ids] == (0.005, 1.0))
    with pytest.raises(InvalidInputError, match="two physics steps"):
        hexapod_scene(geometry=HexapodGeometry(contact_timeconst=0.0015), visuals=False)
    with pytest.raises(InvalidInputError, match="contact_timeconst"):
        HexapodGeometry(contact_timeconst=0.0)


def test_contact_time_constant_sets_the_sink_depth() -> None:
    """Standing still on flat ground (1.87 kg on six feet, 3.06 N each), the foot balls sink 0.89 mm into it at
    MuJoCo's 20 ms and 0.39 mm at 10 ms (a rubber tip: 0.24 mm): the depth falls faster than τ."""
    from coop_ga.sim import Simulation
    from coop_ga.sim.walking import HexapodWalker, VelocityCommand, WalkingOptions, standing_start

    sink = {}
    for tau in (0.02, 0.01):
        hs = hexapod_scene(Terrain.flat(), geometry=HexapodGeometry(contact_timeconst=tau), visuals=False)
        opt = WalkingOptions()
        q0, pose = standing_start(hs, opt)
        sim = Simulation(hs.scene, HexapodWalker(hs, VelocityCommand.constant(0.0), opt), q=q0, base_pose=pose)
        sim.run(0.5)
        d = sim.data
        feet = [k for k in range(d.ncon) if set(d.contact.geom[k]) & set(hs.foot_geoms.tolist())]
        assert len(feet) == 6 and hs.touch(d) == pytest.approx(3.06, abs=0.02)
        sink[tau] = -d.contact.dist[feet]
    assert sink[0.02] == pytest.approx(0.89e-3, abs=0.02e-3)
    assert sink[0.01] == pytest.approx(0.39e-3, abs=0.02e-3)


def test_sensors_of_a_robot_standing_still() -> None:
    """Standing on its six feet: the touch sensors carry the weight, the IMU reads R_WB, zero rate and +g."""
    from coop_ga.sim import Simulation
    from coop_ga.sim.walking import HexapodWalker, VelocityCommand, WalkingOptions, standing_start

    hs = scene()
    opt = WalkingOptions()
    q0, pose = standing_start(hs, opt)
    sim = Simulation(hs.scene, HexapodWalker(hs, VelocityCommand.constant(0.0), opt), q=q0, base_pose=pose)
    sim.run(0.5)
    mass = float(sum(hs.model.body_mass))
    touch = hs.touch(sim.data)
    assert touch.sum() == pytest.approx(mass * 9.81, rel=0.02) and np.all(touch > 0.5)
    quat, gyro, acc = hs.imu(sim.data)
    assert np.allclose(quat, hs.scene.base_pose(sim.data)[1], atol=1e-9)
    assert np.abs(gyro).max() < 1e-3 and acc == pytest.approx([0.0, 0.0, 9.81], abs=0.02)
    assert hs.terrain_contacts(sim.data) == {"foot": 6, "shin": 0, "femur": 0, "body": 0, "self": 0}


def test_foot_normals_tell_a_tread_from_a_riser() -> None:
    """The feet's contact normals (a foot force sensor; a touch sensor gives only the force): +z on a tread, the
    riser's outward normal when the front balls are pressed 0.5 mm into its face with every foot 0.5 mm above the
    floor (a 12 mm riser: a taller one meets the shin capsule, wider than the ball, first — it then carries the
    force and the ball none)."""
    from coop_ga.sim.walking import WalkingOptions, standing_start

    hs = hexapod_scene(Terrain.steps(step_height=0.012, start_x=0.15), visuals=False)
    q0, (pos, quat) = standing_start(scene(), WalkingOptions())  # standing on flat ground
    r = hs.foot_radius
    lf, rf = HEXAPOD_LEGS.index("lf"), HEXAPOD_LEGS.index("rf")
    feet = scene().feet_world(scene().scene.make_data(q0, base_pose=(pos, quat)))
    d = hs.scene.make_data(q0, base_pose=(pos + np.array([0.0, 0.0, -0.0005]), quat))
    n = hs.foot_normals(d)
    assert np.all(n[:, 2] > 0.999), n  # every ball 0.5 mm into the ground floor (x < 0.15 m)
    shift = np.array([0.15 - r + 0.0005 - feet[lf, 0], 0.0, 0.0005])  # front balls into the riser
    d = hs.scene.make_data(q0, base_pose=(pos + shift, quat))
    n = hs.foot_normals(d)
    for i in range(6):
        if i in (lf, rf):
            assert n[i] == pytest.approx([-1.0, 0.0, 0.0], abs=1e-6), (i, n[i])
        else:
            assert np.all(n[i] == 0.0), (i, n[i])


def test_bad_input_is_refused() -> None:
    with pytest.raises(InvalidInputError, match="Terrain"):
        terrain_geoms("flat", ((0, 1), (0, 1)))
    tilted = Terrain("random", np.array([0.0]), np.zeros(0), np.array([[[0.1, 0.0, 1.0, 0.0], [0.0, 0.0, 1.0, 0.0]]]))
    with pytest.raises(InvalidInputError, match="tilted"):
        terrain_geoms(tilted, ((-1, 1), (-1, 1)))
    with pytest.raises(InvalidInputError, match="region"):
        hexapod_scene(Terrain.flat(), region=((1, 0), (0, 1)))
    with pytest.raises(InvalidInputError, match="impratio"):
        hexapod_scene(Terrain.flat(), impratio=0.0)
    with pytest.raises(InvalidInputError, match="body_box"):
        HexapodGeometry(body_box=(0.1, 0.0, 0.1))
