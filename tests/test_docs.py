"""The documentation site builds with every warning an error (mkdocs.yml): every page,
notebook, chart and relative link between them found, every public docstring parsed. The
user guide's pages (docs/guide/): every link into them lands on a page and a heading there,
the contents and the site's nav list every page, and each page's examples stand alone."""

import builtins
import os
import re
import subprocess
import symtable
import sys
from pathlib import Path

from markdown.extensions.toc import slugify  # the anchors mkdocs' toc extension gives

ROOT = Path(__file__).resolve().parents[1]
GUIDE = ROOT / "docs" / "guide"
#: the site's markdown pages, which link into the guide
LINKING = ("README.md", "docs/**/*.md", "benchmarks/*.md", "benchmarks/archive/README.md")
_FENCED = re.compile(r"^```.*?^```", re.S | re.M)
_LINK = re.compile(r"\]\(([^()\s]+)\)")
_HEADING = re.compile(r"^#{1,6}\s+(.+?)\s*$", re.M)


def test_the_site_builds_strictly(tmp_path):
    env = dict(os.environ, NO_MKDOCS_2_WARNING="1")
    out = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path)],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert out.returncode == 0, out.stderr[-4000:]
    api = (tmp_path / "docs" / "api.html").read_text()
    for name in ("jaxchain.simulate", "jaxchain.scenes.drive", "jaxchain.contact.OilFilm"):
        assert f'id="{name}"' in api, name  # the reference documents the public API
    assert ":class:<code>" not in api and ":meth:<code>" not in api  # roles shown as code
    assert (tmp_path / "notebooks" / "01_drive_walkthrough.html").exists()
    assert (tmp_path / "benchmarks" / "results" / "engagement.gif").exists()
    guide = tmp_path / "docs" / "guide"
    assert (guide / "loads.html").exists()
    index = (guide / "index.html").read_text()
    contents = index[index.index("<article") : index.index("</article>")]  # not the nav
    for page in guide_pages():
        assert (guide / f"{page.stem}.html").exists(), page.name
        assert f'href="{page.stem}.html"' in contents, page.name  # the contents link it


def guide_pages() -> list[Path]:
    """The guide's pages but its contents (index.md)."""
    return [page for page in sorted(GUIDE.glob("*.md")) if page.name != "index.md"]


def anchors(page: Path) -> set[str]:
    """The anchors of ``page``'s headings, as the site gives them (code blocks' comments
    are no headings)."""
    return {slugify(h, "-") for h in _HEADING.findall(_FENCED.sub("", page.read_text()))}


def test_links_into_the_guide_land_on_a_page_and_heading():
    """Every relative link from README.md, docs/ and the studies' pages into the user guide
    (docs/guide/, or the former docs/guide.md) names a page that exists and, with an anchor,
    a heading of that page: a page renamed or a heading reworded fails here, without a
    site build (mkdocs.yml reports missing anchors only as info)."""
    checked, broken = 0, []
    for source in sorted({p for pattern in LINKING for p in ROOT.glob(pattern)}):
        for target in _LINK.findall(_FENCED.sub("", source.read_text())):
            if "://" in target or target.startswith("mailto:"):
                continue
            path, _, anchor = target.partition("#")
            page = (source.parent / path).resolve() if path else source
            if not page.relative_to(ROOT).as_posix().startswith("docs/guide"):
                continue
            checked += 1
            where = f"{source.relative_to(ROOT)}: ]({target})"
            if not page.is_file():
                broken.append(f"{where}: no such page")
            elif anchor and anchor not in anchors(page):
                broken.append(f"{where}: no heading with that anchor on {page.name}")
    assert checked >= 30, checked  # README's links and the contents' at least
    assert not broken, "\n".join(broken)


def test_the_contents_and_the_nav_list_every_guide_page():
    """docs/guide/index.md links every page of the guide and mkdocs.yml's nav lists them,
    the contents first."""
    contents = _LINK.findall((GUIDE / "index.md").read_text())
    nav = (ROOT / "mkdocs.yml").read_text()
    assert "docs/guide/index.md" in nav
    for page in guide_pages():
        assert page.name in contents, page.name
        assert f"docs/guide/{page.name}" in nav, page.name
        assert nav.index("docs/guide/index.md") < nav.index(f"docs/guide/{page.name}")
    assert not (ROOT / "docs" / "guide.md").exists()  # the guide is its pages, once


def test_every_study_has_a_short_section_and_its_notes():
    """benchmarks/README.md is the studies' index: every study (each script under benchmarks/
    with a main, and the main job's committed runs) has a short section there under its own
    name, which links its notes, benchmarks/<name>.md beside the script; the notes start with
    the study's name and the site's nav lists them."""
    benchmarks = ROOT / "benchmarks"
    readme = (benchmarks / "README.md").read_text()
    sections = dict(re.findall(r"^## (\S+)\n(.*?)(?=^## |\Z)", readme, re.S | re.M))
    sections.pop("Index")
    scripts = {p.stem for p in benchmarks.glob("*.py") if "__main__" in p.read_text()}
    assert scripts <= set(sections), sorted(scripts - set(sections))
    nav = (ROOT / "mkdocs.yml").read_text()
    for name, body in sections.items():
        notes = benchmarks / f"{name}.md"
        assert notes.is_file(), name
        text = notes.read_text()
        assert text.startswith(f"# {name}\n") and len(text) > 500, name
        assert f"]({name}.md)" in body, name
        assert len(body.strip().splitlines()) <= 6, name  # short: the notes hold the rest
        assert f"benchmarks/{name}.md" in nav, name


def undefined_names(code: str) -> set[str]:
    """Names ``code`` reads that it never binds (nor Python does)."""
    top = symtable.symtable(code, "<example>", "exec")
    bound = {s.get_name() for s in top.get_symbols() if s.is_assigned() or s.is_imported()}
    bound |= set(dir(builtins))
    missing, tables = set(), [top]
    while tables:
        table = tables.pop()
        tables.extend(table.get_children())
        for s in table.get_symbols():
            global_ = table is top or s.is_global()
            if s.is_referenced() and global_ and not s.is_assigned() and not s.is_parameter():
                missing.add(s.get_name())
    return missing - bound


def test_each_guide_page_s_examples_stand_alone():
    """Each page's Python examples, read in order, bind every name they use (their imports,
    the chain, the tooth period...): an example copied from one page does not lean on
    another's."""
    for page in guide_pages():
        code = "\n\n".join(re.findall(r"^```python\n(.*?)^```", page.read_text(), re.S | re.M))
        assert not undefined_names(code), (page.name, sorted(undefined_names(code)))
