"""The control-step benchmark's CI mode runs, writes its ratios, and compares like with like.

No timing is asserted (the machine is shared): the test checks that every candidate was timed, that the
ratios are finite and positive, and that ``new_pv`` (the control layer with the former limits) follows the
former ``diff_ik_step``'s trajectory (the same number of steps with a QP), which is what makes new_pv / old
a measure of the layer's own cost.
"""

from __future__ import annotations

import importlib
import json
import math
import sys
from pathlib import Path

BENCH = Path(__file__).resolve().parents[2] / "benchmarks"


def test_control_step_ci(tmp_path: Path) -> None:
    if str(BENCH) not in sys.path:
        sys.path.insert(0, str(BENCH))
    cs = importlib.import_module("control_step")
    assert cs.main(["--ci", "--out", str(tmp_path), "--quiet"]) == 0
    res = json.loads((tmp_path / "results.json").read_text())
    for k in ("new", "new_pv", "old", "old_reach"):
        assert res["us_per_step"][k] > 0.0, k
    for k, r in res["ratios"].items():
        assert math.isfinite(r) and r > 0.0, k
    assert {"new_pv/old", "new/old"} <= set(res["ratios"])
    qp = res["qp_steps"]
    assert qp["new_pv"] == qp["old"]  # the same trajectory, the same QPs
    assert qp["new"] > qp["new_pv"]  # the acceleration bounds are active while the arms speed up
    assert res["final_error"]["new"] < 0.05 and res["final_error"]["old"] < 0.05
