"""Every experiment, figure and benchmark script has the harness's command line."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
SCRIPTS = sorted(
    str(p.relative_to(ROOT))
    for d in ("experiments", "paper_figures", "benchmarks")
    for p in (ROOT / d).glob("*.py")
    if not p.name.startswith("_")
)


def _main(script: str):
    path = ROOT / script
    name = f"cli_{path.stem}"
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod  # dataclasses defined in a script look their module up here
    spec.loader.exec_module(mod)
    return mod.main


def test_scripts_found():
    names = sorted(Path(s).name for s in SCRIPTS)
    assert names == sorted(
        [
            *("circle_reaching.py", "impedance_three_iiwa.py", "line_constraint.py", "nullspace_secondary.py"),
            *("reaching.py", "singularity.py", "table1.py", "teleop_allegro.py"),  # experiments
            *("hexapod_posture.py", "hexapod_walk.py", "linkages.py", "obstacle_circle.py", "potential_field.py"),
            "systems.py",  # paper_figures (the runner is the package's __main__)
            *("algebra.py", "cooperative.py", "kinematics.py", "ocp.py", "robustness.py"),  # benchmarks
            *("legged.py", "linkages.py", "motor_fk.py", "sweep.py"),  # benchmarks: our additions
        ]
    ), names


@pytest.mark.parametrize("script", SCRIPTS)
def test_help_and_bad_seed(script, capsys):
    main = _main(script)
    with pytest.raises(SystemExit) as ex:
        main(["--help"])
    assert ex.value.code == 0
    out = " ".join(capsys.readouterr().out.split())
    for opt in ("--out", "--seed", "--quiet"):
        assert opt in out, opt
    assert "(default: " in out
    with pytest.raises(SystemExit) as ex:
        main(["--seed", "abc"])
    assert ex.value.code == 2
    assert "argument --seed: expected an integer, got 'abc'" in capsys.readouterr().err


def test_system_figures(tmp_path):
    """paper_figures/systems.py draws the chosen systems (one PNG each, not blank)."""
    import matplotlib.image as mpimg

    assert _main("paper_figures/systems.py")(["--out", str(tmp_path), "--only", "allegro", "g1_arms", "--quiet"]) == 0
    for name in ("allegro", "g1_arms"):
        img = mpimg.imread(tmp_path / f"{name}.png")
        assert img.shape[0] > 500 and float(np.std(img[..., :3])) > 0.05
    assert sorted(p.name for p in tmp_path.iterdir()) == ["allegro.png", "g1_arms.png", "metrics.json"]


def test_unknown_system_is_rejected(capsys):
    with pytest.raises(SystemExit) as ex:
        _main("paper_figures/systems.py")(["--only", "no_such_system"])
    assert ex.value.code == 2
    assert "argument --only: invalid choice: 'no_such_system'" in capsys.readouterr().err
