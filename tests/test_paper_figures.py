"""The figures runner ``python -m paper_figures``: selection, checks, gallery."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import paper_figures
from paper_figures.__main__ import _limit_violations, _output_problems, main, write_gallery


def test_every_figure_of_the_paper_has_an_entry():
    covered = {n for f in paper_figures.FIGURES for n in f.numbers}
    assert covered == set(range(5, 22)), sorted(set(range(5, 22)) - covered)  # Figs. 5–21
    assert any(f.key == "table01" for f in paper_figures.FIGURES)
    for f in paper_figures.FIGURES:
        assert (paper_figures.ROOT / f.script).exists(), f.script
        if f.numbers:  # figNN_<name>, NN the paper's first number, two digits
            assert f.folder.startswith(f"fig{f.numbers[0]:02d}_"), f.folder


@pytest.mark.parametrize(
    "name,keys",
    [
        ("fig12", ["fig12"]),
        ("fig17", ["fig16_17"]),
        ("16", ["fig16_17"]),
        ("fig05_06_impedance", ["fig05_06"]),
        ("table1", ["table01"]),
        ("TABLE01", ["table01"]),
    ],
)
def test_select_by_key_folder_or_number(name, keys):
    assert [f.key for f in paper_figures.select([name])] == keys


def test_select_keeps_gallery_order_and_refuses_unknown_names():
    assert [f.key for f in paper_figures.select(["fig20", "fig07", "fig21"])] == ["fig07", "fig20_21"]
    with pytest.raises(ValueError, match=r"unknown figure 'fig99'.*choose from"):
        paper_figures.select(["fig99"])
    with pytest.raises(SystemExit) as ex:
        main(["--only", "fig99"])
    assert ex.value.code == 2


def test_limit_violations_are_found_anywhere_in_the_metrics():
    m = {"max_limit_violation": 0.0, "a": {"max_limit_violation": 0.2}, "runs": [{"max_limit_violation": 1e-3}]}
    assert _limit_violations(m) == [("a.max_limit_violation", 0.2), ("runs[0].max_limit_violation", 1e-3)]
    assert _limit_violations({"max_limit_violation": 0}) == []


def test_runner_writes_folders_and_gallery(tmp_path, capsys):
    assert main(["--only", "table01", "systems", "--fast", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "[1/2]" in out and "[2/2]" in out and "done in" in out  # progress per figure
    for folder in ("systems", "table01_controllable_spaces"):
        m = json.loads((tmp_path / folder / "metrics.json").read_text())
        assert m["gallery"]["claim"] and m["gallery"]["evidence"]
        assert (tmp_path / folder / "log.txt").exists()
    text = (tmp_path / "README.md").read_text()
    assert "## Table 1: controllable bivector spaces" in text
    assert "![systems/allegro.png](systems/allegro.png)" in text
    assert "python -m paper_figures --only table01" in text
    assert "Fast mode" in text
    # deterministic: a second run leaves metrics and gallery byte-identical
    before = {
        p: p.read_bytes() for p in tmp_path.rglob("*") if p.suffix in (".json", ".md") and p.name != "timing.json"
    }
    # (the second run re-makes Table 1 only, to keep the test short; the gallery page is written from every folder
    # present, so it must come out byte-identical too)
    assert main(["--only", "table01", "--fast", "--quiet", "--out", str(tmp_path)]) == 0
    after = {p: p.read_bytes() for p in before}
    assert after == before


def test_a_failing_figure_is_reported_and_the_rest_still_runs(tmp_path, monkeypatch, capsys):
    bad = paper_figures.Figure("table01", "table01_controllable_spaces", "experiments/table1.py", ("--samples", "0"))
    monkeypatch.setattr(paper_figures.__main__, "FIGURES", (bad,))
    monkeypatch.setattr(paper_figures.__main__, "select", lambda names: [bad])
    assert main(["--out", str(tmp_path)]) == 1
    out = capsys.readouterr().out
    assert "FAILED" in out and "exited with status 2" in out
    assert "This figure failed in the last run" in write_gallery(tmp_path, False, {"table01": ["x"]}).read_text()


def test_help_lists_the_options(capsys):
    with pytest.raises(SystemExit) as ex:
        main(["--help"])
    assert ex.value.code == 0
    out = " ".join(capsys.readouterr().out.split())
    for opt in ("--out", "--only", "--fast", "--jobs", "--seed", "--quiet", "--list"):
        assert opt in out, opt
    assert "usage: python -m paper_figures" in out


def test_stale_outputs_are_removed_before_a_figure_runs(tmp_path):
    folder = tmp_path / "table01_controllable_spaces"
    folder.mkdir()
    (folder / "old_figure.png").write_bytes(b"stale")
    (folder / "notes.keep").write_text("not an output")
    assert main(["--only", "table01", "--fast", "--quiet", "--out", str(tmp_path)]) == 0
    assert not (folder / "old_figure.png").exists()
    assert (folder / "notes.keep").exists() and (folder / "table1.md").exists()


# ---------------------------------------------------------------------- the one command, every figure
#: every figure's script runs in its own test (tests/experiments/, checked below), which asserts its numbers; the
#: runner itself is run here on two figures (a reaching preset and the nullspace pair), and its output checks are
#: applied to every committed folder (what ``python -m paper_figures`` last wrote)
RUN_HERE = [f for f in paper_figures.FIGURES if f.key in ("fig07", "fig16_17")]
EXPERIMENT_TESTS = paper_figures.ROOT / "tests" / "experiments"


@pytest.fixture(scope="module")
def fast_run(tmp_path_factory):
    """``python -m paper_figures --fast`` over the figures of :data:`RUN_HERE`, once for the checks below."""
    out = tmp_path_factory.mktemp("paper_figures_fast")
    rc = main(["--fast", "--quiet", "--out", str(out), "--only", *(f.key for f in RUN_HERE)])
    return rc, out


@pytest.mark.parametrize("fig", paper_figures.FIGURES, ids=lambda f: f.key)
def test_every_figure_script_has_its_own_test(fig):
    """The script's own test runs it (a file of tests/experiments naming the script); the runner's test above
    covers the systems page and Table 1."""
    stem = Path(fig.script).stem
    if fig.key in ("systems", "table01"):
        return
    assert any(stem in p.read_text() for p in EXPERIMENT_TESTS.glob("test_*.py") if p.name != "test_cli.py"), stem


@pytest.mark.parametrize("fig", paper_figures.FIGURES, ids=lambda f: f.key)
def test_every_committed_folder_passes_the_runner_checks(fig):
    """The committed outputs: metrics with a complete gallery block, every listed picture present and a real image,
    no trajectory outside the joint limits (the checks ``python -m paper_figures`` applies after each script)."""
    folder = paper_figures.ROOT / "paper_figures" / fig.folder
    assert _output_problems(folder) == []
    g = json.loads((folder / "metrics.json").read_text())["gallery"]
    for name in g["figures"]:
        assert (folder / name).stat().st_size > 10_000, (fig.key, name)
    text = (paper_figures.ROOT / "paper_figures" / "README.md").read_text()
    assert g["title"] in text and g["evidence"] in text, fig.key  # the gallery page shows it


def _metrics(out, key):
    fig = next(f for f in paper_figures.FIGURES if f.key == key)
    return json.loads((out / fig.folder / "metrics.json").read_text())


def test_fast_run_succeeds_for_every_figure(fast_run):
    rc, out = fast_run
    assert rc == 0  # no script failed, every listed figure exists, nothing left the joint limits
    text = (out / "README.md").read_text()
    for f in RUN_HERE:
        g = _metrics(out, f.key)["gallery"]
        assert g["title"] in text and g["evidence"] in text
        for name in g["figures"]:
            assert (out / f.folder / name).stat().st_size > 10_000, (f.key, name)  # a real image


def test_fast_reaching_figure_converges_inside_the_limits(fast_run):
    m = _metrics(fast_run[1], "fig07")
    assert m["converged"] is True and m["terminal_error"] < 1e-5
    assert 1 <= m["iterations"] <= 5  # the paper: "typically five or less iterations"
    assert m["max_limit_violation"] == 0.0


# ---------------------------------------------------------------------- regeneration never loses committed files
FAKE_SCRIPT = """
import json, sys
from pathlib import Path

def main(argv):
    out = Path(argv[argv.index("--out") + 1])
    out.mkdir(parents=True, exist_ok=True)
    (out / "scene.png").write_bytes(b"new picture")
    gallery = {{"title": "t", "claim": "c", "evidence": "e", "agrees": True, "figures": {figures}}}
    (out / "metrics.json").write_text(json.dumps({{"value": 2, "gallery": gallery}}))
    print("half-way")
    {fail}
    return 0
"""


def _fake_figure(tmp_path, monkeypatch, fail="", figures=("scene.png",)):
    script = tmp_path / "fake_script.py"
    script.write_text(FAKE_SCRIPT.format(fail=fail, figures=list(figures)))
    fig = paper_figures.Figure("fake", "fake_fig", str(script))
    monkeypatch.setattr(paper_figures.__main__, "FIGURES", (fig,))
    monkeypatch.setattr(paper_figures.__main__, "select", lambda names: [fig])
    out = tmp_path / "out"
    folder = out / "fake_fig"
    (folder / "sub").mkdir(parents=True)
    (folder / "metrics.json").write_text('{"value": 1}')
    (folder / "scene.png").write_bytes(b"committed picture")
    (folder / "old_figure.png").write_bytes(b"committed, no longer made")
    (folder / "table.md").write_text("| committed |")
    (folder / "notes.keep").write_text("not an output")
    (folder / "sub" / "data.bin").write_bytes(b"\x00\x01")
    return out, folder


def _snapshot(folder):
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.parametrize(
    "fail,figures",
    [
        ("raise RuntimeError('the solver diverged')", ["scene.png"]),  # the script fails half-way
        ("return 3", ["scene.png"]),  # non-zero exit status
        ("", ["scene.png", "missing.png"]),  # its gallery lists a figure it did not write
    ],
)
def test_a_failed_figure_leaves_its_committed_folder_byte_identical(tmp_path, monkeypatch, capsys, fail, figures):
    """Old: the folder's PNG/JSON/NPZ/MD/TXT files were deleted before the script ran, so a run that failed
    (or was interrupted) half-way left the tracked files deleted or half-rewritten."""
    out, folder = _fake_figure(tmp_path, monkeypatch, fail, figures)
    before = _snapshot(folder)
    assert main(["--out", str(out), "--quiet"]) == 1
    assert _snapshot(folder) == before
    failed = out / ".fake_fig.failed"
    assert (failed / "scene.png").read_bytes() == b"new picture" and "half-way" in (failed / "log.txt").read_text()
    assert not (out / ".fake_fig.new").exists()


def test_an_interrupted_figure_leaves_its_committed_folder_byte_identical(tmp_path, monkeypatch):
    out, folder = _fake_figure(tmp_path, monkeypatch, "raise KeyboardInterrupt")
    before = _snapshot(folder)
    with pytest.raises(KeyboardInterrupt):
        main(["--out", str(out), "--quiet"])
    assert _snapshot(folder) == before
    assert sorted(p.name for p in out.iterdir()) == ["fake_fig"]  # nothing half-made left next to it


def test_a_successful_figure_replaces_its_outputs_and_keeps_other_files(tmp_path, monkeypatch):
    out, folder = _fake_figure(tmp_path, monkeypatch)
    (out / ".fake_fig.failed").mkdir()  # from an earlier failed run: gone after a success
    assert main(["--out", str(out), "--quiet"]) == 0
    after = _snapshot(folder)
    assert sorted(after) == ["log.txt", "metrics.json", "notes.keep", "scene.png", "sub/data.bin"]  # stale ones gone
    assert after["scene.png"] == b"new picture" and json.loads(after["metrics.json"])["value"] == 2
    assert after["notes.keep"] == b"not an output" and after["sub/data.bin"] == b"\x00\x01"
    assert sorted(p.name for p in out.iterdir()) == ["README.md", "fake_fig", "timing.json"]


def test_a_swap_interrupted_between_its_renames_is_recovered(tmp_path, monkeypatch):
    """A run killed after the committed folder was renamed aside: the next run puts it back first."""
    out, folder = _fake_figure(tmp_path, monkeypatch, "return 1")
    before = _snapshot(folder)
    folder.rename(out / ".fake_fig.previous")
    assert main(["--out", str(out), "--quiet"]) == 1
    assert _snapshot(folder) == before and not (out / ".fake_fig.previous").exists()


def test_the_command_runs_figures_in_parallel_processes(tmp_path):
    """``python -m paper_figures`` with worker processes (the default on several cores): the module is
    ``__main__`` there, and a spawned worker used to fail unpickling the job function from it."""
    import subprocess
    import sys

    cmd = [sys.executable, "-m", "paper_figures", "--only", "table01", "fig07", "--fast", "--jobs", "2"]
    r = subprocess.run([*cmd, "--out", str(tmp_path)], cwd=paper_figures.ROOT, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-2000:]
    assert (tmp_path / "table01_controllable_spaces" / "table1.md").exists()
    assert (tmp_path / "fig07_line_g1_arms" / "metrics.json").exists()


COUNTING_SCRIPT = """
import json, sys
from pathlib import Path

def main(argv):
    # process-wide state, as OMPL's random generator is: a figure must not see what an earlier figure left
    sys.coop_ga_figure_count = getattr(sys, "coop_ga_figure_count", 0) + 1
    out = Path(argv[argv.index("--out") + 1])
    out.mkdir(parents=True, exist_ok=True)
    gallery = {"title": "t", "claim": "c", "evidence": "e", "agrees": True, "figures": []}
    (out / "metrics.json").write_text(json.dumps({"count": sys.coop_ga_figure_count, "gallery": gallery}))
    return 0
"""


@pytest.mark.parametrize("jobs", ["1", "2"])
def test_each_figure_runs_in_a_fresh_process(tmp_path, monkeypatch, jobs):
    """Old: figures ran one after the other in one process (``--jobs 1``) or in reused workers, so the planning
    execution's plans depended on the figures its worker had run before (OMPL seeds once per process): the full
    gallery gave 1 of 3 box lifts in the goal, the figure run alone 2 of 3."""
    script = tmp_path / "counting.py"
    script.write_text(COUNTING_SCRIPT)
    figs = [paper_figures.Figure(f"count{i}", f"count{i}", str(script)) for i in range(3)]
    monkeypatch.setattr(paper_figures.__main__, "FIGURES", tuple(figs))
    monkeypatch.setattr(paper_figures.__main__, "select", lambda names: figs)
    assert main(["--out", str(tmp_path / "out"), "--quiet", "--jobs", jobs]) == 0
    counts = [json.loads((tmp_path / "out" / f.folder / "metrics.json").read_text())["count"] for f in figs]
    assert counts == [1, 1, 1]


def test_verbose_refuses_parallel_jobs(capsys):
    with pytest.raises(SystemExit) as ex:
        main(["--verbose", "--jobs", "2", "--only", "table01"])
    assert ex.value.code == 2
    assert "--verbose runs the figures in this process" in capsys.readouterr().err


def test_timing_json_records_cpu_seconds(tmp_path, monkeypatch):
    """The run writes wall and CPU seconds per figure (the CPU ones tell what the gallery costs on a loaded
    machine, where the wall times do not)."""
    script = tmp_path / "counting.py"
    script.write_text(COUNTING_SCRIPT)
    figs = [paper_figures.Figure(f"count{i}", f"count{i}", str(script)) for i in range(2)]
    monkeypatch.setattr(paper_figures.__main__, "FIGURES", tuple(figs))
    monkeypatch.setattr(paper_figures.__main__, "select", lambda names: figs)
    out = tmp_path / "out"
    assert main(["--out", str(out), "--quiet", "--jobs", "1"]) == 0
    timing = json.loads((out / "timing.json").read_text())
    assert set(timing["figures_cpu_s"]) == {"count0", "count1"}
    assert all(0 <= v < 60 for v in timing["figures_cpu_s"].values())
    assert set(timing["figures_s"]) == set(timing["figures_cpu_s"])
