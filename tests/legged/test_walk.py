"""coop_ga.legged.walk: walking 1 m on flat ground and across steps with every gait, turning in place and
side-stepping, and the per-step checks (stability margin, limits, slip, torques, COM, hull).

Speed: the walks run at Δt ≈ 0.04 s (``DT``), coarser than the experiment's 0.02 s.  This is legitimate
for these assertions: the plan is kinematic (quasi-static), every lift-off and touch-down still falls on
a knot (Δt is rounded to the gait's grid), and the checks (margin, limits, slip, contact) are evaluated at
every knot, with the margin taken for the supports before and after each knot.  One walk per gait and
terrain is computed once per module (fixtures) and asserted on by several tests.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from coop_ga.errors import InvalidInputError
from coop_ga.legged.body import BodyState
from coop_ga.legged.gait import GAITS
from coop_ga.legged.legs import hexapod_legs
from coop_ga.legged.terrain import Terrain
from coop_ga.legged.walk import (
    WalkOptions,
    convex_hull,
    robot_com,
    robot_mass,
    static_stability_margin,
    static_torques,
    walk,
)

DT = 0.04


@pytest.fixture(scope="module")
def legs():
    return hexapod_legs()


@pytest.fixture(scope="module")
def walks(legs):
    """{(gait, terrain): WalkResult} of 1 m walks, computed once."""
    out = {}
    for gait in GAITS:
        for kind in ("flat", "steps"):
            out[gait, kind] = walk(Terrain.make(kind), WalkOptions(gait=gait, dt=DT), distance=1.0, legs=legs)
    return out


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
    H = convex_hull(sq)
    assert H.shape == (4, 2)


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
    # virtual work: τ·δq = f·δp for each stance leg (f = −m g / 3 ẑ)
    J = legs.jacobians(q).reshape(6, 3, 3)
    f = np.array([0.0, 0.0, -m * 9.81 / 3])
    for i in (0, 2, 4):
        np.testing.assert_allclose(tau[i], J[i].T @ f, atol=1e-12)
    # the coxa carries no load at a vertical force; femur and tibia do, below the 1.5 N·m stall torque
    assert np.all(np.abs(tau[[0, 2, 4], 0]) < 1e-12)
    assert 0.1 < np.max(np.abs(tau)) < 1.5


# ====================================================================== the 1 m walks
@pytest.mark.parametrize("kind", ["flat", "steps"])
@pytest.mark.parametrize("gait", GAITS)
def test_walk_one_metre(walks, gait, kind):
    r = walks[gait, kind]
    assert r.posture and r.posture_failures == 0  # the stance legs went through posture_step, every step
    # the walk stops at the first knot past 1 m: at most one step v Δt further
    assert 1.0 - 1e-9 <= r.distance <= 1.0 + r.options.command()[0] * r.dt + 1e-9
    assert abs(r.body[-1, 1]) < 1e-6  # straight ahead
    # positive static stability margin at every knot (the experiment's numbers: 85–125 mm)
    assert r.min_margin > 0.05
    # joint limits never violated (positions and the URDF's speed limit); no closed-form-IK fallback was needed
    assert r.max_limit_violation == 0.0
    assert r.max_velocity_violation == 0.0 and 0.3 < r.max_velocity_ratio < 1.0
    assert r.fallback_steps == 0
    # stance feet stay where they touched down; stance feet on the terrain; swing feet never below it
    assert r.max_slip < 1e-9
    assert r.contact_error.max() < 1e-9
    assert r.swing_clearance.min() > -1e-9
    # the posture step realises the reference (height along the normal, tilt)
    assert r.max_tracking_error[0] < 1e-6 and r.max_tracking_error[1] < 1e-5
    assert r.body_error.max() < 1e-6
    # static torques for equal load sharing stay below the stall torque
    assert 0.2 < r.max_torque_ratio < 0.8
    # gait structure: the table's number of stance legs
    assert r.stance.sum(axis=1).min() == {"tripod": 3, "ripple": 4, "wave": 5}[gait]
    assert r.q.shape == (len(r.t), 18) and r.body.shape == (len(r.t), 7) and r.stance.shape == (len(r.t), 6)
    np.testing.assert_allclose(np.linalg.norm(r.body[:, 3:], axis=1), 1.0, atol=1e-12)


@pytest.mark.parametrize("gait", GAITS)
def test_ride_height_follows_steps(walks, gait):
    """Across 4 steps of 0.03 m the body climbs with the support plane: it ends 0.12 m higher (the feet on
    the top tread), and it stays 0.1 m (ride height) above the support plane of the stance feet."""
    flat, steps = walks[gait, "flat"], walks[gait, "steps"]
    np.testing.assert_allclose(flat.body[:, 2], flat.body[0, 2], atol=1e-9)  # level on flat ground
    assert flat.body[0, 2] == pytest.approx(0.1, abs=1e-9)
    rise = steps.body[-1, 2] - steps.body[0, 2]
    assert 0.09 < rise < 0.125
    assert steps.ground_height[-1] == pytest.approx(0.12)
    # body origin = support plane + ride height along its normal (tilt ≤ a few degrees)
    gap = steps.body[:, 2] - steps.support_height
    assert np.all(np.abs(gap - 0.1) < 2e-3)
    # the stance primitive is a sphere when ≥ 4 feet span two treads (ripple, wave), else a plane
    kinds = set(steps.primitive_kind.tolist()) - {""}
    assert kinds == ({"plane"} if gait == "tripod" else {"plane", "sphere"})
    assert set(flat.primitive_kind.tolist()) - {""} == {"plane"}


def test_walk_is_deterministic(walks, legs):
    r = walk(Terrain.make("steps"), WalkOptions(gait="ripple", dt=DT), distance=1.0, legs=legs)
    ref = walks["ripple", "steps"]
    for name in ("t", "q", "body", "stance", "margin"):
        np.testing.assert_array_equal(getattr(r, name), getattr(ref, name))


def test_posture_matches_kinematic_baseline(legs):
    """The posture step (body twist and stance legs solved together through the stance primitive) moves the
    body onto the reference that the kinematic baseline (``use_posture=False``) sets directly."""
    terrain = Terrain.make("steps")
    a = walk(terrain, WalkOptions(gait="wave", dt=DT), distance=0.4, legs=legs)
    b = walk(terrain, WalkOptions(gait="wave", dt=DT, use_posture=False), distance=0.4, legs=legs)
    assert a.posture and not b.posture and b.notes
    assert "sphere" in set(a.primitive_kind.tolist()) and set(b.primitive_kind.tolist()) == {""}
    np.testing.assert_allclose(a.body[:, :3], b.body[:, :3], atol=1e-8)
    np.testing.assert_allclose(a.q, b.q, atol=1e-6)


def test_random_terrain_tripod(legs):
    r = walk(Terrain.make("random", seed=0), WalkOptions(gait="tripod", dt=DT), distance=0.6, legs=legs)
    assert 0.6 - 1e-9 <= r.distance <= 0.6 + r.options.command()[0] * r.dt + 1e-9
    assert r.min_margin > 0.05 and r.max_limit_violation == 0.0 and r.max_slip < 1e-9
    assert r.swing_clearance.min() > -1e-9 and r.contact_error.max() < 1e-9
    # footholds keep ≥ 1 cm (edge_clearance) from every tile border
    terrain = Terrain.make("random", seed=0)
    for k, edges in ((0, terrain.x_edges), (1, terrain.y_edges)):
        d = np.abs(r.feet[..., k][..., None] - edges).min(axis=-1)[r.stance]
        assert d.min() > 0.01 - 1e-9


# ====================================================================== velocity commands
@pytest.mark.parametrize("gait", GAITS)
def test_turn_in_place(legs, gait):
    """ω = 0.3 rad/s for 4 s with a smoothstep ramp over one cycle T: yaw = ω (4 − T/2), the body stays put."""
    opts = WalkOptions(gait=gait, speed=(0.0, 0.0, 0.3), dt=DT)
    r = walk(Terrain.flat(), opts, duration=4.0, legs=legs)
    T = opts.period
    yaw = r.state(len(r.t) - 1).rpy()[2]
    assert yaw == pytest.approx(0.3 * (r.t[-1] - T / 2), abs=1e-6)
    assert np.linalg.norm(r.body[-1, :2]) < 1e-6
    assert r.min_margin > 0.05 and r.max_limit_violation == 0.0 and r.max_slip < 1e-9


@pytest.mark.parametrize("gait", GAITS)
def test_sideways(legs, gait):
    """v_y = 0.05 m/s for 4 s: y = v_y (4 − T/2), no drift in x or heading."""
    opts = WalkOptions(gait=gait, speed=(0.0, 0.05, 0.0), dt=DT)
    r = walk(Terrain.flat(), opts, duration=4.0, legs=legs)
    T = opts.period
    assert r.body[-1, 1] == pytest.approx(0.05 * (r.t[-1] - T / 2), abs=1e-6)
    assert abs(r.body[-1, 0]) < 1e-6 and abs(r.state(len(r.t) - 1).rpy()[2]) < 1e-9
    assert r.min_margin > 0.05 and r.max_limit_violation == 0.0 and r.max_slip < 1e-9


def test_options_and_errors(legs):
    with pytest.raises(InvalidInputError):
        WalkOptions(gait="gallop")
    with pytest.raises(InvalidInputError):
        WalkOptions(tilt_follow=2.0)
    with pytest.raises(InvalidInputError, match="distance"):
        walk(Terrain.flat(), WalkOptions(speed=(0.0, 0.0, 0.3)), distance=1.0, legs=legs)
    with pytest.raises(InvalidInputError):
        walk(Terrain.flat(), WalkOptions(), legs=legs)
    o = WalkOptions(gait="wave")
    assert o.period == 4.0 and o.command() == pytest.approx([0.08 / (5 / 6 * 4.0), 0.0, 0.0])
