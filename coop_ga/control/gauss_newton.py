"""Gauss–Newton inverse kinematics in the cooperative similarity space (Eq 43–47).

The residual is the similarity error (Eq 44)

    e(q) = log(Ṽ_Sc(q) V_Sd)   (7,)  on [e12, e13, e23, e0∞, e1∞, e2∞, e3∞],

the target seen from the current cooperative frame, and ``J_e = ∂e/∂q`` (7×nq, Eq 47)
comes from :meth:`CooperativeTask.error_and_jacobian` in the same compiled call
(``J_e = J_log(W) · [½ b_i W]`` with ``W = Ṽ_Sc V_Sd``, b_i the columns of J^G; near
e = 0 it tends to ``−J^G``).  The Levenberg-damped Gauss–Newton step (Eq 45–46)

    Δq = −(J_eᵀ J_e + λ I)⁻¹ J_eᵀ e

is evaluated through the SVD ``J_e = U S Vᵀ`` as ``Δq = −V diag(s/(s²+λ)) Uᵀ e``
(algebraically identical, but stable although J_e is always rank deficient: Table 1,
e.g. rank 6 for a circle, 4 for a sphere or line).  With ``line_search=True`` a
backtracking Armijo search on ``f = ½‖e‖²`` picks the step length α ∈ {1, ½, ¼, …}.

Non-convergence (unreachable target, a local minimum with e ≠ 0, joint limits) is
reported as ``converged=False`` with the honest final error; nothing is disguised.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..cooperative.task import versor_coeffs
from ..errors import DegeneracyWarning, DegeneratePrimitiveError, InvalidInputError, NonFiniteError
from .diffik import _bounds, _check_limits, _check_positive, _check_q

__all__ = ["gauss_newton_ik", "IKResult", "gauss_newton_step"]


@dataclass(frozen=True)
class IKResult:
    """Result of :func:`gauss_newton_ik`.

    Attributes
    ----------
    q: (nq,) final configuration [rad].
    converged: True iff ``‖e(q)‖ < tol``.
    error: final ``‖e(q)‖`` (Euclidean norm of the 7-vector; mixed units rad / log-scale / m).
    iterations: number of Gauss–Newton steps taken.
    history: (iterations + 1,) error norms, ``history[0]`` at ``q_init``.
    step_sizes: (iterations,) accepted line-search step lengths α.
    message: why the iteration stopped.
    """

    q: np.ndarray
    converged: bool
    error: float
    iterations: int
    history: np.ndarray
    step_sizes: np.ndarray = field(default_factory=lambda: np.zeros(0))
    message: str = ""


def gauss_newton_step(e: np.ndarray, Je: np.ndarray, damping: float) -> np.ndarray:
    """``Δq = −(J_eᵀ J_e + λ I)⁻¹ J_eᵀ e`` (nq,) via the SVD of ``J_e`` (Eq 45–46)."""
    U, s, Vt = np.linalg.svd(Je, full_matrices=False)
    return -(Vt.T @ ((s / (s * s + damping)) * (U.T @ e)))


def gauss_newton_ik(task: Any, q_init: Any, target_versor: Any, *, max_iter: int = 100, tol: float = 1e-10,
                    damping: float = 1e-9, line_search: bool = True, armijo: float = 1e-4,
                    min_step: float = 1e-8, max_step: float = 0.5, gtol: float = 1e-9, xtol: float = 1e-14,
                    ftol: float = 1e-6, stall_window: int = 10,
                    limits: str = "none") -> IKResult:
    """Solve ``V_Sc(q) = V_Sd`` by damped Gauss–Newton with Armijo backtracking (Eq 43–47).

    Parameters
    ----------
    task: a :class:`coop_ga.CooperativeTask`.
    q_init: (nq,) initial configuration [rad].
    target_versor: V_Sd (Multivector or 12 coefficients on SIMILARITY_BLADES).
    max_iter: maximum number of Gauss–Newton steps.
    tol: convergence threshold on ``‖e‖``.
    damping: λ ≥ 0 in ``(J_eᵀ J_e + λ I)`` (Levenberg term; units of J_e²).
    line_search: backtracking on ``½‖e‖²`` with the Armijo constant ``armijo``; the step is
        halved until sufficient decrease or ``α < min_step`` (then the iteration stops with
        ``converged=False``: no descent possible, a local minimum of the residual).
        Without line search the full step is always taken.
    max_step: trust bound [rad]: a step whose largest joint change exceeds it is scaled
        down to it before the line search (keeps the linearisation meaningful far from the
        solution; has no effect near convergence, so the local rate stays quadratic).
        ``np.inf`` disables it.
    gtol, xtol: stop (``converged=False``) when the gradient ``J_eᵀ e`` of ½‖e‖² satisfies
        ``‖J_eᵀ e‖ ≤ gtol · ‖J_e‖_F · ‖e‖`` — e is orthogonal to the range of J_e: a
        stationary point with e ≠ 0, i.e. a local minimum / unreachable target — or when the step's max-norm is
        ≤ ``xtol · (1 + max|q|)``.
    ftol, stall_window: stop (stalled) when ‖e‖ decreased by less than ``ftol·‖e‖`` over
        the last ``stall_window`` iterations.
    limits: ``'none'`` (default; the problem is unconstrained as in Eq 43) or ``'clamp'``
        (every trial point is clipped to the joint limits, a projected Gauss–Newton).

    Trial points at which the cooperative primitive degenerates
    (:class:`~coop_ga.errors.DegeneratePrimitiveError`, e.g. collinear points for a circle)
    are rejected like a failed Armijo test; :class:`~coop_ga.errors.DegeneracyWarning` of
    trial points are silenced and the final configuration is re-checked once (warning
    at most once).  The initial configuration must be well defined (otherwise the error
    is raised).
    """
    _check_limits(limits)
    if int(max_iter) != max_iter or max_iter < 0:
        raise InvalidInputError(f"max_iter must be a non-negative integer, got {max_iter}")
    tol = _check_positive(tol, "tol", allow_zero=True)
    max_step = float(max_step)
    if not max_step > 0:  # inf allowed: no trust bound
        raise InvalidInputError(f"max_step must be > 0 (inf disables the bound), got {max_step}")
    damping = _check_positive(damping, "damping", allow_zero=True)
    Vd = versor_coeffs(target_versor)
    if not np.all(np.isfinite(Vd)):
        raise NonFiniteError("target_versor contains NaN or inf")
    q = _check_q(task, q_init)
    lo, hi = _bounds(task)
    if limits == "clamp":
        q = np.clip(q, lo, hi)

    e, Je = task.error_and_jacobian(q, Vd)
    f = 0.5 * float(e @ e)
    hist = [float(np.sqrt(2 * f))]
    alphas: list[float] = []
    message = "max_iter reached"
    it = 0
    while hist[-1] >= tol:
        if it >= max_iter:
            break
        grad = Je.T @ e
        if float(np.linalg.norm(grad)) <= gtol * float(np.linalg.norm(Je)) * hist[-1]:
            message = ("stationary point of ‖e‖² with e ≠ 0 (‖J_eᵀ e‖ ≤ gtol): a local minimum, "
                       "the target is not reachable from here")
            break
        dq = gauss_newton_step(e, Je, damping)
        if float(np.max(np.abs(dq))) <= xtol * (1.0 + float(np.max(np.abs(q)))):
            message = "step below xtol: no further progress (local minimum or unreachable target)"
            break
        big = float(np.max(np.abs(dq)))
        if big > max_step:
            dq *= max_step / big
        slope = float(e @ (Je @ dq))  # d/dα ½‖e(q + α Δq)‖² at α = 0
        alpha = 1.0
        while True:
            qt = q + alpha * dq
            if limits == "clamp":
                np.clip(qt, lo, hi, out=qt)
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", DegeneracyWarning)
                    et, Jt = task.error_and_jacobian(qt, Vd)
                ft = 0.5 * float(et @ et)
            except DegeneratePrimitiveError:
                ft = np.inf
            if ft < np.inf and (not line_search or ft <= f + armijo * alpha * min(slope, 0.0)):
                break
            alpha *= 0.5
            if alpha < min_step:
                qt = None
                break
        if qt is None:
            message = "line search failed: no descent direction (local minimum of ‖e‖ or unreachable target)"
            break
        it += 1
        q, e, Je, f = qt, et, Jt, ft
        hist.append(float(np.sqrt(2 * f)))
        alphas.append(alpha)
        if it >= stall_window and hist[-1] >= tol and hist[-1 - stall_window] - hist[-1] <= ftol * hist[-1]:
            message = (f"stalled: ‖e‖ decreased by less than ftol·‖e‖ over {stall_window} iterations "
                       "(local minimum, singular configuration or unreachable target)")
            break
    if it:
        task.error_and_jacobian(q, Vd)  # re-check the final configuration (one DegeneracyWarning at most)
    converged = hist[-1] < tol
    if converged:
        message = "converged"
    return IKResult(q=q, converged=bool(converged), error=hist[-1], iterations=it, history=np.array(hist),
                    step_sizes=np.array(alphas), message=message)
