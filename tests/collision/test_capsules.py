"""Bounding capsules: every mesh vertex is inside, in the link frame and in the world at random q."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import coop_ga
from coop_ga.collision import Capsule, CollisionModel, fit_capsule, fit_capsules, link_meshes
from coop_ga.errors import CoopGAError, UnknownNameError


@pytest.fixture(scope="module")
def franka():
    return coop_ga.systems.load("three_franka")


def test_fit_capsule_encloses_random_clouds_and_is_tight():
    rng = np.random.default_rng(0)
    for _ in range(30):
        # points inside a known capsule (axis u, half length h, radius r), randomly placed
        u = rng.normal(size=3)
        u /= np.linalg.norm(u)
        h, r = rng.uniform(0.05, 0.3), rng.uniform(0.02, 0.1)
        c = rng.normal(size=3)
        n = 400
        t = rng.uniform(-h - r, h + r, n)
        w = rng.normal(size=(n, 3))
        w -= (w @ u)[:, None] * u
        w /= np.linalg.norm(w, axis=1, keepdims=True)
        rad = r * np.sqrt(rng.uniform(0, 1, n))
        P = c + t[:, None] * u + rad[:, None] * w
        cap = Capsule("f", *fit_capsule(P)[:2], fit_capsule(P)[2])
        assert np.all(cap.point_distance(P) <= cap.radius)
        # tight: not much fatter than the generating capsule
        assert cap.radius <= 1.35 * r + 1e-6
        assert cap.length <= 2 * h + 2 * r


def test_fit_capsule_of_a_ball_like_cloud_degenerates_to_a_ball():
    rng = np.random.default_rng(1)
    P = rng.normal(size=(500, 3))
    P /= np.linalg.norm(P, axis=1, keepdims=True)
    a, b, r = fit_capsule(0.2 * P)
    assert Capsule("f", a, b, r).contains(0.2 * P).all()
    assert np.linalg.norm(b - a) < 0.02 and r < 0.2 * 1.05


def test_fit_capsule_along_a_given_axis():
    """A 65 × 40 × 32 mm box along x with a tessellated cylinder across it (a servo and its horn, the hexapod's
    femur): PCA follows the cylinder's vertices across the box; ``axis`` keeps the capsule along the box, thinner,
    and both enclose every vertex."""
    bx = np.array([[x, y, z] for x in (0.0, 0.065) for y in (-0.02, 0.02) for z in (-0.016, 0.016)])
    ang = np.linspace(0.0, 2 * np.pi, 100, endpoint=False)
    ring = np.column_stack([0.014 * np.cos(ang), np.zeros_like(ang), 0.014 * np.sin(ang)])
    P = np.vstack([bx, ring + [0, -0.023, 0], ring + [0, 0.023, 0]])
    a0, b0, r0 = fit_capsule(P)
    a, b, r = fit_capsule(P, axis=(2.0, 0.0, 0.0))
    assert abs((b0 - a0)[1]) > 0.9 * np.linalg.norm(b0 - a0)  # PCA: across the box, along the horn
    assert np.allclose((b - a)[1:], 0.0) and (b - a)[0] > 0.05  # along x, as asked
    assert r < 0.7 * r0 and r == pytest.approx(np.hypot(0.023, 0.014), abs=1e-6)
    for cap in (Capsule("f", a0, b0, r0), Capsule("f", a, b, r)):
        assert cap.contains(P).all()
    with pytest.raises(CoopGAError, match="axis"):
        fit_capsule(P, axis=(0.0, 0.0, 0.0))
    with pytest.raises(CoopGAError, match="axis"):
        fit_capsule(P, axis=(1.0, 0.0))


@pytest.mark.parametrize("source", ["collision", "visual"])
def test_capsules_enclose_every_link_vertex(franka, source):
    caps = fit_capsules(franka, source)
    meshes = link_meshes(franka, source)
    assert len(caps) == len(meshes) == 33  # 11 Panda links per arm (link0…link7, hand, 2 fingers)
    for c in caps:
        V = meshes[c.frame]
        assert len(V) > 50
        assert c.contains(V).all(), c.frame
        slack = c.radius - c.point_distance(V).max()
        assert 0.0 <= slack < 1e-6  # touches the mesh: no gratuitous padding
    radii = {c.link: c.radius for c in caps}
    assert 0.05 < radii["arm0_panda_link4"] < 0.1  # Panda links are ~6–9 cm in radius
    assert radii["arm0_panda_link4"] == pytest.approx(radii["arm2_panda_link4"], abs=1e-12)


def test_chains_of_the_capsules(franka):
    caps = {c.frame: c for c in fit_capsules(franka)}
    assert caps["arm0_panda_link0"].chain == 0  # a world-fixed base belongs to the arm mounted on it
    assert caps["arm2_panda_link0"].chain == 2
    assert caps["arm1_panda_link3"].chain == 1
    assert caps["arm2_panda_hand"].chain == 2


def test_world_vertices_stay_inside_at_random_q(franka):
    """The visual meshes placed by Pinocchio (updateGeometryPlacements) at random q are inside the
    capsules placed by CollisionModel: the frame conventions agree."""
    caps = fit_capsules(franka, "visual")
    cm = CollisionModel(franka, capsules=caps, self_collision=False)
    vm = franka.visual_model()
    gd = vm.createData()
    data = franka.model.createData()
    from coop_ga.systems.meshes import object_mesh

    by_frame = {c.frame: k for k, c in enumerate(caps)}
    rng = np.random.default_rng(2)
    for _ in range(3):
        q = franka.random_q(rng)
        pin.updateGeometryPlacements(franka.model, data, vm, gd, q)
        A, B = cm.capsule_segments(q)
        for i, obj in enumerate(vm.geometryObjects):
            k = by_frame[franka.model.frames[obj.parentFrame].name]
            M = gd.oMg[i]
            V = object_mesh(obj).vertices @ np.asarray(M.rotation).T + np.asarray(M.translation)
            d = B[k] - A[k]
            t = np.clip((V - A[k]) @ d / (d @ d), 0, 1) if d @ d > 0 else np.zeros(len(V))
            dist = np.linalg.norm(V - (A[k] + t[:, None] * d), axis=1)
            assert dist.max() <= caps[k].radius + 1e-9, obj.name


def test_links_filter_and_errors(franka):
    caps = fit_capsules(franka, links=["arm0_panda_link5", "arm1_panda_hand"])
    assert [c.frame for c in caps] == ["arm0_panda_link5", "arm1_panda_hand"]
    with pytest.raises(UnknownNameError):
        fit_capsules(franka, links=["arm0_panda_link9"])
    with pytest.raises(CoopGAError):
        fit_capsules(franka, source="mesh")
    with pytest.raises(CoopGAError):
        fit_capsule(np.zeros((0, 3)))
    with pytest.raises(CoopGAError):
        Capsule("f", [0, 0], [0, 0, 1], 0.1)
    with pytest.raises(CoopGAError):
        Capsule("f", [0, 0, 0], [0, 0, 1], -0.1)
    c = Capsule("f", [0, 0, 0], [0, 0, 1], 0.1)
    assert c.link == "f" and c.length == 1.0
    assert c == Capsule("f", np.zeros(3), [0, 0, 1.0], 0.1) and hash(c) == hash(Capsule("f", [0, 0, 0], [0, 0, 1], 0.1))
