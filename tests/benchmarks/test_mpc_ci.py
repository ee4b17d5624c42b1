"""benchmarks/mpc.py --ci: runs, writes its JSON with the tick statistics, the anchors and the ratios.

No timing assertion (the numbers are printed and recorded, not tested): the test checks the structure, that every
warm tick used its iteration budget, and that the ratios are the ratios of the recorded times.
"""

from __future__ import annotations

import importlib
import json
import sys
from pathlib import Path
from typing import Any

import pytest

BENCH = Path(__file__).resolve().parents[2] / "benchmarks"


def _module() -> Any:
    if str(BENCH) not in sys.path:
        sys.path.insert(0, str(BENCH))
    return importlib.import_module("mpc")


@pytest.fixture(scope="module")
def doc(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    out = tmp_path_factory.mktemp("mpc_bench")
    assert _module().main(["--ci", "--quiet", "--out", str(out)]) == 0
    return json.loads((out / "results.json").read_text())


def test_results_structure_and_ratios(doc: dict[str, Any]) -> None:
    assert doc["config"]["horizons"] == [20] and doc["config"]["ticks"] == 4 and len(doc["load_average"]) == 3
    a = doc["anchors"]
    assert a["task_evaluate_s"] > 0 and a["collision_evaluate_s"] > 0
    (r,) = doc["results"]
    assert r["horizon"] == 20 and r["lookahead_s"] == pytest.approx(0.4)
    for v in ("clearance", "plain"):
        x = r[v]
        assert x["iterations"] == 2.0  # the per-tick budget, used on every warm tick
        t = x["tick_s"]
        assert 0 < t["median"] <= t["p95"] <= t["max"]
        assert x["solve_s"]["median"] <= t["max"]
        assert x["tick_over_task_evaluate"] == pytest.approx(
            t["median"] / a["task_evaluate_s"], rel=1e-4
        )  # JSON rounding
        assert x["sustained_rate_hz"] == pytest.approx(1.0 / t["median"], rel=1e-4)
    assert r["note"].startswith("H=20: with the clearance cost") and "without it" in r["note"]
    o = r["setup_overhead"]  # the inner call set up once vs ilqr_reach on the same ticks (CPU)
    assert o["receding_reach_cpu_s"] > 0 and o["ilqr_reach_cpu_s"] > 0 and o["ratio"] > 0
    assert "RecedingReach" in r["note"]
    assert doc["config"]["core"] is not None  # pinned to one core
    for part in ("tick", "filter"):  # the profile: shares of the profiled time, each with its Python share
        shares = r["profile"][part]
        assert sum(v["share"] for v in shares.values()) == pytest.approx(1.0, abs=1e-4)
        assert all(0.0 <= v["share"] <= 1.0 and 0.0 <= v["python"] <= 1.0 for v in shares.values())
    assert {"iLQR", "collision"} <= set(r["profile"]["tick"]) and "QP" in r["profile"]["filter"]
    assert "profile, tick: " in r["note"] and "profile, safety step: " in r["note"]


def test_cli(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as ex:
        _module().main(["--help"])
    assert ex.value.code == 0
    text = capsys.readouterr().out
    for opt in ("--horizons", "--ticks", "--ci", "--out", "--quiet"):
        assert opt in text, opt
