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
the cache directory* (same filesystem) and moved over the entry with ``os.replace`` (atomic, a new inode; a process
that mapped the old file keeps it).  The checksum is written (atomically) after the
library and verified before every ``dlopen``, so a truncated or damaged library is never
loaded (that is a SIGBUS, not an exception).  Building takes an exclusive ``flock`` on
the lock file, so N processes that need the same new entry compile it once; the others
wait and load it.  An entry that fails verification or loading is rebuilt under the
lock.  Loading a verified entry writes nothing, so a read-only, pre-populated cache works.

Fallbacks (never an exception other than :class:`~coop_ga.errors.CoopGAError`)
------------------------------------------------------------------------------
* cache directory unusable (read-only, full, a file in the way, mkdir fails) → the
  per-user temporary cache ``<tempfile.gettempdir()>/coop_ga-<uid>`` (mode 0700, ours);
* that unusable too, no ``gcc``, gcc failing, C generation or loading failing → the
  CasADi virtual machine (the uncompiled ``casadi.Function``: same results, ~5-20x slower).

Each fallback emits one :class:`~coop_ga.errors.CacheWarning` per process and reason
(not one per function), naming the problem and the fix.  ``CompiledFunction(...,
fallback=False)`` raises :class:`~coop_ga.errors.CompilationError` instead.

Environment
-----------
``COOP_GA_CACHE``
    Cache directory (default ``~/.cache/coop_ga``).
``COOP_GA_CODEGEN``
    ``0`` / ``false`` / ``no`` / ``off``: never generate C, always use the CasADi VM,
    without a warning (e.g. on machines without a compiler).
"""

from __future__ import annotations

import errno
import fcntl
import functools
import hashlib
import logging
import math
import os
import secrets
import shutil
import stat
import subprocess
import tempfile
import threading
from pathlib import Path
from typing import Any, Self

import casadi as ca
import numpy as np

from .diagnostics import warn
from .errors import CacheWarning, CompilationError, InvalidInputError, NonFiniteError

__all__ = ["Binding", "CompiledFunction", "cache_dir", "gcc_available"]

_log = logging.getLogger(__name__)

# -march=native: FMA/AVX give ~25 % on the generated straight-line code (measured on the
# cooperative task of three_franka); the cache key includes the CPU signature, so a
# library built for one CPU is never loaded on another.  No -ffast-math: NaN must survive
# so that bad input is detected.
_CFLAGS = ("-O2", "-march=native", "-fPIC", "-shared", "-fno-math-errno", "-fno-trapping-math")

# Per-process counters (read by the reliability tests and useful when diagnosing a cache):
# libraries compiled, verified entries loaded, entries rebuilt after failing verification,
# functions that fell back to the VM.
_stats = {"compiled": 0, "loaded": 0, "rebuilt": 0, "vm": 0}

_state_lock = threading.RLock()  # guards the module state below (threads may compile concurrently)
_warned: set[str] = set()  # fallback reasons already warned about in this process
_dir_errors: dict[str, str] = {}  # cache directory -> why it is unusable (found once per process)
_loaded: dict[str, ca.Function] = {}  # verified library path -> its casadi.external
_buffer_lock = threading.Lock()  # FunctionBuffer creation (checkout) is rare; serialize it

# gcc messages that mean "the output directory is the problem", not the compiler
_DIR_FAILURES = ("No space left on device", "Read-only file system", "Permission denied", "Disk quota exceeded")


class _DirUnusable(Exception):
    """A cache directory cannot be written (internal: triggers the next directory)."""


class _Fallback(Exception):
    """Compiled code is unavailable; use the VM (internal).  ``reason`` keys the warning."""

    def __init__(self, reason: str, message: str):
        super().__init__(message)
        self.reason = reason
        self.message = message


def _warn_once(reason: str, message: str) -> None:
    with _state_lock:
        if reason in _warned:
            return
        _warned.add(reason)
    warn(message, CacheWarning, key=reason)


@functools.lru_cache(maxsize=1)
def _cpu_signature() -> str:
    """CPU model and feature flags (Linux), part of the compiled-library cache key."""
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        import platform

        return platform.machine() + platform.processor()
    keep = [ln for ln in text.splitlines() if ln.startswith(("model name", "flags"))][:2]
    return "\n".join(keep)


def _codegen_disabled() -> bool:
    return os.environ.get("COOP_GA_CODEGEN", "").strip().lower() in ("0", "false", "no", "off")


def _configured_dir() -> Path:
    env = os.environ.get("COOP_GA_CACHE")
    if env:
        return Path(env)
    try:
        return Path.home() / ".cache" / "coop_ga"
    except (RuntimeError, KeyError, OSError):  # no HOME and no passwd entry
        return Path("/nonexistent-home/.cache/coop_ga")


def _fallback_dir() -> Path:
    try:
        base = tempfile.gettempdir()
    except (OSError, FileNotFoundError):  # no usable temporary directory at all
        base = "/tmp"
    uid = os.getuid() if hasattr(os, "getuid") else 0
    return Path(base) / f"coop_ga-{uid}"


def _probe_dir(d: Path, private: bool) -> str | None:
    """Create ``d`` if needed and check that a file can be created in it; returns why not (or None).

    ``private``: ``d`` is the shared-/tmp fallback, so it must be a real directory owned by us
    and writable by nobody else (else another user could plant a library we would load).
    """
    try:
        d.mkdir(parents=True, exist_ok=True, mode=0o700 if private else 0o777)
        if private:
            st = os.lstat(d)
            if not stat.S_ISDIR(st.st_mode):
                return "it is not a directory"
            if hasattr(os, "getuid") and st.st_uid != os.getuid():
                return f"it is owned by uid {st.st_uid}, not by this user"
            if st.st_mode & 0o022:
                os.chmod(d, 0o700)  # ours, but group/world-writable: close it
        fd, probe = tempfile.mkstemp(dir=d, prefix=".probe-")
        try:
            os.write(fd, b"coop_ga")
        finally:
            os.close(fd)
            os.unlink(probe)
    except OSError as e:
        return f"{type(e).__name__}: {e.strerror or e}"
    return None


def _dir_error(d: Path, private: bool) -> str | None:
    """Memoized :func:`_probe_dir` (probing once per process and directory)."""
    k = str(d)
    with _state_lock:
        if k in _dir_errors:
            return _dir_errors[k] or None
        err = _probe_dir(d, private)
        _dir_errors[k] = err or ""
        return err


def _mark_unusable(d: Path, why: str) -> None:
    with _state_lock:
        _dir_errors[str(d)] = why


def _dirs() -> list[tuple[Path, bool]]:
    """Candidate cache directories in order of preference, each with whether it is the private fallback."""
    primary, fb = _configured_dir(), _fallback_dir()
    return [(primary, False)] + ([(fb, True)] if fb != primary else [])


def cache_dir() -> Path:
    """The directory compiled libraries are written to.

    ``$COOP_GA_CACHE`` or ``~/.cache/coop_ga`` (created if needed); if that cannot be
    written, the per-user temporary cache ``<tempfile.gettempdir()>/coop_ga-<uid>`` (with
    one :class:`CacheWarning` per process).  Raises :class:`CompilationError` when neither
    is usable.
    """
    tried: list[tuple[Path, str]] = []
    for d, private in _dirs():
        err = _dir_error(d, private)
        if err is None:
            if tried:
                _warn_fell_back(tried[0][0], tried[0][1], d)
            return d
        tried.append((d, err))
    raise CompilationError(_no_cache_message(tried))


def _warn_fell_back(primary: Path, why: str, used: Path) -> None:
    _warn_once(
        "cache_unusable",
        f"coop_ga: the compile cache {primary} is unusable ({why}); compiled libraries go to {used} instead "
        "(lost at reboot). Set COOP_GA_CACHE to a writable directory.",
    )


def _no_cache_message(tried: list[tuple[Path, str]]) -> str:
    where = "; ".join(f"{d}: {err}" for d, err in tried)
    return (
        f"coop_ga: no writable compile cache ({where}); CasADi functions run on the (slower, same results) "
        "virtual machine. Set COOP_GA_CACHE to a writable directory."
    )


def gcc_available() -> bool:
    """Whether a ``gcc`` is on ``PATH`` (it may still fail; failures fall back to the VM)."""
    return shutil.which("gcc") is not None


def _rename(f: ca.Function, name: str) -> ca.Function:
    """Re-trace ``f`` under a new name (avoids clashes such as ``expf`` with libm)."""
    if f.is_a("SXFunction"):
        sx_args = f.sx_in()
        return ca.Function(name, sx_args, f.call(sx_args), f.name_in(), f.name_out())
    mx_args = f.mx_in()
    return ca.Function(name, mx_args, f.call(mx_args), f.name_in(), f.name_out())


def _sha256_file(path: Path) -> str | None:
    """sha256 of a file read with ``read()`` (never mmap: a truncated file must not SIGBUS), or None."""
    h = hashlib.sha256()
    try:
        with open(path, "rb") as fh:
            for chunk in iter(lambda: fh.read(1 << 20), b""):
                h.update(chunk)
    except OSError:
        return None
    return h.hexdigest()


def _verified(so: Path) -> bool:
    """The library exists, is non-empty and matches its checksum sidecar."""
    try:
        want = Path(str(so) + ".sha256").read_text().split()[0]
    except (OSError, IndexError, UnicodeDecodeError):
        return False
    return len(want) == 64 and _sha256_file(so) == want


def _matches(lib: ca.Function, f: ca.Function) -> bool:
    """The loaded library has ``f``'s signature (a cheap check that the right code was loaded)."""
    if lib.n_in() != f.n_in() or lib.n_out() != f.n_out():
        return False
    return all(lib.sparsity_in(i) == f.sparsity_in(i) for i in range(f.n_in())) and all(
        lib.sparsity_out(i) == f.sparsity_out(i) for i in range(f.n_out())
    )


def _try_load(so: Path, f: ca.Function) -> ca.Function | None:
    """Load a verified entry; None if it is missing, unverified or does not load (then rebuild)."""
    k = str(so)
    with _state_lock:
        lib = _loaded.get(k)
    if lib is not None:
        return lib
    if not _verified(so):  # checked *before* dlopen: a damaged library would crash the process
        return None
    try:
        lib = ca.external(f.name(), k)
        if not _matches(lib, f):
            return None
    except RuntimeError as e:  # casadi's error for anything dlopen/dlsym reject
        _log.warning("cached library %s failed to load (%s); rebuilding it", so, e)
        return None
    with _state_lock:
        _loaded[k] = lib
        _stats["loaded"] += 1
    return lib


def _atomic_write(path: Path, data: bytes) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp")
    try:
        with open(tmp, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def _fsync(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _remove_stale_temps(d: Path, stem: str) -> None:
    """Delete temporaries of this entry left by killed builders (called with the entry locked)."""
    for p in d.glob(f".{stem}.*"):
        try:
            if p.is_dir() and not p.is_symlink():
                shutil.rmtree(p)
            else:
                p.unlink()
        except OSError:
            pass


def _build(d: Path, so: Path, src: str, flags: tuple[str, ...], name: str) -> None:
    """Compile ``src`` into ``so`` (caller holds the entry's lock): build in ``d``, then os.replace.

    The build directory lies inside ``d`` so that the final ``os.replace`` is a rename on one
    filesystem (atomic), never a copy into the existing entry.  gcc runs in it on relative
    names, so the library does not depend on the temporary path (reproducible bytes).
    """
    stem = so.name[: -len(".so")]
    _remove_stale_temps(d, stem)
    tmp = d / f".{stem}.{os.getpid()}.{secrets.token_hex(4)}.build"
    c, out = tmp / f"{stem}.c", tmp / so.name
    try:
        try:
            tmp.mkdir(mode=0o700)
            c.write_text(src)
        except OSError as e:
            raise _DirUnusable(f"{type(e).__name__}: {e.strerror or e}") from None
        cmd = ["gcc", *flags, c.name, "-o", out.name, "-lm"]
        try:
            res = subprocess.run(cmd, cwd=tmp, check=False, capture_output=True, text=True, errors="replace")
        except FileNotFoundError:
            raise _Fallback("no_gcc", _no_gcc_message()) from None
        except OSError as e:
            raise _Fallback("gcc_failed", _gcc_failed_message(name, f"{type(e).__name__}: {e}")) from None
        if res.returncode != 0 or not out.is_file():
            err = res.stderr.strip()
            why = [ln for ln in err.splitlines() if any(s in ln for s in _DIR_FAILURES)]
            if why:  # e.g. "ld: final link failed: No space left on device": the directory, not the compiler
                raise _DirUnusable(why[0].strip())
            raise _Fallback("gcc_failed", _gcc_failed_message(name, f"exit code {res.returncode}: {err[-1500:]}"))
        try:
            _fsync(out)  # the data is on disk before the name points at it (crash consistency)
            digest = _sha256_file(out)
            os.replace(out, so)  # atomic; never an in-place rewrite of a library others have mapped
            _atomic_write(Path(str(so) + ".sha256"), f"{digest}  {so.name}\n".encode())
        except OSError as e:
            raise _DirUnusable(f"{type(e).__name__}: {e.strerror or e}") from None
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    with _state_lock:
        _stats["compiled"] += 1
    _log.info("compiled %s", so)


class _EntryLock:
    """Exclusive ``flock`` on ``<entry>.lock``; conflicts across processes *and* threads
    (each acquisition opens its own file description)."""

    def __init__(self, path: Path):
        self.path = path
        self.fd = -1

    def __enter__(self) -> Self:
        try:
            self.fd = os.open(self.path, os.O_RDONLY | os.O_CREAT, 0o666)  # flock needs no write access
        except OSError as e:
            raise _DirUnusable(f"{type(e).__name__}: {e.strerror or e}") from None
        while True:
            try:
                fcntl.flock(self.fd, fcntl.LOCK_EX)
                return self
            except InterruptedError:
                continue
            except OSError as e:
                if e.errno in (errno.ENOLCK, errno.EOPNOTSUPP, errno.ENOSYS):
                    # filesystem without locks: still correct (os.replace is atomic), at worst compiled twice
                    _log.warning("cannot lock %s (%s); compiling without the lock", self.path, e)
                    return self
                os.close(self.fd)
                self.fd = -1
                raise _DirUnusable(f"{type(e).__name__}: {e.strerror or e}") from None

    def __exit__(self, *exc: object) -> None:
        if self.fd >= 0:
            os.close(self.fd)  # closing the last descriptor releases the flock
            self.fd = -1


def _load_or_build(d: Path, f: ca.Function, src: str, key: str, flags: tuple[str, ...]) -> ca.Function:
    so = d / f"{f.name()}_{key}.so"
    lib = _try_load(so, f)
    if lib is not None:
        return lib
    with _EntryLock(d / f"{f.name()}_{key}.lock"):
        lib = _try_load(so, f)  # another process may have built it while we waited for the lock
        if lib is not None:
            return lib
        rebuilt = so.exists()
        _build(d, so, src, flags, f.name())
        if rebuilt:
            with _state_lock:
                _stats["rebuilt"] += 1
        lib = _try_load(so, f)
    if lib is None:
        raise _Fallback(
            "load_failed",
            f"coop_ga: the freshly compiled library {so} does not load; CasADi functions run on the (slower) "
            "virtual machine. Check that gcc produces working shared libraries (or set COOP_GA_CODEGEN=0).",
        )
    return lib


def _no_gcc_message() -> str:
    return (
        "coop_ga: gcc was not found on PATH; CasADi functions run on the (slower, same results) virtual "
        "machine. Install gcc (e.g. apt-get install gcc), or set COOP_GA_CODEGEN=0 to use the VM without "
        "this warning."
    )


def _gcc_failed_message(name: str, detail: str) -> str:
    return (
        f"coop_ga: compiling {name} with gcc failed ({detail}); CasADi functions run on the (slower, same "
        "results) virtual machine. Check the compiler (gcc --version, a test compile), or set "
        "COOP_GA_CODEGEN=0 to use the VM without this warning."
    )


def _compile(f: ca.Function, flags: tuple[str, ...]) -> ca.Function:
    """Generate C for ``f``, compile (cached) and load it as ``casadi.external``.

    Raises :class:`_Fallback` when compiled code cannot be had (the caller uses the VM).
    """
    try:
        f = _rename(f, "coop_ga_" + f.name())
        cg = ca.CodeGenerator(f"{f.name()}.c", {"with_header": False, "casadi_real": "double"})
        cg.add(f)
        src = cg.dump()  # in memory: no dependence on a usable TMPDIR
    except (RuntimeError, NotImplementedError) as e:  # e.g. a function CasADi cannot generate C for
        raise _Fallback(
            "codegen_failed",
            f"coop_ga: CasADi cannot generate C for {f.name()} ({e}); it runs on the (slower) virtual machine.",
        ) from None
    version = ca.__version__  # type: ignore[attr-defined]  # casadi's stubs omit __version__ (set at import)
    key = hashlib.sha256((src + " ".join(flags) + version + _cpu_signature()).encode()).hexdigest()[:20]
    entry = f"{f.name()}_{key}.so"
    dirs = _dirs()
    # a verified entry is loaded without writing anything, so a read-only (pre-populated) cache works;
    # the shared-/tmp fallback only once it has passed the ownership check (no planted libraries)
    for d, private in dirs:
        if private and not (d.is_dir() and _dir_error(d, private) is None):
            continue
        lib = _try_load(d / entry, f)
        if lib is not None:
            return lib
    tried: list[tuple[Path, str]] = []
    for d, private in dirs:
        err = _dir_error(d, private)
        if err is None:
            try:
                lib = _load_or_build(d, f, src, key, flags)
            except _DirUnusable as e:  # e.g. the disk filled up after the probe
                err = str(e)
                _mark_unusable(d, err)
            else:
                if tried:
                    _warn_fell_back(tried[0][0], tried[0][1], d)
                return lib
        tried.append((d, err))
    raise _Fallback("no_cache", _no_cache_message(tried))


class Binding:
    """One thread's buffers of a :class:`CompiledFunction`.

    Attributes
    ----------
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

    Parameters
    ----------
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

    Attributes
    ----------
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
