"""What a figure's legend promises is visible in its picture: paths and markers drawn over the meshes,
curves told apart by their style, intermediate spheres as outlines, labelled axes, legends outside
the data, and animations that take one primitive per trajectory row."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

import coop_ga as cg
from coop_ga import viz
from coop_ga.viz import backends

HAS_PYVISTA = importlib.util.find_spec("pyvista") is not None
needs_vtk = pytest.mark.skipif(not HAS_PYVISTA, reason="pyvista is not installed (pip install '.[viz]')")


@pytest.fixture(scope="module")
def franka():
    return cg.systems.load("three_franka")


def _colour_pixels(png, colour, tol=0.12):
    """How many pixels of the PNG are within ``tol`` (per channel, 0–1) of ``colour``."""
    import matplotlib.image as mpimg
    from matplotlib.colors import to_rgb

    img = mpimg.imread(png)[..., :3]
    return int(np.sum(np.all(np.abs(img - np.array(to_rgb(colour))) < tol, axis=2)))


@needs_vtk
def test_a_path_inside_the_robot_is_drawn_over_it(franka, tmp_path):
    """A path through the joint origins of the first arm (inside its links) shows in the picture, in the
    colour its style gives; a target point shows over the end-point marker it coincides with."""
    ok, why = viz.vtk_status()
    assert ok, why
    q = np.array(franka.q0)
    joints = viz.skeleton(franka, q).joints[:7]  # inside the first arm's meshes
    purple = viz.PALETTE.trajectories[1]
    scene = (
        viz.Scene()
        .robot(franka, q, "final")
        .curve(joints, "trajectory", "hidden path", style={"color": purple, "lw": 3.0})
        .primitive(cg.point(franka.end_points(q)[0]), "initial", "target point", style={"marker_size": 30.0})
    )
    png = viz.render_scene(scene, tmp_path / "s.png", backend="vtk", size=(5, 4), dpi=100, legend=False)
    assert _colour_pixels(png, purple) > 400  # drawn in the 3-D scene only, 89 pixels of it show
    # the green target point, as large as the red end-point marker at the same place, is drawn over it
    assert _colour_pixels(png, viz.PALETTE.initial_primitive) > 15
    # the same scene without the path: no purple at all (the count above is the path's)
    plain = viz.Scene().robot(franka, q, "final")
    assert _colour_pixels(viz.render_scene(plain, tmp_path / "p.png", backend="vtk", size=(5, 4), dpi=100), purple) < 5


def test_curve_styles_reach_the_legend_and_default_by_role():
    left = {"color": viz.PALETTE.trajectories[1], "ls": "--"}
    scene = (
        viz.Scene()
        .curve(np.zeros((2, 3)), "trajectory", "right")
        .curve(np.ones((2, 3)), "trajectory", "left", style=left)
        .curve(np.ones((1, 3)), "target", "goal", markers=True, style={"marker": "*", "marker_size": 100.0})
    )
    right_h, left_h, goal_h = backends._legend_handles([], [], scene)
    from matplotlib.colors import to_hex

    assert to_hex(right_h.get_color()) == to_hex(viz.PALETTE.trajectory)
    assert to_hex(left_h.get_color()) == to_hex(viz.PALETTE.trajectories[1]) and left_h.get_linestyle() == "--"
    assert goal_h.get_marker() == "*" and goal_h.get_markersize() == pytest.approx(10.0)
    assert viz.scene.curve_style(scene.curves[0])["lw"] == viz.LINEWIDTH["trajectory"]
    assert len(set(viz.PALETTE.trajectories)) == len(viz.PALETTE.trajectories) >= 2


def test_intermediate_spheres_are_outlines_in_the_legend():
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    X = cg.sphere(*[np.array(p, float) for p in ((0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1))])
    scene = viz.Scene().primitive(X, "initial", "initial sphere").primitive(X, "intermediate", "intermediate spheres")
    prims = backends._prims(scene)
    assert [backends._outline_only(p) for p in prims] == [False, True]
    h_init, h_inter = backends._legend_handles([], prims, scene)
    assert isinstance(h_init, Patch) and isinstance(h_inter, Line2D)


def test_bivector_and_error_panels_are_labelled_with_legends_outside():
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6, 5))
    FigureCanvasAgg(fig)
    ax1, ax2 = fig.subplots(2, 1)
    t = np.linspace(0.0, 1.0, 20)
    viz.plot_bivector(ax1, t, np.outer(np.sin(3 * t), np.arange(7)), ylabel=viz.bivector_ylabel("command", rate=True))
    viz.plot_error(ax2, t, np.exp(-t), label="e")
    viz.legend_outside(ax2)
    assert ax1.get_ylabel() == "command [rad/s | 1/s | body length/s]"
    assert viz.bivector_ylabel("error") == "error [rad | 1 | body length]"
    assert ax2.get_ylabel() == r"error $\|e\|$"
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    for ax in (ax1, ax2):
        assert ax.get_legend().get_window_extent(r).x0 >= ax.get_window_extent(r).x1  # right of the data
    ax2.set_ylabel("distance [m]")
    viz.plot_error(ax2, t, np.exp(-2 * t))
    assert ax2.get_ylabel() == "distance [m]"  # an existing label is kept


def test_animate_takes_one_primitive_per_row(tmp_path):
    """A list with one primitive (or None) per trajectory row, longer than the frame count, is accepted."""
    s = cg.systems.load("three_iiwa14")
    Q = np.tile(s.q0, (10, 1))
    Q[:, 0] += np.linspace(0.0, 0.5, 10)
    task = cg.cooperative_task(s, "circle")
    prims = [task.primitive(q) if k < 5 else None for k, q in enumerate(Q)]
    path = viz.animate(s, Q, prims, tmp_path / "a.gif", frames=3, backend="skeleton")
    from PIL import Image

    with Image.open(path) as im:
        assert im.n_frames == 3
