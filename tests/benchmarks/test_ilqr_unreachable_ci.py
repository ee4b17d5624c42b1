"""benchmarks/ilqr_unreachable.py --ci: runs, writes its JSON, and iLQR gives up before iterating on every target.

No timing assertion (the ratio to the Gauss–Newton IK is printed and recorded, not tested): the test checks what makes
the failure fast — zero iterations — and honest — the message — and that the trajectory stays inside the limits.
"""

from __future__ import annotations

import importlib
import json
import math
import sys
from pathlib import Path
from typing import Any

import pytest

BENCH = Path(__file__).resolve().parents[2] / "benchmarks"


def _module() -> Any:
    if str(BENCH) not in sys.path:
        sys.path.insert(0, str(BENCH))
    return importlib.import_module("ilqr_unreachable")


@pytest.fixture(scope="module")
def doc(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    mod = _module()
    out = tmp_path_factory.mktemp("ilqr_unreachable")
    assert mod.main(["--ci", "--quiet", "--repeats", "1", "--out", str(out)]) == 0
    return json.loads((out / "results.json").read_text())


def test_every_target_fails_fast_and_honestly(doc: dict[str, Any]) -> None:
    mod = _module()
    assert doc["config"]["ci"] is True and doc["config"]["distance_m"] == 3.0
    recs = doc["records"]
    assert [(r["system"], r["kind"]) for r in recs] == [tuple(c) for c in mod.CI_CASES]
    for r in recs:
        assert math.hypot(*r["translation_m"]) == pytest.approx(3.0)
        assert r["gn"]["converged"] is False and r["ilqr"]["converged"] is False and r["reachable"] is False
        assert r["ilqr"]["iterations"] == 0 and r["certified"] is True
        assert mod.UNREACHABLE_PHRASE in r["ilqr"]["message"] and r["ilqr"]["within_limits"] is True
        assert r["ratio"] > 0 and math.isfinite(r["ratio"])
    s = doc["summary"]
    assert s["targets"] == s["unreachable"] == s["certified"] == s["says_unreachable"] == len(recs)
    assert s["outside_limits"] == 0


def test_cli(capsys: pytest.CaptureFixture[str]) -> None:
    mod = _module()
    with pytest.raises(SystemExit) as ex:
        mod.main(["--help"])
    assert ex.value.code == 0
    text = capsys.readouterr().out
    for opt in ("--targets", "--distance", "--repeats", "--ci", "--out", "--seed", "--quiet"):
        assert opt in text, opt
    for bad in (["--distance", "-1"], ["--targets", "0"]):
        with pytest.raises(SystemExit) as ex:
            mod.main(bad)
        assert ex.value.code == 2
