"""A kinematic hexapod plan (posture or walk) in MuJoCo: joint PD with a static feed-forward.

The planners of :mod:`coop_ga.legged` give a plan: times ``t`` (T,) [s], leg joints ``q`` (T, 18) [rad]
(the URDF order = the fixed-base ``hexapod`` system's), the body pose ``body`` (T, 7) (position [m],
quaternion x, y, z, w in W) and the stance legs ``stance`` (T, 6) bool (lf, lm, lr, rf, rm, rr).
:class:`PlanTracker` is a :data:`coop_ga.sim.Controller` for the scene
``build_scene(hexapod, floating_base=True, capsules=leg_capsules(legs))`` that tracks the plan's
joints (the body is not actuated: it follows from the feet on the ground)::

    τ = τ_ff(t) + d q̇*(t) + K_p (q*(t) − q) + K_d (q̇*(t) − q̇)

with q* the plan interpolated linearly in time, q̇* its finite-difference rate, d the joints' viscous
damping of the scene (``build_scene(..., damping=d)``, which MuJoCo integrates implicitly: fed forward
here, so that together with it the controller is a PD with the damping d + K_d on the velocity error,
not a lag), and τ_ff
(:func:`static_feedforward`) the torques that hold the planned configuration statically: the legs'
own weight (Pinocchio's generalized gravity of the fixed-base model with gravity turned into the body
frame) minus the ground forces on the stance feet mapped through the foot Jacobians.  The ground forces
are the least-norm set that carries the whole robot's weight with no moment about its centre of mass,
acting where the foot balls touch the ground (one radius below their centres; the moment about the ball
centre goes through the foot frame's 6-D Jacobian).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import validation
from ..errors import InvalidInputError

__all__ = ["PlanTracker", "static_feedforward"]


def _plan(t: Any, q: Any, body: Any, stance: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    tt = validation.array(t, "t")
    Q = validation.array(q, "q")
    B = validation.array(body, "body")
    S = np.asarray(stance, dtype=bool)
    T = tt.shape[0] if tt.ndim == 1 else -1
    if T < 2 or Q.shape != (T, 18) or B.shape != (T, 7) or S.shape != (T, 6) or np.any(np.diff(tt) <= 0):
        raise InvalidInputError(
            f"a plan is t (T ≥ 2,) increasing, q (T, 18), body (T, 7), stance (T, 6) bool; got t {tt.shape}, "
            f"q {Q.shape}, body {B.shape}, stance {S.shape}"
        )
    return tt, Q, B, S


def static_feedforward(legs: Any, q: Any, body: Any, stance: Any, normals: Any = None) -> np.ndarray:
    """(T, 18) [N m]: the joint torques that hold each planned configuration statically (module docstring).

    Args:
        legs: the :class:`~coop_ga.legged.legs.LegModel` (its ``system`` is the fixed-base hexapod).
        q: (T, 18) leg joints [rad]; body: (T, 7) body poses (position, quaternion xyzw) in W; stance: (T, 6) bool.
        normals: (T, 6, 3) ground normals under the feet in W (default +z): where the balls touch.

    Returns:
        τ_ff (T, 18) in the order of ``q``.  Swing legs carry only their own weight.
    """
    import pinocchio as pin
    from scipy.spatial.transform import Rotation

    from ..legged.legs import check_legs
    from ..legged.walk import robot_com, robot_mass

    lm = check_legs(legs)
    T = np.asarray(q).shape[0]
    _, Q, B, S = _plan(np.arange(T, dtype=float), q, body, stance)
    n_W = np.broadcast_to([0.0, 0.0, 1.0], (T, 6, 3)) if normals is None else validation.array(normals, "normals")
    model = lm.system.model.copy()
    data = model.createData()
    fids = [model.getFrameId(f"{leg}_foot") for leg in lm.legs]
    mg = robot_mass(lm) * 9.81
    out = np.zeros((T, 18))
    for k in range(T):
        R = Rotation.from_quat(B[k, 3:]).as_matrix()
        model.gravity.linear = R.T @ np.array([0.0, 0.0, -9.81])
        qk = np.asarray(lm.system.q0, float).copy()
        qk[np.asarray(lm.model_q_index).ravel()] = Q[k][np.asarray(lm.q_index).ravel()]
        tau = np.array(pin.computeGeneralizedGravity(model, data, qk))
        pin.computeJointJacobians(model, data, qk)
        pin.updateFramePlacements(model, data)
        feet_B = lm.fk(Q[k])
        n_B = n_W[k] @ R
        contact_B = feet_B - lm.foot_radius * n_B
        idx = np.flatnonzero(S[k])
        f_B = _equilibrium(contact_B[idx], robot_com(Q[k], lm), R.T @ np.array([0.0, 0.0, mg]))
        for j, i in enumerate(idx):
            J = pin.getFrameJacobian(model, data, fids[i], pin.LOCAL_WORLD_ALIGNED)  # (6, nv), B-aligned
            m = np.cross(contact_B[i] - feet_B[i], f_B[j])
            tau -= J.T @ np.concatenate([f_B[j], m])
        out[k, np.asarray(lm.q_index).ravel()] = tau[np.asarray(lm.model_q_index).ravel()]
    return out


def _equilibrium(points: np.ndarray, com: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """Least-norm ground forces (k, 3) at ``points`` (k, 3) with Σ f = ``weight`` (3,) and no moment about ``com``."""
    k = len(points)
    if k == 0:
        return np.zeros((0, 3))
    A = np.zeros((6, 3 * k))
    for j, p in enumerate(points):
        A[:3, 3 * j : 3 * j + 3] = np.eye(3)
        d = p - com
        A[3:, 3 * j : 3 * j + 3] = np.array([[0.0, -d[2], d[1]], [d[2], 0.0, -d[0]], [-d[1], d[0], 0.0]])
    b = np.concatenate([weight, np.zeros(3)])
    return np.asarray(np.linalg.lstsq(A, b, rcond=None)[0]).reshape(k, 3)


@dataclass
class PlanTracker:
    """Joint PD + static feed-forward tracking a kinematic plan (module docstring); a ``coop_ga.sim`` controller.

    Args:
        legs: the :class:`~coop_ga.legged.legs.LegModel`.
        t, q, body, stance: the plan (module docstring).
        kp, kd: joint gains [N m/rad, N m s/rad] (scalars or (18,)).
        t0: simulated time [s] at which the plan starts (before it: hold its first sample).
        damping: the scene's joint damping [N m s/rad] (scalar or (18,)), fed forward as ``damping · q̇*``.
        normals: (T, 6, 3) ground normals under the feet (W; default +z) for the feed-forward.

    Call it as ``tracker(t, q, q̇, sensors) -> τ`` (18,).
    """

    legs: Any
    t: Any
    q: Any
    body: Any
    stance: Any
    kp: Any = 20.0
    kd: Any = 0.3
    t0: float = 0.0
    damping: Any = 0.0
    normals: Any = None
    tau_ff: np.ndarray = field(init=False, repr=False)
    qd_ref: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.t, self.q, self.body, self.stance = _plan(self.t, self.q, self.body, self.stance)
        self.kp = np.broadcast_to(validation.array(self.kp, "kp"), (18,)).astype(float)
        self.kd = np.broadcast_to(validation.array(self.kd, "kd"), (18,)).astype(float)
        self.damping = np.broadcast_to(validation.array(self.damping, "damping"), (18,)).astype(float)
        if np.any(self.kp < 0) or np.any(self.kd < 0) or np.any(self.damping < 0):
            raise InvalidInputError("kp, kd and damping must be ≥ 0")
        self.t0 = validation.scalar(self.t0, "t0")
        self.tau_ff = static_feedforward(self.legs, self.q, self.body, self.stance, self.normals)
        self.qd_ref = np.gradient(self.q, self.t, axis=0)

    def reference(self, time: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(q*, q̇*, τ_ff) at simulated ``time`` [s] (linear interpolation; held outside the plan)."""
        s = float(np.clip(time - self.t0, self.t[0], self.t[-1]))
        k = int(np.clip(np.searchsorted(self.t, s, side="right") - 1, 0, len(self.t) - 2))
        a = (s - self.t[k]) / (self.t[k + 1] - self.t[k])
        q = (1 - a) * self.q[k] + a * self.q[k + 1]
        tau = (1 - a) * self.tau_ff[k] + a * self.tau_ff[k + 1]
        inside = self.t[0] < time - self.t0 < self.t[-1]
        qd = (1 - a) * self.qd_ref[k] + a * self.qd_ref[k + 1] if inside else np.zeros(18)
        return q, qd, tau

    def __call__(self, time: float, q: np.ndarray, qd: np.ndarray, sensors: Any = None) -> np.ndarray:
        q_ref, qd_ref, tau = self.reference(time)
        return tau + self.damping * qd_ref + self.kp * (q_ref - q) + self.kd * (qd_ref - qd)
