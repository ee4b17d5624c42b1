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

import dataclasses
import math

import numpy as np
import pytest

pytest.importorskip("mujoco")

from coop_ga.errors import CoopGAError, InvalidInputError, NonFiniteError, UnreachableError
from coop_ga.sim import Box, Simulation, replay
from coop_ga.sim.hold import squeeze_admittance
from coop_ga.sim.partner import (
    BOUNDS,
    HAND_START,
    HOLD_S,
    LIFT_M,
    LIFT_S,
    PAD_RADIUS,
    RAMP_S,
    HandRecording,
    PartnerCase,
    _rolling,
    _series,
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
    # the squeeze: ℓ* starts 15 N / 800 N/m = 18.75 mm below the contact length; the admittance loop then holds
    # the pad's force within 10 % of 15 N while the hand moves (the fixed dilation alone: ~13–14 N, next test)
    assert m["length_compression_m"] == pytest.approx(0.01875, abs=1e-12)
    assert 13.5 < m["squeeze_min_N"] <= m["squeeze_max_N"] < 16.5
    assert m["squeeze_mean_N"] == pytest.approx(15.0, abs=0.3)
    # the slip's split: the pad's rolling and sliding each at most the total plus the other
    assert m["slip_pad_rolling_max_m"] < BOUNDS["slip_m"] and m["slip_pad_sliding_max_m"] < BOUNDS["slip_m"]
    assert m["slip_pad_max_m"] <= m["slip_pad_rolling_max_m"] + m["slip_pad_sliding_max_m"] + 1e-12
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


def test_the_squeeze_loop_moves_the_length_target_and_without_it_the_squeeze_sits_below_its_set_point(short):
    run, _ = short
    tr, ctl = run.trace, run.setup.controller
    after = tr["time"] >= HOLD_S + LIFT_S
    # regulated: ℓ* left the fixed dilation ℓ_c − s_d / K∥ (the soft contacts' penetration asks it shorter)
    shift = tr["length_target"][after] - ctl.l_final
    assert np.all(np.abs(shift) <= ctl.gains.dr_max + 1e-15) and np.min(shift) < -1e-3
    # the same short run with the loop off: ℓ* is the ramp alone and the squeeze stays ~1.5 N below 15 N
    fixed = run_partner(
        dataclasses.replace(CASE, name="short fixed", gains=dataclasses.replace(CASE.gains, admittance=0.0))
    )
    tf = fixed.trace
    np.testing.assert_allclose(tf["length_target"], [fixed.setup.controller.length_target(t) for t in tf["time"]])
    assert tf["length_target"][-1] == pytest.approx(fixed.setup.controller.l_final, abs=1e-15)
    m, mf = run.metrics, fixed.metrics
    assert mf["squeeze_mean_N"] < 14.2 < m["squeeze_mean_N"]
    assert abs(m["squeeze_mean_N"] - 15.0) < abs(mf["squeeze_mean_N"] - 15.0) / 3


def test_the_admittance_step_is_the_hold_controllers():
    # one function for both controllers: rate k (s − s_d) clipped to ±v_max, offset clipped to ±dr_max
    assert squeeze_admittance(0.0, 17.0, 15.0, 0.002, 0.03, 0.1, 0.01) == pytest.approx(0.002 * 0.03 * 2.0, abs=1e-18)
    assert squeeze_admittance(0.0, 0.0, 15.0, 0.002, 1.0, 0.1, 0.01) == pytest.approx(-0.002 * 0.1, abs=1e-18)
    assert squeeze_admittance(0.0099, 100.0, 15.0, 0.01, 1.0, 1.0, 0.01) == 0.01
    assert squeeze_admittance(0.003, 99.0, 15.0, 0.002, 0.0, 0.1, 0.01) == 0.003  # k = 0: the fixed dilation


def test_the_rolling_part_is_the_pads_turn_times_its_radius():
    # a pad turning by 0.1 rad about the bar's y axis (in 100 steps) rolls its centre r × 0.1 along the bar's z;
    # a spin about the bar's axis x (the pad's normal) rolls nothing
    T = 101
    R_bar = np.tile(np.eye(3), (T, 1, 1))
    a = np.linspace(0.0, 0.1, T)
    Ry = np.array([[[math.cos(x), 0, math.sin(x)], [0, 1, 0], [-math.sin(x), 0, math.cos(x)]] for x in a])
    roll = _rolling(R_bar, Ry, 0)
    np.testing.assert_allclose(roll[-1], [0.0, PAD_RADIUS * 0.1], atol=1e-9)
    Rx = np.array([[[1, 0, 0], [0, math.cos(x), -math.sin(x)], [0, math.sin(x), math.cos(x)]] for x in a])
    np.testing.assert_allclose(_rolling(R_bar, Rx, 0), 0.0, atol=1e-15)
    # the same turn with the bar turning along: no relative rotation, no rolling; rows before i0 do not count
    np.testing.assert_allclose(_rolling(Ry, Ry, 0), 0.0, atol=1e-15)
    np.testing.assert_allclose(_rolling(R_bar, Ry, 50)[-1], [0.0, PAD_RADIUS * 0.05], atol=1e-9)


def test_the_sliding_part_is_the_material_points_relative_motion_measured_in_mujoco(short):
    # independent of the rolling formula: MuJoCo's pad–bar contact point c, its material point on the pad and on
    # the bar carried to the next control update with each body's pose; their difference summed (bar frame)
    import mujoco

    run, _ = short
    st, log, tr = run.setup, run.log, run.trace
    m, d = st.scene.model, mujoco.MjData(st.scene.model)
    bar, pad = st.scene.object_ids["bar"], st.scene.end_bodies[0]
    i0 = int(np.searchsorted(tr["time"], HOLD_S))
    rows = np.rint(tr["time"] / m.opt.timestep).astype(int)
    prev, slide, ours = None, np.zeros(3), []
    for k in rows[i0:]:
        d.qpos[:] = log.qpos[k]
        d.mocap_pos[:] = log.mocap_pos[k]
        mujoco.mj_forward(m, d)
        con = d.contact[: d.ncon]
        (i,) = [j for j in range(d.ncon) if {m.geom_bodyid[con.geom1[j]], m.geom_bodyid[con.geom2[j]]} == {bar, pad}]
        now = (
            con.pos[i].copy(),
            *(d.xmat[b].reshape(3, 3).copy() for b in (pad, bar)),
            d.xpos[pad].copy(),
            d.xpos[bar].copy(),
        )
        if prev is not None:
            c0, Rp0, Rb0, pp0, pb0 = prev
            _, Rp, Rb, pp, pb = now
            slide += Rb.T @ ((pp + Rp @ (Rp0.T @ (c0 - pp0))) - (pb + Rb @ (Rb0.T @ (c0 - pb0))))
        prev = now
        ours.append(np.linalg.norm(slide[1:]))
    split = _series(run)["slip_pad_sliding"][i0:]
    np.testing.assert_allclose(ours, split, atol=2e-4)  # 0.2 mm over the run
    assert max(ours) > 5e-4  # something slid: the comparison is not 0 = 0


def test_a_phase_starts_the_figure_eight_elsewhere_from_the_same_point():
    a, b = figure_eight(HAND_START, period=3.0, phase=0.0), figure_eight(HAND_START, period=3.0, phase=2.1)
    np.testing.assert_allclose(b.position[0], HAND_START, atol=1e-15)  # still at the start, then lifted
    np.testing.assert_allclose(b.position[-1], a.position[-1], atol=1e-12)  # one period: back at the lifted start
    assert np.max(np.linalg.norm(b.position - a.position, axis=1)) > 0.03  # another path
    assert np.ptp(b.position[:, 0]) == pytest.approx(np.ptp(a.position[:, 0]), abs=1e-3)  # the same size


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
