"""A human partner in MuJoCo: the G1 and a human hand carry a free bar held only by the squeeze along it.

The physics version of ``examples/12_human_partner.py`` (paper §5.5).  One end of the point pair is a
**measured point the controller cannot move**: the human's hand, a palm plate that a MuJoCo mocap body drives
along a :class:`HandRecording`; the other is the G1's right hand (``g1_arms``: pelvis fixed to the
world, waist and both arms torque-controlled).  A free bar lies between the robot's pad and the human's palm,
its axis along the pair; nothing welds or constrains it — contacts and gravity on.

Scene (:func:`partner_setup`)
-----------------------------
* ``g1_arms`` with a 4 cm stick on the right hand along the hand frame's x axis (where the fingers point),
  ending in a 2 cm rubber sphere pad whose centre is the end point (:func:`hand_tool`,
  :func:`~coop_ga.sim.add_pads`): the hand frame lies inside the wrist's collision capsule, the stick moves
  the contact out of it.  The left hand only holds its posture;
* a free box bar (default 0.40 × 0.04 × 0.04 m, 0.4 kg, friction 1.0) along world x in front of the right
  hand, resting on a thin static post (the start: nobody holds it yet);
* the human's palm: a free 0.4 kg box 2 cm thick (the bar's end face presses on its flat face; a forearm is
  drawn behind it), **welded to a mocap target** ``hand_target`` that plays the recording (soft weld, time
  constant 10 ms).  Why not the palm itself as the mocap body: MuJoCo gives a mocap body no velocity in its
  contacts, so its friction does not drag what it touches — a bar pressed against a mocap palm slid 5 cm down
  the palm as the palm rose 5 cm.  The weld joins the human's hand to its target, never the bar.  The palm's
  centre h — measured from MuJoCo with its velocity, as a motion-capture system measures a real hand — is the
  partner's point.  The pair's contact length ℓ_c = bar length + pad radius + half the palm's thickness.

The hand's motion (:func:`figure_eight`): still while the squeeze builds up, a lift (the bar leaves the
post), then the **synthetic** figure-eight of example 12 (±4 cm along the bar, ±3 cm across, rising 4 cm,
period 4 s by default), sampled at 100 Hz and read back through a C¹ cubic (Catmull–Rom) interpolation
— a recorded-like signal, not motion-capture data.

Controller (:class:`PartnerController`)
---------------------------------------
:class:`~coop_ga.control.tasks.PartnerPairTask` gives the pair's error ``e = [d − d*; ℓ − ℓ*]`` (4,) and its
Jacobian J_e (4, nq) with the hand held; the torque is a Jacobian-transpose impedance on it::

    f = −W e − D ė,   W = diag(K⊥ ℓ², K⊥ ℓ², K⊥ ℓ², K∥),  D = diag(D⊥ ℓ², …, D∥)
    τ = h(q, q̇) + J_eᵀ f + J_pᵀ ŵ + J_ωᵀ m_a + Nᵀ M (K_post (q_post − q) − D_null q̇)

``J_eᵀ f = J_pᵀ [(I − d dᵀ) f_d / ℓ + d f_ℓ]`` is a Cartesian force at the pad: K⊥ [N/m] pulls the pad
across the pair back onto the line h + ℓ d*, K∥ [N/m] along it.  ℓ* is commanded ``s_d / K∥`` below ℓ_c
(the **dilation of the pair**): the bar blocks the pad, so the pad presses the bar into the palm with
about s_d — the squeeze whose friction carries the bar's weight.  ℓ* ramps from the start length to that
value while the hand is still (minimum jerk).  From the lift on, the squeeze is **regulated**: the admittance
loop of :class:`~coop_ga.sim.HoldController`'s e0∞ squeeze (:func:`~coop_ga.sim.hold.squeeze_admittance`)
moves ℓ* by δ, ``δ̇ = k (s − s_d)`` clipped (s the measured squeeze, the pad's contact force along d) —
without it the hand's motion along the bar, which the pad follows with a lag, swung the fixed spring's
squeeze between ~9 and 17 N at a 2.5 s period and to 0 at the doubled, faster hand.  The hand's motion enters

* as a disturbance (feedback only): ``ė = J_e q̇`` — the robot damps its own motion and lags the hand;
* fed forward: ``ė = J_e q̇ + (∂e/∂h) ḣ`` with ḣ the palm's measured velocity — the damping acts on the relative
  motion, so the pad moves with the hand (``PartnerPairTask.partner_jacobian``).

ŵ is the bar's weight share, estimated: the pad's contact force across the pair, low-pass filtered
(``weight_tau``) and fed forward (an integral action removing the impedance's sag, as in
:class:`~coop_ga.sim.HoldController`).  m_a holds the tool's axis along the bar (two rows across the axis,
``K_axis``, ``D_axis``): the pad is a sphere, so a turning hand rolls it on the bar's end — without these
rows the wrist turned ~45° under the posture alone and the pad rolled 12 mm.  The posture term (q_post: the
start configuration) acts in the null space of the pad point's and the pointing rows' Jacobian N
(dynamically consistent projector), so it holds the left arm and the waist without pushing the pad.

:func:`run_partner` simulates a :class:`PartnerCase` and :func:`partner_metrics` measures it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

import numpy as np

from .. import validation
from ..errors import InvalidInputError, NonFiniteError, UnreachableError
from ._mujoco import mj as _mj
from .hold import min_jerk, squeeze_admittance
from .objects import Box
from .scene import Scene, build_scene
from .simulation import Simulation, SimulationLog
from .tools import add_pads

__all__ = [
    "HandRecording",
    "PartnerCase",
    "PartnerController",
    "PartnerGains",
    "PartnerRun",
    "PartnerSetup",
    "figure_eight",
    "hand_tool",
    "partner_metrics",
    "partner_setup",
    "run_partner",
]

SYSTEM = "g1_arms"
TOOL_LENGTH = 0.04  # [m] the stick beyond the hand frame, along its x axis
PAD_RADIUS = 0.02  # [m]
PALM_SIZE = (0.02, 0.09, 0.09)  # [m] the palm plate: thickness along the bar, width, height
PAD_START = (0.36, -0.18, 0.12)  # [m] the pad's centre at the start (in front of the right shoulder)
BAR_AXIS = (1.0, 0.0, 0.0)  # the bar lies along world x, from the pad to the palm
POST_SIZE = 0.03  # [m] the post's square section (under the bar's centre)
FLOOR = -0.80  # [m] below the G1's locked feet (pelvis at z = 0)
GAP = 5e-4  # [m] the pad and the palm start this far from the bar's ends
RATE = 100.0  # [Hz] the recording's sampling rate
PALM_MASS = 0.4  # [kg] the palm plate (welded to the mocap target, not to the bar)
GRIP_TIMECONST = 0.01  # [s] the weld's time constant: how stiffly the palm follows the recording
HOLD_S, LIFT_S = 0.6, 0.8  # [s] still (squeeze builds up), then the lift
RAMP_S = 0.5  # [s] the figure-eight's clock speeds up from rest (and slows down to rest) over this
LIFT_M = 0.05  # [m]
VISUAL_CELL = 0.008  # [m] the G1's visual meshes decimated to this (model.xml stays ~1 MB)
CONTROL_DT = 0.002  # [s] the controller's period (the physics steps at 1 ms)


# ====================================================================== the human hand
@dataclass(frozen=True)
class HandRecording:
    """A recorded hand trajectory: ``time`` (K,) [s] strictly increasing, ``position`` (K, 3) [m] world frame.

    :meth:`at` interpolates with a C¹ cubic (Catmull–Rom: Hermite with the finite-difference slopes of the
    samples) and returns the velocity of that cubic; outside the recording the hand holds its first or
    last sample (velocity 0).

    Raises:
        NonFiniteError: a NaN or inf sample (a dropped marker must be filled before, not interpolated over).
        InvalidInputError: shapes, fewer than 2 samples, times not strictly increasing.
    """

    time: Any
    position: Any
    slopes: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        t = np.array(self.time, dtype=float)
        p = np.array(self.position, dtype=float)
        if t.ndim != 1 or t.size < 2 or p.shape != (t.size, 3):
            raise InvalidInputError(
                f"a hand recording needs time (K,) and position (K, 3) with K ≥ 2, got {t.shape} and {p.shape}"
            )
        bad = np.flatnonzero(~np.isfinite(p).all(axis=1) | ~np.isfinite(t))
        if bad.size:
            raise NonFiniteError(
                f"the hand recording has {bad.size} non-finite sample(s) (first at row {bad[0]}, t = {t[bad[0]]}); "
                "fill the gaps (e.g. interpolate the lost marker) before giving it to the controller"
            )
        if np.any(np.diff(t) <= 0):
            raise InvalidInputError("the hand recording's times must be strictly increasing")
        object.__setattr__(self, "time", t)
        object.__setattr__(self, "position", p)
        object.__setattr__(self, "slopes", np.gradient(p, t, axis=0))

    @property
    def duration(self) -> float:
        """Last sample time [s]."""
        return float(self.time[-1])

    def at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(position (3,) [m], velocity (3,) [m/s]) of the hand at time t [s] (class docstring)."""
        ts, P = self.time, self.position
        if t <= ts[0]:
            return P[0].copy(), np.zeros(3)
        if t >= ts[-1]:
            return P[-1].copy(), np.zeros(3)
        i = int(np.searchsorted(ts, t, side="right")) - 1
        h = ts[i + 1] - ts[i]
        s = (t - ts[i]) / h
        m0, m1 = self.slopes[i] * h, self.slopes[i + 1] * h
        s2, s3 = s * s, s * s * s
        pos = (2 * s3 - 3 * s2 + 1) * P[i] + (s3 - 2 * s2 + s) * m0 + (-2 * s3 + 3 * s2) * P[i + 1] + (s3 - s2) * m1
        dpos = (
            (6 * s2 - 6 * s) * P[i] + (3 * s2 - 4 * s + 1) * m0 + (-6 * s2 + 6 * s) * P[i + 1] + (3 * s2 - 2 * s) * m1
        )
        return pos, dpos / h

    def mocap(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """The palm's mocap pose at t: (position (1, 3), identity quaternion (1, 4)) (:class:`~coop_ga.sim.Simulation`'s ``mocap=``)."""
        return self.at(t)[0][None, :], np.array([[1.0, 0.0, 0.0, 0.0]])


def figure_eight(
    h0: Any, *, period: float = 4.0, periods: float = 1.0, scale: float = 1.0, phase: float = 0.0, rate: float = RATE
) -> HandRecording:
    """The synthetic recording (module docstring) starting at ``h0`` (3,) [m]: still for ``HOLD_S``, a lift of
    ``LIFT_M`` over ``LIFT_S`` (minimum jerk), then ``periods`` of example 12's figure-eight (±4 cm in x, ±3 cm in
    y, rising 4 cm in z, times ``scale``) of ``period`` [s], then still for 0.5 s; sampled at ``rate`` [Hz].

    The figure-eight's clock speeds up from rest over ``RAMP_S`` and slows down to rest over the last ``RAMP_S``
    (minimum-jerk rate; the motion lasts ``periods × period + RAMP_S``): a hand does not start at full speed.
    ``phase`` [rad] starts the figure-eight further along its curve (shifted so that it still starts at the lifted
    point): another hand path of the same size and speed."""
    h0 = validation.vector(h0, 3, "h0")
    T = validation.positive(period, "period")
    n_per = validation.positive(periods, "periods")
    a = validation.nonnegative(scale, "scale")
    ph = validation.scalar(phase, "phase")
    dt = 1.0 / validation.positive(rate, "rate")
    move = n_per * T + RAMP_S
    t = np.arange(0.0, HOLD_S + LIFT_S + move + 0.5, dt)
    lift = np.array([LIFT_M * min_jerk((x - HOLD_S) / LIFT_S) for x in t])
    w = 2 * math.pi / T
    x = t - HOLD_S - LIFT_S
    rate_ = np.array([min_jerk(u / RAMP_S) * min_jerk((move - u) / RAMP_S) for u in x])
    tm = np.concatenate([[0.0], np.cumsum(0.5 * (rate_[1:] + rate_[:-1]) * dt)])  # the figure-eight's clock
    u = w * tm + ph
    P = np.stack(
        [
            h0[0] + a * 0.04 * (np.sin(u) - math.sin(ph)),
            h0[1] + a * 0.03 * (np.sin(2 * u) - math.sin(2 * ph)),
            h0[2] + lift + a * 0.02 * (math.cos(ph) - np.cos(u)),
        ],
        axis=1,
    )
    return HandRecording(t, P)


# ====================================================================== the scene
def hand_tool(system: Any, length: float = TOOL_LENGTH, hand: str = "right_rubber_hand") -> Any:
    """A copy of ``system`` whose end frame ``hand`` is replaced by ``<hand>_tool``: ``length`` [m] further along
    the hand frame's x axis, its z axis along that x axis (so :func:`~coop_ga.sim.add_pads` with
    ``shaft_length=length`` draws the stick back to the hand)."""
    import dataclasses

    import pinocchio as pin

    L = validation.positive(length, "length")
    if hand not in system.end_frames:
        raise InvalidInputError(f"'{hand}' is not an end frame of '{system.name}' ({', '.join(system.end_frames)})")
    model = pin.Model(system.model)
    fid = model.getFrameId(hand)
    fr = model.frames[fid]
    Ry = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])  # its z axis = the hand's x axis
    placement = fr.placement * pin.SE3(Ry, np.array([L, 0.0, 0.0]))
    model.addFrame(pin.Frame(f"{hand}_tool", fr.parentJoint, fid, placement, pin.FrameType.OP_FRAME))
    frames = tuple(f"{hand}_tool" if f == hand else f for f in system.end_frames)
    return dataclasses.replace(system, model=model, end_frames=frames, name=f"{system.name}_hand_tool")


@lru_cache(maxsize=1)
def _tool_system() -> Any:
    from .. import systems

    return hand_tool(systems.load(SYSTEM))


@lru_cache(maxsize=1)
def _pair_model() -> Any:
    from ..cooperative import cooperative_task

    return cooperative_task(_tool_system(), "point_pair")


@dataclass(frozen=True)
class PartnerGains:
    """Gains of :class:`PartnerController` (module docstring).

    K_perp, D_perp: [N/m], [N s/m] across the pair; K_par, D_par: along it.  squeeze: s_d [N] (ℓ* = ℓ_c −
    s_d / K_par).  K_axis, D_axis: [N m/rad], [N m s/rad] the tool's pointing along the bar (the pad is a sphere:
    a turning hand rolls it on the bar's end).  K_post, D_null: null-space posture [1/s², 1/s] (scaled by M).  weight_tau: [s] the weight
    estimator's time constant (0: no weight feed-forward).  admittance: k [m/(N s)] of the squeeze loop on ℓ*
    (:func:`~coop_ga.sim.hold.squeeze_admittance`; 0: the fixed dilation s_d / K∥ alone), v_max [m/s] its speed
    limit, dr_max [m] its range.
    """

    K_perp: float = 800.0
    D_perp: float = 60.0
    K_par: float = 800.0
    D_par: float = 40.0
    squeeze: float = 15.0
    K_axis: float = 3.0
    D_axis: float = 0.15
    K_post: float = 60.0
    D_null: float = 15.0
    weight_tau: float = 0.2
    admittance: float = 0.03
    v_max: float = 0.1
    dr_max: float = 0.01

    def __post_init__(self) -> None:
        for name in ("K_perp", "K_par", "squeeze"):
            validation.positive(getattr(self, name), name)
        for name in ("D_perp", "D_par", "K_axis", "D_axis", "K_post", "D_null", "weight_tau", "admittance", "v_max",
                     "dr_max"):  # fmt: skip
            validation.nonnegative(getattr(self, name), name)

    def scaled(self, k: float) -> PartnerGains:
        """These gains with the pair's stiffnesses × k and dampings × √k (the same damping ratio)."""
        r = math.sqrt(k)
        return PartnerGains(
            self.K_perp * k, self.D_perp * r, self.K_par * k, self.D_par * r, self.squeeze, self.K_axis,
            self.D_axis, self.K_post, self.D_null, self.weight_tau, self.admittance, self.v_max, self.dr_max,
        )  # fmt: skip


@dataclass(frozen=True)
class PartnerCase:
    """One run: ``name``; ``feed_forward`` (the hand's measured velocity) or feedback only; the hand's
    ``period`` [s], ``periods``, ``scale`` and ``phase`` [rad] (:func:`figure_eight`); the gains; the bar's ``bar_length`` [m],
    ``bar_mass`` [kg] and ``friction``."""

    name: str
    feed_forward: bool = True
    period: float = 4.0
    periods: float = 1.0
    scale: float = 1.0
    gains: PartnerGains = field(default_factory=PartnerGains)
    phase: float = 0.0
    bar_length: float = 0.40
    bar_mass: float = 0.4
    friction: float = 1.0

    def describe(self) -> dict[str, Any]:
        """The case as JSON-able numbers."""
        g = self.gains
        return {
            "name": self.name,
            "feed_forward": self.feed_forward,
            "period_s": self.period,
            "periods": self.periods,
            "scale": self.scale,
            "phase_rad": self.phase,
            "K_perp_N_per_m": g.K_perp,
            "K_par_N_per_m": g.K_par,
            "squeeze_set_N": g.squeeze,
            "admittance_m_per_N_s": g.admittance,
            "bar_length_m": self.bar_length,
            "bar_mass_kg": self.bar_mass,
            "friction": self.friction,
        }


@dataclass
class PartnerSetup:
    """What :func:`partner_setup` builds: the case, system, scene, pair model, recording, controller, the start
    configuration, the pair's contact length ℓ_c [m] and the start of the hand's motion [s]."""

    case: PartnerCase
    system: Any
    scene: Scene
    model: Any
    recording: HandRecording
    controller: PartnerController
    q_start: np.ndarray
    contact_length: float
    move_start: float


@dataclass
class PartnerRun:
    """A simulated case: its setup, the log, the controller's trace and (whole runs) the metrics."""

    setup: PartnerSetup
    log: SimulationLog
    trace: dict[str, np.ndarray]
    metrics: dict[str, Any] = field(default_factory=dict)


# ====================================================================== the controller
#: the signals :meth:`PartnerController.trace` returns (one row per control update)
TRACE_FIELDS = (
    "time",
    "hand",
    "pad",
    "direction",
    "length",
    "length_target",
    "error",
    "squeeze",
    "pad_force",
    "palm_force",
    "weight_estimate",
    "other_contacts",
    "pad_rotation",
)


class PartnerController:
    """The impedance on the human–robot point pair (module docstring), as a ``Simulation`` controller.

    Args:
        scene: the scene (a free ``palm`` welded to a mocap target, a free ``bar``); model: the point-pair task of
            its system (end point 0 is the robot's pad).  The measured point h and its velocity ḣ are the palm's
            (read from MuJoCo each update, as a motion-capture system measures the real hand).
        gains: :class:`PartnerGains`.  feed_forward: use ḣ (else the hand is an unknown disturbance).
        q_start: the start configuration (the posture).  contact_length: ℓ_c [m].
        ramp: [s] ℓ* goes from the start length to ℓ_c − s_d / K∥ over this time (minimum jerk).
        estimate_from: [s] the weight estimator runs from this time (when the bar leaves the post).
    """

    def __init__(
        self,
        scene: Scene,
        model: Any,
        gains: PartnerGains,
        *,
        feed_forward: bool,
        q_start: Any,
        contact_length: float,
        ramp: float = HOLD_S,
        estimate_from: float = HOLD_S,
    ):
        import pinocchio as pin

        from ..control import Configuration
        from ..control.tasks import PartnerPairTask

        self.scene, self.model, self.gains = scene, model, gains
        self.feed_forward = bool(feed_forward)
        self._pin, self._pm = pin, scene.system.model
        self._pd = self._pm.createData()
        self.q_post = np.array(validation.configuration(q_start, model.nq, "q_start"))
        self.cfg = Configuration(model, self.q_post)
        h0 = np.asarray(scene.object("palm").pos, float)
        self.l_start = float(np.linalg.norm(model.points(self.q_post)[0] - h0))
        self.l_final = validation.positive(contact_length, "contact_length") - gains.squeeze / gains.K_par
        if not self.l_final > 0:
            raise InvalidInputError("squeeze / K_par must be below the pair's contact length (ℓ* > 0)")
        self.ramp, self.estimate_from = validation.positive(ramp, "ramp"), float(estimate_from)
        self.task = PartnerPairTask(model, 0, direction=-np.asarray(BAR_AXIS), length=self.l_start, partner=h0)
        m = scene.model
        self._bodies = np.array([scene.end_bodies[0], scene.object_ids["palm"]])
        self._bar = scene.object_ids["bar"]
        self._robot = np.zeros(m.nbody, dtype=bool)
        self._robot[list(scene.robot_bodies)] = True
        self._geom_body = np.asarray(m.geom_bodyid)
        self._iu = np.triu_indices(model.nq, 1)
        self._tool = self._pm.getFrameId(model.end_frames[0])
        self.reset()

    def reset(self) -> None:
        """Clear the weight estimate, the squeeze loop's offset and the trace."""
        self.w_est = np.zeros(3)
        self.dr = 0.0
        self._last_t: float | None = None
        self._rows: list[tuple[Any, ...]] = []

    def length_target(self, t: float) -> float:
        """ℓ*(t) [m]: the start length ramped to ℓ_c − s_d / K∥ (the squeeze's dilation), plus the squeeze loop's
        offset (0 until ``estimate_from``)."""
        return self.l_start + (self.l_final - self.l_start) * min_jerk(t / self.ramp) + self.dr

    def _other_contacts(self, data: Any) -> int:
        """Touching contacts (distance ≤ 0) between the robot and anything but the bar (the floor, the post, the
        palm, its own links)."""
        n = int(data.ncon)
        if n == 0:
            return 0
        c = data.contact
        b1, b2 = self._geom_body[c.geom1[:n]], self._geom_body[c.geom2[:n]]
        robot = self._robot[b1] | self._robot[b2]
        bar = (b1 == self._bar) | (b2 == self._bar)
        return int(np.count_nonzero(robot & ~bar & (c.dist[:n] <= 0.0)))

    def _posture(self, q: np.ndarray, qd: np.ndarray, M: np.ndarray, Jp: np.ndarray) -> np.ndarray:
        """``Nᵀ M (K_post (q_post − q) − D_null q̇)``: the posture through the dynamically consistent null space of
        the tasks' Jacobian ``Jp`` (k, nq) (the pad point and the tool's pointing)."""
        g = self.gains
        tau0 = M @ (g.K_post * (self.q_post - q) - g.D_null * qd)
        X = np.linalg.solve(M, Jp.T)  # M⁻¹ J_pᵀ
        Lam = np.linalg.inv(Jp @ X)
        return tau0 - Jp.T @ (Lam @ (X.T @ tau0))  # (I − J_pᵀ J̄ᵀ) τ0, J̄ = M⁻¹ J_pᵀ Λ

    def _pointing(self, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The tool's pointing: (J_w⊥ (2, nq) the hand's angular Jacobian across its axis a, the moment (2,) [N m]
        ``K_axis (a × a_d) − D_axis ω``) across a, with a_d = −d* (the tool points along the bar, to the palm)."""
        pin, pm, pd, g = self._pin, self._pm, self._pd, self.gains
        pin.computeJointJacobians(pm, pd, q)
        pin.updateFramePlacements(pm, pd)
        J = pin.getFrameJacobian(pm, pd, self._tool, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)[3:]
        R = pd.oMf[self._tool].rotation
        B = R[:, :2].T  # the two axes across the tool's z axis a
        a, ad = R[:, 2], -self.task.direction
        Jw = B @ J
        return Jw, B @ (g.K_axis * np.cross(a, ad)) - g.D_axis * (Jw @ qd)

    def __call__(self, t: float, q: np.ndarray, qd: np.ndarray, sensors: Any) -> np.ndarray:
        from .simulation import body_wrenches

        pin, g, task = self._pin, self.gains, self.task
        h, hd = sensors.object_pose("palm")[0], sensors.object_velocity("palm")[0]
        task.set_partner(h, hd if self.feed_forward else None)
        self.cfg.update(q, qd)
        d, ell, Jp = task.state(self.cfg)
        data = sensors.data
        pts = np.stack([self.cfg.kinematics().points[0], h])
        wr = body_wrenches(self.scene.model, data, self._bodies, pts)  # on the pad's body and on the palm
        Fc = wr[0, :3]
        s = float(d @ Fc)  # the squeeze: the pad's contact force along the pair
        dt = 0.0 if self._last_t is None else t - self._last_t
        self._last_t = t
        if t >= self.estimate_from:  # the squeeze is built: regulate it, estimate the weight
            self.dr = squeeze_admittance(self.dr, s, g.squeeze, dt, g.admittance, g.v_max, g.dr_max)
            if g.weight_tau > 0:
                perp = Fc - d * s  # the bar's weight share (and friction) across the pair
                self.w_est += (dt / g.weight_tau) * (-perp - self.w_est)
        task.length = self.length_target(t)
        e = task.error(self.cfg)
        Je = task.jacobian(self.cfg)
        edot = Je @ qd
        if self.feed_forward:
            edot = edot + task.partner_jacobian(self.cfg) @ hd
        l2 = ell * ell
        f = -np.array([g.K_perp * l2] * 3 + [g.K_par]) * e - np.array([g.D_perp * l2] * 3 + [g.D_par]) * edot
        M = pin.crba(self._pm, self._pd, q)
        M[self._iu[1], self._iu[0]] = M[self._iu]
        nle = pin.nonLinearEffects(self._pm, self._pd, q, qd)
        Jw, moment = self._pointing(q, qd)
        tau = nle + Je.T @ f + Jp.T @ self.w_est + Jw.T @ moment + self._posture(q, qd, M, np.vstack([Jp, Jw]))
        self._rows.append(
            (t, h, pts[0], d, ell, task.length, e, s, Fc, wr[1, :3], self.w_est.copy(), self._other_contacts(data),
             self._pd.oMf[self._tool].rotation.copy())
        )  # fmt: skip
        return tau

    def trace(self) -> dict[str, np.ndarray]:
        """The logged signals (:data:`TRACE_FIELDS`): ``time`` [s], ``hand`` and ``pad`` (T, 3) [m] (h and the pad's
        centre p), ``direction`` (T, 3) d, ``length`` and ``length_target`` [m] ℓ and ℓ*, ``error`` (T, 4) e,
        ``squeeze`` [N] (the pad's contact force along d), ``pad_force`` and ``palm_force`` (T, 3) [N] (on the
        robot's hand body and on the palm, by what they touch), ``weight_estimate`` (T, 3) [N] ŵ,
        ``other_contacts`` (T,) the robot's touching contacts with anything but the bar, ``pad_rotation``
        (T, 3, 3) the tool frame's rotation (world frame; the pad turns with it)."""
        return {name: np.array([r[i] for r in self._rows]) for i, name in enumerate(TRACE_FIELDS)}


# ====================================================================== setup and run
HAND_START = (0.791, -0.18, 0.12)  # [m] the palm's centre at the start (the human faces the robot)


def partner_setup(case: PartnerCase, recording: HandRecording | None = None) -> PartnerSetup:
    """Build the scene, the hand's recording (default: :func:`figure_eight` from :data:`HAND_START` with the
    case's period, periods and scale) and the controller of ``case`` (module docstring).

    Raises:
        UnreachableError: the pad's start point (the recording's first sample minus the contact length along
            the bar) is out of the right arm's reach, e.g. a bar longer than the reach.
        InvalidInputError: a bad case.
    """
    from .carry import point_ik

    system, model = _tool_system(), _pair_model()
    L = validation.positive(case.bar_length, "bar_length")
    if recording is None:
        recording = figure_eight(
            HAND_START, period=case.period, periods=case.periods, scale=case.scale, phase=case.phase
        )
    ax = np.asarray(BAR_AXIS)
    lc = L + PAD_RADIUS + 0.5 * PALM_SIZE[0]  # ℓ_c: the palm's centre to the pad's centre, touching
    h0 = recording.at(0.0)[0]
    p0 = h0 - (lc + 2 * GAP) * ax
    try:
        q_start = point_ik(system, np.asarray(system.q0, float), np.stack([p0, model.points(system.q0)[1]]))
    except InvalidInputError as e:
        raise UnreachableError(
            f"a bar of {L:g} m with the human's hand at {np.round(h0, 3).tolist()} puts the robot's pad at "
            f"{np.round(p0, 3).tolist()}, out of the G1's right-arm reach ({e}); use a bar of another length or "
            "start the hand elsewhere"
        ) from e
    if p0[0] < 0.15:  # the point IK ignores the body: a pad at or behind the chest is not a grasp
        raise UnreachableError(
            f"a bar of {L:g} m puts the robot's pad at x = {p0[0]:.3f} m, at or behind the G1's chest (needs x ≥ "
            "0.15 m): the bar is longer than the reach between the hand and the robot; use a shorter bar"
        )
    scene = _scene(case, L, p0, h0)
    ctl = PartnerController(
        scene, model, case.gains, feed_forward=case.feed_forward, q_start=q_start, contact_length=lc
    )
    return PartnerSetup(case, system, scene, model, recording, ctl, q_start, lc, HOLD_S + LIFT_S)


def _scene(case: PartnerCase, L: float, p0: np.ndarray, h0: np.ndarray) -> Scene:
    """The G1 with the pad, the bar on its post between the pad and the palm, the mocap palm."""
    ax = np.asarray(BAR_AXIS)
    fr = (validation.positive(case.friction, "friction"), 0.01, 0.0001)
    centre = p0 + (PAD_RADIUS + GAP + 0.5 * L) * ax
    w = 0.04  # [m] the bar's square section
    bottom = centre[2] - 0.5 * w
    bar = Box(name="bar", size=(L, w, w), mass=case.bar_mass, pos=centre, friction=fr, condim=4,
              rgba=(0.75, 0.55, 0.3, 0.6))  # fmt: skip  # see-through: the pictures show the squeeze inside
    post = Box(name="post", size=(POST_SIZE, POST_SIZE, bottom - FLOOR), pos=(centre[0], centre[1], 0.5 * (bottom + FLOOR)),
               static=True, friction=0.3, rgba=(0.45, 0.45, 0.5, 1.0))  # fmt: skip
    palm = Box(name="palm", size=PALM_SIZE, pos=h0, mass=PALM_MASS, friction=fr, condim=4, rgba=(0.9, 0.7, 0.6, 1.0))
    target = Box(name="hand_target", size=(0.01, 0.01, 0.01), pos=h0, mocap=True, rgba=(0.9, 0.3, 0.1, 0.5))
    scene = build_scene(_tool_system(), objects=[bar, post, palm, target], floor=FLOOR, visual_cell=VISUAL_CELL)
    mj = _mj()
    g = scene.spec.geom("hand_target_geom")
    g.contype = g.conaffinity = 0  # the target is a marker: only the palm touches
    scene.spec.body("palm").add_geom(  # the human's forearm, drawn only (no contact, no mass)
        name="forearm", type=mj.mjtGeom.mjGEOM_CAPSULE, size=[0.03, 0.0, 0.0], fromto=[0.03, 0, -0.01, 0.3, 0, -0.08],
        contype=0, conaffinity=0, rgba=[0.9, 0.7, 0.6, 1.0],
    )  # fmt: skip
    scene.spec.add_equality(
        name="hand_grip", type=mj.mjtEq.mjEQ_WELD, objtype=mj.mjtObj.mjOBJ_BODY, name1="hand_target", name2="palm",
        solref=[GRIP_TIMECONST, 1.0], data=[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0],
    )  # fmt: skip  # data: anchor, the palm's pose in the target's frame (identity), torque scale
    return add_pads(scene, PAD_RADIUS, shaft_length=TOOL_LENGTH, friction=fr)


def run_partner(
    case: PartnerCase, *, recording: HandRecording | None = None, duration: float | None = None, progress: bool = False
) -> PartnerRun:
    """Simulate ``case`` (1 kHz physics, the controller at 500 Hz) for the recording's duration (or ``duration`` [s])
    with the palm on the recording, and measure it (:func:`partner_metrics`, whole runs only)."""
    st = partner_setup(case, recording)
    sim = Simulation(st.scene, st.controller, q=st.q_start, mocap=st.recording.mocap, control_dt=CONTROL_DT)
    log = sim.run(st.recording.duration if duration is None else duration, progress=progress)
    run = PartnerRun(st, log, st.controller.trace())
    if duration is None:
        run.metrics = partner_metrics(run)
    return run


# ====================================================================== measurements
#: the claims' bounds: direction error [rad], |ℓ − ℓ_c| [m], slip [m], the lowest squeeze (fraction of s_d)
BOUNDS = {"direction_rad": 0.05, "length_m": 0.005, "slip_m": 0.005, "squeeze_fraction": 0.25, "dropped_m": 0.02}


def bar_pose(run: PartnerRun, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(centres (k, 3) [m], rotation matrices (k, 3, 3)) of the bar at log rows ``rows``."""
    a = run.setup.scene.object_qpos["bar"]
    q = run.log.qpos[rows, a : a + 7]
    R = np.empty((len(rows), 9))
    for k, qk in enumerate(q[:, 3:]):
        _mj().mju_quat2Mat(R[k], qk)
    return q[:, :3], R.reshape(-1, 3, 3)


def _rolling(R_bar: np.ndarray, R_pad: np.ndarray, i0: int) -> np.ndarray:
    """The pad centre's displacement across the bar's end face that the pad's rolling explains (T, 2) [m] (bar frame,
    its y and z; 0 up to row ``i0``): the sum of ``Δθ × (−r x̂)`` over the control updates, Δθ the pad's rotation
    relative to the bar between two updates (bar frame; ``R_bar``, ``R_pad`` (T, 3, 3)) and −r x̂ the contact
    point to the centre (the pad presses the bar's −x end).  A sphere rolling without sliding on a plane moves its
    centre by exactly this; what the centre moved beyond it is sliding.  The spin about x̂ moves nothing."""
    Rrel = np.einsum("kji,kjl->kil", R_bar, R_pad)  # R_barᵀ R_pad
    dR = np.einsum("kij,klj->kil", Rrel[1:], Rrel[:-1])  # R_rel(k+1) R_rel(k)ᵀ
    theta = 0.5 * np.stack([dR[:, 2, 1] - dR[:, 1, 2], dR[:, 0, 2] - dR[:, 2, 0], dR[:, 1, 0] - dR[:, 0, 1]], axis=1)
    step = np.cross(theta, np.array([-PAD_RADIUS, 0.0, 0.0]))[:, 1:]  # at 500 Hz the steps are small: vee ≈ log
    step[:i0] = 0.0
    return np.concatenate([np.zeros((1, 2)), np.cumsum(step, axis=0)])


def _series(run: PartnerRun) -> dict[str, np.ndarray]:
    """Per control update: the bar's offset from where the pair holds it [m], each end's slip on the bar [m] (pad,
    palm; across the bar's axis, in its frame, from the lift start), the pad's slip split into rolling and sliding
    (:func:`_rolling`; the palm is flat on the flat end: its slip is sliding), the direction error [rad] and
    ℓ − ℓ_c [m]."""
    st, tr = run.setup, run.trace
    t = tr["time"]
    rows = np.rint(t / float(st.scene.model.opt.timestep)).astype(int)
    c, R = bar_pose(run, rows)
    d, p, h = tr["direction"], tr["pad"], tr["hand"]
    expect = p - (PAD_RADIUS + 0.5 * st.case.bar_length) * d
    i0 = int(np.searchsorted(t, HOLD_S))
    moved = [np.einsum("kji,kj->ki", R, x - c)[:, 1:] for x in (p, h)]  # across the bar's axis (its x), bar frame
    moved = [x - x[i0] for x in moved]
    roll = _rolling(R, tr["pad_rotation"], i0)
    dd = np.linalg.norm(d - st.controller.task.direction, axis=1)
    return {
        "offset": np.linalg.norm(c - expect, axis=1),
        "slip_pad": np.linalg.norm(moved[0], axis=1),
        "slip_pad_rolling": np.linalg.norm(roll, axis=1),
        "slip_pad_sliding": np.linalg.norm(moved[0] - roll, axis=1),
        "slip_palm": np.linalg.norm(moved[1], axis=1),
        "direction": 2 * np.arcsin(np.minimum(1.0, 0.5 * dd)),
        "length": tr["length"] - st.contact_length,
        "after_lift": t >= HOLD_S,
        "moving": (t >= st.move_start) & (t <= st.move_start + st.case.periods * st.case.period + RAMP_S),
    }


def _palm_lag(run: PartnerRun) -> float:
    """The palm's largest distance [m] from its mocap target over the log (the soft weld's lag and sag)."""
    a = run.setup.scene.object_qpos["palm"]
    return float(np.max(np.linalg.norm(run.log.qpos[:, a : a + 3] - run.log.mocap_pos[:, 0], axis=1)))


def partner_metrics(run: PartnerRun) -> dict[str, Any]:
    """The run's measured claims (lengths [m], angles [rad], forces [N]); windows: after the lift starts (the bar
    off its post) and while the hand moves (the figure-eight):

    * ``dropped``: the bar's centre ever more than 2 cm from where the pair holds it (p − (r + L/2) d) after the
      lift start; ``bar_offset_max_m``;
    * ``slip_pad_max_m``, ``slip_palm_max_m``: each end's largest displacement across the bar's axis on the bar
      (bar frame, from the lift start); ``slip_pad_rolling_max_m`` / ``slip_pad_sliding_max_m``: the pad's split
      into the part its rolling explains and the rest (sliding);
    * ``direction_error_max_rad`` / ``_rms_rad`` and ``length_error_max_m`` (|ℓ − ℓ_c|, ℓ_c the contact length)
      while the hand moves; ``length_compression_m``: ℓ_c − ℓ* (the dilation that makes the squeeze);
    * ``squeeze_min_N`` / ``_mean_N`` / ``_max_N`` while the hand moves (the pad's contact force along d);
    * ``palm_lag_max_m``: the palm's largest distance from its mocap target (the recording) over the run;
    * ``other_contact_updates``: control updates in which the robot touched anything but the bar;
    * ``max_limit_violation`` [rad], ``max_velocity_violation`` [rad/s], ``saturated_updates``, ``effort_ratio``;
    * ``success``: none dropped, slip ≤ 5 mm at both ends, direction error ≤ 0.05 rad, |ℓ − ℓ_c| ≤ 5 mm, the
      squeeze ≥ 25 % of its set-point, no other contact, no joint limit left, no torque clipped; ``failures``.
    """
    from .carry import limit_excursions

    st, tr, log = run.setup, run.trace, run.log
    s = _series(run)
    after, mov = s["after_lift"], s["moving"]
    sq = tr["squeeze"][mov]
    m: dict[str, Any] = {
        "case": st.case.describe(),
        "dropped": bool(np.max(s["offset"][after]) > BOUNDS["dropped_m"]),
        "bar_offset_max_m": float(np.max(s["offset"][after])),
        "slip_pad_max_m": float(np.max(s["slip_pad"][after])),
        "slip_pad_rolling_max_m": float(np.max(s["slip_pad_rolling"][after])),
        "slip_pad_sliding_max_m": float(np.max(s["slip_pad_sliding"][after])),
        "slip_palm_max_m": float(np.max(s["slip_palm"][after])),
        "direction_error_max_rad": float(np.max(s["direction"][mov])),
        "direction_error_rms_rad": float(np.sqrt(np.mean(s["direction"][mov] ** 2))),
        "length_error_max_m": float(np.max(np.abs(s["length"][mov]))),
        "length_compression_m": float(st.contact_length - st.controller.l_final),
        "squeeze_set_N": float(st.case.gains.squeeze),
        "squeeze_min_N": float(np.min(sq)),
        "squeeze_mean_N": float(np.mean(sq)),
        "squeeze_max_N": float(np.max(sq)),
        "hand_speed_max_m_s": float(
            np.max(np.linalg.norm(np.gradient(tr["hand"][mov], tr["time"][mov], axis=0), axis=1))
        ),
        "palm_lag_max_m": _palm_lag(run),
        "other_contact_updates": int(np.count_nonzero(tr["other_contacts"])),
        "saturated_updates": int(log.saturated_updates),
        "control_updates": int(log.control_updates),
        "effort_ratio": float(log.effort_ratio),
        **limit_excursions(run),  # type: ignore[arg-type]
    }
    m["failures"] = _failures(m)
    m["success"] = not m["failures"]
    return m


def _failures(m: dict[str, Any]) -> list[str]:
    """What a run missed, in words (:data:`BOUNDS`)."""
    b, out = BOUNDS, []
    if m["dropped"]:
        out.append(f"the bar dropped (its centre {100 * m['bar_offset_max_m']:.1f} cm from the pair's hold)")
    slip = max(m["slip_pad_max_m"], m["slip_palm_max_m"])
    if slip > b["slip_m"]:
        out.append(f"slip {1e3 * slip:.1f} mm > {1e3 * b['slip_m']:g} mm")
    if m["direction_error_max_rad"] > b["direction_rad"]:
        out.append(f"direction error {m['direction_error_max_rad']:.3f} rad > {b['direction_rad']:g} rad")
    if m["length_error_max_m"] > b["length_m"]:
        out.append(f"length error {1e3 * m['length_error_max_m']:.1f} mm > {1e3 * b['length_m']:g} mm")
    if m["squeeze_min_N"] < b["squeeze_fraction"] * m["squeeze_set_N"]:
        out.append(f"squeeze fell to {m['squeeze_min_N']:.1f} N (< {100 * b['squeeze_fraction']:g} % of the set-point)")
    if m["other_contact_updates"]:
        out.append(f"the robot touched something other than the bar in {m['other_contact_updates']} control updates")
    if m["max_limit_violation"] > 0:
        out.append(f"joint limits left by {m['max_limit_violation']:.3g} rad")
    if m["saturated_updates"]:
        out.append(f"torque clipped at the effort limit in {m['saturated_updates']} control updates")
    return out
