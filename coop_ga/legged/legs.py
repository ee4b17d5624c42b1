"""Leg kinematics of the hexapod: motor FK, closed-form IK (both knee branches), DLS IK, Jacobians.

Every leg is a coxa–femur–tibia chain (README of ``coop_ga/systems/robots/hexapod``): a yaw joint
(the **coxa**) on a mount of the body, then two parallel pitch joints (**femur**, **tibia**) that move
the foot in the vertical plane of the leg.  All geometry is read from the Pinocchio model of the
system (:meth:`LegModel.from_system`): the mount placement of every coxa joint, the joint axes
(their signs give the joint sign conventions), the femur/tibia/foot offsets, the limits and the
servo stall torque (URDF ``effort``).  Nothing is hard-coded; ``tests/legged/test_legs.py`` checks
the numbers read against the README's table (coxa 52 mm, femur 65 mm, tibia 133 mm, mounts, yaws).

Frames and units: positions [m] in the body frame ``B`` (+x forward, +y left, +z up; the parent
frame of the coxa joints), angles [rad].  Arrays over legs are ``(..., 6, ·)`` in the order
:data:`LEGS` = (lf, lm, lr, rf, rm, rr) (the URDF's); a joint vector is ``(..., 18)`` in the model's
q order, and ``q_index[leg, j]`` says where joint j ∈ (coxa, femur, tibia) of a leg sits in it.

The computations (seed 000, "Hexapod kinematics with geometric algebra", §3)
------------------------------------------------------------------------------------
* **FK as a product of motors** (:meth:`LegModel.fk_motors`): with ``P_j`` the constant placement
  motor of joint j (``model.jointPlacements``) and ``exp(q_j B_j)`` its rotor (paper Eq 7),
  ``M_foot = P_coxa e^{q_1 B_1} P_femur e^{q_2 B_2} P_tibia e^{q_3 B_3} P_foot`` and the foot point
  ``P_toe = M_foot e0 M̃_foot`` (the seed writes ``P_toe = M_B M_hip R_1 … P_0 (~·)``: the body motor
  ``M_B`` is the identity in ``B``, and the ``(~·)`` means the sandwich with the reverse).  The
  batch path :meth:`LegModel.fk` evaluates the same product in closed form over the six legs and
  any batch (yaw rotation of the planar femur–tibia chain), equal to the motors and to Pinocchio
  to ~1e-16 m.
* **Closed-form IK** (:meth:`LegModel.ik`): the coxa yaw from the foot's projection on the plane
  of the coxa axis, measured *at the coxa axis* (not at the body centre: the mounts sit 0.10–0.13 m
  out) — two yaws ψ and ψ + π, the second with the foot behind the coxa axis; then, in the leg plane,
  the femur–tibia triangle by the cosine law about the femur joint (which sits the coxa length out
  along the leg).  The knee angle is taken in the half-angle form
  ``ψ_3 = ±2 atan2(√(L_max² − r²), √(r² − L_min²))`` (= ±acos of the cosine law, but accurate near
  the straight leg) with ``r`` the femur-joint → foot distance and ``L_max/min = L_f ± L_t``.
  ``knee_up``: the knee above the femur-joint→foot line (ψ_3 ≤ 0: the tibia folded *down*, which
  for this robot is a **negative tibia angle** — the standing branch); ``knee_down``: ψ_3 ≥ 0
  (tibia ∈ [0, +25.5°] here).  Of the two yaws, the one inside (or least outside) the joint limits
  is returned (the coxa range is 140° < 180°, so at most one is inside).
* **DLS IK** (:meth:`LegModel.dls_ik`): Jacobian columns from twists, ``ω_j × (p − o_j)`` for the
  world axis ω_j through o_j of each revolute joint (seed §3), and the damped step
  ``Δq = (JᵀJ + λ²I)⁻¹ Jᵀ (x* − x)`` per leg (3×3), all legs and batch entries at once.  The seed
  writes ``Δθ = J†(x* − x) "with damping"``; the damped form above is the one used (λ as everywhere
  in coop_ga: ``damping`` is λ of ``JᵀJ + λ²I``).

Seed discrepancies (trust the computation): the seed's contact condition "Π ∧ P = 0" holds for a
plane in the *outer-product* (direct) representation; for the dual plane Π = n + d e∞ that
:mod:`coop_ga.legged.terrain` uses, contact is the inner product ``P · Π = 0``
(P · Π is the signed distance).  Its analytic IK takes "the angle between the hip axis and the
projected toe direction"; the yaw must be measured from the coxa axis and the hip's mounting
direction, and it has the second (ψ + π) solution the seed does not mention.

Reach (:meth:`LegModel.workspace_margin`): without limits a leg reaches the solid of revolution
(about its coxa axis) of the planar annulus L_min ≤ |v − c| ≤ L_max around the femur joint c; in
the meridian plane through the coxa axis it is the union of that annulus and its mirror image (the
second yaw ψ + π).  The margin is ``max(m(ρ), m(−ρ))`` with ``m(x) = min(L_max − r, r − L_min)`` at
``r = |(x, z) − c|`` and ρ the foot's distance from the coxa axis.  Outside the workspace (< 0) it is
exactly minus the Euclidean distance to it (the nearest point of a solid of revolution lies in the
meridian plane, and an annulus's signed distance is ``m``): "out of reach by |margin|".  Inside (> 0)
it is the depth inside the better yaw's annulus, a lower bound of the distance to the boundary
(exact unless both yaws reach the target).  The joint limits are not part of it:
:meth:`LegModel.ik` with ``check_limits`` (the default) refuses a reachable target whose solution
leaves them — e.g. a foot target under or through the body — and says which joint by how much.
"""

from __future__ import annotations

import math
import threading
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import validation
from ..algebra.basis import blade_index
from ..algebra.multivector import Multivector
from ..errors import InvalidInputError, UnknownNameError, UnreachableError, UnsupportedJointError
from ..geometry.groups import MOTOR_BLADES, motor_rotor_translation
from ..kinematics.chains import KinematicTree

__all__ = [
    "BRANCHES",
    "JOINTS",
    "LEGS",
    "LIMIT_TOL",
    "REACH_TOL",
    "DLSResult",
    "LegModel",
    "UnreachableError",
    "hexapod_legs",
]

#: Leg order of :mod:`coop_ga.legged`: arrays over legs are (..., 6, ·) in this order (the URDF's).
LEGS: tuple[str, ...] = ("lf", "lm", "lr", "rf", "rm", "rr")
#: Joints of a leg, root to tip; joint names are ``f"{leg}_{joint}_joint"``.
JOINTS: tuple[str, ...] = ("coxa", "femur", "tibia")
#: Knee branches of the closed-form IK (module docstring).
BRANCHES: tuple[str, ...] = ("knee_up", "knee_down")
#: joint angles [rad] and foot coordinates [m] beyond these are refused (sums of angles, squared lengths overflow)
MAX_ANGLE = 1e9
MAX_COORDINATE = 1e150
#: :meth:`LegModel.dls_ik` refuses a larger ``max_iter`` (bounded work)
MAX_DLS_ITERATIONS = 100_000
#: Joint-limit tolerance of :meth:`LegModel.ik` [rad]: a solution at most this far outside a limit
#: counts as inside and is clipped onto it (moves the foot by < 0.3 nm).
LIMIT_TOL = 1e-9
#: Reach tolerance of :meth:`LegModel.ik` [m]: a target at most this far outside the workspace is
#: solved as on its boundary (the straight or fully folded leg).
REACH_TOL = 1e-9

_MAX_HALVINGS = 12  # step halvings of dls_ik's backtracking (then the leg stays put for that iteration)
_GEOM_TOL = 1e-9  # structural checks on the model (axes, zero offsets, identity rotations)
_E0 = blade_index("e0")[0]


def _wrap(a: np.ndarray) -> np.ndarray:
    """Angles wrapped to [−π, π)."""
    return (a + np.pi) % (2.0 * np.pi) - np.pi


def _rot2(phi: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Planar rotation of (x, z) vectors ``v`` (..., 2) by ``phi`` (...) (x toward z)."""
    c, s = np.cos(phi), np.sin(phi)
    return np.stack((c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]), axis=-1)


@dataclass(frozen=True)
class DLSResult:
    """Result of :meth:`LegModel.dls_ik`.

    Attributes:
        q: (..., 18) joint vector [rad] (angles wrapped to [−π, π)).
        converged: (..., 6) bool, foot error ≤ ``tol`` for that leg.
        error: (..., 6) final foot position error ‖x* − fk(q)‖ [m] in B.
        iterations: (..., 6) int, damped steps taken by each leg.
        within_limits: (..., 6) bool, the leg's joints inside the limits.
        message: one line summary (how many legs converged, worst error).
    """

    q: np.ndarray
    converged: np.ndarray
    error: np.ndarray
    iterations: np.ndarray
    within_limits: np.ndarray
    message: str

    @property
    def all_converged(self) -> bool:
        """True when every leg of every batch entry converged."""
        return bool(np.all(self.converged))


def _read_only(a: np.ndarray) -> np.ndarray:
    """A read-only copy of ``a``."""
    a = np.array(a)
    a.setflags(write=False)
    return a


def _bad_leg(leg: str, what: str) -> UnsupportedJointError:
    """The error for a leg whose structure the closed-form IK cannot handle."""
    return UnsupportedJointError(
        f"leg '{leg}': {what}. The leg kinematics need a coxa yaw joint and two parallel pitch "
        "joints (femur, tibia) with all offsets in the leg's vertical plane (README of "
        "robots/hexapod)"
    )


def _check_leg_names(system: Any, legs: tuple[str, ...], foot_frames: tuple[str, ...]) -> None:
    """Every leg's ``{leg}_{coxa,femur,tibia}_joint`` and ``{leg}_foot`` exist in ``system.model``.

    Raises:
        UnknownNameError: a missing joint or frame (the message lists the model's joints).
    """
    model = system.model
    names = list(model.names)
    frames = [f.name for f in model.frames]
    for leg, ff in zip(legs, foot_frames):
        for j in JOINTS:
            if f"{leg}_{j}_joint" not in names:
                raise UnknownNameError(
                    f"system '{getattr(system, 'name', '?')}' has no joint '{leg}_{j}_joint'. "
                    f"Joints: {', '.join(names[1:])}"
                )
        if ff not in frames:
            raise UnknownNameError(f"system '{getattr(system, 'name', '?')}' has no frame '{ff}'")


def _leg_geometry(
    model: Any, tree: Any, leg: str, jids: np.ndarray, foot_frame: str, body_parent: int | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Check one leg's structure and read its geometry (:class:`LegModel`'s attributes of one leg).

    Args:
        model: the Pinocchio model; tree: its :class:`~coop_ga.kinematics.KinematicTree`.
        jids: (3,) joint ids of (coxa, femur, tibia); foot_frame: the leg's ``{leg}_foot`` frame.
        body_parent: the joint the previous legs' coxa joints hang from (None for the first leg).

    Returns:
        mount position (3,) [m] and rotation (3, 3) (B ← coxa frame), the joint signs (3,) (coxa, femur,
            tibia) and the in-plane offsets (3, 2) [m] (femur joint, femur link, tibia link as (x, z)).

    Raises:
        UnsupportedJointError: not a yaw + two parallel pitch joints with in-plane offsets, its coxa hanging from
            another body than ``body_parent``, or a zero-length link.
    """
    names = list(model.names)
    jc, jf, jt = (int(x) for x in jids)
    fr = model.frames[model.getFrameId(foot_frame)]
    if int(model.parents[jf]) != jc or int(model.parents[jt]) != jf or int(fr.parentJoint) != jt:
        raise _bad_leg(leg, "joints are not chained coxa → femur → tibia → foot")
    if body_parent is not None and int(model.parents[jc]) != body_parent:
        raise _bad_leg(leg, "its coxa joint hangs from a different body than the other legs'")
    for jid in (jc, jf, jt):
        if tree.joints[jid].kind != "revolute" or int(model.nqs[jid]) != 1:
            raise _bad_leg(leg, f"joint '{names[jid]}' is not a 1-DOF revolute joint")
    ac = np.array(tree.joints[jc].axis)
    af, at = np.array(tree.joints[jf].axis), np.array(tree.joints[jt].axis)
    if abs(abs(ac[2]) - 1.0) > _GEOM_TOL:
        raise _bad_leg(leg, f"the coxa axis {ac.tolist()} is not the z axis of its joint frame")
    for a, nm in ((af, "femur"), (at, "tibia")):
        if abs(abs(a[1]) - 1.0) > _GEOM_TOL:
            raise _bad_leg(leg, f"the {nm} axis {a.tolist()} is not the y axis of its joint frame")
    for jid, nm in ((jf, "femur"), (jt, "tibia")):
        Pl = model.jointPlacements[jid]
        if np.abs(np.asarray(Pl.rotation) - np.eye(3)).max() > _GEOM_TOL:
            raise _bad_leg(leg, f"the {nm} joint placement is rotated")
    t_f = np.asarray(model.jointPlacements[jf].translation, float)
    t_t = np.asarray(model.jointPlacements[jt].translation, float)
    t_p = np.asarray(fr.placement.translation, float)
    if max(abs(t_f[1]), abs(t_t[1]), abs(t_p[1])) > _GEOM_TOL:
        raise _bad_leg(leg, "an offset leaves the leg's vertical plane (non-zero y)")
    Pc = model.jointPlacements[jc]
    signs = np.array((np.sign(ac[2]), -np.sign(af[1]), -np.sign(at[1])))
    offs = np.array((t_f[[0, 2]], t_t[[0, 2]], t_p[[0, 2]]))
    L2, L3 = np.hypot(*offs[1]), np.hypot(*offs[2])
    if min(L2, L3) < 1e-6:
        raise _bad_leg(leg, "the femur or tibia has zero length")
    return np.asarray(Pc.translation, float), np.asarray(Pc.rotation, float), signs, offs


@dataclass(frozen=True, eq=False)
class LegModel:
    """Per-leg geometry read from a Pinocchio model (not hard-coded), and the leg kinematics.

    Build it with :func:`hexapod_legs` (cached) or :meth:`from_system`.  All arrays are read-only.

    Attributes:
        legs: leg names, :data:`LEGS`.
        q_index: (6, 3) int, index of (coxa, femur, tibia) of each leg in the 18-vector of leg joints
            (the leg joints in the model's q order; for the fixed-base ``hexapod`` system this *is* q).
        q_lower, q_upper: (6, 3) position limits [rad] (from ``system.limits``).
        effort_limit: (6, 3) servo stall torque [N·m] (URDF ``effort``; 1.5 N·m for the AX-12A).
        velocity_limit: (6, 3) [rad/s].
        joint_names: per leg the three joint names.
        model_q_index: (6, 3) int, the same joints' indices in the system's full q (= ``q_index`` for the
            fixed-base hexapod; offset by 7, the position and quaternion, on the free-flyer hexapod, whose
            velocities are offset by 6: the limits, read from ``system.limits``, are in q̇ order).
        end_frame_index: (6,) int, index of each leg's ``{leg}_foot`` in ``system.end_frames`` (−1 if not
            an end frame): the system orders its feet as two tripods, this package as :data:`LEGS`.
        mount_position: (6, 3) coxa joint origin in B [m].
        mount_rotation: (6, 3, 3) rotation B ← coxa frame at q_coxa = 0 (yaw = mounting angle).
        coxa_sign: (6,) ±1, the coxa axis is ``coxa_sign · z`` of the coxa frame.
        femur_sign, tibia_sign: (6,) ±1, a positive joint angle rotates the leg's x toward its +z by
            ``sign · q`` (the URDF axes are −y: sign +1, positive lifts the foot).
        femur_joint: (6, 2) femur joint (x, z) in the coxa frame [m] (the coxa offset: (0.052, 0)).
        femur_link: (6, 2) tibia joint (x, z) in the femur frame [m].
        tibia_link: (6, 2) foot (x, z) in the tibia frame [m].
        system: the :class:`~coop_ga.systems.System` it was read from.
        foot_radius: [m] radius of the foot ball: the URDF's sphere (visual or collision geometry) centred on the
            ``{leg}_foot`` frame of every leg (0.009 m for the hexapod); 0 if the model has none (a point foot).
            The foot frame is the ball's **centre**: a foot on the ground has its centre one radius above the
            terrain along the normal, and touches it at :meth:`contact_points` (:mod:`coop_ga.legged.contact`).
    """

    legs: tuple[str, ...]
    q_index: np.ndarray
    q_lower: np.ndarray
    q_upper: np.ndarray
    effort_limit: np.ndarray
    velocity_limit: np.ndarray
    joint_names: tuple[tuple[str, str, str], ...]
    model_q_index: np.ndarray
    end_frame_index: np.ndarray
    mount_position: np.ndarray
    mount_rotation: np.ndarray
    coxa_sign: np.ndarray
    femur_sign: np.ndarray
    tibia_sign: np.ndarray
    femur_joint: np.ndarray
    femur_link: np.ndarray
    tibia_link: np.ndarray
    system: Any = field(repr=False)
    _tree: Any = field(repr=False)
    _joint_ids: np.ndarray = field(repr=False)
    _foot_frames: tuple[str, ...] = field(repr=False)
    foot_radius: float = 0.0

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_system(cls, system: Any, legs: Sequence[str] = LEGS) -> LegModel:
        """Read the legs of ``system`` (a :class:`~coop_ga.systems.System` whose model has joints
        ``{leg}_{coxa,femur,tibia}_joint`` and frames ``{leg}_foot``).

        Raises :class:`~coop_ga.errors.UnknownNameError` for a missing joint or frame and
        :class:`~coop_ga.errors.UnsupportedJointError` when a leg is not a yaw + two parallel pitch
        joints with in-plane offsets (the structure the closed-form IK needs).
        """
        model = getattr(system, "model", None)
        if model is None or not hasattr(model, "getJointId"):
            raise InvalidInputError(f"LegModel.from_system needs a coop_ga System, got {type(system).__name__}")
        legs = _leg_names(legs)
        names = list(model.names)
        foot_frames = tuple(f"{leg}_foot" for leg in legs)
        _check_leg_names(system, legs, foot_frames)
        tree = KinematicTree(model, foot_frames)
        n = len(legs)
        jids = np.zeros((n, 3), dtype=int)
        mpos, mrot = np.zeros((n, 3)), np.zeros((n, 3, 3))
        signs = np.zeros((n, 3))
        offs = np.zeros((n, 3, 2))
        body_parent = None
        for i, leg in enumerate(legs):
            for k, j in enumerate(JOINTS):
                jids[i, k] = model.getJointId(f"{leg}_{j}_joint")
            mpos[i], mrot[i], signs[i], offs[i] = _leg_geometry(model, tree, leg, jids[i], foot_frames[i], body_parent)
            body_parent = int(model.parents[int(jids[i, 0])])
        # indices: the leg joints in the model's q order form the 18-vector
        mq = np.array([[int(model.idx_qs[int(j)]) for j in row] for row in jids])
        order = np.argsort(mq.ravel(), kind="stable")
        rank = np.empty(order.size, dtype=int)
        rank[order] = np.arange(order.size)
        mv = np.array([[int(model.idx_vs[int(j)]) for j in row] for row in jids])  # limits are in q̇ order (nv)
        limits = system.limits
        end_frames = list(getattr(system, "end_frames", ()))
        efi = np.array([end_frames.index(f) if f in end_frames else -1 for f in foot_frames])

        ro = _read_only
        return cls(
            legs=legs,
            q_index=ro(rank.reshape(n, 3)),
            q_lower=ro(np.asarray(limits.lower)[mv]),
            q_upper=ro(np.asarray(limits.upper)[mv]),
            effort_limit=ro(np.asarray(limits.effort)[mv]),
            velocity_limit=ro(np.asarray(limits.velocity)[mv]),
            joint_names=tuple((names[int(a)], names[int(b)], names[int(c)]) for a, b, c in jids),
            model_q_index=ro(mq),
            end_frame_index=ro(efi),
            mount_position=ro(mpos),
            mount_rotation=ro(mrot),
            coxa_sign=ro(signs[:, 0]),
            femur_sign=ro(signs[:, 1]),
            tibia_sign=ro(signs[:, 2]),
            femur_joint=ro(offs[:, 0]),
            femur_link=ro(offs[:, 1]),
            tibia_link=ro(offs[:, 2]),
            system=system,
            _tree=tree,
            _joint_ids=ro(jids),
            _foot_frames=foot_frames,
            foot_radius=_foot_ball_radius(system, legs, foot_frames),
        )

    # ------------------------------------------------------------------ derived geometry
    @property
    def n_legs(self) -> int:
        return len(self.legs)

    @property
    def nq(self) -> int:
        """Length of the joint vector (3 per leg: 18)."""
        return 3 * self.n_legs

    @property
    def coxa_length(self) -> np.ndarray:
        """(6,) coxa axis → femur joint distance [m] (0.052)."""
        return np.hypot(self.femur_joint[:, 0], self.femur_joint[:, 1])

    @property
    def femur_length(self) -> np.ndarray:
        """(6,) femur joint → tibia joint [m] (0.065)."""
        return np.hypot(self.femur_link[:, 0], self.femur_link[:, 1])

    @property
    def tibia_length(self) -> np.ndarray:
        """(6,) tibia joint → foot [m] (0.133)."""
        return np.hypot(self.tibia_link[:, 0], self.tibia_link[:, 1])

    @property
    def reach_min(self) -> np.ndarray:
        """(6,) smallest femur-joint → foot distance |L_f − L_t| [m] (fully folded knee)."""
        return np.abs(self.femur_length - self.tibia_length)

    @property
    def reach_max(self) -> np.ndarray:
        """(6,) largest femur-joint → foot distance L_f + L_t [m] (straight knee)."""
        return self.femur_length + self.tibia_length

    @property
    def mount_yaw(self) -> np.ndarray:
        """(6,) mounting yaw of each coxa frame about B's z [rad] (±45°, ±90°, ±135°)."""
        return np.arctan2(self.mount_rotation[:, 1, 0], self.mount_rotation[:, 0, 0])

    @property
    def _alpha(self) -> np.ndarray:
        """(6,) angle of the tibia offset minus that of the femur offset in the leg plane (0 here)."""
        return np.arctan2(self.tibia_link[:, 1], self.tibia_link[:, 0]) - np.arctan2(
            self.femur_link[:, 1], self.femur_link[:, 0]
        )

    def leg_index(self, leg: str) -> int:
        """Position of ``leg`` in :attr:`legs` (UnknownNameError otherwise)."""
        if not isinstance(leg, str) or leg not in self.legs:
            raise UnknownNameError(f"unknown leg {leg!r}; legs are {', '.join(self.legs)}")
        return self.legs.index(leg)

    # ------------------------------------------------------------------ argument checks
    def _q(self, q: Any, what: str = "q") -> np.ndarray:
        a = validation.array(q, what)
        if a.ndim < 1 or a.shape[-1] != self.nq:
            raise InvalidInputError(f"{what} must have shape (..., {self.nq}) (leg joints), got shape {a.shape}")
        if a.size and float(np.max(np.abs(a))) > MAX_ANGLE:
            raise InvalidInputError(
                f"{what} has a joint angle of {float(np.max(np.abs(a))):.3g} rad, beyond ±{MAX_ANGLE:g}"
            )
        return a

    def _feet(self, feet: Any, what: str = "feet") -> np.ndarray:
        a = validation.array(feet, what)
        if a.size and float(np.max(np.abs(a))) > MAX_COORDINATE:
            raise InvalidInputError(
                f"{what} has a coordinate of {float(np.max(np.abs(a))):.3g} m, beyond ±{MAX_COORDINATE:g}"
            )
        if a.ndim < 2 or a.shape[-2:] != (self.n_legs, 3):
            raise InvalidInputError(
                f"{what} must have shape (..., {self.n_legs}, 3) (one foot point [m] in B per leg, "
                f"order {', '.join(self.legs)}), got shape {a.shape}"
            )
        return a

    def per_leg(self, q: Any) -> np.ndarray:
        """(..., 18) joint vector → (..., 6, 3) per leg (coxa, femur, tibia) [rad] (a copy)."""
        return self._q(q)[..., self.q_index]

    def from_legs(self, q_legs: Any) -> np.ndarray:
        """(..., 6, 3) per-leg angles → (..., 18) joint vector (inverse of :meth:`per_leg`)."""
        Q = validation.array(q_legs, "q_legs")
        if Q.ndim < 2 or Q.shape[-2:] != (self.n_legs, 3):
            raise InvalidInputError(f"q_legs must have shape (..., {self.n_legs}, 3), got {Q.shape}")
        q = np.zeros((*Q.shape[:-2], self.nq))
        q[..., self.q_index.ravel()] = Q.reshape(*Q.shape[:-2], self.nq)
        return q

    @property
    def q_stand(self) -> np.ndarray:
        """(18,) the system's q0 restricted to the leg joints (the stand pose for ``hexapod``)."""
        q = np.zeros(self.nq)
        q[self.q_index.ravel()] = np.asarray(self.system.q0)[self.model_q_index.ravel()]
        return q

    # ------------------------------------------------------------------ forward kinematics
    def _planar(self, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Yaw ψ (..., 6), tibia-joint and foot (x, z) (..., 6, 2) in the yawed coxa frame, φ2 + φ3."""
        psi = self.coxa_sign * Q[..., 0]
        phi2 = self.femur_sign * Q[..., 1]
        phi3 = self.tibia_sign * Q[..., 2]
        knee = self.femur_joint + _rot2(phi2, np.broadcast_to(self.femur_link, Q.shape[:-1] + (2,)))
        foot = knee + _rot2(phi2 + phi3, np.broadcast_to(self.tibia_link, Q.shape[:-1] + (2,)))
        return psi, knee, foot, phi2 + phi3

    def _to_body(self, psi: np.ndarray, xz: np.ndarray) -> np.ndarray:
        """Points (x, z) of the leg plane at yaw ψ → (..., 6, 3) in B."""
        c, s = np.cos(psi), np.sin(psi)
        pc = np.stack((c * xz[..., 0], s * xz[..., 0], xz[..., 1]), axis=-1)
        return np.einsum("lij,...lj->...li", self.mount_rotation, pc) + self.mount_position

    def _feet_of(self, Q: np.ndarray) -> np.ndarray:
        """Feet (..., 6, 3) in B of per-leg angles Q (..., 6, 3) (no checks)."""
        psi, _, foot, _ = self._planar(Q)
        return self._to_body(psi, foot)

    def fk(self, q: Any) -> np.ndarray:
        """Foot positions (..., 6, 3) [m] in B of joint vectors ``q`` (..., 18) [rad].

        The closed form of the motor product of :meth:`fk_motors` (module docstring), vectorised over
        legs and batches; equals Pinocchio's ``oMf[{leg}_foot]`` to ~1e-16 m.
        """
        Q = self.per_leg(q)
        psi, _, foot, _ = self._planar(Q)
        return self._to_body(psi, foot)

    def fk_motors(self, q_leg: Any, leg: str) -> list[Multivector]:
        """The seed's product of motors (§3; paper Eq 7) for one leg.

        ``q_leg``: (3,) or (..., 3) (coxa, femur, tibia) [rad] (a batch gives array coefficients).
        Returns the motors (body frame B ← joint frame) ``[M_coxa, M_femur, M_tibia, M_foot]`` with
        ``M_coxa = P_coxa e^{q1 B1}``, ``M_femur = M_coxa P_femur e^{q2 B2}``,
        ``M_tibia = M_femur P_tibia e^{q3 B3}``, ``M_foot = M_tibia P_foot``: each equals Pinocchio's
        ``oMi``/``oMf`` of that joint/frame.  The foot point is ``M_foot e0 M̃_foot``
        (:meth:`foot_point`).
        """
        i = self.leg_index(leg)
        a = validation.array(q_leg, "q_leg")
        if a.ndim < 1 or a.shape[-1] != 3:
            raise InvalidInputError(f"q_leg must have shape (3,) or (..., 3) (coxa, femur, tibia), got {a.shape}")
        tree = self._tree
        out: list[Multivector] = []
        M: Multivector | None = None
        for k in range(3):
            J = tree.joints[int(self._joint_ids[i, k])]
            qk: Any = float(a[0 + k]) if a.ndim == 1 else a[..., k]
            local = J.placement * J.motion(qk)
            M = local.project(MOTOR_BLADES) if M is None else (M * local).project(MOTOR_BLADES)
            out.append(M)
        fi = tree.end_frames.index(self._foot_frames[i])
        assert M is not None
        out.append((M * tree.frame_placement[fi]).project(MOTOR_BLADES))
        return out

    def foot_point(self, q_leg: Any, leg: str) -> Multivector:
        """Conformal foot point ``P_toe = M_foot e0 M̃_foot`` (seed §3, paper Eq 2) of one leg."""
        M = self.fk_motors(q_leg, leg)[-1]
        return (M * Multivector((_E0,), (1.0,)) * M.reverse()).grade(1)

    def fk_via_motors(self, q: Any) -> np.ndarray:
        """Foot positions (6, 3) [m] in B of one ``q`` (18,) through the GA motors (the reference
        route of :meth:`fk`; slow, Python multivectors)."""
        Q = self.per_leg(validation.vector(q, self.nq, "q"))
        out = np.zeros((self.n_legs, 3))
        for i, leg in enumerate(self.legs):
            out[i] = np.array(motor_rotor_translation(self.fk_motors(Q[i], leg)[-1])[1], dtype=float)
        return out

    # ------------------------------------------------------------------ Jacobians
    def _kin(self, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Feet (..., 6, 3) and Jacobians (..., 6, 3, 3) of per-leg angles Q (..., 6, 3)."""
        psi, knee, foot, _ = self._planar(Q)
        p = self._to_body(psi, foot)
        c, s = np.cos(psi), np.sin(psi)
        R = self.mount_rotation
        # joint axes ω_j and points o_j in B (the twists of seed §3)
        ez = np.einsum("lij,j->li", R, np.array([0.0, 0.0, 1.0]))
        w1 = np.broadcast_to(self.coxa_sign[:, None] * ez, p.shape)
        lat = np.einsum("lij,...lj->...li", R, np.stack((-s, c, np.zeros_like(c)), axis=-1))  # yawed +y
        w2 = -self.femur_sign[:, None] * lat
        w3 = -self.tibia_sign[:, None] * lat
        o1 = np.broadcast_to(self.mount_position, p.shape)
        o2 = self._to_body(psi, np.broadcast_to(self.femur_joint, knee.shape))
        o3 = self._to_body(psi, knee)
        J = np.stack([np.cross(w, p - o) for w, o in ((w1, o1), (w2, o2), (w3, o3))], axis=-1)
        return p, J

    def jacobians(self, q: Any) -> np.ndarray:
        """Foot Jacobians ∂p_foot/∂q_leg (..., 6, 3, 3) in B [m/rad] of ``q`` (..., 18).

        ``J[..., i, :, j]`` is column j ∈ (coxa, femur, tibia) of leg i: ``ω_j × (p − o_j)`` for the
        joint's axis ω_j through o_j in B (seed §3; the Euclidean part of paper Eq 16–17).  Equals the
        linear rows of Pinocchio's ``LOCAL_WORLD_ALIGNED`` frame Jacobian of ``{leg}_foot``.
        """
        return self._kin(self.per_leg(q))[1]

    def link_frames(self, q: Any) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """The joint frames of every leg in B: ``{"coxa" | "femur" | "tibia": (R (..., 6, 3, 3), o (..., 6, 3))}``
        (rotation B ← joint frame, origin [m]) of joint vectors ``q`` (..., 18) — the frames the links (and their
        collision capsules) are attached to; equal to Pinocchio's ``oMi`` of the fixed-base model (tests)."""
        Q = self.per_leg(q)
        psi = self.coxa_sign * Q[..., 0]
        phi2 = self.femur_sign * Q[..., 1]
        phi3 = self.tibia_sign * Q[..., 2]

        def rot(axis: int, a: np.ndarray) -> np.ndarray:
            c, s_ = np.cos(a), np.sin(a)
            R = np.zeros((*a.shape, 3, 3))
            i, j = (0, 1) if axis == 2 else (2, 0)  # Rz: x → y; Ry: z → x
            R[..., axis, axis] = 1.0
            R[..., i, i], R[..., j, j], R[..., j, i], R[..., i, j] = c, c, s_, -s_
            return R

        def pt(xz: np.ndarray) -> np.ndarray:
            return np.stack((xz[..., 0], np.zeros_like(xz[..., 0]), xz[..., 1]), axis=-1)

        R_c = self.mount_rotation @ rot(2, psi)
        o_c = np.broadcast_to(self.mount_position, R_c.shape[:-1]).copy()
        R_f = R_c @ rot(1, -phi2)  # about −y by φ: the leg's x turns toward +z
        o_f = o_c + np.einsum("...ij,...j->...i", R_c, pt(np.broadcast_to(self.femur_joint, (*psi.shape, 2))))
        R_t = R_f @ rot(1, -phi3)
        o_t = o_f + np.einsum("...ij,...j->...i", R_f, pt(np.broadcast_to(self.femur_link, (*psi.shape, 2))))
        return {"coxa": (R_c, o_c), "femur": (R_f, o_f), "tibia": (R_t, o_t)}

    def contact_points(self, q: Any, normals: Any = (0.0, 0.0, 1.0)) -> np.ndarray:
        """Where the foot balls touch the ground: ``fk(q) − foot_radius · n`` (..., 6, 3) [m] in B, for the
        unit ground normals ``normals`` (3,) or (..., 6, 3) expressed in B (default +z of B, level ground under a
        level body).  The foot frame is the ball's centre; a ball resting on a plane with normal n touches it
        one radius below its centre along −n (:mod:`coop_ga.legged.contact`)."""
        feet = self.fk(q)
        n = validation.array(normals, "normals")
        if n.shape[-1:] != (3,):
            raise InvalidInputError(f"normals must have shape (3,) or (..., 6, 3) (unit vectors in B), got {n.shape}")
        norm = np.linalg.norm(n, axis=-1, keepdims=True)
        if not np.all(norm > 1e-12):
            raise InvalidInputError("normals must be non-zero (unit ground normals in B)")
        return feet - self.foot_radius * np.broadcast_to(n / norm, feet.shape)

    # ------------------------------------------------------------------ limits and reach
    def within_limits(self, q: Any, tol: float = 0.0) -> np.ndarray:
        """(..., 6) bool per leg of joint vectors ``q`` (..., 18) [rad]: all three joints of the leg inside
        [q_lower − tol, q_upper + tol] (``tol`` ≥ 0 [rad])."""
        tol = validation.nonnegative(tol, "tol")
        Q = self.per_leg(q)
        return np.all((Q >= self.q_lower - tol) & (Q <= self.q_upper + tol), axis=-1)

    def _violation(self, Q: np.ndarray) -> np.ndarray:
        """(..., 3) per-joint distance outside the limits [rad] (0 inside); Q (..., 6, 3)."""
        return np.maximum(np.maximum(self.q_lower - Q, Q - self.q_upper), 0.0)

    def _leg_frame(self, feet: np.ndarray) -> np.ndarray:
        """Feet (..., 6, 3) in B → in each leg's coxa frame at q_coxa = 0."""
        return np.einsum("lji,...lj->...li", self.mount_rotation, feet - self.mount_position)

    def _margins(self, pc: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """ρ, and for the two yaws (a = +ρ, −ρ) the planar vectors v (..., 6, 2, 2) and margins (..., 6, 2)."""
        rho = np.hypot(pc[..., 0], pc[..., 1])
        a = np.stack((rho, -rho), axis=-1)
        v = np.stack(
            (a - self.femur_joint[:, None, 0], np.repeat(pc[..., 2:3], 2, axis=-1) - self.femur_joint[:, None, 1]),
            axis=-1,
        )
        r = np.hypot(v[..., 0], v[..., 1])
        lo, hi = self.reach_min[:, None], self.reach_max[:, None]
        m = np.minimum(hi - r, r - lo)
        return rho, v, m

    def workspace_margin(self, feet: Any) -> np.ndarray:
        """Reach margin (..., 6) [m] of foot targets (..., 6, 3) in B: < 0 out of reach by exactly that
        Euclidean distance; > 0 reachable, at least that far inside the workspace (module docstring).

        The workspace is the kinematic one (module docstring): the joint limits are not part of it;
        :meth:`ik` with ``check_limits`` enforces them.
        """
        _, _, m = self._margins(self._leg_frame(self._feet(feet)))
        return m.max(axis=-1)

    # ------------------------------------------------------------------ inverse kinematics
    def _branch(self, branch: Any, batch: tuple[int, ...]) -> np.ndarray:
        """``branch`` → bool (..., 6), True = knee_up."""
        if isinstance(branch, str):
            return np.full(batch, validation.choice(branch, BRANCHES, "branch") == "knee_up")
        b = np.asarray(branch)
        if b.dtype.kind in "US":
            bad = sorted({str(x) for x in b.ravel()} - set(BRANCHES))
            if bad:
                raise InvalidInputError(f"branch entries must be one of {BRANCHES}, got {bad}")
            b = b == "knee_up"
        elif b.dtype != np.bool_:
            raise InvalidInputError(
                f"branch must be 'knee_up', 'knee_down', or a bool array (True = knee_up) / array of those "
                f"strings broadcastable to {batch}, got {b.dtype} array"
            )
        try:
            return np.broadcast_to(b, batch).copy()
        except ValueError:
            raise InvalidInputError(f"branch of shape {b.shape} does not broadcast to {batch}") from None

    def branch_of(self, q: Any) -> np.ndarray:
        """(..., 6) bool, True where a configuration (..., 18) is on the ``knee_up`` branch (ψ_3 ≤ 0)."""
        Q = self.per_leg(q)
        return _wrap(self.tibia_sign * Q[..., 2] + self._alpha) <= 0.0

    def ik_candidates(self, feet: Any) -> tuple[np.ndarray, np.ndarray]:
        """Every closed-form solution of foot targets (..., 6, 3) in B, limits ignored.

        Returns ``(Q, margin)``: ``Q`` (..., 6, 2, 2, 3) [rad] indexed [yaw, knee, joint] with yaw 0
        the foot in front of the coxa axis (ψ = atan2(y, x) in the coxa frame), yaw 1 behind it
        (ψ + π), knee 0 ``knee_up``, knee 1 ``knee_down``; ``margin`` (..., 6, 2) the reach margin
        [m] of each yaw (< 0: that yaw cannot reach; the angles are then those of the nearest
        boundary point).  Seed §3: coxa yaw from the projection, cosine law for femur–tibia.
        """
        pc = self._leg_frame(self._feet(feet))
        _, v, m = self._margins(pc)
        psi0 = np.arctan2(pc[..., 1], pc[..., 0])
        psi = np.stack((psi0, psi0 + np.pi), axis=-1)  # (..., 6, 2)
        r = np.hypot(v[..., 0], v[..., 1])
        lo, hi = self.reach_min[:, None], self.reach_max[:, None]
        far = np.sqrt(np.maximum((hi - r) * (hi + r), 0.0))
        near = np.sqrt(np.maximum((r - lo) * (r + lo), 0.0))
        knee = 2.0 * np.arctan2(far, near)  # |ψ_3| ∈ [0, π]
        psi3 = np.stack((-knee, knee), axis=-1)  # (..., 6, 2 yaw, 2 knee)
        phi3 = psi3 - self._alpha[:, None, None]
        shape = phi3.shape + (2,)
        w = np.broadcast_to(self.femur_link[:, None, None, :], shape) + _rot2(
            phi3, np.broadcast_to(self.tibia_link[:, None, None, :], shape)
        )
        phi2 = np.arctan2(v[..., None, 1], v[..., None, 0]) - np.arctan2(w[..., 1], w[..., 0])
        Q = np.stack(
            (
                np.broadcast_to((self.coxa_sign[:, None] * psi)[..., None], phi2.shape),
                self.femur_sign[:, None, None] * phi2,
                self.tibia_sign[:, None, None] * phi3,
            ),
            axis=-1,
        )
        return _wrap(Q), m

    def ik(self, feet: Any, branch: Any = "knee_up", check_limits: bool = True) -> np.ndarray:
        """Closed-form IK: foot targets (..., 6, 3) [m] in B → joint vector (..., 18) [rad].

        ``branch``: ``"knee_up"`` (default; the standing branch, negative tibia), ``"knee_down"``, or a
        bool array (True = knee_up) or array of those strings broadcastable to (..., 6).  Of the two
        coxa yaws (module docstring), the one inside — or least outside — the limits is taken.

        Raises :class:`~coop_ga.errors.UnreachableError` if a target is out of reach (the message names
        the legs and by how many mm, see :meth:`workspace_margin`), and, when ``check_limits``, if the
        solution of the requested branch leaves the joint limits by more than :data:`LIMIT_TOL` (the
        message names the joint, the limit and by how much, and says whether the other knee branch
        would do).  Solutions within :data:`LIMIT_TOL` outside a limit are clipped onto it.
        """
        P = self._feet(feet)
        if not isinstance(check_limits, (bool, np.bool_)):
            raise InvalidInputError(f"check_limits must be a bool, got {type(check_limits).__name__}")
        batch = P.shape[:-1]
        up = self._branch(branch, batch)
        Qc, m = self.ik_candidates(P)  # (..., 6, 2, 2, 3), (..., 6, 2)
        out_of_reach = m.max(axis=-1) < -REACH_TOL
        if np.any(out_of_reach):
            raise self._reach_error(P, m.max(axis=-1), out_of_reach)
        kidx = np.where(up, 0, 1)
        Qk = np.take_along_axis(Qc, kidx[..., None, None, None], axis=-2)[..., 0, :]  # (..., 6, 2, 3)
        viol = self._violation_yaw(Qk)  # (..., 6, 2)
        score = np.where(m >= -REACH_TOL, viol, np.inf)
        yidx = np.argmin(score, axis=-1)
        Q = np.take_along_axis(Qk, yidx[..., None, None], axis=-2)[..., 0, :]  # (..., 6, 3)
        if check_limits:
            v = self._violation(Q)
            bad = v.max(axis=-1) > LIMIT_TOL
            if np.any(bad):
                raise self._limit_error(P, Qc, m, up, Q, v, bad)
            Q = np.clip(Q, self.q_lower, self.q_upper)
        q = np.zeros((*batch[:-1], self.nq))
        q[..., self.q_index.ravel()] = Q.reshape(*batch[:-1], self.nq)
        return q

    def _violation_yaw(self, Qk: np.ndarray) -> np.ndarray:
        """Summed limit violation (..., 6, 2) of candidates Qk (..., 6, 2, 3)."""
        lo, hi = self.q_lower[:, None, :], self.q_upper[:, None, :]
        return np.maximum(np.maximum(lo - Qk, Qk - hi), 0.0).sum(axis=-1)

    # ------------------------------------------------------------------ error messages
    def _where(self, mask: np.ndarray) -> str:
        """' (at 3 of 100 configurations; first at batch index (7,))' for a (..., 6) mask."""
        if mask.ndim == 1:
            return ""
        per = mask.any(axis=-1)
        first = tuple(int(x) for x in np.argwhere(per)[0])
        return f" (at {int(per.sum())} of {per.size} configurations; first at batch index {first})"

    def _reach_error(self, P: np.ndarray, margin: np.ndarray, bad: np.ndarray) -> UnreachableError:
        worst = np.where(bad, -margin, -np.inf).reshape(-1, self.n_legs).max(axis=0)
        parts, legs = [], []
        for i, leg in enumerate(self.legs):
            if np.isfinite(worst[i]):
                legs.append(leg)
                idx = np.argwhere(bad[..., i] & (-margin[..., i] == worst[i]))[0]
                tgt = P[(*idx, i)] if idx.size else P[..., i, :].reshape(-1, 3)[0]
                parts.append(
                    f"leg {leg} out of reach by {1e3 * worst[i]:.2f} mm (target {np.round(tgt, 4).tolist()} m in B)"
                )
        i0 = self.legs.index(legs[0])
        msg = (
            f"foot target out of reach: {'; '.join(parts)}{self._where(bad)}. "
            f"A leg reaches {1e3 * self.reach_min[i0]:.1f}–{1e3 * self.reach_max[i0]:.1f} mm from its femur joint, "
            f"which sits {1e3 * self.coxa_length[i0]:.1f} mm out from the coxa axis; check "
            "LegModel.workspace_margin(feet) before solving"
        )
        return UnreachableError(msg, legs=tuple(legs), distance=float(np.max(worst[np.isfinite(worst)])))

    def _limit_error(
        self,
        P: np.ndarray,
        Qc: np.ndarray,
        m: np.ndarray,
        up: np.ndarray,
        Q: np.ndarray,
        v: np.ndarray,
        bad: np.ndarray,
    ) -> UnreachableError:
        # is the other knee branch feasible where this one is not?
        other = np.take_along_axis(Qc, np.where(up, 1, 0)[..., None, None, None], axis=-2)[..., 0, :]
        ov = np.where(m >= -REACH_TOL, self._violation_yaw(other), np.inf).min(axis=-1)
        parts, legs = [], []
        vmax = v.max(axis=-1)
        for i, leg in enumerate(self.legs):
            if not bad[..., i].any():
                continue
            legs.append(leg)
            idx = tuple(np.argwhere(bad[..., i] & (vmax[..., i] == vmax[..., i][bad[..., i]].max()))[0])
            br = "knee_up" if bool(up[(*idx, i)]) else "knee_down"
            alt = "knee_down" if br == "knee_up" else "knee_up"
            hint = f"; the {alt} solution is inside the limits (branch='{alt}')" if ov[(*idx, i)] <= LIMIT_TOL else ""
            joints = []
            for k in np.argsort(-v[(*idx, i)], kind="stable"):
                d = float(v[(*idx, i, k)])
                if d <= LIMIT_TOL:
                    break
                qk = float(Q[(*idx, i, k)])
                side = "lower" if qk < self.q_lower[i, k] else "upper"
                lim = float(self.q_lower[i, k] if side == "lower" else self.q_upper[i, k])
                joints.append(
                    f"{self.joint_names[i][k]} = {qk:.4f} rad, beyond its {side} limit {lim:.4f} rad by "
                    f"{d:.4f} rad ({math.degrees(d):.2f}°)"
                )
            parts.append(
                f"leg {leg}: the {br} solution has {' and '.join(joints)} "
                f"(target {np.round(P[(*idx, i)], 4).tolist()} m in B){hint}"
            )
        msg = (
            f"foot target reachable only outside the joint limits — {'; '.join(parts)}{self._where(bad)}. "
            "Targets under or through the body need joint angles beyond the limits; pass check_limits=False "
            "to get the solution anyway"
        )
        return UnreachableError(msg, legs=tuple(legs), violation=float(v.max()))

    # ------------------------------------------------------------------ damped least squares
    def _backtrack(
        self, Q0: np.ndarray, dq: np.ndarray, P: np.ndarray, active: np.ndarray, en: np.ndarray, clip: bool
    ) -> tuple[np.ndarray, np.ndarray]:
        """One backtracked step of :meth:`dls_ik`: halve a leg's step ``dq`` (B, 6, 3) [rad] from ``Q0`` (B, 6, 3)
        until its foot error against the targets ``P`` (B, 6, 3) [m] does not exceed ``en`` (B, 6) (the damped
        Gauss-Newton step alone can cycle across the straight-knee singularity when the target is out of
        reach); a leg that finds no descent in ``_MAX_HALVINGS`` stays put.  Only ``active`` (B, 6) legs move;
        ``clip`` projects onto the joint limits.  Returns the new joints (B, 6, 3) and each leg's step factor
        (B, 6) (0: it did not move)."""
        step = np.where(active, 1.0, 0.0)
        sub = np.arange(Q0.shape[0])  # entries whose step is being (re)tried
        Qr = Q0.copy()
        for h in range(_MAX_HALVINGS + 1):
            Qs = Q0[sub] + step[sub, :, None] * dq[sub]
            if clip:
                Qs = np.clip(Qs, self.q_lower, self.q_upper)
            Qr[sub] = Qs
            worse = active[sub] & (np.linalg.norm(P[sub] - self._feet_of(Qs), axis=-1) > en[sub])
            if not worse.any():
                break
            step[sub] = np.where(worse, 0.5 * step[sub] if h < _MAX_HALVINGS - 1 else 0.0, step[sub])
            sub = sub[worse.any(axis=-1)]
        return Qr, step

    def dls_ik(
        self,
        feet: Any,
        q_init: Any,
        damping: float = 1e-3,
        tol: float = 1e-10,
        max_iter: int = 100,
        max_step: float = 0.5,
        clip_to_limits: bool = False,
    ) -> DLSResult:
        """Damped-least-squares IK (seed §3) of foot targets (..., 6, 3) [m] in B from ``q_init`` (18,)
        or (..., 18) [rad]: per leg ``Δq = (JᵀJ + λ²I)⁻¹ Jᵀ (x* − fk(q))`` with J from twists
        (:meth:`jacobians`), all legs and batch entries at once, until ‖x* − fk(q)‖ ≤ ``tol`` [m].

        ``damping`` λ ≥ 0; ``max_step`` caps the largest joint change of a step [rad];
        ``clip_to_limits`` projects every iterate onto the joint limits (off by default: the result's
        ``within_limits`` reports them).  Each step is backtracked (halved, per leg) until the foot
        error does not grow, so the error is monotone; without it the damped step cycles across the
        straight-knee singularity for targets out of reach.  ``iterations`` counts the steps that moved
        a leg.  Legs that converged stop moving.  Never raises for an unreachable target: such a leg
        ends ``converged=False`` at the nearest point it found (for a target beyond the straight leg:
        the straight leg pointing at it, ``error`` = the reach distance of :meth:`workspace_margin`).
        """
        P = self._feet(feet)
        q0 = self._q(q_init, "q_init")
        lam = validation.nonnegative(damping, "damping")
        tol = validation.positive(tol, "tol")
        max_iter = validation.integer(max_iter, "max_iter", minimum=1)
        if max_iter > MAX_DLS_ITERATIONS:
            raise InvalidInputError(f"max_iter = {max_iter} is above {MAX_DLS_ITERATIONS} damped least-squares steps")
        max_step = validation.positive(max_step, "max_step")
        if not isinstance(clip_to_limits, (bool, np.bool_)):
            raise InvalidInputError(f"clip_to_limits must be a bool, got {type(clip_to_limits).__name__}")
        batch = P.shape[:-2]
        try:
            q0 = np.broadcast_to(q0, (*batch, self.nq))
        except ValueError:
            raise InvalidInputError(f"q_init of shape {q0.shape} does not broadcast to {(*batch, self.nq)}") from None
        n = self.n_legs
        Q = q0[..., self.q_index].reshape(-1, n, 3).copy()  # flat batch (B, 6, 3)
        Pf = P.reshape(-1, n, 3)
        if clip_to_limits:
            Q = np.clip(Q, self.q_lower, self.q_upper)
        it = np.zeros(Pf.shape[:-1], dtype=int)
        eye = np.eye(3) * lam * lam
        rows = np.arange(Pf.shape[0])  # batch entries with a leg still moving
        for _ in range(max_iter):
            p, J = self._kin(Q[rows])
            e = Pf[rows] - p
            en = np.linalg.norm(e, axis=-1)
            active = en > tol
            keep = active.any(axis=-1)
            rows, active, J, e, en = rows[keep], active[keep], J[keep], e[keep], en[keep]
            if rows.size == 0:
                break
            Jt = np.swapaxes(J, -1, -2)
            dq = np.linalg.solve(Jt @ J + eye, Jt @ e[..., None])[..., 0]
            big = np.abs(dq).max(axis=-1, keepdims=True)
            dq = dq * np.minimum(1.0, max_step / np.maximum(big, 1e-300))
            Qr, step = self._backtrack(Q[rows], dq, Pf[rows], active, en, clip_to_limits)
            Q[rows] = Qr
            it[rows] += active & (step > 0.0)
        Q = Q.reshape(*batch, n, 3)
        it = it.reshape(*batch, n)
        Q = _wrap(Q)
        if clip_to_limits:
            Q = np.clip(Q, self.q_lower, self.q_upper)
        p = self._kin(Q)[0]
        err = np.linalg.norm(P - p, axis=-1)
        conv = err <= tol
        q = np.zeros((*batch, self.nq))
        q[..., self.q_index.ravel()] = Q.reshape(*batch, self.nq)
        inside = np.all((Q >= self.q_lower - LIMIT_TOL) & (Q <= self.q_upper + LIMIT_TOL), axis=-1)
        msg = (
            f"DLS IK: {int(conv.sum())} of {conv.size} legs converged to ≤ {tol:g} m "
            f"(worst error {float(err.max()):.3g} m, at most {int(it.max())} iterations, λ = {lam:g})"
        )
        return DLSResult(q=q, converged=conv, error=err, iterations=it, within_limits=inside, message=msg)


def _leg_names(legs: Any) -> tuple[str, ...]:
    """A non-empty sequence of distinct leg names (not a single string)."""
    if isinstance(legs, str) or not isinstance(legs, Sequence):
        raise InvalidInputError(f"legs must be a list of leg names (e.g. {LEGS}), got {legs!r}")
    out = tuple(legs)
    if len(out) == 0 or len(set(out)) != len(out) or not all(isinstance(x, str) for x in out):
        raise InvalidInputError(f"legs must be distinct leg names (str), got {out}")
    return out


def _foot_ball_radius(system: Any, legs: tuple[str, ...], foot_frames: tuple[str, ...]) -> float:
    """The radius [m] of the sphere the robot's URDF puts on every foot frame (0.0 without one): a sphere
    geometry object of the tibia joint whose placement is the foot frame's.  Raises
    :class:`~coop_ga.errors.UnsupportedJointError` if the legs' balls differ."""
    import pinocchio as pin

    model = system.model
    found: dict[str, float] = {}
    for src in getattr(system, "visuals", ()):
        if getattr(src, "urdf", None) is None:
            continue
        for gtype in (pin.GeometryType.COLLISION, pin.GeometryType.VISUAL):
            smodel = pin.buildModelFromUrdf(str(src.urdf))
            try:
                geom = pin.buildGeomFromUrdf(smodel, str(src.urdf), gtype, None, list(src.package_dirs))
            except (ValueError, RuntimeError):  # pragma: no cover - a URDF that loads for kinematics loads here
                continue
            for leg, ff in zip(legs, foot_frames):
                if leg in found or not model.existFrame(ff):
                    continue
                foot = np.asarray(model.frames[model.getFrameId(ff)].placement.translation, float)
                for obj in geom.geometryObjects:
                    jname = src.prefix + smodel.names[int(obj.parentJoint)]
                    if (
                        jname == f"{leg}_tibia_joint"
                        and type(obj.geometry).__name__ == "Sphere"
                        and np.abs(np.asarray(obj.placement.translation, float) - foot).max() < _GEOM_TOL
                    ):
                        found[leg] = float(obj.geometry.radius)
                        break
    if not found:
        return 0.0
    radii = set(found.values())
    if len(radii) > 1 or len(found) != len(legs):
        raise UnsupportedJointError(
            f"the feet of system '{getattr(system, 'name', '?')}' are not equal balls: {found} (legs without one "
            f"are missing); the contact model needs the same foot ball on every leg"
        )
    return radii.pop()


def check_legs(legs: Any, what: str = "legs") -> LegModel:
    """``legs`` if it is a :class:`LegModel`, else :class:`~coop_ga.errors.InvalidInputError` naming ``what``."""
    if not isinstance(legs, LegModel):
        raise InvalidInputError(
            f"{what} must be a coop_ga.legged.LegModel (hexapod_legs() or LegModel.from_system(system)), "
            f"got {type(legs).__name__}"
        )
    return legs


#: how many leg models :func:`hexapod_legs` keeps (least recently used first out): each holds its system
LEGS_CACHE_SIZE = 16
_CACHE: OrderedDict[int, tuple[Any, LegModel]] = OrderedDict()
_CACHE_LOCK = threading.Lock()


def hexapod_legs(system: Any = None) -> LegModel:
    """The :class:`LegModel` of ``system`` (default ``coop_ga.systems.load("hexapod")``), cached per system
    (the :data:`LEGS_CACHE_SIZE` most recently used; a model dropped from the cache stays valid)."""
    if system is None:
        from ..systems import load

        system = load("hexapod")
    with _CACHE_LOCK:
        hit = _CACHE.get(id(system))
        if hit is not None and hit[0] is system:  # (an id may be reused by a new system once the old one is gone)
            _CACHE.move_to_end(id(system))
            return hit[1]
    legs = LegModel.from_system(system)
    with _CACHE_LOCK:
        _CACHE[id(system)] = (system, legs)
        while len(_CACHE) > LEGS_CACHE_SIZE:
            _CACHE.popitem(last=False)
    return legs
