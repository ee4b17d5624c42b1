"""Regions over the primitive's natural coordinates: read-outs against closed-form geometry, residual
Jacobians against central finite differences for every kind, sampling, and the projection onto them."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from coop_ga.cooperative import cooperative_task
from coop_ga.errors import DegeneratePrimitiveError, InvalidInputError
from coop_ga.geometry.similarity import primitive_parameters
from coop_ga.plan import Region, RigidGrasp, Stack, finite_difference_jacobian, readout
from coop_ga.plan.projection import project

#: kind → the system that has its end points (sphere kinds need four)
KIND_SYSTEMS = {
    "point": "three_franka",
    "point_pair": "three_franka",
    "line": "three_franka",
    "circle": "three_franka",
    "plane": "three_franka",
    "plane_fit": "three_franka",
    "sphere": "allegro",
    "sphere_fit": "allegro",
}


def _frame() -> np.ndarray:
    """A fixed region frame: rotated 0.5 rad about (1, −2, 3), origin (0.1, 0.2, 0.3)."""
    a = np.array([1.0, -2.0, 3.0]) / math.sqrt(14.0)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    H = np.eye(4)
    H[:3, :3] = np.eye(3) + math.sin(0.5) * K + (1 - math.cos(0.5)) * K @ K
    H[:3, 3] = [0.1, 0.2, 0.3]
    return H


def _setup(load_system, kind: str, seed: int = 0):
    s = load_system(KIND_SYSTEMS[kind])
    task = cooperative_task(s, kind)
    q = s.limits.clip(s.q0 + 0.1 * np.random.default_rng(seed).standard_normal(s.nq))
    return s, task, q


def _tight_region(task, q, frame=None) -> Region:
    """A region whose bounds every coordinate at q violates (so every Jacobian row is active)."""
    reg = Region(task, frame=frame)
    ro, x, _ = reg.coordinates(q)
    kw = {}
    if task.spec.axis is not None:
        kw.update(cone_axis=[0.3, -0.2, 1.0], cone_angle=0.05)
    if task.spec.has_radius:
        kw["log_scale"] = (ro.log_scale + 0.1, ro.log_scale + 0.2)
    return Region(task, x + 0.02, x + 0.05, frame=frame, **kw)


@pytest.mark.parametrize("kind", list(KIND_SYSTEMS))
def test_readout_matches_the_primitive(load_system, kind):
    _, task, q = _setup(load_system, kind)
    ro = readout(task, q)
    _, c, r, o = primitive_parameters(task.primitive(q))
    assert np.max(np.abs(np.array([float(v) for v in c]) - ro.centre)) < 1e-12
    if o is not None:
        assert np.max(np.abs(np.array([float(v) for v in o]) - ro.axis)) < 1e-12
    else:
        assert ro.axis is None
    if r is not None:
        assert abs(float(r) - ro.radius) < 1e-12 and abs(math.log(float(r)) - ro.log_scale) < 1e-12
    else:
        assert ro.log_scale is None


@pytest.mark.parametrize("kind", list(KIND_SYSTEMS))
def test_region_and_target_jacobians_match_finite_differences(load_system, kind, rng):
    _, task, q = _setup(load_system, kind)
    reg = _tight_region(task, q, frame=_frame())
    r, J = reg.evaluate(q)
    assert reg.dim == 3 + (task.spec.axis is not None) + task.spec.has_radius
    assert np.all(np.abs(r) > 1e-3)  # every row active
    Jfd = finite_difference_jacobian(reg, q, h=1e-6, central=True)
    assert np.max(np.abs(J - Jfd)) < 1e-7 * max(1.0, np.max(np.abs(J)))
    wide = Region(task, -1.0, 1.0, cone_axis=reg.cone_axis, cone_angle=0.05, log_scale=reg.beta, frame=_frame())
    tgt = reg.target(wide.sample(rng))
    r, J = tgt.evaluate(q)
    Jfd = finite_difference_jacobian(tgt, q, h=1e-6, central=True)
    assert np.max(np.abs(J - Jfd)) < 1e-7 * max(1.0, np.max(np.abs(J)))


@pytest.mark.parametrize("kind", ["point_pair", "circle", "plane", "sphere", "sphere_fit"])
def test_rigid_grasp_jacobian_matches_finite_differences(load_system, kind):
    s, task, q = _setup(load_system, kind)
    g = RigidGrasp(task, s.q0)
    n = len(task.end_frames)
    assert g.dim == min(n * (n - 1) // 2, 3 * n - 6 if n > 4 else n * (n - 1) // 2)
    r0, _ = g.evaluate(s.q0)
    assert np.max(np.abs(r0)) == 0.0
    r, J = g.evaluate(q)
    P = task.points(q)
    i, j = g.pairs[0]
    assert abs(r[0] + g.reference[0] - np.linalg.norm(P[i] - P[j])) < 1e-12  # Pinocchio points = the task's
    assert np.max(np.abs(J - finite_difference_jacobian(g, q, central=True))) < 1e-7
    if task.spec.has_radius:
        gs = RigidGrasp(task, s.q0, mode="scale")
        assert gs.dim == 1
        assert np.max(np.abs(gs.evaluate(q)[1] - finite_difference_jacobian(gs, q, central=True))) < 1e-7


def test_flat_centre_is_the_point_closest_to_the_frame_origin(load_system):
    _, task, q = _setup(load_system, "plane")
    H = _frame()
    _, x, _ = Region(task, frame=H).coordinates(q)
    ro = readout(task, q)
    world = H[:3, :3] @ x + H[:3, 3]
    assert abs((world - ro.centre) @ ro.axis) < 1e-12  # on the plane
    assert np.linalg.norm(np.cross(world - H[:3, 3], ro.axis)) < 1e-12  # along the normal from the origin


def test_contains_distance_and_sampling(load_system, rng):
    _, task, q = _setup(load_system, "circle")
    ro = readout(task, q)
    inside = Region(task, ro.centre - 0.01, ro.centre + 0.01, cone_axis=ro.axis, cone_angle=0.1,
                    log_scale=(ro.log_scale - 0.1, ro.log_scale + 0.1))  # fmt: skip
    assert inside.contains(q) and inside.distance(q) == 0.0
    assert not np.any(inside.evaluate(q)[1])
    above = Region(task, ro.centre + [0, 0, 0.03], ro.centre + [0, 0, 0.05])
    assert not above.contains(q) and abs(above.distance(q) - 0.03) < 1e-12
    tilted = Region(task, cone_axis=np.cross(ro.axis, [1.0, 0, 0]), cone_angle=0.2)
    assert abs(tilted.distance(q) - (math.pi / 2 - 0.2)) < 1e-9
    for _ in range(50):
        smp = inside.sample(rng)
        assert np.all(smp.centre >= inside.lower) and np.all(smp.centre <= inside.upper)
        assert smp.axis @ inside.cone_axis >= math.cos(0.1) - 1e-12 and abs(np.linalg.norm(smp.axis) - 1) < 1e-12
        assert inside.beta[0] <= smp.log_scale <= inside.beta[1]


@pytest.mark.parametrize("kind", ["line", "plane"])
def test_flat_samples_are_consistent_with_their_axis(load_system, kind, rng):
    _, task, _ = _setup(load_system, kind)
    reg = Region(task, -0.2, 0.2, cone_axis=[0.0, 0.3, 1.0] if kind == "plane" else [0.0, 1.0, 0.1], cone_angle=0.3,
                 frame=_frame())  # fmt: skip
    for _ in range(20):
        smp = reg.sample(rng)
        if kind == "line":  # the closest point to the origin is ⟂ to the direction
            assert abs(smp.centre @ smp.axis) < 1e-12
        else:  # and along the normal for a plane
            assert np.linalg.norm(np.cross(smp.centre, smp.axis)) < 1e-12
        assert np.all(smp.centre >= reg.lower - 1e-12) and np.all(smp.centre <= reg.upper + 1e-12)


def test_bad_regions_are_refused(load_system):
    s = load_system("allegro")
    sphere = cooperative_task(s, "sphere")
    with pytest.raises(InvalidInputError, match="no axis"):
        Region(sphere, cone_axis=[0, 0, 1])
    point = cooperative_task(load_system("three_franka"), "point")
    with pytest.raises(InvalidInputError, match="no radius"):
        Region(point, log_scale=(0, 1))
    with pytest.raises(InvalidInputError, match="lower ≤ upper"):
        Region(point, 1.0, 0.0)
    with pytest.raises(InvalidInputError, match="homogeneous"):
        Region(point, frame=2 * np.eye(4))
    with pytest.raises(InvalidInputError, match="finite centre bounds"):
        Region(point).sample(np.random.default_rng(0))
    with pytest.raises(InvalidInputError, match="one end point"):
        RigidGrasp(point, load_system("three_franka").q0)


def test_projection_reaches_sampled_goals_inside_the_limits(load_system, rng):
    s, task, _ = _setup(load_system, "circle")
    ro = readout(task, s.q0)
    reg = Region(task, ro.centre + [-0.03, -0.03, 0.15], ro.centre + [0.03, 0.03, 0.2], cone_axis=[0, 0, 1],
                 cone_angle=math.radians(10))  # fmt: skip
    grasp = RigidGrasp(task, s.q0)
    for _ in range(5):
        p = project(Stack([grasp, reg.target(reg.sample(rng))]), s, s.q0)
        assert p.converged, p.message
        assert reg.contains(p.q, 1e-6)
        assert np.max(np.abs(grasp.evaluate(p.q)[0])) < 1e-8
        assert s.limits.position_violation(p.q) == 0.0
    far = Region(task, ro.centre + [0, 0, 5.0], ro.centre + [0, 0, 5.1])  # out of reach: an honest failure
    p = project(far, s, s.q0)
    assert not p.converged and np.all(np.isfinite(p.q)) and p.error > 1.0


def test_projection_of_a_degenerate_start_is_a_failure_not_nan(load_system):
    s = load_system("three_franka")

    class Degenerate:
        nq, dim = s.nq, 1

        def evaluate(self, q):
            raise DegeneratePrimitiveError("the three end points are (nearly) collinear")

    p = project(Degenerate(), s, s.q0)
    assert not p.converged and "collinear" in p.message and np.all(np.isfinite(p.q))


def test_projection_on_a_free_flyer():
    """The floating G1 (nq = 24, nv = 23): the region and rigid-grasp residuals' Jacobians have nv columns along
    q ⊕ v (central differences through pinocchio.integrate); project() moves the pelvis by integrate to put the
    hands' midpoint into a box 0.5 m ahead, holding their distance (Pinocchio FK), the quaternion unit, the
    joints inside their limits."""
    import pinocchio as pin

    from coop_ga.systems import load

    s = load("g1_arms", free_flyer=True)
    task = cooperative_task(s, "point_pair")
    q0 = s.q0
    c0 = readout(task, q0).centre
    lo, hi = c0 + np.array([0.5, -0.05, 0.1]), c0 + np.array([0.6, 0.05, 0.2])
    region, grasp = Region(task, lo, hi), RigidGrasp(task, q0)
    stack = Stack([region, grasp])
    q1 = s.integrate(q0, 0.1 * np.random.default_rng(0).normal(size=s.nv))
    J = stack.evaluate(q1)[1]
    assert J.shape == (stack.dim, 23)
    assert np.abs(J - finite_difference_jacobian(stack, q1, central=True, system=s)).max() < 1e-6
    with pytest.raises(InvalidInputError, match="system="):
        finite_difference_jacobian(stack, q1)
    p = project(stack, s, q0)
    assert p.converged and p.error < 1e-8, p.message
    assert abs(np.linalg.norm(p.q[3:7]) - 1.0) < 1e-12 and np.linalg.norm(p.q[:3] - q0[:3]) > 0.3
    assert s.limits.position_violation(s.limit_coordinates(p.q)) == 0.0
    d = s.model.createData()

    def hands(q):
        pin.framesForwardKinematics(s.model, d, q)
        return np.array([d.oMf[s.model.getFrameId(f)].translation for f in s.end_frames])

    h0, h1 = hands(q0), hands(p.q)
    mid = h1.mean(axis=0)
    assert np.all(mid >= lo - 1e-8) and np.all(mid <= hi + 1e-8)
    assert abs(np.linalg.norm(h1[0] - h1[1]) - np.linalg.norm(h0[0] - h0[1])) < 1e-8


def _g1_hands(s, q):
    import pinocchio as pin

    d = s.model.createData()
    pin.framesForwardKinematics(s.model, d, q)
    return np.array([d.oMf[s.model.getFrameId(f)].translation for f in s.end_frames])


def test_ompl_plans_a_free_flyer_with_the_quaternion_embedded():
    """The floating G1 in OMPL's ambient R^24 with the quaternion kept unit by an extra constraint row: the
    ambient Jacobian equals central differences of the constraint function; RRTConnect carries the hands (their
    distance held) into a box 0.3 m ahead; along the interpolated path the quaternion is unit, the grasp holds
    (Pinocchio FK), the joints stay inside their limits and each step is at most delta along the manifold."""
    pytest.importorskip("ompl")
    from coop_ga.plan.ompl import PlannerOptions, PlanningProblem, _EmbeddedResidual, plan
    from coop_ga.systems import load

    s = load("g1_arms", free_flyer=True)
    task = cooperative_task(s, "point_pair")
    q0 = s.q0
    grasp = RigidGrasp(task, q0)
    emb = _EmbeddedResidual(grasp, s)
    q1 = s.integrate(q0, 0.1 * np.random.default_rng(1).normal(size=s.nv))
    r, J = emb.evaluate(q1)
    assert r.shape == (2,) and J.shape == (2, 24) and abs(r[1]) < 1e-14
    h = 1e-6
    fd = np.array([(emb.value(q1 + h * e) - emb.value(q1 - h * e)) / (2 * h) for e in np.eye(24)]).T
    assert np.abs(J - fd).max() < 1e-6
    c0 = readout(task, q0).centre
    lo, hi = c0 + np.array([0.3, -0.05, 0.1]), c0 + np.array([0.4, 0.05, 0.2])
    opts = PlannerOptions(time_limit=30.0, window=0.5, seed=0)
    res = plan(PlanningProblem(s, q0, grasp, Region(task, lo, hi)), opts)
    assert res.success and res.valid, res.message
    Q = res.path
    assert Q.shape[1] == 24 and np.abs(np.linalg.norm(Q[:, 3:7], axis=1) - 1.0).max() < 1e-12
    assert res.max_violation <= 10 * opts.tolerance
    d0 = np.linalg.norm(np.subtract(*_g1_hands(s, q0)))
    dev = max(abs(np.linalg.norm(np.subtract(*_g1_hands(s, q))) - d0) for q in Q)
    assert dev <= 10 * opts.tolerance
    mid = _g1_hands(s, Q[-1]).mean(axis=0)
    assert np.all(mid >= lo - 1e-6) and np.all(mid <= hi + 1e-6)
    assert s.limits.position_violation(s.limit_coordinates(Q)) == 0.0
    assert max(np.linalg.norm(s.difference(Q[k], Q[k + 1])) for k in range(len(Q) - 1)) <= 1.1 * opts.delta
    assert np.linalg.norm(Q[-1, :3] - q0[:3]) > 0.1  # the pelvis moved
    # the length sums tangent steps (metres and radians), not ‖Δq‖ with quaternion units
    tangent = sum(np.linalg.norm(pin.difference(s.model, Q[k], Q[k + 1])) for k in range(len(Q) - 1))
    assert res.length == pytest.approx(tangent, rel=1e-12)
