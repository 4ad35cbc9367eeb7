"""Every pointer a reader may follow leads somewhere: the relative links and images of the README
and of the documentation's pages (docs/) name files that exist, and their `#anchors` headings of
those pages; the comments of the example models (mechanisms/) that send the reader to a page of
the documentation, or to a section of the README or of a page, name ones that exist.

A page's headings are read as mkdocs reads them (its toc extension: an explicit `{#id}`, else the
heading's text made a slug), with the generated reference tables put in (docs/_gen/hooks.py).
The gallery (docs/gallery/) is generated at build time from mechanisms/: a link to a model's
page or figure there is good when the model exists."""

import re
import runpy
import unicodedata
from functools import cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
README = ROOT / "README.md"
PAGES = sorted(p for p in DOCS.rglob("*.md") if "_gen" not in p.parts)
MODELS = sorted((ROOT / "mechanisms").rglob("*.yaml"))
# the figures a run may write, each a page section of the gallery (docs/_gen/gallery.py)
GALLERY_FIGURES = {"mechanism", "trajectories", "bodies", "points", "forces", "measures",
                   "centres"}

_FENCE = re.compile(r"^\s*(`{3,}|~{3,})")
_LINK = re.compile(r"!?\[(?:[^\]\[]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
_HEADING = re.compile(r"^(#{1,6})\s+(.*?)\s*#*\s*$")


def _ids(paths):
    return [str(p.relative_to(ROOT)) for p in paths]


def _prose(text: str, blank_code: bool = True) -> list[tuple[int, str]]:
    """(line number, line) of the lines outside fenced and indented code, with code spans
    blanked (blank_code)."""
    out, fence = [], None
    for n, line in enumerate(text.splitlines(), 1):
        m = _FENCE.match(line)
        if fence is None and m:
            fence = m.group(1)[0] * len(m.group(1))
            continue
        if fence is not None:
            if line.strip().startswith(fence) and not line.strip().strip(fence[0]):
                fence = None
            continue
        if line.startswith("    ") and not line.strip().startswith(("-", "*", "|")) and \
                (not out or not out[-1][1].strip()):
            continue                        # an indented code block
        out.append((n, re.sub(r"`[^`]*`", lambda m: " " * len(m.group()), line) if blank_code
                    else line))
    return out


def _links(path: Path) -> list[tuple[int, str]]:
    """(line, target) of every inline link and image of a markdown file (a link may span two
    lines: its text is joined with the next line's)."""
    lines = _prose(path.read_text())
    out = []
    for k, (n, line) in enumerate(lines):
        joined = line + (" " + lines[k + 1][1] if k + 1 < len(lines) else "")
        for m in _LINK.finditer(joined):
            if m.start() < len(line):
                out.append((n, m.group(1)))
    return out


def slug(text: str) -> str:
    """The id mkdocs (Python-Markdown's toc) gives a heading: its text without markup, ASCII,
    lower case, anything but letters, digits, _, - and spaces dropped, spaces made -."""
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", text)           # a link: its text
    text = re.sub(r"<[^>]+>", "", text).replace("`", "")
    text = unicodedata.normalize("NFKD", text).encode("ascii", "ignore").decode("ascii")
    text = re.sub(r"[^\w\s-]", "", text).strip().lower()
    return re.sub(r"[-\s]+", "-", text)


def heading_text(raw: str) -> str:
    """A heading as the reader sees it: without `{#id}`, code marks and surrounding space."""
    return " ".join(re.sub(r"\s*\{#[^}]*\}\s*$", "", raw).replace("`", "").split())


@cache
def _generated() -> dict:
    return runpy.run_path(str(DOCS / "_gen" / "hooks.py"))["GENERATORS"]


@cache
def headings(path: Path) -> tuple[set[str], set[str]]:
    """(ids, texts) of a page's headings, the generated tables put in as the site has them."""
    text = path.read_text()
    gens = _generated()
    text = re.sub(r"^<!-- planarkin: ([\w-]+) -->$", lambda m: gens[m.group(1)](), text,
                  flags=re.M)
    ids, texts = set(), set()
    for _, line in _prose(text, blank_code=False):
        m = _HEADING.match(line)
        if not m:
            continue
        raw = m.group(2)
        explicit = re.search(r"\{#([^}\s]+)\}\s*$", raw)
        ids.add(explicit.group(1) if explicit else slug(re.sub(r"\s*\{[^}]*\}\s*$", "", raw)))
        texts.add(heading_text(raw))
    return ids, texts


def _plugin_page(path: Path) -> bool:
    """A page whose headings a plugin writes at build time (mkdocstrings, mkdocs-click: `:::`
    lines); `mkdocs build --strict` checks the anchors into it."""
    return any(line.startswith("::: ") for line in path.read_text().splitlines())


def _gallery_target_exists(rel: Path) -> bool:
    """docs/gallery/...: generated from mechanisms/ when the site is built."""
    parts = rel.parts
    if parts == ("index.md",):
        return True
    if len(parts) == 1 and rel.suffix == ".md":
        return (ROOT / "mechanisms" / f"{rel.stem}.yaml").is_file()
    if len(parts) == 2 and rel.suffix == ".png":
        return (ROOT / "mechanisms" / f"{parts[0]}.yaml").is_file() and \
            rel.stem in GALLERY_FIGURES
    return False


def resolve(source: Path, target: str) -> tuple[Path | None, str | None, str | None]:
    """(file, anchor, problem) of a relative link from source; file None for a generated one."""
    path, _, anchor = target.partition("#")
    if not path:
        return source, anchor or None, None
    dest = (source.parent / path).resolve()
    try:
        gallery = dest.relative_to(DOCS / "gallery")
    except ValueError:
        gallery = None
    if gallery is not None:
        ok = _gallery_target_exists(gallery)
        return None, None, None if ok else f"{target}: no such model or figure in the gallery"
    if not dest.exists():
        return None, None, f"{target}: no such file"
    return dest, anchor or None, None


def _external(target: str) -> bool:
    return bool(re.match(r"^[a-z][a-z0-9+.-]*:", target, re.I))


@pytest.mark.parametrize("path", [README] + PAGES, ids=_ids([README] + PAGES))
def test_every_relative_link_leads_to_a_file_and_a_heading(path):
    problems = []
    for n, target in _links(path):
        if _external(target):
            continue
        dest, anchor, problem = resolve(path, target)
        if problem:
            problems.append(f"{path.name}:{n}: {problem}")
        elif anchor and dest.suffix == ".md" and anchor not in headings(dest)[0] and \
                not _plugin_page(dest):
            problems.append(f"{path.name}:{n}: {target}: no heading #{anchor} in {dest.name}")
        elif dest is not None and path.is_relative_to(DOCS) and not dest.is_relative_to(DOCS):
            problems.append(f"{path.name}:{n}: {target}: outside docs/, not on the site")
    assert not problems, "\n".join(problems)


# -- the comments of the example models ------------------------------------------------------
def comments(path: Path) -> list[tuple[int, str]]:
    """(first line, text) of each comment of a model: a run of whole-line comments joined into
    one text, and each comment after a value on its own."""
    out, run = [], None
    for n, line in enumerate(path.read_text().splitlines(), 1):
        stripped = line.strip()
        if stripped.startswith("#"):
            text = stripped.lstrip("#").strip()
            if run is None:
                run = [n, text]
            else:
                run[1] += " " + text
            continue
        if run is not None:
            out.append(tuple(run))
            run = None
        m = re.search(r"\s#\s?(.*)$", line)
        if m and not re.search(r"[\"'][^\"']*#", line[:m.start() + 1]):
            out.append((n, m.group(1).strip()))
    if run is not None:
        out.append(tuple(run))
    return out


# a docs page, a README, a bare page name; then an optional #anchor and an optional section
_POINTER = re.compile(r"(?P<file>(?:docs/[\w./-]+\.md|README(?:\.md)?|\b[\w-]+\.md))"
                      r"(?:#(?P<anchor>[\w-]+))?"
                      r"(?:,?\s*(?:section\s+|under\s+)?\"(?P<section>[^\"]+)\")?")


def pointers(text: str) -> list[tuple[str, str | None, str | None]]:
    return [(m.group("file"), m.group("anchor"), m.group("section"))
            for m in _POINTER.finditer(text)]


def pointer_problem(model: Path, name: str, anchor: str | None, section: str | None):
    """What is wrong with a comment's pointer, or None."""
    if name.startswith("README"):
        page = README
    elif "/" in name:
        page = ROOT / name
    else:
        found = [p for p in [README] + PAGES if p.name == name]
        if not found:
            return f"{name}: no such page"
        page = found[0]
    if not page.is_file():
        return f"{name}: no such page"
    ids, texts = headings(page)
    if anchor and anchor not in ids:
        return f"{name}#{anchor}: no such heading in {page.name}"
    if section and heading_text(section) not in texts:
        return f"{name}, \"{section}\": no such section in {page.name} (its sections: " \
               f"{'; '.join(sorted(texts))})"
    return None


@pytest.mark.parametrize("model", MODELS, ids=_ids(MODELS))
def test_every_pointer_in_a_models_comments_leads_to_a_page_and_a_section(model):
    problems = []
    for n, text in comments(model):
        for name, anchor, section in pointers(text):
            problem = pointer_problem(model, name, anchor, section)
            if problem:
                problems.append(f"{model.name}:{n}: {problem}")
        # a model named in a comment is one of the examples
        for other in re.findall(r"(?<![\w/.-])([\w-]+\.yaml)\b", text):
            if not any((d / other).is_file() for d in (model.parent, ROOT / "mechanisms")):
                problems.append(f"{model.name}:{n}: {other}: no such model in mechanisms/")
    assert not problems, "\n".join(problems)


# -- the checks themselves --------------------------------------------------------------------
def test_slugs_are_the_ones_mkdocs_makes():
    assert slug("A pin on a curve: `curve-slot`") == "a-pin-on-a-curve-curve-slot"
    assert slug("Tabulated motion (`table:`)") == "tabulated-motion-table"
    assert slug("Gears, racks and their bearings") == "gears-racks-and-their-bearings"


def test_a_pointer_to_a_missing_section_or_page_is_caught(tmp_path):
    model = tmp_path / "m.yaml"
    model.write_text('# see the README, "Motion profiles"\n'
                     '# see docs/how-to/motion.md, "Motion profiles (motion:)"\n'
                     "# see docs/how-to/nothing.md and docs/how-to/cams.md#nowhere\n"
                     "name: m  # as four-bar.yaml and nothing-here.yaml\n")
    found = [(name, anchor, section) for _, text in comments(model)
             for name, anchor, section in pointers(text)]
    problems = [pointer_problem(model, *p) for p in found]
    assert [p is None for p in problems] == [False, True, False, False]
    assert 'README, "Motion profiles": no such section' in problems[0]
    assert "cams.md#nowhere: no such heading" in problems[3]


def test_a_broken_link_is_caught(tmp_path):
    assert resolve(DOCS / "how-to" / "cams.md", "../gallery/valve-cam.md")[2] is None
    assert resolve(DOCS / "how-to" / "cams.md", "../gallery/no-such-model.md")[2]
    assert resolve(DOCS / "how-to" / "cams.md", "motion.md")[2] is None
    assert resolve(DOCS / "how-to" / "cams.md", "no-such-page.md")[2]
    assert "tabulated-motion-table" in headings(DOCS / "how-to" / "motion.md")[0]
    assert "kind-cam" in headings(DOCS / "reference" / "kinds.md")[0]
