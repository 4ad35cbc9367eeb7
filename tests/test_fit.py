"""planarkin fit: tracked data of mechanisms/four-bar.yaml's coupler point, exact and noisy;
the data file's validation."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import planarkin
from planarkin.cli import main

ROOT = Path(__file__).resolve().parents[1]
FOUR = ROOT / "mechanisms" / "four-bar.yaml"
TRUE = np.array([0.04, 0.12, 0.1, 0.1])
FREE = ["a", "b", "c", "d"]
START = {"a": 0.042, "b": 0.118, "c": 0.103, "d": 0.098}


@pytest.fixture(scope="module")
def track():
    res = planarkin.solve(planarkin.load(FOUR), steps=48)
    P = res.point("P")
    return res.t, P["x"], P["y"]


def _write(path, t, x, y, head="t [s],P.x [mm],P.y [mm]"):
    rows = [head] + [f"{float(a)!r},{float(b) * 1e3!r},{float(c) * 1e3!r}"
                     for a, b, c in zip(t, x, y)]
    path.write_text("\n".join(rows) + "\n")
    return path


def test_exact_data_gives_the_parameters(tmp_path, track):
    """Data in mm for a model in m (converted); from 2-5 % off, the fit returns the model."""
    p = _write(tmp_path / "d.csv", *track)
    r = planarkin.fit(FOUR, p, FREE, overrides=START)
    assert r.status == 0
    assert np.abs(r.estimate - TRUE).max() < 1e-9
    assert r.rms < 1e-12


def test_noisy_data_true_within_two_standard_errors(tmp_path, track):
    """0.1 mm noise: the true parameters within 2 standard errors in >= 90 % of the trials
    (all 4 parameters jointly counted per parameter; 10 seeded trials here, 100 in
    benchmarks/bench_synth.py)."""
    t, x, y = track
    rng = np.random.default_rng(1)
    hits = total = 0
    for k in range(10):
        p = _write(tmp_path / f"n{k}.csv", t, x + 1e-4 * rng.standard_normal(len(t)),
                   y + 1e-4 * rng.standard_normal(len(t)))
        r = planarkin.fit(FOUR, p, FREE, overrides=START)
        assert r.status == 0
        hits += int((np.abs(r.estimate - TRUE) <= 2 * r.se).sum())
        total += len(FREE)
        assert 0.5e-4 < r.rms < 2e-4
    assert hits >= 0.9 * total


BAD = [
    ("t [s],P.x [mm],P.y [mm]\n0,1,2\n0.1,nan,2\n", 3, "a value is NaN or infinite"),
    ("t [s],Q.x [mm],P.y [mm]\n0,1,2\n0.1,1,2\n", 1, "column 'Q.x [mm]': write POINT.x"),
    ("t [s],P.x [kg],P.y [mm]\n0,1,2\n0.1,1,2\n", 1, "column 'P.x [kg]': give the length unit"),
    ("time,P.x [mm]\n0,1\n0.1,1\n", 1, "the first column must be the time 't [s]'"),
    ("t [s],P.x [mm],P.y [mm]\n0,1,2\n0.1,x,2\n", 3, "not a number"),
    ("t [s],P.x [mm],P.y [mm]\n0,1,2\n0.1,1\n", 3, "2 values for 3 columns"),
    ("t [s],P.x [mm],P.y [mm]\n0.2,1,2\n0.1,1,2\n", 3, "the times must increase"),
]


@pytest.mark.parametrize("text,line,message", BAD)
def test_bad_data_is_a_file_line_error(tmp_path, text, line, message):
    p = tmp_path / "bad.csv"
    p.write_text(text)
    r = CliRunner().invoke(main, ["fit", str(FOUR), "--data", str(p), "--free", "a",
                                  "--out", str(tmp_path)])
    assert r.exit_code == 2, r.output
    assert f"{p}:{line}: error: {message}" in r.output, r.output


def test_cli_fit_writes_estimates(tmp_path, track):
    p = _write(tmp_path / "d.csv", *track)
    r = CliRunner().invoke(main, ["fit", str(FOUR), "--data", str(p), "--out", str(tmp_path),
                                  "--free", "a", "--free", "c", "--set", "a=0.041"])
    assert r.exit_code == 0, r.output
    out = tmp_path / "four-bar.fit"
    s = json.loads((out / "summary.json").read_text())
    assert abs(s["parameters"]["a"]["estimate"] - 0.04) < 1e-9
    assert s["jacobians"] > 0
    for f in ("estimates.csv", "residuals.csv", "fitted.yaml", "fit.png"):
        assert (out / f).exists()
    assert CliRunner().invoke(main, ["check", str(out / "fitted.yaml")]).exit_code == 0


def test_unknown_free_parameter(tmp_path, track):
    p = _write(tmp_path / "d.csv", *track)
    r = CliRunner().invoke(main, ["fit", str(FOUR), "--data", str(p), "--free", "aa",
                                  "--out", str(tmp_path)])
    assert r.exit_code == 2 and "--free aa: not a parameter of the model" in r.output


MORE_BAD = [
    ("", 1, "the data file is empty"),
    ("t [s],P.x [mm],P.x [mm]\n0,1,1\n0.1,1,1\n", 1, "a point coordinate is given in two "
                                                    "columns"),
    ("t [s]\n0\n0.1\n", 1, "no point columns"),
    ("t [s],P.x [mm]\n0,1\n", 1, "the data needs at least two rows"),
    ("t [s],P.x [mm],P.y [mm]\n0,1,2\n0.1,inf,2\n", 3, "a value is NaN or infinite"),
    ("t [s],P.x [mm],P.y [mm]\n0,1,2\n0,1,2\n", 3, "the times must increase"),
]


@pytest.mark.parametrize("text,line,message", MORE_BAD)
def test_more_bad_data(tmp_path, text, line, message):
    test_bad_data_is_a_file_line_error(tmp_path, text, line, message)


def test_missing_data_file_and_data_before_the_start(tmp_path, track):
    r = CliRunner().invoke(main, ["fit", str(FOUR), "--data", str(tmp_path / "none.csv"),
                                  "--free", "a", "--out", str(tmp_path)])
    assert r.exit_code == 2 and "cannot read the data file" in r.output, r.output
    t, x, y = track
    p = _write(tmp_path / "d.csv", t - 0.5, x, y)
    r = CliRunner().invoke(main, ["fit", str(FOUR), "--data", str(p), "--free", "a",
                                  "--out", str(tmp_path)])
    assert r.exit_code == 2, r.output
    assert "the data starts at t = -0.5 s, before the model's analysis start 0 s" in r.output


def test_no_free_parameters_is_refused(tmp_path, track):
    """Without --free the design block's free parameters are fitted; a model without one is
    refused (FILE:LINE, exit 2)."""
    p = _write(tmp_path / "d.csv", *track)
    r = CliRunner().invoke(main, ["fit", str(FOUR), "--data", str(p), "--out", str(tmp_path)])
    assert r.exit_code == 2, r.output
    assert f"{FOUR}:1: error: the model has no design: block" in r.output


def test_a_parameter_the_data_do_not_see_is_not_identifiable(tmp_path, track):
    """A free parameter that nothing in the model uses leaves the data unchanged: its column
    of J is zero, J^T J singular: exit 1 with the reason, the estimates still written."""
    t, x, y = track
    m = tmp_path / "m.yaml"
    m.write_text(FOUR.read_text().replace("parameters:\n", "parameters:\n  unused: 1\n", 1))
    p = _write(tmp_path / "d.csv", t, x, y)
    r = CliRunner().invoke(main, ["fit", str(m), "--data", str(p), "--free", "a", "--free",
                                  "unused", "--out", str(tmp_path), "--no-plots"])
    assert r.exit_code == 1, r.output
    assert "not identifiable" in r.output
    assert (tmp_path / "m.fit" / "estimates.csv").exists()


@pytest.mark.parametrize("model,point,free,truth,start", [
    ("slider-crank.yaml", "B", ["a"], [0.1], {"a": 0.104}),
    ("six-bar.yaml", "F", ["e5", "e6"], [0.16, 0.10], {"e5": 0.155, "e6": 0.103}),
])
def test_fit_the_slider_crank_and_the_six_bar(tmp_path, model, point, free, truth, start):
    """Exact data of the example models' own points (the slider-crank's B moves with a and
    b = 3a; the six-bar's F on its output link): the fit from a few % off returns the
    parameters to 1e-9."""
    path = ROOT / "mechanisms" / model
    res = planarkin.solve(planarkin.load(path), steps=36)
    P = res.point(point)
    rows = [f"t [s],{point}.x [m],{point}.y [m]"] + [
        f"{float(t)!r},{float(x)!r},{float(y)!r}" for t, x, y in zip(res.t, P["x"], P["y"])]
    p = tmp_path / "d.csv"
    p.write_text("\n".join(rows) + "\n")
    r = planarkin.fit(path, p, free, overrides=start)
    assert r.status == 0, r.message
    assert np.abs(r.estimate - np.array(truth)).max() < 1e-9


def test_fit_and_run_in_the_same_out_keep_each_others_files(tmp_path, track):
    """fit writes DIR/<name>.fit/ beside run's DIR/<name>/: neither replaces the other."""
    p = _write(tmp_path / "d.csv", *track)
    out = tmp_path / "out"
    runner = CliRunner()
    assert runner.invoke(main, ["run", str(FOUR), "--out", str(out), "--no-plots"]).exit_code == 0
    before = {f.name: f.read_bytes() for f in (out / "four-bar").iterdir()}
    r = runner.invoke(main, ["fit", str(FOUR), "--data", str(p), "--free", "a", "--out",
                             str(out), "--set", "a=0.041", "--no-plots"])
    assert r.exit_code == 0, r.output
    assert {f.name: f.read_bytes() for f in (out / "four-bar").iterdir()} == before
    fitted = {f.name: f.read_bytes() for f in (out / "four-bar.fit").iterdir()}
    assert runner.invoke(main, ["run", str(FOUR), "--out", str(out), "--no-plots"]).exit_code == 0
    assert {f.name: f.read_bytes() for f in (out / "four-bar.fit").iterdir()} == fitted


# -- the data file under the budgets of the tables a model reads (issue 33) --------------------

def _fit_cli(tmp_path, data, *more):
    from clitools import run_cli
    return run_cli("fit", FOUR, "--data", data, "--free", "a", "--out", tmp_path / "out",
                   "--no-plots", *more)


def test_a_fifo_or_a_device_is_refused_before_it_is_read(tmp_path):
    """A FIFO without a writer (it hung for ever) and /dev/zero (it grew past 6 GB): refused
    from their type, before they are opened for reading. Hang guard: after 10 s a writer
    opens the FIFO and closes it, so a reader gets end of file instead of waiting."""
    import os
    import threading
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)

    def release():
        try:
            os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))
        except OSError:             # no reader: nothing waits on it
            pass
    guard = threading.Timer(10.0, release)
    guard.start()
    try:
        for data in (fifo, Path("/dev/zero")):
            r = _fit_cli(tmp_path, data)
            assert r.returncode == 2, r.stdout + r.stderr
            assert f"{data}: error: the data file is not a regular file (a FIFO, device or " \
                   f"folder is not read): give a CSV file" in r.stderr, r.stderr
    finally:
        guard.cancel()


def test_data_file_budgets_bound_what_is_read(tmp_path, monkeypatch):
    """The table reader's budgets, each a FILE[:LINE] error with exit 2: a file larger than
    MAX_BYTES refused from its size (a sparse 16 MB file: nothing read); a line longer than
    MAX_LINE (a 140 kB field ended in a _csv.Error traceback); a quote left open, the rest of
    the file one field; more than MAX_ROWS rows refused at the row after the last allowed
    (a 2,000,000-row file grew past 6 GB)."""
    from planarkin.functions import inputtable
    big = tmp_path / "big.csv"
    with open(big, "wb") as f:
        f.truncate(inputtable.MAX_BYTES + 1)
    r = _fit_cli(tmp_path, big)
    assert r.returncode == 2 and f"{big}: error: the data file is too large " \
                                 f"({inputtable.MAX_BYTES + 1} bytes" in r.stderr, r.stderr
    wide = tmp_path / "wide.csv"
    wide.write_text("t [s],P.x [mm],P.y [mm]\n0,\"" + "1" * 140_000 + "\",2\n0.1,1,2\n")
    r = _fit_cli(tmp_path, wide)
    assert r.returncode == 2 and f"{wide}:2: error: the line is longer than " \
                                  f"{inputtable.MAX_LINE} characters" in r.stderr, r.stderr
    quote = tmp_path / "quote.csv"
    quote.write_text("t [s],P.x [mm],P.y [mm]\n0,\"1\n" + "2\n" * 70_000 + "0.1,1,2\n")
    r = _fit_cli(tmp_path, quote)
    assert r.returncode == 2 and f"{quote}:" in r.stderr and "error: not a CSV line" in \
        r.stderr, r.stderr
    monkeypatch.setattr(inputtable, "MAX_ROWS", 50)
    rows = tmp_path / "rows.csv"
    rows.write_text("t [s],P.x [mm],P.y [mm]\n" + "".join(f"{k * 1e-3},1,2\n"
                                                          for k in range(10_000)))
    r = _fit_cli(tmp_path, rows)
    assert r.returncode == 2, r.stdout + r.stderr
    assert f"{rows}:52: error: the data file has more than 50 rows" in r.stderr, r.stderr


def test_free_given_twice_is_a_usage_error(tmp_path, track):
    """--free a --free a answered 'not identifiable' (exit 1: J^T J of two equal columns is
    singular); it is a usage error naming the option, as is the API's."""
    p = _write(tmp_path / "d.csv", *track)
    r = _fit_cli(tmp_path, p, "--free", "a")
    assert r.returncode == 2, r.stdout + r.stderr
    assert "Invalid value for '--free': 'a' given twice: name each parameter once" in \
        r.stderr, r.stderr
    with pytest.raises(planarkin.InputError, match="--free a is given twice"):
        planarkin.fit(FOUR, p, ["a", "b", "a"])


def test_fitted_yaml_carries_every_set_value_and_reproduces_its_rms(tmp_path, track):
    """--set d=0.098 (d not fitted) against data of d = 0.1: the fit uses it, so fitted.yaml
    must carry it (it held the file's d = 0.1: the written model was not the one fitted).
    Running fitted.yaml at the data's times reproduces the rms residual it states."""
    t, x, y = track
    p = _write(tmp_path / "d.csv", t, x, y)
    r = _fit_cli(tmp_path, p, "--set", "d=0.098", "--set", "a=0.041")
    assert r.returncode == 0, r.stdout + r.stderr
    out = tmp_path / "out" / "four-bar.fit"
    s = json.loads((out / "summary.json").read_text())
    assert s["set"] == {"d": 0.098} and s["rms_residual"] > 1e-5
    assert "# planarkin fit" in (out / "fitted.yaml").read_text()
    assert "set: d = 0.098" in (out / "fitted.yaml").read_text()
    fitted = planarkin.load(out / "fitted.yaml")
    assert fitted.spec.parameters["d"] == 0.098
    P = planarkin.solve(fitted, steps=len(t) - 1).point("P")
    res = np.concatenate([P["x"] - x, P["y"] - y])
    assert np.sqrt(np.mean(res ** 2)) == pytest.approx(s["rms_residual"], rel=1e-6)
