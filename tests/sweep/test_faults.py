"""coop_ga.sweep under faults: dead workers, hung jobs, hostile specs, two sweeps on one directory, bad arguments.

Faults are provoked by the worker's test hook (``coop_ga.sweep.worker.FAULTS_ENV``): with
``COOP_GA_SWEEP_TEST_FAULTS=1`` in a worker's environment, a job tagged ``fault`` exits, segfaults, kills itself
or hangs (``time.sleep(1e6)``) instead of running.  Every process start costs an import of coop_ga (seconds on a
loaded machine), so each sweep here provokes as few worker restarts as its claim needs.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import coop_ga.sweep as sw
from coop_ga.errors import CoopGAError, InvalidInputError
from coop_ga.sweep import pool
from coop_ga.sweep.worker import FAULTS_ENV

ROOT = Path(__file__).resolve().parents[2]
SYSTEM = "three_finger_hand"
TIMEOUT = 3.0  # [s] per job: a normal job here takes milliseconds, the hung one forever


def _job(k: int, **tags: Any) -> dict[str, Any]:
    return {
        "system": SYSTEM,
        "kind": "circle",
        "controller": "gauss_newton",
        "target": {"sampler": "displacement", "level": "small"},
        "seed": sw.seeds(7, 8)[k],
        "tags": {"sample": k, **tags},
    }


@pytest.fixture
def faults(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(FAULTS_ENV, "1")


def _clean(rec: dict[str, Any]) -> dict[str, Any]:
    """A record without timings and the job index (to compare one job's record across sweeps)."""
    return {k: v for k, v in sw.strip_timing(rec).items() if k not in ("job", "job_hash", "fault", "fault_once")}


def _check_normal(recs: list[dict[str, Any]], normal: dict[int, int]) -> None:
    """The jobs at the indices of ``normal`` (index → sample) have the records of a clean serial run."""
    ref = sw.run([_job(k) for k in normal.values()])
    for (i, _), r in zip(normal.items(), ref):
        assert recs[i]["status"] == "ok" and recs[i]["error"] is not None
        assert _clean(recs[i]) == _clean(r)


# ---------------------------------------------------------------------------- dead workers, hung jobs
def test_process_pool_dead_worker_fails_only_its_job(faults: None, tmp_path: Path) -> None:
    """A segfaulting job dies twice (retried once on a fresh worker) and is recorded; a job that SIGKILLs its
    worker once succeeds on the retry; a hung job is killed at the timeout; every other job completes."""
    once = tmp_path / "killed-once"
    jobs = [
        _job(0),
        _job(1, fault="segfault"),
        _job(2),
        _job(3, fault="kill", fault_once=str(once)),
        _job(4, fault="hang"),
        _job(5),
    ]
    recs = sw.run(jobs, executor="process", workers=2, timeout=TIMEOUT, out=tmp_path / "out", warmup=False)
    assert [r["job"] for r in recs] == list(range(6))
    assert [r["status"] for r in recs] == ["ok", "failed", "ok", "ok", "timeout", "ok"]
    seg = recs[1]
    assert seg["exception_type"] == "WorkerDied" and not seg["converged"]
    assert "SIGSEGV" in seg["exception"] and "2 attempts" in seg["exception"]
    assert once.exists() and recs[3]["exception_type"] is None  # died once, then ran on a fresh worker
    hung = recs[4]
    assert hung["exception_type"] == "Timeout" and hung["seconds"] >= TIMEOUT
    assert "timeout=3 s" in hung["exception"]
    _check_normal(recs, {0: 0, 2: 2, 3: 3, 5: 5})
    assert sw.read_records(tmp_path / "out") == recs
    rows = sw.summarize(recs, by="controller")
    assert rows[0]["failed"] == 2 and rows[0]["timeouts"] == 1 and rows[0]["runs"] == 6


def test_serial_with_a_timeout_runs_in_a_child_that_can_be_killed(faults: None) -> None:
    """Serial cannot stop its own stuck call: with timeout= the jobs run one at a time in a child process."""
    pid = os.getpid()
    recs = sw.run([_job(4, fault="hang"), _job(0)], executor="serial", timeout=TIMEOUT, warmup=False)
    assert os.getpid() == pid
    assert [r["status"] for r in recs] == ["timeout", "ok"]
    assert recs[0]["exception_type"] == "Timeout"
    _check_normal(recs, {1: 0})


# ---------------------------------------------------------------------------- the scheduler, without processes
class FakeSlots:
    """Scripted workers: ``plan[job index]`` in ok | die | die_once | hang; records are ``{"job": i}``."""

    def __init__(self, plan: dict[int, str], start_dies: int = 0):
        self.plan, self.start_dies = plan, start_dies
        self.started = self.killed = 0
        self.jobs: dict[int, tuple[int, dict[str, Any]] | None] = {}
        self.died_once: set[int] = set()
        self.events: list[tuple[Any, str, Any]] = []

    def start(self) -> int:
        self.started += 1
        self.jobs[self.started] = None
        self.events.append((self.started, "died" if self.start_dies > 0 else "ready", "x"))
        self.start_dies -= 1
        return self.started

    def send(self, slot: int, item: tuple[int, dict[str, Any]]) -> None:
        self.jobs[slot] = item
        what = self.plan.get(item[0], "ok")
        if what == "die_once" and item[0] not in self.died_once:
            self.died_once.add(item[0])
            what = "die"
        if what == "ok" or what == "die_once":
            self.events.append((slot, "done", {"job": item[0]}))
        elif what == "die":
            self.events.append((slot, "died", "the worker process died (killed by SIGKILL)"))

    def wait(self, slots: Any, timeout: float | None) -> list[tuple[Any, str, Any]]:
        out = [e for e in self.events if e[0] in slots]
        self.events = [e for e in self.events if e[0] not in slots]
        if not out:
            assert timeout is not None, "the scheduler would wait forever"
            time.sleep(timeout)
        return out

    def kill(self, slot: int) -> None:
        self.killed += 1

    def close(self) -> None:
        pass


def _items(n: int) -> list[tuple[int, dict[str, Any]]]:
    return [(i, sw.normalize_job(_job(i % 8))) for i in range(n)]


def test_scheduler_retries_once_and_charges_only_the_dying_job() -> None:
    slots = FakeSlots({3: "die", 5: "die_once", 7: "hang"})
    recs = list(pool.schedule(slots, _items(10), 3, pool.TimeoutPolicy.of(0.05), retries=1))
    by = {r["job"]: r for r in recs}
    assert sorted(by) == list(range(10))
    assert by[3]["exception_type"] == "WorkerDied" and "2 attempts" in by[3]["exception"]
    assert by[5] == {"job": 5} and by[7]["status"] == "timeout" and slots.killed == 1
    assert all(by[i] == {"job": i} for i in (0, 1, 2, 4, 6, 8, 9))
    assert slots.started == 3 + 3  # 3 workers, plus one per death (2) and per kill (1)
    slots = FakeSlots({3: "die"})
    (rec,) = [r for r in pool.schedule(slots, _items(5), 2, pool.TimeoutPolicy(), retries=0) if r["job"] == 3]
    assert "1 attempts" in rec["exception"]


class IdleDeaths(FakeSlots):
    """Workers that die right after returning a record (between jobs, e.g. picked by the OOM killer), ``n`` times."""

    def __init__(self, n: int):
        super().__init__({})
        self.n = n

    def send(self, slot: int, item: tuple[int, dict[str, Any]]) -> None:
        super().send(slot, item)
        if self.n > 0:
            self.n -= 1
            self.events.append((slot, "died", "the worker process died (killed by SIGKILL)"))


def test_scheduler_charges_no_job_for_a_death_between_jobs() -> None:
    """A worker that dies while it runs no job (the case that breaks pebble's pool for every job, pool docstring)
    costs no record: it is replaced and every job completes once."""
    slots = IdleDeaths(3)
    recs = list(pool.schedule(slots, _items(8), 2, pool.TimeoutPolicy.of(5.0), retries=0))
    assert sorted(r["job"] for r in recs) == list(range(8)) and all(r == {"job": r["job"]} for r in recs)
    assert slots.started == 2 + 3 and slots.killed == 0  # one replacement per death


def test_scheduler_gives_up_when_workers_die_at_start_up() -> None:
    slots = FakeSlots({}, start_dies=10**6)
    with pytest.raises(sw.SweepError, match="keep dying while they start"):
        list(pool.schedule(slots, _items(4), 2, pool.TimeoutPolicy(), retries=1))
    assert slots.started == 2 * (pool.START_FAILURES + 1)  # two at a time, given up at the 7th death
    slots = FakeSlots({}, start_dies=3)  # a few start-up deaths: replaced, nothing charged
    assert sorted(r["job"] for r in pool.schedule(slots, _items(4), 2, pool.TimeoutPolicy())) == [0, 1, 2, 3]


def test_auto_timeout_policy() -> None:
    p = pool.TimeoutPolicy.of("auto")
    assert p.limit() == pool.AUTO_INITIAL_S
    for s in (0.01, 0.02, 0.03, 0.04):
        p.observe(s)
    assert p.limit() == pool.AUTO_INITIAL_S  # 4 < AUTO_MIN_JOBS
    p.observe(0.05)
    assert p.limit() == pool.AUTO_FLOOR_S  # 10 × 0.03 s is under the floor
    for s in (3.0, 3.0, 3.0, 3.0, 3.0, 3.0):
        p.observe(s)
    assert p.limit() == 30.0  # 10 × the median 3 s
    assert pool.TimeoutPolicy.of(None).limit() is None and pool.TimeoutPolicy.of(2).limit() == 2.0
    for bad in (0, -1.0, float("nan"), float("inf"), "soon", True, [1]):
        with pytest.raises(InvalidInputError, match="timeout"):
            pool.TimeoutPolicy.of(bad)


# ---------------------------------------------------------------------------- hostile specs
_HOSTILE = r"""
import json, resource, sys, time, tracemalloc
resource.setrlimit(resource.RLIMIT_AS, (2 * 2**30, 2 * 2**30))  # a bomb that expands fails here, not the machine
import coop_ga.sweep as sw
from coop_ga.errors import CoopGAError
out = {}
for name, src in json.loads(sys.argv[1]).items():
    tracemalloc.start()
    t0 = time.perf_counter()
    try:
        if name.startswith("yaml"):
            p = sys.argv[2] + f"/{name}.yaml"
            open(p, "w").write(src)
            sw.expand(p)
        else:
            sw.expand(json.loads(src))
        got = "accepted"
    except CoopGAError as exc:
        got = f"CoopGAError: {exc}"
    except BaseException as exc:
        got = f"{type(exc).__name__}: {exc}"
    out[name] = [got, tracemalloc.get_traced_memory()[1], time.perf_counter() - t0]
    tracemalloc.stop()
print(json.dumps(out))
"""

BASE = {"system": SYSTEM, "kind": "circle", "controller": "gn"}


def _billion_laughs() -> str:
    """9 levels of 10 aliases each: 10⁹ strings once expanded, 1 kB of YAML."""
    lines = ['a0: &a0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    for k in range(1, 9):
        lines.append(f"a{k}: &a{k} [" + ", ".join([f"*a{k - 1}"] * 10) + "]")
    lines.append("name: bomb\nbase:\n  system: three_finger_hand\n  kind: circle\n  controller: gn\n  tags: {x: *a8}")
    return "\n".join(lines) + "\n"


def test_hostile_specs_are_refused_without_allocating(tmp_path: Path) -> None:
    """An alias bomb, a recursive alias, 10⁸ samples and a 10⁸-job grid are refused with a CoopGAError, each
    allocating under 10 MB (measured with tracemalloc in a child process whose address space is capped at 2 GiB,
    so that code which does expand them fails there)."""
    specs = {
        "yaml_bomb": _billion_laughs(),
        "yaml_cycle": "name: x\nbase: &b {system: three_finger_hand, kind: circle, controller: gn, tags: {me: *b}}\n",
        "yaml_aliases": "a: &a 1\nname: x\ndescription: [" + ", ".join(["*a"] * 200) + "]\n",
        "samples": json.dumps({"base": BASE, "grid": {"sample": 10**8}}),
        "grid": json.dumps(
            {"base": BASE, "grid": {"sample": 10**4, "options.max_iter": list(range(100)), "target.scale": [1.0] * 100}}
        ),
    }
    proc = subprocess.run(
        [sys.executable, "-c", _HOSTILE, json.dumps(specs), str(tmp_path)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    res = json.loads(proc.stdout.strip().splitlines()[-1])
    expected = {
        "yaml_bomb": "once its aliases are expanded",
        "yaml_cycle": "cycle",
        "yaml_aliases": "more than 100 YAML aliases",
        "samples": "expands to 100000000 jobs, more than max_jobs=1000000",
        "grid": "expands to 100000000 jobs",
    }
    for name, (got, peak, _seconds) in res.items():
        assert got.startswith("CoopGAError") and expected[name] in got, (name, got)
        assert peak < 10e6, (name, peak)


def test_max_jobs_is_the_limit_and_can_be_raised(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = {"name": "ten", "base": BASE, "grid": {"sample": 10}}
    assert sw.count_jobs(spec) == 10 and len(sw.expand(spec, max_jobs=10)) == 10
    with pytest.raises(sw.InvalidJobError, match="10 jobs, more than max_jobs=9"):
        sw.expand(spec, max_jobs=9)
    for bad in (0, -1, 2.5, True, "10"):
        with pytest.raises(sw.InvalidJobError, match="max_jobs"):
            sw.expand(spec, max_jobs=bad)
    from coop_ga.sweep.__main__ import main

    p = tmp_path / "ten.json"
    p.write_text(json.dumps(spec))
    assert main([str(p), "--max-jobs", "9", "--out", str(tmp_path / "o")]) == 2
    assert "more than max_jobs=9" in capsys.readouterr().err
    big = tmp_path / "big.json"
    big.write_text("[" + " " * (sw.spec.MAX_SPEC_BYTES + 1) + "]")
    with pytest.raises(sw.InvalidJobError, match="over the 8388608-byte limit"):
        sw.load_spec(big)


def test_yaml_aliases_within_the_limits_still_work(tmp_path: Path) -> None:
    pytest.importorskip("yaml")
    p = tmp_path / "s.yaml"
    p.write_text(
        "base: &b\n  system: three_finger_hand\n  kind: circle\n  controller: gn\n"
        "fast:\n  base: *b\n  grid: {sample: 1}\ngrid:\n  sample: 3\n"
    )
    assert len(sw.expand(p)) == 3 and len(sw.expand(p, fast=True)) == 1


# ---------------------------------------------------------------------------- two sweeps on one directory
def test_a_second_sweep_on_a_locked_directory_is_refused(tmp_path: Path) -> None:
    """Sweep A (a CLI process, stuck in a hung job) holds the directory; sweep B (another CLI process, at the same
    time) and sweep C (this process) are refused with the holder's pid; once A is killed the lock is free."""
    spec = tmp_path / "spec.json"
    spec.write_text(json.dumps({"name": "locked", "jobs": [_job(4, fault="hang"), _job(0)]}))
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "coop_ga.sweep", str(spec), "--executor", "serial", "--out", str(out), "--quiet"]
    env = {**os.environ, FAULTS_ENV: "1", "PYTHONPATH": str(ROOT)}
    a = subprocess.Popen([*cmd, "--timeout", "none"], cwd=ROOT, env=env, stderr=subprocess.PIPE, text=True)
    try:
        lock = out / ".sweep.lock"
        t0 = time.monotonic()
        while not (lock.is_file() and f"pid {a.pid}" in lock.read_text()):
            assert a.poll() is None, a.stderr.read() if a.stderr else ""
            assert time.monotonic() - t0 < 120, "sweep A never took the lock"
            time.sleep(0.05)
        b = subprocess.run([*cmd, "--timeout", "1"], cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
        assert b.returncode == 2 and "is in use by another sweep" in b.stderr and f"pid {a.pid}" in b.stderr
        with pytest.raises(sw.SweepLockedError, match=f"pid {a.pid}"):
            sw.run(sw.expand(spec), out=out, timeout=1.0)
        assert a.poll() is None and sw.read_records(out) == []  # A still runs; nobody wrote a record
    finally:
        a.send_signal(signal.SIGKILL)
        a.wait()
    with sw.store.directory_lock(out):  # the kernel released A's lock with its process
        pass


# ---------------------------------------------------------------------------- the error contract
BAD_RUN = [
    ({"executor": "threads"}, "unknown executor"),
    ({"executor": None}, "unknown executor"),
    ({"workers": 0, "executor": "process"}, "workers must be"),
    ({"workers": 2.5, "executor": "process"}, "workers must be"),
    ({"workers": True, "executor": "process"}, "workers must be"),
    ({"workers": "2", "executor": "process"}, "workers must be"),
    ({"format": "csv"}, "unknown format"),
    ({"timeout": float("nan")}, "timeout"),
    ({"timeout": -1}, "timeout"),
    ({"timeout": "later"}, "timeout"),
    ({"retries": -1}, "retries"),
    ({"retries": 1.0}, "retries"),
    ({"resume": "yes"}, "resume must be True or False"),
    ({"progress": 1}, "progress must be True or False"),
    ({"address": 5}, "address"),
]


@pytest.mark.parametrize(("kw", "match"), BAD_RUN)
def test_run_refuses_bad_arguments(kw: dict[str, Any], match: str) -> None:
    with pytest.raises(CoopGAError, match=match) as ei:
        sw.run([_job(0)], **kw)
    assert isinstance(ei.value, InvalidInputError)


J = {"system": SYSTEM, "kind": "circle", "controller": "gn"}


def _nested(depth: int) -> list[Any]:
    x: list[Any] = [0]
    for _ in range(depth):
        x = [x]
    return x


BAD_JOBS = [
    ({**J, "kind": "hexagon"}, "unknown job.kind"),
    ({**J, "kind": 3}, "unknown job.kind"),
    ({**J, "controller": ["gn"]}, "unknown controller"),
    ({**J, "points": [0, "a"]}, "end-point indices"),
    ({**J, "points": [0, 1.5]}, "end-point indices"),
    ({**J, "points": 2}, "end-point indices"),
    ({**J, "points": [-1, 0]}, "end-point indices"),
    ({**J, "target": {"translation": [0.0, float("nan"), 0.0]}}, "non-finite"),
    ({**J, "target": {"translation": [0.0, 1.0]}}, "3 entries"),
    ({**J, "target": {"translation": "up"}}, "translation"),
    ({**J, "target": {"axis": [0, 0, 0]}}, "nonzero"),
    ({**J, "target": {"angle": float("inf")}}, "non-finite"),
    ({**J, "target": {"angle": "big"}}, "angle"),
    ({**J, "target": {"scale": 0.0}}, "scale"),
    ({**J, "target": {"scale": -2}}, "scale"),
    ({**J, "target": {"coeffs": [1.0] * 11}}, "12 entries"),
    ({**J, "target": {"sampler": "displacement", "level": ["small"]}}, "unknown target level"),
    ({**J, "target": {"sampler": "displacement", "translation": -0.1, "angle_deg": 5, "scale": 0.1}}, "translation"),
    ({**J, "target": {"sampler": "displacement", "translation": 0.1, "angle_deg": 5, "scale": 1.5}}, "scale"),
    ({**J, "target": {"sampler": "displacement", "level": "small", "qd_max": -1}}, "qd_max"),
    ({**J, "start": {"spread": -0.1}}, "spread"),
    ({**J, "start": {"spread": "wide"}}, "spread"),
    ({**J, "start": {"q": [0.0, float("nan")]}}, "non-finite"),
    ({**J, "start": [1, 2]}, "job.start"),
    ({**J, "options": [1]}, "job.options must be a dict"),
    ({**J, "tags": {"x": float("nan")}}, "non-finite"),
    ({**J, "tags": {"x": object()}}, "plain data"),
    ({**J, "seed": {"entropy": "abc"}}, "seed"),
    ({**J, "seed": {"entropy": 1, "spawn_key": [-1]}}, "seed"),
    ({**J, "seed": {"entropy": 1, "spawn_key": 5}}, "seed"),
    ({**J, "seed": 1.5}, "seed"),
    ({**J, "certify": 1}, "certify"),
    ({**J, "system": 3}, "job.system"),
    ({**J, "tags": {"x": _nested(70)}}, "nested deeper"),
    ("gn", "a job must be a dict"),
]


@pytest.mark.parametrize(("job", "match"), BAD_JOBS)
def test_bad_jobs_raise_before_running(job: Any, match: str) -> None:
    with pytest.raises(sw.InvalidJobError, match=match):
        sw.normalize_job(job)
    with pytest.raises(sw.InvalidJobError):
        sw.run([job])


def test_valid_jobs_keep_their_hash() -> None:
    """The value checks change no valid job's normalized form, so stored sweeps still resume: the hashes are the
    ones the code before the checks gave (computed with it)."""
    assert sw.job_hash(sw.normalize_job(J)) == "43cd1b5d26ad6884"
    assert sw.spec.sweep_hash(sw.expand("robustness", fast=True)) == "925d25315199b2b9"
    assert sw.spec.sweep_hash(sw.expand("impedance_gains")) == "aa69dd4af342679e"
    assert sw.normalize_job(sw.normalize_job(_job(3))) == sw.normalize_job(_job(3))


def _self_ref() -> dict[str, Any]:
    d: dict[str, Any] = {"name": "x"}
    d["base"] = d
    return d


BAD_CALLS = [
    (lambda: sw.run({"system": SYSTEM}), "jobs must be a list"),
    (lambda: sw.run("jobs.json"), "jobs must be a list"),
    (lambda: sw.expand(42), "a spec is a dict"),
    (lambda: sw.expand({"base": J, "grid": {"sample": 0}}), "count ≥ 1"),
    (lambda: sw.expand({"base": J, "grid": {"sample": 2.0}}), "count ≥ 1"),
    (lambda: sw.expand({"base": J, "grid": {"kind": "circle"}}), "non-empty list"),
    (lambda: sw.expand({"base": J, "grid": []}), "grid must be a mapping"),
    (lambda: sw.expand({"base": [1], "grid": {"sample": 1}}), "'base' must be a mapping"),
    (lambda: sw.expand({"base": J, "seed": -1}), "seed must be"),
    (lambda: sw.expand({"base": J, "jobs": 3}), "'jobs' must be a list"),
    (lambda: sw.expand({"base": J, "timeout": 0}), "timeout"),
    (lambda: sw.expand({"base": J, "fast": 3}, fast=True), "'fast' must be a mapping"),
    (lambda: sw.expand({"base": J, "grid": {"sample": 2}, "seeding": {"by": [3]}}), "seeding by"),
    (lambda: sw.load_spec({"base": J}, fast="yes"), "fast must be"),
    (lambda: sw.load_spec(_self_ref()), "nested deeper"),
    (lambda: sw.seeds(-1, 3), "root"),
    (lambda: sw.seeds(0, 2.5), "n "),
    (lambda: sw.seeds(0, -1), "n "),
    (lambda: sw.seed_sequence([1, 2]), "seed must be"),
    (lambda: sw.seed_sequence({"entropy": 1.5}), "seed entropy"),
    (lambda: sw.name_spawn_key([1.5]), "seed key"),
    (lambda: sw.draw_displacement(np.random.default_rng(0), sw.LEVELS["small"], -1), "nq"),
    (lambda: sw.draw_displacement(np.random.default_rng(0), "small", 3), "level must be"),
    (lambda: sw.draw_displacement(np.random.default_rng(0), sw.Level(np.nan, 5, 0.1), 3), "translation_m"),
    (lambda: sw.draw_displacement(np.random.default_rng(0), sw.LEVELS["small"], 3, np.inf), "qd_max"),
    (lambda: sw.draw_displacement(0, sw.LEVELS["small"], 3), "Generator"),
    (lambda: sw.summarize([{"controller": "a"}], by=3), "by must"),
    (lambda: sw.summarize([{"controller": "a"}], quantiles=[1.5]), "quantiles"),
    (lambda: sw.summarize([{"controller": "a"}], quantiles=[float("nan")]), "quantiles"),
    (lambda: sw.summarize([{"controller": "a"}], fields=[None]), "fields"),
    (lambda: sw.summarize([1, 2]), "records must be"),
    (lambda: sw.summarize({"controller": "a"}), "records must be"),
    (lambda: sw.format_table([1]), "rows must be"),
    (lambda: sw.plot([], 5), "path must be"),
    (lambda: sw.read_records(5), "out must be"),
    (lambda: sw.read_records("/nonexistent/sweep"), "not a directory"),
    (lambda: sw.RecordWriter("/tmp", "csv"), "unknown record format"),
    (lambda: sw.RecordWriter("/tmp", "jsonl", batch=0), "batch"),
    (lambda: sw.count_jobs({"base": J, "grid": {"sample": -3}}), "count ≥ 1"),
    (lambda: sw.job_hash([1]), "job_hash takes"),
    (lambda: sw.job_hash({"x": float("nan")}), "not plain finite data"),
    (lambda: sw.run_job(-1, J), "index"),
    (lambda: sw.run_job(0, {**J, "kind": "blob"}), "unknown job.kind"),
    (lambda: sw.strip_timing([1]), "a record is a dict"),
    (lambda: sw.records_equal("ab", []), "a must be a list"),
    (lambda: sw.certify(object(), [0.0], None), "cooperative task"),
]


@pytest.mark.parametrize(("call", "match"), BAD_CALLS)
def test_public_functions_raise_coop_ga_errors(call: Any, match: str) -> None:
    with pytest.raises(CoopGAError, match=match):
        call()


def test_summary_never_reports_nan() -> None:
    recs = [
        {"controller": "a", "status": "ok", "converged": True, "iterations": x, "seconds": 0.001}
        for x in (1, float("nan"), float("inf"), 3)
    ]
    (row,) = sw.summarize(recs)
    assert row["iterations_q50"] == 2.0 and row["iterations_q100"] == 3.0  # over the finite values only
    huge = [{**recs[0], "iterations": x} for x in (-1.7e308, 1.7e308)]  # interpolating overflows: the nearest
    assert sw.summarize(huge)[0]["iterations_q50"] == -1.7e308
    odd = [{**recs[0], "controller": {"k": object()}}, {**recs[0], "controller": {1, 2}}]
    assert len(sw.summarize(odd)) == 2  # unhashable or non-JSON group values are grouped by their repr


def test_record_writer_refuses_bad_records(tmp_path: Path) -> None:
    with sw.RecordWriter(tmp_path) as w:
        for bad in ({"status": "ok"}, {"job": "1"}, {"job": True}, [1], {"job": 1, "x": object()}):
            with pytest.raises(sw.SweepError):
                w.write(bad)  # type: ignore[arg-type]
        w.write({"job": 0, "error": float("nan")})
    assert sw.read_records(tmp_path) == [{"job": 0, "error": None}]


def test_cli_refuses_bad_options(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from coop_ga.sweep.__main__ import main

    for argv in (["--timeout", "nan"], ["--timeout", "-3"], ["--max-jobs", "0"], ["--max-jobs", "1.5"]):
        with pytest.raises(SystemExit) as ei:
            main(["robustness", *argv])
        assert ei.value.code == 2
    assert "expected" in capsys.readouterr().err
    p = tmp_path / "s.json"
    p.write_text(json.dumps({"name": "x", "jobs": [{**J, "kind": "hexagon"}]}))
    assert main([str(p), "--out", str(tmp_path / "o")]) == 2
    assert "unknown job.kind" in capsys.readouterr().err


def test_worker_fault_hook_needs_its_variable(monkeypatch: pytest.MonkeyPatch) -> None:
    """Without COOP_GA_SWEEP_TEST_FAULTS=1 a "fault" tag is only a tag: the job runs."""
    monkeypatch.delenv(FAULTS_ENV, raising=False)
    (r,) = sw.run([_job(0, fault="exit")])
    assert r["status"] == "ok" and r["fault"] == "exit"
    monkeypatch.setenv(FAULTS_ENV, "1")
    (r,) = sw.run([_job(0, fault="raise")])
    assert r["status"] == "failed" and "test fault 'raise'" in r["exception"]


def test_timeout_flows_from_the_spec_to_the_cli(
    faults: None, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The spec's timeout is the CLI's default; --timeout overrides it (here: none → the run gets None)."""
    import coop_ga.sweep.__main__ as cli

    seen: list[Any] = []

    def fake_run(jobs: Any, **kw: Any) -> list[dict[str, Any]]:
        seen.append(kw["timeout"])
        return []

    monkeypatch.setattr(cli, "run", fake_run)
    (tmp_path / "o").mkdir()
    p = tmp_path / "s.json"
    p.write_text(json.dumps({"name": "x", "timeout": 12.5, "jobs": [J]}))
    for argv, want in (([], 12.5), (["--timeout", "none"], None), (["--timeout", "3"], 3.0)):
        assert cli.main([str(p), "--out", str(tmp_path / "o"), "--no-figure", *argv]) == 0
        assert seen[-1] == want
    p.write_text(json.dumps({"name": "x", "jobs": [J]}))
    assert cli.main([str(p), "--out", str(tmp_path / "o"), "--no-figure"]) == 0
    assert seen[-1] == "auto"
