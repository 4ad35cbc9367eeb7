"""The README and the documentation site's sources (docs/): size and clean CommonMark, the
generated reference against the validator, every whole model shown passes `planarkin check`,
every command marked as runnable exits as the text says, and every figure a page marks is what
its example writes.

Markers in the markdown (HTML comments, invisible on the page), on the line before a fence:

    <!-- file: NAME -->        the next block is a file the page asks the reader to save as NAME
    <!-- test: exit 0 -->      every planarkin command of the next block exits 0 (or a list,
                               `exit 0, 1`, one status per command in order); commands are the
                               lines starting with `$ ` when the block has any, else the lines
                               starting with `planarkin `
    <!-- test: python -->      the next block runs (exec) and must not raise

and on the line before an image:

    <!-- figure: PATH -->      the image is the file PATH written by the blocks above it

A page's marked blocks run in order in one temporary directory holding mechanisms/ and the
page's files, commands in process (clitools.run_cli), by planarkin.docs.replay: the same code
that writes the figures (`python -m planarkin.docs --figure`).

The how-to guides open with their example: a whole model saved as a file, run by the page, and
the figure the run writes, before any prose.
"""

import re
from pathlib import Path

import pytest
from click.testing import CliRunner
from clitools import run_cli

from planarkin.cli import main
from planarkin.docs import (KEYS, figure, keys_table, kinds_reference, kinds_table, options_table,
                            page_blocks, reaction_signs, replay)
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


def test_keys_reference_lists_every_design_key_with_its_default():
    """design: its sections, the search's settings (each with the default spec.SEARCH gives:
    local's follows probe), targets' and constraints' keys: what synthesis/spec.py accepts."""
    from planarkin.synthesis.spec import CONSTRAINT_KEYS, INPUT_KEYS, KEYS as DESIGN, SEARCH
    from planarkin.synthesis.spec import TARGET_KEYS, TURNS_KEYS
    assert {k.split(".")[1].removesuffix("[]") for k in KEYS if k.startswith("design.")} == \
        set(DESIGN)
    search = {k.split(".")[2]: doc for k, doc in KEYS.items() if k.startswith("design.search.")}
    assert set(search) == set(SEARCH)
    for key, (_, _, _, default) in SEARCH.items():
        if default is not None:
            assert f"default {default:g}" in search[key], key
    targets = KEYS["design.targets"] + KEYS["design.targets[].inputs"]
    for key in {k for keys in TARGET_KEYS.values() for k in keys} | set(INPUT_KEYS):
        assert key in targets, key
    for key in (*CONSTRAINT_KEYS, *TURNS_KEYS):
        assert key in KEYS["design.constraints"], key


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
    for _, other, kind, name, _ in _blocks(path):      # the files it may read (a table)
        if kind == "file":
            Path(name).write_text(other)
    Path("shown.yaml").write_text(content)
    r = CliRunner().invoke(main, ["check", "shown.yaml"])
    assert r.exit_code == 0, f"{path.name}:{start + 1}:\n{r.output}"


RUNNABLE = [p for p in ALL if any(kind == "test" for _, _, kind, _, _ in _blocks(p))]


@needs_markdown_it
def test_the_marked_pages_are_the_ones_expected():
    names = {p.stem for p in RUNNABLE}
    assert {"README", "first-mechanism", "studies", "ci-gate", "measures"} <= names
    assert {p.stem for p in HOW_TO} <= names


@needs_markdown_it
@pytest.mark.parametrize("path", ALL, ids=_ids(ALL))
def test_replay_reads_the_blocks_markdown_reads(path):
    """planarkin.docs.page_blocks (what replay runs) finds the fenced blocks CommonMark finds."""
    ours = [(b.info, b.content, b.kind, b.value, b.line)
            for b in page_blocks(path.read_text()) if b.kind != "figure"]
    assert ours == _blocks(path)


def _run(args):
    r = run_cli(*args, cwd=Path.cwd())
    return r.returncode, r.stdout + r.stderr


def _same_image(made: Path, image: Path, where: str):
    import numpy as np
    from matplotlib.image import imread
    assert image.is_file(), f"{where}: {image.name} is missing: python -m planarkin.docs --figure"
    old, new = imread(image), imread(made)
    assert old.shape == new.shape, f"{where}: run python -m planarkin.docs --figure"
    assert np.mean(np.abs(old - new) > 0.1) < 0.002, f"{where}: run python -m planarkin.docs " \
                                                     f"--figure"


@pytest.mark.parametrize("path", [pytest.param(p, marks=pytest.mark.slow) if p.stem == "studies"
                                  else p for p in RUNNABLE], ids=_ids(RUNNABLE))
def test_every_marked_command_exits_as_the_text_says(path, tmp_path):
    """...and every figure the page marks is the checked-in image."""
    replay(path, _workdir(tmp_path), run=_run, figure=_same_image)


# -- the how-to guides: their examples first ---------------------------------------------------
HOW_TO = [p for p in PAGES if p.parent.name == "how-to"]


@pytest.mark.parametrize("path", HOW_TO, ids=_ids(HOW_TO))
def test_a_how_to_opens_with_its_example_and_figure(path):
    """Under the title, at most a sentence, then a whole model saved as a file; its run's figure
    comes before the next heading and before any block that is not the example's."""
    text = path.read_text()
    lines = text.splitlines()
    blocks = page_blocks(text)
    first = blocks[0]
    assert first.kind == "file" and first.info == "yaml", \
        f"{path.name}: the first block is not a model saved as a file"
    assert re.search(r"^(bodies|links):", first.content, re.M), f"{path.name}: not a whole model"
    lead = [line for line in lines[1:first.line - 1] if line.strip()]
    assert len(lead) <= 3, f"{path.name}: {len(lead)} lines of prose before the example"
    fig = next((b for b in blocks if b.kind == "figure"), None)
    assert fig is not None, f"{path.name}: no figure"
    fenced = {n for b in blocks if b.kind != "figure"
              for n in range(b.line, b.line + b.content.count("\n") + 2)}
    headings = [n for n in range(first.line, fig.line)
                if lines[n].startswith("#") and n not in fenced]
    assert not headings, f"{path.name}: a heading between the example and its figure"
    assert fig.content.startswith("../images/"), fig.content
    for b in blocks:
        if b.line > fig.line:
            break
        assert b.kind in ("file", "test", "figure"), f"{path.name}:{b.line + 1}: unmarked block"


# benchmark logs (load averages, clock times, dates) and team notes belong to the Performance
# page and benchmarks/README.md, not to a user's guide
NOTES = re.compile(r"\bload( average)? (of )?\d|\bUTC\b|\b20\d\d-\d\d-\d\d\b"
                   r"|\b\d{1,2} [a-z]{3,9} 20\d\d\b|\bissue \d|\bteam notes?\b"
                   r"|\banother branch\b|\bsession\b", re.I)


@pytest.mark.parametrize("path", HOW_TO, ids=_ids(HOW_TO))
def test_a_how_to_holds_no_benchmark_log_or_team_notes(path):
    found = [f"{path.name}:{n}: {m.group()!r}"
             for n, line in enumerate(path.read_text().splitlines(), 1)
             for m in [NOTES.search(line)] if m]
    assert not found, "; ".join(found)


@pytest.mark.parametrize("path", HOW_TO, ids=_ids(HOW_TO))
def test_every_yaml_block_of_a_how_to_is_a_model_the_page_runs(path):
    """Each YAML block is a whole model saved as a file that a marked command (or Python block)
    of the page uses: test_every_marked_command_exits_as_the_text_says loads and runs it."""
    blocks = page_blocks(path.read_text())
    used = " ".join(b.content for b in blocks if b.kind == "test")
    for b in blocks:
        if b.info != "yaml":
            continue
        where = f"{path.name}:{b.line + 1}"
        assert b.kind == "file", f"{where}: a YAML block that is not a file of the example"
        assert re.search(r"^(bodies|links):", b.content, re.M), f"{where}: not a whole model"
        assert re.search(rf"(?<![\w./-]){re.escape(b.value)}(?![\w-])", used), \
            f"{where}: no marked command runs {b.value}"


def test_the_site_configuration_lists_every_hand_written_page():
    nav = (ROOT / "mkdocs.yml").read_text()
    for page in PAGES:
        rel = page.relative_to(ROOT / "docs").as_posix()
        assert rel in nav, f"{rel} is not in mkdocs.yml's nav"
