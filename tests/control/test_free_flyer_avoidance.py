"""Obstacle avoidance with a free flyer: the floating G1 reaches a point-pair target past a sphere that the plain
reaches run into, by the avoidance QP (differential IK) and by the iLQR's clearance cost (in its chart).

References: central differences through ``pinocchio.integrate`` (the clearance Jacobian, nv columns, and its rows
in the iLQR's chart), the closed-form segment–sphere distance of the capsules placed by Pinocchio's forward
kinematics (the clearances), Pinocchio's forward kinematics (the hands on the target).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import coop_ga as cg
from coop_ga.collision.distance import Sphere
from coop_ga.collision.model import CollisionModel
from coop_ga.control import avoidance_reach, diff_ik_reach, ilqr_reach
from coop_ga.control.avoidance import ClearanceCost
from coop_ga.control.ilqr.chart import ChartClearance, FlyerChart
from coop_ga.cooperative.targets import displaced_target
from coop_ga.systems.library import g1_floating

MOVE = {"translation": (0.6, 0.2, 0.3), "axis": (0.0, 0.0, 1.0), "angle": 0.4}
#: a sphere 8 cm above where the right hand passes a third of the way along the plain differential-IK reach
CENTER, RADIUS = np.array([0.95081039, 0.02713399, 0.48439615]), 0.05


@pytest.fixture(scope="module")
def scene():
    s = g1_floating()
    task = cg.cooperative_task(s, "point_pair")
    Vd = displaced_target(task, s.q0, **MOVE)
    cm = CollisionModel(s, obstacles=[Sphere(CENTER, RADIUS)], self_collision=False)
    return s, task, Vd, cm


def _hands(s, q) -> np.ndarray:
    d = s.model.createData()
    pin.framesForwardKinematics(s.model, d, q)
    return np.array([d.oMf[s.model.getFrameId(f)].translation for f in s.end_frames])


def _clearance(cm, q) -> float:
    """The smallest capsule–sphere clearance at q [m], in closed form from the capsules' segments (Pinocchio FK)."""
    A, B = cm.capsule_segments(q)
    L2 = np.einsum("ij,ij->i", B - A, B - A)
    t = np.clip(np.einsum("ij,ij->i", CENTER - A, B - A) / np.maximum(L2, 1e-300), 0.0, 1.0)  # a ball: A = B
    closest = A + t[:, None] * (B - A)
    radii = np.array([c.radius for c in cm.capsules])
    return float(np.min(np.linalg.norm(closest - CENTER, axis=1) - radii - RADIUS))


def _on_target(s, q, tol) -> None:
    p0 = _hands(s, s.q0)
    c = p0.mean(axis=0)
    R = pin.AngleAxis(MOVE["angle"], np.array(MOVE["axis"])).toRotationMatrix()
    assert np.abs(_hands(s, q) - ((p0 - c) @ R.T + c + np.array(MOVE["translation"]))).max() <= tol
    assert abs(np.linalg.norm(q[3:7]) - 1.0) <= 1e-12


def test_clearance_jacobian_has_nv_columns_equal_to_differences_through_integrate(scene) -> None:
    s, _, _, cm = scene
    q = s.random_q(np.random.default_rng(0), 0.2)
    d, J = cm.distances_and_jacobian(q)
    assert J.shape == (cm.n, s.nv) and abs(d.min() - _clearance(cm, q) + cm.margin) <= 1e-12
    h = 1e-6
    fd = np.array([(cm.distances(s.integrate(q, h * e)) - cm.distances(s.integrate(q, -h * e))) / (2 * h)
                   for e in np.eye(s.nv)]).T  # fmt: skip
    assert np.abs(fd - J).max() <= 1e-8 and np.abs(J[:, :6]).max() > 0.5  # the flyer's columns move the capsules


def test_clearance_rows_in_the_chart_equal_differences(scene) -> None:
    s, _, _, cm = scene
    rng = np.random.default_rng(1)
    chart = FlyerChart(s, s.q0)
    cost = ClearanceCost(cm, weight=1e4, activation=1.0)
    cc = ChartClearance(cost, chart)
    X = chart.c + 0.2 * rng.standard_normal((3, s.nv))
    k, v, J = cc.trajectory_rows(X)
    assert k.size > 0 and J.shape == (k.size, s.nv)
    h = 1e-6
    for r in range(0, k.size, max(1, k.size // 5)):
        row = int(np.argmin(np.abs(cm.distances(chart.to_q(X[k[r]])) - (1.0 - v[r]))))  # the pair of row r
        dist = lambda x: cm.distances(chart.to_q(x))[row]  # noqa: E731
        fd = [(dist(X[k[r]] + h * e) - dist(X[k[r]] - h * e)) / (2 * h) for e in np.eye(s.nv)]
        assert np.abs(np.array(fd) - J[r]).max() <= 1e-8
    c, g, _, _ = cc.evaluate(X[0])
    assert c == pytest.approx(cost.value(chart.to_q(X[0])), rel=1e-15) and g.shape == (s.nv,)


def test_avoidance_reach_keeps_clear_with_the_floating_base(scene) -> None:
    s, task, Vd, cm = scene
    plain = diff_ik_reach(task, s.q0, Vd, steps=400)
    assert plain.converged and min(_clearance(cm, q) for q in plain.trajectory) < -0.005  # runs into the sphere
    r = avoidance_reach(task, s.q0, Vd, collision_model=cm, steps=400)
    assert r.converged, r.message
    _on_target(s, r.q, 1e-3)
    assert r.min_clearance > 0.005 and min(_clearance(cm, q) for q in r.trajectory) == pytest.approx(r.min_clearance)
    assert np.linalg.norm(r.q[:3] - s.q0[:3]) > 0.3  # with the pelvis
    assert s.limits.position_violation(s.limit_coordinates(r.trajectory)) == 0.0


def test_ilqr_clearance_cost_with_the_floating_base(scene) -> None:
    s, task, Vd, cm = scene
    plain = ilqr_reach(task, s.q0, Vd, horizon=60, dt=0.025)
    assert plain.converged and min(_clearance(cm, q) for q in plain.trajectory) < -0.005
    r = ilqr_reach(task, s.q0, Vd, horizon=60, dt=0.025, clearance=ClearanceCost(cm, weight=1e4, activation=0.05))
    assert r.converged and r.error < 1e-5, r.message
    _on_target(s, r.q, 1e-5)
    assert r.trajectory.shape == (61, 24) and r.min_clearance > 0.005
    assert min(_clearance(cm, q) for q in r.trajectory[1:]) == pytest.approx(r.min_clearance, abs=1e-12)
