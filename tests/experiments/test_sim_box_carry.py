"""experiments/sim_box_carry.py: the gallery's runs (paper_figures/ours_sim_box_*) hold their claims, replay
in their model.xml with MuJoCo alone, and are what the current code computes (not stale).

The runs themselves take minutes (MuJoCo at 1 kHz with the controller in the loop), so the claims are read
from the committed gallery; the staleness check rebuilds the nominal scene and re-simulates its first
0.3 s with the current code, which must reproduce the committed log bit for bit.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mujoco")

from tests.helpers import assert_same_mujoco_xml, read_metrics

ROOT = Path(__file__).resolve().parents[2]
CARRY = ROOT / "paper_figures" / "ours_sim_box_carry"
CONTROL = ROOT / "paper_figures" / "ours_sim_box_no_squeeze"


def test_the_carry_holds_its_claims():
    m = read_metrics(CARRY)
    assert m["object_body"] == "box" and m["experiment"] == "carry" and m["fast"] is True
    assert m["runs_count"] >= 2 and m["success_count"] == m["runs_count"] and m["failures"] == {}
    for r in m["runs"]:
        assert r["success"] and r["failures"] == []
        assert r["lift_m"] >= 0.10 and r["tilt_max_deg"] <= 10.0 and r["slip_max_mm"] <= 5.0
        assert r["squeeze_error_max"] <= 0.25 and r["carry_error_m"] <= 0.03 and r["on_table"] is True
        assert abs(r["turn_deg"] - 20.0) < 3.0  # the box turned with the plan
        assert r["weight_estimate_kg"] == pytest.approx(r["case"]["mass_kg"], rel=0.05)
        assert r["max_limit_violation"] == 0.0 and r["max_velocity_violation"] == 0.0
        assert len(r["slip_mm"]) == 3 and r["carried_s"] > 1.0
    assert {r["case"]["name"] for r in m["runs"]} >= {"nominal", "heavy_slippery_offset"}
    g = m["gallery"]
    assert g["agrees"] is True and g["figures"] == ["carry.png", "keyframes.png", "carry.gif"]
    for name in g["figures"]:
        assert (CARRY / name).stat().st_size > 10_000, name


def test_without_the_squeeze_the_box_stays_on_the_table():
    m = read_metrics(CONTROL)
    assert m["object_body"] == "box" and m["experiment"] == "control_no_squeeze"
    (r,) = m["runs"]
    assert r["case"]["squeeze_N"] == 0.0 and r["success"]
    assert r["rise_max_m"] < 0.01  # the circle lifted 0.15 m; the box did not follow
    assert r["squeeze_max_N"] < 10.0  # nothing pressed (the squeeze loop backs off)
    assert r["pad_force_max_N"] > 1.0  # … though the pads did touch the box's walls
    assert m["gallery"]["agrees"] is True


@pytest.mark.parametrize("folder", [CARRY, CONTROL], ids=["carry", "no_squeeze"])
def test_the_logs_replay_with_mujoco_alone(folder):
    from coop_ga.sim import replay

    assert replay(folder) <= 1e-12


@pytest.mark.parametrize(("folder", "squeeze"), [(CARRY, 40.0), (CONTROL, 0.0)], ids=["carry", "no_squeeze"])
def test_the_gallery_run_is_what_the_code_computes(folder, squeeze):
    """The committed model.xml is the current scene's, and the first 0.3 s of the current controller
    reproduce the committed log (regenerate: python experiments/sim_box_carry.py --fast [--no-squeeze] --out ...)."""
    from coop_ga.sim import Simulation
    from coop_ga.sim.carry import FAST_DURATIONS, CarryCase, carry_setup

    st = carry_setup(CarryCase("nominal", squeeze=squeeze, durations=FAST_DURATIONS))
    assert_same_mujoco_xml(st.scene.to_xml(), (folder / "model.xml").read_text())
    log = np.load(folder / "log.npz")
    sim = Simulation(st.scene, st.controller, q=st.q_start)
    new = sim.run(0.3)
    k = len(new.time)
    # to a tolerance, not bit for bit: the model's last bits are the machine's (assert_same_mujoco_xml)
    np.testing.assert_allclose(new.qpos, log["qpos"][:k], rtol=0, atol=1e-9)
    np.testing.assert_allclose(new.ctrl[:-1], log["ctrl"][: k - 1], rtol=0, atol=1e-6)
