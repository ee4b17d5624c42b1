"""Examples are tests (crocoddyl style): the experiment scripts of Figs. 5–6, 16–17 and 20–21 run
headless with ``--fast`` into a temp dir, twice (the metrics must be byte-identical), and their
metrics back the claims of their ``gallery`` block."""

from __future__ import annotations

import importlib.util
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
GALLERY_KEYS = {"title", "claim", "evidence", "agrees", "figures"}


def _run(script: str, out: Path, *extra: str) -> dict:
    name = f"exp_{script}"
    spec = importlib.util.spec_from_file_location(name, ROOT / "experiments" / f"{script}.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    rc = mod.main(["--out", str(out), "--fast", "--quiet", *extra])
    assert rc == 0
    return json.loads((out / "metrics.json").read_text())


def _runs(tmp_path_factory, script: str) -> tuple[dict, Path, Path]:
    a, b = tmp_path_factory.mktemp(f"{script}_a"), tmp_path_factory.mktemp(f"{script}_b")
    m = _run(script, a)
    _run(script, b)
    return m, a, b


def _check_common(m: dict, a: Path, b: Path, pngs: set[str], gifs: frozenset[str] = frozenset()) -> None:
    """Determinism, no wall-clock times in metrics.json, timing.json written, gallery complete (its PNGs and
    animations, each GIF small enough for the gallery)."""
    assert (a / "metrics.json").read_bytes() == (b / "metrics.json").read_bytes()
    npz = [p.name for p in a.glob("*.npz")]
    assert npz and all((a / n).read_bytes() == (b / n).read_bytes() for n in npz)
    text = (a / "metrics.json").read_text()
    assert "time_s" not in text and "wall" not in text
    timing = json.loads((a / "timing.json").read_text())
    assert timing["total_s"] > 0
    assert m["fast"] is True
    assert m["max_limit_violation"] == 0.0
    g = m["gallery"]
    assert set(g) == GALLERY_KEYS
    assert g["agrees"] is True
    assert set(g["figures"]) == pngs | gifs
    for name in g["figures"]:
        assert (a / name).stat().st_size > 10_000, name
    assert {p.name for p in a.glob("*.png")} == pngs  # every PNG written is listed
    assert {p.name for p in a.glob("*.gif")} == gifs
    for name in gifs:
        assert (a / name).stat().st_size < 1_500_000, name


# ---------------------------------------------------------------------------- Figs. 5–6
@pytest.fixture(scope="module")
def impedance(tmp_path_factory):
    return _runs(tmp_path_factory, "impedance_three_iiwa")


def test_impedance_outputs(impedance):
    m, a, b = impedance
    _check_common(m, a, b, {"fig05_scene.png", "fig06_cost.png", "fig06_cost_stiff.png"})
    d = np.load(a / "errors.npz")
    assert d["error_norm_paper"].shape == d["error_norm_stiff"].shape == (4, 2001)  # 4 runs × 2 s at 1 kHz
    assert m["runs"] == 4 and m["duration_s"] == 2.0 and m["dt_s"] == 1e-3
    assert m["gains"]["paper"]["K"] == [1.0, 1.0, 1.0, 7.5, 7.5, 7.5, 7.5]
    assert m["gains"]["paper"]["D"] == [5.0] * 7


def test_impedance_paper_gains_regulate(impedance):
    m = impedance[0]
    paper, stiff = m["gains"]["paper"], m["gains"]["stiff"]
    assert len(paper["runs"]) == 4
    for r in paper["runs"]:
        assert 0.08 < r["initial_error"] < 0.4
        assert r["ratio"] < 0.75  # after 2 s (after 4 s: < 0.5)
        assert r["max_rise_above_running_min"] <= 1e-6  # the cost never rises: monotone
        assert r["final_error"] == pytest.approx(r["ratio"] * r["initial_error"], rel=1e-4)
    assert stiff["max_ratio"] < 1e-3  # K = 25 I, D = 10 I: converges
    # inside every limit, no torque saturated
    assert paper["saturated_steps"] == stiff["saturated_steps"] == 0
    assert m["max_velocity_ratio"] < 1.0
    assert m["start_limit_violation_rad"] == 0.0
    # the paper's Eq 52 alone (no nullspace compensation) makes the cost grow
    assert m["ablation_eq52_as_printed"]["ratio"] > 3.0
    ev = m["gallery"]["evidence"]
    assert f"{paper['min_ratio']:.2f}–{paper['max_ratio']:.2f}" in ev
    assert f"{m['ablation_eq52_as_printed']['ratio']:.1f}×" in ev


# ---------------------------------------------------------------------------- Figs. 16–17
@pytest.fixture(scope="module")
def nullspace(tmp_path_factory):
    return _runs(tmp_path_factory, "nullspace_secondary")


def test_nullspace_outputs(nullspace):
    m, a, b = nullspace
    pngs = {"fig16_scene.png", "fig16_distances.png", "fig17_scene.png", "fig17_distances.png"}
    _check_common(m, a, b, pngs, frozenset({"fig16_animation.gif", "fig17_animation.gif"}))
    assert m["gallery"]["figures"][0] == "fig17_distances.png"
    d = np.load(a / "trajectories.npz")
    assert d["nullspace_trajectory"].shape == (201, 21)  # 2 s at 0.01 s
    np.testing.assert_allclose(
        d["nullspace_similarity_distance"].max(), m["nullspace"]["max_similarity_distance"], 1e-5
    )


def test_nullspace_holds_the_circle(nullspace):
    m = nullspace[0]
    ns, direct = m["nullspace"], m["direct"]
    # the target point lies on the circle, 30° along it
    c = m["circle"]
    p = np.array(m["target_point_m"]) - np.array(c["center_m"])
    assert np.linalg.norm(p) == pytest.approx(c["radius_m"], rel=1e-5) and abs(p @ c["normal"]) < 1e-5
    assert m["chord_length_m"] == pytest.approx(2 * c["radius_m"] * math.sin(math.radians(15)), rel=1e-5)
    for v in (ns, direct):  # both reach the point (2 s: within 5 % of the 25.5 cm)
        assert v["final_point_error_m"] < 0.05 * v["initial_point_error_m"]
        assert v["limit_violation_rad"] == 0.0 and v["velocity_violation_rad_s"] == 0.0
        assert v["acceleration_violation_rad_s2"] == 0.0  # the Franka's acceleration limits, from rest
    assert m["max_acceleration_violation"] == 0.0 and m["max_velocity_violation"] == 0.0
    # Fig. 17: V_Sc held (similarity distance ≈ 0) and the TCP on the circle
    assert ns["max_similarity_distance"] < 1e-3
    assert ns["max_distance_from_circle_m"] < 1e-3
    # Fig. 16: without the projection the circle is left while the arm moves
    assert direct["max_similarity_distance"] > 50 * ns["max_similarity_distance"]
    assert direct["max_distance_from_circle_m"] > 1e-2  # the chord's sagitta is 1.7 cm
    assert direct["other_tcps_max_displacement_m"] == 0.0  # only the first arm moves
    # Eq 60 without the primary feedback drifts
    assert m["nullspace_without_primary_feedback"]["max_similarity_distance"] > 3 * ns["max_similarity_distance"]
    assert m["similarity_distance_ratio_direct_over_nullspace"] == pytest.approx(
        direct["max_similarity_distance"] / ns["max_similarity_distance"], rel=1e-4
    )
    assert f"{ns['max_similarity_distance']:.1e}" in m["gallery"]["evidence"]


# ---------------------------------------------------------------------------- Figs. 20–21
@pytest.fixture(scope="module")
def teleop(tmp_path_factory):
    return _runs(tmp_path_factory, "teleop_allegro")


def test_teleop_outputs(teleop):
    m, a, b = teleop
    pngs = {
        "fig21_scene.png",
        "fig21_closed.png",
        "fig21_original.png",
        "fig21_opened.png",
        "fig20_mapping.png",
        "fig20_session.png",
        "fig20_scene.png",
    }
    _check_common(m, a, b, pngs, frozenset({"fig20_animation.gif"}))
    d = np.load(a / "session.npz")
    assert d["mapping_measured"].shape == (6, 7)
    assert m["fig20"]["session"]["mode"] == "scripted"
    assert m["fig20"]["session"]["duration_s"] == pytest.approx(1.85)  # the 3.7 s script halved


def test_teleop_dilation_closes_and_opens(teleop):
    m = teleop[0]
    closed, opened = m["fig21"]["closed"], m["fig21"]["opened"]
    r0 = m["initial_radius_m"]
    assert 0.04 < r0 < 0.05
    for v, beta in ((closed, -1.0), (opened, 1.0)):
        assert v["dt_s"] == 0.25 and v["d_of_command"] == pytest.approx(math.exp(beta), rel=1e-5)
        expected = math.exp(beta * 0.25)  # the scale of a command applied for Δt, not d = e^β
        assert v["ratio_first_order_expected"] == pytest.approx(expected, rel=1e-5)
        assert v["radius_before_m"] == r0
        assert v["radius_after_m"] == pytest.approx(v["ratio"] * r0, rel=1e-5)
        assert abs(v["ratio"] / expected - 1) < 0.03  # one Euler step of 0.25 s
        assert abs(v["fine_integration"]["ratio"] / expected - 1) < 0.005  # 25 steps of 0.01 s
        assert v["center_displacement_m"] < 0.1 * r0  # a pure dilation: the centre stays
        assert v["joints_at_limit"] == 0 and v["max_velocity_ratio"] <= 1.0
    assert closed["ratio"] < 0.8 and opened["ratio"] > 1.25  # the hand visibly closes and opens


def test_teleop_mapping(teleop):
    m = teleop[0]
    mp, ss = m["fig20"]["mapping"], m["fig20"]["session"]
    G = np.array(mp["commanded_bivector"])
    # Fig. 20: tx, ty, tz → e1∞, e2∞, e3∞; rz → e0∞ (rx, ry → e23, e13)
    assert np.count_nonzero(G) == 6
    assert [int(np.flatnonzero(row)[0]) for row in G] == [4, 5, 6, 2, 1, 3]
    assert mp["jacobian_rank"] == 4 and mp["controllable_rows"] == [3, 4, 5, 6]  # a sphere: no rotation
    assert mp["max_error_controllable"] < 0.01  # each axis produces its bivector
    assert mp["max_response_to_rotation_axes"] < 1e-9  # rotations are inert on a sphere
    cv = np.array(mp["center_velocity_radii_per_s"])
    np.testing.assert_allclose(cv[:3], 0.5 * np.eye(3), atol=5e-3)  # k_t = 0.5 radii/s along x, y, z
    assert mp["log_radius_rate_per_s"][5] == pytest.approx(1.0, abs=0.01)  # k_d = 1/s
    assert ss["max_translation_error_m"] < 2e-4
    assert ss["max_radius_change_while_translating"] < 0.005
    assert ss["max_dilation_ratio_error"] < 0.005
    assert ss["max_center_drift_while_dilating_m"] < 1e-3
    assert ss["max_motion_during_rotation_m"] < 1e-9
    assert ss["joints_at_limit_during_session"] == []
    assert m["max_velocity_ratio"] <= 1.0
