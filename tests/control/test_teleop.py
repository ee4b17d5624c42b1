"""Teleoperation (§4.5, Fig. 20–21): axis mapping, dilation opens/closes, scripted input."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import coop_ga as cg
from coop_ga.control.teleop import (
    KEY_BINDINGS,
    ScriptedInput,
    Teleoperator,
    command_to_bivector,
    run_interactive,
)
from coop_ga.viz import skeleton


def _load(name):
    return cg.systems.load(name)


def test_axis_mapping():
    g = dict(translation_gain=0.1, rotation_gain=0.5, dilation_gain=2.0)
    np.testing.assert_allclose(command_to_bivector([1, 0, 0, 0, 0, 0], **g), [0, 0, 0, 0, 0.1, 0, 0])
    np.testing.assert_allclose(command_to_bivector([0, 1, 0, 0, 0, 0], **g), [0, 0, 0, 0, 0, 0.1, 0])
    np.testing.assert_allclose(command_to_bivector([0, 0, 1, 0, 0, 0], **g), [0, 0, 0, 0, 0, 0, 0.1])
    np.testing.assert_allclose(command_to_bivector([0, 0, 0, 1, 0, 0], **g), [0, 0, 0.5, 0, 0, 0, 0])
    np.testing.assert_allclose(command_to_bivector([0, 0, 0, 0, 1, 0], **g), [0, -0.5, 0, 0, 0, 0, 0])
    np.testing.assert_allclose(command_to_bivector([0, 0, 0, 0, 0, 1], **g), [0, 0, 0, 2.0, 0, 0, 0])
    np.testing.assert_allclose(
        command_to_bivector([0, 0, 0, 0, 0, 1], rz_mode="rotation", **g), [0.5, 0, 0, 0, 0, 0, 0]
    )
    with pytest.raises(cg.InvalidInputError):
        command_to_bivector([1, 2, 3])
    with pytest.raises(cg.InvalidInputError):
        command_to_bivector(np.zeros(6), rz_mode="scale")


def test_rotation_signs_are_right_handed():
    """The rx / ry axes rotate right-handedly about +x / +y (checked on a point)."""
    p = np.array([0.0, 0.0, 1.0])
    for cmd, expected in [
        ([0, 0, 0, 1, 0, 0], np.array([0, -1.0, 0])),  # +x: z → −y
        ([0, 0, 0, 0, 1, 0], np.array([1.0, 0, 0])),
    ]:  # +y: z → +x
        b = command_to_bivector(cmd, rotation_gain=1e-3)
        moved = cg.to_euclidean(cg.geometry.apply(cg.geometry.exp(b), cg.point(p)))
        d = (np.asarray(moved, float) - p) / 1e-3
        np.testing.assert_allclose(d, expected, atol=1e-3)


@pytest.mark.parametrize("name,kind", [("allegro", "sphere"), ("three_franka", "circle")])
@pytest.mark.parametrize("beta", [-1.0, -0.3, 0.5, 1.0])
def test_pure_dilation_scales_radius(name, kind, beta):
    """One step of β e0∞ with Δt = 0.01 scales the radius by e^{βΔt} to first order; the centre stays."""
    s = _load(name)
    t = cg.cooperative_task(s, kind)
    dt = 0.01
    X0 = t.primitive(s.q0)
    r0, c0 = cg.radius(X0), np.asarray(cg.center(X0), float)
    tel = Teleoperator(t, s.q0, dt=dt, limit_mode="none")
    tel.step([0, 0, 0, 0, 0, beta])
    X1 = t.primitive(tel.q)
    r1, c1 = cg.radius(X1), np.asarray(cg.center(X1), float)
    expected = np.exp(beta * dt)
    # relative error of the radius change (stricter than of the ratio) < 1 %
    assert abs(r1 / r0 - expected) < 0.01 * abs(expected - 1.0)
    assert np.linalg.norm(c1 - c0) < 0.02 * abs(r1 - r0)
    print(name, beta, "radius ratio", r1 / r0, "expected", expected)


def test_fig21_close_and_open():
    """Fig. 21: −e0∞ closes and +e0∞ opens the hand (radius shrinks / grows)."""
    s = _load("allegro")
    t = cg.cooperative_task(s, "sphere")
    r0 = cg.radius(t.primitive(s.q0))
    radii = {}
    for beta in (-1.0, 1.0):
        tel = Teleoperator(t, s.q0, dt=0.25)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", cg.DegeneracyWarning)
            tel.step([0, 0, 0, 0, 0, beta])
        radii[beta] = cg.radius(t.primitive(tel.q))
    # one first-order step of 0.25: radius ≈ (1 ∓ 0.25) r0 where the joints allow it
    assert radii[-1.0] < 0.9 * r0
    assert radii[1.0] > 1.1 * r0


def test_teleoperation_respects_the_joint_limits():
    """Closing the Allegro hand for 2 s (β = −1 /s): with the default limit_mode='enforce' every
    configuration stays inside the position limits and every step inside the velocity limits;
    without limits the fingers pass through them."""
    s = _load("allegro")
    t = cg.cooperative_task(s, "sphere")
    lim = s.limits
    runs = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", cg.DegeneracyWarning)
        for mode in ("enforce", "none"):
            tel = Teleoperator(t, s.q0, dt=0.01, limit_mode=mode)
            try:
                tel.run(ScriptedInput([(2.0, [0, 0, 0, 0, 0, -1])], dt=0.01))
            except cg.DegeneratePrimitiveError:
                pass
            runs[mode] = np.array(tel.log.q)
    Q = runs["enforce"]
    assert tel.limit_mode == "none" and Teleoperator(t, s.q0).limit_mode == "enforce"
    assert Q.shape[0] == 201 and lim.position_violation(Q) == 0.0
    assert lim.velocity_violation(np.diff(Q, axis=0) / 0.01) <= 1e-9
    assert lim.position_violation(runs["none"]) > 0.01
    assert cg.radius(t.primitive(Q[-1])) < 0.9 * cg.radius(t.primitive(s.q0))  # the hand did close


def test_scripted_input_and_log():
    s = cg.systems.load("three_franka")
    t = cg.cooperative_task(s, "circle")
    script = ScriptedInput([(0.05, [1, 0, 0, 0, 0, 0]), (0.03, [0, 0, 0, 0, 0, -1])], dt=0.01)
    assert len(script) == 8
    # the mapping, not the robot: without the acceleration limits the commanded motion is realised at once
    tel = Teleoperator(t, s.q0, dt=0.01, translation_gain=0.1, acceleration_limit=False)
    c0 = np.asarray(cg.center(t.primitive(s.q0)), float)
    tel.run(script)
    log = tel.log.arrays()
    assert log["q"].shape == (9, s.nq) and log["commands"].shape == (8, 6) and log["bivectors"].shape == (8, 7)
    assert log["t"][-1] == pytest.approx(0.08)
    # 0.05 s at 0.1 /s along the circle frame's x axis: the body frame is scaled by the
    # radius r0 (V_Sc contains the dilation), so the centre moves by 0.005 · r0 in the world
    r0 = cg.radius(t.primitive(s.q0))
    c1 = np.asarray(cg.center(t.primitive(tel.q)), float)
    assert np.linalg.norm(c1 - c0) == pytest.approx(0.005 * r0, rel=0.05)
    with pytest.raises(cg.InvalidInputError):
        ScriptedInput([(1.0, [0, 0, 0])])


def test_headless_falls_back_to_script(monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    s = cg.systems.load("three_franka")
    t = cg.cooperative_task(s, "circle")
    tel = Teleoperator(t, s.q0, dt=0.01)
    with pytest.warns(UserWarning, match="scripted"):
        mode = run_interactive(tel, fallback_script=[(0.02, [0, 0, 0, 0, 0, 1])])
    assert mode == "scripted" and len(tel.log.q) == 3


def test_key_bindings_and_skeleton():
    assert {i for i, _ in KEY_BINDINGS.values()} == set(range(6))
    s = cg.systems.load("three_franka")
    t = cg.cooperative_task(s, "circle")
    lines = skeleton(s, s.q0).chains
    assert len(lines) == 3
    for line, p in zip(lines, t.points(s.q0)):
        np.testing.assert_allclose(line[-1], p, atol=1e-9)
