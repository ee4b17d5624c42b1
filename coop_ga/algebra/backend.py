"""Scalar functions that dispatch on the coefficient type: numpy (floats, arrays) or CasADi.

The algebra only needs ``+ - *`` from its coefficients; everything non-polynomial
(square roots, trigonometry, branches) goes through this module, so the same source
runs on floats, on numpy arrays (batched: one array per blade) and on CasADi SX/MX.

Branches use :func:`where`, which on CasADi becomes ``if_else``.  Guarded formulas
evaluate a *safe* argument in the branch not taken (the "double where" trick), so
neither values nor derivatives ever contain NaN.
"""

from __future__ import annotations

from typing import Any

import numpy as np

try:  # casadi is a hard dependency, but keep import errors readable
    import casadi as ca
except ImportError:  # pragma: no cover
    ca = None

__all__ = [
    "is_symbolic",
    "any_symbolic",
    "sqrt",
    "sin",
    "cos",
    "sinh",
    "cosh",
    "atan2",
    "log",
    "exp",
    "fabs",
    "where",
    "is_structural_zero",
    "asarray_coeff",
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
        return ca_f(x) if isinstance(x, _SYM_TYPES) else np_f(x)

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


def atan2(y, x):
    """Quadrant-correct ``atan2(y, x)``."""
    if any_symbolic(y, x):
        return ca.atan2(y, x)
    return np.arctan2(y, x)


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
    a = np.asarray(x, dtype=float)
    return float(a) if a.ndim == 0 else a
