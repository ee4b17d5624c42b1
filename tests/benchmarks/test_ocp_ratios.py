"""benchmarks/ocp.py's ratio lines, from made-up rows (the solvers themselves run for minutes: not here)."""

from __future__ import annotations

import importlib
import sys
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest

pytest.importorskip("casadi")
BENCH = Path(__file__).resolve().parents[2] / "benchmarks"


def _module() -> Any:
    if str(BENCH) not in sys.path:
        sys.path.insert(0, str(BENCH))
    return importlib.import_module("ocp")


def test_time_to_optimum_sums_the_iterations_until_the_best_cost():
    m = _module()
    it = [
        SimpleNamespace(cost=c, time_s=0.5, violation=v) for c, v in ((2.0, 0), (1.0 + 1e-5, 0), (1.0, 1e-3), (1.0, 0))
    ]
    assert m.time_to_optimum(SimpleNamespace(stats=it), 1.0) == 2.0  # the third is within 1e-6 but infeasible
    assert m.time_to_optimum(SimpleNamespace(stats=it[:2]), 1.0) is None


def test_ratio_lines():
    m = _module()
    rows = [
        {"solver": "iLQR", "solve_time_s": 1.0, "cost": 1.01, "terminal_error": 1e-6},
        {"solver": "iLQR (tol = 0)", "solve_time_s": 8.0, "time_to_optimum_s": 2.0,
         "time_to_ipopt_cost_s": {"1e-06": 2.0, "1e-10": None}},
        {"solver": "IPOPT", "solve_time_s": 4.0, "cost": 1.0},
    ]  # fmt: skip
    clear = {"plain": {"solve_time_s": 0.1, "iterations": 5, "converged": True, "error": 1e-6, "min_clearance_knots_m": -0.03},
             "clearance": {"solve_time_s": 3.0, "iterations": 20, "converged": True, "error": 1e-6, "min_clearance_knots_m": 0.05},
             "time_ratio": 30.0, "per_iteration_ratio": 7.5}  # fmt: skip
    r = m._ratios({"velocity": {"rows": rows}}, clear)
    d = r["velocity_vs_ipopt"]
    assert (d["ilqr_tol0_over_ref"], d["ilqr_time_to_optimum_over_ref"], d["ilqr_tol_over_ref"]) == (2.0, 0.5, 0.25)
    assert d["ilqr_time_to_ipopt_cost_over_ref"] == {"1e-06": 0.5, "1e-10": None}
    assert "1e-06: 0.5×, 1e-10: never of IPOPT's cost" in r["lines"][0]
    assert "velocity_vs_fatrop" not in r  # no FATROP row: no ratio
    assert r["velocity_default_tol_gap"] == pytest.approx(0.01)
    assert "stops +1.00e-02 (relative cost) from IPOPT's optimum" in r["lines"][1]
    assert r["clearance"] == {"time_ratio": 30.0, "per_iteration_ratio": 7.5}
    assert "30.0× the same reach without it" in r["lines"][2]
    assert r["lines"][-1].startswith("[crocoddyl] BoxFDDP not run")
    # with crocoddyl (its row present): the ratios against BoxFDDP, and no note
    rows_c = [*rows, {"solver": "BoxFDDP", "solve_time_s": 0.5}]
    rc = m._ratios({"velocity": {"rows": rows_c}}, None, croc=True)
    assert rc["velocity_vs_boxfddp"]["ilqr_tol_over_ref"] == 2.0
    assert not any(line.startswith("[crocoddyl]") for line in rc["lines"])
