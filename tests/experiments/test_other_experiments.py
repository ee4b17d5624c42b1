"""Examples are tests (crocoddyl style): each experiment script runs headless into a temp dir
and its metrics satisfy the claims the README makes about it."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]


def _run(script: str, out: Path, *extra: str) -> dict:
    spec = importlib.util.spec_from_file_location(script, ROOT / "experiments" / f"{script}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    rc = mod.main(["--out", str(out), *extra])
    assert rc in (0, None)
    assert any(p.suffix == ".png" and p.stat().st_size > 10_000 for p in out.iterdir())
    return json.loads((out / "metrics.json").read_text())


def test_nullspace_secondary(tmp_path: Path) -> None:
    m = _run("nullspace_secondary", tmp_path)
    assert m["nullspace"]["final_point_error_m"] < 1e-2  # the arm reaches its new point on the circle
    assert m["nullspace"]["max_similarity_distance"] < 1e-3  # while V_Sc is held (Eq 60)
    assert m["direct"]["max_similarity_distance"] > 10 * m["nullspace"]["max_similarity_distance"]


def test_teleop_allegro_dilation_closes_and_opens(tmp_path: Path) -> None:
    m = _run("teleop_allegro", tmp_path)
    close, open_ = m["fig21"]["close"], m["fig21"]["open"]
    assert close["ratio"] < 0.85 < 1.15 < open_["ratio"]  # Fig. 21: visibly closes and opens
    # integrated finely, the radius follows e^{βΔt} (β = ∓1, Δt = 0.25 s) to ~1 %
    assert abs(close["fine_integration"]["ratio"] - np.exp(-0.25)) < 0.01
    assert abs(open_["fine_integration"]["ratio"] - np.exp(0.25)) < 0.015


def test_impedance_three_iiwa(tmp_path: Path) -> None:
    m = _run("impedance_three_iiwa", tmp_path)
    paper = m["gains"]["paper"]["runs"]
    assert len(paper) == 10
    assert all(r["ratio"] < 0.5 and r["max_rise_above_running_min"] <= 0.05 * r["initial_error"] for r in paper)
