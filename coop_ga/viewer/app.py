"""The two pages of the viewer: teleoperation (:func:`serve`) and trajectory playback (:func:`play`).

Both start a viser server (http://HOST:PORT, one page per browser tab; every tab sees the same scene)
and return a :class:`Viewer`.  ``block=True`` (the command line) serves until Ctrl+C; ``block=False``
returns at once (notebooks, tests) and :meth:`Viewer.stop` ends it.

Teleoperation: a thread steps the :class:`~coop_ga.viewer.session.TeleopSession` every Δt = 1/``rate``
seconds of wall time and moves the robots, the primitive (turquoise, the paper's *final* colour), its
target (black, dashed) and the end points (red); the start primitive stays in green.  The gizmo and the
scale slider set the target (:meth:`TeleopSession.set_target_pose`); the read-outs (‖e‖, well-definedness,
manipulability per bivector direction, active limits, warnings, the measured control rate) are
refreshed ten times a second.

Playback: a time slider, play/pause, speed and loop; the robots, the primitive at each frame (turquoise;
green at the first frame), the target (black, dashed; a target point as a black dot), the end-point paths
up to the current frame (red) and the free objects of a physics log.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from .. import validation
from ..diagnostics import collect_warnings
from ..errors import CoopGAError, InvalidInputError
from ..geometry.kinds import Kind, kind_spec
from ..viz.style import PALETTE
from .drawing import DEFAULT_MAX_FACES, BodyNode, PathNode, PointsNode, PrimitiveNode, RobotNode
from .recording import Recording, load_recording
from .session import DILATION_KINDS, ROWS, TeleopSession, collected

__all__ = ["Viewer", "play", "play_file", "play_recording", "serve"]

#: read-outs refreshed every this many seconds
GUI_PERIOD = 0.1


def _viser() -> Any:
    try:
        import viser
    except ImportError as e:
        raise CoopGAError(f"the viewer needs viser ({e}); pip install 'coop_ga[viewer]'") from None
    return viser


class Viewer:
    """A running viewer (module docstring).

    Attributes:
        server: the ``viser.ViserServer``.  url: ``http://host:port``.  port: the port bound.
        clients_seen: how many browser connections the server has had.  frames: scene updates drawn.
        session: the :class:`TeleopSession` (teleoperation) or None.  recording: the :class:`Recording`
            (playback) or None.  page: the page's scene nodes and controls.
    """

    def __init__(self, server: Any, host: str):
        self.server = server
        self.port: int = int(server.get_port())
        self.url = f"http://{host}:{self.port}"
        self.clients_seen = 0
        self.frames = 0
        self.session: TeleopSession | None = None
        self.recording: Recording | None = None
        self.page: Any = None
        self.lock = threading.RLock()
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []
        server.on_client_connect(self._connected)

    def _connected(self, client: Any) -> None:
        self.clients_seen += 1

    def start(self, target: Callable[[], None], name: str) -> None:
        th = threading.Thread(target=target, name=name, daemon=True)
        self._threads.append(th)
        th.start()

    @property
    def stopped(self) -> bool:
        return self._stop.is_set()

    def stop(self) -> None:
        """Stop the threads and the server (idempotent)."""
        if self._stop.is_set():
            return
        self._stop.set()
        for th in self._threads:
            th.join(timeout=5.0)
        self.server.stop()

    def wait(self) -> None:
        """Serve until Ctrl+C (or :meth:`stop` from another thread)."""
        try:
            while not self._stop.wait(0.5):
                pass
        except KeyboardInterrupt:
            pass
        finally:
            self.stop()

    def __enter__(self) -> Viewer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


def _server(host: str, port: int, title: str) -> Viewer:
    viser = _viser()
    validation.integer(port, "port", minimum=0)
    server = viser.ViserServer(host=host, port=int(port), label=title, verbose=False)
    server.scene.set_up_direction("+z")
    server.scene.add_grid("/grid", width=4.0, height=4.0, cell_size=0.1, section_size=0.5, plane="xy")
    server.gui.configure_theme(control_width="large")
    return Viewer(server, host)


def _frame_camera(server: Any, points: np.ndarray) -> None:
    """Look at the bounding box of ``points`` (N, 3) [m] from the paper figures' side (elevation 22°,
    azimuth −60°), near enough that it fills the view (viser's vertical field of view, 75° by default)."""
    P = np.asarray(points, float).reshape(-1, 3)
    c = 0.5 * (P.min(axis=0) + P.max(axis=0))
    r = 0.5 * max(float(np.linalg.norm(P.max(axis=0) - P.min(axis=0))), 0.3)
    e, a = np.deg2rad(22.0), np.deg2rad(-60.0)
    w = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
    d = 1.1 * r / np.sin(0.5 * float(server.initial_camera.fov))
    server.initial_camera.position = tuple(c + d * w)
    server.initial_camera.look_at = tuple(c)
    server.initial_camera.up = (0.0, 0.0, 1.0)


def _lines_extent(points: np.ndarray) -> float:
    """Length [m] of the drawn piece of a line / side of a plane: 1.5 × the spread of the end points (≥ 0.5 m)."""
    P = np.asarray(points, float).reshape(-1, 3)
    return max(0.5, 1.5 * float(np.ptp(P, axis=0).max())) if len(P) else 1.0


def _mean(points: np.ndarray) -> np.ndarray:
    return np.asarray(points, float).reshape(-1, 3).mean(axis=0)


# ====================================================================== teleoperation
class _TeleopPage:
    """The scene and the controls of the teleoperation page, bound to a session."""

    def __init__(self, viewer: Viewer, session: TeleopSession, max_faces: int | None):
        self.viewer, self.session = viewer, session
        sc, gui = viewer.server.scene, viewer.server.gui
        task = session.task
        pts = task.points(session.q0)
        self.extent = _lines_extent(pts)
        self.robot = RobotNode(sc, "/robot", task.system, max_faces=max_faces)
        self.start = PrimitiveNode(sc, "/primitive/start", PALETTE.initial_primitive, width=2.0)
        self.target_node = PrimitiveNode(sc, "/primitive/target", PALETTE.target_primitive, width=3.0, dashed=True)
        self.current = PrimitiveNode(sc, "/primitive/current", PALETTE.final_primitive, width=5.0)
        self.ends = PointsNode(sc, "/end_points")
        self.start.update(task.primitive(session.q0), _mean(pts), self.extent)
        p, wxyz, s = session.handle_pose()
        self.gizmo = sc.add_transform_controls("/gizmo", scale=0.25, position=p, wxyz=wxyz)
        self._pending: tuple[np.ndarray, np.ndarray, float] | None = None
        self._target_drawn: Any = None
        with gui.add_folder("Target (the cooperative similarity)"):
            self.scale = gui.add_slider(
                "scale (dilation)", 0.5, 2.0, 0.01, float(s), disabled=session.kind not in DILATION_KINDS
            )
            hold = gui.add_button("hold here", hint="make the current pose the target")
            reset = gui.add_button("reset", hint="back to q0 and the start pose")
        with gui.add_folder("Read-outs"):
            self.text = gui.add_markdown("")
        self.gizmo.on_update(lambda _: self._queue())
        self.scale.on_update(lambda _: self._queue())
        hold.on_click(lambda _: self._hold())
        reset.on_click(lambda _: self._reset())
        _frame_camera(
            viewer.server,
            np.vstack([pts, self.robot.placements(session.q0)[:, :3, 3]]) if self.robot.geometry is not None else pts,
        )
        self.draw()

    # -------------------------------------------------------------- events (viser's threads)
    def _queue(self) -> None:
        with self.viewer.lock:
            self._pending = (np.array(self.gizmo.position), np.array(self.gizmo.wxyz), float(self.scale.value))

    def _hold(self) -> None:
        with self.viewer.lock:
            self._pending = None
            self.session.hold()
            self._show_target()

    def _reset(self) -> None:
        with self.viewer.lock:
            self._pending = None
            self.session.reset()
            self._show_target()

    def _show_target(self) -> None:
        p, wxyz, s = self.session.handle_pose()
        self.gizmo.position, self.gizmo.wxyz = p, wxyz
        self.scale.value = float(np.clip(s, 0.5, 2.0))

    # -------------------------------------------------------------- the control thread
    def tick(self) -> None:
        """One control step (apply a pending gizmo pose, step, draw)."""
        with self.viewer.lock:
            if self._pending is not None:
                self.session.set_target_pose(*self._pending)
                self._pending = None
            self.session.step()
            self.draw()

    def draw(self) -> None:
        with self.viewer.server.atomic():  # one message batch (and one wake-up of viser's loop) per frame
            self._draw()

    def _draw(self) -> None:
        s = self.session
        q = s.teleop.q
        pts = s.task.points(q)
        self.robot.update(q)
        self.current.update(s.task.primitive(q), _mean(pts), self.extent)
        self.ends.update(pts)
        if self._target_drawn is not s.target:
            self.target_node.update(s.target.apply(s.task.unit), _mean(pts), self.extent)
            self._target_drawn = s.target
        self.viewer.frames += 1

    def show_readouts(self) -> None:
        self.text.content = readout_markdown(self.session)


def readout_markdown(session: TeleopSession) -> str:
    """The read-outs of a session as Markdown (module docstring of :mod:`coop_ga.viewer.session`)."""
    r = session.readout
    lines = [
        f"**‖e‖ = {r.error_norm:.2e}** · well-definedness {r.well_definedness:.3f}",
        f"control rate **{r.rate:.1f} Hz** (step {r.step_ms:.1f} ms, Δt {1e3 * session.dt:.1f} ms) · t = {r.t:.2f} s",
        f"sixth axis: {session.rz_mode}",
        "",
        "| | " + " | ".join(ROWS) + " |",
        "|---|" + "---|" * len(ROWS),
        "| e | " + " | ".join(f"{x:+.3f}" for x in r.error) + " |",
        "| b | " + " | ".join(f"{x:+.3f}" for x in r.bivector) + " |",
        "| ‖J_i‖ | " + " | ".join(f"{x:.3f}" for x in r.manipulability) + " |",
        "",
        "active limits: " + (", ".join(r.active_limits()) or "none"),
    ]
    if r.error_message:
        lines += ["", f"⚠ {r.error_message}"]
    for w in session.warnings.values():
        lines += ["", f"⚠ **{w.category}** ×{w.count} (last at t = {w.time:.2f} s): {w.message}"]
    return "\n".join(lines)


def serve(
    task: Any,
    q0: Any = None,
    *,
    host: str = "127.0.0.1",
    port: int = 8080,
    rate: float = 60.0,
    max_faces: int | None = DEFAULT_MAX_FACES,
    block: bool = True,
    **session_options: Any,
) -> Viewer:
    """Teleoperate ``task`` in the browser: a gizmo at the primitive's centre and a scale slider set the
    target similarity, the robots follow through the limit-aware differential IK (module docstring).

    Args:
        task: a :class:`~coop_ga.CooperativeTask` (e.g. ``coop_ga.cooperative_task("three_franka", "circle")``).
        q0: (nq,) start configuration (default ``task.system.q0``).
        host: the address to serve on.
        port: the port to serve on (0: a free port, see :attr:`Viewer.port`).
        rate: control steps per second of wall time (Δt = 1/rate in Eq 61).
        max_faces: triangles per robot sent to the browser (None: full meshes).
        block: serve until Ctrl+C (True) or return the running :class:`Viewer` at once (False).
        **session_options: :class:`~coop_ga.viewer.session.TeleopSession` options (``servo_gain``,
            ``translation_gain``, ``rotation_gain``, ``dilation_gain``, ``rz_mode``, ``limit_mode``, ...).

    Returns:
        The :class:`Viewer` (already stopped when ``block=True``).

    Raises:
        InvalidInputError: bad arguments.  CoopGAError: viser is not installed.
    """
    rate = validation.positive(rate, "rate")
    session = TeleopSession(task, q0, dt=1.0 / rate, **session_options)
    viewer = _server(host, port, f"coop_ga · {task.system.name} · {task.kind}")
    try:
        page = _TeleopPage(viewer, session, max_faces)
    except BaseException:
        viewer.stop()
        raise
    viewer.session, viewer.page = session, page
    viewer.start(lambda: _control_loop(viewer, page), "coop_ga-viewer-control")
    if block:
        print(f"coop_ga viewer: {viewer.url} (Ctrl+C to stop)", flush=True)
        viewer.wait()
    return viewer


def _control_loop(viewer: Viewer, page: _TeleopPage) -> None:
    """Step every Δt of wall time; read-outs every :data:`GUI_PERIOD`."""
    dt = page.session.dt
    next_step = next_gui = time.perf_counter()
    while not viewer.stopped:
        page.tick()
        now = time.perf_counter()
        if now >= next_gui:
            page.show_readouts()
            next_gui = now + GUI_PERIOD
        next_step += dt
        if next_step < now - dt:  # fell behind (a slow machine): do not try to catch up
            next_step = now
        viewer._stop.wait(max(0.0, next_step - time.perf_counter()))


# ====================================================================== playback
def _frame_primitives(system: Any, Q: np.ndarray, primitives: Any) -> tuple[list[Any], dict[str, str]]:
    """One primitive (or None) per frame from ``primitives`` (None, a kind, a CooperativeTask or a sequence),
    and the warnings met (condition → message with its count).  A frame whose primitive the library refuses
    (degenerate end points) has None."""
    if primitives is None:
        return [None] * len(Q), {}
    if isinstance(primitives, str):
        from ..cooperative import cooperative_task

        primitives = cooperative_task(system, kind_spec(primitives).name)  # checked: an unknown kind raises
    if not (hasattr(primitives, "primitive") and hasattr(primitives, "points")):
        if isinstance(primitives, Sequence) and len(primitives) == len(Q):
            return list(primitives), {}
        raise InvalidInputError(
            "primitives must be None, a kind ('circle', ...), a CooperativeTask or one Primitive per frame "
            f"({len(Q)}), got {type(primitives).__name__}"
        )
    out: list[Any] = []
    refused: list[int] = []
    with collect_warnings(emit=False) as seen:
        for k, q in enumerate(Q):
            try:
                out.append(primitives.primitive(q))
            except CoopGAError:
                out.append(None)
                refused.append(k)
    notes = {label: f"{message} (×{count})" for label, _, message, count in collected(seen)}
    if refused:
        notes["refused"] = f"no primitive at {len(refused)} frame(s) (first: {refused[0]}): degenerate end points"
    return out, notes


class _PlaybackPage:
    """The scene and the controls of the playback page."""

    SPEEDS = ("0.1", "0.25", "0.5", "1", "2", "4")

    def __init__(self, viewer: Viewer, rec: Recording, prims: list[Any], notes: dict[str, str], max_faces: int | None):
        self.viewer, self.rec, self.prims, self.notes = viewer, rec, prims, notes
        sc, gui = viewer.server.scene, viewer.server.gui
        self.ends = np.array([rec.system.end_points(q) for q in rec.q])  # (T, k, 3)
        if rec.base is not None:
            self.ends = np.einsum("tij,tkj->tki", rec.base[:, :3, :3], self.ends) + rec.base[:, None, :3, 3]
        self.extent = _lines_extent(self.ends[0])
        self.robot = RobotNode(sc, "/robot", rec.system, max_faces=max_faces)
        self.current = PrimitiveNode(sc, "/primitive/current", PALETTE.final_primitive, width=5.0)
        self.paths = PathNode(sc, "/paths")
        self.dots = PointsNode(sc, "/end_points")
        self.bodies = [BodyNode(sc, f"/objects/{b.name}", b.shapes) for b in rec.bodies]
        self._static(sc)
        T = len(rec.q)
        with gui.add_folder("Playback"):
            self.slider = gui.add_slider("frame", 0, T - 1, 1, 0)
            self.clock = gui.add_markdown("")
            self.button = gui.add_button("play")
            self.speed = gui.add_dropdown("speed", self.SPEEDS, initial_value="1")
            self.loop = gui.add_checkbox("loop", True)
        with gui.add_folder("Recording"):
            gui.add_markdown(self._info())
        self.playing = False
        self._t0 = (0.0, 0.0)  # (wall time, trajectory time) when play was pressed
        self.slider.on_update(lambda _: self.draw(int(self.slider.value)))
        self.button.on_click(lambda _: self.toggle())
        _frame_camera(viewer.server, self.ends.reshape(-1, 3))
        self.draw(0)

    def _static(self, sc: Any) -> None:
        rec, anchor = self.rec, _mean(self.ends[0])
        if self.prims[0] is not None:
            PrimitiveNode(sc, "/primitive/start", PALETTE.initial_primitive, width=2.0).update(
                self.prims[0], anchor, self.extent
            )
        if rec.target is not None and rec.kind is not None:
            from ..geometry import unit_primitive

            X = rec.target.apply(unit_primitive(_primitive_kind(rec.kind)))
            PrimitiveNode(sc, "/primitive/target", PALETTE.target_primitive, width=3.0, dashed=True).update(
                X, anchor, self.extent
            )
        if rec.target_point is not None:
            PointsNode(sc, "/target_point", PALETTE.target_primitive, 0.03).update(rec.target_point)

    def _info(self) -> str:
        r = self.rec
        lines = [
            f"**{r.system.name}**, {r.q.shape[1]} joints, {len(r.q)} frames over {r.t[-1] - r.t[0]:.2f} s",
            f"primitive: {r.kind or 'none'}",
        ]
        if r.source:
            lines.append(f"source: `{r.source}` (array `{r.key}`)")
        if r.alternatives:
            lines.append("other trajectories in the file: " + ", ".join(f"`{k}`" for k in r.alternatives))
        lines += [f"⚠ **{label}**: {msg}" for label, msg in self.notes.items()]
        return "\n\n".join(lines)

    def draw(self, k: int) -> None:
        """Show frame k."""
        with self.viewer.lock, self.viewer.server.atomic():
            k = int(np.clip(k, 0, len(self.rec.q) - 1))
            r = self.rec
            base = None if r.base is None else r.base[k]
            self.robot.update(r.q[k], base)
            self.current.update(self.prims[k], _mean(self.ends[k]), self.extent)
            self.dots.update(self.ends[k])
            self.paths.update(self.ends.transpose(1, 0, 2), upto=k + 1)
            for node, b in zip(self.bodies, r.bodies):
                node.update(b.positions[k], b.wxyz[k])
            self.clock.content = f"t = {r.t[k] - r.t[0]:.3f} s / {r.t[-1] - r.t[0]:.3f} s"
            self.viewer.frames += 1

    def toggle(self) -> None:
        self.playing = not self.playing
        self.button.label = "pause" if self.playing else "play"
        if self.playing:
            k = int(self.slider.value)
            if k >= len(self.rec.q) - 1:
                k = 0
            self._t0 = (time.perf_counter(), float(self.rec.t[k]))

    def advance(self) -> None:
        """Move the slider to the frame of the current wall time (called by the playback thread)."""
        if not self.playing:
            return
        t = self.rec.t
        now = self._t0[1] + float(self.speed.value) * (time.perf_counter() - self._t0[0])
        if now > t[-1]:
            if self.loop.value:
                self._t0 = (time.perf_counter(), float(t[0]))
                now = float(t[0])
            else:
                self.slider.value = len(t) - 1
                self.toggle()
                return
        self.slider.value = min(int(np.searchsorted(t, now)), len(t) - 1)


def _primitive_kind(kind: str) -> Kind:
    """The exact kind of a task kind (``"sphere"`` for ``"sphere_fit"``; :attr:`KindSpec.primitive_kind`)."""
    return kind_spec(kind).primitive_kind


def play_recording(
    rec: Recording,
    primitives: Any = None,
    *,
    host: str = "127.0.0.1",
    port: int = 8080,
    max_faces: int | None = DEFAULT_MAX_FACES,
    fps: float = 60.0,
    block: bool = True,
) -> Viewer:
    """Play a :class:`~coop_ga.viewer.recording.Recording` (see :func:`play`); ``primitives`` defaults to ``rec.kind``."""
    prims, notes = _frame_primitives(rec.system, rec.q, rec.kind if primitives is None else primitives)
    viewer = _server(host, port, f"coop_ga · {rec.system.name} · playback")
    try:
        page = _PlaybackPage(viewer, rec, prims, notes, max_faces)
    except BaseException:
        viewer.stop()
        raise
    viewer.recording = rec
    period = 1.0 / validation.positive(fps, "fps")

    def run() -> None:
        while not viewer._stop.wait(period):
            page.advance()

    viewer.start(run, "coop_ga-viewer-playback")
    viewer.page = page
    if block:
        print(f"coop_ga viewer: {viewer.url} (Ctrl+C to stop)", flush=True)
        viewer.wait()
    return viewer


def play(
    system: Any,
    trajectory: Any,
    primitives: Any = None,
    *,
    t: Any = None,
    target: Any = None,
    host: str = "127.0.0.1",
    port: int = 8080,
    max_faces: int | None = DEFAULT_MAX_FACES,
    block: bool = True,
) -> Viewer:
    """Play a joint trajectory in the browser with a time slider and play/pause (module docstring).

    Args:
        system: a :class:`~coop_ga.systems.System` or a registered name.
        trajectory: (T, nq) configurations [rad | m] (e.g. ``result.trajectory`` of any controller).
        primitives: None; a primitive kind (``"circle"``: the cooperative primitive of the system's first end
            points at each frame); a :class:`~coop_ga.CooperativeTask`; or one :class:`~coop_ga.Primitive`
            (or None) per frame.
        t: (T,) times [s] (default: 0.01 s per frame, Eq 61).
        target: a target :class:`~coop_ga.Similarity` (drawn black and dashed; needs a kind or a task).
        host: as :func:`serve`.
        port: as :func:`serve`.
        max_faces: as :func:`serve`.
        block: as :func:`serve`.

    Returns:
        The :class:`Viewer`.

    Raises:
        InvalidInputError: a trajectory of the wrong shape, times of the wrong length, bad primitives.
    """
    from .recording import _system

    sys_ = _system(system)
    Q = validation.array(trajectory, "trajectory")
    if Q.ndim != 2 or Q.shape[1] != sys_.nq or len(Q) < 1:
        raise InvalidInputError(f"trajectory must be (T, {sys_.nq}) for system {sys_.name!r}, got {Q.shape}")
    tt = 0.01 * np.arange(len(Q)) if t is None else validation.array(t, "t")
    if tt.shape != (len(Q),):
        raise InvalidInputError(f"t must have one time per frame ({len(Q)}), got shape {tt.shape}")
    kind = primitives if isinstance(primitives, str) else getattr(primitives, "primitive_kind", None)
    tgt = None if target is None else validation.target(target)
    rec = Recording(sys_, Q, tt, kind=kind, target=tgt, source="", key="trajectory")
    return play_recording(rec, primitives, host=host, port=port, max_faces=max_faces, block=block)


def play_file(
    path: Any, *, key: str | None = None, system: Any = None, kind: str | None = None, **options: Any
) -> Viewer:
    """Play an experiment's NPZ or a physics log (:func:`~coop_ga.viewer.recording.load_recording`)."""
    return play_recording(load_recording(path, key=key, system=system, kind=kind), **options)
