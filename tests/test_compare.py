"""`planarkin compare`: the CI regression gate between two result directories."""

import json
import os
import shutil

import numpy as np
import pytest

from clitools import run_cli
from planarkin.studies.compare import (DIFFERS, SAME, UNUSABLE, compare_dirs, read_table,
                                       report)


@pytest.fixture(scope="module")
def golden(tmp_path_factory):
    out = tmp_path_factory.mktemp("golden")
    r = run_cli("run", "mechanisms/four-bar.yaml", "--out", out, "--no-plots", "--steps", "36")
    assert r.returncode == 0, r.stderr
    return out / "four-bar"


def _copy(golden, tmp_path):
    d = tmp_path / "new"
    shutil.copytree(golden, d)
    return d


def _rewrite(path, column, f):
    """Apply f to one column of a CSV table, writing shortest round-trip text."""
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    c = header.index(column)
    out = [lines[0]]
    for line in lines[1:]:
        v = line.split(",")
        v[c] = repr(f(float(v[c])))
        out.append(",".join(v))
    path.write_text("\n".join(out) + "\n")


def test_identical_runs_are_the_same(golden, tmp_path):
    r = run_cli("run", "mechanisms/four-bar.yaml", "--out", tmp_path, "--no-plots", "--steps",
                "36")
    assert r.returncode == 0
    r = run_cli("compare", tmp_path / "four-bar", golden, "--rtol", "0", "--atol", "0")
    assert r.returncode == 0, r.stdout + r.stderr
    assert r.stdout.startswith("same: 2 tables, 41 columns, ")


def test_one_ulp_scaled_column_is_caught_above_the_tolerance(golden, tmp_path):
    new = _copy(golden, tmp_path)
    _rewrite(new / "bodies.csv", "coupler.ay [m/s^2]", lambda x: x * (1 + 2.0 ** -52))
    c = compare_dirs(new, golden, rtol=0, atol=0)
    assert c.status == DIFFERS
    assert [(d.table, d.column) for d in c.differences] == [("bodies.csv", "coupler.ay [m/s^2]")]
    d = c.differences[0]
    header, data, _ = read_table(golden / "bodies.csv")
    col = data[:, header.index("coupler.ay [m/s^2]")]
    assert d.count == np.count_nonzero(col) > 30
    assert d.t == read_table(golden / "bodies.csv")[1][d.row - 1, 0]
    # a tolerance of a few ulps passes the same change
    assert compare_dirs(new, golden, rtol=1e-15, atol=0).status == SAME
    r = run_cli("compare", new, golden, "--rtol", "0", "--atol", "0")
    assert r.returncode == 1
    assert r.stdout.splitlines()[0] == "differs: 1 of 41 columns outside rtol 0, atol 0"
    assert r.stdout.splitlines()[1].startswith("  bodies.csv: coupler.ay [m/s^2] at t = ")


def test_worst_difference_names_column_and_time(golden, tmp_path):
    new = _copy(golden, tmp_path)
    t = read_table(golden / "points.csv")[1][:, 0]
    bump = {float(t[7]): 1e-6, float(t[3]): 1e-11}
    _rewrite(new / "points.csv", "P.x [m]", lambda x: x)      # text round trip is exact
    lines = (new / "points.csv").read_text().splitlines()
    for k, line in enumerate(lines[1:], start=1):
        v = line.split(",")
        v[1] = repr(float(v[1]) + bump.get(float(v[0]), 0.0))
        lines[k] = ",".join(v)
    (new / "points.csv").write_text("\n".join(lines) + "\n")
    c = compare_dirs(new, golden)
    assert c.status == DIFFERS and len(c.differences) == 1
    d = c.differences[0]
    assert (d.column, d.row, d.t, d.count) == ("P.x [m]", 8, float(t[7]), 1)


def test_status_change_in_summary_differs(golden, tmp_path):
    new = _copy(golden, tmp_path)
    s = json.loads((new / "summary.json").read_text())
    s["status"] = "failed"
    (new / "summary.json").write_text(json.dumps(s))
    c = compare_dirs(new, golden)
    assert c.status == DIFFERS and c.notes == ["summary.json: status 'failed' (new) vs 'ok' "
                                               "(golden)"]


@pytest.mark.parametrize("damage, message", [
    ("nodir", "no such directory (the new results)"),
    ("table", "different tables (missing in NEW: points.csv)"),
    ("column", "bodies.csv: different columns (columns missing in the new table: "
               "rocker.alpha [deg/s^2])"),
    ("rows", "bodies.csv: different number of rows: 36 new, 37 golden"),
    ("text", "bodies.csv:3: column 'crank.x [m]': 'abc' is not a number"),
    ("short", "bodies.csv:4: 27 values, the header has 28"),
])
def test_unusable_input_exits_2_saying_why(golden, tmp_path, damage, message):
    new = _copy(golden, tmp_path)
    b = new / "bodies.csv"
    lines = b.read_text().splitlines()
    if damage == "nodir":
        shutil.rmtree(new)
    elif damage == "table":
        (new / "points.csv").unlink()
    elif damage == "column":
        b.write_text("\n".join(",".join(x.split(",")[:-1]) for x in lines) + "\n")
    elif damage == "rows":
        b.write_text("\n".join(lines[:-1]) + "\n")
    elif damage == "text":
        v = lines[2].split(",")
        v[1] = "abc"
        lines[2] = ",".join(v)
        b.write_text("\n".join(lines) + "\n")
    elif damage == "short":
        lines[3] = ",".join(lines[3].split(",")[:-1])
        b.write_text("\n".join(lines) + "\n")
    c = compare_dirs(new, golden)
    assert c.status == UNUSABLE
    assert c.error.replace(str(new), "NEW").endswith(message)
    r = run_cli("compare", new, golden)
    assert r.returncode == 2 and r.stderr.startswith("error: cannot compare: ")


def test_nan_equals_nan_and_infinities_must_match(tmp_path):
    for name, col in (("a", "1.0\nnan\ninf\n"), ("b", "1.0\nnan\ninf\n")):
        (tmp_path / name).mkdir()
        (tmp_path / name / "x.csv").write_text("v [m]\n" + col)
    assert compare_dirs(tmp_path / "a", tmp_path / "b", rtol=0, atol=0).status == SAME
    (tmp_path / "b" / "x.csv").write_text("v [m]\n1.0\nnan\n-inf\n")
    c = compare_dirs(tmp_path / "a", tmp_path / "b", rtol=1, atol=1)
    assert c.status == DIFFERS and c.differences[0].row == 3 and c.differences[0].t is None


def test_text_columns_compare_exactly_and_empty_cells_are_nan(tmp_path):
    for name, rows in (("a", ["1,ok,", "2,failed,0.5"]), ("b", ["1,ok,", "2,failed,0.5"])):
        (tmp_path / name).mkdir()
        (tmp_path / name / "sweep.csv").write_text("variant,status,m [m]\n" + "\n".join(rows)
                                                   + "\n")
    assert compare_dirs(tmp_path / "a", tmp_path / "b", rtol=0, atol=0).status == SAME
    (tmp_path / "a" / "sweep.csv").write_text("variant,status,m [m]\n1,ok,\n2,invalid,0.5\n")
    c = compare_dirs(tmp_path / "a", tmp_path / "b")
    assert c.status == DIFFERS
    assert c.differences[0].format() == ("sweep.csv: status at row 2: 'invalid' (new) vs "
                                         "'failed' (golden); 1 value of the column differ")


def test_sweep_parquet_text_columns_compare_like_the_csv(tmp_path):
    """sweep.parquet holds text columns (status, kind, message) beside the numbers: they
    compare exactly, as in sweep.csv, instead of making the table unusable."""
    pa = pytest.importorskip("pyarrow")
    pq = pytest.importorskip("pyarrow.parquet")

    def write(name, status, m):
        (tmp_path / name).mkdir()
        pq.write_table(pa.table({"variant": [1, 2], "status": status, "message": ["", None],
                                 "m [m]": m}), tmp_path / name / "sweep.parquet")
    write("a", ["ok", "failed"], [0.25, None])
    write("b", ["ok", "failed"], [0.25, None])
    assert compare_dirs(tmp_path / "a", tmp_path / "b", rtol=0, atol=0).status == SAME
    header, data, texts = read_table(tmp_path / "a" / "sweep.parquet")
    assert header == ["variant", "status", "message", "m [m]"]
    assert texts[1][0] == ["ok", "failed"] and texts[2][0] == ["", ""]
    assert data[1, 3] != data[1, 3]                       # a missing number is NaN
    shutil.rmtree(tmp_path / "a")
    write("a", ["ok", "invalid"], [0.25, None])
    c = compare_dirs(tmp_path / "a", tmp_path / "b")
    assert c.status == DIFFERS
    assert c.differences[0].format().startswith("sweep.parquet: status at row 2: 'invalid' "
                                                "(new) vs 'failed' (golden)")


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_a_fifo_or_device_is_refused_not_read(golden, tmp_path):
    new = _copy(golden, tmp_path)
    os.mkfifo(new / "extra.csv")                   # the old code blocked in open() for ever
    c = compare_dirs(new, golden)
    assert c.status == UNUSABLE
    assert c.error == f"{new}/extra.csv: not a regular file (a FIFO, device or folder is not read)"
    (new / "extra.csv").unlink()
    (new / "summary.json").unlink()
    (new / "summary.json").symlink_to("/dev/zero")
    c = compare_dirs(new, golden)
    assert c.status == UNUSABLE and c.error.endswith("summary.json: not a regular file (a FIFO, "
                                                     "device or folder is not read)")


def test_folders_without_summaries_say_that_no_status_was_compared(tmp_path):
    for name in ("a", "b"):
        (tmp_path / name).mkdir()
        (tmp_path / name / "x.csv").write_text("v [m]\n1.0\n")
    c = compare_dirs(tmp_path / "a", tmp_path / "b")
    assert report(c, 1e-9, 1e-12) == ["same: 1 tables, 1 columns, 1 values within rtol 1e-09, "
                                      "atol 1e-12; neither directory holds summary.json, so no "
                                      "run status was compared"]
