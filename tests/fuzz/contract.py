"""Shared pieces of the fuzz suites of coop_ga.collision, linkages, legged and systems.

:func:`check` is :func:`tests.fuzz.test_fuzz_geometry.call` — (b) only CoopGAError subclasses are raised,
(c) no argument is modified — with property (a), no NaN or inf returned, extended to the result objects of
these modules (dataclasses such as ``PotentialPath``, ``LinkageMotion``, ``DLSResult``, ``BodyState``,
``System``; ±inf in a ``JointLimits`` means "unbounded" and is allowed there).  Strategies are those of the
geometry suite, plus ``bad`` (a value that is wrong for any numeric argument) and ``reals`` (finite floats of any
magnitude mixed with NaN/inf and wrong types).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np
from hypothesis import strategies as st

from coop_ga.algebra import Multivector
from tests.fuzz.test_fuzz_geometry import BAD_SCALARS, EXTREME, call, junk_for, moderate, number, scalar, vec3

__all__ = [
    "BAD_SCALARS",
    "EXTREME",
    "bad",
    "check",
    "finite_everywhere",
    "junk_for",
    "moderate",
    "number",
    "reals",
    "scalar",
    "vec",
    "vec3",
]

#: a value no numeric argument accepts
bad = st.one_of(st.sampled_from(BAD_SCALARS), st.text(max_size=3), st.just(float("nan")), st.just(float("inf")))
#: a real argument: moderate and extreme finite floats, NaN/inf, and junk
reals = st.one_of(moderate, number, scalar)


def vec(n: int, elem: Any = number) -> Any:
    """An n-vector argument: finite (moderate or extreme), NaN/inf, or wrongly typed / shaped."""
    good = st.lists(elem, min_size=n, max_size=n)
    return st.one_of(good.map(np.array), good, good.map(tuple), junk_for(n))


def finite_everywhere(out: Any, where: str = "result", depth: int = 0) -> None:
    """Assert that ``out`` holds no NaN/inf: numbers, arrays, containers, dataclasses, multivectors."""
    if depth > 6 or out is None or isinstance(out, (bool, np.bool_, str, bytes, int, np.integer)):
        return
    if isinstance(out, (float, np.floating)):
        assert math.isfinite(float(out)), f"{where} = {out}"
    elif isinstance(out, np.ndarray):
        if out.dtype.kind in "fc":
            assert np.all(np.isfinite(out)), f"{where} has non-finite values"
        elif out.dtype == object:
            finite_everywhere(out.tolist(), where, depth + 1)
    elif isinstance(out, Multivector):
        finite_everywhere(list(out.coeffs), f"{where}.coeffs", depth + 1)
    elif isinstance(out, dict):
        for k, v in out.items():
            finite_everywhere(v, f"{where}[{k!r}]", depth + 1)
    elif isinstance(out, (list, tuple)):
        for i, v in enumerate(out):
            finite_everywhere(v, f"{where}[{i}]", depth + 1)
    elif type(out).__name__ == "JointLimits":
        return  # ±inf: unbounded (coop_ga.systems.limits)
    elif dataclasses.is_dataclass(out) and not isinstance(out, type):
        for f in dataclasses.fields(out):
            finite_everywhere(getattr(out, f.name, None), f"{where}.{f.name}", depth + 1)


def check(f: Any, *args: Any, **kwargs: Any) -> Any:
    """Run ``f``: only CoopGAErrors, arguments unchanged (:func:`call`), and a result without NaN/inf."""
    out = call(f, *args, _finite_out=False, **kwargs)
    finite_everywhere(out, getattr(f, "__name__", repr(f)))
    return out
