"""coop_ga.sweep: executors agree, resume, failures are data, specs, store, summary.

Sweeps are tiny (a few jobs on ``three_finger_hand``, 12 joints) so that the file runs in well under a minute;
records are compared exactly, timing fields (``coop_ga.sweep.TIME_FIELDS``) excepted.
"""

from __future__ import annotations

import importlib.util
import json
import os
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import coop_ga.sweep as sw
from coop_ga.errors import CoopGAError

ROOT = Path(__file__).resolve().parents[2]
SYSTEM = "three_finger_hand"


def _jobs(n: int = 3, controllers: tuple[str, ...] = ("gauss_newton", "ilqr")) -> list[dict[str, Any]]:
    """n sampled small targets × controllers, seeds from SeedSequence(7).spawn(n) (one per target)."""
    seeds = sw.seeds(7, n)
    return [
        {
            "system": SYSTEM,
            "kind": "circle",
            "controller": c,
            "target": {"sampler": "displacement", "level": "small"},
            "seed": seeds[k],
            "tags": {"sample": k},
        }
        for k in range(n)
        for c in controllers
    ]


def _failing() -> list[dict[str, Any]]:
    return [
        {"system": "no_such_system", "kind": "circle", "controller": "gauss_newton"},
        {"system": SYSTEM, "kind": "circle", "controller": "gauss_newton", "options": {"no_such_option": 1}},
        {"system": SYSTEM, "kind": "sphere", "controller": "ilqr"},  # 3 end points: cannot span a sphere
    ]


@pytest.fixture(scope="module")
def serial() -> list[dict[str, Any]]:
    return sw.run(_jobs() + _failing(), executor="serial")


def _same(a: list[dict[str, Any]], b: list[dict[str, Any]]) -> None:
    assert [r["job"] for r in a] == [r["job"] for r in b]
    for x, y in zip(a, b):
        assert sw.strip_timing(x) == sw.strip_timing(y), (x, y)
    assert sw.records_equal(a, b)


# ---------------------------------------------------------------------------- records
def test_record_fields_and_values(serial: list[dict[str, Any]]) -> None:
    ok = [r for r in serial if r["status"] == "ok"]
    assert len(ok) == 6
    for r in ok:
        for k in ("job", "converged", "error", "iterations", "seconds", "violation", "seed_spawn_key"):
            assert k in r
        assert r["violation"] == 0.0  # inside the limits
        assert r["seconds"] > 0.0
        assert r["system"] == SYSTEM and r["kind"] == "circle"
    assert [r["job"] for r in serial] == list(range(9))
    # the two controllers of one sample share its seed, hence its target
    for k in range(3):
        a, b = serial[2 * k], serial[2 * k + 1]
        assert a["seed_spawn_key"] == b["seed_spawn_key"] == [k]
        assert a["target_translation"] == b["target_translation"]
        assert np.isclose(np.linalg.norm(a["target_translation"]), 0.02)  # the small level: 2 cm
    # sample 1 is unreachable inside the limits (both controllers stop at active joint limits, ‖e‖ ≈ 0.03)
    assert [r["converged"] for r in ok] == [True, True, False, False, True, True]
    assert all(r["error"] < 1e-5 for r in ok if r["converged"])
    assert "joint limits active" in ok[2]["message"]
    ilqr = [r for r in ok if r["controller"] == "ilqr"]
    assert all("solve_time_s" in r and "joint_limit_violation" in r for r in ilqr)


def test_failing_job_is_recorded_not_raised(serial: list[dict[str, Any]]) -> None:
    bad_sys, bad_opt, sphere = serial[6:]
    assert bad_sys["status"] == "failed" and not bad_sys["converged"]
    assert bad_sys["exception_type"] == "UnknownNameError" and "no_such_system" in bad_sys["exception"]
    assert bad_opt["status"] == "failed" and "no_such_option" in bad_opt["exception"]
    assert sphere["status"] == "skipped" and "needs 4 end points" in sphere["reason"]
    rows = sw.summarize(serial, by="controller")
    gn = next(r for r in rows if r["controller"] == "gauss_newton")
    assert gn["jobs"] == 5 and gn["runs"] == 5 and gn["failed"] == 2 and gn["skipped"] == 0
    il = next(r for r in rows if r["controller"] == "ilqr")
    assert il["jobs"] == 4 and il["runs"] == 3 and il["skipped"] == 1
    assert gn["success_rate"] == gn["converged"] / 5


def test_seeds_are_spawned_children_and_order_free() -> None:
    got = sw.seeds(11, 4)
    ref = np.random.SeedSequence(11).spawn(4)
    for g, r in zip(got, ref):
        a = np.random.default_rng(sw.seed_sequence(g)).random(3)
        assert np.array_equal(a, np.random.default_rng(r).random(3))
    jobs = _jobs(2, ("gauss_newton",))
    fwd = sw.run(jobs)
    back = sw.run(jobs[::-1])
    for a, b in zip(fwd, back[::-1]):
        assert {**sw.strip_timing(a), "job": 0} == {**sw.strip_timing(b), "job": 0}


def test_plain_dict_job_of_the_issue() -> None:
    job = {
        "system": SYSTEM,
        "kind": "circle",
        "controller": "gauss_newton",
        "target": {"translation": [0.005, 0.0, -0.004], "angle": 0.05, "axis": [0, 0, 1], "scale": 1.05},
        "seed": 3,
    }
    filters, env = list(warnings.filters), dict(os.environ)
    (r,) = sw.run([job])
    assert warnings.filters == filters and dict(os.environ) == env  # serial: the caller's process is left alone
    assert r["status"] == "ok" and r["converged"] and r["error"] < 1e-6
    assert r["target_scale"] == 1.05 and r["seed_entropy"] == 3
    job2 = sw.Job(system=SYSTEM, kind="circle", controller="gn", target=job["target"], seed=3)
    assert sw.normalize_job(job2)["controller"] == "gn"


def test_from_urdf_recipe_job() -> None:
    """A system given as a from_urdf recipe (the shipped hexapod, three feet, neutral q0) runs like a registered one."""
    from coop_ga.systems import ROBOTS_DIR

    recipe = {"urdf": str(ROBOTS_DIR / "hexapod" / "hexapod.urdf"), "end_frames": ["lf_foot", "lr_foot", "rm_foot"]}
    job = {
        "system": {**recipe, "name": "tripod"},
        "kind": "circle",
        "controller": "gauss_newton",
        "target": {"translation": [0.0, 0.0, 0.01], "scale": 0.97},
        "seed": 0,
    }
    (r,) = sw.run([job])
    assert r["system"] == "tripod" and r["nq"] == 18
    assert r["status"] == "ok" and r["converged"] and r["error"] < 1e-9 and r["violation"] == 0.0
    with pytest.raises(sw.InvalidJobError, match="needs 'urdf' and 'end_frames'"):
        sw.normalize_job({**job, "system": {"urdf": recipe["urdf"]}})


@pytest.mark.parametrize(
    ("job", "match"),
    [
        ([1, 2], "a job must be a dict"),
        ({"system": SYSTEM, "kind": "circle"}, "needs 'controller'"),
        ({"system": SYSTEM, "kind": "circle", "controller": "newton"}, "unknown controller"),
        ({"system": SYSTEM, "kind": "circle", "controller": "gn", "colour": 1}, "unknown job field"),
        ({"system": SYSTEM, "kind": "circle", "controller": "gn", "target": {"where": 1}}, "unknown target field"),
        ({"system": SYSTEM, "kind": "circle", "controller": "gn", "seed": -1}, "seed must be"),
        ({"system": SYSTEM, "kind": "circle", "controller": "gn", "tags": {"error": 1}}, "record fields"),
    ],
)
def test_malformed_jobs_raise_before_running(job: Any, match: str) -> None:
    with pytest.raises(sw.InvalidJobError, match=match):
        sw.run([job])


# ---------------------------------------------------------------------------- executors
def test_process_pool_equals_serial_with_a_cold_shared_cache(
    serial: list[dict[str, Any]], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """2 workers build the same tasks for the first time, in one empty cache, at once.

    coop_ga.codegen makes that safe (flock per entry + atomic os.replace; the compile-once and
    no-crash properties under 12 concurrent processes are tests/reliability/test_compile_cache.py::
    test_defect1_concurrent_first_compiles_do_not_crash).  Here: the records equal the serial ones and the
    cache holds exactly one verified library per entry, no temporaries.
    """
    import hashlib

    cache = tmp_path / "cache"
    monkeypatch.setenv("COOP_GA_CACHE", str(cache))
    recs = sw.run(_jobs() + _failing(), executor="process", workers=2)
    _same(serial, recs)
    so = sorted(cache.glob("*.so"))
    assert so, "the workers compiled nothing into the shared cache"
    for p in so:
        sha = Path(f"{p}.sha256").read_text().split()[0]
        assert sha == hashlib.sha256(p.read_bytes()).hexdigest()
    names = [p.name for p in cache.iterdir()]
    assert not [n for n in names if not n.endswith((".so", ".so.sha256", ".lock"))], names


def _faults() -> list[dict[str, Any]]:
    """A job that kills its worker (os._exit) and one that hangs (worker test hook, COOP_GA_SWEEP_TEST_FAULTS=1)."""
    base = {"system": SYSTEM, "kind": "circle", "controller": "gauss_newton"}
    return [{**base, "tags": {"fault": "exit"}}, {**base, "tags": {"fault": "hang"}}]


FAULT_TIMEOUT = 20.0  # [s]: above any normal job here on a loaded machine (an unreachable iLQR runs seconds)


def _same_with_faults(serial: list[dict[str, Any]], recs: list[dict[str, Any]]) -> None:
    """The faults ran first (restarts overlap the other jobs); the normal jobs' records equal serial's; the killer
    is WorkerDied after its retry, the hung job timed out."""
    died, hung = recs[:2]
    assert died["status"] == "failed" and died["exception_type"] == "WorkerDied", died
    assert hung["status"] == "timeout" and hung["exception_type"] == "Timeout", hung
    _same(serial, [{**r, "job": r["job"] - 2} for r in recs[2:]])


def test_dask_local_cluster_equals_serial(serial: list[dict[str, Any]], monkeypatch: pytest.MonkeyPatch) -> None:
    """Dask's own death rule (allowed-failures = retries = 1 on the local cluster) and the cancel-and-restart
    timeout give the same records as the process pool."""
    pytest.importorskip("dask.distributed", reason="the dask extra is not installed: pip install 'coop_ga[dask]'")
    monkeypatch.setenv("COOP_GA_SWEEP_TEST_FAULTS", "1")
    recs = sw.run(_faults() + _jobs() + _failing(), executor="dask", workers=2, timeout=FAULT_TIMEOUT)
    _same_with_faults(serial, recs)
    assert "KilledWorker" in recs[0]["exception"]


def test_dask_existing_scheduler_address(serial: list[dict[str, Any]]) -> None:
    """``address=``: the sweep connects to a running scheduler (here a LocalCluster of 2 workers started by the test)."""
    dd = pytest.importorskip("dask.distributed", reason="the dask extra is not installed: pip install 'coop_ga[dask]'")
    with dd.LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None, silence_logs=40) as cluster:
        recs = sw.run(_jobs() + _failing(), executor="dask", workers=2, address=cluster.scheduler_address)
        assert len(cluster.scheduler_info["workers"]) == 2  # the cluster outlives the sweep
    _same(serial, recs)


def test_ray_equals_serial(serial: list[dict[str, Any]], monkeypatch: pytest.MonkeyPatch) -> None:
    """Ray actors, one job at a time each: a dead actor's job is retried once on a new actor, a hung one killed."""
    pytest.importorskip("ray", reason="the ray extra is not installed: pip install 'coop_ga[ray]'")
    monkeypatch.setenv("COOP_GA_SWEEP_TEST_FAULTS", "1")
    recs = sw.run(_faults() + _jobs() + _failing(), executor="ray", workers=2, timeout=FAULT_TIMEOUT)
    _same_with_faults(serial, recs)
    assert "ActorDiedError" in recs[0]["exception"] and "2 attempts" in recs[0]["exception"]


@pytest.mark.parametrize(("executor", "module", "extra"), [("dask", "dask.distributed", "dask"), ("ray", "ray", "ray")])
def test_missing_extra_names_it(monkeypatch: pytest.MonkeyPatch, executor: str, module: str, extra: str) -> None:
    monkeypatch.setitem(sys.modules, module, None)  # import → ImportError
    with pytest.raises(sw.MissingExtraError, match=rf"pip install 'coop_ga\[{extra}\]'") as ei:
        sw.run(_jobs(1, ("gauss_newton",)), executor=executor, workers=2)
    assert isinstance(ei.value, CoopGAError)


def test_bad_executor_and_workers() -> None:
    with pytest.raises(sw.SweepError, match="unknown executor"):
        sw.run([], executor="threads")
    with pytest.raises(sw.SweepError, match="workers must be"):
        sw.run([], executor="process", workers=0)
    with pytest.raises(sw.SweepArgumentError, match="workers must be"):
        sw.run([], executor="process", workers=1.5)


# ---------------------------------------------------------------------------- store and resume
@pytest.mark.parametrize("fmt", ["jsonl", "parquet"])
def test_stored_records_read_back_equal(tmp_path: Path, serial: list[dict[str, Any]], fmt: str) -> None:
    if fmt == "parquet":
        pytest.importorskip("pyarrow", reason="pyarrow is not installed")
    jobs = _jobs() + _failing()
    recs = sw.run(jobs, out=tmp_path, format=fmt)
    assert sw.read_records(tmp_path) == recs
    _same(serial, recs)
    again = sw.run(jobs, out=tmp_path, format=fmt)  # everything done: nothing runs, the stored records return
    assert again == recs
    meta = json.loads((tmp_path / "sweep.json").read_text())
    assert meta["n_jobs"] == 9 and meta["format"] == fmt


def test_other_sweep_in_out_is_refused(tmp_path: Path) -> None:
    sw.run(_jobs(1, ("gauss_newton",)), out=tmp_path)
    with pytest.raises(sw.SweepError, match="another sweep"):
        sw.run(_jobs(2, ("gauss_newton",)), out=tmp_path)
    recs = sw.run(_jobs(2, ("gauss_newton",)), out=tmp_path, resume=False)  # --overwrite
    assert len(sw.read_records(tmp_path)) == len(recs) == 2


def test_resume_after_an_interrupted_run(tmp_path: Path) -> None:
    """A CLI run killed (SIGKILL) mid-sweep, a torn last line appended; the resumed sweep runs only the rest."""
    jobs = [
        {
            "system": "three_iiwa14",
            "kind": "circle",
            "controller": "impedance",
            "options": {"duration": 0.6, "K": 25.0, "D": 10.0, "warn_limits": False},
            "start": {"spread": 0.1},
            "seed": s,
        }
        for s in sw.seeds(5, 10)
    ]
    spec = tmp_path / "spec.json"
    spec.write_text(json.dumps({"name": "resume", "jobs": jobs}))
    out = tmp_path / "out"
    proc = subprocess.Popen(
        [sys.executable, "-m", "coop_ga.sweep", str(spec), "--executor", "serial", "--out", str(out), "--quiet"],
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    lines = out / "records.jsonl"
    t0 = time.monotonic()
    try:
        while not (lines.is_file() and lines.read_text().count("\n") >= 3):
            assert proc.poll() is None, proc.stderr.read().decode() if proc.stderr else ""
            assert time.monotonic() - t0 < 60
            time.sleep(0.01)
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        proc.wait()
    before = sw.read_records(out)
    assert 3 <= len(before) < len(jobs), "the run was not interrupted mid-sweep"
    with open(lines, "a") as f:
        f.write('{"job": 9, "status": "ok", "conv')  # a torn write
    recs = sw.run(sw.expand(spec), out=out)
    assert len(recs) == len(jobs) and [r["job"] for r in recs] == list(range(len(jobs)))
    for b in before:  # not re-run: the stored records (timings included) are returned as they were
        assert recs[b["job"]] == b
    assert sw.read_records(out) == recs
    stored = [json.loads(x) for x in lines.read_text().splitlines()]
    assert sorted(r["job"] for r in stored) == list(range(len(jobs)))  # each job once, the torn line cut off
    fresh = sw.run(sw.expand(spec))
    _same(fresh, recs)
    # K = 25, D = 10: within 0.6 s ‖B_e‖ falls to 0.024–0.040 (seeds 5/0–2), not yet below tol = 1e-3
    assert all(r["status"] == "ok" and not r["converged"] and r["error"] < 0.05 for r in recs)


# ---------------------------------------------------------------------------- specs
def test_ready_specs_expand() -> None:
    specs = sw.ready_specs()
    assert set(specs) >= {"robustness", "impedance_gains"}
    rob = sw.expand("robustness")
    from coop_ga import KINDS, systems

    assert len(rob) == len(systems.names()) * len(KINDS) * 3 * 20 * 4
    assert {r["controller"] for r in rob} == {"ilqr", "ilqr_moving", "gn", "diffik"}
    imp = sw.expand("impedance_gains")
    assert len(imp) == 4 * 4 * 20 and {j["system"] for j in imp} == {"three_iiwa14"}
    # the same 20 starts for every gain pair
    assert imp[0]["seed"] == imp[20]["seed"] and imp[0]["seed"] != imp[1]["seed"]
    assert len(sw.expand("impedance_gains", fast=True)) == 4


def test_robustness_spec_reproduces_the_benchmark_jobs() -> None:
    """The ready spec's jobs of one target = benchmarks/robustness.py's run_target (targets, certificate, results)."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        import robustness as rb
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))
    jobs = [j for j in sw.expand("robustness", fast=True) if j["system"] == "allegro" and j["kind"] == "sphere"]
    assert [j["controller"] for j in jobs] == list(rb.SOLVERS)
    recs = sw.run(jobs)
    ref = rb.run_target(rb.TargetSpec("allegro", "sphere", "small", 0, 0, rb.SOLVERS))
    # the stream of (allegro, sphere, small, 0) under seed 0, as the study drew it before the sampler moved here
    assert recs[0]["target_translation"] == [0.011089795618541709, -0.015178492755970082, -0.00682860093986586]
    assert recs[0]["target_axis"] == [0.9003151839195849, 0.17173186883042213, -0.399925911678469]
    assert recs[0]["target_scale"] == 0.95 and recs[0]["target_angle"] == np.deg2rad(5.0)
    assert recs[0]["seed_spawn_key"] == ref["spawn_key"]
    assert recs[0]["target_translation"] == ref["displacement"]["translation_m"]
    assert recs[0]["target_axis"] == ref["displacement"]["axis"]
    assert recs[0]["target_scale"] == ref["displacement"]["scale"]
    assert recs[0]["certified"] is ref["certification"]["certified"] is True
    for rec in recs:
        j = ref["jobs"][rec["controller"]]
        for k in ("converged", "error", "iterations", "violation", "max_speed"):
            assert rec[k] == j[k], (rec["controller"], k)


def test_yaml_spec_when_pyyaml_is_there(tmp_path: Path) -> None:
    p = tmp_path / "s.yaml"
    p.write_text("grid:\n  sample: 2\nbase:\n  system: three_finger_hand\n  kind: circle\n  controller: gn\n")
    if importlib.util.find_spec("yaml") is None:
        with pytest.raises(sw.InvalidJobError, match="PyYAML"):
            sw.expand(p)
    else:
        jobs = sw.expand(p)
        assert [j["tags"]["sample"] for j in jobs] == [0, 1]
        assert [j["seed"]["spawn_key"] for j in jobs] == [[0], [1]]


# ---------------------------------------------------------------------------- summary, figure, CLI
def test_summary_quantiles() -> None:
    recs = [
        {"controller": "a", "status": "ok", "converged": True, "iterations": i, "seconds": 0.001 * i, "violation": 0.0}
        for i in (1, 2, 3, 4)
    ]
    recs += [{"controller": "a", "status": "failed", "converged": False, "iterations": None, "seconds": 0.0}]
    recs += [{"controller": "b", "status": "skipped", "converged": False}]
    a, b = sw.summarize(recs, by=["controller"])
    assert a["runs"] == 5 and a["failed"] == 1 and a["success_rate"] == 0.8
    assert a["iterations_q50"] == 2.5 and a["iterations_q100"] == 4.0
    assert np.isclose(a["seconds_q90"], 0.0037)
    assert b["runs"] == 0 and b["skipped"] == 1 and b["success_rate"] is None
    assert "80.0 %" in sw.format_table([a, b])
    (c,) = sw.summarize(recs[:5], by="controller", fields=["violation"], quantiles=[1.0])
    assert c["violation_q100"] == 0.0 and "iterations_q50" not in c


def test_cli_writes_records_summary_and_figure(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from coop_ga.sweep.__main__ import main

    spec = tmp_path / "spec.json"
    spec.write_text(json.dumps({"name": "cli", "jobs": _jobs(2, ("gauss_newton",)), "summary_by": ["controller"]}))
    out = tmp_path / "out"
    assert main([str(spec), "--executor", "serial", "--out", str(out), "--quiet"]) == 0
    assert "gauss_newton" in capsys.readouterr().out
    summary = json.loads((out / "summary.json").read_text())
    assert summary["rows"][0]["jobs"] == 2 and summary["rows"][0]["runs"] == 2
    assert (out / "sweep.png").stat().st_size > 10_000
    assert len(sw.read_records(out)) == 2
    assert main([str(tmp_path / "missing.json"), "--out", str(out)]) == 2


# ---------------------------------------------------------------------------- the benchmark's CI mode
def test_benchmark_ci_mode(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """benchmarks/sweep.py --ci: every executor's records equal serial; the tables print; linear extrapolation."""
    spec = importlib.util.spec_from_file_location("bench_sweep", ROOT / "benchmarks" / "sweep.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules["bench_sweep"] = mod
    spec.loader.exec_module(mod)
    assert mod.main(["--ci", "--quiet", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    for title in ("24 iLQR solves", "per-job overhead of the process pool", "extrapolation"):
        assert title in out
    res = json.loads((tmp_path / "results.json").read_text())
    assert res["jobs"] == 24 and res["ci"] is True
    assert {"serial", "process"} <= set(res["executors"])
    assert all(r.get("records_equal_serial", True) for r in res["executors"].values())
    assert res["overhead"]["records_equal_serial"] is True and res["overhead"]["jobs"] == 40
    ext = res["extrapolation"]
    assert [e["cores"] for e in ext] == [2, 64, 640]
    assert np.isclose(ext[2]["jobs_per_s"] / ext[1]["jobs_per_s"], 10.0, rtol=1e-3)  # linear in the cores


def test_free_flyer_recipe_job() -> None:
    """The hexapod body on a free flyer (from_urdf(free_flyer=True), nq = 25, nv = 24): the start spread is a
    velocity applied by integrate, the limit measures compare the joints (not the quaternion) with the limits,
    and certify — scipy's bounded least squares on δ in q = q0 ⊕ δ — certifies the target inside the joint limits."""
    from coop_ga.systems import ROBOTS_DIR

    recipe = {
        "urdf": str(ROBOTS_DIR / "hexapod" / "hexapod.urdf"),
        "end_frames": ["lf_foot", "lr_foot", "rm_foot"],
        "free_flyer": True,
        "name": "tripod_ff",
    }
    job = {
        "system": recipe,
        "kind": "circle",
        "controller": "gauss_newton",
        "target": {"translation": [0.0, 0.0, 0.01], "scale": 0.97},
        "start": {"spread": 0.05},
        "seed": 0,
    }
    gn, diffik, cert = sw.run([job, {**job, "controller": "diff_ik"}, {**job, "certify": True}])
    assert gn["nq"] == 25 and gn["status"] == "ok" and gn["converged"] and gn["error"] < 1e-9
    assert gn["violation"] == 0.0
    assert diffik["status"] == "ok" and diffik["converged"] and diffik["error"] < 1e-4
    assert diffik["violation"] == 0.0 and diffik["speed_violation"] == 0.0 and diffik["max_speed"] > 0.1
    assert cert["status"] == "ok" and cert["certified"] is True and cert["converged"], cert.get("exception")


MOVE = {"translation": [0.6, 0.2, 0.3], "axis": [0.0, 0.0, 1.0], "angle": 0.4}


def test_free_flyer_job_field_loads_the_registry_variant() -> None:
    """``free_flyer: True`` with a registry name is load(name, free_flyer=True) (the floating G1, nq = 24): a target
    0.6 m away is certified and reached with the floating pelvis and not certified with the fixed one; False is
    dropped from the normalized job (its hash unchanged); a name without a variant fails as a job."""
    from coop_ga.sweep.targets import CERT_TOL

    job = {"system": "g1_arms", "kind": "point_pair", "controller": "gauss_newton", "target": MOVE, "certify": True}
    assert sw.normalize_job({**job, "free_flyer": False}) == sw.normalize_job(job)
    assert sw.job_hash(sw.normalize_job({**job, "free_flyer": False})) == sw.job_hash(sw.normalize_job(job))
    with pytest.raises(CoopGAError, match="free_flyer must be True or False"):
        sw.normalize_job({**job, "free_flyer": 1})
    floating, fixed, none = sw.run(
        [{**job, "free_flyer": True}, job, {**job, "system": "three_franka", "free_flyer": True}]
    )
    assert floating["nq"] == 24 and floating["free_flyer"] is True and "free_flyer" not in fixed
    assert floating["status"] == "ok" and floating["certified"] is True, floating.get("exception")
    assert floating["converged"] and floating["error"] < 1e-9 and floating["violation"] == 0.0
    assert fixed["certified"] is False and fixed["nq"] == 17
    assert none["status"] == "failed" and none["exception_type"] == "UnsupportedJointError"
    assert "has no free-flyer variant" in none["exception"]
    task = sw.worker._task({**job, "free_flyer": True})
    from coop_ga.control import displaced_target

    Vd = displaced_target(task, task.system.q0, **MOVE)
    c = sw.targets.certify(task, task.system.q0, Vd)
    assert c["certified"] and c["error"] < CERT_TOL and c["violation"] == 0.0


def test_ilqr_jobs_on_a_free_flyer() -> None:
    """The iLQR controllers take the floating G1 (its chart, coop_ga.control.ilqr.chart): the 0.6 m target the fixed
    pelvis cannot reach, and a sampled small target from a moving start (q̇ drawn with nv = 23 entries)."""
    job = {"system": "g1_arms", "kind": "point_pair", "controller": "ilqr", "target": MOVE, "free_flyer": True}
    moving = {**job, "controller": "ilqr_moving", "target": {"sampler": "displacement", "level": "small"}}
    far, mov = sw.run([job, moving])
    assert far["status"] == "ok" and far["nq"] == 24 and far["converged"] and far["error"] < 1e-5, far.get("exception")
    assert far["violation"] == 0.0 and far["speed_violation"] == 0.0
    assert mov["status"] == "ok" and mov["converged"] and mov["violation"] == 0.0, mov.get("exception")
