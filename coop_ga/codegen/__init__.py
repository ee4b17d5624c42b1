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
returns the internal buffers, which the next call *from the same thread* overwrites
(zero-copy hot loops).

Threads
-------
Every thread gets its own :class:`Binding` (input/output arrays, a ``FunctionBuffer``
with its own work vectors and CasADi memory object), created lazily on its first call;
:meth:`CompiledFunction.binding` returns the calling thread's one (one thread-local
attribute lookup: ~45 ns per ``binding()`` call on the 2-core reference machine; ``eval()``
costs ~40 ns more than with the former shared buffers).  ``inputs``, ``outputs``,
``eval()``, ``call_views()`` and ``__call__`` all act on the calling thread's binding, so a
:class:`CompiledFunction` may be shared by threads; arrays obtained in one thread must not
be used to feed another thread's calls.  CasADi releases the GIL while evaluating, so
threads do run in parallel.  A lock was measured at ~160 ns per call (and cannot make the
``inputs`` → ``eval()`` → ``outputs`` sequence atomic), so it is not used.

The cache
---------
An entry is ``<name>_<key>.so`` plus ``<name>_<key>.so.sha256`` (its checksum) and
``<name>_<key>.lock``.  Other processes may have the library loaded (mmap'ed), so an
entry is never rewritten in place: it is compiled in a temporary build directory *inside
the cache directory* (same filesystem) and moved over the entry with ``os.replace`` (atomic,
a new inode; a process that mapped the old file keeps it).  The checksum is written
(atomically) after the library.  Building takes an exclusive ``flock`` on the lock file, so
N processes that need the same new entry compile it once; the others wait and load it.
An entry that fails verification or loading is rebuilt under the lock.  Loading a verified
entry writes nothing, so a read-only, pre-populated cache works.

Trust: a loaded library runs inside this process, so the cache trusts only what no other
user can write (root is trusted: it can change the process anyway).

* Directories are created 0700 and files 0600 whatever the umask.
* Before anything is loaded from a directory (once per directory and process): the directory
  must be owned by you or root and writable by nobody else, and so must every component of
  its real path up to a trusted root (your home, a sticky root-owned directory such as
  ``/tmp``, or ``/``; sticky components are allowed above the cache directory itself).  A
  group that is private to its owner (Debian, Ubuntu and Fedora make one per user, with a
  umask of 002) counts as nobody else, as for Debian's OpenSSH.  Nothing is created below a
  directory that fails this check.
* Every library is opened without following links and checked through that descriptor
  before ``dlopen``: a regular file owned by you or root, writable by nobody else, matching
  its checksum (also read that way), and a complete ELF shared object (every loadable
  segment and both header tables inside the file: a truncated library whose checksum was
  recomputed would otherwise be a SIGBUS, not an exception); the path must still name that
  very file (device, inode, size, times) just before ``dlopen``.
* flock needs only read access, so a lock file others could open (left by an older version
  under a loose umask) is replaced by a private one; a lock wait ends after
  ``COOP_GA_LOCK_TIMEOUT`` seconds (:data:`LOCK_TIMEOUT_S`), then the entry is built in the
  process's private directory (one :class:`~coop_ga.errors.CacheWarning`).

Fallbacks (never an exception other than :class:`~coop_ga.errors.CoopGAError`)
------------------------------------------------------------------------------
* cache directory unusable (read-only, full, a file in the way, mkdir fails) or not trusted
  (above) → the per-user temporary cache ``<tempfile.gettempdir()>/coop_ga-<uid>`` (0700,
  yours; found writable by others, it is closed and emptied, since anything in it may have
  been planted; a file in it that is not yours is never loaded in any case);
* that unusable or not trusted either (e.g. another user created it first) → a fresh
  private ``mkdtemp`` directory of this process, removed at exit;
* none, no ``gcc``, gcc failing, C generation or loading failing → the CasADi virtual
  machine (the uncompiled ``casadi.Function``: same results, ~5-20x slower).

Each fallback emits one :class:`~coop_ga.errors.CacheWarning` per process and reason
(not one per function), naming the directory, the problem (owner, mode) and the fix.
``CompiledFunction(..., fallback=False)`` raises :class:`~coop_ga.errors.CompilationError`
instead.

Environment
-----------
``COOP_GA_CACHE``
    Cache directory (default ``~/.cache/coop_ga``).
``COOP_GA_CODEGEN``
    ``0`` / ``false`` / ``no`` / ``off``: never generate C, always use the CasADi VM,
    without a warning (e.g. on machines without a compiler).
``COOP_GA_LOCK_TIMEOUT``
    Seconds to wait for another process's build of the same entry (default
    :data:`LOCK_TIMEOUT_S`).
"""

from __future__ import annotations

import math
import threading
from typing import Any

import casadi as ca
import numpy as np

from ..errors import CompilationError, InvalidInputError, NonFiniteError
from ._cache import (
    _CFLAGS,
    LOCK_TIMEOUT_S,
    _buffer_lock,
    _codegen_disabled,
    _compile,
    _Fallback,
    _no_gcc_message,
    _stats,
    _warn_once,
    cache_dir,
    gcc_available,
)
from ._trust import _state_lock

__all__ = ["LOCK_TIMEOUT_S", "Binding", "CompiledFunction", "cache_dir", "gcc_available"]


class Binding:
    """One thread's buffers of a :class:`CompiledFunction`.

    Attributes:
        inputs:
            One Fortran-order array per input, in the input's shape: write into them, then
            call :meth:`eval`.
        flat_inputs:
            Flat (1-D) views of :attr:`inputs` (``np.copyto(b.flat_inputs[0], q)``).
        outputs:
            One Fortran-order array per output, overwritten by every :meth:`eval`.
        eval:
            Zero-argument callable: evaluate on the current :attr:`inputs` (~0.1 µs, no checks).
    """

    __slots__ = ("_buffer", "eval", "flat_inputs", "inputs", "outputs")

    def __init__(self, function: ca.Function, in_shapes: list[tuple[int, int]], out_shapes: list[tuple[int, int]]):
        self.inputs = [np.zeros(s, order="F") for s in in_shapes]
        self.outputs = [np.zeros(s, order="F") for s in out_shapes]
        self.flat_inputs = [a.reshape(-1, order="F") for a in self.inputs]  # views (F-order is contiguous)
        with _buffer_lock:
            buf, ev = function.buffer()  # own work vectors and memory object (casadi checkout)
        for i, a in enumerate(self.inputs):
            # a.T.data is memoryview(a.T); the stub splits SWIG's (buffer, size) pair into two parameters
            buf.set_arg(i, a.T.data)  # type: ignore[call-arg]
        for i, a in enumerate(self.outputs):
            # a.T.data is memoryview(a.T); the stub splits SWIG's (buffer, size) pair into two parameters
            buf.set_res(i, a.T.data)  # type: ignore[call-arg]
        self._buffer = buf  # ev holds a raw pointer into buf: keep buf (and the arrays) alive with it
        self.eval = ev


class CompiledFunction:
    """A CasADi function bound to numpy buffers for low-overhead calls (thread-safe).

    Args:
        f:
            The CasADi function (SX or MX).  Inputs must be dense vectors or matrices.
        codegen:
            ``True``: generate and compile C with gcc (cached on disk); ``False``: use
            CasADi's SX virtual machine; ``"auto"``: C when gcc is available.  When C cannot
            be had, the VM is used with one :class:`CacheWarning` per process and reason
            (module docstring); ``COOP_GA_CODEGEN=0`` selects the VM silently.
        check_finite:
            Raise :class:`NonFiniteError` when an input contains NaN/inf (cheap; default).
        flags:
            gcc flags (part of the cache key).
        fallback:
            ``False``: raise :class:`CompilationError` instead of falling back to the VM.

    Attributes:
        codegen:
            Whether compiled C is actually used.
        fallback_reason:
            Why the VM is used although C was requested (None otherwise).
        function:
            The evaluated ``casadi.Function`` (the ``casadi.external`` or ``f`` itself).
    """

    def __init__(
        self,
        f: ca.Function,
        codegen: bool | str = "auto",
        check_finite: bool = True,
        flags: tuple[str, ...] = _CFLAGS,
        *,
        fallback: bool = True,
    ):
        if not isinstance(f, ca.Function):
            raise InvalidInputError(f"CompiledFunction needs a casadi.Function, got {type(f).__name__}")
        self.source = f
        self.name = f.name()
        self.check_finite = check_finite
        self.fallback_reason: str | None = None
        self._in_shapes = [f.size_in(i) for i in range(f.n_in())]
        self._out_shapes = [f.size_out(i) for i in range(f.n_out())]
        for i in range(f.n_out()):
            if not f.sparsity_out(i).is_dense():
                raise InvalidInputError(f"output {i} of {f.name()} must be dense (wrap it in casadi.densify)")
        self.function = self._select(f, codegen, flags, fallback)
        self.codegen = self.function is not f
        self._tls = threading.local()
        self._tls.b = Binding(self.function, self._in_shapes, self._out_shapes)

    def _select(self, f: ca.Function, codegen: bool | str, flags: tuple[str, ...], fallback: bool) -> ca.Function:
        """The function to evaluate: compiled C, or ``f`` (VM) with the fallback reason recorded."""
        if not codegen or _codegen_disabled():
            return f
        try:
            if not gcc_available():
                raise _Fallback("no_gcc", _no_gcc_message())
            return _compile(f, flags)
        except _Fallback as e:
            if not fallback:
                raise CompilationError(e.message) from None
            reason, message = e.reason, e.message
        except Exception as e:  # anything unforeseen: still a working (VM) function, never a crash
            if not fallback:
                raise CompilationError(f"compiling {f.name()} failed: {type(e).__name__}: {e}") from e
            reason = "unexpected"
            message = (
                f"coop_ga: compiling {f.name()} failed unexpectedly ({type(e).__name__}: {e}); CasADi "
                "functions run on the (slower) virtual machine. Please report this; set COOP_GA_CODEGEN=0 "
                "to use the VM without this warning."
            )
        self.fallback_reason = reason
        with _state_lock:
            _stats["vm"] += 1
        _warn_once(reason, message)
        return f

    # ------------------------------------------------------------------ per-thread buffers
    def binding(self) -> Binding:
        """The calling thread's :class:`Binding` (created on the thread's first use)."""
        try:
            return self._tls.b
        except AttributeError:
            return self._new_binding()

    def _new_binding(self) -> Binding:
        b = self._tls.b = Binding(self.function, self._in_shapes, self._out_shapes)
        return b

    @property
    def inputs(self) -> list[np.ndarray]:
        """The calling thread's input arrays (write into them, then call :meth:`eval`)."""
        return self.binding().inputs

    @property
    def outputs(self) -> list[np.ndarray]:
        """The calling thread's output arrays (overwritten by its every evaluation)."""
        return self.binding().outputs

    def eval(self) -> None:
        """Evaluate on the current contents of the calling thread's :attr:`inputs` (no checks)."""
        try:
            b = self._tls.b
        except AttributeError:
            b = self._new_binding()
        b.eval()

    @property
    def n_instructions(self) -> int:
        """Number of SX instructions of the source function (-1 if it is not an SX function)."""
        return self.source.n_instructions() if hasattr(self.source, "n_instructions") else -1

    def _load(self, b: Binding, args: tuple[Any, ...]) -> None:
        if len(args) != len(b.inputs):
            raise InvalidInputError(f"{self.name} takes {len(b.inputs)} arguments, got {len(args)}")
        for i, a in enumerate(args):
            flat = b.flat_inputs[i]
            if type(a) is np.ndarray and a.shape == flat.shape:  # hot path: a plain vector
                np.copyto(flat, a, casting="unsafe")
            else:
                dst = b.inputs[i]
                try:
                    a = np.asarray(a, dtype=float)
                except (TypeError, ValueError):
                    raise InvalidInputError(
                        f"argument {i} of {self.name} must be numeric, got {type(a).__name__}"
                    ) from None
                if a.size != flat.size:
                    raise InvalidInputError(
                        f"argument {i} of {self.name} must have {dst.size} entries (shape {dst.shape}), got shape {a.shape}"
                    )
                dst[...] = a if a.shape == dst.shape else a.reshape(dst.shape)
            # one dot product detects NaN/inf (and overflow) cheaply; the full scan runs only then
            if self.check_finite and not math.isfinite(flat.dot(flat)):
                bad = np.flatnonzero(~np.isfinite(flat)).tolist()
                if bad:
                    raise NonFiniteError(f"argument {i} of {self.name} contains NaN or inf at indices {bad}")
                raise InvalidInputError(f"argument {i} of {self.name} is too large (its squared norm overflows)")

    def call_views(self, *args: Any) -> list[np.ndarray]:
        """Evaluate and return the calling thread's output buffers (overwritten by its next call)."""
        try:
            b = self._tls.b
        except AttributeError:
            b = self._new_binding()
        self._load(b, args)
        b.eval()
        return b.outputs

    def __call__(self, *args: Any) -> list[np.ndarray] | np.ndarray:
        """Evaluate; returns a copy of each output (a single array if there is one output)."""
        outs = [o.copy() for o in self.call_views(*args)]
        return outs[0] if len(outs) == 1 else outs
