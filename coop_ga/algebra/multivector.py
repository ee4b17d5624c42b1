"""Sparse multivectors of CGA G(4,1), generic over the coefficient type.

A :class:`Multivector` stores only the blades it structurally has (a sorted tuple of
blade bitmasks, see :mod:`coop_ga.algebra.basis`) and one coefficient per blade.  A
coefficient may be a python float, a numpy array (all blades share one shape: a
batch), or a CasADi SX/MX expression; the algebra itself only uses ``+``, ``-`` and
``*`` on coefficients.

Products are *compiled*: for each pair of blade patterns and each product kind, a
straight-line python function is generated from the exact tables once and cached.
So a motor×motor product touches 8×8 blade pairs, never a dense 32×32 table, and on
CasADi it emits exactly the scalar graph that is needed.  On CasADi SX, result blades
that CasADi proves to be zero are dropped, which keeps symbolic graphs small.

Operators: ``*`` geometric product, ``^`` outer product, ``|`` left contraction,
``~`` reverse, ``+ - /`` as usual (``/`` by a scalar or by an invertible multivector).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from ..errors import InvalidInputError, InvalidVersorError, NonFiniteError
from . import backend as B
from .basis import (
    BLADES_BY_GRADE,
    N_BLADES,
    blade_index,
    blade_name,
    grade_of,
    outer_table,
    product_table,
)

__all__ = ["Multivector", "PSEUDOSCALAR_BLADE"]

PSEUDOSCALAR_BLADE = N_BLADES - 1  # e0∧e1∧e2∧e3∧e∞

# reverse sign by grade: (-1)^{k(k-1)/2}
_REV_SIGN = tuple(1 if (k * (k - 1) // 2) % 2 == 0 else -1 for k in range(6))
_INV_SIGN = tuple(1 if k % 2 == 0 else -1 for k in range(6))  # grade involution

_PLANS: dict[tuple[str, tuple[int, ...], tuple[int, ...]], tuple[tuple[int, ...], Any]] = {}


def _left_contraction_table():
    gp = product_table()
    out = []
    for a in range(N_BLADES):
        row = []
        for b in range(N_BLADES):
            ga, gb = grade_of(a), grade_of(b)
            if ga > gb:
                row.append(())
            else:
                row.append(tuple((k, c) for k, c in gp[a][b] if grade_of(k) == gb - ga))
        out.append(tuple(row))
    return tuple(out)


def _scalar_product_table():
    gp = product_table()
    return tuple(tuple(tuple((k, c) for k, c in gp[a][b] if k == 0) for b in range(N_BLADES)) for a in range(N_BLADES))


_TABLES = {"gp": product_table, "op": outer_table, "lc": _left_contraction_table, "sp": _scalar_product_table}
_TABLE_CACHE: dict[str, Any] = {}


def _table(kind: str):
    t = _TABLE_CACHE.get(kind)
    if t is None:
        t = _TABLE_CACHE[kind] = _TABLES[kind]()
    return t


def _fmt_coef(c: float) -> str:
    return repr(float(c))


def _plan(kind: str, ba: tuple[int, ...], bb: tuple[int, ...]):
    """Return (result_blades, fn) where fn(a_coeffs, b_coeffs) -> tuple of result coeffs."""
    key = (kind, ba, bb)
    plan = _PLANS.get(key)
    if plan is not None:
        return plan
    table = _table(kind)
    terms: dict[int, dict[tuple[int, int], float]] = {}
    for i, a in enumerate(ba):
        row = table[a]
        for j, b in enumerate(bb):
            for k, c in row[b]:
                d = terms.setdefault(k, {})
                d[(i, j)] = d.get((i, j), 0.0) + c
    res_blades = []
    exprs = []
    for k in sorted(terms):
        parts = []
        for (i, j), c in terms[k].items():
            if c == 0.0:
                continue
            prod = f"a[{i}]*b[{j}]"
            if c == 1.0:
                parts.append(("+", prod))
            elif c == -1.0:
                parts.append(("-", prod))
            elif c > 0:
                parts.append(("+", f"{_fmt_coef(c)}*{prod}"))
            else:
                parts.append(("-", f"{_fmt_coef(-c)}*{prod}"))
        if not parts:
            continue
        s = ("-" if parts[0][0] == "-" else "") + parts[0][1]
        for sign, p in parts[1:]:
            s += f" {sign} {p}"
        res_blades.append(k)
        exprs.append(s)
    src = "def _f(a, b):\n    return (" + "".join(e + ", " for e in exprs) + ")\n"
    ns: dict[str, Any] = {}
    exec(compile(src, f"<coop_ga {kind} plan>", "exec"), ns)  # noqa: S102 - generated from exact tables
    plan = (tuple(res_blades), ns["_f"])
    _PLANS[key] = plan
    return plan


def _is_scalar_like(x: Any) -> bool:
    if isinstance(x, (int, float, np.floating, np.integer)):
        return True
    if isinstance(x, np.ndarray):
        return True  # a batch of scalars
    if B.is_symbolic(x):
        return x.shape == (1, 1)
    return False


class Multivector:
    """A sparse multivector of G(4,1) in the null basis {e0, e1, e2, e3, e∞}.

    Parameters
    ----------
    blades:
        Sorted tuple of blade bitmasks (bit 0 = e0, 1..3 = e1..e3, 4 = e∞).
    coeffs:
        One coefficient per blade: float, numpy array (batch) or CasADi SX/MX.

    Use :meth:`from_dict` or :meth:`from_names` to build from a mapping.
    """

    __slots__ = ("blades", "coeffs")

    def __init__(self, blades: tuple[int, ...], coeffs: tuple[Any, ...]):
        self.blades = blades
        self.coeffs = coeffs

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_dict(cls, d: Mapping[int, Any]) -> Multivector:
        """From ``{blade_bitmask: coeff}``; missing blades are zero."""
        items = sorted(d.items())
        return cls(tuple(k for k, _ in items), tuple(v for _, v in items))

    @classmethod
    def from_names(cls, d: Mapping[str, Any]) -> Multivector:
        """From ``{'e12': 1.0, 'e1inf': 0.5, ...}`` (names as in :func:`basis.blade_index`)."""
        acc: dict[int, Any] = {}
        for name, v in d.items():
            k, s = blade_index(name)
            acc[k] = acc[k] + s * v if k in acc else (v if s == 1 else -v)
        return cls.from_dict(acc)

    @classmethod
    def scalar(cls, s: Any) -> Multivector:
        return cls((0,), (s,))

    @classmethod
    def zero(cls) -> Multivector:
        return cls((), ())

    @classmethod
    def blade(cls, name: str, coeff: Any = 1.0) -> Multivector:
        k, s = blade_index(name)
        return cls((k,), (coeff if s == 1 else -coeff,))

    @classmethod
    def from_dense(cls, x: Any, blades: Iterable[int] | None = None) -> Multivector:
        """From a dense 32-vector (or its entries at ``blades``), numpy or CasADi."""
        if blades is None:
            blades = range(N_BLADES)
        blades = tuple(blades)
        return cls(blades, tuple(x[i] for i in range(len(blades))))

    # ------------------------------------------------------------------ access
    def __getitem__(self, name: str | int) -> Any:
        """Coefficient of a blade, by name (``'e12'``, ``'e1inf'``) or bitmask; 0 if absent."""
        if isinstance(name, str):
            k, s = blade_index(name)
        else:
            k, s = int(name), 1
        try:
            c = self.coeffs[self.blades.index(k)]
        except ValueError:
            return 0.0
        return c if s == 1 else -c

    def get(self, blade: int) -> Any:
        """Coefficient at a blade bitmask (0.0 if structurally absent)."""
        try:
            return self.coeffs[self.blades.index(blade)]
        except ValueError:
            return 0.0

    def as_dict(self) -> dict[int, Any]:
        return dict(zip(self.blades, self.coeffs))

    def to_dense(self) -> np.ndarray:
        """Dense numpy array of shape (32,) (or (32, *batch)); numeric coefficients only."""
        if any(B.is_symbolic(c) for c in self.coeffs):
            raise InvalidInputError("to_dense() needs numeric coefficients; use .coeffs for CasADi expressions")
        shape = np.broadcast_shapes(*(np.shape(c) for c in self.coeffs)) if self.coeffs else ()
        out = np.zeros((N_BLADES, *shape))
        for k, c in zip(self.blades, self.coeffs):
            out[k] = c
        return out

    @property
    def grades(self) -> tuple[int, ...]:
        """Grades structurally present."""
        return tuple(sorted({grade_of(b) for b in self.blades}))

    @property
    def is_symbolic(self) -> bool:
        return any(B.is_symbolic(c) for c in self.coeffs)

    # ------------------------------------------------------------------ linear ops
    def _combine(self, other: Multivector, sign: int) -> Multivector:
        d = dict(zip(self.blades, self.coeffs))
        for k, c in zip(other.blades, other.coeffs):
            if k in d:
                d[k] = d[k] + c if sign > 0 else d[k] - c
            else:
                d[k] = c if sign > 0 else -c
        return Multivector.from_dict(d)

    def __add__(self, other: Any) -> Multivector:
        if isinstance(other, Multivector):
            return self._combine(other, 1)
        if _is_scalar_like(other):
            return self._combine(Multivector.scalar(other), 1)
        return NotImplemented

    __radd__ = __add__

    def __sub__(self, other: Any) -> Multivector:
        if isinstance(other, Multivector):
            return self._combine(other, -1)
        if _is_scalar_like(other):
            return self._combine(Multivector.scalar(other), -1)
        return NotImplemented

    def __rsub__(self, other: Any) -> Multivector:
        return (-self) + other

    def __neg__(self) -> Multivector:
        return Multivector(self.blades, tuple(-c for c in self.coeffs))

    def scale(self, s: Any) -> Multivector:
        """Multiply every coefficient by the scalar ``s``."""
        return Multivector(self.blades, tuple(c * s for c in self.coeffs))

    # ------------------------------------------------------------------ products
    def _product(self, other: Multivector, kind: str) -> Multivector:
        blades, fn = _plan(kind, self.blades, other.blades)
        coeffs = fn(self.coeffs, other.coeffs)
        if coeffs and any(B.is_symbolic(c) for c in coeffs):
            keep = [i for i, c in enumerate(coeffs) if not B.is_structural_zero(c)]
            if len(keep) != len(coeffs):
                return Multivector(tuple(blades[i] for i in keep), tuple(coeffs[i] for i in keep))
        return Multivector(blades, coeffs)

    def __mul__(self, other: Any) -> Multivector:
        """Geometric product (or scaling by a scalar)."""
        if isinstance(other, Multivector):
            return self._product(other, "gp")
        if _is_scalar_like(other):
            return self.scale(other)
        return NotImplemented

    def __rmul__(self, other: Any) -> Multivector:
        if _is_scalar_like(other):
            return self.scale(other)
        return NotImplemented

    def __xor__(self, other: Any) -> Multivector:
        """Outer product."""
        if isinstance(other, Multivector):
            return self._product(other, "op")
        if _is_scalar_like(other):
            return self.scale(other)
        return NotImplemented

    def __rxor__(self, other: Any) -> Multivector:
        if _is_scalar_like(other):
            return self.scale(other)
        return NotImplemented

    def __or__(self, other: Any) -> Multivector:
        """Left contraction ``self ⌋ other`` (the paper's inner product ``·``)."""
        if isinstance(other, Multivector):
            return self._product(other, "lc")
        return NotImplemented

    def gp(self, other: Multivector) -> Multivector:
        return self._product(other, "gp")

    def outer(self, other: Multivector) -> Multivector:
        return self._product(other, "op")

    def lc(self, other: Multivector) -> Multivector:
        """Left contraction."""
        return self._product(other, "lc")

    def scalar_product(self, other: Multivector) -> Any:
        """``<self other>_0`` as a coefficient."""
        return self._product(other, "sp").get(0)

    def __truediv__(self, other: Any) -> Multivector:
        if isinstance(other, Multivector):
            return self * other.inverse()
        if _is_scalar_like(other):
            return self.scale(1.0 / other)
        return NotImplemented

    # ------------------------------------------------------------------ involutions
    def reverse(self) -> Multivector:
        """Reverse X̃: the order of every blade's vectors reversed."""
        return Multivector(
            self.blades, tuple(c if _REV_SIGN[grade_of(k)] > 0 else -c for k, c in zip(self.blades, self.coeffs))
        )

    __invert__ = reverse

    def involute(self) -> Multivector:
        """Grade involution X̂ = Σ (−1)^k <X>_k."""
        return Multivector(
            self.blades, tuple(c if _INV_SIGN[grade_of(k)] > 0 else -c for k, c in zip(self.blades, self.coeffs))
        )

    def grade(self, *ks: int) -> Multivector:
        """Grade projection <X>_k (several grades may be given)."""
        keep = [i for i, b in enumerate(self.blades) if grade_of(b) in ks]
        return Multivector(tuple(self.blades[i] for i in keep), tuple(self.coeffs[i] for i in keep))

    def project(self, blades: Iterable[int]) -> Multivector:
        """Keep only the given blades (a structural projection onto a known subspace)."""
        bs = set(blades)
        keep = [i for i, b in enumerate(self.blades) if b in bs]
        return Multivector(tuple(self.blades[i] for i in keep), tuple(self.coeffs[i] for i in keep))

    def with_blades(self, blades: tuple[int, ...]) -> Multivector:
        """Same multivector laid out on exactly ``blades`` (zeros filled in, others must be absent)."""
        d = self.as_dict()
        extra = set(d) - set(blades)
        if extra:
            raise InvalidInputError(
                f"multivector has blades {[blade_name(b) for b in sorted(extra)]} outside the requested layout"
            )
        return Multivector(tuple(blades), tuple(d.get(b, 0.0) for b in blades))

    # ------------------------------------------------------------------ duality, norm, inverse
    def dual(self) -> Multivector:
        """Dual X* = X I⁻¹ with I = e0∧e1∧e2∧e3∧e∞ (I⁻¹ = −I)."""
        return self * Multivector((PSEUDOSCALAR_BLADE,), (-1.0,))

    def undual(self) -> Multivector:
        """Inverse of :meth:`dual`: X I."""
        return self * Multivector((PSEUDOSCALAR_BLADE,), (1.0,))

    def norm_squared(self) -> Any:
        """``<X X̃>_0`` (may be negative in this indefinite metric)."""
        return self.scalar_product(self.reverse())

    def norm(self) -> Any:
        """``sqrt(|<X X̃>_0|)``."""
        return B.sqrt(B.fabs(self.norm_squared()))

    def inverse(self) -> Multivector:
        """X⁻¹ = X̃ (X X̃)⁻¹ (paper Eq 80); valid when X X̃ is a scalar (versors, blades).

        Raises
        ------
        InvalidVersorError
            If X X̃ is zero or (numerically) not a scalar.
        """
        xx = self * self.reverse()
        s = xx.get(0)
        if not self.is_symbolic:
            s_arr = np.asarray(s, dtype=float)
            rest = xx.grade(1, 2, 3, 4, 5)
            big = max([float(np.max(np.abs(c))) for c in self.coeffs] + [0.0])
            tol = 1e-9 * max(big * big, 1e-300)
            if np.any(np.abs(s_arr) <= tol):
                raise InvalidVersorError(
                    "cannot invert a multivector with X·X̃ = 0 (zero norm or null blade); "
                    "check that it is a versor or a non-null blade"
                )
            if rest.coeffs and max(float(np.max(np.abs(c))) for c in rest.coeffs) > 1e-7 * max(big * big, 1e-300):
                raise InvalidVersorError(
                    "X·X̃ is not a scalar, so Eq 80 does not apply; only versors and blades are invertible here"
                )
        return self.reverse().scale(1.0 / s)

    # ------------------------------------------------------------------ numerics
    def check_finite(self, what: str = "multivector") -> Multivector:
        """Raise :class:`NonFiniteError` if any numeric coefficient is NaN or inf."""
        for k, c in zip(self.blades, self.coeffs):
            if not B.is_symbolic(c) and not np.all(np.isfinite(c)):
                raise NonFiniteError(f"{what} has a non-finite coefficient on {blade_name(k)}: {c!r}")
        return self

    def prune(self, tol: float = 0.0) -> Multivector:
        """Drop numeric blades with ``|coeff| <= tol`` (and symbolic structural zeros)."""
        keep = []
        for i, c in enumerate(self.coeffs):
            if B.is_symbolic(c):
                if not B.is_structural_zero(c):
                    keep.append(i)
            elif np.any(np.abs(c) > tol):
                keep.append(i)
        return Multivector(tuple(self.blades[i] for i in keep), tuple(self.coeffs[i] for i in keep))

    def allclose(self, other: Multivector, atol: float = 1e-9, rtol: float = 1e-9) -> bool:
        """Numeric comparison of two multivectors (absent blades count as zero)."""
        a, b = self.to_dense(), other.to_dense()
        return bool(np.allclose(a, b, atol=atol, rtol=rtol))

    def __repr__(self) -> str:
        if not self.blades:
            return "Multivector(0)"
        parts = []
        for k, c in zip(self.blades, self.coeffs):
            if B.is_symbolic(c):
                cs = str(c)
            elif np.ndim(c):
                cs = f"array{np.shape(c)}"
            else:
                cs = f"{c:.6g}"
            parts.append(f"{cs}" if k == 0 else f"{cs}*{blade_name(k)}")
        return "Multivector(" + " + ".join(parts) + ")"

    def __iter__(self):  # guard against accidental numpy coercion
        raise TypeError("Multivector is not iterable; use .blades/.coeffs or .to_dense()")

    __array_ufunc__ = None  # so that ndarray * Multivector defers to our __rmul__


def grade_blades(*ks: int) -> tuple[int, ...]:
    """All blade bitmasks of the given grades, sorted."""
    return tuple(sorted(b for k in ks for b in BLADES_BY_GRADE[k]))
