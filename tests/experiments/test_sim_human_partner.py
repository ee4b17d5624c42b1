"""experiments/sim_human_partner.py: the gallery's run (paper_figures/ours_sim_human_partner) holds its claims,
replays in its model.xml with MuJoCo alone (the palm's mocap target moved by the logged poses), and is what the
current code computes (not stale).

The claims are read from the committed gallery (its three runs take ~15 s of CPU); the staleness check rebuilds
the scene and re-simulates the first 0.3 s with the current code, which must reproduce the committed log bit for
bit.  The full version's extra cases (softer gains, the weak squeeze, the doubled faster hand) are run by
``python experiments/sim_human_partner.py --out DIR``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mujoco")

from tests.helpers import read_metrics

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
        assert r["squeeze_min_N"] > 0.25 * r["squeeze_set_N"] and r["squeeze_max_N"] < 1.25 * r["squeeze_set_N"]
        assert r["other_contact_updates"] == 0 and r["saturated_updates"] == 0
        assert r["palm_lag_max_m"] < 0.005  # the palm (the measured point) follows the recording's mocap target
        assert r["max_limit_violation"] == 0.0 and r["max_velocity_violation"] == 0.0
        assert r["length_compression_m"] == pytest.approx(15.0 / 800.0)  # ℓ* = ℓ_c − s_d / K∥
    # the feed-forward of the hand's measured velocity: the direction error at least 3× smaller than feedback only
    assert by["feed_forward"]["direction_error_max_rad"] < by["feedback"]["direction_error_max_rad"] / 3
    # a faster hand (period 2.5 s instead of 4 s) costs feedback-only control direction accuracy
    assert by["feedback_fast_hand"]["direction_error_max_rad"] > by["feedback"]["direction_error_max_rad"]
    assert by["feedback_fast_hand"]["hand_speed_max_m_s"] > 1.4 * by["feedback"]["hand_speed_max_m_s"]
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
    assert st.scene.to_xml() == (FOLDER / "model.xml").read_text()
    log = np.load(FOLDER / "log.npz")
    sim = Simulation(st.scene, st.controller, q=st.q_start, mocap=st.recording.mocap, control_dt=CONTROL_DT)
    new = sim.run(0.3)
    k = len(new.time)
    np.testing.assert_array_equal(new.qpos, log["qpos"][:k])
    np.testing.assert_array_equal(new.ctrl[:-1], log["ctrl"][: k - 1])
    np.testing.assert_array_equal(new.mocap_pos, log["mocap_pos"][:k])
