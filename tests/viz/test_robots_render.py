"""coop_ga.viz: robot skeletons from Pinocchio FK, and render() to PNG."""

from __future__ import annotations

import numpy as np
import pytest

import coop_ga as cg
from coop_ga import viz


@pytest.fixture(scope="module")
def franka():
    return cg.systems.load("three_franka")


def _agg_axes(size=(5.0, 5.0), dpi=100):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=size, dpi=dpi)
    FigureCanvasAgg(fig)
    return fig, fig.add_subplot(projection="3d")


def test_skeleton_matches_forward_kinematics(franka):
    q = franka.q0 + np.random.default_rng(3).uniform(-0.3, 0.3, franka.nq)
    sk = viz.skeleton(franka, q)
    np.testing.assert_allclose(sk.end_points, franka.tree.end_points_array(q), atol=1e-12)
    assert len(sk.chains) == 3 and sk.joints.shape == (21, 3)
    for chain, p in zip(sk.chains, sk.end_points):
        np.testing.assert_allclose(chain[-1], p, atol=0)
        assert chain.shape == (7 + 2, 3)  # base body, 7 joints, end frame
    ends = sk.segments[np.array(sk.kinds) == "end"]
    np.testing.assert_allclose(ends[:, 1], sk.end_points, atol=0)
    with pytest.raises(ValueError, match="21 entries"):
        viz.skeleton(franka, np.zeros(3))


def test_draw_robot_data_coordinates(franka):
    _, ax = _agg_axes()
    q = franka.q0
    d = viz.draw_robot(ax, franka, q)
    ends = d.artists[-1]  # the end-point markers are drawn last
    np.testing.assert_allclose(np.column_stack(ends._offsets3d), franka.tree.end_points_array(q), atol=1e-12)
    assert d.points.shape[1] == 3 and len(d.points) > 21


def test_end_points_are_drawn_where_fk_puts_them(franka):
    """Project the FK end points with the axes' projection: the pixel there is the end-point red."""
    from matplotlib.colors import to_rgb
    from mpl_toolkits.mplot3d import proj3d

    dpi = 100
    fig, ax = _agg_axes((6.0, 6.0), dpi)
    d = viz.draw_robot(ax, franka, franka.q0, end_size=80)
    viz.set_equal_3d(ax, d.points)
    ax.view_init(35, -70)
    fig.canvas.draw()
    img = np.asarray(fig.canvas.buffer_rgba())[..., :3] / 255.0
    P = franka.tree.end_points_array(franka.q0)
    x, y, _ = proj3d.proj_transform(P[:, 0], P[:, 1], P[:, 2], ax.get_proj())
    px = ax.transData.transform(np.column_stack([x, y]))
    red = np.array(to_rgb(viz.PALETTE.end_point))
    H = img.shape[0]
    for u, v in px:
        pixel = img[round(H - v), round(u)]
        assert np.abs(pixel - red).max() < 0.1, (u, v, pixel)
    bg = img[5, 5]  # a corner is background, and not red
    assert np.abs(bg - red).max() > 0.3


def test_render_writes_a_nonblank_png(franka, tmp_path):
    import matplotlib.image as mpimg

    X = cg.circle(*franka.end_points(franka.q0))
    p = viz.render(
        franka,
        franka.q0,
        [X, (cg.plane(*franka.end_points(franka.q0)), {"size": 0.5})],
        tmp_path / "sub" / "three_franka.png",
        view=(35, -70),
        size=(5, 4),
        dpi=80,
    )
    assert p.exists() and p.stat().st_size > 10_000
    img = mpimg.imread(p)
    assert img.shape[0] > 200 and img.shape[1] > 250
    assert float(np.std(img[..., :3])) > 0.05  # not blank


def test_any_system_renders(tmp_path):
    """A system from a URDF (the hexapod) and a two-robot system draw without special cases."""
    for name in ("hexapod", "franka_and_g1"):
        s = cg.systems.load(name)
        sk = viz.skeleton(s, s.q0)
        np.testing.assert_allclose(sk.end_points, s.tree.end_points_array(s.q0), atol=1e-12)
        assert viz.render(s, s.q0, (), tmp_path / f"{name}.png", size=(3, 3), dpi=50).exists()


def test_a_free_flyer_skeleton_and_meshes_follow_the_base():
    """The floating G1 (nq = 24): the base moved 1 m along x and turned 90° about z moves every skeleton point and
    visual object rigidly (Pinocchio FK on the 7 free-flyer coordinates); a q of nv entries is refused."""
    from coop_ga.viz.mesh import object_placements

    s = cg.systems.load("g1_arms", free_flyer=True)
    q = s.q0.copy()
    q[:3] = [1.0, 0.0, 0.0]
    q[3:7] = [0.0, 0.0, np.sin(np.pi / 4), np.cos(np.pi / 4)]  # x y z w
    Rz = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    a, b = viz.skeleton(s, s.q0), viz.skeleton(s, q)
    np.testing.assert_allclose(b.points(), a.points() @ Rz.T + [1.0, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(b.end_points, a.end_points @ Rz.T + [1.0, 0.0, 0.0], atol=1e-12)
    P0, P1 = object_placements(s, s.q0), object_placements(s, q)
    assert P0 is not None and P1 is not None and len(P0) > 10
    np.testing.assert_allclose(P1[:, :3, 3], P0[:, :3, 3] @ Rz.T + [1.0, 0.0, 0.0], atol=1e-12)
    with pytest.raises(ValueError, match="q must have 24 entries"):
        viz.skeleton(s, np.zeros(s.nv))
