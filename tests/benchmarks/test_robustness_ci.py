"""The robustness benchmark's CI mode: runs, writes strict JSON of the documented shape, and is reproducible.

One module-scoped fixture runs ``--ci`` three times (serial, serial again, ``--workers 2``)
and once on a sub-selection; the tests only read the JSON files (no timing assertions).
"""

from __future__ import annotations

import importlib
import json
import math
import sys
from pathlib import Path
from typing import Any, ClassVar

import pytest

BENCH = Path(__file__).resolve().parents[2] / "benchmarks"


def _module() -> Any:
    # on sys.path (not loaded from a file spec): spawned workers re-import the module by name
    if str(BENCH) not in sys.path:
        sys.path.insert(0, str(BENCH))
    return importlib.import_module("robustness")


def _strict_load(path: Path) -> dict[str, Any]:
    def refuse(name: str) -> None:
        raise AssertionError(f"non-strict JSON constant {name} in {path}")

    return json.loads(path.read_text(), parse_constant=refuse)


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, dict[str, Any]]:
    rb = _module()
    out: dict[str, dict[str, Any]] = {}
    for name, extra in (
        ("serial", []),
        ("again", []),
        ("workers", ["--workers", "2"]),
        ("subset", ["--systems", "allegro", "--kinds", "sphere"]),
    ):
        d = tmp_path_factory.mktemp(f"robustness_{name}")
        argv = ["--out", str(d), "--quiet", "--seed", "7"]
        argv += ["--ci", *extra] if name != "subset" else ["--levels", "small", "--targets", "1", *extra]
        assert rb.main(argv) == 0
        out[name] = _strict_load(d / "robustness.json")
    return out


def _without_times(records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    rb = _module()
    out = []
    for r in records:
        r = json.loads(json.dumps(r))
        r["certification"].pop("time_s")
        for job in r["jobs"].values():
            for k in rb.TIME_FIELDS:
                job.pop(k)
        out.append(r)
    return out


def _is_num(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def test_schema(runs: dict[str, dict[str, Any]]) -> None:
    rb = _module()
    doc = runs["serial"]
    for key in (
        "schema_version",
        "config",
        "cases",
        "skipped",
        "setup",
        "records",
        "aggregates",
        "issue_targets",
        "wall_time_s",
        "versions",
        "machine",
    ):
        assert key in doc, key
    cfg = doc["config"]
    assert cfg["ci"] is True and cfg["seed"] == 7 and cfg["targets"] == rb.CI_TARGETS
    assert cfg["levels"] == list(rb.CI_LEVELS) and cfg["solvers"] == list(rb.SOLVERS)
    assert set(cfg["level_definitions"]) == set(rb.LEVELS)
    assert all(isinstance(s["reason"], str) and s["reason"] for s in doc["skipped"])
    assert {"system": "three_franka", "kind": "sphere"} in [
        {k: s[k] for k in ("system", "kind")} for s in doc["skipped"]
    ]  # 3 arms: no sphere
    assert len(doc["records"]) == len(doc["cases"]) * len(cfg["levels"]) * cfg["targets"] > 0
    assert isinstance(doc["versions"]["numpy"], str) and isinstance(doc["machine"]["cpu_count"], int)
    for r in doc["records"]:
        assert {
            "system",
            "kind",
            "level",
            "index",
            "nq",
            "spawn_key",
            "displacement",
            "qd_init",
            "certification",
            "jobs",
        } <= set(r)
        assert len(r["qd_init"]) == r["nq"] and all(abs(v) <= rb.QD_INIT_MAX for v in r["qd_init"])
        d = r["displacement"]
        level = rb.LEVELS[r["level"]]
        assert math.hypot(*d["translation_m"]) == pytest.approx(level.translation_m)
        assert math.hypot(*d["axis"]) == pytest.approx(1.0)
        assert math.degrees(d["angle_rad"]) == pytest.approx(level.angle_deg)
        assert abs(d["scale"] - 1.0) == pytest.approx(level.scale)
        c = r["certification"]
        assert isinstance(c["certified"], bool) and _is_num(c["time_s"])
        if c["certified"]:
            assert c["error"] < rb.CERT_TOL and c["violation"] == 0.0 and set(r["jobs"]) == set(rb.SOLVERS)
        else:
            assert isinstance(c["reason"], str) and r["jobs"] == {}
    agg = doc["aggregates"]
    for key in (
        "by_solver_level",
        "by_solver",
        "by_case",
        "certification_by_level",
        "certification_by_case",
        "certification",
    ):
        assert key in agg, key
    assert len(agg["by_solver_level"]) == len(cfg["solvers"]) * len(cfg["levels"])
    for a in agg["by_solver_level"]:
        for key in (
            "runs",
            "convergence_rate",
            "iterations_median",
            "iterations_max",
            "time_median_s",
            "time_max_s",
            "max_violation",
            "outside_limits",
            "converged_outside_limits",
            "max_speed",
            "within_5_iterations_rate",
            "exceptions",
        ):
            assert key in a, key
        assert a["runs"] == agg["certification"]["certified"]
        assert a["convergence_rate"] is None or 0.0 <= a["convergence_rate"] <= 1.0
    assert {t["status"] for t in doc["issue_targets"]} <= {"PASS", "MISS", "N/A"}
    assert len(doc["issue_targets"]) >= 7


def test_numbers_are_finite_or_recorded_errors(runs: dict[str, dict[str, Any]]) -> None:
    n_jobs = 0
    for r in runs["serial"]["records"]:
        for name, job in r["jobs"].items():
            n_jobs += 1
            assert job["solver"] == name and _is_num(job["time_s"]) and job["time_s"] >= 0
            if job["exception"] is not None:
                assert isinstance(job["exception"]["type"], str) and isinstance(job["exception"]["message"], str)
                assert job["converged"] is False
                continue
            assert isinstance(job["converged"], bool)
            assert isinstance(job["iterations"], int) and job["iterations"] >= 0
            assert _is_num(job["error"]) and job["error"] >= 0
            assert _is_num(job["violation"]) and job["violation"] >= 0
            if name == "gn":  # no trajectory, no speed
                assert job["max_speed"] is None
            else:
                assert _is_num(job["max_speed"]) and _is_num(job["velocity_violation"])
            if name == "diffik":
                assert isinstance(job["reached_1e-4_in_2.5s"], bool)
                assert job["t_reach_1e-4_s"] is None or _is_num(job["t_reach_1e-4_s"])
            if name == "ilqr_moving":  # starts at the drawn velocity
                assert job["max_speed"] >= max(abs(v) for v in r["qd_init"]) - 1e-12
    assert n_jobs > 0


def test_same_seed_same_records(runs: dict[str, dict[str, Any]]) -> None:
    assert _without_times(runs["serial"]["records"]) == _without_times(runs["again"]["records"])


def test_workers_same_records_as_serial(runs: dict[str, dict[str, Any]]) -> None:
    assert runs["workers"]["config"]["workers"] == 2
    assert _without_times(runs["workers"]["records"]) == _without_times(runs["serial"]["records"])
    assert len({s["pid"] for s in runs["workers"]["setup"]} - {s["pid"] for s in runs["serial"]["setup"]}) >= 1


def test_target_independent_of_selection(runs: dict[str, dict[str, Any]]) -> None:
    """A target's stream depends on its names, not on which systems/kinds were selected."""
    sub = _without_times(runs["subset"]["records"])
    assert [(r["system"], r["kind"]) for r in sub] == [("allegro", "sphere")]
    full = [r for r in _without_times(runs["serial"]["records"]) if (r["system"], r["kind"]) == ("allegro", "sphere")]
    assert full == sub


def test_other_seed_other_targets(runs: dict[str, dict[str, Any]]) -> None:
    rb = _module()
    a = rb.draw_target(rb.target_rng(7, "allegro", "sphere", "small", 0), rb.LEVELS["small"], 16)
    b = rb.draw_target(rb.target_rng(8, "allegro", "sphere", "small", 0), rb.LEVELS["small"], 16)
    c = rb.draw_target(rb.target_rng(7, "allegro", "sphere", "small", 0), rb.LEVELS["small"], 16)
    assert a == c and a != b
    rec = next(r for r in runs["serial"]["records"] if (r["system"], r["kind"]) == ("allegro", "sphere"))
    assert rec["displacement"]["translation_m"] == list(a.translation) and rec["qd_init"] == list(a.qd_init)


def test_cli_help_and_bad_values(capsys: pytest.CaptureFixture[str]) -> None:
    rb = _module()
    with pytest.raises(SystemExit) as ex:
        rb.main(["--help"])
    assert ex.value.code == 0
    text = capsys.readouterr().out
    for opt in (
        "--targets",
        "--systems",
        "--kinds",
        "--levels",
        "--solvers",
        "--seed",
        "--out",
        "--ci",
        "--quiet",
        "--workers",
        "default",
    ):
        assert opt in text, opt
    for bad in (
        ["--targets", "0"],
        ["--workers", "x"],
        ["--seed", "-1"],
        ["--systems", "no_such_robot"],
        ["--levels", "huge"],
    ):
        with pytest.raises(SystemExit) as ex:
            rb.main(bad)
        assert ex.value.code == 2
        assert "argument" in capsys.readouterr().err


def test_solver_failures_are_records(monkeypatch: pytest.MonkeyPatch) -> None:
    """An exception, a non-finite result or a result without the public fields is a recorded failed job."""
    rb = _module()
    task = rb._task("three_franka", "point")
    q0 = task.system.q0

    def boom(*args: Any, **kwargs: Any) -> Any:
        raise RuntimeError("boom")

    class NaNResult:
        converged, error, iterations, q, message = True, float("nan"), 3, q0, "ok"
        warnings: ClassVar[dict[str, int]] = {}

    jobs = []
    for fake in (boom, lambda *a, **k: NaNResult(), lambda *a, **k: object()):
        monkeypatch.setattr(rb, "_call_solver", fake)
        jobs.append(rb.run_job("gn", task, q0, None))
    assert [j["exception"]["type"] for j in jobs] == ["RuntimeError", "NonFiniteResult", "ResultError(AttributeError)"]
    assert jobs[0]["exception"]["message"] == "boom"
    assert all(j["converged"] is False for j in jobs)
    agg = rb.summarize(jobs, "gn")
    assert agg["runs"] == 3 and agg["exceptions"] == 3 and agg["convergence_rate"] == 0.0
