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

import math
import numbers
from collections.abc import Callable, Iterable, Mapping
from numbers import Integral
from typing import Any, TypeAlias

import numpy as np

from ..errors import InvalidInputError, InvalidVersorError, NonFiniteError
from . import backend as B
from .basis import (
    BLADES_BY_GRADE,
    N_BLADES,
    _blade_int,
    blade_index,
    blade_name,
    grade_of,
    outer_table,
    product_table,
)

__all__ = ["OMEGA", "PSEUDOSCALAR_BLADE", "Multivector", "balance_exponents", "coeff_problem", "safe_range"]

_EPS = float(np.finfo(float).eps)
_F64 = np.float64

#: ``OMEGA[b] = #e∞ − #e0`` of blade ``b``: the weight of its coefficient under the dilation
#: automorphism ``X ↦ D X D̃`` (scale factor σ multiplies it by ``σ^OMEGA[b]``).  Numeric code
#: rescales by exact powers of two along this grading (and overall) before squaring, so no
#: intermediate overflows or underflows; see :func:`balance_exponents`.
OMEGA = tuple(((b >> 4) & 1) - (b & 1) for b in range(N_BLADES))


class _NotIterableError(InvalidInputError, TypeError):
    """Iterating over a Multivector (a TypeError for Python's protocols, and a CoopGAError)."""


def coeff_problem(c: Any) -> str | None:
    """Why ``c`` is not an acceptable numeric coefficient (None if it is).

    Accepted: python ints/floats (not bools), numpy integer/float scalars and arrays, and
    CasADi SX/MX expressions.  (The raw container ``Multivector(blades, coeffs)`` also holds
    other real number types, e.g. :class:`fractions.Fraction` for exact references; the
    numeric functions of coop_ga reject them.)  Rejected: booleans, complex numbers (the imaginary part
    would be silently dropped), strings, None, containers, object arrays, ints beyond the
    float range.  Finiteness is checked separately (:meth:`Multivector.check_finite`).
    """
    t = type(c)
    if t is float:
        return None
    if t is int:
        if abs(c) > 1e308:
            return f"an integer with {len(str(abs(c)))} digits is outside the float range (|x| < 1.8e308)"
        return None
    if B.is_symbolic(c):
        return None
    if isinstance(c, (bool, np.bool_)):
        return f"a boolean ({c!r}) is not a number here"
    if isinstance(c, (complex, np.complexfloating)):
        return f"complex value {c!r}: only real coefficients are supported (the imaginary part would be lost)"
    if isinstance(c, (np.floating, np.integer)):
        return None
    if isinstance(c, Integral):
        return None if abs(int(c)) <= 1e308 else "an integer outside the float range (|x| < 1.8e308)"
    if isinstance(c, np.ndarray):
        k = c.dtype.kind
        if k in "fiu":
            return None
        if k == "c":
            return f"a complex array (dtype {c.dtype}): only real coefficients are supported"
        return f"an array of dtype {c.dtype} (booleans, strings, objects are not numbers here)"
    if isinstance(c, float):  # float subclasses
        return None
    return f"a {t.__name__} ({_short(c)}) is not a real number"


def _short(x: Any, n: int = 60) -> str:
    try:
        r = repr(x)
    except Exception:  # pragma: no cover - a broken __repr__ must not hide the real error
        r = object.__repr__(x)
    return r if len(r) <= n else r[: n - 3] + "..."


def _absmax(c: Any) -> float:
    t = type(c)
    if t is float or t is _F64:
        return abs(c)
    return float(np.max(np.abs(c))) if np.ndim(c) else abs(float(c))


def _exponents(X: Multivector) -> list[tuple[int, int]]:
    """``(OMEGA[b], binary exponent of max |coeff|)`` per non-zero numeric coefficient."""
    out = []
    frexp = math.frexp
    for b, c in zip(X.blades, X.coeffs):
        t = type(c)
        a = c if (t is float or t is _F64) else _absmax(c)
        if a != 0.0 and math.isfinite(a):
            out.append((OMEGA[b], frexp(a)[1]))
    return out


def balance_exponents(*Xs: Multivector) -> tuple[int, list[int]]:
    """Exact power-of-two rescaling that brings numeric multivectors to unit size.

    Returns ``(k, [l_1, ...])``: multiplying every coefficient on blade ``b`` of ``X_i`` by
    ``2**(l_i − k·OMEGA[b])`` applies the dilation automorphism by ``2**−k`` (shared by all
    ``X_i``, so products are consistent) and an overall ``2**l_i``, after which the
    e0-, e∞- and e0/e∞-free parts are of comparable size and the largest coefficient is in
    [0.5, 1).  Geometric results are invariant (scale-free quantities) or covariant
    (positions and lengths scale by ``2**−k``, exactly).
    """
    exps = [_exponents(X) for X in Xs]
    e: dict[int, int] = {}
    for ex in exps:
        for w, x in ex:
            if w not in e or x > e[w]:
                e[w] = x
    if -1 in e and 1 in e:
        k = (e[1] - e[-1]) // 2
    elif 1 in e and 0 in e:
        k = e[1] - e[0]
    elif -1 in e and 0 in e:
        k = e[0] - e[-1]
    else:
        k = 0
    ls = [-max(x - k * w for w, x in ex) if ex else 0 for ex in exps]
    return k, ls


def safe_range(*Xs: Multivector, lim: int = 250) -> bool:
    """True if every non-zero coefficient of the numeric ``Xs`` has a binary exponent within
    ±lim: products of up to ~1000/lim factors can then neither overflow nor underflow, and
    rescaling by powers of two (which is exact) would not change any result."""
    frexp = math.frexp
    for X in Xs:
        for c in X.coeffs:
            t = type(c)
            if t is float or t is _F64:
                if c != 0.0:
                    e = frexp(c)[1]
                    if e > lim or e < -lim:
                        return False
            else:
                a = np.abs(np.asarray(c, dtype=float))
                nz = a[a > 0]
                if nz.size and (float(nz.max()) > 2.0**lim or float(nz.min()) < 2.0**-lim):
                    return False
    return True


def _ldexp(c: Any, e: int) -> Any:
    """c · 2**e exactly (inf on overflow, like numpy; 0 on underflow)."""
    t = type(c)
    if t is float or t is _F64:
        try:
            return math.ldexp(c, e)
        except OverflowError:
            return math.copysign(math.inf, c)
    v = np.ldexp(c, e)
    return float(v) if np.ndim(v) == 0 else v


PSEUDOSCALAR_BLADE = N_BLADES - 1  # e0∧e1∧e2∧e3∧e∞

# reverse sign by grade: (-1)^{k(k-1)/2}
_REV_SIGN = tuple(1 if (k * (k - 1) // 2) % 2 == 0 else -1 for k in range(6))
_INV_SIGN = tuple(1 if k % 2 == 0 else -1 for k in range(6))  # grade involution

_PLANS: dict[tuple[str, tuple[int, ...], tuple[int, ...]], tuple[tuple[int, ...], Any]] = {}

_Terms: TypeAlias = tuple[tuple[int, float], ...]  # (blade, coeff) pairs of e_a e_b
_Table: TypeAlias = tuple[tuple[_Terms, ...], ...]  # T[a][b], as basis.product_table


def _left_contraction_table() -> _Table:
    gp = product_table()
    out: list[tuple[_Terms, ...]] = []
    for a in range(N_BLADES):
        row: list[_Terms] = []
        for b in range(N_BLADES):
            ga, gb = grade_of(a), grade_of(b)
            if ga > gb:
                row.append(())
            else:
                row.append(tuple((k, c) for k, c in gp[a][b] if grade_of(k) == gb - ga))
        out.append(tuple(row))
    return tuple(out)


def _scalar_product_table() -> _Table:
    gp = product_table()
    return tuple(tuple(tuple((k, c) for k, c in gp[a][b] if k == 0) for b in range(N_BLADES)) for a in range(N_BLADES))


_TABLES: dict[str, Callable[[], _Table]] = {
    "gp": product_table,
    "op": outer_table,
    "lc": _left_contraction_table,
    "sp": _scalar_product_table,
}
_TABLE_CACHE: dict[str, _Table] = {}


def _table(kind: str) -> _Table:
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
    exec(compile(src, f"<coop_ga {kind} plan>", "exec"), ns)
    plan = (tuple(res_blades), ns["_f"])
    _PLANS[key] = plan
    return plan


def _as_layout(blades: Any, coeffs: Any) -> tuple[tuple[int, ...], tuple[Any, ...]]:
    """Validate a user-given (blades, coeffs) layout: blades are distinct ints 0..31."""
    if isinstance(blades, (str, bytes, Mapping)) or not isinstance(blades, Iterable):
        raise InvalidInputError(
            f"Multivector blades must be a tuple of blade bitmasks (ints 0..31), got {_short(blades)}"
        )
    if isinstance(coeffs, (str, bytes, Mapping)) or not isinstance(coeffs, Iterable):
        raise InvalidInputError(f"Multivector coeffs must be a tuple of coefficients, got {_short(coeffs)}")
    bl = tuple(_blade_int(b, "Multivector blade") for b in blades)
    if len(set(bl)) != len(bl):
        raise InvalidInputError(f"Multivector blades must be distinct, got {bl}")
    return bl, tuple(coeffs)


_BAD_OPERANDS = (str, bytes, bytearray, list, tuple, dict, set, frozenset, complex, type(None), np.complexfloating, int)


def _is_scalar_like(x: Any) -> bool:
    t = type(x)
    if t is float:
        return True
    if t is int:
        return abs(x) <= 1e308
    if isinstance(x, (bool, np.bool_)):
        return False
    if isinstance(x, (int, float, np.floating, np.integer)):
        return True
    if isinstance(x, np.ndarray):
        return x.dtype.kind in "fiu"  # a batch of real scalars
    if B.is_symbolic(x):
        return x.shape == (1, 1)
    return False


def _require_coeff(c: Any, what: str) -> None:
    why = coeff_problem(c)
    if why is not None:
        raise InvalidInputError(f"{what}: {why}")
    if not B.is_symbolic(c) and not np.all(np.isfinite(c)):
        raise NonFiniteError(f"{what} is not finite: {_short(c)}")


def _bad_operand(op: str, x: Any) -> InvalidInputError:
    what = coeff_problem(x) if not isinstance(x, np.ndarray) or x.dtype.kind not in "fiu" else None
    why = what or f"a {type(x).__name__} is neither a Multivector nor a real scalar"
    return InvalidInputError(f"Multivector {op}: the other operand is invalid: {why}")


_REFLECTED = {"+": "__radd__", "-": "__rsub__", "*": "__rmul__", "^": "__rxor__", "|": "__ror__", "/": "__rtruediv__"}


def _check_operand(op: str, x: Any) -> None:
    """Raise for operands that no other type can handle (strings, None, complex, containers, bools,
    objects without the reflected operator); other types get ``NotImplemented`` (e.g. group elements)."""
    if isinstance(x, (*_BAD_OPERANDS, bool, np.bool_)) or (isinstance(x, np.ndarray) and x.dtype.kind not in "fiu"):
        raise _bad_operand(op, x)
    name = _REFLECTED.get(op)
    if name is not None and not any(name in k.__dict__ for k in type(x).__mro__):  # (not the metaclass's)
        raise _bad_operand(op, x)


class Multivector:
    """A sparse multivector of G(4,1) in the null basis {e0, e1, e2, e3, e∞}.

    Args:
        blades:
            Sorted tuple of blade bitmasks (bit 0 = e0, 1..3 = e1..e3, 4 = e∞).
        coeffs:
            One coefficient per blade: float, numpy array (batch) or CasADi SX/MX.

    Use :meth:`from_dict` or :meth:`from_names` to build from a mapping.
    """

    __slots__ = ("blades", "coeffs")

    def __init__(self, blades: tuple[int, ...], coeffs: tuple[Any, ...]):
        if type(blades) is not tuple or type(coeffs) is not tuple:
            blades, coeffs = _as_layout(blades, coeffs)
        if len(blades) != len(coeffs):
            raise InvalidInputError(
                f"Multivector(blades, coeffs) needs one coefficient per blade, got {len(blades)} blades "
                f"and {len(coeffs)} coefficients"
            )
        for i, c in enumerate(coeffs):
            t = type(c)
            if t is not float and t is not _F64:
                why = coeff_problem(c)
                if why is not None and not (isinstance(c, numbers.Real) and not isinstance(c, (bool, np.bool_))):
                    raise InvalidInputError(f"Multivector coefficient {i} (on blade {blades[i]!r}) is invalid: {why}")
        self.blades = blades
        self.coeffs = coeffs

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_dict(cls, d: Mapping[int, Any]) -> Multivector:
        """From ``{blade_bitmask: coeff}``; missing blades are zero."""
        if not isinstance(d, Mapping):
            raise InvalidInputError(
                f"Multivector.from_dict needs a mapping {{blade bitmask: coefficient}}, got {_short(d)}"
            )
        items = sorted((_blade_int(k, "Multivector.from_dict key"), v) for k, v in d.items())
        for k, v in items:
            _require_coeff(v, f"Multivector.from_dict coefficient of {blade_name(k)}")
        return cls(tuple(k for k, _ in items), tuple(v for _, v in items))

    @classmethod
    def from_names(cls, d: Mapping[str, Any]) -> Multivector:
        """From ``{'e12': 1.0, 'e1inf': 0.5, ...}`` (names as in :func:`basis.blade_index`)."""
        if not isinstance(d, Mapping):
            raise InvalidInputError(
                f"Multivector.from_names needs a mapping {{blade name: coefficient}}, got {_short(d)}"
            )
        acc: dict[int, Any] = {}
        for name, v in d.items():
            k, s = blade_index(name)
            _require_coeff(v, f"Multivector.from_names coefficient of {name!r}")
            acc[k] = acc[k] + s * v if k in acc else (v if s == 1 else -v)
        return cls.from_dict(acc)

    @classmethod
    def scalar(cls, s: Any) -> Multivector:
        _require_coeff(s, "Multivector.scalar(s)")
        return cls((0,), (s,))

    @classmethod
    def zero(cls) -> Multivector:
        return cls((), ())

    @classmethod
    def blade(cls, name: str, coeff: Any = 1.0) -> Multivector:
        k, s = blade_index(name)
        _require_coeff(coeff, f"Multivector.blade({name!r}, coeff)")
        return cls((k,), (coeff if s == 1 else -coeff,))

    @classmethod
    def from_dense(cls, x: Any, blades: Iterable[int] | None = None) -> Multivector:
        """From a dense 32-vector (or its entries at ``blades``), numpy or CasADi."""
        if blades is None:
            blades = range(N_BLADES)
        if isinstance(blades, (str, bytes)) or not isinstance(blades, Iterable):
            raise InvalidInputError(f"Multivector.from_dense blades must be blade bitmasks, got {_short(blades)}")
        blades = tuple(_blade_int(b, "Multivector.from_dense blade") for b in blades)
        n = len(blades)
        if B.is_symbolic(x):
            if x.numel() < n:
                raise InvalidInputError(
                    f"Multivector.from_dense needs {n} entries, got a CasADi expression of shape {x.shape}"
                )
            return cls(blades, tuple(x[i] for i in range(n)))
        if isinstance(x, (str, bytes, Mapping)) or x is None:
            raise InvalidInputError(f"Multivector.from_dense needs {n} real numbers, got {_short(x)}")
        try:
            a = np.asarray(x)
        except (TypeError, ValueError, OverflowError) as exc:
            raise InvalidInputError(f"Multivector.from_dense needs {n} real numbers: {exc}") from None
        if a.dtype.kind not in "fiu":
            raise InvalidInputError(f"Multivector.from_dense needs real numbers, got dtype {a.dtype}")
        if a.ndim < 1 or a.shape[0] != n:
            raise InvalidInputError(f"Multivector.from_dense needs {n} entries (one per blade), got shape {a.shape}")
        a = a.astype(float)
        if not np.all(np.isfinite(a)):
            raise NonFiniteError("Multivector.from_dense: x contains NaN or inf")
        return cls(blades, tuple(float(a[i]) if a.ndim == 1 else a[i].copy() for i in range(n)))

    # ------------------------------------------------------------------ access
    def __getitem__(self, name: str | int) -> Any:
        """Coefficient of a blade, by name (``'e12'``, ``'e1inf'``) or bitmask; 0 if absent."""
        if isinstance(name, str):
            k, s = blade_index(name)
        else:
            k, s = _blade_int(name, "blade index"), 1
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
            if type(blade) is not int or not 0 <= blade < N_BLADES:
                _blade_int(blade, "Multivector.get(blade)")
            return 0.0

    def as_dict(self) -> dict[int, Any]:
        return dict(zip(self.blades, self.coeffs))

    def to_dense(self) -> np.ndarray:
        """Dense numpy array of shape (32,) (or (32, *batch)); numeric coefficients only."""
        if any(B.is_symbolic(c) for c in self.coeffs):
            raise InvalidInputError("to_dense() needs numeric coefficients; use .coeffs for CasADi expressions")
        self._check_types("multivector")
        shape = self._batch_shape("multivector")
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
        try:
            for k, c in zip(other.blades, other.coeffs):
                if k in d:
                    d[k] = d[k] + c if sign > 0 else d[k] - c
                else:
                    d[k] = c if sign > 0 else -c
        except (TypeError, ValueError, OverflowError) as exc:
            raise self._op_error("+" if sign > 0 else "-", other, exc) from None
        items = sorted(d.items())
        return Multivector(tuple(k for k, _ in items), tuple(v for _, v in items))

    def _op_error(self, op: str, other: Any, exc: Exception) -> InvalidInputError:
        for who, X in (("left", self), ("right", other)):
            if isinstance(X, Multivector):
                for k, c in zip(X.blades, X.coeffs):
                    why = coeff_problem(c)
                    if why is not None:
                        return InvalidInputError(
                            f"Multivector {op}: the {who} operand's coefficient on {blade_name(k)} is {why}"
                        )
        if isinstance(other, Multivector):
            try:
                self._batch_shape("left operand")
                other._batch_shape("right operand")
                np.broadcast_shapes(self._batch_shape("left operand"), other._batch_shape("right operand"))
            except InvalidInputError as e2:
                return e2
            except ValueError:
                return InvalidInputError(f"Multivector {op}: the operands' batch shapes do not broadcast")
        return InvalidInputError(f"Multivector {op} failed on these coefficients: {exc}")

    def __add__(self, other: Any) -> Multivector:
        if isinstance(other, Multivector):
            return self._combine(other, 1)
        if _is_scalar_like(other):
            return self._combine(Multivector((0,), (other,)), 1)
        _check_operand("+", other)
        return NotImplemented

    __radd__ = __add__

    def __sub__(self, other: Any) -> Multivector:
        if isinstance(other, Multivector):
            return self._combine(other, -1)
        if _is_scalar_like(other):
            return self._combine(Multivector((0,), (other,)), -1)
        _check_operand("-", other)
        return NotImplemented

    def __rsub__(self, other: Any) -> Multivector:
        if not isinstance(other, Multivector) and not _is_scalar_like(other):
            _check_operand("-", other)
            return NotImplemented
        return (-self) + other

    def __neg__(self) -> Multivector:
        try:
            return Multivector(self.blades, tuple(-c for c in self.coeffs))
        except (TypeError, ValueError, OverflowError) as exc:
            raise self._op_error("negation", None, exc) from None

    def scale(self, s: Any) -> Multivector:
        """Multiply every coefficient by the scalar ``s``."""
        if type(s) is not float and not _is_scalar_like(s):
            raise _bad_operand("scale(s)", s)
        try:
            return Multivector(self.blades, tuple(c * s for c in self.coeffs))
        except (TypeError, ValueError, OverflowError) as exc:
            raise self._op_error("scale", None, exc) from None

    # ------------------------------------------------------------------ products
    def _product(self, other: Multivector, kind: str) -> Multivector:
        try:
            blades, fn = _plan(kind, self.blades, other.blades)
        except (IndexError, TypeError):
            for X in (self, other):
                for b in X.blades:
                    _blade_int(b, "Multivector blade")
            raise
        try:
            coeffs = fn(self.coeffs, other.coeffs)
        except (TypeError, ValueError, OverflowError) as exc:
            raise self._op_error({"gp": "*", "op": "^", "lc": "|", "sp": "scalar product"}[kind], other, exc) from None
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
        _check_operand("*", other)
        return NotImplemented

    def __rmul__(self, other: Any) -> Multivector:
        if _is_scalar_like(other):
            return self.scale(other)
        _check_operand("*", other)
        return NotImplemented

    def __xor__(self, other: Any) -> Multivector:
        """Outer product."""
        if isinstance(other, Multivector):
            return self._product(other, "op")
        if _is_scalar_like(other):
            return self.scale(other)
        _check_operand("^", other)
        return NotImplemented

    def __rxor__(self, other: Any) -> Multivector:
        if _is_scalar_like(other):
            return self.scale(other)
        _check_operand("^", other)
        return NotImplemented

    def __or__(self, other: Any) -> Multivector:
        """Left contraction ``self ⌋ other`` (the paper's inner product ``·``)."""
        if isinstance(other, Multivector):
            return self._product(other, "lc")
        if _is_scalar_like(other):
            return self._product(Multivector((0,), (other,)), "lc")
        _check_operand("|", other)
        return NotImplemented

    def __ror__(self, other: Any) -> Multivector:
        if _is_scalar_like(other):  # a scalar contracts as a scaling: s ⌋ X = s X
            return self.scale(other)
        _check_operand("|", other)
        return NotImplemented

    def _mv_arg(self, other: Any, op: str) -> Multivector:
        if not isinstance(other, Multivector):
            raise InvalidInputError(f"Multivector.{op}(other) needs a Multivector, got {type(other).__name__}")
        return other

    def gp(self, other: Multivector) -> Multivector:
        return self._product(self._mv_arg(other, "gp"), "gp")

    def outer(self, other: Multivector) -> Multivector:
        return self._product(self._mv_arg(other, "outer"), "op")

    def lc(self, other: Multivector) -> Multivector:
        """Left contraction."""
        return self._product(self._mv_arg(other, "lc"), "lc")

    def scalar_product(self, other: Multivector) -> Any:
        """``<self other>_0`` as a coefficient."""
        return self._product(self._mv_arg(other, "scalar_product"), "sp").get(0)

    def __truediv__(self, other: Any) -> Multivector:
        if isinstance(other, Multivector):
            return self * other.inverse()
        if _is_scalar_like(other):
            if not B.is_symbolic(other) and np.any(np.asarray(other) == 0):
                raise InvalidInputError("Multivector / s: division by zero (s = 0)")
            return self.scale(1.0 / other)
        _check_operand("/", other)
        return NotImplemented

    def __rtruediv__(self, other: Any) -> Multivector:
        if _is_scalar_like(other):
            return self.inverse().scale(other)
        _check_operand("/", other)
        return NotImplemented

    # ------------------------------------------------------------------ involutions
    def reverse(self) -> Multivector:
        """Reverse X̃: the order of every blade's vectors reversed."""
        try:
            return Multivector(
                self.blades, tuple(c if _REV_SIGN[grade_of(k)] > 0 else -c for k, c in zip(self.blades, self.coeffs))
            )
        except (TypeError, ValueError, OverflowError) as exc:
            raise self._op_error("reverse", None, exc) from None

    __invert__ = reverse

    def involute(self) -> Multivector:
        """Grade involution X̂ = Σ (−1)^k <X>_k."""
        try:
            return Multivector(
                self.blades, tuple(c if _INV_SIGN[grade_of(k)] > 0 else -c for k, c in zip(self.blades, self.coeffs))
            )
        except (TypeError, ValueError, OverflowError) as exc:
            raise self._op_error("involute", None, exc) from None

    def grade(self, *ks: int) -> Multivector:
        """Grade projection <X>_k (several grades may be given)."""
        for k in ks:
            if not (isinstance(k, Integral) and not isinstance(k, bool) and 0 <= int(k) <= 5):
                raise InvalidInputError(f"Multivector.grade(k): grades are ints 0..5, got {k!r}")
        keep = [i for i, b in enumerate(self.blades) if grade_of(b) in ks]
        return Multivector(tuple(self.blades[i] for i in keep), tuple(self.coeffs[i] for i in keep))

    def project(self, blades: Iterable[int]) -> Multivector:
        """Keep only the given blades (a structural projection onto a known subspace)."""
        if isinstance(blades, (str, bytes)) or not isinstance(blades, Iterable):
            raise InvalidInputError(f"Multivector.project(blades) needs blade bitmasks, got {_short(blades)}")
        bs = set(blades)
        keep = [i for i, b in enumerate(self.blades) if b in bs]
        return Multivector(tuple(self.blades[i] for i in keep), tuple(self.coeffs[i] for i in keep))

    def with_blades(self, blades: tuple[int, ...]) -> Multivector:
        """Same multivector laid out on exactly ``blades`` (zeros filled in, others must be absent)."""
        if type(blades) is not tuple:
            if isinstance(blades, (str, bytes)) or not isinstance(blades, Iterable):
                raise InvalidInputError(f"Multivector.with_blades(blades) needs blade bitmasks, got {_short(blades)}")
            blades = tuple(_blade_int(b, "Multivector.with_blades blade") for b in blades)
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

        Numeric X is first rescaled exactly (powers of two, :func:`balance_exponents`), so the
        test is scale-invariant (X → λX and dilations of X give the same verdict) and nothing
        overflows: X X̃ must be a scalar that is not lost in the rounding noise of its own
        computation (``|⟨X X̃⟩₀| > 32 ε ‖X‖²`` after rescaling), and its other grades must be
        below ``1e-7 |⟨X X̃⟩₀|`` plus that noise.

        Raises:
            InvalidVersorError: If X X̃ is zero (zero norm, null blade) or (numerically) not a scalar.
        """
        if self.is_symbolic:
            s = (self * self.reverse()).get(0)
            return self.reverse().scale(1.0 / s)
        self.check_finite("the multivector to invert")
        k, (lam,) = balance_exponents(self)
        Xb = self._rescaled(k, lam)
        xx = Xb * Xb.reverse()
        s = np.asarray(xx.get(0), dtype=float)
        n2 = sum(np.asarray(c, dtype=float) ** 2 for c in Xb.coeffs) if Xb.coeffs else np.zeros(())
        noise = 32.0 * _EPS * n2
        if np.any(np.abs(s) <= noise):
            raise InvalidVersorError(
                "cannot invert a multivector with X·X̃ = 0 (zero norm or null blade); "
                "check that it is a versor or a non-null blade"
            )
        rest = [np.abs(np.asarray(c, dtype=float)) for c in xx.grade(1, 2, 3, 4, 5).coeffs]
        if rest and np.any(np.max(np.stack(np.broadcast_arrays(*rest)), axis=0) > 1e-7 * np.abs(s) + noise):
            raise InvalidVersorError(
                "X·X̃ is not a scalar, so Eq 80 does not apply; only versors and blades are invertible here"
            )
        s_c = float(s) if s.ndim == 0 else s
        with np.errstate(over="ignore"):
            out = Xb.reverse().scale(1.0 / s_c)._rescaled(-k, lam)
        for c in out.coeffs:
            if not np.all(np.isfinite(c)):
                raise InvalidInputError("X⁻¹ is beyond the float64 range (X is too small or too large to invert)")
        return out

    def _rescaled(self, k: int, lam: int) -> Multivector:
        """Coefficient on blade b times ``2**(lam − k·OMEGA[b])`` (exact; see :func:`balance_exponents`)."""
        if k == 0 and lam == 0:
            return self
        with np.errstate(over="ignore", under="ignore"):
            out = tuple(_ldexp(c, lam - k * OMEGA[b]) for b, c in zip(self.blades, self.coeffs))
        return Multivector(self.blades, out)

    # ------------------------------------------------------------------ numerics
    def _check_types(self, what: str) -> None:
        for k, c in zip(self.blades, self.coeffs):
            if type(c) is float or type(c) is _F64:
                continue
            why = coeff_problem(c)
            if why is not None:
                raise InvalidInputError(f"{what} has an invalid coefficient on {blade_name(k)}: {why}")

    def _batch_shape(self, what: str) -> tuple[int, ...]:
        shapes = [
            np.shape(c) for c in self.coeffs if type(c) is not float and type(c) is not _F64 and not B.is_symbolic(c)
        ]
        if not shapes:
            return ()
        try:
            return np.broadcast_shapes(*shapes)
        except ValueError:
            raise InvalidInputError(
                f"{what} has coefficients of incompatible batch shapes {sorted(set(shapes))}"
            ) from None

    def check_finite(self, what: str = "multivector") -> Multivector:
        """Validate the numeric coefficients: real numbers (no bools, complex, strings, None),
        consistent batch shapes, no NaN or inf.

        Raises :class:`InvalidInputError` (wrong type/shape) or :class:`NonFiniteError`
        (NaN/inf); symbolic coefficients are not checked.  Returns ``self``.
        """
        if type(self.blades) is not tuple or type(self.coeffs) is not tuple or len(self.blades) != len(self.coeffs):
            raise InvalidInputError(
                f"{what} is not a well-formed Multivector (blades and coeffs must be tuples of equal length)"
            )
        for k in self.blades:
            if type(k) is not int or not 0 <= k < N_BLADES:
                _blade_int(k, f"{what} blade")
        batched = False
        for k, c in zip(self.blades, self.coeffs):
            t = type(c)
            if t is float or t is _F64:
                if not math.isfinite(c):
                    raise NonFiniteError(f"{what} has a non-finite coefficient on {blade_name(k)}: {c!r}")
                continue
            why = coeff_problem(c)
            if why is not None:
                raise InvalidInputError(f"{what} has an invalid coefficient on {blade_name(k)}: {why}")
            if B.is_symbolic(c):
                continue
            if not np.all(np.isfinite(c)):
                raise NonFiniteError(f"{what} has a non-finite coefficient on {blade_name(k)}: {_short(c)}")
            batched = batched or bool(np.ndim(c))
        if batched:
            self._batch_shape(what)
        return self

    def prune(self, tol: float = 0.0) -> Multivector:
        """Drop numeric blades with ``|coeff| <= tol`` (and symbolic structural zeros)."""
        if coeff_problem(tol) is not None or B.is_symbolic(tol) or np.ndim(tol) or not tol >= 0:
            raise InvalidInputError(f"prune(tol): tol must be a real number ≥ 0, got {_short(tol)}")
        self._check_types("prune: the multivector")
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
        if not isinstance(other, Multivector):
            raise InvalidInputError(f"allclose(other) needs a Multivector, got {type(other).__name__}")
        for name, v in (("atol", atol), ("rtol", rtol)):
            if coeff_problem(v) is not None or B.is_symbolic(v) or np.ndim(v) or not v >= 0:
                raise InvalidInputError(f"allclose({name}): must be a real number ≥ 0, got {_short(v)}")
        a, b = self.to_dense(), other.to_dense()
        try:
            return bool(np.allclose(a, b, atol=atol, rtol=rtol))
        except ValueError:
            raise InvalidInputError(
                f"allclose: batch shapes {a.shape[1:]} and {b.shape[1:]} do not broadcast"
            ) from None

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
                try:
                    cs = f"{c:.6g}"
                except (TypeError, ValueError, OverflowError):
                    cs = _short(c, 30)
            parts.append(f"{cs}" if k == 0 else f"{cs}*{blade_name(k)}")
        return "Multivector(" + " + ".join(parts) + ")"

    def __iter__(self):  # guard against accidental numpy coercion
        raise _NotIterableError("Multivector is not iterable; use .blades/.coeffs or .to_dense()")

    __array_ufunc__ = None  # so that ndarray * Multivector defers to our __rmul__


def grade_blades(*ks: int) -> tuple[int, ...]:
    """All blade bitmasks of the given grades, sorted."""
    for k in ks:
        if not (isinstance(k, Integral) and not isinstance(k, bool) and 0 <= int(k) <= 5):
            raise InvalidInputError(f"grade_blades(k): grades are ints 0..5, got {k!r}")
    return tuple(sorted(b for k in ks for b in BLADES_BY_GRADE[int(k)]))
