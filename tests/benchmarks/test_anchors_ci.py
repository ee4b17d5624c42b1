"""The anchors benchmark's CI mode runs and reports every anchor: a row with its agreement where the library is
installed, a skipped row saying why where it is not (crocoddyl: needs Pinocchio 4.0.0).  No timing is asserted."""

from __future__ import annotations

import importlib
import json
import math
import sys
from pathlib import Path

BENCH = Path(__file__).resolve().parents[2] / "benchmarks"
#: the largest agreement accepted per row [the row's unit]
AGREE = {
    "end points (FK)": 1e-12,
    "diff-IK step": 1e-4,
    "steps to converge": 1e-9,
    "reach (OCP)": 1e-4,
    "circle primitive": 1e-12,
    "motor FK (Franka)": 1e-12,
}


def _installed(name: str) -> bool:
    try:
        importlib.import_module(name)
    except ImportError:
        return False
    return True


def test_anchors_ci(tmp_path: Path) -> None:
    if str(BENCH) not in sys.path:
        sys.path.insert(0, str(BENCH))
    anchors = importlib.import_module("anchors")
    assert anchors.main(["--ci", "--out", str(tmp_path), "--quiet"]) == 0
    res = json.loads((tmp_path / "results.json").read_text())
    rows = {(r["anchor"], r["what"]): r for r in res["rows"]}
    assert {r["anchor"] for r in res["rows"]} == {"Pinocchio", "pink", "crocoddyl", "pygafro"}
    for (anchor, what), r in rows.items():
        if r["note"].startswith("skipped"):
            assert r["agreement"] is None and "ratio" not in r, (anchor, what)
            continue
        assert r["agreement"] < AGREE[what], (anchor, what, r["agreement"])
        assert math.isfinite(r["ratio"]) and r["ratio"] > 0.0, (anchor, what)
        assert "NOT CONVERGED" not in r["note"], (anchor, what)
    assert not rows["Pinocchio", "end points (FK)"]["note"].startswith("skipped")
    if _installed("pink"):
        assert {("pink", "diff-IK step"), ("pink", "steps to converge")} <= set(rows)
    croc = rows["crocoddyl", "reach (OCP)"]
    runs = _installed("crocoddyl") and res["pin"].startswith("4.0.")
    assert croc["note"].startswith("skipped") != runs
    if not runs:
        assert "pin 4.0.0" in croc["note"]
    pygafro_runs = ("pygafro", "circle primitive") in rows
    assert pygafro_runs == _installed("pygafro")
