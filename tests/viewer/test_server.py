"""The viewer's server without a browser: a scripted client drags the gizmo, the robots follow; playback pages."""

from __future__ import annotations

import numpy as np
import pytest

import coop_ga as cg

pytest.importorskip("viser")

from coop_ga.viewer import play, play_file, serve
from coop_ga.viewer.__main__ import main

from .client import check_primitive_follows_the_gizmo, drag_gizmo, wait_for


@pytest.fixture
def teleop_viewer():
    v = serve(cg.cooperative_task("three_iiwa14", "circle"), port=0, block=False)
    yield v
    v.stop()


def test_a_client_drags_the_gizmo_and_the_robots_follow(teleop_viewer):
    check_primitive_follows_the_gizmo(teleop_viewer)
    assert teleop_viewer.frames > 10
    assert "control rate" in teleop_viewer.page.text.content


def test_hold_and_reset_buttons_move_the_gizmo(teleop_viewer):
    v = teleop_viewer
    s = v.session
    p0, w0, _ = s.handle_pose()
    drag_gizmo(v.port, "/gizmo", p0 + [0.05, 0.0, 0.0], w0)
    wait_for(lambda: not np.allclose(s.q, s.q0), 30, "the robots to move")
    v.page._reset()
    assert np.allclose(v.page.gizmo.position, p0) and float(v.page.scale.value) == pytest.approx(1.0)
    assert s.target is s.home


def test_playback_page_draws_each_frame(load_system):
    s = load_system("three_iiwa14")
    Q = s.q0 + np.linspace(0.0, 0.2, 6)[:, None] * np.sin(np.arange(s.nq))[None, :]
    task = cg.cooperative_task(s, "circle")
    v = play(s, Q, "circle", t=0.1 * np.arange(6), block=False, port=0)
    try:
        page = v.page
        page.slider.value = 3
        X = task.primitive(Q[3])
        drawn = np.asarray(page.current._nodes["lines"].points, float).reshape(-1, 3)
        assert np.allclose(np.linalg.norm(drawn - cg.center(X), axis=1), cg.radius(X), atol=1e-5)
        assert page.clock.content.startswith("t = 0.300 s")
        ends = np.asarray(page.dots._h.points, float)
        assert np.allclose(ends, task.points(Q[3]), atol=1e-6)
        assert np.asarray(page.paths._h.points).shape == (3 * 3, 2, 3)  # 3 end points × 3 segments up to frame 3
        page.toggle()
        wait_for(lambda: not page.playing or int(page.slider.value) != 3, 30, "playback to advance")
    finally:
        v.stop()
    with pytest.raises(cg.InvalidInputError, match="trajectory must be"):
        play(s, Q[:, :5], block=False, port=0)
    with pytest.raises(cg.InvalidInputError, match="one time per frame"):
        play(s, Q, t=np.arange(3), block=False, port=0)


def test_play_file_of_a_physics_log_draws_the_box(tmp_path, load_system):
    pytest.importorskip("mujoco")
    from coop_ga.sim import Box, Simulation, build_scene

    s = load_system("three_iiwa14")
    scene = build_scene(s, objects=[Box(name="box", pos=(0.0, 0.0, 0.3))], floor=0.0, visuals=False, collision=False)
    log = Simulation(scene).run(0.02)
    v = play_file(log.save(tmp_path / "run"), block=False, port=0)
    try:
        v.page.slider.value = len(log.time) - 1
        frame = v.page.bodies[0]._frame
        assert np.allclose(frame.position, log.object_positions("box")[-1], atol=1e-6)
    finally:
        v.stop()


def test_command_line(tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        main(["--help"])
    assert e.value.code == 0 and "--play" in capsys.readouterr().out
    with pytest.raises(SystemExit) as e:
        main([])
    assert e.value.code == 2
    assert main(["--play", str(tmp_path / "missing.npz"), "--port", "0"]) == 1
    assert "no such file" in capsys.readouterr().err
