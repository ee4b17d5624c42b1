"""Figure scenes: several robot configurations, primitives, curves and points in one rendered PNG.

:func:`render_scene` is the one call every paper figure's 3-D panel goes through.  A scene is
described by *roles* rather than colours, so every figure gets the same paper style
(:data:`~coop_ga.viz.style.PALETTE`):

============  ====================================================================
role          drawn as
============  ====================================================================
initial       robot light, primitive green
final         robot grey, primitive turquoise
target        primitive black, dashed
intermediate  primitive thin, shaded green → turquoise by ``fraction`` ∈ [0, 1]
trajectory    curve red (end-point paths); a second, third … path in :data:`~coop_ga.viz.style.PALETTE`'s
              ``trajectories`` colours through ``style={"color": ...}``
neutral       robot / primitive / curve / points in the default colour
============  ====================================================================

Backends (:mod:`coop_ga.viz.backends`): ``"vtk"`` draws the robots from their visual
meshes (:meth:`coop_ga.systems.System.visual_model`) with PyVista/VTK offscreen — depth
buffer, lighting, primitives as tubes and translucent surfaces — and composes the image
into a matplotlib figure (title, legend, fonts of the paper style); ``"matplotlib"`` draws
the same meshes, decimated, as one depth-sorted ``Poly3DCollection``; ``"skeleton"`` draws
stick figures (joint origins, Pinocchio FK); ``"auto"`` (default) is ``"vtk"`` when an
offscreen OpenGL context can be made, else ``"matplotlib"`` with one
:class:`~coop_ga.errors.RenderWarning`.  ``$COOP_GA_RENDERER`` replaces ``"auto"``.
A robot without visual geometry is drawn as its skeleton (with a notice).

With the VTK backend, paths (curves in the ``trajectory`` role), markers and the end-point markers
are drawn over the rendered image (projected with its camera, with a white halo): a fingertip path inside a translucent sphere or
behind a finger would otherwise be hidden while the legend lists it.  Spheres in the
``intermediate`` role are drawn as outlines only, so a stack of them does not hide the robot.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .axes import label_axes_3d, set_equal_3d
from .primitives import draw_primitive
from .robots import draw_robot
from .style import DPI, LINEWIDTH, PALETTE, style

__all__ = ["ROLES", "Scene", "SceneCurve", "ScenePrimitive", "SceneRobot", "render_scene"]

ROLES = ("initial", "final", "target", "intermediate", "trajectory", "neutral")


def _role(role: str) -> str:
    if role not in ROLES:
        from ..errors import InvalidInputError

        raise InvalidInputError(f"scene role must be one of {', '.join(ROLES)}, got {role!r}")
    return role


@dataclass
class SceneRobot:
    """A system drawn at configuration ``q`` (nq,) [rad | m] in a role (``initial``, ``final`` or ``neutral``);
    ``end_labels``: write ``system.labels`` next to its end points."""

    system: Any
    q: Any
    role: str = "neutral"
    label: str | None = None
    end_labels: bool = False


@dataclass
class ScenePrimitive:
    """A :class:`coop_ga.Primitive` in a role; ``fraction`` shades ``intermediate`` ones (0 → initial, 1 → final).

    ``style``: optional :func:`~coop_ga.viz.draw_primitive` keywords that override the role's
    (``color``, ``lw``, ``ls``, ``alpha``, ``size``, ``length``, ``normal_arrow``, ``marker_size``).
    """

    X: Any
    role: str = "neutral"
    label: str | None = None
    fraction: float = 0.5
    style: dict[str, Any] | None = None


@dataclass
class SceneCurve:
    """A polyline (N, 3) [m], e.g. an end-point path (role ``trajectory``), or markers if ``markers``.

    ``style``: optional overrides of the role's look: ``color``, ``lw`` [pt], ``ls``, ``marker``
    (a matplotlib marker for ``markers``), ``marker_size`` [pt²].
    """

    points: Any
    role: str = "trajectory"
    label: str | None = None
    markers: bool = False
    style: dict[str, Any] | None = None


@dataclass
class Scene:
    """Everything one 3-D panel shows (world frame, metres)."""

    robots: list[SceneRobot] = field(default_factory=list)
    primitives: list[ScenePrimitive] = field(default_factory=list)
    curves: list[SceneCurve] = field(default_factory=list)

    def robot(
        self, system: Any, q: Any, role: str = "neutral", label: str | None = None, *, end_labels: bool = False
    ) -> Scene:
        """Add ``system`` at configuration ``q`` (nq,) [rad | m]; returns the scene (chainable)."""
        self.robots.append(SceneRobot(system, q, _role(role), label, bool(end_labels)))
        return self

    def primitive(
        self,
        X: Any,
        role: str = "neutral",
        label: str | None = None,
        fraction: float = 0.5,
        *,
        style: dict[str, Any] | None = None,
    ) -> Scene:
        """Add the primitive ``X`` (world frame, metres); returns the scene (chainable)."""
        self.primitives.append(ScenePrimitive(X, _role(role), label, float(fraction), dict(style) if style else None))
        return self

    def curve(
        self,
        points: Any,
        role: str = "trajectory",
        label: str | None = None,
        markers: bool = False,
        *,
        style: dict[str, Any] | None = None,
    ) -> Scene:
        """Add a polyline (N, 3) [m] (or markers); ``style`` overrides the role's look (:class:`SceneCurve`);
        returns the scene (chainable)."""
        P = np.asarray(points, dtype=float).reshape(-1, 3)
        self.curves.append(SceneCurve(P, _role(role), label, markers, dict(style) if style else None))
        return self


def _robot_style(role: str) -> dict[str, Any]:
    styles: dict[str, dict[str, Any]] = {
        "initial": {"color": PALETTE.initial_robot, "ends": False},
        "final": {"color": PALETTE.final_robot},
    }
    return styles.get(role, {"color": PALETTE.robot})


def _primitive_style(p: ScenePrimitive) -> dict[str, Any]:
    if p.role == "initial":
        return {"color": PALETTE.initial_primitive, "lw": LINEWIDTH["primitive"]}
    if p.role == "final":
        return {"color": PALETTE.final_primitive, "lw": LINEWIDTH["primitive"]}
    if p.role == "target":
        return {"color": PALETTE.target_primitive, "ls": "--", "lw": LINEWIDTH["primitive"]}
    if p.role == "intermediate":
        return {"color": PALETTE.intermediate(p.fraction), "lw": LINEWIDTH["intermediate"]}
    return {"color": PALETTE.primitive}


def curve_style(c: SceneCurve) -> dict[str, Any]:
    """The look of a curve: ``color``, ``lw`` [pt], ``ls``, ``marker``, ``marker_size`` [pt²] (role, then overrides)."""
    base = {
        "color": PALETTE.trajectory if c.role == "trajectory" else PALETTE.robot,
        "lw": LINEWIDTH["trajectory"],
        "ls": "-",
        "marker": "o",
        "marker_size": 25.0,
    }
    return {**base, **(c.style or {})}


def _styled(p: ScenePrimitive) -> dict[str, Any]:
    """The role's style with the primitive's own ``style`` overrides."""
    return {**_primitive_style(p), **(p.style or {})}


def render_scene(
    scene: Scene,
    path: str | Path,
    *,
    view: tuple[float, float] = (22.0, -60.0),
    size: tuple[float, float] = (7.0, 6.0),
    dpi: int = DPI,
    title: str | None = None,
    backend: str = "auto",
    legend: bool = True,
    pad: float = 0.05,
) -> Path:
    """Write the PNG of ``scene`` (module docstring), headless.

    Args:
        scene: the :class:`Scene`.  path: output PNG (parents created).
        view: camera (elevation, azimuth) [deg], as matplotlib's ``view_init``; size: figure size [in];
            dpi: resolution.
        title: panel title.  backend: ``"auto"`` (VTK meshes if an offscreen OpenGL context can be
            made, else matplotlib meshes; ``$COOP_GA_RENDERER`` replaces it), ``"vtk"``,
            ``"matplotlib"`` (meshes, depth-sorted) or ``"skeleton"`` (stick figures).
        legend: a legend of the labelled items.  pad: margin around the content [m].

    Everything drawn is framed by the camera (mesh backends) or by axes with equal scales
    (skeleton).  Returns the path written.  Raises :class:`~coop_ga.errors.InvalidInputError`
    for an unknown backend and :class:`~coop_ga.errors.RendererUnavailableError` for
    ``"vtk"`` where it cannot run.
    """
    from .backends import render_mesh_scene, resolve_backend

    chosen = resolve_backend(backend)
    if chosen == "skeleton":
        return _render_matplotlib(scene, Path(path), view=view, size=size, dpi=dpi, title=title, legend=legend, pad=pad)
    return render_mesh_scene(
        scene, path, backend=chosen, view=view, size=size, dpi=dpi, title=title, legend=legend, pad=pad
    )


def _render_matplotlib(
    scene: Scene,
    path: Path,
    *,
    view: tuple[float, float],
    size: tuple[float, float],
    dpi: int,
    title: str | None,
    legend: bool,
    pad: float,
) -> Path:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from ..geometry import KIND_SPECS, kind_of

    with style():
        fig = Figure(figsize=size)
        FigureCanvasAgg(fig)
        ax = fig.add_subplot(projection="3d")
        pts: list[np.ndarray] = []
        anchors: list[np.ndarray] = []
        # light (initial) robots first, so that the final configuration is drawn over them
        order = sorted(scene.robots, key=lambda r: {"initial": 0, "neutral": 1, "final": 2}.get(r.role, 1))
        for r in order:
            drawn = draw_robot(
                ax,
                r.system,
                r.q,
                label=r.label,
                zorder=2 if r.role == "final" else 1,
                end_labels=r.end_labels,
                **_robot_style(r.role),
            )
            pts.append(drawn.points)
            if drawn.skeleton is not None and len(drawn.skeleton.end_points):
                anchors.append(drawn.skeleton.end_points.mean(axis=0))
        flats = []
        for p in scene.primitives:
            if KIND_SPECS[kind_of(p.X)].flat:
                flats.append(p)
                continue
            pts.append(draw_primitive(ax, p.X, label=p.label, **_styled(p)).points)
        for c in scene.curves:
            P = np.asarray(c.points, dtype=float).reshape(-1, 3)
            cs = curve_style(c)
            if c.markers:
                ax.scatter(
                    *P.T, s=cs["marker_size"], color=cs["color"], marker=cs["marker"], depthshade=False, label=c.label
                )
            else:
                ax.plot(*P.T, color=cs["color"], lw=cs["lw"], ls=cs["ls"], label=c.label)
            pts.append(P)
        if pts:
            set_equal_3d(ax, np.vstack(pts), pad)
        anchor = np.mean(anchors, axis=0) if anchors else None
        for p in flats:
            draw_primitive(ax, p.X, label=p.label, **{"anchor": anchor, **_styled(p)})
        ax.view_init(*view)
        label_axes_3d(ax)
        if title:
            ax.set_title(title)
        labels = [h.get_label() for h in ax.get_children() if hasattr(h, "get_label")]
        if legend and any(isinstance(lab, str) and lab and not lab.startswith("_") for lab in labels):
            ax.legend(loc="upper left", fontsize=7)
        path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path, dpi=dpi)
    return path
