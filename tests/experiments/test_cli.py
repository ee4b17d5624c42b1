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
    """The paper's scripts are all found (new scripts may join; each gets the --help test below)."""
    names = sorted(Path(s).name for s in SCRIPTS)
    assert len(names) >= 23
    assert set(names) >= set(
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


# ---------------------------------------------------------------------- --fast never overrides an explicit option
EXPERIMENTS = [s for s in SCRIPTS if s.startswith("experiments/")]


class _Parsed(Exception):
    """Raised right after an Experiment parsed its command line (carries the Experiment)."""


def _parse_only(script, argv, monkeypatch):
    """The script's Experiment after parsing ``argv`` (the script stops there)."""
    from coop_ga.harness import Experiment

    parse = Experiment.parse

    def stop(self, argv=None):
        parse(self, argv)
        raise _Parsed(self)

    monkeypatch.setattr(Experiment, "parse", stop)
    with pytest.raises(_Parsed) as ex:
        _main(script)(argv)
    return ex.value.args[0]


@pytest.mark.parametrize("script", EXPERIMENTS)
def test_fast_keeps_every_explicit_option(script, monkeypatch, tmp_path):
    """Every experiment declares --fast through the harness, and an option given with it keeps its value
    (here: each preset option given explicitly at its full-run default)."""
    exp = _parse_only(script, ["--fast", "--quiet", "--out", str(tmp_path)], monkeypatch)
    assert exp.fast is True
    actions = {a.dest: a for a in exp.parser._actions}
    argv = ["--fast", "--quiet", "--out", str(tmp_path)]
    for dest in exp.fast_presets:
        d = actions[dest].default
        argv += [actions[dest].option_strings[0], *map(str, d if isinstance(d, (list, tuple)) else [d])]
    exp = _parse_only(script, argv, monkeypatch)
    for dest in exp.fast_presets:
        got, want = getattr(exp.args, dest), actions[dest].default
        assert (list(got) if isinstance(got, (list, tuple)) else got) == (
            list(want) if isinstance(want, (list, tuple)) else want
        ), dest


@pytest.mark.parametrize("script", EXPERIMENTS)
def test_no_script_replaces_an_option_under_fast_itself(script, monkeypatch, tmp_path):
    """The old pattern ``dt = 0.04 if args.fast else args.dt`` (and ``min(args.runs, 4) if args.fast``)
    is gone: a line that reads args.fast reads no other option (the presets live in add_fast)."""
    exp = _parse_only(script, ["--quiet", "--out", str(tmp_path)], monkeypatch)
    dests = {a.dest for a in exp.parser._actions} - {"fast", "help"}
    import re

    for i, line in enumerate((ROOT / script).read_text().splitlines(), 1):
        if "args.fast" in line:
            used = set(re.findall(r"args\.(\w+)", line)) & dests
            assert not used, f"{script}:{i} decides {sorted(used)} from --fast: {line.strip()}"


@pytest.mark.parametrize("argv", [["--fast", "--dt", "5"], ["--dt", "0.6"], ["--gait", "wave", "--dt", "1.5"]])
def test_hexapod_walk_refuses_a_step_coarser_than_its_gait_grid(argv, capsys, tmp_path):
    """Old: ``--fast --dt 5`` ran at Δt = 0.038 s (the fast preset, rounded), and ``--dt 5`` at 0.267 s
    (walk() clamps to six knots per cycle) — both silently."""
    with pytest.raises(SystemExit) as ex:
        _main("experiments/hexapod_walk.py")([*argv, "--quiet", "--out", str(tmp_path)])
    assert ex.value.code == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "argument --dt:" in err and "too coarse" in err and "give --dt <" in err
