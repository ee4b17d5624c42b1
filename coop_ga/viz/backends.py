"""The renderers behind :func:`coop_ga.viz.render_scene` and :func:`coop_ga.viz.render`.

======================  =====================================================================
backend                 draws
======================  =====================================================================
``"vtk"``               robots from their visual meshes with a depth buffer and lighting
                        (PyVista/VTK, offscreen), primitives as tubes / translucent surfaces;
                        the image is composed into a matplotlib figure (title, legend, fonts;
                        paths and markers projected over it, so none hides inside a mesh)
``"matplotlib"``        the same meshes, decimated, as one depth-sorted ``Poly3DCollection``
                        with flat shading (painter's algorithm); primitives drawn over them
``"skeleton"``          stick figures (joint origins, :func:`coop_ga.viz.draw_robot`)
``"auto"`` (default)    ``"vtk"`` if an offscreen OpenGL context can be made, else
                        ``"matplotlib"`` with one :class:`~coop_ga.errors.RenderWarning`
======================  =====================================================================

The environment variable ``COOP_GA_RENDERER`` (one of the names above) replaces ``"auto"``;
an explicit ``backend=`` argument wins over it.

Renderer detection (:func:`vtk_status`, once per process): pyvista must import; then a
child process tries to render one offscreen frame with each candidate VTK render window —
``$VTK_DEFAULT_OPENGL_WINDOW`` if set; else, with a display (``DISPLAY`` /
``WAYLAND_DISPLAY``), the X window, then EGL and OSMesa; without one, EGL then OSMesa
(so VTK never tries an X server that is not there: no "bad X server connection"). The
probe runs in a child process because a broken OpenGL driver can crash the process that
asks it for a context.  The first window that renders is exported as
``VTK_DEFAULT_OPENGL_WINDOW`` for this process, so every PyVista plotter uses it.

Camera: ``view = (elevation, azimuth)`` [deg] as in matplotlib's ``view_init`` — the camera
looks at the scene from the direction (cos e cos a, cos e sin a, sin e), z up on the image —
with a perspective of :data:`VIEW_ANGLE` (vertical field of view, both mesh backends),
placed so that everything drawn fits (:func:`frame_camera`).
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InvalidInputError
from ..geometry.kinds import KIND_SPECS, KindSpec
from .mesh import RendererUnavailableError, TriMesh, _notice, object_placements, robot_mesh
from .robots import Skeleton, skeleton
from .scene import Scene, ScenePrimitive, _primitive_style, curve_style
from .style import LINEWIDTH, PALETTE, style

__all__ = [
    "BACKENDS",
    "ENV_RENDERER",
    "MPL_MAX_FACES",
    "VIEW_ANGLE",
    "VTK_MAX_FACES",
    "Camera",
    "frame_camera",
    "mpl_axes",
    "render_mesh_scene",
    "resolve_backend",
    "view_direction",
    "vtk_image",
    "vtk_status",
]

#: Names accepted by ``render_scene(backend=...)`` and ``$COOP_GA_RENDERER``.
BACKENDS = ("auto", "vtk", "matplotlib", "skeleton")
#: Environment variable that replaces ``backend="auto"``.
ENV_RENDERER = "COOP_GA_RENDERER"
#: Vertical field of view of the perspective camera [deg] (both mesh backends).
VIEW_ANGLE = 20.0
#: Triangle budget per robot drawing for VTK (a G1 has 290 000, a Panda 135 000: drawn in full).
VTK_MAX_FACES = 400_000
#: Triangle budget per robot drawing for the matplotlib meshes (vertex clustering).
MPL_MAX_FACES = 30_000

#: Scale of the visual objects of a robot drawn again later in the scene (module :func:`_robots`).
_SHRINK = 0.99

_WINDOWS_DISPLAY = ("vtkXOpenGLRenderWindow", "vtkEGLRenderWindow", "vtkOSOpenGLRenderWindow")
_WINDOWS_HEADLESS = ("vtkEGLRenderWindow", "vtkOSOpenGLRenderWindow")

_PROBE = r"""
import sys
import vtkmodules.vtkRenderingOpenGL2 as gl
from vtkmodules.vtkCommonCore import vtkLogger, vtkObject, vtkUnsignedCharArray
from vtkmodules.vtkRenderingCore import vtkRenderer
vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_OFF)
vtkObject.GlobalWarningDisplayOff()
w = getattr(gl, sys.argv[1])()
w.SetOffScreenRendering(1)
w.SetSize(8, 8)
r = vtkRenderer()
r.SetBackground(1.0, 0.0, 0.0)
w.AddRenderer(r)
if not w.SupportsOpenGL():
    print("no OpenGL")
    sys.exit(3)
w.Render()
a = vtkUnsignedCharArray()
w.GetPixelData(0, 0, 3, 3, 1, a, 0)
ok = a.GetNumberOfTuples() == 16 and a.GetValue(0) > 200 and a.GetValue(1) < 50
print("OK" if ok else "wrong pixels")
sys.exit(0 if ok else 4)
"""

_STATUS: tuple[bool, str] | None = None


def _pyvista() -> Any:
    """The ``pyvista`` module (imported on first use; typed as Any: its stubs do not cover the calls here)."""
    import importlib

    return importlib.import_module("pyvista")


def vtk_status() -> tuple[bool, str]:
    """(usable, reason): whether PyVista/VTK can render offscreen here, and why (or which window).

    Probed once per process (module docstring); on success ``VTK_DEFAULT_OPENGL_WINDOW`` is
    set for this process.  The reason is a short sentence for the fallback notice.
    """
    global _STATUS
    if _STATUS is not None:
        return _STATUS
    try:
        import importlib

        importlib.import_module("pyvista")
        importlib.import_module("vtkmodules.vtkRenderingOpenGL2")
    except ImportError as e:
        _STATUS = (False, f"pyvista/vtk not importable ({e}; pip install 'coop_ga[viz]')")
        return _STATUS
    user = os.environ.get("VTK_DEFAULT_OPENGL_WINDOW")
    if user:
        candidates: tuple[str, ...] = (user,)
    elif os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"):
        candidates = _WINDOWS_DISPLAY
    else:
        candidates = _WINDOWS_HEADLESS
    failures = []
    for cls in candidates:
        try:
            r = subprocess.run(
                [sys.executable, "-c", _PROBE, cls], capture_output=True, text=True, timeout=60, env=os.environ.copy()
            )
            out = (r.stdout.strip().splitlines() or [""])[-1]
            if r.returncode == 0 and out == "OK":
                os.environ["VTK_DEFAULT_OPENGL_WINDOW"] = cls
                _STATUS = (True, cls)
                return _STATUS
            code = f"crashed (signal {-r.returncode})" if r.returncode < 0 else f"exit code {r.returncode}"
            failures.append(f"{cls}: {out or code}")
        except (OSError, subprocess.TimeoutExpired) as e:
            failures.append(f"{cls}: {type(e).__name__}")
    _STATUS = (False, "no offscreen OpenGL context (" + "; ".join(failures) + ")")
    return _STATUS


def resolve_backend(backend: str = "auto") -> str:
    """The renderer that draws: ``"vtk"``, ``"matplotlib"`` or ``"skeleton"`` (module docstring).

    ``"auto"`` is replaced by ``$COOP_GA_RENDERER`` if set, then by ``"vtk"`` when
    :func:`vtk_status` allows it, else by ``"matplotlib"`` with a one-line
    :class:`~coop_ga.errors.RenderWarning` (once per process).  An explicit ``"vtk"`` that
    cannot run raises :class:`~coop_ga.errors.RendererUnavailableError`.
    """
    if backend not in BACKENDS:
        raise InvalidInputError(f"backend must be one of {', '.join(map(repr, BACKENDS))}, got {backend!r}")
    if backend == "auto":
        env = os.environ.get(ENV_RENDERER, "").strip().lower()
        if env:
            if env not in BACKENDS:
                raise InvalidInputError(f"${ENV_RENDERER} must be one of {', '.join(BACKENDS)}, got {env!r}")
            backend = env
    if backend == "vtk":
        ok, why = vtk_status()
        if not ok:
            raise RendererUnavailableError(f"the VTK renderer cannot run here: {why}; use backend='auto'")
    if backend == "auto":
        ok, why = vtk_status()
        if ok:
            return "vtk"
        _notice(f"mesh renderer (VTK) unavailable: {why}; drawing meshes with matplotlib", key="novtk")
        return "matplotlib"
    return backend


# ====================================================================== camera
def view_direction(view: tuple[float, float]) -> np.ndarray:
    """Unit vector from the scene towards the camera for ``view = (elevation, azimuth)`` [deg]
    (matplotlib's ``view_init`` convention)."""
    e, a = np.deg2rad(float(view[0])), np.deg2rad(float(view[1]))
    return np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])


@dataclass(frozen=True)
class Camera:
    """A pinhole camera: ``position``, ``focal_point`` [m] (world), ``up`` (image up), vertical
    field of view ``view_angle`` [deg], image ``width`` × ``height`` [px] (VTK's conventions)."""

    position: np.ndarray
    focal_point: np.ndarray
    up: np.ndarray
    view_angle: float
    width: int
    height: int

    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(right, up, forward) unit vectors of the image, world frame."""
        f = self.focal_point - self.position
        f = f / np.linalg.norm(f)
        r = np.cross(f, self.up)
        r /= np.linalg.norm(r)
        return r, np.cross(r, f), f

    @property
    def distance(self) -> float:
        """Camera to focal point [m]."""
        return float(np.linalg.norm(self.focal_point - self.position))

    @property
    def metres_per_pixel(self) -> float:
        """Size of one pixel at the focal distance [m]."""
        return 2.0 * self.distance * math.tan(math.radians(0.5 * self.view_angle)) / self.height

    def project(self, points: Any) -> tuple[np.ndarray, np.ndarray]:
        """Pixel coordinates (N, 2) — column from the left, row from the top — and depths (N,) [m]
        of world points (N, 3)."""
        P = np.asarray(points, dtype=float).reshape(-1, 3) - self.position
        r, u, f = self.basis()
        z = P @ f
        tv = math.tan(math.radians(0.5 * self.view_angle))
        th = tv * self.width / self.height
        x, y = (P @ r) / (z * th), (P @ u) / (z * tv)
        return np.column_stack([0.5 * (x + 1.0) * self.width, 0.5 * (1.0 - y) * self.height]), z


def frame_camera(
    points: Any, view: tuple[float, float], width: int, height: int, *, pad: float = 0.05, angle: float = VIEW_ANGLE
) -> Camera:
    """The camera looking from ``view`` (elevation, azimuth) [deg] that frames ``points`` (N, 3) [m]
    with ``pad`` [m] around them in an image of ``width`` × ``height`` [px]."""
    P = np.asarray(points, dtype=float).reshape(-1, 3)
    P = P[np.all(np.isfinite(P), axis=1)]
    if len(P) == 0:
        P = np.zeros((1, 3))
    w = view_direction(view)
    hint = np.array([0.0, 0.0, 1.0]) if abs(w[2]) < 0.999 else np.array([-w[0] - 1e-9, -w[1], 0.0]) + [0, 1e-6, 0]
    r = np.cross(-w, hint)
    r /= np.linalg.norm(r)
    u = np.cross(r, -w)
    c0 = 0.5 * (P.min(axis=0) + P.max(axis=0))
    X, Y, Z = (P - c0) @ r, (P - c0) @ u, (P - c0) @ w
    xm, ym = 0.5 * (X.min() + X.max()), 0.5 * (Y.min() + Y.max())
    tv = math.tan(math.radians(0.5 * angle))
    th = tv * width / height
    extent = float(np.ptp(P, axis=0).max()) + 2 * pad
    d = 0.0
    for _ in range(4):
        # the nearest distance at which every point (plus pad) is inside the frustum ...
        d = max(float(np.max(Z + (np.abs(X - xm) + pad) / th)), float(np.max(Z + (np.abs(Y - ym) + pad) / tv)))
        d = max(1.02 * d, float(Z.max()) + 0.25 * max(extent, 1e-3))
        # ... then centre the perspective image of the points (nearer points look larger)
        depth = d - Z
        x, y = (X - xm) / depth, (Y - ym) / depth
        xm += 0.5 * (x.min() + x.max()) * d
        ym += 0.5 * (y.min() + y.max()) * d
    focal = c0 + xm * r + ym * u
    return Camera(focal + d * w, focal, u, float(angle), int(width), int(height))


# ====================================================================== scene preparation
@dataclass
class _Robot:
    system: Any
    q: np.ndarray
    role: str
    label: str | None
    color: Any
    mesh: TriMesh | None
    skeleton: Skeleton
    end_labels: tuple[str, ...]


@dataclass
class _Prim:
    """A primitive resolved to geometry: kind, style, and what to draw (world frame, metres)."""

    p: ScenePrimitive
    spec: KindSpec
    style: dict[str, Any]
    data: dict[str, Any]

    @property
    def surface(self) -> bool:
        """A plane or sphere: drawn translucent, a patch in the legend."""
        return self.spec.dimension == 2

    @property
    def line_role(self) -> str | None:
        """A flat's axis role (``"direction"`` for a line, ``"normal"`` for a plane); None for a round."""
        return self.spec.axis_role if self.spec.flat else None


def _mesh_color(role: str) -> str:
    return {"initial": PALETTE.initial_mesh, "final": PALETTE.final_mesh}.get(role, PALETTE.robot_mesh)


def _skeleton_color(role: str) -> str:
    return {"initial": PALETTE.initial_robot, "final": PALETTE.final_robot}.get(role, PALETTE.robot)


def _robots(scene: Scene, max_faces: int, vtk_normals: bool = False) -> list[_Robot]:
    """The scene's robots in drawing order (initial, neutral, final), each with its world mesh.

    A visual object at the same pose in a robot drawn later (the same system: e.g. a fixed
    base in the initial and the final configuration) is left out of the earlier one, so the
    two surfaces do not fight for the same pixels.
    """
    order = sorted(scene.robots, key=lambda r: {"initial": 0, "neutral": 1, "final": 2}.get(r.role, 1))
    qs = [np.asarray(r.q, dtype=float).reshape(-1) for r in order]
    poses = [object_placements(r.system, q) for r, q in zip(order, qs)]
    out = []
    for i, (r, q) in enumerate(zip(order, qs)):
        P = poses[i]
        skip: set[int] = set()
        shared = False
        if P is not None:
            for j in range(i + 1, len(order)):
                Q = poses[j]
                if order[j].system is r.system and Q is not None and Q.shape == P.shape:
                    shared = True
                    same = np.all(np.abs(P - Q).reshape(len(P), -1) < 1e-9, axis=1)
                    skip |= set(np.flatnonzero(same).tolist())
        # a link turning about its own axis (a cylinder on its joint axis) nearly coincides with
        # itself in the later configuration: the earlier copy shrinks by 1 % so the two do not interleave
        shrink = _SHRINK if shared else 1.0
        m = (
            robot_mesh(
                r.system, q, max_faces=max_faces, exclude=skip, placements=P, shrink=shrink, vtk_normals=vtk_normals
            )
            if P is not None
            else None
        )
        col = _mesh_color(r.role) if m is not None else _skeleton_color(r.role)
        labels = tuple(getattr(r.system, "labels", ())) if getattr(r, "end_labels", False) else ()
        out.append(_Robot(r.system, q, r.role, r.label, col, m, skeleton(r.system, q), labels))
    return out


def _prims(scene: Scene) -> list[_Prim]:
    from ..geometry import center, closest_point_to_origin, direction, endpoints, kind_of, normal, radius

    out = []
    for p in scene.primitives:
        spec = KIND_SPECS[kind_of(p.X)]
        st = {**_primitive_style(p), **(getattr(p, "style", None) or {})}
        data: dict[str, Any] = {}
        if spec.n_points == 1:
            data["points"] = np.asarray(center(p.X), float).reshape(1, 3)
        elif spec.dimension == 0:  # a point pair: its two points
            data["points"] = np.array([np.asarray(e, float).reshape(3) for e in endpoints(p.X)])
        elif spec.flat:  # a line (base, direction) or a plane (base, normal)
            data["base"] = np.asarray(closest_point_to_origin(p.X), float)
        else:  # a circle (center, radius, normal) or a sphere (center, radius)
            data.update(center=np.asarray(center(p.X), float), radius=float(radius(p.X)))
        if spec.dimension > 0 and spec.axis_role is not None:
            read = direction if spec.axis_role == "direction" else normal
            data[spec.axis_role] = np.asarray(read(p.X), float)
        out.append(_Prim(p, spec, st, data))
    return out


def _prim_points(pr: _Prim) -> np.ndarray:
    """Points of a bounded primitive for framing (lines/planes are sized after framing)."""
    from .primitives import circle_points

    d = pr.data
    if "points" in d:  # a point or a point pair
        return d["points"]
    if pr.spec.flat:
        return np.zeros((0, 3))
    if "normal" in d:  # a circle
        P = circle_points(d["center"], d["radius"], d["normal"], 48)
        if pr.style.get("normal_arrow"):
            P = np.vstack([P, d["center"] + 0.5 * d["radius"] * d["normal"] / np.linalg.norm(d["normal"])])
        return P
    from .primitives import sphere_mesh

    return np.stack([a.ravel() for a in sphere_mesh(d["center"], d["radius"], 24)], axis=1)


def _anchor(robots: list[_Robot]) -> np.ndarray | None:
    ends = [r.skeleton.end_points.mean(axis=0) for r in robots if len(r.skeleton.end_points)]
    return np.mean(ends, axis=0) if ends else None


def _flat_geometry(pr: _Prim, anchor: np.ndarray | None, extent: float) -> np.ndarray:
    """A line's segment (2, 3) or a plane's square (4, 3) [m] about the foot of ``anchor``:
    side/length ``style['size'|'length']`` or 0.6 × the scene's extent."""
    from .primitives import _foot, square_points

    d = pr.data
    if pr.line_role == "direction":  # a line
        k = d["direction"] / np.linalg.norm(d["direction"])
        p = _foot(anchor, d["base"], k, "direction")
        L = float(pr.style.get("length") or 0.6 * extent)
        return np.array([p - 0.5 * L * k, p + 0.5 * L * k])
    p = _foot(anchor, d["base"], d["normal"], "normal")
    return square_points(p, d["normal"], float(pr.style.get("size") or 0.6 * extent))


def _scene_points(robots: list[_Robot], prims: list[_Prim], scene: Scene) -> np.ndarray:
    pts = []
    for r in robots:
        if r.mesh is not None and len(r.mesh.vertices):
            V = r.mesh.vertices
            pts.append(V[:: max(1, len(V) // 20000)])
            pts.append(V[np.concatenate([V.argmin(axis=0), V.argmax(axis=0)])])  # the extreme vertices
        else:
            pts.append(r.skeleton.points())
        pts.append(r.skeleton.end_points)
    pts += [_prim_points(p) for p in prims]
    pts += [np.asarray(c.points, float).reshape(-1, 3) for c in scene.curves]
    pts = [p for p in pts if len(p)]
    return np.vstack(pts) if pts else np.zeros((1, 3))


def _title_height(title: str | None) -> float:
    """Height [in] reserved above the image for the title (10 pt lines)."""
    if not title:
        return 0.0
    return (title.count("\n") + 1) * 10.0 * 1.3 / 72.0 + 0.08


def _legend_handles(robots: list[_Robot], prims: list[_Prim], scene: Scene) -> list[Any]:
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    hs: list[Any] = []
    for r in robots:
        if r.label:
            hs.append(Patch(facecolor=r.color, edgecolor="0.35", lw=0.6, label=r.label))
    for pr in prims:
        if not pr.p.label:
            continue
        col, ls, lw = pr.style.get("color", PALETTE.primitive), pr.style.get("ls", "-"), pr.style.get("lw", 2.0)
        if pr.surface and not _outline_only(pr):
            from matplotlib.colors import to_rgba

            hs.append(Patch(facecolor=to_rgba(col, 0.3), edgecolor=col, ls=ls, label=pr.p.label))
        elif pr.spec.n_points == 1:
            hs.append(Line2D([], [], color=col, marker="o", ls="none", label=pr.p.label))
        else:
            hs.append(Line2D([], [], color=col, ls=ls, lw=lw, label=pr.p.label))
    for c in scene.curves:
        if not c.label:
            continue
        cs = curve_style(c)
        if c.markers:
            ms = math.sqrt(float(cs["marker_size"]))
            hs.append(Line2D([], [], color=cs["color"], marker=cs["marker"], ms=ms, ls="none", label=c.label))
        else:
            hs.append(Line2D([], [], color=cs["color"], lw=cs["lw"], ls=cs["ls"], label=c.label))
    return hs


def _outline_only(pr: _Prim) -> bool:
    """An intermediate sphere: its outline only (a stack of translucent spheres would hide the robot)."""
    return pr.surface and not pr.spec.flat and pr.p.role == "intermediate"


def _overlaid(c: Any) -> bool:
    """Whether a scene curve is drawn over the VTK image: paths (role ``trajectory``) and markers; other
    curves (terrain, reference lines) keep their depth so the robot hides what is behind it."""
    return bool(c.markers or c.role == "trajectory")


@dataclass
class _Overlay:
    """A polyline or markers drawn over the rendered image (world points, matplotlib style)."""

    points: np.ndarray
    color: Any
    lw: float = 0.0
    ls: str = "-"
    marker: str | None = None
    size: float = 0.0  # marker area [pt²]
    alpha: float = 1.0


def _overlays(robots: list[_Robot], prims: list[_Prim], scene: Scene) -> list[_Overlay]:
    """What :func:`_compose` draws over the VTK image: point primitives' markers, the end-point markers of
    the robots not in the ``initial`` role, and every curve (module :mod:`coop_ga.viz.scene`)."""
    # drawn in this order: end-point markers, paths, then the markers the legend names (a target point
    # reached by a TCP stays visible over the TCP's marker)
    out = []
    for r in robots:
        if r.role != "initial" and len(r.skeleton.end_points):
            out.append(_Overlay(r.skeleton.end_points, PALETTE.end_point, marker="o", size=30.0))
    marks = []
    for c in filter(_overlaid, scene.curves):
        cs = curve_style(c)
        P = np.asarray(c.points, float).reshape(-1, 3)
        if c.markers:
            marks.append(_Overlay(P, cs["color"], marker=cs["marker"], size=float(cs["marker_size"])))
        else:
            out.append(_Overlay(P, cs["color"], lw=float(cs["lw"]), ls=cs["ls"]))
    for pr in prims:
        ms, alpha = float(pr.style.get("marker_size", 40.0)), float(pr.style.get("alpha", 1.0))
        if "points" in pr.data and ms > 0 and alpha > 0:
            col = pr.style.get("color", PALETTE.primitive)
            marks.append(_Overlay(pr.data["points"], col, marker="o", size=ms, alpha=alpha * _alpha(col)))
    return out + marks


def _draw_overlays(ax: Any, cam: Camera, overlays: list[_Overlay]) -> None:
    """Project each overlay with ``cam`` and draw it on ``ax`` (image pixels), with a white halo."""
    from matplotlib import patheffects

    for o in overlays:
        uv, z = cam.project(o.points)
        uv = np.where((z > 0)[:, None], uv, np.nan)
        if o.marker is not None:
            ax.plot(
                *uv.T,
                ls="none",
                marker=o.marker,
                ms=math.sqrt(max(o.size, 0.0)),
                color=o.color,
                mec="white",
                mew=0.8,
                alpha=o.alpha,
            )
        elif len(uv) > 1:
            halo = [patheffects.withStroke(linewidth=o.lw + 1.6, foreground="white")]
            ax.plot(*uv.T, color=o.color, lw=o.lw, ls=o.ls, alpha=o.alpha, path_effects=halo, solid_capstyle="round")


# ====================================================================== VTK
def _rgb(c: Any) -> tuple[float, float, float]:
    from matplotlib.colors import to_rgb

    r, g, b = to_rgb(c)
    return (float(r), float(g), float(b))


def _alpha(c: Any) -> float:
    from matplotlib.colors import to_rgba

    return float(to_rgba(c)[3])


def _dashes(P: np.ndarray, on: float, off: float) -> list[np.ndarray]:
    """Split the polyline P (N, 3) into dashes of length ``on`` separated by ``off`` [m]."""
    seg = np.linalg.norm(np.diff(P, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    total, out, a = float(s[-1]), [], 0.0
    while a < total:
        b = min(a + on, total)
        t = np.linspace(a, b, max(2, int(np.ceil((b - a) / max(total / len(P), 1e-12))) + 1))
        out.append(np.column_stack([np.interp(t, s, P[:, k]) for k in range(3)]))
        a = b + off
    return out


class _VTKScene:
    """Adds the scene's pieces to a PyVista plotter (tube radii from line widths in points)."""

    def __init__(self, plotter: Any, camera: Camera, dpi: int) -> None:
        self.pl = plotter
        self.px = camera.metres_per_pixel
        self.dpi = dpi
        self.w = -camera.basis()[2]

    @staticmethod
    def flat(color: Any, opacity: float = 1.0) -> dict[str, Any]:
        """Material of lines and markers: mostly ambient, so they keep the palette's colour."""
        return {
            "color": _rgb(color),
            "opacity": opacity,
            "smooth_shading": True,
            "ambient": 0.45,
            "diffuse": 0.6,
            "specular": 0.0,
        }

    def radius(self, lw_pt: float) -> float:
        """World radius [m] of a tube drawn ``lw_pt`` points wide (at the focal distance)."""
        return 0.5 * max(float(lw_pt), 0.3) * self.dpi / 72.0 * self.px

    def tube(self, P: np.ndarray, color: Any, lw: float, ls: str = "-", opacity: float = 1.0) -> None:
        pv = _pyvista()

        P = np.asarray(P, float).reshape(-1, 3)
        if len(P) < 2:
            return
        r = self.radius(lw)
        parts = [P] if ls in ("-", "solid") else _dashes(P, 10 * r, 6 * r)
        for Q in parts:
            line = pv.lines_from_points(Q)
            self.pl.add_mesh(line.tube(radius=r, n_sides=10, capping=True), **self.flat(color, opacity))

    def balls(self, P: np.ndarray, color: Any, radius: float, opacity: float = 1.0) -> None:
        pv = _pyvista()

        for p in np.asarray(P, float).reshape(-1, 3):
            s = pv.Sphere(radius=radius, center=p, theta_resolution=16, phi_resolution=12)
            self.pl.add_mesh(s, **self.flat(color, opacity))

    def marker_radius(self, size_pt2: float) -> float:
        return 0.5 * math.sqrt(max(size_pt2, 0.0)) * self.dpi / 72.0 * self.px

    def robot(self, r: _Robot, ends: bool = True) -> None:
        pv = _pyvista()

        if r.mesh is not None:
            poly = pv.PolyData.from_regular_faces(r.mesh.vertices, r.mesh.faces)
            poly.point_data["Normals"] = r.mesh.normals
            poly.point_data.active_normals_name = "Normals"
            self.pl.add_mesh(poly, color=_rgb(r.color), smooth_shading=True, specular=0.25, specular_power=20.0)
        else:
            sk = r.skeleton
            for (a, b), kind in zip(sk.segments, sk.kinds):
                if kind == "joint":
                    self.tube(np.array([a, b]), r.color, LINEWIDTH["robot"])
                elif kind == "end":
                    self.tube(np.array([a, b]), r.color, 0.55 * LINEWIDTH["robot"], "--")
                else:
                    self.tube(np.array([a, b]), PALETTE.fixed, 0.45 * LINEWIDTH["robot"])
            self.balls(sk.joints, r.color, self.radius(2.0 * LINEWIDTH["robot"]))
        if ends and r.role != "initial" and len(r.skeleton.end_points):
            self.balls(r.skeleton.end_points, PALETTE.end_point, self.marker_radius(40.0))

    def primitive(self, pr: _Prim, flat: np.ndarray | None, markers: bool = True) -> None:
        pv = _pyvista()

        from .primitives import circle_points

        st, d = pr.style, pr.data
        col = st.get("color", PALETTE.primitive)
        lw = float(st.get("lw", LINEWIDTH["primitive"]))
        ls = st.get("ls", "-")
        alpha = float(st.get("alpha", 1.0)) * _alpha(col)
        if "points" in d:  # a point or a point pair
            if len(d["points"]) > 1:
                self.tube(d["points"], col, lw, ls, alpha)
            ms = float(st.get("marker_size", 40.0))
            if ms > 0 and markers:
                self.balls(d["points"], col, self.marker_radius(ms), alpha)
        elif pr.line_role is not None:
            if flat is not None:
                self.flat_primitive(pr.line_role, flat, col, lw, ls, alpha)
        elif "normal" in d:  # a circle
            self.tube(circle_points(d["center"], d["radius"], d["normal"], int(st.get("m", 120))), col, lw, ls, alpha)
            if st.get("normal_arrow"):
                n = d["normal"] / np.linalg.norm(d["normal"])
                L = 0.5 * d["radius"]
                rr = self.radius(max(0.6 * lw, 0.8))
                arrow = pv.Arrow(
                    start=d["center"],
                    direction=n,
                    tip_length=0.25,
                    tip_radius=2.5 * rr / L,
                    shaft_radius=rr / L,
                    scale=L,
                )
                self.pl.add_mesh(arrow, **self.flat(col, alpha))
        else:  # a sphere
            outline = circle_points(d["center"], d["radius"], self.w, 120)
            if _outline_only(pr):
                self.tube(outline, col, 0.6 * lw, ls, alpha)
                return
            s = pv.Sphere(radius=d["radius"], center=d["center"], theta_resolution=48, phi_resolution=32)
            self.pl.add_mesh(s, color=_rgb(col), opacity=0.22 * alpha, smooth_shading=True, specular=0.2)
            # its outline seen from the camera, and its equator, as thin lines
            self.tube(outline, col, 0.6 * lw, ls, alpha)
            self.tube(circle_points(d["center"], d["radius"], [0.0, 0.0, 1.0], 120), col, 0.35 * lw, ls, 0.6 * alpha)

    def flat_primitive(self, role: str, flat: np.ndarray, col: Any, lw: float, ls: str, alpha: float) -> None:
        """A line's segment (role ``"direction"``) or a plane's translucent square with its outline."""
        if role == "direction":
            self.tube(flat, col, lw, ls, alpha)
            return
        pv = _pyvista()
        quad = pv.PolyData(flat, faces=np.array([4, 0, 1, 2, 3]))
        self.pl.add_mesh(quad, color=_rgb(col), opacity=0.25 * alpha, lighting=False)
        self.tube(np.vstack([flat, flat[:1]]), col, 0.5 * lw, ls, alpha)

    def curve(self, P: np.ndarray, cs: dict[str, Any], markers: bool) -> None:
        if markers:
            self.balls(P, cs["color"], self.marker_radius(float(cs["marker_size"])))
        else:
            self.tube(P, cs["color"], float(cs["lw"]), cs["ls"])


def vtk_image(
    scene: Scene,
    *,
    view: tuple[float, float],
    width: int,
    height: int,
    dpi: int,
    pad: float = 0.05,
    robots: list[_Robot] | None = None,
    overlay: bool = False,
) -> tuple[np.ndarray, Camera]:
    """Render ``scene`` with VTK offscreen: the RGB image (height, width, 3) uint8 on white, and
    the :class:`Camera` it was taken with (``camera.project`` maps world points to its pixels).

    ``overlay``: leave out the paths, point markers and end-point markers (the caller draws them
    over the image, :func:`_overlays`)."""
    pv = _pyvista()
    ok, why = vtk_status()
    if not ok:
        raise RendererUnavailableError(f"the VTK renderer cannot run here: {why}")
    robots = _robots(scene, VTK_MAX_FACES, vtk_normals=True) if robots is None else robots
    prims = _prims(scene)
    pts = _scene_points(robots, prims, scene)
    cam = frame_camera(pts, view, width, height, pad=pad)
    extent = float(np.ptp(pts, axis=0).max())
    anchor = _anchor(robots)
    pl = pv.Plotter(off_screen=True, window_size=(int(width), int(height)), lighting="light kit")
    try:
        pl.set_background("white")
        vs = _VTKScene(pl, cam, dpi)
        for r in robots:
            vs.robot(r, ends=not overlay)
        translucent = False
        for pr in prims:
            flat = _flat_geometry(pr, anchor, extent) if pr.spec.flat else None
            vs.primitive(pr, flat, markers=not overlay)
            translucent |= pr.surface or float(pr.style.get("alpha", 1.0)) < 1.0
        for c in [c for c in scene.curves if not (overlay and _overlaid(c))]:
            vs.curve(np.asarray(c.points, float).reshape(-1, 3), curve_style(c), c.markers)
        if translucent:
            pl.enable_depth_peeling(number_of_peels=6)
        pl.enable_anti_aliasing("ssaa")
        camera = pl.camera
        camera.position = tuple(cam.position)
        camera.focal_point = tuple(cam.focal_point)
        camera.up = tuple(cam.up)
        camera.view_angle = cam.view_angle
        pl.renderer.ResetCameraClippingRange()
        img = np.asarray(pl.screenshot(return_img=True))[..., :3].copy()
    finally:
        pl.close()
    return img, cam


def _compose(
    img: np.ndarray,
    cam: Camera,
    path: Path,
    *,
    size: tuple[float, float],
    dpi: int,
    title: str | None,
    handles: list[Any],
    legend: bool,
    labels: list[tuple[np.ndarray, str]],
    overlays: list[_Overlay] | None = None,
) -> Path:
    """Put the rendered image into a matplotlib figure of ``size`` [in] at ``dpi`` with the
    paper style's title, legend, ``overlays`` (:func:`_overlays`) and end-point labels, and save it as PNG."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    with style():
        fig = Figure(figsize=size, dpi=dpi)
        FigureCanvasAgg(fig)
        frac = _title_height(title) / float(size[1])
        ax = fig.add_axes((0.0, 0.0, 1.0, 1.0 - frac))
        ax.imshow(img, interpolation="antialiased", origin="upper")
        ax.set_xlim(-0.5, img.shape[1] - 0.5)
        ax.set_ylim(img.shape[0] - 0.5, -0.5)
        ax.set_axis_off()
        _draw_overlays(ax, cam, overlays or [])
        ax.set_xlim(-0.5, img.shape[1] - 0.5)
        ax.set_ylim(img.shape[0] - 0.5, -0.5)
        for p, text in labels:
            (uv,), (z,) = cam.project(p)
            if z > 0:
                ax.text(uv[0], uv[1], f"  {text}", fontsize=7, color=PALETTE.end_point, va="center")
        if title:
            fig.suptitle(title, y=1.0 - 0.04 / float(size[1]), va="top", fontsize=10)
        if legend and handles:
            _place_legend(fig, ax, handles, img)
        path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path, dpi=dpi, bbox_inches=_full(fig))
    return path


def _place_legend(fig: Any, ax: Any, handles: list[Any], img: np.ndarray) -> None:
    """The legend in the image corner where it hides the fewest drawn (non-white) pixels."""
    ink = img.min(axis=2) < 245
    renderer = fig.canvas.get_renderer()
    best: tuple[float, str] | None = None
    for loc in ("upper left", "upper right", "lower left", "lower right"):
        leg = ax.legend(handles=handles, loc=loc, fontsize=7)
        bb = leg.get_window_extent(renderer)
        (u0, v1), (u1, v0) = ax.transData.inverted().transform([[bb.x0, bb.y0], [bb.x1, bb.y1]])
        rows = slice(max(int(v0), 0), max(int(np.ceil(v1)), 0))
        cols = slice(max(int(u0), 0), max(int(np.ceil(u1)), 0))
        hidden = float(ink[rows, cols].sum())
        if best is None or hidden < best[0]:
            best = (hidden, loc)
        leg.remove()
    assert best is not None
    ax.legend(handles=handles, loc=best[1], fontsize=7)


def _full(fig: Any) -> Any:
    """The whole figure as the saved area: mesh renders keep ``size`` × ``dpi`` pixels exactly."""
    from matplotlib.transforms import Bbox

    w, h = fig.get_size_inches()
    return Bbox.from_bounds(0.0, 0.0, float(w), float(h))


def _render_vtk(
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
    W = round(float(size[0]) * dpi)
    H = round((float(size[1]) - _title_height(title)) * dpi)
    robots = _robots(scene, VTK_MAX_FACES, vtk_normals=True)
    img, cam = vtk_image(scene, view=view, width=W, height=H, dpi=dpi, pad=pad, robots=robots, overlay=True)
    labels = [(p, t) for r in robots for p, t in zip(r.skeleton.end_points, r.end_labels)]
    prims = _prims(scene)
    handles = _legend_handles(robots, prims, scene)
    overlays = _overlays(robots, prims, scene)
    return _compose(
        img,
        cam,
        path,
        size=size,
        dpi=dpi,
        title=title,
        handles=handles,
        legend=legend,
        labels=labels,
        overlays=overlays,
    )


# ====================================================================== matplotlib meshes
def _shaded(mesh: TriMesh, color: Any, light: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Triangles (m, 3, 3) and their RGBA colours: ambient 0.45 + diffuse 0.55 |n·l| (two-sided)."""
    from matplotlib.colors import to_rgba

    tri = mesh.vertices[mesh.faces]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True) + 1e-300
    k = 0.45 + 0.55 * np.abs(n @ light)
    base = np.asarray(to_rgba(color))
    rgba = np.empty((len(tri), 4))
    rgba[:, :3] = np.clip(base[:3] * k[:, None], 0.0, 1.0)
    rgba[:, 3] = 1.0
    return tri, rgba


def mpl_axes(
    scene: Scene,
    fig: Any,
    *,
    view: tuple[float, float],
    pad: float,
    rect: tuple[float, float, float, float] = (0.0, 0.0, 1.0, 1.0),
    robots: list[_Robot] | None = None,
) -> Any:
    """Draw ``scene`` with matplotlib meshes on a new 3-D axes of ``fig`` at ``rect``; returns the axes."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    from .axes import set_equal_3d
    from .primitives import draw_primitive
    from .robots import draw_robot

    robots = _robots(scene, MPL_MAX_FACES) if robots is None else robots
    prims = _prims(scene)
    ax = fig.add_axes(rect, projection="3d", computed_zorder=False)
    ax.set_proj_type("persp", focal_length=1.0 / math.tan(math.radians(0.5 * VIEW_ANGLE)))
    w = view_direction(view)
    cam_right = np.cross(-w, [0.0, 0.0, 1.0]) if abs(w[2]) < 0.999 else np.array([1.0, 0.0, 0.0])
    light = w + 0.35 * np.array([0.0, 0.0, 1.0]) - 0.25 * cam_right / (np.linalg.norm(cam_right) or 1.0)
    light /= np.linalg.norm(light)
    tris, cols = [], []
    for r in robots:
        if r.mesh is not None and r.mesh.n_faces:
            t, c = _shaded(r.mesh, r.color, light)
            tris.append(t)
            cols.append(c)
    if tris:
        # one collection: matplotlib sorts all robot triangles by depth together
        T, C = np.concatenate(tris), np.concatenate(cols)
        ax.add_collection3d(Poly3DCollection(list(T), facecolors=C, edgecolors=C, linewidths=0.15, zorder=1))
    for r in robots:
        if r.mesh is None:  # no visual geometry: its skeleton
            draw_robot(ax, r.system, r.q, color=r.color, ends=False, zorder=2)
    pts = _scene_points(robots, prims, scene)
    set_equal_3d(ax, pts, pad, tight=True)
    extent = float(np.ptp(pts, axis=0).max())
    anchor = _anchor(robots)
    for pr in prims:
        kw = dict(pr.style)
        kw.pop("m", None)
        if pr.surface and not pr.spec.flat:  # a sphere, a wireframe: thin lines, whatever the role's line width
            kw["lw"] = min(float(kw.get("lw", LINEWIDTH["wire"])), 2.0 * LINEWIDTH["wire"])
        if pr.spec.flat:
            flat = _flat_geometry(pr, anchor, extent)
            kw.setdefault("size" if pr.line_role == "normal" else "length", float(np.linalg.norm(flat[1] - flat[0])))
            kw.setdefault("anchor", anchor)
        draw_primitive(ax, pr.p.X, label=pr.p.label, zorder=3, **kw)
    for r in robots:
        if r.role != "initial" and len(r.skeleton.end_points):
            E = r.skeleton.end_points
            ax.scatter(*E.T, s=30, color=PALETTE.end_point, depthshade=False, zorder=4)
            for p, text in zip(E, r.end_labels):
                ax.text(p[0], p[1], p[2], f"  {text}", fontsize=7, color=PALETTE.end_point, zorder=5)
    for cv in scene.curves:
        C = np.asarray(cv.points, dtype=float).reshape(-1, 3)
        cs = curve_style(cv)
        if cv.markers:
            ax.scatter(*C.T, s=cs["marker_size"], color=cs["color"], marker=cs["marker"], depthshade=False, zorder=4)
        else:
            ax.plot(*C.T, color=cs["color"], lw=cs["lw"], ls=cs["ls"], zorder=4)
    ax.view_init(*view)
    ax.set_axis_off()
    _fill_axes(ax, pts)
    return ax


def _fill_axes(ax: Any, pts: np.ndarray) -> None:
    """Zoom the 3-D axes so that the projected ``pts`` fill 95 % of the axes' width or height."""
    from mpl_toolkits.mplot3d import proj3d

    fig = ax.get_figure()
    fig.canvas.draw()  # fixes the projection and the axes' transforms
    x, y, _ = proj3d.proj_transform(pts[:, 0], pts[:, 1], pts[:, 2], ax.get_proj())
    uv = ax.transData.transform(np.column_stack([x, y]))
    box = ax.get_window_extent()
    half = np.abs(uv - [0.5 * (box.x0 + box.x1), 0.5 * (box.y0 + box.y1)]).max(axis=0)  # about the axes' centre
    zoom = 0.94 * min(0.5 * box.width / max(half[0], 1e-9), 0.5 * box.height / max(half[1], 1e-9))
    ax.set_box_aspect(tuple(ax.get_box_aspect()), zoom=float(np.clip(zoom, 0.3, 3.0)))


def _render_mpl(
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

    robots = _robots(scene, MPL_MAX_FACES)
    with style():
        fig = Figure(figsize=size, dpi=dpi)
        FigureCanvasAgg(fig)
        frac = _title_height(title) / float(size[1])
        ax = mpl_axes(scene, fig, view=view, pad=pad, rect=(0.0, 0.0, 1.0, 1.0 - frac), robots=robots)
        if title:
            fig.suptitle(title, y=1.0 - 0.04 / float(size[1]), va="top", fontsize=10)
        handles = _legend_handles(robots, _prims(scene), scene)
        if legend and handles:
            ax.legend(handles=handles, loc="upper left", fontsize=7)
        path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path, dpi=dpi, bbox_inches=_full(fig))
    return path


def render_mesh_scene(
    scene: Scene,
    path: str | Path,
    *,
    backend: str,
    view: tuple[float, float],
    size: tuple[float, float],
    dpi: int,
    title: str | None,
    legend: bool,
    pad: float,
) -> Path:
    """Write ``scene`` with the mesh renderer ``backend`` (``"vtk"`` or ``"matplotlib"``) to ``path``."""
    kw = {"view": view, "size": size, "dpi": dpi, "title": title, "legend": legend, "pad": pad}
    if backend == "vtk":
        return _render_vtk(scene, Path(path), **kw)  # type: ignore[arg-type]
    return _render_mpl(scene, Path(path), **kw)  # type: ignore[arg-type]
