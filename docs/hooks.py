"""MkDocs hooks: the pages whose text lives elsewhere in the repository, generated at build time.

Generated here, so they cannot drift from their sources:

* ``index.md`` from the top-level ``README.md`` (the front page of both GitHub and the site);
* ``gallery.md`` from ``paper_figures/README.md`` (written by ``python -m paper_figures``);
* ``examples/index.md`` from ``examples/README.md`` and ``examples/NN_name.md`` from each ``examples/NN_*.py``
  (its docstring, then the whole script);
* every ``paper_figures/…`` file that a page links or shows (PNG, GIF, JSON, Markdown), served from where it
  is: nothing is copied into ``docs/`` (the folder holds 40+ MB; the build copies only what the pages
  show into ``site/``).

Links are written for GitHub (``docs/x.md`` in the README, ``../paper_figures/…`` in ``docs/``) and
rewritten here for the site.  ``tests/docs`` checks the page list and the links without building
(:func:`generated_pages`, :func:`site_path`).
"""

from __future__ import annotations

import ast
import posixpath
import re
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # mkdocs is imported by the build; tests/docs reads the page list without it
    from mkdocs.structure.files import Files

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
EXAMPLES = ROOT / "examples"
FIGURES = ROOT / "paper_figures"

# a Markdown link or image target: ](target) — the group stops at a space, '#' or ')'
LINK = re.compile(r"\]\(([^)\s#]+)")


def example_scripts() -> list[Path]:
    """The numbered example scripts, in order."""
    return sorted(EXAMPLES.glob("[0-9][0-9]_*.py"))


def example_page(path: Path) -> str:
    """The page of one example script: its docstring as text, how to run it, then the script itself."""
    source = path.read_text()
    doc = ast.get_docstring(ast.parse(source)) or ""
    first, _, body = doc.partition("\n")
    title, _, lead = first.strip().partition(": ")  # "Title: what it shows" → a short title and a lead
    lead = f"*{lead[0].upper()}{lead[1:]}*\n\n" if lead else ""
    body = body.replace("Run::", "Run:")
    return (
        f"# {path.stem[:2]} · {title}\n\n{lead}{body.strip()}\n\n"
        f"## The script\n\n`examples/{path.name}` (this page is generated from it). Every example takes "
        "`--out DIR`, `--fast` and `--help`, and is run by `tests/examples/test_examples.py`.\n\n"
        f"```python\n{source.rstrip()}\n```\n"
    )


def site_path(repo: str) -> str | None:
    """The site path of a repository file (``None``: not on the site)."""
    special = {
        "README.md": "index.md",
        "paper_figures/README.md": "gallery.md",
        "examples/README.md": "examples/index.md",
    }
    if repo in special:
        return special[repo]
    if repo.startswith("examples/") and repo.endswith(".py"):
        return repo[:-3] + ".md"
    if repo.startswith("docs/"):
        return repo[len("docs/") :]
    if repo.startswith("paper_figures/"):
        return repo
    return None


def repo_links(text: str, source_dir: str) -> list[str]:
    """The repository paths that the relative links of a Markdown file in ``source_dir`` point to."""
    return [
        posixpath.normpath(posixpath.join(source_dir, link))
        for link in LINK.findall(text)
        if not re.match(r"[a-z]+:", link) and not link.startswith("/")
    ]


def rewrite_links(text: str, source_dir: str, page_uri: str) -> str:
    """Rewrite the links of a Markdown file written for GitHub (in ``source_dir`` of the repository) into
    links between the site's pages, as seen from ``page_uri``.
    """

    def target(match: re.Match[str]) -> str:
        link = match.group(1)
        if re.match(r"[a-z]+:", link) or link.startswith("/"):
            return match.group(0)
        site = site_path(posixpath.normpath(posixpath.join(source_dir, link)))
        if site is None:
            return match.group(0)
        return "](" + posixpath.relpath(site, posixpath.dirname(page_uri) or ".")

    return LINK.sub(target, text)


def generated_pages() -> dict[str, tuple[str, str]]:
    """The generated pages: site path → (the repository folder its links are relative to, Markdown as written)."""
    pages = {
        "index.md": ("", (ROOT / "README.md").read_text()),
        "gallery.md": ("paper_figures", (FIGURES / "README.md").read_text()),
        "examples/index.md": ("examples", (EXAMPLES / "README.md").read_text()),
    }
    for path in example_scripts():
        pages[f"examples/{path.stem}.md"] = ("examples", example_page(path))
    return pages


def shown_figure_files(pages: dict[str, tuple[str, str]]) -> list[str]:
    """The ``paper_figures/…`` files (repository paths) that the generated pages and ``docs/*.md`` link or show."""
    texts = list(pages.values()) + [("docs", p.read_text()) for p in DOCS.glob("*.md")]
    shown = {repo for folder, text in texts for repo in repo_links(text, folder)}
    return sorted(
        repo
        for repo in shown
        if repo.startswith("paper_figures/") and repo != "paper_figures/README.md" and (ROOT / repo).is_file()
    )


def on_files(files: Files, config: Any) -> Files:
    """Add the generated pages and the ``paper_figures`` files they show."""
    from mkdocs.structure.files import File

    pages = generated_pages()
    for uri, (folder, text) in pages.items():
        files.append(File.generated(config, uri, content=rewrite_links(text, folder, uri)))
    for repo in shown_figure_files(pages):
        files.append(File.generated(config, repo, abs_src_path=str(ROOT / repo)))
    return files


def on_page_markdown(markdown: str, page: Any, config: Any, files: Files) -> str:
    """Rewrite the links of the hand-written pages of ``docs/`` (written for GitHub) for the site."""
    if page.file.generated_by is not None:
        return markdown
    folder = posixpath.join("docs", posixpath.dirname(page.file.src_uri))
    return rewrite_links(markdown, folder, page.file.src_uri)
