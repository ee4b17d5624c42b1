"""The task object: compiled route, batch API, bad input and geometric singularities (§5.3)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import coop_ga as cg
from coop_ga import systems
from coop_ga.codegen import gcc_available
from coop_ga.cooperative import CooperativeTask, cooperative_task


def test_definition_of_the_task_api() -> None:
    """primitive/similarity/log/jacobian agree with each other and with Eq 28."""
    sys = systems.load("three_franka")
    task = cooperative_task(sys, "circle")
    q = sys.q0 + 0.1
    X = task.primitive(q)
    V = task.similarity(q)
    # X_c = V X_u Ṽ (Eq 28)
    Y = cg.geometry.apply(V, cg.unit_primitive("circle"))
    k = (X.to_dense() @ Y.to_dense()) / (Y.to_dense() @ Y.to_dense())
    np.testing.assert_allclose(X.to_dense(), k * Y.to_dense(), atol=1e-12)
    assert k > 0
    np.testing.assert_allclose(task.log(q), cg.geometry.log(V), atol=1e-12)
    pts = sys.end_points(q)
    np.testing.assert_allclose(task.points(q), pts, atol=1e-12)
    # closed-form circumcircle radius / centre of the three TCPs
    a, b, c = pts
    ab, ac = b - a, c - a
    n = np.cross(ab, ac)
    ctr = a + (np.dot(ac, ac) * np.cross(n, ab) + np.dot(ab, ab) * np.cross(ac, n)) / (2 * n @ n)
    np.testing.assert_allclose(cg.center(X), ctr, atol=1e-12)
    np.testing.assert_allclose(np.exp(task.log(q)[3]), np.linalg.norm(a - ctr), rtol=1e-12)


@pytest.mark.skipif(not gcc_available(), reason="needs gcc")
def test_compiled_route_matches_vm() -> None:
    sys = systems.load("three_franka")
    fast = cooperative_task(sys, "circle", codegen=True)
    vm = CooperativeTask(sys, "circle", codegen=False)
    rng = np.random.default_rng(0)
    for _ in range(5):
        q = sys.random_q(rng, 0.5)
        a, b = fast.evaluate(q), vm.evaluate(q)
        np.testing.assert_allclose(a.coeffs, b.coeffs, atol=1e-13)
        np.testing.assert_allclose(a.jacobian, b.jacobian, atol=1e-12)
    assert fast.compiled.codegen


def test_batch_equals_sequential() -> None:
    sys = systems.load("three_franka")
    task = CooperativeTask(sys, "circle", codegen=False)
    rng = np.random.default_rng(4)
    Q = np.array([sys.random_q(rng, 0.5) for _ in range(6)])
    V, B, J = task.evaluate_batch(Q)
    assert V.shape == (6, 12) and B.shape == (6, 7) and J.shape == (6, 7, sys.nq)
    for i, q in enumerate(Q):
        st = task.evaluate(q)
        np.testing.assert_allclose(V[i], st.coeffs, atol=1e-13)
        np.testing.assert_allclose(B[i], st.log, atol=1e-13)
        np.testing.assert_allclose(J[i], st.jacobian, atol=1e-13)


def test_bad_input_raises_named_errors() -> None:
    sys = systems.load("three_franka")
    task = CooperativeTask(sys, "circle", codegen=False)
    with pytest.raises(cg.InvalidInputError, match="21 entries"):
        task.jacobian(np.zeros(20))
    q = sys.q0.copy()
    q[4] = np.nan
    with pytest.raises(cg.NonFiniteError, match=r"\[4\]"):
        task.log(q)
    with pytest.raises(cg.InvalidInputError, match="needs 4 end points"):
        CooperativeTask(sys, "sphere")
    with pytest.raises(cg.UnknownNameError, match="circle"):
        CooperativeTask(sys, "ellipse")
    with pytest.raises(cg.InvalidInputError, match="distinct indices"):
        CooperativeTask(sys, "point_pair", points=(0, 0))
    with pytest.raises(cg.NonFiniteError):
        task.evaluate_batch(np.full((2, 21), np.nan))
    # nothing the user passes in is modified
    q = sys.q0.copy()
    q0 = q.copy()
    task.jacobian(q)
    np.testing.assert_array_equal(q, q0)


def test_nan_in_unused_chain_is_still_reported(cartesian4) -> None:
    task = CooperativeTask(cartesian4, "circle", codegen=False)  # chain 3 is unused
    q = np.zeros(cartesian4.nq)
    q[-1] = np.nan
    with pytest.raises(cg.NonFiniteError):
        task.jacobian(q)


@pytest.mark.parametrize(
    "kind,move",
    [
        ("point_pair", lambda p: {1: p[0]}),  # coincident
        ("line", lambda p: {1: p[0]}),
        ("circle", lambda p: {2: 2 * p[1] - p[0]}),  # collinear
        ("plane", lambda p: {2: 2 * p[1] - p[0]}),
        ("sphere", lambda p: {3: p[0] + 0.3 * (p[1] - p[0]) + 0.2 * (p[2] - p[0])}),  # coplanar
    ],
)
def test_degeneracy_raises_on_every_route(kind, move, cartesian4) -> None:
    from .conftest import BASES

    task = CooperativeTask(cartesian4, kind, codegen=False)
    q = np.zeros(cartesian4.nq)
    target = {i: np.asarray(x) for i, x in move(BASES).items()}
    for i, x in target.items():
        q[3 * i : 3 * i + 3] = x - BASES[i]
    routes = [
        task.similarity,
        task.log,
        task.jacobian,
        task.evaluate,
        task.jacobian_closed_form,
        task.jacobian_ad,
        task.similarity_numpy,
        lambda q: task.error(q, cg.geometry.exp(np.zeros(7))),
        lambda q: task.evaluate_batch(q[None, :]),
    ]
    for route in routes:
        with pytest.raises(cg.DegeneratePrimitiveError):
            route(q)
    # approaching degeneracy warns, with a finite answer.  For point pairs and lines the measure is
    # scale-free (d / (d + ε·max|p|)): two distinct points a few mm apart are
    # a well-defined (small) pair, so only coincidence within the floating-point resolution degenerates
    i, x = next(iter(target.items()))
    q_near = q.copy()
    q_near[3 * i : 3 * i + 3] += 3e-3  # just off the degenerate set
    if kind in ("point_pair", "line"):
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            B = task.log(q_near)  # 3 mm apart: fine
        assert task.well_definedness(q_near) > 0.99
    else:
        with pytest.warns(cg.DegeneracyWarning):
            B = task.log(q_near)
    assert np.all(np.isfinite(B))
    # far from it: silent
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        task.log(np.zeros(cartesian4.nq))


def test_well_definedness_measure_values(cartesian4) -> None:
    task = CooperativeTask(cartesian4, "circle", codegen=False)
    # the base points (1,0,0), (0,1,0), (−1,0,0): a right isoceles triangle
    # smallest altitude = 1/√2·… ; measure = (2A/ℓmax)/ℓmax/(√3/2) with 2A = 2, ℓmax = 2
    assert task.well_definedness(np.zeros(12)) == pytest.approx((2 / 2) / 2 / (np.sqrt(3) / 2))


def test_task_cache_returns_same_object() -> None:
    sys = systems.load("three_franka")
    assert cooperative_task(sys, "circle") is cooperative_task("three_franka", "circle")


def test_task_cache_is_bounded_and_keeps_the_most_recently_used(monkeypatch) -> None:
    """The cache held every task ever asked for (a sweep over systems grew without bound); it is an LRU of
    TASK_CACHE_SIZE tasks: the least recently used one goes first, a task dropped stays usable."""
    import gc
    import weakref

    from coop_ga.cooperative import task as task_module

    monkeypatch.setattr(task_module, "TASK_CACHE_SIZE", 3)
    monkeypatch.setattr(task_module, "_TASK_CACHE", task_module.OrderedDict())
    syss = [systems.cartesian_points(1) for _ in range(5)]
    opts = {"codegen": False}
    first = cooperative_task(syss[0], "point", **opts)
    for s in syss[1:3]:
        cooperative_task(s, "point", **opts)
    assert cooperative_task(syss[0], "point", **opts) is first  # a hit makes it the most recent
    for s in syss[3:]:
        cooperative_task(s, "point", **opts)  # two more: evicts syss[1] and syss[2], not syss[0]
    cache = task_module._TASK_CACHE
    assert len(cache) == 3
    assert [t.system for t in cache.values()] == [syss[0], syss[3], syss[4]]
    assert cooperative_task(syss[0], "point", **opts) is first
    dropped = weakref.ref(cooperative_task(syss[1], "point", **opts))  # rebuilt, evicting syss[3]'s task
    np.testing.assert_allclose(first.points(np.zeros(3)), [[1.0, 0.0, 0.0]])  # still usable
    for s in syss[2:]:
        cooperative_task(s, "point", **opts)
    gc.collect()
    assert dropped() is None  # evicted and unreferenced: freed, not kept by the cache


def test_overflowing_q_is_reported_as_too_large() -> None:
    task = CooperativeTask(systems.load("three_franka"), "circle", codegen=False)
    with pytest.raises(cg.InvalidInputError, match="too large"):
        task.evaluate(np.full(21, 1e200))


@pytest.mark.parametrize("name", systems.names())
def test_nominal_axis_is_far_from_the_chart_discontinuity(name: str) -> None:
    """At q0, the natural primitive's axis must not point near the antipode of the unit axis
    (−e2 for point pairs/lines, −e3 for circles/planes), where the minimal rotation of V_Sc
    jumps by a half-turn (g1_arms once had its hands ordered left → right: exactly −e2)."""
    sys = systems.load(name)
    kinds = {2: ("point_pair", "line"), 3: ("circle", "plane")}.get(
        min(sys.n_chains, 3) if sys.n_chains != 4 else 4, ()
    )
    for kind in kinds:
        task = CooperativeTask(sys, kind, codegen=False)
        theta = task.log(sys.q0)[:3]
        assert np.linalg.norm(theta) < np.deg2rad(150), (kind, np.rad2deg(np.linalg.norm(theta)))


def test_scalar_q_is_rejected_not_broadcast() -> None:
    task = CooperativeTask(systems.load("three_franka"), "circle", codegen=False)
    with pytest.raises(cg.InvalidInputError, match="21 entries"):
        task.jacobian(0.5)
    np.testing.assert_allclose(task.log(list(task.system.q0)), task.log(task.system.q0))


def test_chart_warning_near_the_antipodal_axis() -> None:
    """g1_arms ordered left → right points along −e2: the canonical chart's half-turn; a ChartWarning says so.
    The default chart ('auto') is measured from that axis instead, and is silent."""
    sys = systems.load("g1_arms")
    task = CooperativeTask(sys, "point_pair", points=(1, 0), codegen=False, chart_axis=None)
    with pytest.warns(cg.ChartWarning, match="half-turn"):
        task.log(sys.q0)
    auto = CooperativeTask(sys, "point_pair", points=(1, 0), codegen=False)
    assert auto.chart_axis is not None
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        auto.log(sys.q0)
    assert auto.chart_angle(sys.q0) < 1e-6 and task.chart_angle(sys.q0) > np.pi - 1e-6
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        CooperativeTask(sys, "point_pair", codegen=False).log(sys.q0)
