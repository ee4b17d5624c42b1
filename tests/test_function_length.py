"""No function in ``coop_ga/``, ``experiments/``, ``benchmarks/`` or ``paper_figures/`` is longer than 80 lines (the
developers' guide; ruff's C901 checks complexity).

A function's length is counted from its ``def`` (decorators excluded) to its last line, docstring and
comments included, the way a reader sees it; nested functions count in their parent too.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PKG = ROOT / "coop_ga"
MAX_LINES = 80
#: the scripts' folders, checked like the package
SCRIPT_DIRS = ("experiments", "benchmarks", "paper_figures")


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


def _too_long(files: list[Path]) -> list[str]:
    return [
        f"{path.relative_to(ROOT)}:{line} {name} ({n} lines)"
        for path in files
        for name, line, n in function_lengths(path)
        if n > MAX_LINES
    ]


def test_no_function_over_80_lines():
    files = sorted(PKG.rglob("*.py"))
    assert len(files) > 100  # the whole package is scanned
    long = _too_long(files)
    assert not long, f"functions over {MAX_LINES} lines (split them into one function per stage):\n" + "\n".join(long)


def test_no_script_function_over_80_lines():
    """The experiment, benchmark and gallery scripts too: one function per stage (setup, run, metrics, drawing,
    gallery block)."""
    checked = [path for d in SCRIPT_DIRS for path in sorted((ROOT / d).rglob("*.py"))]
    names = {p.relative_to(ROOT).as_posix() for p in checked}
    # every folder is scanned, the scripts split here among them
    assert {"experiments/singularity.py", "benchmarks/bad_inputs.py", "paper_figures/__main__.py"} <= names
    assert {"experiments/sim_hexapod_walk.py", "benchmarks/ocp.py"} <= names  # the last two allow-listed ones
    long = _too_long(checked)
    assert not long, f"functions over {MAX_LINES} lines (split them into one function per stage):\n" + "\n".join(long)
