"""Motor forward kinematics of Pinocchio models (paper §2.2, Eq 7–8, 16–17; seed 001).

A :class:`KinematicTree` turns a ``pinocchio.Model`` (revolute and prismatic joints, and
free flyers) and a list of end frames into motors:

* every joint ``j`` contributes its fixed placement (a constant motor ``P_j``, from
  ``model.jointPlacements``) and its motion ``exp(q_j B_j)``: a rotor about the joint
  axis or a translator along it (Eq 7);
* the world motor of joint ``j`` is ``C_j = C_parent(j) P_j exp(q_j B_j)``; an end frame
  adds its constant frame placement.  Chains that share joints (a humanoid's waist)
  share the products, and q holds every joint once, in Pinocchio's order.

A **free flyer** (``JointModelFreeFlyer``, a floating base) has 7 coordinates ``[p; x y z w]``
(position [m], unit quaternion) and 6 velocities, Pinocchio's LOCAL ``[v; ω]``: its motion is
``T(p) R(quaternion)`` (:func:`free_flyer_motor`) and it contributes six Jacobian columns, the
translations and rotations along/about its local axes.  A model with one has nq ≠ nv: q has nq
entries, every Jacobian has nv columns (velocities, in Pinocchio's order ``model.idx_vs``), and a
velocity moves q through ``pinocchio.integrate`` (:meth:`coop_ga.systems.System.integrate`).
For models without one, nq = nv and column j is joint j's coordinate.

Every function takes ``q`` as a numpy vector or a CasADi SX column and runs the same
sparse multivector code on both, so later layers differentiate it exactly.

Frames and conventions
----------------------
* Motors ``M = T(t) R`` map body coordinates to world coordinates (same as ``oMf``).
* The **geometric (body) Jacobian** has the 7 rows of
  :data:`coop_ga.geometry.groups.TANGENT_BASIS` (the e0∞ row is 0 for motors).  Column
  ``j`` is the body-frame velocity bivector ``−2 M̃ ∂M/∂q_j`` (Eq 8) as a 7-vector.
  In terms of Pinocchio's ``LOCAL`` frame Jacobian ``[v; ω]`` the rows are
  ``[ω_z, −ω_y, ω_x, 0, v_x, v_y, v_z]`` (see :data:`LOCAL_TO_TANGENT`).
* The **analytic Jacobian** is ``∂M/∂q`` itself: 8 motor coefficients per joint,
  ``∂M/∂q_j = −½ M b_j`` with ``b_j`` the bivector of body column j.
* The **end-point Jacobian** (Eq 16–17) of the conformal point ``P = M e0 M̃`` is
  ``∂P/∂q_j = P ⌋ L_j`` where ``L_j = C_j B_j C̃_j`` is joint j's axis in the world
  (a line for a revolute joint, a direction at infinity for a prismatic one).
  Its Euclidean part is ``ω_j × (p − o_j)`` (revolute) or ``a_j`` (prismatic) and its
  e∞ part ``p · ∂p`` (Eq 17); the e0 part is zero.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import validation
from ..algebra import backend as Bk
from ..algebra.basis import blade_index
from ..algebra.multivector import Multivector
from ..errors import InvalidInputError, UnknownNameError, UnsupportedJointError
from ..geometry.groups import (
    MOTOR_BLADES,
    bivector_to_tangent,
    motor_rotor_translation,
    rotor_from_matrix,
    rotor_matrix,
)

__all__ = [
    "LOCAL_TO_TANGENT",
    "QUATERNION_TOLERANCE",
    "Joint",
    "KinematicTree",
    "at_zero_velocity",
    "free_flyer_motor",
    "integrate_symbolic",
    "integrate_to_second_order",
    "motor_from_se3",
    "require_nq_equals_nv",
]


def _b(name: str) -> int:
    return blade_index(name)[0]


_E0, _E1, _E2, _E3, _EI = _b("e0"), _b("e1"), _b("e2"), _b("e3"), _b("einf")
_E12, _E13, _E23 = _b("e12"), _b("e13"), _b("e23")
_E1I, _E2I, _E3I = _b("e1inf"), _b("e2inf"), _b("e3inf")
_POINT_BLADES = (_E0, _E1, _E2, _E3, _EI)

#: ``LOCAL_TO_TANGENT @ [v; ω]`` (Pinocchio's 6-vector) gives the 7-vector body twist.
LOCAL_TO_TANGENT = np.zeros((7, 6))
LOCAL_TO_TANGENT[0, 5] = 1.0  # e12 <- ω_z
LOCAL_TO_TANGENT[1, 4] = -1.0  # e13 <- −ω_y
LOCAL_TO_TANGENT[2, 3] = 1.0  # e23 <- ω_x
LOCAL_TO_TANGENT[4, 0] = LOCAL_TO_TANGENT[5, 1] = LOCAL_TO_TANGENT[6, 2] = 1.0

_PRUNE = 1e-14  # constant placement coefficients below this are structural zeros


def _constant_motor(R: tuple[float, float, float, float], t: Sequence[float] | np.ndarray) -> Multivector:
    """Unit motor ``T(t) R`` with exact zeros dropped (sparser symbolic graphs)."""
    w, r12, r13, r23 = R
    Rm = Multivector((0, _E12, _E13, _E23), (w, r12, r13, r23))
    M = Multivector((0, _E1I, _E2I, _E3I), (1.0, -0.5 * t[0], -0.5 * t[1], -0.5 * t[2])) * Rm
    d = {k: c for k, c in zip(M.blades, M.coeffs) if abs(c) > _PRUNE}
    return Multivector.from_dict(d)


def motor_from_se3(M: Any) -> Multivector:
    """Unit motor of a ``pinocchio.SE3`` (or a (rotation 3×3, translation 3) pair)."""
    if isinstance(M, tuple):
        Rm, t = M
    else:
        Rm, t = M.rotation, M.translation
    R = rotor_from_matrix(np.asarray(Rm))
    if R[0] < 0:  # canonical sheet: keeps identities exactly 1
        R = (-R[0], -R[1], -R[2], -R[3])
    return _constant_motor(R, np.asarray(t, dtype=float))


#: a free flyer's six velocity columns, Pinocchio's LOCAL order [v; ω]: (kind, axis in the joint frame)
_FREE_COLUMNS = (
    ("prismatic", (1.0, 0.0, 0.0)),
    ("prismatic", (0.0, 1.0, 0.0)),
    ("prismatic", (0.0, 0.0, 1.0)),
    ("revolute", (1.0, 0.0, 0.0)),
    ("revolute", (0.0, 1.0, 0.0)),
    ("revolute", (0.0, 0.0, 1.0)),
)

#: a numeric free-flyer quaternion whose norm differs from 1 by more than this is refused (not normalised)
QUATERNION_TOLERANCE = 1e-6


def free_flyer_motor(qf: Any, name: str = "free flyer") -> Multivector:
    """Motor ``T(p) R`` of a free flyer's 7 coordinates ``[p_x, p_y, p_z, x, y, z, w]`` (p [m], the unit
    quaternion in Pinocchio's x y z w order), numpy or CasADi.

    The quaternion is divided by its norm, so rounding drift never leaves the motor group; a numeric one whose
    norm is off by more than :data:`QUATERNION_TOLERANCE` (or not finite) raises :class:`InvalidInputError`
    (normalise it, e.g. with ``pinocchio.normalize``).  A symbolic one is normalised (its norm must not be 0).
    """
    px, py, pz, x, y, z, w = (qf[i] for i in range(7))
    n = Bk.sqrt(x * x + y * y + z * z + w * w)
    if not Bk.is_symbolic(n):
        if not (abs(float(n) - 1.0) <= QUATERNION_TOLERANCE):
            raise InvalidInputError(
                f"joint '{name}': the free flyer's quaternion (x y z w) = {[float(c) for c in (x, y, z, w)]} has norm "
                f"{float(n):.9g}, not 1 (±{QUATERNION_TOLERANCE:g}); normalise it (pinocchio.normalize(model, q))"
            )
    # a rotation by θ about the unit axis a: quaternion (sin(θ/2) a, cos(θ/2)), rotor cos(θ/2) − sin(θ/2) a*
    R = Multivector((0, _E12, _E13, _E23), (w / n, -z / n, y / n, -x / n))
    T = Multivector((0, _E1I, _E2I, _E3I), (1.0, -0.5 * px, -0.5 * py, -0.5 * pz))
    return (T * R).project(MOTOR_BLADES)


@dataclass(frozen=True)
class Joint:
    """One joint of the tree: a 1-DOF revolute/prismatic joint, or a free flyer.

    Attributes:
        name: Pinocchio joint name.
        index: Pinocchio joint id.
        q_index: position of its (first) coordinate in q (``model.idx_qs``).
        parent: Pinocchio id of the parent joint (0 = world).
        kind: ``"revolute"``, ``"prismatic"`` or ``"free"`` (q = [p; quaternion x y z w], 7 coordinates,
            6 velocities [v; ω] in the joint's LOCAL frame, Pinocchio's ``JointModelFreeFlyer``).
        axis: unit axis in the joint frame ((0, 0, 0) for a free flyer).
        placement: constant motor of ``model.jointPlacements[index]`` (parent joint frame).
        v_index: position of its (first) velocity in q̇ (``model.idx_vs``; −1: the same as ``q_index``).
    """

    name: str
    index: int
    q_index: int
    parent: int
    kind: str
    axis: tuple[float, float, float]
    placement: Multivector
    v_index: int = -1

    @property
    def v(self) -> int:
        """The Jacobian column of this (1-DOF) joint or the first of a free flyer's six."""
        return self.q_index if self.v_index < 0 else self.v_index

    def columns(self) -> tuple[Joint, ...]:
        """One 1-DOF joint per velocity: this joint itself, or a free flyer's six (``v_index`` v … v+5):
        prismatic along the local x, y, z then revolute about them (Pinocchio's LOCAL ``[v; ω]``)."""
        if self.kind != "free":
            return (self,)
        return tuple(
            dataclasses.replace(self, kind=k, axis=a, v_index=self.v + i) for i, (k, a) in enumerate(_FREE_COLUMNS)
        )

    def bivector(self) -> Multivector:
        """B_j with ``exp(q B_j)`` written as ``1 − ½ q B_j + …`` : the joint's local screw."""
        ax, ay, az = self.axis
        if self.kind == "revolute":
            # θ on (e12, e13, e23) = (a_z, −a_y, a_x)·q; bivector = θ (TANGENT signs +1)
            d = {_E12: az, _E13: -ay, _E23: ax}
        else:
            d = {_E1I: ax, _E2I: ay, _E3I: az}
        return Multivector.from_dict({k: v for k, v in d.items() if v != 0.0})

    def motion(self, qj: Any) -> Multivector:
        """``exp(q_j B_j)``: the joint's motor at coordinate ``q_j`` (rad or m); for a free flyer, its
        7 coordinates [p; x y z w] give ``T(p) R(quaternion)`` (:func:`free_flyer_motor`)."""
        if self.kind == "free":
            return free_flyer_motor(qj, self.name)
        ax, ay, az = self.axis
        if self.kind == "revolute":
            c, s = Bk.cos(0.5 * qj), Bk.sin(0.5 * qj)
            d = {0: c, _E12: -s * az, _E13: s * ay, _E23: -s * ax}
        else:
            h = -0.5 * qj
            d = {0: 1.0, _E1I: h * ax, _E2I: h * ay, _E3I: h * az}
        return Multivector.from_dict({k: v for k, v in d.items() if not (isinstance(v, float) and v == 0.0 and k != 0)})


_SUPPORTED = {
    "JointModelRX": ("revolute", (1.0, 0.0, 0.0)),
    "JointModelRY": ("revolute", (0.0, 1.0, 0.0)),
    "JointModelRZ": ("revolute", (0.0, 0.0, 1.0)),
    "JointModelPX": ("prismatic", (1.0, 0.0, 0.0)),
    "JointModelPY": ("prismatic", (0.0, 1.0, 0.0)),
    "JointModelPZ": ("prismatic", (0.0, 0.0, 1.0)),
    "JointModelRevoluteUnaligned": ("revolute", None),
    "JointModelPrismaticUnaligned": ("prismatic", None),
    "JointModelFreeFlyer": ("free", (0.0, 0.0, 0.0)),
}


def _joint_axis(model: Any, jid: int, kind: str) -> tuple[float, float, float]:
    """Unit axis from the joint's motion subspace (robust to every 1-DOF revolute/prismatic class)."""
    import pinocchio as pin

    jm = model.joints[jid]
    jd = jm.createData()
    jm.calc(jd, pin.neutral(model))
    S = np.asarray(jd.S).reshape(6)
    v, w = S[:3], S[3:]
    a = w if kind == "revolute" else v
    if kind == "revolute" and np.linalg.norm(v) > 1e-12:
        raise UnsupportedJointError(f"joint '{model.names[jid]}': revolute axis does not pass through its frame origin")
    n = float(np.linalg.norm(a))
    a = a / n
    x, y, z = (0.0 if abs(c) < 1e-15 else float(c) for c in a)  # a has 3 entries
    return x, y, z


def require_nq_equals_nv(model: Any, what: str, instead: str, owner: str = "the model") -> None:
    """Raise :class:`UnsupportedJointError` when ``model`` has nq ≠ nv (a free flyer), naming ``what`` (a
    controller or function that assumes one coordinate per velocity) and ``instead`` (what works with it)."""
    if model.nq != model.nv:
        raise UnsupportedJointError(
            f"{what} assumes one coordinate per velocity (q ← q + q̇ Δt) and {owner} has a free flyer "
            f"(nq = {model.nq}, nv = {model.nv}); use {instead}, or lock the free flyer (a fixed-base model)"
        )


def _free_flyer_step(qf: Any, v: Any) -> list[Any]:
    """A free flyer's 7 coordinates moved by its LOCAL velocity ``v = [ν; ω]`` (6), to second order in v:
    ``M exp6(v)`` with ``exp6(v) ≈ (exp(ω), ν + ½ ω × ν)`` and the quaternion ``(ω/2, 1 − |ω|²/8)``."""
    px, py, pz, x, y, z, w = (qf[i] for i in range(7))
    nu, om = [v[i] for i in range(3)], [v[3 + i] for i in range(3)]
    # ν + ½ ω × ν, then rotated by the flyer's rotation R(x, y, z, w) into its parent frame
    t = [
        nu[0] + 0.5 * (om[1] * nu[2] - om[2] * nu[1]),
        nu[1] + 0.5 * (om[2] * nu[0] - om[0] * nu[2]),
        nu[2] + 0.5 * (om[0] * nu[1] - om[1] * nu[0]),
    ]
    R = (
        (1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)),
        (2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)),
        (2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)),
    )
    p = [c + R[i][0] * t[0] + R[i][1] * t[1] + R[i][2] * t[2] for i, c in enumerate((px, py, pz))]
    ex, ey, ez = (0.5 * c for c in om)
    ew = 1 - 0.125 * (om[0] * om[0] + om[1] * om[1] + om[2] * om[2])
    # Hamilton product (x, y, z, w) ⊗ (ex, ey, ez, ew): the rotation R exp(ω)
    quat = [
        w * ex + ew * x + y * ez - z * ey,
        w * ey + ew * y + z * ex - x * ez,
        w * ez + ew * z + x * ey - y * ex,
        w * ew - x * ex - y * ey - z * ez,
    ]
    return p + quat


def _integrate_joints(model: Any, q: Any, v: Any, free_flyer: Any, name: str) -> Any:
    """``q ⊕ v`` joint by joint (CasADi SX): q + v for 1-DOF joints, ``free_flyer(q_joint, v_joint)`` for a free
    flyer; :class:`UnsupportedJointError` naming ``name`` for any other joint."""
    import casadi as ca

    out: list[Any] = []
    for jid in range(1, model.njoints):
        iq, iv, nqj, nvj = (int(a[jid]) for a in (model.idx_qs, model.idx_vs, model.nqs, model.nvs))
        if nqj == nvj:
            out += [q[iq + k] + v[iv + k] for k in range(nqj)]
        elif model.joints[jid].shortname() == "JointModelFreeFlyer":
            out += free_flyer([q[iq + k] for k in range(7)], [v[iv + k] for k in range(6)])
        else:
            raise UnsupportedJointError(
                f"joint '{model.names[jid]}' has type {model.joints[jid].shortname()}: only 1-DOF joints and "
                f"free flyers move by {name}; lock it (pinocchio.buildReducedModel)"
            )
    return ca.vertcat(*out)


def integrate_to_second_order(model: Any, q: Any, v: Any) -> Any:
    """``q ⊕ v`` (nq CasADi SX) as a polynomial in the velocity v (nv), equal to ``pinocchio.integrate(model,
    q, v)`` up to O(|v|³): q + v for 1-DOF joints, ``M exp6(v)`` to second order for a free flyer.

    Its first and second derivatives in v at v = 0 are those through ``pinocchio.integrate``, so
    ``f(integrate_to_second_order(model, q, v))`` differentiated by AD at v = 0 gives a function's
    derivatives along the tangent space (nv columns) — exactly, without the 0/0 of ``sin|ω|/|ω|``.
    Raises :class:`UnsupportedJointError` for a joint that is neither 1-DOF nor a free flyer."""
    return _integrate_joints(model, q, v, _free_flyer_step, "integrate_to_second_order")


#: Below this |ω|² [rad²] the free flyer's exponential uses its Taylor series (to θ⁶; error < 1e-16 there), above
#: it the closed form (whose cancellation in θ − sin θ costs ~1e-14 at the switch): no 0/0 in value or derivatives.
EXP_TAYLOR_THETA2 = 1e-2


def _free_flyer_exp(qf: Any, v: Any) -> list[Any]:
    """A free flyer's 7 coordinates moved by its LOCAL velocity ``v = [ν; ω]`` (6) for 1 s, exactly (CasADi SX):
    ``M exp6(v)``, ``exp6(v) = (exp(ω), V(ω) ν)`` with ``V ν = ν + a ω × ν + b ω × (ω × ν)``,
    ``a = (1 − cos θ)/θ² = 2 s²``, ``b = (θ − sin θ)/θ³``, and the quaternion ``(s ω, cos(θ/2))``,
    ``s = sin(θ/2)/θ`` (θ = |ω|) — ``pinocchio.integrate``'s SE(3) exponential."""
    import casadi as ca

    px, py, pz, x, y, z, w = (qf[i] for i in range(7))
    nu, om = [v[i] for i in range(3)], [v[3 + i] for i in range(3)]
    t2 = om[0] * om[0] + om[1] * om[1] + om[2] * om[2]
    small = t2 < EXP_TAYLOR_THETA2
    th = ca.sqrt(ca.if_else(small, 1.0, t2))  # never 0 in the closed-form branch (its derivatives stay finite)
    s = ca.if_else(small, 0.5 - t2 / 48 + t2 * t2 / 3840 - t2 * t2 * t2 / 645120, ca.sin(0.5 * th) / th)
    b = ca.if_else(small, 1 / 6 - t2 / 120 + t2 * t2 / 5040 - t2 * t2 * t2 / 362880, (th - ca.sin(th)) / (th * th * th))
    c = ca.if_else(small, 1 - t2 / 8 + t2 * t2 / 384 - t2 * t2 * t2 / 46080, ca.cos(0.5 * ca.sqrt(t2)))
    a = 2 * s * s

    def cross(p: list[Any], q: list[Any]) -> list[Any]:
        return [p[1] * q[2] - p[2] * q[1], p[2] * q[0] - p[0] * q[2], p[0] * q[1] - p[1] * q[0]]

    wn = cross(om, nu)
    wwn = cross(om, wn)
    t = [nu[i] + a * wn[i] + b * wwn[i] for i in range(3)]
    R = (
        (1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)),
        (2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)),
        (2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)),
    )
    p = [o + R[i][0] * t[0] + R[i][1] * t[1] + R[i][2] * t[2] for i, o in enumerate((px, py, pz))]
    ex, ey, ez, ew = s * om[0], s * om[1], s * om[2], c
    quat = [  # Hamilton product (x, y, z, w) ⊗ (ex, ey, ez, ew): the rotation R exp(ω)
        w * ex + ew * x + y * ez - z * ey,
        w * ey + ew * y + z * ex - x * ez,
        w * ez + ew * z + x * ey - y * ex,
        w * ew - x * ex - y * ey - z * ez,
    ]
    return p + quat


def integrate_symbolic(model: Any, q: Any, v: Any) -> Any:
    """``pinocchio.integrate(model, q, v)`` as a CasADi SX expression (nq) of q (nq) and v (nv), exact: q + v for
    1-DOF joints, ``M exp6(v)`` for a free flyer (:func:`_free_flyer_exp`; a unit quaternion stays unit).
    Raises :class:`UnsupportedJointError` for a joint that is neither 1-DOF nor a free flyer."""
    return _integrate_joints(model, q, v, _free_flyer_exp, "integrate_symbolic")


def at_zero_velocity(model: Any, build: Any, q: Any, *extra: Any) -> Any:
    """``build(q ⊕ v, v)`` evaluated at v = 0 (CasADi SX): ``build`` returns an expression of its two arguments
    and of the symbols ``extra`` (e.g. ``lambda qv, v: ca.jacobian(f(qv), v)``, the derivative of f along the
    tangent space, nv columns), q ⊕ v is :func:`integrate_to_second_order` (exact up to second derivatives)."""
    import casadi as ca

    v = ca.SX.sym("v", int(model.nv))
    qs = ca.SX.sym("q", int(model.nq))
    f = ca.Function("at_v", [qs, v, *extra], [build(integrate_to_second_order(model, qs, v), v)])
    return f(q, ca.DM.zeros(int(model.nv)), *extra)


def _as_q(q: Any, nq: int, what: str = "q") -> Any:
    if Bk.is_symbolic(q):
        if q.numel() != nq:
            raise InvalidInputError(f"{what} must have {nq} entries, got a CasADi expression of shape {q.shape}")
        return q
    return validation.configuration(q, nq, what)


class KinematicTree:
    """The motor kinematics of a Pinocchio model restricted to the paths to ``end_frames``.

    Args:
        model:
            ``pinocchio.Model`` with revolute/prismatic joints and free flyers only (lock others
            with ``pinocchio.buildReducedModel`` first).  A free flyer has 7 coordinates in q and
            6 velocities: the Jacobians have ``nv`` columns (module docstring).
        end_frames:
            Names of the frames whose motors/points are the chain ends, in the order
            the cooperative layer will use them.
    """

    def __init__(self, model: Any, end_frames: Sequence[str]):
        self.model = model
        names = [f.name for f in model.frames]
        self.end_frames = tuple(end_frames)
        if not self.end_frames:
            raise InvalidInputError("end_frames is empty: name at least one frame, e.g. an end-effector link")
        self.joints: dict[int, Joint] = {}
        self.frame_parent: list[int] = []
        self.frame_placement: list[Multivector] = []
        self.chains: list[tuple[int, ...]] = []
        for fname in self.end_frames:
            if fname not in names:
                raise UnknownNameError(f"unknown frame '{fname}'. Available frames: {', '.join(sorted(set(names)))}")
            fid = model.getFrameId(fname)
            f = model.frames[fid]
            parent = int(f.parentJoint)
            self.frame_parent.append(parent)
            self.frame_placement.append(motor_from_se3(f.placement))
            chain = []
            j = parent
            while j > 0:
                chain.append(j)
                self._add_joint(j)
                j = int(model.parents[j])
            self.chains.append(tuple(reversed(chain)))
        self.nq = int(model.nq)
        #: number of velocities (Jacobian columns): nq, or nq − 1 per free flyer
        self.nv = int(model.nv)
        # evaluation order: parents before children
        self._order = sorted(self.joints)

    def _add_joint(self, jid: int) -> None:
        if jid in self.joints:
            return
        m = self.model
        jm = m.joints[jid]
        short = jm.shortname()
        if short not in _SUPPORTED:
            raise UnsupportedJointError(
                f"joint '{m.names[jid]}' has type {short}; coop_ga supports revolute and prismatic joints "
                "(RX/RY/RZ, PX/PY/PZ, unaligned) and free flyers (JointModelFreeFlyer). Lock it with "
                "pinocchio.buildReducedModel (or coop_ga.systems.from_urdf(..., locked_joints=[...]))."
            )
        kind, axis = _SUPPORTED[short]
        if axis is None:
            axis = _joint_axis(m, jid, kind)
        self.joints[jid] = Joint(
            name=m.names[jid],
            index=jid,
            q_index=int(m.idx_qs[jid]),
            parent=int(m.parents[jid]),
            kind=kind,
            axis=axis,
            placement=motor_from_se3(m.jointPlacements[jid]),
            v_index=int(m.idx_vs[jid]),
        )

    # ------------------------------------------------------------------ joints
    def _chain_v(self, chain: tuple[int, ...]) -> list[int]:
        """The Jacobian columns (indices in q̇) of a chain's joints, root to tip."""
        return [c.v for j in chain for c in self.joints[j].columns()]

    @property
    def joint_columns(self) -> list[tuple[int, ...]]:
        """For each chain, the Jacobian columns (indices in q̇) of its joints, root to tip: a joint's q index
        when nq = nv, a free flyer's six velocities."""
        return [tuple(c.v for j in ch for c in self.joints[j].columns()) for ch in self.chains]

    def joint_motors(self, q: Any) -> dict[int, Multivector]:
        """World motors ``C_j`` (after the joint's motion) of every joint on a chain."""
        q = _as_q(q, self.nq)
        C: dict[int, Multivector] = {}
        for jid in self._order:
            J = self.joints[jid]
            local = J.placement * J.motion(q[J.q_index : J.q_index + 7] if J.kind == "free" else q[J.q_index])
            C[jid] = (C[J.parent] * local if J.parent in C else local).project(MOTOR_BLADES)
        return C

    # ------------------------------------------------------------------ forward kinematics
    def frame_motors(self, q: Any, C: dict[int, Multivector] | None = None) -> list[Multivector]:
        """Motor of each end frame in the world (equals Pinocchio's ``oMf``)."""
        if C is None:
            C = self.joint_motors(q)
        out = []
        for parent, Pf in zip(self.frame_parent, self.frame_placement):
            out.append((C[parent] * Pf).project(MOTOR_BLADES) if parent > 0 else Pf)
        return out

    def end_points(self, q: Any, motors: list[Multivector] | None = None) -> list[tuple[Any, Any, Any]]:
        """Euclidean end points [m] of every end frame (translation parts of the motors)."""
        if motors is None:
            motors = self.frame_motors(q)
        return [motor_rotor_translation(M)[1] for M in motors]

    def end_points_array(self, q: Any) -> np.ndarray:
        """End points as a numeric (k, 3) array."""
        return np.array([[float(c) for c in p] for p in self.end_points(q)])

    def conformal_points(self, q: Any) -> list[Multivector]:
        """End points as conformal points ``P = e0 + p + ½|p|² e∞`` (Eq 2)."""
        pts = self.end_points(q)
        return [
            Multivector(_POINT_BLADES, (1.0, p[0], p[1], p[2], 0.5 * (p[0] * p[0] + p[1] * p[1] + p[2] * p[2])))
            for p in pts
        ]

    # ------------------------------------------------------------------ Jacobians
    def joint_lines(self, q: Any, C: dict[int, Multivector] | None = None) -> dict[int, Multivector]:
        """World axis ``L_j = C_j B_j C̃_j`` of every Jacobian column (a line, or a direction for prismatic
        joints), keyed by its index in q̇ (a free flyer has six: its local x, y, z translations and rotations)."""
        if C is None:
            C = self.joint_motors(q)
        return {
            c.v: (C[j] * c.bivector() * C[j].reverse()).grade(2) for j in self._order for c in self.joints[j].columns()
        }

    def geometric_jacobians(self, q: Any) -> list[Any]:
        """Body-frame geometric Jacobian of each end frame, 7×nv (Eq 8), numpy or CasADi.

        Column j is ``−2 M̃ ∂M/∂q_j = M̃ L_j M`` as a 7-vector; columns of joints
        not on the chain are zero.  With a free flyer, columns are velocities (Pinocchio's ``v``, the
        flyer's LOCAL [v; ω]), so there are nv of them.
        """
        qv = _as_q(q, self.nq)
        C = self.joint_motors(qv)
        Ms = self.frame_motors(qv, C)
        L = self.joint_lines(qv, C)
        sym = Bk.is_symbolic(qv)
        out = []
        for M, chain in zip(Ms, self.chains):
            cols = {}
            Mr = M.reverse()
            for v in self._chain_v(chain):
                Bb = (Mr * L[v] * M).grade(2)
                cols[v] = bivector_to_tangent(Bb)
            out.append(_assemble(cols, 7, self.nv, sym))
        return out

    def analytic_jacobians(self, q: Any) -> list[list[Multivector | None]]:
        """∂M/∂q_j for each end frame and joint (Eq 8 before the frame change), None off-chain.

        ``∂M/∂q_j = −½ L_j M``: the joint's world axis acting on the motor from the left.
        """
        qv = _as_q(q, self.nq)
        C = self.joint_motors(qv)
        Ms = self.frame_motors(qv, C)
        L = self.joint_lines(qv, C)
        out = []
        for M, chain in zip(Ms, self.chains):
            cols: list[Multivector | None] = [None] * self.nv
            for v in self._chain_v(chain):
                cols[v] = (L[v] * M).project(MOTOR_BLADES).scale(-0.5)
            out.append(cols)
        return out

    def point_jacobians(self, q: Any) -> tuple[list[Multivector], list[list[Multivector | None]]]:
        """Conformal end points and their Jacobians ``∂P/∂q_j = P ⌋ L_j`` (Eq 16–17).

        Returns ``(points, columns)`` with ``columns[i][j]`` the vector ∂P_i/∂q_j (None
        when joint j is not on chain i).
        """
        qv = _as_q(q, self.nq)
        C = self.joint_motors(qv)
        Ms = self.frame_motors(qv, C)
        L = self.joint_lines(qv, C)
        P = []
        for M in Ms:
            p = motor_rotor_translation(M)[1]
            P.append(
                Multivector(_POINT_BLADES, (1.0, p[0], p[1], p[2], 0.5 * (p[0] * p[0] + p[1] * p[1] + p[2] * p[2])))
            )
        cols = []
        for Pi, chain in zip(P, self.chains):
            c: list[Multivector | None] = [None] * self.nv
            for v in self._chain_v(chain):
                c[v] = Pi.lc(L[v]).grade(1)
            cols.append(c)
        return P, cols

    def euclidean_point_jacobians(self, q: Any) -> list[Any]:
        """3×nv world-frame Jacobians of the end points (the e1, e2, e3 part of Eq 17).

        Evaluated in the cheap vector form ``ω_j × (p − o_j)`` (revolute) / ``a_j``
        (prismatic), with the world axis ``ω_j = R_j a_j`` and origin ``o_j`` read off the
        joint motor ``C_j``; it is the Euclidean part of ``P ⌋ L_j``
        (:meth:`point_jacobians`), and about 4× fewer operations in a symbolic graph.
        """
        qv = _as_q(q, self.nq)
        C = self.joint_motors(qv)
        Ms = self.frame_motors(qv, C)
        sym = Bk.is_symbolic(qv)
        frames: dict[int, tuple[Any, Any, str]] = {}
        for j in {j for ch in self.chains for j in ch}:
            R, o = motor_rotor_translation(C[j])
            Rm = rotor_matrix(R)
            for c in self.joints[j].columns():
                a = c.axis
                w = tuple(sum(Rm[r][k] * a[k] for k in range(3) if a[k] != 0.0) for r in range(3))
                frames[c.v] = (w, o, c.kind)
        out = []
        for M, chain in zip(Ms, self.chains):
            p = motor_rotor_translation(M)[1]
            cols = {}
            for v in self._chain_v(chain):
                w, o, kind = frames[v]
                if kind == "revolute":
                    d = (p[0] - o[0], p[1] - o[1], p[2] - o[2])
                    cols[v] = (
                        w[1] * d[2] - w[2] * d[1],
                        w[2] * d[0] - w[0] * d[2],
                        w[0] * d[1] - w[1] * d[0],
                    )
                else:
                    cols[v] = w
            out.append(_assemble(cols, 3, self.nv, sym))
        return out


def _assemble(cols: dict[int, tuple[Any, ...]], rows: int, n: int, sym: bool) -> Any:
    if sym:
        import casadi as ca

        Js = ca.SX.zeros(rows, n)
        for j, v in cols.items():
            for r in range(rows):
                Js[r, j] = v[r]
        return Js
    J = np.zeros((rows, n))
    for j, v in cols.items():
        J[:, j] = [float(x) for x in v]
    return J
