"""Closed-loop receding-horizon tracking in MuJoCo: three Frankas follow a moving circle past a moving sphere.

Scenario (:func:`run_track`): ``three_franka``'s cooperative circle (Eq 14) tracks ``V_d(t)`` — its centre on a
figure-eight of ±``amplitude`` (10 cm) in x and ±amplitude/2 in y, its radius oscillating ±15 %, period 4 s
(:func:`figure_eight_target`) — while a 6 cm sphere crosses the workspace on a straight line (random height,
heading, offset and speed per seed: :func:`obstacle_path`).

Physics (MuJoCo, 1 kHz, gravity and contacts on, no weld): the robot is the scene of
:func:`~coop_ga.sim.build_scene`; the sphere is a body with three slide joints driven by position servos
(``gravcomp``: the servos carry no weight), so its motion is in ``ctrl`` and the run replays from
``model.xml`` + ``log.npz`` alone (:func:`coop_ga.sim.replay`).  It is a physical body: if a link touched it,
MuJoCo would report the contact (counted; the claim is zero).

Control (:class:`TrackingController`, the three loops of :mod:`coop_ga.control.mpc`): the MPC tick every
``period`` (re-plans with the iLQR), the clearance-limited safety QP every ``filter_dt``, and at every physics
step the joint-level law ``τ = RNEA(q, q̇, a_r + K_p (q_r − q) + K_d (q̇_r − q̇))`` along the safety layer's
velocity ramp.  The MPC sees the sphere's commanded path (a perfectly known obstacle); its servo is driven
with a velocity lead so that it follows that path (the lag of a position servo on a ramp is cancelled).

Metrics (:func:`track_metrics`): the primitive's centre and radius against the target's (from the logged q,
every 10 ms), ‖e‖ (Eq 44), the collision model's clearance with the sphere at its *simulated* position
(arm–obstacle and arm–arm), MuJoCo's contacts robot–sphere and robot–robot (counted at every physics step),
joint position / velocity limit excursions of the simulated state, torque saturation, the MPC's ticks and
iterations, the safety layer's fallbacks; with a push (:class:`TrackCase` ``push``: 20 N on one arm for 0.2 s
through ``xfrc_applied``) the peak deviation and the recovery time.  These depend on the seed alone (the MPC's
budget is a count of iterations, not a time); the wall-clock tick times are apart (:func:`track_timing`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..control.mpc import CooperativeMPC, MovingSphere, MPCInfeasibleError, MPCOptions
from ._mujoco import mj
from .hold import circle_target
from .scene import Scene, build_scene, set_inertial
from .simulation import Disturbance, Simulation, SimulationLog

__all__ = [
    "TrackCase",
    "TrackRun",
    "TrackingController",
    "figure_eight_target",
    "mpc_timing",
    "obstacle_path",
    "recovery_time",
    "run_track",
    "stats",
    "track_metrics",
    "track_scene",
    "track_timing",
]

OBSTACLE = "obstacle"
#: position-servo stiffness [N/m] and damping [N s/m] of the sphere's slide joints
SERVO_KP, SERVO_KV = 4000.0, 120.0
#: joint-level PD gains [1/s², 1/s] (multiplied by the RNEA: acceleration-level gains)
KP, KD = 400.0, 40.0


@dataclass(frozen=True)
class TrackCase:
    """One closed-loop run: ``seed`` draws the sphere's path; ``obstacle=False`` runs without it; ``push``
    applies ``push_force`` [N] (world frame) to ``push_body`` (default arm 0's hand: its last link) from ``push_start`` for ``push_duration`` [s]."""

    name: str
    seed: int = 0
    duration: float = 4.0
    obstacle: bool = True
    push: bool = False
    push_force: tuple[float, float, float] = (0.0, 20.0, 0.0)
    push_start: float = 1.5
    push_duration: float = 0.2
    push_body: str = "arm0_panda_link7"
    sphere_radius: float = 0.06


@dataclass
class TrackRun:
    """A finished run: the case, the log, the controller (its traces), the target and the sphere's path."""

    case: TrackCase
    log: SimulationLog
    controller: TrackingController
    target: Callable[[float], Any]
    path: Callable[[float], np.ndarray] | None
    wall_s: float = 0.0
    extra: dict[str, Any] = field(default_factory=dict)


def figure_eight_target(
    centre: Any, radius: float, amplitude: float = 0.10, oscillation: float = 0.15, period: float = 4.0
) -> Callable[[float], Any]:
    """``V_d(t)``: the horizontal circle of centre ``centre + (A sin ωt, ½A sin 2ωt, 0)`` and radius
    ``r (1 + ρ sin ωt)`` (ω = 2π/period) — at t = 0 the circle (centre, radius)."""
    c0 = np.asarray(centre, float)
    w = 2.0 * math.pi / period

    def target(t: float) -> Any:
        c = c0 + np.array([amplitude * math.sin(w * t), 0.5 * amplitude * math.sin(2.0 * w * t), 0.0])
        return circle_target(c, radius * (1.0 + oscillation * math.sin(w * t)))

    return target


def target_parameters(target: Callable[[float], Any], task: Any, t: float) -> tuple[np.ndarray, float]:
    """(centre (3,) [m], radius [m]) of the target circle at t."""
    from ..geometry import primitives as P

    X = target(t).apply(task.unit)
    return np.asarray(P.center(X), float), float(P.radius(X))


def obstacle_path(seed: int, centre: Any, duration: float) -> Callable[[float], np.ndarray]:
    """A straight crossing of the workspace at constant speed: through a point within 15 cm (horizontally) of
    ``centre`` at height 0.60–0.80 m, heading uniform, speed 0.15–0.25 m/s, at a time uniform in the middle
    of the run; the sphere starts at most 0.9 m from the crossing point and stops there after."""
    rng = np.random.default_rng(seed)
    rho, phi, theta = rng.uniform(0.0, 0.15), rng.uniform(0.0, 2 * math.pi), rng.uniform(0.0, 2 * math.pi)
    z, speed = rng.uniform(0.60, 0.80), rng.uniform(0.15, 0.25)
    t_c = rng.uniform(0.4, 0.6) * duration
    p_c = np.array([centre[0] + rho * math.cos(phi), centre[1] + rho * math.sin(phi), z])
    u = np.array([math.cos(theta), math.sin(theta), 0.0])
    reach = 0.9 / speed

    def path(t: float) -> np.ndarray:
        return p_c + speed * float(np.clip(t - t_c, -reach, reach)) * u

    return path


def track_scene(system: Any, start: Any, radius: float) -> Scene:
    """The robot's scene plus the sphere ``obstacle`` of ``radius`` [m] at ``start`` (3,) [m]: three slide joints
    ``obstacle_x/y/z`` with position servos ``obstacle_x/y/z_servo`` (ctrl: displacement from ``start`` [m])."""
    m = mj()
    scene = build_scene(system, floor=0.0, visual_cell=0.02)  # coarse visual meshes: a 0.2 MB model.xml
    body = scene.spec.worldbody.add_body(name=OBSTACLE, pos=np.asarray(start, float), gravcomp=1.0)
    for k, ax in enumerate("xyz"):
        axis = np.eye(3)[k]
        body.add_joint(name=f"{OBSTACLE}_{ax}", type=m.mjtJoint.mjJNT_SLIDE, axis=axis, damping=0.0)
        act = scene.spec.add_actuator(
            name=f"{OBSTACLE}_{ax}_servo", target=f"{OBSTACLE}_{ax}", trntype=m.mjtTrn.mjTRN_JOINT
        )
        act.set_to_position(kp=SERVO_KP, kv=SERVO_KV)
    set_inertial(body, 1.0, np.zeros(3), 0.4 * radius * radius * np.eye(3), "the obstacle sphere")  # 1 kg solid
    body.add_geom(
        name=f"{OBSTACLE}_geom", type=m.mjtGeom.mjGEOM_SPHERE, size=[radius, 0, 0], rgba=[0.85, 0.2, 0.2, 0.8], contype=1, conaffinity=1,
    )  # fmt: skip
    return scene.recompile()


class TrackingController:
    """The three loops of :mod:`coop_ga.control.mpc` as a :class:`~coop_ga.sim.Simulation` controller (module
    docstring); also drives the sphere's servos and counts MuJoCo's contacts at every physics step."""

    def __init__(self, mpc: CooperativeMPC, scene: Scene, path: Callable[[float], np.ndarray] | None, start: Any):
        self.mpc, self.scene, self.path = mpc, scene, path
        self.start = np.asarray(start, float)
        o = mpc.o
        self._every_filter = round(o.filter_dt / scene.model.opt.timestep)
        self._every_tick = round(o.period / o.filter_dt)
        self._steps = 0
        self._ref: tuple[float, np.ndarray, np.ndarray, np.ndarray] | None = None
        self._servo = np.array([scene.id_of("actuator", f"{OBSTACLE}_{a}_servo") for a in "xyz"])
        ob_body = scene.id_of("body", OBSTACLE)
        m = scene.model
        self._geom_body = np.asarray(m.geom_bodyid)
        self._ob_body = ob_body
        robot = np.zeros(m.ngeom, bool)
        robot[scene.capsule_geoms] = True
        self._robot_geom = robot
        self.ticks: list[Any] = []
        self.filters: list[Any] = []
        self.fallbacks: list[tuple[float, str]] = []
        self.contacts = {"robot_obstacle_steps": 0, "robot_robot_steps": 0, "robot_obstacle": 0, "robot_robot": 0}

    def _drive_sphere(self, t: float, data: Any) -> None:
        if self.path is None:
            return
        v = (self.path(t + 1e-3) - self.path(t - 1e-3)) / 2e-3
        data.ctrl[self._servo] = self.path(t) - self.start + (SERVO_KV / SERVO_KP) * v

    def _count_contacts(self, data: Any) -> None:
        n = int(data.ncon)
        if not n:
            return
        g = np.asarray(data.contact.geom[:n])
        rob = self._robot_geom[g]
        ob = self._geom_body[g] == self._ob_body
        r_o = int(np.sum((rob[:, 0] & ob[:, 1]) | (rob[:, 1] & ob[:, 0])))
        r_r = int(np.sum(rob[:, 0] & rob[:, 1]))
        self.contacts["robot_obstacle"] += r_o
        self.contacts["robot_robot"] += r_r
        self.contacts["robot_obstacle_steps"] += int(r_o > 0)
        self.contacts["robot_robot_steps"] += int(r_r > 0)

    def _update(self, t: float, q: np.ndarray, qd: np.ndarray) -> None:
        """The MPC tick (every period) and the safety step (every filter_dt): a new acceleration ramp."""
        k = self._steps // self._every_filter
        try:
            if k % self._every_tick == 0 or self.mpc.plan is None:
                self.ticks.append(self.mpc.tick(t, q, qd))
            f = self.mpc.filter(t, q, qd)
            self.filters.append(f)
            a = f.acceleration
        except MPCInfeasibleError as exc:
            self.fallbacks.append((t, str(exc)))
            a = exc.fallback_acceleration
        self._ref = (t, q.copy(), qd.copy(), a)

    def __call__(self, t: float, q: np.ndarray, qd: np.ndarray, sensors: Any) -> np.ndarray:
        data = sensors.data
        self._count_contacts(data)
        self._drive_sphere(t, data)
        if self._steps % self._every_filter == 0:
            self._update(t, q, qd)
        self._steps += 1
        assert self._ref is not None
        t0, q0, qd0, a = self._ref
        s = t - t0
        q_r, qd_r = q0 + s * qd0 + 0.5 * s * s * a, qd0 + s * a
        return self.mpc.torque(q, qd, a + KP * (q_r - q) + KD * (qd_r - qd))


def run_track(
    case: TrackCase,
    options: MPCOptions | None = None,
    *,
    path: Callable[[float], np.ndarray] | None = None,
    progress: bool = False,
) -> TrackRun:
    """Build, simulate ``case.duration`` s and return the :class:`TrackRun` (module docstring); ``path``
    (t → centre (3,) [m]) replaces the seed's sphere path."""
    import coop_ga as cg

    system = cg.systems.load("three_franka")
    task = cg.cooperative_task(system, "circle")
    q0 = np.array(system.q0, float)
    X0 = task.primitive(q0)
    from ..geometry import primitives as P

    c0, r0 = np.asarray(P.center(X0), float), float(P.radius(X0))
    target = figure_eight_target(c0, r0)
    if path is None and case.obstacle:
        path = obstacle_path(case.seed, c0, case.duration)
    start = path(0.0) if path is not None else np.array([2.5, 2.5, 0.5])  # parked far away, still simulated
    spheres = [MovingSphere(case.sphere_radius, path, OBSTACLE)] if path is not None else []
    mpc = CooperativeMPC(task, target, options, obstacles=spheres)
    scene = track_scene(system, start, case.sphere_radius)
    ctrl = TrackingController(mpc, scene, path, start)
    dist = []
    if case.push:
        dist.append(
            Disturbance(
                case.push_body, case.push_force, start=case.push_start, stop=case.push_start + case.push_duration
            )
        )
    sim = Simulation(scene, ctrl, q=q0, disturbances=dist)
    t0 = time.perf_counter()
    log = sim.run(case.duration, progress=progress)
    return TrackRun(case, log, ctrl, target, path, time.perf_counter() - t0)


def _samples(run: TrackRun, every: float = 0.01) -> np.ndarray:
    k = max(1, round(every / float(run.log.scene.model.opt.timestep)))
    return np.arange(0, len(run.log.time), k)


def tracking_series(run: TrackRun) -> dict[str, np.ndarray]:
    """Every 10 ms: time, the primitive's and the target's centre (3,) and radius, ‖e‖ (Eq 44)."""
    from ..geometry import primitives as P

    task = run.controller.mpc.task
    idx = _samples(run)
    t, Q = run.log.time[idx], run.log.q[idx]
    c, r, ct, rt, e = [], [], [], [], []
    for tk, qk in zip(t, Q):
        X = task.primitive(qk)
        c.append(np.asarray(P.center(X), float))
        r.append(float(P.radius(X)))
        a, b = target_parameters(run.target, task, float(tk))
        ct.append(a)
        rt.append(b)
        e.append(float(np.linalg.norm(task.error(qk, run.target(float(tk))))))
    return {"t": t, "centre": np.array(c), "radius": np.array(r), "target_centre": np.array(ct),
            "target_radius": np.array(rt), "error": np.array(e)}  # fmt: skip


def clearance_series(run: TrackRun) -> dict[str, np.ndarray]:
    """Every 10 ms: the collision model's smallest arm–obstacle and arm–arm (different chains) clearance [m],
    with the sphere at its simulated position."""
    from ..collision.distance import Sphere

    cm = run.controller.mpc.world.model
    scene = run.log.scene
    adr = np.array([scene.model.jnt_qposadr[scene.id_of("joint", f"{OBSTACLE}_{a}")] for a in "xyz"])
    idx = _samples(run)
    n_obs = cm.n_obstacle_rows
    inter = cm.inter_branch
    obst, arms = [], []
    saved = cm.obstacles
    try:
        for k in idx:
            if n_obs:
                cm.obstacles = (Sphere(run.controller.start + run.log.qpos[k, adr], run.case.sphere_radius),)
            d = cm.distances(run.log.q[k])
            obst.append(float(d[:n_obs].min(initial=np.inf)))
            arms.append(float(d[inter].min(initial=np.inf)))
    finally:
        cm.obstacles = saved
    return {"t": run.log.time[idx], "obstacle": np.array(obst), "arm_arm": np.array(arms)}


def recovery_time(t: np.ndarray, err: np.ndarray, start: float, threshold: float, hold: float = 0.2) -> float:
    """Seconds from ``start`` until ``err`` is below ``threshold`` and stays there for ``hold`` s (inf: never)."""
    below = err < threshold
    after = t >= start
    for i in np.flatnonzero(after & below):
        window = (t >= t[i]) & (t < t[i] + hold)
        if t[i] + hold <= t[-1] and below[window].all():
            return float(t[i] - start)
    return math.inf


def _finite(x: float) -> float | None:
    """x, or None (JSON null) where it is not finite (no obstacle: no clearance; never recovered)."""
    return float(x) if math.isfinite(x) else None


def stats(x: Any) -> dict[str, float]:
    """``{"median", "p95", "max"}`` of the values x (m,) (NaN for none)."""
    x = np.asarray(x, float)
    if not x.size:
        return {"median": math.nan, "p95": math.nan, "max": math.nan}
    return {"median": float(np.median(x)), "p95": float(np.percentile(x, 95)), "max": float(x.max())}


def mpc_timing(
    mpc: CooperativeMPC, ticks: Sequence[Any], filters: Sequence[Any] = (), wall_s: float = 0.0
) -> dict[str, Any]:
    """The wall-clock side of a closed-loop run, for ``timing.json`` and never ``metrics.json`` (it changes with
    the machine and its load, the rest of a run does not): the MPC ticks' own time (``tick_s``), their iLQR solve
    (``solve_s``) and the safety steps (``filter_s``) as :func:`stats` [s], the ticks over the budget
    (``overruns``: warned and counted, never skipped: :class:`~coop_ga.control.mpc.CooperativeMPC`) and the whole
    simulation's ``wall_s`` [s]."""
    return {
        "tick_s": stats([k.tick_time for k in ticks]),
        "solve_s": stats([k.solve_time for k in ticks]),
        "filter_s": stats([f.step_time for f in filters]),
        "overruns": int(mpc.overruns),
        "ticks": len(ticks),
        "wall_s": float(wall_s),
    }


def track_timing(run: TrackRun) -> dict[str, Any]:
    """:func:`mpc_timing` of a tracking run."""
    ctrl = run.controller
    return mpc_timing(ctrl.mpc, ctrl.ticks, ctrl.filters, run.wall_s)


def _limits(run: TrackRun, rows: np.ndarray | None = None) -> dict[str, float]:
    lim = run.controller.mpc.lim
    q, qd = run.log.q, run.log.qd
    if rows is not None:
        q, qd = q[rows], qd[rows]
    return {
        "position_violation_rad": float(lim.position_violation(q)),
        "velocity_violation_rad_s": float(lim.velocity_violation(qd)),
        "saturated_torque_updates": int(run.log.saturated_updates),
        "effort_ratio": float(run.log.effort_ratio),
    }


def track_metrics(run: TrackRun, settle: float = 0.5) -> dict[str, Any]:
    """The run's numbers (module docstring); tracking statistics after ``settle`` [s]."""
    tr, cl = tracking_series(run), clearance_series(run)
    ctrl, case = run.controller, run.case
    ok = tr["t"] >= settle
    ce = np.linalg.norm(tr["centre"] - tr["target_centre"], axis=1)
    re = np.abs(tr["radius"] - tr["target_radius"])
    m: dict[str, Any] = {
        "case": case.name, "seed": case.seed, "duration_s": case.duration, "obstacle": case.obstacle,
        "centre_error_m": {"rms": float(np.sqrt(np.mean(ce[ok] ** 2))), "max": float(ce[ok].max())},
        "radius_error_m": {"rms": float(np.sqrt(np.mean(re[ok] ** 2))), "max": float(re[ok].max())},
        "error_norm": {"rms": float(np.sqrt(np.mean(tr["error"][ok] ** 2))), "max": float(tr["error"][ok].max())},
        "min_clearance_obstacle_m": _finite(float(cl["obstacle"].min(initial=np.inf))),
        "min_clearance_arm_arm_m": float(cl["arm_arm"].min(initial=np.inf)),
        "contacts": dict(ctrl.contacts),
        "limits": _limits(run),
        "mpc_ticks": len(ctrl.ticks),
        "iterations_per_tick": stats(np.array([k.iterations for k in ctrl.ticks], float)),
        "plan_violation_max": float(max((k.violation for k in ctrl.ticks), default=0.0)),
        "fallbacks": len(ctrl.fallbacks), "first_fallback": ctrl.fallbacks[0][1] if ctrl.fallbacks else None,
        "period_s": ctrl.mpc.o.period, "filter_dt_s": ctrl.mpc.o.filter_dt, "horizon": ctrl.mpc.o.horizon,
    }  # fmt: skip
    if case.push:
        m["push"] = _push_metrics(tr["t"], ce, case)
        t = run.log.time
        rows = (t < case.push_start) | (t >= case.push_start + case.push_duration + 0.5)
        m["push"]["limits_outside_push"] = _limits(run, rows)  # the push itself may drive a joint past a limit
    return m


def _push_metrics(t: np.ndarray, ce: np.ndarray, case: TrackCase) -> dict[str, Any]:
    before = ce[(t >= case.push_start - 1.0) & (t < case.push_start)]
    threshold = max(2.0 * float(np.percentile(before, 95)) if before.size else 0.0, 0.005)
    during = ce[(t >= case.push_start) & (t < case.push_start + case.push_duration + 1.0)]
    return {
        "force_n": float(np.linalg.norm(case.push_force)),
        "duration_s": case.push_duration,
        "peak_centre_error_m": float(during.max(initial=0.0)),
        "threshold_m": threshold,
        "recovery_time_s": _finite(recovery_time(t, ce, case.push_start, threshold)),
    }
