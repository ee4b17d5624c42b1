"""The flagship experiment (Fig. 8): runs end to end and produces sane numbers and files."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "experiments" / "circle_reaching.py"


def _load_main():
    spec = importlib.util.spec_from_file_location("circle_reaching", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod.main


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("circle_reaching")
    assert _load_main()(["--out", str(out), "--quiet"]) == 0
    return out


def test_metrics(run):
    m = json.loads((run / "metrics.json").read_text())
    for key in (
        "ilqr_iterations",
        "terminal_error",
        "solve_time_s",
        "diffik_final_error",
        "diffik_steps",
        "ilqr_converged",
        "diffik_converged",
        "target",
        "initial_circle",
        "final_circle",
    ):
        assert key in m, key
    assert m["ilqr_converged"] is True
    assert m["terminal_error"] < 1e-4
    assert 1 <= m["ilqr_iterations"] <= 10
    assert m["solve_time_s"] < 5.0
    assert m["reachable_by_gauss_newton_ik"] is True
    assert m["joint_limit_violation_rad"] == 0.0
    # the target really is larger, displaced and tilted, and the final circle is on it
    t, c0, cf = m["target"]["circle"], m["initial_circle"], m["final_circle"]
    assert t["radius_m"] == pytest.approx(1.25 * c0["radius_m"])
    assert np.linalg.norm(np.subtract(t["center_m"], c0["center_m"])) > 0.1
    assert m["target"]["tilt_from_initial_deg"] == pytest.approx(25.0)
    assert np.linalg.norm(np.subtract(cf["center_m"], t["center_m"])) < 1e-4
    assert cf["radius_m"] == pytest.approx(t["radius_m"], abs=1e-4)
    # differential IK ran over the same horizon and made real progress
    assert m["diffik_steps"] > 0 and m["diffik_final_error"] < 0.01 * m["initial_error"]
    hist = m["terminal_error_history"]
    assert len(hist) == m["ilqr_iterations"] + 1 and hist[-1] == pytest.approx(m["terminal_error"])
    assert np.all(np.diff(m["cost_history"]) < 0)


def test_trajectory_file(run):
    d = np.load(run / "trajectory.npz")
    assert d["q"].shape == (251, 21) and d["u"].shape == (250, 21)
    assert d["error_bivector"].shape == (251, 7) and d["command_bivector"].shape == (251, 7)
    assert np.linalg.norm(d["error_bivector"][-1]) < 1e-4
    np.testing.assert_allclose(d["command_bivector"][0], 0.0, atol=1e-12)  # starts at rest


def test_figure(run):
    png = run / "circle_reaching.png"
    assert png.exists() and png.stat().st_size > 50_000
    import matplotlib.image as mpimg

    img = mpimg.imread(png)
    assert img.shape[0] > 500 and img.shape[1] > 1000
    assert float(np.std(img[..., :3])) > 0.05  # not blank


def test_help_is_clean():
    r = subprocess.run([sys.executable, str(SCRIPT), "--help"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0 and r.stderr == ""
    assert "--out" in r.stdout and "--seed" in r.stdout and "Fig. 8" in r.stdout
