"""The carried box: its pose follows the grasp points rigidly, and its closed-form clearances equal coal's."""

from __future__ import annotations

import numpy as np
import pytest

from coop_ga.collision import Plane, Sphere
from coop_ga.errors import DegeneratePrimitiveError, InvalidInputError
from coop_ga.plan.carried import CarriedBox, box_sphere_distance, points_frame


def _rotation(rng) -> np.ndarray:
    Q, R = np.linalg.qr(rng.standard_normal((3, 3)))
    Q = Q * np.sign(np.diag(R))
    return Q if np.linalg.det(Q) > 0 else -Q


def test_pose_follows_a_rigid_motion_of_the_grasp_points(rng):
    P = np.array([[0.0, -0.3, 0.45], [0.26, 0.15, 0.45], [-0.26, 0.15, 0.45]])
    Rb, b = _rotation(rng), np.array([0.0, -0.06, 0.38])
    box = CarriedBox([0.26, 0.24, 0.1], Rb, b, P)
    R0, c0 = box.pose(P)
    assert np.allclose(R0, Rb, atol=1e-12) and np.allclose(c0, b, atol=1e-12)
    R, t = _rotation(rng), rng.standard_normal(3)
    R1, c1 = box.pose(P @ R.T + t)
    assert np.allclose(R1, R @ Rb, atol=1e-12) and np.allclose(c1, R @ b + t, atol=1e-12)
    with pytest.raises(DegeneratePrimitiveError, match="collinear"):
        points_frame(np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]]))
    with pytest.raises(InvalidInputError, match="positive"):
        CarriedBox([0.1, 0.0, 0.1], Rb, b, P)


def test_clearances_equal_coal(rng):
    coal = pytest.importorskip("coal")
    half = np.array([0.2, 0.15, 0.05])
    for _ in range(40):
        R, c = _rotation(rng), rng.uniform(-0.1, 0.1, 3)
        s = c + rng.uniform(-0.35, 0.35, 3)
        rad = float(rng.uniform(0.01, 0.08))
        T1, T2 = coal.Transform3s(), coal.Transform3s()
        T1.setRotation(R)
        T1.setTranslation(c)
        T2.setTranslation(s)
        d = box_sphere_distance(half, R, c, s, rad)
        ref = coal.distance(coal.Box(2 * half), T1, coal.Sphere(rad), T2, coal.DistanceRequest(), coal.DistanceResult())
        if ref > 0:  # coal's penetration depth of a deep overlap is its own estimate: compare signs there
            assert abs(d - ref) < 1e-9
        else:
            assert d <= 1e-12
    P = np.array([[0.0, -0.3, 0.45], [0.26, 0.15, 0.45], [-0.26, 0.15, 0.45]])
    box = CarriedBox(half, np.eye(3), [0.0, 0.0, 0.4], P, [Plane([0, 0, 1.0], 0.3), Sphere([0, 0, 0.7], 0.05)])
    assert np.allclose(box.clearances(P), [0.4 - 0.05 - 0.3, 0.7 - 0.05 - 0.45], atol=1e-12)
