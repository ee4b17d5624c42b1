"""Differential inverse kinematics in the cooperative similarity space (Eq 48, 61).

Convention (the one every controller in :mod:`coop_ga.control` uses)
-------------------------------------------------------------------
``J^G`` (7×nq, rows ``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]``) is a *body-frame*
Jacobian: for a joint velocity ``q̇`` the 7-vector ``b = J^G q̇`` satisfies, to first
order in Δt,

    V_Sc(q + Δt q̇) ≈ V_Sc(q) · exp(Δt b).

So a commanded body velocity bivector ``B_S`` (7,) [rad/s for the rotation rows, 1/s
(log of scale per second) for e0∞, body length units per second for the translation
rows, all expressed in the current cooperative frame V_Sc(q)] is realised by the damped
least-squares joint velocity (Eq 48, 61).  Note that the body frame of V_Sc is *scaled*:
V_Sc = V_T V_R V_D contains the primitive's dilation (radius r of a circle or sphere), so
a body translation t moves the primitive by ``r · R t`` metres in the world.

    q̇ = J^G⁺ B_S,        q_{t+1} = q_t + Δt q̇.

Reaching a target ``V_Sd``: the error ``e = log(Ṽ_Sc(q) V_Sd)`` (Eq 44) is the target
seen from the current pose; after a step ``Ṽ_Sc(q_{t+1}) V_Sd ≈ exp(−Δt b) exp(e)``, so
commanding ``b = gain · e`` decreases the error like ``e_{t+1} ≈ (1 − gain Δt) e_t``
(exactly on the controllable directions; the uncontrollable ones of Table 1 — e.g. the
seventh direction of a circle — cannot be reduced, see :class:`DiffIKResult`).

Joint limits: with ``limits='clamp'`` (default) q is clipped to
``[system.q_lower, system.q_upper]`` *after* every step (a clamped joint simply stops;
no nullspace re-distribution); ``limits='none'`` leaves q unconstrained.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..cooperative.manipulability import damped_pinv
from ..cooperative.task import versor_coeffs
from ..errors import InvalidInputError, NonFiniteError

__all__ = ["diff_ik_step", "diff_ik_reach", "DiffIKResult", "joint_velocity"]

_LIMITS = ("clamp", "none")


def _check_limits(limits: str) -> str:
    if limits not in _LIMITS:
        raise InvalidInputError(f"limits must be one of {_LIMITS}, got {limits!r}")
    return limits


def _check_q(task: Any, q: Any) -> np.ndarray:
    a = np.array(q, dtype=float).reshape(-1) if np.ndim(q) <= 1 else np.array(q, dtype=float)
    if a.shape != (task.nq,):
        raise InvalidInputError(f"task '{task.name}' expects q with {task.nq} entries, got shape {np.shape(q)}")
    if not np.all(np.isfinite(a)):
        raise NonFiniteError(f"q contains NaN or inf at indices {np.flatnonzero(~np.isfinite(a)).tolist()}")
    return a


def _check_bivector(b: Any, what: str = "command_bivector") -> np.ndarray:
    a = np.asarray(b, dtype=float)
    if a.shape not in ((7,), (7, 1)):
        raise InvalidInputError(
            f"{what} must be a 7-vector [e12, e13, e23, e0∞, e1∞, e2∞, e3∞], got shape {a.shape}"
        )
    a = a.reshape(7)
    if not np.all(np.isfinite(a)):
        raise NonFiniteError(f"{what} contains NaN or inf")
    return a


def _check_positive(x: float, what: str, allow_zero: bool = False) -> float:
    x = float(x)
    if not np.isfinite(x) or x < 0 or (x == 0 and not allow_zero):
        raise InvalidInputError(f"{what} must be {'≥' if allow_zero else '>'} 0 and finite, got {x}")
    return x


def _bounds(task: Any) -> tuple[np.ndarray, np.ndarray]:
    m = task.system.model
    return np.asarray(m.lowerPositionLimit, float), np.asarray(m.upperPositionLimit, float)


def joint_velocity(J: Any, command_bivector: Any, damping: float = 1e-3) -> np.ndarray:
    """``q̇ = J⁺ B`` (nq,) with the damped pseudo-inverse ``Jᵀ(J Jᵀ + λ² I)⁻¹`` (Eq 48).

    ``J`` is the 7×nq body-frame Jacobian, ``command_bivector`` the 7-vector B_S,
    ``damping`` λ (same units as J's singular values).
    """
    return damped_pinv(J, damping) @ _check_bivector(command_bivector)


def diff_ik_step(task: Any, q: Any, command_bivector: Any, dt: float = 0.01, damping: float = 1e-3,
                 limits: str = "clamp") -> np.ndarray:
    """One differential-IK step (Eq 48, 61): ``q_next = q + Δt · J^G(q)⁺ B_S``.

    Parameters
    ----------
    task: a :class:`coop_ga.CooperativeTask`.
    q: (nq,) joint configuration [rad].
    command_bivector: (7,) body-frame similarity velocity B_S on
        ``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]`` [rad/s, 1/s, m/s], expressed in the
        current cooperative frame V_Sc(q) (``V(q_next) ≈ V(q) exp(Δt B_S)``).
    dt: time step Δt [s] (> 0).
    damping: λ of the damped pseudo-inverse (≥ 0; 0 = Moore–Penrose).
    limits: ``'clamp'`` clips q_next to the joint limits, ``'none'`` does not.

    Returns
    -------
    q_next: (nq,) new configuration (a new array).
    """
    _check_limits(limits)
    dt = _check_positive(dt, "dt")
    damping = _check_positive(damping, "damping", allow_zero=True)
    q = _check_q(task, q)
    b = _check_bivector(command_bivector)
    J = task.evaluate_views(q)[2]
    q_next = q + dt * (damped_pinv(J, damping) @ b)
    if limits == "clamp":
        lo, hi = _bounds(task)
        np.clip(q_next, lo, hi, out=q_next)
    return q_next


@dataclass(frozen=True)
class DiffIKResult:
    """Result of :func:`diff_ik_reach`.

    Attributes
    ----------
    q_traj: (T, nq) configurations, ``q_traj[0] = q0``, T = steps + 1.
    errors: (T,) ``‖log(Ṽ_Sc(q_t) V_Sd)‖`` at each configuration (mixed units: rad, log
        scale, m — the plain Euclidean norm of the 7-vector).
    converged: True iff the last error is below ``tol``.
    final_error: ``errors[-1]``.
    steps: number of steps taken (stops early once converged).
    """

    q_traj: np.ndarray
    errors: np.ndarray
    converged: bool
    final_error: float
    steps: int

    @property
    def q(self) -> np.ndarray:
        """The final configuration ``q_traj[-1]``."""
        return self.q_traj[-1]


def diff_ik_reach(task: Any, q0: Any, target_versor: Any, *, gain: float = 1.0, dt: float = 0.01,
                  steps: int = 500, damping: float = 1e-3, tol: float = 1e-6,
                  limits: str = "clamp") -> DiffIKResult:
    """Drive V_Sc(q) to ``target_versor`` by differential IK on the error (Eq 44, 48).

    Each step commands the body velocity ``B_S = gain · log(Ṽ_Sc(q) V_Sd)`` (the error
    bivector in the current frame, 1/s × error units) through :func:`diff_ik_step`;
    with ``gain · dt = 1`` this is a damped Gauss–Newton step.  Stops when the error norm
    is below ``tol`` or after ``steps`` steps.  Non-convergence (unreachable target,
    joint limits, singularity) is reported as ``converged=False``.

    Parameters
    ----------
    task: a :class:`coop_ga.CooperativeTask`.
    q0: (nq,) initial configuration [rad].
    target_versor: V_Sd, a similarity versor (Multivector or its 12 coefficients).
    gain: proportional gain [1/s] (> 0).
    dt: time step [s].  steps: maximum number of steps.
    damping: λ of the damped pseudo-inverse.  tol: error-norm threshold.
    limits: ``'clamp'`` (clip to joint limits after each step) or ``'none'``.
    """
    _check_limits(limits)
    gain = _check_positive(gain, "gain")
    dt = _check_positive(dt, "dt")
    damping = _check_positive(damping, "damping", allow_zero=True)
    tol = _check_positive(tol, "tol", allow_zero=True)
    if int(steps) != steps or steps < 0:
        raise InvalidInputError(f"steps must be a non-negative integer, got {steps}")
    steps = int(steps)
    Vd = versor_coeffs(target_versor)
    if not np.all(np.isfinite(Vd)):
        raise NonFiniteError("target_versor contains NaN or inf")
    q = _check_q(task, q0)
    lo, hi = _bounds(task)
    qs = [q.copy()]
    e = task.error(q, Vd)
    errs = [float(np.linalg.norm(e))]
    k = 0
    while k < steps and errs[-1] >= tol:
        J = task.evaluate_views(q)[2]
        q = q + dt * (damped_pinv(J, damping) @ (gain * e))
        if limits == "clamp":
            np.clip(q, lo, hi, out=q)
        e = task.error(q, Vd)
        qs.append(q.copy())
        errs.append(float(np.linalg.norm(e)))
        k += 1
    errors = np.array(errs)
    return DiffIKResult(np.array(qs), errors, bool(errors[-1] < tol), float(errors[-1]), k)
