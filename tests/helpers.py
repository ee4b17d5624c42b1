"""Helpers shared by tests (kept out of conftest so they can be imported)."""

from __future__ import annotations

import numpy as np


def proportionality(A, B) -> tuple[float, float]:
    """(λ, relative residual) of the least-squares fit A ≈ λ B of two numeric multivectors."""
    a, b = A.to_dense(), B.to_dense()
    lam = float(a @ b / (b @ b))
    return lam, float(np.linalg.norm(a - lam * b) / max(np.linalg.norm(a), 1e-300))


def central_difference(f, x: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """Jacobian of f at x by central differences; f returns an array."""
    x = np.asarray(x, dtype=float)
    f0 = np.asarray(f(x))
    J = np.zeros((f0.size, x.size))
    for i in range(x.size):
        xp, xm = x.copy(), x.copy()
        xp[i] += h
        xm[i] -= h
        J[:, i] = (np.asarray(f(xp)).ravel() - np.asarray(f(xm)).ravel()) / (2 * h)
    return J
