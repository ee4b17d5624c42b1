"""Every gait × terrain row of the physics walk, with the map and blind, as a short walk against the issue's bar;
and the experiment script's files."""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("mujoco")

from coop_ga.legged import Terrain
from coop_ga.sim.walking import VelocityCommand, WalkingOptions
from coop_ga.sim.walking_run import BAR, simulate_walk
from tests.helpers import read_metrics, script_main

SCRIPT = Path(__file__).resolve().parents[2] / "experiments" / "sim_hexapod_walk.py"
#: simulated seconds of a short walk per gait: about two swings of every leg group after a quick ramp
SHORT = {"tripod": 1.9, "ripple": 2.4, "wave": 2.6}


def short_walk(gait: str, terrain: str, blind: bool):
    opt = WalkingOptions(gait=gait, blind=blind)
    tab = opt.table()
    v = 0.08 / (tab.duty * tab.period)
    ramp = 0.4
    opt = WalkingOptions(gait=gait, blind=blind, max_accel=v / ramp)
    cmd = VelocityCommand.constant(v, start=0.2, ramp=ramp)
    return simulate_walk(Terrain.make(terrain), cmd, opt, duration=SHORT[gait], label=f"{gait}_{terrain}")


@pytest.mark.parametrize("blind", [False, True], ids=["map", "blind"])
@pytest.mark.parametrize("terrain", ["flat", "slope", "steps", "random"])
@pytest.mark.parametrize("gait", ["tripod", "ripple", "wave"])
def test_short_walk_meets_the_bar(gait: str, terrain: str, blind: bool) -> None:
    run = short_walk(gait, terrain, blind)
    m = run.metrics()
    assert m["walked_fraction"] >= 0.9, run.summary()  # short walks: a few mm of lag is several %
    assert not m["fell"], run.summary()
    assert max(m["max_roll_deg"], m["max_pitch_deg"]) <= BAR["max_tilt_deg"]
    assert m["max_height_error_m"] <= BAR["max_height_error_m"]
    assert m["max_slip_m"] <= BAR["max_slip_m"], run.summary()
    assert m["saturated_updates"] == 0 and m["effort_ratio"] <= 1.0, run.summary()
    assert m["shin_contact_steps"] == 0, run.summary()


def test_script_writes_the_run_files_and_the_table(tmp_path) -> None:
    out = tmp_path / "walk"
    assert (
        script_main(SCRIPT)(
            ["--gait", "tripod", "--terrain", "flat", "--distance", "0.1", "--quiet", "--out", str(out)]
        )
        == 0
    )
    doc = read_metrics(out)
    run = doc["runs"]["tripod_flat_map"]
    assert run["passed"] and doc["all_passed"] and doc["gallery"]["agrees"]
    assert (out / "walk_tripod_flat_map.gif").stat().st_size > 10_000
    assert "tripod_flat_map" in (out / "table.md").read_text()
    folder = out / "tripod_flat_map"
    assert {p.name for p in folder.iterdir()} >= {"model.xml", "log.npz", "metrics.json"}
    assert read_metrics(folder)["walk"]["label"] == "tripod_flat_map"


def test_help_and_bad_values(capsys) -> None:
    with pytest.raises(SystemExit) as ex:
        script_main(SCRIPT)(["--help"])
    assert ex.value.code == 0
    text = capsys.readouterr().out
    for opt in ("--gait", "--terrain", "--blind", "--all", "--fast", "--jobs", "--gifs", "--command"):
        assert opt in text
    with pytest.raises(SystemExit) as ex:
        script_main(SCRIPT)(["--terrain", "ice"])
    assert ex.value.code == 2
