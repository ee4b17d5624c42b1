"""Cooperative task-space dynamics (Eq 32–38).

Joint space (Eq 32), from Pinocchio::

    M(q) q̈ + C(q, q̇) q̇ + g(q) = τ        (τ_ext = 0)

M from ``pin.crba`` (Pinocchio fills only the upper triangle: we symmetrise it), C from
``pin.computeCoriolisMatrix``, g from ``pin.computeGeneralizedGravity``.  Units: q [rad],
τ [N m]; the task quantities mix the units of the 7 bivector rows (rotation [rad],
dilation [ln scale], translation [m]).

Task space (Eq 33–38), with the body-frame geometric similarity Jacobian J = J^G (7×nq)
and the twist ``𝒱 = J q̇`` (Eq 33), ``𝒱̇ = J q̈ + J̇ q̇`` (Eq 34; J̇ q̇ from
:meth:`CooperativeTask.jdot_qdot`, CasADi AD)::

    Λ 𝒱̇ + μ + g_S = 𝒲                                      (Eq 35)
    Λ   = (J M⁻¹ Jᵀ)⁺                                         (Eq 36)
    μ   = Λ (J M⁻¹ C q̇ − J̇ q̇)                               (Eq 37; C multiplies q̇)
    g_S = Λ J M⁻¹ g                                           (Eq 38)

Rank deficiency.  ``A = J M⁻¹ Jᵀ`` is never invertible for a cooperative task: J has
the rank of the primitive's DOF (Table 1: circle 6 of 7 rows, sphere/line 4, plane 3,
point 3, point pair 6).  Eq 36 is therefore evaluated as a pseudo-inverse on the
eigen-decomposition of the symmetric A: eigenvalues below ``rcond · max eigenvalue``
are treated as zero (exact Moore–Penrose on the numerical range of J); optionally a
Tikhonov ``damping`` λ turns the surviving ones into ``w/(w² + λ²)``.  With the exact
pseudo-inverse ``A Λ = P``, the orthogonal projector onto range(J), which makes
``J̄ = M⁻¹ Jᵀ Λ`` a dynamically consistent generalised inverse (``J M⁻¹ N̄ᵀ = 0`` for
``N̄ᵀ = I − Jᵀ J̄ᵀ``): see :func:`dynamically_consistent_projector`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import validation
from .base import check_q, check_v

__all__ = [
    "TaskDynamics",
    "dynamically_consistent_projector",
    "joint_dynamics",
    "task_inertia",
    "task_space_dynamics",
]


def _pin():
    import pinocchio as pin

    return pin


def _data(task: Any) -> Any:
    d = getattr(task, "_dyn_data", None)
    if d is None:
        d = task.system.model.createData()
        task._dyn_data = d  # a private pinocchio.Data per task (systems share theirs with other code)
    return d


def joint_dynamics(task_or_system: Any, q: Any, qd: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(M (nv,nv) symmetric, C (nv,nv), g (nv,))`` of Eq 32 from Pinocchio at q (nq,), q̇ (nv,) (nv = nq
    without a free flyer; with one, its six velocities are Pinocchio's LOCAL [v; ω]).

    ``pin.crba`` writes only the upper triangle of M; it is symmetrised here.
    Accepts a :class:`CooperativeTask` (uses its system's model) or a System.
    """
    pin = _pin()
    sysm = getattr(task_or_system, "system", task_or_system)
    model = sysm.model
    task = task_or_system if hasattr(task_or_system, "system") else None
    data = _data(task) if task is not None else sysm.data
    q = validation.configuration(q, model.nq, "q")
    qd = validation.configuration(qd, model.nv, "qd")
    M = pin.crba(model, data, q)
    M = np.triu(M) + np.triu(M, 1).T
    C = np.array(pin.computeCoriolisMatrix(model, data, q, qd))
    g = np.array(pin.computeGeneralizedGravity(model, data, q))
    return M, C, g


def task_inertia(J: np.ndarray, Minv: np.ndarray, *, rcond: float = 1e-8, damping: float = 0.0) -> np.ndarray:
    """``Λ = (J M⁻¹ Jᵀ)⁺`` (Eq 36), 7×7 symmetric positive semi-definite.

    Pseudo-inverse on the eigen-decomposition of ``A = J M⁻¹ Jᵀ``: eigenvalues
    ``w ≤ rcond · max(w)`` are dropped (the uncontrollable directions of Table 1),
    the others inverted as ``w / (w² + damping²)`` (``damping = 0``: exact inverse).
    """
    A = J @ Minv @ J.T
    A = 0.5 * (A + A.T)
    w, Q = np.linalg.eigh(A)
    keep = w > rcond * max(float(w[-1]), 1e-300)
    inv = np.zeros_like(w)
    inv[keep] = w[keep] / (w[keep] ** 2 + damping * damping)
    return (Q * inv) @ Q.T


def dynamically_consistent_projector(J: np.ndarray, Minv: np.ndarray, Lam: np.ndarray) -> np.ndarray:
    """``N̄ᵀ = I − Jᵀ J̄ᵀ`` with ``J̄ = M⁻¹ Jᵀ Λ`` (nq×nq): joint torques ``N̄ᵀ τ₀`` produce
    no task acceleration (``J M⁻¹ N̄ᵀ = 0`` when Λ is the exact pseudo-inverse)."""
    return np.eye(J.shape[1]) - J.T @ (Lam @ (J @ Minv))


@dataclass(frozen=True)
class TaskDynamics:
    """Everything :func:`task_space_dynamics` computes (arrays are copies).

    Lambda (7,7) Eq 36; mu (7,) Eq 37; g (7,) Eq 38; J (7,nv) J^G; Jdot_qd (7,) J̇^G q̇;
    M, C (nv,nv); g_joint (nv,); Minv (nv,nv).
    """

    Lambda: np.ndarray
    mu: np.ndarray
    g: np.ndarray
    J: np.ndarray
    Jdot_qd: np.ndarray
    M: np.ndarray
    C: np.ndarray
    g_joint: np.ndarray
    Minv: np.ndarray

    def __iter__(self):  # (Lambda, mu, g, J, Jdot_qd) unpacking, as documented
        return iter((self.Lambda, self.mu, self.g, self.J, self.Jdot_qd))


def task_space_dynamics(task: Any, q: Any, qd: Any, *, rcond: float = 1e-8, damping: float = 0.0) -> TaskDynamics:
    """Cooperative task-space dynamics at (q, q̇) (Eq 35–38).

    Args:
        task: a :class:`coop_ga.CooperativeTask`.
        q: (nq,) [rad].  qd: (nv,) [rad/s].
        rcond: pseudo-inverse option of :func:`task_inertia` (J is rank deficient).
        damping: pseudo-inverse option of :func:`task_inertia`.

    Returns:
        A :class:`TaskDynamics`; unpacks as ``Lambda (7,7), mu (7,), g (7,), J (7,nq), Jdot_qd (7,)``.
        ``mu`` and ``g`` are task-space wrenches (dual to the 7 bivector rows) such that
        ``τ = Jᵀ (Λ 𝒱̇_d + μ + g_S)`` realises the task acceleration 𝒱̇_d on range(J) (Eq 51–52).
    """
    q = check_q(task, q, "q")
    qd = check_v(task, qd, "qd")
    J = task.jacobian(q)
    M, C, g = joint_dynamics(task, q, qd)
    Minv = np.linalg.inv(M)
    Minv = 0.5 * (Minv + Minv.T)
    Lam = task_inertia(J, Minv, rcond=rcond, damping=damping)
    Jd_qd = task.jdot_qdot(q, qd)
    JMinv = J @ Minv
    mu = Lam @ (JMinv @ (C @ qd) - Jd_qd)
    gS = Lam @ (JMinv @ g)
    return TaskDynamics(Lam, mu, gS, J, Jd_qd, M, C, g, Minv)
