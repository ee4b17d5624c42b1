"""Helpers of the reliability tests: run :mod:`_worker` in a subprocess with a controlled environment."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
WORKER = HERE / "_worker.py"


@dataclass
class Run:
    """Outcome of one worker process."""

    returncode: int
    stdout: str
    stderr: str
    result: dict = field(default_factory=dict)

    @property
    def cache_warnings(self) -> list[str]:
        return [w["message"] for w in self.result.get("warnings", []) if w["category"] == "CacheWarning"]

    def describe(self) -> str:
        return f"exit code {self.returncode}\nstdout:\n{self.stdout[-3000:]}\nstderr:\n{self.stderr[-3000:]}"


def worker_env(cache: Path | str, tmpdir: Path | str, **extra: str) -> dict[str, str]:
    """The test process's environment with the cache and TMPDIR set and coop_ga switches removed
    (but ``COOP_GA_CODEGEN_IMPL``, set by hand to run the tests against another implementation)."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("COOP_GA_") or k == "COOP_GA_CODEGEN_IMPL"}
    env.update(COOP_GA_CACHE=str(cache), TMPDIR=str(tmpdir), PYTHONDONTWRITEBYTECODE="1")
    env.update(extra)
    return env


def parse(proc_returncode: int, stdout: str, stderr: str) -> Run:
    run = Run(proc_returncode, stdout, stderr)
    for line in stdout.splitlines():
        if line.startswith("RESULT "):
            run.result = json.loads(line[len("RESULT ") :])
    return run


def run_worker(
    spec: dict, env: dict[str, str], prefix: list[str] | None = None, worker: Path = WORKER, timeout: float = 120.0
) -> Run:
    """Run the worker to completion (``prefix``: e.g. a ``setpriv`` command line)."""
    cmd = [*(prefix or []), sys.executable, str(worker), json.dumps(spec)]
    p = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=timeout, check=False)
    return parse(p.returncode, p.stdout, p.stderr)


def start_worker(spec: dict, env: dict[str, str]) -> subprocess.Popen:
    """Start the worker without waiting (finish with :func:`finish`)."""
    cmd = [sys.executable, str(WORKER), json.dumps(spec)]
    return subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def finish(p: subprocess.Popen, timeout: float = 120.0) -> Run:
    out, err = p.communicate(timeout=timeout)
    return parse(p.returncode, out, err)


def entries(cache: Path) -> dict[str, list[Path]]:
    """Files of a cache directory by kind: libraries, checksums, locks and anything else (temporaries)."""
    kinds: dict[str, list[Path]] = {"so": [], "sha256": [], "lock": [], "other": []}
    for p in sorted(cache.iterdir()):
        if p.name.endswith(".so"):
            kinds["so"].append(p)
        elif p.name.endswith(".so.sha256"):
            kinds["sha256"].append(p)
        elif p.name.endswith(".lock"):
            kinds["lock"].append(p)
        else:
            kinds["other"].append(p)
    return kinds


def fake_gcc_dir(where: Path) -> Path:
    """A directory holding a ``gcc`` that always fails (put it first on PATH)."""
    where.mkdir(parents=True, exist_ok=True)
    gcc = where / "gcc"
    gcc.write_text("#!/bin/sh\necho 'gcc: fatal error: fake compiler for the coop_ga tests' >&2\nexit 1\n")
    gcc.chmod(0o755)
    return where


def setpriv_nobody() -> list[str] | None:
    """A command prefix running as user ``nobody`` (uid 65534), or None if that is impossible here."""
    if os.geteuid() != 0 or shutil.which("setpriv") is None:
        return None
    return ["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups"]
