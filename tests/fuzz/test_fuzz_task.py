"""Fuzz the task and controller API: for arbitrary inputs — finite, extreme, NaN/inf,
wrongly typed, wrongly shaped — (a) no NaN/inf is ever returned, (b) every exception is a CoopGAError,
(c) no input is mutated.  CI runs the ``default`` hypothesis profile; ``--hypothesis-profile=long`` runs
10 000 examples per property."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import coop_ga as cg
from coop_ga.control import diff_ik_step, displaced_target, gauss_newton_ik, impedance_torque, nullspace_step
from tests.cooperative.conftest import cartesian_system

NQ = 9  # three Cartesian chains (three prismatic joints each): exact control over the points

floats = st.one_of(
    st.floats(-2.0, 2.0),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0.0, -0.0, 1e-300, -1e-300, 1e300, -1e300, 1e-12, 5.0, -5.0]),
)
junk = st.one_of(
    st.none(),
    st.text(max_size=3),
    st.integers(-3, 3),
    st.booleans(),
    st.just({"a": 1}),
    st.lists(st.text(max_size=2), max_size=3),
    st.complex_numbers(max_magnitude=2.0),
)


def vectors(n: int):
    return st.one_of(
        st.lists(floats, min_size=n, max_size=n).map(np.array),
        st.lists(floats, min_size=0, max_size=n + 2).map(np.array),  # wrong lengths
        st.lists(floats, min_size=n, max_size=n),  # plain lists
        junk,
    )


@pytest.fixture(scope="module")
def task() -> cg.CooperativeTask:
    return cg.CooperativeTask(cartesian_system(3), "circle", codegen=False)


def _finite(out) -> bool:
    if isinstance(out, np.ndarray):
        return bool(np.all(np.isfinite(out)))
    if isinstance(out, (tuple, list)):
        return all(_finite(x) for x in out)
    if isinstance(out, float):
        return np.isfinite(out)
    if isinstance(out, cg.Similarity):
        return _finite(out.coeffs)
    if hasattr(out, "q") and hasattr(out, "error"):
        return _finite(np.asarray(out.q)) and np.isfinite(out.error)
    if hasattr(out, "well_definedness"):  # TaskState
        return _finite(out.coeffs) and _finite(out.jacobian)
    return True


def _call(f, *args):
    """Run f; the result must be finite, an exception must be a CoopGAError, the inputs must be unchanged."""
    before = copy.deepcopy(args)
    try:
        out = f(*args)
    except cg.CoopGAError:
        out = None
    for a, b in zip(args, before, strict=True):
        if isinstance(a, np.ndarray):
            assert isinstance(b, np.ndarray) and a.shape == b.shape
            assert np.array_equal(a, b, equal_nan=True), "an input array was modified"
    assert out is None or _finite(out), f"non-finite output {out!r}"
    return out


@given(q=vectors(NQ))
def test_fuzz_task_evaluations(task, q):
    target = task.similarity(np.zeros(NQ))
    for f in (
        task.evaluate,
        task.similarity,
        task.jacobian,
        task.points,
        task.log,
        task.primitive,
        lambda x: task.error_and_jacobian(x, target),
        lambda x: task.jdot_qdot(x, x),
        lambda x: task.evaluate_batch([x, x]),
        task.analytic_jacobian,
        task.bivector_jacobian,
    ):
        _call(f, q)


@given(b=st.lists(floats, min_size=7, max_size=7).map(np.array), scale=floats)
def test_fuzz_targets(task, b, scale):
    q = np.zeros(NQ)
    try:
        V = cg.Similarity.exp(b)
    except cg.CoopGAError:
        return
    for t in (V, V.versor.scale(scale) if np.isfinite(scale) else V.versor, V.coeffs, V.versor.grade(1)):
        _call(lambda x: task.error_and_jacobian(q, x), t)
        _call(lambda x: gauss_newton_ik(task, q, x, max_iter=2), t)
        _call(lambda x: nullspace_step(task, q, x, np.zeros(NQ)), t)


@given(q=vectors(NQ), command=vectors(7), dt=st.one_of(floats, junk), damping=st.one_of(floats, junk))
def test_fuzz_diff_ik_step(task, q, command, dt, damping):
    _call(lambda *a: diff_ik_step(task, *a), q, command, dt, damping)


@given(q=vectors(NQ), translation=vectors(3), angle=st.one_of(floats, junk), scale=st.one_of(floats, junk))
def test_fuzz_displaced_target(task, q, translation, angle, scale):
    _call(
        lambda *a: displaced_target(task, a[0], translation=a[1], angle=a[2], scale=a[3]), q, translation, angle, scale
    )


@given(qd=vectors(NQ), K=st.one_of(floats, junk))
def test_fuzz_impedance_gains(qd, K):
    s = cg.systems.load("three_franka")
    t = cg.cooperative_task(s, "circle")
    _call(
        lambda a, k: impedance_torque(
            t, s.q0, np.resize(a, s.nq) if isinstance(a, np.ndarray) else a, t.similarity(s.q0), K=k
        ),
        qd,
        K,
    )
