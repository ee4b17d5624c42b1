"""The physics benchmark's CI mode runs, checks its own run and writes strict JSON of the documented shape
(never a timing assertion: the numbers are read for their shape and finiteness only)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

pytest.importorskip("mujoco")

from tests.helpers import read_metrics, script_main

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "sim.py"


def test_ci_mode_writes_the_documented_json(tmp_path) -> None:
    assert script_main(SCRIPT)(["--ci", "--quiet", "--out", str(tmp_path)]) == 0
    doc = read_metrics(tmp_path, "results.json")
    assert doc["ci"] is True and doc["steps"] == 200 and doc["simulated_s"] == pytest.approx(0.2)
    loops = [r["loop"] for r in doc["rows"]]
    assert loops == ["bare mj_step (anchor)", "Simulation, constant τ", "Simulation + joint PD"]
    for r in doc["rows"]:
        assert all(math.isfinite(r[k]) and r[k] > 0 for k in ("us_per_step", "ratio", "realtime"))
    assert doc["rows"][0]["ratio"] == 1.0
    assert 0.0 < doc["controller_share"] < 1.0 and doc["controller_us_per_call"] > 0.0
    assert doc["issue_target_realtime"] in ("PASS", "MISS")
    assert doc["check"]["max_q_error_rad"] < 1e-6 and abs(doc["check"]["box_z_m"] - 0.1) < 1e-3
    # part 2: the carry scenario with the hold controller, and its anchor (the logged controls replayed)
    hold = doc["hold"]
    assert hold["steps"] == 200 and hold["simulated_s"] == pytest.approx(0.2)
    for k in ("us_per_step", "cpu_us_per_step", "anchor_us_per_step", "ratio", "realtime", "controller_us_per_call"):
        assert math.isfinite(hold[k]) and hold[k] > 0, k
    assert 0.0 < hold["controller_share"] < 1.0 and hold["issue_target_realtime"] in ("PASS", "MISS")
    assert hold["check"]["replay_max_qpos_error"] == 0.0  # the anchor ran the same physics, bit for bit
    # part 3: the cooperative wrench against task.evaluate
    w = doc["wrench"]
    assert set(w["us_per_call"]) == {"wrench", "evaluate", "wrench_views", "evaluate_views"}
    assert all(math.isfinite(v) and v > 0 for v in w["us_per_call"].values())
    assert w["ratio"] == pytest.approx(w["us_per_call"]["wrench"] / w["us_per_call"]["evaluate"])
    assert w["issue_target_ratio"] in ("PASS", "MISS") and w["instructions"]["wrench"] > 1000


def test_help_lists_the_options(capsys) -> None:
    with pytest.raises(SystemExit) as ex:
        script_main(SCRIPT)(["--help"])
    assert ex.value.code == 0
    text = capsys.readouterr().out
    for opt in ("--seconds", "--hold-seconds", "--ci", "--out", "--quiet"):
        assert opt in text
