"""Reliability of the runtime layer of the task and the controllers: one regression test per defect.

Items 1–3 (compile cache, CompiledFunction threads) are in ``test_compile_cache.py`` and
``test_codegen_threads.py``; items 5, 7 (geometry part), 10–12 in ``tests/geometry/test_reliability.py``.
"""

from __future__ import annotations

import threading

import numpy as np
import pytest

import coop_ga as cg
from coop_ga.control import (
    diff_ik_reach,
    displaced_target,
    gauss_newton_ik,
    ilqr_reach,
    impedance_torque,
    nullspace_step,
    simulate_impedance,
)
from coop_ga.cooperative import CooperativeTask
from tests.cooperative.conftest import BASES, cartesian_system


@pytest.fixture(scope="module")
def franka(load_system):
    s = load_system("three_franka")
    task = cg.cooperative_task(s, "circle")
    q0 = np.array(s.q0)
    return task, q0, displaced_target(task, q0, translation=(0.05, 0, 0), angle=0.1)


# ----------------------------------------------------------------------------- item 2
def test_item2_task_is_thread_safe(franka):
    """8 threads share the cached task: every result equals the serial one (was 4–229 of 12 000 wrong)."""
    task, q0, target = franka
    rng = np.random.default_rng(11)
    Q = q0 + rng.uniform(-0.3, 0.3, (400, task.nq))
    ref_J = np.array([task.jacobian(q) for q in Q])
    ref_e = np.array([task.error(q, target) for q in Q])
    ref_jd = np.array([task.jdot_qdot(q, 0.1 * q) for q in Q])
    ref_batch = task.evaluate_batch(Q[:50])[2]
    bad: list[str] = []

    def work(k: int) -> None:
        order = np.random.default_rng(k).permutation(len(Q))
        for i in order:
            if not np.array_equal(task.jacobian(Q[i]), ref_J[i]):
                bad.append(f"J {i}")
            if not np.array_equal(task.error(Q[i], target), ref_e[i]):
                bad.append(f"e {i}")
            if not np.array_equal(task.jdot_qdot(Q[i], 0.1 * Q[i]), ref_jd[i]):
                bad.append(f"jdot {i}")
        for _ in range(5):
            if not np.array_equal(task.evaluate_batch(Q[:50])[2], ref_batch):
                bad.append("batch")

    threads = [threading.Thread(target=work, args=(k,)) for k in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert bad == []


# ----------------------------------------------------------------------------- item 4
@pytest.mark.parametrize("scale", [1e-200, 1e-9, 1.0, 1e9, 1e200])
def test_item4_scaled_target_versors_give_the_same_finite_result(franka, scale):
    """A tiny- or huge-scaled target versor (a valid positive multiple) gave NaN; now it is normalised."""
    task, q0, target = franka
    e_ref = task.error(q0, target)
    Vs = target.versor.scale(scale)
    for f in (
        lambda V: task.error(q0, V),
        lambda V: gauss_newton_ik(task, q0, V, max_iter=3).q,
        lambda V: impedance_torque(task, q0, np.zeros(task.nq), V),
        lambda V: nullspace_step(task, q0, V, np.zeros(task.nq)),
    ):
        out = f(Vs)
        assert np.all(np.isfinite(out))
    np.testing.assert_allclose(task.error(q0, Vs), e_ref, atol=1e-12)


def test_item4_non_versor_targets_are_refused_by_every_route(franka):
    """A random non-versor (which log rejects) gave finite garbage in every controller."""
    task, q0, _ = franka
    rng = np.random.default_rng(4)
    from coop_ga.geometry.groups import SIMILARITY_BLADES

    junk = cg.Multivector(SIMILARITY_BLADES, tuple(rng.standard_normal(12)))
    routes = [
        lambda: task.error_and_jacobian(q0, junk),
        lambda: gauss_newton_ik(task, q0, junk),
        lambda: diff_ik_reach(task, q0, junk, steps=1),
        lambda: ilqr_reach(task, q0, junk, horizon=3),
        lambda: simulate_impedance(task, q0, junk, duration=0.001),
        lambda: impedance_torque(task, q0, np.zeros(task.nq), junk),
        lambda: nullspace_step(task, q0, junk, np.zeros(task.nq)),
    ]
    for r in routes:
        with pytest.raises(cg.InvalidInputError, match="not a similarity"):
            r()


# ----------------------------------------------------------------------------- item 6
@pytest.mark.parametrize(
    "call",
    [
        lambda t, q, V: diff_ik_reach(t, q, V, damping=np.nan),
        lambda t, q, V: diff_ik_reach(t, q, V, gain=np.nan),
        lambda t, q, V: gauss_newton_ik(t, q, V, armijo=np.nan),
        lambda t, q, V: gauss_newton_ik(t, q, V, damping=np.inf),
        lambda t, q, V: ilqr_reach(t, q, V, armijo=np.nan),
        lambda t, q, V: nullspace_step(t, q, V, np.zeros(t.nq), primary_gain=np.nan),
        lambda t, q, V: nullspace_step(t, q, V, np.zeros(t.nq), damping=np.nan),
        lambda t, q, V: cg.control.point_on_circle(t, q, 0, np.nan),
        lambda t, q, V: cg.control.command_to_bivector(np.zeros(6), translation_gain=np.nan),
        lambda t, q, V: cg.control.Teleoperator(t, q, rotation_gain=np.nan),
        lambda t, q, V: simulate_impedance(t, q, V, D_null=np.nan),
    ],
)
def test_item6_nan_parameters_are_refused(franka, call):
    task, q0, target = franka
    with pytest.raises(cg.InvalidInputError):
        call(task, q0, target)


def test_item6_jdot_qdot_raises_at_a_degenerate_configuration():
    task = CooperativeTask(cartesian_system(3), "circle", codegen=False)
    q = (np.array([[0.0, 0, 0], [1.0, 0, 0], [2.0, 0, 0]]) - BASES[:3]).reshape(-1)
    with pytest.raises(cg.DegeneratePrimitiveError):
        task.jdot_qdot(q, np.ones(task.nq))


# ----------------------------------------------------------------------------- item 7 (cooperative part)
@pytest.mark.parametrize("offset", [0.0, 1e3, 1e6])
def test_item7_cooperative_primitive_is_accurate_far_from_the_origin(offset):
    """A unit circle 10⁶ m away reported radius 3.87; the task builds X_c about the centroid."""
    task = CooperativeTask(cartesian_system(3), "circle", codegen=False)
    ang = np.array([0.0, 2.0, 4.0])
    pts = np.stack([np.cos(ang), np.sin(ang), np.zeros(3)], axis=1) + np.array([offset, -offset, 0.5 * offset])
    q = (pts - BASES[:3]).reshape(-1)
    S = task.similarity(q)
    assert S.scale == pytest.approx(1.0, rel=1e-9)
    np.testing.assert_allclose(S.translation, [offset, -offset, 0.5 * offset], rtol=1e-12, atol=1e-9)
    J = task.jacobian(q)
    assert np.all(np.isfinite(J))
    np.testing.assert_allclose(
        np.linalg.svd(J, compute_uv=False)[:6],
        np.linalg.svd(task.jacobian((pts - pts.mean(0) - BASES[:3]).reshape(-1)), compute_uv=False)[:6],
        rtol=1e-6,
    )


def test_item7_small_well_shaped_circles_are_accepted():
    task = CooperativeTask(cartesian_system(3), "circle", codegen=False)
    for r in (1e-3, 1e-5):
        ang = np.array([0.0, 2.0, 4.0])
        pts = r * np.stack([np.cos(ang), np.sin(ang), np.zeros(3)], axis=1) + 0.3
        S = task.similarity((pts - BASES[:3]).reshape(-1))
        assert S.scale == pytest.approx(r, rel=1e-8)


# ----------------------------------------------------------------------------- item 8
@pytest.mark.parametrize("q", [0.0, np.zeros(1), [0.0], np.zeros((1, 1))])
def test_item8_scalar_q_is_not_broadcast(franka, q):
    task, _, target = franka
    for f in (task.evaluate, lambda x: task.error_and_jacobian(x, target), lambda x: task.jdot_qdot(x, x)):
        with pytest.raises(cg.InvalidInputError, match="21 entries"):
            f(q)


# ----------------------------------------------------------------------------- item 9
BAD_VALUES = ["abc", {"a": 1}, ["a", "b"], None, object(), np.array(["x"] * 21), [1.0] * 20 + ["x"]]


@pytest.mark.parametrize("bad", BAD_VALUES, ids=lambda b: type(b).__name__)
def test_item9_bad_q_raises_coopga_error(franka, bad):
    task, q0, target = franka
    calls = [
        task.evaluate,
        task.jacobian,
        task.points,
        lambda x: task.error(x, target),
        lambda x: task.jdot_qdot(x, q0),
        lambda x: task.jdot_qdot(q0, x),
        lambda x: task.evaluate_batch(x),
        lambda x: gauss_newton_ik(task, x, target),
        lambda x: ilqr_reach(task, x, target),
        lambda x: diff_ik_reach(task, x, target),
        lambda x: displaced_target(task, x),
        lambda x: task.system.check_q(x),
        lambda x: cg.control.task_space_dynamics(task, x, q0),
    ]
    for c in calls:
        with pytest.raises(cg.CoopGAError):
            c(bad)


@pytest.mark.parametrize("bad", BAD_VALUES + [1.5, -1], ids=lambda b: type(b).__name__)
def test_item9_bad_options_raise_coopga_error(franka, bad):
    task, q0, target = franka
    for c in (
        lambda v: ilqr_reach(task, q0, target, horizon=v),
        lambda v: gauss_newton_ik(task, q0, target, max_iter=v),
        lambda v: diff_ik_reach(task, q0, target, steps=v),
        lambda v: ilqr_reach(task, q0, target, hessian=v),
    ):
        with pytest.raises(cg.CoopGAError):
            c(bad)


def test_item9_unknown_names_raise_coopga_error():
    with pytest.raises(cg.UnknownNameError):
        cg.systems.load("nope")
    with pytest.raises(cg.CoopGAError):
        cg.systems.load(None)  # type: ignore[arg-type]
    with pytest.raises(cg.CoopGAError):
        cg.cooperative_task("three_franka", "torus")


# ----------------------------------------------------------------------------- item 11 (task part)
@pytest.mark.parametrize("points", [(0.5, 1, 2), (0, 1, 1), (0, 1), ("0", "1", "2"), (True, 1, 2), 3])
def test_item11_points_are_not_coerced(franka, points):
    task, _, _ = franka
    with pytest.raises(cg.InvalidInputError, match="points"):
        cg.cooperative_task(task.system, "circle", points=points)
    with pytest.raises(cg.InvalidInputError, match="points"):
        CooperativeTask(task.system, "circle", points=points)
