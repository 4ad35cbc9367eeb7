"""`planarkin sweep`: variants over parameter ranges, metrics checked against closed forms."""

import csv
import math
import os

import numpy as np
import pytest

from clitools import run_cli
from closedforms import four_bar_pose
from planarkin.studies.sweep import Range, factorial, latin_hypercube, parse_range, run_sweep
from planarkin.studies.variants import Study

FB = "mechanisms/four-bar.yaml"


def four_bar_closed_form(a, b, c, d, theta2):
    """Rocker angle (deg) and coupler point P of the four-bar of mechanisms/four-bar.yaml (A at
    the origin, D = (d, 0), P at (0.06, 0.045) in the coupler frame at B along B->C), on the
    branch with C to the left of B->D (closedforms.four_bar_pose)."""
    t3, t4 = four_bar_pose(theta2, a, b, c, d)
    Bx, By = a * np.cos(theta2), a * np.sin(theta2)
    Px = Bx + 0.06 * np.cos(t3) - 0.045 * np.sin(t3)
    Py = By + 0.06 * np.sin(t3) + 0.045 * np.cos(t3)
    return np.degrees(t4), Px, Py


def closed_form_extreme(f, sense):
    """The largest (sense 1) or smallest (-1) value of f(theta2) over a turn, located on a fine
    grid and polished by a bounded scalar search (independent of planarkin's refinement)."""
    from scipy.optimize import minimize_scalar
    th = np.linspace(0, 2 * np.pi, 20001)
    i = int(np.argmax(sense * f(th)))
    r = minimize_scalar(lambda x: -sense * f(np.array([x]))[0], method="bounded",
                        bounds=(th[max(i - 1, 0)], th[min(i + 1, len(th) - 1)]),
                        options={"xatol": 1e-13})
    return -sense * r.fun


def test_four_bar_sweep_metrics_match_the_closed_form(tmp_path):
    # the metrics are the extremes refined between the grid rows (as run's cycle figures), so
    # they match the closed form's true extremes, not its grid's: at 72 steps per turn to a few
    # 1e-9 (the quintic Hermite's O(h^6)), where the grid's own extremes are ~1e-4 off
    steps = 72
    study = Study(FB, analysis={"steps": steps},
                  metrics=["max:rocker.phi", "min:rocker.phi", "stroke:rocker.phi", "max:P.x",
                           "absmax:P.y"])
    ranges = [Range("a", 0.03, 0.05, 3), Range("b", 0.11, 0.13, 2)]
    res = run_sweep(study, ranges, tmp_path, plots=None)
    assert [o.status for o in res.outcomes] == ["ok"] * 6
    theta2 = np.radians(360 * np.linspace(0, 1, steps + 1))
    worst = grid_worst = 0.0
    for v, o in zip(res.variants, res.outcomes):
        f = [lambda th, k=k: four_bar_closed_form(v["a"], v["b"], 0.10, 0.10, th)[k]
             for k in range(3)]
        hi, lo = closed_form_extreme(f[0], 1), closed_form_extreme(f[0], -1)
        expect = [hi, lo, hi - lo, closed_form_extreme(f[1], 1),
                  max(closed_form_extreme(f[2], 1), -closed_form_extreme(f[2], -1))]
        worst = max(worst, max(abs(x - y) / abs(y) for x, y in zip(o.metrics, expect)))
        rocker, Px, Py = four_bar_closed_form(v["a"], v["b"], 0.10, 0.10, theta2)
        grid = [rocker.max(), rocker.min(), rocker.max() - rocker.min(), Px.max(),
                np.abs(Py).max()]
        grid_worst = max(grid_worst, max(abs(x - y) / abs(y) for x, y in zip(grid, expect)))
    assert worst < 1e-8 and grid_worst > 1e-5
    with open(tmp_path / "sweep.csv") as f:
        rows = list(csv.reader(f))
    assert rows[0] == ["variant", "a", "b", "status", "kind", "t [s]", "message",
                       "max:rocker.phi [deg]", "min:rocker.phi [deg]", "stroke:rocker.phi [deg]",
                       "max:P.x [m]", "absmax:P.y [m]"]
    assert [r[1:3] for r in rows[1:]] == [["0.03", "0.11"], ["0.03", "0.13"], ["0.04", "0.11"],
                                          ["0.04", "0.13"], ["0.05", "0.11"], ["0.05", "0.13"]]
    assert [float(x) for x in rows[1][7:]] == list(res.outcomes[0].metrics)


def test_failed_and_invalid_variants_are_rows_with_their_reason(tmp_path):
    study = Study(FB, analysis={"steps": 36}, metrics=["max:rocker.phi"])
    # a = 0.08: s + l = p + q, the coupler and rocker are folded at t = 0 (cannot be
    # assembled); a = 0.17 and 0.30: non-Grashof, the crank cannot turn: lock-up
    res = run_sweep(study, [Range("a", 0.04, 0.08, 2), Range("b", 0.12, 0.12, 1)], tmp_path,
                    plots=None)
    res2 = run_sweep(study, [Range("a", 0.17, 0.30, 2)], tmp_path, plots=None)
    st = [(o.status, o.kind) for o in res.outcomes + res2.outcomes]
    assert st == [("ok", ""), ("invalid", ""), ("failed", "lock-up"), ("failed", "lock-up")]
    # folded flat at t = 0: a change point (the joints lose a rank at this pose only), not a
    # missing driver (tests/cases/four-bar-folded.yaml)
    assert res.outcomes[1].message.startswith("at t = start = 0 the mechanism is at a dead "
                                              "point or a change point")
    for o, tmax in zip(res2.outcomes, (0.30, 0.09)):
        assert 0 < o.t < tmax and o.message.startswith("singular configuration at t = ")
    res = run_sweep(study, [Range("a", 0.04, 0.08, 2), Range("b", 0.12, 0.12, 1)], tmp_path,
                    plots=None)
    assert all(math.isnan(o.metrics[0]) for o in res.outcomes if o.status != "ok")
    text = (tmp_path / "sweep.csv").read_text().splitlines()
    assert len(text) == 3 and text[2].startswith('2,0.08,0.12,invalid,,,"at t = start = 0 the mechanism is at a dead ')


def test_factorial_order_and_ranges():
    assert parse_range("a=0.10:0.20:11", True) == Range("a", 0.1, 0.2, 11)
    assert parse_range("b = 1:2", False) == Range("b", 1.0, 2.0, None)
    assert factorial([Range("a", 0, 1, 2), Range("b", 5, 5, 1)]) == [{"a": 0.0, "b": 5.0},
                                                                      {"a": 1.0, "b": 5.0}]
    for bad, why in (("a=1:2", "give the number of values"), ("a", "write NAME=LO:HI:N"),
                     ("a=x:2:3", "LO and HI must be numbers"), ("a=1:2:0", "at least 1"),
                     ("a=1:2:2.5", "whole number")):
        with pytest.raises(ValueError, match=why):
            parse_range(bad, True)


def test_latin_hypercube_is_seeded_and_stratified():
    r = [Range("a", 0.1, 0.2, None), Range("b", -1.0, 3.0, None)]
    v1 = latin_hypercube(r, 50, seed=7)
    assert v1 == latin_hypercube(r, 50, seed=7)
    assert v1 != latin_hypercube(r, 50, seed=8)
    for rg in r:
        u = np.array([(v[rg.name] - rg.lo) / (rg.hi - rg.lo) for v in v1])
        assert sorted(np.floor(u * 50).astype(int)) == list(range(50))   # one per stratum


@pytest.mark.slow
def test_cli_sweep_writes_table_and_plot(tmp_path):
    r = run_cli("sweep", FB, "--vary", "a=0.03:0.05:3", "--metric", "max:rocker.phi",
                "--out", tmp_path, "--steps", "24")
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("ok       mechanisms/four-bar.yaml: 3 variants: 3 ok, 0 failed, "
                               "0 invalid, ")
    assert (tmp_path / "four-bar" / "sweep.png").stat().st_size > 0


def test_cli_sweep_usage_and_input_errors(tmp_path):
    from click.testing import CliRunner
    from planarkin.cli import main
    run = lambda *a: CliRunner().invoke(main, ["sweep", FB, "--out", str(tmp_path)] + list(a))
    r = run("--vary", "aa=0.03:0.05:3")
    assert r.exit_code == 2
    assert r.stderr == "mechanisms/four-bar.yaml: error: unknown parameter 'aa'; did you mean 'a'?\n"
    r = run("--vary", "a=0.03:0.05:3", "--metric", "max:rocker.ph")
    assert r.exit_code == 2
    assert r.stderr == ("mechanisms/four-bar.yaml: error: --metric max:rocker.ph: no column "
                        "'rocker.ph' in this model's tables; did you mean 'rocker.phi'?\n")
    r = run("--vary", "a=0.03:0.05")
    assert r.exit_code == 2 and "give the number of values" in r.stderr
    r = run("--vary", "a=0.03:0.05:2", "--vary", "a=1:2:2")
    assert r.exit_code == 2 and "each parameter may be varied once" in r.stderr


def test_sweep_parquet_holds_the_same_table(tmp_path):
    pq = pytest.importorskip("pyarrow.parquet")
    study = Study(FB, analysis={"steps": 12}, metrics=["max:rocker.phi"])
    res = run_sweep(study, [Range("a", 0.04, 0.08, 2)], tmp_path, plots=None)
    assert tmp_path / "sweep.parquet" in res.files
    t = pq.read_table(tmp_path / "sweep.parquet").to_pydict()
    with open(tmp_path / "sweep.csv") as f:
        rows = list(csv.reader(f))
    assert list(t) == rows[0]
    assert t["status"] == ["ok", "invalid"] and t["a"] == [0.04, 0.08]
    assert t["max:rocker.phi [deg]"][0] == float(rows[1][-1])
    assert math.isnan(t["max:rocker.phi [deg]"][1])


def test_sweep_csv_cells_are_the_tables_shortest_round_trip_text():
    # sweep.csv and samples.csv write each number as the run tables' vectorised formatter
    # does (repr per cell: the formatter per cell cost 0.25 ms, five times the solve)
    from planarkin.output.fastcsv import format_value
    from planarkin.studies.sweep import _cell
    vals = [0.0, -0.0, 0.1, 1 / 3, 1e23, 5e-324, 2.2250738585072014e-308, 1.7976931348623157e308,
            9007199254740993.0, 1e16, 1e-5, 123.456, float("inf"), -float("inf"), -1.5e-7,
            np.float64(0.3), np.float32(0.1)]
    for v in vals:
        assert _cell(v) == format_value(float(v)), v
    assert _cell(float("nan")) == "" and _cell(7) == "7" and _cell('a "b", c') == '"a ""b"", c"'


def test_a_sweeps_files_are_replaced_all_or_none(tmp_path, monkeypatch):
    # the files of a study command go into place together: a rerun without plots removes the
    # earlier run's plot (it described another sweep); an error while writing leaves the
    # earlier files as they were; no temporary is left either way, and a killed run's
    # temporaries are removed by the next run
    from planarkin.studies import sweep as sweepmod
    study = Study("mechanisms/four-bar.yaml", analysis={"steps": 24}, metrics=["max:rocker.phi"])
    run_sweep(study, [Range("a", 0.035, 0.045, 3)], tmp_path, plots="png")
    assert (tmp_path / "sweep.png").exists()
    run_sweep(study, [Range("b", 0.115, 0.125, 2)], tmp_path, plots=None)
    assert not (tmp_path / "sweep.png").exists()
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    assert "sweep.csv" in before and not any(n.startswith(".") for n in before)

    def broken(path, *a):
        path.write_bytes(b"half")
        raise OSError("disk full")
    monkeypatch.setattr(sweepmod, "write_parquet", broken)
    with pytest.raises(OSError, match="disk full"):
        run_sweep(study, [Range("a", 0.03, 0.05, 4)], tmp_path, plots=None)
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before
    # without a Parquet library nothing is written to sweep.parquet's temporary: the earlier
    # sweep's sweep.parquet goes (it describes another sweep), the rest is put in place
    monkeypatch.setattr(sweepmod, "write_parquet", lambda path, head, table: None)
    had = (tmp_path / "sweep.parquet").exists()
    run_sweep(study, [Range("a", 0.03, 0.05, 3)], tmp_path, plots=None)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sweep.csv"], had
    monkeypatch.undo()
    dead = tmp_path / f".tmp-{os.getppid()}-sweep.csv"    # a killed run's (any pid)
    dead.write_text("x")
    run_sweep(study, [Range("a", 0.03, 0.05, 2)], tmp_path, plots=None)
    assert not dead.exists()
    # another run or study writing the directory holds its lock: refused, nothing touched
    from planarkin.output.directory import OutputError, locked
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    with locked(tmp_path):
        with pytest.raises(OutputError, match="being written by another planarkin run"):
            run_sweep(study, [Range("a", 0.03, 0.05, 3)], tmp_path, plots=None)
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before
    assert not list(tmp_path.parent.glob(f".{tmp_path.name}.lock"))


def test_grid_values_print_as_written(tmp_path):
    # linspace gave 0.09999999999999999 and 0.12000000000000001 for a=0.02:0.12:6 (issue 21/17)
    assert [repr(float(x)) for x in parse_range("a=0.02:0.12:6", True).values()] == \
        ["0.02", "0.04", "0.06", "0.08", "0.1", "0.12"]
    assert [repr(float(x)) for x in parse_range("a=0.1:0.2:11", True).values()] == \
        ["0.1", "0.11", "0.12", "0.13", "0.14", "0.15", "0.16", "0.17", "0.18", "0.19", "0.2"]
    assert parse_range("a=0:1:4", True).values().tolist() == [0.0, 1 / 3, 2 / 3, 1.0]
    study = Study(FB, analysis={"steps": 4})
    run_sweep(study, [parse_range("a=0.02:0.05:4", True)], tmp_path, plots=None)
    col = [line.split(",")[1] for line in (tmp_path / "sweep.csv").read_text().splitlines()[1:]]
    assert col == ["0.02", "0.03", "0.04", "0.05"]


def test_a_grid_count_with_samples_and_a_metric_twice_are_refused(tmp_path):
    from click.testing import CliRunner
    from planarkin.cli import main
    run = lambda *a: CliRunner().invoke(main, ["sweep", FB, "--out", str(tmp_path)] + list(a))
    r = run("--vary", "a=0.02:0.05:3", "--samples", "5")       # the :3 was silently ignored
    assert r.exit_code == 2
    assert "'a=0.02:0.05:3': with --samples the range is sampled, so N is not used: write " \
           "a=0.02:0.05" in r.stderr
    r = run("--vary", "a=0.03:0.05:2", "--metric", "max:rocker.phi", "--metric", "max:rocker.phi")
    assert r.exit_code == 2                                  # it was written twice
    assert r.stderr == "mechanisms/four-bar.yaml: error: --metric max:rocker.phi is given " \
                       "twice; give each metric once\n"
