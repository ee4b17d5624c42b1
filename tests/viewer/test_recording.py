"""Reading what the experiments and the physics simulations write into a Recording (no browser)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import coop_ga as cg
from coop_ga.viewer.recording import DEFAULT_DT, load_recording, trajectory_keys


def _write(folder, name="trajectory.npz", metrics=None, **arrays):
    folder.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(folder / name, **arrays)
    if metrics is not None:
        (folder / "metrics.json").write_text(json.dumps(metrics))
    return folder / name


def test_reaching_layout(tmp_path, load_system, rng):
    """trajectory.npz of experiments/reaching.py: q, t, target_versor; system and kind from metrics.json."""
    s = load_system("three_iiwa14")
    Q = s.q0 + 0.01 * rng.normal(size=(7, s.nq))
    V = cg.Similarity.from_parts((0.1, 0.0, 0.5), (1, 0, 0), 0.2, 0.4)
    f = _write(
        tmp_path,
        q=Q,
        t=np.linspace(0, 0.6, 7),
        target_versor=V.coeffs,
        u=Q[:-1],
        metrics={"system": s.name, "kind": "circle"},
    )
    rec = load_recording(f)
    assert rec.system is s and rec.kind == "circle" and rec.key == "q" and rec.alternatives == ()
    assert np.array_equal(rec.q, Q) and np.allclose(rec.t, np.linspace(0, 0.6, 7))
    assert np.allclose(rec.target.coeffs, V.coeffs)
    assert load_recording(f, kind="none").kind is None
    assert load_recording(f, kind="sphere").kind == "sphere"


def test_several_trajectories_and_their_times(tmp_path, load_system):
    """trajectories.npz of nullspace_secondary / line_constraint: <name>_trajectory or <name>_q, <name>_t or t;
    a 3-vector target is a target point; without times, metrics' dt_s per row."""
    s = load_system("three_iiwa14")
    A, B = np.tile(s.q0, (5, 1)), np.tile(s.q0, (4, 1))
    f = _write(
        tmp_path,
        "trajectories.npz",
        {"system": s.name, "kind": "circle", "dt_s": 0.02},
        direct_trajectory=A,
        nullspace_trajectory=B,
        nullspace_t=np.arange(4) * 0.5,
        target=np.array([0.1, 0.2, 0.3]),
        points=np.zeros((5, 3)),
    )
    rec = load_recording(f)
    assert rec.key == "direct_trajectory" and rec.alternatives == ("nullspace_trajectory",)
    assert np.allclose(rec.t, 0.02 * np.arange(5))  # no t of length 5: dt_s per row
    assert rec.target is None and np.array_equal(rec.target_point, [0.1, 0.2, 0.3])
    rec = load_recording(f, key="nullspace_trajectory")
    assert np.allclose(rec.t, [0.0, 0.5, 1.0, 1.5])
    with pytest.raises(cg.InvalidInputError, match=r"not a trajectory of this file.*direct_trajectory"):
        load_recording(f, key="points")


def test_trajectory_keys_filter_by_name_shape_and_columns():
    data = {
        "q": np.zeros((3, 4)),
        "arm_q_seed": np.zeros((3, 5)),
        "q_no_avoidance": np.zeros((3, 4)),
        "end_points": np.zeros((3, 4)),
        "q_closed": np.zeros(4),
        "scenario1_q": np.zeros((1, 4)),
    }
    assert trajectory_keys(data) == ["q", "arm_q_seed", "q_no_avoidance"]
    assert trajectory_keys(data, 4) == ["q", "q_no_avoidance"]


def test_hexapod_layout_plays_on_the_floating_hexapod(tmp_path, load_system, rng):
    """q (T, 18) + body (T, 7) (position, quaternion xyzw) → the free-flyer hexapod, q = [body, legs] (the
    quaternion as it is): its feet are the fixed hexapod's feet moved by the body pose; a non-unit quaternion is
    refused."""
    from scipy.spatial.transform import Rotation

    fixed = load_system("hexapod")
    legs = fixed.q0 + 0.05 * rng.normal(size=(3, 18))
    rot = Rotation.from_euler("zyx", [[0.3, 0.1, -0.2], [0.0, 0.0, 0.0], [-0.5, 0.2, 0.1]])
    body = np.hstack([[[0.1, 0.0, 0.12], [0.0, 0.0, 0.1], [0.2, -0.1, 0.15]], rot.as_quat()])
    rec = load_recording(_write(tmp_path, q=legs, body=body, t=np.arange(3.0)))
    assert rec.system is cg.systems.load("hexapod", free_flyer=True) and rec.q.shape == (3, 25)
    np.testing.assert_array_equal(rec.q, np.hstack([body, legs]))
    for k in range(3):
        feet = rec.system.end_points(rec.q[k])
        expected = fixed.end_points(legs[k]) @ rot[k].as_matrix().T + body[k, :3]
        assert np.allclose(feet, expected, atol=1e-12)
    body[1, 3:] *= 1.1
    with pytest.raises(cg.InvalidInputError, match=r"frame 1.*norm 1\.1"):
        load_recording(_write(tmp_path / "bad", q=legs, body=body, t=np.arange(3.0)))


def test_errors_name_the_problem(tmp_path, load_system):
    s = load_system("three_iiwa14")
    f = _write(tmp_path / "a", q=np.tile(s.q0, (3, 1)))
    with pytest.raises(cg.InvalidInputError, match=r"metrics\.json naming the system"):
        load_recording(f)
    assert load_recording(f, system="three_iiwa14").q.shape == (3, s.nq)
    assert np.allclose(load_recording(f, system=s).t, DEFAULT_DT * np.arange(3))
    with pytest.raises(cg.InvalidInputError, match="no trajectory"):
        load_recording(_write(tmp_path / "b", x=np.zeros((3, 2))), system=s)
    with pytest.raises(cg.InvalidInputError, match="no such file"):
        load_recording(tmp_path / "missing.npz")
    with pytest.raises(cg.InvalidInputError, match=r"without log\.npz"):
        load_recording(tmp_path / "a")
    with pytest.raises(cg.UnknownNameError):
        load_recording(f, system="no_such_system")


def test_physics_log(tmp_path, load_system):
    """A coop_ga.sim run folder: q = qpos[:, qpos_index], the free box read from model.xml and posed per frame."""
    pytest.importorskip("mujoco")
    from coop_ga.sim import Box, Simulation, build_scene

    s = load_system("three_iiwa14")
    box = Box(name="box", size=(0.1, 0.2, 0.06), pos=(0.0, 0.0, 0.3), rgba=(0.2, 0.4, 0.8, 1.0))
    scene = build_scene(s, objects=[box], floor=0.0, visuals=False, collision=False)
    log = Simulation(scene).run(0.05)
    folder = log.save(tmp_path / "run")
    rec = load_recording(folder)
    assert rec.system is s and rec.key == "qpos" and rec.base is None
    assert np.array_equal(rec.q, log.q) and np.array_equal(rec.t, log.time)
    (b,) = rec.bodies
    assert b.name == "box" and len(b.shapes) == 1
    sh = b.shapes[0]
    assert sh.kind == "box" and np.allclose(sh.size, (0.05, 0.1, 0.03)) and np.allclose(sh.rgba, (0.2, 0.4, 0.8, 1.0))
    assert np.allclose(b.positions, log.object_positions("box"), atol=1e-12)
    assert b.positions[-1, 2] < 0.3 - 1e-3  # it falls
    assert np.allclose(np.linalg.norm(b.wxyz, axis=1), 1.0)
    assert load_recording(folder / "log.npz").q.shape == log.q.shape


def test_physics_log_with_a_floating_base(tmp_path, load_system):
    """A floating hexapod: played on the free-flyer hexapod, its body pose from the free joint (MuJoCo's w x y z
    → x y z w); the feet drawn (free-flyer FK) are MuJoCo's foot sites of the logged states.  Another system
    with a floating base keeps its base poses (Recording.base)."""
    mujoco = pytest.importorskip("mujoco")
    from coop_ga.sim import Simulation, build_scene

    s = load_system("hexapod")
    scene = build_scene(s, floor=None, visuals=False, collision=False, floating_base=True)
    sim = Simulation(scene, base_pose=((0.0, 0.0, 0.3), (np.cos(0.2), 0.0, 0.0, np.sin(0.2))))
    log = sim.run(0.03)
    rec = load_recording(log.save(tmp_path / "run"))
    assert rec.base is None and rec.system is cg.systems.load("hexapod", free_flyer=True)
    assert rec.q.shape == (len(log.time), 25) and rec.key == "qpos"
    np.testing.assert_array_equal(rec.q[:, 7:], log.q)
    model = mujoco.MjModel.from_xml_string((tmp_path / "run" / "model.xml").read_text())
    data = mujoco.MjData(model)
    for k in (0, len(log.time) - 1):
        data.qpos[:] = log.qpos[k]
        mujoco.mj_kinematics(model, data)
        sites = np.array([data.site_xpos[i] for i in scene.site_ids])
        assert np.allclose(rec.system.end_points(rec.q[k]), sites, atol=1e-9)
    a = scene.base_qpos
    np.testing.assert_allclose(rec.q[0, :7], log.qpos[0, [a, a + 1, a + 2, a + 4, a + 5, a + 6, a + 3]], atol=1e-15)
    # a floating base of another system: its root's world poses
    arm = load_system("three_iiwa14")
    scene = build_scene(arm, floor=None, visuals=False, collision=False, floating_base=True)
    log = Simulation(scene, base_pose=((0.0, 0.0, 0.3), (1.0, 0.0, 0.0, 0.0))).run(0.01)
    rec = load_recording(log.save(tmp_path / "arm"))
    assert rec.system is arm and rec.base is not None and rec.base.shape == (len(log.time), 4, 4)
    model = mujoco.MjModel.from_xml_string((tmp_path / "arm" / "model.xml").read_text())
    data = mujoco.MjData(model)
    k = len(log.time) - 1
    data.qpos[:] = log.qpos[k]
    mujoco.mj_kinematics(model, data)
    B = rec.base[k]
    feet = arm.end_points(rec.q[k]) @ B[:3, :3].T + B[:3, 3]
    assert np.allclose(feet, [data.site_xpos[i] for i in scene.site_ids], atol=1e-9)
