"""The blind walker's riser handling (coop_ga.sim.walking_blind): the legs' shin reach toward a riser against the
terrain's own capsule clearance, and the probing swing's shape."""

from __future__ import annotations

import math

import numpy as np
import pytest

from coop_ga.legged import Terrain
from coop_ga.legged.contact import leg_segments
from coop_ga.legged.gait import swing_arc
from coop_ga.legged.legs import hexapod_legs
from coop_ga.sim.walking import WalkingOptions, nominal_feet
from coop_ga.sim.walking_blind import PROBE_DESCENT, approach_lengths, probe_path, riser_distance, shin_reach
from coop_ga.sim.walking_kin import FastLegs


def test_riser_distance_of_simple_capsules() -> None:
    """A vertical capsule standing on the guard height needs the riser one radius away; one higher than guard +
    radius cannot reach it; a tilted one is limited by its lowest end's cap."""
    up = riser_distance(np.array([0.0, 0.0, 0.03]), np.array([0.0, 0.0, 0.1]), 0.02, 0.03)
    assert up == pytest.approx(0.02, abs=1e-12)
    assert riser_distance(np.array([0.0, 0.0, 0.06]), np.array([0.0, 0.0, 0.1]), 0.02, 0.03) == -math.inf
    # lowest point 1 cm above the guard, 5 mm ahead: √(0.02² − 0.01²) beyond it
    tilted = riser_distance(np.array([0.005, 0.0, 0.04]), np.array([-0.05, 0.0, 0.09]), 0.02, 0.03)
    assert tilted == pytest.approx(0.005 + math.sqrt(0.02**2 - 0.01**2), abs=1e-12)


def test_shin_reach_agrees_with_the_terrains_capsule_clearance() -> None:
    """Per leg, a 3 cm riser at the computed reach (+ 1 mm) clears every capsule of that leg at every stance pose
    the reach was computed over (Terrain.capsule_clearance ≥ −0.5 mm: its own sampling bound), and one 3 mm
    closer does not at some pose.  Front legs 18.9 mm, middle 25.9 mm, rear 39.4 mm (the rear knee stands ahead of
    its foot)."""
    lm = hexapod_legs()
    opt = WalkingOptions()
    reach = shin_reach(lm, opt, guard=0.03)
    assert reach[[0, 3]] == pytest.approx(0.0189, abs=5e-4)
    assert reach[[1, 4]] == pytest.approx(0.0259, abs=5e-4)
    assert reach[[2, 5]] == pytest.approx(0.0394, abs=5e-4)
    fl = FastLegs(lm)
    feet = nominal_feet(lm, opt) + np.array([0.0, 0.0, opt.ride_height + lm.foot_radius])
    for i in range(6):
        worst = {}
        for e in (reach[i] + 0.001, reach[i] - 0.003):
            riser = Terrain.steps(step_height=0.03, step_length=10.0, start_x=float(feet[i, 0] + e), n_steps=1)
            clear = math.inf
            for dx in np.linspace(-0.04, 0.04, 5):
                for dz in (0.0, 0.0075, 0.015):
                    body = np.array([dx, 0.0, opt.ride_height + lm.foot_radius + dz])
                    q, _ = fl.ik(feet - body)
                    a, b, rho = leg_segments(lm, body, np.eye(3), q)
                    c = min(float(riser.capsule_clearance(a[i, k], b[i, k], rho[k], 0.001)) for k in range(3))
                    clear = min(clear, c)
            worst[e] = clear
        assert worst[reach[i] + 0.001] >= -5e-4, (i, worst)
        assert worst[reach[i] - 0.003] < -1e-3, (i, worst)


def test_probe_path_goes_past_the_foothold_and_back_down() -> None:
    """From lift-off to 15 mm past the foothold at 11 mm above it, back over it, then straight down onto it; the arc
    and the way back share the swing so that their horizontal speeds peak alike."""
    p0, p1 = np.array([0.0, 0.0, 0.01]), np.array([0.08, 0.0, 0.01])
    s = np.linspace(0.0, 1.0, 2001)
    path = probe_path(p0, p1, 0.04, 0.015, 0.011, s)
    assert np.allclose(path[0], p0) and np.allclose(path[-1], p1)
    f1 = (1.0 - PROBE_DESCENT) * 0.095 / (0.08 + 1.6 * 0.015)
    k = int(np.argmin(np.abs(s - f1)))
    assert np.allclose(path[k], [0.095, 0.0, 0.021], atol=1e-5)  # the far point, 15 mm past, 11 mm above p1
    assert path[:, 0].max() == pytest.approx(0.095, abs=1e-12)
    back = path[k:]
    assert np.all(np.diff(back[:, 0]) <= 1e-12) and np.all(np.diff(back[:, 2]) <= 1e-12)  # back, then down
    assert np.allclose(path[s >= 1.0 - PROBE_DESCENT, 0], 0.08)  # the descent is vertical, over the foothold
    vx = np.abs(np.diff(path[:, 0])) / np.diff(s)
    assert vx[s[1:] > f1].max() == pytest.approx(vx[s[1:] <= f1].max(), rel=0.02)
    plain = probe_path(p0, p0 + np.array([0.002, 0.0, 0.0]), 0.04, 0.015, 0.011, s)  # no direction: the plain arc
    assert np.allclose(plain, swing_arc(p0, p0 + np.array([0.002, 0.0, 0.0]), 0.04, s)[0])


def test_approach_lengths_are_the_front_shins_reach_back() -> None:
    """Blind, the legs whose shins lie behind their feet (shin_reach toward −x beyond that toward +x, 35 mm ledge:
    the front legs, 42.1 vs 21.0 mm) come in low over their reach back − the ball's radius (33.1 mm); the middle
    (27.4 mm both ways) and rear legs do not; with the map or without the probe no leg does."""
    lm = hexapod_legs()
    blind = WalkingOptions(blind=True)
    back = shin_reach(lm, blind, guard=0.035, direction=(-1.0, 0.0))
    ahead = shin_reach(lm, blind, guard=0.035)
    assert back[[0, 3]] == pytest.approx(0.0421, abs=5e-4) and ahead[[0, 3]] == pytest.approx(0.0210, abs=5e-4)
    got = approach_lengths(lm, blind)
    assert got[[0, 3]] == pytest.approx(back[[0, 3]] - lm.foot_radius, abs=1e-12)
    assert got[[0, 3]] == pytest.approx(0.0331, abs=5e-4)
    assert np.all(got[[1, 2, 4, 5]] == 0.0)
    assert np.all(approach_lengths(lm, WalkingOptions()) == 0.0)
    assert np.all(approach_lengths(lm, WalkingOptions(blind=True, probe_guard=0.0)) == 0.0)


def test_probe_path_comes_in_low_before_the_foothold() -> None:
    """With an approach of 33 mm at 7 mm above the foothold: the arc ends 33 mm before it at that height (at the
    time share 2.5 (L − a) : 1.5 (a + 2 reach) of the first 90 %), the foot then goes straight on, never higher
    than the probe's 11 mm, to the far point 15 mm past it, back over it and down onto it; no approach: the
    probe of old, unchanged."""
    p0, p1 = np.array([0.0, 0.0, 0.01]), np.array([0.08, 0.0, 0.01])
    s = np.linspace(0.0, 1.0, 4001)
    path = probe_path(p0, p1, 0.04, 0.015, 0.011, s, approach=0.033, low_height=0.007)
    assert np.allclose(path[0], p0) and np.allclose(path[-1], p1)
    fa = (1.0 - PROBE_DESCENT) * 2.5 * 0.047 / (2.5 * 0.047 + 1.5 * (0.033 + 0.03))
    k = int(np.argmin(np.abs(s - fa)))
    assert np.allclose(path[k], [0.047, 0.0, 0.017], atol=2e-5)  # 33 mm before p1, 7 mm above it
    arc = swing_arc(p0, np.array([0.047, 0.0, 0.017]), 0.04, s[: k + 1] / fa)[0]
    assert np.allclose(path[: k + 1], arc, atol=1e-9)
    on = path[k:][path[k:, 0] >= path[k:, 0].max() - 1e-12][0]
    assert on == pytest.approx([0.095, 0.0, 0.021], abs=1e-5)  # the far point
    j = k + int(np.argmax(path[k:, 0]))
    assert np.all(np.diff(path[k : j + 1, 0]) >= -1e-12)  # straight on to it
    assert np.all(path[k:, 2] <= 0.021 + 1e-12) and np.all(path[k:, 2] >= 0.01 - 1e-12)
    old = probe_path(p0, p1, 0.04, 0.015, 0.011, s)
    assert np.array_equal(probe_path(p0, p1, 0.04, 0.015, 0.011, s, approach=0.0), old)
    short = probe_path(p0, np.array([0.03, 0.0, 0.01]), 0.04, 0.015, 0.011, s, approach=0.033)
    assert short[:, 0].min() >= -1e-12 and np.isclose(short[-1, 0], 0.03)  # at most half the swing: 15 mm


def _probe_speed(lm, opt, i: int, probe: float, speed: float) -> float:
    """The largest joint speed over the URDF limit of leg i's probing swing of a straight walk at ``speed`` [m/s]
    (the other feet nominal), by LegModel's own IK (not the walker's FastLegs)."""
    tab = opt.table()
    nom = nominal_feet(lm, opt)
    stroke = np.array([speed * tab.duty * tab.period, 0.0, 0.0])
    s = np.linspace(0.0, 1.0, 401)
    h = opt.probe_height + opt.touchdown_depth
    low = {"approach": approach_lengths(lm, opt)[i], "low_height": opt.approach_height + opt.touchdown_depth}
    path = probe_path(
        nom[i] - 0.5 * stroke, nom[i] + 0.5 * stroke, max(opt.lift_height, opt.blind_lift), probe, h, s, **low
    )
    feet = np.repeat(nom[None], len(s), axis=0)
    feet[:, i] = path
    q = lm.ik(feet, check_limits=False)
    rate = np.abs(np.diff(q, axis=0)).max(axis=0) / (np.diff(s)[0] * (1.0 - tab.duty) * tab.period)
    vlim = np.empty(18)
    vlim[np.asarray(lm.q_index)] = np.asarray(lm.velocity_limit, float)
    return float(np.max(rate / vlim))


def test_check_command_accounts_for_the_probing_swing() -> None:
    """Blind, the swing the walker flies is the probe (the stroke plus the probe out and back): check_command
    measures its joint speed (against LegModel's own IK on a 2.5× finer path: within 2 %; well above the plain
    arc's), and where it needs more than the URDF limit (the front legs' probes, coming in low; the wave's 0.67 s
    swing) finds the longest probe that does not: at the returned scale ≤ 1.01×, 1/16 of the probe longer > 1.0×.
    With the map there is no probe."""
    from dataclasses import replace

    from coop_ga.sim.walking import check_command
    from coop_ga.sim.walking_blind import probe_reaches
    from coop_ga.sim.walking_experiments import straight_command

    lm = hexapod_legs()
    for gait in ("tripod", "wave"):
        cmd, opt, _ = straight_command(gait, 1.0)
        speed = float(cmd.values[:, 0].max())
        mapped = check_command(cmd, opt, lm)
        assert mapped["probe_speed_ratio"] == 0.0 and np.all(mapped["probe_scale"] == 1.0)
        blind = replace(opt, blind=True)
        got = check_command(cmd, blind, lm)
        probe = probe_reaches(lm, blind)
        assert np.all(probe > 0.0)
        plain = max(_probe_speed(lm, blind, i, 0.0, speed) for i in range(6))
        assert got["joint_speed_ratio"] == pytest.approx(plain, rel=0.02)
        full = max(_probe_speed(lm, blind, i, probe[i], speed) for i in range(6))
        assert got["probe_speed_ratio"] == pytest.approx(full, rel=0.02)
        assert full > plain + 0.3  # the probe's extra path is counted
        for i in range(6):
            assert _probe_speed(lm, blind, i, got["probe_scale"][i] * probe[i], speed) <= 1.01
            if got["probe_scale"][i] < 1.0:
                longer = min(got["probe_scale"][i] + 1.0 / 16.0, 1.0) * probe[i]
                assert _probe_speed(lm, blind, i, longer, speed) > 1.0
        # the front legs come in low (approach_lengths): 1.035× the limit in the tripod's 0.8 s swing, 1.24× in
        # the wave's 0.67 s; the other legs' probes fit in the tripod
        assert full > 1.0 and np.all(got["probe_scale"][[0, 3]] < 1.0)
        if gait == "tripod":
            assert full == pytest.approx(1.035, abs=0.01) and np.all(got["probe_scale"][[1, 2, 4, 5]] == 1.0)
        else:
            assert full == pytest.approx(1.24, abs=0.01)
