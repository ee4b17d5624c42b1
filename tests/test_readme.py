"""The README is the front page: its Python example runs as written, and its commands are the ones CI runs.

The rest of the user-facing code lives in ``docs/`` and runs in ``tests/docs/test_code_blocks.py``.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
TEXT = README.read_text()
BLOCKS = re.findall(r"```python\n(.*?)```", TEXT, flags=re.S)


def test_readme_has_an_example():
    assert len(BLOCKS) >= 1


def test_readme_quickstart_is_what_ci_runs():
    quickstart = re.search(r"```bash\n(.*?)```", TEXT, flags=re.S)
    assert quickstart is not None
    commands = quickstart.group(1)
    assert 'pip install -e ".[test,viz,sim,plan]" && python -m paper_figures' in commands
    assert 'pip install -e ".[test,viz,sweep,sim,viewer,plan,adapters]" && python -m pytest -q' in commands
    assert "python -m pytest -q" in (ROOT / ".ci" / "run").read_text()


def test_readme_stays_a_front_page():
    """What it is, the two commands, one picture, links: the manual is docs/ (mkdocs.yml)."""
    assert len(TEXT.splitlines()) <= 120, "the README is the front page: put the details in a docs/ page and link it"
    assert TEXT.count("![") == 1, "one picture"
    for page in re.findall(r"\]\((docs/[^)#]+)", TEXT):
        assert (ROOT / page).is_file(), f"the README links {page}, which does not exist"


@pytest.mark.parametrize("code", BLOCKS, ids=[f"block{i}" for i in range(len(BLOCKS))])
def test_readme_example_runs(code: str) -> None:
    namespace: dict[str, object] = {"__name__": "readme_example"}
    exec(compile(code, str(README), "exec"), namespace)
