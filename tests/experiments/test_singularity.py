"""Figs. 18–19 (experiments/singularity.py): TCP 0 of three_franka driven onto the line through the
other two TCPs; the cooperative circle degenerates and the run stops one step before the guard raises."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.helpers import script_main, strict_json

SCRIPT = Path(__file__).resolve().parents[2] / "experiments" / "singularity.py"
FIGURES = ("fig18_scene.png", "fig19_circle_parameters.png", "fig19_bivector.png", "fig19_manipulability.png")


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("singularity")
    assert script_main(SCRIPT)(["--fast", "--quiet", "--out", str(out)]) == 0  # no exception although w reaches ~1e-6
    return out, strict_json((out / "metrics.json").read_text()), np.load(out / "trajectory.npz")


def test_files_and_gallery(run):
    out, m, _ = run
    for f in FIGURES:
        assert (out / f).stat().st_size > 30_000, f
    g = m["gallery"]
    assert set(g) == {"title", "claim", "evidence", "agrees", "figures"}
    assert g["agrees"] is True and g["figures"][0] == "fig18_scene.png"
    assert set(g["figures"]) == {*FIGURES, "fig18_animation.gif"}
    from PIL import Image

    with Image.open(out / "fig18_animation.gif") as gif:  # --fast: 4 frames
        assert gif.n_frames == 4
    assert (out / "fig18_animation.gif").stat().st_size < 1_500_000
    assert "rounding noise" in g["evidence"]  # the disagreement/caveat is stated
    # wall-clock times go to timing.json only (metrics.json is committed and must not change between runs)
    assert set(strict_json((out / "timing.json").read_text())) == {"start_preparation_s", "run_s", "total_s"}
    assert not [k for k in m if "runtime" in k or "wall" in k or "seconds" in k]


def test_stops_between_the_thresholds(run):
    _, m, d = run
    assert m["stopped_at_threshold"] is True and m["stopped_reason"].startswith("raise threshold")
    # stopping rule: the recorded last step is above the raise threshold, the refused next one is not
    assert m["raise_below"] == 1e-6 and m["warn_below"] == 1e-2
    assert m["raise_below"] < m["well_definedness_final"] < m["warn_below"]
    assert m["well_definedness_next_refused"] <= m["raise_below"]
    # exponential approach at gain 2/s, Δt = 0.05 s: w shrinks ≈ 0.9× per step, so the stop is within ~11 % of 1e-6
    assert m["well_definedness_final"] < 1.2e-6
    assert m["well_definedness_initial"] > 0.8 and m["distance_to_line_initial_m"] > 0.4
    assert m["distance_to_line_final_m"] < 1e-6  # TCP 0 is within a micrometre of the line
    w = d["well_definedness"]
    assert len(w) == m["steps"] + 1 and np.all(np.diff(w) < 0)  # monotone approach
    # every guarded call below 1e-2 warned (2 guarded calls per step), none raised
    assert m["warnings"] == {"DegeneracyWarning:three_franka": 2 * m["steps_below_warn"]}
    assert m["steps_below_warn"] == int(np.sum(w < 1e-2)) > 50


def test_manipulability_eigenvalues_fall_toward_zero(run):
    _, m, d = run
    E, w = d["eigenvalues"], d["well_definedness"]
    assert E.shape == (m["steps"] + 1, 7)
    assert np.max(E[:, 0] / E[:, -1]) < 1e-20  # λ₁ ≡ 0: rank J^G = 6 (circle DOF)
    assert m["min_eigenvalue_initial"] == pytest.approx(0.3444, rel=1e-3)
    assert m["min_eigenvalue_ratio"] < 1e-8  # even the noise-limited final value
    assert m["min_eigenvalue_ratio_last_resolved"] < 1e-8  # resolved by both Jacobian routes
    assert m["resolved_down_to_well_definedness"] < 1e-5
    assert m["eigenvalues_fallen_10x"] == 2 and m["eigenvalues_grown_10x"] == 2
    # power laws λ ∝ w^p over the resolved range w ≤ 1e-2: two fall like w², two stay, two grow like w⁻²
    np.testing.assert_allclose(m["eigenvalue_slopes_vs_w"], [2, 2, 0, 0, -2, -2], atol=0.05)
    # λ₂ falls strictly monotonically over the last part (w < 1e-2) as long as it is resolved
    k = m["resolved_last_step"]
    part = np.flatnonzero(w[: k + 1] < 1e-2)
    assert part.size > 40 and np.all(np.diff(np.log(E[part, 1])) < 0)
    assert np.all(np.asarray(m["eigenvalues_initial"]) == np.sort(m["eigenvalues_initial"]))
    assert np.all(np.asarray(m["eigenvalues_final"]) == np.sort(m["eigenvalues_final"]))


def test_circle_degenerates(run):
    _, m, d = run
    assert m["radius_initial"] == pytest.approx(0.3235, rel=1e-3)
    assert m["radius_growth"] > 1e5 and m["radius_final"] > 1e4
    assert m["radius_slope_vs_w"] == pytest.approx(-1.0, abs=0.02)  # r ∝ 1/w
    assert m["readout_radius_max_rel_error"] < 1e-8 and m["readout_center_max_error_per_radius"] < 1e-8
    assert {"e012", "e123"} <= set(m["circle_coefficients_fallen_100x"])  # the e0 (round) part vanishes
    # bivector: translation diverges ∝ 1/w, dilation β = ln r
    assert m["translation_norm_final"] > 1e4 * m["translation_norm_initial"]
    assert m["translation_slope_vs_w"] == pytest.approx(-1.0, abs=0.02)
    np.testing.assert_allclose(d["bivector"][:, 3], np.log(d["radius"]), atol=1e-8)


def test_limits_and_fixed_arms(run):
    _, m, d = run
    assert m["max_limit_violation"] == 0.0 and m["max_velocity_excess_rad_s"] == 0.0
    assert m["fixed_arms_max_joint_motion_rad"] == 0.0
    P = d["end_points"]
    assert np.max(np.abs(P[:, 1:] - P[0, 1:])) == 0.0  # TCPs 1, 2 stay put


def test_deterministic(run, tmp_path):
    out, _, _ = run
    assert script_main(SCRIPT)(["--fast", "--quiet", "--out", str(tmp_path)]) == 0
    assert (tmp_path / "metrics.json").read_bytes() == (out / "metrics.json").read_bytes()
    assert (tmp_path / "trajectory.npz").read_bytes() == (out / "trajectory.npz").read_bytes()


def test_unreachable_fixed_points_are_refused(tmp_path):
    from coop_ga.errors import CoopGAError

    with pytest.raises(CoopGAError, match="not reachable"):
        script_main(SCRIPT)(["--fast", "--quiet", "--out", str(tmp_path), "--half-width", "3"])


def test_bad_option_value(capsys):
    with pytest.raises(SystemExit) as ex:
        script_main(SCRIPT)(["--dt", "-1"])
    assert ex.value.code == 2
    assert "argument --dt: expected a number > 0" in capsys.readouterr().err
