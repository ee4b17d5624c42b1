"""One guard on every compiled entry point: evaluate, error-and-Jacobian, J̇q̇ and batch raise or warn alike.

Before, ``error_and_jacobian`` and ``evaluate_batch`` had no
chart check and ``jdot_qdot`` no degeneracy check.  Each case below is run through every
entry point and must give the same exception class (or warning class).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import coop_ga as cg
from coop_ga.cooperative import CooperativeTask

from .conftest import BASES, cartesian_system


@pytest.fixture(scope="module")
def pair_task() -> CooperativeTask:
    return CooperativeTask(cartesian_system(2), "point_pair", codegen=False)


@pytest.fixture(scope="module")
def circle_task() -> CooperativeTask:
    return CooperativeTask(cartesian_system(3), "circle", codegen=False)


def _entry_points(task: CooperativeTask):
    target = task.similarity(np.zeros(task.nq))
    return {
        "evaluate": lambda q: task.evaluate(q),
        "similarity": lambda q: task.similarity(q),
        "error_and_jacobian": lambda q: task.error_and_jacobian(q, target),
        "jdot_qdot": lambda q: task.jdot_qdot(q, np.full(task.nq, 0.1)),
        "evaluate_batch": lambda q: task.evaluate_batch([np.zeros(task.nq), q]),
    }


ENTRY_POINTS = ["evaluate", "similarity", "error_and_jacobian", "jdot_qdot", "evaluate_batch"]


def _q_circle(points: np.ndarray) -> np.ndarray:
    """q of the Cartesian system that puts its three end points at ``points``."""
    return (points - BASES[:3]).reshape(-1)


@pytest.mark.parametrize("entry", ENTRY_POINTS)
def test_nan_q_raises_nonfinite_naming_the_index(circle_task, entry):
    q = np.zeros(circle_task.nq)
    q[4] = np.nan
    with pytest.raises(cg.NonFiniteError, match=r"\b4\b"):
        _entry_points(circle_task)[entry](q)


@pytest.mark.parametrize("entry", ENTRY_POINTS)
def test_overflowing_q_raises_invalid_input(circle_task, entry):
    q = np.zeros(circle_task.nq)
    q[0] = 1e200
    with pytest.raises(cg.InvalidInputError, match="too large"):
        _entry_points(circle_task)[entry](q)


@pytest.mark.parametrize("entry", ENTRY_POINTS)
def test_wrong_size_and_scalar_q_raise(circle_task, entry):
    f = _entry_points(circle_task)[entry]
    for bad in (np.zeros(circle_task.nq - 1), 0.0, np.zeros(1)):
        with pytest.raises(cg.InvalidInputError):
            f(bad)


@pytest.mark.parametrize("entry", ENTRY_POINTS)
def test_degenerate_circle_raises(circle_task, entry):
    q = _q_circle(np.array([[0.0, 0, 0], [1.0, 0, 0], [2.0, 0, 0]]))  # collinear
    with pytest.raises(cg.DegeneratePrimitiveError, match="collinear"):
        _entry_points(circle_task)[entry](q)


@pytest.mark.parametrize("entry", ENTRY_POINTS)
def test_nearly_degenerate_circle_warns_once(circle_task, entry):
    q = _q_circle(np.array([[0.0, 0, 0], [1.0, 0, 0], [2.0, 0.005, 0]]))  # well-definedness ≈ 3e-3
    assert 1e-6 < circle_task.guard.raise_below * 1e4
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        _entry_points(circle_task)[entry](q)
    degenerate = [w for w in rec if issubclass(w.category, cg.DegeneracyWarning)]
    assert len(degenerate) == 1, [str(w.message) for w in rec]
    assert degenerate[0].filename == __file__  # points at the caller's line, not the library's


@pytest.mark.parametrize("entry", ENTRY_POINTS)
def test_chart_antipode_warns(pair_task, entry):
    # point pair from p0 to p1 along −e2 (171.4° from the unit axis +e2): the chart's half-turn
    ang = np.radians(171.4)
    p0 = np.zeros(3)
    p1 = np.array([np.sin(ang), np.cos(ang), 0.0])
    q = (np.stack([p0, p1]) - BASES[:2]).reshape(-1)
    with pytest.warns(cg.ChartWarning, match="171"):
        _entry_points(pair_task)[entry](q)


def test_away_from_the_antipode_no_warning(pair_task):
    ang = np.radians(160.0)
    q = (np.stack([np.zeros(3), [np.sin(ang), np.cos(ang), 0.0]]) - BASES[:2]).reshape(-1)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for f in _entry_points(pair_task).values():
            f(q)


def test_batch_names_the_offending_configuration(circle_task):
    good = np.zeros(circle_task.nq)
    bad = _q_circle(np.array([[0.0, 0, 0], [1.0, 0, 0], [2.0, 0, 0]]))
    with pytest.raises(cg.DegeneratePrimitiveError, match="configuration 2"):
        circle_task.evaluate_batch(np.stack([good, good, bad]))
    with pytest.raises(cg.InvalidInputError, match="N ≥ 1"):
        circle_task.evaluate_batch(np.zeros((0, circle_task.nq)))


def test_complex_q_is_refused(circle_task):
    with pytest.raises(cg.InvalidInputError, match="complex"):
        circle_task.evaluate(np.zeros(circle_task.nq, dtype=complex))
