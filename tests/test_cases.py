"""Every broken model in tests/cases/ with its exact diagnostics and exit status.

Each `NAME.yaml` has a `NAME.expected`: the first line is `exit N`, the rest is the exact text
planarkin writes to stderr for `planarkin check tests/cases/NAME.yaml` (leftover or missing
lines fail). Regenerate after a deliberate wording change with
`PLANARKIN_REGEN=1 python -m pytest tests/test_cases.py` and review the diff."""

import os

import pytest

from clitools import ROOT, run_cli

CASES = sorted((ROOT / "tests" / "cases").glob("*.yaml"))


@pytest.mark.parametrize("path", CASES, ids=[p.stem for p in CASES])
def test_case(path):
    rel = path.relative_to(ROOT).as_posix()
    r = run_cli("check", rel)
    expected_file = path.with_suffix(".expected")
    got = f"exit {r.returncode}\n{r.stderr}"
    if os.environ.get("PLANARKIN_REGEN"):
        expected_file.write_text(got)
    expected = expected_file.read_text()
    assert "Traceback" not in r.stderr
    assert got == expected


def test_every_case_has_expectations():
    assert CASES, "no cases found"
    for p in CASES:
        assert p.with_suffix(".expected").exists(), f"{p.name} has no .expected file"
