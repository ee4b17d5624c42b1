"""coop_ga.legged.gait: the phase-table generator (tripod / ripple / wave, any n ≥ 4) and the swing arc."""

from __future__ import annotations

import numpy as np
import pytest

from coop_ga.errors import CoopGAError, InvalidInputError
from coop_ga.legged.gait import GAITS, leg_names, phase_table, swing_arc

LEGS = ("lf", "lm", "lr", "rf", "rm", "rr")
DUTY6 = {"tripod": 1 / 2, "ripple": 2 / 3, "wave": 5 / 6}
SWINGING = {"tripod": lambda n: n // 2, "ripple": lambda n: 2, "wave": lambda n: 1}


def _cycle(table, samples=6000):
    # a fine grid that avoids the boundaries by half a sample
    return (np.arange(samples) + 0.5) * (table.period / samples)


@pytest.mark.parametrize("gait", GAITS)
def test_six_legs_duty_and_support(gait):
    tab = phase_table(gait)
    assert tab.legs == LEGS
    assert tab.duty == pytest.approx(DUTY6[gait], abs=1e-15)
    st = tab.stance(_cycle(tab))
    # every leg's stance fraction equals the duty factor
    np.testing.assert_allclose(st.mean(axis=0), DUTY6[gait], atol=1e-3)
    # at every phase at least 3 legs stand; exactly n·β of them for the textbook tables
    counts = st.sum(axis=1)
    assert counts.min() >= 3
    assert set(counts.tolist()) == {round(6 * DUTY6[gait])}
    assert tab.min_stance() == round(6 * DUTY6[gait])


def test_tripod_groups():
    tab = phase_table("tripod")
    off = dict(zip(tab.legs, tab.offsets))
    a, b = ("lf", "lr", "rm"), ("rf", "lm", "rr")
    assert {off[k] for k in a} == {0.0} and {off[k] for k in b} == {0.5}
    st = tab.stance(_cycle(tab))
    ia, ib = [LEGS.index(k) for k in a], [LEGS.index(k) for k in b]
    # each tripod moves as one, the two in antiphase
    assert np.all(st[:, ia] == st[:, [ia[0]]]) and np.all(st[:, ib] == ~st[:, [ia[0]]])


def test_ripple_and_wave_order():
    """Lift-off order: the metachronal wave rear → front on each side, the right side half a cycle later."""
    rip = phase_table("ripple")
    order = [rip.legs[i] for i in np.argsort(rip.offsets)]
    assert order == ["lr", "rf", "lm", "rr", "lf", "rm"]
    np.testing.assert_allclose(np.sort(rip.offsets), np.arange(6) / 6, atol=1e-15)
    wave = phase_table("wave")
    order = [wave.legs[i] for i in np.argsort(wave.offsets)]
    assert order == ["lr", "lm", "lf", "rr", "rm", "rf"]


@pytest.mark.parametrize("n", [4, 5, 6, 7, 8, 10])
@pytest.mark.parametrize("gait", GAITS)
def test_any_number_of_legs(gait, n):
    if gait == "tripod" and n % 2:
        with pytest.raises(InvalidInputError, match="even"):
            phase_table(gait, n)
        return
    tab = phase_table(gait, n)
    assert tab.n_legs == n and len(set(tab.legs)) == n
    st = tab.stance(_cycle(tab))
    np.testing.assert_allclose(st.mean(axis=0), tab.duty, atol=1e-3)
    # the gait's number of legs in the air at every phase
    assert set((n - st.sum(axis=1)).tolist()) == {SWINGING[gait](n)}
    if gait == "wave":
        assert tab.duty == pytest.approx(1 - 1 / n)
    if gait == "ripple":
        assert tab.duty == pytest.approx(1 - 2 / n)


def test_leg_names():
    assert leg_names(6) == LEGS
    assert leg_names(4) == ("lf", "lr", "rf", "rr")
    assert leg_names(5) == ("l0", "l1", "l2", "r0", "r1")


def test_custom_duty_and_period():
    tab = phase_table("tripod", duty=0.75, period=2.0)
    st = tab.stance(_cycle(tab))
    np.testing.assert_allclose(st.mean(axis=0), 0.75, atol=1e-3)
    assert tab.swing_time == pytest.approx(0.5)
    # a leg lifts off exactly at its offset: swing at u = 0, stance at u = σ
    i = tab.legs.index("lm")
    t_lift = tab.offsets[i] * tab.period
    assert not tab.stance(t_lift)[i]
    assert tab.stance(t_lift + tab.swing_time)[i]
    assert not tab.stance(t_lift + tab.swing_time - 1e-6)[i]
    # boundaries are exact even when t / T is not (3 · 0.1 s)
    tab2 = phase_table("wave", period=0.6)
    assert tab2.stance(np.arange(0, 61) * 0.01).shape == (61, 6)
    sw = tab2.swing_progress(0.3)
    assert np.isnan(sw).sum() == 5 and np.nanmin(sw) == pytest.approx(0.0)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"gait": "gallop"},
        {"gait": "wave", "n_legs": 3},
        {"gait": "wave", "n_legs": 6.0},
        {"gait": "wave", "duty": 1.0},
        {"gait": "wave", "duty": 0.0},
        {"gait": "wave", "period": -1.0},
    ],
)
def test_bad_input(kwargs):
    with pytest.raises(CoopGAError):
        phase_table(**kwargs)


def test_swing_arc_ends_and_c1():
    p0, p1, lift = np.array([0.1, 0.2, -0.01]), np.array([0.18, 0.25, 0.02]), 0.03
    s = np.linspace(0.0, 1.0, 20001)
    p, v = swing_arc(p0, p1, lift, s)
    np.testing.assert_allclose(p[0], p0, atol=1e-15)
    np.testing.assert_allclose(p[-1], p1, atol=1e-15)
    np.testing.assert_allclose(v[[0, -1]], 0.0, atol=1e-15)
    # v is the derivative of p (central differences) and continuous (no jumps between samples)
    ds = s[1] - s[0]
    fd = (p[2:] - p[:-2]) / (2 * ds)
    np.testing.assert_allclose(fd, v[1:-1], atol=1e-4)  # O(ds) at the kinks of p″
    assert np.abs(np.diff(v, axis=0)).max() < 1e-3
    # apex: lift above the higher end, at mid-swing; never below the lower end
    assert p[:, 2].max() == pytest.approx(max(p0[2], p1[2]) + lift, abs=1e-12)
    assert p[len(s) // 2, 2] == pytest.approx(p1[2] + lift, abs=1e-12)
    assert p[:, 2].min() >= min(p0[2], p1[2]) - 1e-15
    # horizontal progress is monotone and waits at both ends (pure lift-off / set-down)
    d = np.linalg.norm(p[:, :2] - p0[:2], axis=1)
    assert np.all(np.diff(d) >= -1e-15)
    early = s < 0.2
    np.testing.assert_allclose(p[early, :2], np.broadcast_to(p0[:2], (early.sum(), 2)), atol=1e-15)


def test_swing_arc_scalar_and_errors():
    p, v = swing_arc([0, 0, 0], [0.1, 0, 0], 0.02, 0.5)
    assert p.shape == (3,) and v.shape == (3,)
    np.testing.assert_allclose(p, [0.05, 0.0, 0.02], atol=1e-15)
    assert v[0] > 0 and v[2] == 0.0
    with pytest.raises(InvalidInputError):
        swing_arc([0, 0, 0], [0.1, 0, 0], -0.01, 0.5)
    with pytest.raises(InvalidInputError):
        swing_arc([0, 0, 0], [0.1, 0, 0], 0.01, 1.5)
    with pytest.raises(InvalidInputError):
        swing_arc([0, 0], [0.1, 0, 0], 0.01, 0.5)
