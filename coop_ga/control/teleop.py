"""Teleoperation in the cooperative similarity space (§4.5, Fig. 20–21, Eq 48, 61).

A 6-axis input (a CAD "space mouse": three translations, three rotations) is mapped to a
similarity bivector, which drives differential IK (Eq 48: a
:class:`~coop_ga.control.tasks.BodyVelocityTask` in :func:`~coop_ga.control.solve_step`, with the
position, velocity and — where the system has them — acceleration limits) in a first-order kinematic simulation ``q_{t+1} = q_t + Δt q̇`` (Eq 61, Δt = 0.01 s).

Axis mapping (Fig. 20), command ``u = (tx, ty, tz, rx, ry, rz)`` (dimensionless, typically
in [−1, 1]) → ``b = [θ12, θ13, θ23, β, t1, t2, t3]`` (body frame of V_Sc)::

    t1 = k_t · tx        t2 = k_t · ty        t3 = k_t · tz          [1/s, see below]
    θ23 = k_r · rx       (right-handed rotation about +x)            [rad/s]
    θ13 = −k_r · ry      (e13 turns e1 → e3, i.e. −θ about +y; the minus makes it right-handed about +y)
    β   = k_d · rz       (rz = "twist the knob about z" → dilation e0∞, scale e^{β Δt} per step) [1/s]
    θ12 = 0

Units of the translation rows: b is a *body-frame* velocity of V_Sc, and V_Sc contains
the primitive's dilation (radius r for circles/spheres), so a body translation t moves the
primitive by ``r · R t`` in the world (R: rotation of V_Sc): k_t is in radii per second.

With ``rz_mode='rotation'`` the z axis is a rotation instead (``θ12 = k_r · rz``, β = 0),
e.g. for primitives without a dilation (planes, lines).  Fig. 20 uses the dilation
mapping: a sphere is invariant to rotations about its centre, so the rotation rows are
inert for it and the hand is opened/closed by a single scalar (Fig. 21: ``B = −e0∞``
closes, ``+e0∞`` opens).

Input sources
-------------
* :class:`ScriptedInput` — a list of ``(duration [s], 6-vector)`` segments, always
  available and deterministic;
* :func:`run_interactive` — keyboard control in a matplotlib window (needs an interactive
  backend and a display; otherwise it falls back to a script).  Key bindings (hold a key
  for a constant command, release to stop):

  ==================  =======================================
  ``left`` / ``right``  −x / +x translation (tx)
  ``down`` / ``up``     −y / +y translation (ty)
  ``pagedown``/``pageup``, ``f`` / ``r``   −z / +z translation (tz)
  ``k`` / ``i``         −/+ rotation about x (rx)
  ``j`` / ``l``         −/+ rotation about y (ry)
  ``-`` / ``+`` (``=``)  close / open: −/+ rz, i.e. dilation (rz_mode='dilation')
  ``space``             stop (zero command)
  ``escape``            quit
  ==================  =======================================
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any, TypedDict

import numpy as np

from .. import validation
from ..errors import InvalidInputError
from ..geometry.groups import Similarity
from .base import check_q
from .configuration import Configuration
from .diffik import LIMIT_MODES, step_limits
from .qp import DEFAULT_LIMIT_GAIN, project_into_limits
from .solve import advance, solve_step
from .tasks.similarity import BodyVelocityTask

__all__ = [
    "KEY_BINDINGS",
    "ScriptedInput",
    "TeleopLog",
    "Teleoperator",
    "command_to_bivector",
    "interactive_available",
    "run_interactive",
]

#: key → (axis index in (tx, ty, tz, rx, ry, rz), sign)
KEY_BINDINGS: dict[str, tuple[int, float]] = {
    "left": (0, -1.0),
    "right": (0, 1.0),
    "down": (1, -1.0),
    "up": (1, 1.0),
    "pagedown": (2, -1.0),
    "pageup": (2, 1.0),
    "f": (2, -1.0),
    "r": (2, 1.0),
    "k": (3, -1.0),
    "i": (3, 1.0),
    "j": (4, -1.0),
    "l": (4, 1.0),
    "-": (5, -1.0),
    "+": (5, 1.0),
    "=": (5, 1.0),
}


class _Gains(TypedDict):
    """The keyword arguments of :func:`command_to_bivector` a :class:`Teleoperator` keeps."""

    translation_gain: float
    rotation_gain: float
    dilation_gain: float
    rz_mode: str


def command_to_bivector(
    command: Any,
    *,
    translation_gain: float = 0.05,
    rotation_gain: float = 0.5,
    dilation_gain: float = 1.0,
    rz_mode: str = "dilation",
) -> np.ndarray:
    """Map a 6-axis command ``(tx, ty, tz, rx, ry, rz)`` to the bivector ``b`` (7,) of Fig. 20.

    See the module docstring for the exact mapping.  Gains: ``translation_gain`` k_t [m/s],
    ``rotation_gain`` k_r [rad/s], ``dilation_gain`` k_d [1/s] per unit of input.
    """
    u = validation.vector(command, 6, "command (tx, ty, tz, rx, ry, rz)")
    translation_gain = validation.scalar(translation_gain, "translation_gain")
    rotation_gain = validation.scalar(rotation_gain, "rotation_gain")
    dilation_gain = validation.scalar(dilation_gain, "dilation_gain")
    validation.choice(rz_mode, ("dilation", "rotation"), "rz_mode")
    b = np.zeros(7)
    b[4:7] = translation_gain * u[0:3]
    b[2] = rotation_gain * u[3]  # e23: about +x
    b[1] = -rotation_gain * u[4]  # e13: −θ about +y
    if rz_mode == "dilation":
        b[3] = dilation_gain * u[5]  # e0∞: scale e^{β t}
    else:
        b[0] = rotation_gain * u[5]  # e12: about +z
    return b


class ScriptedInput:
    """A deterministic command source: segments ``(duration [s], command (6,))`` sampled at ``dt``.

    Iterating yields one 6-vector per control step; a segment of duration d contributes
    ``round(d / dt)`` steps.
    """

    def __init__(self, segments: Iterable[tuple[float, Any]], dt: float = 0.01):
        self.dt = validation.positive(dt, "dt")
        self.segments: list[tuple[float, np.ndarray]] = []
        for seg in segments:
            try:
                d, c = seg
            except (TypeError, ValueError):
                raise InvalidInputError(f"each script segment is (duration, 6-vector), got {seg!r}") from None
            c = validation.vector(c, 6, "script command (tx, ty, tz, rx, ry, rz)")
            self.segments.append((validation.nonnegative(d, "segment duration"), c))

    def __iter__(self) -> Iterator[np.ndarray]:
        for d, c in self.segments:
            for _ in range(round(d / self.dt)):
                yield c

    def __len__(self) -> int:
        return sum(round(d / self.dt) for d, _ in self.segments)


@dataclass
class TeleopLog:
    """What :meth:`Teleoperator.run` records (T = steps + 1): t (T,), q (T, nq),
    commands (T−1, 6), bivectors (T−1, 7)."""

    t: list = field(default_factory=list)
    q: list = field(default_factory=list)
    commands: list = field(default_factory=list)
    bivectors: list = field(default_factory=list)

    def arrays(self) -> dict[str, np.ndarray]:
        return {k: np.array(getattr(self, k)) for k in ("t", "q", "commands", "bivectors")}


class Teleoperator:
    """State of a teleoperated cooperative system: ``step(command)`` advances Eq 61 once.

    Args:
        task: a :class:`coop_ga.CooperativeTask` (e.g. the allegro sphere).
        q_init: (nq,) initial configuration.
        dt: Δt [s] (Eq 61; 0.01 s in §4.5).  damping: λ of the damped least squares.
        limit_mode: ``'enforce'`` (default: each step is the QP of :func:`coop_ga.control.diff_ik_step`,
            within the position, velocity and acceleration limits of ``task.system.limits``), ``'clamp'``
            (ablation: clip q after an unconstrained step) or ``'none'``.
        translation_gain: see :func:`command_to_bivector`.
        rotation_gain: see :func:`command_to_bivector`.
        dilation_gain: see :func:`command_to_bivector`.
        rz_mode: see :func:`command_to_bivector`.
        acceleration_limit: with ``'enforce'``, the system's acceleration limits too (the hand starts at rest;
            ``velocity`` is the last step's q̇).
    """

    def __init__(
        self,
        task: Any,
        q_init: Any,
        *,
        dt: float = 0.01,
        damping: float = 1e-3,
        limit_mode: str = "enforce",
        translation_gain: float = 0.05,
        rotation_gain: float = 0.5,
        dilation_gain: float = 1.0,
        rz_mode: str = "dilation",
        acceleration_limit: bool = True,
    ):
        self.task = task
        self.q = check_q(task, q_init, "q_init")
        self.dt = validation.positive(dt, "dt")
        self.damping = validation.nonnegative(damping, "damping")
        self.limit_mode = validation.choice(limit_mode, LIMIT_MODES, "limit_mode")
        self.gains: _Gains = dict(
            translation_gain=translation_gain, rotation_gain=rotation_gain, dilation_gain=dilation_gain, rz_mode=rz_mode
        )
        command_to_bivector(np.zeros(6), **self.gains)  # validate the gains now, not at the first step
        self.t = 0.0
        self.log = TeleopLog(t=[0.0], q=[self.q.copy()])
        mode = "none" if self.limit_mode == "clamp" else self.limit_mode
        self._limits = step_limits(task, mode, DEFAULT_LIMIT_GAIN, bool(acceleration_limit))
        self._configuration = Configuration(task, self.q)

    @property
    def velocity(self) -> np.ndarray:
        """The joint velocity q̇ (nv,) [rad/s] of the last step (zeros at the start)."""
        return self._configuration.velocity.copy()

    @property
    def pose(self) -> Similarity:
        """The current cooperative pose V_Sc(q) as a :class:`~coop_ga.Similarity`."""
        return self.task.similarity(self.q)

    def bivector(self, command: Any) -> np.ndarray:
        return command_to_bivector(command, **self.gains)

    def step(self, command: Any) -> np.ndarray:
        """Apply one 6-axis command for Δt: ``q ← q + Δt q̇`` with q̇ the (limit-aware) differential-IK
        velocity for ``b(command)`` (Eq 48, 61); returns the new q."""
        b = self.bivector(command)
        cfg = self._configuration
        q = self.q if self.limit_mode == "none" else project_into_limits(self.task, self.q)
        if q is not self.q or not np.array_equal(cfg.q, q):
            cfg.update(q, cfg.velocity.copy())  # q set from outside (or projected): keep the last velocity
        st = solve_step(cfg, [BodyVelocityTask(b)], self._limits, self.dt, damping=self.damping)
        system = self.task.system
        if system.nq == system.nv:
            q_next = advance(q, st.velocity, self.dt)
            if self.limit_mode != "none":  # 'enforce': rounding only; 'clamp': the ablation
                np.clip(q_next, system.limits.lower, system.limits.upper, out=q_next)
            cfg.update(q_next, (q_next - q) / self.dt)
        else:  # a free flyer: q moves by the system's integrate, the limits bound its velocity coordinates
            q_next = advance(q, st.velocity, self.dt, system)
            if self.limit_mode != "none":
                system.clip(q_next, out=q_next)
            cfg.update(q_next, system.difference(q, q_next) / self.dt)
        self.q = q_next
        self.t += self.dt
        self.log.t.append(self.t)
        self.log.q.append(self.q.copy())
        self.log.commands.append(np.asarray(command, float).copy())
        self.log.bivectors.append(b)
        return self.q

    def run(self, commands: Iterable[Any]) -> np.ndarray:
        """Apply a sequence of commands (e.g. a :class:`ScriptedInput`); returns the final q."""
        for c in commands:
            self.step(c)
        return self.q


def interactive_available() -> bool:
    """True when matplotlib can open a window (interactive backend and a display)."""
    import os

    import matplotlib

    backend = matplotlib.get_backend().lower()
    if backend in ("agg", "pdf", "ps", "svg", "cairo", "template") or "inline" in backend:
        return False
    if os.name == "posix" and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        return False
    return True


def run_interactive(
    teleop: Teleoperator,
    *,
    fallback_script: Sequence[tuple[float, Any]] | None = None,
    max_duration: float = 600.0,
    draw: Any = None,
) -> str:
    """Keyboard teleoperation in a matplotlib window (bindings: module docstring).

    Returns ``'interactive'`` after the window is closed or ``escape`` pressed, or
    ``'scripted'`` when no interactive display is available, in which case
    ``fallback_script`` (default: close then open the hand) is run instead and a
    :class:`UserWarning` says so.  ``draw(ax, teleop)`` redraws the scene (default: the
    system's skeleton and end points, :func:`coop_ga.viz.draw_robot`).
    """
    if not interactive_available():
        script = (
            fallback_script if fallback_script is not None else [(1.0, [0, 0, 0, 0, 0, -1]), (1.0, [0, 0, 0, 0, 0, 1])]
        )
        warnings.warn(
            "no interactive matplotlib display: running the scripted command sequence instead",
            UserWarning,
            stacklevel=2,
        )
        teleop.run(ScriptedInput(script, teleop.dt))
        return "scripted"

    import matplotlib.pyplot as plt

    from ..viz import draw_robot, set_equal_3d

    fig = plt.figure("coop_ga teleoperation")
    ax = fig.add_subplot(projection="3d")
    held: set[str] = set()
    state: dict[str, Any] = {"quit": False, "box": None}

    def _draw():
        ax.cla()
        if draw is not None:
            draw(ax, teleop)
        else:
            pts = draw_robot(ax, teleop.task.system, teleop.q).points
            if state["box"] is None:  # fixed limits from the first frame (the view must not jump)
                state["box"] = pts
            set_equal_3d(ax, state["box"], pad=0.1)
        ax.set_title("arrows/f/r: translate  i/k j/l: rotate  -/+: close/open  space: stop  esc: quit", fontsize=8)
        fig.canvas.draw_idle()

    def _press(ev):
        if ev.key == "escape":
            state["quit"] = True
            plt.close(fig)
        elif ev.key == " ":
            held.clear()
        elif ev.key in KEY_BINDINGS:
            held.add(ev.key)

    def _release(ev):
        held.discard(ev.key)

    def _tick():
        if state["quit"] or teleop.t > max_duration:
            return
        u = np.zeros(6)
        for k in held:
            i, s = KEY_BINDINGS[k]
            u[i] += s
        teleop.step(np.clip(u, -1, 1))
        if len(teleop.log.t) % 5 == 0:
            _draw()

    fig.canvas.mpl_connect("key_press_event", _press)
    fig.canvas.mpl_connect("key_release_event", _release)
    timer = fig.canvas.new_timer(interval=int(1000 * teleop.dt))
    timer.add_callback(_tick)
    timer.start()
    _draw()
    plt.show()
    return "interactive"
