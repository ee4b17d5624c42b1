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

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .. import validation
from ..cooperative.manipulability import damped_pinv
from ..diagnostics import collect_warnings
from .base import SolverResult, bounds, check_q, resolve_options

__all__ = ["DiffIKOptions", "DiffIKResult", "diff_ik_reach", "diff_ik_step", "joint_velocity"]

LIMIT_MODES = ("clamp", "none")


def _check_bivector(b: Any, what: str = "command_bivector") -> np.ndarray:
    """A 7-vector (7,) — or a (7, 1) column, as the task's ``evaluate_views`` returns B."""
    if isinstance(b, np.ndarray) and b.shape == (7, 1):
        b = b.reshape(7)
    return validation.vector(b, 7, f"{what} [e12, e13, e23, e0∞, e1∞, e2∞, e3∞]")


def joint_velocity(J: Any, command_bivector: Any, damping: float = 1e-3) -> np.ndarray:
    """``q̇ = J⁺ B`` (nq,) with the damped pseudo-inverse ``Jᵀ(J Jᵀ + λ² I)⁻¹`` (Eq 48).

    ``J`` is the 7×nq body-frame Jacobian, ``command_bivector`` the 7-vector B_S,
    ``damping`` λ (same units as J's singular values).
    """
    return damped_pinv(J, validation.nonnegative(damping, "damping")) @ _check_bivector(command_bivector)


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
    validation.choice(limits, LIMIT_MODES, "limits")
    dt = validation.positive(dt, "dt")
    damping = validation.nonnegative(damping, "damping")
    q = check_q(task, q)
    b = _check_bivector(command_bivector)
    J = task.evaluate_views(q)[2]
    q_next = q + dt * (damped_pinv(J, damping) @ b)
    if limits == "clamp":
        lo, hi = bounds(task)
        np.clip(q_next, lo, hi, out=q_next)
    return q_next


@dataclass(frozen=True)
class DiffIKOptions:
    """Settings of :func:`diff_ik_reach`.

    gain: proportional gain [1/s] (> 0); ``gain · dt = 1`` is a damped Gauss–Newton step.
    dt: time step [s] (> 0).
    steps: maximum number of steps (≥ 0).
    damping: λ of the damped pseudo-inverse (≥ 0).
    tol: converged when ‖e‖ < tol (≥ 0).
    limits: ``'clamp'`` (clip to the joint limits after each step) or ``'none'``.
    """

    gain: float = 1.0
    dt: float = 0.01
    steps: int = 500
    damping: float = 1e-3
    tol: float = 1e-6
    limits: str = "clamp"

    def __post_init__(self) -> None:
        validation.positive(self.gain, "gain")
        validation.positive(self.dt, "dt")
        validation.integer(self.steps, "steps", minimum=0)
        validation.nonnegative(self.damping, "damping")
        validation.nonnegative(self.tol, "tol")
        validation.choice(self.limits, LIMIT_MODES, "limits")


@dataclass(frozen=True, kw_only=True)
class DiffIKResult(SolverResult):
    """Result of :func:`diff_ik_reach` (fields of :class:`~coop_ga.control.base.SolverResult` plus):

    trajectory: (T, nq) configurations, ``trajectory[0] = q0``, T = iterations + 1.
    errors: (T,) ``‖log(Ṽ_Sc(q_t) V_Sd)‖`` at each configuration (mixed units: rad, log
        scale, m — the plain Euclidean norm of the 7-vector).
    """

    trajectory: np.ndarray
    errors: np.ndarray = field(default_factory=lambda: np.zeros(0))


def diff_ik_reach(task: Any, q0: Any, target: Any, options: DiffIKOptions | None = None,
                  **overrides: Any) -> DiffIKResult:
    """Drive V_Sc(q) to ``target`` (a :class:`~coop_ga.Similarity`) by differential IK (Eq 44, 48).

    Each step commands the body velocity ``B_S = gain · log(Ṽ_Sc(q) V_Sd)`` (the error
    bivector in the current frame, 1/s × error units) through :func:`diff_ik_step`.
    Stops when ‖e‖ < ``tol`` or after ``steps`` steps.  Non-convergence (unreachable
    target, joint limits, singularity) is reported as ``converged=False``.
    ``options``: :class:`DiffIKOptions` (keyword ``overrides`` replace its fields).
    """
    o = resolve_options(DiffIKOptions, options, overrides, "diff_ik_reach")
    Vd = validation.target(target)
    q = check_q(task, q0, "q0")
    lo, hi = bounds(task)
    with collect_warnings() as caught:
        qs = [q.copy()]
        e = task.error(q, Vd)
        errs = [float(np.linalg.norm(e))]
        k = 0
        while k < o.steps and errs[-1] >= o.tol:
            J = task.evaluate_views(q)[2]
            q = q + o.dt * (damped_pinv(J, o.damping) @ (o.gain * e))
            if o.limits == "clamp":
                np.clip(q, lo, hi, out=q)
            e = task.error(q, Vd)
            qs.append(q.copy())
            errs.append(float(np.linalg.norm(e)))
            k += 1
    errors = np.array(errs)
    converged = bool(errors[-1] < o.tol)
    message = "converged" if converged else f"not converged after {k} steps (‖e‖ = {errors[-1]:.3g} ≥ tol)"
    return DiffIKResult(converged=converged, error=float(errors[-1]), iterations=k, message=message, q=q.copy(),
                        warnings=dict(caught.counts), trajectory=np.array(qs), errors=errors)
