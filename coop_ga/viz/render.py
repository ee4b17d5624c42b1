"""One call from a system and a configuration to a PNG: :func:`render`; :func:`save` for any figure."""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .axes import label_axes_3d, set_equal_3d
from .primitives import draw_primitive
from .robots import draw_robot
from .style import DPI, style

__all__ = ["render", "save"]


def save(fig: Any, path: str | Path, dpi: int = DPI) -> Path:
    """Save ``fig`` to ``path`` (parent directories created) at ``dpi`` and close it if pyplot owns it."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(p, dpi=dpi)
    if "matplotlib.pyplot" in sys.modules:
        import matplotlib.pyplot as plt

        plt.close(fig)
    return p


def render(
    system: Any,
    q: Any,
    primitives: Sequence[Any] = (),
    path: str | Path = "robot.png",
    *,
    view: tuple[float, float] = (22.0, -60.0),
    size: tuple[float, float] = (7.0, 7.0),
    dpi: int = DPI,
    title: str | None = None,
    end_labels: bool = True,
    pad: float = 0.05,
    backend: str = "auto",
) -> Path:
    """Write a PNG of ``system`` at ``q`` (nq,) and of ``primitives``, headless.

    Args:
        system: a :class:`coop_ga.systems.System` (or any object with ``model``, ``end_frames``).
        q: configuration (nq,) [rad | m].
        primitives: :class:`coop_ga.Primitive` objects, or ``(primitive, kwargs)`` pairs whose
            keyword arguments go to :func:`~coop_ga.viz.draw_primitive` (``color``, ``lw``, ``ls``,
            ``alpha``, ``size``, ``length``, ``normal_arrow``, ``marker_size``).
        path: output file; view: camera (elevation, azimuth) [deg]; size: figure size [in];
            dpi: resolution; title: figure title (default: the system's name);
            end_labels: label the end points with ``system.labels``; pad: margin [m].
        backend: as :func:`~coop_ga.viz.render_scene`: ``"auto"`` (the robot from its visual
            meshes, VTK or matplotlib), ``"vtk"``, ``"matplotlib"`` or ``"skeleton"``.

    The same machinery as :func:`~coop_ga.viz.render_scene` with one robot in the neutral
    role.  Returns the path written.
    """
    from .backends import render_mesh_scene, resolve_backend

    chosen = resolve_backend(backend)
    name = getattr(system, "name", "") if title is None else title
    if chosen != "skeleton":
        from .scene import Scene

        scene = Scene().robot(system, q, "neutral", end_labels=end_labels)
        for X in primitives:
            X, kw = X if isinstance(X, tuple) else (X, {})
            scene.primitive(X, "neutral", style=kw)
        return render_mesh_scene(
            scene, path, backend=chosen, view=view, size=size, dpi=dpi, title=name, legend=False, pad=pad
        )
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    with style():
        fig = Figure(figsize=size)
        FigureCanvasAgg(fig)
        ax = fig.add_subplot(projection="3d")
        drawn = draw_robot(ax, system, q, end_labels=end_labels)
        items = [(X, {}) if not isinstance(X, tuple) else X for X in primitives]
        flats = [(X, kw) for X, kw in items if _is_flat(X)]
        pts = [drawn.points] + [draw_primitive(ax, X, **kw).points for X, kw in items if not _is_flat(X)]
        set_equal_3d(ax, np.vstack(pts), pad)
        assert drawn.skeleton is not None
        for X, kw in flats:
            draw_primitive(ax, X, **{"anchor": drawn.skeleton.end_points.mean(axis=0), **kw})
        ax.view_init(*view)
        label_axes_3d(ax)
        ax.set_title(name)
        p = Path(path)
        p.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(p, dpi=dpi)
    return p


def _is_flat(X: Any) -> bool:
    from ..geometry import KIND_SPECS, kind_of

    return KIND_SPECS[kind_of(X)].flat
