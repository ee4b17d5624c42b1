"""Similarity manipulability, damped pseudo-inverse and nullspace projection (§3.10–3.11, Eq 58–59).

All functions take a geometric similarity Jacobian ``J`` (7×m, rows
``[e12, e13, e23, e0∞, e1∞, e2∞, e3∞]``, body frame) as produced by
:meth:`coop_ga.cooperative.CooperativeTask.jacobian`.

Units: rows mix rotation [rad], dilation [ln of scale] and translation [m] per unit of
joint motion, so eigenvalues of ``M_S`` mix units too; compare them within a row block
or weight the rows first (``weights``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import InvalidInputError, NonFiniteError

__all__ = [
    "damped_pinv",
    "force_manipulability",
    "manipulability",
    "manipulability_ellipsoid",
    "manipulability_index",
    "nullspace_projector",
]


def _check_J(J: Any) -> np.ndarray:
    J = np.asarray(J, dtype=float)
    if J.ndim != 2:
        raise InvalidInputError(f"a Jacobian must be a 2-D array, got shape {J.shape}")
    if not np.all(np.isfinite(J)):
        raise NonFiniteError("the Jacobian contains NaN or inf")
    return J


def damped_pinv(J: Any, damping: float = 1e-6) -> np.ndarray:
    """Damped least-squares pseudo-inverse ``Jᵀ (J Jᵀ + λ² I)⁻¹`` (m×7), λ = ``damping``.

    ``damping = 0`` gives the Moore–Penrose pseudo-inverse (via SVD, rank-revealing), so
    rank-deficient J (every cooperative task: Table 1) is handled either way.
    """
    J = _check_J(J)
    from .. import validation

    damping = validation.nonnegative(damping, "damping")
    if damping == 0.0:
        return np.linalg.pinv(J, rcond=1e-10)
    U, s, Vt = np.linalg.svd(J, full_matrices=False)
    return (Vt.T * (s / (s * s + damping * damping))) @ U.T


def nullspace_projector(J: Any, damping: float = 0.0) -> np.ndarray:
    """N = I − J⁺ J (Eq 58), m×m.  With ``damping > 0`` J⁺ is the damped pseudo-inverse.

    With ``damping = 0`` N is an exact orthogonal projector onto ker J, so
    ``J N q̇ = 0``: a projected joint velocity leaves V_Sc unchanged to first order.
    Damping trades that exactness for robustness near singularities.
    """
    J = _check_J(J)
    return np.eye(J.shape[1]) - damped_pinv(J, damping) @ J


def manipulability(J: Any, weights: Any | None = None) -> np.ndarray:
    """Similarity (velocity) manipulability ``M_S = J Jᵀ`` (Eq 59), 7×7.

    ``weights`` (7,) scales the rows first (``W J (W J)ᵀ``), e.g. to make units comparable.
    """
    J = _check_J(J)
    if weights is not None:
        J = np.asarray(weights, dtype=float).reshape(-1, 1) * J
    return J @ J.T


def force_manipulability(J: Any, cutoff: float = 1e-9, weights: Any | None = None) -> np.ndarray:
    """Force manipulability ``M_S⁻¹`` as a pseudo-inverse (every M_S is rank-deficient, Table 1):
    eigenvalues of M_S at or below ``cutoff`` (absolute, in M_S's units) are treated as zero."""
    from .. import validation

    cutoff = validation.positive(cutoff, "cutoff")
    M = manipulability(J, weights)
    w, Q = np.linalg.eigh(M)
    inv = np.where(w > cutoff, 1.0 / np.maximum(w, cutoff), 0.0)
    return (Q * inv) @ Q.T


def manipulability_ellipsoid(J: Any, weights: Any | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues (ascending, 7) and eigenvectors (columns) of ``M_S``.

    Principal semi-axes of the velocity ellipsoid are ``√eigenvalue`` along the
    eigenvectors (in bivector coordinates); zero eigenvalues are the geometric
    nullspace directions of Table 1 (uncontrollable similarity directions).

    Computed from the SVD of ``J`` (``M_S = U Σ² Uᵀ``), not by ``eigh(J Jᵀ)``: forming
    ``J Jᵀ`` squares the condition number, so ``eigh`` resolves eigenvalues only down to
    ~1e-16 × the largest.  Near a geometric singularity the largest grow like w⁻² and the
    smallest fall like w² (Figs. 18–19, ``experiments/singularity.py``), and ``eigh``
    reported the falling ones as rounding noise ~1e-3 long before the guard's threshold;
    the SVD keeps them to ~1e-16 × σ_max *relative to σ*, i.e. eigenvalues to ~1e-32 λ_max.
    """
    J = _check_J(J)
    if weights is not None:
        J = np.asarray(weights, dtype=float).reshape(-1, 1) * J
    U, s, _ = np.linalg.svd(J, full_matrices=True)
    lam = np.zeros(J.shape[0])
    lam[: s.size] = s**2
    order = np.argsort(lam, kind="stable")
    return lam[order], U[:, order]


def manipulability_index(J: Any, rank: int | None = None, weights: Any | None = None) -> float:
    """Yoshikawa-style index √(product of the ``rank`` largest eigenvalues of M_S).

    ``rank`` defaults to the numerical rank of J; it should be the primitive's DOF
    (point 3, point pair 6, line 4, circle 6, plane 3, sphere 4) — the full 7×7
    determinant is always 0 for cooperative tasks.
    """
    J = _check_J(J)
    s = np.linalg.svd(np.asarray(weights, float).reshape(-1, 1) * J if weights is not None else J, compute_uv=False)
    if rank is None:
        rank = int(np.sum(s > 1e-9 * max(s[0], 1e-300)))
    return float(np.prod(s[:rank]))
