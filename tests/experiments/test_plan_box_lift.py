"""experiments/plan_box_lift.py: two box-lift plans through the script (OMPL's projected state space, the rigid
grasp, the shelf), the time parameterisation inside the limits, the outputs the gallery reads, determinism."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("ompl", reason="the plan extra is not installed: pip install 'coop_ga[plan]'")
pytest.importorskip("toppra", reason="the plan extra is not installed: pip install 'coop_ga[plan]'")

from tests.helpers import script_main

SCRIPT = Path(__file__).resolve().parents[2] / "experiments" / "plan_box_lift.py"


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("plan_box_lift")
    assert script_main(SCRIPT)(["--fast", "--plans", "2", "--quiet", "--out", str(out)]) == 0
    return out, json.loads((out / "metrics.json").read_text())


def test_every_plan_solves_and_the_outputs_exist(run):
    out, m = run
    g = m["gallery"]
    assert g["agrees"] is True and all((out / name).stat().st_size > 10_000 for name in g["figures"])
    d = np.load(out / "trajectory.npz")
    assert d["q"].shape[1] == d["waypoints"].shape[1] == 21 and d["t"][0] == 0.0
    assert np.all(np.diff(d["t"]) > 0)


def test_plans_hold_the_grasp_and_the_timing_stays_inside_the_limits(run):
    s, t = run[1]["statistics"], run[1]["timed"]
    assert s["plans"] == 2 and s["success_rate"] == 1.0 and s["failures"] == []
    assert s["all_waypoints_valid"] is True and s["worst_violation"] < 1e-5  # the rigid grasp, metres
    assert t["velocity_excess"] == 0.0 and t["acceleration_excess"] <= 0.01  # TOPP-RA: ≤ 1 % over, see tests/plan
    assert 0.0 < t["max_grasp_error_m"] < 1e-4 and t["duration_s"] > 0.0
