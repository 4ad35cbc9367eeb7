"""The command line end to end: the installed console script once, then the commands in
process (click's CliRunner)."""

import csv
import os
import json
import subprocess
import sys

import numpy as np
import pytest

from clitools import ROOT, run_cli, run_process

SC = "mechanisms/slider-crank.yaml"


def test_version_and_help():
    r = run_process("--version")                    # the installed console script
    assert r.returncode == 0 and "planarkin" in r.stdout
    r = run_cli("--help")
    assert r.returncode == 0 and "run" in r.stdout and "check" in r.stdout


def test_python_dash_m_works():
    r = subprocess.run([sys.executable, "-m", "planarkin", "--version"], cwd=ROOT,
                       capture_output=True, text=True)
    assert r.returncode == 0


def test_run_writes_tables_summary_and_plots(tmp_path):
    r = run_cli("run", SC, "--out", tmp_path)
    assert r.returncode == 0, r.stderr
    d = tmp_path / "slider-crank"
    for name in ("bodies.csv", "points.csv", "summary.json", "bodies.png", "mechanism.png"):
        assert (d / name).stat().st_size > 0, name
    with open(d / "bodies.csv") as f:
        rows = list(csv.reader(f))
    assert rows[0][:4] == ["t [s]", "crank.x [m]", "crank.y [m]", "crank.phi [rad]"]
    assert rows[0][-1] == "slider.alpha [rad/s^2]"
    assert len(rows) == 362                         # header + steps + 1
    s = json.loads((d / "summary.json").read_text())
    assert s["status"] == "ok" and s["exit_code"] == 0 and s["dof"] == 1
    assert s["time"]["rows_written"] == 361
    assert s["residual"]["max"] < 1e-14
    assert "slider.x [m]" in s["columns"]["bodies.csv"]
    assert "1 model analysed: 1 ok" in r.stdout


def test_csv_is_byte_identical_and_full_precision(tmp_path):
    for k in (1, 2):
        r = run_cli("run", SC, "--out", tmp_path / str(k), "--no-plots", "--steps", "50")
        assert r.returncode == 0
    a = (tmp_path / "1" / "slider-crank" / "bodies.csv").read_bytes()
    b = (tmp_path / "2" / "slider-crank" / "bodies.csv").read_bytes()
    assert a == b
    import planarkin
    res = planarkin.solve(planarkin.load(ROOT / SC), steps=50)
    data = np.loadtxt(tmp_path / "1" / "slider-crank" / "bodies.csv", delimiter=",", skiprows=1)
    np.testing.assert_array_equal(data[:, 19], res.body("slider")["x"])   # bit for bit


def test_options_override_the_model(tmp_path):
    r = run_cli("run", SC, "--out", tmp_path, "--no-plots", "--steps", "10", "--end", "0.5",
                "--up-to", "velocity")
    assert r.returncode == 0, r.stderr
    header = (tmp_path / "slider-crank" / "bodies.csv").read_text().splitlines()[0]
    assert "crank.omega [rad/s]" in header and "alpha" not in header
    lines = (tmp_path / "slider-crank" / "bodies.csv").read_text().splitlines()
    assert len(lines) == 12 and lines[-1].startswith("0.5,")


def test_several_models_worst_exit_status(tmp_path):
    r = run_cli("run", SC, "tests/cases/unknown-body.yaml", "mechanisms/four-bar.yaml",
                "--out", tmp_path, "--no-plots")
    assert r.returncode == 2
    assert "3 models analysed: 2 ok, 1 invalid" in r.stdout
    assert "unknown-body.yaml:7: error:" in r.stderr
    assert (tmp_path / "four-bar" / "bodies.csv").exists()


def test_analysis_failure_exits_1_and_keeps_results(tmp_path):
    text = (ROOT / SC).read_text().replace("b: 3*a", "b: a")     # rod equal to crank
    model = tmp_path / "equal.yaml"
    model.write_text(text)
    r = run_cli("run", model, "--out", tmp_path / "o", "--no-plots")
    assert r.returncode == 1
    assert "singular" in r.stderr and "bifurcation" in r.stderr
    s = json.loads((tmp_path / "o" / "equal" / "summary.json").read_text())
    assert s["status"] == "failed" and s["exit_code"] == 1
    assert abs(s["event"]["t"] - 0.25) < 1e-6
    rows = (tmp_path / "o" / "equal" / "bodies.csv").read_text().splitlines()
    assert 2 < len(rows) < 362 and float(rows[-1].split(",")[0]) <= 0.25


def test_missing_file_and_usage_errors(tmp_path):
    r = run_cli("run", tmp_path / "nope.yaml", "--out", tmp_path)   # (not into the checkout)
    assert r.returncode == 2 and "cannot read file" in r.stderr and "Traceback" not in r.stderr
    r = run_cli("run", SC, "--steps", "0", "--out", tmp_path)
    assert r.returncode == 2
    r = run_cli("frobnicate")
    assert r.returncode == 2


def test_check_reports_dof_and_branches():
    r = run_cli("check", "mechanisms/four-bar.yaml")
    assert r.returncode == 0
    assert "1 DOF" in r.stdout and "coupler+rocker: -" in r.stdout


@pytest.mark.parametrize("fmt", ["svg", "pdf"])
def test_plot_formats(tmp_path, fmt):
    r = run_cli("run", SC, "--out", tmp_path, "--steps", "40", "--format", fmt)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "slider-crank" / f"mechanism.{fmt}").exists()


def test_tradeoff_writes_table_and_plot(tmp_path):
    r = run_cli("tradeoff", "mechanisms/four-bar.yaml", "--out", tmp_path, "--steps", "2000",
                "--repeats", "1")
    assert r.returncode == 0, r.stderr
    rows = (tmp_path / "four-bar" / "tradeoff.csv").read_text().splitlines()
    assert len(rows) >= 5
    errs = []
    for line in rows[1:]:
        fields = line.split(",")
        errs.append(float(fields[-4]))          # position error
    positive = [e for e in errs if e > 0]
    assert max(positive) / min(positive) >= 1e3
    assert (tmp_path / "four-bar" / "tradeoff.png").exists()


@pytest.mark.parametrize("given, expected", [(None, "1"), ("2", "2")])
def test_the_command_runs_openblas_on_one_thread_unless_told(given, expected):
    """OpenBLAS's idle threads spin (0.2 s of CPU in a 360-step run of the four-bar): the
    command sets OPENBLAS_NUM_THREADS=1 before numpy loads, unless the user set it."""
    code = ("import os, sys\n"
            "sys.argv = ['planarkin', '--version']\n"
            "leave = os._exit\n"
            "def report(code):\n"           # the command leaves by os._exit once it is done
            "    print('threads', os.environ['OPENBLAS_NUM_THREADS'], flush=True)\n"
            "    leave(code)\n"
            "os._exit = report\n"
            "from planarkin.__main__ import entry\n"
            "entry()\n")
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    if given is not None:
        env["OPENBLAS_NUM_THREADS"] = given
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                       timeout=60)
    assert r.returncode == 0, r.stderr
    assert f"threads {expected}" in r.stdout


def test_run_junit_has_a_case_per_model_failure_error_and_time(tmp_path):
    """run --junit: a test case per model argument, in order: nothing for an analysis that ran
    to its end, failure for one that failed, error for invalid input; also from run --jobs,
    whose models are reported by their workers."""
    from test_compare import check_junit
    failing = tmp_path / "equal.yaml"
    failing.write_text((ROOT / SC).read_text().replace("b: 3*a", "b: a"))
    models = [SC, "tests/cases/unknown-body.yaml", str(failing), "mechanisms/four-bar.yaml"]
    for jobs in ("1", "2"):
        junit = tmp_path / f"jobs{jobs}" / "run.xml"
        r = run_cli("run", *models, "--out", tmp_path / "o", "--no-plots", "--steps", "20",
                    "--jobs", jobs, "--junit", junit)
        assert r.returncode == 2, r.stdout + r.stderr
        cases = check_junit(junit, tests=4, failures=1, errors=1)
        assert list(cases) == models
        assert cases[SC] == cases["mechanisms/four-bar.yaml"] == (None, None)
        kind, message = cases[str(failing)]
        assert kind == "failure" and message.startswith("singular configuration at t = 0.25 s")
        kind, message = cases["tests/cases/unknown-body.yaml"]
        assert kind == "error" and message.startswith("invalid input: 1 error; tests/cases/"
                                                      "unknown-body.yaml:7: error: ")
        import xml.etree.ElementTree as ET
        root = ET.parse(junit).getroot()
        assert root.find(".//testcase").get("classname") == "planarkin.run"
        assert "-> " in root.find(".//testcase/system-out").text     # its terminal line
        assert [p.name for p in junit.parent.iterdir()] == ["run.xml"]


def test_run_junit_path_checked_before_anything_runs(tmp_path):
    (tmp_path / "file").write_text("")
    r = run_cli("run", SC, "--out", tmp_path / "o", "--junit", tmp_path / "file" / "run.xml")
    assert r.returncode == 2 and r.stdout == "" and "Traceback" not in r.stderr
    assert r.stderr == (f"error: --junit {tmp_path}/file/run.xml: {tmp_path}/file is not a "
                        f"folder: choose another path\n")
    assert not (tmp_path / "o" / "slider-crank").exists()


def test_run_junit_marks_models_an_interruption_never_reached_as_skipped():
    """An interruption stops the batch: the model it stopped is an error, the ones after it
    skipped (planarkin.report.Report.model_entries)."""
    from planarkin.report import Report
    rep = Report(quiet=True)
    rep.ok("a.yaml", "fine")
    rep.interrupted("b.yaml", "SIGTERM", "3 complete rows -> out/b/")
    got = [(e.name, e.outcome) for e in rep.model_entries(["a.yaml", "b.yaml", "c.yaml"])]
    assert got == [("a.yaml", "ok"), ("b.yaml", "interrupted"), ("c.yaml", "skipped")]
    assert rep.model_entries(["c.yaml"])[0].message == ("not analysed: the run was "
                                                        "interrupted by SIGTERM first")
