"""Walking: a phase-table gait, stance legs through the posture task of the stance primitive, swing feet
on arcs to footholds on the terrain, and the per-step checks (static stability, limits, slip, torques).

One step Δt of :func:`walk` (all positions in the world frame W unless said otherwise):

1. **Gait** (:func:`~coop_ga.legged.gait.phase_table`): leg i's phase counter w_i = (k − o_i) mod N on
   an integer grid of N knots per cycle, N a multiple of 6 (Δt is rounded to T / N so that every
   lift-off and touch-down falls on a knot, exactly).  Leg i swings during [t_k, t_{k+1}] when
   w_i(k) < S = σN and stands otherwise (the table's u ≥ σ): a stance foot stays at its touch-down
   point in W.  Legs that the table has in mid-swing at t = 0 swing over the rest of their swing.
2. **Body reference** at t_{k+1}: the horizontal pose (x, y, yaw) integrates the velocity command
   ``(v_x, v_y, ω_z)`` (body forward, body left, yaw rate; ramped in over ``ramp_time`` from rest with a
   smoothstep).  Height and tilt come from the **support plane**, the least-squares plane of the stance
   feet, low-pass filtered with ``terrain_filter`` [s] so that the body does not jump when the stance set
   changes: the body's z axis is its normal n (``tilt_follow`` ∈ [0, 1] blends toward the world z), the
   body x axis is the heading projected on the plane, and the body origin rides at ``ride_height``
   above the plane along n.
3. **Stance legs and body through the cooperative task** (:func:`~coop_ga.legged.posture.posture_step`,
   issue items 2 and 5): the body twist (v, ω) in B that reaches the reference in Δt is handed over as the
   body-frame twist of the stance primitive it causes (``command_from_body_twist(v, ω) = −ξ``: feet fixed
   in W appear to move by the inverse motion), with (v, ω) also as the ``nullspace_twist`` for the motions
   the primitive cannot see (for a plane: in-plane translation and yaw about its normal; for a circle:
   the rotation about its axis; for a sphere: every rotation about its centre).  The posture step picks the
   stance primitive (a sphere when ≥ 4 stance feet span one — ripple or wave on uneven ground — else the
   plane), solves body twist and stance joint velocities together inside the joint limits, moves the body
   and re-solves the stance legs by closed-form IK for the same world feet.  The body takes the pose the
   posture step reached; its residual against the reference (along the support normal [m] and of the body
   z axis [rad]) is the reported tracking error, and the next step's command closes the loop on it.  So
   the body keeps its posture relative to the support primitive (ride height and tilt follow the ground)
   and walks where it is told.  With ``use_posture=False`` (or no ``posture`` module) the body is put at
   its reference pose directly (kinematic baseline).
4. **Swing legs**: at lift-off the foothold is planned: ``terrain.land`` of the nominal foothold (B:
   ``foot_reach`` out from the coxa axis along the mounting direction, ``ride_height`` below the body)
   placed at the reference body pose of mid-stance (touch-down + βT/2), so that each stance foot sweeps
   the stride symmetrically about its nominal point, and kept ``edge_clearance`` away from the terrain's
   cell edges (a foot on a riser's edge has no single support plane).  The foot follows
   :func:`~coop_ga.legged.gait.swing_arc` from its lift-off point with the apex ``lift_height`` above the
   highest terrain under the straight line between them (``Terrain.max_height``: risers are never
   missed).  All legs by closed-form IK in the body frame at the new body pose (``knee_up``, limits
   enforced).  Should a target be unreachable inside the limits, DLS IK with every iterate clipped to
   the limits is used instead (counted in ``fallback_steps``; the foot then misses its target, which
   shows as slip for a stance foot): the joint limits hold by construction.
5. **Checks** at every knot: the static stability margin (:func:`static_stability_margin`: the
   whole-robot COM's ground projection inside the convex hull of the stance feet, in metres, for the
   supports of the steps before and after the knot), joint-limit violation (0 by construction), foot
   slip (drift of a stance foot from its touch-down point, from the FK of the joint angles), terrain
   contact of the stance feet and clearance of the swing feet, the workspace margin of the foot targets,
   the static joint torques for equal load sharing (:func:`static_torques`) against the servo stall
   torque (URDF effort), and the posture tracking error.

Gait parameters (:class:`WalkOptions` defaults), chosen for the PhantomX-size robot (feet 0.1 m below
the body, leg reach 0.2 m): footholds 0.16 m out from the coxa axes (at the stand pose's 0.174 m the
corner legs come within 1 cm of full extension at the ends of the stride, and closer on steps), stride
0.08 m, cycle times 1.6 / 2.4 / 4.0 s (tripod / ripple / wave: 0.10 / 0.05 / 0.024 m/s), lift 0.03 m
(the steps rise 0.03 m, the random tiles ≤ 0.025 m).  With these, over a 1 m walk (Δt ≈ 0.02 s,
``experiments/hexapod_walk.py``) the minimum static stability margin is 82–88 / 110–115 / 122–123 mm
(tripod / ripple / wave, over flat, steps and random ground), the foot targets keep ≥ 5.6 mm of
workspace margin, the static torques stay ≤ 0.57 × stall, stance-foot slip is ≤ 4e-16 m and no joint
leaves its position limits.  The plan is kinematic; its joint speeds are checked against the URDF's
speed limit (6.18 rad/s, the AX-12A's no-load speed): the default cycle times keep the peak below it
(``max_velocity_violation`` 0; with the earlier 1.0 / 1.2 / 1.5 s the swings reached 8.6–14.2 rad/s).

Model assumptions, said once: the COM is the whole robot's (Pinocchio, base link included: 1.873 kg);
torques treat the legs as massless with the full weight shared equally by the stance feet (the
issue's "equal load sharing"), the foot is the point ``{leg}_foot`` (the 9 mm foot ball is drawn but
not collided), and the plan is kinematic (quasi-static): an optional rigid-contact roll-out is the
check of the dynamics.
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
#: default cycle times T [s] per gait (module docstring of :class:`WalkOptions`).
#: default gait periods [s], chosen so that the plan's peak joint speed stays below the URDF's speed
#: limit (6.18 rad/s, the AX-12A's no-load speed) on flat, steps and random ground: measured peaks over
#: 1 m on steps 5.4 / 5.4 / 5.6 rad/s (tripod / ripple / wave); with 1.0 / 1.2 / 1.5 s they were 8.6 /
#: 10.3 / 14.2 rad/s (the swing speed scales like 1 / period)
CYCLE_TIME: dict[str, float] = {"tripod": 1.6, "ripple": 2.4, "wave": 4.0}
#: :class:`WalkOptions` refuses a ``dt`` that gives more knots per cycle, :func:`walk` a walk of more knots
MAX_KNOTS_PER_CYCLE = 100_000
MAX_KNOTS = 1_000_000
#: the servo's no-load speed [rad/s] (AX-12A at 12 V: 59 rev/min, robot README [AX]); reported, not enforced.
SERVO_SPEED = 59.0 * 2.0 * math.pi / 60.0


@dataclass(frozen=True)
class WalkOptions:
    """Options of :func:`walk`.

    Attributes
    ----------
    gait: "tripod" | "ripple" | "wave" (:func:`~coop_ga.legged.gait.phase_table`).
    speed: the velocity command ``(v_x, v_y, ω_z)`` [m/s, m/s, rad/s] in the body frame (forward, left,
        yaw rate); ``None``: straight ahead at ``stride / (β T)``, the speed at which each stance foot
        travels ``stride`` relative to the body.
    stride: stance stroke [m] of the default forward speed (0.08 m: the corner legs of the PhantomX-size
        robot reach about ±0.06 m along x from their stand foothold at 0.1 m below the body).
    cycle_time: T [s]; ``None``: :data:`CYCLE_TIME` (tripod 1.6, ripple 2.4, wave 4.0 s).
    duty: duty factor β; ``None``: the gait's (1/2, 2/3, 5/6).
    lift_height: swing apex above the highest terrain under the swing [m].
    ride_height: body origin above the support plane along its normal [m] (stand pose: 0.0993 m).
    dt: requested time step [s]; rounded so that a cycle is a whole multiple of the gait's phase grid
        (every lift-off and touch-down on a step).
    ramp_time: the command ramps in from rest over this time [s] (smoothstep); ``None``: one cycle.
    terrain_filter: time constant [s] of the low-pass filter on the support plane (height and tilt).
    tilt_follow: 1 = body z along the support plane normal, 0 = stays level (world z).
    foot_reach: horizontal distance [m] of the nominal foothold from its coxa axis, along the mounting
        direction (0.16 m, module docstring); ``None``: the stand pose's (0.174 m).
    edge_clearance: footholds keep at least this distance [m] from the terrain's cell edges (step risers,
        tile borders), moved inside their cell: a foot on an edge has no well-defined support plane.
    use_posture: drive the stance legs through :func:`~coop_ga.legged.posture.posture_step` (the default);
        False: the body is put at its reference pose directly (kinematic baseline, for comparison).
    """

    gait: str = "tripod"
    speed: tuple[float, float, float] | None = None
    stride: float = 0.08
    cycle_time: float | None = None
    duty: float | None = None
    lift_height: float = 0.03
    ride_height: float = 0.1
    dt: float = 0.02
    ramp_time: float | None = None
    terrain_filter: float = 0.25
    tilt_follow: float = 1.0
    foot_reach: float | None = 0.16
    edge_clearance: float = 0.01
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
        tf = scalar(self.tilt_follow, "tilt_follow")
        if not 0.0 <= tf <= 1.0:
            raise InvalidInputError(f"tilt_follow must be in [0, 1], got {tf}")
        if self.foot_reach is not None:
            positive(self.foot_reach, "foot_reach")
        nonnegative(self.edge_clearance, "edge_clearance")
        if not isinstance(self.use_posture, (bool, np.bool_)):
            raise InvalidInputError(f"use_posture must be True or False, got {self.use_posture!r}")
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
    body_ref (T, 7) the reference body pose; stance (T, 6) bool: the legs that carry the robot during
    [t_k, t_{k+1}] (the gait table's u ≥ σ: a foot touching down at t_k is in stance, one lifting off is
    not); feet (T, 6, 3) [m] W (from the joint angles by FK); com (T, 3) [m] W;
    margin (T,) [m]: static stability margin (the smaller of the supports before and after t_k);
    slip (T,) [m]: largest drift of a stance foot from its touch-down point;
    torque_ratio (T,): max |τ| / stall over the joints (equal load sharing);
    tracking_error (T, 2): the posture step's residual against the reference body pose
    [m along the support normal, rad of body-z tilt]; body_error (T,) [m]: final body position vs reference;
    ground_height (T,) [m]: terrain height under the body origin; support_height (T,): the filtered
    support plane's height under it; swing_clearance (T,) [m]: min height of a swing foot above the
    terrain (inf with no swing foot); contact_error (T,) [m]: max |signed distance| of a stance foot;
    yaw (T,) [rad] the reference heading; reach_margin (T,) [m]: the smallest workspace margin of a foot
    target (:meth:`~coop_ga.legged.legs.LegModel.workspace_margin`); primitive_kind (T,) str: the stance
    primitive the posture step used to reach knot k ("plane", "circle", "sphere", …; "" at k = 0 or
    without posture), well_definedness (T,) its well-definedness (NaN where none).

    Scalars: ``distance`` [m] horizontal distance of the body from its start; ``yaw`` [rad] the
    body's final heading (unwrapped); ``min_margin``, ``max_slip``, ``max_torque_ratio``,
    ``max_tracking_error`` (2,), ``max_limit_violation`` [rad] (0: inside the limits everywhere),
    ``max_joint_speed`` [rad/s]; ``posture`` True if the stance legs went through ``posture_step``;
    ``fallback_steps``: knots where closed-form IK failed and the DLS fallback (clipped to the limits)
    was used; ``posture_failures``: steps where ``posture_step`` raised a
    :class:`~coop_ga.errors.CoopGAError` and the body was put at its reference pose instead (0 in every
    run we know of); ``q_lower``, ``q_upper`` (18,) the joint limits [rad]; ``velocity_limit`` (18,) the
    URDF's joint speed limits [rad/s] (``max_velocity_violation``, ``max_velocity_ratio`` measure the plan's
    finite-difference joint speeds against them); ``table`` the gait table,
    ``options``, ``dt``.
    """

    t: np.ndarray
    q: np.ndarray
    body: np.ndarray
    body_ref: np.ndarray
    stance: np.ndarray
    feet: np.ndarray
    com: np.ndarray
    margin: np.ndarray
    slip: np.ndarray
    torque_ratio: np.ndarray
    tracking_error: np.ndarray
    body_error: np.ndarray
    ground_height: np.ndarray
    support_height: np.ndarray
    swing_clearance: np.ndarray
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
    def max_torque_ratio(self) -> float:
        return float(self.torque_ratio.max())

    @property
    def max_tracking_error(self) -> np.ndarray:
        return np.asarray(self.tracking_error.max(axis=0), dtype=float)

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
    """(6, 3) nominal footholds in B: the stand feet (or ``foot_reach`` out from the coxa axis along the
    mounting direction) at z = −ride_height."""
    feet = np.asarray(legs.fk(legs.q_stand), dtype=float).reshape(6, 3).copy()
    if options.foot_reach is not None:
        yaw = np.asarray(legs.mount_yaw, dtype=float)
        mount = np.asarray(legs.mount_position, dtype=float)
        feet[:, 0] = mount[:, 0] + options.foot_reach * np.cos(yaw)
        feet[:, 1] = mount[:, 1] + options.foot_reach * np.sin(yaw)
    feet[:, 2] = -options.ride_height
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


def _posture_module() -> Any:
    try:
        from . import posture
    except ImportError:  # pragma: no cover - posture.py is another engineer's module
        return None
    return posture


def _posture_update(
    posture: Any,
    state: BodyState,
    stance_idx: tuple[int, ...],
    p_ref: np.ndarray,
    R_ref: np.ndarray,
    legs: LegModel,
    dt: float,
) -> tuple[BodyState, np.ndarray, Any]:
    """Step 3 of the module docstring: the stance legs and the body through ``posture_step``.

    The command is the velocity of the stance primitive in B that the reference body motion causes: a
    world-fixed primitive seen from a body moving with the tangent ξ (``M ← M exp(Δt ξ)``, body.py)
    moves by ``exp(−Δt ξ)``, so the command is −ξ with ξ the body twist that reaches (p_ref, R_ref)
    in Δt.  Returns the new state (body at the posture step's pose; stance legs as it solved them) and
    the residual [m along the body z, rad of z tilt] of that pose against the reference, and the
    ``PostureStep``.
    """
    v = state.rotation.T @ (p_ref - state.position) / dt
    w = _rotation_log(state.rotation.T @ R_ref) / dt
    command = posture.command_from_body_twist(v, w)
    opts = posture.PostureOptions(dt=dt, frame="body")
    stance_names = tuple(LEG_ORDER[i] for i in stance_idx)
    new, info = posture.posture_step(state, stance_names, command, legs, opts, nullspace_twist=np.concatenate([v, w]))
    n_ref = R_ref[:, 2]
    err_h = abs(float(n_ref @ (new.position - p_ref)))
    err_t = float(math.acos(float(np.clip(new.rotation[:, 2] @ n_ref, -1.0, 1.0))))
    return new, np.array([err_h, err_t]), info


# ====================================================================== walking
def _walk_args(terrain: Any, options: Any, legs: Any) -> tuple[WalkOptions, LegModel]:
    """The checked options (default :class:`WalkOptions`) and legs (default the hexapod's) of :func:`walk`."""
    from .legs import hexapod_legs

    opts = options if options is not None else WalkOptions()
    if not isinstance(opts, WalkOptions):
        raise InvalidInputError(f"options must be a WalkOptions, got {type(opts).__name__}")
    if not all(callable(getattr(terrain, f, None)) for f in ("height", "land")):
        raise InvalidInputError(
            f"terrain must be a coop_ga.legged.Terrain (or have height(xy) and land(xy)), got {type(terrain).__name__}"
        )
    return opts, check_legs(legs) if legs is not None else hexapod_legs()


def _walk_duration(speed: float, ramp: float, dt: float, distance: Any, duration: Any) -> float:
    """The walk's duration [s] from ``distance`` [m] at ``speed`` [m/s] after a ``ramp`` [s], or ``duration`` [s];
    at most :data:`MAX_KNOTS` knots of ``dt`` (bounded work)."""
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
    return t_end


def walk(
    terrain: Terrain,
    options: WalkOptions | None = None,
    distance: float | None = None,
    duration: float | None = None,
    legs: LegModel | None = None,
) -> WalkResult:
    """Walk the hexapod over ``terrain`` (module docstring: gait, body reference, stance legs through the
    posture task, swing arcs to landed footholds, checks at every step).

    Parameters
    ----------
    terrain: a :class:`~coop_ga.legged.terrain.Terrain` (any object with ``height(xy)`` and ``land(xy)``).
    options: :class:`WalkOptions` (default: the tripod at its default speed).
    distance: walk until the reference has travelled this far [m] (needs a translation command);
    duration: or for this long [s]; exactly one of the two (``distance`` wins if both are given).
    legs: the :class:`~coop_ga.legged.legs.LegModel` (default :func:`~coop_ga.legged.legs.hexapod_legs`).

    Returns a :class:`WalkResult`.  Raises :class:`~coop_ga.errors.InvalidInputError` for bad arguments.
    """
    opts, lm = _walk_args(terrain, options, legs)
    tab = opts.table()
    cmd = opts.command()
    T = tab.period
    # ---- the integer phase grid: N knots per cycle, a multiple of 6 (all table offsets are k/6)
    N = max(6, 6 * round(T / opts.dt / 6))
    dt = T / N
    S = round(tab.swing_fraction * N)
    if abs(S - tab.swing_fraction * N) > 1e-9 or S < 1:
        raise InvalidInputError(
            f"duty {tab.duty} does not put touch-down on the {N}-step grid of a cycle; choose a duty with "
            f"(1 − duty)·{N} integer"
        )
    offsets = np.round(tab.offsets * N).astype(int)
    ramp = T if opts.ramp_time is None else float(opts.ramp_time)
    t_end = _walk_duration(float(np.linalg.norm(cmd[:2])), ramp, dt, distance, duration)
    K = math.ceil(t_end / dt - 1e-9)
    mid = round(0.5 * tab.duty * N)
    ref = _reference_path(cmd, dt, K + N + mid + 2, ramp)

    nominal = _nominal_feet(lm, opts)
    posture = _posture_module() if opts.use_posture else None

    def phase(k: int) -> np.ndarray:
        return np.mod(k - offsets, N)

    def foothold(i: int, k_td: int) -> np.ndarray:
        x, y, yaw = ref[min(k_td + mid, len(ref) - 1)]
        xy = np.array([x, y]) + _rot_z(yaw)[:2, :2] @ nominal[i, :2]
        return np.asarray(terrain.land(_off_edges(terrain, xy, opts.edge_clearance)), dtype=float).reshape(3)

    # ---- initial state: all six feet on the ground at the nominal footholds, body at ride height
    feet_W = np.array(
        [
            np.asarray(terrain.land(_off_edges(terrain, nominal[i, :2], opts.edge_clearance)), dtype=float).reshape(3)
            for i in range(6)
        ]
    )
    n_pl, d_pl = _fit_plane(feet_W)
    R0 = _body_rotation(_tilt(n_pl, opts.tilt_follow), 0.0)
    p0 = _on_plane(n_pl, d_pl, np.zeros(2), opts.ride_height, R0[:, 2])
    q0, _ = _solve_legs(lm, (feet_W - p0) @ R0, lm.q_stand)
    state = BodyState(p0, R0, q0)
    feet_W = state.feet_world(lm)
    touchdown = feet_W.copy()
    arcs: dict[int, tuple[np.ndarray, np.ndarray, float, int]] = {}
    mass = robot_mass(lm)
    alpha = dt / (opts.terrain_filter + dt) if opts.terrain_filter > 0 else 1.0

    rows: dict[str, list[Any]] = {k: [] for k in _ROWS}
    fallback = 0
    failures = 0
    posture_used = False
    err_track = np.zeros(2)
    p_ref, R_ref = p0, R0
    reach = float(np.min(lm.workspace_margin(state.feet_body(lm))))
    kind, wdef = "", math.nan

    def record(k: int, stance_prev: np.ndarray | None) -> None:
        st = phase(k) >= S
        fw = state.feet_world(lm)
        com_W = state.to_world(robot_com(state.q, lm))
        sets = [st] if stance_prev is None else [st, stance_prev]
        margin = min(static_stability_margin(com_W[:2], fw[s][:, :2]) for s in sets)
        slip = float(np.linalg.norm(fw[st] - touchdown[st], axis=1).max()) if st.any() else 0.0
        tau = static_torques(state, st, lm, mass)
        h_ground = float(np.asarray(terrain.height(state.position[:2])))
        sw = ~st
        if sw.any():
            hs = np.asarray(terrain.height(fw[sw][:, :2]), dtype=float)
            clear = float((fw[sw][:, 2] - hs).min())
        else:
            clear = math.inf
        hc = np.asarray(terrain.height(fw[st][:, :2]), dtype=float) if st.any() else np.zeros(0)
        contact = float(np.abs(fw[st][:, 2] - hc).max()) if st.any() else 0.0
        n_f = n_pl / np.linalg.norm(n_pl)
        support = (d_pl - n_f[0] * state.position[0] - n_f[1] * state.position[1]) / n_f[2]
        rows["t"].append(k * dt)
        rows["q"].append(state.q.copy())
        rows["body"].append(state.pose7())
        rows["body_ref"].append(BodyState(p_ref, R_ref, state.q).pose7())
        rows["stance"].append(st)
        rows["feet"].append(fw)
        rows["com"].append(com_W)
        rows["margin"].append(margin)
        rows["slip"].append(slip)
        rows["torque_ratio"].append(float(np.max(np.abs(tau) / np.asarray(lm.effort_limit))))
        rows["tracking_error"].append(err_track.copy())
        rows["body_error"].append(float(np.linalg.norm(state.position - p_ref)))
        rows["ground_height"].append(h_ground)
        rows["support_height"].append(float(support))
        rows["swing_clearance"].append(clear)
        rows["contact_error"].append(contact)
        rows["yaw"].append(float(ref[k, 2]))
        rows["reach_margin"].append(reach)
        rows["primitive_kind"].append(kind)
        rows["well_definedness"].append(wdef)

    record(0, None)
    for k in range(K):
        w = phase(k)
        st = w >= S
        idx = tuple(int(i) for i in np.flatnonzero(st))
        # plan the arcs of the legs lifting off now (w = 0; at k = 0 also the legs the table has in mid-swing,
        # over the rest of their swing): from where the foot is to its foothold
        for i in np.flatnonzero((w == 0) | ((k == 0) & (w < S))):
            p_lo = feet_W[i].copy()
            p_td = foothold(int(i), k + S - int(w[i]))
            top = _max_height(terrain, p_lo[:2], p_td[:2])
            lift = max(top, p_lo[2], p_td[2]) - max(p_lo[2], p_td[2]) + opts.lift_height
            arcs[int(i)] = (p_lo, p_td, lift, int(w[i]))
        # body reference at t_{k+1}: horizontal pose from the command, height/tilt from the support plane
        n_new, d_new = _fit_plane(feet_W[list(idx)]) if len(idx) >= 3 else (n_pl, d_pl)
        n_pl = (1.0 - alpha) * n_pl + alpha * n_new
        d_pl = (1.0 - alpha) * d_pl + alpha * d_new
        nn = np.linalg.norm(n_pl)
        n_unit, d_unit = n_pl / nn, float(d_pl / nn)
        x, y, yaw = ref[k + 1]
        R_ref = _body_rotation(_tilt(n_unit, opts.tilt_follow), yaw)
        p_ref = _on_plane(n_unit, d_unit, np.array([x, y]), opts.ride_height, R_ref[:, 2])
        # stance legs and body through the posture task (the body moves, the stance feet stay in W)
        p_new, R_new = p_ref, R_ref
        kind, wdef = "", math.nan
        if posture is not None and len(idx) >= 3:
            try:
                moved, err_track, info = _posture_update(posture, state, idx, p_ref, R_ref, lm, dt)
            except CoopGAError:
                failures += 1
            else:
                p_new, R_new = moved.position, moved.rotation
                kind, wdef = str(info.kind), float(info.well_definedness)
                posture_used = True
        # swing feet on their arcs; every leg by closed-form IK at the new body pose (the stance legs get
        # the posture step's own re-solve: the same world feet, the same branch)
        targets = touchdown.copy()  # stance feet: fixed at their touch-down points in W
        w1 = phase(k + 1)
        for i in np.flatnonzero(~st):
            a, b, lift, w0 = arcs[int(i)]
            targets[i] = swing_arc(a, b, lift, (w1[i] - w0) / (S - w0))[0]
        targets_B = (targets - p_new) @ R_new
        reach = float(np.min(lm.workspace_margin(targets_B)))
        q_new, fb = _solve_legs(lm, targets_B, state.q)
        fallback += int(fb)
        state = BodyState(p_new, R_new, q_new)
        new_feet = state.feet_world(lm)
        # touch-downs at k + 1 register their contact point
        for i in np.flatnonzero(w1 == S):
            touchdown[i] = new_feet[i]
        record(k + 1, st)
        feet_W = new_feet
    data = {key: np.asarray(val) for key, val in rows.items()}
    lo, hi = np.empty(18), np.empty(18)
    lo[np.asarray(lm.q_index).ravel()] = np.asarray(lm.q_lower).ravel()
    hi[np.asarray(lm.q_index).ravel()] = np.asarray(lm.q_upper).ravel()
    vmax = np.empty(18)
    vmax[np.asarray(lm.q_index).ravel()] = np.asarray(lm.system.limits.velocity)[np.asarray(lm.model_q_index).ravel()]
    notes = []
    if posture is None:
        notes.append("posture_step unavailable or disabled: body set to its reference pose directly")
    return WalkResult(
        t=data["t"].astype(float),
        q=data["q"],
        body=data["body"],
        body_ref=data["body_ref"],
        stance=data["stance"].astype(bool),
        feet=data["feet"],
        com=data["com"],
        margin=data["margin"],
        slip=data["slip"],
        torque_ratio=data["torque_ratio"],
        tracking_error=data["tracking_error"],
        body_error=data["body_error"],
        ground_height=data["ground_height"],
        support_height=data["support_height"],
        swing_clearance=data["swing_clearance"],
        contact_error=data["contact_error"],
        yaw=data["yaw"],
        reach_margin=data["reach_margin"],
        primitive_kind=data["primitive_kind"].astype(str),
        well_definedness=data["well_definedness"].astype(float),
        table=tab,
        options=opts,
        dt=dt,
        posture=posture_used,
        q_lower=lo,
        q_upper=hi,
        velocity_limit=vmax,
        fallback_steps=fallback,
        posture_failures=failures,
        notes=notes,
    )


_ROWS = (
    "t",
    "q",
    "body",
    "body_ref",
    "stance",
    "feet",
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


def _tilt(n: np.ndarray, follow: float) -> np.ndarray:
    """The body z axis: the support normal n blended toward world z (``tilt_follow``)."""
    z = follow * n + (1.0 - follow) * np.array([0.0, 0.0, 1.0])
    return z / np.linalg.norm(z)


def _on_plane(n: np.ndarray, d: float, xy: np.ndarray, ride: float, z_axis: np.ndarray) -> np.ndarray:
    """The body origin with horizontal position ``xy`` at ``ride`` along ``z_axis`` above the plane n·x = d."""
    # x = (xy, Z), x − ride z_axis on the plane: n·x − ride n·z_axis = d
    Z = (d + ride * float(n @ z_axis) - n[0] * xy[0] - n[1] * xy[1]) / n[2]
    return np.array([xy[0], xy[1], Z])
