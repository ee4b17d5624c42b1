"""The one place where arguments are checked: configurations, vectors, scalars, weights, choices,
indices, frame names and similarity targets.

Every check returns a *new* value (inputs are never modified) or raises a
:class:`~coop_ga.errors.CoopGAError` subclass whose message names the argument, what was
passed and what is expected.  What is rejected, everywhere:

* wrong shapes — including a scalar or a (1,)-array where a vector is expected (never
  broadcast);
* NaN and inf (:class:`~coop_ga.errors.NonFiniteError`, with the offending indices);
* complex numbers (the imaginary part is never dropped), booleans, strings, ``None``,
  dicts and other non-numeric objects;
* floats where an integer or an index is expected (``points=(0.5, 1, 2)`` is not
  ``(0, 1, 2)``).

This module sits at the bottom of the layers (numpy and :mod:`coop_ga.errors` only), so
that every layer can use it; :func:`target` calls the conversion that the geometry layer
installs when it is imported (:meth:`coop_ga.Similarity.coerce`), without importing it.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from .errors import InvalidInputError, NonFiniteError, UnknownNameError

__all__ = [
    "array",
    "choice",
    "configuration",
    "finite_result",
    "frames",
    "indices",
    "integer",
    "nonnegative",
    "positive",
    "scalar",
    "target",
    "vector",
    "weight",
]


def _describe(x: Any) -> str:
    if isinstance(x, np.ndarray):
        return f"an array of shape {x.shape} and dtype {x.dtype}"
    if isinstance(x, (list, tuple)):
        return f"a {type(x).__name__} of length {len(x)}"
    return f"{type(x).__name__} {x!r}"[:120]


def array(x: Any, what: str, *, shape: tuple[int, ...] | None = None, finite: bool = True) -> np.ndarray:
    """``x`` as a new float64 array (optionally of exactly ``shape``), checked (module docstring)."""
    if x is None or isinstance(x, (str, bytes, dict, set)):
        raise InvalidInputError(f"{what} must be numeric, got {_describe(x)}")
    try:
        a = np.array(x)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f"{what} must be numeric, got {_describe(x)} ({exc})") from None
    if a.dtype.kind == "c":
        raise InvalidInputError(f"{what} must be real, got complex values ({_describe(x)})")
    if a.dtype == np.bool_ or a.dtype.kind not in "fiu":
        raise InvalidInputError(f"{what} must be real numbers, got {_describe(x)}")
    a = a.astype(np.float64, copy=False)
    if shape is not None and a.shape != shape:
        raise InvalidInputError(f"{what} must have shape {shape}, got {_describe(x)}")
    if finite and not np.all(np.isfinite(a)):
        bad = np.argwhere(~np.isfinite(a)).tolist()[:10]
        raise NonFiniteError(f"{what} contains NaN or inf at {bad}")
    return a


def finite_result(x: Any, what: str) -> Any:
    """``x`` if every number in it is finite; else :class:`InvalidInputError`: finite arguments whose result
    overflows (e.g. coordinates of 1e200 m squared) are out of range — ``what`` names them and the fix."""
    if not np.all(np.isfinite(x)):
        raise InvalidInputError(f"{what}: the result overflows (inf or NaN); rescale the arguments")
    return x


def vector(x: Any, n: int, what: str) -> np.ndarray:
    """A finite real vector of exactly ``n`` entries, shape (n,) (no column, no scalar: never reshaped)."""
    a = array(x, what, finite=False)
    if a.shape != (n,):
        raise InvalidInputError(f"{what} must have {n} entries (shape ({n},)), got {_describe(x)}")
    if not np.all(np.isfinite(a)):
        raise NonFiniteError(f"{what} contains NaN or inf at indices {np.flatnonzero(~np.isfinite(a)).tolist()}")
    return a


def configuration(q: Any, nq: int, what: str = "q", *, owner: str = "", joint_names: Sequence[str] = ()) -> np.ndarray:
    """A joint configuration (nq,) [rad or m]: :func:`vector` with a message naming the owner."""
    try:
        return vector(q, nq, what)
    except NonFiniteError:
        raise
    except InvalidInputError as exc:
        who = f" for {owner}" if owner else ""
        names = f" (joints: {', '.join(joint_names)})" if joint_names else ""
        raise InvalidInputError(f"{exc}{who}{names}") from None


def scalar(
    x: Any,
    what: str,
    *,
    low: float | None = None,
    high: float | None = None,
    low_open: bool = False,
    allow_inf: bool = False,
) -> float:
    """A real number (not a bool, string, array or complex), optionally within [low, high] (or (low, high])."""
    if isinstance(x, (bool, np.bool_)) or not isinstance(x, numbers.Real):
        if isinstance(x, np.ndarray) and x.shape == () and x.dtype.kind in "fiu":
            x = x.item()
        else:
            raise InvalidInputError(f"{what} must be a real number, got {_describe(x)}")
    try:
        v = float(x)
    except OverflowError:  # an integer beyond the doubles (10**400)
        raise NonFiniteError(f"{what} must be finite, got an integer of {len(str(abs(int(x))))} digits") from None
    if math.isnan(v) or (math.isinf(v) and not allow_inf):
        raise NonFiniteError(f"{what} must be finite, got {v}")
    if low is not None and (v < low or (low_open and v == low)):
        raise InvalidInputError(f"{what} must be {'>' if low_open else '≥'} {low:g}, got {v:g}")
    if high is not None and v > high:
        raise InvalidInputError(f"{what} must be ≤ {high:g}, got {v:g}")
    return v


def positive(x: Any, what: str, *, allow_inf: bool = False) -> float:
    """A real number > 0."""
    return scalar(x, what, low=0.0, low_open=True, allow_inf=allow_inf)


def nonnegative(x: Any, what: str, *, allow_inf: bool = False) -> float:
    """A real number ≥ 0."""
    return scalar(x, what, low=0.0, allow_inf=allow_inf)


def integer(x: Any, what: str, *, minimum: int | None = None) -> int:
    """An integer (``int`` or numpy integer; not a bool, not a float — even an integral one)."""
    if isinstance(x, (bool, np.bool_)) or not isinstance(x, numbers.Integral):
        raise InvalidInputError(f"{what} must be an integer, got {_describe(x)}")
    v = int(x)
    if minimum is not None and v < minimum:
        raise InvalidInputError(f"{what} must be an integer ≥ {minimum}, got {v}")
    return v


def choice(x: Any, options: Sequence[str], what: str) -> str:
    """One of the strings in ``options``."""
    if not isinstance(x, str) or x not in options:
        raise InvalidInputError(f"{what} must be one of {', '.join(map(repr, options))}; got {_describe(x)}")
    return x


def weight(W: Any, n: int, what: str, *, definite: bool) -> np.ndarray:
    """A weight matrix (n, n) from a scalar, an (n,) diagonal or an (n, n) symmetric matrix,
    positive definite (``definite=True``) or semi-definite."""
    a = array(W, what, finite=True)
    if a.ndim == 0:
        a = float(a) * np.eye(n)
    elif a.shape == (n,):
        a = np.diag(a)
    elif a.shape != (n, n):
        raise InvalidInputError(
            f"{what} must be a scalar, a ({n},) diagonal or a ({n}, {n}) matrix, got shape {a.shape}"
        )
    if not np.allclose(a, a.T, rtol=1e-12, atol=1e-12 * max(1.0, float(np.abs(a).max()))):
        raise InvalidInputError(f"{what} must be symmetric")
    a = 0.5 * (a + a.T)
    ev = np.linalg.eigvalsh(a)
    if definite and not ev[0] > 0:
        raise InvalidInputError(f"{what} must be positive definite (smallest eigenvalue {ev[0]:.3g})")
    if not definite and ev[0] < -1e-12 * max(1.0, float(ev[-1])):
        raise InvalidInputError(f"{what} must be positive semi-definite (smallest eigenvalue {ev[0]:.3g})")
    return a


def indices(x: Any, n: int, size: int, what: str, *, labels: Sequence[str] = ()) -> tuple[int, ...]:
    """``n`` distinct integer indices into a sequence of ``size`` items (e.g. end frames)."""
    listing = f" ({', '.join(f'{i}: {s}' for i, s in enumerate(labels))})" if labels else ""
    if isinstance(x, (str, bytes)) or not isinstance(x, Sequence | np.ndarray):
        raise InvalidInputError(
            f"{what} must be a sequence of {n} distinct indices into {size} items{listing}; got {_describe(x)}"
        )
    out = []
    for v in list(x):
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Integral):
            raise InvalidInputError(f"{what} must contain integers, got {_describe(v)} in {list(x)!r}")
        out.append(int(v))
    if len(out) != n or len(set(out)) != n or any(not 0 <= i < size for i in out):
        raise InvalidInputError(f"{what} must be {n} distinct indices into {size} items{listing}; got {tuple(out)}")
    return tuple(out)


def frames(names: Any, available: Sequence[str], what: str = "end_frames") -> tuple[str, ...]:
    """A non-empty sequence of distinct frame names, each in ``available``."""
    if isinstance(names, str) or not isinstance(names, Sequence):
        raise InvalidInputError(f"{what} must be a list of frame names, got {_describe(names)}")
    out = tuple(names)
    if not out:
        raise InvalidInputError(f"{what} must name at least one frame")
    for f in out:
        if not isinstance(f, str):
            raise InvalidInputError(f"{what} must contain frame names (str), got {_describe(f)}")
    if len(set(out)) != len(out):
        raise InvalidInputError(f"{what} contains duplicates: {list(out)}")
    missing = [f for f in out if f not in available]
    if missing:
        raise UnknownNameError(f"unknown frame(s) {missing} in {what}. Frames of the model: {', '.join(available)}")
    return out


#: ``Similarity.coerce``, set by :mod:`coop_ga.geometry.groups` when it is imported (``import coop_ga``
#: imports it): this module is below the geometry layer and must not import it
similarity_coerce: Callable[[Any, str], Any] | None = None


def target(x: Any, what: str = "target") -> Any:
    """A similarity argument as a :class:`~coop_ga.Similarity` (:meth:`Similarity.coerce`)."""
    if similarity_coerce is None:  # pragma: no cover - coop_ga/__init__ imports the geometry layer
        raise InvalidInputError(f"{what}: no similarity type is loaded; import coop_ga first")
    return similarity_coerce(x, what)
