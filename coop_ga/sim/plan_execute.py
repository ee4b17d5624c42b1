"""A planned box lift executed in MuJoCo: three iiwa arms grasp a free box, then follow an OMPL path past a shelf.

The planner (:mod:`coop_ga.plan`) and the physics (:mod:`coop_ga.sim.carry`) meet here, on the carry's robots:
``three_iiwa14`` with the 16 cm stick-and-pad tools, the box (0.481 × 0.481 × 0.2 m, free, on a static table),
contacts and gravity on, nothing welded.  Why plan for the carry's robots and not the planning scene's Frankas:
the planner takes any system, while the hold controller, its tools, its grasp geometry and its squeeze capacity
were built and measured for the iiwas; the box-lift scene's pieces (the goal region, the rigid grasp, the
carried box, the shelf lip) are rebuilt around the carry's grasp instead.

Pipeline (:func:`grasp`, :func:`lift_problem`, :func:`plan_lift`, :func:`run_execution`):

1. **grasp** — the carry's approach, close and squeeze phases (:class:`~coop_ga.sim.HoldController`, squeeze
   set-point s_d, durations of :data:`~coop_ga.sim.carry.FAST_DURATIONS`) in MuJoCo; the configuration and the
   box pose at their end are *measured*;
2. **plan** from that configuration (:class:`~coop_ga.plan.PlanningProblem`): the rigid grasp (the three pad
   distances as measured), the circle upright within :data:`PATH_TILT` along the path, the goal region of the
   box-lift scene (:mod:`coop_ga.plan.box_lift`: the circle's centre 0.2 m higher ± 1 cm, 8–14 cm towards −y,
   x ± 2 cm, its normal within 10° of vertical; the planner aims at its inner half, :data:`GOAL_MARGIN`), the
   arms' capsules clear of the shelf and of each other, the carried box (its measured pose) clear of the shelf
   and the table top, ``clearance`` :data:`CLEARANCE`;
3. **time** the path with TOPP-RA (:func:`~coop_ga.plan.timing.time_parameterise`) within
   :data:`SPEED` × the velocity limits and :data:`ACCELERATION`;
4. **execute** (:class:`PathHoldController`): the same simulation from t = 0 (the grasp is deterministic, so the
   state at the end of the squeeze is the measured one), then the plan's joint trajectory q_p(t) with the squeeze
   held.  Composition, as the carry composes its motion with its squeeze: the hold controller's task targets
   follow the plan — the circle's centre moves by the planned centre's displacement c_p(t) − c_p(0), the end
   points' angles turn by the planned yaw, the tools' axes turn with the planned grasp frame
   (:func:`~coop_ga.plan.points_frame`) — the radius stays under the e0∞ squeeze admittance, and the nullspace
   posture target is q_p(t) itself (it fixes the elbows and the tool rolls the task leaves free).  The circle's
   rotation target of the hold controller is horizontal (:func:`~coop_ga.sim.hold.circle_target` has no
   rotation), hence the tight path cone :data:`PATH_TILT`.  A final ``hold`` phase keeps the box at the goal.
   Why the tools' axes turn with the grasp frame and are not the planned axes: the rigid grasp fixes the pads'
   distances only, so the planner leaves each tool free to pivot about its pad; following those pivots the pads
   rolled on the box (seed 0: tilt 9.5°, slip 9.6 mm, against 4.5° and 4 mm with the axes fixed in the grasp
   frame).  The wrists therefore leave the plan's joint reference (``tracking_wrist_max_rad``), while joints 1–4
   and the pads follow it (``tracking_arm_max_rad``, ``pad_tracking_max_m``).

The shelf lip: five static spheres (radius 4 cm, |x| ≤ 8 cm) :data:`SHELF_ABOVE_BOX` above the box's top,
reaching :data:`~coop_ga.plan.box_lift.SHELF_OVERHANG` over its +y edge (a straight lift hits it), built from
one description (:class:`Shelf`) into the planner's obstacles and MuJoCo's static geoms.

:func:`execution_metrics` measures the run (lengths [m], angles [deg]): the box's displacement from the end of
the squeeze against the goal region (translated to the box), its tilt, whether it dropped, each pad's slip on
the box, the MuJoCo contacts of the shelf and the smallest MuJoCo distance (``mj_geomDistance``) between the shelf
and the robots' and the box's geoms, joint-limit violations, and the tracking error of the joint reference.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import cached_property
from typing import Any, ClassVar, cast

import numpy as np

from ..collision import CollisionModel, Plane, Sphere
from ..errors import InfeasibleConstraintsError, InvalidInputError
from ..plan import CarriedBox, PlannerOptions, PlanningProblem, PlanResult, Region, RigidGrasp, plan, points_frame
from ..plan.box_lift import GOAL_SHIFT, GOAL_TOL_XY, GOAL_TOL_Z, LIFT, SHELF_OVERHANG, SHELF_RADIUS, TILT
from ..plan.regions import readout
from .carry import (
    BOX_HEIGHT,
    FAST_DURATIONS,
    CarryCase,
    CarryRun,
    CarrySetup,
    box_state,
    carry_setup,
    default_gains,
    limit_excursions,
    slip_series,
)
from .hold import CarryPlan, HoldController, HoldGains, PhasedPlan, PlanPoint
from .objects import Ball
from .scene import Scene, add_objects
from .simulation import Simulation, SimulationLog

__all__ = [
    "ACCELERATION",
    "CLEARANCE",
    "EXECUTION_OPTIONS",
    "PATH_TILT",
    "SPEED",
    "Grasp",
    "Lift",
    "PathCarryPlan",
    "PathHoldController",
    "PathReference",
    "Shelf",
    "execution_gains",
    "execution_metrics",
    "execution_setup",
    "grasp",
    "lift_off",
    "lift_problem",
    "plan_lift",
    "run_execution",
]

SHELF_ABOVE_BOX = 0.10  # [m] the lip's sphere centres above the box's top (its underside 6 cm above it)
PATH_TILT = math.radians(3.0)  # [rad] the circle's largest tilt along the path (module docstring)
CLEARANCE = 0.01  # [m] the smallest clearance the planner accepts (arms' capsules and box)
SPEED, ACCELERATION = 0.3, 1.0  # the fraction of the velocity limits, the acceleration bound [rad/s²]
HOLD = 1.2  # [s] the final hold at the goal (the weight estimate's integral action removes the sag)
#: the planner aims at the goal region's inner part: this fraction of each interval is left at its edges, a margin
#: for the held box's sag and tilt (the run is measured against the whole region; with the planner aiming at the
#: whole region 2 of 3 boxes ended inside, one 5.7 mm below it)
GOAL_MARGIN = 0.5
POSTURE, WRIST_POSTURE = 40.0, 160.0  # [1/s²] the nullspace posture stiffness (execution_gains)
DWELL = 0.6  # [s] the pause at the top of the lift-off
TRANSLATION_K = 400.0  # [1/s²] the circle's translation stiffness (execution_gains; critically damped)
LIFT_OFF = 0.04  # [m] the straight lift-off before the planned path (module docstring)
#: the planner settings: the box-lift scene's (extensions ≤ 0.5 rad, a 0.4 rad window), 10 s per plan
EXECUTION_OPTIONS = PlannerOptions(range=0.5, window=0.4, time_limit=10.0)


# ====================================================================== the shelf
@dataclass(frozen=True)
class Shelf:
    """The shelf lip: sphere ``centres`` (k, 3) [m] of ``radius`` [m]; :meth:`spheres` for the planner,
    :meth:`objects` for MuJoCo (static geoms)."""

    centres: np.ndarray
    radius: float

    @classmethod
    def over(cls, box_centre: Any, half: Any) -> Shelf:
        """The lip over a box of centre (3,) and half extents (3,) [m] (module docstring)."""
        c, h = np.asarray(box_centre, float), np.asarray(half, float)
        y = c[1] + h[1] - SHELF_OVERHANG + SHELF_RADIUS
        z = c[2] + h[2] + SHELF_ABOVE_BOX
        return cls(np.array([[x, y, z] for x in np.linspace(-0.08, 0.08, 5)]), SHELF_RADIUS)

    def spheres(self) -> tuple[Sphere, ...]:
        return tuple(Sphere(c, self.radius, name=f"shelf {k}") for k, c in enumerate(self.centres))

    def objects(self) -> tuple[Ball, ...]:
        return tuple(
            Ball(name=f"shelf{k}", radius=self.radius, pos=c, static=True, rgba=(0.55, 0.35, 0.2, 1.0))
            for k, c in enumerate(self.centres)
        )


def with_static(scene: Scene, objects: Any) -> Scene:
    """A new :class:`Scene` with static ``objects`` added (the spec is copied)."""
    if any(not o.static for o in objects):
        raise InvalidInputError("with_static adds static objects only; give free objects to build_scene")
    spec = scene.spec.copy()
    add_objects(spec, objects, {o.name for o in scene.objects})
    return Scene(
        scene.system, spec, spec.compile(), (*scene.objects, *objects), scene.floating_base, scene.base_body,
        scene.excluded, scene.visual_skipped, scene.capsules,
    )  # fmt: skip


# ====================================================================== the plan as hold references
@dataclass(frozen=True)
class PathReference:
    """A timed path as the hold controller's references, on ``t`` (T,) [s] from the start of the follow phase:
    ``q`` (T, nq) the joint reference, ``shift`` (T, 3) [m] the circle centre's displacement from t = 0,
    ``turn`` (T, 3, 3) the grasp frame's rotation from t = 0 (:func:`~coop_ga.plan.points_frame` of the end
    points), ``yaw`` (T,) [rad] its turn about the vertical."""

    t: np.ndarray
    q: np.ndarray
    shift: np.ndarray
    turn: np.ndarray
    yaw: np.ndarray

    @classmethod
    def from_path(cls, task: Any, t: Any, q: Any) -> PathReference:
        """Read the references off a timed joint path ``q`` (T, nq) at ``t`` (T,) [s] of the circle ``task``."""
        Q = np.asarray(q, float)
        c = np.array([readout(task, qk).centre for qk in Q])
        R = np.array([points_frame(task.points(qk))[0] for qk in Q])
        turn = np.einsum("kij,lj->kil", R, R[0])  # R(t) R(0)ᵀ
        yaw = np.arctan2(turn[:, 1, 0] - turn[:, 0, 1], turn[:, 0, 0] + turn[:, 1, 1])
        return cls(np.asarray(t, float), Q, c - c[0], turn, yaw)

    @property
    def duration(self) -> float:
        return float(self.t[-1])

    def _at(self, s: float) -> tuple[int, float]:
        k = int(np.clip(np.searchsorted(self.t, s, side="right") - 1, 0, len(self.t) - 2))
        w = float(np.clip((s - self.t[k]) / (self.t[k + 1] - self.t[k]), 0.0, 1.0))
        return k, w

    def sample(self, s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """``(q, shift, turn, yaw)`` at s [s] (linear between samples; the end value after the end)."""
        k, w = self._at(s)
        v = 1.0 - w
        return (
            v * self.q[k] + w * self.q[k + 1],
            v * self.shift[k] + w * self.shift[k + 1],
            v * self.turn[k] + w * self.turn[k + 1],
            v * self.yaw[k] + w * self.yaw[k + 1],
        )


@dataclass(frozen=True)
class PathCarryPlan(PhasedPlan):
    """The carry's grasp (``base``: its approach, close and squeeze), then ``path`` (None: hold the grasp),
    then a hold; the squeeze set-point ``squeeze`` [N] held from the squeeze on (module docstring)."""

    phases: ClassVar[tuple[str, ...]] = ("approach", "close", "squeeze", "follow", "hold")
    base: CarryPlan
    path: PathReference | None
    durations: tuple[float, ...]
    start: tuple[Any, float] | None = None

    def __post_init__(self) -> None:
        self._check_durations()

    @classmethod
    def make(cls, base: CarryPlan, path: PathReference | None, hold: float = HOLD) -> PathCarryPlan:
        follow = path.duration if path is not None else 1e-3
        return cls(base, path, (*base.durations[:3], follow, hold))

    # what HoldController reads of a plan
    @property
    def squeeze(self) -> float:
        return float(self.base.squeeze)

    @property
    def angles(self) -> Any:
        return self.base.angles

    @property
    def tool_pitch(self) -> float | None:
        return self.base.tool_pitch

    @property
    def radius_touch(self) -> float:
        return float(self.base.radius_touch)

    @property
    def follow_start(self) -> float:
        return self.phase_times()["follow"][0]

    @cached_property
    def _base(self) -> CarryPlan:
        return replace(self.base, start=self.start)

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, float] | None:
        """The path's ``(q, shift, turn, yaw)`` at time t [s] (None before the follow phase or without a path)."""
        t0 = self.follow_start
        if self.path is None or t < t0:
            return None
        return self.path.sample(t - t0)

    def at(self, t: float) -> PlanPoint:
        """The :class:`~coop_ga.sim.hold.PlanPoint` at t [s] (the base plan's before the follow phase)."""
        t0 = self.follow_start
        if t < t0:
            return self._base.at(t)
        g = self._base.at(t0)
        s = self.sample(t)
        shift, yaw = (np.zeros(3), 0.0) if s is None else (s[1], s[3])
        phase = "follow" if t < self.phase_times()["follow"][1] else "hold"
        return PlanPoint(g.centre + shift, yaw, g.radius, self.squeeze, True, True, phase)


class PathHoldController(HoldController):
    """:class:`~coop_ga.sim.HoldController` whose references follow a :class:`PathCarryPlan` (module docstring):
    in the follow and hold phases the nullspace posture target is the plan's q_p(t) and the tools' axis targets
    turn with the planned grasp frame; everything else (the squeeze admittance, the weight estimate, the task law)
    is the hold controller's."""

    _t = 0.0

    def __call__(self, t: float, q: np.ndarray, qd: np.ndarray, sensors: Any) -> np.ndarray:
        self._t = t
        s = self.plan.sample(t)
        if s is not None and self._squeeze_started:
            self.q_post = s[0]
        return super().__call__(t, q, qd, sensors)

    def _axis_target(self, i: int, ref: PlanPoint) -> np.ndarray:
        a = super()._axis_target(i, ref)
        s = self.plan.sample(self._t)
        if s is None:
            return a
        b = s[2] @ a  # turned with the planned grasp frame; _axis_rows turns its target by the yaw: undo it here
        c, sn = math.cos(ref.yaw), math.sin(ref.yaw)
        b = np.array([c * b[0] + sn * b[1], -sn * b[0] + c * b[1], b[2]])
        return b / np.linalg.norm(b)


# ====================================================================== the pipeline
@dataclass
class Grasp:
    """The measured grasp: the carry ``setup`` (its scene with the shelf), the ``shelf``, the configuration ``q``
    (nq,) and the box pose (``box_R`` (3, 3), ``box_centre`` (3,) [m]) at the end of the squeeze (time ``t``)."""

    setup: CarrySetup
    shelf: Shelf
    q: np.ndarray
    box_R: np.ndarray
    box_centre: np.ndarray
    t: float

    @property
    def box_half(self) -> np.ndarray:
        s = self.setup
        return np.array([s.box_half, s.box_half, 0.5 * BOX_HEIGHT])


def execution_gains(posture: float = POSTURE, wrist_posture: float = WRIST_POSTURE) -> HoldGains:
    """The carry's :func:`~coop_ga.sim.carry.default_gains` with a stiffer nullspace posture (joints 1–4:
    ``posture``, 5–7: ``wrist_posture`` [1/s²]): the posture target is the plan's joint trajectory, and with the
    carry's 10 /s² against the wrists' 40 /s damping the tool roll lagged its reference by 0.77 rad."""
    g = default_gains()
    K, D = np.array(g.K, float), np.array(g.D, float)
    K[4:7], D[4:7] = TRANSLATION_K, 2.0 * math.sqrt(TRANSLATION_K)
    return replace(g, K=K, D=D, K_post=np.tile([posture] * 4 + [wrist_posture] * 3, 3))


def _controller(setup: CarrySetup, plan_: PathCarryPlan, gains: HoldGains | None) -> PathHoldController:
    return PathHoldController(
        setup.scene, setup.task, plan_, gains or execution_gains(), q_start=setup.q_start, q_grasp=setup.q_grasp
    )


def execution_setup(case: CarryCase | None = None, gains: HoldGains | None = None) -> tuple[CarrySetup, Shelf]:
    """The carry's setup (:func:`~coop_ga.sim.carry.carry_setup`, ``FAST_DURATIONS``) with the shelf lip added
    to its scene as static spheres, and the :class:`Shelf`."""
    case = case or CarryCase("plan_execute", durations=FAST_DURATIONS)
    st = carry_setup(case, gains or execution_gains())
    shelf = Shelf.over(st.box_centre, (st.box_half, st.box_half, 0.5 * BOX_HEIGHT))
    return replace(st, scene=with_static(st.scene, shelf.objects())), shelf


def grasp(case: CarryCase | None = None, gains: HoldGains | None = None) -> Grasp:
    """Simulate the grasp (approach, close, squeeze) in :func:`execution_setup`'s scene and measure it."""
    st, shelf = execution_setup(case, gains)
    p = PathCarryPlan.make(st.plan, None)
    sim = Simulation(st.scene, _controller(st, p, gains), q=st.q_start)
    sim.run(p.follow_start)
    R, b = _box_pose(sim)
    return Grasp(st, shelf, sim.q.copy(), R, b, sim.time)


def _box_pose(sim: Simulation) -> tuple[np.ndarray, np.ndarray]:
    from ._mujoco import mj

    pos, quat = sim.object_pose("box")
    R = np.empty(9)
    mj().mju_quat2Mat(R, np.asarray(quat, float))
    return R.reshape(3, 3), np.asarray(pos, float).copy()


@dataclass
class Lift:
    """The lift to plan: the ``problem`` from the top of the ``lift_off`` (k, nq) (the straight lift-off from the
    measured grasp, :func:`lift_off`), ``centre`` (3,) [m] the circle's centre at the grasp (the goal region is
    relative to it), and ``region``, the goal region the run is measured against (the problem's goal is its
    inner part, :data:`GOAL_MARGIN`)."""

    problem: PlanningProblem
    lift_off: np.ndarray
    centre: np.ndarray
    region: Region


def lift_off(g: Grasp, height: float = LIFT_OFF, step: float = 0.005) -> np.ndarray:
    """(k + 1, nq) configurations from the grasp ``g.q`` lifting the end points straight up by ``height`` [m] in
    ``step`` s, each projected (bounded Gauss–Newton, exact point Jacobians) from the one before: the box leaves
    the table vertically before the planned path moves it sideways (sideways on the table, its friction
    tilts the held box).

    Raises:
        InfeasibleConstraintsError: a projection failed (the lift-off is out of reach).
    """
    from ..plan import project
    from ..plan.box_lift import EndPointTargets

    st = g.setup
    P = st.task.points(g.q)
    out = [g.q]
    for h in np.linspace(step, height, max(1, round(height / step))):
        pr = project(EndPointTargets(st.system, st.task.end_frames, P + [0.0, 0.0, h]), st.system, out[-1], tol=1e-10)
        if not pr.converged:
            raise InfeasibleConstraintsError(f"the lift-off is out of reach at {h * 100:.1f} cm: {pr.message}")
        out.append(pr.q)
    return np.array(out)


def lift_problem(g: Grasp) -> Lift:
    """The planning problem from the top of the lift-off above the measured grasp (module docstring, step 2)."""
    st = g.setup
    task, system = st.task, st.system
    up = lift_off(g)
    P = task.points(g.q)
    table = Plane(np.array([0.0, 0.0, 1.0]), float(st.table_top), name="table")
    spheres = g.shelf.spheres()
    box = CarriedBox(g.box_half, g.box_R, g.box_centre, P, (*spheres, table))
    c0 = readout(task, g.q).centre
    lo = c0 + np.array([-GOAL_TOL_XY, GOAL_SHIFT[0], LIFT - GOAL_TOL_Z])
    hi = c0 + np.array([GOAL_TOL_XY, GOAL_SHIFT[1], LIFT + GOAL_TOL_Z])
    z = [0.0, 0.0, 1.0]
    inset = 0.5 * GOAL_MARGIN * (hi - lo)
    problem = PlanningProblem(
        system=system,
        q_start=up[-1],
        path_constraint=RigidGrasp(task, up[-1]),
        goal=Region(task, lo + inset, hi - inset, cone_axis=z, cone_angle=TILT),
        collision=CollisionModel(system, spheres),
        carried=box,
        path_region=Region(task, cone_axis=z, cone_angle=PATH_TILT),
        clearance=CLEARANCE,
    )
    return Lift(problem, up, c0, Region(task, lo, hi, cone_axis=z, cone_angle=TILT))


def plan_lift(lift: Lift, seed: int, options: PlannerOptions | None = None) -> tuple[PlanResult, Any]:
    """Plan the lift (OMPL, ``seed``) and time it: the lift-off and the plan each by TOPP-RA (from rest to rest,
    :data:`SPEED` × the velocity limits, :data:`ACCELERATION`) with a :data:`DWELL` at the top of the lift-off
    (the hold controller's weight estimate settles before the box moves sideways).  Returns ``(result, Timed)``
    (the timing None when the plan failed)."""
    from ..plan.timing import Timed, time_parameterise

    problem = lift.problem
    r = plan(problem, options or EXECUTION_OPTIONS, seed=seed)
    if not r.success:
        return r, None
    lim = problem.system.with_limits(acceleration=ACCELERATION).limits
    dt = 0.002
    a = time_parameterise(lift.lift_off, lim, velocity_scale=SPEED, dt=dt)
    b = time_parameterise(r.path, lim, velocity_scale=SPEED, dt=dt)
    t_dwell = np.arange(dt, DWELL, dt)
    z = np.zeros((len(t_dwell), a.q.shape[1]))
    t1 = a.duration + DWELL
    return r, Timed(
        np.concatenate((a.t, a.duration + t_dwell, t1 + b.t)),
        np.vstack((a.q, z + a.q[-1], b.q)),
        np.vstack((a.qd, z, b.qd)),
        np.vstack((a.qdd, z, b.qdd)),
        t1 + b.duration,
        max(a.velocity_excess, b.velocity_excess),
        max(a.acceleration_excess, b.acceleration_excess),
    )


def run_execution(
    g: Grasp, timed: Any, gains: HoldGains | None = None, *, progress: bool = False
) -> tuple[CarryRun, PathCarryPlan]:
    """Simulate the grasp and the timed path from t = 0 (module docstring, step 4)."""
    st = g.setup
    ref = PathReference.from_path(st.task, timed.t, timed.q)
    p = PathCarryPlan.make(st.plan, ref)
    ctl = _controller(st, p, gains)
    sim = Simulation(st.scene, ctl, q=st.q_start)
    log = sim.run(p.duration, progress=progress)
    return CarryRun(replace(st, plan=cast(Any, p), controller=ctl), log, ctl.trace()), p


# ====================================================================== measurements
def shelf_contacts(scene: Scene, log: SimulationLog, stride: int = 10) -> dict[str, Any]:
    """MuJoCo's view of the shelf over the log: ``contacts`` (rows with any contact of a shelf geom, every row),
    ``clearance_m`` the smallest ``mj_geomDistance`` between a shelf geom and any colliding geom of the robots or
    the box (every ``stride``-th row), and the geom it was measured to."""
    from ._mujoco import mj

    m = scene.model
    d = mj().MjData(m)
    shelf = {scene.id_of("geom", f"{o.name}_geom") for o in scene.objects if o.name.startswith("shelf")}
    static = {scene.object_ids[o.name] for o in scene.objects if o.static} | {0}
    others = [
        g for g in range(m.ngeom)
        if int(m.geom_bodyid[g]) not in static and (m.geom_contype[g] or m.geom_conaffinity[g])
    ]  # fmt: skip
    rows, best, near = 0, math.inf, -1
    for k in range(len(log.time)):
        d.qpos[:], d.qvel[:] = log.qpos[k], log.qvel[k]
        mj().mj_forward(m, d)
        c = d.contact
        if d.ncon and any(int(c.geom1[i]) in shelf or int(c.geom2[i]) in shelf for i in range(d.ncon)):
            rows += 1
        if k % stride == 0:
            for s in shelf:
                for g in others:
                    dist = float(mj().mj_geomDistance(m, d, s, g, 0.5, None))
                    if dist < best:
                        best, near = dist, g
    return {"contact_rows": rows, "clearance_m": best, "nearest_geom": scene.contact_name(near) if near >= 0 else ""}


def _tracking(run: CarryRun, p: PathCarryPlan, stride: int = 10) -> dict[str, float]:
    """The joint reference's tracking error from the follow phase on (every joint; joints 1–4 of each arm, which
    place the pads and the elbows; the wrists 5–7) [rad], and the pads' distance from the planned pads [m]
    (every ``stride``-th row)."""
    t = run.log.time
    rows = np.flatnonzero(t >= p.follow_start)
    q = run.log.q[rows]
    ref = np.array([p.sample(float(tk))[0] for tk in t[rows]])  # type: ignore[index]
    e = np.abs(q - ref).reshape(len(rows), -1, 7)
    task = run.setup.task
    dp = [np.max(np.linalg.norm(task.points(q[k]) - task.points(ref[k]), axis=1)) for k in range(0, len(rows), stride)]
    return {
        "tracking_max_rad": float(np.max(e)),
        "tracking_rms_rad": float(np.sqrt(np.mean(e**2))),
        "tracking_arm_max_rad": float(np.max(e[:, :, :4])),
        "tracking_wrist_max_rad": float(np.max(e[:, :, 4:])),
        "tracking_final_rad": float(np.max(e[-1])),
        "pad_tracking_max_m": float(np.max(dp)),
    }


def execution_metrics(run: CarryRun, p: PathCarryPlan, lift: Lift) -> dict[str, Any]:
    """The run's measured claims (module docstring); ``success`` = the box ends in the goal region (its
    displacement inside the region's, tilt ≤ 10°), not dropped, slip ≤ 5 mm per pad, no shelf contact, no
    joint-limit violation."""
    pos, R = box_state(run)
    t = run.log.time
    i0 = int(np.searchsorted(t, p.follow_start - 1e-9))
    region, c0 = lift.region, lift.centre
    lo, hi = region.lower - c0, region.upper - c0  # the region as a displacement
    disp = pos[-1] - pos[i0]
    tilt = np.degrees(np.arccos(np.clip(R[:, 2, 2], -1.0, 1.0)))
    slip = np.nanmax(slip_series(run, "follow"), axis=0)
    sh = shelf_contacts(run.setup.scene, run.log)
    q_end = run.log.q[-1]
    m: dict[str, Any] = {
        "box_displacement_m": disp.tolist(),
        "goal_displacement_lower_m": lo.tolist(),
        "goal_displacement_upper_m": hi.tolist(),
        "box_in_goal": bool(np.all(disp >= lo) and np.all(disp <= hi) and tilt[-1] <= math.degrees(TILT)),
        "goal_distance_m": float(np.linalg.norm(np.maximum(lo - disp, 0.0) + np.maximum(disp - hi, 0.0))),
        "circle_in_goal": bool(region.contains(q_end, tol=1e-9)),
        "tilt_max_deg": float(np.max(tilt[i0:])),
        "tilt_final_deg": float(tilt[-1]),
        "dropped": bool(disp[2] < 0.5 * LIFT),
        "slip_mm": (1e3 * slip).tolist(),
        "slip_max_mm": float(1e3 * np.max(slip)),
        "shelf_contact_rows": sh["contact_rows"],
        "shelf_clearance_m": sh["clearance_m"],
        "shelf_nearest": sh["nearest_geom"],
        "squeeze_min_N": float(np.min(run.trace["squeeze"][i0:])),
        "squeeze_max_N": float(np.max(run.trace["squeeze"][i0:])),
        "weight_estimate_kg": float(run.trace["weight_estimate"][-1]),
        "saturated_updates": int(run.log.saturated_updates),
        **limit_excursions(run),
        **_tracking(run, p),
    }
    fails = []
    if not m["box_in_goal"]:
        fails.append(f"box {m['goal_distance_m'] * 100:.1f} cm outside the goal region (tilt {tilt[-1]:.1f}°)")
    if m["dropped"]:
        fails.append(f"box dropped (rose {disp[2] * 100:.1f} cm)")
    if m["slip_max_mm"] > 5.0:
        fails.append(f"slip {m['slip_max_mm']:.1f} mm > 5 mm")
    if m["shelf_contact_rows"]:
        fails.append(f"shelf touched in {m['shelf_contact_rows']} steps")
    if m["max_limit_violation"] > 0.0:
        fails.append(f"joint limits left by {m['max_limit_violation']:.3g} rad")
    m["failures"], m["success"] = fails, not fails
    return m
