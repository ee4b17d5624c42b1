"""coop_ga.harness: CLI options and checked values, strict JSON, seeding, quiet, backend."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from coop_ga import harness
from coop_ga.harness import Experiment

ROOT = Path(__file__).resolve().parents[1]


def _exp(seed=7):
    e = Experiment("/x/demo_script.py", "Demo experiment.\n\n    indented usage line", seed=seed)
    e.add("--duration", type=harness.positive_float, default=4.0, help="simulated time [s]")
    e.add("--runs", type=harness.int_at_least(2), default=10, help="number of runs")
    e.add("--p", type=harness.probability, default=0.5, help="a probability")
    e.add("--mode", choices=("a", "b"), default="a", help="a choice")
    return e


def test_help_shows_every_default(capsys):
    with pytest.raises(SystemExit) as ex:
        _exp().parse(["--help"])
    assert ex.value.code == 0
    raw = capsys.readouterr().out
    out = " ".join(raw.split())  # argparse wraps lines at the terminal width
    assert "usage: demo_script.py" in out and "\n    indented usage line\n" in raw  # docstring layout kept
    for opt, default in (
        ("--out", "results/demo_script"),
        ("--seed", "7"),
        ("--duration", "4.0"),
        ("--runs", "10"),
        ("--mode", "a"),
    ):
        assert opt in out and f"(default: {default})" in out, (opt, default)
    assert "--quiet" in out


@pytest.mark.parametrize(
    "argv,option,words",
    [
        (["--seed", "abc"], "--seed", "expected an integer, got 'abc'"),
        (["--seed", "-3"], "--seed", "expected an integer >= 0"),
        (["--duration", "-1"], "--duration", "expected a number > 0, got '-1'"),
        (["--duration", "nan"], "--duration", "expected a finite number"),
        (["--runs", "1"], "--runs", "expected an integer >= 2"),
        (["--p", "1.5"], "--p", "expected a probability in [0, 1]"),
        (["--mode", "c"], "--mode", "invalid choice"),
    ],
)
def test_bad_values_exit_2_naming_the_option(capsys, argv, option, words):
    with pytest.raises(SystemExit) as ex:
        _exp().parse(argv)
    assert ex.value.code == 2
    err = capsys.readouterr().err
    assert f"argument {option}:" in err and words in err, err


def test_parse_creates_out_and_seeds_rng(tmp_path):
    e = _exp()
    args = e.parse(["--out", str(tmp_path / "a" / "b"), "--duration", "2.5"])
    assert args.duration == 2.5 and args.runs == 10 and args.seed == 7
    assert e.out.is_dir() and e.out == tmp_path / "a" / "b"
    draws = e.rng.uniform(size=5)
    e2 = _exp()
    e2.parse(["--out", str(tmp_path / "c")])
    np.testing.assert_array_equal(e2.rng.uniform(size=5), draws)  # same seed, same draws
    e3 = _exp()
    e3.parse(["--out", str(tmp_path / "d"), "--seed", "8"])
    assert not np.array_equal(e3.rng.uniform(size=5), draws)
    np.testing.assert_array_equal(harness.make_rng(7).uniform(size=5), draws)


def _strict(text):
    def bad(name):
        raise ValueError(f"non-standard JSON constant {name}")

    return json.loads(text, parse_constant=bad)


def test_json_is_strict_and_nan_becomes_null(tmp_path):
    obj = {
        "nan": float("nan"),
        "inf": np.inf,
        "ninf": -np.float32(np.inf),
        "arr": np.array([1.0, np.nan, 3.0]),
        "int": np.int64(4),
        "bool": np.bool_(True),
        "f32": np.float32(0.5),
        "tuple": (1, 2.5),
        3: "int key",
        "path": Path("a/b"),
        "nested": [{"x": np.array([[np.inf]])}],
    }
    p = harness.write_json(tmp_path / "sub" / "m.json", obj)
    back = _strict(p.read_text())
    assert back == {
        "nan": None,
        "inf": None,
        "ninf": None,
        "arr": [1.0, None, 3.0],
        "int": 4,
        "bool": True,
        "f32": 0.5,
        "tuple": [1, 2.5],
        "3": "int key",
        "path": "a/b",
        "nested": [{"x": [[None]]}],
    }
    with pytest.raises(TypeError, match="cannot encode a complex"):
        harness.write_json(tmp_path / "c.json", {"z": 1j})


def test_npz_roundtrip(tmp_path):
    p = harness.write_npz(tmp_path / "d" / "x.npz", a=np.arange(3), b=np.eye(2))
    d = np.load(p)
    np.testing.assert_array_equal(d["a"], [0, 1, 2])
    np.testing.assert_array_equal(d["b"], np.eye(2))


def test_quiet_prints_nothing_on_stderr(tmp_path, capsys):
    e = _exp()
    e.parse(["--out", str(tmp_path), "--quiet"])
    with e.stage("compiling") as st:
        total = sum(e.progress(range(50), "summing"))
    assert total == 1225 and st.seconds >= 0
    assert capsys.readouterr().err == ""
    e = _exp()
    e.parse(["--out", str(tmp_path)])
    with e.stage("compiling"):
        list(e.progress(range(5), "looping"))
    err = capsys.readouterr().err
    assert err.startswith("compiling ...\n") and "looping" in err and "5/5" in err
    assert "compiling: done (" in err  # the bar broke the stage's line: the result names the stage
    with e.stage("loading"):
        pass
    assert capsys.readouterr().err.startswith("loading ... done (")


def test_headless_backend():
    import matplotlib

    assert harness.use_backend().lower() == "agg"
    plt = _exp().pyplot()
    assert matplotlib.get_backend().lower() == "agg"
    from coop_ga.viz import DPI

    assert plt.rcParams["savefig.dpi"] == DPI


def test_script_quiet_run_has_empty_stderr(tmp_path):
    """A whole experiment with --quiet writes nothing on stderr (and its strict JSON)."""
    r = subprocess.run(
        [
            sys.executable,
            str(ROOT / "experiments" / "nullspace_secondary.py"),
            "--out",
            str(tmp_path),
            "--quiet",
            "--fast",  # every output still written; 4 animation frames (30 took 28 of the run's 37 s)
            "--duration",
            "0.5",
        ],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=ROOT,
        check=False,
    )
    assert r.returncode == 0, r.stderr
    assert r.stderr == ""
    m = _strict((tmp_path / "metrics.json").read_text())
    assert m["seed"] == 0 and m["nullspace"]["max_similarity_distance"] < 1e-3


def test_script_rejects_bad_value():
    r = subprocess.run(
        [sys.executable, str(ROOT / "experiments" / "nullspace_secondary.py"), "--duration", "-1"],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=ROOT,
        check=False,
    )
    assert r.returncode == 2
    assert "argument --duration: expected a number > 0, got '-1'" in r.stderr


def test_write_npz_is_byte_reproducible(tmp_path):
    # numpy.savez_compressed stamps the current time; ours must give identical bytes
    import time

    a = harness.write_npz(tmp_path / "a.npz", x=np.arange(4.0), y=np.eye(2))
    time.sleep(2.1)  # zip timestamps have 2 s resolution
    b = harness.write_npz(tmp_path / "b.npz", y=np.eye(2), x=np.arange(4.0))
    assert a.read_bytes() == b.read_bytes()
    d = np.load(a)
    np.testing.assert_array_equal(d["x"], np.arange(4.0))
    np.testing.assert_array_equal(d["y"], np.eye(2))


def test_experiment_rounds_metrics_and_splits_timing(tmp_path):
    exp = harness.Experiment("demo.py", "demo", seed=0)
    exp.parse(["--out", str(tmp_path), "--quiet"])
    p = exp.write_json("m.json", {"e": 1.234567891e-7, "v": [np.float64(2.0 / 3.0)], "n": 3})
    assert json.loads(p.read_text()) == {"e": 1.23457e-07, "v": [0.666667], "n": 3}
    t = exp.write_timing({"solve_s": 0.123456})
    assert t.name == harness.TIMING_FILE and json.loads(t.read_text()) == {"solve_s": 0.123}


# ---------------------------------------------------------------------- --fast and explicit options
def _fast_exp():
    e = _exp()
    e.add("--dt", type=harness.positive_float, default=0.02, help="time step [s]")
    e.add("--target", type=harness.finite_float, nargs=3, default=(0.0, 0.0, 1.0), help="a 3-vector")
    e.add_fast("short run (CI)", dt=0.04, runs=3, target=(1.0, 2.0, 3.0))
    return e


@pytest.mark.parametrize(
    "argv,expected",
    [
        ([], {"dt": 0.02, "runs": 10, "target": (0.0, 0.0, 1.0), "fast": False}),
        (["--fast"], {"dt": 0.04, "runs": 3, "target": (1.0, 2.0, 3.0), "fast": True}),
        # an explicit option wins over --fast, before or after it, also when it repeats the default
        (["--fast", "--dt", "5"], {"dt": 5.0, "runs": 3, "target": (1.0, 2.0, 3.0)}),
        (["--dt", "0.02", "--fast"], {"dt": 0.02, "runs": 3}),
        (["--fast", "--runs", "10", "--target", "0", "0", "1"], {"dt": 0.04, "runs": 10, "target": [0.0, 0.0, 1.0]}),
        (["--dt", "0.5"], {"dt": 0.5, "runs": 10}),
    ],
)
def test_explicit_options_win_over_fast_presets(tmp_path, argv, expected, capsys):
    """Old: each script replaced its options under --fast (``dt = 0.04 if args.fast else args.dt``), so
    ``hexapod_walk.py --fast --dt 5`` silently ran at Δt = 0.038 s."""
    e = _fast_exp()
    args = e.parse([*argv, "--out", str(tmp_path)])
    for k, v in expected.items():
        assert getattr(args, k) == v, k
    assert e.fast is ("--fast" in argv)
    err = capsys.readouterr().err
    kept = [k for k in ("dt", "runs", "target") if f"--{k}" in argv] if "--fast" in argv else []
    assert ("--fast: kept the explicit" in err) == bool(kept)
    for k in kept:
        assert f"{k} = " in err


def test_explicit_options_are_detected_without_changing_the_parser(tmp_path):
    e = _fast_exp()
    assert harness.explicit_options(e.parser, ["--dt", "0.02", "--mode", "b", "--fast"]) == {"dt", "mode", "fast"}
    assert harness.explicit_options(e.parser, []) == set()
    assert e.parse(["--out", str(tmp_path)]).dt == 0.02  # defaults untouched by the probe


def test_fast_presets_name_existing_options_and_are_listed_in_help(capsys):
    with pytest.raises(ValueError, match="no option with dest 'steps'"):
        _exp().add_fast("x", steps=3)
    with pytest.raises(SystemExit):
        _fast_exp().parse(["--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert (
        "short run (CI) (--dt 0.04, --runs 3, --target 1.0 2.0 3.0; an option given explicitly keeps its value)" in out
    )


def test_quiet_fast_run_says_nothing_about_kept_options(tmp_path, capsys):
    _fast_exp().parse(["--fast", "--dt", "5", "--quiet", "--out", str(tmp_path)])
    assert capsys.readouterr().err == ""
