"""The basis of CGA G(4,1) in the null basis {e0, e1, e2, e3, e∞}, and exact product tables.

Conventions (paper §2.1): e1, e2, e3, e4 square to +1, e5 squares to -1,
``e0 = ½(e5 − e4)`` and ``e∞ = e4 + e5``, hence ``e0² = e∞² = 0`` and
``e0·e∞ = −1``.

We never store multivectors in the orthogonal basis {e1..e5}: in the null basis a
translator is ``1 − ½ t e∞`` (4 blades) instead of 7, a motor has 8 blades and a
similarity versor 12.  A blade is a bitmask over the generators in the order
``e0 < e1 < e2 < e3 < e∞`` (bit 0 = e0, bit 4 = e∞), so the pseudoscalar is
``I = e0∧e1∧e2∧e3∧e∞`` (= e12345 in the orthogonal basis, I² = −1).

The tables below are computed once, exactly (``fractions.Fraction``), by expanding
each null blade in the orthogonal basis, multiplying there, and mapping back.
"""

from __future__ import annotations

from fractions import Fraction
from functools import cache
from numbers import Integral

from ..errors import InvalidInputError

__all__ = [
    "BLADES_BY_GRADE",
    "GEN_NAMES",
    "N_BLADES",
    "N_GEN",
    "blade_index",
    "blade_name",
    "grade_of",
    "outer_table",
    "product_table",
]

N_GEN = 5
N_BLADES = 1 << N_GEN
GEN_NAMES = ("0", "1", "2", "3", "∞")
_ASCII_GEN = {"0": 0, "1": 1, "2": 2, "3": 3, "∞": 4, "i": 4}

# metric of the null basis: g[i][j] = e_i · e_j
_G_NULL = [[Fraction(0)] * N_GEN for _ in range(N_GEN)]
for _k in (1, 2, 3):
    _G_NULL[_k][_k] = Fraction(1)
_G_NULL[0][4] = _G_NULL[4][0] = Fraction(-1)


def _blade_int(blade: object, what: str = "blade") -> int:
    """``blade`` as a python int in 0..31 (a bitmask); raises :class:`InvalidInputError` otherwise."""
    if isinstance(blade, Integral) and not isinstance(blade, bool) and 0 <= int(blade) < N_BLADES:
        return int(blade)
    raise InvalidInputError(
        f"{what} must be a blade bitmask, an int in 0..{N_BLADES - 1} (bit 0 = e0, 1..3 = e1..e3, 4 = e∞), "
        f"got {blade!r} ({type(blade).__name__})"
    )


_GRADES = tuple(b.bit_count() for b in range(N_BLADES))


def grade_of(blade: int) -> int:
    """Grade (number of generators) of a blade bitmask."""
    if type(blade) is int and 0 <= blade < N_BLADES:
        return _GRADES[blade]
    return _GRADES[_blade_int(blade)]


def blade_name(blade: int) -> str:
    """Human-readable name, e.g. ``0b10110 -> 'e12∞'``; the scalar is ``'1'``."""
    blade = _blade_int(blade)
    if blade == 0:
        return "1"
    return "e" + "".join(GEN_NAMES[i] for i in range(N_GEN) if blade >> i & 1)


def blade_index(name: str) -> tuple[int, int]:
    """Parse a blade name into ``(bitmask, sign)``.

    Accepts ``'1'``, ``'e12'``, ``'e1∞'``, ``'e1inf'``, ``'e0inf'``, ``'e21'`` (→ sign −1).
    Raises :class:`~coop_ga.InvalidInputError` (a ``ValueError``) for anything else.
    """
    if not isinstance(name, str):
        raise InvalidInputError(
            f"blade name must be a string such as 'e12' or 'e1inf', got {name!r} ({type(name).__name__})"
        )
    return _blade_index(name)


@cache
def _blade_index(name: str) -> tuple[int, int]:
    if name in ("1", "", "scalar"):
        return 0, 1
    s = name.strip()
    if not s.startswith("e"):
        raise InvalidInputError(f"blade name must start with 'e' (e.g. 'e12', 'e1inf'), got {name!r}")
    s = s[1:].replace("inf", "∞")
    gens = []
    for ch in s:
        if ch not in _ASCII_GEN:
            raise InvalidInputError(f"unknown generator {ch!r} in blade name {name!r}; use 0,1,2,3,∞ (or 'inf')")
        gens.append(_ASCII_GEN[ch])
    if not gens:
        raise InvalidInputError(f"blade name {name!r} has no generators; use '1' for the scalar")
    if len(set(gens)) != len(gens):
        raise InvalidInputError(f"repeated generator in blade name {name!r}")
    # sign of the permutation that sorts gens
    sign = 1
    g = list(gens)
    for i in range(len(g)):
        for j in range(len(g) - 1 - i):
            if g[j] > g[j + 1]:
                g[j], g[j + 1] = g[j + 1], g[j]
                sign = -sign
    mask = 0
    for k in gens:
        mask |= 1 << k
    return mask, sign


BLADES_BY_GRADE: tuple[tuple[int, ...], ...] = tuple(
    tuple(b for b in range(N_BLADES) if grade_of(b) == k) for k in range(N_GEN + 1)
)


def _reorder_sign(a: int, b: int) -> int:
    """Sign of moving the generators of blade b past those of blade a (canonical order)."""
    a >>= 1
    swaps = 0
    while a:
        swaps += bin(a & b).count("1")
        a >>= 1
    return -1 if swaps & 1 else 1


# ---------------------------------------------------------------- orthogonal basis
# orthogonal generators f1, f2, f3, f4, f5 as bits 0..4 with squares +,+,+,+,-
_ORTHO_SQ = (1, 1, 1, 1, -1)


def _ortho_gp(a: int, b: int) -> tuple[int, int]:
    sign = _reorder_sign(a, b)
    common = a & b
    for i in range(N_GEN):
        if common >> i & 1:
            sign *= _ORTHO_SQ[i]
    return a ^ b, sign


def _outer_expand(vectors: list[dict[int, Fraction]]) -> dict[int, Fraction]:
    """Outer product of vectors given as {generator: coeff}; returns {blade: coeff}.

    The outer product is metric-free, so the same routine serves both bases.
    """
    out: dict[int, Fraction] = {0: Fraction(1)}
    for vec in vectors:
        new: dict[int, Fraction] = {}
        for blade, c in out.items():
            for gen, v in vec.items():
                bit = 1 << gen
                if blade & bit:
                    continue
                s = _reorder_sign(blade, bit)
                new[blade | bit] = new.get(blade | bit, Fraction(0)) + s * c * v
        out = {k: v for k, v in new.items() if v != 0}
    return out


# null generator -> orthogonal vector; orthogonal bit index: e1->0, e2->1, e3->2, e4->3, e5->4
_NULL_TO_ORTHO = {
    0: {4: Fraction(1, 2), 3: Fraction(-1, 2)},  # e0 = ½(e5 − e4)
    1: {0: Fraction(1)},
    2: {1: Fraction(1)},
    3: {2: Fraction(1)},
    4: {3: Fraction(1), 4: Fraction(1)},  # e∞ = e4 + e5
}
# orthogonal generator -> null vector; e4 = ½e∞ − e0, e5 = e0 + ½e∞
_ORTHO_TO_NULL = {
    0: {1: Fraction(1)},
    1: {2: Fraction(1)},
    2: {3: Fraction(1)},
    3: {4: Fraction(1, 2), 0: Fraction(-1)},
    4: {0: Fraction(1), 4: Fraction(1, 2)},
}


def _gens(blade: int) -> list[int]:
    return [i for i in range(N_GEN) if blade >> i & 1]


@cache
def _null_to_ortho(blade: int) -> tuple[tuple[int, Fraction], ...]:
    return tuple(_outer_expand([_NULL_TO_ORTHO[g] for g in _gens(blade)]).items())


@cache
def _ortho_to_null(blade: int) -> tuple[tuple[int, Fraction], ...]:
    return tuple(_outer_expand([_ORTHO_TO_NULL[g] for g in _gens(blade)]).items())


@cache
def _gp_null_blades(a: int, b: int) -> tuple[tuple[int, Fraction], ...]:
    acc: dict[int, Fraction] = {}
    for oa, ca in _null_to_ortho(a):
        for ob, cb in _null_to_ortho(b):
            oc, s = _ortho_gp(oa, ob)
            for nb, cn in _ortho_to_null(oc):
                acc[nb] = acc.get(nb, Fraction(0)) + s * ca * cb * cn
    return tuple(sorted((k, v) for k, v in acc.items() if v != 0))


@cache
def product_table() -> tuple[tuple[tuple[tuple[int, float], ...], ...], ...]:
    """``T[a][b]`` = tuple of ``(blade, coeff)`` with ``e_a e_b = Σ coeff e_blade`` (null basis)."""
    return tuple(
        tuple(tuple((k, float(v)) for k, v in _gp_null_blades(a, b)) for b in range(N_BLADES)) for a in range(N_BLADES)
    )


@cache
def outer_table() -> tuple[tuple[tuple[tuple[int, float], ...], ...], ...]:
    """``T[a][b]`` for the outer product: ``±e_{a|b}`` when a, b share no generator, else empty."""
    return tuple(
        tuple(((a | b, float(_reorder_sign(a, b))),) if not a & b else () for b in range(N_BLADES))
        for a in range(N_BLADES)
    )


def metric(i: int, j: int) -> float:
    """Inner product of null-basis generators ``e_i · e_j`` (bit indices)."""
    return float(_G_NULL[i][j])
