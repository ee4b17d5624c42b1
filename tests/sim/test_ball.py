"""coop_ga.sim.ball: the ball plan's profiles, the sphere controller's direction rows against finite differences,
and bad input refused before simulating (the whole run is checked by tests/experiments/test_sim_ball_hold.py)."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("mujoco")

from coop_ga.errors import CoopGAError, InvalidInputError


@pytest.fixture(scope="module")
def setup():
    from coop_ga.sim.ball import FAST_DURATIONS, BallCase, ball_setup

    return ball_setup(BallCase(durations=FAST_DURATIONS))


def test_plan_profiles(setup):
    plan = setup.plan
    pt = plan.phase_times()
    assert plan.duration == pytest.approx(3.6) and list(pt) == [
        "close",
        "squeeze",
        "move",
        "settle",
        "tighten",
        "loosen",
        "dilate",
        "undilate",
        "disturb",
    ]
    start, squeezed = plan.at(0.0), plan.at(pt["squeeze"][1])
    assert start.radius == pytest.approx(plan.radius_open) and start.squeeze == 0.0 and not start.admittance
    assert squeezed.radius == pytest.approx(plan.radius_touch - plan.press) and squeezed.squeeze == pytest.approx(4.0)
    np.testing.assert_allclose(plan.at(pt["settle"][0]).centre - plan.centre, plan.move, atol=1e-15)
    assert np.linalg.norm(plan.move) == pytest.approx(0.03) and plan.move[2] > 0.015  # 3 cm, up off the pedestal
    assert plan.at(pt["tighten"][1]).squeeze == pytest.approx(8.0)  # tightened …
    assert plan.at(pt["loosen"][1]).squeeze == pytest.approx(4.0)  # … and loosened by the e0∞ set-point
    dilated = plan.at(pt["dilate"][1])  # Fig. 21's command: the sphere smaller, the squeeze loop paused
    assert dilated.radius == pytest.approx(squeezed.radius - plan.dilation) and not dilated.admittance
    assert dilated.squeeze == pytest.approx(4.0) and plan.at(pt["undilate"][1]).radius == pytest.approx(squeezed.radius)
    pushes = plan.push_windows()
    assert [p[0] for p in pushes] == ["+x", "-x", "+y", "-y", "+z", "-z"]
    assert pushes[0][2] == pytest.approx(pt["disturb"][0]) and pushes[-1][3] < pt["disturb"][1]
    # the ball's radius: the grasp sphere's minus the pad; it starts on the pedestal, the tips 8 mm out
    assert setup.ball_radius == pytest.approx(plan.radius_touch - 0.012)


def test_direction_rows_against_finite_differences(setup):
    """J_i = B_i (I − u uᵀ)(J_pi − J_c) / ρ_i is the derivative of −e_i = B_i u_i (u_i: the tip's direction from
    the sphere's centre c), with ċ = r R b_t (R = 1: a sphere's similarity has no rotation)."""
    ctl, task = setup.controller, setup.task
    rng = np.random.default_rng(3)
    q = setup.q_grasp + 0.05 * rng.standard_normal(task.nq)

    def rows(q):
        st = task.evaluate(q)
        ctl._centre = np.array(st.log[4:7])
        r = float(np.exp(st.log[3]))
        assert np.allclose(st.log[:3], 0.0)
        Js, _ = ctl._frame_jacobians(q)
        return ctl._direction_rows(st.points, [J[:3] for J in Js], r * st.jacobian[4:7])

    J, _ = rows(q)
    h = 1e-6
    fd = np.column_stack([-(rows(q + h * d)[1] - rows(q - h * d)[1]) / (2 * h) for d in np.eye(task.nq)])
    np.testing.assert_allclose(J, fd, atol=2e-6 * np.abs(fd).max())
    assert J.shape == (8, 16) and np.linalg.matrix_rank(np.vstack([task.evaluate(q).jacobian[3:7], J])) == 12


def test_bad_input_is_refused_before_simulating(setup):
    from coop_ga.sim import HoldController
    from coop_ga.sim.ball import BallCase, BallPlan, ball_setup

    cap = setup.controller.capacity["squeeze_max"]
    assert 100.0 < cap < 300.0  # the URDF's 15 N m per joint (a real Allegro gives ~0.7 N m)
    with pytest.raises(CoopGAError, match="squeeze set-point 400 N exceeds"):
        ball_setup(BallCase(tighten=400.0))  # the tightened set-point beyond the hand's capacity
    with pytest.raises(InvalidInputError, match="needs a circle task, got a sphere task"):
        HoldController(setup.scene, setup.task, setup.plan)
    with pytest.raises(InvalidInputError, match="directions must be"):
        BallPlan(setup.plan.centre, 0.04, 0.05, 4.0, 8.0, directions=np.ones((4, 3)))
    with pytest.raises(InvalidInputError, match="radius_open"):
        BallPlan(setup.plan.centre, 0.05, 0.04, 4.0, 8.0, directions=setup.plan.directions)
