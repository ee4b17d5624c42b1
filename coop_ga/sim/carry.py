"""Three iiwa arms carry a box with the cooperative circle: the scenario, one run, and its measured claims.

The scenario of ``experiments/sim_box_carry.py`` and of its tests, built from the pieces of
:mod:`coop_ga.sim` (:func:`~coop_ga.sim.build_scene`, :mod:`~coop_ga.sim.tools`,
:mod:`~coop_ga.sim.hold`); nothing here is welded or constrained — the box is a free body on a table,
contacts and gravity on.

Scene (:func:`carry_setup`)
---------------------------
* ``three_iiwa14`` with a 16 cm tool on each flange (:func:`~coop_ga.sim.with_tool`): a stick ending
  in a 3 cm rubber sphere pad whose centre is the end point (margin 2 mm, ``condim`` 4, ``solref``
  (0.005, 1), elliptic cones, ``impratio`` 10, 10 no-slip iterations; friction = the box's).  The
  stick keeps the wrists and elbows off the box: with 6 cm, a folding arm's elbow rested on it;
* a box of 0.481 × 0.481 × 0.20 m (mass and friction per :class:`CarryCase`) resting on a static
  table (top 0.45 × 0.35 m at z = 0.30 m, under the box's start and end), centre at z = 0.40 m;
* the grasp: the pads' centres on a horizontal circle of radius 0.28 m about (0, 0, 0.40) at −90°,
  15° and 165° — arm 0 on the box's −y face, arms 1 and 2 on its ±x faces.  Why not the arms' own
  120° layout: a box has no three faces 120° apart, and the e0∞ squeeze pushes along −∂ ln r / ∂p_i
  (radial for evenly spaced points), so at 30°/150° the side pads need tangential friction of
  tan 30° = 0.58 of their normal force just to squeeze; at 15°/165° about 0.3;
* the tools point horizontally at the circle's centre, raised by 0.2 rad (the pointing rows of the
  controller): with the tool level, an extending arm's wrist reaches its singularity (joint 6 → 0)
  and flips (joints 5 and 7 beyond their velocity limits); raised, joint 6 stays bent;
* the carry: lift 0.15 m, then 0.2 m towards 150° (towards arm 2) while turning +20° about the
  vertical through the box's centre, hold, put down, release.  Why this direction: each iiwa with
  its tool reaches its pad between a folded (joint 4 at its limit) and a stretched pose; of all
  headings and both turning senses this one keeps the three pads inside that range.

A case may offset the box from where the plan expects it (the controller is not told): the pads
then touch at different times and the squeeze loop centres the grasp on the box.

:func:`run_carry` simulates a case (1 kHz, the :class:`~coop_ga.sim.HoldController` every step) and
:func:`carry_metrics` measures its claims (module docstring of ``experiments/sim_box_carry.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

import numpy as np

from .. import validation
from ..errors import InvalidInputError
from .hold import CarryPlan, HoldController, HoldGains
from .objects import Box
from .scene import Scene, build_scene
from .simulation import Simulation, SimulationLog
from .tools import add_pads, with_tool

__all__ = [
    "FAST_DURATIONS",
    "FULL_DURATIONS",
    "CarryCase",
    "CarryRun",
    "CarrySetup",
    "box_state",
    "carry_metrics",
    "carry_setup",
    "carry_task",
    "default_gains",
    "grasp_overlays",
    "limit_excursions",
    "run_carry",
    "slip_series",
]

SYSTEM = "three_iiwa14"
TOOL_LENGTH, PAD_RADIUS, PAD_MARGIN = 0.16, 0.03, 0.002  # [m]
GRASP_RADIUS = 0.28  # [m] circle of the pad centres at the grasp
SPREAD = math.radians(15.0)  # arms 1, 2 at SPREAD and 180° − SPREAD, arm 0 at −90°
GRASP_HEIGHT, BOX_HEIGHT = 0.40, 0.20  # [m]
TABLE_SIZE, TABLE_CENTRE = (0.45, 0.35), (-0.09, 0.05)  # [m] covers the box's start and end
OPEN = 0.03  # [m] pre-grasp circle this much outside the touching one
START_RADIUS, START_HEIGHT = GRASP_RADIUS + 0.05, GRASP_HEIGHT + 0.03  # [m] the arms start with the pads on this circle
TOOL_PITCH = 0.2  # [rad] the tools point at the centre, raised by this (module docstring)
OFF_TABLE = 0.002  # [m] the box counts as carried this far above its rest
LIFT, SHIFT, HEADING, YAW = 0.15, 0.20, math.radians(150.0), math.radians(20.0)
#: phase durations [s] (approach, close, squeeze, lift, carry, hold, lower, release, open)
FULL_DURATIONS = (1.5, 0.5, 0.5, 1.5, 2.5, 0.5, 1.5, 0.5, 0.5)
FAST_DURATIONS = (1.0, 0.4, 0.4, 1.2, 1.8, 0.3, 1.2, 0.4, 0.3)


@dataclass(frozen=True)
class CarryCase:
    """One run: ``name``, box ``mass`` [kg], ``friction`` (box and pads, sliding), the box's ``offset``
    (2,) [m] from where the plan expects it, the squeeze set-point ``squeeze`` [N] (0: the control
    case), the phase ``durations`` [s], and the carry: ``shift`` [m] towards 150°, ``turn`` [rad]."""

    name: str = "nominal"
    mass: float = 2.0
    friction: float = 0.8
    offset: Any = (0.0, 0.0)
    squeeze: float = 40.0
    durations: tuple[float, ...] = FULL_DURATIONS
    shift: float = SHIFT
    turn: float = YAW

    def __post_init__(self) -> None:
        validation.positive(self.mass, "mass")
        validation.positive(self.friction, "friction")
        object.__setattr__(self, "offset", tuple(float(x) for x in validation.vector(self.offset, 2, "offset")))
        validation.nonnegative(self.squeeze, "squeeze")

    def describe(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "mass_kg": self.mass,
            "friction": self.friction,
            "offset_m": list(self.offset),
            "squeeze_N": self.squeeze,
        }


@dataclass
class CarrySetup:
    """Everything a run needs: the tool system, its scene, task, plan, controller and start configuration."""

    case: CarryCase
    system: Any
    scene: Scene
    task: Any
    plan: CarryPlan
    controller: HoldController
    q_start: np.ndarray
    q_grasp: np.ndarray
    box_centre: np.ndarray
    box_half: float
    table_top: float


@dataclass
class CarryRun:
    """A finished run: its setup, the :class:`~coop_ga.sim.SimulationLog`, the controller's trace, the metrics."""

    setup: CarrySetup
    log: SimulationLog
    trace: dict[str, np.ndarray]
    metrics: dict[str, Any] = field(default_factory=dict)


@lru_cache(maxsize=1)
def _tool_system() -> Any:
    from .. import systems

    return with_tool(systems.load(SYSTEM), TOOL_LENGTH)


@lru_cache(maxsize=1)
def carry_task() -> Any:
    """The cooperative circle task of the box scene's robot (``three_iiwa14`` with its tools; built once)."""
    from ..cooperative import cooperative_task

    return cooperative_task(_tool_system(), "circle")


def grasp_points(radius: float, height: float, yaw: float = 0.0) -> np.ndarray:
    """(3, 3) pad centres on the circle of ``radius`` about (0, 0, ``height``) at the grasp angles + ``yaw``."""
    ang = np.array([-0.5 * math.pi, SPREAD, math.pi - SPREAD]) + yaw
    return np.stack([radius * np.cos(ang), radius * np.sin(ang), np.full(3, height)], axis=1)


def point_ik(system: Any, q0: np.ndarray, points: np.ndarray, iters: int = 60) -> np.ndarray:
    """A configuration near ``q0`` putting the end points at ``points`` (n, 3) [m]: damped least squares on
    the stacked point Jacobians, clipped to the joint limits; raises if it misses by more than 0.1 mm."""
    import pinocchio as pin

    model, data = system.model, system.model.createData()
    frames = [model.getFrameId(f) for f in system.end_frames]
    q = np.array(q0, float)
    lim = system.limits
    for _ in range(iters):
        pin.framesForwardKinematics(model, data, q)
        pin.computeJointJacobians(model, data, q)
        err = np.concatenate([points[i] - data.oMf[f].translation for i, f in enumerate(frames)])
        if np.max(np.abs(err)) < 1e-7:
            break
        J = np.vstack(
            [pin.getFrameJacobian(model, data, f, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)[:3] for f in frames]
        )
        dq = J.T @ np.linalg.solve(J @ J.T + 1e-6 * np.eye(J.shape[0]), err)
        q = np.clip(q + dq, lim.lower, lim.upper)
    miss = float(np.max(np.abs(err)))
    if miss > 1e-4:
        raise InvalidInputError(f"the end points cannot reach the grasp points (missing by {miss * 1e3:.1f} mm)")
    return q


def default_gains(wrist_damping: float = 40.0) -> HoldGains:
    """:class:`~coop_ga.sim.HoldGains` with a stronger nullspace damping on the wrist joints (5–7 of each arm,
    ``wrist_damping`` [1/s]): the tool's roll about its axis is free in the task."""
    base = HoldGains()
    Dn = np.tile([10.0, 10.0, 10.0, 10.0, wrist_damping, wrist_damping, wrist_damping], 3)
    return HoldGains(K=base.K, D=base.D, K_post=base.K_post, D_null=Dn)


def _circle_ik(task: Any, q0: Any, radius: float, height: float) -> np.ndarray:
    from ..control import gauss_newton_ik
    from .hold import circle_target

    res = gauss_newton_ik(task, q0, circle_target((0.0, 0.0, height), radius))
    if not res.converged:
        raise InvalidInputError(
            f"the start circle (radius {radius} m at z = {height} m) is out of reach: {res.message}"
        )
    return np.asarray(res.q, float)


def carry_setup(case: CarryCase, gains: HoldGains | None = None) -> CarrySetup:
    """Build the scene, plan and controller of ``case`` (module docstring); raises like
    :class:`~coop_ga.sim.HoldController` if the squeeze exceeds the arms' capacity at the grasp."""
    system, task = _tool_system(), carry_task()
    half = GRASP_RADIUS * math.cos(SPREAD) - PAD_RADIUS  # the box's half width: the x faces touch the pads
    centre = np.array([0.0, GRASP_RADIUS * (math.cos(SPREAD) - 1.0), GRASP_HEIGHT])  # its −y face touches arm 0
    table_top = GRASP_HEIGHT - 0.5 * BOX_HEIGHT
    fr = (case.friction, 0.01, 0.0001)
    box = Box(
        name="box",
        size=(2 * half, 2 * half, BOX_HEIGHT),
        mass=case.mass,
        pos=centre + np.array([case.offset[0], case.offset[1], 0.0005]),
        friction=fr,
        condim=4,
        rgba=(0.78, 0.6, 0.38, 0.6),  # see-through: the pictures show the circle and the forces inside
    )
    table = Box(
        name="table",
        size=(*TABLE_SIZE, table_top),
        pos=(*TABLE_CENTRE, 0.5 * table_top),
        static=True,
        friction=fr,
        rgba=(0.45, 0.45, 0.5, 1.0),
    )
    scene = build_scene(system, objects=[box, table])
    scene = add_pads(
        scene,
        PAD_RADIUS,
        shaft_length=TOOL_LENGTH,
        friction=fr,
        margin=PAD_MARGIN,
        solref=(0.005, 1.0),
        noslip_iterations=10,
    )
    plan = CarryPlan(
        centre=(0.0, 0.0, GRASP_HEIGHT),
        object_centre=centre,
        radius_touch=GRASP_RADIUS,
        radius_open=GRASP_RADIUS + OPEN,
        squeeze=case.squeeze,
        lift=LIFT,
        shift=(case.shift * math.cos(HEADING), case.shift * math.sin(HEADING), 0.0),
        yaw=case.turn,
        durations=case.durations,
        angles=(-0.5 * math.pi, SPREAD, math.pi - SPREAD),
        tool_pitch=TOOL_PITCH,
    )
    # the start: the q0 posture moved (Gauss–Newton on the circle alone) until the pads lie on a circle
    # START_RADIUS wide — the tools keep pointing at the centre as at q0; the approach then slides the
    # pads along the circle to the grasp angles
    q_start = _circle_ik(task, system.q0, START_RADIUS, START_HEIGHT)
    q_grasp = point_ik(system, q_start, grasp_points(GRASP_RADIUS, GRASP_HEIGHT))
    ctl = HoldController(scene, task, plan, gains or default_gains(), q_start=q_start, q_grasp=q_grasp)
    return CarrySetup(case, system, scene, task, plan, ctl, q_start, q_grasp, centre, half, table_top)


def run_carry(
    case: CarryCase,
    *,
    gains: HoldGains | None = None,
    duration: float | None = None,
    disturbances: Any = (),
    progress: bool = False,
) -> CarryRun:
    """Simulate ``case`` (for its plan's duration, or ``duration`` [s]; with :class:`~coop_ga.sim.Disturbance`
    s on the box) and measure it (:func:`carry_metrics`, only for a whole run)."""
    st = carry_setup(case, gains)
    sim = Simulation(st.scene, st.controller, q=st.q_start, disturbances=disturbances)
    log = sim.run(st.plan.duration if duration is None else duration, progress=progress)
    trace = st.controller.trace()
    run = CarryRun(st, log, trace)
    if duration is None:
        run.metrics = carry_metrics(run)
    return run


# ====================================================================== measurements
def box_state(run: CarryRun) -> tuple[np.ndarray, np.ndarray]:
    """(positions (T, 3), rotation matrices (T, 3, 3)) of the box over the log."""
    from ._mujoco import mj

    a = run.setup.scene.object_qpos["box"]
    pos = run.log.qpos[:, a : a + 3]
    quat = run.log.qpos[:, a + 3 : a + 7]
    R = np.empty((len(quat), 9))
    for k, qk in enumerate(quat):
        mj().mju_quat2Mat(R[k], qk)
    return pos, R.reshape(-1, 3, 3)


def _window(run: CarryRun, first: str, last: str, edge: str = "start") -> np.ndarray:
    """Log row indices from the start of phase ``first`` to the end of phase ``last``."""
    pt = run.setup.plan.phase_times()
    t = run.log.time
    return np.flatnonzero((t >= pt[first][0] - 1e-9) & (t <= pt[last][1] + 1e-9))


def slip_series(run: CarryRun, first: str = "lift") -> np.ndarray:
    """(T, n) tangential displacement [m] of each end point on the box's surface (box frame) from its place at
    the start of phase ``first``, per trace row (NaN before); the face normal is the box axis the point sits
    out along (its normal component, the pad's compression, is not slip)."""
    P = run.trace["points"]  # (T, n, 3): trace row k = log row k
    pos, R = box_state(run)
    T = len(P)
    local = np.einsum("kji,knj->kni", R[:T], P - pos[:T, None, :])  # Rᵀ (p − b)
    i0 = int(np.searchsorted(run.trace["time"], run.setup.plan.phase_times()[first][0] - 1e-9))
    d = local - local[i0]
    for i, ax in enumerate(np.argmax(np.abs(local[i0]), axis=1)):
        d[:, i, ax] = 0.0
    out = np.linalg.norm(d, axis=2)
    out[:i0] = np.nan
    return out


def limit_excursions(run: CarryRun) -> dict[str, float]:
    """The simulated state's largest excursions outside the system's joint limits over the whole run:
    ``max_limit_violation`` (position) [rad] and ``max_velocity_violation`` [rad/s]; 0 inside (the keys the
    gallery runner checks in every published figure)."""
    lim = run.setup.system.limits
    return {
        "max_limit_violation": lim.position_violation(run.log.q),
        "max_velocity_violation": lim.velocity_violation(run.log.qd),
    }


def carry_metrics(run: CarryRun) -> dict[str, Any]:
    """The run's measured claims (all lengths [m], angles [deg], forces [N]):

    * ``rise_max_m``: the box's highest rise over its resting height; ``lift_m``: its lowest height
      over the carry (lift end → lower start) above the resting height;
    * carried: the rows of the log in which the box is off the table (more than 2 mm above its rest)
      between the lift start and the end of the put-down (``carried_s`` [s] of them);
    * ``tilt_max_deg``: the largest angle of the box's z axis from vertical while carried;
    * ``slip_mm`` (n,): each end point's largest tangential displacement on the box's surface while
      carried (box frame, from its place at the lift start); ``slip_max_mm``;
    * ``squeeze_min_N``, ``squeeze_max_N``, ``squeeze_error_max``: the measured squeeze while carried
      and its largest relative deviation from the set-point; ``squeeze_error_max_holding``: the same
      from the lift start to the end of the put-down (with the lift-off and touch-down transients);
      ``pad_force_max_N``: the largest contact force of an end point over that time (the control case:
      the pads did touch the box);
    * ``carry_error_m``: |box displacement at the end of the hold − the planned shift|;
      ``turn_deg``: the box's turn about the vertical by then;
    * ``weight_estimate_kg``: the estimate at the end of the hold; ``on_table``: at the end the box
      rests on the table (height within 5 mm of the start, tilt < 2°, speed < 1 cm/s) and no pad
      touches it; ``final_offset_m``: its final displacement;
    * saturation (``saturated_updates``, ``effort_ratio``) and ``max_limit_violation`` [rad],
      ``max_velocity_violation`` [rad/s] over the run; ``success`` (squeeze > 0): lift ≥ 0.10 m,
      tilt ≤ 10°, slip ≤ 5 mm, squeeze within ±25 %, carried within 3 cm, on the table, no joint
      limit left; ``success`` (squeeze = 0, the control case): the box never rises 1 cm.
    """
    st, log, tr = run.setup, run.log, run.trace
    pos, R = box_state(run)
    z0 = pos[0, 2]
    holding = _window(run, "lift", "lower")  # from the lift start to the end of the put-down
    holding = holding[holding < len(tr["time"])]
    off = holding[pos[holding, 2] - z0 > OFF_TABLE]  # carried: off the table (a control case may be empty)
    carried = off if off.size else holding
    aloft = _window(run, "carry", "hold")
    tilt = np.degrees(np.arccos(np.clip(R[:, 2, 2], -1.0, 1.0)))
    s = tr["squeeze"]
    slip = np.max(slip_series(run)[carried], axis=0)
    hold_end = _window(run, "hold", "hold")[-1]
    yaw = np.degrees(np.arctan2(R[hold_end, 1, 0], R[hold_end, 0, 0]) - np.arctan2(R[0, 1, 0], R[0, 0, 0]))
    shift = np.asarray(st.plan.shift)
    speed = float(np.linalg.norm(log.qvel[-1, st.scene.object_qvel["box"] : st.scene.object_qvel["box"] + 3]))
    released = bool(np.all(np.abs(tr["forces"][-1]) < 1e-9))
    on_table = bool(abs(pos[-1, 2] - z0) < 5e-3 and tilt[-1] < 2.0 and speed < 0.01 and released)
    set_point = st.case.squeeze
    m = {
        "case": st.case.describe(),
        "rise_max_m": float(np.max(pos[:, 2] - z0)),
        "lift_m": float(np.min(pos[aloft, 2] - z0)),
        "tilt_max_deg": float(np.max(tilt[carried])),
        "slip_mm": (1e3 * slip).tolist(),
        "slip_max_mm": float(1e3 * np.max(slip)),
        "squeeze_min_N": float(np.min(s[carried])),
        "squeeze_max_N": float(np.max(s[carried])),
        "squeeze_error_max": float(np.max(np.abs(s[carried] / set_point - 1.0))) if set_point > 0 else None,
        "squeeze_error_max_holding": float(np.max(np.abs(s[holding] / set_point - 1.0))) if set_point > 0 else None,
        "carried_s": float(len(off) * st.scene.model.opt.timestep),
        "pad_force_max_N": float(np.max(np.linalg.norm(tr["forces"][holding], axis=2))),
        "carry_error_m": float(np.linalg.norm(pos[hold_end, :2] - pos[0, :2] - shift[:2])),
        "turn_deg": float((yaw + 180.0) % 360.0 - 180.0),
        "weight_estimate_kg": float(tr["weight_estimate"][min(hold_end, len(s) - 1)]),
        "on_table": on_table,
        "final_offset_m": (pos[-1] - pos[0]).tolist(),
        "saturated_updates": int(log.saturated_updates),
        "control_updates": int(log.control_updates),
        "effort_ratio": float(log.effort_ratio),
        **limit_excursions(run),
    }
    if set_point > 0:
        m["success"] = bool(
            m["lift_m"] >= 0.10
            and m["tilt_max_deg"] <= 10.0
            and m["slip_max_mm"] <= 5.0
            and m["squeeze_error_max"] <= 0.25
            and m["carry_error_m"] <= 0.03
            and on_table
            and m["max_limit_violation"] == 0.0
        )
    else:
        m["success"] = bool(m["rise_max_m"] < 0.01)
    m["failures"] = _failures(m, set_point)
    return m


def _failures(m: dict[str, Any], set_point: float) -> list[str]:
    """What a failed run missed, in words."""
    if set_point == 0:
        return [] if m["success"] else [f"the box rose {m['rise_max_m'] * 100:.1f} cm without a squeeze"]
    out = []
    if m["lift_m"] < 0.10:
        out.append(f"lift {m['lift_m'] * 100:.1f} cm < 10 cm")
    if m["tilt_max_deg"] > 10.0:
        out.append(f"tilt {m['tilt_max_deg']:.1f}° > 10°")
    if m["slip_max_mm"] > 5.0:
        out.append(f"slip {m['slip_max_mm']:.1f} mm > 5 mm")
    if m["squeeze_error_max"] > 0.25:
        out.append(f"squeeze off its set-point by {100 * m['squeeze_error_max']:.0f} % > 25 %")
    if m["carry_error_m"] > 0.03:
        out.append(f"carried {m['carry_error_m'] * 100:.1f} cm off the planned shift")
    if not m["on_table"]:
        out.append("the box did not end at rest on the table, released")
    if m["max_limit_violation"] > 0:
        out.append(f"joint limits left by {m['max_limit_violation']:.3g} rad")
    return out


def grasp_overlays(run: CarryRun, k: int) -> list[Any]:
    """Overlays of log row ``k`` for :func:`coop_ga.sim.render.render_log`: the cooperative circle through
    the end points (orange) and the squeeze part of each end point's force on the box (blue arrows,
    1 cm per 2 N)."""
    from ..cooperative import cooperative_wrench
    from ..cooperative.primitive import cooperative_primitive
    from ..geometry.primitives import point as conformal_point
    from . import render

    tr = run.trace
    k = min(k, len(tr["time"]) - 1)
    P, F = tr["points"][k], tr["forces"][k]
    X = cooperative_primitive("circle", [conformal_point(p) for p in P])
    D = cooperative_wrench(run.setup.task, P, -F).direction  # unit (over all points) inward squeeze direction
    sq = float(np.sum(-F * D)) * D  # the squeeze part of the forces on the box: (F · d) d

    def circle(scn: Any) -> None:
        render.add_primitive(scn, X, width=0.006)

    def arrows(scn: Any) -> None:
        for p, f in zip(P, sq):
            render.add_force(scn, p, f, scale=0.005, width=0.008)

    return [circle, arrows]
