"""The hexapod walking benchmark's CI mode runs, checks its own run and writes strict JSON of the documented shape
(never a timing assertion: the numbers are read for their shape and finiteness only)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

pytest.importorskip("mujoco")

from tests.helpers import read_metrics, script_main

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "sim_hexapod.py"


def test_ci_mode_writes_the_documented_json(tmp_path) -> None:
    assert script_main(SCRIPT)(["--ci", "--quiet", "--out", str(tmp_path)]) == 0
    doc = read_metrics(tmp_path, "results.json")
    assert doc["ci"] is True and doc["steps"] == 400 and doc["simulated_s"] == pytest.approx(0.4)
    assert [r["loop"] for r in doc["rows"]] == ["bare mj_step (anchor)", "Simulation + walker"]
    for r in doc["rows"]:
        assert all(math.isfinite(r[k]) and r[k] > 0 for k in ("us_per_step", "ratio", "realtime"))
    assert doc["rows"][0]["ratio"] == 1.0
    assert 0.0 < doc["controller_share"] < 1.0 and doc["plan_us"] > 0.0 and doc["servo_us"] > 0.0
    assert doc["plans"] == 80  # 200 Hz over 0.4 s
    assert doc["issue_target_realtime"] in ("PASS", "MISS")
    assert doc["check"]["walked_m"] > 0.0 and doc["check"]["saturated_updates"] == 0


def test_help_lists_the_options(capsys) -> None:
    with pytest.raises(SystemExit) as ex:
        script_main(SCRIPT)(["--help"])
    assert ex.value.code == 0
    text = capsys.readouterr().out
    for opt in ("--seconds", "--gait", "--ci", "--out", "--quiet"):
        assert opt in text
