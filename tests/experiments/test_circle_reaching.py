"""The flagship experiment (Fig. 8, experiments/circle_reaching.py): runs end to end and produces sane numbers and files."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.helpers import read_metrics, script_main

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "experiments" / "circle_reaching.py"


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("circle_reaching")
    assert script_main(SCRIPT)(["--out", str(out), "--quiet", "--fast"]) == 0
    return out


def testread_metrics(run):
    m = read_metrics(run)
    for key in (
        "converged",
        "terminal_error",
        "iterations",
        "max_limit_violation",
        "ilqr_iterations",
        "ilqr_converged",
        "diffik_final_error",
        "diffik_steps",
        "diffik_converged",
        "target",
        "initial_circle",
        "final_circle",
        "gallery",
    ):
        assert key in m, key
    # wall-clock times are in timing.json, not in the committed metrics
    for key in ("solve_time_s", "ilqr_wall_time_s", "task_compile_or_load_s", "diffik_time_s", "total_runtime_s"):
        assert key not in m, key
    assert all("time_s" not in x for x in m["ilqr_iteration_stats"])
    timing = json.loads((run / "timing.json").read_text())
    assert 0 < timing["solve_time_s"] < 5.0 and timing["total_runtime_s"] > timing["solve_time_s"]
    assert m["converged"] is True and m["ilqr_converged"] is True
    assert m["terminal_error"] < m["tol"] == 1e-5
    assert 1 <= m["iterations"] == m["ilqr_iterations"] <= 5
    assert m["reachable_by_gauss_newton_ik"] is True
    assert m["max_limit_violation"] == 0.0 and m["joint_limit_violation_rad"] == 0.0
    assert m["figure"] == "fig08" and m["system"] == "three_franka" and m["dof"] == 21
    # the target really is larger, displaced and tilted, and the final circle is on it
    t, c0, cf = m["target"]["circle"], m["initial_circle"], m["final_circle"]
    assert t["radius_m"] == pytest.approx(1.25 * c0["radius_m"])
    assert np.linalg.norm(np.subtract(t["center_m"], c0["center_m"])) > 0.1
    assert m["target"]["tilt_from_initial_deg"] == pytest.approx(25.0)
    assert np.linalg.norm(np.subtract(cf["center_m"], t["center_m"])) < 1e-4
    assert cf["radius_m"] == pytest.approx(t["radius_m"], abs=1e-4)
    # Fig. 8b: a larger circle needs a non-zero dilation command; it integrates to log 1.25
    assert m["max_abs_dilation_command"] > 0.1
    assert m["integrated_dilation_command"] == pytest.approx(np.log(1.25), abs=1e-4)
    # differential IK ran over the same horizon and made real progress
    assert m["diffik_steps"] > 0 and m["diffik_final_error"] < 0.01 * m["initial_error"]
    # … inside the position, velocity and acceleration limits of the Franka arms (from rest)
    lims = m["diffik_limits"]
    assert lims["max_limit_violation"] == 0.0 and lims["max_velocity_violation"] == 0.0
    assert lims["max_acceleration_violation"] == 0.0 and lims["relaxed_steps"] == 0
    hist = m["terminal_error_history"]
    assert len(hist) == m["ilqr_iterations"] + 1 and hist[-1] == pytest.approx(m["terminal_error"])
    assert np.all(np.diff(m["cost_history"]) < 0)
    g = m["gallery"]
    assert g["agrees"] is True and g["figures"] == ["scene.png", "bivector.png", "animation.gif"]
    assert "log(r_n/r_0)" in g["evidence"] and "Differential IK" in g["evidence"]


def test_trajectory_file(run):
    d = np.load(run / "trajectory.npz")
    assert d["q"].shape == (101, 21) and d["u"].shape == (100, 21)  # --fast: 100 knots × 0.025 s
    assert d["error_bivector"].shape == (101, 7) and d["command_bivector"].shape == (101, 7)
    assert np.linalg.norm(d["error_bivector"][-1]) < 1e-4
    np.testing.assert_allclose(d["command_bivector"][0], 0.0, atol=1e-12)  # starts at rest


def test_figures(run):
    import matplotlib.image as mpimg

    assert not (run / "circle_reaching.png").exists()
    for name in ("scene.png", "bivector.png"):
        png = run / name
        assert png.exists() and png.stat().st_size > 50_000, name
        img = mpimg.imread(png)
        assert img.shape[0] > 500 and img.shape[1] > 500, name
        assert float(np.std(img[..., :3])) > 0.05, name  # not blank


def test_same_as_reaching_fig08(run, tmp_path):
    """circle_reaching.py is the fig08 preset of reaching.py: the same bytes."""
    main = script_main(ROOT / "experiments" / "reaching.py")
    assert main(["--figure", "fig08", "--fast", "--quiet", "--out", str(tmp_path)]) == 0
    for name in ("metrics.json", "trajectory.npz"):
        assert (tmp_path / name).read_bytes() == (run / name).read_bytes(), name


def test_help_is_clean():
    r = subprocess.run([sys.executable, str(SCRIPT), "--help"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0 and r.stderr == ""
    assert "--out" in r.stdout and "--seed" in r.stdout and "--fast" in r.stdout and "Fig. 8" in r.stdout
    assert "{fig07," not in r.stdout  # the preset is fixed: no --figure option
