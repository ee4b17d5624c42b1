"""Closed-loop walking of the hexapod in MuJoCo: the stance legs as a cooperative primitive that regulates the body.

:class:`HexapodWalker` is a :class:`~coop_ga.sim.Simulation` controller ``(t, q, q̇, sensors) → τ`` for the scene
of :func:`~coop_ga.sim.hexapod.hexapod_scene`.  It is called at every physics step (1 kHz: the servos' joint
PD, as a Dynamixel runs its position loop internally) and plans at ``control_rate`` (200 Hz).  What it reads:
the 18 joint encoders (q, q̇), the IMU (``imu_quat``: R_WB; ``imu_gyro``) and the six foot touch sensors — and,
with the map only, a localisation of the body (module section "Map").  It never reads the terrain in blind
mode.

The plan (every 1/``control_rate`` s)
-------------------------------------
The controller keeps a *desired state* D — a body pose in its odometry frame W_o (started at the robot's
known initial pose) and the 18 joint targets q_D — and the stance feet's anchors in W_o.

1. **Gait** (:func:`coop_ga.legged.gait.phase_table`, tripod / ripple / wave): a gait clock τ_g runs the phase
   table; at a leg's lift-off phase it swings (if the command is not zero: a stopped robot lifts no leg),
   on :func:`~coop_ga.legged.gait.swing_arc` from its anchor to a foothold: the nominal foothold (``foot_reach``
   out from the coxa axis, ``ride_height`` below the body) at the reference body pose of mid-stance.  The
   foothold's height: with the map, the terrain under it (+ the foot radius: the ball's centre); blind, the
   plane of the current stance anchors extrapolated to it.  Apex: ``lift_height`` above the highest terrain
   under the swing (map) or ``blind_lift`` above the higher end (blind).  Blind, the swing ends with a *probe*
   (:mod:`coop_ga.sim.walking_blind`): past the foothold as far as the leg's shin would reach toward a riser
   during the stance, just above the expected ground, back, and down — a riser there is felt (a face: stepped
   over) before the foot stands where its shin would lean on the riser's edge.
2. **Touchdown from the touch sensors** (the stance set follows the contacts): from mid-swing on, a swing foot
   whose touch sensor reads more than ``touch_threshold`` stops — it is in stance, its anchor is where it is
   commanded at that instant (q_D stays continuous).  Unless the contact is a *face*: the foot's contact normal
   (:meth:`~coop_ga.sim.hexapod.HexapodScene.foot_normals`, a foot force sensor's direction; a touch sensor
   cannot tell a riser's vertical face from a tread) tilted more than ``face_tilt`` from vertical — touching
   down against a riser would leave the shin capsule, 15.7 mm wider than the ball, leaning on its edge — then
   the foot steps over it (up, over ``step_over`` past the face, down) — or an *edge*: tilted more than
   ``edge_tilt`` but not more than ``face_tilt``, the ball resting on a tread's edge, from which it would roll
   off under load — then it moves onto the tread the edge bounds.  A foot that reaches the end of its arc
   without contact keeps descending — at ``search_fast_speed`` for its first ``search_fast_depth``, then at
   ``search_speed`` (for at most ``search_depth``, moving forward along its swing as it goes: away from a
   down-step's edge it crossed) — while the gait clock and the reference wait for it (with ``search_clock``, a
   foot that searches or steps over lets them run on up to the next lift-off, which waits for it); the
   command's schedule waits too (:attr:`HexapodWalker.lag`), so that the whole commanded path is walked, later.
   The stance primitive is built from the feet that are in stance *and* in contact.
3. **Body posture through the stance primitive**: the stance feet's plane seen from the body, from the joint
   encoders — the similarity V(q) of :func:`coop_ga.legged.stance.stance_task` (exact plane of 3 feet,
   least-squares plane of more; compiled by :class:`~coop_ga.codegen.CompiledFunction`) with its body-frame
   Jacobian J^G — is compared with its reference
   V_ref: the same plane as seen from a body with the desired attitude (level, or ``tilt_follow`` toward the
   support; yaw kept) at ``ride_height``: with R_c = R_IMUᵀ R_des the correction rotation in B,
   ``n_ref = R_cᵀ n`` and ``t_ref = −ride_height · n_ref``.  Its error ``e = log(Ṽ V_ref)`` (seed 003 Eq 44;
   :func:`~coop_ga.sim.walking_kin.plane_error`) has three observable rows — the plane's tilt (e13, e23) and
   offset (e3∞) (Table 1: a plane cannot see yaw, in-plane translation or dilation), i.e. the body's roll,
   pitch and height over the support.  The command ``c = posture_gain · e`` goes through the posture map of
   :mod:`coop_ga.legged.posture` (``A = J^G L``: body twist → primitive twist with the stance feet fixed,
   :func:`~coop_ga.sim.walking_kin.stance_map`): the body twist u = u_gait + δ with δ the smallest twist whose
   observable primitive rows give c (u_gait: the commanded (v_x, v_y, ω_z) plus a pull of D to the reference
   path; it decides what the plane cannot see).  D moves by u; the stance legs' targets are the closed-form
   IK of their anchors from D's new pose.  Integrated through D, the primitive error acts as an integral
   controller on the measured posture (the joint PD's sag under load is removed too).
4. **Torques**: joint PD on q_D (interpolated between plans at q̇_D) + feed-forward: the legs' gravity torques
   and −Jᵀ F for vertical foot forces F that carry the robot's weight with no moment about its centre of mass
   (weighted least norm, loads ramped in after touchdown and out before lift-off), from the measured state.
   The command is rounded to :data:`TORQUE_QUANTUM` (a servo's duty cycle has a finite resolution; the logged
   ``ctrl`` is then exact in float32); the simulation clips at the URDF effort (1.5 N m) and counts it.  The
   targets q_D follow the plan at most at ``joint_speed`` × the servos' no-load speed, and the step of a leg that
   swings (or has just touched down) is shortened where the servo law would ask more than :data:`TORQUE_BUDGET` of
   the effort at the plan's start (``HexapodWalker._servo_limited``).

``feedback=False`` is the ablation's **open-loop replay of the kinematic plan**: the same gait, footholds and
swing arcs, but touchdown on schedule (no touch sensors), the stance set from the phase table, no posture
correction, feed-forward from the plan: q_D(t) is then a function of time alone (the test checks that it is
the same whatever happens to the robot).

Map
---
With ``blind=False`` the planner gets the terrain and a localisation (``localize(data) → (position, R_WB)``,
default: MuJoCo's free-joint pose, i.e. perfect localisation, as a motion-capture system gives): footholds
and swing apexes use the terrain at the localised position (converted to W_o).  ``blind=True`` uses neither.

Bad input: an unknown gait, a velocity command the legs cannot follow (:func:`check_command`: the stance stroke
beyond the legs' reach, or a swing needing more than the URDF's joint speed — refused before the run, naming
the leg, the limit and the fix) and a stance set with fewer than three feet for a posture command raise
:class:`~coop_ga.errors.CoopGAError` subclasses.
"""

from __future__ import annotations

import math
import time as _time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import validation
from ..errors import InvalidInputError
from .hexapod import HEXAPOD_LEGS, HexapodScene
from .walking_kin import FastLegs, plane_error, plane_log, rotation_from_tangent, stance_map

__all__ = [
    "GAIT_NAMES",
    "TORQUE_QUANTUM",
    "HexapodWalker",
    "VelocityCommand",
    "WalkingOptions",
    "check_command",
    "nominal_feet",
    "posture_legs",
    "search_depth_at",
    "stance_pose",
    "standing_start",
]

#: the gaits of :func:`coop_ga.legged.gait.phase_table`
GAIT_NAMES: tuple[str, ...] = ("tripod", "ripple", "wave")
#: the blind search's options whose None means "per gait", and their defaults (measured per gait: the
#: blind walks on random tiles swing with small changes; :class:`WalkingOptions` gives the measurements)
PER_GAIT_DEFAULTS: dict[str, dict[str, float | bool]] = {
    "search_clock": {"tripod": True, "ripple": False, "wave": False},
    "search_fast_depth": {"tripod": 0.01, "ripple": 0.0, "wave": 0.0},
    "search_ahead": {"tripod": 1.0, "ripple": 1.0, "wave": 2.0},
}
G = 9.81
_MODES = {"stance": 0, "swing": 1, "search": 2}
#: plane rows of a similarity twist the stance plane can see (Table 1): e13, e23 (tilt), e3∞ (offset)
_PLANE_ROWS = np.array([1, 2, 6])
#: the servo command's resolution [N m]: 2⁻¹⁴, 24× finer than the AX-12A's 10-bit duty cycle (1.5 N m / 1023);
#: commands are rounded to it, so that the log stores them exactly in float32
TORQUE_QUANTUM = 2.0**-14
_TORQUE_STEPS = 2.0**14
#: swing progress samples of an arc (linear interpolation between them is within 1e-5 m of swing_arc)
_ARC_S = np.linspace(0.0, 1.0, 201)
#: the fraction of the URDF effort a swinging leg's servo law may ask for at a plan's start (the rest: its
#: tracking error growing over the plan)
TORQUE_BUDGET = 0.9


# ====================================================================== commands
@dataclass(frozen=True)
class VelocityCommand:
    """A time-varying velocity command: (v_x, v_y, ω_z) [m/s, m/s, rad/s] in the heading frame (forward, left,
    yaw rate), piecewise linear through ``values`` (n, 3) at ``times`` (n,) [s] (ascending), held before the first
    and after the last knot."""

    times: Any
    values: Any

    def __post_init__(self) -> None:
        t = validation.array(self.times, "VelocityCommand.times").reshape(-1)
        v = validation.array(self.values, "VelocityCommand.values")
        if t.size == 0 or v.shape != (t.size, 3):
            raise InvalidInputError(
                f"VelocityCommand: values must have shape (len(times), 3) = ({t.size}, 3) of (vx, vy, wz), got {v.shape}"
            )
        if np.any(np.diff(t) <= 0) or t[0] < 0:
            raise InvalidInputError(f"VelocityCommand.times must be ≥ 0 and strictly ascending, got {t.tolist()}")
        for a in (t, v):
            a.setflags(write=False)
        object.__setattr__(self, "times", t)
        object.__setattr__(self, "values", v)

    @classmethod
    def constant(
        cls, vx: float, vy: float = 0.0, wz: float = 0.0, *, start: float = 0.3, ramp: float = 0.5, duration: Any = None
    ) -> VelocityCommand:
        """Rest until ``start`` [s], ramp linearly to (vx, vy, wz) over ``ramp`` [s]; with ``duration`` [s] (from
        ``start``) ramp back down to rest at its end (a stop)."""
        v = validation.vector([vx, vy, wz], 3, "velocity (vx, vy, wz)")
        s = validation.nonnegative(start, "start")
        r = validation.positive(ramp, "ramp")
        ts, vs = [s, s + r], [np.zeros(3), v]
        if duration is not None:
            d = validation.positive(duration, "duration")
            if d < 2 * r:
                raise InvalidInputError(f"duration ({d} s) must be at least two ramps ({2 * r} s)")
            if d > 2 * r:
                ts.append(s + d - r)
                vs.append(v)
            ts.append(s + d)
            vs.append(np.zeros(3))
        return cls(np.array(ts), np.array(vs))

    @classmethod
    def tour(cls, speed: float, turn_rate: float, *, start: float = 0.3, leg: float = 2.0) -> VelocityCommand:
        """Start, speed change, turn while walking, stop — within one run: ramp to ``speed`` [m/s]; after ``leg``
        [s] change to 0.6 ``speed``; after another ``leg`` turn at ``turn_rate`` [rad/s] while walking at 0.6
        ``speed``; after another ``leg`` straight again, then stop (each change ramped over 0.5 s)."""
        v = validation.positive(speed, "speed")
        w = validation.scalar(turn_rate, "turn_rate")
        L = validation.positive(leg, "leg")
        r = 0.5
        knots = [
            (start, (0.0, 0.0, 0.0)),
            (start + r, (v, 0.0, 0.0)),
            (start + L, (v, 0.0, 0.0)),
            (start + L + r, (0.6 * v, 0.0, 0.0)),
            (start + 2 * L, (0.6 * v, 0.0, 0.0)),
            (start + 2 * L + r, (0.6 * v, 0.0, w)),
            (start + 3 * L, (0.6 * v, 0.0, w)),
            (start + 3 * L + r, (0.6 * v, 0.0, 0.0)),
            (start + 4 * L, (0.6 * v, 0.0, 0.0)),
            (start + 4 * L + r, (0.0, 0.0, 0.0)),
        ]
        return cls(np.array([k[0] for k in knots]), np.array([k[1] for k in knots]))

    @property
    def end(self) -> float:
        """Time [s] of the last knot."""
        return float(self.times[-1])

    def at(self, t: float) -> np.ndarray:
        """The command (3,) at time t [s]."""
        return np.array([np.interp(t, self.times, self.values[:, k]) for k in range(3)])

    def path(self, t_end: float, dt: float = 0.005) -> np.ndarray:
        """The commanded pose (x, y, yaw) (n, 3) [m, m, rad] from rest at the origin, on a grid of ``dt`` [s]
        up to ``t_end`` (midpoint rule)."""
        n = max(1, math.ceil(validation.nonnegative(t_end, "t_end") / validation.positive(dt, "dt")))
        out = np.zeros((n + 1, 3))
        for k in range(n):
            c = self.at((k + 0.5) * dt)
            yaw = out[k, 2] + 0.5 * c[2] * dt
            out[k + 1, 0] = out[k, 0] + (math.cos(yaw) * c[0] - math.sin(yaw) * c[1]) * dt
            out[k + 1, 1] = out[k, 1] + (math.sin(yaw) * c[0] + math.cos(yaw) * c[1]) * dt
            out[k + 1, 2] = out[k, 2] + c[2] * dt
        return out


# ====================================================================== options
@dataclass(frozen=True)
class WalkingOptions:
    """Options of :class:`HexapodWalker` (module docstring).

    gait: "tripod" | "ripple" | "wave"; cycle_time: T [s] (None: :data:`coop_ga.legged.walk.CYCLE_TIME`, 1.6 /
        2.4 / 4.0 s); duty: β (None: the gait's).
    ride_height: body origin above the plane of the foot-ball centres [m] (0.1: the legged planner's feet 0.1 m
        below the body; the body is then 0.109 m above the ground).
    foot_reach: nominal foothold's distance from the coxa axis along the mounting direction [m].
    lift_height: swing apex above the highest terrain under the swing, with the map [m] (raised where a leg
        capsule needs it); blind_lift: above the higher end of the swing, blind [m]; blind_reach: blind, the
        expected foothold height (the stance anchors' plane extrapolated) stays within this of the lift-off
        height [m]; foot_drop: a swing's apex stays at least this far [m] below the body (0.055: at 0.035 a
        blind tripod swing from the top of a 3 cm step bent the femur to 1.5 rad and clipped its torque at the
        effort limit for 0.14 s; measured in the fast tripod/ripple steps runs).
    edge_clearance, clearance_margin: with the map, footholds keep their contact this far [m] from the terrain's
        cell edges, and the leg capsules this far above the terrain (:mod:`coop_ga.sim.walking_map`).
    blind: plan without the terrain and the localisation; feedback: False for the open-loop replay (module
        docstring).
    tilt_follow: desired body z axis between world up (0: level) and the support normal (1).
    posture_gain: gain [1/s] of the stance-primitive error; max_correction: (m/s, rad/s) caps of its body twist.
    path_gain: pull [1/s] of D's horizontal pose to the reference path.
    max_accel: the reference velocity follows the command with at most this acceleration [m/s²] (the yaw rate
        with max_accel / 0.3 m, the corner feet's radius); None: the gait's nominal speed (a stance stroke of
        0.08 m) reached in one cycle.  A robot standing on its nominal footholds must not be dragged a whole
        stroke by its first stance legs.
    control_rate: planning rate [Hz] (a divisor of the physics rate).
    kp, kd: joint PD gains [N m/rad, N m s/rad] per joint kind (coxa, femur, tibia).
    touch_threshold: a foot is in contact above this normal force [N]; touchdown_depth: with feedback the swing
        aims this far [m] below the expected ground, so that the contact ends it; contact_hold: a stance foot
        whose touch sensor read contact within this time [s] still carries load; stumble_lift: a swing foot that
        touches something before mid-swing goes on this far [m] above the higher of where it is and its
        foothold; face_tilt: [rad] a contact whose normal (the foot's force sensor,
        :meth:`~coop_ga.sim.hexapod.HexapodScene.foot_normals`) is tilted more than this from vertical is a face
        (a riser, a tile's side), not a foothold; step_over: [m] a swing foot that meets a face from mid-swing on
        steps over it — its foothold moves this far past where it touched, into the face's direction, on a path
        ``stumble_lift`` high (at most up to ``foot_drop`` below the body) lasting ``step_over_time`` [s] — instead
        of touching down against it (the shin would then lean on the edge); edge_tilt: [rad] a contact tilted
        more than this but not more than ``face_tilt`` is the ball on an edge: the foot moves onto the tread the
        edge bounds, its centre ``edge_inset`` [m] inside it (``HexapodWalker._face_directions``), instead of
        standing where it would roll off under load (above the slope terrain's 5.7°); search_speed [m/s],
        search_depth [m]:
        how a late foot looks for the ground — down, and forward along its swing by ``search_forward`` × the
        depth (at most ``search_forward_max`` [m]): a foot that finds no ground where it expected it has crossed
        a down-step's edge, and moving away from that edge keeps its shin off it; search_fast_speed [m/s],
        search_fast_depth [m] (None: 0.01 for the tripod, 0 for ripple and wave, :attr:`fast_search_depth`): a
        late foot's first ``search_fast_depth`` of descent goes at ``search_fast_speed``
        (:func:`search_depth_at`): most late feet find the ground within 1–2 cm below the end of their arc
        (1 m blind tripod walks on random tiles, seeds 0 and 1: 1–18 mm), while one past a 3 cm down-step still
        lands at ``search_speed``.  Measured on those walks (with ``search_clock``): 0.12 m/s for 10 mm cut the
        searches' waits from 0.45 / 0.98 s to 0.22 / 0.39 s (seed 0 / 1); the other settings tried were worse
        on the bar — 0.15 m/s for 10 mm slipped 5.26 mm (seed 1), 0.12 m/s for 6 mm clipped a torque update
        (seed 1), 0.10 m/s for 10 mm slipped 4.97 mm on the 1 m blind tripod steps walk.
        search_load [N m]: a searching
        leg whose femur and tibia servos push harder than this without foot contact rests on its shin and steps
        over instead (blind, a leg whose shin lies behind its foot steps back: ``HexapodWalker._blocked``).
        search_clock (None: True for the tripod, False for ripple and wave, :attr:`clock_runs_in_search`): while
        a foot searches or steps over, the gait clock and the reference run on up to the next lift-off, which
        waits for it (``HexapodWalker._gait_events``: no lift-off while a foot is late); False: they stop as
        soon as the search or the step-over starts.  A tripod (duty 0.5) has no slack — its late foot holds the
        other tripod's lift-off — but a foot that meets a face or an edge mid-swing need not stop its partners'
        swings and the stance tripod's stroke.  Measured, 1 m blind tripod on random tiles, seed 0: the waits
        3.78 → 3.38 s, walked 93.1 → 95.9 % (both: 3.02 s, 97.9 %; seed 1: 92.7 → 97.2 %).  Not the default
        for ripple and wave: their blind walks on random tiles swing with small changes — the short wave walk
        there laid a front shin on a tile edge for 182 steps with ``search_clock`` — and for 183 with neither
        setting but ``edge_inset`` 5.1 mm or ``step_over_time`` 0.46 s instead of 5 mm / 0.45 s.
        load_ramp: [s] feed-forward load ramp after touchdown / before lift-off.  joint_speed: the joint targets move at most this fraction
        of the URDF's joint speed (the servos' no-load speed; at 0.7 its back-EMF takes 0.7 of the stall torque,
        leaving 0.45 N m for the PD's tracking error and the load); a faster plan is followed at that speed
        (counted as ``speed_limited_plans``).  At 0.8 the 0.3 N m left was exceeded by a lag of 25 mrad: the 1 m
        blind walks, whose probing swings run at the limit for most of the swing, clipped 1–29 torque updates
        each (tripod on flat ground: 29, each at a rear coxa or front tibia entering the probe's way back).
    probe_guard, probe_height, probe_margin: blind, every swing ends with a probe
        (:mod:`coop_ga.sim.walking_blind`): it reaches past its foothold as far as the leg's capsules would reach
        toward a riser ``probe_guard`` [m] high during the stance (:func:`~coop_ga.sim.walking_blind.shin_reach`,
        + ``probe_margin`` [m], − the ball's radius) with the ball's bottom ``probe_height`` [m] above the
        expected ground, then comes back and descends: a riser there is touched (a face: stepped over) before
        the foot stands where its shin would lean on it.  ``probe_guard = 0``: no probe.
    approach_height: [m] blind, a leg whose shin lies behind its foot (the front legs) also comes in low: its
        probing arc comes down to ``approach_height`` above the expected ground (the ball's bottom) as far before
        the foothold as its shin reaches back toward a ``probe_guard`` ledge
        (:func:`~coop_ga.sim.walking_blind.approach_lengths`: 33 mm) and goes on from there to the probe's far
        point, so that a ledge behind the foothold that the shin could meet in the final descent is met by the
        ball first (a tread: the foot lands on it — a contact after the arc's apex is a landing, not a stumble;
        a face: stepped over).  Measured without it (1 m walks on random tiles, blind): front feet that had
        crossed a 21.6 mm down-step high descended 15 mm (ripple) and 24.5 mm (wave) past its edge and laid their
        shins on it, 14.4 / 14.6 mm below its top (164 and 116 shin-contact steps); with it (6 mm, the probe's
        height) none — measured on an earlier state of the walker (before ``search_ahead``, ``search_margin``
        and ``search_clock``; which change made the difference is not measured): today, ``approach_height = 0``
        walks those two 1 m rows 97.5 % (ripple) and 100.0 % (wave) with no shin contact (seed 0), so its need
        there is not shown any more; it is kept because every row of the bar was measured with it.  The final
        descent is then 11 mm, within 1 mm of what
        :func:`~coop_ga.sim.walking_blind.shin_reach` clears (12 mm; a shin touched an edge 11.1 mm above the
        ball 18.5 mm behind it in a search, its leg stretched beyond the stance range that reach is measured
        over).  At 2 mm the 1 m ripple walk on random tiles walked 97.8 % instead of 95.3 %, but the ball slid
        along the expected ground and a front foot landed at the approach's start, 17 mm short of a riser the
        probe never reached (1 m tripod walk on steps, blind: 594 shin-contact steps).  Coming in low with every
        leg, the middle and rear legs (whose shins reach back 18 and 12 mm, not beyond their reach ahead) stepped
        over 4 more faces in the ripple walk, 0.4 s each, which the gait waits for (89.6 % walked).
    search_ahead, search_margin: blind, the search of a leg that comes in low goes forward ``search_ahead`` ×
        as far as the other legs' (``search_forward``, ``search_forward_max``) while the leg keeps
        ``search_margin`` [m] of its workspace (from D); None: 2 for the wave, 1 for the tripod and the ripple
        (:attr:`search_ahead_factor`).  Measured at 1×: a wave front foot whose arc ended 2 mm above a 19 mm tile
        at its edge searched forward and down and laid its shin on that edge 16 mm behind it, 12.8 mm below its top
        (short wave walk on random tiles, blind: 165 shin-contact steps; 106 at 1.5×, none at 2×; the 1 m wave walk
        there passes at 2×: 99.9 %, no shin contact); but at 2× the ripple's front legs, stretched, pressed against
        their reach and stepped back (:meth:`HexapodWalker._blocked`: 1 s), and its 1 m walk on random tiles walked
        93.6 % (93.5 % with ``search_clock`` as well, and 66 shin-contact steps).
    """

    gait: str = "tripod"
    cycle_time: float | None = None
    duty: float | None = None
    ride_height: float = 0.1
    foot_reach: float = 0.16
    lift_height: float = 0.02
    blind_lift: float = 0.04
    blind_reach: float = 0.01
    foot_drop: float = 0.055
    edge_clearance: float = 0.016
    clearance_margin: float = 0.004
    blind: bool = False
    feedback: bool = True
    tilt_follow: float = 0.0
    posture_gain: float = 6.0
    max_correction: tuple[float, float] = (0.05, 0.5)
    path_gain: float = 2.0
    max_accel: float | None = None
    control_rate: float = 200.0
    kp: tuple[float, float, float] = (12.0, 12.0, 12.0)
    kd: tuple[float, float, float] = (0.1, 0.1, 0.08)
    touch_threshold: float = 0.5
    touchdown_depth: float = 0.005
    stumble_lift: float = 0.03
    face_tilt: float = math.radians(45.0)
    edge_tilt: float = math.radians(12.0)
    edge_inset: float = 0.005
    step_over: float = 0.03
    step_over_time: float = 0.45
    contact_hold: float = 0.05
    search_speed: float = 0.06
    search_forward: float = 1.0
    search_forward_max: float = 0.02
    search_depth: float = 0.05
    search_load: float = 0.3
    search_fast_speed: float = 0.12
    search_fast_depth: float | None = None
    search_clock: bool | None = None
    load_ramp: float = 0.05
    joint_speed: float = 0.7
    probe_guard: float = 0.035
    probe_height: float = 0.006
    probe_margin: float = 0.003
    approach_height: float = 0.006
    search_ahead: float | None = None
    search_margin: float = 0.005

    def __post_init__(self) -> None:
        validation.choice(self.gait, GAIT_NAMES, "gait")
        for name in (
            "ride_height",
            "foot_reach",
            "control_rate",
            "touch_threshold",
            "search_speed",
            "search_fast_speed",
            "search_load",
            "step_over_time",
            "joint_speed",
        ):
            validation.positive(getattr(self, name), name)
        for name in (
            "lift_height",
            "blind_lift",
            "blind_reach",
            "foot_drop",
            "edge_clearance",
            "clearance_margin",
            "posture_gain",
            "path_gain",
            "search_depth",
            "search_forward",
            "search_forward_max",
            "load_ramp",
            "touchdown_depth",
            "stumble_lift",
            "step_over",
            "contact_hold",
            "probe_guard",
            "probe_height",
            "probe_margin",
            "approach_height",
            "search_margin",
            "edge_inset",
        ):
            validation.nonnegative(getattr(self, name), name)
        if self.cycle_time is not None:
            validation.positive(self.cycle_time, "cycle_time")
        if not 0.0 < validation.scalar(self.face_tilt, "face_tilt") < math.pi / 2:
            raise InvalidInputError(f"face_tilt must be in (0, π/2) rad, got {self.face_tilt}")
        if not 0.0 < validation.scalar(self.edge_tilt, "edge_tilt") <= self.face_tilt:
            raise InvalidInputError(
                f"edge_tilt must be in (0, face_tilt = {self.face_tilt:.4g}] rad, got {self.edge_tilt}; set it to "
                "face_tilt to treat no contact as an edge"
            )
        if self.max_accel is not None:
            validation.positive(self.max_accel, "max_accel")
        tf = validation.scalar(self.tilt_follow, "tilt_follow")
        if not 0.0 <= tf <= 1.0:
            raise InvalidInputError(f"tilt_follow must be in [0, 1], got {tf}")
        for name in ("kp", "kd"):
            a = validation.vector(getattr(self, name), 3, f"{name} (coxa, femur, tibia)")
            if np.any(a < 0):
                raise InvalidInputError(f"{name} must be ≥ 0, got {a.tolist()}")
            object.__setattr__(self, name, tuple(float(x) for x in a))
        mc = validation.vector(self.max_correction, 2, "max_correction (m/s, rad/s)")
        object.__setattr__(self, "max_correction", (float(mc[0]), float(mc[1])))
        for name in ("search_fast_depth", "search_ahead"):
            if getattr(self, name) is not None:
                validation.nonnegative(getattr(self, name), name)
        for name in ("blind", "feedback") + (("search_clock",) if self.search_clock is not None else ()):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise InvalidInputError(f"{name} must be True or False, got {getattr(self, name)!r}")
        self.table()

    @property
    def period(self) -> float:
        from ..legged.walk import CYCLE_TIME

        return float(self.cycle_time) if self.cycle_time is not None else CYCLE_TIME[self.gait]

    def _per_gait(self, name: str) -> Any:
        """Option ``name``, or where it is None its default for this gait (:data:`PER_GAIT_DEFAULTS`)."""
        value = getattr(self, name)
        return PER_GAIT_DEFAULTS[name][self.gait] if value is None else value

    @property
    def clock_runs_in_search(self) -> bool:
        """``search_clock``, or its default: True for the tripod only."""
        return bool(self._per_gait("search_clock"))

    @property
    def search_ahead_factor(self) -> float:
        """``search_ahead``, or its default: 2 for the wave, 1 for the tripod and the ripple."""
        return float(self._per_gait("search_ahead"))

    @property
    def fast_search_depth(self) -> float:
        """``search_fast_depth`` [m], or its default: 0.01 for the tripod, 0 (none) for ripple and wave."""
        return float(self._per_gait("search_fast_depth"))

    @property
    def accel(self) -> float:
        """The reference's acceleration limit [m/s²] (``max_accel`` or its default)."""
        if self.max_accel is not None:
            return float(self.max_accel)
        tab = self.table()
        return 0.08 / (tab.duty * tab.period * tab.period)

    def table(self) -> Any:
        """The gait's :class:`~coop_ga.legged.gait.GaitTable`."""
        from ..legged.gait import phase_table

        return phase_table(self.gait, 6, self.duty, period=self.period)


def search_depth_at(options: WalkingOptions, elapsed: float) -> float:
    """How far [m] a searching foot has descended below the end of its arc ``elapsed`` [s] into its search:
    at ``search_fast_speed`` for the first :attr:`~WalkingOptions.fast_search_depth`, then at ``search_speed``.
    """
    fast = options.fast_search_depth / options.search_fast_speed  # [s] the fast first millimetres
    if elapsed <= fast:
        return options.search_fast_speed * elapsed
    return options.fast_search_depth + options.search_speed * (elapsed - fast)


# ====================================================================== geometry helpers
def nominal_feet(legs: Any, options: WalkingOptions) -> np.ndarray:
    """(6, 3) nominal foot-ball centres in B: ``foot_reach`` out from each coxa axis along its mounting
    direction, ``ride_height`` below the body."""
    yaw = np.asarray(legs.mount_yaw, float)
    mount = np.asarray(legs.mount_position, float)
    out = np.empty((6, 3))
    out[:, 0] = mount[:, 0] + options.foot_reach * np.cos(yaw)
    out[:, 1] = mount[:, 1] + options.foot_reach * np.sin(yaw)
    out[:, 2] = -options.ride_height
    return out


def _rot_z(yaw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _yaw_of(R: np.ndarray) -> float:
    return math.atan2(float(R[1, 0]), float(R[0, 0]))


def _quat_to_R(q: np.ndarray) -> np.ndarray:
    w, x, y, z = (float(v) for v in q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def _R_to_quat(R: np.ndarray) -> np.ndarray:
    from ._mujoco import mj

    q = np.empty(4)
    mj().mju_mat2Quat(q, np.ascontiguousarray(R, float).reshape(9))
    return q


def _frame_with_z(z: np.ndarray, yaw: float) -> np.ndarray:
    """R_WB with body z = z (unit) and body x the heading (cos yaw, sin yaw, 0) projected ⊥ z."""
    h = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    x = h - (h @ z) * z
    x /= np.linalg.norm(x)
    return np.column_stack((x, np.cross(z, x), z))


def _expm_so3(w: np.ndarray) -> np.ndarray:
    a = float(np.linalg.norm(w))
    K = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
    if a < 1e-10:
        return np.eye(3) + K
    return np.eye(3) + math.sin(a) / a * K + (1.0 - math.cos(a)) / (a * a) * K @ K


def _limited(v: np.ndarray, cmd: np.ndarray, a: float, dt: float) -> np.ndarray:
    """The velocity (vx, vy, wz) one step of ``dt`` later, moved toward ``cmd`` by at most ``a dt`` (linear,
    as a vector) and ``a dt / 0.3`` (yaw rate)."""
    out = v.copy()
    d = cmd[:2] - v[:2]
    n = float(np.hypot(d[0], d[1]))
    out[:2] = cmd[:2] if n <= a * dt else v[:2] + d * (a * dt / n)
    w = a * dt / 0.3
    out[2] = v[2] + min(max(cmd[2] - v[2], -w), w)
    return out


def _rotvec(R: np.ndarray) -> np.ndarray:
    """Rotation vector (3,) of a rotation matrix (angle < π)."""
    c = max(-1.0, min(1.0, 0.5 * (float(R[0, 0] + R[1, 1] + R[2, 2]) - 1.0)))
    a = math.acos(c)
    v = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    return 0.5 * v if a < 1e-8 else a / (2.0 * math.sin(a)) * v


def _fit_plane(P: np.ndarray) -> tuple[np.ndarray, float]:
    """Least-squares plane n · x = d (n_z > 0) of points (k ≥ 3, 3)."""
    c = P.mean(axis=0)
    n = np.linalg.svd(P - c)[2][-1]
    n = -n if n[2] < 0 else n
    return n, float(n @ c)


_POSE_FUNCTIONS: dict[int, Any] = {}
_STANCE_ORDERS: dict[tuple[int, ...], tuple[int, ...]] = {}


def stance_pose(feet: np.ndarray, stance: Sequence[int]) -> tuple[tuple[int, ...], np.ndarray, np.ndarray]:
    """The stance plane of the feet of ``stance`` (leg indices, ≥ 3): ``(order, log V (7,), G (7, 3k))``.

    The feet are taken in :data:`coop_ga.legged.stance.STANCE_ORDER` (counter-clockwise from above: the normal
    points up) — ``order`` gives their leg indices — and passed to the pose function of the task graph of
    :func:`coop_ga.legged.stance.stance_task` (the exact plane of 3 feet, the least-squares ``plane_fit`` of
    more): ``p (3k) → (V, B = log V, G = −2 Ṽ ∂V/∂p, …)`` (:mod:`coop_ga.cooperative.graph`).  That function
    depends only on the number of feet, so one per k serves every stance set (built once per process, compiled
    by :class:`~coop_ga.codegen.CompiledFunction`); ``J^G = G ∂p/∂q`` is the task's Jacobian (``tests/sim/test_hexapod_walking.py`` compares both with
    ``stance_task(...).evaluate``)."""
    key = tuple(stance)
    hit = _STANCE_ORDERS.get(key)
    if hit is None:
        from ..legged.stance import STANCE_ORDER

        names = posture_legs(stance)
        hit = _STANCE_ORDERS[key] = tuple(HEXAPOD_LEGS.index(n) for n in STANCE_ORDER if n in names)
    order = hit
    k = len(order)
    fn = _POSE_FUNCTIONS.get(k)
    if fn is None:
        from ..codegen import CompiledFunction
        from ..legged.stance import stance_task

        legs = tuple(HEXAPOD_LEGS[i] for i in order)
        task = stance_task("hexapod", legs, "plane" if k == 3 else "plane_fit", codegen=False)
        # compiled C where gcc is (cached on disk), bound to numpy buffers: no CasADi DM per call
        fn = _POSE_FUNCTIONS[k] = CompiledFunction(task.graph.pose_function, check_finite=False)
    out = fn.call_views(feet[list(order)].reshape(-1))
    return order, out[1].reshape(7).copy(), out[2].copy()


def posture_legs(stance: Any) -> tuple[str, ...]:
    """The leg names of a stance set for a posture command (indices into :data:`HEXAPOD_LEGS`, or names);
    :class:`~coop_ga.errors.InvalidInputError` for fewer than three feet (no plane through them)."""
    names = tuple(HEXAPOD_LEGS[int(i)] if not isinstance(i, str) else i for i in stance)
    bad = [n for n in names if n not in HEXAPOD_LEGS]
    if bad:
        raise InvalidInputError(f"unknown leg(s) {bad} in the stance set; the legs are {HEXAPOD_LEGS}")
    if len(set(names)) < 3:
        raise InvalidInputError(
            f"a posture command needs a stance primitive of at least 3 feet (a plane); the stance set has "
            f"{len(set(names))} ({', '.join(names) or 'none'}): with fewer feet the body has no support to move on"
        )
    return names


# ====================================================================== limits of the command
def check_command(command: VelocityCommand, options: WalkingOptions, legs: Any = None, margin: float = 0.005) -> dict:
    """Refuse (:class:`~coop_ga.errors.InvalidInputError`) a command the legs cannot follow, before the run.

    For every knot of ``command`` and every leg: the stance stroke ``|v + ω × p_i| β T`` (the nominal foothold
    p_i) must keep both ends of the stroke (nominal ± half of it) reachable with ``margin`` [m] of workspace
    and inside the joint limits (the legs' reach), and the swing that brings the foot back over it in (1 − β) T
    must need at most the URDF's joint speed (6.18 rad/s) on the :func:`~coop_ga.legged.gait.swing_arc` (apex
    ``max(lift_height, blind_lift)``).  Blind with the probe, the walker flies the probing swing instead
    (:func:`~coop_ga.sim.walking_blind.probe_path`, :func:`~coop_ga.sim.walking_blind.probe_reaches`: the stroke
    plus the probe out and back in the same time): its joint speed is measured (``probe_speed_ratio``) and,
    where it needs more than the URDF's joint speed, the longest probe that does not (``probe_scale``, per leg,
    by bisection to 1/32).  That is reported, not refused: the walker flies the whole probe, its joint targets
    at most at ``joint_speed`` × the URDF speed (``speed_limited_plans``), so the foot cuts the probe's corners
    where the path is faster — the front legs' probes, coming in low, need 1.035× in the tripod's 0.8 s swing
    and 1.24× in the wave's 0.67 s (1.05× without; measured: flying the shortened probe instead let a shin onto
    a tile edge in the short wave walk on random tiles, blind).  Returns the worst
    ratios {"stroke_m", "reach_margin_m", "joint_speed_ratio" (the plain swing), "probe_speed_ratio" (the
    probing swing)} and "probe_scale" (6,)."""
    from ..legged.legs import hexapod_legs
    from .walking_blind import approach_lengths, probe_reaches

    lm = hexapod_legs() if legs is None else legs
    fl = FastLegs(lm)
    tab = options.table()
    T, beta = tab.period, tab.duty
    nom = nominal_feet(lm, options)
    vlim = np.empty(18)
    vlim[fl.q_index] = np.asarray(lm.velocity_limit, float)
    probe = probe_reaches(lm, options)
    low = approach_lengths(lm, options)  # the front legs' probe comes in low (WalkingOptions.approach_height)
    scale = np.ones(6)
    worst: dict[str, Any] = {"stroke_m": 0.0, "reach_margin_m": math.inf, "joint_speed_ratio": 0.0}
    worst["probe_speed_ratio"] = 0.0
    for c in np.asarray(command.values, float):
        for i, leg in enumerate(HEXAPOD_LEGS):
            v_foot = -(np.array([c[0], c[1], 0.0]) + np.cross([0.0, 0.0, c[2]], nom[i]))  # foot velocity in B
            stroke = v_foot * beta * T
            ends = np.stack([nom[i] - 0.5 * stroke, nom[i] + 0.5 * stroke])
            worst["stroke_m"] = max(worst["stroke_m"], float(np.linalg.norm(stroke)))
            feet = np.repeat(nom[None], 2, axis=0)
            feet[:, i] = ends
            for k in range(2):
                q, m = fl.ik(feet[k])
                worst["reach_margin_m"] = min(worst["reach_margin_m"], float(m[i]))
                if m[i] < margin or fl.violation(q) > 1e-9:
                    raise InvalidInputError(
                        f"velocity command (vx, vy, wz) = {tuple(np.round(c, 4))} needs a stance stroke of "
                        f"{np.linalg.norm(stroke):.3f} m for leg {leg} ({options.gait}, T = {T:g} s, duty {beta:.3g}): "
                        f"its end is {'out of the legs reach' if m[i] < margin else 'outside the joint limits'} "
                        f"(reach margin {1e3 * m[i]:.1f} mm, limit {1e3 * margin:.0f} mm); lower the speed or the "
                        "cycle time"
                    )
            swing = (fl, nom, i, ends[1], ends[0], options, float(low[i]))
            ratio = _swing_speed_ratio(*swing, 0.0, (1 - beta) * T, vlim)
            worst["joint_speed_ratio"] = max(worst["joint_speed_ratio"], ratio)
            if ratio > 1.0:
                raise InvalidInputError(
                    f"velocity command (vx, vy, wz) = {tuple(np.round(c, 4))}: the swing of leg {leg} needs "
                    f"{ratio:.2f}× the URDF joint speed limit ({vlim.max():.2f} rad/s) at T = {T:g} s; lower the speed "
                    "or lengthen the cycle (cycle_time)"
                )
            if probe[i] > 0.0:  # the probing swing, and the longest probe (bisection) the servos can fly
                r_full = _swing_speed_ratio(*swing, probe[i], (1 - beta) * T, vlim)
                worst["probe_speed_ratio"] = max(worst["probe_speed_ratio"], r_full)
                lo, hi = 0.0, float(scale[i])
                fits = r_full <= 1.0 or _swing_speed_ratio(*swing, hi * probe[i], (1 - beta) * T, vlim) <= 1.0
                for _ in range(0 if fits else 5):
                    mid = 0.5 * (lo + hi)
                    ok = _swing_speed_ratio(*swing, mid * probe[i], (1 - beta) * T, vlim) <= 1.0
                    lo, hi = (mid, hi) if ok else (lo, mid)
                scale[i] = hi if fits else lo
    worst["probe_scale"] = scale
    return worst


def _swing_speed_ratio(
    fl: FastLegs,
    nom: np.ndarray,
    i: int,
    p0: np.ndarray,
    p1: np.ndarray,
    options: WalkingOptions,
    approach: float,
    probe: float,
    duration: float,
    vlim: np.ndarray,
) -> float:
    """The largest joint speed over the URDF limit ``vlim`` (18,) [rad/s] of leg i's swing (B, the other feet at
    ``nom`` (6, 3)) from ``p0`` to ``p1`` (3,) [m] in ``duration`` [s]: the arc, or with ``probe`` [m] > 0 the
    probing swing (:func:`check_command`), coming in low over ``approach`` [m] (``approach_height``) as the
    walker's does."""
    from ..legged.gait import swing_arc
    from .walking_blind import probe_path

    s = np.linspace(0.0, 1.0, 161)  # the peak speed within 1 % of a 401-sample path (tested)
    lift = max(options.lift_height, options.blind_lift)
    if probe > 0.0:
        h = options.probe_height + options.touchdown_depth  # as the walker: p1 aimed touchdown_depth below
        low = options.approach_height + options.touchdown_depth
        path = probe_path(p0, p1, lift, probe, h, s, approach=approach, low_height=low)
    else:
        path = swing_arc(p0, p1, lift, s)[0]
    qs = np.array([fl.ik(np.where(np.arange(6)[:, None] == i, a, nom))[0] for a in path])
    speed = np.abs(np.diff(qs, axis=0)).max(axis=0) / (np.diff(s)[0] * duration)
    return float(np.max(speed / vlim))


# ====================================================================== the start
def standing_start(hs: HexapodScene, options: WalkingOptions, xy: Any = (0.0, 0.0), yaw: float = 0.0) -> tuple:
    """The robot standing on the terrain of ``hs``: feet on their nominal footholds, the balls touching the
    ground (centre r/n_z above it), the body level (``tilt_follow`` toward the support) at ``ride_height`` above
    the plane of the foot centres.  Returns ``(q (18,) joint angles, (position (3,), quaternion (w, x, y, z)))``
    for :class:`~coop_ga.sim.Simulation` (``q=``, ``base_pose=``)."""
    from ..legged.legs import hexapod_legs

    lm = hexapod_legs()
    fl = FastLegs(lm)
    p = validation.vector(xy, 2, "xy")
    Rz = _rot_z(validation.scalar(yaw, "yaw"))
    nom = nominal_feet(lm, options)
    feet_xy = p + nom[:, :2] @ Rz[:2, :2].T
    P = hs.terrain.plane_params(feet_xy)
    r = hs.foot_radius
    feet = np.column_stack([feet_xy, hs.terrain.height(feet_xy) + r / P[:, 2]])
    n, d = _fit_plane(feet)
    z = (1.0 - options.tilt_follow) * np.array([0.0, 0.0, 1.0]) + options.tilt_follow * n
    R = _frame_with_z(z / np.linalg.norm(z), yaw)
    # body origin above (p) at distance ride_height from the plane n·x = d
    zb = (d + options.ride_height - n[0] * p[0] - n[1] * p[1]) / n[2]
    pos = np.array([p[0], p[1], zb])
    q, m = fl.ik((feet - pos) @ R)
    if np.any(m < 0) or fl.violation(q) > 1e-9:
        raise InvalidInputError(
            f"the robot cannot stand at {tuple(p)} on this terrain with ride_height {options.ride_height} m and "
            f"foot_reach {options.foot_reach} m (reach margins {np.round(m, 4).tolist()} m)"
        )
    return q, (pos, _R_to_quat(R))


# ====================================================================== the controller
@dataclass
class _Leg:
    mode: int = 0  # _MODES
    anchor: np.ndarray = field(default_factory=lambda: np.zeros(3))
    arc: tuple[np.ndarray, np.ndarray, float, float] | None = None  # (p0, p1, lift, τ_lift-off)
    touchdown: float = -1.0  # sim time of its last touchdown
    search_from: float = 0.0  # sim time its search began
    last_touch: float = -math.inf  # sim time its touch sensor last read contact
    tibia0: np.ndarray = field(default_factory=lambda: np.eye(3))  # W_o ← tibia rotation at touchdown
    target: np.ndarray = field(default_factory=lambda: np.zeros(3))  # its foot target in W_o
    path: np.ndarray = field(default_factory=lambda: np.zeros((2, 3)))  # the swing arc sampled at _ARC_S
    s0: float = 0.0  # the swing progress where ``path`` starts (0, or where a stumble raised it)
    raises: int = 0  # stumbles and step-overs of the current swing
    over_from: float = math.inf  # sim time a step-over began (its arc is ``path``; the search starts at its end)
    apex: float = 0.5  # from this fraction of ``path`` on a contact is a landing (a low path's apex; else half)


class HexapodWalker:
    """The closed-loop walking controller (module docstring) for :class:`~coop_ga.sim.Simulation`.

    Args:
        hs: the :class:`~coop_ga.sim.hexapod.HexapodScene` it runs in (sensor addresses, foot radius; its
            terrain is used only with ``blind=False``).
        command: the :class:`VelocityCommand` (checked by :func:`check_command`).
        options: :class:`WalkingOptions`.
        localize: with the map, ``localize(data) → (position (3,), R_WB (3, 3))`` (default: MuJoCo's free-joint
            pose); ignored blind.

    The command is a schedule the gait follows: while the gait waits for a late foot (a search, a step-over) the
    schedule waits too (:attr:`lag`), so that the robot walks the whole commanded path, later.

    After a run, :attr:`records` holds one row per plan (:meth:`records_arrays`), :attr:`timing` the CPU seconds
    (``time.process_time``) spent planning and in the servo loop, :attr:`counts` the events (touchdowns, searches, lost feet,
    plans without three contact feet).
    """

    #: the events counted in :attr:`counts`
    EVENTS = (
        "touchdowns",
        "early_touchdowns",
        "searches",
        "lost_feet",
        "stumbles",
        "step_overs",
        "held_lift_offs",
        "unsupported_plans",
        "speed_limited_plans",
        "torque_limited_plans",
        "short_probes",
    )

    def __init__(
        self,
        hs: HexapodScene,
        command: VelocityCommand,
        options: WalkingOptions | None = None,
        *,
        localize: Callable[[Any], tuple[np.ndarray, np.ndarray]] | None = None,
    ):
        import pinocchio as pin

        from ..legged.legs import hexapod_legs

        if not isinstance(hs, HexapodScene):
            raise InvalidInputError(f"hs must be a HexapodScene (hexapod_scene(...)), got {type(hs).__name__}")
        if not isinstance(command, VelocityCommand):
            raise InvalidInputError(f"command must be a VelocityCommand, got {type(command).__name__}")
        self.options = opt = options or WalkingOptions()
        if not isinstance(opt, WalkingOptions):
            raise InvalidInputError(f"options must be WalkingOptions, got {type(opt).__name__}")
        self.hs, self.command = hs, command
        self.legs = hexapod_legs()
        self.fast = FastLegs(self.legs)
        self.limits = check_command(command, opt, self.legs)
        ts = float(hs.model.opt.timestep)
        k = opt.control_rate * ts
        if abs(1.0 / k - round(1.0 / k)) > 1e-9:
            raise InvalidInputError(
                f"control_rate {opt.control_rate} Hz must divide the physics rate {1.0 / ts:g} Hz (timestep {ts} s)"
            )
        self.every = round(1.0 / k)
        self.dt = self.every * ts
        self.table = opt.table()
        self._accel = opt.accel
        self.nominal = nominal_feet(self.legs, opt)
        self.localize = localize or self._true_pose
        from .walking_map import MapFootholds

        self._map = MapFootholds(
            hs.terrain,
            self.legs,
            self.nominal,
            ride_height=opt.ride_height,
            tilt_follow=opt.tilt_follow,
            edge_clearance=opt.edge_clearance,
            clearance_margin=opt.clearance_margin,
            lift_height=opt.lift_height,
        )
        system = self.legs.system
        self._pin = pin
        self._model = pin.Model(system.model)  # own copy: its gravity is set to the body frame's every plan
        self._data = self._model.createData()
        self._mass = float(sum(self._model.inertias[i].mass for i in range(self._model.njoints)))
        qi = self.fast.q_index
        self._kp = np.empty(18)
        self._kd = np.empty(18)
        for j in range(3):
            self._kp[qi[:, j]] = opt.kp[j]
            self._kd[qi[:, j]] = opt.kd[j]
        # the servos' back-EMF damping (hexapod module docstring, "Servos"): τ must also supply b q̇_D
        self._b = np.asarray(hs.model.dof_damping, float)[hs.scene.qvel_index].copy()
        self._effort = np.asarray(system.limits.effort, float).copy()  # (18,) [N m], the q order
        self._dq_max = np.empty(18)
        self._dq_max[self.fast.q_index] = opt.joint_speed * self.dt * np.asarray(self.legs.velocity_limit, float)
        self._tasks: dict[tuple[str, ...], Any] = {}
        if opt.feedback and opt.posture_gain > 0:  # the stance planes' pose functions, built once per process
            for k in range(3, 7):
                stance_pose(self.nominal, range(k))
        self.records: list[tuple[Any, ...]] = []
        self.timing = {"plan_s": 0.0, "servo_s": 0.0, "plans": 0, "servo_calls": 0}
        self.counts = dict.fromkeys(self.EVENTS, 0)
        self._calls = 0
        self._started = False
        self._faces: dict[int, np.ndarray] = {}
        #: {leg: (distance [m], lift [m], duration [s], back-off [m])} of a step-over that is not the default
        #: (:meth:`_step_over`)
        self._moves: dict[int, tuple[float, float, float, float]] = {}
        self._probe, self._approach = self._probe_reaches()
        #: [s] how long the gait has waited for late feet while moving: the command is followed at t − lag
        self.lag = 0.0

    # ------------------------------------------------------------------ the Simulation callback
    def __call__(self, t: float, q: np.ndarray, qd: np.ndarray, sensors: Any) -> np.ndarray:
        if not self._started:
            self._start(t, q, sensors.data)
        if self._calls % self.every == 0:
            t0 = _time.process_time()
            self._plan(t, q, qd, sensors.data)
            self.timing["plan_s"] += _time.process_time() - t0
            self.timing["plans"] += 1
        self._calls += 1
        t0 = _time.process_time()
        h = min(t - self._t_plan, self.dt)
        tau = (
            self._tau_ff + self._kp * (self._qD + self._qdD * h - q) + (self._kd + self._b) * self._qdD - self._kd * qd
        )
        self.timing["servo_s"] += _time.process_time() - t0
        self.timing["servo_calls"] += 1
        # a multiple of TORQUE_QUANTUM (the log's ctrl is then exact in float32, and compresses)
        return (np.round(tau * _TORQUE_STEPS) / _TORQUE_STEPS).astype(np.float32)

    def _true_pose(self, data: Any) -> tuple[np.ndarray, np.ndarray]:
        a = self.hs.scene.base_qpos
        assert a is not None  # the hexapod scene has a free base
        return np.array(data.qpos[a : a + 3]), _quat_to_R(np.array(data.qpos[a + 3 : a + 7]))

    def _start(self, t: float, q: np.ndarray, data: Any) -> None:
        """D = the measured initial state (odometry starts at the known pose); every leg in stance."""
        pos, R = self._true_pose(data)
        self._pD, self._RD = pos.copy(), R.copy()
        self._qD = q.copy()
        self._qdD = np.zeros(18)
        self._tau_ff = np.zeros(18)
        self._t_plan = t
        feet = self.fast.fk(q) @ R.T + pos
        self._legs = [_Leg(anchor=feet[i].copy(), target=feet[i].copy(), touchdown=t - 1.0) for i in range(6)]
        for i in range(6):
            self._roll_reference(i)
        self._tau_g, self._tau_prev = 0.0, -1e-9
        self._ref = np.array([pos[0], pos[1], _yaw_of(R)])
        self._vel = np.zeros(3)  # the reference velocity (the command through the acceleration limit)
        self._ref_z = pos[2]
        self._started = True

    # ------------------------------------------------------------------ one plan
    def _plan(self, t: float, q: np.ndarray, qd: np.ndarray, data: Any) -> None:
        """One plan (module docstring): sensors → gait → posture through the stance plane → D → q_D, τ_ff."""
        opt = self.options
        quat, _, _ = self.hs.imu(data)
        R_M = _quat_to_R(quat)
        touch = data.sensordata[self.hs.touch_adr] > opt.touch_threshold
        self._faces, self._moves = self._face_directions(data, touch, R_M) if opt.feedback else ({}, {})
        cmd = self.command.at(t - self.lag)
        waiting = self._clock(t, q, data, touch, cmd)
        if waiting and (np.any(np.abs(cmd) > 1e-9) or np.any(np.abs(self._vel) > 1e-9)):
            self.lag += self.dt  # the command's schedule waits with the gait
        u = self._gait_twist(self._vel if not waiting else np.zeros(3))
        err = np.zeros(3)
        stance = self._support(t, touch)
        feet, J = self.fast.fk_jac(q)
        if opt.feedback and opt.posture_gain > 0:
            if len(stance) >= 3:
                du, err = self._posture(feet, R_M, stance, u)
                u = u + du
            else:
                self.counts["unsupported_plans"] += 1
        self._pD = self._pD + self._RD @ u[:3] * self.dt
        self._RD = self._RD @ _expm_so3(u[3:] * self.dt)
        q_new = self._servo_limited(q, qd, self._targets(), t)
        self._qdD = (q_new - self._qD) / self.dt
        self._qD = q_new
        self._t_plan = t
        if opt.feedback:  # with fewer than three touching feet, the plan's stance legs are about to carry it
            carry = stance if len(stance) >= 3 else tuple(i for i, leg in enumerate(self._legs) if leg.mode == 0)
            self._tau_ff = self._feedforward(t, q, feet, J, R_M, carry)
        else:  # the plan's own torques (open loop)
            self._tau_ff = self._feedforward(t, q_new, *self.fast.fk_jac(q_new), self._RD, stance)
        self._record(t, stance, touch, err, u, waiting)

    def _servo_limited(self, q: np.ndarray, qd: np.ndarray, q_new: np.ndarray, t: float) -> np.ndarray:
        """The plan's joint targets ``q_new`` (18,) [rad] within what the servos can follow from the measured
        ``q``, ``qd`` (18,): each leg's step toward them scaled (its three joints together: scaled one by one they
        left the foot's path — a probing front foot dipped 2 cm onto the tread 12 mm short of a riser, 1 m tripod
        steps walk, blind) to at most ``joint_speed`` × the URDF's no-load speed (``speed_limited_plans``) and, for
        a leg off the ground or within ``load_ramp`` of its touchdown (at time ``t`` [s]), so that the servo law's
        torque at the plan's start stays within :data:`TORQUE_BUDGET` of the effort (``torque_limited_plans``)."""
        qi = self.fast.q_index
        dq = q_new - self._qD
        # the servos' speed: a target faster than joint_speed × the URDF's no-load speed needs more torque than
        # the back-EMF leaves (τ = τ_stall (u − q̇/ω₀)); the target follows at that speed instead
        scale = np.minimum(np.min(self._dq_max[qi] / np.maximum(np.abs(dq[qi]), 1e-300), axis=1), 1.0)
        if np.any(scale < 1.0):
            self.counts["speed_limited_plans"] += 1
        # the servos' torque: a target whose velocity jumps (a speed-limited target turning toward a path that
        # went on without it) asks for b q̇_D + kd (q̇_D − q̇) at once: a front tibia at rest, sent to 4.3 rad/s,
        # needed 1.56 N m (1 m ripple walk, blind).  τ(s) = C + s B with the step s dq; stance legs keep theirs
        tau0 = self._tau_ff + self._kp * (self._qD - q) - self._kd * qd
        slope = (self._kp + (self._kd + self._b) / self.dt) * dq
        bound = TORQUE_BUDGET * self._effort
        with np.errstate(divide="ignore", invalid="ignore"):
            room = np.where(slope > 0, (bound - tau0) / slope, np.where(slope < 0, (-bound - tau0) / slope, np.inf))
        # and a leg that has just touched down (within load_ramp): its targets turn from the swing's way to the
        # stance's at once, while its joints still move at the swing's speed — a front tibia at 4.3 rad/s whose
        # target turned to −2.4 rad/s as its foot landed on a higher tread asked 1.52 N m (1 m tripod steps walk,
        # blind: 3 clipped updates, one per landing on a riser's tread)
        ramp = max(self.options.load_ramp, self.dt)
        free = np.array([leg.mode != 0 or t - leg.touchdown < ramp for leg in self._legs])
        torque = np.where(free, np.clip(np.min(room[qi], axis=1), 0.0, 1.0), 1.0)
        if np.any(torque < scale):
            self.counts["torque_limited_plans"] += 1
        dq[qi] *= np.minimum(scale, torque)[:, None]
        return self._qD + dq

    def _clock(self, t: float, q: np.ndarray, data: Any, touch: np.ndarray, cmd: np.ndarray) -> bool:
        """Advance the gait clock and the reference path (not while standing still, nor past a lift-off that
        waits for a late foot — nor at all while a foot is late, without ``search_clock``) and run the gait's
        events; returns whether the gait waits for a foot."""
        moving = bool(np.any(np.abs(cmd) > 1e-9) or np.any(np.abs(self._vel) > 1e-9))
        waiting = not self.options.clock_runs_in_search and any(leg.mode == _MODES["search"] for leg in self._legs)
        airborne = any(leg.mode != 0 for leg in self._legs)
        advanced = not waiting and (moving or airborne)
        saved = (self._tau_g, self._ref.copy(), self._vel.copy())
        swinging = {i: leg.target.copy() for i, leg in enumerate(self._legs) if leg.mode == 1}
        if advanced:
            self._tau_g += self.dt
            self._vel = _limited(self._vel, cmd, self._accel, self.dt)
            v = self._vel
            c, s = math.cos(self._ref[2]), math.sin(self._ref[2])
            self._ref += self.dt * np.array([c * v[0] - s * v[1], s * v[0] + c * v[1], v[2]])
        if (advanced or waiting) and not self._gait_events(t, q, data, touch, cmd if moving else None):
            self._tau_g, self._ref, self._vel = saved  # the clock waits for the support
            # and so do the swings: a target moved on at the clock just set back would step back at the next plan
            # (at the servos' speed limit, a reversal that clipped the torque: measured on the 1 m steps walks)
            for i, target in swinging.items():
                if self._legs[i].mode == 1:
                    self._legs[i].target = target
            return True
        return waiting

    def _support(self, t: float, touch: np.ndarray) -> tuple[int, ...]:
        """The legs carrying the robot: in stance and touching — a touch sensor that read contact within the last
        ``contact_hold`` s still counts (a loaded foot's force dips) — with feedback; in stance by the plan in
        open loop."""
        if not self.options.feedback:
            return tuple(i for i, leg in enumerate(self._legs) if leg.mode == 0)
        for i, leg in enumerate(self._legs):
            if touch[i]:
                leg.last_touch = t
        hold = self.options.contact_hold
        return tuple(i for i, leg in enumerate(self._legs) if leg.mode == 0 and t - leg.last_touch <= hold)

    # ------------------------------------------------------------------ gait
    def _gait_events(self, t: float, q: np.ndarray, data: Any, touch: np.ndarray, cmd: np.ndarray | None) -> bool:
        """The swings and searches, then the lift-offs where the gait clock crossed a leg's lift-off phase this
        plan (none while the command is zero: a stopped robot keeps its feet down).  Returns False if a lift-off
        must wait (a foot is late, or the support would drop below three feet): the clock is then set back."""
        tab = self.table
        T, sigma = tab.period, tab.swing_fraction
        for i, leg in enumerate(self._legs):  # swings and searches first: a late foot holds the lift-offs
            if leg.mode == 1:
                self._swing(i, t, q, touch, sigma * T)
            elif leg.mode == 2:
                self._search(i, t, q, touch)
        late = any(leg.mode == 2 for leg in self._legs)
        for i, leg in enumerate(self._legs):
            before = math.floor(self._tau_prev / T - tab.offsets[i])
            now = math.floor(self._tau_g / T - tab.offsets[i])
            support = sum(1 for j, o in enumerate(self._legs) if j != i and o.mode == 0)
            if leg.mode == 0 and now > before and cmd is not None and t - leg.touchdown > 0.5 * sigma * T:
                # never lift a leg off a support of fewer than three feet, nor off a foot whose load is still
                # ramping in (a late foot that lands as its partners lift takes its share at once and slides)
                if late or support < 3 or self._loading(i, t):
                    self.counts["held_lift_offs"] += 1
                    return False
                self._lift_off(i, (now + tab.offsets[i]) * T, t, data)
        self._tau_prev = self._tau_g
        return True

    def _loading(self, i: int, t: float) -> bool:
        """Whether a stance foot other than leg i touched down less than ``load_ramp`` ago (with feedback: its
        feed-forward load is still ramping in, :meth:`_weights`)."""
        ramp = self.options.load_ramp
        return self.options.feedback and any(
            j != i and o.mode == 0 and t - o.touchdown < ramp for j, o in enumerate(self._legs)
        )

    def _lift_off(self, i: int, tau_lo: float, t: float, data: Any) -> None:
        leg = self._legs[i]
        opt = self.options
        tab = self.table
        T = tab.period
        t_td = (tau_lo - self._tau_g) + tab.swing_fraction * T  # from now to its touchdown
        ref_mid = self._predict(t, max(t_td + 0.5 * tab.duty * T, 0.0))
        xy = ref_mid[:2] + _rot_z(ref_mid[2])[:2, :2] @ self.nominal[i, :2]
        p0 = leg.target.copy()  # where its foot is commanded now (the anchor moved by rolling)
        if opt.blind:
            # the plane of the other stance anchors extrapolated to the foothold, at most blind_reach off the
            # lift-off height (anchors straddling a step tilt that plane)
            P = np.array([self._legs[j].anchor for j in range(6) if j != i and self._legs[j].mode == 0])
            n, d = _fit_plane(P) if len(P) >= 3 else (np.array([0.0, 0.0, 1.0]), float(p0[2]))
            z = (d - n[0] * xy[0] - n[1] * xy[1]) / n[2]
            p1 = np.array([xy[0], xy[1], p0[2] + min(max(z - p0[2], -opt.blind_reach), opt.blind_reach)])
            lift = opt.blind_lift
        else:
            p1, lift = self._map_foothold(i, t, max(t_td, 0.0), p0, xy, data)
        # the apex stays foot_drop below the body: a swing higher than that bends the femur onto its limit
        top = max(p0[2], p1[2])
        lift = max(min(lift, self._pD[2] - opt.foot_drop - top), 0.01)
        if opt.feedback:  # aim below the expected ground: the contact, not the end of the arc, ends the swing
            p1 = p1 - np.array([0.0, 0.0, opt.touchdown_depth])
        leg.arc = (p0, p1, lift, tau_lo)
        leg.path = self._swing_path(i, p0, p1, lift, t)  # sampled once; interpolated at each plan
        leg.mode, leg.s0, leg.raises = 1, 0.0, 0

    def _probe_reaches(self) -> tuple[np.ndarray, np.ndarray]:
        """(6,), (6,) [m] how far each leg's blind swing probes past its foothold and comes in low before it
        (:func:`~coop_ga.sim.walking_blind.probe_reaches`, :func:`~coop_ga.sim.walking_blind.approach_lengths`;
        zeros without the probe)."""
        from .walking_blind import approach_lengths, probe_reaches

        return probe_reaches(self.legs, self.options), approach_lengths(self.legs, self.options)

    def _swing_path(self, i: int, p_from: np.ndarray, p1: np.ndarray, lift: float, t: float) -> np.ndarray:
        """Leg i's swing path from ``p_from`` to ``p1`` sampled at ``_ARC_S``: the arc, or blind the probing arc
        (:func:`~coop_ga.sim.walking_blind.probe_path`) along the swing's direction from its lift-off point, its
        probe halved (down to a quarter, else none) while the path keeps less of the leg's workspace than the
        plain arc does (:meth:`_workspace_margins`)."""
        from ..legged.gait import swing_arc

        arc = self._legs[i].arc
        d = p1 - (p_from if arc is None else arc[0])
        plain = swing_arc(p_from, p1, lift, _ARC_S)[0]
        reach = float(self._probe[i])
        self._legs[i].apex = 0.5
        if reach > 0.0:
            from .walking_blind import probe_path

            h = self.options.probe_height + self.options.touchdown_depth  # p1 is aimed touchdown_depth below
            # the probe may keep as much workspace as the plain arc keeps, up to 10 mm: a foot lifting off a
            # lower tread than its partners stands at the edge of its workspace whatever path it takes (a rear
            # foot 3 cm below the plane of the others had 6 mm at lift-off: every probe was refused there and
            # the foot landed 37 mm short of a riser, its shin on the edge — 1 m tripod steps walk, blind)
            need = np.minimum(self._workspace_margins(i, plain, t), 0.01)
            for k in (1.0, 0.5, 0.25):
                low = self.options.approach_height + self.options.touchdown_depth
                path = probe_path(p_from, p1, lift, k * reach, h, _ARC_S, d, self._approach[i], low)
                if np.all(self._workspace_margins(i, path, t) >= need - 1e-9):
                    if self._approach[i] > 0.0:  # coming in low: a contact after the apex is a landing
                        self._legs[i].apex = min(0.5, float(_ARC_S[np.argmax(path[:, 2])]))
                    return path
            self.counts["short_probes"] += 1
        return plain

    def _workspace_margins(self, i: int, path: np.ndarray, t: float) -> np.ndarray:
        """Leg i's workspace margin [m] (:meth:`FastLegs.ik <coop_ga.sim.walking_kin.FastLegs.ik>`) at every tenth
        of ``path`` (sampled at ``_ARC_S``, W_o; the start left out: it is where the foot is) from D moved as the
        reference over the swing → (10,): a front foot probing past its foothold while the body lagged reached
        beyond its workspace — the straightened leg dropped the foot 2 cm onto the tread 12 mm short of a riser,
        and its shin leaned on the edge (1 m tripod steps walk, blind)."""
        tab = self.table
        T_sw = tab.swing_fraction * tab.period
        ahead = self._predict(t, T_sw) - self._ref
        feet = (np.array([leg.target for leg in self._legs]) - self._pD) @ self._RD
        out = []
        for k in range(20, len(_ARC_S), 20):
            f = float(_ARC_S[k])
            body = self._pD + f * np.array([ahead[0], ahead[1], 0.0])
            R = self._RD @ _rot_z(f * ahead[2])
            feet[i] = R.T @ (path[k] - body)
            out.append(float(self.fast.ik(feet)[1][i]))
        return np.array(out)

    def _predict(self, t: float, horizon: float) -> np.ndarray:
        """The reference pose (x, y, yaw) ``horizon`` [s] ahead: the command schedule through the acceleration
        limit, integrated from the current reference (steps of 4 plans)."""
        x, v = self._ref.copy(), self._vel.copy()
        h = 4.0 * self.dt
        n = math.ceil(horizon / h - 1e-9)
        if n <= 0:
            return x
        ts = t - self.lag + h * np.arange(1, n + 1)
        C = np.column_stack([np.interp(ts, self.command.times, self.command.values[:, k]) for k in range(3)])
        for k in range(n):
            hk = min(h, horizon - k * h)
            v = _limited(v, C[k], self._accel, hk)
            yaw = x[2] + 0.5 * v[2] * hk
            c, s = math.cos(yaw), math.sin(yaw)
            x[0] += hk * (c * v[0] - s * v[1])
            x[1] += hk * (s * v[0] + c * v[1])
            x[2] += hk * v[2]
        return x

    def _map_foothold(
        self, i: int, t: float, t_td: float, p0: np.ndarray, xy_o: np.ndarray, data: Any
    ) -> tuple[np.ndarray, float]:
        """Leg i's foothold (ball centre) in W_o near ``xy_o`` and its swing's apex lift, from the map
        (:class:`~coop_ga.sim.walking_map.MapFootholds`; module docstring, "Map"): horizontal positions go to the
        world through the localisation (W_o = Rz(Δyaw)(W − position) + D's position), heights are taken
        *relative to the lift-off point* (p0's height plus the terrain's rise from under p0), so D's height in
        W_o needs no localisation."""
        pos, R = self.localize(data)
        dyaw = _yaw_of(self._RD) - _yaw_of(R)
        Ro = _rot_z(dyaw)

        def to_w(p_o: np.ndarray) -> np.ndarray:  # horizontal pose / point (x, y[, yaw]) W_o → W
            xy = Ro[:2, :2].T @ (p_o[:2] - self._pD[:2]) + pos[:2]
            return np.array([*xy, p_o[2] - dyaw]) if len(p_o) == 3 else xy

        tab, T = self.table, self.table.period
        mf = self._map
        stance = [to_w(self._predict(t, t_td + f * tab.duty * T)) for f in (0.0, 0.5, 1.0)]
        c1 = mf.foothold(i, to_w(xy_o), stance)
        a0 = mf.centre(to_w(p0[:2]))  # the map's ball centre under the lift-off point
        lift = mf.swing_lift(i, a0, c1, (to_w(self._ref.copy()), stance[0]))
        xy1 = Ro[:2, :2] @ (c1[:2] - pos[:2]) + self._pD[:2]
        return np.array([xy1[0], xy1[1], p0[2] + c1[2] - a0[2]]), lift

    def _swing(self, i: int, t: float, q: np.ndarray, touch: np.ndarray, T_sw: float) -> None:
        """Leg i's swing at progress s: touchdown at contact from mid-swing on; a contact before mid-swing (the foot
        stubbed a riser or a tile edge) raises the rest of the arc by ``stumble_lift`` (at most twice);
        the end of the arc without contact starts the search (feedback) or is the touchdown (open loop)."""
        leg = self._legs[i]
        assert leg.arc is not None
        _p0, p1, _lift, tau_lo = leg.arc
        s = min(max((self._tau_g - tau_lo) / T_sw, 0.0), 1.0)
        fb = self.options.feedback
        if fb and touch[i] and s >= min(0.5, leg.s0 + (1.0 - leg.s0) * leg.apex):
            if i in self._faces and leg.raises < 2:
                self._step_over(i, t, q)
            else:
                self._touchdown(i, t, q, early=s < 1.0)
            return
        if fb and touch[i] and leg.raises < 2 and s > 0.1:
            top = max(leg.target[2], p1[2]) + self.options.stumble_lift
            leg.path = self._swing_path(i, leg.target, p1, top - max(leg.target[2], p1[2]), t)
            leg.s0, leg.raises = s, leg.raises + 1
            self.counts["stumbles"] += 1
        x = (s - leg.s0) / (1.0 - leg.s0) * (len(_ARC_S) - 1)
        k = min(int(x), len(_ARC_S) - 2)
        leg.target = leg.path[k] + (x - k) * (leg.path[k + 1] - leg.path[k])
        if s >= 1.0:
            if fb:
                leg.mode, leg.search_from = 2, t
                self.counts["searches"] += 1
            else:
                leg.mode, leg.anchor, leg.touchdown = 0, p1.copy(), t
                self._roll_reference(i)
                self.counts["touchdowns"] += 1

    def _search(self, i: int, t: float, q: np.ndarray, touch: np.ndarray) -> None:
        """A late foot descends from the end of its arc until it touches; a step-over first follows its arc
        (:meth:`_step_over`; a contact in its first half is the face it leaves)."""
        leg = self._legs[i]
        assert leg.arc is not None
        if t < leg.search_from:  # stepping over
            s = (t - leg.over_from) / (leg.search_from - leg.over_from)
            s = s * s * (3.0 - 2.0 * s)  # starts and ends at rest
            if touch[i] and s >= 0.5:
                if i in self._faces and leg.raises < 2:
                    self._step_over(i, t, q)
                else:
                    self._touchdown(i, t, q, early=True)
                return
            x = s * (len(_ARC_S) - 1)
            k = min(int(x), len(_ARC_S) - 2)
            leg.target = leg.path[k] + (x - k) * (leg.path[k + 1] - leg.path[k])
            return
        if touch[i]:
            if i in self._faces and leg.raises < 2:
                self._step_over(i, t, q)
            else:
                self._touchdown(i, t, q, early=False)
            return
        opt = self.options
        depth = search_depth_at(opt, t - leg.search_from)
        if leg.raises < 2 and self._blocked(i, t, q):
            return
        if depth > opt.search_depth:
            leg.mode, leg.anchor, leg.touchdown = 0, leg.target.copy(), t  # no ground found: stand on the target
            self._roll_reference(i)
            self.counts["lost_feet"] += 1
            return
        p0, p1 = leg.arc[0], leg.arc[1]
        h = (p1 - p0)[:2]
        nh = float(np.hypot(h[0], h[1]))
        fwd = min(opt.search_forward * depth, opt.search_forward_max)
        if self._approach[i] > 0.0 and nh > 1e-9:
            fwd = self._search_ahead(i, fwd, depth, p1, h / nh)
        fwd = fwd / nh if nh > 1e-9 else 0.0
        leg.target = p1 + np.array([fwd * h[0], fwd * h[1], -depth])

    def _search_ahead(self, i: int, fwd: float, depth: float, p1: np.ndarray, u: np.ndarray) -> float:
        """How far [m] the search of leg i, a leg that comes in low (its shin behind its foot), goes forward from
        ``p1`` (3,) along ``u`` (2,) at ``depth`` [m]: :attr:`~WalkingOptions.search_ahead_factor` × ``fwd``
        (the other legs' forward), while
        the leg keeps ``search_margin`` [m] of its workspace there (from D); else no further than ``fwd`` or where
        it already is (:class:`WalkingOptions`)."""
        opt = self.options
        far = opt.search_ahead_factor * fwd
        if far <= fwd:
            return fwd
        feet = (np.array([o.target for o in self._legs]) - self._pD) @ self._RD
        feet[i] = self._RD.T @ (p1 + np.array([far * u[0], far * u[1], -depth]) - self._pD)
        if self.fast.ik(feet)[1][i] >= opt.search_margin:
            return far
        return max(fwd, min(far, float((self._legs[i].target - p1)[:2] @ u)))

    def _blocked(self, i: int, t: float, q: np.ndarray) -> bool:
        """A searching foot without contact whose leg nevertheless bears load — its servos' position error pushes
        with more than ``search_load`` (femur and tibia) — rests on something else: its shin on the edge of a
        tile or step it crossed.  It steps over it along its swing (:meth:`_step_over`) instead of pressing on
        (the leg would lift the body off its shin) — or, for a leg whose shin lies behind its foot (a front leg
        walking forward: :func:`~coop_ga.sim.walking_blind.shin_reach` toward −swing beyond that toward +swing),
        back onto the tread it crossed, past that reach: the edge under its shin is within it.  Stepping over
        could not get the shin clear there: a front foot 17 mm past a 22 mm down-step needs 34 mm, and the body
        waiting behind it left the leg 12 mm of reach (1 m ripple walk on random tiles, blind: 3 s on the edge).
        Returns whether it did."""
        leg = self._legs[i]
        assert leg.arc is not None
        j = self.fast.q_index[i, 1:]
        load = float(np.linalg.norm(self._kp[j] * (self._qD[j] - q[j])))
        h = (leg.arc[1] - leg.arc[0])[:2]
        nh = float(np.hypot(h[0], h[1]))
        if load <= self.options.search_load or nh < 1e-9:
            return False
        h = h / nh
        self._faces[i] = h
        if self._probe[i] > 0.0:  # blind with the probe: the shin's reach is known
            from .walking_blind import shin_reach

            opt = self.options
            u = (self._RD.T @ np.array([h[0], h[1], 0.0]))[:2]  # the swing's direction in B
            back = float(shin_reach(self.legs, opt, guard=opt.probe_guard, direction=-u)[i])
            ahead = float(shin_reach(self.legs, opt, guard=opt.probe_guard, direction=u)[i])
            if back > ahead:
                self._faces[i] = -h
                self._moves[i] = (back + opt.edge_inset, opt.stumble_lift, opt.step_over_time, self.hs.foot_radius)
        self._step_over(i, t, q)
        return True

    def _face_directions(
        self, data: Any, touch: np.ndarray, R_M: np.ndarray
    ) -> tuple[dict[int, np.ndarray], dict[int, tuple[float, float, float, float]]]:
        """``(faces, moves)``: {leg: unit horizontal direction (2,) into the face, in W_o} for the touching feet
        whose contact normal is tilted more than ``edge_tilt`` from vertical (the normal measured in B through the
        IMU, to W_o through D), and for those tilted no more than ``face_tilt`` — the ball on an *edge*, not a
        face — the move onto the tread the edge bounds (:meth:`_step_over`): ``r sin(tilt)`` (the ball centre's
        offset from the edge) + ``edge_inset``, lifted by the ball's radius (its bottom then clears the edge),
        in half the ``step_over_time``.  (The next lift-off waits for it: with the clock stopped for every
        search, ten such moves and their searches made the 1 m tripod walk on random tiles 3.8 s late, beyond
        the run's catch-up, 93 % walked — 3.0 s, 97.9 % with ``search_clock`` and the fast search; at 0.3 or 0.4
        ``step_over_time``, or without the back-off from the edge, that walk passed but the short wave walk on
        random tiles laid a front shin on a tile edge — the blind outcomes there swing with small changes.)
        A ball left on an edge rolls off it under load: measured, a front foot 2 mm past a 17 mm down-step (tilt
        15°) dropped onto the lower tile 1 s into its stance, slipped 5 mm and laid its shin on the edge (1 m tripod
        walk on random tiles, blind).  Only the feet in the air
        (swinging, searching) are asked: a stance foot's normal decides nothing."""
        airborne = [i for i in np.flatnonzero(touch).tolist() if self._legs[i].mode != 0]
        if not airborne:
            return {}, {}
        opt = self.options
        N = self.hs.foot_normals(data) @ R_M  # rows: n in B
        c_face, c_edge = math.cos(opt.face_tilt), math.cos(opt.edge_tilt)
        r = self.hs.foot_radius
        faces, moves = {}, {}
        for i in airborne:
            n = self._RD @ N[i]
            h = -n[:2]
            nh = float(np.hypot(*h))
            if n[2] < c_edge and nh > 1e-9:
                faces[i] = h / nh
                if n[2] >= c_face:
                    moves[i] = (r * nh + opt.edge_inset, r, 0.5 * opt.step_over_time, r)
        return faces, moves

    def _step_over(self, i: int, t: float, q: np.ndarray) -> None:
        """Leg i met a face (:class:`WalkingOptions`, ``step_over``): a new path from its target — up ``stumble_lift``
        while backing off the face, over to ``step_over`` past the foot into the face, down — over
        ``step_over_time`` (a smoothstep in time); then the search.  The next lift-off waits for it (it is searching)."""
        opt = self.options
        leg = self._legs[i]
        assert leg.arc is not None
        h = np.array([*self._faces[i], 0.0])
        p0 = self._pD + self._RD @ self.fast.fk(q)[i]  # where the encoders put it (its target is in the face)
        move = self._moves.pop(i, None)
        r = self.hs.foot_radius
        dist, lift, duration, back = (
            move if move is not None else (self._step_over_reach(i, p0, h), opt.stumble_lift, opt.step_over_time, r)
        )
        p1 = p0 + dist * h
        lift = max(min(lift, self._pD[2] - opt.foot_drop - p0[2]), 0.005 if move else 0.01)  # as _lift_off's apex
        up = np.array([0.0, 0.0, lift])
        # up (backing off a face by the ball's radius), over, down: a box, not an arc that grazes the edge
        W = np.array([p0, p0 - back * h + up, p1 + up, p1])
        L = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(W, axis=0), axis=1))]
        leg.arc = (p0, p1, lift, leg.arc[3])
        leg.path = np.column_stack([np.interp(_ARC_S * L[-1], L, W[:, k]) for k in range(3)])
        leg.mode, leg.over_from, leg.search_from = 2, t, t + duration
        leg.raises += 1
        self.counts["step_overs"] += 1

    def _step_over_reach(self, i: int, p0: np.ndarray, h: np.ndarray, margin: float = 0.01) -> float:
        """How far [m] past the face touched at ``p0`` leg i steps: ``step_over``, or with the feet of the blind
        probe (``probe_guard`` > 0) less — down to the ball's radius + ``probe_margin`` — where the leg, seen from
        D, would keep less than ``margin`` [m] of its workspace (a front foot stepping 3 cm past a face from
        a body waiting 0.33 m behind it laid its tibia 65–79° over and its shin on the riser's edge: 1 m ripple
        steps walk, blind)."""
        opt = self.options
        if self._probe[i] <= 0.0:
            return opt.step_over
        shortest = min(self.hs.foot_radius + opt.probe_margin, opt.step_over)
        feet = (np.array([leg.target for leg in self._legs]) - self._pD) @ self._RD
        for dist in (opt.step_over, 0.5 * (opt.step_over + shortest)):
            feet[i] = self._RD.T @ (p0 + dist * h - self._pD)
            if self.fast.ik(feet)[1][i] >= margin:
                return dist
        return shortest

    def _touchdown(self, i: int, t: float, q: np.ndarray, early: bool) -> None:
        """The foot stops where it is commanded now: its anchor is where the joint targets q_D put it (continuous
        q_D) — its swing target when q_D follows it, else (the servos' speed limit) the point q_D has reached:
        a target run ahead at touchdown kept q_D moving at the speed limit into the ground, and the torque clipped
        (measured: the short blind tripod walk on steps, a front foot landing on a tread during a probe)."""
        leg = self._legs[i]
        leg.target = self._pD + self._RD @ self.fast.fk(self._qD)[i]
        leg.anchor = leg.target.copy()
        leg.mode, leg.touchdown = 0, t
        self._roll_reference(i)
        self.counts["touchdowns"] += 1
        self.counts["early_touchdowns"] += int(early)

    def _gait_twist(self, cmd: np.ndarray) -> np.ndarray:
        """u_gait (6,) in B: the command plus a pull of D's horizontal pose to the reference path."""
        k = self.options.path_gain
        yaw = _yaw_of(self._RD)
        v_w = _rot_z(yaw) @ np.array([cmd[0], cmd[1], 0.0])
        v_w[:2] += k * (self._ref[:2] - self._pD[:2])
        dyaw = (self._ref[2] - yaw + math.pi) % (2 * math.pi) - math.pi
        w_w = np.array([0.0, 0.0, cmd[2] + k * dyaw])
        if not self.options.feedback:  # the plan also holds the body at its start height and level
            v_w[2] += k * (self._ref_z - self._pD[2])
            tilt = np.cross(self._RD[:, 2], np.array([0.0, 0.0, 1.0]))
            w_w += k * tilt
        return np.concatenate([self._RD.T @ v_w, self._RD.T @ w_w])

    # ------------------------------------------------------------------ the stance primitive
    def _posture(
        self, feet: np.ndarray, R_M: np.ndarray, stance: Sequence[int], u_gait: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """The body twist δ (6,) from the stance primitive's error, and the error's observable rows (3,).

        ``feet`` (6, 3): the feet in B from the encoders.  The stance plane's similarity and its Jacobian
        G = ∂(body-frame twist)/∂p come from the task graph's pose function (:func:`stance_pose`); the map from
        a body twist to the primitive's twist with the feet fixed in W is ``A = Σ_j G_j [−I, [p_j]×]`` (the
        leg Jacobians of ``J^G L`` cancel: ``J^G = G ∂p/∂q`` and ``∂p/∂q · L = [−I, [p]×]``)."""
        opt = self.options
        order, log_m, G = stance_pose(feet, stance)
        R_pl = rotation_from_tangent(log_m[:3])  # B ← plane frame (its z: the measured normal n_m)
        n_w = R_M @ R_pl[:, 2]
        if opt.tilt_follow > 0.0:
            z_des = (1.0 - opt.tilt_follow) * np.array([0.0, 0.0, 1.0]) + opt.tilt_follow * n_w
            R_des = _frame_with_z(z_des / np.linalg.norm(z_des), _yaw_of(R_M))
        else:
            R_des = _rot_z(_yaw_of(R_M))
        n_ref = R_des.T @ n_w  # the support normal seen from the desired attitude
        e = plane_error(log_m, plane_log(n_ref, -opt.ride_height), R_pl)
        A = stance_map(G, feet[list(order)])[_PLANE_ROWS]
        r = opt.posture_gain * e[_PLANE_ROWS] - A @ u_gait
        du = A.T @ np.linalg.solve(A @ A.T + 1e-8 * np.eye(3), r)
        vmax, wmax = opt.max_correction
        nv, nw = float(np.linalg.norm(du[:3])), float(np.linalg.norm(du[3:]))
        du[:3] *= min(1.0, vmax / nv) if nv > 0 else 1.0
        du[3:] *= min(1.0, wmax / nw) if nw > 0 else 1.0
        return du, e[_PLANE_ROWS]

    # ------------------------------------------------------------------ joint targets and torques
    def _targets(self) -> np.ndarray:
        """q_D: closed-form IK of every leg's target from D — the swing arc (or search) point in swing, and in
        stance the anchor moved by the ball's rolling: a ball that rolls without slipping moves its centre by
        ``r δ × n`` when it turns by the rotation vector δ (here the tibia's rotation in W_o since touchdown,
        from the previous q_D, n = +z of W_o), so the foot-ball contact model keeps the contact point, not the
        ball centre, fixed on the ground."""
        stance = [i for i, leg in enumerate(self._legs) if leg.mode == 0]
        if stance:
            R_tib = self._RD @ self.fast.tibia_rotations(self._qD)
            r = self.hs.foot_radius
            for i in stance:
                leg = self._legs[i]
                d = _rotvec(R_tib[i] @ leg.tibia0.T)
                leg.target = leg.anchor + r * np.array([d[1], -d[0], 0.0])  # r δ × e_z
        feet = np.array([leg.target for leg in self._legs])
        q, _ = self.fast.ik((feet - self._pD) @ self._RD)
        return self.fast.clip(q)

    def _roll_reference(self, i: int) -> None:
        """The tibia's rotation in W_o now (D and q_D): the start of leg i's rolling (touchdown)."""
        self._legs[i].tibia0 = self._RD @ self.fast.tibia_rotations(self._qD)[i]

    def _weights(self, t: float, stance: Sequence[int]) -> np.ndarray:
        """Load weights (6,) in [0, 1]: ramped in after touchdown and out before the next scheduled lift-off."""
        tab = self.table
        ramp = self.options.load_ramp
        w = np.zeros(6)
        for i in stance:
            leg = self._legs[i]
            a = 1.0 if ramp <= 0 else min(1.0, (t - leg.touchdown) / ramp + 0.05)
            u = (self._tau_g / tab.period - tab.offsets[i]) % 1.0
            to_lift = (1.0 - u) * tab.period
            b = 1.0 if ramp <= 0 else min(1.0, to_lift / ramp + 0.05)
            w[i] = max(min(a, b), 0.05)
        return w

    def _feedforward(
        self, t: float, q: np.ndarray, feet: np.ndarray, J: np.ndarray, R: np.ndarray, stance: Sequence[int]
    ) -> np.ndarray:
        """Gravity of the legs and −Jᵀ F for the vertical foot forces that carry the weight with no moment about
        the centre of mass (module docstring); ``feet`` (6, 3) and leg Jacobians ``J`` (6, 3, 3) in B at q."""
        pin = self._pin
        m, d = self._model, self._data
        m.gravity.linear = R.T @ np.array([0.0, 0.0, -G])
        tau = np.array(pin.computeGeneralizedGravity(m, d, q))
        if len(stance) == 0:
            return tau
        pin.centerOfMass(m, d, q, False)
        base = m.inertias[0]
        com = (base.mass * np.asarray(base.lever) + d.mass[0] * np.asarray(d.com[0])) / self._mass
        idx = list(stance)
        xy = ((feet[idx] - com) @ R.T)[:, :2]
        w = self._weights(t, stance)[idx]
        A = np.vstack([np.ones(len(idx)), xy.T])
        b = np.array([self._mass * G, 0.0, 0.0])
        AW = A * w
        try:
            f = w * (A.T @ np.linalg.solve(AW @ A.T, b))
        except np.linalg.LinAlgError:
            f = w / w.sum() * self._mass * G
        f = np.maximum(f, 0.0)
        f *= self._mass * G / max(float(f.sum()), 1e-9)
        zB = R[2]  # world z in B (the third row of R_WB)
        tau[self.fast.q_index[idx]] -= np.einsum("kji,j->ki", J[idx], zB) * f[:, None]
        return tau

    # ------------------------------------------------------------------ records
    def _record(
        self, t: float, stance: Sequence[int], touch: np.ndarray, err: np.ndarray, u: np.ndarray, waiting: bool
    ) -> None:
        mask = np.zeros(6, bool)
        mask[list(stance)] = True
        modes = np.array([leg.mode for leg in self._legs], np.int8)
        self.records.append(
            (t, mask, touch.copy(), modes, err.copy(), u.copy(), (self._pD, self._RD), self._qD.copy(), waiting)
        )

    #: names of :meth:`records_arrays`
    RECORD_FIELDS = ("t", "stance", "contact", "mode", "posture_error", "body_twist", "plan_pose", "q_plan", "waiting")

    def records_arrays(self) -> dict[str, np.ndarray]:
        """The plans' records as arrays (P = number of plans): ``t`` (P,) [s]; ``stance`` (P, 6) bool — the
        stance set the plan used (in stance and touching; the plan's stance legs in open loop); ``contact``
        (P, 6) bool (touch sensors); ``mode`` (P, 6) 0 stance / 1 swing / 2 searching; ``posture_error`` (P, 3)
        the stance plane's error rows (e13, e23 [rad], e3∞ [m]); ``body_twist`` (P, 6) u = (v, ω) of D in B;
        ``plan_pose`` (P, 7) D's body pose (position [m], quaternion w, x, y, z) in W_o; ``q_plan`` (P, 18);
        ``waiting`` (P,) bool: the gait waited for a late foot."""
        cols: list[Any] = list(zip(*self.records)) if self.records else [[] for _ in self.RECORD_FIELDS]
        out = {name: np.array(col) for name, col in zip(self.RECORD_FIELDS, cols) if name != "plan_pose"}
        poses = cols[6] if self.records else []
        out["plan_pose"] = np.array([np.concatenate([p, _R_to_quat(R)]) for p, R in poses]).reshape(-1, 7)
        return {name: out[name] for name in self.RECORD_FIELDS}
