"""Every script of ``examples/`` runs: exit code 0 and the files it declares in ``OUTPUTS`` written.

The scripts are collected from the folder, so a new example is tested without editing this file.  Each one
is run in this process (the compiled tasks and imports are shared, which keeps the file within a minute of
CPU) through its ``main(argv)`` with ``--out`` in a temporary folder and ``--fast``.  An example that needs an
optional extra names its import in ``REQUIRES`` and is skipped only when that import is missing.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

import pytest

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
SCRIPTS = sorted(EXAMPLES.glob("[0-9][0-9]_*.py"))


def _load(path: Path) -> ModuleType:
    spec = importlib.util.spec_from_file_location(f"coop_ga_example_{path.stem}", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_folder_has_the_numbered_examples():
    assert len(SCRIPTS) >= 8, [p.name for p in SCRIPTS]
    numbers = [p.name[:2] for p in SCRIPTS]
    assert numbers == sorted(set(numbers)), f"two examples share a number: {numbers}"
    readme = (EXAMPLES / "README.md").read_text()
    missing = [p.name for p in SCRIPTS if p.name not in readme]
    assert not missing, f"examples/README.md does not list {missing}"


@pytest.mark.parametrize("path", SCRIPTS, ids=[p.stem for p in SCRIPTS])
def test_example_runs(path: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    source = path.read_text()
    assert source.startswith('"""'), f"{path.name}: no module docstring"
    assert "Run::" in source, f"{path.name}: the docstring does not say how to run it"
    module = _load(path)
    for name in getattr(module, "REQUIRES", ()):
        pytest.importorskip(name)
    outputs = module.OUTPUTS
    assert outputs, f"{path.name}: OUTPUTS names no file"
    with pytest.raises(SystemExit) as help_exit:
        module.main(["--help"])
    assert help_exit.value.code == 0
    assert "--out" in capsys.readouterr().out
    out = tmp_path / "out"
    code = module.main(["--out", str(out), "--fast"])
    printed = capsys.readouterr().out
    assert code == 0, f"{path.name} returned {code}:\n{printed}"
    assert printed.strip(), f"{path.name} printed nothing"
    for name in outputs:
        f = out / name
        assert f.is_file() and f.stat().st_size > 0, f"{path.name} did not write {name}"
