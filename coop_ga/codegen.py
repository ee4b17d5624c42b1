"""Fast evaluation of CasADi functions from Python: buffers, generated C, a disk cache.

Calling ``casadi.Function`` with numpy arguments costs ~15 µs per call on a 2-core
machine, whatever the function computes.  :class:`CompiledFunction` avoids that:

* it binds preallocated numpy arrays to a ``casadi.FunctionBuffer`` once, so a call
  is a copy into the input arrays plus ~0.1 µs of dispatch;
* optionally (``codegen=True``) it generates C for the function, compiles it with the
  machine's ``gcc`` into a shared library, and loads it with ``casadi.external``;
* compiled libraries are cached on disk, keyed by a hash of the generated C source,
  the compiler flags, the CPU signature and the CasADi version, in ``$COOP_GA_CACHE`` (default
  ``~/.cache/coop_ga``), so a system is compiled once per machine.

Outputs are dense numpy arrays in the function's output shapes (Fortran order, as
CasADi stores them).  ``__call__`` returns copies; :meth:`CompiledFunction.call_views`
returns the internal buffers, which the next call overwrites (zero-copy hot loops).
"""

from __future__ import annotations

import hashlib
import math
import os
import shutil
import subprocess
import tempfile
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

from .errors import InvalidInputError, NonFiniteError

__all__ = ["CompiledFunction", "cache_dir", "gcc_available"]

# -march=native: FMA/AVX give ~25 % on the generated straight-line code (measured on the
# cooperative task of three_franka); the cache key includes the CPU signature, so a
# library built for one CPU is never loaded on another.  No -ffast-math: NaN must survive
# so that bad input is detected.
_CFLAGS = ("-O2", "-march=native", "-fPIC", "-shared", "-fno-math-errno", "-fno-trapping-math")


def _cpu_signature() -> str:
    """CPU model and feature flags (Linux), part of the compiled-library cache key."""
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        import platform

        return platform.machine() + platform.processor()
    keep = [ln for ln in text.splitlines() if ln.startswith(("model name", "flags"))][:2]
    return "\n".join(keep)


def cache_dir() -> Path:
    """Directory of compiled libraries (``$COOP_GA_CACHE`` or ``~/.cache/coop_ga``)."""
    d = Path(os.environ.get("COOP_GA_CACHE", Path.home() / ".cache" / "coop_ga"))
    d.mkdir(parents=True, exist_ok=True)
    return d


def gcc_available() -> bool:
    return shutil.which("gcc") is not None


def _rename(f: ca.Function, name: str) -> ca.Function:
    """Re-trace ``f`` under a new name (avoids clashes such as ``expf`` with libm)."""
    args = f.sx_in() if f.is_a("SXFunction") else f.mx_in()
    return ca.Function(name, args, f.call(args), f.name_in(), f.name_out())


def _compile(f: ca.Function, flags: tuple[str, ...]) -> ca.Function:
    """Generate C for ``f``, compile (cached) and load it as ``casadi.external``."""
    f = _rename(f, "coop_ga_" + f.name())
    with tempfile.TemporaryDirectory() as tmp:
        cname = f"{f.name()}.c"
        cg = ca.CodeGenerator(cname, {"with_header": False, "casadi_real": "double"})
        cg.add(f)
        src_path = Path(tmp) / cname
        cg.generate(str(Path(tmp)) + os.sep)
        src = src_path.read_text()
    key = hashlib.sha256((src + " ".join(flags) + ca.__version__ + _cpu_signature()).encode()).hexdigest()[:20]
    so = cache_dir() / f"{f.name()}_{key}.so"
    if not so.exists():
        with tempfile.TemporaryDirectory() as tmp:
            c = Path(tmp) / cname
            c.write_text(src)
            out = Path(tmp) / so.name
            cmd = ["gcc", *flags, str(c), "-o", str(out), "-lm"]
            res = subprocess.run(cmd, capture_output=True, text=True)
            if res.returncode != 0:
                raise RuntimeError(f"gcc failed for {f.name()}: {res.stderr[-2000:]}")
            shutil.move(str(out), so)  # atomic enough: a partial file never has the final name
    return ca.external(f.name(), str(so))


class CompiledFunction:
    """A CasADi function bound to numpy buffers for low-overhead calls.

    Parameters
    ----------
    f:
        The CasADi function (SX or MX).  Inputs must be dense vectors or matrices.
    codegen:
        ``True``: generate and compile C with gcc (cached on disk); ``False``: use
        CasADi's SX virtual machine; ``"auto"``: C when gcc is available.
    check_finite:
        Raise :class:`NonFiniteError` when an input contains NaN/inf (cheap; default).
    """

    def __init__(self, f: ca.Function, codegen: bool | str = "auto", check_finite: bool = True,
                 flags: tuple[str, ...] = _CFLAGS):
        if codegen == "auto":
            codegen = gcc_available()
        self.source = f
        self.codegen = bool(codegen)
        self.function = _compile(f, flags) if codegen else f
        self.check_finite = check_finite
        self._in_shapes = [f.size_in(i) for i in range(f.n_in())]
        self._out_shapes = [f.size_out(i) for i in range(f.n_out())]
        for i in range(f.n_out()):
            if not f.sparsity_out(i).is_dense():
                raise InvalidInputError(f"output {i} of {f.name()} must be dense (wrap it in casadi.densify)")
        self._inputs = [np.zeros(s, order="F") for s in self._in_shapes]
        self._outputs = [np.zeros(s, order="F") for s in self._out_shapes]
        self._flat_inputs = [a.reshape(-1, order="F") for a in self._inputs]  # views (F-order is contiguous)
        self._buf, self._eval = self.function.buffer()
        for i, a in enumerate(self._inputs):
            self._buf.set_arg(i, memoryview(a.T))
        for i, a in enumerate(self._outputs):
            self._buf.set_res(i, memoryview(a.T))
        self.name = f.name()

    @property
    def inputs(self) -> list[np.ndarray]:
        """The bound input arrays (write into them, then call :meth:`eval`)."""
        return self._inputs

    @property
    def outputs(self) -> list[np.ndarray]:
        """The bound output arrays (overwritten by every evaluation)."""
        return self._outputs

    def eval(self) -> None:
        """Evaluate on the current contents of :attr:`inputs` (no checks, ~0.1 µs overhead)."""
        self._eval()

    @property
    def n_instructions(self) -> int:
        return self.source.n_instructions() if hasattr(self.source, "n_instructions") else -1

    def _load(self, args: tuple[Any, ...]) -> None:
        if len(args) != len(self._inputs):
            raise InvalidInputError(f"{self.name} takes {len(self._inputs)} arguments, got {len(args)}")
        for i, a in enumerate(args):
            flat = self._flat_inputs[i]
            if type(a) is np.ndarray and a.shape == flat.shape:  # hot path: a plain vector
                np.copyto(flat, a, casting="unsafe")
            else:
                a = np.asarray(a, dtype=float)
                if a.size != flat.size:
                    dst = self._inputs[i]
                    raise InvalidInputError(
                        f"argument {i} of {self.name} must have {dst.size} entries (shape {dst.shape}), got shape {a.shape}"
                    )
                self._inputs[i][...] = a if a.shape == self._inputs[i].shape else a.reshape(self._inputs[i].shape)
            # one dot product detects NaN/inf (and overflow) cheaply; the full scan runs only then
            if self.check_finite and not math.isfinite(flat.dot(flat)):
                bad = np.flatnonzero(~np.isfinite(flat)).tolist()
                if bad:
                    raise NonFiniteError(f"argument {i} of {self.name} contains NaN or inf at indices {bad}")
                raise InvalidInputError(f"argument {i} of {self.name} is too large (its squared norm overflows)")

    def call_views(self, *args: Any) -> list[np.ndarray]:
        """Evaluate and return the internal output buffers (overwritten by the next call)."""
        self._load(args)
        self._eval()
        return self._outputs

    def __call__(self, *args: Any) -> list[np.ndarray] | np.ndarray:
        """Evaluate; returns a copy of each output (a single array if there is one output)."""
        outs = [o.copy() for o in self.call_views(*args)]
        return outs[0] if len(outs) == 1 else outs
