"""coop_ga.legged.terrain: the terrain kinds, heights and normals, contact by point–plane incidence, landing,
the npz array layout, determinism under a seed."""

from __future__ import annotations

import math

import numpy as np
import pytest

from coop_ga.errors import CoopGAError, InvalidInputError, NonFiniteError
from coop_ga.geometry.primitives import normal, plane, point
from coop_ga.legged.terrain import TERRAIN_KINDS, Terrain

RNG = np.random.default_rng(7)
XY = RNG.uniform(-1.5, 1.5, size=(40, 2))


def _all():
    return [Terrain.flat(0.02), Terrain.slope(0.2, (1.0, 1.0), 0.05), Terrain.steps(), Terrain.random(seed=3)]


def test_flat_and_slope_heights():
    np.testing.assert_allclose(Terrain.flat(0.02).height(XY), 0.02, atol=0)
    T = Terrain.slope(0.2, (3.0, 4.0), 0.05)
    expect = 0.05 + math.tan(0.2) * (XY @ np.array([0.6, 0.8]))
    np.testing.assert_allclose(T.height(XY), expect, atol=1e-15)
    n = T.normal(XY)
    np.testing.assert_allclose(np.linalg.norm(n, axis=-1), 1.0, atol=1e-15)
    np.testing.assert_allclose(n[0], np.array([-0.6 * math.sin(0.2), -0.8 * math.sin(0.2), math.cos(0.2)]), atol=1e-15)


def test_steps_go_up_along_x():
    T = Terrain.steps(step_height=0.03, step_length=0.25, start_x=0.15, n_steps=4)
    # rises at x = 0.15, 0.40, 0.65, 0.90; the top tread (0.12 m) continues to +∞; edges belong to the +x side
    x = np.array([-5.0, 0.1499, 0.15, 0.3999, 0.40, 0.65, 0.8999, 0.90, 50.0])
    h = T.height(np.stack([x, np.full_like(x, -3.0)], axis=-1))
    np.testing.assert_allclose(h, [0.0, 0.0, 0.03, 0.03, 0.06, 0.09, 0.09, 0.12, 0.12], atol=1e-15)
    assert np.all(T.normal(XY) == np.array([0.0, 0.0, 1.0]))
    # climbable: no rise exceeds the default 0.03 m and the feet reach ~0.1 m below the body
    assert np.max(np.diff(T.planes[0, :, 3])) == pytest.approx(0.03)


def test_random_is_seeded_bounded_and_tiled():
    a, b, c = Terrain.random(seed=5), Terrain.random(seed=5), Terrain.random(seed=6)
    assert a == b and not a == c
    xy = RNG.uniform(-3.0, 3.0, size=(2000, 2))
    h = a.height(xy)
    assert 0.0 <= h.min() and h.max() <= 0.025
    assert h.std() > 0.005  # really uneven
    # constant over one tile, zero outside the extent
    c0 = np.array([0.5 * 0.08 - 3.0 + 0.08 * 30, 0.5 * 0.08 - 3.0 + 0.08 * 41])
    np.testing.assert_array_equal(a.height(c0 + RNG.uniform(-0.039, 0.039, (20, 2))), a.height(c0))
    np.testing.assert_array_equal(a.height(np.array([[3.5, 0.0], [0.0, -3.5], [-10.0, 10.0]])), 0.0)
    # neighbouring tiles differ by less than the amplitude (walkable by a tripod)
    H = a.planes[..., 3]
    assert np.max(np.abs(np.diff(H, axis=0))) <= 0.025 and np.max(np.abs(np.diff(H, axis=1))) <= 0.025


def test_make_kinds():
    for k in TERRAIN_KINDS:
        assert Terrain.make(k).kind == k
    assert Terrain.make("random", seed=2) == Terrain.random(seed=2)
    assert Terrain.make("steps") == Terrain.steps()
    with pytest.raises(InvalidInputError, match="terrain kind"):
        Terrain.make("lava")


@pytest.mark.parametrize("T", _all(), ids=lambda t: t.kind)
def test_signed_distance_is_the_incidence(T):
    ground = T.land(XY)
    np.testing.assert_allclose(ground[:, :2], XY, atol=0)
    np.testing.assert_allclose(ground[:, 2], T.height(XY), atol=0)
    d = RNG.uniform(-0.05, 0.05, size=len(XY))
    pts = ground + d[:, None] * T.normal(XY)  # along the normal: the signed distance is d exactly
    np.testing.assert_allclose(T.signed_distance(pts), d, atol=1e-15)
    assert np.all(np.abs(T.signed_distance(ground)) < 1e-15)
    # the same number from the algebra by hand: ⟨Π ∧ P⟩ of the patch's plane primitive
    for i in range(5):
        Pi = T.plane_at(XY[i])
        assert Pi.kind == "plane"
        np.testing.assert_allclose(normal(Pi), T.normal(XY[i]), atol=1e-15)
        X = Pi ^ point(pts[i])
        assert float(X.get(31)) == pytest.approx(-d[i], abs=1e-15)  # 31 = e0123∞
    # vertical offset h above a tilted patch: distance h·n_z
    up = ground + np.array([0.0, 0.0, 0.01])
    np.testing.assert_allclose(T.signed_distance(up), 0.01 * T.normal(XY)[:, 2], atol=1e-15)


def test_in_contact_tolerance_and_shapes():
    T = Terrain.steps()
    g = T.land(XY).reshape(4, 10, 3)
    assert T.in_contact(g).shape == (4, 10) and T.in_contact(g).all()
    assert T.in_contact(g + [0, 0, 0.0009]).all()
    assert not T.in_contact(g + [0, 0, 0.0011]).any()
    assert not T.in_contact(g - [0, 0, 0.0011]).any()  # penetration is not contact either
    assert T.in_contact(g + [0, 0, 0.004], tol=0.005).all()
    assert T.signed_distance(np.zeros((0, 3))).shape == (0,)


def test_plane_at_agrees_with_a_plane_through_three_terrain_points():
    T = Terrain.slope(0.3, (0.0, 1.0))
    a, b, c = T.land(np.array([[0.1, 0.2], [0.5, 0.2], [0.1, 0.7]]))
    ref = plane(a, b, c)  # normal (b−a)×(c−a) points up
    Pi = T.plane_at([0.3, 0.3])
    k = np.array([ref.get(bl) for bl in Pi.blades], float)
    v = np.array([Pi.get(bl) for bl in Pi.blades], float)
    np.testing.assert_allclose(v, k / np.linalg.norm(k[:3]), atol=1e-15)  # same plane, same orientation


@pytest.mark.parametrize("T", _all(), ids=lambda t: t.kind)
def test_arrays_round_trip_through_npz(T, tmp_path):
    d = T.to_arrays()
    assert all(k.startswith("terrain_") for k in d)
    np.savez(tmp_path / "t.npz", t=np.zeros(3), **d)
    with np.load(tmp_path / "t.npz", allow_pickle=False) as f:
        T2 = Terrain.from_arrays(f)
    assert T2 == T and T2.kind == T.kind and T2.seed == T.seed
    np.testing.assert_array_equal(T2.height(XY), T.height(XY))
    # the documented lookup reproduces the heights from the raw arrays
    ix = np.searchsorted(d["terrain_x_edges"], XY[:, 0], side="right")
    iy = np.searchsorted(d["terrain_y_edges"], XY[:, 1], side="right")
    P = d["terrain_planes"][iy, ix]
    np.testing.assert_allclose((P[:, 3] - P[:, 0] * XY[:, 0] - P[:, 1] * XY[:, 1]) / P[:, 2], T.height(XY), atol=1e-15)


def test_max_height_sees_steps():
    T = Terrain.steps()
    assert T.max_height([0.0, 0.0], [0.40, 0.0], samples=2) == pytest.approx(0.06)
    assert T.max_height([0.0, 0.0], [0.14, 0.0]) == 0.0


def test_bad_input():
    T = Terrain.flat()
    with pytest.raises(InvalidInputError):
        T.height(np.zeros(3))
    with pytest.raises(NonFiniteError):
        T.signed_distance([0.0, np.nan, 0.0])
    with pytest.raises(InvalidInputError):
        Terrain.slope(math.pi / 2)
    with pytest.raises(InvalidInputError):
        Terrain.slope(0.1, (0.0, 0.0))
    with pytest.raises(InvalidInputError):
        Terrain.steps(step_length=0.0)
    with pytest.raises(InvalidInputError):
        Terrain.random(seed=-1)
    with pytest.raises(CoopGAError):
        Terrain.from_arrays({"terrain_kind": np.array("flat")})
    with pytest.raises(InvalidInputError):
        Terrain("flat", np.zeros(0), np.zeros(0), np.array([[[1.0, 0.0, 0.0, 0.0]]]))  # a vertical "ground"
