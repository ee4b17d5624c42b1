"""Posture control through the stance primitive (coop_ga.legged.posture; issue 13 item 5)."""

from __future__ import annotations

import numpy as np
import pytest

from coop_ga.errors import InvalidInputError
from coop_ga.legged.body import BodyState
from coop_ga.legged.legs import LEGS, hexapod_legs
from coop_ga.legged.posture import (
    OBSERVABLE,
    PostureOptions,
    adjoint,
    body_motion_target,
    command_from_body_twist,
    feet_field,
    posture_step,
    posture_to,
)

L = hexapod_legs()
STAND = np.tile([0.0, 0.3, -1.4], 6)
H = -float(L.fk(STAND)[0, 2])  # stand height [m]: feet on z = 0
TRIPOD = ("lf", "lr", "rm")
N_STEPS = 40
SLIP_BOUND = 1e-4  # the issue's 0.1 mm per step; the re-solve gives ~1e-16


def flat_state() -> BodyState:
    return BodyState([0.0, 0.0, H], np.eye(3), STAND)


def uneven_state() -> BodyState:
    """Feet on uneven ground: stand feet raised/lowered by up to 2 cm (no four coplanar)."""
    f = L.fk(STAND)
    f[:, 2] += np.array([0.02, -0.015, 0.01, -0.02, 0.015, -0.005])
    return BodyState([0.0, 0.0, H], np.eye(3), L.ik(f))


def run(state, stance, command, n=N_STEPS, **opt):
    o = PostureOptions(**opt)
    infos = []
    for _ in range(n):
        state, info = posture_step(state, stance, command, L, o)
        infos.append(info)
    return state, infos


RIGID = {
    "x": ([0.02, 0.0, 0.0], [0.0, 0.0, 0.0]),
    "y": ([0.0, -0.02, 0.0], [0.0, 0.0, 0.0]),
    "z": ([0.0, 0.0, 0.02], [0.0, 0.0, 0.0]),
    "roll": ([0.0, 0.0, 0.0], [0.2, 0.0, 0.0]),
    "pitch": ([0.0, 0.0, 0.0], [0.0, -0.2, 0.0]),
    "yaw": ([0.0, 0.0, 0.0], [0.0, 0.0, 0.3]),
}


@pytest.mark.parametrize("stance", [TRIPOD, LEGS], ids=["tripod_plane", "six_plane"])
@pytest.mark.parametrize("motion", sorted(RIGID))
def test_rigid_commands_flat(stance, motion):
    v, w = RIGID[motion]
    s0 = flat_state()
    s, infos = run(s0, stance, command_from_body_twist(v, w), frame="body")
    assert all(i.kind == "plane" for i in infos)
    slip = max(i.max_slip for i in infos)
    assert slip < 1e-12 < SLIP_BOUND
    # the feet did not move over the whole run
    idx = [LEGS.index(leg) for leg in stance]
    assert np.max(np.abs(s.feet_world(L)[idx] - s0.feet_world(L)[idx])) < 1e-12
    # the body followed the command: every step's body twist is the commanded (v, ω)
    dev = max(float(np.max(np.abs(i.body_twist - np.r_[v, w]))) for i in infos)
    assert dev < 1e-6
    # observable rows tracked (the plane sees tilt and height): error from the step discretisation only
    assert max(i.tracking_error_norm for i in infos) < 2e-4
    assert max(i.max_limit_violation for i in infos) == 0.0
    assert not any(i.limited for i in infos)
    # the pose: translation along B (body axes = world axes here) / rotation angle
    T = N_STEPS * 0.01
    if motion in ("x", "y", "z"):
        assert np.allclose(s.position - s0.position, np.array(v) * T, atol=1e-9)
        assert np.allclose(s.rotation, np.eye(3), atol=1e-9)
    else:
        from scipy.spatial.transform import Rotation

        assert np.allclose(Rotation.from_matrix(s.rotation).as_rotvec(), np.array(w) * T, atol=1e-9)
        assert np.allclose(s.position, s0.position, atol=1e-8)
    # the swing legs kept their joints
    swing = [i for i in range(6) if LEGS[i] not in stance]
    if swing:
        cols = L.q_index[swing].ravel()
        assert np.array_equal(s.q[cols], s0.q[cols])


def test_linear_step_alone_would_slip():
    """Without the closed-form re-solve the linearised step slips ~1e-7 m per step: the re-solve matters."""
    _, infos = run(flat_state(), TRIPOD, command_from_body_twist([0, 0, 0], [0, 0, 0.3]), n=3, frame="body")
    assert min(i.linear_slip for i in infos) > 1e-8
    assert max(i.max_slip for i in infos) < 1e-14


@pytest.mark.parametrize("stance", [TRIPOD, LEGS], ids=["tripod", "six"])
def test_dilation_of_plane_is_ride_height(stance):
    """A body-frame dilation of the stance plane is an offset change: the body rises by (1 + βΔt) per step."""
    beta = 0.2
    s0 = flat_state()
    s, infos = run(s0, stance, np.array([0, 0, 0, beta, 0, 0, 0.0]), frame="body")
    assert max(i.max_slip for i in infos) < 1e-12
    assert s.position[2] == pytest.approx(H * (1.0 + beta * 0.01) ** N_STEPS, rel=1e-6)  # explicit Euler steps
    assert max(abs(i.radius_rate_error) for i in infos) == 0.0  # a plane has no radius
    assert max(i.tracking_error_norm for i in infos) < 1e-9


@pytest.mark.parametrize(
    "stance", [("lf", "lm", "rf", "rm"), ("lf", "lm", "lr", "rf", "rm"), LEGS], ids=["4", "5", "6"]
)
def test_uneven_sphere(stance):
    s0 = uneven_state()
    idx = [LEGS.index(leg) for leg in stance]
    for motion, (v, w) in RIGID.items():
        s, infos = run(s0, stance, command_from_body_twist(v, w), n=20, frame="body")
        assert infos[0].kind == "sphere" and infos[0].well_definedness > 0.1
        assert max(i.max_slip for i in infos) < 1e-12, motion
        assert np.max(np.abs(s.feet_world(L)[idx] - s0.feet_world(L)[idx])) < 1e-12
        # translations are seen by the sphere; rotations (about its centre) come from the feet field
        dev = max(float(np.max(np.abs(i.body_twist - np.r_[v, w]))) for i in infos)
        assert dev < 1e-6, motion
        assert max(i.tracking_error_norm for i in infos) < 2e-4, motion
    # dilation about the body origin: the centre moves (realised), the radius cannot change (error = β)
    beta = 0.2
    s, infos = run(s0, stance, np.array([0, 0, 0, beta, 0, 0, 0.0]), n=20, frame="body")
    assert max(i.max_slip for i in infos) < 1e-12
    for i in infos:
        assert i.radius_rate_error == pytest.approx(beta, abs=1e-9)
        assert np.linalg.norm(np.delete(i.tracking_error, 3)) < 1e-5  # the centre's part is realised (to O(Δt))
    # the sphere's centre moved away from the body origin by (1 + βΔt) per step; its radius did not change
    from coop_ga.legged.stance import stance_primitive

    sp0 = stance_primitive(s0.feet_body(L)[idx], kind="sphere")
    sp1 = stance_primitive(s.feet_body(L)[idx], kind="sphere")
    ratio = np.linalg.norm(sp1.center) / np.linalg.norm(sp0.center)
    assert ratio == pytest.approx((1.0 + beta * 0.01) ** 20, rel=1e-4)
    assert sp1.radius == pytest.approx(sp0.radius, abs=1e-12)
    # dilation in the primitive frame (about the sphere's centre): nothing a rigid body can do
    s, infos = run(s0, stance, np.array([0, 0, 0, beta, 0, 0, 0.0]), n=3)
    assert all(i.radius_rate_error == pytest.approx(beta, abs=1e-9) for i in infos)
    # (the feet field of a dilation about the centre has a rigid part; its weight μ² lets ~1e-8 m through)
    assert np.allclose(s.position, s0.position, atol=1e-7)


def test_primitive_and_body_frames_agree():
    s0 = uneven_state()
    stance = ("lf", "lm", "rf", "rm")
    c_P = np.array([0.0, 0.0, 0.0, 0.0, 0.1, -0.05, 0.02])
    _, a = posture_step(s0, stance, c_P, L, PostureOptions(frame="primitive"))
    from coop_ga.legged.posture import stance_posture_task

    task = stance_posture_task(L, s0.q, stance, "sphere")
    c_B = adjoint(task.similarity(s0.q)) @ c_P
    _, b = posture_step(s0, stance, c_B, L, PostureOptions(frame="body"))
    assert np.allclose(a.body_twist, b.body_twist, atol=1e-9)
    assert np.allclose(b.command_primitive, c_P, atol=1e-12)


def test_adjoint_and_field():
    """Ad of a translation; the field of a twist is the derivative of its action on points."""
    from coop_ga.geometry.groups import Similarity
    from coop_ga.geometry.primitives import point, to_euclidean

    V = Similarity.from_parts(translation=[0.0, 0.0, -0.1])
    Ad = adjoint(V)
    b = Ad @ np.array([0, 0, 0, 1.0, 0, 0, 0])  # dilation about (0, 0, −0.1)
    assert np.allclose(b, [0, 0, 0, 1.0, 0, 0, 0.1], atol=1e-15)
    x = np.array([0.3, -0.2, 0.5])
    c = np.array([0.1, -0.2, 0.3, 0.05, 0.4, -0.1, 0.2])
    eps = 1e-7
    y = np.asarray(to_euclidean(Similarity.exp(eps * c).apply(point(x))), dtype=float)
    assert np.allclose((y - x) / eps, feet_field(c, x[None])[0], atol=1e-6)
    assert OBSERVABLE["sphere"].sum() == 4 and OBSERVABLE["plane"].sum() == 3 and OBSERVABLE["circle"].sum() == 6


def test_limits_stop_the_body():
    """A yaw command driving the coxas into their limits (±70°) stops at them, reported; never beyond."""
    s, infos = run(flat_state(), TRIPOD, command_from_body_twist([0, 0, 0], [0, 0, 3.0]), n=80, frame="body")
    assert max(i.max_limit_violation for i in infos) == 0.0
    assert max(i.max_slip for i in infos) < 1e-12
    assert any(i.limited for i in infos)
    held = [i for i in infos if i.position_limited_joints]
    assert held, "no step reached a position limit"
    assert abs(infos[-1].body_twist[5]) < 0.05  # stopped (command 3 rad/s)
    assert s.rpy()[2] < 3.0 * 80 * 0.01 / 2  # far short of the commanded 2.4 rad
    Q = L.per_leg(s.q)
    assert np.all(Q >= L.q_lower) and np.all(Q <= L.q_upper)
    names = [n for leg in L.joint_names for n in leg]
    gap = np.minimum(Q - L.q_lower, L.q_upper - Q).ravel()
    held_names = {j for i in held for j in i.position_limited_joints}
    coxas = [j for j in held_names if "coxa" in j]
    assert coxas and min(gap[names.index(j)] for j in coxas) < 1e-3  # a coxa stopped at its limit (±70°)
    # the tibias are held short of the straight leg by knee_margin (the end of the reach)
    bend = np.abs(Q[:, 2])
    assert np.all(bend[[LEGS.index(x) for x in TRIPOD]] >= 0.05 - 1e-9)


def test_posture_to_reaches_rigid_targets():
    s0 = uneven_state()
    stance = ("lf", "lm", "rf", "rm")
    from coop_ga.legged.posture import stance_posture_task

    _, first = posture_step(s0, stance, np.zeros(7), L)
    task = stance_posture_task(L, s0.q, stance)
    assert task.kind == first.kind == "sphere"
    V0 = task.similarity(s0.q)
    target = body_motion_target(V0, translation=[0.015, -0.01, 0.01])
    res = posture_to(s0, stance, target, L, PostureOptions(gain=10.0, tol=1e-8, max_steps=300))
    assert res.converged, res.message
    assert res.max_slip < 1e-12 and res.max_limit_violation == 0.0
    assert np.allclose(res.states[-1].position - s0.position, [0.015, -0.01, 0.01], atol=1e-6)
    assert res.q.shape == (len(res.t), 18) and res.body.shape == (len(res.t), 7)
    # a target with another radius: the radius part stays as the final error
    from coop_ga.geometry.groups import Similarity

    bigger = V0 @ Similarity.from_parts(scale=1.1)
    res = posture_to(s0, stance, bigger, L, PostureOptions(gain=10.0, max_steps=60))
    assert not res.converged
    assert res.final_error[3] == pytest.approx(np.log(1.1), rel=1e-9)
    assert res.max_slip < 1e-12


def test_bad_input():
    s = flat_state()
    with pytest.raises(InvalidInputError, match="≥ 3 stance_legs"):
        posture_step(s, ("lf", "rm"), np.zeros(7), L)
    with pytest.raises(InvalidInputError):
        posture_step(s, TRIPOD, np.zeros(6), L)
    with pytest.raises(InvalidInputError, match="unknown leg"):
        posture_step(s, ("lf", "rm", "xx"), np.zeros(7), L)
    with pytest.raises(InvalidInputError, match="frame"):
        PostureOptions(frame="world")
    bad = s.copy()
    bad.q[0] = 2.0  # coxa beyond 1.22 rad
    with pytest.raises(InvalidInputError, match="outside the joint limits"):
        posture_step(bad, TRIPOD, np.zeros(7), L)
    with pytest.raises(InvalidInputError, match="in stance"):
        posture_step(s, TRIPOD, np.zeros(7), L, swing_q={"lf": [0, 0, 0]})


def test_swing_targets():
    s0 = flat_state()
    f = s0.feet_world(L)[LEGS.index("rf")] + [0.0, 0.0, 0.03]
    s, info = posture_step(s0, TRIPOD, np.zeros(7), L, swing_feet_W={"rf": f}, swing_q={"lm": [0.1, 0.5, -1.2]})
    assert np.allclose(s.feet_world(L)[LEGS.index("rf")], f, atol=1e-12)
    assert np.allclose(s.q[L.q_index[LEGS.index("lm")]], [0.1, 0.5, -1.2])
    assert info.max_slip < 1e-14
