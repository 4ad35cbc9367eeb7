"""The README and the documentation site's sources (docs/): size and clean CommonMark, the
generated reference against the validator, every whole model shown passes `planarkin check`, and
every command marked as runnable exits as the text says.

Markers in the markdown (HTML comments, invisible on the page), on the line before a fence:

    <!-- file: NAME -->        the next block is a file the page asks the reader to save as NAME
    <!-- test: exit 0 -->      every planarkin command of the next block exits 0 (or a list,
                               `exit 0, 1`, one status per command in order); commands are the
                               lines starting with `$ ` when the block has any, else the lines
                               starting with `planarkin `
    <!-- test: python -->      the next block runs (exec) and must not raise

A page's marked blocks run in order in one temporary directory holding mechanisms/ and the
page's files, commands in process through click's CliRunner.
"""

import re
import shlex
from pathlib import Path

import pytest
from click.testing import CliRunner

from planarkin.cli import main
from planarkin.docs import (KEYS, figure, keys_table, kinds_reference, kinds_table, options_table,
                            reaction_signs)
from planarkin.elements import KINDS

try:
    import markdown_it
except ImportError:         # the test extra installs it; without it the markdown checks skip
    markdown_it = None
needs_markdown_it = pytest.mark.skipif(markdown_it is None, reason="markdown-it-py not installed")

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
PAGES = sorted(p for p in (ROOT / "docs").rglob("*.md") if "_gen" not in p.parts)
ALL = [README] + PAGES
MARK = re.compile(r"<!-- (file|test): (.*?) -->\s*$")


def _ids(paths):
    return [str(p.relative_to(ROOT)) for p in paths]


def _tokens(text):
    return markdown_it.MarkdownIt("commonmark").enable("table").parse(text)


def _blocks(path: Path):
    """(info, content, marker kind, marker value, first line) of every fenced block."""
    if markdown_it is None:
        return []
    lines = path.read_text().splitlines()
    out = []
    for tok in _tokens(path.read_text()):
        if tok.type != "fence":
            continue
        start = tok.map[0]
        before = lines[start - 1] if start > 0 else ""
        m = MARK.match(before.strip())
        out.append((tok.info.strip(), tok.content, m and m.group(1), m and m.group(2), start))
    return out


# -- the README -------------------------------------------------------------------------------
def test_readme_is_at_most_20_kb():
    assert len(README.read_bytes()) <= 20_000


@needs_markdown_it
@pytest.mark.parametrize("path", ALL, ids=_ids(ALL))
def test_markdown_has_no_raw_table_text_and_no_unclosed_fence(path):
    text = path.read_text()
    lines = text.splitlines()
    covered = set()
    for tok in _tokens(text):
        if tok.map and tok.type in ("table_open", "fence", "code_block", "html_block"):
            covered.update(range(*tok.map))
        if tok.type == "fence":
            last = lines[tok.map[1] - 1].strip()
            assert tok.map[1] - tok.map[0] >= 2 and last.startswith(tok.markup) and \
                last.strip("`~") == "", f"{path.name}:{tok.map[0] + 1}: unclosed fence"
            # a fence line with text after it (```` ``` text ````) does not close the block: the
            # prose after it becomes code, and the next fence closes it instead
            inner = [line for line in tok.content.splitlines() if line.startswith(tok.markup)]
            assert not inner, f"{path.name}:{tok.map[0] + 1}: a fence does not close: {inner[0]!r}"
    raw = [n + 1 for n, line in enumerate(lines) if line.startswith("|") and n not in covered]
    assert not raw, f"{path.name}: lines {raw} start with | outside a table"


def test_quick_start_has_the_two_commands():
    text = README.read_text()
    block = text.split("## Quick start", 1)[1].split("```sh", 1)[1].split("```", 1)[0]
    lines = [line for line in block.strip().splitlines() if line.strip()]
    assert lines == ["python -m pip install -e . && planarkin run mechanisms/slider-crank.yaml",
                     "python -m pip install -e '.[test]' && python -m pytest -q -n auto"]
    # CI runs the README's test command (pytest-xdist's workers: one per core)
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    assert lines[1].split(" && ")[1] in ci


def test_readme_mentions_existing_examples():
    for name in re.findall(r"`([\w-]+\.yaml)`", README.read_text()):
        assert (ROOT / "mechanisms" / name).exists(), name


def test_readme_links_point_to_existing_files():
    for target in re.findall(r"\]\(([^)#:]+)(?:#[^)]*)?\)", README.read_text()):
        assert (ROOT / target).exists(), target


@pytest.mark.slow
def test_readme_figure_is_what_the_code_draws(tmp_path):
    """docs/images/four-bar.png is regenerable: `python -m planarkin.docs --figure`."""
    import numpy as np
    from matplotlib.image import imread
    figure(tmp_path / "new.png", root=ROOT)
    old, new = imread(ROOT / "docs/images/four-bar.png"), imread(tmp_path / "new.png")
    assert old.shape == new.shape, "run: python -m planarkin.docs --figure"
    assert np.mean(np.abs(old - new) > 0.1) < 0.002, "run: python -m planarkin.docs --figure"


# -- the generated reference ------------------------------------------------------------------
def _valid_keys(section_text: str) -> set[str]:
    """The keys the validator accepts in a section, read from its message for an unknown key."""
    from planarkin import InputError, load
    base = ("bodies:\n  b: {q: [0, 0, 0]}\njoints:\n  - {type: revolute, i: ground, j: b, "
            "si: [0, 0], sj: [0, 0]}\ndrivers:\n  - {type: angle, body: b, f: t}\n")
    with pytest.raises(InputError) as e:
        load("m.yaml", text=base + section_text)
    m = re.search(r"valid keys: ([^)]*)\)", str(e.value))
    assert m, str(e.value)
    return set(m.group(1).split(", "))


@pytest.mark.parametrize("section", ["", "units", "analysis", "output", "assembly"])
def test_keys_reference_lists_exactly_the_keys_the_validator_accepts(section):
    text = "zzzzzzzz: 1\n" if not section else f"{section}: {{zzzzzzzz: 1}}\n"
    valid = _valid_keys(text)
    if not section:
        documented = {k for k in KEYS if "." not in k and "[" not in k}
    else:
        documented = {k.split(".", 1)[1] for k in KEYS if k.startswith(section + ".")}
    if section == "analysis":
        documented = {line.split("`")[1].split(".", 1)[1] for line in keys_table().splitlines()
                      if line.startswith("| `analysis.")}
    assert documented == valid


def test_keys_reference_names_the_body_and_load_keys():
    from planarkin.forces.keys import BODY_KEYS, LOAD_KEYS
    table = keys_table()
    assert all(f".{k}" in table for k in BODY_KEYS)
    for kind, keys in LOAD_KEYS.items():
        row = next(line for line in table.splitlines() if f"`{kind}` |" in line)
        assert all(k in row for k in keys), kind


def test_kinds_reference_covers_every_kind_with_its_keys_and_reaction():
    table, ref = kinds_table(), kinds_reference()
    for name, kind in KINDS.items():
        assert f"[`{name}`](#kind-{name})" in table
        section = ref.split(f"{{#kind-{name}}}", 1)[1].split("{#kind-", 1)[0]
        for p in kind.params:
            assert f"| `{p.name}` |" in section, (name, p.name)
        # the sign convention is the kind's own (no hand-written notes to drift)
        sign = kind.reaction_sign.replace("<", "&lt;")
        assert f"- reactions in forces.csv: {sign}" in section, name
        assert f"| `{name}` | {sign.replace('|', chr(92) + '|')} |" in reaction_signs(), name


def test_generated_tables_have_no_stray_markers():
    for text in (keys_table(), kinds_table(), kinds_reference(), options_table()):
        assert "<!-- planarkin:" not in text


def test_reference_pages_ask_for_generators_that_exist():
    import runpy
    hooks = runpy.run_path(str(ROOT / "docs/_gen/hooks.py"))
    for page in PAGES:
        for name in re.findall(r"^<!-- planarkin: ([\w-]+) -->$", page.read_text(), re.M):
            assert name in hooks["GENERATORS"], (page.name, name)


# -- the examples in the text -----------------------------------------------------------------
def _workdir(tmp_path: Path) -> Path:
    (tmp_path / "mechanisms").symlink_to(ROOT / "mechanisms")
    return tmp_path


WHOLE = [(p, start, content) for p in ALL for info, content, kind, _, start in _blocks(p)
         if info == "yaml" and re.search(r"^(bodies|links):", content, re.M)]


@pytest.mark.parametrize("path,start,content", WHOLE,
                         ids=[f"{p.relative_to(ROOT)}:{s + 1}" for p, s, _ in WHOLE])
def test_every_whole_model_shown_passes_check(path, start, content, tmp_path, monkeypatch):
    monkeypatch.chdir(_workdir(tmp_path))
    Path("shown.yaml").write_text(content)
    r = CliRunner().invoke(main, ["check", "shown.yaml"])
    assert r.exit_code == 0, f"{path.name}:{start + 1}:\n{r.output}"


def _commands(content: str) -> list[list[str]]:
    text = content.replace("\\\n", " ")
    lines = text.splitlines()
    if any(line.startswith("$ ") for line in lines):
        lines = [line[2:] for line in lines if line.startswith("$ ")]
    return [shlex.split(line, comments=True)[1:] for line in lines
            if line.startswith("planarkin ")]


RUNNABLE = [p for p in ALL if any(kind == "test" for _, _, kind, _, _ in _blocks(p))]


@needs_markdown_it
def test_the_marked_pages_are_the_ones_expected():
    names = {p.stem for p in RUNNABLE}
    assert {"README", "first-mechanism", "studies", "ci-gate", "measures"} <= names


@pytest.mark.parametrize("path", [pytest.param(p, marks=pytest.mark.slow) if p.stem == "studies"
                                  else p for p in RUNNABLE], ids=_ids(RUNNABLE))
def test_every_marked_command_exits_as_the_text_says(path, tmp_path, monkeypatch):
    monkeypatch.chdir(_workdir(tmp_path))
    for info, content, kind, value, start in _blocks(path):
        where = f"{path.name}:{start + 1}"
        if kind == "file":
            Path(value).write_text(content)
        elif kind == "test" and value == "python":
            exec(compile(content, where, "exec"), {"__name__": "__docs__"})
        elif kind == "test":
            m = re.fullmatch(r"exit ([\d, ]+)", value)
            assert m, f"{where}: unknown marker {value!r}"
            codes = [int(c) for c in m.group(1).split(",")]
            commands = _commands(content)
            codes = codes * len(commands) if len(codes) == 1 else codes
            assert len(commands) == len(codes), f"{where}: {len(commands)} commands"
            for args, code in zip(commands, codes):
                r = CliRunner().invoke(main, args)
                assert r.exit_code == code, f"{where}: planarkin {shlex.join(args)}:\n{r.output}"


def test_the_site_configuration_lists_every_hand_written_page():
    nav = (ROOT / "mkdocs.yml").read_text()
    for page in PAGES:
        rel = page.relative_to(ROOT / "docs").as_posix()
        assert rel in nav, f"{rel} is not in mkdocs.yml's nav"
