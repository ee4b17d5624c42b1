"""Which cache directories and files may be trusted: only what no other user can write.

Part of :mod:`coop_ga.codegen` (its docstring states the trust model).  A directory is checked
once per process and role (:func:`_check`); every later file operation uses its real path.
"""

from __future__ import annotations

import atexit
import contextlib
import functools
import grp
import os
import pwd
import shutil
import stat
import struct
import tempfile
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from dataclasses import replace as _replace
from pathlib import Path

_state_lock = threading.RLock()  # guards the state of coop_ga.codegen (threads may compile concurrently)
_checked: dict[tuple[str, str], _CacheDir] = {}  # (directory, role) -> its check (once per process)
_private: dict[int, _CacheDir] = {}  # pid -> that process's private build directory


class _Unverified(Exception):
    """A cached file must not be loaded (internal: the entry is rebuilt); the message says why."""


def _oserror(e: OSError) -> str:
    return f"{type(e).__name__}: {e.strerror or e}"


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
    except OSError:  # no usable temporary directory at all (FileNotFoundError)
        base = "/tmp"
    uid = os.getuid() if hasattr(os, "getuid") else 0
    return Path(base) / f"coop_ga-{uid}"


@dataclass(frozen=True)
class _CacheDir:
    """A candidate cache directory as checked (once per process).

    ``path`` is its real path (links resolved), used for every later file operation, so a link
    changed afterwards changes nothing; None when the directory does not exist.
    """

    shown: Path  # as configured (messages)
    role: str  # "primary", "fallback" (per-user, in the temporary directory) or "private" (mkdtemp)
    path: Path | None = None
    untrusted: str | None = None  # why nothing may be loaded from it
    unwritable: str | None = None  # why nothing can be written into it
    note: str = ""  # what was done to it (the fallback closed and emptied)

    @property
    def loadable(self) -> bool:
        return self.path is not None and self.untrusted is None

    @property
    def writable(self) -> bool:
        return self.loadable and self.unwritable is None

    @property
    def problem(self) -> str:
        return self.untrusted or self.unwritable or "unusable"


def _home() -> Path | None:
    try:
        return Path(os.path.realpath(Path.home()))
    except (RuntimeError, KeyError, OSError):
        return None


@functools.lru_cache(maxsize=16)
def _private_group(gid: int, uid: int) -> bool:
    """Whether group ``gid`` is the private group of user ``uid`` and has no other member.

    Debian, Ubuntu and Fedora give every user a group of their own and a umask of 002, so their
    directories are group-writable without anyone else being able to write them.  The rule of
    Debian's OpenSSH (StrictModes, patch user-group-modes): the group is named after the user, is
    the user's primary group, no other user has it as primary group, and it lists no other member.
    """
    try:
        user, group = pwd.getpwuid(uid), grp.getgrgid(gid)
        others = [p.pw_name for p in pwd.getpwall() if p.pw_gid == gid and p.pw_uid != uid]
    except (KeyError, OSError):
        return False
    return group.gr_name == user.pw_name and user.pw_gid == gid and not others and set(group.gr_mem) <= {user.pw_name}


def _writable_by_others(st: os.stat_result) -> str | None:
    """Who besides the owner can write a file or directory (None: no one; mode bits, ACL masks included)."""
    mode = stat.S_IMODE(st.st_mode)
    group = bool(mode & 0o020) and not _private_group(st.st_gid, st.st_uid)
    who = " and ".join(w for w, bit in (("its group", group), ("other users", mode & 0o002)) if bit)
    return who or None


def _component_problem(p: Path, st: os.stat_result, euid: int, leaf: bool) -> str | None:
    """Why another user could change the entries of directory ``p`` (None: no one but you or root can)."""
    mode = stat.S_IMODE(st.st_mode)
    if not stat.S_ISDIR(st.st_mode):
        return f"{p} is not a directory"
    if st.st_uid not in (euid, 0):
        return f"{p} is owned by uid {st.st_uid}, not by you (uid {euid}) or root (mode {mode:04o})"
    # a sticky directory lets others create names but not rename or delete yours: fine above the
    # cache directory (its next component is checked to be yours), not as the cache directory itself
    if not leaf and mode & stat.S_ISVTX:
        return None
    who = _writable_by_others(st)
    if who is not None:
        return f"{p} is writable by {who} (mode {mode:04o}, owner uid {st.st_uid}, group {st.st_gid})"
    return None


def _trust_problem(real: Path, leaf: bool = True) -> str | None:
    """Why someone other than you or root could change what directory ``real`` holds (None: no one can).

    ``real`` is a real path (no links).  Its components are checked from ``real`` up to a trusted
    root: your home directory, a sticky root-owned directory (``/tmp``) or ``/``.  ``leaf=False``:
    ``real`` is to be the parent of new directories of yours (then it may be sticky, like ``/tmp``).
    """
    euid, home = os.geteuid(), _home()
    p = real
    while True:
        try:
            st = os.lstat(p)
        except OSError as e:
            return f"{p}: {_oserror(e)}"
        problem = _component_problem(p, st, euid, leaf=leaf and p == real)
        if problem is not None:
            return problem
        if p == home or p.parent == p or (st.st_uid == 0 and st.st_mode & stat.S_ISVTX):
            return None
        p = p.parent


def _fchmod_dir(p: Path, mode: int) -> None:
    fd = os.open(p, os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW)
    try:
        os.fchmod(fd, mode)
    finally:
        os.close(fd)


def _makedirs_private(d: Path) -> _CacheDir | None:
    """Create ``d`` and its missing parents, each 0700 whatever the umask, but only below a trusted
    directory; a :class:`_CacheDir` saying why not when that fails (None when ``d`` is a directory)."""
    missing: list[Path] = []
    p = d
    while not os.path.lexists(p) and p.parent != p:
        missing.append(p)
        p = p.parent
    if not missing:
        return None
    if not os.path.isdir(p):
        return _CacheDir(d, "", unwritable=f"{p} is not a directory")
    untrusted = _trust_problem(Path(os.path.realpath(p)), leaf=False)
    if untrusted is not None:  # create nothing where others could rename or replace it
        return _CacheDir(d, "", untrusted=untrusted)
    try:
        for q in reversed(missing):
            try:
                os.mkdir(q, 0o700)
            except FileExistsError:  # made meanwhile by another process: checked like any existing one
                continue
            if stat.S_IMODE(os.lstat(q).st_mode) != 0o700:  # a umask that took bits from the owner
                _fchmod_dir(q, 0o700)
    except OSError as e:
        if not os.path.isdir(d):
            return _CacheDir(d, "", unwritable=_oserror(e))
    return None


def _close_fallback(d: Path) -> tuple[str | None, str]:
    """The per-user fallback in the shared temporary directory must be a directory of yours (not a
    link); made 0700, and emptied if others could write it (a library in it may have been planted).

    Returns (why it cannot be used or None, what was done to it).
    """
    st = os.lstat(d)
    mode = stat.S_IMODE(st.st_mode)
    if not stat.S_ISDIR(st.st_mode):
        return f"{d} is not a directory (a link or a file, owner uid {st.st_uid}, mode {mode:04o})", ""
    if st.st_uid != os.geteuid():
        return f"{d} is owned by uid {st.st_uid}, not by you (uid {os.geteuid()}; mode {mode:04o})", ""
    if mode == 0o700:
        return None, ""
    fd = os.open(d, os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW)
    try:
        os.fchmod(fd, 0o700)  # from now on no one else can add or rename anything in it
        if _writable_by_others(st) is None:
            return None, ""
        for name in os.listdir(fd):
            with contextlib.suppress(OSError):
                if stat.S_ISDIR(os.lstat(name, dir_fd=fd).st_mode):
                    shutil.rmtree(name, dir_fd=fd, ignore_errors=True)
                else:
                    os.unlink(name, dir_fd=fd)
    finally:
        os.close(fd)
    return None, f"{d} had been writable by others (mode {mode:04o}), so it was closed (0700) and emptied"


def _probe_writable(real: Path) -> str | None:
    try:
        fd, probe = tempfile.mkstemp(dir=real, prefix=".probe-")
        try:
            os.write(fd, b"coop_ga")
        finally:
            os.close(fd)
            os.unlink(probe)
    except OSError as e:
        return _oserror(e)
    return None


def _inspect(d: Path, role: str) -> _CacheDir:
    """Create ``d`` if it is missing (0700), then check whether it may be trusted and written."""
    d = Path(os.path.abspath(d))
    failed = _makedirs_private(d)
    if failed is not None:
        return _replace(failed, role=role)
    note = ""
    try:
        untrusted, note = _close_fallback(d) if role == "fallback" else (None, "")
    except OSError as e:
        untrusted = f"{d}: {_oserror(e)}"
    if untrusted is None and not os.path.isdir(d):
        untrusted = f"{d} is not a directory"
    if untrusted is not None:
        return _CacheDir(d, role, untrusted=untrusted, note=note)
    real = Path(os.path.realpath(d))
    untrusted = _trust_problem(real)
    if untrusted is not None:
        return _CacheDir(d, role, untrusted=untrusted, note=note)
    return _CacheDir(d, role, path=real, unwritable=_probe_writable(real), note=note)


def _check(d: Path, role: str) -> _CacheDir:
    """Memoized :func:`_inspect` (once per directory and process: nothing of it on the hot path)."""
    with _state_lock:
        cd = _checked.get((str(d), role))
        if cd is None:
            cd = _checked[(str(d), role)] = _inspect(d, role)
        return cd


def _mark_unwritable(cd: _CacheDir, why: str) -> _CacheDir:
    cd = _replace(cd, unwritable=why)
    with _state_lock:
        if cd.role == "private":
            _private[os.getpid()] = cd
        else:
            _checked[(str(cd.shown), cd.role)] = cd
    return cd


def _remove_private(path: Path, pid: int) -> None:
    if os.getpid() == pid:  # not from a forked child: the parent still uses it
        shutil.rmtree(path, ignore_errors=True)


def _new_private_dir() -> _CacheDir:
    try:
        d = Path(tempfile.mkdtemp(prefix=f"coop_ga-{os.getuid()}-private-"))  # 0700, a fresh name
    except OSError as e:
        return _CacheDir(Path(tempfile.tempdir or "/tmp"), "private", unwritable=f"mkdtemp failed: {_oserror(e)}")
    real = Path(os.path.realpath(d))
    untrusted = _trust_problem(real)  # e.g. TMPDIR writable by others and not sticky
    if untrusted is not None:
        shutil.rmtree(d, ignore_errors=True)
        return _CacheDir(d, "private", untrusted=untrusted)
    atexit.register(_remove_private, real, os.getpid())
    return _CacheDir(d, "private", path=real)


def _private_dir() -> _CacheDir:
    """This process's private build directory (a fresh ``mkdtemp``, removed at exit; one per process)."""
    with _state_lock:
        cd = _private.get(os.getpid())
        if cd is None:
            cd = _private[os.getpid()] = _new_private_dir()
        return cd


def _candidates(existing: bool = False) -> Iterator[_CacheDir]:
    """Cache directories in order of preference, each checked when the iteration reaches it.

    ``existing``: only those that already exist (looking for a built entry creates nothing but
    the configured directory).
    """
    primary, fb = _configured_dir(), _fallback_dir()
    yield _check(primary, "primary")
    if fb != primary and (not existing or os.path.isdir(fb)):
        yield _check(fb, "fallback")
    if not existing:
        yield _private_dir()
    elif (cd := _private.get(os.getpid())) is not None:
        yield cd


# ---------------------------------------------------------------------------- files
def _identity(st: os.stat_result) -> tuple[int, ...]:
    return (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns)


def _file_problem(st: os.stat_result) -> str | None:
    mode = stat.S_IMODE(st.st_mode)
    if not stat.S_ISREG(st.st_mode):
        return "not a regular file"
    if st.st_uid not in (os.geteuid(), 0):
        return f"owned by uid {st.st_uid}, not by you or root"
    who = _writable_by_others(st)
    if who is not None:
        return f"writable by {who} (mode {mode:04o}, group {st.st_gid})"
    return None


def _read_own_file(path: Path, limit: int) -> tuple[bytes, tuple[int, ...]]:
    """Contents and identity of a regular file that only you or root can write, read through one
    descriptor opened without following links.

    Raises FileNotFoundError when it is absent or unreadable, :class:`_Unverified` otherwise.
    """
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC)
    except (FileNotFoundError, PermissionError):
        raise FileNotFoundError(path) from None
    except OSError as e:  # ELOOP: a symbolic link
        raise _Unverified(_oserror(e)) from None
    try:
        st = os.fstat(fd)
        problem = _file_problem(st) or (f"{st.st_size} bytes, more than {limit}" if st.st_size > limit else None)
        if problem is not None:
            raise _Unverified(problem)
        chunks = []
        while chunk := os.read(fd, 1 << 20):  # read(), never mmap: a truncated file must not SIGBUS
            chunks.append(chunk)
    except OSError as e:
        raise _Unverified(_oserror(e)) from None
    finally:
        os.close(fd)
    data = b"".join(chunks)
    if len(data) != st.st_size:
        raise _Unverified("its size changed while it was read")
    return data, _identity(st)


def _elf_problem(data: bytes) -> str | None:
    """Why ``data`` is not a complete ELF shared object (None if it is).

    ``dlopen`` maps the loadable (PT_LOAD) segments; a page of them past the end of a truncated
    file is a SIGBUS when touched.  So every loadable segment, the program header table and the
    section header table (the file's tail) must lie inside the file.
    """
    if len(data) < 64 or data[:4] != b"\x7fELF" or data[4] not in (1, 2) or data[5] not in (1, 2):
        return "not an ELF file"
    order, wide = ("<" if data[5] == 1 else ">"), data[4] == 2
    w = "Q" if wide else "I"
    head = struct.unpack_from(f"{order}HHI{w}{w}{w}IHHHHHH", data, 16)
    e_type, phoff, shoff, phentsize, phnum, shentsize, shnum = (head[i] for i in (0, 4, 5, 8, 9, 10, 11))
    if e_type != 3:  # ET_DYN
        return f"not a shared library (ELF type {e_type})"
    n = len(data)
    ph = struct.Struct(order + ("I4xQ16xQ" if wide else "II8xI"))  # p_type, p_offset, p_filesz
    if phnum == 0 or phentsize < ph.size or phoff + phnum * phentsize > n:
        return f"truncated: its program headers end past its {n} bytes"
    for i in range(phnum):
        p_type, p_offset, p_filesz = ph.unpack_from(data, phoff + i * phentsize)
        if p_type == 1 and p_offset + p_filesz > n:  # PT_LOAD
            return f"truncated: a loadable segment ends at byte {p_offset + p_filesz}, past its {n} bytes"
    if shoff and shoff + max(shnum, 1) * shentsize > n:
        return f"truncated: its section headers end past its {n} bytes"
    return None
