"""The ablation's numbers: under an unknown 3 cm step and an unknown 5° slope the stance-primitive feedback keeps
the body's attitude and height closer to their references than the open-loop replay of the kinematic plan."""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("mujoco")

from coop_ga.sim.walking_experiments import ablation_row
from tests.helpers import script_main

SCRIPT = Path(__file__).resolve().parents[2] / "experiments" / "sim_hexapod_ablation.py"


@pytest.fixture(scope="module")
def ablation():
    out = {}
    for disturbance in ("step", "slope"):
        for variant in ("feedback", "open_loop"):
            out[(disturbance, variant)] = ablation_row(variant, disturbance, 0.22)[0]
    return out


@pytest.mark.parametrize("disturbance", ["step", "slope"])
def test_feedback_beats_the_open_loop_replay(ablation, disturbance: str) -> None:
    fb, ol = ablation[(disturbance, "feedback")], ablation[(disturbance, "open_loop")]
    tilt = lambda m: max(m["max_roll_deg"], m["max_pitch_deg"])  # noqa: E731
    assert tilt(fb) < tilt(ol), (tilt(fb), tilt(ol))
    assert fb["max_height_error_m"] < ol["max_height_error_m"]
    assert not fb["fell"] and fb["saturated_updates"] == 0 and fb["shin_contact_steps"] == 0


def test_slope_numbers(ablation) -> None:
    """The unknown 5° slope: the feedback holds the body level to a fraction of a degree and its height to a few
    mm; the replay, planned for flat ground, tilts by ≥ 0.5° and sinks by ≥ 5 mm toward the slope."""
    fb, ol = ablation[("slope", "feedback")], ablation[("slope", "open_loop")]
    assert max(fb["max_roll_deg"], fb["max_pitch_deg"]) < 0.5 and fb["max_height_error_m"] < 0.004
    assert max(ol["max_roll_deg"], ol["max_pitch_deg"]) > 0.5 and ol["max_height_error_m"] > 0.005


def test_help_lists_the_options(capsys) -> None:
    with pytest.raises(SystemExit) as ex:
        script_main(SCRIPT)(["--help"])
    assert ex.value.code == 0
    text = capsys.readouterr().out
    for opt in ("--distance", "--jobs", "--fast", "--out"):
        assert opt in text
