"""The Allegro hand holds a ball with the cooperative sphere of its four fingertips: scene, controller, run, metrics.

The fingertip counterpart of :mod:`coop_ga.sim.carry` (three arms, a box, the circle), built from the same
pieces: :func:`~coop_ga.sim.build_scene`, :func:`~coop_ga.sim.add_pads`, the squeeze admittance loop, the
weight estimator and the torque law of :class:`~coop_ga.sim.HoldController` (here
:class:`SphereHoldController`, which only swaps the task rows).  Nothing is welded: the ball is a free
body, contacts and gravity on.

Scene (:func:`ball_setup`)
--------------------------
* ``allegro`` (palm frame = world, gravity −z: the fingers point up, the thumb opposes from below); the
  fitted tip spheres (radius 1.2 cm, centred on the tip frames, the end points) are replaced by pads of
  the same size carrying the contact settings (:func:`~coop_ga.sim.add_pads`: ``condim`` 4, margin
  1 mm, ``solref`` (0.005, 1), elliptic cones, ``impratio`` 10, 10 no-slip iterations; friction = the
  ball's);
* joint damping 0.05 N m s/rad and no Coulomb friction instead of the URDF's 3–10 N m s/rad and
  5–12 N m (example-robot-data's allegro_right_hand; the real hand's motors give about 0.7 N m): the
  URDF's friction alone holds every finger still against any torque the controller commands, and its
  damping torque at 0.5 rad/s (1.5–5 N m) is three orders above a finger's inertial torque — integrated
  implicitly by MuJoCo it acts as an inertia ~1000× the link's, which a controller written with
  Pinocchio's M (no damping, no friction) cannot follow;
* the ball (radius = the grasp sphere's radius at ``allegro.q0`` minus the pad radius, 3.2 cm; mass and
  friction per :class:`BallCase`) starts resting on a thin static pedestal under the grasp sphere's
  centre, the fingers open (the sphere 8 mm wider);
* the plan (:class:`BallPlan`): close onto the ball, squeeze to the set-point, move the sphere's centre
  3 cm towards the palm and up (−x, +z: 1.8 cm off the pedestal; straight up is out of the fingers'
  reach within their joint limits — Gauss–Newton on the sphere does not converge there — and this heading
  keeps the most joint-limit margin of those tried), settle, tighten (twice the set-point) and loosen
  (back) through the e0∞ squeeze (its feed-forward wrench and the admittance loop), tighten and loosen
  again by Fig. 21's command — the sphere's dilation, 4 mm smaller and back, the squeeze loop paused —
  then hold while a 1 N force pushes the ball along ±x, ±y and ±z in turn (:func:`disturbances`).

:class:`SphereHoldController`: the task rows are J^G's dilation and translation rows (a sphere has no
rotation: its J^G rotation rows are 0) and, per fingertip, the two components of its direction from the
centre across the sphere (which J^G cannot see: a tip sliding on the sphere leaves it unchanged) —
4 + 2·4 = 12 rows for 16 joints, full row rank, so Λ = (J_a M⁻¹ J_aᵀ)⁻¹ (Eq 36) is exact.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property, lru_cache
from typing import Any, ClassVar

import numpy as np

from .. import validation
from ..errors import InvalidInputError
from .hold import HoldController, HoldGains, PhasedPlan, PlanPoint, circle_target, min_jerk
from .objects import Ball, Cylinder
from .scene import Scene, build_scene
from .simulation import Disturbance, Simulation, SimulationLog
from .tools import add_pads

__all__ = [
    "BALL_PHASES",
    "FAST_DURATIONS",
    "FULL_DURATIONS",
    "BallCase",
    "BallPlan",
    "BallRun",
    "BallSetup",
    "SphereHoldController",
    "ball_metrics",
    "ball_setup",
    "ball_state",
    "disturbances",
    "grasp_overlays",
    "run_ball",
    "slip_series",
]

SYSTEM = "allegro"
PAD_RADIUS, PAD_MARGIN = 0.012, 0.001  # [m] the fitted tip spheres' radius
OPEN = 0.008  # [m] the start sphere this much wider than the touching one
MOVE = (-0.024, 0.0, 0.018)  # [m] 3 cm towards the palm and up (off the pedestal; the most reachable heading)
FINGER_DAMPING, FINGER_FRICTION = 0.05, 0.0  # [N m s/rad], [N m] (module docstring)
PEDESTAL_RADIUS, PEDESTAL_LENGTH = 0.008, 0.06  # [m]
#: the phases of a :class:`BallPlan`, in order; ``disturb`` is split into one window per push
BALL_PHASES = ("close", "squeeze", "move", "settle", "tighten", "loosen", "dilate", "undilate", "disturb")
#: the pushes of the disturb phase, in order (unit directions of the 1 N force, world frame)
PUSHES = (
    ("+x", (1, 0, 0)),
    ("-x", (-1, 0, 0)),
    ("+y", (0, 1, 0)),
    ("-y", (0, -1, 0)),
    ("+z", (0, 0, 1)),
    ("-z", (0, 0, -1)),
)
BETA_ROWS = slice(3, 7)  # e0∞, e1∞, e2∞, e3∞ of a similarity 7-vector
FULL_DURATIONS = (0.4, 0.4, 0.8, 0.3, 0.5, 0.5, 0.5, 0.5, 2.4)
FAST_DURATIONS = (0.25, 0.25, 0.5, 0.2, 0.3, 0.3, 0.3, 0.3, 1.2)


# ====================================================================== the plan
@dataclass(frozen=True)
class BallPlan(PhasedPlan):
    """Close, squeeze, move, tighten, loosen, dilate, undilate, hold under pushes (module docstring), for
    :class:`SphereHoldController`.

    Args:
        centre: (3,) the sphere's centre at the grasp [m] (the ball's centre).
        radius_touch: sphere radius [m] at which the tips touch the ball; the close phase ends ``press`` [m]
            inside it.
        radius_open: the start radius [m].
        squeeze: set-point s_d [N]; ``tighten``: the set-point [N] the tighten phase ramps to (and the loosen
            phase back from).
        move: (3,) [m] the centre's translation over the move phase.
        dilation: [m] the sphere's radius shrinks by this over the dilate phase and regrows over undilate
            (Fig. 21's dilation command, now with contact), the squeeze loop paused (its offset and the
            feed-forward of the set-point held).
        directions: (n, 3) each tip's unit direction from the centre at the grasp (the tangential rows' target).
        durations: seconds per phase of :data:`BALL_PHASES`.
    """

    phases: ClassVar[tuple[str, ...]] = BALL_PHASES
    centre: Any
    radius_touch: float
    radius_open: float
    squeeze: float
    tighten: float
    directions: Any
    move: Any = MOVE
    durations: tuple[float, ...] = FULL_DURATIONS
    press: float = 0.001
    dilation: float = 0.004
    # fields HoldController reads from a plan
    angles: Any = None
    tool_pitch: float | None = None
    start: tuple[Any, float] | None = field(default=None)

    def __post_init__(self) -> None:
        object.__setattr__(self, "centre", validation.vector(self.centre, 3, "centre"))
        object.__setattr__(self, "move", validation.vector(self.move, 3, "move"))
        validation.positive(self.radius_touch, "radius_touch")
        if not validation.positive(self.radius_open, "radius_open") > self.radius_touch:
            raise InvalidInputError("radius_open must be larger than radius_touch (the tips start clear of the ball)")
        validation.nonnegative(self.squeeze, "squeeze")
        validation.nonnegative(self.tighten, "tighten")
        u = validation.array(self.directions, "directions")
        if u.ndim != 2 or u.shape[1] != 3 or not np.allclose(np.linalg.norm(u, axis=1), 1.0, atol=1e-9):
            raise InvalidInputError(f"directions must be (n, 3) unit vectors, got shape {u.shape}")
        object.__setattr__(self, "directions", u)
        self._check_durations()

    def at(self, t: float) -> PlanPoint:
        """The :class:`~coop_ga.sim.PlanPoint` at time t [s] (yaw 0; after the end: the final point)."""
        s = {k: min_jerk((t - a) / (b - a)) for k, (a, b) in self._times.items()}
        r_in = self.radius_touch - self.press
        pt = self._times
        sq = self.squeeze * s["squeeze"] + (self.tighten - self.squeeze) * (s["tighten"] - s["loosen"])
        return PlanPoint(
            centre=self.centre + self.move * s["move"],
            yaw=0.0,
            radius=self.radius_open
            + (r_in - self.radius_open) * s["close"]
            - self.dilation * (s["dilate"] - s["undilate"]),
            squeeze=sq,
            admittance=t >= pt["squeeze"][0] and not pt["dilate"][0] <= t < pt["undilate"][1],
            estimate=t >= pt["move"][0],
            phase=next((name for name in BALL_PHASES if t < pt[name][1]), BALL_PHASES[-1]),
        )

    def push_windows(self) -> list[tuple[str, np.ndarray, float, float]]:
        """(name, unit direction (3,), start, stop [s]) of each push of the disturb phase (:data:`PUSHES`):
        the phase split evenly, each push over the first 70 % of its slot (the rest lets the ball settle)."""
        a, b = self._times["disturb"]
        w = (b - a) / len(PUSHES)
        return [(n, np.array(d, float), a + k * w, a + (k + 0.7) * w) for k, (n, d) in enumerate(PUSHES)]


def disturbances(plan: BallPlan, force: float = 1.0, body: str = "ball") -> list[Disturbance]:
    """The pushes of ``plan`` (:meth:`BallPlan.push_windows`): ``force`` [N] on ``body`` at its centre of mass."""
    f = validation.nonnegative(force, "force")
    return [Disturbance(body, force=f * d, start=a, stop=b) for _, d, a, b in plan.push_windows()]


# ====================================================================== the controller
class SphereHoldController(HoldController):
    """:class:`~coop_ga.sim.HoldController` with the cooperative sphere (four end points; module docstring).

    Same arguments, loops and torque law (the squeeze admittance, the weight estimate and feed-forward, the
    posture in the nullspace); the task rows are J^G's β, t rows (4) and each tip's direction across the
    sphere (2 per tip: ``e_i = B_i (u_d,i − u_i)``, ``J_i = B_i (I − u_i u_iᵀ)(J_pi − J_c) / ρ_i``, B_i (2, 3)
    an orthonormal basis ⊥ u_d,i, ρ_i = |p_i − c|).  ``plan``: a :class:`BallPlan`.  Gains: ``K``/``D``
    entries 3–6 (e0∞, e1∞, e2∞, e3∞) and 7 (the direction rows); ``K_axis`` is unused.
    """

    primitive = "sphere"
    plan: BallPlan

    def _row_count(self) -> int:
        return 4 + 2 * self.n

    def _gain_vectors(self) -> tuple[np.ndarray, np.ndarray]:
        g, n = self.gains, self.n
        return (np.concatenate([g.K[3:7], np.full(2 * n, g.K[7])]), np.concatenate([g.D[3:7], np.full(2 * n, g.D[7])]))

    @cached_property
    def _bases(self) -> np.ndarray:
        """(n, 2, 3): per tip two unit vectors ⊥ its target direction (continuous: fixed at construction)."""
        out = np.empty((self.n, 2, 3))
        for i, u in enumerate(self.plan.directions):
            ref = np.eye(3)[int(np.argmin(np.abs(u)))]  # the world axis least aligned with u
            b1 = np.cross(u, ref)
            b1 /= np.linalg.norm(b1)
            out[i] = (b1, np.cross(u, b1))
        return out

    def _direction_rows(self, P: np.ndarray, Jps: list[np.ndarray], Jc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(J (2n, nq), error (2n,)) of the tips' directions from the centre (class docstring)."""
        c, U, B = self._centre, self.plan.directions, self._bases
        J = np.empty((2 * self.n, self.task.nq))
        e = np.empty(2 * self.n)
        for i in range(self.n):
            d = P[i] - c
            rho = float(np.linalg.norm(d))
            u = d / rho
            Bi = B[i]
            J[2 * i : 2 * i + 2] = (Bi - np.outer(Bi @ u, u)) @ (Jps[i] - Jc) / rho
            e[2 * i : 2 * i + 2] = Bi @ (U[i] - u)
        return J, e

    def __call__(self, t: float, q: np.ndarray, qd: np.ndarray, sensors: Any) -> np.ndarray:
        pin, model, data, task, g = self._pin, self.model, self.data, self.task, self.gains
        self._q = q
        st = task.evaluate(q)
        P, J, V = st.points, st.jacobian, st.coeffs
        ref = self.plan.at(t)
        wr = sensors.end_wrenches  # on the robot: the ball feels the negative
        s, w_obj, W_ff, r = self._measure(P, wr, ref.squeeze)
        self._update_loops(t, ref, s, w_obj)
        e, Je = task.error_and_jacobian(q, circle_target(ref.centre, ref.radius + self.dr))  # = T(c) D(ln r)
        bd, _ = self._target_rate(t, ref, V, r)
        M = pin.crba(model, data, q)
        M[self._iu[1], self._iu[0]] = M[self._iu]
        h = pin.nonLinearEffects(model, data, q, qd)
        Js, _ = self._frame_jacobians(q)
        Jc = r * (self._R @ J[4:7])  # ċ = r R b_t
        Jd, ed = self._direction_rows(P, [Jf[:3] for Jf in Js], Jc)
        Ja, err, derr, jdq = self._Ja, self._err, self._derr, self._jdq
        Ja[:4], Ja[4:] = J[BETA_ROWS], Jd
        err[:4], err[4:] = e[BETA_ROWS], ed
        derr[:4], derr[4:] = (Je @ qd + bd)[BETA_ROWS], -(Jd @ qd)
        jdq[:4] = task.jdot_qdot(q, qd)[BETA_ROWS]  # the direction rows' J̇ q̇ is neglected (slow motions)
        Kv, Dv = self._KD
        a0 = g.K_post * (self.q_post - q) - g.D_null * qd
        X = np.linalg.solve(M, Ja.T)
        tau = h + Ja.T @ np.linalg.solve(Ja @ X, Kv * err + Dv * derr - jdq - Ja @ a0) + M @ a0 + J.T @ W_ff
        row = (t, s, ref.squeeze, r, ref.radius + self.dr, w_obj[:3], w_obj[3:], self._centre)
        self._rows.append((*row, self.w_est[2] / self._g, e, 0.0, 0.0, P, -wr[:, :3], ref.phase))
        return tau


def default_gains() -> HoldGains:
    """Gains of the hand: ω = 60 rad/s on the sphere's rows and the tips' directions, critically damped (in
    newtons this is still soft — the stiffness is Λ K with the fingertips' small task inertia Λ: a 1 N push
    moves the held ball 1–2 mm, a 4 mm dilation adds 0.4 N of squeeze); the squeeze loop slower than on the
    arms (the pads are 1.2 cm, the ball 3.2 cm)."""
    k, d = 3600.0, 120.0
    return HoldGains(
        K=(0.0, 0.0, 0.0, k, k, k, k, k),
        D=(0.0, 0.0, 0.0, d, d, d, d, d),
        K_post=10.0,
        D_null=2.0,
        admittance=1e-3,
        v_max=0.02,
        dr_max=0.01,
        weight_tau=0.2,
    )


# ====================================================================== scenario
@dataclass(frozen=True)
class BallCase:
    """One run: ``name``, ball ``mass`` [kg], ``friction`` (ball and pads), ``squeeze`` set-point [N] and the
    ``tighten`` one [N], the push ``force`` [N], the phase ``durations`` [s]."""

    name: str = "nominal"
    mass: float = 0.3
    friction: float = 1.0
    squeeze: float = 4.0
    tighten: float = 8.0
    force: float = 1.0
    durations: tuple[float, ...] = FULL_DURATIONS

    def __post_init__(self) -> None:
        validation.positive(self.mass, "mass")
        validation.positive(self.friction, "friction")
        validation.nonnegative(self.squeeze, "squeeze")
        validation.nonnegative(self.tighten, "tighten")
        validation.nonnegative(self.force, "force")

    def describe(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "mass_kg": self.mass,
            "friction": self.friction,
            "squeeze_N": self.squeeze,
            "tighten_N": self.tighten,
            "push_N": self.force,
        }


@dataclass
class BallSetup:
    """Everything a run needs: the scene, task, plan, controller, start and grasp configurations, the ball."""

    case: BallCase
    system: Any
    scene: Scene
    task: Any
    plan: BallPlan
    controller: SphereHoldController
    q_start: np.ndarray
    q_grasp: np.ndarray
    ball_radius: float


@dataclass
class BallRun:
    """A finished run: its setup, the log, the controller's trace, the metrics."""

    setup: BallSetup
    log: SimulationLog
    trace: dict[str, np.ndarray]
    metrics: dict[str, Any] = field(default_factory=dict)


@lru_cache(maxsize=1)
def _system_and_task() -> tuple[Any, Any]:
    from .. import systems
    from ..cooperative import cooperative_task

    system = systems.load(SYSTEM)
    return system, cooperative_task(system, "sphere")


def _sphere_ik(task: Any, q0: Any, centre: np.ndarray, radius: float) -> np.ndarray:
    from ..control import gauss_newton_ik

    res = gauss_newton_ik(task, q0, circle_target(centre, radius))
    if not res.converged:
        raise InvalidInputError(f"the start sphere (radius {radius} m) is out of the hand's reach: {res.message}")
    return np.asarray(res.q, float)


def _scene(system: Any, case: BallCase, centre: np.ndarray, radius: float) -> Scene:
    from ..collision import fit_capsules

    fr = (case.friction, 0.005, 0.0001)
    ball = Ball(
        name="ball", radius=radius, mass=case.mass, pos=centre, friction=fr, condim=4, rgba=(0.9, 0.45, 0.2, 0.7)
    )
    top = centre[2] - radius  # the pedestal's top touches the ball's bottom
    pedestal = Cylinder(
        name="pedestal",
        radius=PEDESTAL_RADIUS,
        length=PEDESTAL_LENGTH,
        pos=(centre[0], centre[1], top - 0.5 * PEDESTAL_LENGTH),
        static=True,
        friction=fr,
        rgba=(0.45, 0.45, 0.5, 1.0),
    )
    # a fingertip grasp: the pads replace the tip spheres, and the bounding capsules of the distal and middle
    # phalanges (1.7 cm radius around each whole phalanx) are left out — at the grasp the distal ones reach
    # 1.3 cm into the ball (the thumb's into the palm) and the middle ones touch it before the tips do
    model = system.model
    distal = {model.frames[model.getFrameId(f)].parentJoint - k for f in system.end_frames for k in (0, 1)}
    capsules = [c for c in fit_capsules(system) if model.frames[model.getFrameId(c.frame)].parentJoint not in distal]
    scene = build_scene(
        system,
        objects=[ball, pedestal],
        floor=None,
        capsules=capsules,
        damping=FINGER_DAMPING,
        frictionloss=FINGER_FRICTION,
    )
    return add_pads(scene, PAD_RADIUS, friction=fr, margin=PAD_MARGIN, solref=(0.005, 1.0), noslip_iterations=10)


def ball_setup(case: BallCase, gains: HoldGains | None = None) -> BallSetup:
    """Build the scene, plan and controller of ``case`` (module docstring); raises like
    :class:`~coop_ga.sim.HoldController` if a squeeze set-point exceeds the hand's capacity at the grasp."""
    system, task = _system_and_task()
    q_grasp = np.asarray(system.q0, float)
    st = task.evaluate(q_grasp)
    centre, r_grasp = np.array(st.log[4:7]), float(np.exp(st.log[3]))
    u = (st.points - centre) / np.linalg.norm(st.points - centre, axis=1)[:, None]
    radius = r_grasp - PAD_RADIUS
    plan = BallPlan(
        centre=centre,
        radius_touch=r_grasp,
        radius_open=r_grasp + OPEN,
        squeeze=case.squeeze,
        tighten=case.tighten,
        directions=u,
        durations=case.durations,
    )
    scene = _scene(system, case, centre + np.array([0.0, 0.0, 1e-5]), radius)
    q_start = _sphere_ik(task, q_grasp, centre, r_grasp + OPEN)
    ctl = SphereHoldController(scene, task, plan, gains or default_gains(), q_start=q_start, q_grasp=q_grasp)
    ctl.check_squeeze(q_grasp, squeeze=case.tighten)  # the tightened set-point too
    return BallSetup(case, system, scene, task, plan, ctl, q_start, q_grasp, radius)


def run_ball(
    case: BallCase, *, gains: HoldGains | None = None, duration: float | None = None, progress: bool = False
) -> BallRun:
    """Simulate ``case`` with its pushes (for the plan's duration, or ``duration`` [s]) and measure it
    (:func:`ball_metrics`, only for a whole run)."""
    st = ball_setup(case, gains)
    sim = Simulation(st.scene, st.controller, q=st.q_start, disturbances=disturbances(st.plan, case.force))
    log = sim.run(st.plan.duration if duration is None else duration, progress=progress)
    run = BallRun(st, log, st.controller.trace())
    if duration is None:
        run.metrics = ball_metrics(run)
    return run


# ====================================================================== measurements
def ball_state(run: BallRun) -> tuple[np.ndarray, np.ndarray]:
    """(positions (T, 3), rotation matrices (T, 3, 3)) of the ball over the log."""
    from ._mujoco import mj

    a = run.setup.scene.object_qpos["ball"]
    quat = run.log.qpos[:, a + 3 : a + 7]
    R = np.empty((len(quat), 9))
    for k, qk in enumerate(quat):
        mj().mju_quat2Mat(R[k], qk)
    return run.log.qpos[:, a : a + 3], R.reshape(-1, 3, 3)


def _rows(run: BallRun, a: float, b: float) -> np.ndarray:
    t = run.trace["time"]
    return np.flatnonzero((t >= a - 1e-9) & (t < b - 1e-9))


def slip_series(run: BallRun, start: float) -> np.ndarray:
    """(T, n) tangential displacement [m] of each tip on the ball's surface (ball frame) from its place at time
    ``start`` [s] (NaN before): the part of Rᵀ(p − b) − its value then that is ⊥ the surface normal then."""
    P = run.trace["points"]
    pos, R = ball_state(run)
    T = len(P)
    local = np.einsum("kji,knj->kni", R[:T], P - pos[:T, None, :])
    i0 = int(np.searchsorted(run.trace["time"], start - 1e-9))
    nrm = local[i0] / np.linalg.norm(local[i0], axis=1)[:, None]
    d = local - local[i0]
    d -= np.einsum("kni,ni->kn", d, nrm)[:, :, None] * nrm[None]
    out = np.linalg.norm(d, axis=2)
    out[:i0] = np.nan
    return out


def _pushes(run: BallRun, pos: np.ndarray) -> dict[str, float]:
    """Per push: the ball's largest displacement [mm] from where it was when the push started."""
    t = run.log.time
    out = {}
    for name, _, a, b in run.setup.plan.push_windows():
        k = np.flatnonzero((t >= a - 1e-9) & (t < b + 1e-9))
        out[name] = float(1e3 * np.max(np.linalg.norm(pos[k] - pos[k[0]], axis=1)))
    return out


def _squeeze_error(run: BallRun, windows: list[tuple[float, float]]) -> float:
    """Largest |s / s_d − 1| over the trace rows in ``windows`` [s]."""
    tr = run.trace
    k = np.concatenate([_rows(run, a, b) for a, b in windows])
    return float(np.max(np.abs(tr["squeeze"][k] / tr["squeeze_set"][k] - 1.0)))


def _squeeze_metrics(run: BallRun, pt: dict[str, tuple[float, float]]) -> dict[str, float]:
    """The squeeze and dilation entries of :func:`ball_metrics` (``pt``: the plan's phase times [s])."""
    tr = run.trace

    def tail(name: str, frac: float) -> tuple[float, float]:
        a, b = pt[name]
        return b - frac * (b - a), b

    hold_windows = [
        tail("settle", 0.6),
        tail("tighten", 0.4),
        tail("loosen", 0.4),
        tail("undilate", 0.3),
        pt["disturb"],
    ]
    rd, i_tight, i_loose = tr["radius_target"], _rows(run, *pt["tighten"]), _rows(run, *pt["loosen"])
    return {
        "squeeze_error_hold": _squeeze_error(run, hold_windows),
        "squeeze_tight_N": float(np.mean(tr["squeeze"][_rows(run, *tail("tighten", 0.3))])),
        "squeeze_loose_N": float(np.mean(tr["squeeze"][_rows(run, *tail("loosen", 0.3))])),
        "dilation_tight_mm": float(1e3 * (rd[i_tight[0]] - rd[i_tight[-1]])),
        "dilation_loose_mm": float(1e3 * (rd[i_loose[-1]] - rd[i_loose[0]])),
        "dilated_squeeze_N": float(np.mean(tr["squeeze"][_rows(run, *tail("dilate", 0.3))])),
        "undilated_squeeze_N": float(np.mean(tr["squeeze"][_rows(run, *tail("undilate", 0.3))])),
    }


def ball_metrics(run: BallRun) -> dict[str, Any]:
    """The run's measured claims (lengths [m] unless named _mm, forces [N]):

    * ``dropped``: the ball ended more than 1 cm from the sphere's planned centre, or a tip lost contact
      (no force) at any update from the move's start on; ``min_tip_force_N``: the smallest tip contact
      force over that time;
    * ``move_m``: the ball's displacement over the move and settle phases (planned: 3 cm up), ``move_error_m``:
      |that − the planned move|; ``off_pedestal_m``: the ball's lowest height above the pedestal after the move;
    * ``push_displacement_mm``: per push (±x, ±y, ±z, 1 N) the ball's largest displacement from where it was
      when the push began; ``push_displacement_max_mm``;
    * ``slip_mm`` (n,): each tip's largest tangential displacement on the ball's surface (ball frame) from
      the end of the squeeze phase to the end; ``slip_max_mm``;
    * squeeze: ``squeeze_error_hold`` the largest |s/s_d − 1| over the last 60 % of the settle phase, the
      last 40 % of the tighten and loosen phases (after each ramp) and the whole disturb phase;
      ``squeeze_tight_N`` (the mean measured squeeze over the last 30 % of tighten, set-point ``tighten``),
      ``squeeze_loose_N`` (the same over the last 30 % of loosen); ``dilation_tight_mm``: how much the
      squeeze loop closed the sphere's target radius (its dilation) from the start to the end of tighten,
      ``dilation_loose_mm`` how much it reopened it over loosen; the dilation command: ``dilated_squeeze_N``
      (the mean squeeze over the last 30 % of dilate, the sphere ``plan.dilation`` smaller),
      ``undilated_squeeze_N`` (the same over undilate's), ``dilation_stiffness_N_per_mm`` (the squeeze
      gained per mm of dilation over the loosened level);
    * ``weight_estimate_kg``: at the start of the disturb phase; saturation counts; ``success``: not
      dropped, moved within 5 mm of the plan, every push displacing the ball ≤ 5 mm, slip ≤ 5 mm, the
      squeeze within ±25 % of its set-point in the hold windows (they include undilate's end: the loop
      paused, the sphere back to its size), the dilation command raising the squeeze.
    """
    st, tr = run.setup, run.trace
    pt = st.plan.phase_times()
    pos, _ = ball_state(run)
    t = tr["time"]
    after = _rows(run, pt["move"][0], math.inf)
    fmag = np.linalg.norm(tr["forces"], axis=2)
    plan_end = st.plan.at(pt["disturb"][1]).centre
    i_move0 = int(np.searchsorted(run.log.time, pt["move"][0] - 1e-9))
    i_settle1 = int(np.searchsorted(run.log.time, pt["settle"][1] - 1e-9))
    moved = pos[i_settle1] - pos[i_move0]
    pushes = _pushes(run, pos)
    slip = np.nanmax(slip_series(run, pt["squeeze"][1])[after], axis=0)
    dropped = bool(np.linalg.norm(pos[-1] - plan_end) > 0.01 or np.min(fmag[after]) < 1e-6)
    ped_top = st.plan.centre[2] - st.ball_radius
    m = {
        "case": st.case.describe(),
        "dropped": dropped,
        "min_tip_force_N": float(np.min(fmag[after])),
        "move_m": moved.tolist(),
        "move_error_m": float(np.linalg.norm(moved - st.plan.move)),
        "off_pedestal_m": float(
            np.min(pos[int(np.searchsorted(run.log.time, pt["settle"][0])) :, 2] - st.ball_radius - ped_top)
        ),
        "push_displacement_mm": pushes,
        "push_displacement_max_mm": max(pushes.values()),
        "slip_mm": (1e3 * slip).tolist(),
        "slip_max_mm": float(1e3 * np.max(slip)),
        **_squeeze_metrics(run, pt),
        "weight_estimate_kg": float(tr["weight_estimate"][min(int(np.searchsorted(t, pt["disturb"][0])), len(t) - 1)]),
        "saturated_updates": int(run.log.saturated_updates),
        "control_updates": int(run.log.control_updates),
        "effort_ratio": float(run.log.effort_ratio),
    }
    m["dilation_stiffness_N_per_mm"] = (m["dilated_squeeze_N"] - m["squeeze_loose_N"]) / (1e3 * st.plan.dilation)
    m["failures"] = _failures(m)
    m["success"] = not m["failures"]
    return m


def _failures(m: dict[str, Any]) -> list[str]:
    """What a run missed, in words."""
    out = []
    if m["dropped"]:
        out.append(
            f"dropped (a tip's contact force fell to {m['min_tip_force_N']:.2g} N, or the ball left the plan by > 1 cm)"
        )
    if m["move_error_m"] > 0.005:
        out.append(f"moved {1e3 * m['move_error_m']:.1f} mm off the planned 3 cm")
    if m["push_displacement_max_mm"] > 5.0:
        out.append(f"a {m['case']['push_N']:g} N push displaced the ball {m['push_displacement_max_mm']:.1f} mm > 5 mm")
    if m["slip_max_mm"] > 5.0:
        out.append(f"slip {m['slip_max_mm']:.1f} mm > 5 mm")
    if m["dilated_squeeze_N"] <= m["squeeze_loose_N"]:
        out.append("the dilation command did not raise the squeeze")
    if m["squeeze_error_hold"] > 0.25:
        out.append(f"squeeze off its set-point by {100 * m['squeeze_error_hold']:.0f} % > 25 %")
    return out


def grasp_overlays(run: BallRun, k: int) -> list[Any]:
    """Overlays of log row ``k`` for :func:`coop_ga.sim.render.render_log`: the cooperative sphere through the
    tips (translucent orange) and the squeeze part of each tip's force on the ball (blue arrows, 1 cm per N)."""
    from ..cooperative import cooperative_wrench
    from ..cooperative.primitive import cooperative_primitive
    from ..geometry.primitives import point as conformal_point
    from . import render

    tr = run.trace
    k = min(k, len(tr["time"]) - 1)
    P, F = tr["points"][k], tr["forces"][k]
    X = cooperative_primitive("sphere", [conformal_point(p) for p in P])
    D = cooperative_wrench(run.setup.task, P, -F).direction
    sq = float(np.sum(-F * D)) * D

    def sphere(scn: Any) -> None:
        render.add_primitive(scn, X, width=0.0015)

    def arrows(scn: Any) -> None:
        for p, f in zip(P, sq):
            render.add_force(scn, p, f, scale=0.01, width=0.003)

    return [sphere, arrows]
