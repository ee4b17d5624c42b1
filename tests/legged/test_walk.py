"""coop_ga.legged.walk: every gait on every terrain (the foot ball on the ground, every leg capsule off the terrain,
margin, limits, speeds, slip), the body through the stance plane against the kinematic baseline, turning and
side-stepping, commands refused before the run, and the per-step checks (stability margin, COM, hull, torques).

Speed: the walks run at Δt ≈ 0.08 s (``DT``) over 0.3 m (the experiment: 0.02 s over 1 m).  This is legitimate for
these assertions: the plan is kinematic (quasi-static), every lift-off and touch-down still falls on a knot (Δt is
rounded to the gait's grid), and the checks (margin, limits, slip, contact, capsule clearance) are evaluated at every
knot; the joint speeds are finite differences over Δt (coarser: lower peaks, so the experiment's 1 m walks at
0.02 s are the ones ``python -m paper_figures`` checks against the URDF limits).  One walk per gait and terrain is
computed once per module and asserted on by several tests.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from coop_ga.errors import InvalidInputError
from coop_ga.legged.body import BodyState
from coop_ga.legged.gait import GAITS
from coop_ga.legged.legs import hexapod_legs
from coop_ga.legged.terrain import TERRAIN_KINDS, Terrain
from coop_ga.legged.walk import (
    WalkOptions,
    check_command,
    convex_hull,
    robot_com,
    robot_mass,
    static_stability_margin,
    static_torques,
    walk,
)

DT = 0.08
DIST = 0.3
R_FOOT = 0.009
STEPS_NEAR = Terrain.steps(start_x=0.05, n_steps=2)  # the rear legs cross the first riser within 0.3 m


@pytest.fixture(scope="module")
def legs():
    return hexapod_legs()


@pytest.fixture(scope="module")
def walks(legs):
    """{(gait, terrain): WalkResult} of 0.3 m walks, computed once."""
    return {
        (gait, kind): walk(Terrain.make(kind), WalkOptions(gait=gait, dt=DT), distance=DIST, legs=legs)
        for gait in GAITS
        for kind in TERRAIN_KINDS
    }


# ====================================================================== static stability, COM, torques
def test_stability_margin_square():
    sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.5, 0.5]])  # an interior point too
    assert static_stability_margin([0.5, 0.5], sq) == pytest.approx(0.5)
    assert static_stability_margin([0.2, 0.5], sq) == pytest.approx(0.2)
    assert static_stability_margin([1.3, 0.5], sq) == pytest.approx(-0.3)
    assert static_stability_margin([1.3, 1.4], sq) == pytest.approx(-0.5)  # distance to the corner
    # fewer than 3 non-collinear feet span no area: never positive
    assert static_stability_margin([0.5, 0.0], sq[:2]) == pytest.approx(0.0)
    assert static_stability_margin([0.5, 0.2], sq[:2]) == pytest.approx(-0.2)
    assert static_stability_margin([0.0, 0.0], np.zeros((0, 2))) == -math.inf
    with pytest.raises(InvalidInputError):
        static_stability_margin([0.0, 0.0], np.zeros((3, 3)))
    assert convex_hull(sq).shape == (4, 2)


def test_com_and_torques(legs):
    q = legs.q_stand
    assert robot_mass(legs) == pytest.approx(1.8728, abs=1e-4)
    com = robot_com(q, legs)
    np.testing.assert_allclose(com[:2], 0.0, atol=1e-12)  # symmetric stand
    assert -0.01 < com[2] < 0.0
    state = BodyState(np.zeros(3), np.eye(3), q)
    m = robot_mass(legs)
    tau = static_torques(state, ("lf", "lr", "rm"), legs, m)
    assert np.all(tau[[1, 3, 5]] == 0.0)
    J = legs.jacobians(q).reshape(6, 3, 3)  # virtual work: τ·δq = f·δp for each stance leg (f = −m g / 3 ẑ)
    f = np.array([0.0, 0.0, -m * 9.81 / 3])
    for i in (0, 2, 4):
        np.testing.assert_allclose(tau[i], J[i].T @ f, atol=1e-12)
    assert np.all(np.abs(tau[[0, 2, 4], 0]) < 1e-12)
    assert 0.1 < np.max(np.abs(tau)) < 1.5


# ====================================================================== every gait × terrain
@pytest.mark.parametrize("kind", TERRAIN_KINDS)
@pytest.mark.parametrize("gait", GAITS)
def test_every_gait_on_every_terrain(walks, gait, kind):
    r = walks[gait, kind]
    assert r.posture and r.posture_failures == 0 and r.fallback_steps == 0
    # (the posture loop's tilt corrections move the body origin by < 1 mm horizontally on uneven ground)
    assert DIST - 1e-3 <= r.distance <= DIST + r.options.command()[0] * r.dt + 1e-3
    assert r.min_margin > 0.05
    assert r.max_limit_violation == 0.0 and r.max_velocity_violation == 0.0 and r.max_velocity_ratio < 1.0
    # the foot balls rest on the terrain (their centres one radius above it), stay put (rolling, no sliding)
    assert r.contact_error.max() < 1e-9 and r.max_slip < 1e-9
    assert r.swing_clearance.min() > -1e-9
    assert 0.5e-3 < r.max_rolling < 6e-3
    # every leg capsule (coxa, femur, shin) stays off the terrain, not only the foot point
    assert r.min_segment_clearance >= 0.0, (gait, kind, r.min_segment_clearance)
    # the contact point is where the ball touches: one radius below its centre along the terrain normal
    n = np.asarray(Terrain.make(kind).normal(r.feet[..., :2]))
    np.testing.assert_allclose(r.contacts, r.feet - R_FOOT * n, atol=1e-15)
    # the body rides on the stance plane (its height and attitude through the stance primitive)
    assert set(r.primitive_kind[1:].tolist()) == {"plane"}
    assert 0.2 < r.max_torque_ratio < 0.8
    assert r.stance.sum(axis=1).min() == {"tripod": 3, "ripple": 4, "wave": 5}[gait]
    assert r.q.shape == (len(r.t), 18) and r.body.shape == (len(r.t), 7) and r.segment_clearance.shape == (len(r.t), 6)
    np.testing.assert_allclose(np.linalg.norm(r.body[:, 3:], axis=1), 1.0, atol=1e-12)
    if kind in ("flat", "slope"):  # a single plane: the body rides exactly on it
        assert r.max_tracking_error[0] < 1e-9 and r.max_tracking_error[1] < 1e-9


def test_ball_contact_on_flat_ground(walks):
    """The planner puts the ball centres a radius above the ground, the contact points on it; the body rides at
    0.109 m (the ball centres 0.1 m below it)."""
    r = walks["tripod", "flat"]
    st = r.stance
    np.testing.assert_allclose(r.feet[..., 2][st], R_FOOT, atol=1e-12)
    np.testing.assert_allclose(r.contacts[..., 2][st], 0.0, atol=1e-12)
    np.testing.assert_allclose(r.body[:, 2], 0.109, atol=1e-9)


@pytest.fixture(scope="module")
def ripple_steps(legs):
    """0.3 m of ripple over two risers starting 5 cm ahead of the body (every leg crosses the first): the default
    planner, and with footholds and arcs for the foot ball alone (no capsule check, the former planner)."""
    steps = STEPS_NEAR
    return (
        walk(steps, WalkOptions(gait="ripple", dt=DT), distance=DIST, legs=legs),
        walk(steps, WalkOptions(gait="ripple", dt=DT, clearance_margin=None), distance=DIST, legs=legs),
    )


def test_shins_clear_the_steps(ripple_steps):
    """Regression: the plan checked the foot point only, and the shins cut into the first step (14.7 mm with the
    old point foot).  Without the capsule check a rear shin still cuts the step; the default planner moves those
    footholds (by a few cm) and keeps every capsule off it."""
    r, foot_only = ripple_steps
    assert foot_only.min_segment_clearance < -0.003 and foot_only.foothold_shifts == 0
    i = int(np.argmin(foot_only.segment_clearance.min(axis=0)))
    assert i in (2, 5)  # a rear leg (lr, rr): its shin leans forward over the riser behind its foot
    assert r.min_segment_clearance >= 0.0 and r.foothold_shifts >= 1 and 0.0 < r.max_foothold_shift <= 0.07


def test_ride_height_follows_steps(walks):
    r = walks["wave", "steps"]
    # the body origin stays ride height above the stance plane along its normal, to the posture loop's lag
    gap = r.body[:, 2] - r.support_height
    assert np.all(np.abs(gap - 0.109) < 0.02)
    assert r.body[-1, 2] - r.body[0, 2] > 0.02


def test_posture_changes_the_plan(legs, ripple_steps):
    """The body's height and attitude come from the stance plane's error (closed loop, gain 8 /s) with
    use_posture=True and from the low-pass filtered support plane (0.25 s) without: on steps the joint trajectories
    differ, and the body stays closer to the stance reference (smaller RMS height and tilt deviation)."""
    a = ripple_steps[0]
    b = walk(STEPS_NEAR, WalkOptions(gait="ripple", dt=DT, use_posture=False), distance=DIST, legs=legs)
    assert a.posture and not b.posture and b.notes
    assert np.abs(a.q - b.q).max() > 0.02
    rms = [np.sqrt(np.mean(x.tracking_error**2, axis=0)) for x in (a, b)]
    assert rms[0][0] < 0.8 * rms[1][0] and rms[0][1] < 0.8 * rms[1][1]
    for x in (a, b):
        assert x.min_segment_clearance >= 0.0 and x.max_velocity_violation == 0.0 and x.min_margin > 0.05
    flat_a = walk(Terrain.flat(), WalkOptions(gait="ripple", dt=DT), distance=0.15, legs=legs)
    flat_b = walk(Terrain.flat(), WalkOptions(gait="ripple", dt=DT, use_posture=False), distance=0.15, legs=legs)
    np.testing.assert_allclose(flat_a.q, flat_b.q, atol=1e-8)  # on flat ground both are exact


def test_rolling_balls(legs):
    """Held centres (rolling=False): the ball must slide by r |Δθ_⊥| per stance (the error of a fixed-contact plan);
    with rolling the centres move by exactly that and nothing slides."""
    held = walk(Terrain.flat(), WalkOptions(dt=DT, rolling=False), distance=0.2, legs=legs)
    rolled = walk(Terrain.flat(), WalkOptions(dt=DT), distance=0.2, legs=legs)
    assert held.max_slip < 1e-12 and rolled.max_slip < 1e-9
    assert 1e-3 < held.max_rolling < 6e-3
    # with rolling the stance centres drift by the rolled distance (they are not held)
    moved = max(
        float(np.linalg.norm(rolled.feet[k, i] - rolled.feet[k0, i]))
        for i in range(6)
        for k0, k in _stances(rolled.stance[:, i])
    )
    assert moved == pytest.approx(rolled.max_rolling, rel=0.2)


def _stances(col: np.ndarray) -> list[tuple[int, int]]:
    out, k0 = [], None
    for k, on in enumerate(col):
        if on and k0 is None:
            k0 = k
        if not on and k0 is not None:
            out.append((k0, k - 1))
            k0 = None
    return out


def test_walk_is_deterministic(walks, legs):
    r = walk(Terrain.make("random"), WalkOptions(gait="tripod", dt=DT), distance=DIST, legs=legs)
    ref = walks["tripod", "random"]
    for name in ("t", "q", "body", "stance", "margin", "segment_clearance"):
        np.testing.assert_array_equal(getattr(r, name), getattr(ref, name))


# ====================================================================== velocity commands
@pytest.mark.parametrize(("gait", "yaw_rate"), [("tripod", 0.3), ("ripple", 0.3), ("wave", 0.1)])
def test_turn_in_place(legs, gait, yaw_rate):
    """A turn in place with a smoothstep ramp over one cycle T: yaw = ω (t − T/2), the body stays put."""
    opts = WalkOptions(gait=gait, speed=(0.0, 0.0, yaw_rate), dt=DT)
    r = walk(Terrain.flat(), opts, duration=opts.period + 1.0, legs=legs)
    yaw = r.state(len(r.t) - 1).rpy()[2]
    assert yaw == pytest.approx(yaw_rate * (r.t[-1] - opts.period / 2), abs=1e-6)
    assert np.linalg.norm(r.body[-1, :2]) < 1e-6
    assert r.min_margin > 0.05 and r.max_limit_violation == 0.0 and r.max_velocity_violation == 0.0
    assert r.max_slip < 1e-9 and r.min_segment_clearance >= 0.0


def test_sideways(legs):
    opts = WalkOptions(gait="ripple", speed=(0.0, 0.05, 0.0), dt=DT)
    r = walk(Terrain.flat(), opts, duration=4.0, legs=legs)
    assert r.body[-1, 1] == pytest.approx(0.05 * (r.t[-1] - opts.period / 2), abs=1e-6)
    assert abs(r.body[-1, 0]) < 1e-6 and abs(r.state(len(r.t) - 1).rpy()[2]) < 1e-9
    assert r.min_margin > 0.05 and r.max_limit_violation == 0.0 and r.max_slip < 1e-9


def test_commands_beyond_the_legs_are_refused_before_the_run(legs):
    with pytest.raises(InvalidInputError, match=r"\[0\.3, 0\.0, 0\.0\] .* beyond the legs' reach"):
        walk(Terrain.flat(), WalkOptions(speed=(0.3, 0.0, 0.0)), distance=1.0, legs=legs)
    with pytest.raises(InvalidInputError, match=r"needs \w+_joint to turn at .* beyond its URDF speed limit 6\.18"):
        walk(Terrain.flat(), WalkOptions(gait="wave", speed=(0.0, 0.0, 0.3)), duration=1.0, legs=legs)
    with pytest.raises(InvalidInputError, match="lengthen cycle_time"):
        check_command(WalkOptions(cycle_time=0.9), legs)
    ok = check_command(WalkOptions(gait="ripple"), legs)
    assert ok["reach_margin_m"] > 0.01 and 0.3 < ok["velocity_ratio"] < 1.0


def test_options_and_errors(legs):
    with pytest.raises(InvalidInputError, match="gait"):
        WalkOptions(gait="gallop")
    with pytest.raises(InvalidInputError, match="terrain kind"):
        Terrain.make("mud")
    with pytest.raises(InvalidInputError):
        WalkOptions(tilt_follow=2.0)
    with pytest.raises(InvalidInputError, match="rolling"):
        WalkOptions(rolling=1)
    with pytest.raises(InvalidInputError, match="distance"):
        walk(Terrain.flat(), WalkOptions(speed=(0.0, 0.0, 0.1)), distance=1.0, legs=legs)
    with pytest.raises(InvalidInputError):
        walk(Terrain.flat(), WalkOptions(), legs=legs)
    o = WalkOptions(gait="wave")
    assert o.period == 4.0 and o.command() == pytest.approx([0.08 / (5 / 6 * 4.0), 0.0, 0.0])
