"""Holding an object with the cooperative primitive in MuJoCo: the carry plan and the hold controller.

The controller (:class:`HoldController`, a :class:`~coop_ga.sim.Simulation` controller) is the
similarity impedance law of §3.6 (Eq 49–52, the "compensate" form of
:mod:`coop_ga.control.impedance`) driven by MuJoCo's robot state and end-point contact forces —
never by the object's pose — with what holding needs on top:

* **the points along the circle.**  The cooperative circle does not change when its points slide
  along it, so J^G cannot turn a held object about the circle's axis, nor say where on the object
  each point presses.  Each end point's angle φ_i about the circle's centre (world z: the circle
  stays within a few degrees of horizontal) is a task row, ``φ̇_i = t̂_iᵀ (ṗ_i − ċ) / ρ_i`` (t̂_i the
  horizontal tangent, ρ_i the horizontal distance from the centre c; J̇ q̇ of these rows neglected:
  the turns are slow), targets the plan's grasp angles turned by its yaw;
* **each tool's pointing** (2 rows per tool, :class:`HoldGains` ``K_axis``): a sphere pad is free to
  roll on the object — its centre, the end point, then moves on the surface without any sliding —
  and, as the arms fold, the wrists swing into the object; the rows hold the tool axes (turned by
  the plan's yaw).  The roll about the tool axis stays free (a full orientation task meets the
  iiwa's wrist singularity, joint 6 near 0, where that roll is the lost direction);
* **the squeeze on e0∞** (:mod:`coop_ga.cooperative.wrench`): a feed-forward ``𝒲 = −s_d n r e0∞``
  and an admittance loop on the dilation target: ``ṙ_d = k (s − s_d)`` (clipped to ±v_max, the
  offset to ±``dr_max``), s the measured squeeze.  In free space s = 0, so the circle closes at
  v_max until the pads press; in contact r_d settles where s = s_d.  With s_d = 0 the same loop
  backs the pads off until nothing presses (the control case);
* **the object's weight, estimated**: the object wrench w the end points exert (force, torque about
  c, from the contact forces, :func:`~coop_ga.cooperative.wrench_map`) is low-pass filtered (time
  constant ``weight_tau``) while the plan carries the object; its vertical force (clamped ≥ 0: the
  arms only lift) and its horizontal torques are fed forward as ``𝒲_ext`` (τ = J^Gᵀ 𝒲).  In a static
  hold w = the object's weight, so this is an integral action that removes the impedance's sag; the
  estimated mass ŵ_z / g is logged;
* **gravity and Coriolis compensation** of the robots (Pinocchio ``nonLinearEffects``), a nullspace
  posture ``K_post (q_post − q) − D_null q̇`` through the dynamically consistent projector (q_post:
  the start, then the configuration when the squeeze starts), and the Simulation's torque
  saturation at the URDF effort (counted there).

Torque (Eq 50–52) with the task J_a = [J^G without its e12 row (6); J_φ (n); the tools' pointing
(2n)] — for a circle the e12 row of J^G is a combination of the e13 and e23 rows (rank 6, Table 1),
so J_a has full row rank and Λ_a = (J_a M⁻¹ J_aᵀ)⁻¹ (Eq 36) is an exact inverse::

    a_d = K e + D ė          (e: log(Ṽ_Sc V_d) without e12, φ_d − φ, the pointing errors;
                              ė: J_e q̇ + the plan's twist (backward difference over one
                              update), φ̇_d − J_φ q̇, −ω_⊥)
    a_0 = K_post (q_post − q) − D_null q̇
    τ = h + J_aᵀ Λ_a (a_d − J̇_a q̇ − J_a a_0) + M a_0 + J^Gᵀ 𝒲_ff

:class:`CarryPlan`: approach → close → squeeze → lift → carry (translate, turn about the vertical
through the object's centre) → hold → lower → release → open, each phase a minimum-jerk profile.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import cached_property
from typing import Any, ClassVar

import numpy as np

from .. import validation
from ..algebra.multivector import Multivector
from ..cooperative.wrench import BETA, squeeze_capacity, wrench_map
from ..errors import CoopGAError, InvalidInputError
from ..geometry.groups import ROTOR_BLADES, SIMILARITY_BLADES, Similarity, rotor_matrix
from .scene import Scene

__all__ = [
    "PHASES",
    "TRACE_FIELDS",
    "CarryPlan",
    "HoldController",
    "HoldGains",
    "PhasedPlan",
    "PlanPoint",
    "circle_target",
    "min_jerk",
    "squeeze_admittance",
]

_ROTOR_INDEX = [SIMILARITY_BLADES.index(b) for b in ROTOR_BLADES]


# ====================================================================== the plan
def min_jerk(x: float) -> float:
    """Minimum-jerk profile 10x³ − 15x⁴ + 6x⁵ on x clipped to [0, 1]."""
    x = min(max(x, 0.0), 1.0)
    return x * x * x * (10.0 + x * (-15.0 + 6.0 * x))


def squeeze_admittance(offset: float, s: float, s_d: float, dt: float, k: float, v_max: float, dr_max: float) -> float:
    """One step of the squeeze's admittance loop on a dilation target (module docstring): the ``offset`` [m]
    advanced by ``dt`` [s] at the rate ``k (s − s_d)`` [m/s] (s the measured squeeze, s_d its set-point [N], k
    [m/(N s)]) clipped to ±``v_max`` [m/s], the offset clipped to ±``dr_max`` [m].  Pressing harder than s_d
    opens the target (positive offset), pressing less closes it."""
    v = min(max(k * (s - s_d), -v_max), v_max)
    return min(max(offset + dt * v, -dr_max), dr_max)


#: the phases of a :class:`CarryPlan`, in order
PHASES = ("approach", "close", "squeeze", "lift", "carry", "hold", "lower", "release", "open")


@dataclass(frozen=True)
class PlanPoint:
    """The plan at one time: ``centre`` (3,) [m] of the circle, ``yaw`` [rad] of the end points about it,
    ``radius`` [m] (before the admittance offset), ``squeeze`` set-point [N], ``admittance`` and
    ``estimate`` (whether the squeeze loop and the weight estimator run), ``phase`` (a name of :data:`PHASES`),
    ``approach`` ∈ [0, 1] (the approach's progress)."""

    centre: np.ndarray
    yaw: float
    radius: float
    squeeze: float
    admittance: bool
    estimate: bool
    phase: str
    approach: float = 1.0


class PhasedPlan:
    """A plan made of named phases run one after the other: the ``phases`` (class attribute) last ``durations``
    [s] each (a field of the dataclass that mixes this in; :class:`CarryPlan`, :class:`coop_ga.sim.ball.BallPlan`)."""

    phases: ClassVar[tuple[str, ...]] = ()
    durations: tuple[float, ...]

    def _check_durations(self) -> None:
        d = tuple(validation.positive(x, "durations") for x in self.durations)
        if len(d) != len(self.phases):
            raise InvalidInputError(f"durations must give {len(self.phases)} phases {self.phases}, got {len(d)}")
        object.__setattr__(self, "durations", d)

    @property
    def duration(self) -> float:
        """Total duration [s]."""
        return float(sum(self.durations))

    def phase_times(self) -> dict[str, tuple[float, float]]:
        """``{phase: (start, end)}`` [s]."""
        return dict(self._times)

    @cached_property
    def _times(self) -> dict[str, tuple[float, float]]:
        out, t = {}, 0.0
        for name, d in zip(self.phases, self.durations):
            out[name] = (t, t + d)
            t += d
        return out


@dataclass(frozen=True)
class CarryPlan(PhasedPlan):
    """Grasp, lift, carry and put down an object with the cooperative circle (module docstring).

    Args:
        centre: (3,) circle centre at the grasp, object resting [m].
        object_centre: (3,) the object's centre at the grasp [m] (the pivot of the turn).
        radius_touch: circle radius [m] at which the pads touch the object (r_touch); the close phase
            ends ``press`` [m] inside it.
        radius_open: pre-grasp radius [m] (approach and open).
        squeeze: internal-force set-point s_d [N] (0: the control case).
        lift: [m]; shift: (3,) horizontal carry [m]; yaw: turn about the vertical [rad].
        durations: seconds per phase of :data:`PHASES`.
        lower_extra: [m] the lower phase ends this much below the grasp height (the object lands).
        angles: (n,) [rad] the end points' angles about the centre at the grasp (world x towards y;
            None: their angles at the start configuration); the carry turns them by ``yaw``.
        tool_pitch: [rad] the tools point horizontally at the circle's centre raised by this angle
            (None: they keep their axes of the start configuration); the approach turns them there and
            the carry turns them by ``yaw``.
        start: (centre (3,), radius) of the circle at t = 0 (set by the controller from the state).
    """

    phases: ClassVar[tuple[str, ...]] = PHASES
    centre: Any
    object_centre: Any
    radius_touch: float
    radius_open: float
    squeeze: float
    lift: float = 0.15
    shift: Any = (0.0, -0.2, 0.0)
    yaw: float = math.radians(20.0)
    durations: tuple[float, ...] = (1.5, 0.5, 0.5, 1.5, 2.5, 0.5, 1.5, 0.5, 0.5)
    press: float = 0.002
    lower_extra: float = 0.004
    angles: Any = None
    tool_pitch: float | None = None
    start: tuple[Any, float] | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "centre", validation.vector(self.centre, 3, "centre"))
        object.__setattr__(self, "object_centre", validation.vector(self.object_centre, 3, "object_centre"))
        object.__setattr__(self, "shift", validation.vector(self.shift, 3, "shift"))
        validation.positive(self.radius_touch, "radius_touch")
        if not validation.positive(self.radius_open, "radius_open") > self.radius_touch:
            raise InvalidInputError("radius_open must be larger than radius_touch (the pads start clear of the object)")
        validation.nonnegative(self.squeeze, "squeeze")
        self._check_durations()
        if self.angles is not None:
            a = validation.array(self.angles, "angles")
            if a.ndim != 1:
                raise InvalidInputError("angles must be one angle per end point [rad]")
            object.__setattr__(self, "angles", a)

    def at(self, t: float) -> PlanPoint:
        """The :class:`PlanPoint` at time t [s] (after the end: the final point)."""
        s = {k: min_jerk((t - a) / (b - a)) for k, (a, b) in self._times.items()}
        c0, r0 = (self.centre, self.radius_open) if self.start is None else self.start
        lift = self.lift * (s["lift"] - s["lower"]) - self.lower_extra * s["lower"]
        yaw = self.yaw * s["carry"]
        cy, sy = math.cos(yaw), math.sin(yaw)
        rel = self._rel
        a = s["approach"]
        k = 1.0 - a
        oc, sh = self.object_centre, self.shift
        sc = s["carry"]
        centre = np.array(
            [
                k * c0[0] + a * (oc[0] + cy * rel[0] - sy * rel[1] + sh[0] * sc),
                k * c0[1] + a * (oc[1] + sy * rel[0] + cy * rel[1] + sh[1] * sc),
                k * c0[2] + a * (oc[2] + rel[2] + sh[2] * sc + lift),
            ]
        )
        r_in = self.radius_touch - self.press
        radius = k * float(r0) + a * self.radius_open
        radius += (r_in - self.radius_open) * s["close"] + (self.radius_open - r_in) * s["open"]
        pt = self._times
        return PlanPoint(
            centre=centre,
            yaw=yaw,
            radius=radius,
            squeeze=self.squeeze * (s["squeeze"] - s["release"]),
            admittance=pt["squeeze"][0] <= t < pt["release"][1],
            estimate=pt["lift"][0] <= t < pt["release"][1],
            phase=next((name for name in PHASES if t < pt[name][1]), PHASES[-1]),
            approach=a,
        )

    @cached_property
    def _rel(self) -> np.ndarray:
        return self.centre - self.object_centre


# ====================================================================== the controller
_VD_INDEX = [SIMILARITY_BLADES.index(k) for k in (0, 17, 18, 20, 24)]  # 1, e0∞, e1∞, e2∞, e3∞


def circle_target(centre: Any, radius: float) -> Similarity:
    """V_d = T(centre) D(ln radius): the horizontal circle of ``radius`` [m] about ``centre`` (3,) [m] (normal +z,
    no rotation), built in closed form: ``cosh(β/2) + sinh(β/2) e0∞ − ½ (cosh(β/2) − sinh(β/2)) t e∞``
    (``= Similarity.exp([0, 0, 0, β, t])``, tested)."""
    b = 0.5 * math.log(radius)
    ch, sh = math.cosh(b), math.sinh(b)
    v = np.zeros(len(SIMILARITY_BLADES))
    v[_VD_INDEX] = (ch, sh, *(-0.5 * (ch - sh) * np.asarray(centre, float)))
    return Similarity(Multivector(SIMILARITY_BLADES, tuple(v.tolist())), check=False)


@dataclass(frozen=True)
class HoldGains:
    """Gains of :class:`HoldController` (acceleration level: through the task inertia Λ, Eq 36, 51).

    K, D: (8,) stiffness [1/s²] and damping [1/s] on ``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞, φ]`` (φ: each
        end point's angle about the circle's centre, module docstring); the
        e12 entries are unused (the e12 row of a circle's J^G is a combination of the e13 and e23 rows,
        so it is left out of the task; module docstring).
    K_axis, D_axis: stiffness and damping of each tool's pointing (its z axis; 2 rows per tool).  The
        circle and ψ leave each tool's rotation about its pad free: a sphere pad then rolls on the object
        (its centre, the end point, moves on the surface without sliding) and, as the arms fold, the
        wrists swing into the object; the pointing rows hold the tool axes (turned by the plan's yaw).
        The roll about the tool axis stays free (a full orientation task meets the iiwa's wrist
        singularity, joint 6 near 0, where that roll is the lost direction).
    K_post, D_null: nullspace posture stiffness and damping (scaled by M), one number or one per joint.
    admittance: k [m/(N s)] of the squeeze loop; v_max [m/s] its speed limit; dr_max [m] its range.
    weight_tau: time constant [s] of the weight estimator.
    """

    K: Any = (0.0, 150.0, 150.0, 150.0, 150.0, 150.0, 150.0, 100.0)
    D: Any = (0.0, 25.0, 25.0, 25.0, 25.0, 25.0, 25.0, 20.0)
    K_axis: float = 800.0
    D_axis: float = 56.0
    K_post: Any = 10.0
    D_null: Any = 10.0
    admittance: float = 2e-3
    v_max: float = 0.05
    dr_max: float = 0.05
    weight_tau: float = 0.3

    def __post_init__(self) -> None:
        for name in ("K", "D"):
            v = validation.vector(getattr(self, name), 8, name)
            if np.any(v < 0):
                raise InvalidInputError(f"{name} must be ≥ 0")
            object.__setattr__(self, name, v)
        for name in ("K_post", "D_null"):
            v = validation.array(getattr(self, name), name)
            if v.ndim > 1 or np.any(v < 0):
                raise InvalidInputError(f"{name} must be one number or one per joint, ≥ 0")
            object.__setattr__(self, name, v)
        for name in ("K_axis", "D_axis", "admittance", "v_max", "dr_max"):
            validation.nonnegative(getattr(self, name), name)
        validation.positive(self.weight_tau, "weight_tau")


#: the signals :meth:`HoldController.trace` returns
TRACE_FIELDS = (
    "time",
    "squeeze",
    "squeeze_set",
    "radius",
    "radius_target",
    "object_force",
    "object_torque",
    "centre",
    "weight_estimate",
    "error",
    "yaw",
    "yaw_target",
    "points",
    "forces",
    "phase",
)


class HoldController:
    """The hold controller of the module docstring, as a ``Simulation`` controller ``(t, q, q̇, sensors) → τ``.

    Args:
        scene: the :class:`Scene` (with pads: :func:`add_pads`).
        task: the cooperative circle task of ``scene.system`` (its end points are the pads' centres).
        plan: the :class:`CarryPlan` (a subclass's own plan: :attr:`primitive`).
        gains: :class:`HoldGains`.
        q_start: the configuration the run starts from (default ``system.q0``): the tools keep their
            orientation in it, turned by the plan's yaw.
        q_grasp: a configuration at the grasp (e.g. by IK); with it the squeeze set-point is checked
            against the force manipulability along e0∞ (:func:`~coop_ga.cooperative.squeeze_capacity`)
            before anything runs.
        capacity_margin: the set-point must be ≤ this fraction of the capacity.

    Raises:
        CoopGAError: the plan's squeeze exceeds the capacity at ``q_grasp`` (the arms cannot press that
            hard within their effort limits).

    After a run, :meth:`trace` returns the logged signals (one row per control update).
    Subclasses holding with another primitive (:class:`coop_ga.sim.ball.SphereHoldController`) set
    :attr:`primitive` and override :meth:`_row_count`, :meth:`_gain_vectors` and the update.
    """

    #: the cooperative primitive this controller holds with (the task's kind)
    primitive = "circle"

    def __init__(
        self,
        scene: Scene,
        task: Any,
        plan: Any,
        gains: HoldGains | None = None,
        *,
        q_start: Any = None,
        q_grasp: Any = None,
        capacity_margin: float = 0.8,
    ):
        import pinocchio as pin

        if task.system is not scene.system:
            raise InvalidInputError("the task must be a task of the scene's system")
        if task.primitive_kind != self.primitive:
            raise InvalidInputError(
                f"{type(self).__name__} needs a {self.primitive} task, got a {task.primitive_kind} task ({task.kind})"
            )
        self.scene, self.task, self.plan = scene, task, plan
        self.gains = gains or HoldGains()
        self.model = scene.system.model
        self.data = self.model.createData()
        self._pin = pin
        self.wmap = wrench_map(task)
        self.n = task.graph.n_points
        self.frames = [self.model.getFrameId(f) for f in task.end_frames]
        self.effort = np.asarray(scene.system.limits.effort, float)
        self._g = float(np.linalg.norm(scene.model.opt.gravity))  # [m/s²], for the mass estimate
        self.capacity: dict[str, float] | None = None
        if q_grasp is not None:
            self.capacity = self.check_squeeze(q_grasp, capacity_margin)
        q0 = np.array(scene.system.q0 if q_start is None else validation.configuration(q_start, task.nq, "q_start"))
        self.q_post = q0
        p0 = self.task.points(q0)
        d = p0 - p0.mean(axis=0)
        self._angles0 = np.arctan2(d[:, 1], d[:, 0]) if plan.angles is None else np.asarray(plan.angles, float)
        if self._angles0.shape != (self.n,):
            raise InvalidInputError(f"plan.angles must give {self.n} angles, got {self._angles0.shape}")
        pin.framesForwardKinematics(self.model, self.data, q0)
        self._axes0 = [self.data.oMf[f].rotation[:, 2].copy() for f in self.frames]
        self._iu = np.triu_indices(task.nq, 1)
        m = self._row_count()
        self._Ja = np.zeros((m, task.nq))
        self._err, self._derr, self._jdq = np.zeros(m), np.zeros(m), np.zeros(m)
        self._zero = np.zeros(task.nq)
        self._KD = self._gain_vectors()
        self.reset()

    def check_squeeze(self, q_grasp: Any, margin: float = 0.8, squeeze: float | None = None) -> dict[str, float]:
        """Check the squeeze set-point (default: the plan's) against the capacity at ``q_grasp`` (gravity of the
        robots included); returns :func:`~coop_ga.cooperative.squeeze_capacity`'s numbers, raises
        :class:`CoopGAError`."""
        q = validation.configuration(q_grasp, self.task.nq, "q_grasp")
        s_d = self.plan.squeeze if squeeze is None else validation.nonnegative(squeeze, "squeeze")
        g = self._pin.computeGeneralizedGravity(self.model, self.data, q)
        cap = squeeze_capacity(self.task, q, self.effort, bias=np.asarray(g))
        limit = validation.positive(margin, "capacity_margin") * cap["squeeze_max"]
        if s_d > limit:
            raise CoopGAError(
                f"squeeze set-point {s_d:g} N exceeds {margin:g} × the capacity at the grasp "
                f"({cap['squeeze_max']:.3g} N: joint '{self.scene.system.joint_names[int(cap['joint'])]}' reaches its "
                f"effort limit first; force manipulability along e0∞ {cap['ellipsoid']:.3g} N per unit torque norm); "
                "lower the set-point or grasp in a configuration with more force manipulability on e0∞"
            )
        return cap

    def reset(self) -> None:
        """Clear the controller's state (admittance offset, weight estimate, trace)."""
        self.dr = 0.0
        self.w_est = np.zeros(6)
        self._last_t: float | None = None
        self._squeeze_started = False
        self._prev: tuple[float, PlanPoint] | None = None
        self._rows: list[tuple[Any, ...]] = []

    # ------------------------------------------------------------------ pieces of one update
    def _frame_jacobians(self, q: np.ndarray) -> tuple[list[np.ndarray], list[np.ndarray]]:
        """World Jacobians (6, nq) of the end frames (linear; angular, LOCAL_WORLD_ALIGNED) and their rotations."""
        pin, model, data = self._pin, self.model, self.data
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        lwa = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        return [pin.getFrameJacobian(model, data, f, lwa) for f in self.frames], [
            data.oMf[f].rotation for f in self.frames
        ]

    def _axis_target(self, i: int, ref: PlanPoint) -> np.ndarray:
        """Tool i's target axis: the start axis, or (``plan.tool_pitch``) the plan's axis reached over the
        approach, turned by the plan's yaw."""
        a0 = self._axes0[i]
        if self.plan.tool_pitch is not None:
            p, phi = self.plan.tool_pitch, self._angles0[i]
            a1 = np.array([-math.cos(phi) * math.cos(p), -math.sin(phi) * math.cos(p), math.sin(p)])
            a0 = (1.0 - ref.approach) * a0 + ref.approach * a1
            a0 /= np.linalg.norm(a0)
        return a0

    def _axis_rows(self, i: int, Jw: np.ndarray, a: np.ndarray, ref: PlanPoint, qd: np.ndarray) -> tuple:
        """Tool i's pointing rows: (J (2, nq), error (2,), rate (2,)) about two axes u, v ⊥ its z axis a;
        the target axis (:meth:`_axis_target`) turned by the plan's yaw about the vertical."""
        c, s_ = math.cos(ref.yaw), math.sin(ref.yaw)
        a0 = self._axis_target(i, ref)
        ad = np.array([c * a0[0] - s_ * a0[1], s_ * a0[0] + c * a0[1], a0[2]])
        h = math.hypot(a[0], a[1])  # u: horizontal, ⊥ a (the tools point roughly horizontally); v = a × u
        u0, u1 = -a[1] / h, a[0] / h
        B = np.array([[u0, u1, 0.0], [-a[2] * u1, a[2] * u0, a[0] * u1 - a[1] * u0]])
        # the rotation taking a to a_d: a × a_d (|a × a_d| = sin of the angle)
        rot = np.array([a[1] * ad[2] - a[2] * ad[1], a[2] * ad[0] - a[0] * ad[2], a[0] * ad[1] - a[1] * ad[0]])
        J2 = B @ Jw
        return J2, B @ rot, -(J2 @ qd)

    def _angle_rows(self, P: np.ndarray, Js: list[np.ndarray], Jc: np.ndarray, c: np.ndarray, yaw: float):
        """Each end point's angle error about the circle's centre c: (J_φ (n, nq), φ_d − φ (n,)), the target
        φ_d = the plan's angle turned by ``yaw``; ``φ̇_i = t̂_iᵀ (ṗ_i − ċ) / ρ_i`` (horizontal tangent t̂_i,
        horizontal distance ρ_i)."""
        Jphi = np.empty((self.n, self.task.nq))
        err = np.empty(self.n)
        for i in range(self.n):
            d = P[i] - c
            Jp = Js[i]
            Jphi[i] = (d[0] * (Jp[1] - Jc[1]) - d[1] * (Jp[0] - Jc[0])) / (d[0] * d[0] + d[1] * d[1])
            a = self._angles0[i] + yaw - math.atan2(d[1], d[0])
            err[i] = math.atan2(math.sin(a), math.cos(a))
        return Jphi, err

    def _update_loops(self, t: float, ref: PlanPoint, s: float, w_obj: np.ndarray) -> None:
        dt = 0.0 if self._last_t is None else t - self._last_t
        self._last_t = t
        g = self.gains
        if ref.admittance:
            if not self._squeeze_started:
                self._squeeze_started = True
                self.q_post = self._q.copy()
            self.dr = squeeze_admittance(self.dr, s, ref.squeeze, dt, g.admittance, g.v_max, g.dr_max)
        if ref.estimate:
            self.w_est += (dt / g.weight_tau) * (w_obj - self.w_est)
        else:
            self.w_est[:] = 0.0

    def _feedforward(self) -> np.ndarray:
        """(6,) force and torque the arms exert to carry the estimated weight (vertical force ≥ 0, tilt torques)."""
        fz = max(float(self.w_est[2]), 0.0)
        tq = np.array([self.w_est[3], self.w_est[4], 0.0])
        lim = fz * self.plan.radius_touch  # a weight's torque about c is at most m g × the lever
        nt = float(np.linalg.norm(tq))
        if nt > lim:
            tq *= lim / nt
        return np.array([0.0, 0.0, fz, tq[0], tq[1], 0.0])

    def _measure(self, P: np.ndarray, wr: np.ndarray, squeeze: float) -> tuple[float, np.ndarray, np.ndarray, float]:
        """(squeeze s [N], object wrench (6,), feed-forward 𝒲_ff (7,), radius r) from the contact wrenches."""
        out = self.wmap.evaluate_views(
            P.reshape(-1), -wr[:, :3].reshape(-1), -wr[:, 3:].reshape(-1), self._feedforward(), squeeze
        )
        sl = self.wmap.slices
        self._centre = out[sl["centre"]].copy()
        return (
            float(out[sl["squeeze"]][0]),
            out[sl["object_wrench"]].copy(),
            out[sl["command"]].copy(),
            float(out[sl["radius"]][0]),
        )

    def _target_rate(self, t: float, ref: PlanPoint, V: np.ndarray, r: float) -> tuple[np.ndarray, float]:
        """The plan's body twist (7,) at t — β̇ = ṙ_d / r, t-rows Rᵀ ċ_d / r — and its turn rate ψ̇_d [rad/s],
        by the backward difference with the previous control update (0 at the first)."""
        Rq = V[_ROTOR_INDEX]
        R = np.array(rotor_matrix(tuple(Rq / np.linalg.norm(Rq))), float)
        self._R = R
        out = np.zeros(7)
        prev, self._prev = self._prev, (t, ref)
        if prev is None or t <= prev[0]:
            return out, 0.0
        dt, a = t - prev[0], prev[1]
        out[BETA] = (ref.radius - a.radius) / (dt * r)
        out[4:7] = R.T @ (ref.centre - a.centre) / (dt * r)
        return out, (ref.yaw - a.yaw) / dt

    def _row_count(self) -> int:
        """Rows of the task J_a: J^G without e12 (6), each end point's angle (n), each tool's pointing (2n)."""
        return 6 + 3 * self.n

    def _gain_vectors(self) -> tuple[np.ndarray, np.ndarray]:
        g, n = self.gains, self.n
        return (
            np.concatenate([g.K[1:7], np.full(n, g.K[7]), np.full(2 * n, g.K_axis)]),
            np.concatenate([g.D[1:7], np.full(n, g.D[7]), np.full(2 * n, g.D_axis)]),
        )

    # ------------------------------------------------------------------ one update
    def __call__(self, t: float, q: np.ndarray, qd: np.ndarray, sensors: Any) -> np.ndarray:
        pin, model, data, task, g, n = self._pin, self.model, self.data, self.task, self.gains, self.n
        self._q = q
        st = task.evaluate(q)
        P, J, V = st.points, st.jacobian, st.coeffs
        if self.plan.start is None:  # the approach starts where the circle is
            self.plan = replace(self.plan, start=(st.log[4:7].copy(), float(np.exp(st.log[BETA]))))
        ref = self.plan.at(t)
        wr = sensors.end_wrenches  # on the robot: the object feels the negative
        s, w_obj, W_ff, r = self._measure(P, wr, ref.squeeze)
        self._update_loops(t, ref, s, w_obj)
        r_d = ref.radius + self.dr
        e, Je = task.error_and_jacobian(q, circle_target(ref.centre, r_d))
        bd, yaw_rate = self._target_rate(t, ref, V, r)
        # dynamics (Eq 32) and the end frames' Jacobians
        M = pin.crba(model, data, q)
        M[self._iu[1], self._iu[0]] = M[self._iu]
        h = pin.nonLinearEffects(model, data, q, qd)
        Js, axes = self._frame_jacobians(q)
        Jc = r * (self._R @ J[4:7])  # ċ = r R b_t (body translation rows are in units of r)
        Jphi, ephi = self._angle_rows(P, [Jf[:3] for Jf in Js], Jc, self._centre, ref.yaw)
        psi = ref.yaw - float(ephi.mean())  # the mean turn of the end points
        # the rows: J^G without e12 (6), each end point's angle (n), each tool's pointing (2n)
        Ja, err, derr, jdq = self._Ja, self._err, self._derr, self._jdq
        n6 = 6 + n
        Ja[:6] = J[1:]
        Ja[6:n6] = Jphi
        err[:6] = e[1:]
        derr[:6] = (Je @ qd + bd)[1:]
        err[6:n6] = ephi
        derr[6:n6] = yaw_rate - Jphi @ qd
        jdq[:6] = task.jdot_qdot(q, qd)[1:]
        for i in range(n):
            k = n6 + 2 * i
            Ja[k : k + 2], err[k : k + 2], derr[k : k + 2] = self._axis_rows(i, Js[i][3:], axes[i][:, 2], ref, qd)
        Kv, Dv = self._KD
        a_d = Kv * err + Dv * derr
        a0 = g.K_post * (self.q_post - q) - g.D_null * qd
        X = np.linalg.solve(M, Ja.T)  # M⁻¹ J_aᵀ
        # Λ_a = (J_a M⁻¹ J_aᵀ)⁻¹ (Eq 36; J_a has full row rank, so an exact inverse)
        tau = h + Ja.T @ np.linalg.solve(Ja @ X, a_d - jdq - Ja @ a0) + M @ a0 + J.T @ W_ff
        self._rows.append(
            (
                t,
                s,
                ref.squeeze,
                r,
                r_d,
                w_obj[:3],
                w_obj[3:],
                self._centre,
                self.w_est[2] / self._g,
                e,
                psi,
                ref.yaw,
                P,
                -wr[:, :3],
                ref.phase,
            )
        )
        return tau

    def trace(self) -> dict[str, np.ndarray]:
        """The logged signals, one row per control update: ``time`` [s], ``squeeze`` and ``squeeze_set`` [N],
        ``radius`` and ``radius_target`` [m], ``object_force`` (T, 3) [N] and ``object_torque`` (T, 3)
        [N m] (what the end points exert on the object, about the circle's centre, world frame), ``centre``
        (T, 3) [m] that centre,
        ``weight_estimate`` [kg] (ŵ_z / g), ``error`` (T, 7) e = log(Ṽ_Sc V_d), ``yaw`` and
        ``yaw_target`` [rad], ``points`` (T, n, 3) [m], ``forces`` (T, n, 3) [N] the contact force of each end
        body on what it touches (the object), ``phase`` (T,) names."""
        out: dict[str, np.ndarray] = {}
        for i, name in enumerate(TRACE_FIELDS):
            col = [r[i] for r in self._rows]
            out[name] = np.array(col) if name != "phase" else np.array(col, dtype=object)
        return out
