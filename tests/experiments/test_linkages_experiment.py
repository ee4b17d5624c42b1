"""experiments/linkages.py --fast: every linkage completes its cycle, the numbers back the gallery claim."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.helpers import script_main

SCRIPT = Path(__file__).resolve().parents[2] / "experiments" / "linkages.py"


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("linkages")
    assert script_main(SCRIPT)(["--fast", "--quiet", "--out", str(out)]) == 0
    return out, json.loads((out / "metrics.json").read_text())


def test_every_cycle_is_complete_and_exact(run) -> None:
    _, m = run
    assert m["all_complete"] is True
    assert m["max_residual"] < 1e-10
    assert m["max_link_length_error"] < 1e-12
    L = m["linkages"]
    assert [L[k]["grubler_dof"] for k in ("four_bar", "slider_crank", "watt_six_bar", "ten_bar")] == [1, 1, 1, 1]
    assert (L["ten_bar"]["links"], L["ten_bar"]["joints"]) == (10, 13)
    assert (L["watt_six_bar"]["links"], L["watt_six_bar"]["joints"]) == (6, 7)
    assert max(L["four_bar"]["freudenstein_error_branch_plus"], L["four_bar"]["freudenstein_error_branch_minus"]) < 1e-9
    assert L["slider_crank"]["slider_x_max_abs"] < 1e-12
    assert L["slider_crank"]["slider_y_range"] == pytest.approx([3.0, 5.0], abs=1e-3)
    ng = L["non_grashof_four_bar"]
    assert ng["complete"] is False and ng["grashof"] == "triple-rocker"
    assert ng["stop_angle_error_rad"] < 1e-6 and ng["sigma_min_at_stop"] < 1e-3


def test_outputs_and_gallery(run) -> None:
    out, m = run
    g = m["gallery"]
    assert g["agrees"] is True and g["figures"][0] == "coupler_curves.png"
    for f in g["figures"]:
        assert (out / f).stat().st_size > 1000, f
    assert {p.name for p in out.glob("*.gif")} == {
        "four_bar.gif",
        "slider_crank.gif",
        "watt_six_bar.gif",
        "ten_bar.gif",
    }
    assert "seconds_per_step" in " ".join(json.loads((out / "timing.json").read_text()))
    assert "seconds" not in " ".join(m)  # no wall time in the committed metrics
