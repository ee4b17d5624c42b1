"""A griffe extension for the docs build: the docstrings' Sphinx roles become cross-references.

The docstrings name other objects with Sphinx roles (``:class:`~coop_ga.Similarity```, ``:func:`solve_step```,
``:mod:`coop_ga.sim```), which mkdocstrings would print as they are.  Each becomes an *optional* autorefs
link, shown as code: resolved in the docstring's scope like Python names (griffe's ``Object.resolve``), a
link where the target has an API page, plain code where it has none (a private helper, a third-party
name) — never a warning.  ``~`` shows the last component only, as in Sphinx; ``title <target>`` is honoured.
"""

from __future__ import annotations

import html
import re
from typing import Any

import griffe

ROLE = re.compile(r":(?:class|func|mod|meth|data|attr|exc|obj):`(~?)([^`]+)`")


def _resolve(obj: Any, target: str) -> str:
    """The full path of ``target`` as seen from ``obj``'s scope (``target`` itself when it is not found)."""
    if target.startswith("coop_ga"):
        return target
    head, _, rest = target.partition(".")
    try:
        full = obj.resolve(head)
    except Exception:  # griffe's NameResolutionError, or an alias that cannot be followed
        return target
    return f"{full}.{rest}" if rest else full


def link(obj: Any, match: re.Match[str]) -> str:
    """The autorefs element that replaces one role."""
    tilde, target = match.group(1), match.group(2).strip()
    explicit = re.fullmatch(r"(.+?)\s*<([^>]+)>", target)
    if explicit:
        text, target = explicit.group(1), explicit.group(2)
    else:
        target = target.rstrip("()")
        text = target.rsplit(".", 1)[-1] if tilde else target
    ident = html.escape(_resolve(obj, target), quote=True)
    return f'<autoref identifier="{ident}" optional>`{text}`</autoref>'


def rewrite(obj: Any) -> None:
    """Replace the roles of one object's docstring (idempotent: a rewritten docstring has none left)."""
    if obj.docstring is not None and ":" in obj.docstring.value:
        scope = obj if obj.is_module or obj.is_class else obj.parent
        obj.docstring.value = ROLE.sub(lambda m: link(scope, m), obj.docstring.value)


class SphinxRoles(griffe.Extension):
    """Rewrite the roles of every docstring once the object tree is complete."""

    def on_object(self, *, obj: Any, loader: Any, **kwargs: Any) -> None:
        rewrite(obj)

    def on_package(self, *, pkg: Any, loader: Any, **kwargs: Any) -> None:
        """The top-level package (``on_object`` is not called for it)."""
        rewrite(pkg)
