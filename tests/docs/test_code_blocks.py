"""The Python code of the docs pages runs as written (the user-facing text is tested, not a copy of it).

A page's ``python`` blocks run in order in one namespace, from the repository root, as a reader would run
them top to bottom (a later block may use a name an earlier one made). The one block that needs the
reader's own URDF (``my_hand.urdf``) is left out; ``examples/`` has the runnable version of it
(``01_bring_your_own_robot.py``). The README's block is run by ``tests/test_readme.py``.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[2] / "docs"
FENCE = re.compile(r"```python\n(.*?)```", flags=re.S)


def blocks(page: Path) -> list[str]:
    """The page's ``python`` blocks, less those that need a file of the reader's."""
    return [b for b in FENCE.findall(page.read_text()) if "my_hand.urdf" not in b]


PAGES = [p for p in sorted(DOCS.glob("*.md")) if blocks(p)]


def test_the_pages_have_code():
    names = {p.stem for p in PAGES}
    assert {"getting-started", "concepts", "controllers", "physics", "viewer", "sweeps"} <= names, names
    assert sum(len(blocks(p)) for p in PAGES) >= 10


@pytest.mark.parametrize("page", PAGES, ids=[p.stem for p in PAGES])
def test_page_code_runs(page: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(DOCS.parent)
    namespace: dict[str, object] = {"__name__": f"docs_{page.stem}"}
    for i, code in enumerate(blocks(page)):
        exec(compile(code, f"{page.name} (python block {i})", "exec"), namespace)
