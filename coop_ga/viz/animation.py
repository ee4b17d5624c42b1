"""Animations of a trajectory without a browser: :func:`animate` writes a GIF (or an MP4) offscreen.

Each frame is one :func:`~coop_ga.viz.render_scene` of the paper style — the robot from its visual
meshes (VTK offscreen, else matplotlib meshes; ``backend=``), the primitive of that frame (turquoise),
the first frame's primitive (green), the target (black, dashed) and the end-point paths up to that
frame (red) — under the title ``t = … s``.  The camera is the same for every frame: each scene also
holds the eight corners of the box that bounds the whole motion (robot meshes at every rendered frame,
primitives, paths) as invisible points, and the camera frames those (:func:`~coop_ga.viz.frame_camera`).

Files: :func:`write_video` — ``.gif`` with Pillow (a matplotlib dependency, always installed), ``.mp4``
with the ``ffmpeg`` executable when it is on the PATH (H.264, yuv420p; a clear
:class:`~coop_ga.errors.CoopGAError` otherwise).
"""

from __future__ import annotations

import shutil
import subprocess
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .. import validation
from ..errors import CoopGAError, InvalidInputError
from .mesh import object_mesh, object_placements, visual_geometry
from .robots import skeleton
from .scene import Scene

__all__ = ["VIDEO_SUFFIXES", "animate", "frame_indices", "write_video"]

#: file types :func:`write_video` writes
VIDEO_SUFFIXES = (".gif", ".mp4")

#: time per row [s] when no times are given (Eq 61: Δt = 0.01 s)
DEFAULT_DT = 0.01

#: an invisible scene point (framing only)
_HIDDEN = {"marker_size": 0.0, "alpha": 0.0}


def write_video(path: str | Path, frames: Sequence[Any], fps: float = 20.0) -> Path:
    """Write RGB frames (H, W, 3) uint8 (all the same size) as ``.gif`` (Pillow) or ``.mp4`` (ffmpeg).

    Args:
        path: the file (parents created); its suffix picks the format.
        frames: the images, in order.
        fps: frames per second (a GIF stores durations in 10 ms steps).

    Returns:
        The path written.

    Raises:
        InvalidInputError: no frames, frames of different sizes or not RGB, another suffix.
        CoopGAError: ``.mp4`` without ffmpeg on the PATH, or ffmpeg failed.
    """
    fps = validation.positive(fps, "fps")
    imgs = [np.ascontiguousarray(np.asarray(f)[..., :3], dtype=np.uint8) for f in frames]
    if not imgs or imgs[0].ndim != 3 or any(f.shape != imgs[0].shape for f in imgs):
        raise InvalidInputError(f"frames must be one or more RGB images of one size, got {[f.shape for f in imgs][:4]}")
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in VIDEO_SUFFIXES:
        raise InvalidInputError(f"the animation path must end in .gif or .mp4, got {p.name!r}")
    p.parent.mkdir(parents=True, exist_ok=True)
    if suffix == ".gif":
        from PIL import Image

        pil = [Image.fromarray(f) for f in imgs]
        pil[0].save(p, save_all=True, append_images=pil[1:], duration=round(1000.0 / fps), loop=0, optimize=False)
        return p
    ffmpeg = shutil.which("ffmpeg")
    if ffmpeg is None:
        raise CoopGAError(
            "writing MP4 needs the ffmpeg executable on the PATH (apt-get install ffmpeg); or write a .gif"
        )
    h, w = imgs[0].shape[:2]
    cmd = [ffmpeg, "-y", "-loglevel", "error", "-f", "rawvideo", "-pix_fmt", "rgb24", "-s", f"{w}x{h}"]
    cmd += ["-r", f"{fps:g}", "-i", "-", "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-c:v", "libx264"]
    cmd += ["-pix_fmt", "yuv420p", str(p)]
    r = subprocess.run(cmd, input=b"".join(f.tobytes() for f in imgs), capture_output=True)
    if r.returncode != 0:
        raise CoopGAError(f"ffmpeg failed writing {p}: {r.stderr.decode(errors='replace')[-400:]}")
    return p


def frame_indices(n_rows: int, frames: int) -> np.ndarray:
    """``frames`` row indices (distinct, increasing, first and last included) spread evenly over ``n_rows``."""
    n = min(int(frames), int(n_rows))
    if n <= 1:
        return np.zeros(1, dtype=int)
    return np.round(np.linspace(0.0, n_rows - 1.0, n)).astype(int)


def _per_frame_primitives(system: Any, Q: np.ndarray, primitives: Any) -> list[Any]:
    """One primitive (or None) per row of Q: None; a kind (the system's first end points); a callable
    q → primitive (e.g. ``task.primitive``); a sequence with one per row; or one primitive for all."""
    from ..geometry import N_POINTS, Primitive, primitive_from_points
    from ..geometry.kinds import KIND_SPECS

    if primitives is None:
        return [None] * len(Q)
    if isinstance(primitives, str):
        spec = KIND_SPECS[validation.choice(primitives, tuple(N_POINTS), "primitives (a kind)")]
        n = spec.n_points
        return [primitive_from_points(spec.primitive_kind, system.end_points(q)[:n]) for q in Q]
    if isinstance(primitives, Primitive):
        return [primitives] * len(Q)
    if callable(primitives):
        return [primitives(q) for q in Q]
    if isinstance(primitives, Sequence) and len(primitives) == len(Q):
        return list(primitives)
    raise InvalidInputError(
        "primitives must be None, a kind ('circle', ...), a callable q -> Primitive (e.g. task.primitive), one "
        f"Primitive, or one Primitive per row of the trajectory ({len(Q)}); got {type(primitives).__name__}"
    )


def _one_per_row(primitives: Any, n_rows: int) -> bool:
    """Whether ``primitives`` is a sequence with one primitive (or None) per trajectory row."""
    from ..geometry import Primitive

    if isinstance(primitives, (str, Primitive)) or not isinstance(primitives, Sequence):
        return False
    return len(primitives) == n_rows


def _robot_bounds(system: Any, Q: np.ndarray) -> np.ndarray:
    """Points (N, 3) [m] that bound the robot over the rows of Q: the corners of each visual object's box
    at its pose (the skeleton without visual geometry)."""
    gm = visual_geometry(system)
    if gm is None:
        return np.vstack([skeleton(system, q).points() for q in Q])
    boxes = []
    for o in gm.geometryObjects:
        m = object_mesh(o)
        V = m.vertices if m is not None and len(m.vertices) else np.zeros((1, 3))
        lo, hi = V.min(axis=0), V.max(axis=0)
        boxes.append(np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]))
    B = np.stack(boxes)  # (G, 8, 3)
    out = []
    for q in Q:
        P = object_placements(system, q)
        assert P is not None
        out.append(np.einsum("gij,gkj->gki", P[:, :3, :3], B).reshape(-1, 3) + np.repeat(P[:, :3, 3], 8, axis=0))
    return np.vstack(out)


def _primitive_points(X: Any) -> np.ndarray:
    """Points that bound a bounded primitive (lines and planes are sized to the scene afterwards)."""
    from .backends import _prim_points, _prims

    return _prim_points(_prims(Scene().primitive(X))[0])


def _box_corners(points: np.ndarray, pad: float) -> np.ndarray:
    P = np.asarray(points, float).reshape(-1, 3)
    P = P[np.all(np.isfinite(P), axis=1)]
    lo, hi = P.min(axis=0) - pad, P.max(axis=0) + pad
    return np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])


def _same_size(images: list[np.ndarray]) -> list[np.ndarray]:
    """Pad (white) every image to the largest height and width (the skeleton renderer crops tightly)."""
    H = max(im.shape[0] for im in images)
    W = max(im.shape[1] for im in images)
    out = []
    for im in images:
        canvas = np.full((H, W, 3), 255, dtype=np.uint8)
        canvas[: im.shape[0], : im.shape[1]] = im[..., :3]
        out.append(canvas)
    return out


def animate(
    system: Any,
    trajectory: Any,
    primitives: Any = None,
    path: str | Path = "animation.gif",
    *,
    fps: float = 20.0,
    t: Any = None,
    frames: int | None = None,
    target: Any = None,
    paths: bool = True,
    view: tuple[float, float] = (22.0, -60.0),
    size: tuple[float, float] = (6.0, 4.5),
    dpi: int = 100,
    backend: str = "auto",
    title: str | None = None,
    pad: float | None = None,
    progress: bool = False,
) -> Path:
    """Render ``trajectory`` of ``system`` offscreen to a GIF or MP4 (module docstring).

    Args:
        system: a :class:`~coop_ga.systems.System`.
        trajectory: (T, nq) configurations [rad | m] (e.g. ``result.trajectory``).
        primitives: the primitive of each frame: None; a kind (``"circle"``: through the system's first
            end points, as ``cooperative_task``'s default); a callable ``q -> Primitive`` (``task.primitive``);
            one :class:`~coop_ga.Primitive`; or one Primitive (or None) per row.
        path: ``.gif`` or ``.mp4``.
        fps: frames per second of the file.
        t: (T,) times [s] (default 0.01 s per row, Eq 61).
        frames: how many frames (rows spread evenly; default: real time at ``fps``, at most T).
        target: a target :class:`~coop_ga.Primitive` drawn black and dashed.
        paths: draw the end-point paths up to each frame.
        view: as :func:`~coop_ga.viz.render_scene`.
        size: as :func:`~coop_ga.viz.render_scene`: the size [in] of a frame.
        dpi: as :func:`~coop_ga.viz.render_scene`: the dpi of a frame.
        backend: as :func:`~coop_ga.viz.render_scene`.
        pad: margin [m] around the box of the whole motion (default: 4 % of its largest side, so a hand
            fills the frame as a humanoid does).
        title: a first title line (the second is ``t = … s``).
        progress: a progress bar on stderr.

    Returns:
        The path written.

    Raises:
        InvalidInputError: a trajectory of the wrong shape, times of the wrong length, bad primitives or
            path.  CoopGAError: ``.mp4`` without ffmpeg.
    """
    Q, tt = _checked_motion(system, trajectory, t, path)
    fps = validation.positive(fps, "fps")
    n = round((tt[-1] - tt[0]) * fps) + 1 if frames is None else validation.integer(frames, "frames", minimum=1)
    idx = frame_indices(len(Q), n)
    if _one_per_row(primitives, len(Q)):  # one primitive (or None) per row: those of the rendered rows
        primitives = [primitives[k] for k in idx]
    prims = _per_frame_primitives(system, Q[idx], primitives)
    ends = np.array([system.end_points(q) for q in Q])  # (T, k, 3)
    corners = _framing(system, Q[idx], prims, target, ends if paths else ends[idx], pad)
    # the corners hold the margin already
    render = _frame_renderer(system, view=view, size=size, dpi=dpi, backend=backend, pad=0.0, title=title)
    from tqdm.auto import tqdm

    images = []
    with tempfile.TemporaryDirectory(prefix="coop_ga_animation_") as tmp:
        for j, k in enumerate(tqdm(idx, desc=f"animating {Path(path).name}", disable=not progress)):
            initial = prims[0] if j > 0 else None
            sc = _frame_scene(system, Q[k], initial, target, prims[j], ends[: k + 1] if paths and k > 0 else None)
            for c in corners:
                sc.primitive(_point(c), "neutral", style=_HIDDEN)
            images.append(render(sc, Path(tmp) / f"{j:05d}.png", float(tt[k] - tt[0])))
    return write_video(path, _same_size(images), fps)


def _checked_motion(system: Any, trajectory: Any, t: Any, path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """The (T, nq) trajectory and its (T,) times [s], checked; the file suffix checked before any rendering."""
    Q = validation.array(trajectory, "trajectory")
    if Q.ndim != 2 or Q.shape[1] != system.nq or len(Q) < 1:
        raise InvalidInputError(f"trajectory must be (T, {system.nq}) for system {system.name!r}, got {Q.shape}")
    tt = DEFAULT_DT * np.arange(len(Q)) if t is None else validation.array(t, "t")
    if tt.shape != (len(Q),):
        raise InvalidInputError(f"t must have one time per row ({len(Q)}), got shape {tt.shape}")
    if Path(path).suffix.lower() not in VIDEO_SUFFIXES:
        raise InvalidInputError(f"the animation path must end in .gif or .mp4, got {Path(path).name!r}")
    return Q, tt


def _frame_scene(system: Any, q: np.ndarray, initial: Any, target: Any, current: Any, ends: Any) -> Scene:
    """One frame: the robot at ``q``, the initial (from the second frame on), target and current primitives
    (None: not drawn), and the end-point paths ``ends`` (k+1, n, 3) up to this row (None: none)."""
    sc = Scene().robot(system, q)
    if initial is not None:
        sc.primitive(initial, "initial")
    if target is not None:
        sc.primitive(target, "target")
    if current is not None:
        sc.primitive(current, "final")
    if ends is not None:
        for i in range(ends.shape[1]):
            sc.curve(ends[:, i], "trajectory")
    return sc


def _point(c: np.ndarray) -> Any:
    from ..geometry import point

    return point(np.asarray(c, float))


def _framing(
    system: Any, Q: np.ndarray, prims: list[Any], target: Any, ends: np.ndarray, pad: float | None
) -> np.ndarray:
    """The 8 corners of the box around everything the animation draws, ``pad`` [m] around it (None: 4 % of
    the box's largest side; module docstring)."""
    pts = [_robot_bounds(system, Q), np.asarray(ends, float).reshape(-1, 3)]
    pts += [_primitive_points(X) for X in [*prims, target] if X is not None]
    P = np.vstack([p for p in pts if len(p)])
    P = P[np.all(np.isfinite(P), axis=1)]
    margin = 0.04 * float(np.ptp(P, axis=0).max()) if pad is None else validation.nonnegative(pad, "pad")
    return _box_corners(P, margin)


def _frame_renderer(system: Any, **kw: Any) -> Callable[[Scene, Path, float], np.ndarray]:
    """``render(scene, png, time) -> image (H, W, 3)``: one :func:`render_scene` call, read back."""
    from PIL import Image

    from .backends import resolve_backend
    from .scene import render_scene

    backend = resolve_backend(kw.pop("backend"))  # once: the notice of a fallback is given once
    head = kw.pop("title")

    def render(scene: Scene, png: Path, time: float) -> np.ndarray:
        title = f"t = {time:.2f} s" if head is None else f"{head}\nt = {time:.2f} s"
        render_scene(scene, png, backend=backend, title=title, legend=False, **kw)
        with Image.open(png) as im:
            return np.asarray(im.convert("RGB"))

    return render
