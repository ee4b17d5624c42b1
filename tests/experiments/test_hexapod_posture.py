"""experiments/hexapod_posture.py: runs in --fast mode; six body DOF through stance primitives with the feet fixed,
statically stable, honest refusals, and MuJoCo following the plan within 2 mm / 1° without lifted feet touching."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from tests.helpers import read_metrics, script_main

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "experiments" / "hexapod_posture.py"


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("hexapod_posture")
    assert script_main(SCRIPT)(["--out", str(out), "--quiet", "--fast"]) == 0
    return out


def test_metrics(run):
    m = read_metrics(run)
    g = m["gallery"]
    assert g["agrees"] is True and "equator" in g["caption"]
    for f in g["figures"]:
        assert (run / f).stat().st_size > 10_000, f
    assert m["stance_legs"] == ["lf", "lr", "rf", "rr"] and m["lifted_legs"] == ["lm", "rm"]
    assert set(m["primitives"]) == {"sphere", "circle", "point_pair"}
    # statically stable at every sample (with both front legs lifted the COM left the polygon on 669 of 801)
    assert m["min_stability_margin_m"] >= 0.010 and m["samples_below_margin"] == 0
    assert m["min_lifted_clearance_m"] >= 0.005
    # feet fixed, limits kept
    assert m["max_slip_m"] < 1e-12 < m["slip_limit_m"] and m["max_drift_m"] < 1e-12
    assert m["max_limit_violation"] == 0.0
    ph = m["phases"]
    assert ph["translate"]["primitives"] == ["sphere(lf, lr, rr, rf)"]
    assert [p.split("(")[0] for p in ph["tilt"]["primitives"]] == ["circle", "point_pair"]
    for name in ("translate", "tilt", "yaw", "six_dof"):
        assert ph[name]["displacement_error_m"] < 2e-4, name  # explicit Euler over 20 steps
        assert ph[name]["rotation_error_rad"] < 1e-3, name
        assert ph[name]["max_slip_m"] < 1e-12 and ph[name]["limited_steps"] == 0
    assert ph["six_dof"]["body_rpy_rad"] == pytest.approx(np.deg2rad([5.0, -5.0, 8.0]), abs=1e-3)
    assert m["max_return_error_m"] < 2e-4
    # what the primitives cannot carry is refused, named
    r = m["refused"]
    assert r["tilt_through_sphere"].startswith("InvalidInputError") and "e13" in r["tilt_through_sphere"]
    assert "e12" in r["yaw_through_sphere"] and "point pair" in r["yaw_through_sphere"]
    assert "e1∞" in r["translation_through_flat_plane"] and "coplanar" in r["translation_through_flat_plane"]
    assert "cannot dilate" in r["dilation_through_sphere"]
    assert "timing" not in json.dumps(m)


def test_mujoco(run):
    """MuJoCo: the free body follows the plan within 2 mm / 1°, the lifted legs touch nothing, and the run's
    model.xml + log.npz replay with MuJoCo alone, bit for bit."""
    from coop_ga.sim import replay

    mj = read_metrics(run)["mujoco"]
    assert mj["max_position_error_m"] <= 0.002 and mj["max_rotation_error_deg"] <= 1.0
    assert mj["lifted_leg_contacts"] == 0 and mj["saturated_updates"] == 0 and mj["effort_ratio"] < 1.0
    assert mj["max_stance_ball_offset_m"] < 0.003
    assert (run / "model.xml").exists() and mj["log"]["log_version"] == 1
    log = np.load(run / "log.npz")
    assert {"time", "qpos", "qvel", "ctrl"} <= set(log.files) and log["qpos"].shape[1] == 7 + 18
    assert replay(run) == 0.0
    from PIL import Image

    gif = Image.open(run / "posture.gif")
    assert gif.n_frames >= 20 and (run / "posture.gif").stat().st_size < 3_000_000


def test_trajectory_npz(run):
    d = np.load(run / "trajectory.npz")
    T = d["t"].shape[0]
    assert d["q"].shape == (T, 18) and d["body"].shape == (T, 7) and d["stance"].shape == (T, 6)
    assert d["stance"].dtype == np.bool_ and d["stance"].sum(axis=1).tolist() == [4] * T
    assert d["margin"].min() >= 0.010
    np.testing.assert_allclose(np.linalg.norm(d["body"][:, 3:], axis=1), 1.0, atol=1e-12)
    assert str(d["terrain_kind"]) == "random"
    # an independent check with Pinocchio and the floating system: the stance feet stay put in W
    import pinocchio as pin

    import coop_ga as cg
    from coop_ga.legged.body import BodyState

    s = cg.systems.load("hexapod", free_flyer=True)
    m, data = s.model, s.model.createData()
    legs = ("lf", "lm", "lr", "rf", "rm", "rr")
    stance = [leg for leg, on in zip(legs, d["stance"][0]) if on]
    fids = [m.getFrameId(f"{leg}_foot") for leg in stance]
    feet = []
    for k in range(0, T, max(1, T // 20)):
        st = BodyState.from_quaternion(d["body"][k, :3], d["body"][k, 3:], d["q"][k])
        pin.framesForwardKinematics(m, data, st.free_flyer_q())
        feet.append([data.oMf[f].translation.copy() for f in fids])
    feet = np.array(feet)
    assert np.max(np.abs(feet - feet[0])) < 1e-12
    # the balls rest on the terrain: their centres one radius above it
    from coop_ga.legged.terrain import Terrain

    terrain = Terrain.from_arrays({k: d[k] for k in d.files if k.startswith("terrain_")})
    np.testing.assert_allclose(terrain.solid_distance(feet[0]), 0.009, atol=1e-12)
