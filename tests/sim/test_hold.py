"""Holding a box in MuJoCo with the e0∞ squeeze (coop_ga.sim.hold, coop_ga.sim.carry), short runs.

One run with the squeeze: approach, close, squeeze, lift 0.15 m, then hold still while a known force and
torque push the box (``xfrc_applied``); one run without the squeeze (the control case).  Asserted: the box
rises with the squeeze and not without it, the measured object wrench (from the end-point contact forces,
coop_ga.cooperative.wrench) balances gravity and the push within 5 %, the weight estimate, the squeeze
tracks its set-point, both logs replay in their model.xml with MuJoCo alone.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("mujoco")

from coop_ga.errors import CoopGAError
from coop_ga.sim import Disturbance, replay
from coop_ga.sim.carry import CarryCase, carry_setup, run_carry

#: approach, close, squeeze, lift, "carry" (no shift, no turn: a hold), hold, lower, release, open [s]
DURATIONS = (0.5, 0.3, 0.4, 0.7, 1.1, 0.2, 0.5, 0.3, 0.3)
LIFT_END, HOLD_END = 1.9, 3.0
PUSH_FORCE, PUSH_TORQUE, PUSH_START = np.array([3.0, -2.0, 4.0]), np.array([0.3, -0.2, 0.1]), 2.2
MASS = 2.0


@pytest.fixture(scope="module")
def held(tmp_path_factory):
    case = CarryCase("hold", mass=MASS, squeeze=40.0, durations=DURATIONS, shift=0.0, turn=0.0)
    push = Disturbance("box", force=PUSH_FORCE, torque=PUSH_TORQUE, start=PUSH_START)
    run = run_carry(case, duration=HOLD_END, disturbances=[push])
    folder = run.log.save(tmp_path_factory.mktemp("held"))
    return run, folder


@pytest.fixture(scope="module")
def loose(tmp_path_factory):
    case = CarryCase("loose", mass=MASS, squeeze=0.0, durations=DURATIONS, shift=0.0, turn=0.0)
    run = run_carry(case, duration=LIFT_END + 0.1)
    return run, run.log.save(tmp_path_factory.mktemp("loose"))


def _box(run):
    a = run.setup.scene.object_qpos["box"]
    return run.log.qpos[:, a : a + 3]


def test_the_squeeze_lifts_the_box_and_nothing_else_does(held, loose):
    run, _ = held
    rise = _box(run)[:, 2] - _box(run)[0, 2]
    t = run.log.time
    assert rise[np.searchsorted(t, PUSH_START)] >= 0.05  # lifted (0.15 m planned)
    lrun, _ = loose
    lrise = _box(lrun)[:, 2] - _box(lrun)[0, 2]
    assert np.max(lrise) < 0.01  # the pads touch its walls, nothing presses: it stays on the table
    # the control case really touched: the pads were at the box (the squeeze loop backed them off to ~0 N)
    tr = lrun.trace
    assert np.max(np.linalg.norm(tr["forces"], axis=2)) > 0.5
    held_s = run.trace["squeeze"][(run.trace["time"] > LIFT_END) & (run.trace["time"] < PUSH_START)]
    assert np.all(np.abs(held_s / 40.0 - 1.0) < 0.25)
    assert run.log.saturated_updates == 0 and lrun.log.saturated_updates == 0


def test_external_wrench_recovered_within_5_percent(held):
    """Settled under the push: the end points' wrench on the box (about the circle's centre c) balances
    gravity and the push, −(m g + f) and −((x_com − c) × (m g + f) + τ)."""
    run, _ = held
    tr = run.trace
    window = tr["time"] > HOLD_END - 0.2
    f = tr["object_force"][window].mean(axis=0)
    tq = tr["object_torque"][window].mean(axis=0)
    c = tr["centre"][window].mean(axis=0)
    com = _box(run)[: len(tr["time"])][window].mean(axis=0)
    g = np.asarray(run.setup.scene.model.opt.gravity)
    load = MASS * g + PUSH_FORCE
    f_exp = -load
    t_exp = -(np.cross(com - c, load) + PUSH_TORQUE)
    assert np.linalg.norm(f - f_exp) <= 0.05 * np.linalg.norm(f_exp)
    assert np.linalg.norm(tq - t_exp) <= 0.05 * np.linalg.norm(t_exp)
    # the weight estimate before the push approaches the box's mass (a 0.3 s low-pass started at the lift)
    i = np.searchsorted(tr["time"], PUSH_START) - 1
    assert tr["weight_estimate"][i] == pytest.approx(MASS, rel=0.15)


def test_logs_replay_with_mujoco_alone(held, loose):
    for _, folder in (held, loose):
        assert replay(folder) <= 1e-12
    import json

    assert json.loads((held[1] / "metrics.json").read_text())["object_body"] == "box"


def test_a_squeeze_beyond_the_capacity_is_refused_before_simulating():
    with pytest.raises(CoopGAError, match=r"exceeds .* capacity at the grasp"):
        carry_setup(CarryCase("too_hard", squeeze=5e4, durations=DURATIONS))
