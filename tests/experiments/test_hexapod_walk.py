"""experiments/hexapod_walk.py: --fast runs, each gait once and each terrain once, assert on metrics."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from tests.helpers import read_metrics, script_main

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "experiments" / "hexapod_walk.py"
RUNS = [("tripod", "flat"), ("ripple", "steps"), ("wave", "random")]


@pytest.fixture(scope="module", params=RUNS, ids=[f"{g}-{t}" for g, t in RUNS])
def run(request, tmp_path_factory):
    gait, terrain = request.param
    out = tmp_path_factory.mktemp(f"hexapod_walk_{gait}_{terrain}")
    assert script_main(SCRIPT)(["--gait", gait, "--terrain", terrain, "--fast", "--quiet", "--out", str(out)]) == 0
    return gait, terrain, out


def testread_metrics(run):
    gait, terrain, out = run
    m = read_metrics(out)
    assert m["gait"] == gait and m["terrain"] == terrain and m["fast"] is True
    assert m["commanded_distance_m"] == 0.3
    # the walk stops at the first knot past the distance (the posture loop moves the body < 1 mm sideways of it)
    assert 0.3 - 1e-3 <= m["distance_m"] <= 0.3 + m["command"]["vx_m_s"] * m["dt_s"] + 1e-3
    assert m["min_stability_margin_m"] > 0.05
    assert m["max_limit_violation"] == 0.0
    assert m["max_velocity_violation"] == 0.0 and m["max_velocity_ratio"] < 1.0
    # the foot balls rest on the terrain and roll without sliding; every leg capsule stays off the terrain
    assert m["foot_radius_m"] == 0.009 and m["max_contact_error_m"] < 1e-9 and m["max_slip_m"] < 1e-9
    assert 0.0005 < m["max_rolling_m"] < 0.006
    assert m["min_segment_clearance_m"] >= 0.0 and m["min_swing_clearance_m"] > -1e-9
    assert 0.2 < m["max_torque_ratio"] < 0.8
    assert m["ik_fallback_steps"] == 0 and m["posture_step"] is True and m["posture_failures"] == 0
    assert m["min_stance_legs"] == {"tripod": 3, "ripple": 4, "wave": 5}[gait]
    assert set(m["stance_primitive_steps"]) == {"plane"}  # the primitive that carries height and attitude
    pb = m["posture_vs_baseline"]
    if terrain == "flat":  # one plane: both put the body exactly on it
        assert pb["posture"]["max_height_m"] < 1e-9 and pb["baseline"]["max_height_m"] < 1e-9
        assert pb["max_joint_difference_rad"] < 1e-6
    else:  # the stance-plane loop keeps the body closer to the stance reference than the filtered baseline
        assert pb["max_joint_difference_rad"] > 0.01
        assert pb["posture"]["rms_height_m"] < pb["baseline"]["rms_height_m"]
        assert pb["posture"]["rms_tilt_rad"] < pb["baseline"]["rms_tilt_rad"]
        assert pb["baseline_min_segment_clearance_m"] >= 0.0 and pb["baseline_max_velocity_ratio"] < 1.0
    if terrain == "steps":
        assert m["terrain_rise_m"] == pytest.approx(0.03) and 0.01 < m["body_rise_m"] < 0.035
    g = m["gallery"]
    assert g["agrees"] is True and g["figures"] == ["scene.png", "walk.gif", "margin.png", "height.png"]
    assert "stability margin" in g["evidence"] and "support polygon" in g["caption"]
    for key in ("walk_s", "render_s", "gif_s", "total_runtime_s"):  # wall-clock times live in timing.json
        assert key not in m, key
    timing = json.loads((out / "timing.json").read_text())
    assert timing["total_runtime_s"] > timing["walk_s"] > 0


def test_trajectory_file(run):
    _, terrain, out = run
    d = np.load(out / "trajectory.npz")
    T = d["t"].shape[0]
    assert d["q"].shape == (T, 18) and d["body"].shape == (T, 7) and d["stance"].shape == (T, 6)
    assert d["stance"].dtype == bool
    np.testing.assert_allclose(np.linalg.norm(d["body"][:, 3:], axis=1), 1.0, atol=1e-12)
    assert str(d["terrain_kind"]) == terrain and "terrain_planes" in d
    # the file is enough to check the motion: stance feet by FK from q and body stay put in W
    from coop_ga.legged.body import BodyState
    from coop_ga.legged.legs import hexapod_legs

    legs = hexapod_legs()
    feet = np.array(
        [BodyState.from_quaternion(d["body"][k, :3], d["body"][k, 3:], d["q"][k]).feet_world(legs) for k in range(T)]
    )
    np.testing.assert_allclose(feet, d["feet"], atol=1e-12)
    # a stance ball only rolls: its centre moves by at most r · Δθ per step (≪ a swing foot's motion)
    both = d["stance"][:-1] & d["stance"][1:]
    moved = np.linalg.norm(feet[1:] - feet[:-1], axis=-1)[both]
    assert moved.max() < 1e-3
    np.testing.assert_allclose(d["contacts"][..., :2], d["feet"][..., :2], atol=1e-3)
    assert d["segment_clearance"].min() >= 0.0


def test_figures(run):
    import matplotlib.image as mpimg
    from PIL import Image

    _, _, out = run
    for name in ("scene.png", "margin.png", "height.png"):
        img = mpimg.imread(out / name)
        assert img.shape[0] > 300 and img.shape[1] > 400, name
        assert float(np.std(img[..., :3])) > 0.03, name
    gif = Image.open(out / "walk.gif")
    assert gif.n_frames == 12 and (out / "walk.gif").stat().st_size < 2_000_000
