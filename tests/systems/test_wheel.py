"""The wheel ships the robots: every registered system loads from a wheel install, outside the repository.

Regression test of the installation bug of the architecture issue: with ``pip install .``
(not ``-e``) ``ROBOTS_DIR`` pointed outside the package and ``three_iiwa14`` / ``hexapod``
failed to load.  Here the wheel is built (no build isolation: setuptools comes from the
test extras), unpacked into a temporary directory, and a subprocess started *outside the
repository* imports coop_ga from there — ``PYTHONPATH`` puts it before the editable
install's finder, and the test checks that every module and robot file comes from the
unpacked wheel.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]

_PROBE = r"""
import json, sys
import coop_ga
from coop_ga import systems
out = {"file": coop_ga.__file__, "robots": str(systems.ROBOTS_DIR), "systems": {}}
for name in systems.names():
    s = systems.load(name)
    out["systems"][name] = [s.nq, list(s.end_points(s.q0)[0])]
out["modules"] = sorted({m.__file__ for k, m in sys.modules.items() if k.startswith("coop_ga") and getattr(m, "__file__", None)})
print(json.dumps(out))
"""


@pytest.fixture(scope="module")
def wheel_site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    dist = tmp_path_factory.mktemp("dist")
    res = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", str(REPO), "--no-deps", "--no-build-isolation", "-q", "-w", str(dist)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert res.returncode == 0, res.stderr[-3000:]
    wheels = list(dist.glob("coop_ga-*.whl"))
    assert len(wheels) == 1, wheels
    site = tmp_path_factory.mktemp("site")
    with zipfile.ZipFile(wheels[0]) as z:
        z.extractall(site)
    return site


def test_wheel_contains_robots_and_typing_marker(wheel_site: Path) -> None:
    robots = wheel_site / "coop_ga" / "systems" / "robots"
    for rel in ("iiwa14/iiwa14.urdf", "iiwa14/README.md", "hexapod/hexapod.urdf", "hexapod/README.md"):
        assert (robots / rel).is_file(), rel
    assert (wheel_site / "coop_ga" / "py.typed").is_file()


def test_every_registered_system_loads_from_the_wheel(wheel_site: Path, tmp_path: Path) -> None:
    env = dict(os.environ, PYTHONPATH=str(wheel_site), COOP_GA_CACHE=str(tmp_path / "cache"))
    res = subprocess.run(
        [sys.executable, "-c", _PROBE], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300
    )
    assert res.returncode == 0, res.stderr[-3000:]
    out = json.loads(res.stdout.strip().splitlines()[-1])
    assert out["file"].startswith(str(wheel_site)), out["file"]
    assert out["robots"].startswith(str(wheel_site)), out["robots"]
    assert all(m.startswith(str(wheel_site)) for m in out["modules"]), [
        m for m in out["modules"] if not m.startswith(str(wheel_site))
    ]
    from coop_ga import systems

    assert sorted(out["systems"]) == sorted(systems.names())
    for name, (nq, p0) in out["systems"].items():
        s = systems.load(name)
        assert nq == s.nq, name
        assert max(abs(a - b) for a, b in zip(p0, s.end_points(s.q0)[0])) < 1e-12, name
