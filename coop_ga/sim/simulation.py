"""MuJoCo in the loop: :class:`Simulation` steps a :class:`~coop_ga.sim.Scene` with a torque controller.

Loop (one physics step Δt = ``model.opt.timestep``, 1 ms by default)::

    every control_dt (a multiple of Δt):  τ_cmd = controller(t, q, q̇, sensors)      (nq,)
                                          τ = clip(τ_cmd, −effort, +effort)          (counted)
    data.ctrl[actuator_index] = τ;  data.xfrc_applied = scheduled disturbances;  mujoco.mj_step

* ``q``, ``q̇`` (nq,) are the robot's coordinates in the system's Pinocchio order (``scene.qpos_index``,
  ``scene.qvel_index``), read from ``data.qpos`` / ``data.qvel`` at time t;
* ``sensors`` is a :class:`Sensors` view: contact forces per end point, object poses, MuJoCo's named
  sensors, the raw ``MjData``.  ``mj_step`` computes contacts, constraint forces and sensor values at
  the state *before* it integrates, so these are the values of the last physics step — one Δt old
  (like a real force sensor read once per servo cycle); poses and velocities of objects are read from
  ``qpos``/``qvel`` and are current;
* τ is held between controller calls (zero-order hold).  A τ of the wrong shape or with NaN/inf raises
  :class:`~coop_ga.errors.InvalidInputError` / :class:`~coop_ga.errors.NonFiniteError` naming the time;
  ``torque_limits="saturate"`` (default) clips to the URDF effort and counts the clipped control
  updates (:attr:`SimulationLog.saturated_updates`, :attr:`SimulationLog.effort_ratio`),
  ``"error"`` raises instead.

Contact forces (:meth:`Simulation.end_wrenches`), sign convention: **the force and torque exerted ON
the robot's end body BY everything it touches** (objects, floor, other links), world frame, the torque
about the end frame's origin (``data.site_xpos``), summed over the contacts of every geom of the MuJoCo
body that carries the end frame (:attr:`Scene.end_bodies`: for an arm's tcp, the last link with its
locked hand and fingers).  The force the robot exerts on an object is the negative.  Each contact's
force comes from ``mujoco.mj_contactForce`` (contact frame: normal first, pointing from geom1 to
geom2, the force acting on geom2) rotated to the world by ``contact.frame``.

Logging: every physics step appends a row to the log: ``time`` (T,), ``qpos`` (T, model.nq), ``qvel``
(T, model.nv) — the state at the start of the step — and ``ctrl`` (T, model.nu), the controls applied
during it; the last row is the final state (its ``ctrl`` repeats the previous row's and is not
applied).  A scene with mocap bodies (``SceneObject(mocap=True)``) also logs ``mocap_pos`` (T, nmocap, 3)
and ``mocap_quat`` (T, nmocap, 4), their poses during each step: ``mocap=`` gives them as a function of
time (a recorded hand), set before each step's control update; without it they stay where the model
puts them.  :meth:`SimulationLog.save` writes ``model.xml``, ``log.npz`` and ``metrics.json``
(layout in :mod:`coop_ga.sim.replay`), which :func:`coop_ga.sim.replay` re-simulates with MuJoCo
alone.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import validation
from ..errors import CoopGAError, InvalidInputError, NonFiniteError, UnknownNameError
from ._mujoco import mj
from .scene import Scene

__all__ = ["LOG_VERSION", "Controller", "Disturbance", "MocapTrajectory", "Sensors", "Simulation", "SimulationLog"]

#: ``log_version`` written in ``metrics.json`` (the layout of ``log.npz``, :mod:`coop_ga.sim.replay`).
LOG_VERSION = 1

_NO_XFRC = np.zeros((0, 6))

#: ``controller(time [s], q (nq,), q̇ (nq,), sensors) -> τ (nq,)`` [N m or N]
Controller = Callable[[float, np.ndarray, np.ndarray, "Sensors"], Any]
#: ``mocap(time [s]) -> (positions (nmocap, 3) [m], unit quaternions (nmocap, 4) (w, x, y, z))``, world frame
MocapTrajectory = Callable[[float], tuple[Any, Any]]


@dataclass(frozen=True)
class Disturbance:
    """A force and torque applied to a body from ``start`` to ``stop`` [s] (``data.xfrc_applied``).

    body: MuJoCo body name (an object's name, a link's name);
    force (3,) [N], torque (3,) [N m]: world frame, applied at the body's centre of mass;
    start, stop: active for start ≤ t < stop (stop may be inf).
    """

    body: str
    force: Any = (0.0, 0.0, 0.0)
    torque: Any = (0.0, 0.0, 0.0)
    start: float = 0.0
    stop: float = math.inf

    def __post_init__(self) -> None:
        if not isinstance(self.body, str) or not self.body:
            raise InvalidInputError(f"Disturbance.body must be a body name, got {self.body!r}")
        object.__setattr__(self, "force", validation.vector(self.force, 3, "Disturbance.force"))
        object.__setattr__(self, "torque", validation.vector(self.torque, 3, "Disturbance.torque"))
        object.__setattr__(self, "start", validation.scalar(self.start, "Disturbance.start"))
        stop = validation.scalar(self.stop, "Disturbance.stop", allow_inf=True)
        if stop <= self.start:
            raise InvalidInputError(f"Disturbance.stop ({stop}) must be after start ({self.start})")
        object.__setattr__(self, "stop", stop)

    @property
    def wrench(self) -> np.ndarray:
        """(6,) force then torque, the layout of one row of ``data.xfrc_applied``."""
        return np.concatenate([self.force, self.torque])


# ====================================================================== contact forces
def body_wrenches(model: Any, data: Any, bodies: Sequence[int] | np.ndarray, points: np.ndarray) -> np.ndarray:
    """(len(bodies), 6): force [N] and torque [N m] exerted ON each body by its contacts (world frame; the
    torque about ``points[i]`` (3,) [m]), from the contacts in ``data`` (module docstring)."""
    out = np.zeros((len(bodies), 6))
    n = int(data.ncon)
    if n == 0 or len(bodies) == 0:
        return out
    where: dict[int, list[int]] = {}
    for i, b in enumerate(bodies):
        where.setdefault(int(b), []).append(i)
    con = data.contact
    gb = model.geom_bodyid
    b1s = gb[con.geom1[:n]].tolist()
    b2s = gb[con.geom2[:n]].tolist()
    frames = con.frame
    f6 = np.zeros(6)
    m = mj()
    pts = np.asarray(points, float).tolist()
    acc = [[0.0] * 6 for _ in range(len(bodies))]
    for c in range(n):  # a few contacts: scalar Python beats numpy's per-call overhead here
        b1, b2 = b1s[c], b2s[c]
        if b1 not in where and b2 not in where:
            continue
        m.mj_contactForce(model, data, c, f6)
        R = frames[c].reshape(3, 3)  # rows: normal (geom1 → geom2), tangents
        fx, fy, fz = (f6[:3] @ R).tolist()  # on geom2, world frame
        tx, ty, tz = (f6[3:] @ R).tolist()
        x, y, z = con.pos[c].tolist()
        for body, sign in ((b2, 1.0), (b1, -1.0)):
            for i in where.get(body, ()):
                dx, dy, dz = x - pts[i][0], y - pts[i][1], z - pts[i][2]
                a = acc[i]
                a[0] += sign * fx
                a[1] += sign * fy
                a[2] += sign * fz
                a[3] += sign * (dy * fz - dz * fy + tx)
                a[4] += sign * (dz * fx - dx * fz + ty)
                a[5] += sign * (dx * fy - dy * fx + tz)
    out[:] = acc
    return out


class Sensors:
    """What a controller reads at a control update (module docstring: contact quantities are one Δt old).

    Attributes: ``data`` (the live ``mujoco.MjData``: read it, do not write it), ``scene``.
    """

    def __init__(self, sim: Simulation):
        self._sim = sim
        self.scene = sim.scene
        self.data = sim.data
        self._cache: dict[str, Any] = {}

    def _reset(self) -> None:
        self._cache.clear()

    @property
    def end_wrenches(self) -> np.ndarray:
        """(k, 6) wrench on each end body by its contacts, world frame, about the end frame (:meth:`Simulation.end_wrenches`)."""
        if "w" not in self._cache:
            self._cache["w"] = self._sim.end_wrenches()
        return np.array(self._cache["w"])

    @property
    def end_forces(self) -> np.ndarray:
        """(k, 3) contact force on each end body [N], world frame (the first three columns of ``end_wrenches``)."""
        return self.end_wrenches[:, :3]

    def object_pose(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """(position (3,) [m], quaternion (w, x, y, z)) of a scene object (:meth:`Simulation.object_pose`)."""
        return self._sim.object_pose(name)

    def object_velocity(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """(linear (3,) [m/s], angular (3,) [rad/s]) world-frame velocity of a free object."""
        return self._sim.object_velocity(name)

    def sensor(self, name: str) -> np.ndarray:
        """The values of MuJoCo sensor ``name`` (``data.sensordata`` slice) of the last step."""
        return self._sim.sensor(name)


@dataclass
class SimulationLog:
    """Every physics step of a :class:`Simulation` (module docstring; T = steps + 1 rows).

    time (T,) [s]; qpos (T, model.nq); qvel (T, model.nv); ctrl (T, model.nu): MuJoCo's own arrays.
    q, qd (T, nq): the robot's coordinates in Pinocchio's order; tau (T, nq): applied joint torques;
    tau_command (T, nq): the controller's command before saturation.
    xfrc_bodies (m,) int and xfrc (T, m, 6): ``data.xfrc_applied`` rows of the disturbed bodies
    (m = 0 without disturbances).
    mocap_pos (T, nmocap, 3) [m], mocap_quat (T, nmocap, 4): the mocap bodies' poses during each step
    (nmocap = 0 for a scene without mocap bodies).
    control_updates, saturated_updates: controller calls, and those clipped at the effort limit;
    effort_ratio: max |τ_cmd| / effort (> 1 iff something was clipped).
    """

    scene: Scene
    time: np.ndarray
    qpos: np.ndarray
    qvel: np.ndarray
    ctrl: np.ndarray
    tau_command: np.ndarray
    xfrc_bodies: np.ndarray
    xfrc: np.ndarray
    control_updates: int = 0
    saturated_updates: int = 0
    effort_ratio: float = 0.0
    extra: dict[str, Any] = field(default_factory=dict)
    mocap_pos: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 3)))
    mocap_quat: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 4)))

    def __repr__(self) -> str:
        return (
            f"SimulationLog({self.scene.system.name!r}, steps={len(self.time) - 1}, t=[{self.time[0]:g}, "
            f"{self.time[-1]:g}] s, saturated_updates={self.saturated_updates}/{self.control_updates})"
        )

    @property
    def q(self) -> np.ndarray:
        return self.qpos[:, self.scene.qpos_index]

    @property
    def qd(self) -> np.ndarray:
        return self.qvel[:, self.scene.qvel_index]

    @property
    def tau(self) -> np.ndarray:
        return self.ctrl[:, self.scene.actuator_index]

    def object_positions(self, name: str) -> np.ndarray:
        """(T, 3) position [m] of a free object's body over the run."""
        a = self.scene.object_qpos.get(name)
        if a is None:
            raise UnknownNameError(f"no free object '{name}'; free objects: {sorted(self.scene.object_qpos)}")
        return self.qpos[:, a : a + 3]

    def metrics(self) -> dict[str, Any]:
        """The run's summary for ``metrics.json`` (``object_body``: the first free object's body, or None)."""
        free = [o.name for o in self.scene.objects if o.free]
        return {
            "log_version": LOG_VERSION,
            "system": self.scene.system.name,
            "object_body": free[0] if free else None,
            "object_bodies": free,
            "end_frames": list(self.scene.system.end_frames),
            "joint_names": list(self.scene.system.joint_names),
            "qpos_index": self.scene.qpos_index.tolist(),
            "qvel_index": self.scene.qvel_index.tolist(),
            "actuator_index": self.scene.actuator_index.tolist(),
            "timestep_s": float(self.scene.model.opt.timestep),
            "steps": int(len(self.time) - 1),
            "duration_s": float(self.time[-1] - self.time[0]),
            "control_updates": int(self.control_updates),
            "saturated_updates": int(self.saturated_updates),
            "effort_ratio": float(self.effort_ratio),
            "disturbed_bodies": [
                mj().mj_id2name(self.scene.model, mj().mjtObj.mjOBJ_BODY, int(b)) for b in self.xfrc_bodies
            ],
            **self.extra,
        }

    def save(self, folder: str | Path) -> Path:
        """Write ``model.xml`` (checked to reload bit for bit), ``log.npz`` and ``metrics.json`` to ``folder``."""
        out = Path(folder)
        out.mkdir(parents=True, exist_ok=True)
        self.scene.write_model(out / "model.xml")
        arrays: dict[str, Any] = {"time": self.time, "qpos": self.qpos, "qvel": self.qvel, "ctrl": self.ctrl}
        if len(self.xfrc_bodies):
            arrays |= {"xfrc_bodies": self.xfrc_bodies, "xfrc": self.xfrc}
        if self.mocap_pos.ndim == 3 and self.mocap_pos.shape[1]:
            arrays |= {"mocap_pos": self.mocap_pos, "mocap_quat": self.mocap_quat}
        np.savez_compressed(out / "log.npz", **arrays)
        (out / "metrics.json").write_text(json.dumps(self.metrics(), indent=2, allow_nan=False))
        return out


class Simulation:
    """MuJoCo with a controller in the loop (module docstring).

    Args:
        scene: a :class:`~coop_ga.sim.Scene`.
        controller: ``controller(t, q, q̇, sensors) -> τ`` (nq,) [N m]; None: zero torque.
        q: initial robot configuration (nq,) (default ``system.q0``).
        qd: initial robot velocity (nq,) (default 0).
        base_pose: initial (position (3,), quaternion (w, x, y, z)) of a free base (``floating_base=True``).
        dt: the physics step [s] you expect (None: the scene's ``timestep``); a different value raises —
            the step is part of the model: ``build_scene(..., timestep=dt)``.
        control_dt: controller period [s], a multiple of Δt (default Δt: every step).
        disturbances: :class:`Disturbance` list (more with :meth:`add_disturbance`).
        torque_limits: ``"saturate"`` (clip to ±effort, counted) or ``"error"`` (raise).
        penetration_tol: initial overlaps deeper than this [m] raise (:meth:`Scene.check_state`); None: no check.
        mocap: the mocap bodies' poses as a function of time (:data:`MocapTrajectory`; the scene must have
            mocap bodies), set before every step and logged; None: they stay at the model's poses.

    Raises:
        InvalidInputError: bad arguments, an initial state with an object inside a robot (or anything
            deeper than ``penetration_tol`` in anything else).
    """

    def __init__(
        self,
        scene: Scene,
        controller: Controller | None = None,
        *,
        q: Any = None,
        qd: Any = None,
        base_pose: Any = None,
        dt: float | None = None,
        control_dt: float | None = None,
        disturbances: Sequence[Disturbance] = (),
        torque_limits: str = "saturate",
        penetration_tol: float | None = 1e-3,
        mocap: MocapTrajectory | None = None,
    ):
        if not isinstance(scene, Scene):
            raise InvalidInputError(f"scene must be a coop_ga.sim.Scene (build_scene(...)), got {type(scene).__name__}")
        if controller is not None and not callable(controller):
            raise InvalidInputError("controller must be callable as controller(t, q, qd, sensors) -> tau")
        self.scene, self.model = scene, scene.model
        self.controller = controller
        self.dt = float(self.model.opt.timestep)
        if dt is not None and validation.positive(dt, "dt") != self.dt:
            raise InvalidInputError(
                f"dt = {dt} s differs from the scene's timestep {self.dt} s; build the scene with "
                f"build_scene(..., timestep={dt})"
            )
        self._every = 1
        if control_dt is not None:
            k = validation.positive(control_dt, "control_dt") / self.dt
            if abs(k - round(k)) > 1e-9 * k or round(k) < 1:
                raise InvalidInputError(f"control_dt = {control_dt} s must be a multiple of the timestep {self.dt} s")
            self._every = round(k)
        self.torque_limits = validation.choice(torque_limits, ("saturate", "error"), "torque_limits")
        self.data = scene.make_data(q, qd, base_pose)
        self._nmocap = int(self.model.nmocap)
        if mocap is not None and (not callable(mocap) or self._nmocap == 0):
            raise InvalidInputError(
                "mocap= must be a function of time returning the mocap bodies' (positions, quaternions), and the "
                f"scene needs mocap bodies (it has {self._nmocap}): add an object with mocap=True"
            )
        self._mocap = mocap
        if mocap is not None:
            self._set_mocap()
            mj().mj_forward(self.model, self.data)
        if penetration_tol is not None:
            scene.check_state(self.data, validation.nonnegative(penetration_tol, "penetration_tol"))
        # views into the MjData buffers (fixed for its lifetime): no attribute lookup per step
        self._qpos, self._qvel, self._ctrl = self.data.qpos, self.data.qvel, self.data.ctrl
        self.sensors = Sensors(self)
        self._effort = np.asarray(scene.system.limits.effort, float)
        self._disturbances: list[tuple[Disturbance, int]] = []
        self._xfrc_bodies = np.zeros(0, dtype=np.int64)
        self._steps = 0
        for dist in disturbances:
            self.add_disturbance(dist)
        self._tau = np.zeros(scene.nq)
        self._tau_cmd = np.zeros(scene.nq)
        self._rows: list[tuple[Any, ...]] = []
        self._counts = {"updates": 0, "saturated": 0, "ratio": 0.0}

    # ------------------------------------------------------------------ state
    @property
    def time(self) -> float:
        """Simulated time [s]."""
        return float(self.data.time)

    @property
    def q(self) -> np.ndarray:
        """Robot configuration (nq,) now (Pinocchio order)."""
        return self.scene.q(self.data)

    @property
    def qd(self) -> np.ndarray:
        """Robot velocity (nq,) now (Pinocchio order)."""
        return self.scene.qd(self.data)

    def add_disturbance(self, disturbance: Disturbance) -> None:
        """Schedule a :class:`Disturbance` (its body must exist) — before the first step, so that every row of
        the log has the same disturbed bodies; use ``start=`` to apply it later in the run."""
        if not isinstance(disturbance, Disturbance):
            raise InvalidInputError("disturbances must be coop_ga.sim.Disturbance objects")
        if self._steps:
            raise InvalidInputError(
                f"add_disturbance after the simulation started (t = {self.time:.4f} s); schedule it before the "
                "first step with Disturbance(..., start=t0)"
            )
        self._disturbances.append((disturbance, self.scene.id_of("body", disturbance.body)))
        self._xfrc_bodies = np.array(sorted({b for _, b in self._disturbances}), dtype=np.int64)

    def object_pose(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """(position (3,) [m], unit quaternion (w, x, y, z)) of a scene object's body now (world frame)."""
        self.scene.object(name)
        a = self.scene.object_qpos.get(name)
        if a is None:  # static
            b = self.scene.object_ids[name]
            return np.array(self.model.body_pos[b]), np.array(self.model.body_quat[b])
        return np.array(self.data.qpos[a : a + 3]), np.array(self.data.qpos[a + 3 : a + 7])

    def object_velocity(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """(linear velocity of the body origin (3,) [m/s], angular velocity (3,) [rad/s]), world frame, now."""
        self.scene.object(name)
        a = self.scene.object_qvel.get(name)
        if a is None:
            return np.zeros(3), np.zeros(3)
        quat = self.object_pose(name)[1]
        R = np.empty(9)
        mj().mju_quat2Mat(R, quat)
        return np.array(self.data.qvel[a : a + 3]), R.reshape(3, 3) @ self.data.qvel[a + 3 : a + 6]

    def end_wrenches(self) -> np.ndarray:
        """(k, 6) force [N] and torque [N m] exerted on each end body by its contacts, world frame, torque
        about the end frame (module docstring: sign convention; values of the last physics step)."""
        s = self.scene
        return body_wrenches(self.model, self.data, s.end_bodies, np.asarray(self.data.site_xpos[s.site_ids]))

    def end_forces(self) -> np.ndarray:
        """(k, 3) contact force on each end body [N], world frame (on the robot, by the environment)."""
        return self.end_wrenches()[:, :3]

    def object_wrench(self, name: str) -> np.ndarray:
        """(6,) contact force and torque on an object (about its centre) by everything it touches, world frame."""
        self.scene.object(name)
        b = self.scene.object_ids[name]
        return body_wrenches(self.model, self.data, [b], np.asarray(self.data.xipos[[b]]))[0]

    def sensor(self, name: str) -> np.ndarray:
        """Values of the MuJoCo sensor ``name`` (``data.sensordata``) of the last physics step."""
        i = self.scene.id_of("sensor", name)
        a, n = int(self.model.sensor_adr[i]), int(self.model.sensor_dim[i])
        return np.array(self.data.sensordata[a : a + n])

    # ------------------------------------------------------------------ stepping
    def _command(self, t: float) -> np.ndarray:
        """The controller's τ at time t as a checked (nq,) float array (a new array)."""
        if self.controller is None:
            return np.zeros(self.scene.nq)
        self.sensors._reset()
        cmd = self.controller(t, self._qpos[self.scene.qpos_index], self._qvel[self.scene.qvel_index], self.sensors)
        try:
            tau = np.array(cmd, dtype=float)
        except (TypeError, ValueError) as e:
            raise InvalidInputError(f"the controller returned {type(cmd).__name__} at t = {t:.4f} s: {e}") from e
        if tau.shape != (self.scene.nq,):
            raise InvalidInputError(
                f"the controller returned shape {tau.shape} at t = {t:.4f} s; it must return τ of shape "
                f"({self.scene.nq},) in the order of system.joint_names"
            )
        if not np.isfinite(tau).all():
            bad = [self.scene.system.joint_names[i] for i in np.flatnonzero(~np.isfinite(tau))]
            raise NonFiniteError(f"the controller returned NaN/inf torque at t = {t:.4f} s for joint(s) {bad}")
        return tau

    def _control(self) -> None:
        t = self.time
        cmd = self._command(t)
        ratio = np.abs(cmd) / self._effort
        rmax = float(ratio.max(initial=0.0))
        self._counts["updates"] += 1
        if rmax > self._counts["ratio"]:
            self._counts["ratio"] = rmax
        tau = cmd
        if rmax > 1.0:
            if self.torque_limits == "error":
                over = [self.scene.system.joint_names[i] for i in np.flatnonzero(ratio > 1.0)]
                raise CoopGAError(
                    f"the controller exceeded the effort limit at t = {t:.4f} s on {over} (up to {rmax:.3g}× the "
                    "limit); torque_limits='saturate' clips and counts instead"
                )
            self._counts["saturated"] += 1
            tau = np.clip(cmd, -self._effort, self._effort)
        self._tau_cmd, self._tau = cmd, tau

    def _set_mocap(self) -> None:
        """The mocap bodies' poses at the current time from ``mocap=`` (checked: shapes, finite, unit quaternions)."""
        t = self.time
        pos, quat = self._mocap(t)  # type: ignore[misc]
        n = self._nmocap
        try:
            p = np.array(pos, dtype=float).reshape(n, 3)
            qu = np.array(quat, dtype=float).reshape(n, 4)
        except (TypeError, ValueError) as e:
            raise InvalidInputError(
                f"mocap({t:.4f}) must return positions ({n}, 3) and quaternions ({n}, 4): {e}"
            ) from e
        if not (np.isfinite(p).all() and np.isfinite(qu).all()):
            raise NonFiniteError(f"mocap({t:.4f}) returned NaN/inf: the mocap trajectory is not finite there")
        if np.any(np.abs(np.linalg.norm(qu, axis=1) - 1.0) > 1e-6):
            raise InvalidInputError(f"mocap({t:.4f}) returned quaternions that are not unit (w, x, y, z)")
        self.data.mocap_pos[:] = p
        self.data.mocap_quat[:] = qu

    def _apply_disturbances(self) -> None:
        if not self._disturbances:
            return
        t = self.time
        x = self.data.xfrc_applied
        for _, b in self._disturbances:
            x[b] = 0.0
        for dist, b in self._disturbances:
            if dist.start <= t < dist.stop:
                x[b] += dist.wrench

    def step(self, n: int = 1) -> None:
        """Advance ``n`` physics steps (module docstring), logging each."""
        m, d = self.model, self.data
        act = self.scene.actuator_index
        for _ in range(validation.integer(n, "n", minimum=0)):
            if self._mocap is not None:
                self._set_mocap()
            if self._steps % self._every == 0:
                self._control()
            self._ctrl[act] = self._tau
            self._apply_disturbances()
            self._log()
            mj().mj_step(m, d)
            self._steps += 1
            # one sum per array: NaN or inf anywhere (or an overflow, a divergence too) makes it non-finite
            if not math.isfinite(float(self._qpos.sum()) + float(self._qvel.sum())):
                raise NonFiniteError(
                    f"the MuJoCo state became non-finite at t = {self.time:.4f} s (simulation diverged)"
                )

    def _log(self) -> None:
        d = self.data
        x = d.xfrc_applied[self._xfrc_bodies] if len(self._xfrc_bodies) else _NO_XFRC
        self._rows.append(
            (
                np.float64(d.time),
                self._qpos.copy(),
                self._qvel.copy(),
                self._ctrl.copy(),
                self._tau_cmd,
                x,
                d.mocap_pos.copy(),
                d.mocap_quat.copy(),
            )
        )

    def run(self, duration: float, *, progress: bool = False) -> SimulationLog:
        """Simulate ``duration`` [s] more (rounded to whole steps) and return the log of the whole run so far."""
        n = round(validation.nonnegative(duration, "duration") / self.dt)
        if progress:
            from tqdm import tqdm

            chunk = max(1, n // 100)
            with tqdm(total=n, desc=f"simulating {self.scene.system.name}", unit="step") as bar:
                done = 0
                while done < n:
                    k = min(chunk, n - done)
                    self.step(k)
                    done += k
                    bar.update(k)
        else:
            self.step(n)
        return self.log()

    def log(self) -> SimulationLog:
        """The :class:`SimulationLog` of every step so far (the current state as the last row)."""
        d = self.data
        last = self._rows[-1][3] if self._rows else d.ctrl  # the final row repeats the last applied ctrl
        x = d.xfrc_applied[self._xfrc_bodies] if len(self._xfrc_bodies) else _NO_XFRC
        final = (np.float64(d.time), d.qpos.copy(), d.qvel.copy(), np.array(last), self._tau_cmd, x)
        rows = [*self._rows, (*final, d.mocap_pos.copy(), d.mocap_quat.copy())]
        return SimulationLog(
            scene=self.scene,
            time=np.array([r[0] for r in rows]),
            qpos=np.stack([r[1] for r in rows]),
            qvel=np.stack([r[2] for r in rows]),
            ctrl=np.stack([r[3] for r in rows]),
            tau_command=np.stack([r[4] for r in rows]),
            xfrc_bodies=self._xfrc_bodies.copy(),
            xfrc=np.stack([r[5] for r in rows]),
            control_updates=int(self._counts["updates"]),
            saturated_updates=int(self._counts["saturated"]),
            effort_ratio=float(self._counts["ratio"]),
            mocap_pos=np.stack([r[6] for r in rows]),
            mocap_quat=np.stack([r[7] for r in rows]),
        )
