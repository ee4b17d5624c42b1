"""Closed-loop receding-horizon control of a held box in MuJoCo: three iiwa carry the free box along a moving target.

The box scene of :mod:`coop_ga.sim.carry` (``three_iiwa14`` with 16 cm tools and rubber pads, a free 2 kg box on a
table, gravity and contacts on, no weld): the arms grasp, squeeze and lift the box with the
:class:`~coop_ga.sim.HoldController` (approach → close → squeeze → lift of the carry plan, then 1 s of holding still: ``SETTLE``), then, for
``track`` seconds, the cooperative MPC (:class:`~coop_ga.control.mpc.CooperativeMPC`) makes the held circle's
centre follow a moving target — a figure-eight of ±``amplitude`` along a ``heading`` and ±amplitude/2 across it,
period 4 s, its amplitude ramped in over the first second (:func:`carry_target`).

How the plan and the hold are composed (:class:`MPCFollower`, :class:`FollowPlan`) — a tube MPC with the hold
impedance as its ancillary feedback:

* every ``period`` (40 ms) the MPC re-plans toward ``V_d(t + n·Δt)`` (the target circle: the moving centre, the
  radius held at the grasp) within the position, velocity and acceleration limits, from the **nominal** state
  (its previous plan at t; the measured state at the first tick);
* the hold controller's circle reference is the nominal plan's centre (its knots' centres, interpolated) plus
  the grasp's sag (the hold's reference minus the measured centre at the first tick); the nullspace posture of
  the hold is the plan's configuration (``q_post = q_plan(t)``);
* the radius is **not** the plan's: the hold's squeeze loop (the e0∞ admittance, :class:`~coop_ga.sim.HoldGains`)
  keeps setting it from the measured squeeze, so the MPC moves the held primitive and the squeeze holds the box.

Why the nominal state and not the measured one: the compliant hold lags its reference and its weight estimate is
an integral action on the vertical force.  Re-planning from the measured centre and (a) jumping the reference
to the plan gives steps of a few mm every tick (velocity spikes in the impedance's damping) and, with the sag
offset, a positive feedback through the weight estimate (the box left its target by 11 cm in 4 s); (b)
integrating the plan's velocity into the reference adds a second integrator and the height oscillated with a
growing ±2–4 cm (measured, 4 s, both with a horizon of 10 and 20 knots).  With the nominal state the loop
through the box is the hold's alone (stable), and the measured centre's distance from the nominal one (the
tube) is recorded every tick.

Clearance: the box run has no obstacle; the arm–arm pairs stay ≥ 0.3 m apart over the carry (measured,
:func:`carry_track_metrics`), and MuJoCo's robot–robot contacts are counted (claim 0).  The MPC's safety QP is
not in this loop: the hold controller is the torque law (it must be, to squeeze).

Metrics (:func:`carry_track_metrics`): the box's position against the target carried through the grasp (the box
at the track start moved by the target's displacement), its turn, slip of each pad on the box
(:func:`~coop_ga.sim.carry.slip_series`), drop (the box back on the table or 3 cm below its lifted height),
squeeze, robot–robot contacts, joint limit excursions, MPC ticks and fallbacks; the wall-clock tick times apart
(:func:`carry_track_timing`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from dataclasses import fields as dataclass_fields
from typing import Any

import numpy as np

from .. import validation
from ..control.mpc import CooperativeMPC, MPCInfeasibleError, MPCOptions
from .carry import FAST_DURATIONS, CarryCase, CarryRun, box_state, carry_setup, slip_series
from .hold import CarryPlan, HoldController, PlanPoint, circle_target, min_jerk
from .mpc_track import mpc_timing, stats
from .simulation import Simulation, SimulationLog

__all__ = [
    "CarryTrackCase",
    "CarryTrackRun",
    "FollowPlan",
    "MPCFollower",
    "carry_target",
    "carry_track_metrics",
    "carry_track_timing",
    "run_carry_track",
]

#: the grasp-and-lift phases (approach, close, squeeze, lift) [s]; the carry phase is the tracking window
LIFT_DURATIONS = FAST_DURATIONS[:4]
RAMP = 1.0  # [s] the figure-eight's amplitude ramps in over this (no velocity step in the target)
#: [s] the lifted box is held this long before the MPC starts: a heavier box still rises at the lift's end
#: (3 kg: 2.7 cm below its settled height) and the tube's sag offset is measured at the first tick
SETTLE = 1.0
DROP = 0.03  # [m] the box is dropped if it sinks this far below its height at the track start


@dataclass(frozen=True)
class CarryTrackCase:
    """One run: the figure-eight's ``amplitude`` [m] along ``heading`` [rad] (world x towards y), its ``period``
    [s]; ``track`` [s] of tracking after the lift; the box's ``mass`` [kg] and ``friction``."""

    name: str = "nominal"
    amplitude: float = 0.05
    heading: float = 0.0
    period: float = 4.0
    track: float = 4.0
    mass: float = 2.0
    friction: float = 0.8

    def __post_init__(self) -> None:
        validation.nonnegative(self.amplitude, "amplitude")
        validation.scalar(self.heading, "heading")
        validation.positive(self.period, "period")
        validation.positive(self.track, "track")

    def describe(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "amplitude_m": self.amplitude,
            "heading_deg": math.degrees(self.heading),
            "period_s": self.period,
            "track_s": self.track,
            "mass_kg": self.mass,
            "friction": self.friction,
        }


def carry_target(start: float, centre: Any, amplitude: float, heading: float = 0.0, period: float = 4.0) -> Any:
    """``t -> (3,)`` [m]: ``centre`` moved on a figure-eight from ``start`` [s]: ``s(t) A (sin ωτ u + ½ sin 2ωτ v)``
    (τ = t − start, ω = 2π/period, u the heading, v ⊥ u horizontal, s a minimum-jerk ramp 0 → 1 over 1 s)."""
    c0 = np.asarray(centre, float)
    u = np.array([math.cos(heading), math.sin(heading), 0.0])
    v = np.array([-u[1], u[0], 0.0])
    w = 2.0 * math.pi / period

    def centre_at(t: float) -> np.ndarray:
        tau = max(t - start, 0.0)
        s = min_jerk(tau / RAMP) * amplitude
        return c0 + s * (math.sin(w * tau) * u + 0.5 * math.sin(2.0 * w * tau) * v)

    return centre_at


class MPCFollower:
    """The MPC's side of the composition (module docstring): ticks the MPC, keeps the continuous centre reference
    and the plan's posture; :class:`FollowPlan` reads :meth:`offset`."""

    def __init__(self, mpc: Any, start: float, lifted: np.ndarray, shape: tuple[float, float, float] = (0.0, 0.0, 4.0)):
        self.mpc, self.start, self.lifted = mpc, float(start), np.asarray(lifted, float)
        self.shape = shape  # (amplitude [m], heading [rad], period [s]) of the figure-eight
        self.centre_at: Any = None  # t -> the target centre (3,), set at the first tick
        self.radius = 0.0  # [m] the target radius: the held circle's at the first tick
        self.ticks: list[Any] = []
        self.fallbacks: list[tuple[float, str]] = []
        self.offset = np.zeros(3)  # [m] the hold's reference minus the measured centre at the first tick (its sag)
        self.tube: list[tuple[float, float]] = []  # (t, the measured centre's distance from the nominal) per tick
        self._knot_t: np.ndarray | None = None
        self._knot_c = np.zeros((0, 3))

    def _plan_centre(self, t: float) -> np.ndarray:
        assert self._knot_t is not None
        kt, kc = self._knot_t, self._knot_c
        return np.array([np.interp(t, kt, kc[:, i]) for i in range(3)])

    def reference(self, t: float) -> np.ndarray:
        """c_ref(t) (3,) [m]: the lifted centre before the first plan, then the nominal plan's centre plus the
        grasp's sag (module docstring)."""
        if self._knot_t is None:
            return self.lifted.copy()
        return self._plan_centre(t) + self.offset

    def target(self, t: float) -> Any:
        """V_d(t): the circle of the held radius about the moving centre (:func:`carry_target`)."""
        return circle_target(self.centre_at(t), self.radius)

    def _anchor(self, q: np.ndarray) -> None:
        """The target starts where the held circle is at the first tick (its centre and radius, measured): the
        box's target is then the box moved by the target's displacement."""
        from ..geometry import primitives as P

        X = self.mpc.task.primitive(q)
        c = np.asarray(P.center(X), float)
        self.radius = float(P.radius(X))
        self.centre_at = carry_target(self.start, c, *self.shape)
        self.offset = self.lifted - c

    def tick(self, t: float, q: np.ndarray, qd: np.ndarray) -> None:
        """One MPC tick at t [s] from the nominal state (the previous plan at t; the measured state at the first
        tick); records the tube deviation ‖c_measured + offset − c_ref‖; on an infeasible nominal state the
        reference stops where it is (counted)."""
        from ..geometry import primitives as P

        task = self.mpc.task
        if self.centre_at is None:
            self._anchor(q)
            qn, qdn = q, qd
        else:
            qn, qdn = self.mpc.sample_plan(t)
            c = np.asarray(P.center(task.primitive(q)), float)
            self.tube.append((t, float(np.linalg.norm(c + self.offset - self.reference(t)))))
        try:
            k = self.mpc.tick(t, qn, qdn)
        except MPCInfeasibleError as exc:
            self.fallbacks.append((t, str(exc)))
            self._knot_t, self._knot_c = np.array([t, t + 1.0]), np.tile(self.reference(t) - self.offset, (2, 1))
            return
        self.ticks.append(k)
        self._knot_c = np.array([np.asarray(P.center(task.primitive(qk)), float) for qk in k.plan_q])
        self._knot_t = np.asarray(k.plan_t, float)

    def posture(self, t: float) -> np.ndarray | None:
        """The plan's configuration at t (nq,), or None before the first plan."""
        if self.mpc.plan is None or not self.ticks:
            return None
        return self.mpc.sample_plan(t)[0]


@dataclass(frozen=True)
class FollowPlan(CarryPlan):
    """A :class:`~coop_ga.sim.CarryPlan` whose circle centre, from the carry phase on, is the
    :class:`MPCFollower`'s reference (the lifted centre moved by the MPC plan's increments)."""

    follow: Any = None

    def at(self, t: float) -> PlanPoint:
        p = super().at(t)
        if self.follow is None or t < self.follow.start:
            return p
        return replace(p, centre=p.centre + self.follow.reference(t) - self.follow.lifted)


class CarryTrackController:
    """The hold controller with the MPC ticking every ``period`` from the track start (a ``Simulation`` controller);
    counts MuJoCo's robot–robot contacts at every physics step."""

    def __init__(self, hold: HoldController, follower: MPCFollower, scene: Any):
        self.hold, self.follower, self.scene = hold, follower, scene
        o = follower.mpc.o
        self._every = round(o.period / scene.model.opt.timestep)
        self._steps_since = -1
        m = scene.model
        robot = np.zeros(m.nbody, bool)
        robot[list(scene.robot_bodies)] = True
        self._robot_geom = robot[np.asarray(m.geom_bodyid)]
        self.contacts = {"robot_robot": 0, "robot_robot_steps": 0}

    def _count_contacts(self, data: Any) -> None:
        n = int(data.ncon)
        if not n:
            return
        g = np.asarray(data.contact.geom[:n])
        r_r = int(np.sum(self._robot_geom[g[:, 0]] & self._robot_geom[g[:, 1]]))
        self.contacts["robot_robot"] += r_r
        self.contacts["robot_robot_steps"] += int(r_r > 0)

    def __call__(self, t: float, q: np.ndarray, qd: np.ndarray, sensors: Any) -> np.ndarray:
        self._count_contacts(sensors.data)
        f = self.follower
        if t >= f.start - 1e-9:
            self._steps_since += 1
            if self._steps_since % self._every == 0:
                f.tick(t, q, qd)
            post = f.posture(t)
            if post is not None:
                self.hold.q_post = post
        return self.hold(t, q, qd, sensors)


@dataclass
class CarryTrackRun:
    """A finished run: the case, the carry run (setup, log, hold trace), the follower, the target, wall time."""

    case: CarryTrackCase
    carry: CarryRun
    follower: MPCFollower
    controller: CarryTrackController
    target: Any
    wall_s: float = 0.0
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def log(self) -> SimulationLog:
        return self.carry.log


def run_carry_track(
    case: CarryTrackCase, options: MPCOptions | None = None, *, duration: float | None = None, progress: bool = False
) -> CarryTrackRun:
    """Grasp, lift and track (module docstring); the MPC's options default to :class:`MPCOptions` with
    ``avoid=False`` (no obstacle: the arm–arm clearance is measured, not enforced, module docstring).  ``duration``
    [s]: stop early (default: the end of the tracking window)."""
    durations = (*LIFT_DURATIONS, SETTLE + case.track, 0.3, 1.2, 0.4, 0.3)
    st = carry_setup(
        CarryCase(case.name, mass=case.mass, friction=case.friction, durations=durations, shift=0.0, turn=0.0)
    )
    t_start = st.plan.phase_times()["carry"][0] + SETTLE
    hold0 = st.controller
    lifted = np.asarray(st.plan.at(t_start).centre, float)  # the plan's circle centre at the lift's end
    follower = MPCFollower(None, t_start, lifted)
    shape = (case.amplitude, case.heading, case.period)
    mpc = CooperativeMPC(st.task, follower.target, options or MPCOptions(avoid=False))
    follower.mpc, follower.shape = mpc, shape
    fields = [f.name for f in dataclass_fields(CarryPlan) if f.init]
    plan = FollowPlan(**{f: getattr(st.plan, f) for f in fields}, follow=follower)
    hold = HoldController(st.scene, st.task, plan, hold0.gains, q_start=st.q_start)
    ctrl = CarryTrackController(hold, follower, st.scene)
    sim = Simulation(st.scene, ctrl, q=st.q_start)
    t0 = time.perf_counter()
    log = sim.run(t_start + case.track if duration is None else duration, progress=progress)
    st = replace(st, plan=plan, controller=hold)
    carry = CarryRun(st, log, hold.trace())
    return CarryTrackRun(case, carry, follower, ctrl, follower.centre_at, time.perf_counter() - t0)


def _box_error(run: CarryTrackRun, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(position error (m, 3) [m], turn (m,) [deg]) of the box against the target carried through the grasp."""
    pos, R = box_state(run.carry)
    t, k0, ts = run.log.time, int(rows[0]), run.follower.start
    want = pos[k0] + np.array([run.target(float(x)) - run.target(ts) for x in t[rows]])
    yaw = np.degrees(np.arctan2(R[rows, 1, 0], R[rows, 0, 0]) - math.atan2(R[k0, 1, 0], R[k0, 0, 0]))
    return pos[rows] - want, (yaw + 180.0) % 360.0 - 180.0


def _arm_clearance(run: CarryTrackRun, rows: np.ndarray) -> float:
    """The smallest arm–arm (different chains) clearance of the collision model over ``rows`` (every 50th) [m]."""
    cm = run.follower.mpc.world.model
    return float(
        min((cm.distances(run.log.q[k])[cm.inter_branch].min(initial=np.inf) for k in rows[::50]), default=np.inf)
    )


def carry_track_metrics(run: CarryTrackRun) -> dict[str, Any]:
    """The run's numbers over the tracking window (module docstring): ``box_error_m`` (RMS, max, and its
    largest vertical part), ``turn_max_deg``, ``slip_mm`` (each pad, from the lift's end: 1 s before the track start), ``dropped``,
    ``squeeze_N`` (min, max), ``contacts`` (robot–robot), ``min_clearance_arm_arm_m``, joint limit excursions,
    ``tube_max_m``, the MPC's ticks, iterations and fallbacks (its wall-clock tick times:
    :func:`carry_track_timing`); ``failures`` lists every claim missed (box RMS ≤ 1 cm, max ≤ 2 cm, slip ≤ 5 mm,
    no drop, no robot–robot contact, no joint limit left, no fallback, no tick dropped)."""
    log, f = run.log, run.follower
    rows = np.flatnonzero(log.time >= f.start - 1e-9)
    err, turn = _box_error(run, rows)
    e = np.linalg.norm(err, axis=1)
    pos, _ = box_state(run.carry)
    slip = np.nanmax(slip_series(run.carry, "carry")[rows[rows < len(run.carry.trace["time"])]], axis=0)
    lim = run.carry.setup.system.limits
    sq = run.carry.trace["squeeze"][rows[rows < len(run.carry.trace["time"])]]
    m: dict[str, Any] = {
        "case": run.case.describe(),
        "box_error_m": {"rms": float(np.sqrt(np.mean(e * e))), "max": float(e.max()), "vertical_max": float(np.abs(err[:, 2]).max())},
        "target_travel_m": float(np.ptp(pos[rows, :2], axis=0).max()),
        "turn_max_deg": float(np.abs(turn).max()),
        "slip_mm": (1e3 * slip).tolist(),
        "dropped": bool(pos[rows, 2].min() < pos[rows[0], 2] - DROP),
        "squeeze_N": {"min": float(sq.min()), "max": float(sq.max())},
        "contacts": dict(run.controller.contacts),
        "min_clearance_arm_arm_m": _arm_clearance(run, rows),
        "position_violation_rad": float(lim.position_violation(log.q)),
        "velocity_violation_rad_s": float(lim.velocity_violation(log.qd)),
        "saturated_updates": int(log.saturated_updates),
        "tube_max_m": max((d for _, d in f.tube), default=0.0),
        "mpc_ticks": len(f.ticks), "fallbacks": len(f.fallbacks),
        "iterations_per_tick": stats([k.iterations for k in f.ticks]),
        "plan_violation_max": float(max((k.violation for k in f.ticks), default=0.0)),
        "period_s": f.mpc.o.period, "horizon": f.mpc.o.horizon,
    }  # fmt: skip
    m["failures"] = _failures(m)
    return m


def carry_track_timing(run: CarryTrackRun) -> dict[str, Any]:
    """The run's wall-clock numbers (:func:`~coop_ga.sim.mpc_track.mpc_timing`: tick and solve times, overruns,
    the simulation's wall time), for ``timing.json``: apart from :func:`carry_track_metrics`, which depend on the
    case alone."""
    f = run.follower
    return mpc_timing(f.mpc, f.ticks, (), run.wall_s)


def _failures(m: dict[str, Any]) -> list[str]:
    out = []
    b = m["box_error_m"]
    if b["rms"] > 0.01 or b["max"] > 0.02:
        out.append(f"box off its target by {1e3 * b['rms']:.1f} mm RMS, {1e3 * b['max']:.1f} mm max (claim 10 / 20)")
    if max(m["slip_mm"]) > 5.0:
        out.append(f"slip {max(m['slip_mm']):.1f} mm > 5 mm")
    if m["dropped"]:
        out.append("the box dropped")
    if m["contacts"]["robot_robot"]:
        out.append(f"{m['contacts']['robot_robot']} robot–robot contacts")
    if m["position_violation_rad"] > 0 or m["velocity_violation_rad_s"] > 0:
        out.append(
            f"joint limits left ({m['position_violation_rad']:.3g} rad, {m['velocity_violation_rad_s']:.3g} rad/s)"
        )
    if m["fallbacks"]:
        out.append(f"{m['fallbacks']} MPC fallbacks")
    expected = round(m["case"]["track_s"] / m["period_s"])
    if m["mpc_ticks"] != expected:
        out.append(f"{m['mpc_ticks']} MPC ticks solved of {expected} (one every {m['period_s']} s)")
    return out
