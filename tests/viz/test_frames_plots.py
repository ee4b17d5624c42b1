"""coop_ga.viz: frames (motor, similarity, SE3, matrix) and the bivector / error plots."""

from __future__ import annotations

import numpy as np
import pytest

import coop_ga as cg
from coop_ga import viz


def _fig():
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(4, 3))
    FigureCanvasAgg(fig)
    return fig


def test_frame_axes_of_motor_similarity_and_se3():
    import pinocchio as pin

    b = np.array([0.3, -0.2, 0.5, 0.0, 0.1, -0.4, 0.2])
    _, A = viz.frame_axes(cg.geometry.exp(b))  # a motor: rotation, no scale
    np.testing.assert_allclose(A.T @ A, np.eye(3), atol=1e-12)
    assert np.linalg.det(A) == pytest.approx(1.0)
    bs = b.copy()
    bs[3] = np.log(2.0)  # dilation: every axis twice as long
    _, A2 = viz.frame_axes(cg.geometry.exp(bs))
    np.testing.assert_allclose(np.linalg.norm(A2, axis=0), 2.0, atol=1e-12)
    M = pin.SE3(pin.exp3(np.array([0.1, 0.2, 0.3])), np.array([1.0, 2.0, 3.0]))
    o3, A3 = viz.frame_axes(M)
    np.testing.assert_allclose(o3, [1, 2, 3])
    np.testing.assert_allclose(A3, M.rotation)
    o4, A4 = viz.frame_axes(M.homogeneous)
    np.testing.assert_allclose(A4, M.rotation) and np.testing.assert_allclose(o4, o3)
    # the motor of a Pinocchio placement gives the same frame
    from coop_ga.kinematics.chains import motor_from_se3

    o5, A5 = viz.frame_axes(motor_from_se3(M))
    np.testing.assert_allclose(o5, o3, atol=1e-12)
    np.testing.assert_allclose(A5, M.rotation, atol=1e-12)
    with pytest.raises(ValueError, match="cannot read a frame"):
        viz.frame_axes(np.zeros(5))


def test_draw_frame():
    fig = _fig()
    ax = fig.add_subplot(projection="3d")
    d = viz.draw_frame(ax, np.eye(4), length=0.2, label="world")
    np.testing.assert_allclose(d.points, [[0, 0, 0], [0.2, 0, 0], [0, 0.2, 0], [0, 0, 0.2]])
    assert len(d.artists) == 4
    fig.canvas.draw()


def test_plot_bivector_and_error():
    fig = _fig()
    ax1, ax2 = fig.subplots(1, 2)
    t = np.linspace(0, 1, 11)
    B = np.outer(np.exp(-t), np.arange(1, 8))
    lines = viz.plot_bivector(ax1, t, B)
    assert len(lines) == 7
    assert [ln.get_label() for ln in lines] == list(viz.BIVECTOR_LABELS)
    np.testing.assert_allclose(lines[3].get_ydata(), 4 * np.exp(-t))
    with pytest.raises(ValueError, match="shape"):
        viz.plot_bivector(ax1, t, B[:, :6])
    err = np.exp(-5 * t)
    err[-1] = 0.0
    line = viz.plot_error(ax2, t, err)
    assert ax2.get_yscale() == "log"
    assert line.get_ydata()[-1] == pytest.approx(1e-3 * err[-2])  # zero raised to the floor
    line2 = viz.plot_error(ax2, t, B, log=True, floor=1e-9)
    np.testing.assert_allclose(line2.get_ydata(), np.linalg.norm(B, axis=1))
    fig.canvas.draw()
