"""coop_ga.viz: samplers and drawing of the six primitive kinds."""

from __future__ import annotations

import numpy as np
import pytest

import coop_ga as cg
from coop_ga import viz


def _ax():
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(3, 3))
    FigureCanvasAgg(fig)
    return fig, fig.add_subplot(projection="3d")


@pytest.mark.parametrize("normal", [(0, 0, 1), (1, 0, 0), (0.3, -2.0, 0.7), (0.95, 0.1, -0.2)])
def test_circle_points_lie_on_the_circle(normal):
    c, r = np.array([0.4, -1.2, 2.5]), 0.37
    P = viz.circle_points(c, r, normal, m=90)
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    assert P.shape == (91, 3)
    np.testing.assert_allclose(np.linalg.norm(P - c, axis=1), r, atol=1e-12)
    np.testing.assert_allclose((P - c) @ n, 0.0, atol=1e-12)
    np.testing.assert_array_equal(P[0], P[-1])
    # counter-clockwise about n: (p0 − c) × (p1 − c) points along n
    assert np.cross(P[0] - c, P[1] - c) @ n > 0


def test_sphere_mesh_radius():
    c, r = np.array([0.1, 0.2, -0.3]), 0.25
    X, Y, Z = viz.sphere_mesh(c, r, m=20)
    assert X.shape == Y.shape == Z.shape == (11, 21)
    d = np.sqrt((X - c[0]) ** 2 + (Y - c[1]) ** 2 + (Z - c[2]) ** 2)
    np.testing.assert_allclose(d, r, atol=1e-12)
    assert Z.max() == pytest.approx(c[2] + r) and Z.min() == pytest.approx(c[2] - r)


def test_square_and_clip():
    S = viz.square_points([1, 2, 3], [0, 0, 2], 0.5)
    np.testing.assert_allclose(S[:, 2], 3.0, atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(S - [1, 2, 3], axis=1), 0.25 * np.sqrt(2), atol=1e-12)
    seg = viz.clip_line([0, 0, 0], [1, 1, 0], [-1, -2, -1], [1, 2, 1])
    np.testing.assert_allclose(seg, [[-1, -1, 0], [1, 1, 0]], atol=1e-15)
    assert viz.clip_line([0, 0, 5], [1, 0, 0], [-1, -1, -1], [1, 1, 1]) is None


PTS = np.array([[0.3, 0.0, 0.1], [0.0, 0.4, 0.2], [-0.2, -0.1, 0.3], [0.1, 0.1, 0.6]])


@pytest.mark.parametrize("kind", cg.KINDS)
def test_every_kind_draws(kind):
    n = {"point": 1, "point_pair": 2, "line": 2, "circle": 3, "plane": 3, "sphere": 4}[kind]
    X = cg.primitive_from_points(kind, PTS[:n])
    fig, ax = _ax()
    viz.set_equal_3d(ax, PTS)
    d = viz.draw_primitive(ax, X, label=kind, size=0.3)
    assert d.artists and d.points.shape[1] == 3
    fig.canvas.draw()
    if kind == "point":
        np.testing.assert_allclose(d.points, PTS[:1], atol=1e-12)
    elif kind == "point_pair":
        np.testing.assert_allclose(d.points, PTS[:2], atol=1e-12)
    elif kind == "line":  # clipped to the box: both ends on the box, the segment on the line
        lo, hi = viz.axes_box(ax)
        u = (PTS[1] - PTS[0]) / np.linalg.norm(PTS[1] - PTS[0])
        for p in d.points:
            w = p - PTS[0]
            np.testing.assert_allclose(w - (w @ u) * u, 0.0, atol=1e-12)
            assert np.isclose(p, lo, atol=1e-12).any() or np.isclose(p, hi, atol=1e-12).any()
    elif kind == "circle":
        c, r = np.asarray(cg.center(X)), float(cg.radius(X))
        np.testing.assert_allclose(np.linalg.norm(PTS[:3] - c, axis=1), r, atol=1e-12)
        np.testing.assert_allclose(np.linalg.norm(d.points - c, axis=1), r, atol=1e-12)
    elif kind == "plane":
        nrm = np.asarray(cg.normal(X))
        np.testing.assert_allclose((d.points - PTS[0]) @ nrm, 0.0, atol=1e-12)
        assert np.linalg.norm(d.points[0] - d.points[2]) == pytest.approx(0.3 * np.sqrt(2))
    elif kind == "sphere":
        c, r = np.asarray(cg.center(X)), float(cg.radius(X))
        np.testing.assert_allclose(np.linalg.norm(d.points - c, axis=1), r, atol=1e-12)


def test_line_of_given_length_about_anchor():
    _, ax = _ax()
    L = cg.line([0, 0, 1], [1, 0, 1])
    d = viz.draw_primitive(ax, L, length=2.0, anchor=[3.0, 5.0, 0.0])
    np.testing.assert_allclose(d.points, [[2, 0, 1], [4, 0, 1]], atol=1e-12)


def test_set_equal_3d_limits():
    _, ax = _ax()
    P = np.array([[0.0, 0.0, 0.0], [2.0, 1.0, 0.5], [1.0, -1.0, 0.2]])
    c, h = viz.set_equal_3d(ax, P, pad=0.1)
    np.testing.assert_allclose(c, [1.0, 0.0, 0.25], atol=1e-12)
    assert h == pytest.approx(1.1)
    spans = [np.diff(lim)[0] for lim in (ax.get_xlim3d(), ax.get_ylim3d(), ax.get_zlim3d())]
    np.testing.assert_allclose(spans, 2.2, atol=1e-12)
    lo, hi = viz.axes_box(ax)
    assert np.all(P >= lo) and np.all(P <= hi)
    viz.set_equal_3d(ax, P, pad=0.1, floor=True)
    assert ax.get_zlim3d()[0] == pytest.approx(-0.1)
    viz.set_equal_3d(ax, P, pad=0.1, tight=True)  # the padded bounding box, same scale on every axis
    spans = np.array([np.diff(lim)[0] for lim in (ax.get_xlim3d(), ax.get_ylim3d(), ax.get_zlim3d())])
    np.testing.assert_allclose(spans, [2.2, 2.2, 0.7], atol=1e-12)
    np.testing.assert_allclose(ax.get_box_aspect() / ax.get_box_aspect()[0], spans / spans[0], atol=1e-12)
