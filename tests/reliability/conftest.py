"""Fixtures shared by the compile-cache tests."""

from __future__ import annotations

from pathlib import Path

import pytest

from ._util import run_worker, worker_env


@pytest.fixture(scope="module")
def populated(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A cache holding the entry of ``f0``, compiled by a worker (tests damage copies of it, and its
    name is the one an attacker plants under)."""
    base = tmp_path_factory.mktemp("populated")
    (base / "tmp").mkdir()
    run = run_worker({"functions": ["f0"]}, worker_env(base / "cache", base / "tmp"))
    assert run.returncode == 0, run.describe()
    assert [f["codegen"] for f in run.result["functions"]] == [True] and run.result["functions"][0]["max_err"] < 1e-12
    assert run.result["stats"]["compiled"] == 1
    return base / "cache"
