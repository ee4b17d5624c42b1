"""Regression tests of the compile cache of :mod:`coop_ga.codegen` (reliability campaign).

Defect 1: concurrent first-time compiles crashed processes (``shutil.move`` across
filesystems rewrote a loaded library in place) and a truncated cached library killed
every later run with SIGBUS.  Defect 3: a corrupt or unusable cache, or a failing gcc,
broke every later run with a non-coop_ga exception and no fallback.

Everything that could crash runs in a subprocess (``_worker.py``), so a SIGSEGV/SIGBUS
is a non-zero exit code here.  Results are compared with the CasADi VM (relative 1e-12:
the C code may contract into FMAs; the VM fallback must be exact).
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from coop_ga import codegen
from coop_ga.errors import CacheWarning, CompilationError

from . import _util
from ._util import ROOT, WORKER, Run, entries, fake_gcc_dir, finish, run_worker, start_worker, worker_env
from ._worker import make_function

TOL = 1e-12
UID = os.getuid()


def _sha(p: Path) -> str:
    return hashlib.sha256(p.read_bytes()).hexdigest()


def _assert_compiled_ok(run: Run, n: int = 1) -> None:
    assert run.returncode == 0, run.describe()
    fs = run.result["functions"]
    assert len(fs) == n
    for f in fs:
        assert f["codegen"] is True, run.describe()
        assert f["max_err"] < TOL


def _assert_vm_ok(run: Run, n: int = 2) -> None:
    assert run.returncode == 0, run.describe()
    fs = run.result["functions"]
    assert len(fs) == n
    for f in fs:
        assert f["codegen"] is False
        assert f["max_err"] == 0.0  # the VM fallback *is* the reference
    assert run.result["stats"]["vm"] == n


def _assert_entry_consistent(cache: Path) -> Path:
    """One library, its checksum matching, a lock, and no temporaries left behind."""
    e = entries(cache)
    assert len(e["so"]) == 1 and len(e["sha256"]) == 1, e
    assert e["other"] == [], e
    so = e["so"][0]
    assert e["sha256"][0].read_text().split()[0] == _sha(so)
    return so


@pytest.fixture
def tmpdir_(tmp_path: Path) -> Path:
    d = tmp_path / "tmp"
    d.mkdir()
    return d


@pytest.fixture
def shm_tmpdir() -> Iterator[Path]:
    """A TMPDIR on another filesystem (tmpfs) than pytest's tmp_path: the setting that crashed."""
    shm = Path("/dev/shm")
    if not shm.is_dir() or not os.access(shm, os.W_OK):
        pytest.skip("no writable /dev/shm")
    d = Path(tempfile.mkdtemp(prefix="coop_ga_test_", dir=shm))
    try:
        yield d
    finally:
        shutil.rmtree(d, ignore_errors=True)


# ---------------------------------------------------------------------------- defect 1
def test_defect1_concurrent_first_compiles_do_not_crash(tmp_path: Path, shm_tmpdir: Path) -> None:
    cache = tmp_path / "cache"
    assert os.stat(shm_tmpdir).st_dev != os.stat(tmp_path).st_dev, "TMPDIR must be on another filesystem"
    n = 12
    env = worker_env(cache, shm_tmpdir)
    go = tmp_path / "go"
    # depth 150: ~1 s of gcc, a wide window for the processes to collide in
    specs = [
        {"functions": ["concurrent"], "depth": 150, "ready": str(tmp_path / f"ready{i}"), "go": str(go)}
        for i in range(n)
    ]
    procs = [start_worker(s, env) for s in specs]
    try:
        t0 = time.monotonic()
        while not all(Path(s["ready"]).exists() for s in specs):  # all imported and traced: start together
            assert time.monotonic() - t0 < 60, "workers did not start"
            assert all(p.poll() is None for p in procs), "a worker died before compiling"
            time.sleep(0.01)
        go.touch()
        runs = [finish(p) for p in procs]
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
    for r in runs:
        _assert_compiled_ok(r)
        assert r.cache_warnings == []
    assert sum(r.result["stats"]["compiled"] for r in runs) == 1  # the lock: compiled once, the others loaded it
    assert all(r.result["stats"]["loaded"] == 1 for r in runs)
    _assert_entry_consistent(cache)
    assert not any(p.name.startswith(".coop_ga") for p in shm_tmpdir.iterdir())  # built in the cache dir itself


def test_defect1_rebuild_never_rewrites_a_loaded_library(tmp_path: Path, tmpdir_: Path, populated: Path) -> None:
    cache = tmp_path / "cache"
    shutil.copytree(populated, cache)
    so = entries(cache)["so"][0]
    env = worker_env(cache, tmpdir_)
    hold, resume = tmp_path / "hold", tmp_path / "resume"
    holder = start_worker({"functions": ["f0"], "hold": str(hold), "resume": str(resume)}, env)
    try:
        t0 = time.monotonic()
        while not hold.exists():  # the holder has the library mapped
            assert holder.poll() is None and time.monotonic() - t0 < 60, finish(holder).describe()
            time.sleep(0.01)
        inode = so.stat().st_ino
        Path(str(so) + ".sha256").write_text("0" * 64 + f"  {so.name}\n")  # forces a rebuild by the next process
        rebuilder = run_worker({"functions": ["f0"]}, env)
        resume.touch()
        held = finish(holder)
    finally:
        if holder.poll() is None:
            holder.kill()
    _assert_compiled_ok(rebuilder)
    assert rebuilder.result["stats"]["compiled"] == 1 and rebuilder.result["stats"]["rebuilt"] == 1
    assert so.stat().st_ino != inode  # a new file was moved over the entry ...
    _assert_compiled_ok(held)
    assert held.result["max_err_after_replace"] < TOL  # ... and the holder's mapping was left intact
    assert any(so.name in p and p.endswith("(deleted)") for p in held.result["mapped"]), held.result["mapped"]
    _assert_entry_consistent(cache)


def _damage(so: Path, how: str) -> None:
    data = so.read_bytes()
    sidecar = Path(str(so) + ".sha256")
    if how == "truncated":
        so.write_bytes(data[: len(data) // 2])
    elif how == "garbage":  # starts like an ELF file, so dlopen would try to map it
        so.write_bytes(b"\x7fELF\x02\x01\x01\x00" + np.random.default_rng(7).bytes(16384))
    elif how == "empty":
        so.write_bytes(b"")
    elif how == "checksum_missing":  # e.g. an entry written by an older coop_ga
        sidecar.unlink()
    elif how == "checksum_wrong":
        sidecar.write_text("0" * 64 + "\n")
    else:
        raise AssertionError(how)


@pytest.mark.parametrize("how", ["truncated", "garbage", "empty", "checksum_missing", "checksum_wrong"])
def test_defect1_truncated_so_is_rebuilt(tmp_path: Path, tmpdir_: Path, populated: Path, how: str) -> None:
    """A damaged entry (or one without a valid checksum) is never dlopen'ed: it is rebuilt."""
    cache = tmp_path / "cache"
    shutil.copytree(populated, cache)
    so = entries(cache)["so"][0]
    good = _sha(so)
    _damage(so, how)
    run = run_worker({"functions": ["f0"]}, worker_env(cache, tmpdir_))
    _assert_compiled_ok(run)
    assert run.cache_warnings == []
    assert run.result["stats"]["compiled"] == 1 and run.result["stats"]["rebuilt"] == 1
    assert _assert_entry_consistent(cache) == so
    assert _sha(so) == good  # gcc is deterministic: the rebuilt entry equals the original
    again = run_worker({"functions": ["f0"]}, worker_env(cache, tmpdir_))  # and now it is simply loaded
    _assert_compiled_ok(again)
    assert again.result["stats"]["compiled"] == 0 and again.result["stats"]["loaded"] == 1


# ---------------------------------------------------------------------------- defect 3
@pytest.mark.parametrize("where", ["file_in_the_way", "below_proc"])
def test_defect3_readonly_cache_falls_back(tmp_path: Path, tmpdir_: Path, where: str) -> None:
    if where == "file_in_the_way":
        (tmp_path / "file").write_text("not a directory")
        cache = tmp_path / "file" / "cache"
    else:  # mkdir fails there even for root
        cache = Path("/proc/coop_ga_test_cache")
    run = run_worker({"functions": ["f0", "f1"]}, worker_env(cache, tmpdir_))
    _assert_compiled_ok(run, n=2)
    assert len(run.cache_warnings) == 1  # once per process and reason, not once per function
    msg = run.cache_warnings[0]
    assert str(cache) in msg and "COOP_GA_CACHE" in msg
    fb = tmpdir_ / f"coop_ga-{UID}"
    assert str(fb) in msg
    assert len(entries(fb)["so"]) == 2
    assert fb.stat().st_mode & 0o777 == 0o700  # private: no other user can plant a library there


def test_defect3_non_writable_directory_falls_back() -> None:
    """A directory that really is not writable (user nobody, root-owned 0755) and a read-only, pre-populated one."""
    prefix = _util.setpriv_nobody()
    if prefix is None:
        pytest.skip("needs root and setpriv to run a subprocess as another user")
    base = Path(tempfile.mkdtemp(prefix="coop_ga_test_", dir="/tmp"))  # pytest's tmp_path is 0700: nobody can't enter
    try:
        base.chmod(0o755)
        cache = base / "cache"
        cache.mkdir(mode=0o755)
        tmpdir = base / "tmp"
        tmpdir.mkdir()
        tmpdir.chmod(0o1777)
        worker = base / "_worker.py"
        shutil.copy(WORKER, worker)
        worker.chmod(0o644)
        env = worker_env(cache, tmpdir, COOP_GA_ROOT=str(ROOT))
        probe = run_worker({"functions": []}, env, prefix=prefix, worker=worker)
        if probe.returncode != 0:
            pytest.skip(f"user nobody cannot run this checkout's Python: {probe.stderr[-300:]}")

        run = run_worker({"functions": ["f0", "f1"]}, env, prefix=prefix, worker=worker)
        _assert_compiled_ok(run, n=2)
        assert len(run.cache_warnings) == 1 and str(cache) in run.cache_warnings[0]
        assert list(cache.iterdir()) == []
        assert len(entries(tmpdir / "coop_ga-65534")["so"]) == 2

        # the same directory, populated by its owner (files 0600: private) and then shared read-only by
        # an administrator (chmod a+r): used as it is, read-only, without a warning
        _assert_compiled_ok(run_worker({"functions": ["f0", "f1"]}, env), n=2)
        assert {p.stat().st_mode & 0o777 for p in cache.iterdir()} == {0o600}
        for p in cache.iterdir():
            p.chmod(0o644)
        ro = run_worker({"functions": ["f0", "f1"]}, env, prefix=prefix, worker=worker)
        _assert_compiled_ok(ro, n=2)
        assert ro.cache_warnings == []
        assert ro.result["stats"]["compiled"] == 0 and ro.result["stats"]["loaded"] == 2
    finally:
        shutil.rmtree(base, ignore_errors=True)


@pytest.fixture(params=[8192, 24576], ids=["source_does_not_fit", "library_does_not_fit"])
def full_fs(tmp_path: Path, request: pytest.FixtureRequest) -> Iterator[Path]:
    """A tiny tmpfs, filled up but for a few KiB: writing the C source (8 KiB free) or linking the
    library (24 KiB free) fails with ENOSPC, after the directory probe passed."""
    mnt = tmp_path / "full"
    mnt.mkdir()
    if os.geteuid() != 0 or shutil.which("mount") is None:
        pytest.skip("needs root to mount a tmpfs")
    p = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=256k", "tmpfs", str(mnt)], capture_output=True, check=False)
    if p.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {p.stderr.decode()[-200:]}")
    try:
        with open(mnt / "filler", "wb", buffering=0) as fh:
            try:
                while fh.write(b"\0" * 4096):
                    pass
            except OSError:
                pass
        with open(mnt / "filler", "r+b") as fh:
            fh.truncate(max(0, (mnt / "filler").stat().st_size - request.param))
        yield mnt
    finally:
        subprocess.run(["umount", str(mnt)], capture_output=True, check=False)


def test_defect3_full_cache_falls_back(full_fs: Path, tmpdir_: Path) -> None:
    cache = full_fs / "cache"
    run = run_worker({"functions": ["f0", "f1"]}, worker_env(cache, tmpdir_))
    _assert_compiled_ok(run, n=2)
    assert len(run.cache_warnings) == 1
    msg = run.cache_warnings[0]
    assert str(cache) in msg and "No space left on device" in msg and "COOP_GA_CACHE" in msg
    assert len(entries(tmpdir_ / f"coop_ga-{UID}")["so"]) == 2
    assert [p.name for p in cache.iterdir()] in ([], [p.name for p in cache.glob("*.lock")])  # no partial entries


@pytest.mark.parametrize("fallback", ["is_a_file", "owned_by_another_user"])
def test_defect3_unusable_fallback_builds_privately(tmp_path: Path, tmpdir_: Path, fallback: str) -> None:
    """The per-user fallback taken by another user (or a file): a fresh private directory, removed at exit."""
    (tmp_path / "file").write_text("not a directory")
    cache = tmp_path / "file" / "cache"
    fb = tmpdir_ / f"coop_ga-{UID}"
    if fallback == "is_a_file":
        fb.write_text("in the way")
    else:
        if os.geteuid() != 0:
            pytest.skip("needs root to chown")
        fb.mkdir(mode=0o700)
        os.chown(fb, 65534, 65534)
    run = run_worker({"functions": ["f0", "f1"]}, worker_env(cache, tmpdir_))
    _assert_compiled_ok(run, n=2)
    assert len(run.cache_warnings) == 1
    msg = run.cache_warnings[0]
    assert "COOP_GA_CACHE" in msg and str(cache) in msg and str(fb) in msg and "private" in msg
    assert run.result["stats"]["compiled"] == 2
    if fb.is_dir():
        assert list(fb.iterdir()) == []  # nothing loaded from, or written to, another user's directory
    assert sorted(p.name for p in tmpdir_.iterdir()) == [fb.name]  # the private directory was removed at exit


def test_defect3_no_trusted_directory_uses_vm(tmp_path: Path) -> None:
    """TMPDIR writable by everyone and not sticky, the cache unusable: nothing is trusted, the VM is used."""
    (tmp_path / "file").write_text("not a directory")
    cache = tmp_path / "file" / "cache"
    tmpdir = tmp_path / "open_tmp"
    tmpdir.mkdir()
    tmpdir.chmod(0o777)
    run = run_worker({"functions": ["f0", "f1"]}, worker_env(cache, tmpdir))
    _assert_vm_ok(run)
    assert len(run.cache_warnings) == 1
    msg = run.cache_warnings[0]
    assert "COOP_GA_CACHE" in msg and str(cache) in msg and f"{tmpdir} is writable by" in msg and "0777" in msg
    assert {f["fallback_reason"] for f in run.result["functions"]} == {"no_cache"}
    assert list(tmpdir.iterdir()) == []  # nothing written into the open directory


def test_defect3_failing_gcc_falls_back_to_vm(tmp_path: Path, tmpdir_: Path) -> None:
    bindir = fake_gcc_dir(tmp_path / "bin")
    cache = tmp_path / "cache"
    env = worker_env(cache, tmpdir_, PATH=f"{bindir}{os.pathsep}{os.environ.get('PATH', '')}")
    run = run_worker({"functions": ["f0", "f1"]}, env)
    _assert_vm_ok(run)
    assert len(run.cache_warnings) == 1
    msg = run.cache_warnings[0]
    assert "gcc failed" in msg and "fake compiler" in msg and "COOP_GA_CODEGEN=0" in msg
    e = entries(cache)
    assert e["so"] == [] and e["sha256"] == [] and e["other"] == []  # no half-written entries or temporaries


def test_defect3_missing_gcc_falls_back_to_vm(tmp_path: Path, tmpdir_: Path) -> None:
    empty = tmp_path / "empty_path"
    empty.mkdir()
    run = run_worker({"functions": ["f0", "f1"]}, worker_env(tmp_path / "cache", tmpdir_, PATH=str(empty)))
    _assert_vm_ok(run)
    assert len(run.cache_warnings) == 1
    assert "gcc was not found" in run.cache_warnings[0] and "install gcc" in run.cache_warnings[0].lower()


def test_defect3_corrupt_cache_and_failing_gcc_fall_back_to_vm(tmp_path: Path, tmpdir_: Path, populated: Path) -> None:
    cache = tmp_path / "cache"
    shutil.copytree(populated, cache)
    so = entries(cache)["so"][0]
    _damage(so, "garbage")
    bindir = fake_gcc_dir(tmp_path / "bin")
    env = worker_env(cache, tmpdir_, PATH=f"{bindir}{os.pathsep}{os.environ.get('PATH', '')}")
    run = run_worker({"functions": ["f0", "f1"]}, env)
    _assert_vm_ok(run)  # the garbage library was not loaded (that would be a crash), and no exception
    assert len(run.cache_warnings) == 1


def test_defect3_codegen_env_opt_out_is_silent(tmp_path: Path, tmpdir_: Path) -> None:
    cache = tmp_path / "cache"
    run = run_worker({"functions": ["f0", "f1"]}, worker_env(cache, tmpdir_, COOP_GA_CODEGEN="0"))
    assert run.returncode == 0, run.describe()
    assert [f["codegen"] for f in run.result["functions"]] == [False, False]
    assert run.result["warnings"] == []
    assert not cache.exists()


def test_defect3_no_fallback_raises_compilation_error(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    empty = tmp_path / "empty_path"
    empty.mkdir()
    monkeypatch.setenv("PATH", str(empty))
    monkeypatch.setenv("COOP_GA_CACHE", str(tmp_path / "cache"))
    monkeypatch.delenv("COOP_GA_CODEGEN", raising=False)
    with pytest.raises(CompilationError, match="gcc was not found"):
        codegen.CompiledFunction(make_function("nofallback"), codegen=True, fallback=False)


def test_defect3_cache_dir_reports_the_fallback(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "file").write_text("x")
    monkeypatch.setenv("COOP_GA_CACHE", str(tmp_path / "file" / "cache"))
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    monkeypatch.setattr(tempfile, "tempdir", None)  # gettempdir() caches its answer
    _fresh_codegen_state(monkeypatch)
    with pytest.warns(CacheWarning, match="COOP_GA_CACHE") as rec:
        assert codegen.cache_dir() == tmp_path / f"coop_ga-{UID}"
    assert len(rec) == 1
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert codegen.cache_dir() == tmp_path / f"coop_ga-{UID}"  # once per process
    (tmp_path / f"coop_ga-{UID}").rmdir()
    (tmp_path / f"coop_ga-{UID}").write_text("x")
    _fresh_codegen_state(monkeypatch)
    with pytest.warns(CacheWarning, match="private directory of this process") as rec:
        private = codegen.cache_dir()  # then a fresh private directory
    assert len(rec) == 1 and str(tmp_path / f"coop_ga-{UID}") in str(rec[0].message)
    assert private.parent == tmp_path and private.name.startswith(f"coop_ga-{UID}-private-")
    assert private.stat().st_mode & 0o777 == 0o700 and private.stat().st_uid == os.geteuid()
    monkeypatch.setenv("TMPDIR", str(tmp_path / "file"))  # no usable temporary directory left
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "file"))
    _fresh_codegen_state(monkeypatch)
    with pytest.raises(CompilationError, match="no usable compile cache"):
        codegen.cache_dir()


def _fresh_codegen_state(monkeypatch: pytest.MonkeyPatch) -> None:
    """Forget this process's checks of cache directories and its warnings (as in a new process)."""
    monkeypatch.setattr(codegen._cache, "_warned", set())
    monkeypatch.setattr(codegen._trust, "_checked", {})
    monkeypatch.setattr(codegen._trust, "_private", {})


def test_worker_runs_without_the_package_init() -> None:
    """The worker imports coop_ga.codegen alone (guards the helper the tests above rely on)."""
    code = (
        f"import sys; sys.path.insert(0, {str(WORKER.parent)!r}); import _worker; cg = _worker.import_codegen(); "
        "print(cg.__file__, 'coop_ga.cooperative' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == [str(ROOT / "coop_ga" / "codegen" / "__init__.py"), "False"]
