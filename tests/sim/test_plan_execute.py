"""coop_ga.sim.plan_execute: the pieces that join a plan to the hold controller (no long simulation here; the runs
are checked in tests/experiments/test_sim_plan_box_lift.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("mujoco")

from coop_ga.errors import InvalidInputError


@pytest.fixture(scope="module")
def setup():
    from coop_ga.sim.plan_execute import execution_setup

    return execution_setup()


def test_the_shelf_is_the_same_obstacle_for_the_planner_and_mujoco(setup):
    """One description: the planner's spheres and MuJoCo's static geoms have the same centres and radii, the lip
    reaches 5 cm over the box's +y edge and its underside is 6 cm above the box's top."""
    from coop_ga.sim.plan_execute import SHELF_ABOVE_BOX

    st, shelf = setup
    m = st.scene.model
    for sph, ob in zip(shelf.spheres(), shelf.objects(), strict=True):
        g = st.scene.id_of("geom", f"{ob.name}_geom")
        np.testing.assert_array_equal(m.geom_pos[g] + m.body_pos[m.geom_bodyid[g]], sph.center)
        assert m.geom_size[g][0] == sph.radius == 0.04
        assert m.body_dofnum[m.geom_bodyid[g]] == 0  # static: no joint, nothing welded
    top = st.box_centre[2] + 0.1
    assert np.all(shelf.centres[:, 2] - shelf.radius == pytest.approx(top + SHELF_ABOVE_BOX - 0.04))
    reach = st.box_centre[1] + st.box_half - (shelf.centres[:, 1] - shelf.radius)
    assert np.allclose(reach, 0.05)
    assert m.opt.gravity[2] < 0 and m.neq == 0  # gravity on, no equality constraints


def test_with_static_refuses_free_objects(setup):
    from coop_ga.sim.objects import Box
    from coop_ga.sim.plan_execute import with_static

    with pytest.raises(InvalidInputError, match="static objects only"):
        with_static(setup[0].scene, [Box(name="loose", size=(0.1, 0.1, 0.1))])


def test_the_plan_is_the_carry_before_the_follow_phase_and_the_path_after(setup):
    from coop_ga.sim.plan_execute import PathCarryPlan, PathReference

    st, _ = setup
    q0 = st.q_grasp
    t = np.linspace(0.0, 1.0, 11)
    Q = q0 + np.outer(t, np.full(q0.size, 0.01))
    ref = PathReference.from_path(st.task, t, Q)
    assert ref.shift[0] == pytest.approx(np.zeros(3)) and ref.yaw[0] == 0.0
    np.testing.assert_allclose(ref.turn[0], np.eye(3), atol=1e-12)
    p = PathCarryPlan.make(st.plan, ref, hold=0.5)
    t0 = p.follow_start
    assert p.phase_times()["hold"] == pytest.approx((t0 + 1.0, t0 + 1.5))
    base = st.plan  # before the follow phase: the carry's own plan point
    for tk in (0.3, 1.2, t0 - 1e-3):
        a, b = p.at(tk), base.at(tk)
        np.testing.assert_array_equal(a.centre, b.centre)
        assert (a.radius, a.yaw, a.phase) == (b.radius, b.yaw, b.phase)
    q, shift, _, _ = p.sample(t0 + 0.25)  # halfway between samples 2 and 3: linear
    np.testing.assert_allclose(shift, 0.5 * (ref.shift[2] + ref.shift[3]), rtol=0, atol=1e-15)
    np.testing.assert_allclose(q, 0.5 * (Q[2] + Q[3]), rtol=0, atol=1e-15)
    after = p.at(t0 + 1.2)
    assert after.phase == "hold" and after.squeeze == st.plan.squeeze and after.admittance and after.estimate
    np.testing.assert_allclose(after.centre - p.at(t0).centre, ref.shift[-1], atol=1e-12)
    assert p.sample(0.5) is None


def test_the_lift_off_is_straight_and_rigid(setup):
    from coop_ga.sim.plan_execute import LIFT_OFF, Grasp, lift_off

    st, shelf = setup
    g = Grasp(st, shelf, st.q_grasp, np.eye(3), st.box_centre, 0.0)
    up = lift_off(g)
    P = np.array([st.task.points(q) for q in up])
    d = P - P[0]
    assert np.abs(d[:, :, :2]).max() < 1e-8  # straight up
    np.testing.assert_allclose(d[-1, :, 2], LIFT_OFF, atol=1e-8)
    assert math.isclose(np.max(np.diff(d[:, 0, 2])), 0.005, abs_tol=1e-8)
