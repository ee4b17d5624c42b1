"""experiments/hexapod_posture.py (issue 13 item 7): runs in --fast mode, feet fixed, limits kept, numbers sane."""

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


def testread_metrics(run):
    m = read_metrics(run)
    g = m["gallery"]
    assert g["agrees"] is True
    for f in g["figures"]:
        assert (run / f).stat().st_size > 10_000, f
    assert m["primitive"] == "sphere" and len(m["stance_legs"]) == 4
    assert m["well_definedness_initial"] > 0.01 and m["sphere_radius_m"] < 0.5
    # feet fixed: slip per step far below the 0.1 mm, the linearised step alone would slip
    assert m["max_slip_m"] < 1e-12 < m["slip_limit_m"]
    assert m["max_drift_m"] < 1e-12
    assert m["max_linear_slip_m"] > 1e-7
    assert m["max_limit_violation"] == 0.0
    ph = m["phases"]
    for name in ("translate", "tilt", "yaw"):
        assert ph[name]["displacement_error_m"] < 1e-6, name
        assert ph[name]["rotation_error_rad"] < 1e-6, name
        assert ph[name]["max_radius_rate_error"] < 1e-9, name
    assert m["return_position_error_m"] < 1e-6 and m["return_rotation_error_rad"] < 1e-6
    for name in ("spread", "crouch"):
        d = ph[name]
        # the radius cannot change with the feet fixed: the whole β is tracking error
        assert d["integrated_radius_error"] == pytest.approx(d["commanded_beta"], abs=1e-9)
        assert abs(d["sphere_radius_change_m"]) < 1e-12
        # the centre moved as commanded (to the explicit-Euler step)
        assert d["sphere_centre_distance_ratio"] == pytest.approx(d["sphere_centre_distance_ratio_commanded"], rel=3e-3)
    assert ph["spread"]["sphere_centre_distance_ratio"] > 1.05 and ph["crouch"]["sphere_centre_distance_ratio"] < 0.85
    assert "timing" not in json.dumps(m)


def test_trajectory_npz(run):
    d = np.load(run / "trajectory.npz")
    T = d["t"].shape[0]
    assert d["q"].shape == (T, 18) and d["body"].shape == (T, 7) and d["stance"].shape == (T, 6)
    assert d["stance"].dtype == np.bool_ and d["stance"].sum(axis=1).tolist() == [4] * T
    np.testing.assert_allclose(np.linalg.norm(d["body"][:, 3:], axis=1), 1.0, atol=1e-12)
    assert str(d["terrain_kind"]) == "random"
    # an independent check with Pinocchio and the floating system: the stance feet stay put in W
    import pinocchio as pin

    import coop_ga as cg
    from coop_ga.legged.body import BodyState

    s = cg.systems.load("hexapod_floating")
    m, data = s.model, s.model.createData()
    legs = ("lf", "lm", "lr", "rf", "rm", "rr")
    stance = [leg for leg, on in zip(legs, d["stance"][0]) if on]
    fids = [m.getFrameId(f"{leg}_foot") for leg in stance]
    feet = []
    for k in range(0, T, max(1, T // 20)):
        st = BodyState.from_quaternion(d["body"][k, :3], d["body"][k, 3:], d["q"][k])
        pin.framesForwardKinematics(m, data, st.floating_q())
        feet.append([data.oMf[f].translation.copy() for f in fids])
    feet = np.array(feet)
    assert np.max(np.abs(feet - feet[0])) < 1e-12
    # and on the terrain
    from coop_ga.legged.terrain import Terrain

    terrain = Terrain.from_arrays({k: d[k] for k in d.files if k.startswith("terrain_")})
    assert np.max(np.abs(terrain.signed_distance(feet[0]))) < 1e-12
