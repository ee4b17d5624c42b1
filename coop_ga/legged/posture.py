"""Body posture control through stance primitives (seed 003 §3.4, Table 1, Eq 30, 44, 48).

The stance feet span cooperative primitives — a plane or circle through three feet, a sphere through
four, the least-squares sphere/plane of more, a point pair of two (seed 003 §3, §5.6; built by
:func:`coop_ga.legged.stance.stance_primitive` / :func:`~coop_ga.legged.stance.stance_task`, chosen by
:func:`stance_primitive_tasks`).  Seen from the body frame B a primitive's similarity is
``V(q) = V_Sc(q)`` of the fixed-base ``hexapod`` system (the body at the origin), with the body-frame
geometric Jacobian ``J^G`` (Eq 30).  A *posture command* is a similarity twist ``c`` of a primitive
(7-vector ``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]``, units 1/s):

* ``frame="primitive"`` (default): the convention of the task's Jacobian rows and of its error
  ``e = log(Ṽ V_d)`` (Eq 44): ``V(t + Δt) = V(t) exp(c Δt)``; :func:`posture_to` commands
  ``gain · log(Ṽ V_target)``.  Translation rows are in radii per second for circles, spheres and point
  pairs (metres for planes), as J^G's.
* ``frame="body"``: a twist about B's origin along B's axes, ``V(t + Δt) = exp(c Δt) V(t)``: a point x
  of B moves with ``ẋ = t + ω × x + β x`` (ω = (θ23, −θ13, θ12)).  ``c_P = Ad_V⁻¹ c_B``.  Every primitive
  of feet fixed in W sees the same body-frame twist, the inverse of the body's motion
  (:func:`command_from_body_twist`), so a body-frame command can be carried by several primitives.

**What a stance primitive can carry** (:data:`coop_ga.legged.stance.CARRIED`; seed 003 Table 1 without
e0∞, because fixed feet keep their distances):

==========  ======================================  ==========================================
primitive   carries (feet fixed)                    cannot carry
==========  ======================================  ==========================================
sphere      its centre: translation (e1∞ e2∞ e3∞)   any rotation about its centre; its radius
circle      translation of its centre, tilt of its  rotation about its axis; its radius
            axis (e13 e23)
plane       offset along its normal (e3∞), tilt     rotation about its normal (yaw), in-plane
            (e13 e23)                               translation, scale
point pair  translation of its midpoint, turns      rotation about its own axis; its length
            across it (e12 e23)
==========  ======================================  ==========================================

**Honest commands.**  A command with a component the chosen primitive cannot carry is never turned into
another motion: by default (``PostureOptions.uncontrollable = "raise"``) it raises
:class:`~coop_ga.errors.InvalidInputError` naming the component and the primitive that would carry it;
with ``"report"`` the carried part runs, the rest is not executed and is named in
``PostureStep.uncontrollable`` / ``PostureResult.uncontrollable`` (and :func:`posture_to` ends with
``converged=False``).  Two rules, one for each kind of command:

* a primitive-frame twist or a similarity target of **one** primitive: its rows outside the carried set
  must be zero (|row| ≤ 1e-9 · max(1, ‖c‖)) — e.g. e12/e13/e23 through a sphere, e1∞/e2∞/e12 through a
  plane, e0∞ (radius) through a sphere or circle;
* a body-frame twist or a :class:`BodyMotion` (any number of primitives): the primitives' carried rows
  cannot tell apart body twists that differ by an element of N = ∩ null(C_i A_i) (C_i selects primitive
  i's carried rows, A_i maps a body twist to its twist, below).  Of the twists they cannot tell from the
  command, the one that turns least, and of those the one that translates least, is what they carry (the
  body holds still where no primitive looks); it must be the command itself (to 1e-9 relative, rotations
  weighed by ℓ = :data:`LENGTH_SCALE`).  E.g. a sphere carries pure translations and no rotation, a plane
  its offset and tilts about the body origin, sphere + circle everything but a turn about the circle's
  axis, circle + point pair (not along that axis) all six body DOF.

On flat ground the automatic choice (``primitives=None``) replaces a 4-foot sphere by the plane (the feet
are coplanar, :func:`~coop_ga.legged.stance.stance_primitive`); the step and the result report the kind
used and why (``kind``, ``kind_reason``), and a command the plane cannot carry is refused as above.

**The step** (:func:`posture_step`).  Unknowns: the body twist ``u = (v, ω)`` in B [m/s, rad/s].  A
stance foot fixed in W moves in B with ``ṗ_i = −(v + ω × p_i)``, so its leg's joints move with
``q̇_i = −J_i⁻¹ (v + ω × p_i)`` (J_i the 3×3 foot Jacobian of :meth:`LegModel.jacobians`): the stance
legs' joint velocities are determined by u, ``q̇_s = L u``, and primitive i's twist is linear in u,
``b_i = J^G_i L u = A_i u``.  The step takes the body twist u* that carries the command: the solution of the
carried rows ``C_i A_i u = C_i c_i`` (least squares over the primitives; C_i selects primitive i's carried
rows) that turns least and then translates least (as above), plus the part of the caller's
``nullspace_twist`` that no primitive sees (none: the body holds still there).  The joint box of
:func:`~coop_ga.control.qp.velocity_bounds` (position limits over Δt with the safety gain, URDF velocity
limits; every tibia also kept ``knee_margin`` short of the straight leg, where the leg Jacobian is singular
and the reach ends) then **scales** u* as a whole, ``u = s u*`` with the largest s ∈ [0, 1] for which
``lb ≤ L u ≤ ub``: a limit slows the motion down along its direction, never turns it into another one (a
weighted QP would trade the invisible directions for the carried rows at a limit: a commanded translation
of a sphere's centre came out partly as a rotation of the body).  The body moves by
``M_B ← M_B T(v Δt) R(ω Δt)``; the stance legs are then re-solved by closed-form IK (:meth:`LegModel.ik`,
same knee branch) at the new body pose for the *same world feet*, so the feet stay fixed to round-off
(``max_slip`` ≈ 1e-16 m; ``linear_slip`` is what the linearised joint step alone would have slipped).
If the exact IK would leave a joint limit (the box is linear, the IK is not) the step is halved, up to
``max_backtracks`` times, else not taken (``backtracks``, ``scale``): no returned state is ever outside the
limits.  A joint speed or position limit that holds the body back is reported (``limited``,
``active_joints``), not an error.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import validation
from ..errors import InvalidInputError, UnreachableError
from ..geometry.groups import Similarity, bivector_to_tangent, tangent_to_bivector
from ..geometry.kinds import FIT_KINDS, KIND_SPECS, CooperativeKind, Kind
from ..validation import array, choice, integer, nonnegative, positive, vector
from .body import LEG_ORDER, BodyState, body_tangent, check_rotation, stance_indices
from .stance import CARRIED, ROWS, _primitive_kind, carried_rows, uncarried

if TYPE_CHECKING:  # pragma: no cover
    from ..cooperative.task import CooperativeTask
    from .legs import LegModel

__all__ = [
    "LENGTH_SCALE",
    "OBSERVABLE",
    "BodyMotion",
    "PostureOptions",
    "PostureResult",
    "PostureStep",
    "PrimitiveTask",
    "adjoint",
    "body_motion_target",
    "command_from_body_twist",
    "feet_field",
    "posture_step",
    "posture_to",
    "stance_posture_task",
    "stance_primitive_tasks",
]

#: rows of a primitive-frame twist that move the primitive (True) per kind (seed 003 Table 1; the others map
#: the unit primitive onto itself).  Order ``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]``.  With the feet fixed the
#: e0∞ row cannot move either: what a stance primitive *carries* is :data:`coop_ga.legged.stance.CARRIED`.
OBSERVABLE: dict[str, np.ndarray] = {
    "sphere": np.array([False, False, False, True, True, True, True]),
    "plane": np.array([False, True, True, False, False, False, True]),
    "circle": np.array([False, True, True, True, True, True, True]),
    "point_pair": np.array([True, False, True, True, True, True, True]),
}
#: [m] the length that weighs rotations against translations, ``(v, ℓ ω)``, in the honesty tolerance and the
#: reported secondary error (the hexapod's ride height: a rotation of 1 rad moves a foot about this far)
LENGTH_SCALE = 0.1
#: the e0∞ (dilation) row
_BETA = 3
#: [rad] an exact IK solution this far beyond a limit is clipped onto it (round-off of a joint resting on it)
_CLIP_TOL = 1e-10
#: a command row / body component counts as non-zero above REL · max(1, ‖command‖) + ABS
_REL, _ABS = 1e-9, 1e-12
#: relative singular value below which a direction of the carried map counts as unseen (the null space N)
_RANK_TOL = 1e-9


def _all_feet(kind: str) -> bool:
    """A primitive of ``kind`` goes through all the stance feet: ``"auto"``, a kind with a least-squares fit
    (sphere, plane: any number of feet) or a least-squares kind; the others (circle, point pair) through exactly
    their :attr:`~coop_ga.geometry.kinds.KindSpec.n_points` chosen feet."""
    spec = KIND_SPECS.get(kind)
    return kind == "auto" or (spec is not None and (spec.least_squares or spec.fit_kind is not None))


@dataclass(frozen=True)
class PostureOptions:
    """Options of :func:`posture_step` / :func:`posture_to`.

    dt: step [s].  gain: :func:`posture_to`'s proportional gain [1/s] (command = gain · error).
    frame: ``"primitive"`` or ``"body"``, the frame of the command twist (module docstring).
    kind: the stance primitive when no ``primitives`` are passed: ``"plane"``, ``"circle"``, ``"sphere"``,
        ``"point_pair"`` (``"sphere_fit"`` / ``"plane_fit"`` accepted by name) or None: the choice of
        :func:`coop_ga.legged.stance.stance_primitive` (a sphere when ≥ 4 feet span one with
        well-definedness ≥ ``w_min`` and radius ≤ 5 m, else a plane), reported with its reason.
    uncontrollable: ``"raise"`` (default) or ``"report"``: what a command with a component the primitives
        cannot carry does (module docstring: raise naming it, or run the rest and report it).
    limit_gain: safety gain γ ∈ (0, 1] of the position limits over one step (mink's 0.95).
    max_backtracks: halvings of a step whose exact IK would leave the joint limits.
    knee_margin: [rad] the joint box keeps every tibia this far from the straight leg (singular leg Jacobian,
        the end of the reach; the two knee branches meet there).
    w_min: well-definedness threshold of the automatic sphere.
    tol, max_steps: :func:`posture_to` stops when the carried error norm ≤ tol or after max_steps.
    """

    dt: float = 0.01
    gain: float = 5.0
    frame: str = "primitive"
    kind: str | None = None
    uncontrollable: str = "raise"
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
            _primitive_kind(self.kind)
        choice(self.uncontrollable, ("raise", "report"), "PostureOptions.uncontrollable")
        g = positive(self.limit_gain, "PostureOptions.limit_gain")
        if g > 1.0:
            raise InvalidInputError(f"PostureOptions.limit_gain must be in (0, 1], got {g}")
        integer(self.max_backtracks, "PostureOptions.max_backtracks", minimum=0)
        nonnegative(self.knee_margin, "PostureOptions.knee_margin")
        nonnegative(self.w_min, "PostureOptions.w_min")
        positive(self.tol, "PostureOptions.tol")
        integer(self.max_steps, "PostureOptions.max_steps", minimum=1)


@dataclass(frozen=True)
class PrimitiveTask:
    """One stance primitive resolved for posture control (:func:`stance_primitive_tasks`).

    kind: ``"sphere"``, ``"circle"``, ``"plane"`` or ``"point_pair"``; task_kind: the task-graph kind
    (``"sphere_fit"`` / ``"plane_fit"`` for the least-squares primitives of more feet); legs: its feet in
    the task's point order; task: the :class:`~coop_ga.cooperative.CooperativeTask`; reason: why this kind
    and these feet; well_definedness: of the primitive when it was chosen; carried: (7,) bool, the rows it
    carries with the feet fixed (:data:`coop_ga.legged.stance.CARRIED`).
    """

    kind: Kind
    task_kind: CooperativeKind
    legs: tuple[str, ...]
    task: Any
    reason: str
    well_definedness: float
    carried: np.ndarray

    def describe(self) -> str:
        """``"sphere(lf, lm, rf, rm)"``."""
        return f"{self.kind}({', '.join(self.legs)})"


@dataclass(frozen=True)
class BodyMotion:
    """A rigid displacement of the body over fixed feet: ``M = T(translation) R(rotation)`` in B at the start.

    The body origin moves by ``translation`` (3,) [m] along B's axes and the body turns by ``rotation``
    (3, 3) (B ← B'), i.e. the new pose is ``(p + R_WB t, R_WB R)`` (:meth:`BodyState.moved` for the twist
    :meth:`twist` over unit time).  Build with :meth:`from_rotvec` or :meth:`from_rpy`.
    """

    translation: np.ndarray
    rotation: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "translation", vector(self.translation, 3, "BodyMotion.translation [m]").copy())
        R = array(self.rotation, "BodyMotion.rotation", shape=(3, 3)).copy()
        check_rotation(R, "BodyMotion.rotation")
        object.__setattr__(self, "rotation", R)

    @classmethod
    def from_rotvec(cls, translation: Any, rotvec: Any = (0.0, 0.0, 0.0)) -> BodyMotion:
        """Translation [m] and rotation vector [rad] (axis · angle) in B."""
        from scipy.spatial.transform import Rotation

        return cls(translation, Rotation.from_rotvec(vector(rotvec, 3, "rotvec [rad]")).as_matrix())

    @classmethod
    def from_rpy(cls, translation: Any, rpy: Any) -> BodyMotion:
        """Translation [m] and ``(roll, pitch, yaw)`` [rad] (R = Rz(yaw) Ry(pitch) Rx(roll)) in B."""
        from .body import rotation_from_rpy

        return cls(translation, rotation_from_rpy(rpy))

    @property
    def rotvec(self) -> np.ndarray:
        """(3,) the rotation vector [rad] of :attr:`rotation`."""
        from scipy.spatial.transform import Rotation

        return np.asarray(Rotation.from_matrix(self.rotation).as_rotvec(), dtype=float)

    def twist(self) -> np.ndarray:
        """(6,) ``(v, ω)``: the body twist [m, rad per unit time] whose motion over unit time is M (log of SE(3))."""
        w = self.rotvec
        th = float(np.linalg.norm(w))
        W = _skew(w)
        if th < 1e-8:
            Vinv = np.eye(3) - 0.5 * W + W @ W / 12.0
        else:
            Vinv = np.eye(3) - 0.5 * W + (1.0 - th * math.sin(th) / (2.0 * (1.0 - math.cos(th)))) / th**2 * W @ W
        return np.concatenate([Vinv @ self.translation, w])

    def moved(self, state: BodyState) -> BodyState:
        """``state`` with its body displaced by M (legs unchanged)."""
        return BodyState(state.position + state.rotation @ self.translation, state.rotation @ self.rotation, state.q)


@dataclass(frozen=True)
class PostureStep:
    """What one :func:`posture_step` did.

    kind: the (first) stance primitive used (``"plane"``, ``"circle"``, ``"sphere"``, ``"point_pair"``);
        task_kind: its task-graph kind (``"sphere_fit"`` / ``"plane_fit"`` for the least-squares
        primitives of > 4 / > 3 feet); kind_reason: why that kind (the decision rule's numbers for the
        automatic choice); primitives: every primitive used, e.g. ``("circle(lf, lr, rm)", "point_pair(rm, lf)")``;
        stance_legs: the stance legs (names, LEG ORDER); task_legs: the feet of the first primitive.
    well_definedness: of the first primitive at the start of the step (1 best, 0 degenerate).
    command: (7,) the command in its frame; command_primitive: (7,) the same in the first primitive's frame.
    body_twist: (6,) ``(v [m/s], ω [rad/s])`` in B, as taken (after backtracking).
    achieved_twist: (7,) the first primitive's realised twist over the step, ``log(Ṽ_k V_k+1)/Δt``, mapped
        to the command's frame; carried rows only (others 0).
    tracking_error: (7,) the first primitive's ``command − achieved`` on its carried rows, plus the
        command's refused rows (``uncontrollable="report"``), in its frame [1/s].
    tracking_errors: (m, 7) the same for each of the m primitives.  tracking_error_norm: norm over all of them.
    radius_rate_error: the e0∞ entry of ``tracking_error`` (a refused radius change; 0 otherwise).
    uncontrollable: the refused components, named (empty when the command was carried whole).
    refused_twist: (6,) the body twist ``(v, ω)`` of a body-frame command that no primitive carries and was
        not executed (``"report"``; zeros otherwise).
    secondary_error: ‖S (u − u*)‖ [m/s]: how far the body twist taken is from the one that carries the command
        and the unseen part of ``nullspace_twist`` (module docstring; > 0 when a joint limit holds it back).
    max_slip: [m] largest motion in W of a stance foot over the step (after the IK re-solve).
    linear_slip: [m] what the linearised joint step q + L u Δt alone would have slipped.
    limited: a joint bound scaled the body twist down, or the step was shortened/refused.
    active_joints: names of the stance joints whose bound scaled the twist (position or velocity limit);
        position_limited_joints: those held by their position limit.
    backtracks, scale: halvings for the exact IK to stay inside the limits, and the fraction of the
        step taken (0: refused).
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
    kind_reason: str = ""
    primitives: tuple[str, ...] = ()
    tracking_errors: np.ndarray = field(default_factory=lambda: np.zeros((0, 7)))
    uncontrollable: tuple[str, ...] = ()
    refused_twist: np.ndarray = field(default_factory=lambda: np.zeros(6))


@dataclass
class PostureResult:
    """A :func:`posture_to` run: ``T = steps + 1`` states.

    t: (T,) [s]; q: (T, 18); body: (T, 7) position [m] + quaternion xyzw (W); error: (T, 7) the first
    primitive's carried rows of ``log(Ṽ V_target)`` (its frame); errors: (T, m, 7) every primitive's;
    error_norm: (T,) over all primitives; states: the BodyStates; steps: the PostureSteps; converged: the
    carried error norm ≤ tol at the end and nothing refused; max_slip [m] over the run (stance feet from
    their initial world positions); max_limit_violation [rad]; final_error (7,): the first primitive's full
    error (all rows); kind, kind_reason, primitives: as in :class:`PostureStep`; uncontrollable: the refused
    components (``uncontrollable="report"``); message.
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
    kind: str = ""
    kind_reason: str = ""
    primitives: tuple[str, ...] = ()
    uncontrollable: tuple[str, ...] = ()
    errors: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 7)))


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


def _body_twist_of(c_B: np.ndarray) -> np.ndarray:
    """The body twist (v, ω) whose feet-fixed image is the rigid body-frame twist ``c_B`` (inverse of
    :func:`command_from_body_twist`; the e0∞ entry is ignored)."""
    return np.array([-c_B[4], -c_B[5], -c_B[6], -c_B[2], c_B[1], -c_B[0]])


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


def _skew(p: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -p[2], p[1]], [p[2], 0.0, -p[0]], [-p[1], p[0], 0.0]])


# ====================================================================== choosing the primitives
def stance_posture_task(
    legs: LegModel, q: Any, stance_legs: Any, kind: str | None = None, w_min: float = 1e-2
) -> CooperativeTask:
    """The cooperative task of one stance primitive over ``stance_legs`` of the fixed-base system of ``legs``
    (body frame B) at leg joints ``q`` (18,): the ``task`` of :func:`stance_primitive_tasks` for ``kind``
    (None: the decision rule of :func:`~coop_ga.legged.stance.stance_primitive`)."""
    return stance_primitive_tasks(legs, q, stance_legs, kind, w_min)[0].task


def _specs(primitives: Any) -> list[tuple[str, tuple[str, ...] | None]]:
    """``primitives`` → [(kind, legs or None)] (see :func:`stance_primitive_tasks`)."""
    kinds = (*CARRIED, *(f for f, k in FIT_KINDS.items() if k in CARRIED), "auto")

    def one(x: Any) -> tuple[str, tuple[str, ...] | None] | None:
        if isinstance(x, str):
            return (choice(x, kinds, "primitives"), None)
        if (
            isinstance(x, Sequence)
            and len(x) == 2
            and isinstance(x[0], str)
            and x[0] in kinds
            and isinstance(x[1], Sequence)
            and not isinstance(x[1], str)
        ):
            return (x[0], tuple(x[1]))
        return None

    if primitives is None:
        return [("auto", None)]
    single = one(primitives)
    if single is not None:
        return [single]
    if isinstance(primitives, Sequence) and len(primitives) > 0:
        out = [one(x) for x in primitives]
        if all(o is not None for o in out):
            return [o for o in out if o is not None]
    raise InvalidInputError(
        f"primitives must be a kind ({', '.join(kinds)}), a (kind, legs) pair, or a sequence of those, e.g. "
        f"('circle', 'point_pair') or [('sphere', ('lf', 'lm', 'rf', 'rm')), 'circle']; got {primitives!r}"
    )


def _resolve_legs(kind: str, legs: tuple[str, ...] | None, stance: tuple[str, ...], feet: dict[str, np.ndarray]
                  ) -> tuple[tuple[str, ...], str]:  # fmt: skip
    """The feet of a primitive of ``kind``: given (checked against the stance), or chosen from the stance."""
    from ..geometry.primitives import well_definedness

    if legs is not None:
        bad = [x for x in legs if x not in stance]
        if bad:
            raise InvalidInputError(f"primitive {kind}{legs}: leg(s) {bad} not in stance ({', '.join(stance)})")
        return legs, "legs given"
    if _all_feet(kind):
        return stance, "all stance feet"
    spec = KIND_SPECS[kind]
    n = spec.n_points
    if len(stance) < n:
        raise InvalidInputError(f"a stance {kind} needs {n} stance feet, the stance has {len(stance)}")
    import itertools

    if spec.axis_role == "normal":  # a circle: the best-conditioned one (§5.3)
        tri = max(
            itertools.combinations(stance, n), key=lambda c: well_definedness(spec.primitive_kind, [feet[x] for x in c])
        )
        return tuple(tri), f"the {n} stance feet of the best-conditioned {kind}"
    # point pair: the two stance feet farthest apart across B's xy (turns about the vertical best conditioned)
    pair = max(itertools.combinations(stance, 2), key=lambda c: float(np.linalg.norm((feet[c[0]] - feet[c[1]])[:2])))
    return tuple(pair), "the 2 stance feet farthest apart in B's xy"


def _resolve_one(lm: LegModel, q: np.ndarray, stance: tuple[str, ...], kind: str, legs: tuple[str, ...] | None,
                 w_min: float) -> PrimitiveTask:  # fmt: skip
    from .stance import stance_order, stance_primitive, stance_task

    fk = lm.fk(q)
    feet = {x: fk[LEG_ORDER.index(x)] for x in stance}
    chosen, why_legs = _resolve_legs(kind, legs, stance, feet)
    if _all_feet(kind):
        names = stance_order(chosen)
        want = None if kind == "auto" else _primitive_kind(kind)
        if want is not None and len(names) < KIND_SPECS[want].n_points:
            raise InvalidInputError(f"a stance {want} needs ≥ {KIND_SPECS[want].n_points} feet, got {len(names)} "
                                    f"({', '.join(names)})")  # fmt: skip
        sp = stance_primitive(np.array([feet[x] for x in names]), w_min=w_min, kind=want)
        task_kind, reason, w = sp.task_kind, sp.reason, sp.well_definedness
    else:
        names, task_kind, w = tuple(chosen), KIND_SPECS[kind].name, math.nan
        reason = f"{kind} of {why_legs}"
    task = stance_task(lm.system, names, task_kind)
    order = tuple(LEG_ORDER[int(np.flatnonzero(lm.end_frame_index == i)[0])] for i in task.point_indices)
    if math.isnan(w):
        w = float(task.evaluate(q).well_definedness)
    base = _primitive_kind(task_kind)
    return PrimitiveTask(base, task_kind, order, task, reason, w, carried_rows(base))


def stance_primitive_tasks(
    legs: LegModel, q: Any, stance_legs: Any, primitives: Any = None, w_min: float = 1e-2
) -> tuple[PrimitiveTask, ...]:
    """The stance primitives that carry a posture command, resolved at leg joints ``q`` (18,).

    ``primitives``: None or ``"auto"`` — one primitive by the decision rule of
    :func:`~coop_ga.legged.stance.stance_primitive` over all stance feet (a sphere when ≥ 4 feet span a
    well-defined one, else the plane; its ``reason`` says which and why); a kind — ``"sphere"`` (all stance
    feet, ≥ 4, least-squares for more; coplanar feet raise
    :class:`~coop_ga.errors.DegeneratePrimitiveError`, never a silent plane), ``"plane"`` (all stance feet),
    ``"circle"`` (the 3 stance feet of the best-conditioned circle), ``"point_pair"`` (the 2 stance feet
    farthest apart in B's xy); a ``(kind, legs)`` pair naming the feet; or a sequence of those, e.g.
    ``("circle", "point_pair")`` — all six body DOF on any ground — or ``("sphere", "circle", "point_pair")``.

    Raises :class:`~coop_ga.errors.InvalidInputError` for fewer than 3 stance legs, feet outside the
    stance or a bad spec, :class:`~coop_ga.errors.DegeneratePrimitiveError` for feet that do not span it.
    """
    from .legs import check_legs

    lm = check_legs(legs)
    qq = vector(q, 18, "q")
    w_min = nonnegative(w_min, "w_min")
    stance = tuple(LEG_ORDER[i] for i in stance_indices(stance_legs))
    if len(stance) < 3:
        raise InvalidInputError(
            f"posture control needs ≥ 3 stance_legs (the feet the body stands on), got {list(stance)}"
        )
    return tuple(_resolve_one(lm, qq, stance, k, x, w_min) for k, x in _specs(primitives))


# ====================================================================== honesty checks
def _nonzero(x: np.ndarray, scale: float) -> np.ndarray:
    return np.abs(x) > _REL * max(1.0, scale) + _ABS


def _refused_rows(c_P: np.ndarray, prim: PrimitiveTask) -> np.ndarray:
    """(7,) bool: rows of a primitive-frame command ``c_P`` that ``prim`` cannot carry and that are non-zero."""
    return ~prim.carried & _nonzero(c_P, float(np.linalg.norm(c_P)))


def _rows_message(c_P: np.ndarray, refused: np.ndarray, prim: PrimitiveTask, what: str) -> str:
    parts, alts = [], []
    for i in np.flatnonzero(refused):
        meaning, alt = uncarried(prim.kind, int(i))
        parts.append(f"{ROWS[i]} = {c_P[i]:.3g} ({meaning})")
        if alt not in alts:
            alts.append(alt)
    return (
        f"{what} through the stance {prim.describe()} has component(s) it cannot carry with the feet fixed "
        f"(seed 003 Table 1): {'; '.join(parts)}. The {prim.kind} was chosen because: {prim.reason}. "
        f"Carried instead by: {'; '.join(alts)} — e.g. primitives=('circle', 'point_pair') with a BodyMotion; "
        "or pass PostureOptions(uncontrollable='report') to run the rest and report it"
    )


def _body_message(u_N: np.ndarray, prims: Sequence[PrimitiveTask], what: str) -> str:
    t, w = u_N[:3], u_N[3:]
    parts = []
    if np.linalg.norm(t) > 0:
        parts.append(f"translation {np.round(t, 6).tolist()} along B's axes")
    if np.linalg.norm(w) > 0:
        parts.append(f"rotation {np.round(w, 6).tolist()} about B's axes (rotation vector)")
    return (
        f"{what} has a part no stance primitive of {', '.join(p.describe() for p in prims)} can see with "
        f"the feet fixed: {' and '.join(parts)} (seed 003 Table 1: a sphere carries no rotation, a plane no "
        "in-plane translation or yaw, a circle no rotation about its axis, a point pair none about its own). "
        "Add the primitive that carries it — a circle or plane of 3 stance feet (tilt), a point pair of 2 "
        "(rotation about the vertical), a circle or sphere (translation) — e.g. primitives=('circle', "
        "'point_pair'); or pass PostureOptions(uncontrollable='report') to run the rest and report it"
    )


def _scale() -> np.ndarray:
    """(6,) weights of a body twist's entries when translations and rotations are compared: (v, ℓ ω)."""
    return np.array([1.0, 1.0, 1.0, LENGTH_SCALE, LENGTH_SCALE, LENGTH_SCALE])


def _null_basis(CA: np.ndarray) -> np.ndarray:
    """(6, d) orthonormal basis of the body twists that no carried row ``CA`` (n, 6) sees (N)."""
    if CA.shape[0] == 0:
        return np.eye(6)
    _, s, Vt = np.linalg.svd(CA, full_matrices=True)
    rank = int(np.sum(s > _RANK_TOL * max(float(s[0]), 1e-300)))
    return Vt[rank:].T.copy()


def _split(u: np.ndarray, N: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(seen, unseen)`` with ``u = seen + unseen``, unseen ∈ span(N): of all the body twists the primitives
    cannot tell from u (u + N), ``seen`` is the one that turns least, and of those the one that translates
    least (the body holds still where no primitive looks: a sphere's class of a translation is that pure
    translation, a plane's class of a tilt the tilt about the body origin, a circle's no turn about its axis)."""
    if N.shape[1] == 0:
        return u.copy(), np.zeros(6)
    Nv, Nw = N[:3], N[3:]
    alpha = -np.linalg.pinv(Nw, rcond=_RANK_TOL) @ u[3:]
    _, sw, Vt = np.linalg.svd(Nw, full_matrices=True)
    K = Vt[int(np.sum(sw > _RANK_TOL * max(float(sw[0]) if sw.size else 0.0, 1e-300))) :].T  # pure translations in N
    if K.shape[1]:
        T = Nv @ K
        alpha = alpha - K @ (np.linalg.pinv(T, rcond=_RANK_TOL) @ (u[:3] + Nv @ alpha))
    unseen = -(N @ alpha)
    return u - unseen, unseen


def _significant(x: np.ndarray, ref: np.ndarray) -> bool:
    """A body twist ``x`` is non-zero relative to ``ref`` (translations and ℓ · rotations compared)."""
    xs, rs = x * _scale(), ref * _scale()
    return bool(np.linalg.norm(xs) > _REL * max(1.0, float(np.linalg.norm(rs))) + _ABS)


# ====================================================================== the linearised stance
@dataclass
class _Linear:
    """The stance at q: feet p (6, 3) in B, the stance joint columns, L (3k, 6), and per primitive the
    similarity V, Ad_V, A = J^G L (7, 6) and the well-definedness."""

    p: np.ndarray
    cols: np.ndarray
    L: np.ndarray
    V: list[Similarity]
    A: list[np.ndarray]
    w: list[float]
    _ad: dict[int, np.ndarray] = field(default_factory=dict)

    def ad(self, i: int) -> np.ndarray:
        """Ad of primitive i's similarity (computed when first asked: only body-frame commands need it)."""
        if i not in self._ad:
            self._ad[i] = adjoint(self.V[i])
        return self._ad[i]

    def carried_map(self, prims: Sequence[PrimitiveTask]) -> np.ndarray:
        return np.vstack([A[p.carried] for A, p in zip(self.A, prims)])


def _linearise(lm: LegModel, q: np.ndarray, idx: tuple[int, ...], prims: Sequence[PrimitiveTask]) -> _Linear:
    p = lm.fk(q)
    Jl = lm.jacobians(q)
    k = len(idx)
    L = np.zeros((3 * k, 6))
    for j, i in enumerate(idx):  # q̇_i = J_i⁻¹ (−v − ω × p_i) = J_i⁻¹ [−I  [p_i]×] u (a straight leg is singular)
        L[3 * j : 3 * j + 3] = np.linalg.pinv(Jl[i], rcond=1e-10) @ np.hstack([-np.eye(3), _skew(p[i])])
    cols = lm.q_index[list(idx)].ravel()
    lin = _Linear(p, cols, L, [], [], [])
    for prim in prims:
        st = prim.task.evaluate(q)
        lin.V.append(st.similarity)
        lin.A.append(st.jacobian[:, cols] @ L)  # (7, 18) J^G: the fixed-base system's q is the leg q
        lin.w.append(float(st.well_definedness))
    return lin


def _commands(
    c_in: np.ndarray, frame: str, lin: _Linear, prims: Sequence[PrimitiveTask], mode: str
) -> tuple[list[np.ndarray], list[np.ndarray], np.ndarray, tuple[str, ...], np.ndarray]:
    """Per primitive: the command in its frame (refused rows zeroed; only the carried rows are used) and its refused
    rows; the body twist that was refused (``"report"``, body frame), the refused components' names, and the body
    twist that carries the command (:func:`_split`'s ``seen`` part)."""
    m = len(prims)
    CA = lin.carried_map(prims)
    N = _null_basis(CA)
    if frame == "primitive":
        if m != 1:
            raise InvalidInputError(
                f"a primitive-frame command is the twist of one primitive; with {m} primitives give the command "
                "in frame='body' (every stance primitive sees the same body-frame twist)"
            )
        refused = _refused_rows(c_in, prims[0])
        if refused.any() and mode == "raise":
            raise InvalidInputError(_rows_message(c_in, refused, prims[0], "the posture command"))
        names = tuple(f"{ROWS[i]} of {prims[0].describe()}: {uncarried(prims[0].kind, int(i))[0]}"
                      for i in np.flatnonzero(refused))  # fmt: skip
        c = np.where(refused, 0.0, c_in)
        u_seen = _split(np.linalg.lstsq(CA, c[prims[0].carried], rcond=None)[0], N)[0]
        return [c], [refused], np.zeros(6), names, u_seen
    c_in = c_in.copy()
    if _nonzero(c_in[_BETA : _BETA + 1], float(np.linalg.norm(c_in)))[0]:
        if mode == "raise":
            raise InvalidInputError(
                f"the body-frame posture command has a dilation e0∞ = {c_in[_BETA]:.3g} 1/s: a rigid body over fixed "
                "feet cannot dilate (no stance primitive can change its radius, length or scale); command the "
                "translation toward or away from the primitive's centre instead"
            )
        c_in[_BETA] = 0.0
    u_cmd = _body_twist_of(c_in)
    u_seen, u_N = _split(u_cmd, N)
    names = ()
    if _significant(u_N, u_cmd):
        if mode == "raise":
            raise InvalidInputError(_body_message(u_N, prims, "the body-frame posture command"))
        names = (f"body twist {np.round(u_N, 9).tolist()} (v, ω): seen by no primitive",)
    else:
        u_seen, u_N = u_cmd, np.zeros(6)
    return [A @ u_seen for A in lin.A], [np.zeros(7, bool)] * m, u_N, names, u_seen


# ====================================================================== the step
def _solve(
    lin: _Linear, u_target: np.ndarray, lm: LegModel, q: np.ndarray, idx: tuple[int, ...], opt: PostureOptions
) -> tuple[np.ndarray, tuple[str, ...], tuple[str, ...], float]:
    """The body twist taken: u* scaled (direction kept) into the joint box (module docstring).  Returns (u, the
    joints that bound the scale, those bound by their position limit, ‖S (u − u*)‖)."""
    from ..control.qp import velocity_bounds

    dt = float(opt.dt)
    lo, hi = _effective_limits(lm, q, float(opt.knee_margin))
    vel = np.asarray(lm.velocity_limit, dtype=float).ravel()
    cols = lin.cols
    lb, ub = velocity_bounds(q[cols], lo[cols], hi[cols], vel[cols], dt, float(opt.limit_gain))
    lb, ub = np.minimum(lb, 0.0), np.maximum(ub, 0.0)  # (a joint resting on a bound: no motion past it)
    qd = lin.L @ u_target
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(qd > ub, ub / qd, np.where(qd < lb, lb / qd, 1.0))
    scale = float(np.clip(np.min(ratio), 0.0, 1.0)) if ratio.size else 1.0
    names = [n for i in idx for n in lm.joint_names[i]]
    bound = ratio <= scale + 1e-12 if scale < 1.0 else np.zeros(len(names), bool)
    active = tuple(n for n, b in zip(names, bound) if b)
    # which of them are position limits (the box is the tighter of position/Δt and velocity limits)
    at_pos_hi = opt.limit_gain * (hi[cols] - q[cols]) / dt < vel[cols]
    at_pos_lo = opt.limit_gain * (lo[cols] - q[cols]) / dt > -vel[cols]
    at_pos = tuple(
        n for j, n in enumerate(names) if bound[j] and ((qd[j] > 0 and at_pos_hi[j]) or (qd[j] < 0 and at_pos_lo[j]))
    )
    u = scale * u_target
    return u, active, at_pos, float(np.linalg.norm(_scale() * (u - u_target)))


def _advance(
    lm: LegModel, state: BodyState, u: np.ndarray, idx: tuple[int, ...], opt: PostureOptions
) -> tuple[BodyState, float, int]:
    """Move the body by u Δt and re-solve the stance legs for the same world feet, halving the step while the
    exact IK would leave the limits.  Returns (new state, scale taken, backtracks)."""
    anchors = state.feet_world(lm)
    scale, back = 1.0, 0
    while True:
        cand = state.moved(u[:3] * scale, u[3:] * scale, opt.dt)
        new_q = _resolve(lm, cand, anchors, idx, state.q, float(opt.knee_margin))
        if new_q is not None:
            return BodyState(cand.position, cand.rotation, new_q), scale, back
        if back >= opt.max_backtracks:
            return state.copy(), 0.0, back
        back += 1
        scale *= 0.5


def _swing(lm: LegModel, new: BodyState, idx: tuple[int, ...], swing_q: Any, swing_feet_W: Any) -> BodyState:
    """The swing legs of ``new``: given joint angles, or closed-form IK to world foot targets."""
    qn = new.q.copy()
    if swing_q:
        for leg, qa in swing_q.items():
            qn[lm.q_index[_swing_index(leg, idx)]] = vector(qa, 3, f"swing_q[{leg!r}]")
    if swing_feet_W:
        feet_B = lm.fk(qn).copy()
        chosen = [_swing_index(leg, idx) for leg in swing_feet_W]
        for leg, i in zip(swing_feet_W, chosen):
            feet_B[i] = new.to_body(vector(swing_feet_W[leg], 3, f"swing_feet_W[{leg!r}]"))
        q_ik = lm.ik(feet_B, branch=_branch(lm, qn), check_limits=True)
        for i in chosen:
            qn[lm.q_index[i]] = q_ik[lm.q_index[i]]
    return BodyState(new.position, new.rotation, qn)


def _prims_for_step(
    lm: LegModel, state: BodyState, idx: tuple[int, ...], opt: PostureOptions, primitives: Any, task: Any
) -> tuple[PrimitiveTask, ...]:
    if task is None:
        return stance_primitive_tasks(lm, state.q, idx, primitives if primitives is not None else opt.kind, opt.w_min)
    from ..cooperative.task import CooperativeTask

    if not isinstance(task, CooperativeTask):
        raise InvalidInputError(f"task must be a CooperativeTask (stance_task(...)), got {type(task).__name__}")
    tlegs = tuple(LEG_ORDER[int(np.flatnonzero(lm.end_frame_index == i)[0])] for i in task.point_indices)
    if not set(tlegs) <= {LEG_ORDER[i] for i in idx}:
        raise InvalidInputError(f"the task's feet {list(tlegs)} are not all in stance ({[LEG_ORDER[i] for i in idx]})")
    base = _primitive_kind(task.kind)
    w = float(task.evaluate(state.q).well_definedness)
    return (PrimitiveTask(base, task.kind, tlegs, task, "task given", w, carried_rows(base)),)


def _step_args(
    lm: LegModel, state: BodyState, idx: tuple[int, ...], command: Any, nullspace_twist: Any, swing_q: Any,
    swing_feet_W: Any,
) -> tuple[np.ndarray, np.ndarray | None]:  # fmt: skip
    """:func:`posture_step`'s checked command (7,) and null-space twist (6,) (or None); the swing arguments and the
    start state's joint limits checked."""
    c_in = vector(command, 7, "command_twist_B")
    u_ref = None if nullspace_twist is None else vector(nullspace_twist, 6, "nullspace_twist")
    _swing_args(swing_q, swing_feet_W, idx)
    if _violation(lm, state.q) > 1e-12:
        raise InvalidInputError(
            f"state.q is outside the joint limits by {_violation(lm, state.q):.3g} rad; posture_step starts inside them"
        )
    return c_in, u_ref


def _with_nullspace(
    u_seen: np.ndarray, u_ref: np.ndarray | None, lin: _Linear, prims: Sequence[PrimitiveTask]
) -> np.ndarray:
    """``u_seen`` plus the caller's body twist ``u_ref`` (6,) where no primitive looks (its part in the null space
    N of the carried rows); ``u_seen`` itself without one."""
    if u_ref is None:
        return u_seen
    return u_seen + _split(u_ref, _null_basis(lin.carried_map(prims)))[1]


def _slips(
    lm: LegModel, state: BodyState, new: BodyState, lin: _Linear, u: np.ndarray, idx: tuple[int, ...],
    opt: PostureOptions,
) -> tuple[float, float]:  # fmt: skip
    """The largest drift [m] in W of a stance foot from where it stood in ``state``: after the step (``new``), and
    after the linearised step (the body moved by u Δt, the stance joints by L u Δt)."""
    anchors = state.feet_world(lm)
    q_lin = state.q.copy()
    q_lin[lin.cols] = state.q[lin.cols] + lin.L @ u * opt.dt
    lin_state = state.moved(u[:3], u[3:], opt.dt, q=q_lin)
    linear_slip = float(np.max(np.linalg.norm((lin_state.feet_world(lm) - anchors)[list(idx)], axis=1)))
    slip = float(np.max(np.linalg.norm((new.feet_world(lm) - anchors)[list(idx)], axis=1)))
    return slip, linear_slip


def _tracking_errors(
    prims: Sequence[PrimitiveTask], cmds: list[np.ndarray], refused: list[np.ndarray], lin: _Linear,
    new: BodyState, c_in: np.ndarray, opt: PostureOptions,
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Per primitive (m, 7): command − achieved twist on the carried rows, plus the refused rows' command; and the
    first primitive's achieved twist (7,) in the command's frame."""
    errs, achieved0 = [], np.zeros(7)
    for i, (p, c) in enumerate(zip(prims, cmds)):
        b_ach = np.asarray((lin.V[i].inverse() @ p.task.similarity(new.q)).log(), dtype=float) / opt.dt
        b_ach = np.where(p.carried, b_ach, 0.0)
        c_full = c_in if opt.frame == "primitive" else c
        errs.append(np.where(p.carried, c - b_ach, 0.0) + np.where(refused[i], c_full, 0.0))
        if i == 0:
            achieved0 = b_ach if opt.frame == "primitive" else lin.ad(0) @ b_ach
    return np.array(errs), achieved0


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
    primitives: Any = None,
) -> tuple[BodyState, PostureStep]:
    """One posture step: move the body so that the stance primitives (seen from B) follow a twist.

    Args:
        state: the current :class:`BodyState` (joints inside the limits).
        stance_legs: ≥ 3 stance legs (names, indices into LEG ORDER, or a (6,) bool mask); their feet stay
            fixed in W.
        command_twist_B: (7,) similarity twist [1/s] in ``options.frame``: of the one primitive
            (``"primitive"``), or the body-frame twist every stance primitive sees (``"body"``, any number of
            primitives; :func:`command_from_body_twist` of a body twist).  Components the primitives cannot
            carry raise or are reported (``options.uncontrollable``, module docstring).
        legs: the :class:`LegModel` (default :func:`~coop_ga.legged.legs.hexapod_legs`).
        options: :class:`PostureOptions`.
        nullspace_twist: optional (6,) body twist ``(v, ω)`` [m/s, rad/s] in B for the motions no primitive
            sees (default: none of them, the body holds still there).
        swing_q: optional joint angles (3,) per swing leg name at the end of the step (default: unchanged).
        swing_feet_W: optional foot targets (3,) [m] in W per swing leg name, solved by closed-form IK at the
            new body pose (knee_up; :class:`~coop_ga.errors.UnreachableError` if out of reach/limits).
        task: one stance primitive's task (e.g. :func:`coop_ga.legged.stance.stance_task`); default: from
            ``primitives`` / ``options.kind``.
        primitives: the stance primitives (:func:`stance_primitive_tasks`); None: ``options.kind``.

    Returns:
        ``(new state, PostureStep)``.

    Raises:
        InvalidInputError: bad arguments, fewer than 3 stance legs, or a command with a component the
            primitives cannot carry (``uncontrollable="raise"``).
    """
    lm, opt, idx = _posture_args(state, stance_legs, legs, options)
    c_in, u_ref = _step_args(lm, state, idx, command_twist_B, nullspace_twist, swing_q, swing_feet_W)
    prims = _prims_for_step(lm, state, idx, opt, primitives, task)
    lin = _linearise(lm, state.q, idx, prims)
    cmds, refused, u_N, names, u_seen = _commands(c_in, opt.frame, lin, prims, opt.uncontrollable)
    u_seen = _with_nullspace(u_seen, u_ref, lin, prims)
    u, active, at_pos, sec = _solve(lin, u_seen, lm, state.q, idx, opt)
    new, scale, back = _advance(lm, state, u, idx, opt)
    new = _swing(lm, new, idx, swing_q, swing_feet_W)
    slip, linear_slip = _slips(lm, state, new, lin, u, idx, opt)
    E, achieved0 = _tracking_errors(prims, cmds, refused, lin, new, c_in, opt)
    return new, PostureStep(
        kind=prims[0].kind,
        task_kind=prims[0].task_kind,
        stance_legs=tuple(LEG_ORDER[i] for i in idx),
        task_legs=prims[0].legs,
        well_definedness=lin.w[0],
        command=c_in.copy(),
        command_primitive=c_in.copy() if opt.frame == "primitive" else np.linalg.solve(lin.ad(0), c_in),
        body_twist=u * scale,
        achieved_twist=achieved0,
        tracking_error=E[0],
        tracking_error_norm=float(np.linalg.norm(E)),
        radius_rate_error=float(E[0, _BETA]),
        secondary_error=sec * scale,
        max_slip=slip,
        linear_slip=linear_slip,
        limited=bool(active) or scale < 1.0,
        active_joints=active,
        position_limited_joints=at_pos,
        backtracks=back,
        scale=scale,
        max_limit_violation=_violation(lm, new.q),
        kind_reason=prims[0].reason,
        primitives=tuple(p.describe() for p in prims),
        tracking_errors=E,
        uncontrollable=names,
        refused_twist=u_N,
    )


def _branch(legs: LegModel, q: np.ndarray) -> np.ndarray:
    """(6,) bool knee_up per leg of q: the tibia's planar knee angle ≤ 0 (the standing branch)."""
    Q = legs.per_leg(q)
    return np.asarray(legs.tibia_sign * Q[:, 2] <= 0.0)


def _effective_limits(legs: LegModel, q: np.ndarray, margin: float) -> tuple[np.ndarray, np.ndarray]:
    """(18,) lower/upper bounds of the joint box: the joint limits, and for every leg the tibia kept
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
def _targets(
    lm: LegModel, state: BodyState, idx: tuple[int, ...], prims: Sequence[PrimitiveTask], target: Any,
    opt: PostureOptions,
) -> tuple[list[Similarity], tuple[str, ...]]:  # fmt: skip
    """Each primitive's target similarity (B), and the refused components (``"report"``) — after the honesty
    checks and, for a :class:`BodyMotion`, the reach and joint-limit check of the final pose."""
    if isinstance(target, BodyMotion):
        lin = _linearise(lm, state.q, idx, prims)
        u = target.twist()
        u_N = _split(u, _null_basis(lin.carried_map(prims)))[1]
        names: tuple[str, ...] = ()
        if _significant(u_N, u):
            if opt.uncontrollable == "raise":
                raise InvalidInputError(_body_message(u_N, prims, "the body motion"))
            names = (f"body twist {np.round(u_N, 9).tolist()} (v, ω) of the motion: seen by no primitive",)
        _check_reach(lm, state, idx, target, opt)
        return [body_motion_target(V, target.translation, target.rotation) for V in lin.V], names
    if len(prims) != 1:
        raise InvalidInputError(
            f"a Similarity target is the target of one primitive; with {len(prims)} primitives pass a BodyMotion"
        )
    T = Similarity.coerce(target, "target_relative")
    e0 = prims[0].task.error(state.q, T)
    refused = _refused_rows(e0, prims[0])
    if refused.any() and opt.uncontrollable == "raise":
        raise InvalidInputError(_rows_message(e0, refused, prims[0], "the posture target (its error log(Ṽ V_target))"))
    names = tuple(f"{ROWS[i]} of {prims[0].describe()}: {uncarried(prims[0].kind, int(i))[0]}"
                  for i in np.flatnonzero(refused))  # fmt: skip
    return [T], names


def _check_reach(lm: LegModel, state: BodyState, idx: tuple[int, ...], motion: BodyMotion, opt: PostureOptions) -> None:
    """Refuse, before the run, a body motion whose final pose puts a stance foot out of reach, a joint
    outside its limits or a tibia into the straight-leg margin (the error names the leg / joint)."""
    end = motion.moved(state)
    feet_B = lm.fk(state.q).copy()
    feet_B[list(idx)] = end.to_body(state.feet_world(lm)[list(idx)])
    try:
        q_end = lm.ik(feet_B, branch=_branch(lm, state.q), check_limits=True)
    except UnreachableError as e:
        raise UnreachableError(f"the body motion is beyond the legs' reach or joint limits at its end pose: {e}",
                               legs=e.legs) from None  # fmt: skip
    bend = _knee_bend(lm, q_end)[list(idx)]
    if np.any(bend < opt.knee_margin):
        j = int(np.argmin(bend))
        raise UnreachableError(
            f"the body motion straightens stance leg {LEG_ORDER[idx[j]]} to {bend[j]:.3f} rad of knee bend at its end "
            f"pose, inside knee_margin = {opt.knee_margin} rad (the end of the reach); command a smaller motion",
            legs=(LEG_ORDER[idx[j]],),
        )


def posture_to(
    state: BodyState,
    stance_legs: Any,
    target: Any,
    legs: LegModel | None = None,
    options: PostureOptions | None = None,
    *,
    primitives: Any = None,
) -> PostureResult:
    """Drive the stance primitives to a target with the feet fixed in W.

    Args:
        state: the start (:class:`BodyState`, joints inside the limits).
        stance_legs: ≥ 3 stance legs; their feet stay fixed.
        target: a :class:`~coop_ga.Similarity` — the target V_Sc of the one primitive seen from B (e.g.
            :func:`body_motion_target`) — or a :class:`BodyMotion`, the body displacement to make (every
            primitive's target is ``M⁻¹ V``).
        legs: as :func:`posture_step`.
        options: as :func:`posture_step` (``options.frame`` is ignored: commands are primitive-frame).
        primitives: the stance primitives (:func:`stance_primitive_tasks`; fixed at the start); None:
            ``options.kind``.  ``("circle", "point_pair")`` carries every body motion.

    Every step commands ``c_i = gain · C_i e_i`` with ``e_i = log(Ṽ_i V_i,target)`` (Eq 44) on each
    primitive's carried rows and calls the step of :func:`posture_step`.  Stops when the carried error norm
    ≤ ``tol`` or after ``max_steps`` (or when the limits block the body).

    Returns:
        A :class:`PostureResult`; ``converged`` only if the carried error reached ``tol`` and nothing was refused.

    Raises:
        InvalidInputError: a target with a component the primitives cannot carry (``uncontrollable="raise"``:
            e.g. a rotation through a sphere, an in-plane translation through a plane, a radius change).
        UnreachableError: a :class:`BodyMotion` whose end pose is beyond the legs' reach or joint limits
            (before the run, naming the leg and joint).
    """
    lm, opt, idx = _posture_args(state, stance_legs, legs, options)
    opt = replace(opt, frame="primitive")
    if not isinstance(target, BodyMotion | Similarity):
        raise InvalidInputError(f"target must be a Similarity or a BodyMotion, got {type(target).__name__}")
    prims = stance_primitive_tasks(lm, state.q, idx, primitives if primitives is not None else opt.kind, opt.w_min)
    targets, refused = _targets(lm, state, idx, prims, target, opt)
    anchors = state.feet_world(lm)
    states: list[BodyState] = [state.copy()]
    steps: list[PostureStep] = []
    errs: list[np.ndarray] = []
    s = state
    for _ in range(opt.max_steps + 1):
        E = np.array([np.where(p.carried, p.task.error(s.q, T), 0.0) for p, T in zip(prims, targets)])
        errs.append(E)
        if np.linalg.norm(E) <= opt.tol or len(steps) >= opt.max_steps:
            break
        s, info = _target_step(lm, s, idx, prims, opt.gain * E, opt)
        states.append(s)
        steps.append(info)
        if info.scale == 0.0:  # blocked by the limits
            errs.append(np.array([np.where(p.carried, p.task.error(s.q, T), 0.0) for p, T in zip(prims, targets)]))
            break
    return _result(lm, opt, idx, prims, targets, refused, states, steps, np.array(errs), anchors)


def _target_step(
    lm: LegModel, s: BodyState, idx: tuple[int, ...], prims: Sequence[PrimitiveTask], cmds: np.ndarray,
    opt: PostureOptions,
) -> tuple[BodyState, PostureStep]:  # fmt: skip
    """One step of :func:`posture_to`: per-primitive commands (m, 7) on the carried rows."""
    lin = _linearise(lm, s.q, idx, prims)
    CA = lin.carried_map(prims)
    cc = np.concatenate([c[p.carried] for c, p in zip(cmds, prims)])
    u_seen = _split(np.linalg.lstsq(CA, cc, rcond=None)[0], _null_basis(CA))[0]
    u, active, at_pos, sec = _solve(lin, u_seen, lm, s.q, idx, opt)
    new, scale, back = _advance(lm, s, u, idx, opt)
    anchors = s.feet_world(lm)
    E = []
    for i, p in enumerate(prims):
        b = np.asarray((lin.V[i].inverse() @ p.task.similarity(new.q)).log(), dtype=float) / opt.dt
        E.append(np.where(p.carried, cmds[i] - b, 0.0))
    slip = float(np.max(np.linalg.norm((new.feet_world(lm) - anchors)[list(idx)], axis=1)))
    p0 = prims[0]
    return new, PostureStep(
        p0.kind, p0.task_kind, tuple(LEG_ORDER[i] for i in idx), p0.legs, lin.w[0], cmds[0].copy(), cmds[0].copy(),
        u * scale, np.where(p0.carried, cmds[0] - E[0], 0.0), E[0], float(np.linalg.norm(E)), float(E[0][_BETA]),
        sec * scale, slip, math.nan, bool(active) or scale < 1.0, active, at_pos, back, scale,
        _violation(lm, new.q), p0.reason, tuple(p.describe() for p in prims), np.array(E),
    )  # fmt: skip


def _result(
    lm: LegModel, opt: PostureOptions, idx: tuple[int, ...], prims: Sequence[PrimitiveTask],
    targets: Sequence[Similarity], refused: tuple[str, ...], states: list[BodyState], steps: list[PostureStep],
    E: np.ndarray, anchors: np.ndarray,
) -> PostureResult:  # fmt: skip
    En = np.linalg.norm(E.reshape(len(E), -1), axis=1)
    slip = max(float(np.max(np.linalg.norm((x.feet_world(lm) - anchors)[list(idx)], axis=1))) for x in states)
    conv = bool(En[-1] <= opt.tol) and not refused
    final = np.asarray(prims[0].task.error(states[-1].q, targets[0]), dtype=float)
    names = ", ".join(p.describe() for p in prims)
    how = "converged" if conv else ("stopped, refused: " + "; ".join(refused) if refused else "stopped")
    return PostureResult(
        t=np.arange(len(states)) * opt.dt,
        q=np.array([x.q for x in states]),
        body=np.array([x.pose7() for x in states]),
        error=E[: len(states), 0],
        error_norm=En[: len(states)],
        states=states,
        steps=steps,
        converged=conv,
        max_slip=slip,
        max_limit_violation=max(_violation(lm, x.q) for x in states),
        final_error=final,
        message=f"posture_to ({names}): {how} after {len(steps)} steps, error {En[-1]:.3g}, max slip {slip:.3g} m",
        kind=prims[0].kind,
        kind_reason=prims[0].reason,
        primitives=tuple(p.describe() for p in prims),
        uncontrollable=refused,
        errors=E[: len(states)],
    )
