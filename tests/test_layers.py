"""Layers depend downward only, and no modules import each other in a cycle.

Layers, bottom to top: the root modules errors → diagnostics → validation → codegen, then
algebra → geometry → kinematics → linkages → systems → collision → viz → cooperative → control →
plan → legged → sim → viewer → sweep → harness → adapters.  A module may import its own layer and the layers below it
(every import counts, also one inside a function); a root module only the root modules
before it.  Import cycles are looked for among the imports a module runs when it is
imported (module level, ``if TYPE_CHECKING:`` blocks excluded).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[1] / "coop_ga"
ROOT_ORDER = ["errors", "diagnostics", "validation", "codegen"]
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
    "plan",
    "legged",
    "sim",
    "viewer",
    "sweep",
    "harness",
    "adapters",
]


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PKG.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {_module_name(p): p for p in PKG.rglob("*.py")}


def _targets(node: ast.Import | ast.ImportFrom, path: Path) -> list[str]:
    """The coop_ga modules an import statement loads by name (a ``from X import name`` counts as
    X.name when that is a module, else as X; parent packages loaded implicitly are not counted)."""
    if isinstance(node, ast.Import):
        return [a.name for a in node.names if a.name.split(".")[0] == "coop_ga"]
    if node.level == 0:
        base = node.module or ""
    else:
        pkg = _module_name(path).split(".")
        if path.name != "__init__.py":
            pkg = pkg[:-1]
        pkg = pkg[: len(pkg) - (node.level - 1)]
        base = ".".join(pkg + ([node.module] if node.module else []))
    if base.split(".")[0] != "coop_ga":
        return []
    return [f"{base}.{a.name}" if f"{base}.{a.name}" in MODULES else base for a in node.names]


def _is_type_checking(node: ast.If) -> bool:
    t = node.test
    return (isinstance(t, ast.Name) and t.id == "TYPE_CHECKING") or (
        isinstance(t, ast.Attribute) and t.attr == "TYPE_CHECKING"
    )


def _module_level_imports(body: list[ast.stmt], path: Path) -> set[str]:
    out: set[str] = set()
    for node in body:
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            out.update(_targets(node, path))
        elif isinstance(node, ast.If):
            if not _is_type_checking(node):
                out |= _module_level_imports(node.body, path)
            out |= _module_level_imports(node.orelse, path)
        elif isinstance(node, ast.Try):
            for block in (node.body, node.orelse, node.finalbody, *[h.body for h in node.handlers]):
                out |= _module_level_imports(block, path)
        elif isinstance(node, ast.With):
            out |= _module_level_imports(node.body, path)
    return out


def _all_imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text())
    return {t for n in ast.walk(tree) if isinstance(n, (ast.Import, ast.ImportFrom)) for t in _targets(n, path)}


def _layer(module: str) -> str | None:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else None


@pytest.mark.parametrize("layer", ORDER)
def test_no_upward_imports(layer: str) -> None:
    root = PKG / layer
    files = list(root.rglob("*.py")) if root.is_dir() else [p for p in [PKG / f"{layer}.py"] if p.exists()]
    if not files:
        pytest.skip(f"coop_ga has no {layer} layer yet")
    allowed = set(ROOT_ORDER) | set(ORDER[: ORDER.index(layer) + 1])
    for f in files:
        bad = {_layer(m) for m in _all_imports(f)} - allowed - {None}
        assert not bad, f"{f.relative_to(PKG)} imports higher layer(s) {sorted(bad)}"


@pytest.mark.parametrize("module", ROOT_ORDER)
def test_root_modules_import_only_the_root_modules_below_them(module: str) -> None:
    """errors → diagnostics → validation → codegen, nothing above (validation used to import the
    geometry layer for :func:`~coop_ga.validation.target`)."""
    allowed = set(ROOT_ORDER[: ROOT_ORDER.index(module)])
    path = PKG / f"{module}.py"
    files = [path] if path.exists() else sorted((PKG / module).rglob("*.py"))  # a root package
    assert files, f"root module {module} not found"
    used = {_layer(m) for f in files for m in _all_imports(f)} - {module}
    assert used <= allowed, f"{module} imports {sorted(used - allowed)}; it may import only {sorted(allowed)}"


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (or a module importing itself): Tarjan."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1 or v in graph.get(v, ()):
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_cycle_finder_finds_cycles() -> None:
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert _cycles({"a": {"a"}}) == [["a"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []


def test_no_import_cycles() -> None:
    graph = {
        m: {t for t in _module_level_imports(ast.parse(p.read_text()).body, p) if t in MODULES}
        for m, p in MODULES.items()
    }
    assert sum(map(len, graph.values())) > 100  # the graph is read (every module's imports)
    assert _cycles(graph) == []
