"""Nested warning collectors leave the stack as themselves: no crash, no stale collector, no lost warning.

The iLQR restart nests three collectors: ``ilqr_reach``'s own, a silent one around the bounded
Gauss–Newton IK, and the IK's own.  With value equality (a dataclass ``==``) the IK's collector,
empty like ``ilqr_reach``'s, removed *that* one on exit; a warning raised later in the restarted
solve was then recorded by the stale IK collector only, ``ilqr_reach``'s exit raised
``ValueError: list.remove(x): x not in list``, and the stale collector swallowed every later
warning of the thread.
"""

from __future__ import annotations

import threading
import warnings

import pytest

from coop_ga import diagnostics
from coop_ga.diagnostics import collect_warnings, warn
from coop_ga.errors import DegeneracyWarning, InvalidInputError, JointLimitWarning


@pytest.fixture(autouse=True)
def _clean_stack():
    diagnostics._stack().clear()
    yield
    leftover = list(diagnostics._stack())
    diagnostics._stack().clear()
    assert leftover == [], "a collector was left on the thread's stack"


def _messages(caught: list[warnings.WarningMessage]) -> list[tuple[type[Warning], str]]:
    return [(w.category, str(w.message)) for w in caught]


def test_restart_nesting_keeps_later_warnings():
    """The iLQR restart's nesting: outer → silent (IK) → IK's own, then a warning in the restarted solve."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with collect_warnings() as outer:  # ilqr_reach
            with collect_warnings(silent=True):  # around gauss_newton_ik
                with collect_warnings():  # gauss_newton_ik's own: equal in value to `outer` (both empty)
                    pass
            assert diagnostics._stack() == [outer]
            warn("restarted solve: degenerate", DegeneracyWarning)
            warn("restarted solve: degenerate", DegeneracyWarning)
        assert outer.counts == {"DegeneracyWarning": 2}
        assert _messages(caught) == [(DegeneracyWarning, "restarted solve: degenerate (occurred 2 times in this call)")]
        assert diagnostics._stack() == []
        # a later warning of the same thread still reaches the user, at once
        warn("later", JointLimitWarning)
        assert _messages(caught)[-1] == (JointLimitWarning, "later")
        assert len(caught) == 2


def test_equal_collectors_are_distinct():
    a, b = collect_warnings(), collect_warnings()
    assert a != b and a == a  # identity, not value
    with a, b:
        assert diagnostics._stack() == [a, b]
        assert diagnostics._stack()[0] is a and diagnostics._stack()[1] is b


def test_out_of_order_exit_neither_raises_nor_loses_a_warning():
    """An outer block closed before an inner one (e.g. a suspended generator): both leave, each warning once."""
    outer, inner = collect_warnings(), collect_warnings()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        outer.__enter__()
        warn("before inner", DegeneracyWarning)
        inner.__enter__()
        warn("inside both", JointLimitWarning)
        outer.__exit__(None, None, None)  # the outermost: emits both conditions now
        assert diagnostics._stack() == [inner]
        assert sorted(m for _, m in _messages(caught)) == ["before inner", "inside both"]
        warn("inner only", JointLimitWarning, key="x")
        inner.__exit__(None, None, None)  # now the outermost: emits what it recorded since, nothing twice
        assert diagnostics._stack() == []
        assert sorted(m for _, m in _messages(caught)) == ["before inner", "inner only", "inside both"]
        assert inner.counts == {"JointLimitWarning": 1, "JointLimitWarning:x": 1}
        assert outer.counts == {"DegeneracyWarning": 1, "JointLimitWarning": 1}
        outer.__exit__(None, None, None)  # a second exit is a no-op
        warn("later", DegeneracyWarning)
        assert len(caught) == 4 and str(caught[-1].message) == "later"


def test_exit_in_another_thread_leaves_the_right_stack():
    """A collector leaves the stack it joined, whichever thread closes it."""
    c = collect_warnings()
    c.__enter__()
    t = threading.Thread(target=c.__exit__, args=(None, None, None))
    t.start()
    t.join()
    assert diagnostics._stack() == []


def test_reentering_an_active_collector_is_refused():
    c = collect_warnings()
    with c, pytest.raises(InvalidInputError, match="already active"):
        c.__enter__()
    assert diagnostics._stack() == []


def test_ilqr_restart_from_a_random_start_keeps_its_warnings():
    """The crash found by scanning random in-limit starts (allegro circle, seed 35 of 400): the first solve
    stalls without a warning, the restart's Gauss–Newton IK runs (three nested collectors) and warns, and the
    solve goes on.  Before: ``ValueError: list.remove(x): x not in list`` and a stale collector left on the stack.

    The target is in fact out of reach (its circle misses the reach of end point 0, link_3.0_tip, by 1.7 cm), which ``ilqr_reach``
    now certifies before iterating, and whose first solve now ends at the stall test before the warnings; both are
    switched off here so that the run takes the path of the crash.
    """
    import numpy as np

    import coop_ga as cg
    from coop_ga.control import displaced_target, ilqr_reach
    from coop_ga.control import gauss_newton as gn_module
    from coop_ga.control.ilqr import solver
    from coop_ga.sweep.targets import LEVELS, draw_displacement

    task = cg.cooperative_task(cg.systems.load("allegro"), "circle")
    lim = task.system.limits
    rng = np.random.default_rng(35)
    q = rng.uniform(lim.lower, lim.upper)
    d = draw_displacement(rng, LEVELS["large"], task.nq)
    target = displaced_target(
        task, task.system.q0, translation=d.translation, axis=d.axis, angle=d.angle, scale=d.scale
    )
    ik_calls = []
    original = gn_module.gauss_newton_ik

    def spy(*args, **kwargs):
        ik_calls.append(1)
        return original(*args, **kwargs)

    with warnings.catch_warnings(record=True) as caught, pytest.MonkeyPatch.context() as mp:
        warnings.simplefilter("always")
        assert "unreachable" in ilqr_reach(task, q, target).message  # certified: no restart, no nesting
        assert ik_calls == [] and caught == []
        mp.setattr(gn_module, "gauss_newton_ik", spy)
        mp.setattr(solver, "unreachable", lambda ocp, tol: None)
        mp.setattr(solver, "STALL_STATIONARITY", 0.0)  # the stall test never holds
        res = ilqr_reach(task, q, target)
        assert ik_calls == [1]  # the restart ran (the nesting of the crash)
        assert diagnostics._stack() == []
        n = res.warnings["DegeneracyWarning:allegro"]
        assert n > 1
        assert [str(w.message).endswith(f"(occurred {n} times in this call)") for w in caught] == [True]
        warn("later", JointLimitWarning)
        assert len(caught) == 2 and str(caught[-1].message) == "later"
