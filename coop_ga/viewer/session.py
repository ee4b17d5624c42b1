"""The teleoperation session behind the viewer: gizmo pose → target similarity → one limit-aware IK step.

No browser and no viser here: :class:`TeleopSession` is the whole control logic of
:func:`coop_ga.viewer.serve`, so it is tested as plain Python.

The handle (§4.5, Figs. 20–21)
------------------------------
The page shows a transform gizmo at the centre of the cooperative primitive and a scale slider.
Their pose ``(p, R)`` [m, rotation] and the slider's value ``s`` (relative to the starting
dilation s₀) define the *target similarity*

    V_Sd = canonical(T(p) · R · D(s · s₀) applied to the unit primitive),

i.e. the primitive the gizmo frame carries, expressed as the task's canonical similarity in its
chart (:meth:`~coop_ga.CooperativeTask.target_from_primitive`, Eq 28; a twist about a circle's
normal, which the circle does not see, is dropped, so ‖e‖ can reach 0).  Targets across the
chart's half-turn are refused (:class:`~coop_ga.errors.ChartError`, shown in the page) and the
previous target is kept.

Each control step drives the primitive towards V_Sd *through the paper's teleoperation mapping*:
the body-frame error ``e = log(Ṽ_Sc(q) V_Sd)`` (Eq 44) becomes the 6-axis device command ``u``
that :func:`~coop_ga.control.command_to_bivector` maps back to ``b = servo_gain · e`` (Fig. 20),
each axis clipped to the device range [−1, 1] (so the gains are the top speeds), and
:meth:`~coop_ga.control.Teleoperator.step` takes one limit-aware differential-IK step with it
(Eq 48 as a QP within the position, velocity and acceleration limits; Eq 61)::

    u = clip(servo_gain · (e1∞/k_t, e2∞/k_t, e3∞/k_t, e23/k_r, −e13/k_r, e0∞/k_d  or  e12/k_r), −1, 1)

The sixth axis is the dilation (``rz_mode='dilation'``: point pairs, circles, spheres) or the
rotation about the body z axis (``rz_mode='rotation'``: lines and planes, which a dilation does not
change).  A device has six axes for the seven similarity directions: with ``'dilation'`` the e12
rotation is not commanded (inert for circles and spheres; for a point pair a turn about its body z
axis is then not followed — use ``rz_mode='rotation'`` and no dilation).

Read-outs (:class:`Readout`, every step): ‖e‖ and e; the well-definedness of the primitive
(1 best, 0 degenerate); the manipulability along each bivector direction
``√(e_iᵀ M_S e_i) = ‖J^G_i‖`` (M_S = J^G J^Gᵀ, Eq 59: the body velocity along e_i that a unit
joint speed can give); the joints at a position limit (within ``limit_margin``), at their velocity
limit or at their acceleration limit; the coop_ga warnings (:class:`~coop_ga.DegeneracyWarning`,
:class:`~coop_ga.ChartWarning`, …) raised by the step; the measured control rate.
"""

from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import validation
from ..control import Teleoperator
from ..cooperative.manipulability import manipulability
from ..diagnostics import collect_warnings
from ..errors import CoopGAError, InvalidInputError
from ..geometry.groups import Similarity
from ..geometry.kinds import KIND_SPECS, KINDS, Kind, kind_spec

__all__ = ["DILATION_KINDS", "Readout", "TeleopSession", "WarningRecord", "default_rz_mode", "quaternion_to_matrix"]

#: primitive kinds that a dilation changes (the scale slider acts on them): the rounds with a radius
DILATION_KINDS: tuple[Kind, ...] = tuple(k for k in KINDS if KIND_SPECS[k].has_radius)

#: labels of the bivector rows (coop_ga.TANGENT_BASIS order)
ROWS = ("e12", "e13", "e23", "e0∞", "e1∞", "e2∞", "e3∞")


def default_rz_mode(kind: Kind) -> str:
    """The sixth device axis for a primitive kind: ``'dilation'`` if a dilation changes it (or it has no axis to turn
    about: a point), else ``'rotation'``.  Raises :class:`~coop_ga.errors.UnknownNameError` for an unknown kind."""
    spec = kind_spec(kind)
    return "dilation" if spec.has_radius or spec.axis is None else "rotation"


def quaternion_to_matrix(wxyz: Any) -> np.ndarray:
    """Rotation matrix (3, 3) of a quaternion ``(w, x, y, z)`` (normalised first; viser's convention)."""
    q = validation.vector(wxyz, 4, "quaternion (w, x, y, z)")
    n = float(np.linalg.norm(q))
    if not n > 1e-12:
        raise InvalidInputError("quaternion (w, x, y, z) must be non-zero")
    w, x, y, z = q / n
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def matrix_to_quaternion(R: Any) -> np.ndarray:
    """Quaternion ``(w, x, y, z)`` (4,), w ≥ 0, of a rotation matrix (3, 3)."""
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(validation.array(R, "rotation matrix", shape=(3, 3))).as_quat()
    q = np.array([w, x, y, z])
    return q if w >= 0 else -q


def collected(seen: collect_warnings) -> list[tuple[str, str, str, int]]:
    """``(label, category name, first message, count)`` of each condition a :class:`collect_warnings`
    block recorded (its records carry the messages; its public ``counts`` only the labels)."""
    return [
        (c.__name__ + (f":{k}" if k else ""), c.__name__, r.message, r.count) for (c, k), r in seen._records.items()
    ]


@dataclass(frozen=True)
class WarningRecord:
    """A coop_ga warning seen during the session: class name, first message, count, last time [s]."""

    category: str
    message: str
    count: int
    time: float


@dataclass
class Readout:
    """What the page shows after a step (module docstring).

    t: session time [s] (Δt per step); error: e = log(Ṽ_Sc V_Sd) (7,) body frame; error_norm: ‖e‖;
    well_definedness: in [0, 1]; manipulability: (7,) ‖J^G_i‖ per bivector row; command: the device command
    u (6,); bivector: b (7,) it maps to; at_position_limit / at_velocity_limit / at_acceleration_limit:
    joint names; rate: measured steps per second [Hz] (0 until two steps); step_ms: the last step's duration
    [ms]; error_message: why the last step or target was refused ('' if none).
    """

    t: float
    error: np.ndarray
    error_norm: float
    well_definedness: float
    manipulability: np.ndarray
    command: np.ndarray
    bivector: np.ndarray
    at_position_limit: tuple[str, ...] = ()
    at_velocity_limit: tuple[str, ...] = ()
    at_acceleration_limit: tuple[str, ...] = ()
    rate: float = 0.0
    step_ms: float = 0.0
    error_message: str = ""

    def active_limits(self) -> tuple[str, ...]:
        """Every active limit as ``'joint (position)'`` / ``'(velocity)'`` / ``'(acceleration)'``."""
        return (
            tuple(f"{j} (position)" for j in self.at_position_limit)
            + tuple(f"{j} (velocity)" for j in self.at_velocity_limit)
            + tuple(f"{j} (acceleration)" for j in self.at_acceleration_limit)
        )


@dataclass
class _Clock:
    """Wall-clock times of the last steps → the measured rate."""

    window: int = 60
    times: deque = field(default_factory=deque)

    def tick(self) -> float:
        now = time.perf_counter()
        self.times.append(now)
        while len(self.times) > self.window:
            self.times.popleft()
        if len(self.times) < 2:
            return 0.0
        return (len(self.times) - 1) / max(self.times[-1] - self.times[0], 1e-9)


class TeleopSession:
    """A cooperative task teleoperated by a target pose (module docstring); one thread steps it.

    Args:
        task: a :class:`~coop_ga.CooperativeTask`.
        q0: (nq,) start configuration [rad | m] (default ``task.system.q0``).
        dt: Δt [s] of one step (Eq 61); the viewer steps at 1/dt Hz in wall time.
        servo_gain: α [1/s]: the commanded body velocity is ``b = α e`` until an axis saturates.
        translation_gain: k_t [body lengths/s] of :func:`~coop_ga.control.command_to_bivector` (the top
            speed of a translation axis of the device).
        rotation_gain: k_r [rad/s], the top speed of a rotation axis.
        dilation_gain: k_d [1/s], the top speed of the dilation axis.
        rz_mode: the sixth axis, ``'dilation'`` or ``'rotation'`` (default: :func:`default_rz_mode`).
        limit_mode: ``'enforce'`` (QP within the limits), ``'clamp'`` or ``'none'`` (:class:`~coop_ga.control.Teleoperator`).
        damping: λ of the damped least squares.
        limit_margin: a joint within this distance [rad | m] of a position limit is reported at it.

    Raises:
        InvalidInputError: bad arguments (from the checks here and in :class:`~coop_ga.control.Teleoperator`).
    """

    def __init__(
        self,
        task: Any,
        q0: Any = None,
        *,
        dt: float = 1.0 / 60.0,
        servo_gain: float = 5.0,
        translation_gain: float = 0.5,
        rotation_gain: float = 1.0,
        dilation_gain: float = 1.0,
        rz_mode: str | None = None,
        limit_mode: str = "enforce",
        damping: float = 1e-3,
        limit_margin: float = 1e-3,
    ):
        self.task = task
        self.kind: Kind = task.primitive_kind
        self.rz_mode = (
            default_rz_mode(self.kind)
            if rz_mode is None
            else validation.choice(rz_mode, ("dilation", "rotation"), "rz_mode")
        )
        self.servo_gain = validation.positive(servo_gain, "servo_gain")
        self.limit_margin = validation.nonnegative(limit_margin, "limit_margin")
        self._options = dict(
            dt=dt,
            damping=damping,
            limit_mode=limit_mode,
            translation_gain=translation_gain,
            rotation_gain=rotation_gain,
            dilation_gain=dilation_gain,
            rz_mode=self.rz_mode,
        )
        self.teleop = Teleoperator(task, task.system.q0 if q0 is None else q0, **self._options)  # type: ignore[arg-type]
        self.q0 = self.teleop.q.copy()
        self.dt = self.teleop.dt
        self.home: Similarity = task.similarity(self.q0)
        self.target: Similarity = self.home
        self.warnings: dict[str, WarningRecord] = {}
        self._clock = _Clock()
        self._message = ""
        self.readout = self._read(np.zeros(6), self.teleop.velocity, 0.0)

    # ------------------------------------------------------------------ target
    @property
    def q(self) -> np.ndarray:
        """The current configuration (nq,) (a copy)."""
        return self.teleop.q.copy()

    def handle_pose(self, target: Similarity | None = None) -> tuple[np.ndarray, np.ndarray, float]:
        """Where the gizmo shows ``target`` (default: the current target): position (3,) [m], quaternion
        (w, x, y, z) (4,) and the slider value (the scale relative to the start, dimensionless)."""
        S = self.target if target is None else target
        return S.translation, matrix_to_quaternion(S.rotation_matrix), S.scale / self.home.scale

    def target_from_pose(self, position: Any, wxyz: Any, scale: float = 1.0) -> Similarity:
        """The target V_Sd of a gizmo pose (module docstring): ``position`` (3,) [m], ``wxyz`` (4,) and the
        slider's ``scale`` relative to the start (> 0).

        Raises:
            InvalidInputError: bad numbers.  ChartError: the target's axis is across the chart's half-turn.
        """
        p = validation.vector(position, 3, "gizmo position")
        R = quaternion_to_matrix(wxyz)
        s = validation.positive(scale, "scale")
        angle = float(np.arccos(np.clip(0.5 * (np.trace(R) - 1.0), -1.0, 1.0)))
        w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
        if angle > np.pi - 1e-6:  # a half-turn: the axis is the eigenvector of R for +1
            vals, vecs = np.linalg.eigh(0.5 * (R + R.T))
            w = vecs[:, int(np.argmax(vals))]
        axis = w / np.linalg.norm(w) if np.linalg.norm(w) > 1e-12 else np.array([0.0, 0.0, 1.0])
        S = Similarity.from_parts(p, axis, angle, s * self.home.scale)
        V = self.task.target_from_primitive(S.apply(self.task.unit))
        return self.task.check_target(V, "gizmo target")

    def set_target_pose(self, position: Any, wxyz: Any, scale: float = 1.0) -> bool:
        """Set the target from a gizmo pose; returns False (the previous target kept, the reason in
        ``readout.error_message``) for a pose that makes no valid target."""
        try:
            self.target = self.target_from_pose(position, wxyz, scale)
        except CoopGAError as exc:
            self._message = f"target refused: {exc}"
            self.readout.error_message = self._message
            return False
        self._message = self.readout.error_message = ""
        return True

    def hold(self) -> None:
        """Make the current pose V_Sc(q) the target (the robots stop)."""
        self.target = self.task.similarity(self.teleop.q)
        self._message = ""

    def reset(self) -> None:
        """Back to q0 at rest, the target at the start pose."""
        self.teleop = Teleoperator(self.task, self.q0, **self._options)  # type: ignore[arg-type]
        self.target = self.home
        self._message = ""
        self.readout = self._read(np.zeros(6), self.teleop.velocity, 0.0)

    # ------------------------------------------------------------------ control
    def command(self, error: Any) -> np.ndarray:
        """The device command u (6,) in [−1, 1] for the body error ``e`` (7,) (module docstring)."""
        e = validation.vector(error, 7, "error bivector")
        g = self.teleop.gains
        kt, kr, kd = g["translation_gain"], g["rotation_gain"], g["dilation_gain"]
        sixth = e[3] / kd if self.rz_mode == "dilation" else e[0] / kr
        u = self.servo_gain * np.array([e[4] / kt, e[5] / kt, e[6] / kt, e[2] / kr, -e[1] / kr, sixth])
        return np.clip(u, -1.0, 1.0)

    def step(self) -> Readout:
        """One control step towards the target (Eq 44 → Fig. 20 → Eq 48, 61); returns the new :class:`Readout`.

        A step the library refuses (a degenerate primitive, infeasible limits) leaves q where it was and
        puts the reason in ``readout.error_message``; warnings go to :attr:`warnings`.
        """
        t0 = time.perf_counter()
        v_prev = self.teleop.velocity
        u = np.zeros(6)
        with collect_warnings(emit=False) as seen:
            try:
                u = self.command(self.task.error(self.teleop.q, self.target))
                self.teleop.step(u)
                self._message = ""
            except CoopGAError as exc:
                self._message = f"step refused ({type(exc).__name__}): {exc}"
            readout = self._read(u, v_prev, time.perf_counter() - t0)
        self._record(seen)
        self.readout = readout
        return readout

    # ------------------------------------------------------------------ read-outs
    def _read(self, u: np.ndarray, v_prev: np.ndarray, seconds: float) -> Readout:
        task, q = self.task, self.teleop.q
        e = task.error(q, self.target)
        J = task.jacobian(q)
        lim = task.system.limits
        names = np.array(task.system.joint_names)
        v = self.teleop.velocity
        m = self.limit_margin
        x = task.system.limit_coordinates(q)  # q̇ order (nv,): a free flyer's entries are unbounded
        at_pos = (x - lim.lower <= m) | (lim.upper - x <= m)
        at_vel = np.abs(v) >= (1.0 - 1e-6) * lim.velocity
        at_acc = np.isfinite(lim.acceleration) & (np.abs(v - v_prev) >= (1.0 - 1e-6) * lim.acceleration * self.dt)
        return Readout(
            t=self.teleop.t,
            error=e,
            error_norm=float(np.linalg.norm(e)),
            well_definedness=float(task.well_definedness(q)),
            manipulability=np.sqrt(np.maximum(np.diag(manipulability(J)), 0.0)),
            command=u,
            bivector=self.teleop.bivector(u),
            at_position_limit=tuple(names[at_pos]),
            at_velocity_limit=tuple(names[at_vel]),
            at_acceleration_limit=tuple(names[at_acc]),
            rate=self._clock.tick() if seconds > 0 else 0.0,
            step_ms=1e3 * seconds,
            error_message=self._message,
        )

    def _record(self, seen: collect_warnings) -> None:
        for label, category, message, count in collected(seen):
            old = self.warnings.get(label)
            self.warnings[label] = WarningRecord(category, message, count + (old.count if old else 0), self.teleop.t)
