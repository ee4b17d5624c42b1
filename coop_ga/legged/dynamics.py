"""Optional physics check of a walking plan: rigid-contact forward dynamics under joint PD.

The kinematic planners (:mod:`coop_ga.legged.walk`, :mod:`coop_ga.legged.posture`) produce a plan:
times ``t`` (T,) [s], leg joints ``q`` (T, 18) [rad] (URDF order), body pose ``body`` (T, 7)
(position [m] and quaternion (x, y, z, w) in the world W) and ``stance`` (T, 6) bool in the order
:data:`~coop_ga.legged.legs.LEGS` (lf, lm, lr, rf, rm, rr) — the arrays of ``trajectory.npz``.
:func:`contact_rollout` asks whether that plan is *dynamically* consistent: it simulates the whole
robot (the floating hexapod ``coop_ga.systems.load("hexapod", free_flyer=True)``: the body on an
unactuated Pinocchio free flyer, q = [position, quaternion x y z w, 18 legs] (25,), q̇ = [v, ω in
the body frame, 18 leg rates] (24,), masses and inertias from the URDF) with Pinocchio's constraint
dynamics (``pinocchio.constraintDynamics``) and reports how far the body drifts from the plan.

Model
-----
* **Actuation**: the 18 leg joints only, by a joint-space PD tracking the plan,
  ``τ = K_p (q* − q) + K_d (q̇* − q̇) + τ_ff``, saturated at the servo stall torque (URDF ``effort``,
  1.5 N·m).  ``q*`` is the plan interpolated linearly in time, ``q̇*`` its finite-difference rate.
  ``τ_ff`` (optional, on by default) is the static torque of the planned configuration with the
  robot's weight shared equally by the stance feet (vertical forces): ``τ_ff = g(q*) − Σ_i J_iᵀ f_i``
  (leg rows), the same load model as :func:`coop_ga.legged.walk.static_torques`.  The free flyer
  gets no torque.
* **Contact**: a stance foot is a rigid 3-D point contact (``CONTACT_3D``, infinite friction, no
  unilateral condition), anchored at the point where the simulated foot is when the plan puts the
  leg into stance (it lands where it actually is; the height error of that point against the plan's
  foot is reported).  A touch-down is an inelastic impact (``pinocchio.impulseDynamics``,
  restitution 0): the velocity jumps so that the new contacts are at rest.  A lift-off removes the
  contact.  Constraint drift is held by a Baumgarte corrector.
* **Integration**: semi-implicit Euler at ``dt``: ``v ← v + a dt``, then ``q ← pinocchio.integrate(q,
  v dt)`` (on the free flyer the body moves by the SE(3) exponential of its twist, the quaternion stays
  unit; the leg joints by ``q + q̇ dt``).  The plan's body pose enters as it is (position and
  quaternion, :func:`plan_to_free_flyer_q`); its velocity at the first sample (the initial state) is
  the finite-difference body twist of the plan (``np.gradient``'s weights on the SE(3) log of the
  neighbouring poses).

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
from ..errors import InvalidInputError
from .legs import LEGS, LegModel

__all__ = ["RolloutOptions", "RolloutResult", "contact_rollout", "plan_to_free_flyer_q"]

#: :func:`contact_rollout` refuses a plan that needs more integration steps (bounded work: ~0.1 ms each)
MAX_STEPS = 5_000_000
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


def plan_to_free_flyer_q(q: Any, body: Any) -> np.ndarray:
    """Plan arrays → configurations (T, 25) of the floating hexapod (``systems.load("hexapod", free_flyer=True)``):
    ``[x, y, z, qx, qy, qz, qw, q_legs]``.

    ``q`` (T, 18) [rad] (URDF order), ``body`` (T, 7) position [m] + quaternion xyzw in W (normalised here; a
    zero quaternion raises :class:`~coop_ga.errors.InvalidInputError`).  The body pose is taken as it is: no
    Euler angles, nothing to unwrap.
    """
    qq = validation.array(q, "q")
    bb = validation.array(body, "body")
    if qq.ndim != 2 or qq.shape[1] != 18 or bb.shape != (qq.shape[0], 7):
        raise InvalidInputError(f"need q (T, 18) and body (T, 7), got {qq.shape} and {bb.shape}")
    nrm = np.linalg.norm(bb[:, 3:], axis=1, keepdims=True)
    if not np.all(nrm > 1e-12):
        k = int(np.argmin(nrm[:, 0]))
        raise InvalidInputError(f"body[:, 3:] must be quaternions (x, y, z, w); sample {k} is zero")
    return np.concatenate([bb[:, :3], bb[:, 3:] / nrm, qq], axis=1)


def _body_twists(tt: np.ndarray, Qp: np.ndarray) -> np.ndarray:
    """The plan's body twists (T, 6) ``[v, ω]`` in the body frame [m/s, rad/s] (the free flyer's velocity): the
    SE(3) log of each step (what ``pinocchio.difference`` gives on a free flyer) divided by its duration, combined like ``np.gradient``
    (one-sided at the ends, the weighted mean of the two neighbouring steps inside)."""
    import pinocchio as pin

    pose = [pin.XYZQUATToSE3(row[:7]) for row in Qp]
    h = np.diff(tt)
    step = np.array([pin.log6(pose[k].actInv(pose[k + 1])).vector / h[k] for k in range(tt.size - 1)])
    out = np.empty((tt.size, 6))
    out[0], out[-1] = step[0], step[-1]
    hm, hp = h[:-1, None], h[1:, None]
    out[1:-1] = (hm * step[1:] + hp * step[:-1]) / (hm + hp)
    return out


def _check_free_flyer(system: Any) -> LegModel:
    """The legs of ``system`` if its root joint (joint 1, q[0:7], q̇[0:6]) is a free flyer carrying 18 leg joints
    and nothing else; :class:`~coop_ga.errors.InvalidInputError` otherwise."""
    legs = LegModel.from_system(system)
    m = system.model
    if m.njoints < 2 or m.joints[1].shortname() != "JointModelFreeFlyer" or (m.nq, m.nv) != (7 + legs.nq, 6 + legs.nq):
        raise InvalidInputError(
            f"system '{system.name}' is not a free-flyer body + {legs.nq} leg joints (nq = {m.nq}, nv = {m.nv}); "
            'the roll-out simulates coop_ga.systems.load("hexapod", free_flyer=True)'
        )
    return legs


class _Rollout:
    """One :func:`contact_rollout`: the floating model, the plan in its coordinates, the active contacts,
    the simulated state and the samples recorded so far (one method per stage of the module docstring)."""

    def __init__(
        self, system: Any, plan: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray], opts: RolloutOptions,
        gains: tuple[float, float],
    ) -> None:  # fmt: skip
        import pinocchio as pin

        self.pin = pin
        self.tt, self.qq, self.bb, self.st = plan
        self.opts = opts
        self.kp, self.kd = gains
        legs = _check_free_flyer(system)
        model = system.model
        self.model, self.data = model, model.createData()
        nv = model.nv
        self.n_legs_q = legs.nq
        leg_idx = np.asarray(legs.q_index).ravel()  # the leg joints (LEGS order, coxa/femur/tibia) in the 18-vector
        jid = [int(model.getJointId(name)) for names in legs.joint_names for name in names]
        # 18-vector entry k ↔ model coordinate leg_q[k] of q (25,) and leg_v[k] of q̇ (24,)
        self.leg_q, self.leg_v = np.empty(legs.nq, dtype=int), np.empty(legs.nq, dtype=int)
        self.leg_q[leg_idx] = [int(model.idx_qs[j]) for j in jid]
        self.leg_v[leg_idx] = [int(model.idx_vs[j]) for j in jid]
        self.effort = np.asarray(model.effortLimit)[self.leg_v]

        self.Qp = np.zeros((self.tt.size, model.nq))
        self.Qp[:, :7] = plan_to_free_flyer_q(self.qq, self.bb)[:, :7]
        self.Qp[:, self.leg_q] = self.qq
        self.Vp = np.zeros((self.tt.size, nv))
        self.Vp[:, :6] = _body_twists(self.tt, self.Qp)
        self.vq = np.gradient(self.qq, self.tt, axis=0)  # the legs' planned rates (T, 18)
        self.Vp[:, self.leg_v] = self.vq

        self.foot_ids = [model.getFrameId(f"{leg}_foot") for leg in LEGS]
        self.foot_joint = [int(model.frames[f].parentJoint) for f in self.foot_ids]
        self.foot_place = [model.frames[f].placement for f in self.foot_ids]
        self.mass = float(sum(inertia.mass for inertia in model.inertias))
        self.gz = float(np.asarray(model.gravity.linear)[2])
        self.tau_ff = np.array([self.feedforward(k) for k in range(self.tt.size)])
        self.plan_feet = np.array([self.foot_world(self.Qp[k]) for k in range(self.tt.size)])
        self.bp = pin.BaumgarteCorrectorParameters(float(opts.baumgarte[0]), float(opts.baumgarte[1]))
        self.prox = pin.ProximalSettings(1e-12, 1e-12, 0.0, 1)

        self.anchors: dict[int, np.ndarray] = {}
        self.td_err: list[float] = []
        T = self.tt.size
        self.q_out = np.zeros((T, model.nq))
        self.on_out = np.zeros((T, 6), dtype=bool)  # contacts active when the sample was recorded
        self.feet_out = np.zeros((T, 6, 3))
        self.tau_out = np.zeros((T, legs.nq))
        self.f_out = np.zeros((T, 6, 3))
        self.n_sat = self.n_tot = self.n_steps = 0
        self.qs, self.vs = self.Qp[0].copy(), self.Vp[0].copy()
        self.cms: Any = None
        self.cds: Any = None
        self.on: list[int] = []

    def feedforward(self, k: int) -> np.ndarray:
        """Static equal-load leg torques (18,) at plan sample k."""
        pin, model, data, st = self.pin, self.model, self.data, self.st
        if not self.opts.feedforward or not st[k].any():
            return np.zeros(self.n_legs_q)
        qk = self.Qp[k]
        tau = pin.computeGeneralizedGravity(model, data, qk).copy()
        pin.computeJointJacobians(model, data, qk)
        pin.updateFramePlacements(model, data)
        f = np.array([0.0, 0.0, -self.gz * self.mass / int(st[k].sum())])
        for i in np.flatnonzero(st[k]):
            J = pin.getFrameJacobian(model, data, self.foot_ids[i], pin.LOCAL_WORLD_ALIGNED)[:3]
            tau -= J.T @ f
        return np.asarray(tau[self.leg_v])

    def foot_world(self, qk: np.ndarray) -> np.ndarray:
        """The six feet (6, 3) in W [m] at the model configuration ``qk``."""
        self.pin.framesForwardKinematics(self.model, self.data, qk)
        return np.array([self.data.oMf[f].translation for f in self.foot_ids])

    def contacts(self, active: np.ndarray, k: int) -> None:
        """Make the legs ``active`` the rigid contacts: new ones anchored where their simulated foot is."""
        pin, model = self.pin, self.model
        on = [int(i) for i in np.flatnonzero(active)]
        world = self.foot_world(self.qs)
        for i in list(self.anchors):
            if i not in on:
                del self.anchors[i]
        for i in on:
            if i not in self.anchors:
                self.anchors[i] = world[i].copy()
                self.td_err.append(float(world[i, 2] - self.plan_feet[k, i, 2]))
        cms, cds = pin.StdVec_RigidConstraintModel(), pin.StdVec_RigidConstraintData()
        for i in on:
            cm = pin.RigidConstraintModel(
                pin.ContactType.CONTACT_3D,
                model,
                self.foot_joint[i],
                self.foot_place[i],
                0,
                pin.SE3(np.eye(3), self.anchors[i]),
                pin.LOCAL_WORLD_ALIGNED,
            )
            cm.setBaumgarteCorrectorParameters(self.bp)
            cms.append(cm)
        for cm in cms:
            cds.append(cm.createData())
        pin.initConstraintDynamics(model, self.data, cms, cds)
        self.cms, self.cds, self.on = cms, cds, on

    def impact(self) -> None:
        """The inelastic touch-down impact: the velocity jumps so that the active contacts are at rest."""
        v = self.pin.impulseDynamics(self.model, self.data, self.qs, self.vs, self.cms, self.cds, 0.0, self.prox)
        self.vs = np.array(v, dtype=float).copy()

    def torque(self, qref: np.ndarray, vref: np.ndarray, ff: np.ndarray) -> np.ndarray:
        """The joint PD torque (18,) toward the leg references ``qref``, ``vref`` (18,) plus ``ff`` (saturated if
        asked)."""
        tau = self.kp * (qref - self.qs[self.leg_q]) + self.kd * (vref - self.vs[self.leg_v]) + ff
        return np.clip(tau, -self.effort, self.effort) if self.opts.saturate else tau

    def accelerations(self, tau: np.ndarray) -> np.ndarray:
        """Constraint dynamics with the leg torques ``tau`` (the free flyer gets none)."""
        tau_full = np.zeros(self.model.nv)
        tau_full[self.leg_v] = tau
        a = self.pin.constraintDynamics(
            self.model, self.data, self.qs, self.vs, tau_full, self.cms, self.cds, self.prox
        )
        return np.array(a, dtype=float)

    def record(self, k: int, tau: np.ndarray) -> None:
        """Store sample k: configuration, torque, active contacts, feet and contact forces."""
        self.q_out[k] = self.qs
        self.tau_out[k] = tau
        self.on_out[k, self.on] = True
        self.feet_out[k] = self.foot_world(self.qs)
        lam = np.asarray(self.data.lambda_c, dtype=float).reshape(-1, 3)
        for j, i in enumerate(self.on):
            self.f_out[k, i] = lam[j]

    def interval(self, k: int, dt: float) -> None:
        """Integrate the plan interval [t_k, t_{k+1}] in equal sub-steps ≤ ``dt`` (semi-implicit Euler)."""
        qq, Vp, tau_ff = self.qq, self.vq, self.tau_ff
        h_int = self.tt[k + 1] - self.tt[k]
        n_sub = max(1, math.ceil(h_int / dt - 1e-9))
        h = h_int / n_sub
        for s in range(n_sub):
            a0 = s / n_sub
            qref = (1 - a0) * qq[k] + a0 * qq[k + 1]
            vref = (1 - a0) * Vp[k] + a0 * Vp[k + 1]
            ff = (1 - a0) * tau_ff[k] + a0 * tau_ff[k + 1]
            tau = self.torque(qref, vref, ff)
            self.n_sat += int(np.sum(np.abs(tau) >= self.effort * (1 - 1e-12)))
            self.n_tot += tau.size
            acc = self.accelerations(tau)
            self.vs = self.vs + h * acc
            self.qs = self.pin.integrate(self.model, self.qs, h * self.vs)
            self.n_steps += 1
        self.record(k + 1, tau)

    def run(self, dt: float) -> None:
        """Simulate the whole plan from its first state (after the impact of the initial contacts)."""
        st = self.st
        self.contacts(st[0], 0)
        if self.on:
            self.impact()
        tau = self.torque(self.qq[0], self.vq[0], self.tau_ff[0])
        self.accelerations(tau)
        self.record(0, tau)
        for k in range(self.tt.size - 1):
            if k > 0 and np.any(st[k] != st[k - 1]):
                new = bool(np.any(st[k] & ~st[k - 1]))
                self.contacts(st[k], k)
                if new and self.on:
                    self.impact()
            self.interval(k, dt)

    def body_drift(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Simulated body poses (T, 7) and their position [m] and rotation [rad] drift from the plan (T,)."""
        T, bb = self.tt.size, self.bb
        body_sim = np.zeros((T, 7))
        drift_p = np.zeros(T)
        drift_r = np.zeros(T)
        for k in range(T):
            quat = self.q_out[k, 3:7] / np.linalg.norm(self.q_out[k, 3:7])
            R = _quat_to_matrix(quat)
            body_sim[k] = np.concatenate([self.q_out[k, :3], -quat if quat[3] < 0 else quat])
            Rp = _quat_to_matrix(bb[k, 3:] / np.linalg.norm(bb[k, 3:]))
            drift_p[k] = float(np.linalg.norm(body_sim[k, :3] - bb[k, :3]))
            c = (np.trace(Rp.T @ R) - 1.0) / 2.0
            drift_r[k] = float(np.arccos(np.clip(c, -1.0, 1.0)))
        return body_sim, drift_p, drift_r

    def result(self, dt: float) -> RolloutResult:
        """The read-outs of the simulated run (:class:`RolloutResult`)."""
        tt = self.tt
        body_sim, drift_p, drift_r = self.body_drift()
        q_sim = self.q_out[:, self.leg_q]
        jerr = np.abs(q_sim - self.qq).max(axis=1)
        stance_f = self.f_out[self.on_out]
        swing = ~self.on_out
        foot_err = float(np.linalg.norm(self.feet_out - self.plan_feet, axis=-1)[swing].max()) if swing.any() else 0.0
        fz = stance_f[:, 2] if stance_f.size else np.zeros(0)
        min_fn = float(fz.min()) if fz.size else float("nan")
        pos = fz > 1e-9
        ratio = float((np.linalg.norm(stance_f[pos, :2], axis=1) / fz[pos]).max()) if pos.any() else float("nan")
        sat = self.n_sat / max(self.n_tot, 1)
        msg = (
            f"rigid-contact roll-out of {tt[-1] - tt[0]:.3g} s ({self.n_steps} steps of ≤ {dt:g} s, "
            f"K_p = {self.kp:g} N·m/rad): "
            f"body drift {1e3 * drift_p[-1]:.2f} mm at the end (max {1e3 * drift_p.max():.2f} mm, "
            f"{math.degrees(drift_r.max()):.2f}°), joint error ≤ {jerr.max():.4f} rad, "
            f"swing feet within {1e3 * foot_err:.2f} mm of the plan, min normal force {min_fn:.3g} N, "
            f"friction needed {ratio:.3g}, {100 * sat:.1f} % torque-saturated"
        )
        return RolloutResult(
            t=tt.copy(),
            q=q_sim,
            body=body_sim,
            body_plan=self.bb.copy(),
            position_drift=drift_p,
            rotation_drift=drift_r,
            joint_error=jerr,
            tau=self.tau_out,
            saturation=float(sat),
            contact_force=self.f_out,
            min_normal_force=min_fn,
            max_friction_ratio=ratio,
            touchdown_height_error=np.array(self.td_err),
            feet=self.feet_out,
            max_swing_foot_error=foot_err,
            n_steps=self.n_steps,
            message=msg,
        )


def contact_rollout(
    t: Any,
    q: Any,
    body: Any,
    stance: Any,
    options: RolloutOptions | None = None,
    system: Any = None,
) -> RolloutResult:
    """Simulate a plan with rigid contacts and joint PD (module docstring) and measure the body drift.

    Args:
        t: (T,) sample times [s], strictly increasing.
        q: (T, 18) planned leg joints [rad] (URDF order).
        body: (T, 7) planned body pose in W: position [m], quaternion (x, y, z, w).
        stance: (T, 6) bool, leg in stance during [t_k, t_{k+1}) (order lf, lm, lr, rf, rm, rr).
        options: :class:`RolloutOptions` (gains, step, feed-forward, saturation).
        system: the floating hexapod (default ``coop_ga.systems.load("hexapod", free_flyer=True)``; a system
            whose root joint is a free flyer and which has the hexapod's 18 leg joints and six feet).

    The simulation starts at the plan's first state (configuration and finite-difference velocity,
    then the impact of the initial contacts).  Raises :class:`~coop_ga.errors.InvalidInputError` for bad plans
    or a system that is not a free-flyer hexapod.
    """
    from ..systems import load

    opts = options if options is not None else RolloutOptions()
    if not isinstance(opts, RolloutOptions):
        raise InvalidInputError(f"options must be a RolloutOptions, got {type(opts).__name__}")
    kp = validation.nonnegative(opts.kp, "options.kp")
    kd = validation.nonnegative(opts.kd, "options.kd")
    dt = validation.positive(opts.dt, "options.dt")
    plan = _check_plan(t, q, body, stance, dt)
    if system is None:
        system = load("hexapod", free_flyer=True)
    rollout = _Rollout(system, plan, opts, (kp, kd))
    rollout.run(dt)
    return rollout.result(dt)
