"""Layers depend downward only: algebra → geometry → kinematics → linkages → systems → collision → viz → cooperative → control → legged → sim → sweep → harness."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[1] / "coop_ga"
ORDER = [
    "algebra",
    "geometry",
    "kinematics",
    "linkages",
    "systems",
    "collision",
    "viz",
    "cooperative",
    "control",
    "legged",
    "sim",
    "sweep",
    "harness",
]


def _imported_layers(path: Path) -> set[str]:
    tree = ast.parse(path.read_text())
    rel = path.relative_to(PKG).parts
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level == 0:
                parts = (node.module or "").split(".")
                if parts[0] != "coop_ga":
                    continue
                target = parts[1:]
            else:
                base = list(rel[:-1])[: len(rel) - node.level] if node.level > 1 else list(rel[:-1])
                target = base + (node.module.split(".") if node.module else [])
                if not node.module:
                    target = base + [a.name for a in node.names]
            if target and target[0] in ORDER:
                out.add(target[0])
    return out


@pytest.mark.parametrize("layer", ORDER)
def test_no_upward_imports(layer: str) -> None:
    root = PKG / layer
    files = list(root.rglob("*.py")) if root.is_dir() else [PKG / f"{layer}.py"]
    allowed = set(ORDER[: ORDER.index(layer) + 1])
    for f in files:
        bad = _imported_layers(f) - allowed
        assert not bad, f"{f.relative_to(PKG)} imports higher layer(s) {sorted(bad)}"
