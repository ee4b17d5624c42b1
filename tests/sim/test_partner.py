"""The human partner in MuJoCo (coop_ga.sim.partner): a G1 arm and a palm on a recorded trajectory carry a free bar
held by the point pair's squeeze; mocap bodies in Simulation logs and their replay.

One short run (the hand still, the lift, half a figure-eight of period 2 s, at rest): asserted with numbers —
the bar is not dropped, slips < 5 mm, the pair keeps its direction within 0.05 rad and |ℓ − ℓ_c| within 5 mm,
the squeeze stays above 25 % of its set-point, the robot touches nothing but the bar, no joint limit is left;
the log (with the mocap target's pose per step) replays in its model.xml with MuJoCo alone to 0.0, and without
the mocap poses it does not.  Bad input (a NaN in the recording, a bar longer than the reach, a mocap function
returning NaN) raises a CoopGAError naming the problem.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("mujoco")

from coop_ga.errors import CoopGAError, InvalidInputError, NonFiniteError, UnreachableError
from coop_ga.sim import Box, Simulation, replay
from coop_ga.sim.partner import (
    BOUNDS,
    HAND_START,
    HOLD_S,
    LIFT_M,
    LIFT_S,
    RAMP_S,
    HandRecording,
    PartnerCase,
    figure_eight,
    partner_setup,
    run_partner,
)

CASE = PartnerCase("short", feed_forward=True, period=2.0, periods=0.5)


@pytest.fixture(scope="module")
def short(tmp_path_factory):
    run = run_partner(CASE)
    return run, run.log.save(tmp_path_factory.mktemp("partner"))


# ---------------------------------------------------------------------- the hand's recording
def test_the_recording_interpolates_its_samples_and_their_velocity():
    rec = figure_eight(HAND_START, period=4.0, periods=1.0)
    for k in (0, 17, 150, 333, len(rec.time) - 1):  # the cubic passes through every sample
        np.testing.assert_allclose(rec.at(float(rec.time[k]))[0], rec.position[k], atol=1e-15)
    # the velocity is the cubic's derivative: a central difference agrees to 1e-8 m/s (C¹ across samples too)
    for t in (0.95, 2.013, 2.02, 3.777):
        fd = (rec.at(t + 1e-7)[0] - rec.at(t - 1e-7)[0]) / 2e-7
        np.testing.assert_allclose(rec.at(t)[1], fd, atol=1e-6)
    # the lift and the figure-eight: 5 cm up, at most ±4 cm along x and ±3 cm in y, back at the lifted start
    P = rec.position
    assert P[-1, 2] - HAND_START[2] == pytest.approx(LIFT_M, abs=1e-12)
    assert np.max(np.abs(P[:, 0] - HAND_START[0])) == pytest.approx(0.04, abs=1e-3)
    assert np.max(np.abs(P[:, 1] - HAND_START[1])) == pytest.approx(0.03, abs=1e-3)
    np.testing.assert_allclose(P[-1, :2], HAND_START[:2], atol=1e-12)
    assert rec.duration == pytest.approx(HOLD_S + LIFT_S + 4.0 + RAMP_S + 0.5, abs=0.011)
    # still at both ends (velocity 0 outside the recording)
    assert np.all(rec.at(-1.0)[1] == 0.0) and np.all(rec.at(rec.duration + 1.0)[1] == 0.0)


def test_a_recording_with_a_nan_sample_is_refused():
    t = np.arange(0.0, 1.0, 0.01)
    P = np.tile(HAND_START, (t.size, 1))
    lost = P.copy()
    lost[42, 1] = math.nan  # a lost marker
    with pytest.raises(NonFiniteError, match="row 42"):
        HandRecording(t, lost)
    with pytest.raises(InvalidInputError, match="strictly increasing"):
        HandRecording(t[::-1], P)
    with pytest.raises(InvalidInputError, match=r"\(K, 3\)"):
        HandRecording(t, P[:, :2])
    HandRecording(t, P)  # the same samples, clean: accepted


def test_a_bar_longer_than_the_reach_is_refused():
    with pytest.raises(UnreachableError, match=r"bar of 1\.5 m") as e:
        partner_setup(PartnerCase("long", bar_length=1.5))
    assert isinstance(e.value, CoopGAError)
    with pytest.raises(UnreachableError, match="out of the G1's right-arm reach"):
        partner_setup(PartnerCase("short bar", bar_length=0.05))  # the pad would have to reach 0.73 m ahead


def test_a_mocap_object_is_neither_static_nor_free():
    b = Box(name="hand", mocap=True)
    assert b.mocap and not b.free and not b.static
    with pytest.raises(InvalidInputError, match="mocap"):
        Box(name="hand", mocap=True, static=True)


# ---------------------------------------------------------------------- the short run
def test_the_short_run_holds_the_bar(short):
    run, _ = short
    m = run.metrics
    assert m["success"], m["failures"]
    assert not m["dropped"] and m["bar_offset_max_m"] < 0.01
    assert m["slip_pad_max_m"] < BOUNDS["slip_m"] and m["slip_palm_max_m"] < BOUNDS["slip_m"]
    assert m["direction_error_max_rad"] < 0.01  # with the feed-forward (example 12: feedback alone ~1e-2)
    assert m["length_error_max_m"] < BOUNDS["length_m"]
    # the squeeze: ℓ* is 15 N / 800 N/m = 18.75 mm below the contact length; the pad presses 10–16 N
    assert m["length_compression_m"] == pytest.approx(0.01875, abs=1e-12)
    assert 10.0 < m["squeeze_min_N"] <= m["squeeze_max_N"] < 16.0
    assert m["other_contact_updates"] == 0 and m["saturated_updates"] == 0
    assert m["max_limit_violation"] == 0.0 and m["max_velocity_violation"] == 0.0
    # the bar rose with the hand (off its post: 5 cm lift + 4 cm at half the figure-eight): held, not resting
    a = run.setup.scene.object_qpos["bar"]
    z = run.log.qpos[:, a + 2]
    assert z[-1] - z[0] == pytest.approx(LIFT_M + 0.04, abs=0.005)
    assert run.setup.scene.mocap_index == {"hand_target": 0} and run.setup.scene.object_qpos.keys() == {"bar", "palm"}
    # the palm followed its mocap target (the soft weld: lags ~ v × 10 ms, sags under the squeeze) within 5 mm
    rec = run.setup.recording
    k = len(run.log.time) // 2
    np.testing.assert_allclose(run.log.mocap_pos[k, 0], rec.at(float(run.log.time[k]))[0], atol=1e-15)
    p = run.setup.scene.object_qpos["palm"]
    lag = np.max(np.linalg.norm(run.log.qpos[:, p : p + 3] - run.log.mocap_pos[:, 0], axis=1))
    assert lag < 0.005 and m["palm_lag_max_m"] == lag


def test_the_log_replays_with_mujoco_alone_and_needs_the_mocap_poses(short, tmp_path):
    _, folder = short
    log = np.load(folder / "log.npz")
    assert log["mocap_pos"].shape == (len(log["time"]), 1, 3) and log["mocap_quat"].shape == (len(log["time"]), 1, 4)
    assert replay(folder) == 0.0
    # the hand is an input of the run: replayed without its poses, the palm's target stays put and the run differs
    (tmp_path / "model.xml").write_text((folder / "model.xml").read_text())
    np.savez(tmp_path / "log.npz", **{k: log[k] for k in ("time", "qpos", "qvel", "ctrl")})
    assert replay(tmp_path) > 0.01


def test_a_mocap_trajectory_with_nan_raises_naming_the_time(short):
    run, _ = short
    st = run.setup

    def bad(t):
        pos, quat = st.recording.mocap(t)
        return (pos * math.nan if t > 0.0045 else pos), quat

    sim = Simulation(st.scene, None, q=st.q_start, mocap=bad)
    with pytest.raises(NonFiniteError, match=r"mocap\(0.005"):
        sim.run(0.01)
    with pytest.raises(InvalidInputError, match="quaternions"):
        Simulation(st.scene, None, q=st.q_start, mocap=lambda t: (st.recording.mocap(t)[0], [[2.0, 0, 0, 0]]))
