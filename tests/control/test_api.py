"""The controller API: Similarity targets, options dataclasses, one result base,
``damping`` = λ everywhere, warnings once per call at the caller's line."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

import coop_ga as cg
from coop_ga.control import (
    SOLVERS,
    ILQROptions,
    SolverResult,
    diff_ik_reach,
    displaced_target,
    gauss_newton_ik,
    ilqr_reach,
    impedance_torque,
    nullspace_step,
)
from coop_ga.control.gauss_newton import gauss_newton_step


@pytest.fixture(scope="module")
def franka(load_system):
    s = load_system("three_franka")
    task = cg.cooperative_task(s, "circle")
    q0 = np.array(s.q0)
    target = displaced_target(task, q0, translation=(0.05, 0.0, 0.03), axis=(1, 0, 0), angle=0.2, scale=1.1)
    return task, q0, target


#: the registered runners (coop_ga.control.SOLVERS): no hand-kept list
REACH_SOLVERS = [n for n, e in SOLVERS.items() if e.signature == "reach"]
#: the point runners that take a similarity (the one to hold)
HOLD_SOLVERS = [n for n, e in SOLVERS.items() if e.signature == "point" and "V_hold" in e.problem]
#: functions other than the registered runners that take a similarity
SIMILARITY_FUNCTIONS = ["error_and_jacobian", "error_hessian", "impedance_torque", "nullspace_step"]


def _problem(entry, task):
    """The problem data a runner cannot run without (a collision model of the task's system)."""
    from coop_ga.collision.model import CollisionModel

    out = {}
    if "collision_model" in entry.required:
        out["collision_model"] = CollisionModel(task.system, obstacles=[], self_collision=False)
    return out


def _solver_call(name, task, q0):
    """A registered runner as f(target), with its quick options."""
    e = SOLVERS[name]
    if e.signature == "reach":
        extra = _problem(e, task)
        return lambda V: e.solve(task, q0, V, **extra, **e.quick)
    return lambda V: e.solve(task, q0, 0, [0.3, 0, 0.5], V_hold=V, **e.quick)


def _controllers(task, q0):
    """Every public function that takes a similarity, as f(target)."""
    z = np.zeros(task.nq)
    out = {
        "error_and_jacobian": lambda V: task.error_and_jacobian(q0, V),
        "error_hessian": lambda V: task.error_hessian(q0, V, np.ones(7)),
        "impedance_torque": lambda V: impedance_torque(task, q0, z, V),
        "nullspace_step": lambda V: nullspace_step(task, q0, V, z),
    }
    for name in REACH_SOLVERS + HOLD_SOLVERS:
        out[name] = _solver_call(name, task, q0)
    return out


def _bad_targets(task, q0, target):
    X = target.apply(task.unit)
    vec = cg.Multivector.from_names({"e1": 1.0, "e2": 0.5})  # a vector, not a versor
    return {
        "primitive": (X, "Primitive"),
        "tuple": ((target, X), "tuple"),
        "zero": (cg.Multivector.zero(), "zero|not a similarity"),
        "zero_scalar": (cg.Multivector.scalar(0.0), "zero"),
        "vector": (vec, "not a similarity"),
        "coeffs": (target.coeffs, "from_coeffs"),
        "wrong_length": (np.ones(5), "from_coeffs"),
        "string": ("circle", "Similarity"),
        "none": (None, "Similarity"),
    }


@pytest.mark.parametrize("controller", SIMILARITY_FUNCTIONS + REACH_SOLVERS + HOLD_SOLVERS)
def test_bad_targets_raise_invalid_input_naming_the_problem(franka, controller):
    task, q0, target = franka
    f = _controllers(task, q0)[controller]
    for label, (bad, match) in _bad_targets(task, q0, target).items():
        if label == "none" and controller in HOLD_SOLVERS:
            continue  # V_hold=None means "hold V_Sc(q0)"
        with pytest.raises(cg.InvalidInputError, match=match):
            f(bad)
        assert label  # every case raised


@pytest.mark.parametrize("controller", [*REACH_SOLVERS, "nullspace_step"])
def test_targets_accept_similarity_multivector_and_subgroups(franka, controller):
    task, q0, target = franka
    f = _controllers(task, q0)[controller]
    a = f(target)
    b = f(target.versor.scale(3.7))  # a Multivector, positive multiple: converted and normalised
    qa = a if isinstance(a, np.ndarray) else a.q
    qb = b if isinstance(b, np.ndarray) else b.q
    np.testing.assert_allclose(qa, qb, atol=1e-10)
    V0 = task.similarity(q0)
    f(V0 @ cg.Motor.exp([0.0, 0.0, 0.05, 0.01, 0.0, 0.0]))  # Similarity @ Motor is a Similarity
    f(cg.Motor.exp([0.0, 0.0, 0.05, 0.01, 0.0, 0.0]))  # a Motor is accepted as a similarity


def test_displaced_target_returns_a_realisable_similarity(franka):
    task, q0, target = franka
    assert isinstance(target, cg.Similarity)
    r = gauss_newton_ik(task, q0, target)
    assert r.converged and r.error < 1e-9


def test_task_similarity_is_a_similarity(franka):
    task, q0, _ = franka
    V = task.similarity(q0)
    assert isinstance(V, cg.Similarity) and isinstance(task.evaluate(q0).similarity, cg.Similarity)
    np.testing.assert_allclose(V.log(), task.log(q0), atol=1e-14)
    np.testing.assert_allclose(cg.Similarity.from_coeffs(V.coeffs).coeffs, V.coeffs, atol=1e-15)


# ----------------------------------------------------------------------------- results and options
def test_results_share_the_base_fields(franka):
    task, q0, target = franka
    results = {
        "gn": gauss_newton_ik(task, q0, target),
        "ilqr": ilqr_reach(task, q0, target, horizon=20, max_iter=2),
    }
    for name, e in SOLVERS.items():
        if e.signature == "reach":
            results[name] = e.solve(task, q0, target, **_problem(e, task), **e.quick)
        else:
            results[name] = e.solve(task, q0, 0, [0.3, 0.0, 0.5], **e.quick)
    for name, r in results.items():
        assert isinstance(r, SolverResult), name
        assert r.q.shape == (task.nq,), name
        assert isinstance(r.converged, bool) and isinstance(r.iterations, int) and isinstance(r.message, str), name
        assert np.isfinite(r.error), name
        if hasattr(r, "trajectory"):
            np.testing.assert_array_equal(r.trajectory[-1], r.q)
            assert r.trajectory.shape[1] == task.nq
    assert results["gn"].error == pytest.approx(np.linalg.norm(task.error(results["gn"].q, target)), rel=1e-12)
    assert results["ilqr"].error == pytest.approx(np.linalg.norm(task.error(results["ilqr"].q, target)), rel=1e-12)


@pytest.mark.parametrize("name", list(SOLVERS))
def test_registered_runners_share_one_signature(name):
    """``fn(task, q_init, target | index, target_point, options=None, *, <problem data>, **overrides)``."""
    import inspect

    e = SOLVERS[name]
    params = list(inspect.signature(e.function).parameters.values())
    head = ["task", "q_init", "target"] if e.signature == "reach" else ["task", "q_init", "index", "target_point"]
    assert [p.name for p in params[: len(head) + 1]] == [*head, "options"], name
    assert all(p.kind is p.POSITIONAL_OR_KEYWORD for p in params[: len(head) + 1])
    rest = params[len(head) + 1 :]
    assert rest[-1].kind is inspect.Parameter.VAR_KEYWORD  # option overrides
    assert all(p.kind is p.KEYWORD_ONLY for p in rest[:-1]), name  # problem data: keywords, never positional
    assert {p.name for p in rest[:-1]} == set(e.problem), name
    assert dataclasses.is_dataclass(e.options)
    assert set(e.quick) <= {f.name for f in dataclasses.fields(e.options)}


def test_registry_resolves_aliases_and_refuses_unknown_names():
    from coop_ga.control import get_solver, register_solver

    assert get_solver("gn") is SOLVERS["gauss_newton_ik"] and get_solver("diffik") is SOLVERS["diff_ik_reach"]
    assert get_solver("ilqr").initial_velocity and not get_solver("gn").initial_velocity
    with pytest.raises(cg.UnknownNameError, match=r"registered: .*diff_ik_reach"):
        get_solver("newton")
    with pytest.raises(cg.InvalidInputError, match="already registered"):
        register_solver("gn", gauss_newton_ik, ILQROptions)


@pytest.mark.parametrize("name", list(SOLVERS))
def test_options_validate_every_numeric_field(name):
    cls = SOLVERS[name].options
    cls()  # the defaults are valid
    for f in dataclasses.fields(cls):
        default = getattr(cls(), f.name)
        if isinstance(default, bool) or not isinstance(default, (int, float)) or f.name in ("R", "Q", "Qv"):
            continue
        for bad in (np.nan, "1.0", None):
            if bad is None and f.name == "max_speed":
                continue  # max_speed=None means no speed cap
            with pytest.raises(cg.InvalidInputError):
                cls(**{f.name: bad})


def test_unknown_option_is_refused(franka):
    task, q0, target = franka
    with pytest.raises(cg.InvalidInputError, match=r"unknown option.*max_iters"):
        gauss_newton_ik(task, q0, target, max_iters=3)
    with pytest.raises(cg.InvalidInputError, match="GaussNewtonOptions"):
        gauss_newton_ik(task, q0, target, ILQROptions())


def test_options_and_overrides_are_equivalent(franka):
    task, q0, target = franka
    a = ilqr_reach(task, q0, target, ILQROptions(horizon=30, max_iter=3))
    b = ilqr_reach(task, q0, target, horizon=30, max_iter=3)
    np.testing.assert_array_equal(a.u, b.u)


def test_damping_is_lambda_everywhere():
    rng = np.random.default_rng(5)
    J = rng.standard_normal((7, 12))
    e = rng.standard_normal(7)
    lam = 0.3
    ref_gn = -np.linalg.solve(J.T @ J + lam**2 * np.eye(12), J.T @ e)
    np.testing.assert_allclose(gauss_newton_step(e, J, lam), ref_gn, atol=1e-12)
    ref_pinv = J.T @ np.linalg.inv(J @ J.T + lam**2 * np.eye(7))
    np.testing.assert_allclose(cg.cooperative.damped_pinv(J, lam), ref_pinv, atol=1e-12)


# ----------------------------------------------------------------------------- warnings once per call
def test_one_warning_per_condition_and_call_at_the_callers_line():
    """Diff IK holding a nearly degenerate circle: one DegeneracyWarning per call (a flood of 104 before),
    pointing here, with the count in the result."""
    from tests.cooperative.conftest import BASES, cartesian_system

    task = cg.CooperativeTask(cartesian_system(3), "circle", codegen=False)
    q = (np.array([[0.0, 0, 0], [1.0, 0, 0], [2.0, 0.005, 0]]) - BASES[:3]).reshape(-1)  # nearly collinear
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        V0 = task.similarity(q)
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        r = diff_ik_reach(task, q, V0, steps=30, tol=0.0, limit_mode="none")
    deg = [w for w in rec if issubclass(w.category, cg.DegeneracyWarning)]
    assert len(deg) == 1, [str(w.message) for w in rec]
    assert deg[0].filename == __file__
    n = r.warnings.get("DegeneracyWarning:cartesian3", 0)
    assert n > 30  # every evaluation saw it (the start, then J and e at each of the 30 steps)
    assert f"occurred {n} times" in str(deg[0].message)


def test_chart_auto_solves_the_antipode_case(load_system):
    """The study's silent failure: g1_arms line with points=(1, 0) (axis −e2, the canonical chart's half-turn)
    and a 5 cm, 20° target.  chart_axis='auto' measures the chart from the nominal axis: every solver converges,
    without a ChartWarning; the canonical chart refuses to start there (ChartError), never a silent stall."""
    s = load_system("g1_arms")
    q0 = np.array(s.q0)
    task = cg.cooperative_task(s, "line", points=(1, 0))
    assert task.chart_axis is not None and task.chart_axis[1] == pytest.approx(-1.0)
    V = displaced_target(task, q0, translation=(0.05, 0.0, 0.0), axis=(0, 0, 1), angle=np.deg2rad(20))
    with warnings.catch_warnings():
        warnings.simplefilter("error", cg.ChartWarning)
        for solve in (gauss_newton_ik, ilqr_reach, diff_ik_reach):
            assert solve(task, q0, V).converged, solve.__name__
    canonical = cg.cooperative_task(s, "line", points=(1, 0), chart_axis=None)
    V0 = displaced_target(canonical, q0, translation=(0.05, 0.0, 0.0), axis=(0, 0, 1), angle=np.deg2rad(20))
    for solve in (gauss_newton_ik, ilqr_reach, diff_ik_reach):
        with pytest.raises(cg.ChartError, match="half-turn"), warnings.catch_warnings():
            warnings.simplefilter("ignore", cg.ChartWarning)
            solve(canonical, q0, V0)
    # the same primitive either way: the charts differ by a roll no primitive sees
    np.testing.assert_allclose(V.apply(task.unit).to_dense(), V0.apply(canonical.unit).to_dense(), atol=1e-12)


def test_target_across_the_chart_is_refused(load_system):
    s = load_system("three_franka")
    task = cg.cooperative_task(s, "circle")
    q0 = np.array(s.q0)
    flipped = displaced_target(task, q0, axis=(1, 0, 0), angle=np.deg2rad(178.0))  # normal turned over
    with pytest.raises(cg.ChartError, match="crosses the chart"):
        gauss_newton_ik(task, q0, flipped)
    n0 = np.asarray(cg.normal(task.primitive(q0)), float).reshape(3)
    n1 = np.asarray(cg.normal(flipped.apply(task.unit)), float).reshape(3)
    mid = task.with_chart(np.cross(n0, n1))  # an axis at 90° from both
    assert mid.chart_axis is not None
    mid.check_target(mid.target_from_primitive(flipped.apply(task.unit)))  # accepted in that chart
