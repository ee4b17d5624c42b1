"""The figure-scene contract: roles, checked input, a non-blank PNG."""

from __future__ import annotations

import numpy as np
import pytest

import coop_ga as cg
from coop_ga import viz
from coop_ga.errors import InvalidInputError


def test_scene_renders_nonblank_png(tmp_path):
    s = cg.systems.load("three_franka")
    task = cg.cooperative_task(s, "circle")
    q0 = np.array(s.q0, dtype=float)
    q1 = q0 + 0.1
    scene = (
        viz.Scene()
        .robot(s, q0, "initial", "initial")
        .robot(s, q1, "final", "final")
        .primitive(task.primitive(q0), "initial", "initial circle")
        .primitive(task.primitive(q1), "final", "final circle")
        .primitive(task.primitive(0.5 * (q0 + q1)), "intermediate", fraction=0.5)
        .curve(np.array([task.points(q0)[0], task.points(q1)[0]]))
    )
    out = viz.render_scene(scene, tmp_path / "scene.png", backend="matplotlib", title="t")
    import matplotlib.image as mpimg

    img = mpimg.imread(out)[..., :3]
    # a white canvas with drawing on it: a few percent of the pixels are far from white
    dark = (img.mean(axis=2) < 0.8).mean()
    assert 0.01 < dark < 0.6


def test_scene_refuses_unknown_role():
    with pytest.raises(InvalidInputError, match="role must be one of"):
        viz.Scene().curve(np.zeros((2, 3)), role="purple")


def test_scene_refuses_unknown_backend(tmp_path):
    with pytest.raises(InvalidInputError, match="backend"):
        viz.render_scene(viz.Scene(), tmp_path / "x.png", backend="povray")
