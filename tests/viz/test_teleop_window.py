"""The keyboard teleoperation window draws the robot with coop_ga.viz (exercised headless)."""

from __future__ import annotations

import warnings

import numpy as np

import coop_ga as cg
from coop_ga.control import teleop


def test_interactive_window_draws_the_skeleton(monkeypatch):
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    monkeypatch.setattr(teleop, "interactive_available", lambda: True)  # Agg: show() returns at once
    s = cg.systems.load("allegro")
    t = cg.cooperative_task(s, "sphere")
    tel = teleop.Teleoperator(t, s.q0, dt=0.01)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # "FigureCanvasAgg is non-interactive"
        assert teleop.run_interactive(tel) == "interactive"
    fig = plt.figure("coop_ga teleoperation")
    ax = fig.axes[0]
    assert len(ax.collections) >= 3  # links, joints, end points
    ends = np.column_stack(ax.collections[-1]._offsets3d)
    np.testing.assert_allclose(ends, s.tree.end_points_array(s.q0), atol=1e-12)
    lo = np.array([ax.get_xlim3d()[0], ax.get_ylim3d()[0], ax.get_zlim3d()[0]])
    hi = np.array([ax.get_xlim3d()[1], ax.get_ylim3d()[1], ax.get_zlim3d()[1]])
    assert np.all(ends > lo) and np.all(ends < hi)
    plt.close(fig)
