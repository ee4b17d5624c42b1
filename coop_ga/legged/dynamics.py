"""Optional physics check of a walking plan: rigid-contact forward dynamics under joint PD (issue 13 item 8).

The kinematic planners (:mod:`coop_ga.legged.walk`, :mod:`coop_ga.legged.posture`) produce a plan:
times ``t`` (T,) [s], leg joints ``q`` (T, 18) [rad] (URDF order), body pose ``body`` (T, 7)
(position [m] and quaternion (x, y, z, w) in the world W) and ``stance`` (T, 6) bool in the order
:data:`~coop_ga.legged.legs.LEGS` (lf, lm, lr, rf, rm, rr) — the arrays of ``trajectory.npz``.
:func:`contact_rollout` asks whether that plan is *dynamically* consistent: it simulates the whole
robot (the registered system ``hexapod_floating``: six unactuated virtual body joints
``body_px, body_py, body_pz, body_rz, body_ry, body_rx`` and the 18 leg joints, masses and
inertias from the URDF) with Pinocchio's constraint dynamics (``pinocchio.constraintDynamics``)
and reports how far the body drifts from the plan.

Model
-----
* **Actuation**: the 18 leg joints only, by a joint-space PD tracking the plan,
  ``τ = K_p (q* − q) + K_d (q̇* − q̇) + τ_ff``, saturated at the servo stall torque (URDF ``effort``,
  1.5 N·m).  ``q*`` is the plan interpolated linearly in time, ``q̇*`` its finite-difference rate.
  ``τ_ff`` (optional, on by default) is the static torque of the planned configuration with the
  robot's weight shared equally by the stance feet (vertical forces): ``τ_ff = g(q*) − Σ_i J_iᵀ f_i``
  (leg rows), the same load model as :func:`coop_ga.legged.walk.static_torques`.  The body joints
  get no torque.
* **Contact**: a stance foot is a rigid 3-D point contact (``CONTACT_3D``, infinite friction, no
  unilateral condition), anchored at the point where the simulated foot is when the plan puts the
  leg into stance (it lands where it actually is; the height error of that point against the plan's
  foot is reported).  A touch-down is an inelastic impact (``pinocchio.impulseDynamics``,
  restitution 0): the velocity jumps so that the new contacts are at rest.  A lift-off removes the
  contact.  Constraint drift is held by a Baumgarte corrector.
* **Integration**: semi-implicit Euler at ``dt`` (all 24 coordinates are 1-DOF joints, so the
  configuration update is ``q ← q + v dt``); the plan's body pose converted to the virtual joints
  as ZYX Euler angles (yaw unwrapped over time).

Read-outs (:class:`RolloutResult`): body position and rotation drift against the plan at every plan
sample [m, rad], joint tracking error, the contact forces in W (the *required* friction coefficient
``max |f_t| / f_n`` and the smallest normal force: a negative one means the rigid contact pulls the
ground, where a real foot would slip or lift off), torque saturation, touch-down height errors.

Where this disagrees with the kinematic picture, trust the numbers: the plan assumes rigid joints
and feet that land exactly on their targets; the roll-out shows the PD compliance (the body sags
under its weight by ~τ/K_p) and how the errors accumulate over a cycle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import validation
from ..errors import InvalidInputError, UnknownNameError
from .legs import LEGS, LegModel

__all__ = ["FLOATING_SYSTEM", "RolloutOptions", "RolloutResult", "contact_rollout", "plan_to_floating_q"]

#: :func:`contact_rollout` refuses a plan that needs more integration steps (bounded work: ~0.1 ms each)
MAX_STEPS = 5_000_000
#: The registered system the roll-out simulates (6 virtual body joints + 18 leg joints).
FLOATING_SYSTEM = "hexapod_floating"
G = 9.81  # gravity [m/s²] (the model's default gravity is used; this is only for documentation)


@dataclass(frozen=True)
class RolloutOptions:
    """Settings of :func:`contact_rollout`.

    kp: joint PD stiffness [N·m/rad].  kd: joint PD damping [N·m·s/rad].
    dt: integration step [s] (the plan's intervals are split into equal sub-steps ≤ dt).
    feedforward: add the static equal-load torque τ_ff of the planned configuration (module docstring).
    saturate: clip the torque at the URDF effort limit (the servo stall torque).
    baumgarte: (K_p, K_d) of the contact drift corrector [1/s², 1/s].
    """

    kp: float = 20.0
    kd: float = 0.3
    dt: float = 2e-4
    feedforward: bool = True
    saturate: bool = True
    baumgarte: tuple[float, float] = (400.0, 40.0)

    def __post_init__(self) -> None:
        validation.nonnegative(self.kp, "RolloutOptions.kp")
        validation.nonnegative(self.kd, "RolloutOptions.kd")
        validation.positive(self.dt, "RolloutOptions.dt")
        for name in ("feedforward", "saturate"):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise InvalidInputError(f"RolloutOptions.{name} must be True or False, got {getattr(self, name)!r}")
        b = validation.array(self.baumgarte, "RolloutOptions.baumgarte")
        if b.shape != (2,) or np.any(b < 0.0):
            raise InvalidInputError(
                f"RolloutOptions.baumgarte must be (K_p, K_d) ≥ 0 [1/s², 1/s], got {self.baumgarte!r}"
            )


@dataclass(frozen=True)
class RolloutResult:
    """Result of :func:`contact_rollout`; arrays at the plan's samples (T = number of samples).

    t: (T,) [s].  q: (T, 18) simulated leg joints [rad].  body: (T, 7) simulated body pose (position [m],
    quaternion xyzw) in W.  body_plan: (T, 7) the plan's.
    position_drift: (T,) ‖p_sim − p_plan‖ [m].  rotation_drift: (T,) angle of R_planᵀ R_sim [rad].
    joint_error: (T,) max_j |q_j − q*_j| [rad].
    tau: (T, 18) applied leg torques [N·m] (after saturation).  saturation: fraction of (step, joint)
    pairs at the stall torque.
    contact_force: (T, 6, 3) force of the ground on each foot in W [N] (0 in swing), from the last
    integration step before the sample.
    min_normal_force: smallest vertical (world z) contact force over all stance samples [N]
    (< 0: the rigid contact pulls).  max_friction_ratio: max |f_xy| / f_z over stance samples with
    f_z > 0 (the friction coefficient the plan needs on flat ground).
    touchdown_height_error: (n,) z of each touch-down anchor minus the plan's foot z [m] (the first
    entries: the initial contacts).
    feet: (T, 6, 3) simulated feet in W [m].  max_swing_foot_error: max ‖foot − planned foot‖ over the
    swing samples [m] (the swing feet have no ground collision: check it against the clearance).
    n_steps: integration steps taken.  message: one-line summary.
    """

    t: np.ndarray
    q: np.ndarray
    body: np.ndarray
    body_plan: np.ndarray
    position_drift: np.ndarray
    rotation_drift: np.ndarray
    joint_error: np.ndarray
    tau: np.ndarray
    saturation: float
    contact_force: np.ndarray
    min_normal_force: float
    max_friction_ratio: float
    touchdown_height_error: np.ndarray
    feet: np.ndarray
    max_swing_foot_error: float
    n_steps: int
    message: str

    @property
    def final_position_drift(self) -> float:
        """Body position drift at the end of the plan [m]."""
        return float(self.position_drift[-1])

    @property
    def max_position_drift(self) -> float:
        """Largest body position drift over the plan [m]."""
        return float(self.position_drift.max())


def _quat_to_matrix(qxyzw: np.ndarray) -> np.ndarray:
    """Unit quaternions (..., 4) xyzw → rotation matrices (..., 3, 3)."""
    x, y, z, w = np.moveaxis(qxyzw, -1, 0)
    return np.stack(
        (
            np.stack((1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)), -1),
            np.stack((2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)), -1),
            np.stack((2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)), -1),
        ),
        -2,
    )


def _matrix_to_quat(R: np.ndarray) -> np.ndarray:
    """Rotation matrix (3, 3) → unit quaternion (4,) xyzw with w ≥ 0."""
    from scipy.spatial.transform import Rotation

    q = Rotation.from_matrix(R).as_quat()
    return np.asarray(-q if q[3] < 0 else q, dtype=float)


def _rz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _ry(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _rx(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _check_plan(
    t: Any, q: Any, body: Any, stance: Any, dt: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The checked plan arrays; a plan that needs more than :data:`MAX_STEPS` integration steps of ``dt`` [s] is
    refused (bounded work)."""
    tt = validation.array(t, "t")
    if tt.ndim != 1 or tt.size < 2:
        raise InvalidInputError(f"t must have shape (T,) with T ≥ 2 samples [s], got shape {tt.shape}")
    if np.any(np.diff(tt) <= 0.0):
        raise InvalidInputError("t must be strictly increasing")
    with np.errstate(over="ignore"):
        n_steps = float(np.sum(np.maximum(1.0, np.ceil(np.diff(tt) / dt - 1e-9))))
    if not n_steps <= MAX_STEPS:
        raise InvalidInputError(
            f"the plan spans t = {tt[0]:.4g} … {tt[-1]:.4g} s: {n_steps:.3g} integration steps of options.dt = {dt:g} s, "
            f"above {MAX_STEPS}; simulate a shorter plan or take a longer dt"
        )
    T = tt.size
    qq = validation.array(q, "q", shape=(T, 18))
    bb = validation.array(body, "body", shape=(T, 7))
    nrm = np.linalg.norm(bb[:, 3:], axis=1)
    if np.any(np.abs(nrm - 1.0) > 1e-6):
        k = int(np.argmax(np.abs(nrm - 1.0)))
        raise InvalidInputError(f"body[:, 3:] must be unit quaternions (x, y, z, w); sample {k} has norm {nrm[k]:.6g}")
    st = np.asarray(stance)
    if st.dtype != np.bool_ or st.shape != (T, 6):
        raise InvalidInputError(
            f"stance must be a bool array of shape ({T}, 6) (order {', '.join(LEGS)}), got {st.dtype} {st.shape}"
        )
    return tt, qq, bb, st.copy()


def plan_to_floating_q(q: Any, body: Any) -> np.ndarray:
    """Plan arrays → configurations (T, 24) of ``hexapod_floating``: ``[x, y, z, yaw, pitch, roll, q_legs]``.

    ``q`` (T, 18) [rad], ``body`` (T, 7) position [m] + unit quaternion xyzw in W.  The rotation
    R_WB = Rz(yaw) Ry(pitch) Rx(roll) (ZYX Euler angles); the yaw is unwrapped over the samples so that
    the virtual joint moves continuously.
    """
    qq = validation.array(q, "q")
    bb = validation.array(body, "body")
    if qq.ndim != 2 or qq.shape[1] != 18 or bb.shape != (qq.shape[0], 7):
        raise InvalidInputError(f"need q (T, 18) and body (T, 7), got {qq.shape} and {bb.shape}")
    nrm = np.linalg.norm(bb[:, 3:], axis=1, keepdims=True)
    if not np.all(nrm > 1e-12):
        k = int(np.argmin(nrm[:, 0]))
        raise InvalidInputError(f"body[:, 3:] must be quaternions (x, y, z, w); sample {k} is zero")
    R = _quat_to_matrix(bb[:, 3:] / nrm)
    pitch = np.arcsin(np.clip(-R[:, 2, 0], -1.0, 1.0))
    yaw = np.unwrap(np.arctan2(R[:, 1, 0], R[:, 0, 0]))
    roll = np.arctan2(R[:, 2, 1], R[:, 2, 2])
    return np.concatenate([bb[:, :3], yaw[:, None], pitch[:, None], roll[:, None], qq], axis=1)


def contact_rollout(
    t: Any,
    q: Any,
    body: Any,
    stance: Any,
    options: RolloutOptions | None = None,
    system: Any = None,
) -> RolloutResult:
    """Simulate a plan with rigid contacts and joint PD (module docstring) and measure the body drift.

    Parameters
    ----------
    t: (T,) sample times [s], strictly increasing.
    q: (T, 18) planned leg joints [rad] (URDF order).
    body: (T, 7) planned body pose in W: position [m], quaternion (x, y, z, w).
    stance: (T, 6) bool, leg in stance during [t_k, t_{k+1}) (order lf, lm, lr, rf, rm, rr).
    options: :class:`RolloutOptions` (gains, step, feed-forward, saturation).
    system: the floating system (default ``coop_ga.systems.load("hexapod_floating")``).

    The simulation starts at the plan's first state (configuration and finite-difference velocity,
    then the impact of the initial contacts).  Raises :class:`~coop_ga.errors.UnknownNameError` if
    ``hexapod_floating`` is not registered, :class:`~coop_ga.errors.InvalidInputError` for bad plans.
    """
    import pinocchio as pin

    from ..systems import load, names

    opts = options if options is not None else RolloutOptions()
    if not isinstance(opts, RolloutOptions):
        raise InvalidInputError(f"options must be a RolloutOptions, got {type(opts).__name__}")
    kp = validation.nonnegative(opts.kp, "options.kp")
    kd = validation.nonnegative(opts.kd, "options.kd")
    dt = validation.positive(opts.dt, "options.dt")
    tt, qq, bb, st = _check_plan(t, q, body, stance, dt)
    if system is None:
        if FLOATING_SYSTEM not in names():
            raise UnknownNameError(f"the physics check needs the registered system '{FLOATING_SYSTEM}'")
        system = load(FLOATING_SYSTEM)
    legs = LegModel.from_system(system)
    model = system.model
    data = model.createData()
    nv = model.nv
    if model.nq != nv or nv != 6 + legs.nq:
        raise InvalidInputError(f"system '{system.name}' is not 6 body joints + {legs.nq} leg joints")
    iq = legs.model_q_index.ravel()  # leg joints in the model's q/v (LEGS order, coxa/femur/tibia)
    leg_idx = np.asarray(legs.q_index).ravel()  # ... and in the 18-vector
    leg_cols = np.empty(legs.nq, dtype=int)
    leg_cols[leg_idx] = iq  # 18-vector entry k ↔ model coordinate leg_cols[k]
    body_cols = np.setdiff1d(np.arange(nv), iq)
    effort = np.asarray(model.effortLimit)[leg_cols]

    Qp = np.zeros((tt.size, nv))
    Qp[:, body_cols] = plan_to_floating_q(qq, bb)[:, :6]
    Qp[:, leg_cols] = qq
    Vp = np.gradient(Qp, tt, axis=0)

    foot_ids = [model.getFrameId(f"{leg}_foot") for leg in LEGS]
    foot_joint = [int(model.frames[f].parentJoint) for f in foot_ids]
    foot_place = [model.frames[f].placement for f in foot_ids]
    mass = float(sum(inertia.mass for inertia in model.inertias))
    gz = float(np.asarray(model.gravity.linear)[2])

    def feedforward(k: int) -> np.ndarray:
        """Static equal-load leg torques (18,) at plan sample k."""
        if not opts.feedforward or not st[k].any():
            return np.zeros(legs.nq)
        qk = Qp[k]
        tau = pin.computeGeneralizedGravity(model, data, qk).copy()
        pin.computeJointJacobians(model, data, qk)
        pin.updateFramePlacements(model, data)
        f = np.array([0.0, 0.0, -gz * mass / int(st[k].sum())])
        for i in np.flatnonzero(st[k]):
            J = pin.getFrameJacobian(model, data, foot_ids[i], pin.LOCAL_WORLD_ALIGNED)[:3]
            tau -= J.T @ f
        return tau[leg_cols]

    tau_ff = np.array([feedforward(k) for k in range(tt.size)])

    def foot_world(qk: np.ndarray) -> np.ndarray:
        pin.framesForwardKinematics(model, data, qk)
        return np.array([data.oMf[f].translation for f in foot_ids])

    plan_feet = np.array([foot_world(Qp[k]) for k in range(tt.size)])
    bp = pin.BaumgarteCorrectorParameters(float(opts.baumgarte[0]), float(opts.baumgarte[1]))
    prox = pin.ProximalSettings(1e-12, 1e-12, 0.0, 1)

    anchors: dict[int, np.ndarray] = {}
    td_err: list[float] = []

    def contacts(active: np.ndarray, qk: np.ndarray, k: int) -> tuple[Any, Any, list[int]]:
        on = [int(i) for i in np.flatnonzero(active)]
        world = foot_world(qk)
        for i in list(anchors):
            if i not in on:
                del anchors[i]
        for i in on:
            if i not in anchors:
                anchors[i] = world[i].copy()
                td_err.append(float(world[i, 2] - plan_feet[k, i, 2]))
        cms, cds = pin.StdVec_RigidConstraintModel(), pin.StdVec_RigidConstraintData()
        for i in on:
            cm = pin.RigidConstraintModel(
                pin.ContactType.CONTACT_3D,
                model,
                foot_joint[i],
                foot_place[i],
                0,
                pin.SE3(np.eye(3), anchors[i]),
                pin.LOCAL_WORLD_ALIGNED,
            )
            cm.setBaumgarteCorrectorParameters(bp)
            cms.append(cm)
        for cm in cms:
            cds.append(cm.createData())
        pin.initConstraintDynamics(model, data, cms, cds)
        return cms, cds, on

    qs, vs = Qp[0].copy(), Vp[0].copy()
    cms, cds, on = contacts(st[0], qs, 0)
    if on:
        vs = np.array(pin.impulseDynamics(model, data, qs, vs, cms, cds, 0.0, prox), dtype=float).copy()

    T = tt.size
    q_out = np.zeros((T, nv))
    on_out = np.zeros((T, 6), dtype=bool)  # contacts active when the sample was recorded
    feet_out = np.zeros((T, 6, 3))
    tau_out = np.zeros((T, legs.nq))
    f_out = np.zeros((T, 6, 3))
    n_sat = n_tot = n_steps = 0

    def torque(qk: np.ndarray, vk: np.ndarray, qref: np.ndarray, vref: np.ndarray, ff: np.ndarray) -> np.ndarray:
        tau = kp * (qref[leg_cols] - qk[leg_cols]) + kd * (vref[leg_cols] - vk[leg_cols]) + ff
        return np.clip(tau, -effort, effort) if opts.saturate else tau

    def step_forces(tau_full: np.ndarray) -> np.ndarray:
        a = pin.constraintDynamics(model, data, qs, vs, tau_full, cms, cds, prox)
        return np.array(a, dtype=float)

    def record(k: int, tau: np.ndarray) -> None:
        q_out[k] = qs
        tau_out[k] = tau
        on_out[k, on] = True
        feet_out[k] = foot_world(qs)
        lam = np.asarray(data.lambda_c, dtype=float).reshape(-1, 3)
        for j, i in enumerate(on):
            f_out[k, i] = lam[j]

    tau_full = np.zeros(nv)
    tau = torque(qs, vs, Qp[0], Vp[0], tau_ff[0])
    tau_full[leg_cols] = tau
    step_forces(tau_full)
    record(0, tau)
    for k in range(T - 1):
        if k > 0 and np.any(st[k] != st[k - 1]):
            new = bool(np.any(st[k] & ~st[k - 1]))
            cms, cds, on = contacts(st[k], qs, k)
            if new and on:
                vs = np.array(pin.impulseDynamics(model, data, qs, vs, cms, cds, 0.0, prox), dtype=float).copy()
        h_int = tt[k + 1] - tt[k]
        n_sub = max(1, math.ceil(h_int / dt - 1e-9))
        h = h_int / n_sub
        for s in range(n_sub):
            a0 = s / n_sub
            qref = (1 - a0) * Qp[k] + a0 * Qp[k + 1]
            vref = (1 - a0) * Vp[k] + a0 * Vp[k + 1]
            ff = (1 - a0) * tau_ff[k] + a0 * tau_ff[k + 1]
            tau = torque(qs, vs, qref, vref, ff)
            n_sat += int(np.sum(np.abs(tau) >= effort * (1 - 1e-12)))
            n_tot += tau.size
            tau_full[:] = 0.0
            tau_full[leg_cols] = tau
            acc = step_forces(tau_full)
            vs = vs + h * acc
            qs = qs + h * vs
            n_steps += 1
        record(k + 1, tau)

    # ---- read-outs
    body_sim = np.zeros((T, 7))
    drift_p = np.zeros(T)
    drift_r = np.zeros(T)
    for k in range(T):
        x, y, z, yaw, pitch, roll = q_out[k, body_cols]
        R = _rz(yaw) @ _ry(pitch) @ _rx(roll)
        body_sim[k] = np.concatenate([[x, y, z], _matrix_to_quat(R)])
        Rp = _quat_to_matrix(bb[k, 3:] / np.linalg.norm(bb[k, 3:]))
        drift_p[k] = float(np.linalg.norm(body_sim[k, :3] - bb[k, :3]))
        c = (np.trace(Rp.T @ R) - 1.0) / 2.0
        drift_r[k] = float(np.arccos(np.clip(c, -1.0, 1.0)))
    q_sim = q_out[:, leg_cols]
    jerr = np.abs(q_sim - qq).max(axis=1)
    stance_f = f_out[on_out]
    swing = ~on_out
    foot_err = float(np.linalg.norm(feet_out - plan_feet, axis=-1)[swing].max()) if swing.any() else 0.0
    fz = stance_f[:, 2] if stance_f.size else np.zeros(0)
    min_fn = float(fz.min()) if fz.size else float("nan")
    pos = fz > 1e-9
    ratio = float((np.linalg.norm(stance_f[pos, :2], axis=1) / fz[pos]).max()) if pos.any() else float("nan")
    sat = n_sat / max(n_tot, 1)
    msg = (
        f"rigid-contact roll-out of {tt[-1] - tt[0]:.3g} s ({n_steps} steps of ≤ {dt:g} s, K_p = {kp:g} N·m/rad): "
        f"body drift {1e3 * drift_p[-1]:.2f} mm at the end (max {1e3 * drift_p.max():.2f} mm, "
        f"{math.degrees(drift_r.max()):.2f}°), joint error ≤ {jerr.max():.4f} rad, "
        f"swing feet within {1e3 * foot_err:.2f} mm of the plan, min normal force {min_fn:.3g} N, "
        f"friction needed {ratio:.3g}, {100 * sat:.1f} % torque-saturated"
    )
    return RolloutResult(
        t=tt.copy(),
        q=q_sim,
        body=body_sim,
        body_plan=bb.copy(),
        position_drift=drift_p,
        rotation_drift=drift_r,
        joint_error=jerr,
        tau=tau_out,
        saturation=float(sat),
        contact_force=f_out,
        min_normal_force=min_fn,
        max_friction_ratio=ratio,
        touchdown_height_error=np.array(td_err),
        feet=feet_out,
        max_swing_foot_error=foot_err,
        n_steps=n_steps,
        message=msg,
    )
