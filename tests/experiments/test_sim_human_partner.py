"""experiments/sim_human_partner.py: the gallery's run (paper_figures/ours_sim_human_partner) holds its claims,
replays in its model.xml with MuJoCo alone (the palm's mocap target moved by the logged poses), and is what the
current code computes (not stale).

The claims are read from the committed gallery (its runs: the three cases, the feedback case with the squeeze
loop off, four more cells of the robustness grid; ~25 s of CPU with the GIF); the staleness check rebuilds
the scene and re-simulates the first 0.3 s with the current code, which must reproduce the committed log bit for
bit.  The full version's extra cases (softer gains, the weak squeeze, the doubled faster hand) are run by
``python experiments/sim_human_partner.py --out DIR`` (each with the loop off too, and the whole 3 × 3 grid).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mujoco")

from tests.helpers import assert_same_mujoco_xml, read_metrics

ROOT = Path(__file__).resolve().parents[2]
FOLDER = ROOT / "paper_figures" / "ours_sim_human_partner"


def test_the_carry_with_the_human_holds_its_claims():
    m = read_metrics(FOLDER)
    assert m["experiment"] == "human_partner" and m["fast"] is True and m["object_body"] == "bar"
    assert m["runs_count"] == 3 and m["success_count"] == 3 and m["failures"] == {}
    by = {r["case"]["name"]: r for r in m["runs"]}
    assert set(by) == {"feed_forward", "feedback", "feedback_fast_hand"}
    for r in m["runs"]:
        assert r["success"] and r["failures"] == [] and not r["dropped"]
        assert r["bar_offset_max_m"] < 0.005  # the bar stays where the pair holds it
        assert r["slip_pad_max_m"] < 0.005 and r["slip_palm_max_m"] < 0.005
        assert r["direction_error_max_rad"] < 0.05 and r["length_error_max_m"] < 0.005
        # regulated by the admittance loop: within 5 % of the set-point while the hand moves
        assert 0.95 * r["squeeze_set_N"] < r["squeeze_min_N"] <= r["squeeze_max_N"] < 1.05 * r["squeeze_set_N"]
        assert r["slip_pad_rolling_max_m"] < 0.002 and r["slip_pad_sliding_max_m"] < 0.005
        assert r["other_contact_updates"] == 0 and r["saturated_updates"] == 0
        assert r["palm_lag_max_m"] < 0.005  # the palm (the measured point) follows the recording's mocap target
        assert r["max_limit_violation"] == 0.0 and r["max_velocity_violation"] == 0.0
        assert r["length_compression_m"] == pytest.approx(15.0 / 800.0)  # ℓ* = ℓ_c − s_d / K∥
    # the feed-forward of the hand's measured velocity: the direction error at least 3× smaller than feedback only
    assert by["feed_forward"]["direction_error_max_rad"] < by["feedback"]["direction_error_max_rad"] / 3
    # a faster hand (period 2.5 s instead of 4 s) costs feedback-only control direction accuracy
    assert by["feedback_fast_hand"]["direction_error_max_rad"] > by["feedback"]["direction_error_max_rad"]
    assert by["feedback_fast_hand"]["hand_speed_max_m_s"] > 1.4 * by["feedback"]["hand_speed_max_m_s"]
    # before / after: the same feedback case with the fixed dilation alone sat lower and swung wider
    fb = m["squeeze_regulation"]["feedback"]
    fixed, reg = fb["fixed"], fb["regulated"]
    assert not fixed["dropped"] and not reg["dropped"] and reg == {k: by["feedback"][k] for k in reg}
    assert fixed["squeeze_min_N"] < 12.0 and fixed["squeeze_mean_N"] < 14.0  # ~11–15.5 N for 15 N
    assert fixed["squeeze_max_N"] - fixed["squeeze_min_N"] > 3 * (reg["squeeze_max_N"] - reg["squeeze_min_N"])
    assert reg["squeeze_mean_N"] == pytest.approx(15.0, abs=0.1)
    # robustness: gains × 0.5 and × 2 at the nominal hand, two other hands (speed, phase) at the nominal gains
    rb = m["robustness"]
    assert rb["runs_count"] == 5 and rb["success_count"] == 5 and rb["dropped_count"] == 0
    assert {c["name"] for c in rb["runs"]} == {
        "gains0.5_period4_phase0", "gains1_period4_phase0", "gains2_period4_phase0", "gains1_period3_phase2.1",
        "gains1_period2.5_phase4.2",
    }  # fmt: skip
    assert 14.0 < rb["squeeze_min_N"] and rb["squeeze_max_N"] < 16.0
    cell = {c["name"]: c for c in rb["runs"]}
    assert cell["gains1_period4_phase0"]["direction_error_max_rad"] == by["feed_forward"]["direction_error_max_rad"]
    # stiffer pair, smaller direction error (the same damping ratio)
    d = [cell[f"gains{k}_period4_phase0"]["direction_error_max_rad"] for k in ("0.5", "1", "2")]
    assert d[0] > d[1] > d[2] and d[2] < 0.005
    g = m["gallery"]
    assert g["agrees"] is True and g["figures"] == ["partner.png", "partner.gif"]
    for name in g["figures"]:
        assert (FOLDER / name).stat().st_size > 10_000, name


def test_the_log_replays_with_mujoco_alone():
    from coop_ga.sim import replay

    log = np.load(FOLDER / "log.npz")
    assert {"mocap_pos", "mocap_quat"} <= set(log.files)
    assert np.ptp(log["mocap_pos"][:, 0, 2]) > 0.05  # the hand moved (lift + figure-eight)
    assert replay(FOLDER) == 0.0


def test_the_gallery_run_is_what_the_code_computes():
    """The committed model.xml is the current scene's, and the first 0.3 s of the current controller reproduce
    the committed log (regenerate: python -m paper_figures --only sim_human_partner)."""
    from coop_ga.sim import Simulation
    from coop_ga.sim.partner import CONTROL_DT, PartnerCase, partner_setup

    st = partner_setup(PartnerCase("feed_forward", feed_forward=True, periods=1.0))
    assert_same_mujoco_xml(st.scene.to_xml(), (FOLDER / "model.xml").read_text())
    log = np.load(FOLDER / "log.npz")
    sim = Simulation(st.scene, st.controller, q=st.q_start, mocap=st.recording.mocap, control_dt=CONTROL_DT)
    new = sim.run(0.3)
    k = len(new.time)
    # to a tolerance, not bit for bit: the model's last bits are the machine's (assert_same_mujoco_xml)
    np.testing.assert_allclose(new.qpos, log["qpos"][:k], rtol=0, atol=1e-9)
    np.testing.assert_allclose(new.ctrl[:-1], log["ctrl"][: k - 1], rtol=0, atol=1e-6)
    np.testing.assert_allclose(new.mocap_pos, log["mocap_pos"][:k], rtol=0, atol=1e-9)
