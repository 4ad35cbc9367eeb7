"""The README's kinds table is generated from the registry; the examples it names exist."""

import re
from pathlib import Path

from planarkin.docs import BEGIN, END, OPTIONS_BEGIN, OPTIONS_END, kinds_table, options_table

ROOT = Path(__file__).resolve().parent.parent


def test_readme_kinds_table_is_current():
    text = (ROOT / "README.md").read_text()
    a, b = text.index(BEGIN), text.index(END) + len(END)
    assert text[a:b] == kinds_table(), "run: python -m planarkin.docs and paste into README.md"


def test_readme_options_table_is_current():
    text = (ROOT / "README.md").read_text()
    a, b = text.index(OPTIONS_BEGIN), text.index(OPTIONS_END) + len(OPTIONS_END)
    assert text[a:b] == options_table(), "run: python -m planarkin.docs and paste into README.md"


def test_readme_mentions_existing_examples():
    text = (ROOT / "README.md").read_text()
    for name in re.findall(r"`([\w-]+\.yaml)`", text):
        if name in ("model.yaml", "bad.yaml"):
            continue
        assert (ROOT / "mechanisms" / name).exists(), name


def test_quick_start_has_two_commands():
    text = (ROOT / "README.md").read_text()
    block = text.split("## Quick start", 1)[1].split("```sh", 1)[1].split("```", 1)[0]
    lines = [l for l in block.strip().splitlines() if l.strip()]
    assert len(lines) == 2
    assert "planarkin run mechanisms/slider-crank.yaml" in lines[0]
    assert "pytest" in lines[1]
