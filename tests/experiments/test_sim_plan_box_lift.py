"""experiments/sim_plan_box_lift.py: the gallery's run (paper_figures/ours_planning_box_lift_execution) holds its
claims, replays in its model.xml with MuJoCo alone, and is what the current code computes (not stale).

The script takes minutes (a grasp, then per plan OMPL + TOPP-RA + MuJoCo at 1 kHz with the controller in the
loop), so the claims are read from the committed gallery; the staleness check rebuilds the scene and re-simulates
the first 0.3 s with the current code, which must reproduce the committed log bit for bit.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mujoco")

from tests.helpers import assert_same_mujoco_xml, read_metrics

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "paper_figures" / "ours_planning_box_lift_execution"


def test_the_executed_plans_hold_their_claims():
    m = read_metrics(OUT)
    assert m["object_body"] == "box" and m["experiment"] == "plan_execute" and m["fast"] is True
    assert m["runs_count"] == 3 and m["planned_count"] == 3 and m["dropped_count"] == 0
    # 2 of 3 plans end with the box in the goal region; seed 2's box ends 1.4 mm below it: the held box ends
    # below the height the planner aimed at (0.195–0.205 m: the circle's impedance sag, the box's tilt in the
    # compliant grasp)
    assert m["success_count"] == m["in_goal_count"] == 2
    assert list(m["failures"]) == ["seed_2"] and m["failures"]["seed_2"][0].startswith("box 0.1 cm outside the goal")
    for r in m["runs"]:
        p = r["plan"]
        assert p["success"] and p["valid"] and p["max_violation"] < 1e-4
        # TOPP-RA's constant-acceleration segments: within 1e-4 rad/s and 5 % of the 1 rad/s² bound
        assert p["velocity_excess"] < 1e-4 and p["acceleration_excess"] <= 0.05
        assert r["success"] == r["box_in_goal"] == (r["goal_distance_m"] == 0.0) and not r["dropped"]
        lo, hi, d = (np.array(r[k]) for k in ("goal_displacement_lower_m", "goal_displacement_upper_m",
                                               "box_displacement_m"))  # fmt: skip
        assert np.all(lo[:2] <= d[:2]) and np.all(d[:2] <= hi[:2])  # x, y in the region for every run
        assert 0.185 <= d[2] <= hi[2] and r["goal_distance_m"] < 0.002  # the box ≈ 0.2 m up, at most 2 mm below
        assert r["tilt_final_deg"] <= 10.0 and r["tilt_max_deg"] <= 10.0
        assert len(r["slip_mm"]) == 3 and r["slip_max_mm"] <= 5.0
        assert r["shelf_contact_rows"] == 0 and r["shelf_clearance_m"] > 0.005  # MuJoCo: never touched
        assert r["max_limit_violation"] == 0.0 and r["max_velocity_violation"] == 0.0
        assert r["saturated_updates"] == 0
        assert r["weight_estimate_kg"] == pytest.approx(2.0, rel=0.05)
        assert 30.0 <= r["squeeze_min_N"] and r["squeeze_max_N"] <= 60.0
        # the pads follow the planned pads within the grasp's compliance; the wrists do not follow the plan's
        # tool pivots (the controller holds the tools' axes in the grasp frame: module docstring)
        assert r["tracking_arm_max_rad"] < 0.5 and r["pad_tracking_max_m"] < 0.05
    g = m["gallery"]
    assert g["agrees"] is False and g["figures"] == ["execution.png", "execution.gif"]  # 2 of 3: reported
    for name in g["figures"]:
        assert (OUT / name).stat().st_size > 10_000, name


def test_the_log_replays_with_mujoco_alone():
    from coop_ga.sim import replay

    assert replay(OUT) <= 1e-12


def test_the_gallery_run_is_what_the_code_computes():
    """The committed model.xml is the current scene's (the shelf as static spheres), and the first 0.3 s of the
    current controller reproduce the committed log (regenerate: python -m paper_figures --only sim_plan_box_lift)."""
    from coop_ga.sim import Simulation
    from coop_ga.sim.plan_execute import PathCarryPlan, PathHoldController, execution_gains, execution_setup

    st, _ = execution_setup()
    assert_same_mujoco_xml(st.scene.to_xml(), (OUT / "model.xml").read_text())
    log = np.load(OUT / "log.npz")
    p = PathCarryPlan.make(st.plan, None)  # before the follow phase the path plays no part
    ctl = PathHoldController(st.scene, st.task, p, execution_gains(), q_start=st.q_start, q_grasp=st.q_grasp)
    new = Simulation(st.scene, ctl, q=st.q_start).run(0.3)
    k = len(new.time)
    # to a tolerance, not bit for bit: the model's last bits are the machine's (assert_same_mujoco_xml)
    np.testing.assert_allclose(new.qpos, log["qpos"][:k], rtol=0, atol=1e-9)
    np.testing.assert_allclose(new.ctrl[:-1], log["ctrl"][: k - 1], rtol=0, atol=1e-6)
