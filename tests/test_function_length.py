"""No function in ``coop_ga/`` is longer than 80 lines (the developers' guide; ruff's C901 checks complexity).

A function's length is counted from its ``def`` (decorators excluded) to its last line, docstring and
comments included, the way a reader sees it; nested functions count in their parent too.
"""

from __future__ import annotations

import ast
from pathlib import Path

PKG = Path(__file__).resolve().parents[1] / "coop_ga"
MAX_LINES = 80


def function_lengths(path: Path) -> list[tuple[str, int, int]]:
    """``(qualified name, first line, number of lines)`` of every function and method in ``path``."""
    out: list[tuple[str, int, int]] = []

    def visit(node: ast.AST, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef):
                name = f"{prefix}{child.name}"
                out.append((name, child.lineno, int(child.end_lineno or child.lineno) - child.lineno + 1))
                visit(child, f"{name}.")
            elif isinstance(child, ast.ClassDef):
                visit(child, f"{prefix}{child.name}.")
            else:
                visit(child, prefix)

    visit(ast.parse(path.read_text(encoding="utf-8")), "")
    return out


def test_counter_measures_lengths(tmp_path):
    src = tmp_path / "m.py"
    body = "\n".join(f"        x{i} = {i}" for i in range(81))
    src.write_text(f"def short():\n    return 1\n\n\nclass C:\n    def long(self):\n{body}\n")
    assert function_lengths(src) == [("short", 1, 2), ("C.long", 6, 82)]


def test_no_function_over_80_lines():
    files = sorted(PKG.rglob("*.py"))
    assert len(files) > 100  # the whole package is scanned
    long = [
        f"{path.relative_to(PKG.parent)}:{line} {name} ({n} lines)"
        for path in files
        for name, line, n in function_lengths(path)
        if n > MAX_LINES
    ]
    assert not long, f"functions over {MAX_LINES} lines (split them into one function per stage):\n" + "\n".join(long)
