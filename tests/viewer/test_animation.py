"""coop_ga.viz.animate: a trajectory to a GIF offscreen (frames counted, frames differ, the camera fixed)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import coop_ga as cg
from coop_ga.viz.animation import _framing, _per_frame_primitives, frame_indices, write_video


@pytest.fixture(scope="module")
def motion():
    """three_iiwa14 moving its first arm: 12 rows, 0.01 s apart."""
    s = cg.systems.load("three_iiwa14")
    Q = np.tile(s.q0, (12, 1))
    Q[:, 0] += np.linspace(0.0, 0.8, 12)
    Q[:, 3] -= np.linspace(0.0, 0.5, 12)
    return s, Q


def _frames(path):
    from PIL import Image

    out = []
    with Image.open(path) as im:
        for i in range(im.n_frames):
            im.seek(i)
            out.append(np.asarray(im.convert("RGB"), dtype=int))
    return out


def test_frame_indices():
    assert frame_indices(12, 4).tolist() == [0, 4, 7, 11]
    assert frame_indices(5, 9).tolist() == [0, 1, 2, 3, 4]  # never more frames than rows
    assert frame_indices(7, 1).tolist() == [0]
    for n_rows, n in [(101, 51), (250, 17), (3, 2)]:
        idx = frame_indices(n_rows, n)
        assert len(idx) == n and idx[0] == 0 and idx[-1] == n_rows - 1 and np.all(np.diff(idx) >= 1)


def test_gif_has_the_frames_asked_for_and_they_differ(tmp_path, motion):
    s, Q = motion
    path = cg.viz.animate(s, Q, "circle", tmp_path / "a.gif", frames=4, backend="skeleton", fps=10)
    frames = _frames(path)
    assert len(frames) == 4
    assert all(f.shape == frames[0].shape for f in frames)
    for a, b in itertools.pairwise(frames):
        body = slice(a.shape[0] // 5, None)  # below the title "t = … s"
        assert np.mean(np.any(a[body] != b[body], axis=2)) > 1e-3  # the arm moved


def test_default_frame_count_is_real_time(tmp_path, motion):
    s, Q = motion
    path = cg.viz.animate(s, Q, None, tmp_path / "b.gif", fps=20, backend="skeleton", paths=False)
    assert len(_frames(path)) == round(0.11 * 20) + 1  # 0.11 s of motion at 20 frames per second


def test_mesh_renderer_frames(tmp_path, motion):
    """The default renderer (VTK meshes, or matplotlib meshes without an OpenGL context)."""
    s, Q = motion
    task = cg.cooperative_task(s, "circle")
    target = cg.control.displaced_target(task, s.q0, translation=(0.05, 0.0, 0.0))
    path = cg.viz.animate(s, Q, task.primitive, tmp_path / "c.gif", frames=2, target=target.apply(task.unit))
    a, b = _frames(path)
    assert a.shape == b.shape and np.mean(np.any(a != b, axis=2)) > 1e-3


def test_the_framing_box_holds_every_frame(motion):
    """The camera frames the 8 corners, so it is the same for every frame: every robot vertex of every frame, the
    primitives and the paths are inside the box."""
    from coop_ga.viz import robot_mesh

    s, Q = motion
    prims = _per_frame_primitives(s, Q, "circle")
    ends = np.array([s.end_points(q) for q in Q])
    C = _framing(s, Q, prims, None, ends, 0.05)
    lo, hi = C.min(axis=0), C.max(axis=0)
    for q in Q[::3]:
        V = robot_mesh(s, q).vertices
        assert np.all(V >= lo - 1e-12) and np.all(V <= hi + 1e-12)
    assert np.all(ends >= lo) and np.all(ends <= hi)


def test_primitives_argument_forms(motion):
    s, Q = motion
    task = cg.cooperative_task(s, "circle")
    by_kind = _per_frame_primitives(s, Q[:3], "circle")
    by_task = _per_frame_primitives(s, Q[:3], task.primitive)
    for X, Y in zip(by_kind, by_task):
        assert np.allclose(cg.center(X), cg.center(Y), atol=1e-12) and cg.radius(X) == pytest.approx(cg.radius(Y))
    X0 = task.primitive(s.q0)
    assert _per_frame_primitives(s, Q[:3], X0) == [X0, X0, X0]
    with pytest.raises(cg.InvalidInputError, match="one Primitive per row"):
        _per_frame_primitives(s, Q[:3], [X0])
    with pytest.raises(cg.InvalidInputError, match="kind"):
        _per_frame_primitives(s, Q[:3], "ellipse")


def test_bad_input_is_refused(tmp_path, motion, monkeypatch):
    s, Q = motion
    with pytest.raises(cg.InvalidInputError, match="trajectory must be"):
        cg.viz.animate(s, Q[:, :3], path=tmp_path / "x.gif")
    with pytest.raises(cg.InvalidInputError, match="one time per row"):
        cg.viz.animate(s, Q, path=tmp_path / "x.gif", t=np.arange(3))
    with pytest.raises(cg.InvalidInputError, match=r"\.gif or \.mp4"):
        cg.viz.animate(s, Q, path=tmp_path / "x.avi")
    img = np.zeros((8, 8, 3), np.uint8)
    with pytest.raises(cg.InvalidInputError, match="one size"):
        write_video(tmp_path / "y.gif", [img, np.zeros((9, 8, 3), np.uint8)])
    monkeypatch.setattr("coop_ga.viz.animation.shutil.which", lambda name: None)
    with pytest.raises(cg.CoopGAError, match="ffmpeg"):
        write_video(tmp_path / "y.mp4", [img, img])


def test_mp4_with_ffmpeg(tmp_path):
    import shutil

    if shutil.which("ffmpeg") is None:
        pytest.skip("no ffmpeg on the PATH (MP4 needs it; the GIF path is tested without)")
    frames = [np.full((10, 12, 3), 20 * k, np.uint8) for k in range(5)]
    p = write_video(tmp_path / "v.mp4", frames, fps=5)
    assert p.stat().st_size > 0
