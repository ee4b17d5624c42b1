"""The error contract of coop_ga.legged: bad arguments raise a CoopGAError naming them, work is bounded.

Regression tests: before these checks a walk with a coarse ``dt`` silently ran on another grid (and returned
NaN), a walk of 1e9 m or a gait diagram of 10¹² samples ran out of memory (MemoryError), a roll-out over a
10⁹ s plan never returned, ``BodyState.moved(dt=NaN)`` blamed ``BodyState.position``, options and
LegModel arguments of the wrong type gave AttributeErrors, and ``rpy_from_rotation`` read angles off any
3 × 3 matrix.
"""

from __future__ import annotations

import numpy as np
import pytest

from coop_ga.errors import InvalidInputError, NonFiniteError
from coop_ga.geometry.groups import Similarity
from coop_ga.legged import (
    BodyState,
    GaitTable,
    PostureOptions,
    RolloutOptions,
    Terrain,
    WalkOptions,
    contact_rollout,
    hexapod_legs,
    phase_table,
    posture_step,
    posture_to,
    static_torques,
    walk,
)
from coop_ga.legged.body import rpy_from_rotation
from coop_ga.legged.posture import body_motion_target, feet_field

NAN = float("nan")
TRIPOD = ["lf", "lr", "rm"]


@pytest.fixture(scope="module")
def legs():
    return hexapod_legs()


@pytest.fixture(scope="module")
def state(legs):
    return BodyState([0.0, 0.0, 0.1], np.eye(3), legs.q_stand)


def test_walk_refuses_a_dt_longer_than_its_phase_grid():
    """dt = 5 s on a 1.6 s tripod cycle was silently replaced by T/6 = 0.27 s."""
    with pytest.raises(InvalidInputError, match=r"dt = 5 s is longer than a sixth of the cycle \(T = 1\.6 s\)"):
        WalkOptions(dt=5.0)
    with pytest.raises(InvalidInputError, match="knots per cycle"):
        WalkOptions(dt=1e-12)
    assert WalkOptions(dt=0.2).dt == 0.2  # a dt up to T/6 is fine


def test_walk_work_is_bounded_and_its_arguments_checked(legs):
    flat = Terrain.flat()
    with pytest.raises(InvalidInputError, match=r"distance\) would take .* above 1000000"):
        walk(flat, distance=1e9)
    with pytest.raises(InvalidInputError, match=r"terrain must be a coop_ga\.legged\.Terrain"):
        walk("flat", duration=0.1)
    with pytest.raises(InvalidInputError, match=r"legs must be a coop_ga\.legged\.LegModel"):
        walk(flat, duration=0.1, legs="hexapod")
    with pytest.raises(InvalidInputError, match="use_posture"):
        WalkOptions(use_posture="no")
    with pytest.raises(InvalidInputError, match="duty"):
        WalkOptions(duty=1.5)


def test_gait_samples_and_table_fields_are_checked():
    tab = phase_table("tripod")
    for f in (tab.min_stance, tab.diagram):
        with pytest.raises(InvalidInputError, match="samples = 1000000000000 is above"):
            f(10**12)
    with pytest.raises(NonFiniteError, match="offsets"):
        GaitTable("tripod", ("a", "b"), [NAN, 0.5], 0.5)
    with pytest.raises(InvalidInputError, match="duty must be in"):
        GaitTable("tripod", ("a", "b"), [0.0, 0.5], 1.5)
    assert GaitTable("tripod", ("a", "b"), [0.0, 0.5], 0.5).min_stance() == 1


def test_terrain_sizes_are_bounded():
    with pytest.raises(InvalidInputError, match="n_steps"):
        Terrain.steps(n_steps=10**12)
    with pytest.raises(InvalidInputError, match="samples"):
        Terrain.flat().max_height([0, 0], [1, 0], 10**12)
    with pytest.raises(InvalidInputError, match=r"\bd\b must be a dict"):
        Terrain.from_arrays(5)


def test_body_state_arguments_are_named(state, legs):
    with pytest.raises(NonFiniteError, match=r"\bdt\b"):
        state.moved([0.1, 0.0, 0.0], [0.0, 0.0, 0.0], NAN)
    with pytest.raises(InvalidInputError, match=r"\bdt\b"):
        state.moved([0.1, 0.0, 0.0], [0.0, 0.0, 0.0], "0.1")
    with pytest.raises(NonFiniteError, match="points_B"):
        state.to_world([[NAN, 0.0, 0.0]])
    with pytest.raises(InvalidInputError, match="points_W"):
        state.to_body([[0.0, 0.0], [1.0, 1.0]])
    with pytest.raises(InvalidInputError, match=r"legs must be a coop_ga\.legged\.LegModel"):
        state.feet_world(None)
    with pytest.raises(InvalidInputError, match=r"\bR\b must be a rotation matrix"):
        rpy_from_rotation(np.diag([2.0, 1.0, 1.0]))
    np.testing.assert_allclose(rpy_from_rotation(state.rotation), 0.0, atol=1e-15)


def test_posture_arguments_are_checked(state, legs):
    with pytest.raises(InvalidInputError, match="options must be a PostureOptions"):
        posture_step(state, TRIPOD, np.zeros(7), options={"dt": 1})
    with pytest.raises(InvalidInputError, match=r"legs must be a coop_ga\.legged\.LegModel"):
        posture_step(state, TRIPOD, np.zeros(7), "hexapod")
    with pytest.raises(InvalidInputError, match="swing_q must be a dict"):
        posture_step(state, TRIPOD, np.zeros(7), swing_q=[0.0] * 3)
    with pytest.raises(NonFiniteError, match=r"swing_q\['lm'\]"):
        posture_step(state, TRIPOD, np.zeros(7), swing_q={"lm": [NAN, 0.0, 0.0]})
    with pytest.raises(InvalidInputError, match="state must be a BodyState"):
        posture_to(None, TRIPOD, Similarity.identity())
    with pytest.raises(InvalidInputError, match="options must be a PostureOptions"):
        posture_to(state, TRIPOD, Similarity.identity(), options=3)
    with pytest.raises(NonFiniteError, match="points_B"):
        feet_field(np.zeros(7), [[NAN, 0.0, 0.0]])
    with pytest.raises(InvalidInputError, match=r"\brotation\b must be a rotation matrix"):
        body_motion_target(Similarity.identity(), [0, 0, 0], np.diag([2.0, 1.0, 1.0]))
    with pytest.raises(InvalidInputError, match="state must be a BodyState"):
        static_torques(None, TRIPOD, legs, 2.0)
    with pytest.raises(InvalidInputError, match="limit_gain"):
        PostureOptions(limit_gain=2.0)


def _plan(legs, T=3):
    return (
        np.arange(T) * 0.01,
        np.tile(legs.q_stand, (T, 1)),
        np.tile([0.0, 0.0, 0.0993, 0.0, 0.0, 0.0, 1.0], (T, 1)),
        np.ones((T, 6), bool),
    )


def test_rollout_options_and_work_are_checked(legs):
    for kw, arg in (({"dt": 0.0}, "dt"), ({"baumgarte": (NAN, 1.0)}, "baumgarte"), ({"kp": -1.0}, "kp"),
                    ({"feedforward": "yes"}, "feedforward")):  # fmt: skip
        with pytest.raises(InvalidInputError, match=rf"RolloutOptions\.{arg}"):
            RolloutOptions(**kw)
    t, q, body, stance = _plan(legs)
    with pytest.raises(InvalidInputError, match=r"integration steps .* above 5000000"):
        contact_rollout([0.0, 1e9, 2e9], q, body, stance)
    with pytest.raises(InvalidInputError, match="integration steps"):
        contact_rollout(t, q, body, stance, RolloutOptions(dt=1e-12))
