"""coop_ga's cooperative similarity task inside pink: pink.solve_ik (with pink's posture task and limits) reaches the
primitive coop_ga's Gauss–Newton IK reaches, on the three Frankas' circle."""

from __future__ import annotations

import numpy as np
import pytest

pink = pytest.importorskip("pink")

import coop_ga as cg  # noqa: E402
from coop_ga.adapters.pink import CoopGATask, pink_configuration, similarity_task  # noqa: E402
from coop_ga.control import Configuration, PositionTask, displaced_target, gauss_newton_ik  # noqa: E402
from coop_ga.errors import InvalidInputError  # noqa: E402
from coop_ga.geometry.similarity import primitive_parameters  # noqa: E402

DT = 0.01


@pytest.fixture(scope="module")
def circle(load_system):
    task = cg.cooperative_task(load_system("three_franka"), "circle")
    q0 = np.asarray(task.system.q0, dtype=float)
    return task, q0


def _pink_reach(task, q0, target, steps=100):
    """pink.solve_ik with the wrapped similarity task, pink's PostureTask and pink's limits (DAQP)."""
    from pink.limits import ConfigurationLimit, VelocityLimit
    from pink.tasks import PostureTask

    cfg = pink_configuration(task, q0)
    sim = similarity_task(task, target)
    posture = PostureTask(cost=1e-6)  # a small pull to q0 in the redundant directions
    posture.set_target(q0)
    limits = [ConfigurationLimit(cfg.model), VelocityLimit(cfg.model)]
    errors = [float(np.linalg.norm(sim.compute_error(cfg)))]
    for _ in range(steps):
        v = pink.solve_ik(cfg, [sim, posture], DT, solver="daqp", damping=1e-12, limits=limits)
        cfg.update(cfg.integrate(v, DT))
        errors.append(float(np.linalg.norm(sim.compute_error(cfg))))
        if errors[-1] < 1e-11:
            break
    return cfg, np.array(errors)


@pytest.mark.parametrize("scale", [1.15, 0.9])
def test_pink_reaches_the_primitive_of_coop_ga_ik(circle, scale):
    task, q0 = circle
    target = displaced_target(task, q0, translation=(0.05, -0.03, 0.04), axis=(1, 1, 0), angle=0.3, scale=scale)
    gn = gauss_newton_ik(task, q0, target)
    cfg, errors = _pink_reach(task, q0, target)
    assert gn.converged and errors[0] > 0.2
    assert errors[-1] < 1e-10, errors[-5:]  # pink converged (12 and 19 steps here)
    lim = task.system.limits
    assert np.all(cfg.q >= lim.lower - 1e-9) and np.all(cfg.q <= lim.upper + 1e-9)
    # the same circle: center, radius and normal to 1e-9 (m, m, 1); the joints may differ (redundancy)
    _, c1, r1, n1 = primitive_parameters(task.primitive(cfg.q))
    _, c2, r2, n2 = primitive_parameters(task.primitive(gn.q))
    assert np.abs(np.asarray(c1) - np.asarray(c2)).max() < 1e-9
    assert abs(float(r1) - float(r2)) < 1e-9
    assert np.abs(np.asarray(n1) - np.asarray(n2)).max() < 1e-9


def test_the_pink_task_has_coop_gas_error_and_jacobian(circle):
    task, q0 = circle
    q = q0 + np.random.default_rng(7).uniform(-0.1, 0.1, task.nq)
    target = displaced_target(task, q0, translation=(0.02, 0.0, 0.03), axis=(0, 0, 1), angle=0.2, scale=1.1)
    cfg = pink_configuration(task, q)
    exact, body = similarity_task(task, target), similarity_task(task, target, jacobian="body", cost=2.0, gain=0.5)
    np.testing.assert_allclose(exact.compute_error(cfg), -task.error(q, target), rtol=0, atol=1e-14)
    np.testing.assert_allclose(exact.compute_jacobian(cfg), -task.error_jacobian(q, target), rtol=0, atol=1e-13)
    np.testing.assert_allclose(body.compute_jacobian(cfg), task.jacobian(q), rtol=0, atol=1e-13)
    H, c = body.compute_qp_objective(cfg)  # pink's ½‖W (J Δq + α e)‖²
    J, e = task.jacobian(q), -task.error(q, target)
    np.testing.assert_allclose(H, 4.0 * J.T @ J, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(c, 4.0 * 0.5 * J.T @ e, rtol=1e-12, atol=1e-12)
    # any coop_ga task wraps: an end point's position
    point = CoopGATask(task, PositionTask(1, np.zeros(3)))
    np.testing.assert_array_equal(point.compute_error(cfg), PositionTask(1, np.zeros(3)).error(Configuration(task, q)))
    # the system's own Pinocchio model is not touched by pink (it adds attributes to the model it is given)
    assert not hasattr(task.system.model, "tangent")


def test_bad_input_is_refused(circle, load_system):
    task, q0 = circle
    with pytest.raises(InvalidInputError, match="gain"):
        similarity_task(task, task.similarity(q0), gain=10.0)
    with pytest.raises(InvalidInputError, match="error"):
        CoopGATask(task, object())
    other = load_system("g1_arms")
    t = similarity_task(task, task.similarity(q0))
    with pytest.raises(InvalidInputError, match="nq"):
        t.compute_error(pink_configuration(other, other.q0))


def test_pink_barrier_bounds_the_cooperative_task(circle):
    """The circle moved 10 cm down while pink's PositionBarrier keeps arm 0's hand at most 5 cm lower: without the
    barrier pink reaches the target, with it the hand stops at the bound (to the discrete barrier's 1 mm)."""
    from pink.barriers import PositionBarrier
    from pink.limits import ConfigurationLimit, VelocityLimit
    from pink.tasks import PostureTask

    task, q0 = circle
    z_min = task.points(q0)[0, 2] - 0.05
    target = displaced_target(task, q0, translation=(0.0, 0.0, -0.10), axis=(0, 0, 1), angle=0.0, scale=1.0)
    lowest, final = {}, {}
    for use in (False, True):
        cfg = pink_configuration(task, q0)
        sim = similarity_task(task, target, gain=0.5)
        posture = PostureTask(cost=1e-6)
        posture.set_target(q0)
        barrier = PositionBarrier(task.end_frames[0], indices=[2], p_min=np.array([z_min]), gain=np.array([10.0]))
        limits = [ConfigurationLimit(cfg.model), VelocityLimit(cfg.model)]
        z = []
        for _ in range(200):
            v = pink.solve_ik(
                cfg,
                [sim, posture],
                DT,
                solver="daqp",
                damping=1e-12,
                limits=limits,
                barriers=[barrier] if use else None,
            )
            cfg.update(cfg.integrate(v, DT))
            z.append(task.points(cfg.q)[0, 2])
        lowest[use], final[use] = min(z), float(np.linalg.norm(sim.compute_error(cfg)))
    assert final[False] < 1e-9 and lowest[False] < z_min - 0.04
    assert lowest[True] > z_min - 1e-3 and final[True] > 0.05  # the target is out of reach: not reported as reached


def test_pink_holds_the_relative_orientation_of_two_hands(load_system):
    """The dual task space's relative orientation (a coop_ga DualTask) and the G1 hands' point pair, both as pink
    tasks: pink reaches the pair's target with the hands' relative orientation kept."""
    from pink.limits import ConfigurationLimit, VelocityLimit

    from coop_ga.control.tasks import DualTask, DualTaskSpace

    task = cg.cooperative_task(load_system("g1_arms"), "point_pair")
    q0 = np.asarray(task.system.q0, dtype=float)
    space = DualTaskSpace(task)
    target = displaced_target(task, q0, translation=(0.05, 0.0, 0.08), axis=(0, 0, 1), angle=0.5, scale=1.0)
    drift, final = {}, {}
    for hold in (False, True):
        cfg = pink_configuration(task, q0)
        sim = similarity_task(task, target, gain=0.1)
        relative = CoopGATask(task, DualTask(space, "relative", space.relative(q0), components="orientation"))
        limits = [ConfigurationLimit(cfg.model), VelocityLimit(cfg.model)]
        worst = 0.0
        for _ in range(200):
            tasks = [sim, relative] if hold else [sim]
            cfg.update(cfg.integrate(pink.solve_ik(cfg, tasks, DT, solver="daqp", damping=1e-9, limits=limits), DT))
            worst = max(worst, float(np.linalg.norm(relative.compute_error(cfg))))
        assert np.linalg.norm(sim.compute_error(cfg)) < 1e-8
        drift[hold], final[hold] = worst, float(np.linalg.norm(relative.compute_error(cfg)))
    assert final[False] > np.deg2rad(2.0) and final[True] < 1e-9
    assert drift[True] < 0.05 * drift[False], drift
