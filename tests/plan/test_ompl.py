"""OMPL constrained planning of the box lift, every waypoint checked by independent means: Pinocchio forward
kinematics and closed-form geometry (the grasp distances, the circle's circumcentre and normal), and coal
distances between the arms' collision meshes, the box and the obstacles."""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("ompl")
coal = pytest.importorskip("coal")

from coop_ga.collision import link_meshes  # noqa: E402
from coop_ga.errors import InvalidInputError  # noqa: E402
from coop_ga.plan import Validity, plan  # noqa: E402
from coop_ga.plan.box_lift import BOX_LIFT_OPTIONS, TILT, box_lift_problem  # noqa: E402
from coop_ga.plan.ompl import _constraint_class, _ompl  # noqa: E402
from coop_ga.plan.projection import project  # noqa: E402
from coop_ga.plan.regions import RegionSample, Stack  # noqa: E402


@pytest.fixture(scope="module")
def scene():
    return box_lift_problem()


@pytest.fixture(scope="module")
def result(scene):
    r = plan(scene.problem, BOX_LIFT_OPTIONS, seed=3, time_limit=60.0)  # a loaded CI machine: time is not tested
    assert r.success, r.message
    return r


def _tcps(system, Q):
    import pinocchio as pin

    model, data = system.model, system.model.createData()
    fids = [model.getFrameId(f) for f in system.end_frames]
    out = []
    for q in Q:
        pin.framesForwardKinematics(model, data, q)
        out.append([data.oMf[f].translation.copy() for f in fids])
    return np.array(out)  # (N, 3, 3)


def _circumcircle(P):
    a, b, c = P
    u, v = b - a, c - a
    w = np.cross(u, v)
    centre = a + (u @ u * np.cross(v, w) + v @ v * np.cross(w, u)) / (2 * w @ w)
    return centre, w / np.linalg.norm(w)


def _kabsch(A, B):
    """R, t minimising |R A_i + t − B_i|."""
    ca, cb = A.mean(0), B.mean(0)
    U, _, Vt = np.linalg.svd((A - ca).T @ (B - cb))
    D = np.diag([1, 1, np.sign(np.linalg.det(Vt.T @ U.T))])
    R = Vt.T @ D @ U.T
    return R, cb - R @ ca


def test_path_holds_the_grasp_limits_and_region_by_pinocchio_and_closed_form(scene, result):
    p, o = scene.problem, BOX_LIFT_OPTIONS
    Q = result.path
    assert len(Q) >= 10 and np.all(np.isfinite(Q))
    seg = np.linalg.norm(np.diff(Q, axis=0), axis=1)
    assert np.max(seg) <= 1.01 * o.delta  # interpolated at the collision-check resolution
    assert np.allclose(Q[0], p.q_start)
    lim = p.system.limits
    assert np.all(Q >= lim.lower) and np.all(Q <= lim.upper)
    P = _tcps(p.system, Q)
    d = np.linalg.norm(P[:, [0, 0, 1]] - P[:, [1, 2, 2]], axis=2)
    d0 = d[0]
    assert np.max(np.abs(d - d0)) <= 10 * o.tolerance  # the rigid grasp (three TCP distances)
    assert result.max_violation <= 10 * o.tolerance
    tilts = [math.acos(_circumcircle(Pk)[1][2]) for Pk in P]
    assert max(tilts) <= TILT + 1e-6  # the path region: upright within 10°
    c_end, _ = _circumcircle(P[-1])
    g = p.goal
    assert np.all(c_end >= g.lower - 1e-6) and np.all(c_end <= g.upper + 1e-6)  # in the goal region
    c_start, _ = _circumcircle(P[0])
    assert 0.19 - 1e-6 <= c_end[2] - c_start[2] <= 0.21 + 1e-6  # lifted 0.2 m


def _bvh(V):
    from scipy.spatial import ConvexHull

    h = ConvexHull(V)
    m = coal.BVHModelOBBRSS()
    m.beginModel(len(h.simplices), len(V))
    m.addVertices(np.asarray(V, float))
    m.addTriangles(h.simplices.astype(int))
    m.endModel()
    return m


def _T(R=None, t=None):
    T = coal.Transform3s()
    if R is not None:
        T.setRotation(np.asarray(R, float))
    if t is not None:
        T.setTranslation(np.asarray(t, float))
    return T


def _dist(a, Ta, b, Tb) -> float:
    """coal's distance with a fresh result (a DistanceResult keeps the minimum over the calls it is given)."""
    return float(coal.distance(a, Ta, b, Tb, coal.DistanceRequest(), coal.DistanceResult()))


def test_path_is_collision_free_by_coal_meshes(scene, result):
    """The arms' collision meshes (convex hulls, which the capsules bound) against the shelf spheres and each
    other arm, and the box (Kabsch pose from the TCPs) against the shelf and the table half-space, by coal."""
    import pinocchio as pin

    p = scene.problem
    system = p.system
    meshes = {f: _bvh(V) for f, V in link_meshes(system).items()}
    model, data = system.model, system.model.createData()
    fid = {f: model.getFrameId(f) for f in meshes}
    arm = {f: f.split("_")[0] for f in meshes}
    shelf = [(coal.Sphere(s.radius), _T(t=s.center)) for s in scene.shelf]
    table = coal.Halfspace(scene.table.normal, scene.table.offset)
    box = coal.Box(2 * scene.box_half)
    P = _tcps(system, result.path)
    worst = {"shelf": np.inf, "arms": np.inf, "box_shelf": np.inf, "box_table": np.inf}
    for k, q in enumerate(result.path):
        pin.framesForwardKinematics(model, data, q)
        T = {f: _T(data.oMf[i].rotation, data.oMf[i].translation) for f, i in fid.items()}
        for f, m in meshes.items():
            for s, Ts in shelf:
                worst["shelf"] = min(worst["shelf"], _dist(m, T[f], s, Ts))
        if k % 4 == 0:  # arm–arm pairs (every fourth waypoint: 363 mesh pairs each)
            for f in meshes:
                for g in meshes:
                    if arm[f] < arm[g]:
                        worst["arms"] = min(worst["arms"], _dist(meshes[f], T[f], meshes[g], T[g]))
        R, t = _kabsch(P[0], P[k])
        Tb = _T(R, R @ scene.box_centre + t)
        worst["box_shelf"] = min(worst["box_shelf"], *(_dist(box, Tb, s, Ts) for s, Ts in shelf))
        worst["box_table"] = min(worst["box_table"], _dist(box, Tb, table, _T()))
    assert min(worst.values()) > 0.0 and max(worst.values()) < 1.0, worst
    assert worst["box_shelf"] < 0.1  # the box passes the lip closely: the obstacle shapes the path


def test_validity_agrees_with_its_parts_and_a_straight_lift_hits_the_shelf(scene):
    p = scene.problem
    v = Validity(p)
    assert v.reason(p.q_start) == ""
    c0 = scene.task.evaluate(p.q_start).log[4:7]
    up = p.goal.target(RegionSample(c0 + [0, 0, 0.2], np.array([0.0, 0.0, 1.0]), None))
    pr = project(Stack([p.path_constraint, up]), p.system, p.q_start)
    assert pr.converged
    assert v.reason(pr.q) == "carried box collision"  # the lip is in the way of a straight lift
    assert float(np.min(scene.box.clearances(_tcps(p.system, [pr.q])[0]))) < 0
    bad = p.q_start.copy()
    bad[3] = p.system.limits.upper[3] + 0.1
    assert v.reason(bad) == "outside the joint limits"
    with pytest.raises(InvalidInputError, match="not a valid start"):
        plan(type(p)(**{**p.__dict__, "q_start": pr.q}), BOX_LIFT_OPTIONS)


def test_exact_constraint_jacobian_equals_omplss_finite_differences(scene, result):
    ob, _, _ = _ompl()
    exact = _constraint_class(ob, True)(scene.problem.path_constraint, 1e-5)
    fd = _constraint_class(ob, False)(scene.problem.path_constraint, 1e-5)
    for q in result.path[:: max(1, len(result.path) // 4)]:
        Je, Jf = np.zeros((3, 21)), np.zeros((3, 21))
        exact.jacobian(q, Je)
        fd.jacobian(q, Jf)  # OMPL's own central differences of the Python function
        out = np.zeros(3)
        fd.function(q, out)
        assert np.max(np.abs(out)) < 1e-4
        assert np.max(np.abs(Je - Jf)) < 1e-6 and np.max(np.abs(Je)) > 0.1


@pytest.mark.parametrize(("planner", "space"), [("KPIECE1", "projected"), ("RRTConnect", "atlas")])
def test_other_ompl_planners_and_the_atlas_space_solve_the_box_lift(scene, planner, space):
    r = plan(scene.problem, BOX_LIFT_OPTIONS, planner=planner, space=space, seed=1, time_limit=60.0)
    assert r.success and r.valid and r.max_violation <= 10 * BOX_LIFT_OPTIONS.tolerance, r.message
    # OMPL's interpolation of an atlas path spaces its states by up to 1.04 δ (measured), of a projected one by δ
    assert np.max(np.linalg.norm(np.diff(r.path, axis=0), axis=1)) <= 1.1 * BOX_LIFT_OPTIONS.delta
    assert scene.problem.goal.contains(r.path[-1], 1e-6)


@pytest.mark.parametrize("name", ["hand_sphere_problem", "arms_line_problem"])
def test_the_hand_sphere_and_the_two_arm_line_scenes_plan(name):
    from coop_ga.plan import scenes

    problem = getattr(scenes, name)()
    r = plan(problem, scenes.SCENE_OPTIONS, seed=0, time_limit=60.0)
    assert r.success and r.valid and r.max_violation <= 10 * scenes.SCENE_OPTIONS.tolerance, r.message
    assert problem.goal.contains(r.path[-1], 1e-6) and not problem.goal.contains(r.path[0], 1e-3)
    assert np.max(np.abs(problem.path_constraint.evaluate(r.path[-1])[0])) <= 10 * scenes.SCENE_OPTIONS.tolerance


def test_toppra_times_the_path_within_the_limits(scene, result):
    pytest.importorskip("toppra")
    from coop_ga.plan.timing import time_parameterise

    lim = scene.problem.system.limits
    tm = time_parameterise(result.path, lim)
    assert tm.duration > 0 and np.allclose(tm.q[0], result.path[0]) and np.allclose(tm.q[-1], result.path[-1])
    assert np.max(np.abs(tm.qd[[0, -1]])) < 1e-9  # from rest to rest
    assert tm.velocity_excess == 0.0 and np.all(np.abs(tm.qd) <= lim.velocity + 1e-9)
    assert np.all(np.abs(tm.qdd) <= lim.acceleration * 1.01)  # TOPP-RA's constant-acceleration grid: ≤ 1 %
    err = max(np.max(np.abs(scene.problem.path_constraint.value(q))) for q in tm.q)
    assert err < 1e-3  # the spline between waypoints 0.05 rad apart leaves the grasp by < 1 mm
