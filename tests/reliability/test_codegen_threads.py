"""Regression tests of defect 2 of the reliability campaign: ``CompiledFunction`` was not thread-safe.

All calls shared one set of input/output buffers, so 8 threads got silently wrong
results and batch evaluation from threads segfaulted.  Now every thread has its own
:class:`coop_ga.codegen.Binding`.  CasADi releases the GIL while evaluating, so these
threads really run the C code (and the VM) at the same time.

Each thread feeds its own random inputs (fixed integer seeds) through every public
calling convention; every result is compared for exact equality with a serial
evaluation of the same inputs afterwards (same code, so the same bits).
"""

from __future__ import annotations

import sys
import threading
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest

from coop_ga.codegen import CompiledFunction

from ._worker import make_function

N_THREADS = 8
N_CALLS = 1500


@pytest.fixture(scope="module")
def compiled_cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    d = tmp_path_factory.mktemp("thread_cache")
    mp = pytest.MonkeyPatch()
    mp.setenv("COOP_GA_CACHE", str(d))
    mp.delenv("COOP_GA_CODEGEN", raising=False)
    yield d
    mp.undo()


@pytest.fixture
def fast_switching() -> Iterator[None]:
    """Switch threads every 10 µs (default 5 ms) so the Python parts interleave as much as possible."""
    old = sys.getswitchinterval()
    sys.setswitchinterval(1e-5)
    yield
    sys.setswitchinterval(old)


def _function(variant: str, compiled_cache: Path) -> CompiledFunction:
    f = make_function("threads", depth=12)
    cf = CompiledFunction(f, codegen=variant == "compiled", fallback=False)
    assert cf.codegen is (variant == "compiled")
    return cf


def _call(cf: CompiledFunction, mode: int, x: np.ndarray, Y: np.ndarray) -> list[np.ndarray]:
    """One evaluation through one of the public calling conventions (copies of the outputs)."""
    if mode == 0:
        return list(cf(x, Y))
    if mode == 1:
        return [o.copy() for o in cf.call_views(x, Y)]
    if mode == 2:  # the hot-path API the task code uses
        b = cf.binding()
        np.copyto(b.flat_inputs[0], x)
        b.inputs[1][...] = Y
        b.eval()
        return [o.copy() for o in b.outputs]
    cf.inputs[0][:, 0] = x  # the properties: the calling thread's buffers
    cf.inputs[1][...] = Y
    cf.eval()
    return [o.copy() for o in cf.outputs]


def _run_threads(work: Callable[[int], object]) -> list:
    results: list = [None] * N_THREADS
    errors: list[BaseException] = []
    barrier = threading.Barrier(N_THREADS)

    def target(t: int) -> None:
        try:
            barrier.wait()
            results[t] = work(t)
        except BaseException as e:
            errors.append(e)

    threads = [threading.Thread(target=target, args=(t,)) for t in range(N_THREADS)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    if errors:
        raise errors[0]
    return results


@pytest.mark.parametrize("variant", ["compiled", "vm"])
def test_defect2_threads_get_correct_results(variant: str, compiled_cache: Path, fast_switching: None) -> None:
    cf = _function(variant, compiled_cache)
    bindings: dict[int, object] = {}  # the objects, not id()s: a finished thread's id could be reused

    def work(t: int) -> tuple[list, list]:
        rng = np.random.default_rng(100 + t)
        ins, outs = [], []
        for i in range(N_CALLS):
            x, Y = rng.normal(size=6), rng.normal(size=(3, 2))
            ins.append((x, Y))
            outs.append(_call(cf, (t + i) % 4, x, Y))
        bindings[t] = cf.binding()
        return ins, outs

    results = _run_threads(work)
    assert len({id(b) for b in bindings.values()}) == N_THREADS  # one binding per thread
    ref = CompiledFunction(cf.source, codegen=False) if variant == "vm" else cf
    n_checked = 0
    for ins, outs in results:
        for (x, Y), got in zip(ins, outs):
            want = ref(x, Y)  # serial, in the main thread
            assert len(got) == 2
            for g, w in zip(got, want):
                assert np.array_equal(g, w)
            n_checked += 1
    assert n_checked == N_THREADS * N_CALLS


def test_defect2_binding_is_per_thread_and_cheap_to_get(compiled_cache: Path) -> None:
    cf = _function("vm", compiled_cache)
    b = cf.binding()
    assert cf.binding() is b and cf.inputs is b.inputs and cf.outputs is b.outputs
    assert [a.shape for a in b.inputs] == [(6, 1), (3, 2)] and all(a.flags.f_contiguous for a in b.inputs)
    assert all(np.shares_memory(f, a) and f.ndim == 1 for f, a in zip(b.flat_inputs, b.inputs))
    other: list = []
    th = threading.Thread(target=lambda: other.append(cf.binding()))
    th.start()
    th.join()
    assert other[0] is not b and other[0].outputs[0] is not b.outputs[0]


@pytest.mark.parametrize("variant", ["compiled", "vm"])
@pytest.mark.parametrize("parallel", ["serial", "thread"])
def test_defect2_batch_map_threads(variant: str, parallel: str, compiled_cache: Path, fast_switching: None) -> None:
    """``Function.map`` over the (compiled or VM) function, wrapped as evaluate_batch does."""
    n = 24
    base = _function(variant, compiled_cache)
    F = base.function.map(n, "thread", 2) if parallel == "thread" else base.function.map(n, "serial")
    cf = CompiledFunction(F, codegen=False, check_finite=False)

    def work(t: int) -> tuple[list, list]:
        rng = np.random.default_rng(200 + t)
        ins, outs = [], []
        for _ in range(N_CALLS):
            X, Y = rng.normal(size=(6, n)), rng.normal(size=(3, 2 * n))
            cf.inputs[0][...] = X
            cf.inputs[1][...] = Y
            cf.eval()
            ins.append((X, Y))
            outs.append([o.copy() for o in cf.outputs])
        return ins, outs

    results = _run_threads(work)
    for ins, outs in results:
        for (X, Y), got in zip(ins, outs):
            for g, w in zip(got, cf(X, Y)):  # serial reference through the same map
                assert np.array_equal(g, w)
    # and the map agrees with the single function, column block by column block
    X, Y = results[0][0][-1]
    e, M = cf(X, Y)
    for k in (0, n - 1):
        ek, Mk = base(X[:, k], Y[:, 2 * k : 2 * k + 2])
        assert np.array_equal(e[:, k : k + 1], ek) and np.array_equal(M[:, k : k + 1], Mk)


def test_defect2_task_evaluate_batch_from_threads(fast_switching: None) -> None:
    """``CooperativeTask.evaluate_batch`` (the call that segfaulted) from 8 threads, VM task."""
    from coop_ga.cooperative import CooperativeTask
    from tests.cooperative.conftest import cartesian_system

    task = CooperativeTask(cartesian_system(3), "circle", codegen=False)
    n, calls = 16, 150

    def work(t: int) -> tuple[list, list]:
        rng = np.random.default_rng(300 + t)
        ins, outs = [], []
        for _ in range(calls):
            Q = rng.uniform(-0.3, 0.3, size=(n, task.nq))  # end points = bases + q: far from collinear
            ins.append(Q)
            outs.append(task.evaluate_batch(Q))
        return ins, outs

    results = _run_threads(work)
    for ins, outs in results:
        for Q, got in zip(ins, outs):
            for g, w in zip(got, task.evaluate_batch(Q)):
                assert np.array_equal(g, w)


def test_defect2_binding_created_concurrently_by_many_threads(compiled_cache: Path) -> None:
    """First use from many threads at once: each gets a working binding (casadi checkout under a lock)."""
    f = make_function("threads", depth=12)
    cf = CompiledFunction(f, codegen=True, fallback=False)
    x, Y = np.linspace(-1, 1, 6), np.arange(6.0).reshape(3, 2) / 6
    want = cf(x, Y)
    got = _run_threads(lambda t: cf(x, Y))
    for g in got:
        assert all(np.array_equal(a, b) for a, b in zip(g, want))
