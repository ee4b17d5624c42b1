"""Body posture control through the stance primitive (issue 13, item 5; seed 003 §3.4, Eq 30, 44, 48).

The stance feet span a cooperative primitive — a plane or circle through three feet, a sphere through
four, the least-squares sphere/plane of more (seed 003 §3, §5.6; chosen and built by
:func:`coop_ga.legged.stance.stance_primitive` / :func:`~coop_ga.legged.stance.stance_task`, see
:func:`stance_posture_task`).  Seen from the body frame B its similarity is
``V(q) = V_Sc(q)`` of the fixed-base ``hexapod`` system (the body at the origin), with the body-frame
geometric Jacobian ``J^G`` (Eq 30).  A *posture command* is a similarity twist ``c`` of that primitive
(7-vector ``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]``, units 1/s):

* ``frame="primitive"`` (default): the convention of the task's Jacobian rows and of its error
  ``e = log(Ṽ V_d)`` (Eq 44): ``V(t + Δt) = V(t) exp(c Δt)``; :func:`posture_to` commands
  ``gain · log(Ṽ V_target)``.  Translation rows are in radii per second for circles and spheres
  (metres for planes), as J^G's.
* ``frame="body"``: a twist about B's origin along B's axes, ``V(t + Δt) = exp(c Δt) V(t)``: a point x
  of B moves with ``ẋ = t + ω × x + β x`` (ω = (θ23, −θ13, θ12)).  ``c_P = Ad_V⁻¹ c_B``.

**The step** (:func:`posture_step`).  Unknowns: the body twist ``u = (v, ω)`` in B [m/s, rad/s].  A
stance foot fixed in W moves in B with ``ṗ_i = −(v + ω × p_i)``, so its leg's joints move with
``q̇_i = −J_i⁻¹ (v + ω × p_i)`` (J_i the 3×3 foot Jacobian of :meth:`LegModel.jacobians`): the stance
legs' joint velocities are determined by u, ``q̇_s = L u``, and the primitive's twist is linear in u,
``b = J^G_s L u = A u`` (body twist and stance legs solved together, issue item 2).  The step solves the
QP (:func:`coop_ga.control.qp.solve_qp`)

    min_u  ‖M (A u − c_P)‖² + μ² ‖F u − f‖² + λ² ‖u‖²    s.t.  lb ≤ L u ≤ ub

with M the rows the primitive can see (below), F u the feet velocities in B and f the command's velocity
field on the feet (or ``F = I``, ``f = nullspace_twist`` when the caller gives the body twist for the
invisible motions), μ = ``secondary_weight`` (small: the primitive's rows dominate), and the joint box
of :func:`~coop_ga.control.qp.velocity_bounds` (position limits over Δt with the safety gain, URDF
velocity limits; every tibia is also kept ``knee_margin`` short of the straight leg, where the leg
Jacobian is singular and the reach ends).  Should DAQP fail on a nearly singular problem, the
unconstrained minimiser scaled back onto the box is taken (u = 0 is always feasible).  The body moves by ``M_B ← M_B T(v Δt) R(ω Δt)``; the stance legs are then re-solved
by closed-form IK (:meth:`LegModel.ik`, same knee branch) at the new body pose for the *same world
feet*, so the feet stay fixed to round-off (``max_slip`` ≈ 1e-16 m; ``linear_slip`` is what the
linearised joint step alone would have slipped).  If the exact IK would leave a joint limit (the box
is linear, the IK is not) the step is halved, up to ``max_backtracks`` times, else not taken
(``backtracks``, ``scale``): no returned state is ever outside the limits.

**What the primitive sees.**  A motion that maps the unit primitive onto itself does not move the
primitive, so those coordinates of a twist in the primitive frame are not observable (the rank of J^G
is the primitive's DOF, seed 003 Table 1): the rotations of a sphere (e12, e13, e23); the yaw (e12),
in-plane translations (e1∞, e2∞) and dilation (e0∞) of a plane; the rotation of a circle about its
axis (e12).  They are left out of the tracking objective (M) and of the tracking error; the secondary
objective decides them (a yaw command on a plane still yaws the body through the feet field).

**Dilation with the feet fixed.**  A rigid body cannot change the distances between its feet, so the
radius of a stance circle or sphere cannot change: the e0∞ row of A is identically zero.  A dilation
in the primitive frame (about its centre) is therefore not realisable at all and is reported whole as
tracking error; a dilation about the body origin (``frame="body"``) moves the primitive's centre
toward/away from the body (c_P has translation rows), which the body realises — it crouches or rises —
and the radius part remains as tracking error (``radius_rate_error``).  For a plane (no radius) a
body-frame dilation is an offset change and is realised entirely.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import validation
from ..errors import InvalidInputError, UnreachableError
from ..geometry.groups import Similarity, bivector_to_tangent, tangent_to_bivector
from ..validation import array, choice, integer, nonnegative, positive, vector
from .body import LEG_ORDER, BodyState, body_tangent, check_rotation, stance_indices

if TYPE_CHECKING:  # pragma: no cover
    from ..cooperative.task import CooperativeTask
    from .legs import LegModel

__all__ = [
    "OBSERVABLE",
    "PostureOptions",
    "PostureResult",
    "PostureStep",
    "adjoint",
    "body_motion_target",
    "command_from_body_twist",
    "feet_field",
    "posture_step",
    "posture_to",
    "stance_posture_task",
]

#: rows of a primitive-frame twist that move the primitive (True) per kind; the others map the unit
#: primitive onto itself (module docstring).  Order ``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]``.
OBSERVABLE: dict[str, np.ndarray] = {
    "sphere": np.array([False, False, False, True, True, True, True]),
    "plane": np.array([False, True, True, False, False, False, True]),
    "circle": np.array([False, True, True, True, True, True, True]),
}
#: the e0∞ (dilation) row
_BETA = 3
#: [rad] an exact IK solution this far beyond a limit is clipped onto it (round-off of a joint resting on it)
_CLIP_TOL = 1e-10


def _base_kind(kind: str) -> str:
    """``"sphere_fit"`` → ``"sphere"`` (the LSQ kinds of :mod:`coop_ga.legged.stance` have the stabiliser of their kind)."""
    if not isinstance(kind, str):
        raise InvalidInputError(f"kind must be a stance primitive kind (str), got {kind!r}")
    k = kind[:-4] if kind.endswith("_fit") else kind
    if k not in OBSERVABLE:
        raise InvalidInputError(f"posture control needs a stance plane, circle or sphere, got kind {kind!r}")
    return k


@dataclass(frozen=True)
class PostureOptions:
    """Options of :func:`posture_step` / :func:`posture_to`.

    dt: step [s].  gain: :func:`posture_to`'s proportional gain [1/s] (command = gain · error).
    frame: ``"primitive"`` or ``"body"``, the frame of the command twist (module docstring).
    kind: stance primitive ``"plane"``, ``"circle"``, ``"sphere"`` (more than 4 / 3 feet: the least-squares
        ``"sphere_fit"`` / ``"plane_fit"``, also accepted by name) or None: the choice of
        :func:`coop_ga.legged.stance.stance_primitive` (a sphere when ≥ 4 feet span one with
        well-definedness ≥ ``w_min`` and radius ≤ 5 m, else a plane).
    damping: λ of the QP [dimensionless] on the body twist.
    secondary_weight: μ, weight of the secondary objective (feet field / nullspace twist) [s/m, s].
    limit_gain: safety gain γ ∈ (0, 1] of the position limits over one step (mink's 0.95).
    max_backtracks: halvings of a step whose exact IK would leave the joint limits.
    knee_margin: [rad] the QP keeps every tibia this far from the straight leg (singular leg Jacobian,
        the end of the reach; the two knee branches meet there).
    w_min: well-definedness threshold of the automatic sphere.
    tol, max_steps: :func:`posture_to` stops when the observable error norm ≤ tol or after max_steps.
    """

    dt: float = 0.01
    gain: float = 5.0
    frame: str = "primitive"
    kind: str | None = None
    damping: float = 1e-6
    secondary_weight: float = 1e-2
    limit_gain: float = 0.95
    max_backtracks: int = 8
    knee_margin: float = 0.05
    w_min: float = 1e-2
    tol: float = 1e-6
    max_steps: int = 500

    def __post_init__(self) -> None:
        positive(self.dt, "PostureOptions.dt")
        nonnegative(self.gain, "PostureOptions.gain")
        choice(self.frame, ("primitive", "body"), "PostureOptions.frame")
        if self.kind is not None:
            _base_kind(self.kind)
        nonnegative(self.damping, "PostureOptions.damping")
        nonnegative(self.secondary_weight, "PostureOptions.secondary_weight")
        g = positive(self.limit_gain, "PostureOptions.limit_gain")
        if g > 1.0:
            raise InvalidInputError(f"PostureOptions.limit_gain must be in (0, 1], got {g}")
        integer(self.max_backtracks, "PostureOptions.max_backtracks", minimum=0)
        nonnegative(self.knee_margin, "PostureOptions.knee_margin")
        nonnegative(self.w_min, "PostureOptions.w_min")
        positive(self.tol, "PostureOptions.tol")
        integer(self.max_steps, "PostureOptions.max_steps", minimum=1)


@dataclass(frozen=True)
class PostureStep:
    """What one :func:`posture_step` did.

    kind: the stance primitive used (``"plane"``, ``"circle"``, ``"sphere"``); task_kind: its task-graph
        kind (``"sphere_fit"`` / ``"plane_fit"`` for the least-squares primitives of > 4 / > 3 feet); stance_legs: the stance legs (names, LEG ORDER); task_legs: the
        feet that define the primitive (in the task's point order).
    well_definedness: of the primitive at the start of the step (1 best, 0 degenerate).
    command: (7,) the command in its frame; command_primitive: (7,) the same in the primitive frame.
    body_twist: (6,) ``(v [m/s], ω [rad/s])`` in B, as taken (after backtracking).
    achieved_twist: (7,) the primitive's realised twist over the step, ``log(Ṽ_k V_k+1)/Δt`` (primitive
        frame), mapped to the command's frame; observable rows only (others 0).
    tracking_error: (7,) observable rows of ``command_primitive − achieved`` (primitive frame, 1/s).
    tracking_error_norm: its norm.  radius_rate_error: its e0∞ row (the radius change the rigid body
        cannot make, circle/sphere; 0 for a plane).
    secondary_error: max over stance feet of ‖F u − f‖ [m/s] (the command's feet field not realised)
        or ‖u − nullspace_twist‖ when one was given.
    max_slip: [m] largest motion in W of a stance foot over the step (after the IK re-solve).
    linear_slip: [m] what the linearised joint step q + L u Δt alone would have slipped.
    limited: a joint bound of the QP was active, or the step was shortened/refused.
    active_joints: names of the stance joints at a bound of the QP (position or velocity limit);
        position_limited_joints: those held by their position limit.
    backtracks, scale: halvings for the exact IK to stay inside the limits, and the fraction of the
        QP step taken (0: refused).
    max_limit_violation: [rad] of the returned state (all 18 joints; 0 by construction).
    """

    kind: str
    task_kind: str
    stance_legs: tuple[str, ...]
    task_legs: tuple[str, ...]
    well_definedness: float
    command: np.ndarray
    command_primitive: np.ndarray
    body_twist: np.ndarray
    achieved_twist: np.ndarray
    tracking_error: np.ndarray
    tracking_error_norm: float
    radius_rate_error: float
    secondary_error: float
    max_slip: float
    linear_slip: float
    limited: bool
    active_joints: tuple[str, ...]
    position_limited_joints: tuple[str, ...]
    backtracks: int
    scale: float
    max_limit_violation: float


@dataclass
class PostureResult:
    """A :func:`posture_to` run: ``T = steps + 1`` states.

    t: (T,) [s]; q: (T, 18); body: (T, 7) position [m] + quaternion xyzw (W); error: (T, 7) the
    observable rows of ``log(Ṽ V_target)`` (primitive frame); error_norm: (T,); states: the BodyStates;
    steps: the PostureSteps; converged: error_norm ≤ tol at the end; max_slip [m] over the run (stance feet
    from their initial world positions); max_limit_violation [rad]; final_error (7,); message.
    """

    t: np.ndarray
    q: np.ndarray
    body: np.ndarray
    error: np.ndarray
    error_norm: np.ndarray
    states: list[BodyState]
    steps: list[PostureStep]
    converged: bool
    max_slip: float
    max_limit_violation: float
    final_error: np.ndarray
    message: str = field(default="")


# ====================================================================== helpers
def adjoint(V: Any) -> np.ndarray:
    """Ad_V (7, 7): column k is ``V e_k V⁻¹`` on ``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]`` (a similarity V).

    Maps a primitive-frame twist (right: ``V exp(b)``) to the twist about the frame V is expressed in
    (left: ``exp(Ad_V b) V``)."""
    S = Similarity.coerce(V, "V")
    Vm, Vi = S.versor, S.versor.inverse()
    out = np.zeros((7, 7))
    for k in range(7):
        e = np.zeros(7)
        e[k] = 1.0
        out[:, k] = np.asarray(bivector_to_tangent(Vm * tangent_to_bivector(e) * Vi), dtype=float)
    return out


def feet_field(command_B: Any, points_B: Any) -> np.ndarray:
    """Velocity field (k, 3) [m/s] of a body-frame similarity twist on points (k, 3) of B:
    ``ẋ = t + ω × x + β x`` with ``ω = (θ23, −θ13, θ12)`` (the conventions of :mod:`coop_ga.geometry`)."""
    c = vector(command_B, 7, "command_B")
    p = array(points_B, "points_B [m]")
    if p.shape[-1:] != (3,) or p.ndim > 2:
        raise InvalidInputError(f"points_B must have shape (k, 3) or (3,) [m], got shape {p.shape}")
    p = p.reshape(-1, 3)
    w = np.array([c[2], -c[1], c[0]])
    with np.errstate(over="ignore", invalid="ignore"):
        return validation.finite_result(c[4:7] + np.cross(w, p) + c[3] * p, "feet_field(command_B, points_B)")


def command_from_body_twist(v: Any, omega: Any) -> np.ndarray:
    """The body-frame (``frame="body"``) primitive twist (7,) that a body twist ``(v, ω)`` in B
    [m/s, rad/s] produces with the feet fixed in W: the inverse motion, ``−body_tangent(v, ω)``."""
    return -body_tangent(v, omega)


def body_motion_target(V_B: Any, translation: Any = (0.0, 0.0, 0.0), rotation: Any = None) -> Similarity:
    """The body-frame stance similarity after the body moves by ``M = T(translation) R`` (in B,
    ``rotation`` (3, 3) or None): the feet fixed in W appear moved by ``M⁻¹``, so ``V' = M⁻¹ V``."""
    from ..kinematics.chains import motor_from_se3

    t = vector(translation, 3, "translation")
    R = np.eye(3)
    if rotation is not None:
        R = array(rotation, "rotation", shape=(3, 3))
        check_rotation(R, "rotation")
    M = Similarity(motor_from_se3((R, t)))
    return Similarity.coerce(M.inverse() @ Similarity.coerce(V_B, "V_B"), "M⁻¹ V")


def stance_posture_task(
    legs: LegModel, q: Any, stance_legs: Any, kind: str | None = None, w_min: float = 1e-2
) -> CooperativeTask:
    """The cooperative task of the stance primitive of ``stance_legs`` over the fixed-base system of
    ``legs`` (body frame B) at leg joints ``q`` (18,): :func:`coop_ga.legged.stance.stance_task` of the kind
    :func:`~coop_ga.legged.stance.stance_primitive` chooses for the stance feet (``kind=None``: a sphere —
    exact for 4 feet, least-squares for more — when well defined (w ≥ ``w_min``), else a plane — exact
    for 3 feet, least-squares for more), or of ``kind`` (``"sphere"``, ``"plane"``, ``"circle"``,
    ``"sphere_fit"``, ``"plane_fit"``)."""
    from .legs import check_legs
    from .stance import stance_order, stance_primitive, stance_task

    check_legs(legs)
    w_min = nonnegative(w_min, "w_min")
    names = stance_order(stance_legs)
    if kind is None:
        feet = legs.fk(vector(q, 18, "q"))[[LEG_ORDER.index(n) for n in names]]
        kind = stance_primitive(feet, w_min=w_min).task_kind
    _base_kind(kind)
    return stance_task(legs.system, names, kind)


def _branch(legs: LegModel, q: np.ndarray) -> np.ndarray:
    """(6,) bool knee_up per leg of q: the tibia's planar knee angle ≤ 0 (the standing branch)."""
    Q = legs.per_leg(q)
    return np.asarray(legs.tibia_sign * Q[:, 2] <= 0.0)


def _effective_limits(legs: LegModel, q: np.ndarray, margin: float) -> tuple[np.ndarray, np.ndarray]:
    """(18,) lower/upper bounds of the QP box: the joint limits, and for every leg the tibia kept
    ``margin`` [rad] short of the straight leg on its current knee branch (where the leg Jacobian is
    singular and the closed-form branches meet)."""
    lo, hi = legs.q_lower.copy(), legs.q_upper.copy()  # (6, 3)
    up = _branch(legs, q)
    s = np.asarray(legs.tibia_sign, dtype=float)
    # knee_up: tibia_sign · q ≤ −margin; knee_down: tibia_sign · q ≥ margin
    bound = np.where(up, -margin, margin) * s
    tighten_hi = (up & (s > 0)) | (~up & (s < 0))
    hi[:, 2] = np.where(tighten_hi, np.minimum(hi[:, 2], bound), hi[:, 2])
    lo[:, 2] = np.where(~tighten_hi, np.maximum(lo[:, 2], bound), lo[:, 2])
    out_lo, out_hi = np.zeros(legs.nq), np.zeros(legs.nq)
    out_lo[legs.q_index.ravel()] = lo.ravel()
    out_hi[legs.q_index.ravel()] = hi.ravel()
    return out_lo, out_hi


def _violation(legs: LegModel, q: np.ndarray) -> float:
    Q = legs.per_leg(q)
    return float(np.max(np.maximum(np.maximum(legs.q_lower - Q, Q - legs.q_upper), 0.0)))


def _knee_bend(legs: LegModel, q: np.ndarray) -> np.ndarray:
    """(6,) [rad] ≥ 0: how far each knee is from the straight leg, |tibia angle| (planar)."""
    return np.abs(np.asarray(legs.tibia_sign) * legs.per_leg(q)[:, 2])


def _resolve(
    legs: LegModel,
    new: BodyState,
    anchors_W: np.ndarray,
    idx: tuple[int, ...],
    q_ref: np.ndarray,
    knee_margin: float,
) -> np.ndarray | None:
    """The stance legs of ``q_ref`` re-solved by closed-form IK so that their feet are at ``anchors_W``
    (6, 3) at the body pose ``new``; None if out of reach or outside the limits."""
    feet_B = legs.fk(q_ref).copy()
    feet_B[list(idx)] = new.to_body(anchors_W[list(idx)])
    try:
        q_ik = legs.ik(feet_B, branch=_branch(legs, q_ref), check_limits=False)
    except UnreachableError:
        return None
    q = q_ref.copy()
    cols = legs.q_index[list(idx)].ravel()
    q[cols] = q_ik[cols]
    if _violation(legs, q) > _CLIP_TOL:
        return None
    if np.any(_knee_bend(legs, q)[list(idx)] < np.minimum(_knee_bend(legs, q_ref)[list(idx)], knee_margin) - 1e-12):
        return None  # a stance leg would straighten into the knee margin (the end of its reach)
    # round-off beyond a limit (a joint resting on it): onto the limit (moves the foot by < 1e-12 m)
    lo, hi = legs.q_lower.ravel(), legs.q_upper.ravel()
    q[legs.q_index.ravel()] = np.clip(q[legs.q_index.ravel()], lo, hi)
    return q


# ====================================================================== the step
def posture_step(
    state: BodyState,
    stance_legs: Any,
    command_twist_B: Any,
    legs: LegModel | None = None,
    options: PostureOptions | None = None,
    *,
    nullspace_twist: Any = None,
    swing_q: Mapping[str, Any] | None = None,
    swing_feet_W: Mapping[str, Any] | None = None,
    task: CooperativeTask | None = None,
) -> tuple[BodyState, PostureStep]:
    """One posture step: move the body so that the stance primitive (seen from B) follows a twist.

    Parameters
    ----------
    state: the current :class:`BodyState` (joints inside the limits).
    stance_legs: ≥ 3 stance legs (names, indices into LEG ORDER, or a (6,) bool mask); their feet stay
        fixed in W.
    command_twist_B: (7,) similarity twist [1/s] of the stance primitive seen from the body, in
        ``options.frame`` (module docstring; ``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]``, Eq 30's rows).
    legs: the :class:`LegModel` (default :func:`~coop_ga.legged.legs.hexapod_legs`).
    options: :class:`PostureOptions`.
    nullspace_twist: optional (6,) body twist ``(v, ω)`` [m/s, rad/s] in B for the motions the
        primitive does not see (secondary objective instead of the command's feet field).
    swing_q: optional joint angles (3,) per swing leg name at the end of the step (default: unchanged).
    swing_feet_W: optional foot targets (3,) [m] in W per swing leg name, solved by closed-form IK at the
        new body pose (knee_up; :class:`~coop_ga.errors.UnreachableError` if out of reach/limits).
    task: the stance primitive's task (e.g. :func:`coop_ga.legged.stance.stance_task`); default built
        from the stance feet (:func:`stance_posture_task`).

    Returns ``(new state, PostureStep)``.
    """
    from ..control.qp import InfeasibleConstraintsError, damped_lstsq, solve_qp, velocity_bounds

    lm, opt, idx = _posture_args(state, stance_legs, legs, options)
    c_in = vector(command_twist_B, 7, "command_twist_B")
    if nullspace_twist is not None:
        nullspace_twist = vector(nullspace_twist, 6, "nullspace_twist")
    _swing_args(swing_q, swing_feet_W, idx, task)
    if _violation(lm, state.q) > 1e-12:
        raise InvalidInputError(
            f"state.q is outside the joint limits by {_violation(lm, state.q):.3g} rad; posture_step starts inside them"
        )
    dt = float(opt.dt)
    q = state.q
    p = lm.fk(q)  # (6, 3) B
    Jl = lm.jacobians(q)  # (6, 3, 3)
    if task is None:
        task = stance_posture_task(lm, q, idx, opt.kind, opt.w_min)
    kind = _base_kind(task.kind)
    tlegs = tuple(int(np.flatnonzero(lm.end_frame_index == i)[0]) for i in task.point_indices)
    if not set(tlegs) <= set(idx):
        raise InvalidInputError(
            f"the task's feet {[LEG_ORDER[i] for i in tlegs]} are not all in stance ({[LEG_ORDER[i] for i in idx]})"
        )
    st = task.evaluate(q)
    V = st.similarity
    Ad = adjoint(V)
    Adi = np.linalg.inv(Ad)
    if opt.frame == "primitive":
        c_P, c_B = c_in, Ad @ c_in
    else:
        c_B, c_P = c_in, Adi @ c_in
    mask = OBSERVABLE[kind]

    # q̇_s = L u (stance legs), feet velocity in B F u = −(v + ω × p_i)
    k = len(idx)
    cols = lm.q_index[list(idx)].ravel()
    L = np.zeros((3 * k, 6))
    F = np.zeros((3 * k, 6))
    for j, i in enumerate(idx):
        Fi = np.hstack([-np.eye(3), _skew(p[i])])  # −v − ω × p = −v + [p]× ω
        F[3 * j : 3 * j + 3] = Fi
        L[3 * j : 3 * j + 3] = np.linalg.pinv(Jl[i], rcond=1e-10) @ Fi  # (a straight leg is singular)
    Jm = st.jacobian  # (7, 18): the fixed-base system's q is the leg q
    A = Jm[:, cols] @ L  # (7, 6) primitive twist per body twist
    mu = float(opt.secondary_weight)
    if nullspace_twist is not None:
        u_ref = vector(nullspace_twist, 6, "nullspace_twist")
        A2, b2 = np.eye(6), u_ref
    else:
        A2, b2 = F, feet_field(c_B, p[list(idx)]).ravel()
    AA = np.vstack([A[mask], mu * A2])
    bb = np.concatenate([c_P[mask], mu * b2])
    lo, hi = _effective_limits(lm, q, float(opt.knee_margin))
    vel = np.asarray(lm.velocity_limit, dtype=float).ravel()
    lb, ub = velocity_bounds(q[cols], lo[cols], hi[cols], vel[cols], dt, float(opt.limit_gain))
    G = np.vstack([L, -L])
    h = np.concatenate([ub, -lb])
    names = [n for i in idx for n in lm.joint_names[i]]
    try:
        sol = solve_qp(AA, bb, float(opt.damping), G=G, h=h, labels=[*names, *names], what="posture_step")
        u = np.asarray(sol.x, dtype=float)
        act = sol.active_rows.reshape(2, -1) if sol.used_qp else np.zeros((2, 3 * k), bool)
    except InfeasibleConstraintsError:
        # numerically hard QP (a joint on its bound, tiny remaining range): u = 0 is always feasible, so
        # take the unconstrained minimiser scaled back onto the box (exact line search along it)
        u_free = damped_lstsq(AA, bb, float(opt.damping))
        Gu = G @ u_free
        pos = Gu > 0
        alpha = float(min(1.0, np.min(h[pos] / Gu[pos]))) if np.any(pos) else 1.0
        u = max(alpha, 0.0) * u_free
        act = (G @ u >= h - 1e-12).reshape(2, -1)
    act2 = np.asarray(act, dtype=bool).reshape(2, -1)
    act_any = [bool(act2[0, j] or act2[1, j]) for j in range(act2.shape[1])]
    active = tuple(n for n, a in zip(names, act_any) if a)
    # which of them are position limits (the box is the tighter of position/Δt and velocity limits)
    pos_hi = opt.limit_gain * (hi[cols] - q[cols]) / dt < vel[cols]
    pos_lo = opt.limit_gain * (lo[cols] - q[cols]) / dt > -vel[cols]
    at_pos = tuple(n for n, a, b, c, d in zip(names, act2[0], pos_hi, act2[1], pos_lo) if (a and b) or (c and d))

    anchors = state.feet_world(lm)
    # linearised step (for the report) and the exact re-solve with backtracking
    q_lin = q.copy()
    q_lin[cols] = q[cols] + L @ u * dt
    scale, back, new_q, new = 1.0, 0, None, state
    while True:
        cand = state.moved(u[:3] * scale, u[3:] * scale, dt)
        new_q = _resolve(lm, cand, anchors, idx, q, float(opt.knee_margin))
        if new_q is not None:
            new = BodyState(cand.position, cand.rotation, new_q)
            break
        if back >= opt.max_backtracks:
            scale, new = 0.0, state.copy()
            break
        back += 1
        scale *= 0.5
    lin_state = state.moved(u[:3], u[3:], dt, q=q_lin)
    linear_slip = float(np.max(np.linalg.norm((lin_state.feet_world(lm) - anchors)[list(idx)], axis=1)))

    # swing legs
    qn = new.q.copy()
    if swing_q:
        for leg, qa in swing_q.items():
            i = _swing_index(leg, idx)
            qn[lm.q_index[i]] = vector(qa, 3, f"swing_q[{leg!r}]")
    if swing_feet_W:
        feet_B = lm.fk(qn).copy()
        chosen = [_swing_index(leg, idx) for leg in swing_feet_W]
        for leg, i in zip(swing_feet_W, chosen):
            feet_B[i] = new.to_body(vector(swing_feet_W[leg], 3, f"swing_feet_W[{leg!r}]"))
        q_ik = lm.ik(feet_B, branch=_branch(lm, qn), check_limits=True)
        for i in chosen:
            qn[lm.q_index[i]] = q_ik[lm.q_index[i]]
    new = BodyState(new.position, new.rotation, qn)

    V_new = task.similarity(new.q)
    b_ach = np.asarray((V.inverse() @ V_new).log(), dtype=float) / dt
    b_ach = np.where(mask, b_ach, 0.0)
    err = np.where(mask, c_P - b_ach, 0.0)
    achieved = b_ach if opt.frame == "primitive" else Ad @ b_ach
    slip = float(np.max(np.linalg.norm((new.feet_world(lm) - anchors)[list(idx)], axis=1)))
    sec = AA[int(mask.sum()) :] @ (u * scale) / mu - b2 if mu > 0 else A2 @ (u * scale) - b2
    sec_err = (
        float(np.max(np.linalg.norm(sec.reshape(-1, 3), axis=1)))
        if nullspace_twist is None
        else float(np.linalg.norm(sec))
    )
    return new, PostureStep(
        kind=kind,
        task_kind=str(task.kind),
        stance_legs=tuple(LEG_ORDER[i] for i in idx),
        task_legs=tuple(LEG_ORDER[i] for i in tlegs),
        well_definedness=float(st.well_definedness),
        command=c_in.copy(),
        command_primitive=c_P.copy(),
        body_twist=u * scale,
        achieved_twist=achieved,
        tracking_error=err,
        tracking_error_norm=float(np.linalg.norm(err)),
        radius_rate_error=float(err[_BETA]),
        secondary_error=sec_err,
        max_slip=slip,
        linear_slip=linear_slip,
        limited=bool(active) or scale < 1.0,
        active_joints=active,
        position_limited_joints=at_pos,
        backtracks=back,
        scale=scale,
        max_limit_violation=_violation(lm, new.q),
    )


def _skew(p: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -p[2], p[1]], [p[2], 0.0, -p[0]], [-p[1], p[0], 0.0]])


def _posture_args(
    state: Any, stance_legs: Any, legs: Any, options: Any
) -> tuple[LegModel, PostureOptions, tuple[int, ...]]:
    """The checked common arguments of :func:`posture_step` and :func:`posture_to`."""
    from .legs import check_legs, hexapod_legs

    if not isinstance(state, BodyState):
        raise InvalidInputError(f"state must be a BodyState, got {type(state).__name__}")
    lm = hexapod_legs() if legs is None else check_legs(legs)
    if options is not None and not isinstance(options, PostureOptions):
        raise InvalidInputError(f"options must be a PostureOptions, got {type(options).__name__}")
    idx = stance_indices(stance_legs)
    if len(idx) < 3:
        raise InvalidInputError(f"posture control needs ≥ 3 stance_legs, got {[LEG_ORDER[i] for i in idx]}")
    return lm, PostureOptions() if options is None else options, idx


def _swing_args(swing_q: Any, swing_feet_W: Any, idx: tuple[int, ...], task: Any = None) -> None:
    """``swing_q`` / ``swing_feet_W``: None or ``{swing leg: (3,)}`` (joint angles [rad] / a foot target [m] in W);
    ``task``: None or a :class:`~coop_ga.cooperative.CooperativeTask`."""
    if task is not None:
        from ..cooperative.task import CooperativeTask

        if not isinstance(task, CooperativeTask):
            raise InvalidInputError(f"task must be a CooperativeTask (stance_task(...)), got {type(task).__name__}")
    for what, m in (("swing_q", swing_q), ("swing_feet_W", swing_feet_W)):
        if m is None:
            continue
        if not isinstance(m, Mapping):
            raise InvalidInputError(f"{what} must be a dict {{swing leg: (3,)}}, got {type(m).__name__}")
        for leg, v in m.items():
            _swing_index(leg, idx)
            vector(v, 3, f"{what}[{leg!r}]")


def _swing_index(leg: Any, idx: tuple[int, ...]) -> int:
    if leg not in LEG_ORDER:
        raise InvalidInputError(f"unknown swing leg {leg!r}; the legs are {', '.join(LEG_ORDER)}")
    i = LEG_ORDER.index(leg)
    if i in idx:
        raise InvalidInputError(f"leg {leg!r} is in stance; only swing legs take joint or foot targets")
    return i


# ====================================================================== to a target
def posture_to(
    state: BodyState,
    stance_legs: Any,
    target_relative: Any,
    legs: LegModel | None = None,
    options: PostureOptions | None = None,
) -> PostureResult:
    """Drive the body-frame stance similarity to ``target_relative`` (a :class:`~coop_ga.Similarity`, the
    target V_Sc seen from B, e.g. :func:`body_motion_target`) with the feet fixed in W.

    Every step commands ``c = gain · e`` with ``e = log(Ṽ_rel V_target)`` (Eq 44, primitive frame; the
    frame option is ignored) and calls :func:`posture_step` (the stance primitive and its feet are fixed
    at the first step).  Stops when the observable error norm ≤ ``tol`` or after ``max_steps``.  A target
    with a different radius cannot be reached with the feet fixed (module docstring): the run ends with
    that radius part as ``final_error``.
    """
    from dataclasses import replace

    lm, opt, idx = _posture_args(state, stance_legs, legs, options)
    opt = replace(opt, frame="primitive")
    target = Similarity.coerce(target_relative, "target_relative")
    task = stance_posture_task(lm, state.q, idx, opt.kind, opt.w_min)
    kind = _base_kind(task.kind)
    tlegs = tuple(int(np.flatnonzero(lm.end_frame_index == i)[0]) for i in task.point_indices)
    mask = OBSERVABLE[kind]
    anchors = state.feet_world(lm)
    states: list[BodyState] = [state.copy()]
    steps: list[PostureStep] = []
    errs: list[np.ndarray] = []
    s = state
    for _ in range(opt.max_steps + 1):
        e = np.where(mask, task.error(s.q, target), 0.0)
        errs.append(e)
        if np.linalg.norm(e) <= opt.tol or len(steps) >= opt.max_steps:
            break
        s, info = posture_step(s, idx, opt.gain * e, lm, opt, task=task)
        states.append(s)
        steps.append(info)
        if info.scale == 0.0:  # blocked by the limits
            errs.append(np.where(mask, task.error(s.q, target), 0.0))
            break
    E = np.array(errs)
    En = np.linalg.norm(E, axis=1)
    slip = max(float(np.max(np.linalg.norm((x.feet_world(lm) - anchors)[list(idx)], axis=1))) for x in states)
    conv = bool(En[-1] <= opt.tol)
    return PostureResult(
        t=np.arange(len(states)) * opt.dt,
        q=np.array([x.q for x in states]),
        body=np.array([x.pose7() for x in states]),
        error=E[: len(states)],
        error_norm=En[: len(states)],
        states=states,
        steps=steps,
        converged=conv,
        max_slip=slip,
        max_limit_violation=max(_violation(lm, x.q) for x in states),
        final_error=E[-1],
        message=(
            f"posture_to ({kind} of {', '.join(LEG_ORDER[i] for i in tlegs)}): "
            f"{'converged' if conv else 'stopped'} after {len(steps)} steps, error {En[-1]:.3g}, "
            f"max slip {slip:.3g} m"
        ),
    )
