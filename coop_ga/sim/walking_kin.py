"""The hot path of the walking controller: leg kinematics and the stance plane's similarity error, lean.

The walking controller (:mod:`coop_ga.sim.walking`) runs at 200 Hz inside the MuJoCo loop and must keep up
with real time on one core.  :class:`~coop_ga.legged.legs.LegModel` computes everything it needs, but its
vectorised, fully checked routines cost 0.5–2.5 ms per call (argument checks, both knee branches and both
yaws of every leg, batches); this module recomputes the same numbers for one configuration in ~20–60 µs:

* :class:`FastLegs` — foot positions, foot Jacobians (B frame) and the closed-form IK on the ``knee_up``
  branch with the forward coxa yaw (the standing branch; the coxa range ±70° excludes the other yaw), read
  from a :class:`~coop_ga.legged.legs.LegModel`'s geometry (mount placements, joint signs, link offsets) —
  the same formulas as its ``_planar``/``_kin``/``ik_candidates`` (module docstring of
  :mod:`coop_ga.legged.legs`).  ``tests/sim/test_hexapod_walking.py`` checks them against ``LegModel.fk``,
  ``jacobians`` and ``ik`` to 1e-12 at random configurations;
* :func:`plane_error` — the observable rows of ``e = log(Ṽ V_ref)`` (seed 003 Eq 44) for two *plane*
  similarities given as their log coordinates: a plane's similarity is a motor ``T(t) R`` (no dilation;
  coop_ga's ``exp`` is ``V_T V_R V_D`` with the plain translation t, docs/conventions.md), so
  ``Ṽ V_ref = T(Rᵀ(t_ref − t)) · RᵀR_ref`` and ``e = [rotation log of RᵀR_ref ; Rᵀ(t_ref − t)]`` exactly.
  Checked against :meth:`CooperativeTask.error` (the compiled GA computation) to 1e-12;
* :func:`stance_map` — the linear map ``A`` from a body twist (v, ω) in B to the stance primitive's twist
  (primitive frame) with the stance feet fixed in the world (:func:`coop_ga.legged.posture.posture_step`'s
  ``A = J^G L``), from the primitive's Jacobian with respect to its points.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["FastLegs", "plane_error", "plane_log", "rotation_from_tangent", "stance_map", "tangent_of_rotation"]


def _skew(p: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -p[2], p[1]], [p[2], 0.0, -p[0]], [-p[1], p[0], 0.0]])


class FastLegs:
    """FK, Jacobians and IK of the six legs of a :class:`~coop_ga.legged.legs.LegModel` for one configuration
    (module docstring).  Arrays over legs are (6, ·) in the LegModel's leg order; joint vectors (18,) in
    its q order (``q_index``)."""

    def __init__(self, legs: Any):
        self.legs = legs
        self.q_index = np.asarray(legs.q_index)
        self.Rm = np.asarray(legs.mount_rotation, float)
        self.pm = np.asarray(legs.mount_position, float)
        self.s = np.column_stack([legs.coxa_sign, legs.femur_sign, legs.tibia_sign]).astype(float)
        self.f0 = np.asarray(legs.femur_joint, float)
        self.l1 = np.asarray(legs.femur_link, float)
        self.l2 = np.asarray(legs.tibia_link, float)
        self.alpha = np.arctan2(self.l2[:, 1], self.l2[:, 0]) - np.arctan2(self.l1[:, 1], self.l1[:, 0])
        self.L1 = np.hypot(self.l1[:, 0], self.l1[:, 1])
        self.L2 = np.hypot(self.l2[:, 0], self.l2[:, 1])
        self.lo = np.asarray(legs.q_lower, float)
        self.hi = np.asarray(legs.q_upper, float)

    # ------------------------------------------------------------------ forward
    def _planar(self, Q: np.ndarray) -> tuple[np.ndarray, ...]:
        psi = self.s[:, 0] * Q[:, 0]
        p2 = self.s[:, 1] * Q[:, 1]
        p23 = p2 + self.s[:, 2] * Q[:, 2]
        c2, s2, c23, s23 = np.cos(p2), np.sin(p2), np.cos(p23), np.sin(p23)
        kx = self.f0[:, 0] + c2 * self.l1[:, 0] - s2 * self.l1[:, 1]
        kz = self.f0[:, 1] + s2 * self.l1[:, 0] + c2 * self.l1[:, 1]
        fx = kx + c23 * self.l2[:, 0] - s23 * self.l2[:, 1]
        fz = kz + s23 * self.l2[:, 0] + c23 * self.l2[:, 1]
        return psi, kx, kz, fx, fz

    def _body(self, psi: np.ndarray, x: np.ndarray, z: np.ndarray) -> np.ndarray:
        pc = np.column_stack([np.cos(psi) * x, np.sin(psi) * x, z])
        return np.einsum("lij,lj->li", self.Rm, pc) + self.pm

    def fk(self, q: np.ndarray) -> np.ndarray:
        """Feet (6, 3) [m] in B of the joint vector q (18,) (= ``LegModel.fk``)."""
        psi, _, _, fx, fz = self._planar(q[self.q_index])
        return self._body(psi, fx, fz)

    def fk_jac(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(feet (6, 3), Jacobians (6, 3, 3) ∂p_foot/∂(coxa, femur, tibia) in B) (= ``LegModel.jacobians``):
        in the yawed leg plane the coxa moves the foot about the coxa axis, the femur and tibia rotate it
        about their joints (x toward z), then the mount rotation takes the columns to B."""
        Q = q[self.q_index]
        psi, kx, kz, fx, fz = self._planar(Q)
        c, s = np.cos(psi), np.sin(psi)
        M = np.empty((6, 3, 3))
        M[:, 0, 0], M[:, 1, 0], M[:, 2, 0] = -s * fx * self.s[:, 0], c * fx * self.s[:, 0], 0.0
        for col, (ox, oz) in ((1, (self.f0[:, 0], self.f0[:, 1])), (2, (kx, kz))):
            dx, dz = -(fz - oz) * self.s[:, col], (fx - ox) * self.s[:, col]
            M[:, 0, col], M[:, 1, col], M[:, 2, col] = c * dx, s * dx, dz
        pc = np.column_stack([c * fx, s * fx, fz])
        p = np.matmul(self.Rm, pc[:, :, None])[:, :, 0] + self.pm
        return p, np.matmul(self.Rm, M)

    def tibia_rotations(self, q: np.ndarray) -> np.ndarray:
        """(6, 3, 3) rotation B ← tibia frame of each leg (the frame of its tibia joint: x along the tibia):
        the mount rotation, the coxa yaw about z, then the femur + tibia pitch (x toward z)."""
        Q = q[self.q_index]
        psi = self.s[:, 0] * Q[:, 0]
        phi = self.s[:, 1] * Q[:, 1] + self.s[:, 2] * Q[:, 2]
        cy, sy, cp, sp = np.cos(psi), np.sin(psi), np.cos(phi), np.sin(phi)
        R = np.empty((6, 3, 3))  # Rz(ψ) @ [pitch by φ: x → (cos φ, 0, sin φ), z → (−sin φ, 0, cos φ)]
        R[:, 0, 0], R[:, 0, 1], R[:, 0, 2] = cy * cp, -sy, -cy * sp
        R[:, 1, 0], R[:, 1, 1], R[:, 1, 2] = sy * cp, cy, -sy * sp
        R[:, 2, 0], R[:, 2, 1], R[:, 2, 2] = sp, 0.0, cp
        return np.matmul(self.Rm, R)

    # ------------------------------------------------------------------ inverse
    def ik(self, feet: np.ndarray, q_out: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Closed-form IK of foot targets (6, 3) [m] in B, knee_up, forward coxa yaw (= ``LegModel.ik``
        where that is inside the limits).  Returns (q (18,), reach margin (6,) [m]: < 0 where a target is
        out of reach — that leg is then solved for the nearest reachable point, the straight or folded
        leg).  Joint limits are not applied (:meth:`clip`)."""
        pc = np.einsum("lji,lj->li", self.Rm, feet - self.pm)
        psi = np.arctan2(pc[:, 1], pc[:, 0])
        rho = np.hypot(pc[:, 0], pc[:, 1])
        vx, vz = rho - self.f0[:, 0], pc[:, 2] - self.f0[:, 1]
        r = np.hypot(vx, vz)
        lmax, lmin = self.L1 + self.L2, np.abs(self.L1 - self.L2)
        margin = np.minimum(lmax - r, r - lmin)
        far = np.sqrt(np.maximum((lmax - r) * (lmax + r), 0.0))
        near = np.sqrt(np.maximum((r - lmin) * (r + lmin), 0.0))
        phi3 = -2.0 * np.arctan2(far, near) - self.alpha
        c3, s3 = np.cos(phi3), np.sin(phi3)
        wx = self.l1[:, 0] + c3 * self.l2[:, 0] - s3 * self.l2[:, 1]
        wz = self.l1[:, 1] + s3 * self.l2[:, 0] + c3 * self.l2[:, 1]
        phi2 = np.arctan2(vz, vx) - np.arctan2(wz, wx)
        Q = np.column_stack([self.s[:, 0] * psi, self.s[:, 1] * phi2, self.s[:, 2] * phi3])
        Q = (Q + np.pi) % (2.0 * np.pi) - np.pi
        q = np.empty(18) if q_out is None else q_out
        q[self.q_index] = Q
        return q, margin

    def clip(self, q: np.ndarray) -> np.ndarray:
        """q (18,) clipped into the joint limits (a new array)."""
        out = q.copy()
        out[self.q_index] = np.clip(q[self.q_index], self.lo, self.hi)
        return out

    def violation(self, q: np.ndarray) -> float:
        """Largest distance [rad] of a joint of q (18,) outside its limits (0 inside)."""
        Q = q[self.q_index]
        return float(np.max(np.maximum(np.maximum(self.lo - Q, Q - self.hi), 0.0)))


# ====================================================================== the plane's similarity
def rotation_from_tangent(theta: np.ndarray) -> np.ndarray:
    """R (3, 3) of the rotation tangent ``[θ12, θ13, θ23]`` (θ12 about +z, θ13 = −angle about +y, θ23 about +x;
    docs/conventions.md): the rotation vector is ``(θ23, −θ13, θ12)``."""
    w = np.array([theta[2], -theta[1], theta[0]], dtype=float)
    a = math.sqrt(float(w @ w))
    K = _skew(w)
    if a < 1e-8:
        return np.eye(3) + K + 0.5 * K @ K
    return np.eye(3) + math.sin(a) / a * K + (1.0 - math.cos(a)) / (a * a) * K @ K


def tangent_of_rotation(R: np.ndarray) -> np.ndarray:
    """``[θ12, θ13, θ23]`` (3,) of a rotation matrix (inverse of :func:`rotation_from_tangent`; angle < π)."""
    c = max(-1.0, min(1.0, 0.5 * (float(np.trace(R)) - 1.0)))
    a = math.acos(c)
    v = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    w = 0.5 * v if a < 1e-8 else a / (2.0 * math.sin(a)) * v
    return np.array([w[2], -w[1], w[0]])


def plane_log(normal: np.ndarray, offset: float) -> np.ndarray:
    """The log coordinates (7,) of the plane ``n · x = offset`` (unit normal n) in the chart of the stance
    tasks (unit plane z = 0 with normal +e3, minimal rotation): ``[tangent of the shortest rotation
    e3 → n, 0, offset · n]`` (the translation to the plane's point nearest the origin)."""
    n = np.asarray(normal, float)
    axis = np.array([-n[1], n[0], 0.0])  # e3 × n
    s = float(np.linalg.norm(axis))
    ang = math.atan2(s, float(n[2]))
    w = axis * (ang / s) if s > 1e-15 else np.zeros(3)
    return np.array([w[2], -w[1], w[0], 0.0, *(offset * n)])


def plane_error(log_v: np.ndarray, log_ref: np.ndarray, R: np.ndarray | None = None) -> np.ndarray:
    """``log(Ṽ V_ref)`` (7,) of two plane similarities given by their log coordinates (module docstring):
    ``[tangent of RᵀR_ref, 0, Rᵀ(t_ref − t)]`` (primitive frame of V); ``R``: V's rotation if already known."""
    R = rotation_from_tangent(log_v[:3]) if R is None else R
    Rr = rotation_from_tangent(log_ref[:3])
    return np.array([*tangent_of_rotation(R.T @ Rr), 0.0, *(R.T @ (log_ref[4:7] - log_v[4:7]))])


def stance_map(G: np.ndarray, feet: np.ndarray) -> np.ndarray:
    """``A`` (7, 6): the stance primitive's twist (primitive frame) per body twist ``u = (v, ω)`` in B with the
    stance feet fixed in W.  ``G`` (7, 3k): the primitive's body-frame twist per motion of its k points (the
    task graph's ``G(p) = −2 Ṽ ∂V/∂p``), ``feet`` (k, 3) the points in B in the same order: a foot fixed in W
    moves in B with ``ṗ_j = −v + [p_j]× ω``, so ``A = Σ_j G_j [−I, [p_j]×]`` (= ``J^G L`` of
    :func:`coop_ga.legged.posture.posture_step`: the leg Jacobians cancel)."""
    k = len(feet)
    Gk = G.reshape(G.shape[0], k, 3)
    x, y, z = feet[:, 0], feet[:, 1], feet[:, 2]
    # Σ_j G_j [p_j]×, column by column: [p]× = [[0, −z, y], [z, 0, −x], [−y, x, 0]]
    W = np.column_stack(
        [
            Gk[:, :, 1] @ z - Gk[:, :, 2] @ y,
            Gk[:, :, 2] @ x - Gk[:, :, 0] @ z,
            Gk[:, :, 0] @ y - Gk[:, :, 1] @ x,
        ]
    )
    return np.hstack([-Gk.sum(axis=1), W])
