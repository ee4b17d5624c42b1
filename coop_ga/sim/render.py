"""Offscreen pictures of a MuJoCo scene: key frames (PNG), GIF/MP4, and overlays (primitive, force arrows).

OpenGL context (:func:`gl_status`, probed once per process)
-----------------------------------------------------------
MuJoCo's renderer needs an OpenGL context; headless machines have one through EGL (a GPU or Mesa's
llvmpipe) or OSMesa.  A broken driver can crash the process that asks for a context, so, as
:func:`coop_ga.viz.backends.vtk_status` does for VTK, a child process first renders one frame of a red
box with each candidate — ``$MUJOCO_GL`` if set; else, with a display (``DISPLAY`` /
``WAYLAND_DISPLAY``), ``glfw`` then ``egl`` and ``osmesa``; without one, ``egl`` then ``osmesa`` —
and checks the pixels.  The first that works is used in this process: ``MUJOCO_GL`` is set, and
MuJoCo's context class is switched to it even if ``mujoco`` was imported before (it picks its
context class at import from ``MUJOCO_GL``, which defaults to ``glfw``, and that needs an X
server).  Without any, :func:`require_gl` raises :class:`~coop_ga.errors.RendererUnavailableError`
saying what was tried and how to fix it.

Drawing
-------
:class:`Renderer` wraps ``mujoco.Renderer`` (offscreen framebuffer up to the scene's 1280 × 960):
``frame(data, overlays)`` renders the state in ``data`` from a :class:`Camera` (MuJoCo's free camera:
look-at point, distance, azimuth, elevation [deg]).  Robot visual meshes (geom group 2), the floor
and objects (group 0) are drawn; collision capsules (group 3) and sites (group 4) with
``show_collision`` / ``show_sites``.  Overlays are MuJoCo *user geoms* added to the renderer's
``mjvScene`` after ``update_scene`` (``mjv_initGeom`` / ``mjv_connector``; they exist in the picture
only, not in the physics): :func:`add_sphere`, :func:`add_segment`, :func:`add_polyline`,
:func:`add_arrow`, :func:`add_force` and :func:`add_primitive` (the six primitive kinds of
:mod:`coop_ga.geometry`, sampled like :mod:`coop_ga.viz.primitives` draws them).

Files: :func:`write_png`; :func:`write_video` writes ``.gif`` with Pillow (a matplotlib dependency,
always there) and ``.mp4`` with the ``ffmpeg`` executable if it is on the PATH (H.264, yuv420p);
:func:`render_log` renders a :class:`~coop_ga.sim.SimulationLog` (replaying its states) to a video.
"""

from __future__ import annotations

import itertools
import os
import shutil
import subprocess
import sys
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .. import validation
from ..errors import CoopGAError, InvalidInputError, RendererUnavailableError
from ._mujoco import mj
from .scene import GROUP_COLLISION, GROUP_SITES

__all__ = [
    "Camera",
    "Renderer",
    "add_arrow",
    "add_force",
    "add_polyline",
    "add_primitive",
    "add_segment",
    "add_sphere",
    "gl_status",
    "render_log",
    "require_gl",
    "write_png",
    "write_video",
]

_PROBE = r"""
import os, sys
os.environ["MUJOCO_GL"] = sys.argv[1]
import mujoco
m = mujoco.MjModel.from_xml_string(
    '<mujoco><visual><headlight ambient="1 1 1" diffuse="0 0 0" specular="0 0 0"/></visual>'
    '<worldbody><geom type="box" size="1 1 1" rgba="1 0 0 1"/></worldbody></mujoco>')
d = mujoco.MjData(m)
mujoco.mj_forward(m, d)
r = mujoco.Renderer(m, 8, 8)
r.update_scene(d)
px = r.render()[4, 4]
ok = px[0] > 200 and px[1] < 60
print("OK" if ok else f"wrong pixels {px.tolist()}")
sys.exit(0 if ok else 4)
"""

_STATUS: tuple[bool, str] | None = None


def _candidates() -> tuple[str, ...]:
    user = os.environ.get("MUJOCO_GL", "").strip().lower()
    if user:
        return (user,)
    if sys.platform == "darwin":
        return ("cgl", "glfw")
    if os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"):
        return ("glfw", "egl", "osmesa")
    return ("egl", "osmesa")


def _install(backend: str) -> None:
    """Make ``mujoco.Renderer`` use ``backend``'s context class in this process (module docstring)."""
    import importlib

    os.environ["MUJOCO_GL"] = backend
    mj()
    glc: Any = importlib.import_module("mujoco.rendering.classic.gl_context")
    glc.GLContext = importlib.import_module(f"mujoco.{backend}").GLContext


def gl_status() -> tuple[bool, str]:
    """(usable, backend or reason): whether MuJoCo can render offscreen here (module docstring); probed once."""
    global _STATUS
    if _STATUS is not None:
        return _STATUS
    failures = []
    for backend in _candidates():
        try:
            r = subprocess.run(
                [sys.executable, "-c", _PROBE, backend],
                capture_output=True,
                text=True,
                timeout=120,
                env=os.environ.copy(),
            )
            last = (r.stdout.strip().splitlines() or r.stderr.strip().splitlines() or [""])[-1]
            if r.returncode == 0 and last == "OK":
                _install(backend)
                _STATUS = (True, backend)
                return _STATUS
            failures.append(f"{backend}: {last[:160] or f'exit code {r.returncode}'}")
        except (subprocess.TimeoutExpired, OSError) as e:
            failures.append(f"{backend}: {e}")
    _STATUS = (False, "; ".join(failures))
    return _STATUS


def require_gl() -> str:
    """The OpenGL backend MuJoCo renders with (``"egl"``, ``"osmesa"``, …), or raise
    :class:`RendererUnavailableError` naming what was tried and the fix."""
    ok, why = gl_status()
    if not ok:
        raise RendererUnavailableError(
            f"MuJoCo cannot render offscreen here (tried {why}). Install an OpenGL context: EGL (libegl1, with a "
            "GPU driver or Mesa) or OSMesa (libosmesa6), or set MUJOCO_GL to a backend that works"
        )
    return why


# ====================================================================== camera and renderer
@dataclass(frozen=True)
class Camera:
    """MuJoCo's free camera: it looks at ``lookat`` (3,) [m] from ``distance`` [m], turned by ``azimuth``
    [deg] about the world z axis and raised by ``elevation`` [deg] (negative: from above)."""

    lookat: Any = (0.0, 0.0, 0.3)
    distance: float = 2.0
    azimuth: float = 135.0
    elevation: float = -25.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "lookat", validation.vector(self.lookat, 3, "Camera.lookat"))
        validation.positive(self.distance, "Camera.distance")
        validation.scalar(self.azimuth, "Camera.azimuth")
        validation.scalar(self.elevation, "Camera.elevation", low=-90.0, high=90.0)

    @classmethod
    def fit(cls, points: Any, *, azimuth: float = 135.0, elevation: float = -25.0, margin: float = 1.3) -> Camera:
        """A camera looking at the centre of ``points`` (n, 3) [m] from far enough to see them all."""
        P = validation.array(points, "points").reshape(-1, 3)
        c = 0.5 * (P.min(axis=0) + P.max(axis=0))
        r = float(np.max(np.linalg.norm(P - c, axis=1), initial=0.05))
        return cls(c, max(0.1, margin * r / np.tan(np.radians(22.5))), azimuth, elevation)

    def mjv(self) -> Any:
        cam = mj().MjvCamera()
        cam.type = mj().mjtCamera.mjCAMERA_FREE
        cam.lookat[:] = self.lookat
        cam.distance, cam.azimuth, cam.elevation = float(self.distance), float(self.azimuth), float(self.elevation)
        return cam


#: an overlay: called with the renderer's ``mjvScene`` after ``update_scene`` (draw with the ``add_*`` helpers)
Overlay = Callable[[Any], None]


def _new_renderer(model: Any, h: int, w: int) -> Any:
    """``mujoco.Renderer``; with EGL, once more on a fresh display if the cached one was terminated.

    MuJoCo initialises one EGL display per process and keeps it; another EGL user in the same process (VTK's
    offscreen renderer, when figures run one after another in a worker) can ``eglTerminate`` it, after which
    ``eglChooseConfig`` fails with ``EGL_NOT_INITIALIZED``.
    """
    try:
        return mj().Renderer(model, h, w)
    except Exception as e:
        if os.environ.get("MUJOCO_GL", "").lower() != "egl" or "NOT_INITIALIZED" not in repr(e):
            raise
        import mujoco.egl as mj_egl  # only importable with MUJOCO_GL=egl

        mj_egl.EGL_DISPLAY = None  # the next context initialises a display again
        return mj().Renderer(model, h, w)


class Renderer:
    """Offscreen renderer of a scene's model (module docstring).

    Args:
        model: a :class:`~coop_ga.sim.Scene` or a ``mujoco.MjModel``.
        width, height: image size [px] (≤ 1280 × 960 for a scene of :func:`~coop_ga.sim.build_scene`).
        camera: a :class:`Camera` (default: :meth:`Camera.fit` on the model's bodies).
        show_collision, show_sites: also draw collision capsules / sites.

    Raises:
        RendererUnavailableError: no OpenGL context (:func:`require_gl`).
    """

    def __init__(
        self,
        model: Any,
        width: int = 640,
        height: int = 480,
        camera: Camera | None = None,
        *,
        show_collision: bool = False,
        show_sites: bool = False,
    ):
        require_gl()
        self.model = getattr(model, "model", model)
        w, h = validation.integer(width, "width", minimum=1), validation.integer(height, "height", minimum=1)
        vis = self.model.vis.global_
        if w > vis.offwidth or h > vis.offheight:
            raise InvalidInputError(
                f"image {w}×{h} is larger than the model's offscreen buffer {vis.offwidth}×{vis.offheight}; "
                "render smaller or raise spec.visual.global_.offwidth/offheight"
            )
        self._r = _new_renderer(self.model, h, w)
        self.option = mj().MjvOption()
        self.option.geomgroup[GROUP_COLLISION] = int(bool(show_collision))
        self.option.sitegroup[GROUP_SITES] = int(bool(show_sites))
        self.camera = camera

    def frame(self, data: Any, overlays: Iterable[Overlay] = (), camera: Camera | None = None) -> np.ndarray:
        """The picture (height, width, 3) uint8 of the state in ``data`` (kinematics must be current:
        ``mj_forward`` or after ``mj_step``), with ``overlays`` drawn on top."""
        cam = camera or self.camera
        if cam is None:
            cam = self.camera = Camera.fit(np.asarray(data.xpos[1:]) if self.model.nbody > 1 else np.zeros((1, 3)))
        self._r.update_scene(data, camera=cam.mjv(), scene_option=self.option)
        for draw in overlays:
            draw(self._r.scene)
        return np.array(self._r.render())

    def close(self) -> None:
        self._r.close()

    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


# ====================================================================== overlays
def _new_geom(scn: Any) -> Any:
    if scn.ngeom >= scn.maxgeom:
        raise CoopGAError(f"the render scene is full ({scn.maxgeom} geoms); draw fewer overlays")
    g = scn.geoms[scn.ngeom]
    scn.ngeom += 1
    return g


def _rgba(rgba: Any) -> np.ndarray:
    c = validation.vector(rgba, 4, "rgba").astype(np.float32)
    if np.any((c < 0) | (c > 1)):
        raise InvalidInputError(f"rgba must be 4 numbers in [0, 1], got {rgba!r}")
    return c


def add_sphere(scn: Any, center: Any, radius: float, rgba: Any = (0.9, 0.3, 0.1, 0.35)) -> None:
    """A sphere of ``radius`` [m] at ``center`` (3,) [m] (translucent by default)."""
    c = validation.vector(center, 3, "center")
    r = validation.positive(radius, "radius")
    mj().mjv_initGeom(
        _new_geom(scn), mj().mjtGeom.mjGEOM_SPHERE, np.array([r, r, r]), c, np.eye(3).reshape(9), _rgba(rgba)
    )


def add_segment(scn: Any, a: Any, b: Any, rgba: Any = (0.9, 0.3, 0.1, 1.0), width: float = 0.004) -> None:
    """A segment from ``a`` to ``b`` (3,) [m] drawn as a capsule of radius ``width`` [m]."""
    p, q = validation.vector(a, 3, "a"), validation.vector(b, 3, "b")
    g = _new_geom(scn)
    mj().mjv_initGeom(g, mj().mjtGeom.mjGEOM_CAPSULE, np.zeros(3), np.zeros(3), np.eye(3).reshape(9), _rgba(rgba))
    mj().mjv_connector(g, mj().mjtGeom.mjGEOM_CAPSULE, validation.positive(width, "width"), p, q)


def add_polyline(
    scn: Any, points: Any, rgba: Any = (0.9, 0.3, 0.1, 1.0), width: float = 0.004, closed: bool = False
) -> None:
    """Segments through ``points`` (n, 3) [m] (and back to the first with ``closed``)."""
    P = validation.array(points, "points").reshape(-1, 3)
    seq = np.vstack([P, P[:1]]) if closed else P
    for a, b in itertools.pairwise(seq):
        add_segment(scn, a, b, rgba, width)


def add_arrow(scn: Any, origin: Any, vector: Any, rgba: Any = (0.1, 0.4, 0.9, 1.0), width: float = 0.006) -> None:
    """An arrow from ``origin`` along ``vector`` (3,) [m] (nothing for a zero vector)."""
    o, v = validation.vector(origin, 3, "origin"), validation.vector(vector, 3, "vector")
    if float(np.linalg.norm(v)) < 1e-9:
        return
    g = _new_geom(scn)
    mj().mjv_initGeom(g, mj().mjtGeom.mjGEOM_ARROW, np.zeros(3), np.zeros(3), np.eye(3).reshape(9), _rgba(rgba))
    mj().mjv_connector(g, mj().mjtGeom.mjGEOM_ARROW, validation.positive(width, "width"), o, o + v)


def add_force(
    scn: Any, point: Any, force: Any, *, scale: float = 0.01, rgba: Any = (0.1, 0.4, 0.9, 1.0), width: float = 0.006
) -> None:
    """A force ``force`` (3,) [N] acting at ``point`` (3,) [m] as an arrow of ``scale`` [m/N] × its length."""
    add_arrow(scn, point, validation.positive(scale, "scale") * validation.vector(force, 3, "force"), rgba, width)


def add_primitive(
    scn: Any,
    X: Any,
    *,
    rgba: Any = (0.9, 0.3, 0.1, 1.0),
    width: float = 0.004,
    size: float = 0.4,
    anchor: Any = None,
    segments: int = 64,
) -> None:
    """A cooperative primitive (any kind of :func:`coop_ga.kind_of`) as user geoms: a point as a small
    ball, a point pair as its segment and end balls, a line as a segment of length ``size`` [m] and a
    plane as a square of side ``size`` about their point nearest ``anchor`` (default: nearest the
    origin), a circle as a ``segments``-gon with its normal, a sphere translucent (with its equator)."""
    from ..geometry import center, closest_point_to_origin, direction, endpoints, kind_of, normal, radius
    from ..viz.primitives import _foot, circle_points, square_points

    kind = kind_of(X)
    if kind == "point":
        add_sphere(scn, np.asarray(center(X), float), 3 * width, rgba)
    elif kind == "point_pair":
        a, b = (np.asarray(p, float).reshape(3) for p in endpoints(X))
        add_segment(scn, a, b, rgba, width)
        for p in (a, b):
            add_sphere(scn, p, 2.5 * width, rgba)
    elif kind == "circle":
        c, r, n = np.asarray(center(X), float), float(radius(X)), np.asarray(normal(X), float)
        add_polyline(scn, circle_points(c, r, n, segments), rgba, width, closed=True)
        add_arrow(scn, c, 0.4 * r * n, rgba, width)
    elif kind == "sphere":
        c, r = np.asarray(center(X), float), float(radius(X))
        add_sphere(scn, c, r, (*np.asarray(rgba, float)[:3], 0.25))
        add_polyline(scn, circle_points(c, r, np.array([0.0, 0.0, 1.0]), segments), rgba, width, closed=True)
    elif kind == "line":
        d = np.asarray(direction(X), float)
        p = _foot(anchor, np.asarray(closest_point_to_origin(X), float), d, "line")
        add_segment(scn, p - 0.5 * size * d, p + 0.5 * size * d, rgba, width)
    else:  # plane
        n = np.asarray(normal(X), float)
        p = _foot(anchor, np.asarray(closest_point_to_origin(X), float), n, "plane")
        add_polyline(scn, square_points(p, n, size), rgba, width, closed=True)
        add_arrow(scn, p, 0.25 * size * n, rgba, width)


# ====================================================================== files
def _uint8_frames(frames: Iterable[Any]) -> list[np.ndarray]:
    out = [np.asarray(f) for f in frames]
    if not out:
        raise InvalidInputError("no frames to write")
    shape = out[0].shape
    for f in out:
        if f.dtype != np.uint8 or f.ndim != 3 or f.shape != shape or f.shape[2] not in (3, 4):
            raise InvalidInputError(f"frames must be (H, W, 3) uint8 images of one size, got {f.dtype} {f.shape}")
    return out


def write_png(path: str | Path, image: Any) -> Path:
    """Write an (H, W, 3) uint8 image as PNG (Pillow)."""
    from PIL import Image

    img = _uint8_frames([image])[0]
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(img).save(p)
    return p


def write_video(path: str | Path, frames: Sequence[Any], fps: float = 30.0) -> Path:
    """Write frames (H, W, 3) uint8 as ``.gif`` (Pillow) or ``.mp4`` (the ``ffmpeg`` executable; module docstring).

    Raises :class:`CoopGAError` for an ``.mp4`` without ffmpeg on the PATH (write a ``.gif`` instead).
    """
    imgs = _uint8_frames(frames)
    fps = validation.positive(fps, "fps")
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    if p.suffix.lower() == ".gif":
        from PIL import Image

        pil = [Image.fromarray(f[..., :3]) for f in imgs]
        pil[0].save(p, save_all=True, append_images=pil[1:], duration=round(1000.0 / fps), loop=0, optimize=False)
        return p
    if p.suffix.lower() != ".mp4":
        raise InvalidInputError(f"video path must end in .gif or .mp4, got {p.name!r}")
    ffmpeg = shutil.which("ffmpeg")
    if ffmpeg is None:
        raise CoopGAError("writing MP4 needs the ffmpeg executable on the PATH (apt install ffmpeg); or write a .gif")
    h, w = imgs[0].shape[:2]
    cmd = [ffmpeg, "-y", "-loglevel", "error", "-f", "rawvideo", "-pix_fmt", "rgb24", "-s", f"{w}x{h}"]
    cmd += ["-r", f"{fps:g}", "-i", "-", "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-c:v", "libx264"]
    cmd += ["-pix_fmt", "yuv420p", str(p)]
    r = subprocess.run(
        cmd, input=b"".join(np.ascontiguousarray(f[..., :3]).tobytes() for f in imgs), capture_output=True
    )
    if r.returncode != 0:
        raise CoopGAError(f"ffmpeg failed writing {p}: {r.stderr.decode(errors='replace')[-400:]}")
    return p


def render_log(
    log: Any,
    path: str | Path | None = None,
    *,
    fps: float = 25.0,
    width: int = 640,
    height: int = 480,
    camera: Camera | None = None,
    overlays: Callable[[int, Any], Iterable[Overlay]] | None = None,
) -> list[np.ndarray]:
    """Frames of a :class:`~coop_ga.sim.SimulationLog` every 1/``fps`` s of simulated time (its states set
    in a fresh ``MjData``, ``mj_forward``), written to ``path`` (``.gif``/``.mp4``) if given.

    ``overlays(k, data)`` returns the overlays of log row ``k`` (e.g. the primitive through the end
    points and the end forces).  Returns the frames.
    """
    scene = log.scene
    m = scene.model
    d = mj().MjData(m)
    step = max(1, round(1.0 / (validation.positive(fps, "fps") * float(m.opt.timestep))))
    frames = []
    with Renderer(scene, width, height, camera) as r:
        for k in range(0, len(log.time), step):
            d.qpos[:], d.qvel[:], d.time = log.qpos[k], log.qvel[k], float(log.time[k])
            if m.nmocap and len(log.mocap_pos):  # a recorded hand: its pose of that step
                d.mocap_pos[:], d.mocap_quat[:] = log.mocap_pos[k], log.mocap_quat[k]
            mj().mj_forward(m, d)
            frames.append(r.frame(d, overlays(k, d) if overlays is not None else ()))
    if path is not None:
        write_video(path, frames, fps)
    return frames
