"""Simulation: contact wrenches (sign, frame, moment arm), the controller's errors, saturation, control
period, disturbances, sensors, and logs that replay bit for bit with MuJoCo alone."""

from __future__ import annotations

import json

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")
pin = pytest.importorskip("pinocchio")

from coop_ga.errors import CoopGAError, InvalidInputError, NonFiniteError, UnknownNameError  # noqa: E402
from coop_ga.sim import Ball, Box, Disturbance, Simulation, build_scene, replay  # noqa: E402


def _gravity_pd(system, kp: float = 20.0, kd: float = 5.0):
    """τ = g(q) + M (kp (q0 − q) − kd q̇): a joint PD at the acceleration level, stable at 1 kHz."""
    model, data = system.model, system.model.createData()

    def ctl(t, q, qd, sensors):
        M = pin.crba(model, data, q)
        M = np.triu(M) + np.triu(M, 1).T
        return pin.computeGeneralizedGravity(model, data, q) + M @ (kp * (system.q0 - q) - kd * qd)

    return ctl


@pytest.fixture(scope="module")
def iiwa(load_system):
    return load_system("three_iiwa14")


# ---------------------------------------------------------------------- contact wrenches
def test_object_on_the_floor_carries_its_weight(iiwa) -> None:
    ball = Ball(name="ball", radius=0.05, mass=0.3, pos=(0.0, 0.0, 0.05))
    sim = Simulation(build_scene(iiwa, objects=[ball], visuals=False), _gravity_pd(iiwa))
    sim.run(0.5)
    w = sim.object_wrench("ball")
    g = -iiwa.model.gravity.linear[2]
    np.testing.assert_allclose(w[:3], [0.0, 0.0, 0.3 * g], atol=1e-9 * 0.3 * g + 1e-9)  # on the ball, by the floor
    np.testing.assert_allclose(w[3:], 0.0, atol=1e-9)  # through its centre
    pos, quat = sim.object_pose("ball")
    assert abs(pos[2] - 0.05) < 1e-3 and np.allclose(quat, [1, 0, 0, 0], atol=1e-6)


def _wall_in_front_of_flange(iiwa):
    """A static wall 3 mm beyond arm 0's end body, perpendicular to its tool axis z (at q0)."""
    sc = build_scene(iiwa, visuals=False)
    d, m = sc.make_data(), sc.model
    R = d.site_xmat[sc.site_ids[0]].reshape(3, 3)
    z, p = R[:, 2], d.site_xpos[sc.site_ids[0]]
    ext = -np.inf
    for g in np.flatnonzero(m.geom_bodyid == sc.end_bodies[0]):
        axis, (r, hl) = d.geom_xmat[g].reshape(3, 3)[:, 2], m.geom_size[g][:2]
        ext = max(ext, *(((d.geom_xpos[g] + s * hl * axis) - p) @ z + r for s in (1.0, -1.0)))
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, R.reshape(9))
    return Box(name="wall", size=(0.15, 0.15, 0.02), pos=p + (ext + 0.013) * z, quat=quat, static=True), z


def test_end_wrench_sign_frame_and_moment_arm(iiwa) -> None:
    """Arm 0 pushes its end body against a wall with F = 20 N along its tool axis (τ = g + Jᵀ F − M D q̇).
    At rest the wall's wrench on the end body is −F with no torque about the flange (Jᵀ is injective):
    the sign and the reference point of end_wrenches.  The same wrench from MuJoCo's own cfrc_ext
    (moved from the subtree centre of mass to the flange) agrees to round-off."""
    wall, z = _wall_in_front_of_flange(iiwa)
    sc = build_scene(iiwa, objects=[wall], visuals=False)
    model, data = iiwa.model, iiwa.model.createData()
    fid = model.getFrameId(iiwa.end_frames[0])
    F = 20.0 * z

    def push(t, q, qd, sensors):
        J = pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED)
        M = pin.crba(model, data, q)
        M = np.triu(M) + np.triu(M, 1).T
        return pin.computeGeneralizedGravity(model, data, q) + J[:3].T @ F - M @ (5.0 * qd)

    seen = []
    sim = Simulation(sc, lambda t, q, qd, s: (seen.append(s.end_wrenches), push(t, q, qd, s))[1])
    sim.run(1.5)
    w = sim.end_wrenches()
    assert {(sc.contact_name(c.geom1), sc.contact_name(c.geom2)) for c in sim.data.contact[: sim.data.ncon]} == {
        ("arm0_iiwa_link_7", "wall")
    }
    np.testing.assert_allclose(w[0, :3], -F, atol=0.05)
    np.testing.assert_allclose(w[0, 3:], 0.0, atol=0.01)
    np.testing.assert_array_equal(w[1:], 0.0)
    assert len(seen) == 1500 and np.all(seen[0] == 0.0)  # the controller read them (zero before the contact)
    np.testing.assert_array_equal(sim.end_forces(), w[:, :3])
    # against MuJoCo's own external force on the body (torque about the subtree centre of mass c)
    mujoco.mj_rnePostConstraint(sc.model, sim.data)
    b = sc.end_bodies[0]
    tc, fc = sim.data.cfrc_ext[b][:3], sim.data.cfrc_ext[b][3:]
    c, p = sim.data.subtree_com[sc.model.body_rootid[b]], sim.data.site_xpos[sc.site_ids[0]]
    np.testing.assert_allclose(w[0, :3], fc, atol=1e-10)
    np.testing.assert_allclose(w[0, 3:], tc + np.cross(c - p, fc), atol=1e-10)


# ---------------------------------------------------------------------- the controller
def test_controller_errors_name_the_time(iiwa) -> None:
    sc = build_scene(iiwa, visuals=False)

    def nan_late(t, q, qd, s):
        return np.full(21, np.nan) if t > 0.0025 else np.zeros(21)

    with pytest.raises(NonFiniteError, match=r"t = 0\.0030 s.*arm0_iiwa_joint_1"):
        Simulation(sc, nan_late).run(0.01)
    with pytest.raises(InvalidInputError, match=r"shape \(7,\) at t = 0\.0000 s.*\(21,\)"):
        Simulation(sc, lambda t, q, qd, s: np.zeros(7)).run(0.01)
    with pytest.raises(InvalidInputError, match="returned str"):
        Simulation(sc, lambda t, q, qd, s: "tau").run(0.01)
    with pytest.raises(InvalidInputError, match="callable"):
        Simulation(sc, "pd")
    with pytest.raises(InvalidInputError, match="multiple of the timestep"):
        Simulation(sc, control_dt=0.0025)
    with pytest.raises(InvalidInputError, match=r"timestep=0\.002"):
        Simulation(sc, dt=0.002)


def test_saturation_is_counted_or_refused(iiwa) -> None:
    sc = build_scene(iiwa, visuals=False)
    eff = iiwa.limits.effort

    def big(t, q, qd, s):
        return np.where(np.arange(21) == 3, 2.0 * eff, 0.0) if t < 0.005 else np.zeros(21)

    log = Simulation(sc, big).run(0.01)
    assert log.control_updates == 10 and log.saturated_updates == 5 and log.effort_ratio == pytest.approx(2.0)
    np.testing.assert_array_equal(log.tau[:5, 3], eff[3])  # clipped to the effort limit
    np.testing.assert_array_equal(log.tau_command[:5, 3], 2.0 * eff[3])
    with pytest.raises(CoopGAError, match=r"effort limit at t = 0\.0000 s on \['arm0_iiwa_joint_4'\]"):
        Simulation(sc, big, torque_limits="error").run(0.01)


def test_control_period_holds_the_torque(iiwa) -> None:
    sc = build_scene(iiwa, visuals=False)
    calls = []
    ctl = _gravity_pd(iiwa)
    sim = Simulation(sc, lambda t, q, qd, s: (calls.append(t), ctl(t, q, qd, s))[1], control_dt=0.004)
    log = sim.run(0.02)
    np.testing.assert_allclose(calls, np.arange(5) * 0.004, atol=1e-12)
    assert len(log.time) == 21 and log.control_updates == 5
    for k in range(20):
        np.testing.assert_array_equal(log.ctrl[k], log.ctrl[4 * (k // 4)])


# ---------------------------------------------------------------------- disturbances and sensors
def test_disturbance_schedule_is_exact() -> None:
    """A free ball in the air (no floor) pushed by 3 N along x during [0.1, 0.3) s: v_x = F Δt_on / m."""
    from coop_ga import systems

    s = systems.load("three_iiwa14")
    ball = Ball(name="ball", radius=0.05, mass=0.5, pos=(0.0, 0.0, 2.0))
    sc = build_scene(s, objects=[ball], visuals=False, floor=None)
    sim = Simulation(sc, _gravity_pd(s), disturbances=[Disturbance("ball", force=(3.0, 0.0, 0.0), start=0.1, stop=0.3)])
    log = sim.run(0.5)
    v, w = sim.object_velocity("ball")
    assert v[0] == pytest.approx(3.0 * 0.2 / 0.5, rel=1e-9) and v[1] == 0.0 and np.all(w == 0.0)
    assert v[2] == pytest.approx(s.model.gravity.linear[2] * 0.5, rel=1e-9)
    on = (log.time >= 0.1 - 1e-12) & (log.time < 0.3 - 1e-12)
    assert log.xfrc.shape == (501, 1, 6) and np.all(log.xfrc[on, 0, 0] == 3.0) and np.all(log.xfrc[~on, 0, 0] == 0.0)
    with pytest.raises(InvalidInputError, match="before the first step"):
        sim.add_disturbance(Disturbance("ball", force=(1, 0, 0)))
    with pytest.raises(UnknownNameError, match="no body named 'nope'"):
        Simulation(sc, disturbances=[Disturbance("nope")])
    with pytest.raises(InvalidInputError, match="after start"):
        Disturbance("ball", start=1.0, stop=0.5)


def test_named_mujoco_sensors_after_recompile(iiwa) -> None:
    """A sensor added to the spec works after recompile(); the value a controller reads at step k is the
    one of the state before the last physics step (state k − 1), at k = 0 that of the initial state."""
    sc = build_scene(iiwa, visuals=False)
    sc.spec.add_sensor(
        name="tip0", type=mujoco.mjtSensor.mjSENS_FRAMEPOS, objtype=mujoco.mjtObj.mjOBJ_SITE, objname=iiwa.end_frames[0]
    )
    sc2 = sc.recompile()
    assert sc2.model.nsensor == 1 and sc.model.nsensor == 0
    pd = _gravity_pd(iiwa)
    read = []
    sim = Simulation(sc2, lambda t, q, qd, s: (read.append(s.sensor("tip0")), pd(t, q, qd, s))[1], q=iiwa.q0 + 0.05)
    log = sim.run(0.003)
    for k, prev in ((0, 0), (1, 0), (2, 1)):
        d = sc2.make_data(log.q[prev], log.qd[prev])
        np.testing.assert_allclose(read[k], d.site_xpos[sc2.site_ids[0]], rtol=0, atol=1e-15)
    assert not np.allclose(read[2], read[0], rtol=0, atol=1e-12)  # the robot moved


# ---------------------------------------------------------------------- logs and replay
def test_log_replays_bit_for_bit_with_contact(iiwa, tmp_path) -> None:
    box = Box(
        name="box",
        size=(0.1, 0.1, 0.1),
        mass=1.0,
        pos=(0.0, 0.0, 0.3),
        quat=(0.9, 0.1, 0.3, 0.0) / np.linalg.norm([0.9, 0.1, 0.3]),
    )
    sc = build_scene(iiwa, objects=[box], visuals=False)
    sim = Simulation(
        sc, _gravity_pd(iiwa), q=iiwa.q0 + 0.1, disturbances=[Disturbance("box", torque=(0, 0, 0.5), start=0.3)]
    )
    log = sim.run(0.5)
    assert np.min(log.object_positions("box")[:, 2]) < 0.06  # it fell onto the floor: contacts happened
    out = log.save(tmp_path / "run")
    assert {p.name for p in out.iterdir()} == {"model.xml", "log.npz", "metrics.json"}
    z = np.load(out / "log.npz")
    T = 501
    assert z["time"].shape == (T,) and z["qpos"].shape == (T, sc.model.nq) and z["qvel"].shape == (T, sc.model.nv)
    assert z["ctrl"].shape == (T, sc.model.nu) and z["xfrc"].shape == (T, 1, 6)
    metrics = json.loads((out / "metrics.json").read_text())
    assert (
        metrics["object_body"] == "box" and metrics["steps"] == 500 and metrics["qpos_index"] == sc.qpos_index.tolist()
    )
    diff, states = replay(out, return_states=True)
    assert diff == 0.0 and states.shape == (T, sc.model.nq)
    # the replay can fail: a changed control is seen
    np.savez(out / "log.npz", **{**{k: z[k] for k in z.files}, "ctrl": z["ctrl"] * (1 + 1e-9)})
    assert replay(out) > 0.0


def test_saved_model_with_meshes_is_self_contained(load_system, tmp_path) -> None:
    """With visual meshes the folder still replays from model.xml alone (meshes inline, no other file)."""
    s = load_system("allegro")
    sc = build_scene(s, floor=None, objects=[Ball(name="ball", radius=0.02, mass=0.05, pos=(0.0, 0.0, 0.25))])
    assert sc.model.nmesh > 0
    log = Simulation(sc, lambda t, q, qd, sensors: np.zeros(s.nq)).run(0.05)
    out = log.save(tmp_path / "hand")
    assert sorted(p.name for p in out.iterdir()) == ["log.npz", "metrics.json", "model.xml"]
    assert replay(out) == 0.0
