"""The pieces of holding that need no long simulation: the tool frames and pads, the carry plan, the target."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("mujoco")

import coop_ga as cg
from coop_ga.errors import InvalidInputError
from coop_ga.geometry.groups import Similarity
from coop_ga.sim import CarryPlan, HoldGains, add_pads, build_scene, circle_target, with_tool
from coop_ga.sim.hold import PHASES, min_jerk


@pytest.fixture(scope="module")
def tool_system():
    return with_tool(cg.systems.load("three_iiwa14"), 0.16)


def test_tool_frames_are_the_end_frames_moved_along_z(tool_system):
    import pinocchio as pin

    base = cg.systems.load("three_iiwa14")
    q = base.random_q(np.random.default_rng(3))
    d0, d1 = base.model.createData(), tool_system.model.createData()
    pin.framesForwardKinematics(base.model, d0, q)
    pin.framesForwardKinematics(tool_system.model, d1, q)
    for f0, f1 in zip(base.end_frames, tool_system.end_frames):
        M0, M1 = d0.oMf[base.model.getFrameId(f0)], d1.oMf[tool_system.model.getFrameId(f1)]
        np.testing.assert_allclose(M1.translation, M0.translation + 0.16 * M0.rotation[:, 2], atol=1e-14)
        np.testing.assert_allclose(M1.rotation, M0.rotation, atol=1e-14)
    assert tool_system.nq == base.nq and base.end_frames[0] + "_tool" == tool_system.end_frames[0]
    with pytest.raises(InvalidInputError):
        with_tool(base, 0.0)


def test_pads_are_massless_contact_geoms_at_the_end_points(tool_system):
    import mujoco

    scene = build_scene(tool_system, visuals=False)
    padded = add_pads(scene, 0.03, shaft_length=0.16, friction=0.7, margin=0.002, solref=(0.005, 1.0))
    m0, m1 = scene.model, padded.model
    assert m1.ngeom == m0.ngeom + 6 and m1.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC and m1.opt.impratio == 10.0
    d0, d1 = mujoco.MjData(m0), mujoco.MjData(m1)
    q = tool_system.random_q(np.random.default_rng(4))
    for s, d in ((scene, d0), (padded, d1)):
        s.set_q(d, q)
        mujoco.mj_forward(s.model, d)
    M0, M1 = np.zeros((m0.nv, m0.nv)), np.zeros((m1.nv, m1.nv))
    mujoco.mj_fullM(m0, d0, M0)
    mujoco.mj_fullM(m1, d1, M1)
    np.testing.assert_array_equal(M0, M1)  # no mass from the pads: the gate still holds
    for frame, sid in zip(tool_system.end_frames, padded.site_ids):
        g = padded.id_of("geom", f"{frame}_pad")
        np.testing.assert_allclose(d1.geom_xpos[g], d1.site_xpos[sid], atol=1e-14)  # centred on the end point
        assert m1.geom_friction[g][0] == 0.7 and m1.geom_margin[g] == 0.002 and m1.geom_condim[g] == 4
    with pytest.raises(InvalidInputError, match="condim"):
        add_pads(scene, condim=5)


def test_circle_target_is_the_exponential_of_translation_and_dilation():
    a = circle_target((0.1, -0.2, 0.4), 0.37).coeffs
    b = Similarity.exp([0.0, 0.0, 0.0, math.log(0.37), 0.1, -0.2, 0.4]).coeffs
    np.testing.assert_array_equal(a, b)


def _plan(**kw):
    base = dict(centre=(0, 0, 0.4), object_centre=(0, -0.01, 0.4), radius_touch=0.28, radius_open=0.31, squeeze=40.0)
    return CarryPlan(**(base | kw))


def test_plan_phases_and_profiles():
    plan = _plan(durations=(1, 1, 1, 1, 1, 1, 1, 1, 1), start=((0.0, 0.0, 0.43), 0.33))
    pt = plan.phase_times()
    assert list(pt) == list(PHASES) and pt["open"][1] == plan.duration == 9.0
    assert min_jerk(0.5) == 0.5 and min_jerk(-1) == 0.0 and min_jerk(2) == 1.0
    p0 = plan.at(0.0)
    assert p0.radius == pytest.approx(0.33) and np.allclose(p0.centre, (0, 0, 0.43)) and p0.phase == "approach"
    closed = plan.at(2.0 - 1e-9)  # end of the close phase: the touching radius minus the press
    assert closed.radius == pytest.approx(0.28 - plan.press) and closed.squeeze == 0.0 and closed.admittance is False
    assert plan.at(2.0).admittance is True  # the squeeze loop runs from the squeeze phase on
    squeezed = plan.at(3.0)
    assert squeezed.squeeze == pytest.approx(40.0) and squeezed.admittance and squeezed.estimate
    lifted = plan.at(4.0)
    assert lifted.centre[2] == pytest.approx(0.4 + plan.lift)
    carried = plan.at(5.0)  # turned about the object's centre, shifted
    assert carried.yaw == pytest.approx(plan.yaw)
    rel = np.array([0.0, 0.01, 0.0])
    turned = np.array([-math.sin(plan.yaw) * 0.01, math.cos(plan.yaw) * 0.01, 0.0])
    np.testing.assert_allclose(carried.centre, plan.object_centre + turned + plan.shift + [0, 0, plan.lift], atol=1e-12)
    assert np.linalg.norm(turned) == pytest.approx(np.linalg.norm(rel))
    landed = plan.at(7.0)
    assert landed.centre[2] == pytest.approx(0.4 - plan.lower_extra)
    released = plan.at(8.0)
    assert released.squeeze == pytest.approx(0.0) and released.estimate is False
    assert plan.at(9.0).radius == pytest.approx(0.31)


def test_bad_plans_and_gains():
    with pytest.raises(InvalidInputError, match="radius_open"):
        _plan(radius_open=0.2)
    with pytest.raises(InvalidInputError, match="durations"):
        _plan(durations=(1.0, 1.0))
    with pytest.raises(InvalidInputError, match="K must"):
        HoldGains(K=-np.ones(8))
    with pytest.raises(InvalidInputError):
        HoldGains(K_post=np.ones((2, 2)))
