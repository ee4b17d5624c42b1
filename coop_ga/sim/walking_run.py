"""A walk of the hexapod in MuJoCo, measured: :func:`simulate_walk` runs :class:`~coop_ga.sim.walking.HexapodWalker`
and records the ground truth the controller never sees; :class:`WalkRun` turns it into metrics, a replayable log
and pictures.

Ground truth (recorded beside the controller, at every physics step; the controller reads only its sensors)
------------------------------------------------------------------------------------------------------------
* **terrain contacts by robot part** (:meth:`~coop_ga.sim.hexapod.HexapodScene.terrain_contacts`): a step with a
  shin (tibia capsule), femur or body touching the terrain counts;
* **foot slip** (sampled at the plans' rate, 200 Hz): while a foot's touch sensor reads more than the contact
  threshold, the velocity of the ball's material point at the contact, ``v_c = v + ω × (−r n)`` (v, ω: the foot site's linear and angular velocity,
  ``mujoco.mj_objectVelocity``; n the terrain normal under the foot), is integrated in the tangent plane: the
  sliding distance of that stance.  Rolling is not slip (v_c = 0 for a ball that rolls); the ball centre's
  horizontal drift over the stance (rolling included) is reported beside it.  The slip of a stance is the
  norm of the integral (the net sliding displacement); the integral of its norm (the sliding path, which
  also sums the contact's micro-vibration back and forth) is reported too;
* the feet (ball centres) and the touch forces at every plan, for the height over the support.

Metrics (:meth:`WalkRun.metrics`; the gallery table's rows)
----------------------------------------------------------------
``walked_fraction``: the body's displacement along the commanded displacement over the commanded
displacement (the command integrated, :meth:`VelocityCommand.path`); ``max_roll_deg`` / ``max_pitch_deg`` (world);
``max_height_error_m``: |distance of the body origin from the least-squares plane of the touching feet's centres
− ride_height|, over the plans with ≥ 3 touching feet after ``settle`` s (touching: within the last 10 ms,
:meth:`WalkRun.height_errors`); ``max_slip_m`` (sliding per stance),
``max_foot_drift_m``; ``saturated_updates`` / ``effort_ratio`` (the simulation's torque clipping at the URDF
effort); ``shin_contact_steps``, ``femur_contact_steps``, ``body_contact_steps`` (on the terrain),
``self_contact_steps`` (the robot on itself, a femur on the body box: reported, not part of the bar); ``fell``:
|roll| or |pitch| > 10°, a height error > 2 cm, or the body or a femur on the terrain; ``passed``: the bar —
walked ≥ 95 %, not fallen, slip ≤ 5 mm per stance, no saturation, no shin contact.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import validation
from ..errors import InvalidInputError
from ._mujoco import mj
from .hexapod import HEXAPOD_LEGS, HexapodScene, hexapod_scene
from .simulation import Disturbance, Simulation, SimulationLog
from .walking import HexapodWalker, VelocityCommand, WalkingOptions, _fit_plane, standing_start

__all__ = ["BAR", "GroundTruth", "WalkRun", "simulate_walk"]

#: the bar for a walk (module docstring)
BAR = {
    "walked_fraction": 0.95,
    "max_tilt_deg": 10.0,
    "max_height_error_m": 0.02,
    "max_slip_m": 0.005,
    "saturated_updates": 0,
    "shin_contact_steps": 0,
}


@dataclass
class _Stance:
    t0: float
    p0: np.ndarray
    slide: float = 0.0  # ∫ |v_t| dt
    net: np.ndarray = field(default_factory=lambda: np.zeros(3))  # ∫ v_t dt
    t1: float = 0.0
    p1: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self) -> None:
        self.t1, self.p1 = self.t0, self.p0.copy()


class GroundTruth:
    """Wraps the walker as the :class:`~coop_ga.sim.Simulation` controller and records the truth beside it
    (module docstring); the walker gets exactly the arguments it would get alone."""

    def __init__(self, walker: HexapodWalker, threshold: float):
        self.walker = walker
        self.hs: HexapodScene = walker.hs
        self.threshold = float(threshold)
        self.r = self.hs.foot_radius
        self.contacts: list[tuple[int, int, int, int]] = []  # per physics step: (shin, femur, body, self) contacts
        self.plans: list[tuple[float, np.ndarray, np.ndarray]] = []  # (t, feet (6, 3), touch (6,))
        #: (leg, t0, t1, slip = |∫ v_t dt|, drift of the ball centre, sliding path ∫ |v_t| dt) per stance
        self.stances: list[tuple[int, float, float, float, float, float]] = []
        self._open: dict[int, _Stance] = {}
        self._v = np.zeros(6)
        self._steps = 0
        P = self.hs.terrain.planes
        #: the terrain's normal where it is one for all cells (flat, slope, horizontal grids), else None
        self._normal = P[0, 0, :3].copy() if np.all(P[..., :3] == P[0, 0, :3]) else None

    def __call__(self, t: float, q: np.ndarray, qd: np.ndarray, sensors: Any) -> np.ndarray:
        d = sensors.data
        c = self.hs.terrain_contacts(d)
        self.contacts.append((c["shin"], c["femur"], c["body"], c["self"]))
        if self._steps % self.walker.every == 0:  # slip integrated and feet sampled at the plans' rate
            touch = np.asarray(d.sensordata[self.hs.touch_adr])
            self._slip(t, d, touch)
            self.plans.append((t, self.hs.feet_world(d), touch.copy()))
        self._steps += 1
        return self.walker(t, q, qd, sensors)

    def _slip(self, t: float, d: Any, touch: np.ndarray) -> None:
        m = self.hs.model
        dt = float(m.opt.timestep) * self.walker.every
        for i in range(6):
            st = self._open.get(i)
            if touch[i] <= self.threshold:
                if st is not None:
                    self._close(i, st)
                continue
            sid = int(self.hs.foot_sites[i])
            mj().mj_objectVelocity(m, d, mj().mjtObj.mjOBJ_SITE, sid, self._v, 0)
            p = np.array(d.site_xpos[sid])
            n = self._normal if self._normal is not None else self.hs.terrain.normal(p[:2])
            w, r = self._v[:3], -self.r * n
            vc = self._v[3:] + np.array(
                [w[1] * r[2] - w[2] * r[1], w[2] * r[0] - w[0] * r[2], w[0] * r[1] - w[1] * r[0]]
            )
            # (the velocity of the ball's material point at the contact: v + ω × (−r n))
            vt = vc - (vc @ n) * n
            if st is None:
                self._open[i] = _Stance(t, p)
            else:
                st.slide += float(np.linalg.norm(vt)) * dt
                st.net += vt * dt
                st.t1, st.p1 = t, p

    def _close(self, i: int, st: _Stance) -> None:
        drift = float(np.linalg.norm((st.p1 - st.p0)[:2]))
        self.stances.append((i, st.t0, st.t1, float(np.linalg.norm(st.net)), drift, st.slide))
        del self._open[i]

    def finish(self) -> None:
        """Close the stances still open at the end of the run."""
        for i in list(self._open):
            self._close(i, self._open[i])


@dataclass
class WalkRun:
    """One simulated walk: the scene, the walker, the simulation log, the ground truth (module docstring).

    ``label``: a name for the run (``"tripod_steps_blind"``); ``disturbances``: what was applied; ``wall_s``: the
    wall-clock time of the simulation."""

    hs: HexapodScene
    walker: HexapodWalker
    log: SimulationLog
    truth: GroundTruth
    command: VelocityCommand
    options: WalkingOptions
    label: str = ""
    disturbances: tuple[Disturbance, ...] = ()
    wall_s: float = 0.0
    settle: float = 0.3
    _metrics: dict[str, Any] | None = field(default=None, repr=False)
    _records: dict[str, np.ndarray] | None = field(default=None, repr=False)

    def records(self) -> dict[str, np.ndarray]:
        """The walker's plan records (:meth:`~coop_ga.sim.walking.HexapodWalker.records_arrays`), computed once."""
        if self._records is None:
            self._records = self.walker.records_arrays()
        return self._records

    # ------------------------------------------------------------------ body
    @property
    def base(self) -> tuple[np.ndarray, np.ndarray]:
        """(positions (T, 3) [m], quaternions (T, 4) (w, x, y, z)) of the body at every logged step."""
        a = self.hs.scene.base_qpos
        assert a is not None
        return self.log.qpos[:, a : a + 3], self.log.qpos[:, a + 3 : a + 7]

    def rpy(self) -> np.ndarray:
        """(T, 3) roll, pitch, yaw [rad] of the body (R = Rz(yaw) Ry(pitch) Rx(roll), as
        :func:`coop_ga.legged.body.rpy_from_rotation`; pitch in [−π/2, π/2])."""
        w, x, y, z = self.base[1].T
        r20 = 2.0 * (x * z - w * y)
        r21, r22 = 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)
        r10, r00 = 2.0 * (x * y + w * z), 1.0 - 2.0 * (y * y + z * z)
        return np.column_stack([np.arctan2(r21, r22), np.arcsin(np.clip(-r20, -1.0, 1.0)), np.arctan2(r10, r00)])

    def height_errors(self) -> tuple[np.ndarray, np.ndarray]:
        """(t (P,), error (P,) [m]): the body's distance from the plane of the touching feet's centres minus
        ride_height, at the plans with ≥ 3 touching feet (NaN otherwise).  A foot counts as touching if its sensor
        read more than the threshold at this plan or one of the two before (10 ms): a loaded foot's force dips to
        zero for a sample when it bounces, and a plane of the other feet alone (all low, say, while the front feet
        stand on a step) is not the support the body stands on."""
        pos, _ = self.base
        ts = np.array([p[0] for p in self.truth.plans])
        err = np.full(len(ts), np.nan)
        thr = self.truth.threshold
        touching = np.array([p[2] > thr for p in self.truth.plans]).reshape(-1, 6)
        held = touching.copy()
        held[1:] |= touching[:-1]
        held[2:] |= touching[:-2]
        for k, (t, feet, _touch) in enumerate(self.truth.plans):
            on = held[k]
            if on.sum() >= 3:
                n, d = _fit_plane(feet[on])
                i = min(round(t / float(self.hs.model.opt.timestep)), len(pos) - 1)
                err[k] = float(n @ pos[i] - d) - self.options.ride_height
        return ts, err

    # ------------------------------------------------------------------ metrics
    def metrics(self) -> dict[str, Any]:
        """The run's numbers (module docstring)."""
        if self._metrics is not None:
            return self._metrics
        pos, _ = self.base
        t = self.log.time
        path = self.command.path(float(t[-1]), 0.005)
        cmd_disp = path[-1, :2] - path[0, :2]
        cmd_len = float(np.linalg.norm(cmd_disp))
        disp = pos[-1, :2] - pos[0, :2]
        walked = float(disp @ cmd_disp / cmd_len) / cmd_len if cmd_len > 1e-9 else math.nan
        rpy = np.degrees(self.rpy())
        late = t >= self.settle
        th, he = self.height_errors()
        he_late = he[(th >= self.settle) & np.isfinite(he)]
        C = np.array(self.truth.contacts) if self.truth.contacts else np.zeros((0, 4), int)
        S = np.array([s[3:] for s in self.truth.stances]) if self.truth.stances else np.zeros((0, 3))
        m = {
            "label": self.label,
            "gait": self.options.gait,
            "terrain": self.hs.terrain.kind,
            "blind": bool(self.options.blind),
            "feedback": bool(self.options.feedback),
            "duration_s": float(t[-1] - t[0]),
            "commanded_distance_m": cmd_len,
            "distance_m": float(np.linalg.norm(disp)),
            "walked_fraction": walked,
            "final_yaw_deg": float(rpy[-1, 2]),
            "commanded_yaw_deg": float(np.degrees(path[-1, 2])),
            "max_roll_deg": float(np.abs(rpy[late, 0]).max(initial=0.0)),
            "max_pitch_deg": float(np.abs(rpy[late, 1]).max(initial=0.0)),
            "max_height_error_m": float(np.abs(he_late).max(initial=0.0)),
            "mean_height_error_m": float(np.mean(he_late)) if len(he_late) else math.nan,
            "max_slip_m": float(S[:, 0].max(initial=0.0)),
            "max_foot_drift_m": float(S[:, 1].max(initial=0.0)),
            "max_slide_path_m": float(S[:, 2].max(initial=0.0)),
            "stances": len(S),
            "saturated_updates": int(self.log.saturated_updates),
            "control_updates": int(self.log.control_updates),
            "effort_ratio": float(self.log.effort_ratio),
            "shin_contact_steps": int(np.count_nonzero(C[:, 0])) if len(C) else 0,
            "femur_contact_steps": int(np.count_nonzero(C[:, 1])) if len(C) else 0,
            "body_contact_steps": int(np.count_nonzero(C[:, 2])) if len(C) else 0,
            "self_contact_steps": int(np.count_nonzero(C[:, 3])) if len(C) else 0,
            "events": dict(self.walker.counts),
            "schedule_lag_s": float(self.walker.lag),
            "plan_s": float(self.walker.timing["plan_s"]),
            "servo_s": float(self.walker.timing["servo_s"]),
            "wall_s": float(self.wall_s),
        }
        m["fell"] = bool(
            max(m["max_roll_deg"], m["max_pitch_deg"]) > BAR["max_tilt_deg"]
            or m["max_height_error_m"] > BAR["max_height_error_m"]
            or m["body_contact_steps"] > 0
            or m["femur_contact_steps"] > 0
        )
        m["passed"] = bool(
            (math.isnan(walked) or walked >= BAR["walked_fraction"])
            and not m["fell"]
            and m["max_slip_m"] <= BAR["max_slip_m"]
            and m["saturated_updates"] == 0
            and m["shin_contact_steps"] == 0
        )
        self._metrics = m
        return m

    # ------------------------------------------------------------------ files
    def step_arrays(self, rows: np.ndarray | None = None) -> dict[str, np.ndarray]:
        """At the log rows ``rows`` (default: every physics step): ``body_pose`` (S, 7) position [m] + quaternion
        (w, x, y, z) of the body (the free joint's qpos), ``stance`` (S, 6) bool — the stance set of the plan in
        force at that step (legs in :data:`HEXAPOD_LEGS` order)."""
        pos, quat = self.base
        rec = self.records()
        rows = np.arange(len(self.log.time)) if rows is None else np.asarray(rows)
        idx = np.clip(np.searchsorted(rec["t"], self.log.time[rows], side="right") - 1, 0, len(rec["t"]) - 1)
        return {"body_pose": np.hstack([pos[rows], quat[rows]]), "stance": rec["stance"][idx]}

    def save(self, folder: str | Path) -> Path:
        """Write the run's replayable folder: ``model.xml``; ``log.npz`` — the simulation's contract
        (:mod:`coop_ga.sim.replay`) thinned to stay small: ``ctrl`` (and ``xfrc``) at every physics step (float32:
        the walker's torques are float32 values, so the replay is still bit for bit), the state ``time``, ``qpos``,
        ``qvel`` at the plans' rate (``state_rows``: their step indices, the last step included) — plus
        ``body_pose`` and ``stance`` at those rows, the plans' records as ``plan_*`` (float32 but ``plan_t``), the
        terrain as ``terrain_*`` and the legs' order ``legs``; ``metrics.json`` (the log's metrics and
        :meth:`metrics` as ``walk``)."""
        out = Path(folder)
        out.mkdir(parents=True, exist_ok=True)
        log = self.log
        self.hs.scene.write_model(out / "model.xml")
        T = len(log.time)
        rows = np.unique(np.r_[np.arange(0, T, self.walker.every), T - 1])
        c32 = log.ctrl.astype(np.float32)
        arrays: dict[str, Any] = {
            "time": log.time[rows],
            "qpos": log.qpos[rows],
            "qvel": log.qvel[rows],
            "ctrl": c32 if np.array_equal(c32, log.ctrl) else log.ctrl,
            "state_rows": rows,
        }
        if len(log.xfrc_bodies):
            arrays |= {"xfrc_bodies": log.xfrc_bodies, "xfrc": log.xfrc}
        arrays |= self.step_arrays(rows)
        for k, v in self.records().items():
            arrays[f"plan_{k}"] = v.astype(np.float32) if k != "t" and v.dtype == np.float64 else v
        arrays |= self.hs.terrain.to_arrays()
        arrays["legs"] = np.array(HEXAPOD_LEGS)
        np.savez_compressed(out / "log.npz", **arrays)
        meta = log.metrics() | {"walk": self.metrics(), "state_every": int(self.walker.every)}
        (out / "metrics.json").write_text(json.dumps(meta, indent=2, allow_nan=False))
        return out

    def summary(self) -> str:
        m = self.metrics()
        return (
            f"{self.label or 'walk'}: {m['distance_m']:.3f} m ({100 * m['walked_fraction']:.1f} % of "
            f"{m['commanded_distance_m']:.3f} m), roll/pitch ≤ {m['max_roll_deg']:.2f}/{m['max_pitch_deg']:.2f}°, "
            f"height error ≤ {1e3 * m['max_height_error_m']:.1f} mm, slip ≤ {1e3 * m['max_slip_m']:.2f} mm, "
            f"saturated {m['saturated_updates']}/{m['control_updates']}, shin contacts {m['shin_contact_steps']}, "
            f"{'PASS' if m['passed'] else 'FAIL'}"
        )


def stance_overlays(run: WalkRun, k: int, data: Any) -> list[Any]:
    """The overlays of log row ``k`` (:func:`render_walk`): the stance primitive of the plan in force — the
    plane of its stance feet drawn only over their support polygon (a ~1 m square or sphere would hide the
    robot), with its normal at the centroid — and the body's z axis."""
    from ..legged.walk import convex_hull
    from . import render as R

    rec = run.records()
    j = int(np.clip(np.searchsorted(rec["t"], run.log.time[k], side="right") - 1, 0, len(rec["t"]) - 1))
    st = rec["stance"][j]
    feet = np.array(data.site_xpos[run.hs.foot_sites])
    out: list[Any] = []
    if st.sum() >= 3:
        P = feet[st]
        n, d = _fit_plane(P)
        H = convex_hull(P[:, :2])
        ring = np.column_stack([H, (d - H @ n[:2]) / n[2]]) - run.hs.foot_radius * n  # on the ground
        c = ring.mean(axis=0)
        out.append(lambda scn, ring=ring: R.add_polyline(scn, ring, (0.1, 0.65, 0.35, 1.0), 0.003, closed=True))
        out.append(lambda scn, c=c, n=n: R.add_arrow(scn, c, 0.06 * n, (0.1, 0.65, 0.35, 1.0), 0.004))
    b, body = run.hs.scene.base_qpos, run.hs.scene.base_body
    assert b is not None and body is not None
    zb = np.array(data.xmat[run.hs.scene.id_of("body", body)]).reshape(3, 3)[:, 2]
    top = np.array(data.qpos[b : b + 3]) + 0.02 * zb  # on the body's top face
    out.append(lambda scn: R.add_arrow(scn, top, 0.08 * zb, (0.85, 0.3, 0.1, 1.0), 0.004))
    return out


def render_walk(
    run: WalkRun, path: str | Path, *, fps: float = 10.0, width: int = 480, height: int = 360, frames: int | None = None
) -> Path:
    """A MuJoCo-rendered GIF/MP4 of ``run`` (its scene built with ``visuals=True``) with the stance primitive
    drawn (:func:`stance_overlays`), the camera following the body at 0.75 m; ``frames`` caps the number of
    frames (evenly spaced over the run), else one every 1/``fps`` s."""
    from . import render as R

    m = run.hs.model
    d = mj().MjData(m)
    T = len(run.log.time)
    step = max(1, round(1.0 / (validation.positive(fps, "fps") * float(m.opt.timestep))))
    rows = np.arange(0, T, step)
    if frames is not None and len(rows) > frames:
        rows = np.unique(np.linspace(0, T - 1, validation.integer(frames, "frames", minimum=2)).round().astype(int))
    imgs = []
    with R.Renderer(run.hs.scene, width, height) as ren:
        for k in rows:
            d.qpos[:], d.qvel[:], d.time = run.log.qpos[k], run.log.qvel[k], float(run.log.time[k])
            mj().mj_forward(m, d)
            b = run.hs.scene.base_qpos
            assert b is not None
            cam = R.Camera(lookat=np.array(d.qpos[b : b + 3]) - np.array([0.0, 0.0, 0.05]), distance=0.75, azimuth=130.0,
                           elevation=-28.0)  # fmt: skip
            imgs.append(ren.frame(d, stance_overlays(run, int(k), d), camera=cam))
    return R.write_video(path, imgs, fps=len(rows) / max(float(run.log.time[-1] - run.log.time[0]), 1e-9))


def simulate_walk(
    terrain: Any,
    command: VelocityCommand,
    options: WalkingOptions | None = None,
    *,
    duration: float | None = None,
    disturbances: Sequence[Disturbance] = (),
    region: Any = None,
    visuals: bool = False,
    timestep: float = 1e-3,
    label: str = "",
    progress: bool = False,
    catch_up: bool = True,
) -> WalkRun:
    """Stand the hexapod on ``terrain`` (:func:`~coop_ga.sim.walking.standing_start` at the origin), walk it
    with ``command`` for ``duration`` [s] (default: to the command's last knot + one cycle; with ``catch_up``
    then on for the time the gait waited for late feet, :attr:`~coop_ga.sim.walking.HexapodWalker.lag`, up to
    one more cycle) under
    ``disturbances`` (e.g. ``Disturbance("base_link_free", force=(0, 10, 0), start=2, stop=2.2)``), and return
    the :class:`WalkRun`.  ``region``: the terrain's extent (default: the commanded path ± 0.6 m); ``timestep``: the
    physics step [s] (the servo loop's period; ``options.control_rate`` must divide its rate)."""
    import time

    from ..legged.terrain import Terrain

    if not isinstance(terrain, Terrain):
        raise InvalidInputError(f"terrain must be a coop_ga.legged.Terrain, got {type(terrain).__name__}")
    opt = options or WalkingOptions()
    if not isinstance(command, VelocityCommand):
        raise InvalidInputError(f"command must be a VelocityCommand, got {type(command).__name__}")
    dur = float(command.end + opt.period) if duration is None else validation.positive(duration, "duration")
    if region is None:
        path = command.path(dur)
        lo, hi = path[:, :2].min(axis=0), path[:, :2].max(axis=0)
        region = ((float(lo[0]) - 0.6, float(hi[0]) + 0.6), (float(lo[1]) - 0.6, float(hi[1]) + 0.6))
    hs = hexapod_scene(terrain, region=region, visuals=visuals, timestep=timestep)
    walker = HexapodWalker(hs, command, opt)
    truth = GroundTruth(walker, opt.touch_threshold)
    q0, pose = standing_start(hs, opt)
    sim = Simulation(hs.scene, truth, q=q0, base_pose=pose, disturbances=disturbances)
    t0 = time.perf_counter()
    log = sim.run(dur, progress=progress)
    if catch_up and walker.lag > 0:  # the schedule waited for late feet: walk it to its end
        log = sim.run(min(walker.lag, opt.period), progress=progress)
    truth.finish()
    return WalkRun(hs, walker, log, truth, command, opt, label, tuple(disturbances), time.perf_counter() - t0)


def load_metrics(folder: str | Path) -> dict[str, Any]:
    """The ``walk`` metrics of a saved run (``metrics.json``)."""
    return dict(json.loads((Path(folder) / "metrics.json").read_text())["walk"])
