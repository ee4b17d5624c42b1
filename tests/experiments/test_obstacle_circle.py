"""experiments/obstacle_circle.py --fast: three Frankas carry their circle past a sphere, with and without avoidance."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.helpers import read_metrics, script_main

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "experiments" / "obstacle_circle.py"


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("obstacle_circle")
    assert script_main(SCRIPT)(["--fast", "--quiet", "--out", str(out)]) == 0
    return out


def testread_metrics(run):
    m = read_metrics(run)
    assert m["dof"] == 21 and m["system"] == "three_franka"
    (ob,) = m["obstacles"]
    assert set(ob) == {"center", "radius"} and len(ob["center"]) == 3 and ob["radius"] == pytest.approx(0.04)
    # with avoidance: every pair clear (obstacle, arm–arm, same-arm), the circle reaches its target
    assert m["min_clearance"] > 0.0
    assert m["min_clearance"] >= m["d_safe"] - 2e-3
    assert m["min_arm_arm_clearance"] > 0.0
    assert m["converged"] and m["terminal_error"] < 1e-4
    # without avoidance: the gripper enters the sphere (on the way: start and goal are clear)
    assert m["min_clearance_no_avoidance"] < -0.03
    assert "sphere" in m["closest_pair_no_avoidance"]
    # (the goal: 3.6 cm, where the redundant arms end under the acceleration limits)
    assert m["clearance_start"] > 0.04 and m["clearance_goal"] > 0.03
    assert m["converged_no_avoidance"] and m["terminal_error_no_avoidance"] < 1e-4
    assert m["max_limit_violation"] == 0.0
    # every differential-IK run inside the Franka's acceleration limits (from rest), none had to drop them
    assert m["max_acceleration_violation"] == 0.0
    assert all(v["max_acceleration_violation"] == 0.0 and v["relaxed_steps"] == 0 for v in m["modes"].values())
    # the nullspace repulsion leaves the cooperative task velocity as it is (to the QP solver's tolerance where
    # the acceleration bounds are active); dampers alone do not, and together with the repulsion less so
    assert m["modes"]["soft"]["max_task_velocity_deviation"] < 1e-5
    assert m["max_task_velocity_deviation"] < m["modes"]["hard"]["max_task_velocity_deviation"]
    assert m["modes"]["hard"]["min_clearance"] >= m["d_safe"] - 2e-3
    assert m["modes"]["hard"]["max_task_velocity_deviation"] > 0.1
    assert m["modes"]["hard"]["max_damper_residual"] <= 1e-9
    # iLQR: the clearance cost (same distances) lifts the clearance from < 0 to > 0, between the knots too
    il = m["ilqr"]
    assert il["min_clearance_no_clearance_cost"] < -0.01
    assert il["min_clearance"] > 0.03 and il["min_clearance_knots"] >= il["min_clearance"]
    assert il["converged"] and il["terminal_error"] < 1e-5
    assert il["joint_limit_violation"] == 0.0 and il["velocity_violation"] == 0.0
    g = m["gallery"]
    assert g["agrees"] is True and g["figures"][0] == "scene.png"
    for name in g["figures"]:
        assert (run / name).stat().st_size > 10_000, name
    # wall-clock times go to timing.json, not to the committed metrics
    assert not [k for k in m if "time" in k or (k.endswith("_s") and k != "gain_per_s")]
    assert (run / "timing.json").exists()


def test_trajectories(run):
    m = read_metrics(run)
    z = np.load(run / "trajectory.npz")
    T = m["T"]
    assert z["q"].shape == (T, 21) and z["q_no_avoidance"].shape == (T, 21)
    assert z["clearance"].min() == pytest.approx(m["min_clearance"], rel=1e-5)
    assert z["clearance_no_avoidance"].min() == pytest.approx(m["min_clearance_no_avoidance"], rel=1e-5)
    # both runs start at q0 and leave it
    np.testing.assert_array_equal(z["q"][0], z["q_no_avoidance"][0])
    assert np.max(np.abs(z["q"] - z["q_no_avoidance"])) > 0.05


def test_deterministic(run, tmp_path):
    assert script_main(SCRIPT)(["--fast", "--quiet", "--out", str(tmp_path)]) == 0
    assert (tmp_path / "metrics.json").read_text() == (run / "metrics.json").read_text()
