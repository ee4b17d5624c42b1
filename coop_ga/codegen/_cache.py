"""The disk cache of compiled libraries: build under a lock, verify, load, fall back.

Part of :mod:`coop_ga.codegen` (its docstring describes the cache, the trust model and the
fallbacks); which directories and files may be trusted is :mod:`coop_ga.codegen._trust`.
"""

from __future__ import annotations

import contextlib
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
import threading
import time
from pathlib import Path
from typing import Self

import casadi as ca

from ..diagnostics import warn
from ..errors import CacheWarning, CompilationError
from ._trust import (
    _CacheDir,
    _candidates,
    _elf_problem,
    _identity,
    _mark_unwritable,
    _oserror,
    _private_dir,
    _read_own_file,
    _state_lock,
    _Unverified,
)

_log = logging.getLogger("coop_ga.codegen")

# -march=native: FMA/AVX give ~25 % on the generated straight-line code (measured on the
# cooperative task of three_franka); the cache key includes the CPU signature, so a
# library built for one CPU is never loaded on another.  No -ffast-math: NaN must survive
# so that bad input is detected.
_CFLAGS = ("-O2", "-march=native", "-fPIC", "-shared", "-fno-math-errno", "-fno-trapping-math")

#: Seconds a build waits for another process holding the same entry's lock before it builds the
#: entry privately (``$COOP_GA_LOCK_TIMEOUT`` overrides).  Only your own processes can hold a lock
#: (lock files are 0600 in a directory no one else can write), so the wait is a build of yours,
#: normally 1-3 s, longer on a loaded machine; the timeout only bounds a stuck one.
LOCK_TIMEOUT_S = 30.0

# Largest library read for verification (the generated ones are ~50 KB-2 MB).
_MAX_LIBRARY_BYTES = 1 << 30

# Per-process counters (read by the reliability tests and useful when diagnosing a cache):
# libraries compiled, verified entries loaded, entries rebuilt after failing verification,
# files refused (once each) by the checks before dlopen, entries built privately after a lock timeout,
# functions that fell back to the VM.
_stats = {"compiled": 0, "loaded": 0, "rebuilt": 0, "rejected": 0, "private": 0, "vm": 0}

_warned: set[str] = set()  # fallback reasons already warned about in this process
_loaded: dict[str, ca.Function] = {}  # verified library path -> its casadi.external
_rejected: set[str] = set()  # "<library>: <why>" refused before dlopen (logged and counted once)
_buffer_lock = threading.Lock()  # FunctionBuffer creation (checkout) is rare; serialize it

# gcc messages that mean "the output directory is the problem", not the compiler
_DIR_FAILURES = ("No space left on device", "Read-only file system", "Permission denied", "Disk quota exceeded")


class _DirUnusable(Exception):
    """A cache directory cannot be written (internal: triggers the next directory)."""


class _LockTimeout(Exception):
    """Another process held an entry's lock past the lock timeout (internal: build privately)."""


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


def _lock_timeout() -> float:
    """Seconds to wait for an entry's lock: ``$COOP_GA_LOCK_TIMEOUT``, else :data:`LOCK_TIMEOUT_S`."""
    raw = os.environ.get("COOP_GA_LOCK_TIMEOUT", "").strip()
    if not raw:
        return LOCK_TIMEOUT_S
    try:
        value = float(raw)
    except ValueError:
        value = math.nan
    if math.isfinite(value) and value >= 0:
        return value
    _warn_once(
        "bad_lock_timeout",
        f"coop_ga: COOP_GA_LOCK_TIMEOUT={raw!r} is not a number of seconds >= 0; waiting at most "
        f"{LOCK_TIMEOUT_S:g} s for a compile lock. Set it to e.g. 60, or unset it.",
    )
    return LOCK_TIMEOUT_S


def cache_dir() -> Path:
    """The directory compiled libraries are written to (its real path).

    ``$COOP_GA_CACHE`` or ``~/.cache/coop_ga`` (created 0700 if needed); if that cannot be
    written or trusted (module docstring), the per-user temporary cache
    ``<tempfile.gettempdir()>/coop_ga-<uid>``, else a private directory of this process (with
    one :class:`CacheWarning` per process).  Raises :class:`CompilationError` when none is usable.
    """
    tried: list[_CacheDir] = []
    for cd in _candidates():
        if cd.writable and cd.path is not None:
            _warn_fell_back(tried, cd)
            return cd.path
        tried.append(cd)
    raise CompilationError(_no_cache_message(tried))


_UNTRUSTED_FIX = (
    "Another user could have planted a library in a directory they can write, and it would run inside this "
    "process. Fix: make the directory named writable only by you (chmod go-w, and delete the libraries it "
    "holds: they are rebuilt), or set COOP_GA_CACHE to a directory only you can write (created 0700 if missing)."
)


def _warn_fell_back(tried: list[_CacheDir], used: _CacheDir) -> None:
    if not tried:
        return
    where = "; ".join(f"{cd.shown} ({cd.problem})" for cd in tried)
    kind = "a private directory of this process, removed at exit" if used.role == "private" else "lost at reboot"
    notes = "".join(f" Note: {cd.note}." for cd in [*tried, used] if cd.note)
    untrusted = any(cd.untrusted for cd in tried)
    fix = _UNTRUSTED_FIX if untrusted else "Set COOP_GA_CACHE to a writable directory."
    _warn_once(
        "cache_untrusted" if untrusted else "cache_unusable",
        f"coop_ga: the compile cache is not used: {where}; compiled libraries go to {used.shown} instead "
        f"({kind}).{notes} {fix}",
    )


def _no_cache_message(tried: list[_CacheDir]) -> str:
    where = "; ".join(f"{cd.shown}: {cd.problem}" for cd in tried)
    fix = _UNTRUSTED_FIX if any(cd.untrusted for cd in tried) else "Set COOP_GA_CACHE to a writable directory."
    return (
        f"coop_ga: no usable compile cache ({where}); CasADi functions run on the (slower, same results) "
        f"virtual machine. {fix}"
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


def _verify(so: Path) -> tuple[int, ...] | None:
    """Identity of the library ``so`` if it may be ``dlopen``ed; None if it is absent or refused (the
    caller rebuilds it).  Checked before ``dlopen``: a damaged library crashes the process."""
    try:
        sidecar, _ = _read_own_file(Path(f"{so}.sha256"), 4096)
        data, ident = _read_own_file(so, _MAX_LIBRARY_BYTES)
        if sidecar.decode("ascii", "replace").split()[:1] != [hashlib.sha256(data).hexdigest()]:
            raise _Unverified("it does not match its checksum")
        problem = _elf_problem(data)
        if problem is not None:
            raise _Unverified(problem)
    except FileNotFoundError:
        return None
    except _Unverified as e:
        with _state_lock:
            seen = f"{so}: {e}" in _rejected
            _rejected.add(f"{so}: {e}")
            _stats["rejected"] += not seen
        if not seen:
            _log.warning("cached library %s is not loaded (%s); rebuilding it", so, e)
        return None
    return ident


def _matches(lib: ca.Function, f: ca.Function) -> bool:
    """The loaded library has ``f``'s signature (a cheap check that the right code was loaded)."""
    if lib.n_in() != f.n_in() or lib.n_out() != f.n_out():
        return False
    return all(lib.sparsity_in(i) == f.sparsity_in(i) for i in range(f.n_in())) and all(
        lib.sparsity_out(i) == f.sparsity_out(i) for i in range(f.n_out())
    )


def _try_load(so: Path, f: ca.Function) -> ca.Function | None:
    """Load a verified entry of a trusted directory; None if it is missing, refused or does not load
    (then rebuild)."""
    k = str(so)
    with _state_lock:
        lib = _loaded.get(k)
    if lib is not None:
        return lib
    ident = _verify(so)
    if ident is None:
        return None
    try:
        # the name must still denote the verified file (only you or root can change the directory)
        if _identity(os.stat(so, follow_symlinks=False)) != ident:
            return None
        lib = ca.external(f.name(), k)
        if not _matches(lib, f):
            return None
    except OSError:
        return None
    except RuntimeError as e:  # casadi's error for anything dlopen/dlsym reject
        _log.warning("cached library %s failed to load (%s); rebuilding it", so, e)
        return None
    with _state_lock:
        _loaded[k] = lib
        _stats["loaded"] += 1
    return lib


# ---------------------------------------------------------------------------- building
def _write_new(path: Path, data: bytes, sync: bool = True) -> None:
    """Write a new file, mode 0600 whatever the umask (never through an existing name or link)."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | os.O_CLOEXEC, 0o600)
    try:
        os.fchmod(fd, 0o600)
        view = memoryview(data)
        while view:
            view = view[os.write(fd, view) :]
        if sync:
            os.fsync(fd)
    finally:
        os.close(fd)


def _atomic_write(path: Path, data: bytes) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp")
    try:
        _write_new(tmp, data)
        os.replace(tmp, path)
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()


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


def _run_gcc(tmp: Path, c: Path, out: Path, flags: tuple[str, ...], name: str) -> None:
    """gcc in ``tmp`` on relative names (the library does not depend on the temporary path)."""
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


def _build(d: Path, so: Path, src: str, flags: tuple[str, ...], name: str) -> None:
    """Compile ``src`` into ``so`` (caller holds the entry's lock): build in ``d``, then os.replace.

    The build directory lies inside ``d`` so that the final ``os.replace`` is a rename on one
    filesystem (atomic), never a copy into the existing entry.
    """
    stem = so.name[: -len(".so")]
    _remove_stale_temps(d, stem)
    tmp = d / f".{stem}.{os.getpid()}.{secrets.token_hex(4)}.build"
    c, out = tmp / f"{stem}.c", tmp / so.name
    try:
        try:
            os.mkdir(tmp, 0o700)  # at most 0700 whatever the umask; gcc's output is private until chmod'ed
            _write_new(c, src.encode(), sync=False)
        except OSError as e:
            raise _DirUnusable(_oserror(e)) from None
        _run_gcc(tmp, c, out, flags, name)
        try:
            fd = os.open(out, os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC)
            try:
                os.fchmod(fd, 0o600)  # gcc made it 0777 minus the umask
                os.fsync(fd)  # the data is on disk before the name points at it (crash consistency)
                digest = hashlib.sha256(_read_fd(fd)).hexdigest()
            finally:
                os.close(fd)
            os.replace(out, so)  # atomic; never an in-place rewrite of a library others have mapped
            _atomic_write(Path(f"{so}.sha256"), f"{digest}  {so.name}\n".encode())
        except OSError as e:
            raise _DirUnusable(_oserror(e)) from None
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    with _state_lock:
        _stats["compiled"] += 1
    _log.info("compiled %s", so)


def _read_fd(fd: int) -> bytes:
    chunks = []
    while chunk := os.read(fd, 1 << 20):
        chunks.append(chunk)
    return b"".join(chunks)


def _open_lock(path: Path) -> int:
    """A descriptor of the entry's lock file, a regular file of yours that only you can open (0600).

    ``flock`` needs only read access: anyone who can open a lock file can hold it forever.  A lock
    file others could open (left by an older version under a loose umask) is replaced by a new
    one; whoever holds the old one then excludes no one.
    """
    flags = os.O_RDONLY | os.O_CREAT | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC
    try:
        for _ in range(3):
            fd = os.open(path, flags, 0o600)
            st = os.fstat(fd)
            if stat.S_ISREG(st.st_mode) and st.st_uid == os.geteuid() and not st.st_mode & 0o077:
                return fd
            os.close(fd)
            with contextlib.suppress(FileNotFoundError):
                if os.stat(path, follow_symlinks=False).st_ino == st.st_ino:  # not one replaced meanwhile
                    os.unlink(path)
        raise OSError(errno.EPERM, f"cannot make the lock file {path} private")
    except OSError as e:
        raise _DirUnusable(_oserror(e)) from None


def _flock(fd: int, timeout: float | None) -> bool:
    """Take an exclusive ``flock``, waiting at most ``timeout`` s (None: forever); False on timeout."""
    if timeout is None:
        fcntl.flock(fd, fcntl.LOCK_EX)
        return True
    deadline, pause = time.monotonic() + timeout, 0.002
    while True:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return True
        except BlockingIOError:
            pass
        left = deadline - time.monotonic()
        if left <= 0:
            return False
        time.sleep(min(pause, left))
        pause = min(2 * pause, 0.05)


class _EntryLock:
    """Exclusive ``flock`` on ``<entry>.lock``; conflicts across processes *and* threads
    (each acquisition opens its own file description).  Raises :class:`_LockTimeout` after
    ``timeout`` seconds (None: waits as long as it takes)."""

    def __init__(self, path: Path, timeout: float | None):
        self.path = path
        self.timeout = timeout
        self.fd = -1

    def __enter__(self) -> Self:
        self.fd = _open_lock(self.path)
        try:
            if _flock(self.fd, self.timeout):
                return self
        except OSError as e:
            if e.errno in (errno.ENOLCK, errno.EOPNOTSUPP, errno.ENOSYS):
                # filesystem without locks: still correct (os.replace is atomic), at worst compiled twice
                _log.warning("cannot lock %s (%s); compiling without the lock", self.path, e)
                return self
            self.__exit__()
            raise _DirUnusable(_oserror(e)) from None
        self.__exit__()
        raise _LockTimeout(str(self.path))

    def __exit__(self, *exc: object) -> None:
        if self.fd >= 0:
            os.close(self.fd)  # closing the last descriptor releases the flock
            self.fd = -1


def _load_or_build(cd: _CacheDir, f: ca.Function, src: str, key: str, flags: tuple[str, ...]) -> ca.Function:
    """The entry of ``f`` in the (trusted, writable) directory ``cd``, built under its lock if needed."""
    assert cd.path is not None
    d, stem = cd.path, f"{f.name()}_{key}"
    so = d / f"{stem}.so"
    try:
        # the private directory is this process's alone: a wait there is for one of its own threads
        with _EntryLock(d / f"{stem}.lock", None if cd.role == "private" else _lock_timeout()):
            lib = _try_load(so, f)  # another process may have built it while we waited for the lock
            if lib is not None:
                return lib
            rebuilt = os.path.lexists(so)
            _build(d, so, src, flags, f.name())
            if rebuilt:
                with _state_lock:
                    _stats["rebuilt"] += 1
            lib = _try_load(so, f)
    except _LockTimeout as e:
        return _build_privately(f, src, key, flags, Path(str(e)))
    if lib is None:
        raise _Fallback(
            "load_failed",
            f"coop_ga: the freshly compiled library {so} does not load; CasADi functions run on the (slower) "
            "virtual machine. Check that gcc produces working shared libraries (or set COOP_GA_CODEGEN=0).",
        )
    return lib


def _build_privately(f: ca.Function, src: str, key: str, flags: tuple[str, ...], lock: Path) -> ca.Function:
    """After a lock timeout: build the entry in this process's private directory."""
    pd = _private_dir()
    waited = f"another process held the lock {lock} for more than {_lock_timeout():g} s"
    if not pd.writable:
        raise _Fallback(
            "lock_timeout",
            f"coop_ga: {waited}, and there is no private directory to build {f.name()} in ({pd.problem}); "
            "it runs on the (slower) virtual machine. `fuser -v` on the lock file shows the holder.",
        )
    _warn_once(
        "lock_timeout",
        f"coop_ga: {waited}; {f.name()} was compiled in {pd.shown} instead (private, removed at exit). "
        "`fuser -v` on the lock file shows the holder (a stuck or very slow build); COOP_GA_LOCK_TIMEOUT "
        "sets the wait in seconds.",
    )
    with _state_lock:
        _stats["private"] += 1
    try:
        return _load_or_build(pd, f, src, key, flags)
    except _DirUnusable as e:  # not the directory that timed out: do not let the caller blame that one
        _mark_unwritable(pd, str(e))
        raise _Fallback(
            "no_cache",
            f"coop_ga: {waited}, and building {f.name()} in {pd.shown} failed ({e}); "
            "it runs on the (slower) virtual machine.",
        ) from None


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


def _source(f: ca.Function, flags: tuple[str, ...]) -> tuple[ca.Function, str, str]:
    """``f`` renamed, its generated C source and the cache key."""
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
    return f, src, key


def _compile(f: ca.Function, flags: tuple[str, ...]) -> ca.Function:
    """Generate C for ``f``, compile (cached) and load it as ``casadi.external``.

    Raises :class:`_Fallback` when compiled code cannot be had (the caller uses the VM).
    """
    f, src, key = _source(f, flags)
    entry = f"{f.name()}_{key}.so"
    # a verified entry is loaded without writing anything, so a read-only (pre-populated) cache works
    tried: list[_CacheDir] = []
    for cd in _candidates(existing=True):
        if cd.path is not None and cd.loadable and (lib := _try_load(cd.path / entry, f)) is not None:
            _warn_fell_back(tried, cd)
            return lib
        if not cd.writable:
            tried.append(cd)
    tried = []
    for cd in _candidates():
        if cd.writable:
            try:
                lib = _load_or_build(cd, f, src, key, flags)
            except _DirUnusable as e:  # e.g. the disk filled up after the probe
                cd = _mark_unwritable(cd, str(e))
            else:
                _warn_fell_back(tried, cd)
                return lib
        tried.append(cd)
    raise _Fallback("no_cache", _no_cache_message(tried))
