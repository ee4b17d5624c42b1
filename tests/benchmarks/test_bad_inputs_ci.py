"""The bad-input campaign's CI mode: every bad argument to coop_ga.collision, linkages, legged and systems is
refused with a CoopGAError naming it — no other exception, no NaN/inf, nothing accepted, no hang, no input
modified (``benchmarks/bad_inputs.py``; the sweep's cases are run and reported, and checked once that module
meets the contract too)."""

from __future__ import annotations

import importlib
import json
import math
import sys
from pathlib import Path
from typing import Any

import pytest

BENCH = Path(__file__).resolve().parents[2] / "benchmarks"
#: the modules whose cases must all pass (the sweep's own fixes land separately)
CONTRACT = ("collision", "linkages", "legged", "systems")


def _module() -> Any:
    # on sys.path (not loaded from a file spec): the spawned worker re-imports the module by name
    if str(BENCH) not in sys.path:
        sys.path.insert(0, str(BENCH))
    return importlib.import_module("bad_inputs")


@pytest.fixture(scope="module")
def report(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    out = tmp_path_factory.mktemp("bad_inputs")
    rc = _module().main(["--ci", "--quiet", "--out", str(out), "--require", *CONTRACT])
    doc = json.loads((out / "bad_inputs.json").read_text(), parse_constant=lambda c: pytest.fail(f"non-JSON {c}"))
    doc["rc"] = rc
    return doc


def test_the_full_campaign_has_at_least_300_cases_over_the_five_modules():
    bi = _module()
    cases = bi.build_cases()
    assert len(cases) >= 300
    per = {m: sum(c.module == m for c in cases) for m in bi.MODULES}
    assert set(per) == {"collision", "linkages", "legged", "systems", "sweep"} and min(per.values()) >= 30, per
    assert len({c.id for c in cases}) == len(cases)  # every case is told apart in the report
    ci = bi.build_cases(ci=True)
    assert {(c.module, c.function) for c in ci} == {(c.module, c.function) for c in cases}  # every function


def test_ci_run_reports_every_case_with_one_outcome(report):
    bi = _module()
    recs = report["records"]
    assert len(recs) == len(bi.build_cases(ci=True))
    assert all(r["outcome"] in bi.OUTCOMES for r in recs)
    for m, row in report["summary"].items():
        assert row["cases"] == sum(row[o] for o in bi.OUTCOMES), m
    assert report["summary"]["all"]["cases"] == len(recs)
    assert all(math.isfinite(r["seconds"]) and r["seconds"] >= 0 for r in recs)


@pytest.mark.parametrize("module", CONTRACT)
def test_contract_modules_refuse_every_bad_input_with_a_named_coop_ga_error(report, module):
    row = report["summary"][module]
    bad = [f"{r['outcome']} {r['id']}: {r['message'][:120]}" for r in report["records"]
           if r["module"] == module and (r["outcome"] != "refused" or r["mutated"] or r["unnamed"])]  # fmt: skip
    assert row["failures"] == 0 and not bad, "\n".join(bad)
    assert row["refused"] == row["cases"] > 20


def test_exit_status_follows_the_required_modules(report):
    assert report["rc"] == 0
