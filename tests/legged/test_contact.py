"""coop_ga.legged.contact and the terrain solid: the foot ball read from the URDF, contact points, link frames and
leg capsules against Pinocchio, the shin kept above the ball, clearance of capsules (against brute force), rolling."""

from __future__ import annotations

import math

import numpy as np
import pytest

import coop_ga as cg
from coop_ga.errors import InvalidInputError
from coop_ga.legged.body import BodyState
from coop_ga.legged.contact import (
    SHIN_TILT,
    ball_on_terrain,
    leg_capsules,
    leg_clearance,
    leg_segments,
    rolling_distance,
    shin_capsule,
)
from coop_ga.legged.legs import hexapod_legs
from coop_ga.legged.terrain import Terrain

L = hexapod_legs()


def test_foot_ball_from_the_urdf_and_contact_points():
    assert L.foot_radius == 0.009  # <sphere radius="0.009"/> on every {leg}_foot frame
    q = L.q_stand
    c = L.contact_points(q)
    np.testing.assert_allclose(c, L.fk(q) - [0.0, 0.0, 0.009], atol=1e-16)
    n = np.array([0.0, 0.6, 0.8])
    np.testing.assert_allclose(L.contact_points(q, n), L.fk(q) - 0.009 * n, atol=1e-16)
    with pytest.raises(InvalidInputError, match="normals"):
        L.contact_points(q, [0.0, 0.0, 0.0])


def test_link_frames_and_capsules_against_pinocchio():
    """link_frames = Pinocchio's oMi; the capsules of leg_segments = Pinocchio's frames applied to the capsules
    of leg_capsules (the ones a coop_ga.sim scene gets), in W, for random configurations and body poses."""
    import pinocchio as pin

    sysf = cg.systems.load("hexapod", free_flyer=True)
    m, d = sysf.model, sysf.model.createData()
    caps = {c.frame: c for c in leg_capsules(L, sysf)}
    rng = np.random.default_rng(3)
    for _ in range(20):
        q = L.from_legs(rng.uniform(L.q_lower, L.q_upper))
        s = BodyState.from_rpy(rng.uniform(-0.2, 0.2, 3), rng.uniform(-0.3, 0.3, 3), q)
        pin.framesForwardKinematics(m, d, s.free_flyer_q())
        F = L.link_frames(q)
        a, b, rho = leg_segments(L, s.position, s.rotation, q)
        for i, leg in enumerate(L.legs):
            for k, link in enumerate(("coxa", "femur", "tibia")):
                M = d.oMi[m.getJointId(f"{leg}_{link}_joint")]
                np.testing.assert_allclose(s.rotation @ F[link][0][i], M.rotation, atol=1e-14)
                np.testing.assert_allclose(s.to_world(F[link][1][i]), M.translation, atol=1e-14)
                c = caps[f"{leg}_{link}"]
                Mf = d.oMf[m.getFrameId(c.frame)]
                np.testing.assert_allclose(a[i, k], Mf.act(c.a), atol=1e-13)
                np.testing.assert_allclose(b[i, k], Mf.act(c.b), atol=1e-13)
                assert rho[k] == c.radius
            ball = caps[f"{leg}_foot"]
            assert ball.radius == 0.009 and np.all(ball.a == 0) and np.all(ball.b == 0)


def test_coxa_and_femur_capsules_lie_along_their_links_and_enclose_them():
    """The coxa and femur capsules run from the joint along the link (not across it, along the servo horn, as the
    PCA fit put them) and enclose every vertex of the link's URDF geometry; the femur's radius is 26.9 mm, not
    42.6 mm."""
    from coop_ga.collision import fit_capsules
    from coop_ga.collision.capsules import link_meshes

    system = cg.systems.load("hexapod")
    meshes = link_meshes(system)
    caps = {c.frame: c for c in leg_capsules(L, system)}
    pca = {c.frame: c for c in fit_capsules(system, links=["lf_coxa", "lf_femur"])}
    for leg in L.legs:
        for link in ("coxa", "femur"):
            c = caps[f"{leg}_{link}"]
            assert np.allclose(c.a, 0.0, atol=1e-12) and abs(c.b[1]) < 1e-12 and abs(c.b[2]) < 1e-12 and c.b[0] > 0.04
            assert c.contains(meshes[c.frame], tol=1e-12).all()
    assert caps["lf_femur"].radius == pytest.approx(np.hypot(0.023, 0.014), abs=1e-6)
    assert pca["lf_femur"].radius > 0.042 and caps["lf_femur"].radius < 0.65 * pca["lf_femur"].radius
    assert caps["lf_coxa"].radius < pca["lf_coxa"].radius


def test_the_shin_stays_above_the_ball_the_fitted_capsule_did_not():
    """The fitted tibia capsule hangs below the 9 mm ball at any tilt (1.7 mm at the stand pose's 27°): physics would
    touch the ground with the tibia.  The shin's end cap stays above the ball's lowest point up to SHIN_TILT."""
    from coop_ga.collision import fit_capsules

    fitted = next(c for c in fit_capsules(L.system) if c.frame == "lf_tibia")
    _, b, rho = shin_capsule(L)
    foot = np.array([L.tibia_length[0], 0.0, 0.0])
    assert rho == pytest.approx(fitted.radius) and 0.09 < b[0] < fitted.b[0]

    def lowest(end: np.ndarray, radius: float, tilt: float) -> float:
        """Height of a cap's lowest point relative to the ball's, for a tibia tilted ``tilt`` from the vertical
        (the cap's centre lies (foot − end) · cos(tilt) above the ball's centre)."""
        return (foot[0] - end[0]) * math.cos(tilt) - radius + L.foot_radius

    for deg in (0.0, 27.0, 38.0, math.degrees(SHIN_TILT)):
        t = math.radians(deg)
        assert lowest(b, rho, t) >= 1e-3 - 1e-12, deg
        if deg > 0:
            assert lowest(np.asarray(fitted.b), fitted.radius, t) < 0.0, deg  # the fitted capsule: below the ball


def test_solid_distance_against_brute_force():
    terrain = Terrain.random(seed=0)
    P = np.random.default_rng(1).uniform([-0.3, -0.3, 0.0], [0.3, 0.3, 0.05], (600, 3))
    d = terrain.solid_distance(P)
    xe = np.concatenate([[-3.5], terrain.x_edges, [3.5]])
    ye = np.concatenate([[-3.5], terrain.y_edges, [3.5]])
    ref = np.full(len(P), np.inf)
    for iy in range(len(ye) - 1):
        for ix in range(len(xe) - 1):
            h = terrain.planes[iy, ix, 3]
            cx, cy = np.clip(P[:, 0], xe[ix], xe[ix + 1]), np.clip(P[:, 1], ye[iy], ye[iy + 1])
            ref = np.minimum(ref, np.sqrt((P[:, 0] - cx) ** 2 + (P[:, 1] - cy) ** 2 + np.maximum(P[:, 2] - h, 0) ** 2))
    out = d > 0
    np.testing.assert_allclose(d[out], ref[out], atol=1e-15)
    assert np.all(ref[~out] == 0.0) and np.all(d[~out] <= 0.0)
    steps = Terrain.steps()
    np.testing.assert_allclose(
        steps.solid_distance([[0.1, 0.0, 0.05], [0.14, 0.0, 0.04], [0.16, 0.0, 0.01], [0.14, 0.0, 0.02]]),
        [0.05, math.hypot(0.01, 0.01), -0.01, 0.01],
        atol=1e-15,
    )
    slope = Terrain.slope(0.1)
    p = np.array([[0.3, 0.2, 0.1]])
    assert slope.solid_distance(p)[0] == pytest.approx(slope.signed_distance(p)[0], abs=1e-15)


def test_capsule_clearance_is_a_lower_bound():
    steps = Terrain.steps()
    # a horizontal capsule 2 cm above the first tread's top: 20 mm − radius − half a sample spacing
    c = steps.capsule_clearance([0.2, 0.0, 0.05], [0.3, 0.0, 0.05], 0.01, spacing=0.002)
    assert c == pytest.approx(0.02 - 0.01 - 0.001, abs=1e-12)
    # a capsule rising over the riser's edge (0.15, ·, 0.03): its nearest solid point is that edge
    a, b = np.array([0.12, 0.0, 0.05]), np.array([0.18, 0.0, 0.07])
    exact = abs((b - a)[0] * (0.03 - a[2]) - (b - a)[2] * (0.15 - a[0])) / np.linalg.norm(b - a)
    c = steps.capsule_clearance(a, b, 0.005, spacing=0.001)
    assert exact - 0.005 - 0.0006 <= c <= exact - 0.005


def test_ball_on_terrain_and_rolling():
    flat = Terrain.flat(0.02)
    np.testing.assert_allclose(ball_on_terrain(flat, [[0.1, 0.2]], 0.009), [[0.1, 0.2, 0.029]], atol=1e-16)
    slope = Terrain.slope(0.1)
    c = ball_on_terrain(slope, [0.3, 0.0], 0.009)
    assert slope.signed_distance(c) == pytest.approx(0.009, abs=1e-15)
    # a stance leg whose tibia turns by 0.1 rad about a horizontal axis rolls its ball by r · 0.1
    q0 = L.q_stand
    q1 = q0.copy()
    q1[L.q_index[0, 2]] += 0.1  # lf's tibia: about the leg's horizontal axis
    R = np.broadcast_to(np.eye(3), (2, 3, 3))
    st = np.ones((2, 6), bool)
    roll = rolling_distance(L, R, np.array([q0, q1]), np.broadcast_to([0.0, 0.0, 1.0], (2, 6, 3)), st)
    assert roll[1, 0] == pytest.approx(0.009 * 0.1, rel=1e-12) and np.all(roll[:, 1:] == 0.0) and roll[0, 0] == 0.0


def test_leg_clearance_stand_on_flat_ground():
    """At the stand pose on flat ground (balls resting on it) every capsule is off the ground by ≥ 5 mm."""
    flat = Terrain.flat()
    s = BodyState([0.0, 0.0, 0.009 - L.fk(L.q_stand)[0, 2]], np.eye(3), L.q_stand)
    c = leg_clearance(flat, L, s.position, s.rotation, s.q)
    assert c.shape == (6,) and 0.005 < c.min() < 0.05
