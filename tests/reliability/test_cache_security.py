"""Security of the compile cache: a library is loaded only from where no other user can write.

The victim is this test process's user (root, here and in CI); the attacker is a second Unix user
(``nobody``, uid 65534, through ``setpriv``).  The attacker plants, under the victim's entry name
and with a matching checksum, a library that computes the right function (so the results cannot
show it) and whose constructor (``__attribute__((constructor))``, run by ``dlopen``) writes a marker
file.  Before this fix the victim loaded it from a shared world-writable ``COOP_GA_CACHE``, from a
cache directory the attacker owns, from a default cache created under umask 000 and from its
fallback directory after that had once been world-writable; here the marker never appears and the
victim's results still match the CasADi VM.  Also: a lock file held by another user, or by a stuck
process, no longer blocks a build forever; a truncated library whose checksum was recomputed is
rebuilt instead of crashing the process (SIGBUS).

Run against another implementation of ``coop_ga.codegen`` (e.g. the old one, to see these tests
fail): ``COOP_GA_CODEGEN_IMPL=/path/to/codegen.py pytest tests/reliability/test_cache_security.py``.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import stat
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from coop_ga import codegen

from . import _util
from ._util import Run, entries, run_worker, worker_env
from ._worker import make_function

TOL = 1e-12
NOBODY = 65534
MARKER_TEXT = "planted code ran"


def _sha(p: Path) -> str:
    return hashlib.sha256(p.read_bytes()).hexdigest()


def _assert_right_answer(run: Run) -> None:
    assert run.returncode == 0, run.describe()
    (f,) = run.result["functions"]
    assert f["codegen"] is True, run.describe()
    assert f["max_err"] < TOL


@pytest.fixture
def attacker() -> list[str]:
    prefix = _util.setpriv_nobody()
    if prefix is None:
        pytest.skip("needs root and setpriv to act as a second user (nobody)")
    return prefix


@pytest.fixture
def base() -> Iterator[Path]:
    """A directory in /tmp that user nobody can enter (pytest's tmp_path is 0700)."""
    d = Path(tempfile.mkdtemp(prefix="coop_ga_sec_", dir="/tmp"))
    d.chmod(0o755)
    (d / "tmp").mkdir()
    (d / "tmp").chmod(0o1777)  # the victim's TMPDIR: like /tmp
    try:
        yield d
    finally:
        shutil.rmtree(d, ignore_errors=True)


@pytest.fixture
def entry(populated: Path) -> str:
    return entries(populated)["so"][0].name


@pytest.fixture
def planted(base: Path) -> Path:
    """The attacker's library: casadi's C for ``coop_ga_f0`` plus a constructor writing ``base/marker``."""
    import casadi as ca

    f = make_function("f0")
    g = ca.Function("coop_ga_f0", f.sx_in(), f.call(f.sx_in()), f.name_in(), f.name_out())
    gen = ca.CodeGenerator("coop_ga_f0.c", {"with_header": False, "casadi_real": "double"})
    gen.add(g)
    payload = (
        "\n#include <stdio.h>\n__attribute__((constructor)) static void coop_ga_test_planted(void) {\n"
        f'  FILE *fh = fopen("{base / "marker"}", "w");\n'
        f'  if (fh) {{ fputs("{MARKER_TEXT}", fh); fclose(fh); }}\n}}\n'
    )
    src = base / "attacker_src"
    src.mkdir(mode=0o755)
    (src / "planted.c").write_text(gen.dump() + payload)
    subprocess.run(["gcc", "-shared", "-fPIC", "-O1", "planted.c", "-o", "planted.so", "-lm"], cwd=src, check=True)
    (src / "planted.so").chmod(0o644)
    return src / "planted.so"


def _as_attacker(attacker: list[str], script: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([*attacker, "sh", "-c", script, "sh", *args], capture_output=True, text=True, check=False)


def _plant(attacker: list[str], lib: Path, where: Path, entry: str) -> None:
    """As user nobody: copy the library in under the entry's name, with its recomputed checksum."""
    p = _as_attacker(
        attacker,
        'cp "$1" "$2/$3" && printf "%s  %s\\n" "$4" "$3" > "$2/$3.sha256"',
        str(lib),
        str(where),
        entry,
        _sha(lib),
    )
    assert p.returncode == 0, f"the attacker could not plant in {where}: {p.stderr}"
    assert (where / entry).stat().st_uid == NOBODY


def _victim_env(base: Path, cache: Path | None, **extra: str) -> dict[str, str]:
    env = worker_env(cache or base / "unused", base / "tmp", **extra)
    if cache is None:  # the default cache, ~/.cache/coop_ga
        del env["COOP_GA_CACHE"]
    return env


def _assert_not_loaded(base: Path, run: Run) -> None:
    marker = base / "marker"
    assert not marker.exists(), f"the planted library ran in the victim's process: {marker.read_text()!r}"
    _assert_right_answer(run)


# ---------------------------------------------------------------------------- planted libraries
def _shared_world_writable(base: Path, attacker: list[str], lib: Path, entry: str) -> tuple[Path, dict, str]:
    shared = base / "shared"
    shared.mkdir()
    shared.chmod(0o1777)  # a shared scratch cache, sticky like /tmp
    _plant(attacker, lib, shared, entry)
    return shared, _victim_env(base, shared), f"{shared} is writable by other users (mode 1777"


def _attacker_owned(base: Path, attacker: list[str], lib: Path, entry: str) -> tuple[Path, dict, str]:
    evil = base / "tmp" / "offered_cache"  # the attacker's, in the shared /tmp
    assert _as_attacker(attacker, 'mkdir -m 755 "$1"', str(evil)).returncode == 0
    _plant(attacker, lib, evil, entry)
    return evil, _victim_env(base, evil), f"{evil} is owned by uid {NOBODY}"


def _default_under_umask_000(base: Path, attacker: list[str], lib: Path, entry: str) -> tuple[Path, dict, str]:
    home = base / "home"
    default = home / ".cache" / "coop_ga"
    default.mkdir(parents=True)
    for d in (home / ".cache", default):  # what mkdir(parents=True, mode=0o777) made under umask 000
        d.chmod(0o777)
    _plant(attacker, lib, default, entry)
    return default, _victim_env(base, None, HOME=str(home)), f"{default} is writable by other users (mode 0777"


SCENARIOS = {
    "shared_world_writable_cache": _shared_world_writable,
    "attacker_owned_cache": _attacker_owned,
    "default_cache_made_under_umask_000": _default_under_umask_000,
}


@pytest.mark.parametrize("scenario", list(SCENARIOS))
def test_planted_library_in_an_untrusted_cache_is_not_loaded(
    base: Path, attacker: list[str], planted: Path, entry: str, scenario: str
) -> None:
    cache, env, problem = SCENARIOS[scenario](base, attacker, planted, entry)
    before = sorted((p.name, p.stat().st_uid) for p in cache.iterdir())
    run = run_worker({"functions": ["f0"]}, env)
    _assert_not_loaded(base, run)
    assert len(run.cache_warnings) == 1, run.cache_warnings
    msg = run.cache_warnings[0]
    assert problem in msg and "COOP_GA_CACHE" in msg and "planted" in msg, msg
    assert str(base / "tmp" / f"coop_ga-{os.getuid()}") in msg  # where it went instead
    assert sorted((p.name, p.stat().st_uid) for p in cache.iterdir()) == before  # nothing written there either
    again = run_worker({"functions": ["f0"]}, env)  # and the private fallback is then simply reused
    _assert_not_loaded(base, again)
    assert again.result["stats"]["compiled"] == 0 and again.result["stats"]["loaded"] == 1


@pytest.mark.parametrize("still_open", [False, True], ids=["closed_since", "still_world_writable"])
def test_planted_library_in_the_fallback_directory_is_not_loaded(
    base: Path, attacker: list[str], planted: Path, entry: str, still_open: bool
) -> None:
    """The victim's own fallback had once been world-writable and the attacker planted in it."""
    (base / "file").write_text("in the way")
    primary = base / "file" / "cache"  # unusable: the fallback is taken
    fb = base / "tmp" / f"coop_ga-{os.getuid()}"
    fb.mkdir()
    fb.chmod(0o777)
    _plant(attacker, planted, fb, entry)
    if not still_open:
        fb.chmod(0o700)  # what the former version did to it (without looking at what it held)
    run = run_worker({"functions": ["f0"]}, _victim_env(base, primary))
    _assert_not_loaded(base, run)
    assert len(run.cache_warnings) == 1, run.cache_warnings
    msg = run.cache_warnings[0]
    assert str(primary) in msg and str(fb) in msg
    if still_open:
        assert "closed (0700) and emptied" in msg and "mode 0777" in msg
    else:
        assert run.result["stats"]["rejected"] == 1 and run.result["stats"]["rebuilt"] == 1
    assert stat.S_IMODE(fb.stat().st_mode) == 0o700
    so = fb / entry
    assert so.stat().st_uid == os.geteuid() and stat.S_IMODE(so.stat().st_mode) == 0o600
    assert Path(f"{so}.sha256").read_text().split()[0] == _sha(so) != _sha(planted)


def test_entry_that_is_a_link_to_a_planted_library_is_not_loaded(
    base: Path, attacker: list[str], planted: Path, entry: str
) -> None:
    """A trusted cache whose entry is a symbolic link (to another user's copy): never followed."""
    offered = base / "tmp" / "offered"
    assert _as_attacker(attacker, 'mkdir -m 755 "$1"', str(offered)).returncode == 0
    _plant(attacker, planted, offered, entry)
    cache = base / "mine"
    cache.mkdir(mode=0o700)
    (cache / entry).symlink_to(offered / entry)
    shutil.copy(offered / f"{entry}.sha256", cache / f"{entry}.sha256")
    run = run_worker({"functions": ["f0"]}, _victim_env(base, cache))
    _assert_not_loaded(base, run)
    assert run.cache_warnings == []
    assert run.result["stats"]["rebuilt"] == 1 and not (cache / entry).is_symlink()


def test_cache_made_under_umask_000_is_private(base: Path, attacker: list[str]) -> None:
    """Directories 0700 and files 0600 whatever the umask: the attacker cannot plant at all."""
    home = base / "home"
    home.mkdir(mode=0o755)
    umask_000 = ["sh", "-c", 'umask 000 && exec "$@"', "sh"]
    run = run_worker({"functions": ["f0"]}, _victim_env(base, None, HOME=str(home)), prefix=umask_000)
    _assert_right_answer(run)
    (base / "file").write_text("in the way")  # and the fallback directory, made under umask 000 too
    run = run_worker({"functions": ["f0"]}, _victim_env(base, base / "file" / "cache"), prefix=umask_000)
    _assert_right_answer(run)
    fb = base / "tmp" / f"coop_ga-{os.getuid()}"
    for d in (home / ".cache", home / ".cache" / "coop_ga", fb):
        assert stat.S_IMODE(d.stat().st_mode) == 0o700, d
        files = list(d.iterdir()) if d.name != ".cache" else []
        assert all(stat.S_IMODE(p.stat().st_mode) == 0o600 for p in files), [(p, p.stat().st_mode) for p in files]
        if files:
            assert {p.suffix for p in files} == {".so", ".sha256", ".lock"}
            p = _as_attacker(attacker, 'echo x > "$1/planted"', str(d))
            assert p.returncode != 0 and not (d / "planted").exists()


def test_directory_rule(tmp_path: Path) -> None:
    """Owned by you or root, writable by no one else (a group private to its owner counts as no one,
    as Debian's OpenSSH rules; a sticky parent is fine), up to the home or a sticky root-owned directory."""
    from coop_ga.codegen._trust import _private_group, _trust_problem

    if os.geteuid() != 0:
        pytest.skip("needs root to chown")
    if not _private_group(0, 0):
        pytest.skip("group 0 is not private to root on this machine")
    root = Path(tempfile.mkdtemp(prefix="coop_ga_rule_", dir="/tmp"))  # /tmp: sticky and root-owned
    try:
        private_group = root / "private_group"
        private_group.mkdir()
        private_group.chmod(0o770)  # root:root, group root has no other member
        shared_group = root / "shared_group"
        shared_group.mkdir()
        shared_group.chmod(0o770)
        os.chown(shared_group, 0, NOBODY)  # group nogroup: not root's own
        sticky = root / "sticky"
        sticky.mkdir()
        sticky.chmod(0o1777)
        (sticky / "mine").mkdir(mode=0o700)
        theirs = root / "theirs"
        theirs.mkdir(mode=0o755)
        (theirs / "mine").mkdir(mode=0o700)
        os.chown(theirs, NOBODY, NOBODY)  # a directory of yours inside another user's: they can swap it
        assert _trust_problem(private_group) is None
        assert _trust_problem(sticky / "mine") is None
        assert (
            _trust_problem(shared_group)
            == f"{shared_group} is writable by its group (mode 0770, owner uid 0, group {NOBODY})"
        )
        assert _trust_problem(sticky) == f"{sticky} is writable by other users (mode 1777, owner uid 0, group 0)"
        assert (
            _trust_problem(theirs / "mine")
            == f"{theirs} is owned by uid {NOBODY}, not by you (uid 0) or root (mode 0755)"
        )
        assert _trust_problem(Path("/tmp")) is not None and _trust_problem(Path("/tmp"), leaf=False) is None
    finally:
        shutil.rmtree(root, ignore_errors=True)


# ---------------------------------------------------------------------------- lock files
def _hold_lock(lock: Path, prefix: list[str] | None = None) -> subprocess.Popen:
    code = (
        "import fcntl, os, sys, time\n"
        "fd = os.open(sys.argv[1], os.O_RDONLY | os.O_CREAT, 0o600)\n"
        "fcntl.flock(fd, fcntl.LOCK_EX)\n"
        "print('held', flush=True)\n"
        "time.sleep(600)\n"
    )
    p = subprocess.Popen([*(prefix or []), sys.executable, "-c", code, str(lock)], stdout=subprocess.PIPE, text=True)
    assert p.stdout is not None and p.stdout.readline().strip() == "held"
    return p


def _run_or_fail(spec: dict, env: dict[str, str], timeout: float = 120.0) -> Run:
    t0 = time.monotonic()
    try:
        return run_worker(spec, env, timeout=timeout)
    except subprocess.TimeoutExpired:
        pytest.fail(f"the victim was still waiting for the lock after {time.monotonic() - t0:.0f} s")


def test_lock_held_by_a_stuck_process_is_waited_for_only_until_the_timeout(tmp_path: Path, entry: str) -> None:
    """Another process of the victim's holds the entry's lock and never lets go: built privately."""
    cache, tmpdir = tmp_path / "cache", tmp_path / "tmp"
    cache.mkdir(mode=0o700)
    tmpdir.mkdir()
    lock = cache / entry.replace(".so", ".lock")
    holder = _hold_lock(lock)
    try:
        run = _run_or_fail({"functions": ["f0"]}, worker_env(cache, tmpdir, COOP_GA_LOCK_TIMEOUT="1.5"))
    finally:
        holder.kill()
        holder.wait()
    _assert_right_answer(run)
    assert len(run.cache_warnings) == 1, run.cache_warnings
    msg = run.cache_warnings[0]
    assert str(lock) in msg and "1.5 s" in msg and "COOP_GA_LOCK_TIMEOUT" in msg and "fuser" in msg
    assert run.result["stats"]["private"] == 1 and run.result["stats"]["compiled"] == 1
    assert entries(cache)["so"] == []  # not in the cache, whose lock it did not hold
    assert list(tmpdir.iterdir()) == []  # the private directory was removed at exit


def test_lock_file_held_by_another_user_does_not_block(base: Path, attacker: list[str], entry: str) -> None:
    """A lock file others can open (0644, as an older version left it) held by the attacker forever."""
    cache = base / "cache"
    cache.mkdir(mode=0o755)
    lock = cache / entry.replace(".so", ".lock")
    lock.touch(mode=0o644)
    inode = lock.stat().st_ino
    holder = _hold_lock(lock, attacker)
    try:
        run = _run_or_fail({"functions": ["f0"]}, _victim_env(base, cache), timeout=90)
    finally:
        holder.kill()
        holder.wait()
    _assert_right_answer(run)
    assert run.cache_warnings == []
    assert run.result["stats"]["compiled"] == 1 and run.result["stats"]["private"] == 0
    assert [p.name for p in entries(cache)["so"]] == [entry]  # built in the cache itself, without waiting
    assert lock.stat().st_ino != inode and stat.S_IMODE(lock.stat().st_mode) == 0o600  # a private lock now
    assert _as_attacker(attacker, 'exec 3< "$1"', str(lock)).returncode != 0  # which the attacker cannot open


# ---------------------------------------------------------------------------- truncated libraries
def _section_headers_offset(data: bytes) -> int:
    assert data[:4] == b"\x7fELF" and data[4] == 2 and data[5] == 1  # 64-bit little-endian (x86-64, aarch64)
    return int.from_bytes(data[40:48], "little")


@pytest.mark.parametrize("cut", ["half", "section_headers"])
def test_truncated_library_with_recomputed_checksum_is_rebuilt(tmp_path: Path, populated: Path, cut: str) -> None:
    """Truncated, then its checksum recomputed (so the checksum alone cannot tell): dlopen would SIGBUS."""
    cache, tmpdir = tmp_path / "cache", tmp_path / "tmp"
    shutil.copytree(populated, cache)
    tmpdir.mkdir()
    so = entries(cache)["so"][0]
    data = so.read_bytes()
    good = _sha(so)
    keep = len(data) // 2 if cut == "half" else _section_headers_offset(data) + 64
    so.write_bytes(data[:keep])
    Path(f"{so}.sha256").write_text(f"{_sha(so)}  {so.name}\n")
    run = run_worker({"functions": ["f0"]}, worker_env(cache, tmpdir))
    assert run.returncode == 0, run.describe()  # -7 (SIGBUS) before
    _assert_right_answer(run)
    assert run.cache_warnings == []
    assert run.result["stats"]["rebuilt"] == 1 and run.result["stats"].get("rejected") == 1
    assert _sha(so) == good  # rebuilt (gcc is deterministic)


def test_elf_completeness_check(populated: Path) -> None:
    """Every truncation of a real library is refused; the complete one is accepted."""
    from coop_ga.codegen._trust import _elf_problem

    data = entries(populated)["so"][0].read_bytes()
    assert _elf_problem(data) is None
    for keep in (0, 16, 63, 64, 200, 4096, len(data) // 2, _section_headers_offset(data), len(data) - 1):
        problem = _elf_problem(data[:keep])
        assert problem is not None and ("truncated" in problem or "not an ELF" in problem), (keep, problem)
    executable = data[:16] + (2).to_bytes(2, "little") + data[18:]  # e_type ET_EXEC
    assert _elf_problem(executable) == "not a shared library (ELF type 2)"


# ---------------------------------------------------------------------------- cost
def test_directories_are_checked_once_per_process(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The ownership walk runs once per directory and process, not once per function (or call)."""
    cache = tmp_path / "cache"
    cache.mkdir(mode=0o700)
    monkeypatch.setenv("COOP_GA_CACHE", str(cache))
    monkeypatch.setenv("TMPDIR", str(tmp_path))  # no fallback directory of other tests in sight
    monkeypatch.setattr(tempfile, "tempdir", None)
    monkeypatch.delenv("COOP_GA_CODEGEN", raising=False)
    monkeypatch.setattr(codegen._trust, "_checked", {})
    walks: list[Path] = []
    walk = codegen._trust._trust_problem

    def counting(real: Path, leaf: bool = True) -> str | None:
        walks.append(real)
        return walk(real, leaf)

    monkeypatch.setattr(codegen._trust, "_trust_problem", counting)
    fs = [codegen.CompiledFunction(make_function(f"once{i}", depth=2), codegen=True, fallback=False) for i in range(3)]
    assert all(f.codegen for f in fs)
    assert walks == [cache]
