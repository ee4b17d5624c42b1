"""Subprocess worker of the reliability tests: builds CasADi functions through ``CompiledFunction``.

Run as ``python _worker.py '<json spec>'``; prints one JSON line (prefixed ``RESULT ``) with,
per function, whether compiled code is used and the largest deviation from the VM
reference, plus the warnings and the module's counters.  A crash of the process
(SIGSEGV/SIGBUS on a bad library) shows as a non-zero exit code in the test, not as a
crash of pytest.

Spec keys: ``functions`` (names for :func:`make_function`), ``depth`` (size of the
function, default 8), ``ready``/``go`` (barrier files: touch ``ready``, wait for ``go``
before compiling, so that N workers compile at the same moment), ``hold``/``resume``
(after loading: touch ``hold``, wait for ``resume``, evaluate again and report whether the
mapped library file was replaced underneath), ``fallback`` (default true).

``coop_ga.codegen`` is imported without running ``coop_ga/__init__`` (it needs only
``errors`` and ``diagnostics``): faster start-up, and independent of the rest of the
package.  ``COOP_GA_CODEGEN_IMPL=<file>`` loads another implementation instead (used by
hand to check that the tests fail on the old code).
"""

from __future__ import annotations

import importlib.util
import json
import os
import sys
import time
import types
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import casadi as ca
    import numpy as np

# the repository root (COOP_GA_ROOT when the worker is run from a copy, e.g. by another user)
ROOT = Path(os.environ.get("COOP_GA_ROOT") or Path(__file__).resolve().parents[2])


def import_codegen() -> types.ModuleType:
    """``coop_ga.codegen`` with a bare ``coop_ga`` package (its ``__init__`` is not executed)."""
    if "coop_ga" not in sys.modules:
        pkg = types.ModuleType("coop_ga")
        pkg.__path__ = [str(ROOT / "coop_ga")]
        sys.modules["coop_ga"] = pkg
    impl = os.environ.get("COOP_GA_CODEGEN_IMPL")
    if not impl:
        import coop_ga.codegen as cg

        return cg
    spec = importlib.util.spec_from_file_location("coop_ga.codegen", impl)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules["coop_ga.codegen"] = mod
    spec.loader.exec_module(mod)
    return mod


def make_function(name: str, depth: int = 8) -> ca.Function:
    """A deterministic SX function ``(x (6), Y (3×2)) → (e (6), M (2×1))``; ``name`` seeds its constants."""
    import casadi as ca

    seed = sum(ord(c) * (i + 1) for i, c in enumerate(name)) % 97  # fixed, never hash()
    x = ca.SX.sym("x", 6)
    Y = ca.SX.sym("Y", 3, 2)
    e = x
    for k in range(depth):
        c = 0.5 + 0.01 * ((seed + 7 * k) % 13)
        e = ca.sin(e * c) + ca.cos(e[::-1]) * 0.3 + ca.exp(-e * e) * 0.1
    M = ca.mtimes(Y.T, e[:3]) * e[5] + ca.sum1(Y[:, 0] * Y[:, 1])
    return ca.Function(name, [x, Y], [e, M], ["x", "Y"], ["e", "M"])


def sample_inputs(k: int) -> tuple[np.ndarray, np.ndarray]:
    import numpy as np

    rng = np.random.default_rng(1000 + k)
    return rng.normal(size=6), rng.normal(size=(3, 2))


def _wait(path: str, timeout: float = 120.0) -> None:
    t0 = time.monotonic()
    while not os.path.exists(path):
        if time.monotonic() - t0 > timeout:
            raise TimeoutError(path)
        time.sleep(0.005)


def _mapped_libraries() -> list[str]:
    with open("/proc/self/maps") as fh:
        return [ln.split(None, 5)[5].strip() for ln in fh if len(ln.split(None, 5)) == 6 and ".so" in ln]


def _max_err(cf: Any, ref: Any, n: int = 20) -> float:
    import numpy as np

    err = 0.0
    for k in range(n):
        x, Y = sample_inputs(k)
        for a, b in zip(cf(x, Y), ref(x, Y)):
            scale = 1.0 + np.abs(b).max()
            err = max(err, float(np.abs(a - b).max() / scale))
    return err


def main(argv: list[str]) -> int:
    spec = json.loads(argv[1]) if len(argv) > 1 else {}
    cg = import_codegen()
    warnings.simplefilter("always")
    funcs = [make_function(n, spec.get("depth", 8)) for n in spec.get("functions", ["f0"])]
    if spec.get("ready"):
        Path(spec["ready"]).touch()
        _wait(spec["go"])
    out: dict = {"functions": []}
    kw = {} if spec.get("fallback", True) else {"fallback": False}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        t0 = time.perf_counter()
        cfs = [cg.CompiledFunction(f, codegen=spec.get("codegen", True), **kw) for f in funcs]
        out["build_s"] = time.perf_counter() - t0
        refs = [cg.CompiledFunction(f, codegen=False) for f in funcs]
        for cf, ref in zip(cfs, refs):
            out["functions"].append(
                {
                    "name": cf.name,
                    "codegen": bool(cf.codegen),
                    "max_err": _max_err(cf, ref),
                    "fallback_reason": getattr(cf, "fallback_reason", None),
                }
            )
        if spec.get("hold"):
            Path(spec["hold"]).touch()
            _wait(spec["resume"])
            out["max_err_after_replace"] = max(_max_err(cf, ref, 200) for cf, ref in zip(cfs, refs))
            out["mapped"] = [p for p in _mapped_libraries() if "coop_ga_" in p]
    out["warnings"] = [{"category": w.category.__name__, "message": str(w.message)} for w in caught]
    out["stats"] = dict(getattr(cg, "_stats", {}))
    print("RESULT " + json.dumps(out), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
