"""planarkin synth and fit under hostile conditions (issue 33): --set on a parameter that is
not free (the written models must carry it), a full disk, grids and searches too large for
memory or a day, long searches (the progress line), interruptions (SIGTERM during the search
and while the results are written)."""

from __future__ import annotations

import builtins
import errno
import io
import json
import os
import signal
import subprocess
from pathlib import Path

import numpy as np
import pytest

import planarkin
from clitools import ROOT, run_cli, start_held
from planarkin.synthesis import output as synth_output

EX = ROOT / "mechanisms" / "synthesis"
FUNCTION = EX / "four-bar-function.yaml"
INPUTS = [0, 60, 120, 180, 240, 300]        # the function target's crank angles (deg)
FAST = ["--starts", "4", "--local", "1"]


def _no_leftovers(out: Path) -> None:
    """Nothing but result directories: no staged .NAME.tmp-PID, no lock, no .old."""
    if out.exists():
        assert [p.name for p in out.iterdir() if p.name.startswith(".")] == []


# -- --set on a parameter that is not free ----------------------------------------------------

def _function_model(tmp_path, a: float) -> Path:
    """four-bar-function.yaml with its targets those of the crank a (b, c, d as in the file):
    with --set a=<a> the search can meet them exactly."""
    text = FUNCTION.read_text()
    base = planarkin.solve(planarkin.load(FUNCTION, a=a), steps=360)
    phi = base.body("rocker")["phi"][INPUTS]
    old = text[text.index("outputs: ["):text.index("]", text.index("outputs: [")) + 1]
    p = tmp_path / "m.yaml"
    p.write_text(text.replace(old, "outputs: [" + ", ".join(repr(float(v)) for v in phi) + "]"))
    return p


def test_synth_writes_every_set_value_and_the_written_design_meets_its_claim(tmp_path):
    """--set a=0.05 (a is not free): the search uses it, so design-1.yaml must carry it. Run
    the written file and evaluate the targets from it: the sum of squares is the one its
    header and summary.json state (it used to hold the file's a = 0.04: the written linkage
    missed its targets by degrees while claiming 1e-19)."""
    model = _function_model(tmp_path, 0.05)
    r = run_cli("synth", model, "--out", tmp_path, *FAST, "--no-plots", "--set", "a=0.05")
    assert r.returncode == 0, r.stdout + r.stderr
    out = tmp_path / "m.synth"
    s = json.loads((out / "summary.json").read_text())
    claimed = s["designs"][0]["cost"]
    assert claimed < 1e-12 and s["set"] == {"a": 0.05}
    text = (out / "design-1.yaml").read_text()
    assert "# set: a = 0.05" in text
    written = planarkin.load(out / "design-1.yaml")
    assert written.spec.parameters["a"] == 0.05
    res = planarkin.solve(written, steps=360)      # rows at every degree of the crank
    targets = np.array(_outputs(model))
    d = res.body("rocker")["phi"][INPUTS] - targets
    d = (d + 180) % 360 - 180
    assert float(d @ d) == pytest.approx(claimed, abs=1e-12)


def _outputs(model: Path) -> list:
    import yaml
    return yaml.safe_load(model.read_text())["design"]["targets"][0]["outputs"]


# -- a full disk -------------------------------------------------------------------------------

class _Full(io.RawIOBase):
    """A file on a full disk: every write fails (ENOSPC)."""

    def writable(self):
        return True

    def write(self, b):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


@pytest.fixture
def full_disk(monkeypatch):
    """full_disk(name): from now on, writing a file of that name fails as on a full disk (the
    open succeeds, as it does there; the first write does not)."""
    real = builtins.open

    def arm(victim):
        def fake(file, mode="r", *a, **k):
            if Path(str(file)).name == victim and any(c in mode for c in "wax"):
                real(file, mode, *a, **k).close()          # created, as a full disk does
                f = _Full()
                return f if "b" in mode else io.TextIOWrapper(f, encoding="utf-8")
            return real(file, mode, *a, **k)
        monkeypatch.setattr(builtins, "open", fake)
    return arm


@pytest.fixture(scope="module")
def searched():
    """One quick search of four-bar-function.yaml (the writes are the subject)."""
    return planarkin.synthesize(FUNCTION, starts=4, local=1)


@pytest.mark.parametrize("victim", ["designs.csv", "residuals.csv", "design-1.yaml", "synth.png",
                                    "summary.json"])
def test_a_full_disk_while_writing_synth_leaves_the_earlier_results(tmp_path, searched,
                                                                     full_disk, victim):
    """Every file of a synth directory: a full disk while writing it raises WriteError naming
    the file and the errno's text, the staged directory is removed and the earlier results
    stay byte for byte (it was an OSError traceback, and the staged directory was left)."""
    from planarkin.output.directory import WriteError
    out = tmp_path / "four-bar-function.synth"
    synth_output.write_synth(searched, out, None)
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    full_disk(victim)
    with pytest.raises(WriteError, match=f"writing {victim} failed: No space left on device"):
        synth_output.write_synth(searched, out, "png")
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    _no_leftovers(tmp_path)


def test_a_rename_that_fails_leaves_nothing_staged(tmp_path, searched, monkeypatch):
    """The new directory cannot be put in place (an I/O error on the rename): WriteError, and
    the staged directory is removed."""
    from planarkin.output.directory import WriteError

    def fail(src, dst):
        raise OSError(errno.EIO, os.strerror(errno.EIO))
    monkeypatch.setattr(os, "replace", fail)
    with pytest.raises(WriteError, match="putting four-bar-function.synth/ in place failed"):
        synth_output.write_synth(searched, tmp_path / "four-bar-function.synth", None)
    monkeypatch.undo()
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("command", ["synth", "fit"])
def test_a_full_disk_is_exit_1_with_one_line(tmp_path, full_disk, command):
    """The command line: exit 1, one line on stderr saying what could not be written and why,
    never a traceback (run_cli raises it) and never exit 0; nothing staged is left."""
    if command == "synth":
        full_disk("synth.png")
        args = ["synth", FUNCTION, "--out", tmp_path / "out", *FAST]
        victim = "synth.png"
    else:
        data = _track(tmp_path)
        full_disk("fitted.yaml")
        args = ["fit", ROOT / "mechanisms" / "four-bar.yaml", "--data", data, "--free", "a",
                "--set", "a=0.041", "--out", tmp_path / "out", "--no-plots"]
        victim = "fitted.yaml"
    r = run_cli(*args)
    assert r.returncode == 1, r.stdout + r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and f"error: writing {victim} failed: No space left on device" in \
        lines[0] and "is left as it was" in lines[0], r.stderr
    _no_leftovers(tmp_path / "out")
    assert not any((tmp_path / "out").iterdir())


def _track(tmp_path, steps=48, d=None) -> Path:
    """Tracked coupler point P of mechanisms/four-bar.yaml (mm), at the rows of `steps`."""
    model = planarkin.load(ROOT / "mechanisms" / "four-bar.yaml", **({"d": d} if d else {}))
    res = planarkin.solve(model, steps=steps)
    P = res.point("P")
    p = tmp_path / "d.csv"
    p.write_text("t [s],P.x [mm],P.y [mm]\n" + "".join(
        f"{float(t)!r},{float(x) * 1e3!r},{float(y) * 1e3!r}\n"
        for t, x, y in zip(res.t, P["x"], P["y"])))
    return p


# -- memory and time budgets -----------------------------------------------------------------

@pytest.fixture
def no_analysis(monkeypatch):
    """Fail at once if a design is analysed over its whole range (the refusals below come
    before any; without them one analysis of 4e6 rows takes gigabytes, 1e5 starts hours)."""
    from planarkin.synthesis.problem import Model

    def forbidden(self, values):
        raise AssertionError("a design was analysed before the budget was checked")
    monkeypatch.setattr(Model, "analyse", forbidden)


def test_synth_steps_too_many_for_memory_is_refused_before_any_analysis(tmp_path, no_analysis):
    """--steps 4000000: the grids the search holds at once (the starts kept for the local
    runs, the designs kept, the one being analysed) would take about 24 GB (it grew past 6 GB
    before failing): refused before the first analysis, exit 2, naming the budget and the
    largest --steps that fits, which is then accepted."""
    r = run_cli("synth", FUNCTION, "--out", tmp_path, "--steps", "4000000")
    assert r.returncode == 2, r.stdout + r.stderr
    assert "error: synth: 5 grids of 4000001 rows would be held at once" in r.stderr
    assert "more than the budget of 1 GB: use --steps" in r.stderr, r.stderr
    assert not tmp_path.joinpath("four-bar-function.synth").exists()
    most = int(r.stderr.split("use --steps ")[1].split()[0])
    from planarkin.synthesis.synth import Synthesis, check_cost
    syn = Synthesis(FUNCTION, analysis={"steps": most})
    cfg = syn.design.search
    check_cost(syn, cfg, cfg["starts"], cfg["starts"])
    syn = Synthesis(FUNCTION, analysis={"steps": most + 2})
    with pytest.raises(planarkin.InputError):
        check_cost(syn, cfg, cfg["starts"], cfg["starts"])


def test_fit_steps_too_many_for_memory_is_refused(tmp_path, no_analysis):
    data = _track(tmp_path)
    r = run_cli("fit", ROOT / "mechanisms" / "four-bar.yaml", "--data", data, "--free", "a",
                "--steps", "4000000", "--out", tmp_path)
    assert r.returncode == 2, r.stdout + r.stderr
    assert "error: fit: 2 grids of 4000001 rows would be held at once" in r.stderr, r.stderr


def test_a_search_longer_than_a_day_is_refused_at_once(tmp_path, no_analysis):
    """100000 starts of 160001 rows: about 27 h by the study budget's figures: refused before
    any analysis, naming --starts."""
    r = run_cli("synth", FUNCTION, "--out", tmp_path, "--starts", "100000", "--steps", "160000",
                "--local", "1")
    assert r.returncode == 2, r.stdout + r.stderr
    assert "synth: the search would analyse 100000 starts of 160001 grid rows" in r.stderr
    assert "use fewer --starts" in r.stderr


def test_only_the_starts_that_can_be_run_are_held_whole():
    """candidates(limit): every accepted start's score is kept, but only the best `limit`
    whole (each Design holds its grid: 1e5 starts grew past gigabytes); the same best ones, in
    the same order, as without the limit."""
    from planarkin.synthesis.synth import Synthesis
    syn = Synthesis(FUNCTION, analysis={"steps": 60})
    whole, _, scores = syn.candidates(8, 0)
    some, _, again = syn.candidates(8, 0, limit=2)
    assert len(some) == 2 and len(whole) == len(scores) == len(again) > 2
    assert [g[0] for g in some] == [g[0] for g in whole[:2]] == sorted(scores)[:2]


# -- progress -----------------------------------------------------------------------------------

class _Clock:
    def __init__(self):
        self.t = 0.0

    def __call__(self):
        return self.t


def test_progress_line_in_a_log_and_on_a_terminal():
    """In a log: a line every LINE_EVERY seconds, none before (short runs print nothing); on
    a terminal: one line rewritten in place and cleared at the end; quiet: nothing."""
    from planarkin.synthesis import progress as synth_progress
    clock, log = _Clock(), io.StringIO()
    p = synth_progress.SearchProgress("synth", stream=log, clock=clock)
    p(10, float("inf"))
    assert log.getvalue() == ""
    clock.t = synth_progress.LINE_EVERY
    p(50, 2.5e-3)
    p(51, 2.5e-3)
    assert log.getvalue() == (f"synth: 50 evaluations (10/s), best sum of squares 0.0025, "
                              f"{synth_progress.LINE_EVERY:.0f} s\n")

    class Tty(io.StringIO):
        def isatty(self):
            return True
    clock, tty = _Clock(), Tty()
    p = synth_progress.SearchProgress("fit", stream=tty, clock=clock)
    for k in range(1, 4):
        clock.t = k * synth_progress.TTY_EVERY
        p(k, float("inf"))
    p.close()
    text = tty.getvalue()
    assert text.count("\r") == 4 and "\n" not in text and text.endswith("\r\x1b[K")
    assert "fit: 3 evaluations" in text and "best sum of squares none yet" in text
    quiet = synth_progress.SearchProgress("synth", quiet=True, stream=log, clock=clock)
    clock.t = 1e6
    quiet(1, 1.0)
    assert log.getvalue().count("\n") == 1


@pytest.mark.parametrize("quiet", [False, True])
def test_synth_shows_its_progress_unless_quiet(tmp_path, monkeypatch, quiet):
    """A line on stderr every LINE_EVERY seconds (0 here: at every evaluation) with the
    evaluations, their rate and the best sum of squares so far; none with --quiet (a search
    of 1e5 starts showed nothing for 300 s)."""
    from planarkin.synthesis import progress as synth_progress
    monkeypatch.setattr(synth_progress, "LINE_EVERY", 0.0)
    r = run_cli("synth", FUNCTION, "--out", tmp_path, *FAST, "--no-plots",
                *(["--quiet"] if quiet else []))
    assert r.returncode == 0, r.stdout + r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.startswith("synth: ")]
    if quiet:
        assert lines == []
    else:
        assert len(lines) >= 4 and "evaluations" in lines[-1] and "/s)" in lines[-1]


# -- interruptions -----------------------------------------------------------------------------

def _interrupt_at(monkeypatch, module, name, after: int):
    """Make module.name raise Interrupted (SIGTERM) on its call number `after` + 1."""
    from planarkin.output.directory import Interrupted
    real = getattr(module, name)
    calls = []

    def wrapped(*a, **k):
        calls.append(1)
        if len(calls) > after:
            raise Interrupted("SIGTERM")
        return real(*a, **k)
    monkeypatch.setattr(module, name, wrapped)
    return calls


def test_interrupted_search_writes_the_designs_verified_so_far(tmp_path, monkeypatch):
    """SIGTERM after the first local run's design was verified, as the second is checked: the
    verified design is written, summary.json says interrupted and how far the search got,
    exit 143, the report line says what is on disk."""
    from planarkin.synthesis import runs
    _interrupt_at(monkeypatch, runs, "verified", 1)
    r = run_cli("synth", FUNCTION, "--out", tmp_path, "--starts", "4", "--local", "2",
                "--keep", "2", "--goal", "0")
    assert r.returncode == 143, r.stdout + r.stderr
    out = tmp_path / "four-bar-function.synth"
    assert f"interrupted {FUNCTION}: during the search after " in r.stdout
    assert "the 1 design(s) verified so far (best sum of squares" in r.stdout
    assert f"-> {out}/, status interrupted" in r.stdout, r.stdout
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "interrupted" and len(s["designs"]) == 1
    assert s["message"].startswith("interrupted by SIGTERM during the search after")
    assert (out / "design-1.yaml").exists() and (out / "synth.png").exists()
    _no_leftovers(tmp_path)


def test_interrupted_fit_says_how_far_it_got_and_writes_nothing(tmp_path, monkeypatch):
    from planarkin.synthesis.problem import Model
    data = _track(tmp_path)
    _interrupt_at(monkeypatch, Model, "analyse", 2)
    r = run_cli("fit", ROOT / "mechanisms" / "four-bar.yaml", "--data", data, "--free", "a",
                "--set", "a=0.041", "--out", tmp_path / "out")
    assert r.returncode == 143, r.stdout + r.stderr
    assert "during the fit after 2 evaluations: nothing was written; " in r.stdout, r.stdout
    assert not (tmp_path / "out" / "four-bar.fit").exists()
    _no_leftovers(tmp_path / "out")


@pytest.mark.parametrize("moment,said", [
    ("prepare:*", "during the search after 1 evaluation, before a design was verified: "
                  "nothing was written"),
    ("figure:four-bar-function.synth:synth.png", "while the results were being written: "
                                                 "nothing was written"),
])
def test_sigterm_to_synth_leaves_nothing_staged_and_says_what_happened(tmp_path, moment, said):
    """A real process, held (tests/hold) in its first analysis, or with its directory staged
    and synth.png drawn: SIGTERM ends it with 143, the earlier results as they were, no
    .NAME.tmp-PID or lock left, and the line says when it stopped (it said 'interrupted while
    starting: nothing was written' after seconds of searching, and left the staged
    directory)."""
    out = tmp_path / "out"
    r = run_cli("synth", FUNCTION, "--out", out, *FAST, "--no-plots")
    assert r.returncode == 0, r.stdout + r.stderr
    before = {p.name: p.read_bytes() for p in (out / "four-bar-function.synth").iterdir()}
    p = start_held(["synth", FUNCTION, "--out", out, *FAST], moment, tmp_path / "ready")
    p.send_signal(signal.SIGTERM)
    try:
        stdout, stderr = p.communicate(timeout=60)        # a hang guard only
    except subprocess.TimeoutExpired:
        p.kill()
        pytest.fail("planarkin synth hung after SIGTERM")
    assert p.returncode == 143 and "Traceback" not in stderr, (p.returncode, stdout, stderr)
    assert f"interrupted {FUNCTION}: {said}; {out / 'four-bar-function.synth'}/ is left as it " \
           f"was" in stdout, stdout
    assert {p.name: p.read_bytes() for p in (out / "four-bar-function.synth").iterdir()} == \
        before
    _no_leftovers(out)
