"""The floating body of the hexapod: its pose as an SE(3) motor, the world feet, the free-flyer system.

A :class:`BodyState` is the whole robot's configuration: the body pose (position in W, rotation
W←B) and the 18 leg joints (URDF order, :data:`coop_ga.legged.legs.LEGS`).  The body pose is the
GA motor ``M_body = T(position) R`` (:meth:`BodyState.motor`), and a foot at ``p_foot(q)`` in the
body frame B is at

    f = M_body · p_foot(q) = position + R p_foot(q)        (world frame W)

(:meth:`BodyState.feet_world`; the sandwich ``M P(p) M̃`` of the conformal point gives the same
numbers to ~1e-16, ``tests/legged/test_body.py``).

Body velocities are twists in B: ``(v, ω)`` [m/s, rad/s] with ``Ṗ = R v``, ``Ṙ = R [ω]×``; as a
motor, ``M(t + Δt) = M(t) · exp(Δt · ξ)`` with ξ the 7-vector tangent ``[ω_z, −ω_y, ω_x, 0, v]``
on ``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]`` (the tangent convention of :mod:`coop_ga.geometry`:
θ12 about +z, θ13 = −θ about +y, θ23 about +x).  :func:`body_tangent` builds ξ and
:meth:`BodyState.moved` applies one step.

:func:`free_flyer_hexapod` is the floating hexapod, ``coop_ga.systems.load("hexapod", free_flyer=True)`` (built
by :func:`coop_ga.systems.library.hexapod_free_flyer`): the body on a Pinocchio free flyer (``root_joint``) before
the 18 leg joints, ``q = [position (3), quaternion x y z w (4), q_legs (18)]`` (25,), ``q̇ = [v, ω (body frame),
q̇_legs]`` (24,), end frames the six feet in world coordinates, the hexapod's visual geometry.
:meth:`BodyState.free_flyer_q` / :meth:`BodyState.from_free_flyer_q` convert (the quaternion is the body's
rotation itself, no Euler angles), so that whole-robot scenes go through :func:`coop_ga.viz.render_scene` and
Pinocchio checks ``feet_world``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..algebra import Multivector
from ..errors import InvalidInputError
from ..kinematics.chains import motor_from_se3
from ..validation import array, scalar, vector

if TYPE_CHECKING:  # pragma: no cover
    from ..systems.system import System
    from .legs import LegModel

__all__ = [
    "LEG_ORDER",
    "BodyState",
    "body_tangent",
    "free_flyer_hexapod",
    "rotation_from_rpy",
    "rpy_from_rotation",
    "stance_indices",
]

#: this package's leg order (the URDF's; ``coop_ga.legged.legs.LEGS``).
LEG_ORDER: tuple[str, ...] = ("lf", "lm", "lr", "rf", "rm", "rr")
#: orthonormality tolerance of a rotation matrix handed to :class:`BodyState` (re-orthonormalised below it).
_ORTHO_TOL = 1e-6


def free_flyer_hexapod() -> System:
    """The floating hexapod, ``systems.load("hexapod", free_flyer=True)`` (nq = 25, nv = 24).

    ``q = [x, y, z, qx, qy, qz, qw, q_legs (18, URDF order)]``: body position [m] in W and the unit quaternion
    (x, y, z, w) of R_WB; ``q̇ = [v, ω, q̇_legs]`` with the body twist (v, ω) in B [m/s, rad/s].  End frames: the
    six feet (in the order of the fixed-base ``hexapod``: the tripods (lf, lr, rm), (rf, lm, rr)), world frame.
    Used for the contact roll-out, whole-robot scenes and Pinocchio cross-checks; convert with
    :meth:`BodyState.free_flyer_q` / :meth:`BodyState.from_free_flyer_q`.
    """
    from .. import systems

    return systems.load("hexapod", free_flyer=True)


def rotation_from_rpy(rpy: Any) -> np.ndarray:
    """R_WB (3, 3) = Rz(yaw) Ry(pitch) Rx(roll) from ``rpy = (roll, pitch, yaw)`` [rad]."""
    r, p, y = vector(rpy, 3, "rpy (roll, pitch, yaw)")
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def rpy_from_rotation(R: Any) -> np.ndarray:
    """``(roll, pitch, yaw)`` [rad] (3,) of R_WB = Rz(yaw) Ry(pitch) Rx(roll); pitch in [−π/2, π/2].

    At pitch = ±π/2 (gimbal lock) roll is set to 0 and the rotation about z goes to yaw.  Raises
    :class:`~coop_ga.errors.InvalidInputError` if R is not a rotation (to 1e-6)."""
    M = array(R, "R", shape=(3, 3))
    check_rotation(M, "R")
    sp = -float(np.clip(M[2, 0], -1.0, 1.0))
    pitch = float(np.arcsin(sp))
    if abs(sp) < 1.0 - 1e-12:
        roll = float(np.arctan2(M[2, 1], M[2, 2]))
        yaw = float(np.arctan2(M[1, 0], M[0, 0]))
    else:  # gimbal lock: R = Rz(yaw ∓ roll) Ry(±π/2); put it all into yaw
        roll = 0.0
        yaw = float(np.arctan2(-M[0, 1], M[1, 1]))
    return np.array([roll, pitch, yaw])


def check_rotation(R: np.ndarray, what: str) -> float:
    """|RᵀR − I| (max entry) of a (3, 3) array; :class:`~coop_ga.errors.InvalidInputError` naming ``what`` if R
    is not a rotation to :data:`_ORTHO_TOL` (orthonormal, det +1)."""
    err = float(np.max(np.abs(R.T @ R - np.eye(3))))
    if not err <= _ORTHO_TOL or not np.linalg.det(R) > 0:
        raise InvalidInputError(
            f"{what} must be a rotation matrix (orthonormal, det +1); |RᵀR − I| = {err:.3g}, "
            f"det = {np.linalg.det(R):.3g}"
        )
    return err


def _orthonormal(R: np.ndarray) -> np.ndarray:
    """R if it is a rotation (to :data:`_ORTHO_TOL`), re-orthonormalised by the SVD; else InvalidInputError."""
    err = check_rotation(R, "BodyState.rotation (W←B)")
    if err == 0.0:
        return R
    U, _, Vt = np.linalg.svd(R)
    return U @ Vt


def _points3(points: Any, what: str) -> np.ndarray:
    """Points (..., 3) [m], checked (finite, real, last dimension 3)."""
    p = array(points, what)
    if p.ndim == 0 or p.shape[-1] != 3:
        raise InvalidInputError(f"{what} must have shape (..., 3) [m], got shape {p.shape}")
    return p


def body_tangent(v: Any, omega: Any) -> np.ndarray:
    """The 7-vector tangent ξ of a body twist ``(v, ω)`` in B [m/s, rad/s]:
    ``[ω_z, −ω_y, ω_x, 0, v_x, v_y, v_z]`` on ``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]``."""
    vv = vector(v, 3, "v")
    w = vector(omega, 3, "omega")
    return np.array([w[2], -w[1], w[0], 0.0, vv[0], vv[1], vv[2]])


def stance_indices(stance_legs: Any) -> tuple[int, ...]:
    """Leg indices (into :data:`LEG_ORDER`) of ``stance_legs``: names (e.g. ``("lf", "rm")``), indices,
    or a (6,) bool mask; sorted, without repeats.  Raises :class:`InvalidInputError` otherwise."""
    if isinstance(stance_legs, str):
        raise InvalidInputError(
            f"stance_legs must be a sequence of leg names from {LEG_ORDER} (or a (6,) bool mask), got the string "
            f"{stance_legs!r}; write ({stance_legs!r},) for one leg"
        )
    if isinstance(stance_legs, np.ndarray) and stance_legs.dtype == np.bool_:
        if stance_legs.shape != (6,):
            raise InvalidInputError(
                f"stance_legs as a mask must have shape (6,) (legs {LEG_ORDER}), got {stance_legs.shape}"
            )
        return tuple(int(i) for i in np.flatnonzero(stance_legs))
    if not isinstance(stance_legs, Sequence | np.ndarray):
        raise InvalidInputError(f"stance_legs must be a sequence of leg names from {LEG_ORDER}, got {stance_legs!r}")
    out: set[int] = set()
    for leg in stance_legs:
        if isinstance(leg, str):
            if leg not in LEG_ORDER:
                raise InvalidInputError(f"stance_legs: unknown leg {leg!r}; the legs are {', '.join(LEG_ORDER)}")
            out.add(LEG_ORDER.index(leg))
        elif isinstance(leg, int | np.integer) and not isinstance(leg, bool) and 0 <= int(leg) < 6:
            out.add(int(leg))
        else:
            raise InvalidInputError(f"stance_legs: {leg!r} is neither a leg name from {LEG_ORDER} nor an index 0..5")
    return tuple(sorted(out))


@dataclass
class BodyState:
    """The floating hexapod's configuration: body pose and leg joints.

    Attributes:
        position: (3,) body origin (``base_link``, the plane of the coxa axes) in W [m].
        rotation: (3, 3) R_WB, world ← body (columns: the body's x forward, y left, z up in W).
        q: (18,) leg joint angles [rad] in URDF order (lf, lm, lr, rf, rm, rr; coxa, femur, tibia).

    Validated on construction (shapes, finite values; a rotation within 1e-6 of orthonormal is
    re-orthonormalised, anything else raises :class:`~coop_ga.errors.InvalidInputError`); the
    arrays are copies.  Joint limits are not checked here (:meth:`LegModel.within_limits`).
    """

    position: np.ndarray
    rotation: np.ndarray
    q: np.ndarray

    def __post_init__(self) -> None:
        self.position = vector(self.position, 3, "BodyState.position").copy()
        self.rotation = _orthonormal(array(self.rotation, "BodyState.rotation", shape=(3, 3)).copy())
        self.q = vector(self.q, 18, "BodyState.q (18 leg joints)").copy()

    # ------------------------------------------------------------------ constructors
    @classmethod
    def from_rpy(cls, position: Any, rpy: Any, q: Any) -> BodyState:
        """Body at ``position`` [m] (W) with ``rpy = (roll, pitch, yaw)`` [rad] (R = Rz Ry Rx) and legs ``q`` (18,)."""
        return cls(position, rotation_from_rpy(rpy), q)

    @classmethod
    def from_quaternion(cls, position: Any, quat_xyzw: Any, q: Any) -> BodyState:
        """Body at ``position`` [m] with the unit quaternion ``(x, y, z, w)`` (normalised here) and legs ``q``."""
        from scipy.spatial.transform import Rotation

        qu = vector(quat_xyzw, 4, "quaternion (x, y, z, w)")
        n = float(np.linalg.norm(qu))
        if not n > 1e-12:
            raise InvalidInputError("the quaternion (x, y, z, w) is zero; a body orientation needs a unit quaternion")
        return cls(position, Rotation.from_quat(qu / n).as_matrix(), q)

    @classmethod
    def from_free_flyer_q(cls, q25: Any) -> BodyState:
        """The state of a free-flyer configuration ``[x, y, z, qx, qy, qz, qw, q_legs]`` (25,) of
        :func:`free_flyer_hexapod`.  Raises :class:`~coop_ga.errors.InvalidInputError` for another length or a
        quaternion that is not unit (to ``coop_ga.kinematics.chains.QUATERNION_TOLERANCE``, as every free flyer
        of coop_ga)."""
        from scipy.spatial.transform import Rotation

        a = vector(q25, 25, "q of the free-flyer hexapod (25,) = [position, quaternion x y z w, 18 legs]")
        free_flyer_hexapod().check_quaternions(a, "BodyState.from_free_flyer_q: q")
        return cls(a[:3], Rotation.from_quat(a[3:7]).as_matrix(), a[7:])

    # ------------------------------------------------------------------ read-outs
    def motor(self) -> Multivector:
        """M_body = T(position) R (GA unit motor, world ← body; :func:`coop_ga.kinematics.chains.motor_from_se3`)."""
        return motor_from_se3((self.rotation, self.position))

    def quaternion_xyzw(self) -> np.ndarray:
        """The body orientation as a unit quaternion (4,) ``(x, y, z, w)``, w ≥ 0."""
        from scipy.spatial.transform import Rotation

        quat = Rotation.from_matrix(self.rotation).as_quat()
        return np.asarray(-quat if quat[3] < 0 else quat, dtype=float)

    def pose7(self) -> np.ndarray:
        """``[x, y, z, qx, qy, qz, qw]`` (7,): position [m] and quaternion xyzw (the ``body`` row of trajectory.npz)."""
        return np.concatenate([self.position, self.quaternion_xyzw()])

    def rpy(self) -> np.ndarray:
        """``(roll, pitch, yaw)`` [rad] (3,) of the body rotation (ZYX: R = Rz(yaw) Ry(pitch) Rx(roll))."""
        return rpy_from_rotation(self.rotation)

    def free_flyer_q(self) -> np.ndarray:
        """``[x, y, z, qx, qy, qz, qw, q_legs]`` (25,): the configuration of :func:`free_flyer_hexapod`
        (position [m] in W, the unit quaternion of R_WB with w ≥ 0, the 18 leg joints [rad])."""
        return np.concatenate([self.position, self.quaternion_xyzw(), self.q])

    def feet_body(self, legs: LegModel) -> np.ndarray:
        """Feet (6, 3) [m] in B, LEG ORDER: ``legs.fk(q)``."""
        from .legs import check_legs

        return np.asarray(check_legs(legs).fk(self.q), dtype=float).reshape(6, 3)

    def feet_world(self, legs: LegModel) -> np.ndarray:
        """Feet (6, 3) [m] in W, LEG ORDER: ``M_body · p_foot(q) = position + R p_foot(q)``."""
        return self.to_world(self.feet_body(legs))

    def to_world(self, points_B: Any) -> np.ndarray:
        """Points (..., 3) in B → W [m]: ``position + R p``."""
        return _points3(points_B, "points_B") @ self.rotation.T + self.position

    def to_body(self, points_W: Any) -> np.ndarray:
        """Points (..., 3) in W → B [m]: ``Rᵀ (p − position)``."""
        return (_points3(points_W, "points_W") - self.position) @ self.rotation

    # ------------------------------------------------------------------ motion
    def moved(self, v: Any, omega: Any, dt: float, q: Any | None = None) -> BodyState:
        """The body after the twist ``(v, ω)`` in B [m/s, rad/s] for ``dt`` [s]: ``M · T(v Δt) R(ω Δt)``
        (position + R v Δt, rotation R · exp([ω Δt]×)), legs ``q`` (default: unchanged)."""
        from scipy.spatial.transform import Rotation

        vv = vector(v, 3, "v")
        w = vector(omega, 3, "omega")
        h = scalar(dt, "dt [s]")
        if not np.all(np.isfinite(vv * h)) or not np.all(np.isfinite(w * h)):
            raise InvalidInputError(f"dt = {h:g} s times the twist overflows; take a shorter step")
        R_new = self.rotation @ Rotation.from_rotvec(w * h).as_matrix()
        return BodyState(self.position + self.rotation @ vv * h, R_new, self.q if q is None else q)

    def copy(self) -> BodyState:
        return BodyState(self.position, self.rotation, self.q)
