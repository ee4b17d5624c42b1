"""An independent reference for G(4,1): the faithful 4×4 complex matrix representation.

Cl(4,1) ≅ M4(C).  With Pauli matrices σ1..σ3 we take γ1..γ3 = σk ⊗ σ1,
γ4 = 1 ⊗ σ2, γ5 = i·1 ⊗ σ3 (γ1..γ4 square to +1, γ5 to −1, all anticommute).
Nothing here shares code with coop_ga.algebra: products are matrix products.
"""

from __future__ import annotations

import numpy as np

s1 = np.array([[0, 1], [1, 0]], dtype=complex)
s2 = np.array([[0, -1j], [1j, 0]], dtype=complex)
s3 = np.array([[1, 0], [0, -1]], dtype=complex)
I2 = np.eye(2, dtype=complex)

GAMMA_ORTHO = [np.kron(s1, s1), np.kron(s2, s1), np.kron(s3, s1), np.kron(I2, s2), 1j * np.kron(I2, s3)]
E0 = 0.5 * (GAMMA_ORTHO[4] - GAMMA_ORTHO[3])
EINF = GAMMA_ORTHO[3] + GAMMA_ORTHO[4]
# null-basis generators in coop_ga's bit order: e0, e1, e2, e3, e∞
GAMMA_NULL = [E0, GAMMA_ORTHO[0], GAMMA_ORTHO[1], GAMMA_ORTHO[2], EINF]


def blade_matrix(bitmask: int) -> np.ndarray:
    """Matrix of the null-basis blade e_{i1}∧…∧e_{ik}.

    For mutually orthogonal factors the outer product equals the geometric product;
    e0 and e∞ are not orthogonal, so e0∧e∞ = e0 e∞ − e0·e∞ = e0 e∞ + 1 — we build the
    outer product by antisymmetrising over permutations instead (metric-free).
    """
    idx = [i for i in range(5) if bitmask >> i & 1]
    if not idx:
        return np.eye(4, dtype=complex)
    from itertools import permutations

    acc = np.zeros((4, 4), dtype=complex)
    for perm in permutations(range(len(idx))):
        sign = _perm_sign(perm)
        m = np.eye(4, dtype=complex)
        for p in perm:
            m = m @ GAMMA_NULL[idx[p]]
        acc += sign * m
    import math

    return acc / math.factorial(len(idx))


def _perm_sign(perm) -> int:
    p = list(perm)
    s = 1
    for i in range(len(p)):
        for j in range(i + 1, len(p)):
            if p[i] > p[j]:
                s = -s
    return s


_BASIS = [blade_matrix(b) for b in range(32)]
# solve for coordinates: flatten the 32 basis matrices into a real 32×32 system
_M = np.stack([np.concatenate([m.real.ravel(), m.imag.ravel()]) for m in _BASIS], axis=1)
_MINV = np.linalg.inv(_M)


def to_matrix(dense: np.ndarray) -> np.ndarray:
    return sum(c * m for c, m in zip(dense, _BASIS))


def from_matrix(m: np.ndarray) -> np.ndarray:
    return _MINV @ np.concatenate([m.real.ravel(), m.imag.ravel()])
