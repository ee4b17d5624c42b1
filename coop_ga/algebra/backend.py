"""Scalar functions that dispatch on the coefficient type: numpy (floats, arrays) or CasADi.

The algebra only needs ``+ - *`` from its coefficients; everything non-polynomial
(square roots, trigonometry, branches) goes through this module, so the same source
runs on floats, on numpy arrays (batched: one array per blade) and on CasADi SX/MX.

Branches use :func:`where`, which on CasADi becomes ``if_else``.  Guarded formulas
evaluate a *safe* argument in the branch not taken (the "double where" trick), so
neither values nor derivatives ever contain NaN.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import InvalidInputError

try:  # casadi is a hard dependency, but keep import errors readable
    import casadi as ca
except ImportError:  # pragma: no cover
    if not TYPE_CHECKING:  # type checkers see casadi as always present
        ca = None

__all__ = [
    "any_symbolic",
    "asarray_coeff",
    "atan2",
    "atanh",
    "cos",
    "cosh",
    "exp",
    "fabs",
    "is_structural_zero",
    "is_symbolic",
    "log",
    "log1p",
    "sin",
    "sinh",
    "sqrt",
    "where",
]

_SYM_TYPES: tuple[type, ...] = (ca.SX, ca.MX) if ca is not None else ()


def is_symbolic(x: Any) -> bool:
    """True for CasADi SX/MX expressions."""
    return isinstance(x, _SYM_TYPES)


def any_symbolic(*xs: Any) -> bool:
    return any(isinstance(x, _SYM_TYPES) for x in xs)


def _pick(name: str):
    np_f = getattr(np, name)
    ca_f = getattr(ca, name)

    def f(x):
        if isinstance(x, _SYM_TYPES):
            return ca_f(x)
        try:
            return np_f(x)
        except TypeError as exc:
            raise InvalidInputError(
                f"{name}() needs real numbers or CasADi expressions, got {type(x).__name__}: {exc}"
            ) from None

    f.__name__ = name
    f.__doc__ = f"``{name}`` on numpy or CasADi coefficients."
    return f


sqrt = _pick("sqrt")
sin = _pick("sin")
cos = _pick("cos")
sinh = _pick("sinh")
cosh = _pick("cosh")
log = _pick("log")
exp = _pick("exp")
fabs = _pick("fabs")
log1p = _pick("log1p")


def atanh(x):
    """``atanh`` on numpy or CasADi coefficients."""
    if isinstance(x, (ca.SX, ca.MX)):  # _SYM_TYPES, spelled out so that the type checker narrows x
        return ca.atanh(x)
    try:
        return np.arctanh(x)
    except TypeError as exc:
        raise InvalidInputError(
            f"atanh() needs real numbers or CasADi expressions, got {type(x).__name__}: {exc}"
        ) from None


def atan2(y, x):
    """Quadrant-correct ``atan2(y, x)``."""
    if any_symbolic(y, x):
        return ca.atan2(y, x)
    try:
        return np.arctan2(y, x)
    except TypeError as exc:
        raise InvalidInputError(f"atan2() needs real numbers or CasADi expressions: {exc}") from None


def where(cond, a, b):
    """``a`` where ``cond`` else ``b`` (CasADi ``if_else`` for symbols)."""
    if any_symbolic(cond, a, b):
        return ca.if_else(cond, a, b)
    return np.where(cond, a, b) if np.ndim(cond) else (a if cond else b)


def is_structural_zero(x: Any) -> bool:
    """True if ``x`` is known to be exactly zero without evaluation.

    Numbers are never pruned by value (the sparsity pattern of numeric
    multivectors must not depend on the data); CasADi expressions are pruned when
    CasADi can prove they are zero.
    """
    if isinstance(x, ca.SX):
        return x.is_zero()
    return False


def asarray_coeff(x: Any) -> Any:
    """Leave symbols alone; turn python/numpy numbers into float or float arrays."""
    if isinstance(x, _SYM_TYPES):
        return x
    from .multivector import coeff_problem

    why = coeff_problem(x) if not isinstance(x, (list, tuple)) else None
    if why is not None:
        raise InvalidInputError(f"asarray_coeff(x): {why}")
    try:
        a = np.asarray(x)
        if a.dtype.kind not in "fiu":
            raise TypeError(f"dtype {a.dtype}")
        a = a.astype(float)
    except (TypeError, ValueError, OverflowError) as exc:
        raise InvalidInputError(f"asarray_coeff(x) needs real numbers, got {type(x).__name__}: {exc}") from None
    return float(a) if a.ndim == 0 else a
