"""Offscreen rendering: the GL probe and its error, frames with overlays, PNG/GIF/MP4 writers, a log rendered."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("mujoco")

from coop_ga import cooperative_task
from coop_ga.errors import CoopGAError, InvalidInputError, RendererUnavailableError
from coop_ga.sim import Ball, Simulation, build_scene, render
from coop_ga.sim.render import (
    Camera,
    Renderer,
    add_force,
    add_primitive,
    add_sphere,
    render_log,
    write_png,
    write_video,
)


def test_no_gl_context_is_a_clear_error(monkeypatch) -> None:
    monkeypatch.setattr(render, "_STATUS", None)
    monkeypatch.setattr(render, "_candidates", lambda: ("nosuchgl",))
    ok, why = render.gl_status()
    assert not ok and "nosuchgl" in why
    with pytest.raises(RendererUnavailableError, match=r"EGL.*OSMesa.*MUJOCO_GL"):
        render.require_gl()
    with pytest.raises(RendererUnavailableError):
        Renderer(build_scene_cached())


_SCENES: dict[str, object] = {}


def build_scene_cached():
    if "iiwa" not in _SCENES:
        from coop_ga import systems

        s = systems.load("three_iiwa14")
        _SCENES["iiwa"] = build_scene(s, objects=[Ball(name="ball", radius=0.05, mass=0.2, pos=(0, 0, 0.05))])
    return _SCENES["iiwa"]


@pytest.fixture(scope="module")
def gl():
    ok, why = render.gl_status()
    if not ok:
        pytest.skip(f"no OpenGL context here: {why}")
    return why


def _magenta(img: np.ndarray) -> int:
    return int(np.count_nonzero((img[..., 0] > 150) & (img[..., 1] < 90) & (img[..., 2] > 150)))


def test_frame_and_overlays(gl, tmp_path) -> None:
    sc = build_scene_cached()
    s = sc.system
    d = sc.make_data()
    X = cooperative_task(s, "circle").primitive(s.q0)
    cam = Camera((0.0, 0.0, 0.4), 2.0, 90.0, -30.0)
    with Renderer(sc, 320, 240, cam) as r:
        plain = r.frame(d)
        with_circle = r.frame(d, [lambda scn: add_primitive(scn, X, rgba=(1, 0, 1, 1), width=0.01)])
        with_ball = r.frame(d, [lambda scn: add_sphere(scn, (0.0, 0.0, 0.4), 0.1, (1, 0, 1, 1))])
        forces = r.frame(
            d, [lambda scn: [add_force(scn, p, (0, 0, 30.0), rgba=(1, 0, 1, 1)) for p in s.end_points(s.q0)]]
        )
    assert plain.shape == (240, 320, 3) and plain.dtype == np.uint8 and plain.std() > 10
    assert _magenta(plain) < 20  # nothing magenta in the scene itself
    assert _magenta(with_circle) > 300 and _magenta(with_ball) > 300 and _magenta(forces) > 40
    assert write_png(tmp_path / "f.png", with_circle).stat().st_size > 1000
    with pytest.raises(InvalidInputError, match="offscreen buffer"):
        Renderer(sc, 4000, 3000)


def test_videos(gl, tmp_path, monkeypatch) -> None:
    from PIL import Image

    frames = [np.full((40, 60, 3), v, np.uint8) for v in (0, 100, 200)]
    p = write_video(tmp_path / "v.gif", frames, fps=10)
    im = Image.open(p)
    assert im.n_frames == 3 and im.size == (60, 40)
    monkeypatch.setattr(render.shutil, "which", lambda name: None)
    with pytest.raises(CoopGAError, match="ffmpeg"):
        write_video(tmp_path / "v.mp4", frames)
    with pytest.raises(InvalidInputError, match=r"\.gif or \.mp4"):
        write_video(tmp_path / "v.avi", frames)
    with pytest.raises(InvalidInputError, match="uint8"):
        write_video(tmp_path / "v.gif", [np.zeros((4, 4, 3))])


def test_render_log(gl, tmp_path) -> None:
    sc = build_scene_cached()
    log = Simulation(sc, q=sc.system.q0).run(0.2)  # no torque: the arms start to fall
    frames = render_log(log, tmp_path / "run.gif", fps=25, width=160, height=120)
    assert len(frames) == 6  # rows 0, 40, …, 200 of the 201: one every 1/25 s
    assert np.abs(frames[0].astype(int) - frames[-1].astype(int)).max() > 50  # the arms moved
    from PIL import Image

    assert Image.open(tmp_path / "run.gif").n_frames == 6
