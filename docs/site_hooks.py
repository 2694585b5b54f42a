"""mkdocs hook: the site's pages are the repository's own files at their own paths —
README.md as the home page (index.md), docs/*.md, the user guide's pages (docs/guide/*.md),
the studies' README and notes (benchmarks/*.md) with the charts and movies they show, the
executed notebooks — and an API reference generated from the docstrings (docs/api.md), so a
relative link between them works on the site as in the repository."""

from __future__ import annotations

import re
from pathlib import Path

from mkdocs.plugins import event_priority
from mkdocs.structure.files import File, Files

ROOT = Path(__file__).resolve().parents[1]
#: the public modules, in the order the API reference shows them
MODULES = (
    "jaxchain",
    "jaxchain.scenes",
    "jaxchain.contact",
    "jaxchain.elements",
    "jaxchain.loads",
    "jaxchain.observers",
    "jaxchain.design",
    "jaxchain.distributed",
)


def _pages() -> dict[str, Path]:
    """Site path → repository file."""
    pages = {"index.md": ROOT / "README.md"}
    for pattern in (
        "docs/*.md",
        "docs/guide/*.md",
        "benchmarks/*.md",
        "benchmarks/archive/README.md",
        "notebooks/*.ipynb",
        "benchmarks/results/**/*.png",
        "benchmarks/results/**/*.gif",
        "benchmarks/archive/results/**/*.png",
    ):
        for path in sorted(ROOT.glob(pattern)):
            pages[path.relative_to(ROOT).as_posix()] = path
    return pages


def api_page() -> str:
    """The API reference: every public module's docstring and members."""
    parts = ["# API reference\n"]
    for name in MODULES:
        parts.append(f"::: {name}\n    options:\n      show_submodules: false\n")
    return "\n".join(parts)


@event_priority(100)  # before the plugins': mkdocs-jupyter renders the notebooks added here
def on_files(files: Files, config) -> Files:
    for uri, path in _pages().items():
        if files.get_file_from_path(uri) is not None:
            continue
        if uri == path.relative_to(ROOT).as_posix():  # at its own path: an ordinary file
            files.append(File(uri, str(ROOT), config["site_dir"], config["use_directory_urls"]))
        else:
            files.append(File.generated(config, uri, abs_src_path=str(path)))
    files.append(File.generated(config, "docs/api.md", content=api_page()))
    return files


# the docstrings' Sphinx roles (:class:`~jaxchain.Solution`, :meth:`iso606`,
# :class:`jc.elements.CushionRing <jaxchain.elements.CushionRing>`) as plain code: the
# shown name, the last dotted part after a "~"
_ROLE = re.compile(
    r":(?:class|func|meth|attr|mod|data|obj|exc):<code>(~?)([^<]*?)(?: &lt;[^<]*&gt;)?</code>"
)


def _shown(match: re.Match) -> str:
    name = match.group(2)
    return f"<code>{name.rsplit('.', 1)[-1] if match.group(1) else name}</code>"


def on_page_content(html: str, page, config, files) -> str:
    return _ROLE.sub(_shown, html)
