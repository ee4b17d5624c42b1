"""Walking: a phase-table gait, body height and attitude through the stance plane, swing feet on arcs to
footholds that keep the legs off the terrain, and the per-step checks (static stability, limits, slip, clearance,
torques).

The foot is a ball (:mod:`coop_ga.legged.contact`): the planner places the ball *centres* (the
``{leg}_foot`` frames) one radius above the terrain along its normal, so the ball touches the ground where
the planner's contact point is (``WalkResult.contacts``).  One step Δt of :func:`walk` (positions in W):

1. **Gait** (:func:`~coop_ga.legged.gait.phase_table`): leg i's phase counter w_i = (k − o_i) mod N on
   an integer grid of N knots per cycle, N a multiple of 6 (Δt is rounded to T / N so that every
   lift-off and touch-down falls on a knot, exactly).  Leg i swings during [t_k, t_{k+1}] when
   w_i(k) < S = σN and stands otherwise (the table's u ≥ σ): a stance foot stays at its touch-down
   point in W.  Legs that the table has in mid-swing at t = 0 swing over the rest of their swing.
2. **Reference**: the horizontal pose (x, y, yaw) integrates the velocity command ``(v_x, v_y, ω_z)``
   (body forward, body left, yaw rate; ramped in over ``ramp_time`` from rest with a smoothstep).  Height
   and attitude are referred to the **stance plane**, the ground contact plane of the stance feet (the
   least-squares plane of their ball centres, a radius lower): the body z along its normal (``tilt_follow``
   blends toward world z), the body origin ``ride_height`` above it.
3. **Body through the stance primitive** (``use_posture=True``, the default): the plane of the stance feet
   is a cooperative primitive (:func:`~coop_ga.legged.stance.stance_task`, kind ``plane`` / ``plane_fit``),
   and seed 003 Table 1 says what it carries: its tilt (e13, e23) and its offset (e3∞) — exactly the body's
   attitude and ride height — and nothing of the walking motion (in-plane translation and yaw are its
   geometric null space).  Each step measures the plane in B from the joints (FK), takes the error
   ``e = log(Ṽ V_ref)`` against the reference plane in B (the stance plane where step 2 wants it seen from
   the body), commands ``c = min(posture_gain, 1/Δt) · e`` on the carried rows through
   :func:`~coop_ga.legged.posture.posture_step` and hands it the reference's horizontal motion and yaw as the
   ``nullspace_twist``: the posture QP moves the body (joint limits and speeds inside its box), the stance
   legs are re-solved for their fixed ball centres.  So the body's height and attitude close on the
   *measured* stance primitive with the time constant 1 / posture_gain (0.125 s), while it walks where it
   is told.  With ``use_posture=False`` (kinematic baseline) the body is put directly at ride height on the
   stance plane low-pass filtered with ``terrain_filter`` (0.25 s).  The two differ on uneven ground
   (``tracking_error`` is the body's deviation from the instantaneous stance reference in either mode).
   A sphere of ≥ 4 stance feet would carry no attitude at all (no rotation rows), so it is not used here.
4. **Swing legs**: at lift-off the foothold is planned: the ball resting on the terrain at the nominal
   foothold (B: ``foot_reach`` out from the coxa axis along the mounting direction) placed at the reference
   body pose of mid-stance, its contact kept ``edge_clearance`` away from the terrain's cell edges, and —
   where a leg capsule (coxa, femur, shin: :func:`~coop_ga.legged.contact.leg_clearance`) would come closer
   than ``clearance_margin`` to the terrain at the predicted body poses of touch-down, mid-stance and
   lift-off (a rear shin leaning over a riser) — moved to the nearest foothold that keeps it (``foothold_shifts``).
   The foot follows :func:`~coop_ga.legged.gait.swing_arc` with the ball's lowest point ``lift_height``
   above the highest terrain under the straight line between its ends, the apex raised until every leg
   capsule and the moving ball keep ``clearance_margin`` at the predicted body poses (``raised_swings``).
   All legs by closed-form IK in the body frame at the new body pose (``knee_up``, limits enforced); should a
   target be unreachable inside the limits, DLS IK with every iterate clipped to the limits is used instead
   (``fallback_steps``; the foot then misses its target, which shows as slip).
5. **Checks** at every knot: static stability margin (:func:`static_stability_margin`, the supports before and
   after the knot), joint-limit violation (0 by construction), slip (drift of a stance ball centre from its
   touch-down point), contact (distance of a stance ball from the terrain solid), swing-ball clearance, leg
   capsule clearance (``segment_clearance``), rolling (``rolling``: how far a stance ball must slide or roll
   because its centre is held while the tibia turns — the contact model's error, a few mm per stance), the
   workspace margin of the foot targets, static torques for equal load sharing against the stall torque.

A velocity command the legs cannot walk is refused before the run (:func:`check_command`: one cycle on flat
ground must stay inside the reach, the joint limits and the URDF speed limits).

Gait parameters (:class:`WalkOptions` defaults), chosen for the PhantomX-size robot (leg reach 0.2 m):
ball centres 0.1 m below the body (ride height 0.109 m above the ground), footholds 0.16 m out from the coxa
axes, stride 0.08 m, cycle times 1.6 / 2.4 / 4.0 s (tripod / ripple / wave: 0.10 / 0.05 / 0.024 m/s), lift
0.02 m for the ball's lowest point (its centre 0.029 m).  The measured numbers: the ``hexapod_walk`` experiment's
metrics (1 m walks; ``--fast``, 0.3 m: the gallery's ``ours_hexapod_walk_*`` entries, paper_figures/README.md).

Model assumptions, said once: the COM is the whole robot's (Pinocchio, base link included: 1.873 kg); torques
treat the legs as massless with the full weight shared equally by the stance feet; the plan is kinematic
(quasi-static): an optional rigid-contact roll-out (:mod:`coop_ga.legged.dynamics`) and the MuJoCo scenes of
:mod:`coop_ga.sim` are the checks of the dynamics.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import CoopGAError, InvalidInputError
from ..validation import array, choice, nonnegative, positive, scalar, vector
from .body import LEG_ORDER, BodyState, stance_indices
from .gait import GAITS, GaitTable, phase_table, swing_arc
from .legs import check_legs

if TYPE_CHECKING:  # pragma: no cover
    from .legs import LegModel
    from .terrain import Terrain

__all__ = [
    "CYCLE_TIME",
    "SERVO_SPEED",
    "WalkOptions",
    "WalkResult",
    "check_command",
    "convex_hull",
    "robot_com",
    "robot_mass",
    "static_stability_margin",
    "static_torques",
    "walk",
]

G = 9.81


# ====================================================================== static stability
def convex_hull(points_xy: object) -> np.ndarray:
    """The convex hull of (k, 2) points [m], counter-clockwise, without collinear or repeated vertices
    (Andrew's monotone chain); (h, 2) with h ≤ k (h = 1 or 2 for coincident or collinear points)."""
    P = array(points_xy, "points_xy")
    if P.ndim != 2 or P.shape[1] != 2 or P.shape[0] == 0:
        raise InvalidInputError(f"points_xy must have shape (k, 2) with k ≥ 1, got {P.shape}")
    pts = sorted({(float(x), float(y)) for x, y in P})
    if len(pts) <= 2:
        return np.array(pts, dtype=float)
    scale = max(1.0, float(np.abs(P).max()))
    eps = 1e-12 * scale * scale

    def cross(o: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[tuple[float, float]] = []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= eps:
            lower.pop()
        lower.append(p)
    upper: list[tuple[float, float]] = []
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= eps:
            upper.pop()
        upper.append(p)
    hull = lower[:-1] + upper[:-1]
    if len(hull) < 2:  # all points collinear and the chain collapsed to the two extremes
        hull = [pts[0], pts[-1]]
    return np.array(hull, dtype=float)


#: horizontal coordinates [m] beyond this are refused by :func:`static_stability_margin` (squares overflow)
_MAX_XY = 1e150


def _segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    ab = b - a
    L2 = float(ab @ ab)
    s = 0.0 if L2 == 0.0 else float(np.clip((p - a) @ ab / L2, 0.0, 1.0))
    return float(np.linalg.norm(p - (a + s * ab)))


def static_stability_margin(com_xy: object, support_xy: object) -> float:
    """The static stability margin [m]: the signed distance of the COM's ground projection ``com_xy`` (2,)
    to the boundary of the support polygon, the convex hull of the stance feet ``support_xy`` (k, 2)
    (both in the world's horizontal plane, W x/y).

    > 0: the projection lies inside, and the value is its distance to the nearest hull edge (how far
    the COM may move before the robot tips over that edge); < 0: outside, minus its distance to the
    hull.  Fewer than three non-collinear feet span no area: the margin is then minus the distance to
    the segment or point they span (≤ 0, never positive); k = 0 gives −inf.
    """
    c = array(com_xy, "com_xy", shape=(2,))
    S = array(support_xy, "support_xy")
    if S.ndim != 2 or S.shape[1] != 2:
        raise InvalidInputError(f"support_xy must have shape (k, 2), got {S.shape}")
    for what, P in (("com_xy", c), ("support_xy", S)):
        if P.size and float(np.max(np.abs(P))) > _MAX_XY:
            raise InvalidInputError(f"{what} reaches {float(np.max(np.abs(P))):.3g} m, beyond ±{_MAX_XY:g} m")
    if S.shape[0] == 0:
        return -math.inf
    H = convex_hull(S)
    h = H.shape[0]
    if h == 1:
        return -float(np.linalg.norm(c - H[0]))
    if h == 2:
        return -_segment_distance(c, H[0], H[1])
    dist = min(_segment_distance(c, H[i], H[(i + 1) % h]) for i in range(h))
    for i in range(h):
        a, b = H[i], H[(i + 1) % h]
        if (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]) < 0.0:
            return -dist
    return dist


# ====================================================================== mass, COM, torques
_MASS_CACHE: dict[int, tuple[Any, Any, float]] = {}


def _mass_model(legs: LegModel) -> tuple[Any, float]:
    system = legs.system
    hit = _MASS_CACHE.get(id(system))
    if hit is None or hit[0] is not system:
        m = system.model
        total = float(sum(m.inertias[i].mass for i in range(m.njoints)))
        hit = (system, m.createData(), total)
        _MASS_CACHE[id(system)] = hit
    return hit[1], hit[2]


def robot_mass(legs: LegModel) -> float:
    """The whole robot's mass [kg]: every link of the fixed-base model *including* the base link
    (Pinocchio's ``computeTotalMass`` of a fixed-base model leaves the root link out)."""
    return _mass_model(check_legs(legs))[1]


def robot_com(q: object, legs: LegModel) -> np.ndarray:
    """The whole robot's centre of mass (3,) [m] in the body frame B at leg joints ``q`` (18,),
    base link included (see :func:`robot_mass`)."""
    import pinocchio as pin

    system = check_legs(legs).system
    qq = vector(q, legs.nq, "q")
    data, total = _mass_model(legs)
    m = system.model
    qfull = np.array(system.q0, dtype=float)
    qfull[np.asarray(legs.model_q_index).ravel()] = qq[np.asarray(legs.q_index).ravel()]
    pin.centerOfMass(m, data, qfull)
    base = m.inertias[0]
    return np.asarray(
        (base.mass * np.asarray(base.lever) + data.mass[0] * np.asarray(data.com[0])) / total, dtype=float
    )


def static_torques(state: BodyState, stance_legs: object, legs: LegModel, mass: float, g: float = G) -> np.ndarray:
    """Static joint torques (6, 3) [N·m] for equal load sharing (LEG ORDER; (coxa, femur, tibia)).

    Each of the k stance feet carries m g / k: it pushes on the ground with f_W = (0, 0, −m g / k) in W,
    f_B = R_WBᵀ f_W in B, and the leg's motors hold it with τ = J_legᵀ f_B (J_leg = ∂p_foot/∂q_leg in B,
    :meth:`~coop_ga.legged.legs.LegModel.jacobians`; the principle of virtual work: τ·δq = f·δp).
    Swing legs: 0.  The legs are treated as massless (their 1.07 kg is in ``mass``, shared like the
    body's).  Compare ``abs(τ)`` with ``legs.effort_limit`` (the servo stall torque).
    """
    if not isinstance(state, BodyState):
        raise InvalidInputError(f"state must be a BodyState, got {type(state).__name__}")
    legs = check_legs(legs)
    idx = stance_indices(stance_legs)
    m = positive(mass, "mass")
    gg = positive(g, "g")
    tau = np.zeros((6, 3))
    if not idx:
        return tau
    J = np.asarray(legs.jacobians(state.q), dtype=float).reshape(6, 3, 3)
    f_W = np.array([0.0, 0.0, -m * gg / len(idx)])
    f_B = state.rotation.T @ f_W
    for i in idx:
        tau[i] = J[i].T @ f_B
    return tau


# ====================================================================== options and result
#: default gait periods [s], chosen so that the plan's peak joint speed stays below the URDF's speed limit
#: (6.18 rad/s, the AX-12A's no-load speed) on flat, steps and random ground (with 1.0 / 1.2 / 1.5 s the
#: swings reached 8.6 / 10.3 / 14.2 rad/s: the swing speed scales like 1 / period)
CYCLE_TIME: dict[str, float] = {"tripod": 1.6, "ripple": 2.4, "wave": 4.0}
#: :class:`WalkOptions` refuses a ``dt`` that gives more knots per cycle, :func:`walk` a walk of more knots
MAX_KNOTS_PER_CYCLE = 100_000
MAX_KNOTS = 1_000_000
#: the servo's no-load speed [rad/s] (AX-12A at 12 V: 59 rev/min, robot README [AX]); reported, not enforced.
SERVO_SPEED = 59.0 * 2.0 * math.pi / 60.0
#: [m] foothold shifts tried when a leg capsule would touch the terrain during the stance (nearest first)
_SHIFTS = tuple(sorted(
    {(dx, dy) for dx in np.arange(-0.06, 0.0601, 0.01) for dy in np.arange(-0.03, 0.0301, 0.01)},
    key=lambda d: (math.hypot(*d), d),
))[1:]  # fmt: skip
#: [m] a swing arc is raised at most this far above its nominal apex to clear the legs' capsules
_MAX_EXTRA_LIFT = 0.05


@dataclass(frozen=True)
class WalkOptions:
    """Options of :func:`walk`.

    Attributes:
        gait: "tripod" | "ripple" | "wave" (:func:`~coop_ga.legged.gait.phase_table`).
        speed: the velocity command ``(v_x, v_y, ω_z)`` [m/s, m/s, rad/s] in the body frame (forward, left,
            yaw rate); ``None``: straight ahead at ``stride / (β T)``, the speed at which each stance foot
            travels ``stride`` relative to the body.
        stride: stance stroke [m] of the default forward speed (0.08 m).
        cycle_time: T [s]; ``None``: :data:`CYCLE_TIME` (tripod 1.6, ripple 2.4, wave 4.0 s).
        duty: duty factor β; ``None``: the gait's (1/2, 2/3, 5/6).
        lift_height: [m] the swing apex: the foot ball's lowest point this far above the highest terrain under
            the swing (raised where a leg capsule needs it, ``clearance_margin``).
        ride_height: [m] the body origin above the ground contact plane of the stance feet, along the body z
            (0.109 m: the foot-ball centres 0.1 m below the body, the stand pose's 0.0993 m).
        dt: requested time step [s]; rounded so that a cycle is a whole multiple of the gait's phase grid.
        ramp_time: the command ramps in from rest over this time [s] (smoothstep); ``None``: one cycle.
        terrain_filter: time constant [s] of the low-pass filter on the support plane of the kinematic baseline
            (``use_posture=False``).
        posture_gain: [1/s] gain of the stance-plane posture loop (``use_posture=True``, module docstring).
        tilt_follow: 1 = body z along the support plane normal, 0 = stays level (world z).
        foot_reach: horizontal distance [m] of the nominal foothold from its coxa axis, along the mounting
            direction (0.16 m); ``None``: the stand pose's (0.174 m).
        edge_clearance: the foot's contact point keeps at least this distance [m] from the terrain's cell edges
            (a foot on a riser's edge has no single support plane): 16 mm = the 9 mm ball, the ≤ 5 mm it rolls in a
            stance and 2 mm, so the ball rests on its own tread and never touches the riser of a higher neighbour.
        clearance_margin: [m] the footholds and swing arcs keep every leg capsule this far above the terrain, as
            predicted from the reference body path (module docstring; the walk measures the result); None: no
            capsule check, the footholds and arcs of the foot ball alone (for comparison).
        rolling: the stance balls roll with their tibias (their centres move by ``r Δθ × n``, no sliding; the
            default), or their centres are held fixed (then the ball must slide by ``rolling``, the error of a
            point-contact plan).
        use_posture: drive body height and attitude through the stance plane (:func:`~coop_ga.legged.posture.posture_step`,
            the default); False: the body is put at the filtered support-plane pose directly (kinematic baseline).
    """

    gait: str = "tripod"
    speed: tuple[float, float, float] | None = None
    stride: float = 0.08
    cycle_time: float | None = None
    duty: float | None = None
    lift_height: float = 0.02
    ride_height: float = 0.109
    dt: float = 0.02
    ramp_time: float | None = None
    terrain_filter: float = 0.25
    posture_gain: float = 8.0
    tilt_follow: float = 1.0
    foot_reach: float | None = 0.16
    edge_clearance: float = 0.016
    clearance_margin: float | None = 0.004
    rolling: bool = True
    use_posture: bool = True

    def __post_init__(self) -> None:
        choice(self.gait, GAITS, "gait")
        if self.speed is not None:
            object.__setattr__(
                self, "speed", tuple(float(x) for x in vector(self.speed, 3, "speed (vx, vy, yaw_rate)"))
            )
        positive(self.stride, "stride")
        if self.cycle_time is not None:
            positive(self.cycle_time, "cycle_time")
        nonnegative(self.lift_height, "lift_height")
        positive(self.ride_height, "ride_height")
        positive(self.dt, "dt")
        if self.ramp_time is not None:
            nonnegative(self.ramp_time, "ramp_time")
        nonnegative(self.terrain_filter, "terrain_filter")
        positive(self.posture_gain, "posture_gain")
        tf = scalar(self.tilt_follow, "tilt_follow")
        if not 0.0 <= tf <= 1.0:
            raise InvalidInputError(f"tilt_follow must be in [0, 1], got {tf}")
        if self.foot_reach is not None:
            positive(self.foot_reach, "foot_reach")
        nonnegative(self.edge_clearance, "edge_clearance")
        if self.clearance_margin is not None:
            nonnegative(self.clearance_margin, "clearance_margin")
        for flag in ("use_posture", "rolling"):
            if not isinstance(getattr(self, flag), (bool, np.bool_)):
                raise InvalidInputError(f"{flag} must be True or False, got {getattr(self, flag)!r}")
        tab = self.table()  # checks duty and cycle_time against the gait
        if not self.dt <= tab.period / 6.0:
            raise InvalidInputError(
                f"dt = {self.dt:g} s is longer than a sixth of the cycle (T = {tab.period:g} s): the phase grid needs "
                f"≥ 6 knots per cycle; take dt ≤ {tab.period / 6.0:.4g} s"
            )
        if tab.period / self.dt > MAX_KNOTS_PER_CYCLE:
            raise InvalidInputError(
                f"dt = {self.dt:g} s gives {tab.period / self.dt:.3g} knots per cycle (T = {tab.period:g} s), above "
                f"{MAX_KNOTS_PER_CYCLE}; take dt ≥ {tab.period / MAX_KNOTS_PER_CYCLE:.3g} s"
            )

    @property
    def period(self) -> float:
        """The cycle time T [s]."""
        return float(self.cycle_time) if self.cycle_time is not None else CYCLE_TIME[self.gait]

    def table(self) -> GaitTable:
        """The gait's phase table at this cycle time and duty."""
        return phase_table(self.gait, 6, self.duty, period=self.period)

    def command(self) -> np.ndarray:
        """The velocity command (3,) ``(v_x, v_y, ω_z)`` [m/s, m/s, rad/s] (body frame)."""
        if self.speed is not None:
            return np.asarray(self.speed, dtype=float)
        tab = self.table()
        return np.array([self.stride / (tab.duty * tab.period), 0.0, 0.0])


@dataclass
class WalkResult:
    """The outcome of :func:`walk` on the knots t_k = k Δt, k = 0 … K (T = K + 1 samples).

    Arrays (W: world frame; legs in LEG ORDER lf, lm, lr, rf, rm, rr)
    ------------------------------------------------------------------
    t (T,) [s]; q (T, 18) leg joints [rad], URDF order; body (T, 7) position [m] + quaternion xyzw (W);
    body_ref (T, 7) the reference body pose (horizontal pose from the command; height and tilt from the
    stance plane, :attr:`tracking_error`); stance (T, 6) bool: the legs that carry the robot during
    [t_k, t_{k+1}] (the gait table's u ≥ σ: a foot touching down at t_k is in stance, one lifting off is
    not); feet (T, 6, 3) [m] W: the foot-ball centres (the ``{leg}_foot`` frames, from the joint angles by FK);
    contacts (T, 6, 3) [m] W: where the balls touch the terrain (centre − r n; for a swing foot the point
    under it); com (T, 3) [m] W;
    margin (T,) [m]: static stability margin (the smaller of the supports before and after t_k);
    slip (T,) [m]: largest drift of a stance ball centre from where it rests (its touch-down point, rolled
    along with ``rolling=True``): sliding on the ground;
    rolling (T, 6) [m]: per stance foot, how far its ball has turned since touch-down as a rolling distance
    r |Δθ_⊥| (:func:`~coop_ga.legged.contact.rolling_distance`): with ``rolling=True`` how far it rolled (its
    centre and contact point moved that far, without sliding), with ``rolling=False`` how far it must slide
    because the plan holds its centre (the error of a fixed-contact plan);
    torque_ratio (T,): max |τ| / stall over the joints (equal load sharing);
    tracking_error (T, 2): the body against the stance reference — the ground contact plane of the stance
    feet at knot k (least squares, unfiltered), ride height above it, body z along its normal (with
    ``tilt_follow``) — [m along the normal (signed), rad of body-z tilt]; body_error (T,) [m]: body position vs
    ``body_ref``; ground_height (T,) [m]: terrain under the body origin; support_height (T,): the stance
    plane under it (the baseline: its filtered plane); swing_clearance (T,) [m]: smallest clearance of a swing
    foot ball above the terrain solid (inf with no swing foot); segment_clearance (T, 6) [m]: per leg the
    smallest clearance of its capsules (coxa, femur, shin; :func:`~coop_ga.legged.contact.leg_clearance`, a
    lower bound) above the terrain solid; contact_error (T,) [m]: max |distance of a stance ball from the
    terrain| (0: resting on it); yaw (T,) [rad] the reference heading; reach_margin (T,) [m]: the smallest
    workspace margin of a foot target; primitive_kind (T,) str: the stance primitive that carried the posture
    command into knot k ("plane"; "" at k = 0 or without posture), well_definedness (T,) its well-definedness.

    Scalars: ``distance`` [m]; ``min_margin``, ``max_slip``, ``max_rolling``, ``max_torque_ratio``,
    ``max_tracking_error`` (2,) (absolute), ``min_segment_clearance``, ``max_limit_violation`` [rad],
    ``max_joint_speed`` [rad/s]; ``posture`` True if the body went through ``posture_step``;
    ``fallback_steps``: knots where closed-form IK failed and the clipped DLS fallback was used;
    ``posture_failures``: steps where ``posture_step`` raised and the body was put at its reference pose;
    ``foothold_shifts``: footholds moved (by up to ``max_foothold_shift`` [m]) to keep the leg capsules off the
    terrain; ``raised_swings``: swing arcs raised for the same; ``q_lower``, ``q_upper``, ``velocity_limit``
    (18,); ``table``, ``options``, ``dt``.
    """

    t: np.ndarray
    q: np.ndarray
    body: np.ndarray
    body_ref: np.ndarray
    stance: np.ndarray
    feet: np.ndarray
    contacts: np.ndarray
    com: np.ndarray
    margin: np.ndarray
    slip: np.ndarray
    rolling: np.ndarray
    torque_ratio: np.ndarray
    tracking_error: np.ndarray
    body_error: np.ndarray
    ground_height: np.ndarray
    support_height: np.ndarray
    swing_clearance: np.ndarray
    segment_clearance: np.ndarray
    contact_error: np.ndarray
    yaw: np.ndarray
    reach_margin: np.ndarray
    primitive_kind: np.ndarray
    well_definedness: np.ndarray
    table: GaitTable
    options: WalkOptions
    dt: float
    posture: bool
    q_lower: np.ndarray
    q_upper: np.ndarray
    velocity_limit: np.ndarray | None = None
    fallback_steps: int = 0
    posture_failures: int = 0
    foothold_shifts: int = 0
    max_foothold_shift: float = 0.0
    raised_swings: int = 0
    notes: list[str] = field(default_factory=list)

    @property
    def distance(self) -> float:
        """Horizontal distance [m] of the body from its start."""
        return float(np.linalg.norm(self.body[-1, :2] - self.body[0, :2]))

    @property
    def min_margin(self) -> float:
        return float(self.margin.min())

    @property
    def max_slip(self) -> float:
        return float(self.slip.max())

    @property
    def max_rolling(self) -> float:
        """Largest rolling distance [m] of a stance foot ball over one stance."""
        return float(self.rolling.max())

    @property
    def min_segment_clearance(self) -> float:
        """Smallest clearance [m] of a leg capsule above the terrain over the walk (≥ 0: no leg cuts it)."""
        return float(self.segment_clearance.min())

    @property
    def max_torque_ratio(self) -> float:
        return float(self.torque_ratio.max())

    @property
    def max_tracking_error(self) -> np.ndarray:
        return np.asarray(np.abs(self.tracking_error).max(axis=0), dtype=float)

    @property
    def max_limit_violation(self) -> float:
        return float(self._violation().max())

    @property
    def max_joint_speed(self) -> float:
        return float(np.abs(np.diff(self.q, axis=0)).max() / self.dt) if len(self.t) > 1 else 0.0

    def _speeds(self) -> np.ndarray:
        """(T − 1, 18) |Δq|/Δt [rad/s] between consecutive knots."""
        return np.abs(np.diff(self.q, axis=0)) / self.dt if len(self.t) > 1 else np.zeros((0, 18))

    @property
    def max_velocity_violation(self) -> float:
        """Largest joint speed above its URDF limit [rad/s] (0: the plan respects the speed limits)."""
        if self.velocity_limit is None or len(self.t) < 2:
            return 0.0
        return float(np.maximum(self._speeds() - self.velocity_limit, 0.0).max())

    @property
    def max_velocity_ratio(self) -> float:
        """Largest joint speed as a fraction of its URDF limit (≤ 1 inside the limits)."""
        if self.velocity_limit is None or len(self.t) < 2:
            return 0.0
        return float((self._speeds() / self.velocity_limit).max())

    def _violation(self) -> np.ndarray:
        """(T, 18) distance of every joint outside its limits [rad] (0 inside)."""
        return np.maximum(np.maximum(self.q_lower - self.q, self.q - self.q_upper), 0.0)

    def state(self, k: int) -> BodyState:
        """The :class:`BodyState` at knot k."""
        return BodyState.from_quaternion(self.body[k, :3], self.body[k, 3:], self.q[k])


# ====================================================================== helpers
def _rot_z(yaw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _fit_plane(P: np.ndarray) -> tuple[np.ndarray, float]:
    """Least-squares plane n·x = d of points (k ≥ 3, 3), n the unit normal with n_z > 0."""
    c = P.mean(axis=0)
    _, _, Vt = np.linalg.svd(P - c)
    n = Vt[-1]
    if n[2] < 0:
        n = -n
    return n, float(n @ c)


def _contact_plane(centres: np.ndarray, radius: float) -> tuple[np.ndarray, float]:
    """The ground contact plane n·x = d of resting foot balls: the centres' least-squares plane moved down a radius."""
    n, d = _fit_plane(centres)
    return n, d - radius


def _rotation_log(R: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return np.asarray(Rotation.from_matrix(R).as_rotvec(), dtype=float)


def _body_rotation(n: np.ndarray, yaw: float) -> np.ndarray:
    """R_WB with body z = n and the body x axis the heading (cos yaw, sin yaw, 0) projected ⊥ n."""
    h = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    x = h - (h @ n) * n
    x /= np.linalg.norm(x)
    y = np.cross(n, x)
    return np.column_stack((x, y, n))


def _smoothstep(x: float) -> float:
    x = min(max(x, 0.0), 1.0)
    return x * x * (3.0 - 2.0 * x)


def _nominal_feet(legs: LegModel, options: WalkOptions) -> np.ndarray:
    """(6, 3) nominal foot-ball centres in B: the stand feet (or ``foot_reach`` out from the coxa axis along the
    mounting direction) a ride height minus a ball radius below the body."""
    feet = np.asarray(legs.fk(legs.q_stand), dtype=float).reshape(6, 3).copy()
    if options.foot_reach is not None:
        yaw = np.asarray(legs.mount_yaw, dtype=float)
        mount = np.asarray(legs.mount_position, dtype=float)
        feet[:, 0] = mount[:, 0] + options.foot_reach * np.cos(yaw)
        feet[:, 1] = mount[:, 1] + options.foot_reach * np.sin(yaw)
    feet[:, 2] = legs.foot_radius - options.ride_height
    return feet


def _solve_legs(legs: LegModel, feet_B: np.ndarray, q_prev: np.ndarray) -> tuple[np.ndarray, bool]:
    """Closed-form IK (knee_up, limits enforced) of (6, 3) targets in B; where it fails, DLS from
    ``q_prev`` with every iterate clipped to the limits (the feet then miss their targets: measured as slip
    for stance feet).  Returns (q (18,), fallback used)."""
    from ..errors import UnreachableError

    try:
        return np.asarray(legs.ik(feet_B, "knee_up"), dtype=float), False
    except UnreachableError:
        res = legs.dls_ik(feet_B, q_prev, damping=1e-2, tol=1e-9, max_iter=200, clip_to_limits=True)
        return np.asarray(res.q, dtype=float), True


def _reference_path(cmd: np.ndarray, dt: float, n_knots: int, ramp: float) -> np.ndarray:
    """(n_knots, 3) reference (x, y, yaw) [m, m, rad] integrating the body-frame command with the ramp
    (midpoint rule per step: exact for a constant command between knots)."""
    out = np.zeros((n_knots, 3))
    for k in range(1, n_knots):
        tm = (k - 0.5) * dt
        r = _smoothstep(tm / ramp) if ramp > 0 else 1.0
        yaw_mid = out[k - 1, 2] + 0.5 * cmd[2] * r * dt
        v = _rot_z(yaw_mid)[:2, :2] @ cmd[:2]
        out[k, :2] = out[k - 1, :2] + v * r * dt
        out[k, 2] = out[k - 1, 2] + cmd[2] * r * dt
    return out


def _tilt(n: np.ndarray, follow: float) -> np.ndarray:
    """The body z axis: the support normal n blended toward world z (``tilt_follow``)."""
    z = follow * n + (1.0 - follow) * np.array([0.0, 0.0, 1.0])
    return z / np.linalg.norm(z)


def _on_plane(n: np.ndarray, d: float, xy: np.ndarray, ride: float, z_axis: np.ndarray) -> np.ndarray:
    """The body origin with horizontal position ``xy`` at ``ride`` along ``z_axis`` above the plane n·x = d."""
    # x = (xy, Z), x − ride z_axis on the plane: n·x − ride n·z_axis = d
    Z = (d + ride * float(n @ z_axis) - n[0] * xy[0] - n[1] * xy[1]) / n[2]
    return np.array([xy[0], xy[1], Z])


def _off_edges(terrain: Any, xy: np.ndarray, clearance: float) -> np.ndarray:
    """A foothold xy (2,) moved at least ``clearance`` [m] away from the terrain's cell edges (risers, tile
    borders) inside its own cell (the cell centre if the cell is narrower than 2 · clearance)."""
    out = np.array(xy, dtype=float)
    if clearance <= 0:
        return out
    for k, name in ((0, "x_edges"), (1, "y_edges")):
        e = np.asarray(getattr(terrain, name, ()), dtype=float).ravel()
        if e.size == 0:
            continue
        i = int(np.searchsorted(e, out[k], side="right"))
        lo = e[i - 1] if i > 0 else -math.inf
        hi = e[i] if i < e.size else math.inf
        if hi - lo < 2.0 * clearance:
            out[k] = 0.5 * (lo + hi)
        else:
            out[k] = min(max(out[k], lo + clearance), hi - clearance)
    return out


def _max_height(terrain: Any, a: np.ndarray, b: np.ndarray) -> float:
    """The highest terrain [m] under the segment a → b (xy): ``Terrain.max_height`` where it exists."""
    if hasattr(terrain, "max_height"):
        return float(terrain.max_height(a, b))
    line = a[None, :] + np.linspace(0.0, 1.0, 65)[:, None] * (b - a)[None, :]
    return float(np.max(np.asarray(terrain.height(line), dtype=float)))


def _violation_legs(legs: LegModel, q: np.ndarray) -> np.ndarray:
    """(..., 6) largest joint-limit violation [rad] per leg of q (..., 18)."""
    Q = legs.per_leg(q)
    return np.maximum(np.maximum(legs.q_lower - Q, Q - legs.q_upper), 0.0).max(axis=-1)


# ====================================================================== the planner
@dataclass
class _Grid:
    """The walk's integer phase grid and reference path (module docstring, step 1–2)."""

    N: int
    dt: float
    S: int
    offsets: np.ndarray
    K: int
    mid: int
    stance_knots: int
    ref: np.ndarray

    def phase(self, k: int) -> np.ndarray:
        return np.mod(k - self.offsets, self.N)


def _grid(opts: WalkOptions, distance: float | None, duration: float | None) -> _Grid:
    tab = opts.table()
    cmd = opts.command()
    T = tab.period
    N = max(6, 6 * round(T / opts.dt / 6))
    dt = T / N
    S = round(tab.swing_fraction * N)
    if abs(S - tab.swing_fraction * N) > 1e-9 or S < 1:
        raise InvalidInputError(
            f"duty {tab.duty} does not put touch-down on the {N}-step grid of a cycle; choose a duty with "
            f"(1 − duty)·{N} integer"
        )
    ramp = T if opts.ramp_time is None else float(opts.ramp_time)
    speed = float(np.linalg.norm(cmd[:2]))
    if distance is not None:
        dist = positive(distance, "distance")
        if speed <= 1e-12:
            raise InvalidInputError("walk(distance=…) needs a translation command; give duration for a turn in place")
        t_end = dist / speed + 0.5 * ramp if dist / speed >= 0.5 * ramp else math.sqrt(dist / speed * ramp)
    elif duration is not None:
        t_end = positive(duration, "duration")
    else:
        raise InvalidInputError("walk needs distance [m] or duration [s]")
    if not t_end / dt <= MAX_KNOTS:
        raise InvalidInputError(
            f"the walk ({'distance' if distance is not None else 'duration'}) would take {t_end:.4g} s = "
            f"{t_end / dt:.3g} knots of {dt:.4g} s, above {MAX_KNOTS}; walk a shorter distance or duration"
        )
    K = math.ceil(t_end / dt - 1e-9)
    mid = round(0.5 * tab.duty * N)
    offsets = np.round(tab.offsets * N).astype(int)
    ref = _reference_path(cmd, dt, K + 2 * N + 2, ramp)
    return _Grid(N, dt, S, offsets, K, mid, N - S, ref)


class _Walker:
    """The state of one :func:`walk` between knots (module docstring)."""

    def __init__(self, terrain: Any, opts: WalkOptions, lm: LegModel, g: _Grid, light: bool = False) -> None:
        self.terrain, self.opts, self.lm, self.g, self.light = terrain, opts, lm, g, light
        self.r = float(lm.foot_radius)
        self.nominal = _nominal_feet(lm, opts)
        self.alpha = g.dt / (opts.terrain_filter + g.dt) if opts.terrain_filter > 0 else 1.0
        self._pred: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        feet0 = np.array([self.centre(self.nominal[i, :2]) for i in range(6)])
        p0, R0 = self.predicted_body(0, feet0)
        q0, _ = _solve_legs(lm, (feet0 - p0) @ R0, lm.q_stand)
        self.state = BodyState(p0, R0, q0)
        self.feet_W = self.state.feet_world(lm)
        self.touchdown = self.feet_W.copy()
        self.n_pl, self.d_pl = _contact_plane(self.feet_W, self.r)
        self.arcs: dict[int, tuple[np.ndarray, np.ndarray, float, int]] = {}
        self.mass = robot_mass(lm)
        self.rows: dict[str, list[Any]] = {k: [] for k in _ROWS}
        self.fallback = self.failures = self.shifts = self.raised = 0
        self.max_shift = 0.0
        self.posture_used = False
        self.reach = float(np.min(lm.workspace_margin(self.state.feet_body(lm))))
        self.kind, self.wdef = "", math.nan
        self.ref_pose = (p0, R0)

    # ------------------------------------------------------------------ terrain and prediction
    def centre(self, xy: np.ndarray) -> np.ndarray:
        """The ball centre (3,) resting on the terrain with its contact at ``xy`` kept off the cell edges."""
        from .contact import ball_on_terrain

        return ball_on_terrain(self.terrain, _off_edges(self.terrain, xy, self.opts.edge_clearance), self.r)

    def predicted_body(self, k: int, feet: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The reference body pose at knot k: the horizontal pose of the command, height and tilt from the contact
        plane of the six nominal footholds landed at that pose (or of ``feet``)."""
        k = min(k, len(self.g.ref) - 1)
        if feet is None and k in self._pred:
            return self._pred[k]
        x, y, yaw = self.g.ref[k]
        if feet is None:
            xy = np.array([x, y]) + self.nominal[:, :2] @ _rot_z(yaw)[:2, :2].T
            feet = np.array([self.centre(v) for v in xy])
        n, d = _contact_plane(feet, self.r)
        R = _body_rotation(_tilt(n, self.opts.tilt_follow), yaw)
        out = (_on_plane(n, d, np.array([x, y]), self.opts.ride_height, R[:, 2]), R)
        self._pred[k] = out
        return out

    def _clearance(self, i: int, targets: np.ndarray, knots: list[int]) -> tuple[np.ndarray, np.ndarray]:
        """For leg i with its ball at ``targets`` (C, m, 3) at the predicted body poses of ``knots`` (m): the leg
        capsules' smallest clearance (C,) [m] and whether every pose is reachable inside the limits (C,) bool."""
        from .contact import leg_clearance

        poses = [self.predicted_body(k) for k in knots]
        P = np.array([p for p, _ in poses])
        R = np.array([r for _, r in poses])
        C, m = targets.shape[:2]
        feet = np.broadcast_to(self.nominal, (C, m, 6, 3)).copy()
        feet[:, :, i] = np.einsum("mji,cmj->cmi", R, targets - P[None])
        ok: np.ndarray = np.asarray((self.lm.workspace_margin(feet)[..., i] > 0.002).all(axis=1))
        clear = np.full(C, -np.inf)
        idx = np.flatnonzero(ok)
        if idx.size == 0:
            return clear, ok
        q = self.lm.ik(feet[idx], "knee_up", check_limits=False)  # (c, m, 18)
        ok[idx] = (_violation_legs(self.lm, q)[..., i] <= 1e-9).all(axis=1)
        shape = (idx.size, m)
        c = leg_clearance(self.terrain, self.lm, np.broadcast_to(P, (*shape, 3)), np.broadcast_to(R, (*shape, 3, 3)), q)
        clear[idx] = c[..., i].min(axis=1)
        return clear, ok

    def foothold(self, i: int, k_td: int) -> np.ndarray:
        """The ball centre of leg i's next stance (touch-down at knot k_td): the nominal foothold at the reference
        pose of mid-stance, moved (nearest first, :data:`_SHIFTS`) if a leg capsule would come closer than
        ``clearance_margin`` to the terrain at the predicted body poses of touch-down, mid-stance and lift-off."""
        g = self.g
        x, y, yaw = g.ref[min(k_td + g.mid, len(g.ref) - 1)]
        xy = np.array([x, y]) + _rot_z(yaw)[:2, :2] @ self.nominal[i, :2]
        knots = [k_td, k_td + g.stance_knots // 2, k_td + g.stance_knots]
        c0 = self.centre(xy)
        if self.light or self.opts.clearance_margin is None:
            return c0
        clear, ok = self._clearance(i, np.broadcast_to(c0, (1, 3, 3)), knots)
        if ok[0] and clear[0] >= self.opts.clearance_margin:
            return c0
        cands = np.array([self.centre(xy + np.array(d)) for d in _SHIFTS])
        cl, okc = self._clearance(i, np.broadcast_to(cands[:, None, :], (len(cands), 3, 3)), knots)
        good = np.flatnonzero(okc & (cl >= self.opts.clearance_margin))
        j = int(good[0]) if good.size else int(np.argmax(np.where(okc, cl, -np.inf)))
        if not good.size and not (okc[j] and cl[j] > clear[0]):
            return c0
        self.shifts += 1
        self.max_shift = max(self.max_shift, float(np.linalg.norm(cands[j, :2] - c0[:2])))
        return cands[j]

    def swing_lift(self, i: int, a: np.ndarray, b: np.ndarray, lift: float, w0: int, k: int) -> float:
        """The apex lift of leg i's swing a → b (starting at phase w0 at knot k), raised until the leg capsules and
        the ball (while it moves across) stay ``clearance_margin`` off the terrain at the predicted poses."""
        from .contact import leg_clearance

        g, margin = self.g, self.opts.clearance_margin
        n = g.S - w0
        knots = [k + j for j in range(1, n)]
        if not knots or self.light or margin is None:
            return lift
        s = np.array([j / n for j in range(1, n)])
        poses = [self.predicted_body(kk) for kk in knots]
        P = np.array([p for p, _ in poses])
        R = np.array([r for _, r in poses])
        lift0 = lift
        for _ in range(8):
            pts = swing_arc(a, b, lift, s)[0]
            feet = np.broadcast_to(self.nominal, (len(s), 6, 3)).copy()
            feet[:, i] = np.einsum("mji,mj->mi", R, pts - P)
            if np.any(self.lm.workspace_margin(feet)[:, i] < 0.0):
                return lift if lift > lift0 else lift0
            q = self.lm.ik(feet, "knee_up", check_limits=False)
            caps = leg_clearance(self.terrain, self.lm, P, R, q)[:, i]
            moving = (s > 0.15) & (s < 0.85)
            ball = self.terrain.solid_distance(pts[moving]) - self.r if moving.any() else np.array([np.inf])
            worst = float(min(caps.min(), ball.min()))
            if worst >= margin or lift - lift0 >= _MAX_EXTRA_LIFT:
                break
            lift += margin - worst + 0.002
        if lift > lift0:
            self.raised += 1
        return lift

    # ------------------------------------------------------------------ one knot
    def plan_swings(self, k: int, w: np.ndarray) -> None:
        """Arcs of the legs lifting off at knot k (w = 0; at k = 0 also the legs the table has in mid-swing)."""
        g = self.g
        for i in (int(x) for x in np.flatnonzero((w == 0) | ((k == 0) & (w < g.S)))):
            p_lo = self.feet_W[i].copy()
            p_td = self.foothold(i, k + g.S - int(w[i]))
            top = _max_height(self.terrain, p_lo[:2], p_td[:2]) + self.r
            lift = max(top, p_lo[2], p_td[2]) - max(p_lo[2], p_td[2]) + self.opts.lift_height
            lift = self.swing_lift(i, p_lo, p_td, lift, int(w[i]), k)
            self.arcs[i] = (p_lo, p_td, lift, int(w[i]))

    def stance_reference(self, feet: np.ndarray, xyyaw: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """The body reference on the contact plane of the stance ball centres ``feet``: (p, R, n, d)."""
        n, d = _contact_plane(feet, self.r)
        R = _body_rotation(_tilt(n, self.opts.tilt_follow), float(xyyaw[2]))
        return _on_plane(n, d, xyyaw[:2], self.opts.ride_height, R[:, 2]), R, n, d

    def body_baseline(self, k: int, idx: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
        """The kinematic baseline: the body at ride height above the low-pass filtered contact plane."""
        n_new, d_new = _contact_plane(self.feet_W[list(idx)], self.r) if len(idx) >= 3 else (self.n_pl, self.d_pl)
        self.n_pl = (1.0 - self.alpha) * self.n_pl + self.alpha * n_new
        self.d_pl = (1.0 - self.alpha) * self.d_pl + self.alpha * d_new
        nn = np.linalg.norm(self.n_pl)
        n_unit, d_unit = self.n_pl / nn, float(self.d_pl / nn)
        x, y, yaw = self.g.ref[k + 1]
        R_ref = _body_rotation(_tilt(n_unit, self.opts.tilt_follow), yaw)
        return _on_plane(n_unit, d_unit, np.array([x, y]), self.opts.ride_height, R_ref[:, 2]), R_ref

    def body_posture(self, k: int, idx: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
        """Height and attitude through the stance plane (module docstring, step 3)."""
        from . import posture
        from .stance import stance_task

        st, lm, dt = self.state, self.lm, self.g.dt
        names = tuple(LEG_ORDER[i] for i in idx)
        task = stance_task(lm.system, names, "plane")
        V = task.similarity(st.q)
        n_B, d_B = _fit_plane(st.feet_body(lm)[list(idx)])
        p_ref, R_ref, _, _ = self.stance_reference(self.feet_W[list(idx)], self.g.ref[k + 1])
        R_M = st.rotation.T @ R_ref  # the body correction M = T(t) R_M (in B) that puts the plane at its reference
        n_ref = R_M.T @ n_B
        o_ref = -self.opts.ride_height * float(n_ref[2]) + self.r
        target = posture.body_motion_target(V, (d_B - o_ref) * n_B, R_M)
        e = task.error(st.q, target)
        c = min(self.opts.posture_gain, 1.0 / dt) * np.where(posture.OBSERVABLE["plane"], e, 0.0)
        u_ref = np.concatenate([st.rotation.T @ (p_ref - st.position) / dt, _rotation_log(R_M) / dt])
        opts = posture.PostureOptions(dt=dt, frame="primitive")
        new, info = posture.posture_step(st, names, c, lm, opts, nullspace_twist=u_ref, task=task)
        self.kind, self.wdef = str(info.kind), float(info.well_definedness)
        self.posture_used = True
        return new.position, new.rotation

    def step(self, k: int) -> None:
        g = self.g
        w = g.phase(k)
        st = w >= g.S
        idx = tuple(int(i) for i in np.flatnonzero(st))
        self.plan_swings(k, w)
        self.kind, self.wdef = "", math.nan
        p_new, R_new = self.body_baseline(k, idx)
        if self.opts.use_posture:
            try:
                p_new, R_new = self.body_posture(k, idx)
            except CoopGAError:
                self.failures += 1
        targets = self.touchdown.copy()  # stance feet: fixed at their touch-down points in W
        w1 = g.phase(k + 1)
        for i in np.flatnonzero(~st):
            a, b, lift, w0 = self.arcs[int(i)]
            targets[i] = swing_arc(a, b, lift, (w1[i] - w0) / (g.S - w0))[0]
        targets_B = (targets - p_new) @ R_new
        self.reach = float(np.min(self.lm.workspace_margin(targets_B)))
        q_new, fb = _solve_legs(self.lm, targets_B, self.state.q)
        both = st & (w1 >= g.S)
        if self.opts.rolling and self.r > 0 and both.any():  # the stance balls roll with their tibias (no sliding)
            targets[both] = self.touchdown[both] = self.rolled(R_new, q_new, both)
            q_new, fb2 = _solve_legs(self.lm, (targets - p_new) @ R_new, q_new)
            fb = fb or fb2
        self.fallback += int(fb)
        self.state = BodyState(p_new, R_new, q_new)
        new_feet = self.state.feet_world(self.lm)
        for i in np.flatnonzero(w1 == g.S):  # touch-downs at k + 1 register their contact point
            self.touchdown[i] = new_feet[i]
        if not self.light:  # (check_command's dry run needs only q and the reach)
            self.record(k + 1, st)
        self.feet_W = new_feet

    def rolled(self, R_new: np.ndarray, q_new: np.ndarray, legs: np.ndarray) -> np.ndarray:
        """The centres (m, 3) of the stance balls ``legs`` (6,) bool after the step, rolled without sliding: a ball
        whose tibia turns by Δθ (in W) moves its centre by ``r Δθ × n`` (n the ground normal; the contact point's
        velocity ``v_c + ω × (−r n)`` is then 0).  Δθ is taken from the step solved with the centres held, so the
        centre is right to second order in Δθ (the extra turn of the re-solve is ~r Δθ / L)."""
        from scipy.spatial.transform import Rotation

        R0 = self.state.rotation @ self.lm.link_frames(self.state.q)["tibia"][0][legs]
        R1 = R_new @ self.lm.link_frames(q_new)["tibia"][0][legs]
        dth = Rotation.from_matrix(R1 @ np.swapaxes(R0, -1, -2)).as_rotvec()
        c = self.touchdown[legs]
        n = np.asarray(self.terrain.normal(c[:, :2]), float)
        return c + self.r * np.cross(dth, n)

    def record(self, k: int, stance_prev: np.ndarray | None) -> None:
        lm, state, rows, g = self.lm, self.state, self.rows, self.g
        st = g.phase(k) >= g.S
        fw = state.feet_world(lm)
        com_W = state.to_world(robot_com(state.q, lm))
        sets = [st] if stance_prev is None else [st, stance_prev]
        p_ref, R_ref, n, d = self.stance_reference(fw[st], np.array([*state.position[:2], g.ref[k, 2]]))
        z_ref = R_ref[:, 2]
        z = state.rotation[:, 2]  # the tilt as atan2(|z × z_ref|, z · z_ref): exact near 0 (acos is not)
        tilt = math.atan2(float(np.linalg.norm(np.cross(z, z_ref))), float(z @ z_ref))
        rows["tracking_error"].append([float(n @ state.position - d - self.opts.ride_height * (n @ z_ref)), tilt])
        dist = self.terrain.solid_distance(fw) - self.r
        rows["t"].append(k * g.dt)
        rows["q"].append(state.q.copy())
        rows["body"].append(state.pose7())
        rows["body_ref"].append(BodyState(p_ref, R_ref, state.q).pose7())
        rows["stance"].append(st)
        rows["feet"].append(fw)
        rows["contacts"].append(fw - self.r * np.asarray(self.terrain.normal(fw[:, :2]), float))
        rows["com"].append(com_W)
        rows["margin"].append(min(static_stability_margin(com_W[:2], fw[s][:, :2]) for s in sets))
        rows["slip"].append(float(np.linalg.norm(fw[st] - self.touchdown[st], axis=1).max()) if st.any() else 0.0)
        tau = static_torques(state, st, lm, self.mass)
        rows["torque_ratio"].append(float(np.max(np.abs(tau) / np.asarray(lm.effort_limit))))
        rows["body_error"].append(float(np.linalg.norm(state.position - p_ref)))
        rows["ground_height"].append(float(np.asarray(self.terrain.height(state.position[:2]))))
        rows["support_height"].append(float((d - n[0] * state.position[0] - n[1] * state.position[1]) / n[2]))
        rows["swing_clearance"].append(float(dist[~st].min()) if (~st).any() else math.inf)
        rows["contact_error"].append(float(np.abs(dist[st]).max()) if st.any() else 0.0)
        rows["yaw"].append(float(g.ref[k, 2]))
        rows["reach_margin"].append(self.reach)
        rows["primitive_kind"].append(self.kind)
        rows["well_definedness"].append(self.wdef)

    def result(self) -> WalkResult:
        from .contact import leg_clearance, rolling_distance

        lm, data = self.lm, {key: np.asarray(val) for key, val in self.rows.items()}
        lo, hi, vmax = np.empty(18), np.empty(18), np.empty(18)
        lo[np.asarray(lm.q_index).ravel()] = np.asarray(lm.q_lower).ravel()
        hi[np.asarray(lm.q_index).ravel()] = np.asarray(lm.q_upper).ravel()
        vmax[np.asarray(lm.q_index).ravel()] = np.asarray(lm.velocity_limit).ravel()
        states = [BodyState.from_quaternion(b[:3], b[3:], q) for b, q in zip(data["body"], data["q"])]
        P = np.array([s.position for s in states])
        R = np.array([s.rotation for s in states])
        seg = leg_clearance(self.terrain, lm, P, R, data["q"])
        normals = np.asarray(self.terrain.normal(data["feet"][..., :2]), float)
        roll = rolling_distance(lm, R, data["q"], normals, data["stance"])
        notes = [] if self.opts.use_posture else ["use_posture=False: body set to the filtered support-plane pose"]
        return WalkResult(
            t=data["t"].astype(float), q=data["q"], body=data["body"], body_ref=data["body_ref"],
            stance=data["stance"].astype(bool), feet=data["feet"], contacts=data["contacts"], com=data["com"],
            margin=data["margin"], slip=data["slip"], rolling=roll, torque_ratio=data["torque_ratio"],
            tracking_error=data["tracking_error"], body_error=data["body_error"],
            ground_height=data["ground_height"], support_height=data["support_height"],
            swing_clearance=data["swing_clearance"], segment_clearance=seg, contact_error=data["contact_error"],
            yaw=data["yaw"], reach_margin=data["reach_margin"], primitive_kind=data["primitive_kind"].astype(str),
            well_definedness=data["well_definedness"].astype(float), table=self.opts.table(), options=self.opts,
            dt=self.g.dt, posture=self.posture_used, q_lower=lo, q_upper=hi, velocity_limit=vmax,
            fallback_steps=self.fallback, posture_failures=self.failures, foothold_shifts=self.shifts,
            max_foothold_shift=self.max_shift, raised_swings=self.raised, notes=notes,
        )  # fmt: skip


_ROWS = (
    "t",
    "q",
    "body",
    "body_ref",
    "stance",
    "feet",
    "contacts",
    "com",
    "margin",
    "slip",
    "torque_ratio",
    "tracking_error",
    "body_error",
    "ground_height",
    "support_height",
    "swing_clearance",
    "contact_error",
    "yaw",
    "reach_margin",
    "primitive_kind",
    "well_definedness",
)


# ====================================================================== walking
def _walk_args(terrain: Any, options: Any, legs: Any) -> tuple[WalkOptions, LegModel]:
    from .legs import hexapod_legs

    opts = options if options is not None else WalkOptions()
    if not isinstance(opts, WalkOptions):
        raise InvalidInputError(f"options must be a WalkOptions, got {type(opts).__name__}")
    need = ("height", "land", "normal", "solid_distance", "capsule_clearance")
    if not all(callable(getattr(terrain, f, None)) for f in need):
        raise InvalidInputError(
            f"terrain must be a coop_ga.legged.Terrain (Terrain.make(kind) with kind in flat, slope, steps, random), "
            f"got {type(terrain).__name__}"
        )
    return opts, (check_legs(legs) if legs is not None else hexapod_legs())


#: check_command's verdicts on commands that passed, per (options, legs)
_CHECKED: dict[tuple[WalkOptions, int], tuple[Any, dict[str, float]]] = {}


def check_command(options: WalkOptions | None = None, legs: LegModel | None = None) -> dict[str, float]:
    """Refuse a velocity command the legs cannot walk, before a walk: one cycle of the gait at full command
    on flat ground (the kinematic baseline, no posture loop) must keep every foot target inside the legs'
    reach and joint limits and every joint below its URDF speed limit.

    Args:
        options: the :class:`WalkOptions` (gait, speed, cycle time, …).
        legs: the :class:`~coop_ga.legged.legs.LegModel` (default the hexapod's).

    Returns:
        ``{"reach_margin_m", "velocity_ratio"}``: the smallest workspace margin of a foot target [m] and the
            largest joint speed as a fraction of its limit over that cycle.

    Raises:
        InvalidInputError: a foot target beyond the reach or the joint limits, or a joint faster than its
            speed limit; the message names the leg / joint, the limit and the speed that would pass.
    """
    from dataclasses import replace

    from .terrain import Terrain

    opts, lm = _walk_args(Terrain.flat(), options, legs)
    key = (opts, id(lm))
    hit = _CHECKED.get(key)
    if hit is not None and hit[0] is lm:
        return dict(hit[1])
    dry = replace(opts, use_posture=False)
    g = _grid(dry, None, (dry.period if dry.ramp_time is None else float(dry.ramp_time)) + 1.25 * dry.period)
    w = _Walker(Terrain.flat(), dry, lm, g, light=True)
    qs, reaches = [w.state.q], [w.reach]
    for k in range(g.K):
        w.step(k)
        qs.append(w.state.q)
        reaches.append(w.reach)
        if w.fallback or w.reach < 0.0:  # out of reach: no need to walk on
            break
    q = np.asarray(qs)
    reach = float(np.min(reaches))
    cmd = opts.command()
    if w.fallback or reach < 0.0:
        raise InvalidInputError(
            f"the velocity command {np.round(cmd, 4).tolist()} (vx, vy, ωz) is beyond the legs' reach: over one "
            f"{opts.gait} cycle of {opts.period:g} s a foot target leaves the workspace or the joint limits (smallest "
            f"reach margin {1e3 * reach:.1f} mm, {w.fallback} knots without an IK solution inside the limits); "
            "lower the speed or shorten cycle_time"
        )
    speeds = np.abs(np.diff(q, axis=0)) / g.dt
    vmax = np.empty(18)
    vmax[np.asarray(lm.q_index).ravel()] = np.asarray(lm.velocity_limit).ravel()
    ratio = speeds / vmax
    j = int(np.argmax(ratio.max(axis=0)))
    top = float(ratio.max())
    if top > 1.0:
        name = [n for leg in lm.joint_names for n in leg][list(np.asarray(lm.q_index).ravel()).index(j)]
        raise InvalidInputError(
            f"the velocity command {np.round(cmd, 4).tolist()} (vx, vy, ωz) with a {opts.period:g} s {opts.gait} "
            f"cycle needs {name} to turn at {top * vmax[j]:.2f} rad/s, beyond its URDF speed limit {vmax[j]:.2f} "
            f"rad/s ({top:.2f}×); lengthen cycle_time to ≥ {opts.period * top:.3g} s or lower the speed"
        )
    out = {"reach_margin_m": reach, "velocity_ratio": top}
    _CHECKED[key] = (lm, out)
    return dict(out)


def walk(
    terrain: Terrain,
    options: WalkOptions | None = None,
    distance: float | None = None,
    duration: float | None = None,
    legs: LegModel | None = None,
) -> WalkResult:
    """Walk the hexapod over ``terrain`` (module docstring: gait, body reference, the posture loop through the
    stance plane, swing arcs to footholds that keep the legs off the terrain, checks at every step).

    Args:
        terrain: a :class:`~coop_ga.legged.terrain.Terrain`.
        options: :class:`WalkOptions` (default: the tripod at its default speed).
        distance: walk until the reference has travelled this far [m] (needs a translation command);
        duration: or for this long [s]; exactly one of the two (``distance`` wins if both are given).
        legs: the :class:`~coop_ga.legged.legs.LegModel` (default :func:`~coop_ga.legged.legs.hexapod_legs`).

    Returns:
        A :class:`WalkResult`.

    Raises:
        InvalidInputError: bad arguments (an unknown gait is refused by :class:`WalkOptions`, an unknown terrain
            kind by :meth:`Terrain.make`), or a command beyond the legs' reach or speed limits
            (:func:`check_command`, before the run).
    """
    opts, lm = _walk_args(terrain, options, legs)
    check_command(opts, lm)
    g = _grid(opts, distance, duration)
    w = _Walker(terrain, opts, lm, g)
    w.record(0, None)
    for k in range(g.K):
        w.step(k)
    return w.result()
