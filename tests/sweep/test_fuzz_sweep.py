"""Fuzz the pure parts of coop_ga.sweep's public API (no job runs): for arbitrary inputs — NaN/inf, wrong types,
shapes and ranges — (a) every exception is a CoopGAError, (b) nothing returned holds NaN/inf, (c) no input is
mutated.  CI runs the ``default`` hypothesis profile; ``--hypothesis-profile=long`` runs 10 000 examples each."""

from __future__ import annotations

import copy
import json
import math
from typing import Any

from hypothesis import given
from hypothesis import strategies as st

import coop_ga.sweep as sw
from coop_ga.errors import CoopGAError
from coop_ga.sweep.pool import TimeoutPolicy

numbers = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-(2**70), 2**70),
    st.sampled_from([0, -1, 1, 0.5, 1e300, -0.0, True, False]),
)
junk = st.one_of(  # fresh containers per example (a shared one would carry edits from one example to the next)
    st.none(),
    numbers,
    st.text(max_size=4),
    st.lists(numbers, max_size=4),
    st.builds(dict, a=st.just(1)),
    st.builds(object),
)
VALID = {
    "system": "three_finger_hand",
    "kind": "circle",
    "controller": "gn",
    "points": [0, 1, 2],
    "target": {"translation": [0.01, 0.0, 0.0], "axis": [0, 0, 1], "angle": 0.1, "scale": 1.05},
    "start": {"spread": 0.1, "qd_max": 0.2},
    "seed": {"entropy": 3, "spawn_key": [1]},
    "tags": {"sample": 1},
}
PATHS = [
    ("system",),
    ("kind",),
    ("controller",),
    ("points",),
    ("target", "translation"),
    ("target", "axis"),
    ("target", "angle"),
    ("target", "scale"),
    ("start", "spread"),
    ("start", "qd_max"),
    ("seed",),
    ("seed", "entropy"),
    ("seed", "spawn_key"),
    ("tags", "sample"),
    ("options",),
    ("certify",),
]


def _finite(x: Any) -> bool:
    if isinstance(x, float):
        return math.isfinite(x)
    if isinstance(x, dict):
        return all(_finite(v) for v in x.values())
    if isinstance(x, (list, tuple)):
        return all(_finite(v) for v in x)
    return True


@given(st.lists(st.tuples(st.sampled_from(PATHS), junk), min_size=1, max_size=3))
def test_normalize_job_on_corrupted_jobs(edits: list[tuple[tuple[str, ...], Any]]) -> None:
    job = copy.deepcopy(VALID)
    for path, value in edits:
        d = job
        for k in path[:-1]:
            if not isinstance(d.get(k), dict):
                d[k] = {}
            d = d[k]
        d[path[-1]] = copy.deepcopy(value)
    before = repr(job)
    try:
        out = sw.normalize_job(job)
    except CoopGAError:
        pass
    else:
        json.dumps(out, allow_nan=False)  # plain, finite data
        assert sw.normalize_job(out) == out and len(sw.job_hash(out)) == 16
    assert repr(job) == before


@given(
    st.lists(st.dictionaries(st.sampled_from(["controller", "status", "converged", "iterations", "seconds"]), junk)),
    st.one_of(st.just("controller"), junk),
    st.one_of(st.lists(numbers, max_size=3), junk),
)
def test_summarize_on_junk_records(records: list[dict[str, Any]], by: Any, quantiles: Any) -> None:
    before = repr(records)
    try:
        rows = sw.summarize(records, by=by, quantiles=quantiles)
    except CoopGAError:
        pass
    else:
        for row in rows:
            assert _finite({k: v for k, v in row.items() if k != by})  # group values are the records' own
        sw.format_table(rows)
    assert repr(records) == before


@given(
    st.dictionaries(
        st.sampled_from(["sample", "kind", "options.K", "target.scale", "seed", "bogus.x"]),
        st.one_of(junk, st.lists(junk, max_size=3), st.integers(-5, 10**12)),
        max_size=3,
    ),
    st.one_of(st.integers(-2, 10**7), junk),
)
def test_expand_on_junk_grids(grid: dict[str, Any], max_jobs: Any) -> None:
    spec = {"base": {"system": "three_finger_hand", "kind": "circle", "controller": "gn"}, "grid": grid}
    try:
        jobs = sw.expand(spec, max_jobs=max_jobs if not isinstance(max_jobs, int) else min(max_jobs, 50))
    except CoopGAError:
        return
    assert len(jobs) == sw.count_jobs(spec) <= 50
    json.dumps(jobs, allow_nan=False)


@given(junk, junk)
def test_seeds_and_timeouts_on_junk(a: Any, b: Any) -> None:
    for call in (
        lambda: sw.seeds(a, b if not isinstance(b, int) else min(abs(b), 10)),
        lambda: sw.seed_sequence(a),
        lambda: sw.seed_sequence({"entropy": a, "spawn_key": b}),
        lambda: TimeoutPolicy.of(a).limit(),
        lambda: sw.name_spawn_key([a, b]),
    ):
        try:
            out = call()
        except CoopGAError:
            continue
        if isinstance(out, float):
            assert math.isfinite(out) and out > 0
