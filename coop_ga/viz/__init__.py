"""Drawing for coop_ga: robots, the six primitive kinds, frames, bivector and error plots.

It takes systems, configurations and primitives (never tasks: :mod:`coop_ga.cooperative` depends on it,
not the reverse; ``tests/test_layers.py``).  Nothing here imports ``matplotlib.pyplot``:
the functions draw on axes they are given, and :func:`render` writes a PNG with the Agg
canvas directly, so they work headless whatever the backend.

* :mod:`~coop_ga.viz.style` — one palette (:data:`PALETTE`), fonts (:func:`style`,
  :func:`use_style`), :data:`DPI`, :data:`BIVECTOR_LABELS`;
* :mod:`~coop_ga.viz.robots` — :func:`skeleton`, :func:`draw_robot`;
* :mod:`~coop_ga.viz.primitives` — :func:`draw_primitive`, :func:`circle_points`,
  :func:`sphere_mesh`, :func:`square_points`;
* :mod:`~coop_ga.viz.frames` — :func:`draw_frame`;
* :mod:`~coop_ga.viz.plots` — :func:`plot_bivector`, :func:`plot_error`,
  :func:`bivector_ylabel`, :func:`legend_outside`;
* :mod:`~coop_ga.viz.axes` — :func:`set_equal_3d`, :func:`label_axes_3d`;
* :mod:`~coop_ga.viz.render` — :func:`render`, :func:`save`;
* :mod:`~coop_ga.viz.scene` — :class:`Scene`, :func:`render_scene` (every figure's 3-D panel);
* :mod:`~coop_ga.viz.mesh` — robots' visual meshes at a configuration (:func:`robot_mesh`,
  :class:`TriMesh`, :func:`decimate`), cached per process; :class:`RenderWarning`;
* :mod:`~coop_ga.viz.backends` — the renderers behind :func:`render_scene` / :func:`render`
  (``"vtk"``, ``"matplotlib"`` meshes, ``"skeleton"``; :func:`resolve_backend`,
  :func:`vtk_status`, :class:`Camera`, :func:`frame_camera`).
"""

from .animation import animate, write_video
from .axes import Drawn, axes_box, label_axes_3d, set_equal_3d
from .backends import BACKENDS, Camera, frame_camera, resolve_backend, vtk_status
from .frames import draw_frame, frame_axes
from .mesh import RendererUnavailableError, RenderWarning, TriMesh, decimate, object_mesh, robot_mesh
from .plots import bivector_ylabel, legend_outside, plot_bivector, plot_error
from .primitives import circle_points, clip_line, draw_primitive, plane_basis, sphere_mesh, square_points
from .render import render, save
from .robots import RobotDrawn, Skeleton, draw_robot, skeleton
from .scene import ROLES, Scene, SceneCurve, ScenePrimitive, SceneRobot, render_scene
from .style import (
    BIVECTOR_COLORS,
    BIVECTOR_LABELS,
    BIVECTOR_RATE_UNITS,
    BIVECTOR_UNITS,
    DPI,
    LINEWIDTH,
    PALETTE,
    Palette,
    style,
    use_style,
)

__all__ = [
    "BACKENDS",
    "BIVECTOR_COLORS",
    "BIVECTOR_LABELS",
    "BIVECTOR_RATE_UNITS",
    "BIVECTOR_UNITS",
    "DPI",
    "LINEWIDTH",
    "PALETTE",
    "ROLES",
    "Camera",
    "Drawn",
    "Palette",
    "RenderWarning",
    "RendererUnavailableError",
    "RobotDrawn",
    "Scene",
    "SceneCurve",
    "ScenePrimitive",
    "SceneRobot",
    "Skeleton",
    "TriMesh",
    "animate",
    "axes_box",
    "bivector_ylabel",
    "circle_points",
    "clip_line",
    "decimate",
    "draw_frame",
    "draw_primitive",
    "draw_robot",
    "frame_axes",
    "frame_camera",
    "label_axes_3d",
    "legend_outside",
    "object_mesh",
    "plane_basis",
    "plot_bivector",
    "plot_error",
    "render",
    "render_scene",
    "resolve_backend",
    "robot_mesh",
    "save",
    "set_equal_3d",
    "skeleton",
    "sphere_mesh",
    "square_points",
    "style",
    "use_style",
    "vtk_status",
    "write_video",
]
