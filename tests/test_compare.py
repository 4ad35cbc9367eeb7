"""`planarkin compare`: the CI regression gate between two result directories."""

import json
import os
import re
import shutil
import xml.etree.ElementTree as ET

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


# -- two result roots (`run MODEL... --out ROOT`) and the JUnit report -------------------------
JUNIT_XSD = os.path.join(os.path.dirname(__file__), "data", "junit.xsd")
_TIME = re.compile(r"\d+(\.\d+)?")
_CASE_CHILDREN = ("failure", "error", "skipped")


def check_junit(path, tests, failures=0, errors=0, skipped=0):
    """The essential rules of the JUnit XML schema CI systems read (Jenkins, GitLab;
    tests/data/junit.xsd), with xml.etree: testsuites > one testsuite(name, tests, failures,
    errors, skipped, time) > testcase(name, classname, time) > at most one of failure, error,
    skipped (message, one line, and text), then system-out; every count the elements' count,
    every time a number of seconds >= 0. Returns {case name: (kind or None, message)}."""
    root = ET.parse(path).getroot()
    assert root.tag == "testsuites"
    assert set(root.attrib) <= {"name", "time", "tests", "failures", "errors", "disabled"}
    suites = list(root)
    assert [s.tag for s in suites] == ["testsuite"]
    suite = suites[0]
    assert {"name", "tests", "failures", "errors", "skipped", "time"} <= set(suite.attrib)
    assert set(suite.attrib) <= {"name", "tests", "failures", "errors", "skipped", "time",
                                 "disabled", "timestamp", "hostname", "id", "package"}
    cases = list(suite)
    assert {c.tag for c in cases} <= {"testcase"}
    out = {}
    for c in cases:
        assert set(c.attrib) == {"name", "classname", "time"}, c.attrib
        assert c.get("name") and c.get("classname") and _TIME.fullmatch(c.get("time"))
        kids = [k.tag for k in c]
        kinds = [k for k in kids if k in _CASE_CHILDREN]
        assert len(kinds) <= 1 and kids == kinds + ["system-out"] * (len(kids) - len(kinds)), \
            kids
        if kinds:
            e = c.find(kinds[0])
            assert set(e.attrib) == {"message"} and e.get("message").strip()
            assert "\n" not in e.get("message") and (e.text or "").strip()
        assert c.get("name") not in out, "one test case per model"
        out[c.get("name")] = (kinds[0] if kinds else None,
                              c.find(kinds[0]).get("message") if kinds else None)
    counted = {k: sum(1 for v in out.values() if v[0] == k) for k in _CASE_CHILDREN}
    assert (int(suite.get("tests")), int(suite.get("failures")), int(suite.get("errors")),
            int(suite.get("skipped"))) == (len(cases), counted["failure"], counted["error"],
                                           counted["skipped"])
    assert (len(cases), counted["failure"], counted["error"], counted["skipped"]) == \
        (tests, failures, errors, skipped)
    for k in ("tests", "failures", "errors"):
        assert root.get(k) == suite.get(k)
    assert _TIME.fullmatch(suite.get("time")) and _TIME.fullmatch(root.get("time"))
    try:
        import xmlschema
    except ImportError:         # not a dependency: the rules above are what every run checks
        return out
    xmlschema.XMLSchema(JUNIT_XSD).validate(str(path))
    return out


@pytest.fixture(scope="module")
def roots(tmp_path_factory):
    """A golden root of 20 small slider-cranks (m00 ... m19, each its own crank length, 20
    steps, no plots), from one `run`."""
    from clitools import PLAIN_SLIDER_CRANK
    base = tmp_path_factory.mktemp("roots")
    (base / "models").mkdir()
    models = []
    for k in range(20):
        p = base / "models" / f"m{k:02d}.yaml"
        p.write_text(PLAIN_SLIDER_CRANK.replace("  a: 0.1\n", f"  a: {0.1 + 0.002 * k!r}\n"))
        models.append(p)
    r = run_cli("run", *models, "--out", base / "golden", "--no-plots", "--steps", "20")
    assert r.returncode == 0, r.stdout + r.stderr
    return base


def _new_root(roots, tmp_path):
    new = tmp_path / "new"
    shutil.copytree(roots / "golden", new)
    return new


def _lines(r):
    """The per-model lines of a compare of two roots: {model: (word, rest)}, one each."""
    lines = r.stdout.splitlines()
    assert lines[-1].split(" compared: ")[0].endswith("models"), lines[-1]
    out = {}
    for line in lines[:-1]:
        word, _, rest = line.partition(" ")
        name, _, rest = rest.strip().partition(": ")
        assert name not in out, f"two lines for {name}"
        out[name] = (word, rest)
    return out


def test_two_roots_of_20_models_give_one_line_each_and_exit_0(roots, tmp_path):
    new = _new_root(roots, tmp_path)
    r = run_cli("compare", new, roots / "golden", "--rtol", "0", "--atol", "0", "--junit",
                tmp_path / "ci" / "compare.xml")
    assert r.returncode == 0, r.stdout + r.stderr
    lines = _lines(r)
    assert list(lines) == [f"m{k:02d}" for k in range(20)]
    assert {w for w, _ in lines.values()} == {"same"}
    assert lines["m03"][1] == "2 tables, 35 columns, 735 values within rtol 0, atol 0"
    assert r.stdout.splitlines()[-1] == "20 models compared: 20 same"
    cases = check_junit(tmp_path / "ci" / "compare.xml", tests=20)
    assert list(cases) == list(lines) and set(cases.values()) == {(None, None)}
    assert [p.name for p in (tmp_path / "ci").iterdir()] == ["compare.xml"]   # no temporary


def test_two_roots_exit_with_the_worst_and_name_models_missing_on_either_side(roots,
                                                                              tmp_path):
    new = _new_root(roots, tmp_path)
    golden = roots / "golden"
    _rewrite(new / "m04" / "points.csv", "B.x [m]", lambda x: x * (1 + 1e-6))
    shutil.rmtree(new / "m11")                                  # missing in new
    shutil.copytree(new / "m12", new / "m20")                   # missing in golden
    b = new / "m16" / "bodies.csv"                              # unusable
    b.write_text("\n".join(b.read_text().splitlines()[:-1]) + "\n")
    junit = tmp_path / "compare.xml"
    r = run_cli("compare", new, golden, "--junit", junit)
    assert r.returncode == 2, r.stdout + r.stderr
    lines = _lines(r)
    assert list(lines) == [f"m{k:02d}" for k in range(21)]
    words = {m: w for m, (w, _) in lines.items() if w != "same"}
    assert words == {"m04": "differs", "m11": "missing", "m16": "unusable", "m20": "missing"}
    assert lines["m04"][1].startswith("1 of 35 columns outside rtol 1e-09, atol 1e-12; worst: "
                                      "points.csv: B.x [m] at t = ")
    assert lines["m11"][1].startswith(f"missing in {new}/: the model was not run, or its run "
                                      f"found it invalid")
    assert lines["m20"][1].startswith(f"missing in {golden}/: a new model? make its golden "
                                      f"results (planarkin run MODEL --out {golden})")
    assert lines["m16"][1] == "bodies.csv: different number of rows: 20 new, 21 golden"
    assert r.stdout.splitlines()[-1] == ("21 models compared: 17 same, 1 differs, 2 missing, "
                                         "1 unusable")
    cases = check_junit(junit, tests=21, failures=3, errors=1)
    assert cases["m04"] == ("failure", lines["m04"][1])
    assert cases["m11"][0] == cases["m20"][0] == "failure"
    assert cases["m16"] == ("error", "bodies.csv: different number of rows: 20 new, 21 golden")
    text = ET.parse(junit).getroot().find(".//testcase[@name='m04']/failure").text
    assert text.splitlines()[0] == "differs: 1 of 35 columns outside rtol 1e-09, atol 1e-12"
    # the worst of what is left: a difference or a missing model is 1, on either side
    shutil.rmtree(new / "m16")
    shutil.copytree(golden / "m16", new / "m16")
    assert run_cli("compare", new, golden).returncode == 1
    shutil.rmtree(new / "m04")
    shutil.copytree(golden / "m04", new / "m04")
    shutil.rmtree(new / "m20")
    r = run_cli("compare", new, golden)
    assert r.returncode == 1 and r.stdout.splitlines()[-1] == ("20 models compared: 19 same, "
                                                               "1 missing")
    r = run_cli("compare", golden, new)          # the other way round: missing in the other
    assert r.returncode == 1 and _lines(r)["m11"][1].startswith(f"missing in {new}/: a new")


def test_a_run_that_failed_is_said_so_from_its_summary(roots, tmp_path):
    new = _new_root(roots, tmp_path)
    failing = tmp_path / "m07.yaml"                   # the rod as long as the crank
    failing.write_text((roots / "models" / "m07.yaml").read_text().replace("b: 3*a", "b: a"))
    r = run_cli("run", failing, "--out", tmp_path / "f", "--no-plots", "--steps", "20")
    assert r.returncode == 1
    shutil.rmtree(new / "m07")
    shutil.copytree(tmp_path / "f" / "m07", new / "m07")
    r = run_cli("compare", new, roots / "golden")
    assert r.returncode == 1, r.stdout + r.stderr
    word, line = _lines(r)["m07"]
    assert word == "differs"
    assert line.startswith("the new run failed (singular configuration at t = 0.25 s), as its "
                           "summary.json says: its directory holds the rows up to the failure; "
                           "5 rows (new) vs 21 (golden)"), line
    # failed alike on both sides: the same, and said to be the rows up to the failure
    r = run_cli("compare", new, new)
    assert r.returncode == 0
    assert _lines(r)["m07"][1].endswith("; both runs failed (singular configuration at t = "
                                        "0.25 s), as summary.json says: the tables hold the "
                                        "rows up to the failure")


def test_a_root_against_a_model_directory_is_unusable_and_says_what_to_give(roots, tmp_path):
    golden = roots / "golden"
    junit = tmp_path / "j.xml"
    r = run_cli("compare", golden, golden / "m01", "--junit", junit)
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr == (f"error: cannot compare: {golden} holds 20 result directories but "
                        f"{golden}/m01 is one model's result directory: give two roots "
                        f"(planarkin run ... --out ROOT) or two model directories (e.g. "
                        f"{golden}/m01 {golden}/m01)\n")
    assert check_junit(junit, tests=1, errors=1)["golden"][0] == "error"
    # a root and an empty folder: every model missing there
    (tmp_path / "empty").mkdir()
    r = run_cli("compare", golden, tmp_path / "empty")
    assert r.returncode == 1 and r.stdout.splitlines()[-1] == "20 models compared: 0 same, " \
                                                              "20 missing"
    # a folder with neither tables nor result directories: as before, nothing to compare
    r = run_cli("compare", tmp_path / "empty", tmp_path / "empty")
    assert r.returncode == 2 and "no CSV or Parquet tables to compare" in r.stderr


def test_two_model_directories_give_a_one_case_report(golden, tmp_path):
    new = _copy(golden, tmp_path)
    junit = tmp_path / "j.xml"
    r = run_cli("compare", new, golden, "--junit", junit)
    assert r.returncode == 0 and r.stdout.startswith("same: 2 tables, 41 columns, ")
    assert check_junit(junit, tests=1) == {"new": (None, None)}
    _rewrite(new / "bodies.csv", "coupler.ay [m/s^2]", lambda x: x * (1 + 1e-6))
    r = run_cli("compare", new, golden, "--junit", junit)
    assert r.returncode == 1
    kind, message = check_junit(junit, tests=1, failures=1)["new"]
    assert kind == "failure" and message.startswith("1 of 41 columns outside rtol 1e-09, atol "
                                                    "1e-12; worst: bodies.csv: coupler.ay")


@pytest.mark.parametrize("where, message", [
    ("folder", "{p} is a folder: give a file name, e.g. {p}/junit.xml"),
    ("under-file", "{p.parent} is not a folder: choose another path"),
])
def test_a_junit_path_that_cannot_be_written_is_a_usage_error(golden, tmp_path, where,
                                                               message):
    p = tmp_path / "reports"
    if where == "folder":
        p.mkdir()
    else:
        (tmp_path / "file").write_text("")
        p = tmp_path / "file" / "junit.xml"
    r = run_cli("compare", golden, golden, "--junit", p)
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr == f"error: --junit {p}: {message.format(p=p)}\n"


def test_a_junit_write_failure_is_exit_1_one_line_and_leaves_the_file(golden, tmp_path,
                                                                       monkeypatch):
    import errno
    from planarkin.output import junit as junit_module
    junit = tmp_path / "j.xml"
    junit.write_text("earlier")

    def full(*args):
        raise OSError(errno.ENOSPC, "No space left on device")
    monkeypatch.setattr(junit_module.os, "replace", full)
    r = run_cli("compare", golden, golden, "--junit", junit)
    assert r.returncode == 1
    assert r.stderr == (f"error: --junit {junit}: cannot write: No space left on device; "
                        f"{junit} is left as it was\n")
    assert junit.read_text() == "earlier" and sorted(tmp_path.iterdir()) == [junit]


def test_junit_text_is_xml_whatever_the_names_hold(tmp_path):
    """Control characters and undecodable bytes of a name cannot be written in XML 1.0: they
    become U+FFFD, and the file parses."""
    from planarkin.output.junit import Case, write
    write(tmp_path / "j.xml", "planarkin compare",
          [Case("a\x01b\udcff", "planarkin.compare", 0.5, "failure", "x <y> & \"z\"\nnext",
                "text\x00")], 0.5)
    cases = check_junit(tmp_path / "j.xml", tests=1, failures=1)
    assert cases == {"a\ufffdb\ufffd": ("failure", "x <y> & \"z\" next")}
