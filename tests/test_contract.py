"""The output contract (planarkin/output/directory.py), asserted under faults.

After `planarkin run`, a model's directory holds exactly the files of one run and a summary.json
that describes them (status ok, failed or interrupted, rows written), or, for invalid input, the
previous directory untouched. Faults: invalid re-runs, interruptions (SIGINT, SIGTERM) at
moments spread over a run, a full disk (a file-size limit), unwritable and foreign directories,
concurrent runs, colliding and hostile file names. Never a traceback, never a hang, never a
writer process left behind.
"""

import contextlib
import errno
import json
import os
import resource
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

from clitools import PLAIN_SLIDER_CRANK, ROOT, command, run_cli, start_held

from planarkin.output.directory import ResultDirectory, out_dirs, safe_name

SLIDER = Path(tempfile.mkdtemp(prefix="planarkin-contract-")) / "slider-crank.yaml"
SLIDER.write_text(PLAIN_SLIDER_CRANK)
# the slider's guide 1 m above the crank pivot: rod and crank cannot reach it
UNREACHABLE = SLIDER.read_text().replace("{type: translational, i: ground, j: slider, si: [0, 0]",
                                         "{type: translational, i: ground, j: slider, si: [0, 1]")


def _env():
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    env.setdefault("MPLBACKEND", "Agg")
    return env


def assert_contract(d: Path, statuses=("ok",)):
    """d holds one run's files, described by its summary.json; returns the summary."""
    summary = json.loads((d / "summary.json").read_text())
    assert summary["status"] in statuses, summary["status"]
    rows = summary["time"]["rows_written"]
    listed = set(summary["files"]) | set(summary["plots"]) | {"summary.json"}
    assert {p.name for p in d.iterdir()} == listed
    for name, info in summary["files"].items():
        lines = (d / name).read_bytes().split(b"\n")
        assert lines[-1] == b"", f"{name}: last line incomplete"
        body = lines[1:-1]
        assert len(body) == rows == info["rows"], (name, len(body), rows)
        assert all(line.count(b",") == info["columns"] - 1 for line in body[-3:])
    if rows:
        t_last = float((d / "bodies.csv").read_bytes().split(b"\n")[-2].split(b",")[0])
        assert t_last == summary["time"]["last_t"]
    return summary


def no_leftovers(out: Path):
    """No temporaries beside the result directories, and no process still writing there."""
    assert not [p for p in out.iterdir() if ".tmp-" in p.name or ".old-" in p.name
                or p.name.endswith(".lock")]
    deadline = time.time() + 5
    while True:
        alive = []
        for proc in Path("/proc").iterdir():
            if proc.name.isdigit() and proc.name != str(os.getpid()):
                try:
                    if str(out).encode() in (proc / "cmdline").read_bytes():
                        alive.append(proc.name)
                except OSError:
                    pass
        if not alive or time.time() > deadline:
            break
        time.sleep(0.1)
    assert not alive, f"processes still writing into {out}: {alive}"


def test_rerun_of_an_invalid_model_leaves_the_results(tmp_path):
    m = tmp_path / "m.yaml"
    m.write_text(SLIDER.read_text())
    assert run_cli("run", m, "--out", tmp_path / "out", "--no-plots").returncode == 0
    d = tmp_path / "out" / "m"
    before = {p.name: p.read_bytes() for p in d.iterdir()}
    m.write_text(SLIDER.read_text().replace("type: revolute, i: crank", "type: revolute, i: crnk"))
    r = run_cli("run", m, "--out", tmp_path / "out", "--no-plots")
    assert r.returncode == 2 and "unknown body 'crnk'" in r.stderr
    assert {p.name: p.read_bytes() for p in d.iterdir()} == before
    # rejected at assembly (after validation): untouched as well
    m.write_text(UNREACHABLE)
    r = run_cli("run", m, "--out", tmp_path / "out", "--no-plots")
    assert r.returncode == 2 and "cannot assemble" in r.stderr
    assert {p.name: p.read_bytes() for p in d.iterdir()} == before
    no_leftovers(tmp_path / "out")


def test_files_of_an_earlier_version_do_not_survive(tmp_path):
    m = tmp_path / "m.yaml"
    m.write_text(SLIDER.read_text())
    assert run_cli("run", m, "--out", tmp_path, "--steps", "20").returncode == 0
    assert (tmp_path / "m" / "points.csv").exists() and (tmp_path / "m" / "points.png").exists()
    m.write_text(SLIDER.read_text().split("points:")[0] + "analysis: {steps: 10}\n")
    assert run_cli("run", m, "--out", tmp_path, "--no-plots").returncode == 0
    s = assert_contract(tmp_path / "m")
    assert s["time"]["rows_written"] == 11 and not (tmp_path / "m" / "points.csv").exists()
    assert not (tmp_path / "m" / "points.png").exists()


def test_analysis_failure_keeps_the_rows_up_to_it(tmp_path):
    m = tmp_path / "lock.yaml"        # a slider-crank driven by its slider through dead centre
    m.write_text(SLIDER.read_text().replace('{type: angle, body: crank, f: "2*pi*t"}',
                                            '{type: x, i: ground, j: slider, f: "0.35 + 0.1*t"}'))
    r = run_cli("run", m, "--out", tmp_path, "--no-plots")
    assert r.returncode == 1 and "Traceback" not in r.stderr
    s = assert_contract(tmp_path / "lock", ("failed",))
    assert 0 < s["time"]["rows_written"] < 361 and s["time"]["stopped_at"] is not None


@pytest.mark.parametrize("names, expected", [
    (["a/m.yaml", "b/m.yaml", "m-2.yaml"], ["m", "m-3", "m-2"]),
    (["m.yaml", "m.yaml"], ["m", "m-2"]),
    (["x/...yaml", "..", ".", ".hidden.yaml"], ["model", "model-2", "model-3", "hidden"]),
    (["M.yaml", "m.yaml"], ["M", "m-2"]),
    (["a b;c$.yaml", "ü.yaml"], ["a_b_c_", "_"]),
])
def test_output_directories_never_collide(tmp_path, names, expected):
    dirs = out_dirs(names, tmp_path)
    assert [d.name for d in dirs] == expected
    assert all(d.parent == tmp_path for d in dirs)
    assert len({d.name.lower() for d in dirs}) == len(dirs)


def test_many_hostile_names_stay_inside_out():
    stems = ["..", ".", "", "...", "a/../b", "-", "CON", "x" * 300, "a\nb", "m", "m", "M-2",
             "m-2", "m-2", "é", "\x00", "../../etc"]
    dirs = out_dirs([f"{s}.yaml" for s in stems], Path("OUT"))
    assert all(d.parent == Path("OUT") for d in dirs)
    assert len({d.name.lower() for d in dirs}) == len(dirs)
    assert all(safe_name(s) not in ("", ".", "..") and not safe_name(s).startswith(".")
               for s in stems)


def test_same_file_twice_writes_two_complete_directories(tmp_path):
    r = run_cli("run", SLIDER, SLIDER, "--out", tmp_path, "--no-plots", "--steps", "10")
    assert r.returncode == 0, r.stderr
    assert_contract(tmp_path / "slider-crank")
    assert_contract(tmp_path / "slider-crank-2")


def test_concurrent_run_into_the_same_directory_is_refused(tmp_path):
    busy = ResultDirectory(tmp_path / "slider-crank")      # another run holds it
    try:
        r = run_cli("run", SLIDER, "--out", tmp_path, "--no-plots")
        assert r.returncode == 2
        assert "slider-crank/ is being written by another planarkin run" in r.stderr
    finally:
        busy.abandon()
    assert not (tmp_path / "slider-crank").exists()
    assert run_cli("run", SLIDER, "--out", tmp_path, "--no-plots").returncode == 0


def test_a_directory_that_is_not_ours_is_left_alone(tmp_path):
    d = tmp_path / "slider-crank"
    d.mkdir()
    (d / "thesis.tex").write_text("precious")
    r = run_cli("run", SLIDER, "--out", tmp_path, "--no-plots")
    assert r.returncode == 2 and "is not a planarkin result directory" in r.stderr
    assert (d / "thesis.tex").read_text() == "precious" and len(list(d.iterdir())) == 1


def test_unwritable_out_is_a_usage_error(tmp_path):
    f = tmp_path / "file"
    f.write_text("")
    r = run_cli("run", SLIDER, "--out", f / "sub", "--no-plots")
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert r.stderr == f"error: --out {f / 'sub'}: {f} is a file, not a directory: remove it " \
                       f"or choose another --out\n", r.stderr
    if os.geteuid() != 0:          # root writes anywhere; a read-only directory needs a user
        ro = tmp_path / "ro"
        ro.mkdir(mode=0o500)
        r = run_cli("run", SLIDER, "--out", ro, "--no-plots")
        assert r.returncode == 2


def test_full_disk_leaves_the_previous_results(tmp_path):
    out = tmp_path / "out"
    assert run_cli("run", SLIDER, "--out", out, "--no-plots", "--steps", "10").returncode == 0
    before = (out / "slider-crank" / "bodies.csv").read_bytes()

    def small_files():                # every file the run writes is cut at 100 kB
        resource.setrlimit(resource.RLIMIT_FSIZE, (100_000, 100_000))
    r = subprocess.run(command() + ["run", str(SLIDER), "--out", str(out), "--no-plots",
                                    "--steps", "20000"], capture_output=True, text=True,
                       timeout=120, env=_env(), preexec_fn=small_files)
    assert r.returncode == 1, r.stderr
    assert "Traceback" not in r.stderr and "File too large" in r.stderr
    assert "is left as it was" in r.stderr
    assert (out / "slider-crank" / "bodies.csv").read_bytes() == before
    assert_contract(out / "slider-crank")
    no_leftovers(out)


ENTRY = command()                               # the `planarkin` command itself

# moments of a run, each held (tests/hold/sitecustomize.py) until the signal arrives: starting
# (modules loading), preparing (no new directory yet), the first block of rows solved but not
# written, that block in the tables, every row in them before they close
STEPS = 20000                                   # more rows than one block (8,192)
MOMENTS = [("starting", signal.SIGINT), ("prepare:*", signal.SIGTERM),
           ("opened:*", signal.SIGINT), ("rows:*", signal.SIGTERM), ("rows:*", signal.SIGINT),
           ("finish:*", signal.SIGTERM)]


@pytest.mark.parametrize("moment, sig", MOMENTS, ids=[f"{m.split(':')[0]}-{s.name}"
                                                      for m, s in MOMENTS])
def test_interruption_keeps_a_consistent_directory(tmp_path, moment, sig):
    """A run interrupted at every moment: exit 130/143 and no traceback; before the new
    directory the earlier results stay byte for byte, after it the directory says interrupted
    and holds the complete rows (none, a block, or all of them)."""
    out = tmp_path / "out"
    assert run_cli("run", SLIDER, "--out", out, "--no-plots", "--steps", "10").returncode == 0
    before = {f.name: f.read_bytes() for f in (out / "slider-crank").iterdir()}
    p = start_held(["run", SLIDER, "--out", out, "--no-plots", "--steps", STEPS], moment,
                   tmp_path / "ready")
    p.send_signal(sig)
    try:
        stdout, stderr = p.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        p.kill()
        pytest.fail("planarkin hung after the signal")
    assert "Traceback" not in stderr, stderr
    code = {signal.SIGINT: 130, signal.SIGTERM: 143}[sig]
    assert p.returncode == code, (p.returncode, stdout, stderr)
    assert "interrupted" in stdout, stdout
    if moment in ("starting", "prepare:*"):
        assert {f.name: f.read_bytes() for f in (out / "slider-crank").iterdir()} == before
        assert_contract(out / "slider-crank")
    else:
        s = assert_contract(out / "slider-crank", ("interrupted",))
        assert s["exit_code"] == code
        rows = s["time"]["rows_written"]
        assert rows == {"opened:*": 0, "rows:*": 8192, "finish:*": STEPS + 1}[moment], rows
    no_leftovers(out)


def test_a_signal_as_the_new_directory_is_staged_leaves_nothing_behind(tmp_path):
    """A signal between the writer's staging of the new directory and the run's first row: the
    staged directory and its lock used to be left behind (the window is a few bytecodes; the
    hook holds the run in it)."""
    out = tmp_path / "out"
    p = start_held(["run", SLIDER, "--out", out, "--no-plots", "--steps", "100"], "staged:*",
                   tmp_path / "ready")
    p.send_signal(signal.SIGTERM)
    stdout, stderr = p.communicate(timeout=60)
    assert p.returncode == 143 and "Traceback" not in stderr, (p.returncode, stdout, stderr)
    no_leftovers(out)


def test_batch_of_rejected_models_releases_everything(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(UNREACHABLE)
    files = [bad, SLIDER] * 12

    def few_files():
        resource.setrlimit(resource.RLIMIT_NOFILE, (48, 48))
    r = subprocess.run(command() + ["run", *map(str, files), "--out", str(tmp_path / "o"),
                                    "--no-plots", "--steps", "5", "-q"],
                       capture_output=True, text=True, timeout=300, env=_env(),
                       preexec_fn=few_files)
    assert "Too many open files" not in r.stderr and "Traceback" not in r.stderr
    assert r.returncode == 2
    assert r.stdout.strip().splitlines()[-1] == "24 models analysed: 12 ok, 12 invalid"
    no_leftovers(tmp_path / "o")


def test_two_real_runs_into_one_directory(tmp_path):
    """A second run into the directory a first one is writing (held after its first rows) is
    refused; the first then ends as if alone: never an interleaved table."""
    args = ["run", SLIDER, "--out", tmp_path / "out", "--no-plots", "--steps", STEPS]
    first = start_held(args, "rows:*", tmp_path / "ready")
    second = subprocess.run(ENTRY + [str(a) for a in args], capture_output=True, text=True,
                            env=_env(), timeout=120)
    assert second.returncode == 2, (second.stdout, second.stderr)
    assert "is being written by another planarkin run" in second.stderr, second.stderr
    for f in (tmp_path / "ready").iterdir():
        f.unlink()                                      # the first run goes on
    stdout, stderr = first.communicate(timeout=120)
    assert first.returncode == 0, (stdout, stderr)
    s = assert_contract(tmp_path / "out" / "slider-crank")
    assert s["time"]["rows_written"] == STEPS + 1
    no_leftovers(tmp_path / "out")


def test_killed_run_leaves_no_writer_behind(tmp_path):
    p = start_held(["run", SLIDER, "--out", tmp_path / "out", "--no-plots", "--steps", STEPS],
                   "rows:*", tmp_path / "ready")
    p.send_signal(signal.SIGKILL)
    try:
        p.communicate(timeout=20)
    except subprocess.TimeoutExpired:
        pytest.fail("the writers of a killed run kept its stdout open")
    assert p.returncode == -signal.SIGKILL
    assert list((tmp_path / "out").glob(".slider-crank.tmp-*/bodies.csv"))    # killed writing
    r = run_cli("run", SLIDER, "--out", tmp_path / "out", "--no-plots", "--steps", "5")
    assert r.returncode == 0, r.stderr
    no_leftovers(tmp_path / "out")


@pytest.mark.parametrize("sig, group", [(signal.SIGINT, True), (signal.SIGTERM, False)],
                         ids=["SIGINT-to-the-group", "SIGTERM-to-the-parent"])
def test_interrupted_parallel_batch_reports_what_is_on_disk(tmp_path, sig, group):
    """`run --jobs 2` stopped by a Ctrl-C (every process of the group gets it) or by a signal
    to the parent alone (a CI runner's SIGTERM) while both workers write a model's rows: the
    workers stop in order, the models not started are not started, every model's line is
    printed and counted, and each directory on disk says it was interrupted."""
    models = []
    for k in range(6):
        m = tmp_path / f"m{k}.yaml"
        m.write_text(SLIDER.read_text())
        models.append(str(m))
    out = tmp_path / "out"
    p = start_held(["run", *models, "--jobs", "2", "--out", out, "--no-plots", "--steps",
                    STEPS], "rows:*", tmp_path / "ready", count=2, start_new_session=True)
    if group:
        os.killpg(p.pid, sig)
    else:
        p.send_signal(sig)
    try:
        stdout, stderr = p.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        p.kill()
        pytest.fail("planarkin run --jobs hung after the signal")
    assert "Traceback" not in stderr, stderr
    assert p.returncode == {signal.SIGINT: 130, signal.SIGTERM: 143}[sig], (stdout, stderr)
    done = sorted(d.name for d in out.iterdir() if d.is_dir() and not d.name.startswith("."))
    assert done == ["m0", "m1"], (done, stdout)             # the later models never started
    for d in done:
        s = assert_contract(out / d, ("interrupted",))
        assert s["time"]["rows_written"] == 8192
        assert f"{d}.yaml" in stdout, (d, stdout)           # every model on disk has its line
    last = stdout.strip().splitlines()[-1]
    assert "0 ok" in last and f"interrupted by {sig.name}" in last, stdout
    no_leftovers(out)


SIGNAL_AS_THE_LINE_IS_PRINTED = """
import os, signal, sys
from planarkin import run
report_line = run.report_line
def conclude(*args, **kwargs):
    os.kill(os.getpid(), signal.SIGTERM)     # the directory is in place, its line not printed
    return report_line(*args, **kwargs)
run.report_line = conclude
from planarkin.__main__ import entry
sys.argv = ["planarkin"] + sys.argv[1:]
entry()
"""


@pytest.mark.parametrize("plots", [["--no-plots"], []], ids=["no-plots", "plots"])
def test_a_directory_in_place_always_has_its_line(tmp_path, plots):
    """A signal that arrives as a model's directory has been put in place, before its report
    line is printed, waits for the line: never a directory in place that the terminal (and the
    count) does not mention."""
    out = tmp_path / "out"
    r = subprocess.run([sys.executable, "-c", SIGNAL_AS_THE_LINE_IS_PRINTED, "run",
                        str(ROOT / "mechanisms" / "slider-crank.yaml"), "--steps", "40", "--out",
                        str(out), *plots], capture_output=True, text=True, env=_env(), cwd=ROOT,
                       timeout=120)
    assert "Traceback" not in r.stderr, r.stderr
    assert r.returncode == 143, (r.stdout, r.stderr)
    assert json.loads((out / "slider-crank" / "summary.json").read_text())["status"] == "ok"
    assert any(ln.startswith("ok ") and "slider-crank.yaml" in ln
               for ln in r.stdout.splitlines()), r.stdout
    assert "1 ok" in r.stdout, r.stdout


_IN_FINALIZER = r"""
import os, signal, sys, time
from planarkin.output.directory import Interrupted, checkpoint, interruptible

class Slow:
    def __del__(self):                  # the signal arrives while a finalizer runs
        os.kill(os.getpid(), int(sys.argv[1]))
        t = time.time() + 0.05
        while time.time() < t:
            pass

try:
    with interruptible():
        Slow()                          # collected at once: __del__ runs here
        t = time.time() + 5
        while time.time() < t:          # the run goes on ... until its next block of rows
            time.sleep(0.001)
            checkpoint()                # (what DirectoryWriter.add does for every chunk)
        print("not interrupted")
except KeyboardInterrupt as e:
    print("interrupted", type(e).__name__, e.signame)
"""


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_a_signal_during_a_finalizer_still_stops_the_run(sig):
    # raised inside a __del__ (the garbage collector's) the exception would be printed as
    # "Exception ignored in ... __del__" with a traceback and dropped, and the run would go on:
    # the handler leaves it to the next checkpoint between blocks of rows
    r = subprocess.run([sys.executable, "-c", _IN_FINALIZER, str(int(sig))],
                       capture_output=True, text=True, timeout=60)
    assert r.stdout == f"interrupted Interrupted {sig.name}\n" and r.stderr == "", (r.stdout,
                                                                                    r.stderr)


_SHUTDOWN = r"""
import atexit, os, signal, sys, threading, time
import planarkin.__main__ as entry_point
import planarkin.cli as cli

def done():                             # a command that finished, then a slow shutdown
    atexit.register(time.sleep, 0.6)
    threading.Timer(0.3, os.kill, (os.getpid(), signal.SIGTERM)).start()
    sys.exit(0)

cli.main = done
sys.argv = ["planarkin", "--version"]
entry_point.entry()
"""


def test_a_signal_during_shutdown_leaves_a_finished_command_its_status():
    # after the command's work (files in place, processes joined) the interpreter shuts down;
    # a signal then met the start-up handler or, once Python had reset it, the default one,
    # and a finished run ended killed (-15: an intermittent failure of the test above)
    r = subprocess.run([sys.executable, "-c", _SHUTDOWN], capture_output=True, text=True,
                       timeout=60)
    assert r.returncode == 0 and r.stdout == "" and r.stderr == "", (r.returncode, r.stdout,
                                                                     r.stderr)


# -- issue 18: the five failures of the old process model ----------------------------------------

def _wait_for(pattern_dir: Path, pattern: str, p, seconds=60):
    deadline = time.time() + seconds
    while not list(pattern_dir.glob(pattern)) and p.poll() is None and time.time() < deadline:
        time.sleep(0.002)
    assert p.poll() is None, f"the run ended before {pattern} appeared: {p.communicate()}"


def test_sigterm_to_the_process_group_of_a_plotting_run(tmp_path):
    """What a CI timeout, systemd or `docker stop` sends: SIGTERM to every process of the
    group, here while the default four-bar run draws its plots (the first figure is on disk).
    Exit 143, no traceback (the plot server used to print one), a consistent directory that
    says it was interrupted."""
    out = tmp_path / "out"
    p = start_held(["run", ROOT / "mechanisms" / "four-bar.yaml", "--out", out],
                   "figure:four-bar:bodies.png", tmp_path / "ready", start_new_session=True)
    os.killpg(p.pid, signal.SIGTERM)
    try:
        stdout, stderr = p.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        pytest.fail("planarkin hung after the signal")
    assert "Traceback" not in stderr and "Error" not in stderr, stderr
    assert p.returncode == 143, (p.returncode, stdout, stderr)
    s = assert_contract(out / "four-bar", ("interrupted",))
    assert s["exit_code"] == 143 and s["time"]["rows_written"] == 361 and s["plots"] == []
    no_leftovers(out)


SWEEP = ["sweep", str(ROOT / "mechanisms" / "four-bar.yaml"), "--vary", "a=0.03:0.05:4",
         "--metric", "max:rocker.phi", "--steps", "24", "--jobs", "1"]


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_an_interrupted_sweep_leaves_no_staged_tables(tmp_path, sig):
    """Interrupted while its files are staged (sweep.csv written, the plot about to be drawn):
    exit 130/143, one line, and neither a temporary nor a lock file is left (they used to pile
    up in the result directory); the earlier sweep's files are as they were."""
    out = tmp_path / "out"
    assert run_cli(*SWEEP, "--out", out).returncode == 0
    d = out / "four-bar"
    before = {f.name: f.read_bytes() for f in d.iterdir()}
    p = start_held(SWEEP[:3] + ["a=0.03:0.05:5"] + SWEEP[4:] + ["--out", out], "sweep-plot",
                   tmp_path / "ready")
    assert list(d.glob(".tmp-*-sweep.csv"))                 # staged when the signal comes
    p.send_signal(sig)
    stdout, stderr = p.communicate(timeout=60)
    assert p.returncode == 128 + sig, (p.returncode, stdout, stderr)
    assert "Traceback" not in stderr, stderr
    assert stdout.startswith("interrupted "), stdout
    assert {f.name: f.read_bytes() for f in d.iterdir()} == before
    no_leftovers(out)


def test_run_and_the_studies_keep_each_others_files(tmp_path):
    """A model's directory is shared: `run` owns its tables, plots and summary.json, the
    studies own theirs (output.directory.STUDY_FILES). run after sweep used to delete
    sweep.csv, tolerance.csv and samples.csv; sweep before run made run refuse the
    directory."""
    from click.testing import CliRunner

    from planarkin.cli import main
    fb = str(ROOT / "mechanisms" / "four-bar.yaml")
    run = ["run", fb, "--steps", "24", "--no-plots", "--out", str(tmp_path)]
    tol = ["tolerance", fb, "--sigma", "a=1e-4", "--samples", "4", "--steps", "24", "--jobs",
           "1", "--no-plots", "--out", str(tmp_path)]
    d = tmp_path / "four-bar"
    # sweep then run
    assert CliRunner().invoke(main, SWEEP + ["--out", str(tmp_path)]).exit_code == 0
    assert CliRunner().invoke(main, tol).exit_code == 0
    studies = {f.name: f.read_bytes() for f in d.iterdir()}
    assert {"sweep.csv", "sweep.png", "tolerance.csv", "samples.csv"} <= set(studies)
    r = CliRunner().invoke(main, run)
    assert r.exit_code == 0, r.output
    s = json.loads((d / "summary.json").read_text())
    names = {f.name for f in d.iterdir()}
    assert names == set(s["files"]) | set(s["plots"]) | {"summary.json"} | set(studies)
    assert {n: (d / n).read_bytes() for n in studies} == studies
    # run again, then the studies again: each replaces its own files only
    run_files = {n: (d / n).read_bytes() for n in names - set(studies)}
    assert CliRunner().invoke(main, SWEEP[:3] + ["a=0.03:0.05:3"] + SWEEP[4:]
                              + ["--out", str(tmp_path)]).exit_code == 0
    assert {n: (d / n).read_bytes() for n in run_files} == run_files
    assert (d / "sweep.csv").read_bytes() != studies["sweep.csv"]
    assert (d / "tolerance.csv").read_bytes() == studies["tolerance.csv"]
    assert_contract_ignoring_studies(d)
    no_leftovers(tmp_path)


def assert_contract_ignoring_studies(d: Path):
    from planarkin.output.directory import STUDY_FILES
    s = json.loads((d / "summary.json").read_text())
    assert {p.name for p in d.iterdir()} - STUDY_FILES == \
        set(s["files"]) | set(s["plots"]) | {"summary.json"}


def test_no_lock_file_is_left_beside_the_results(tmp_path):
    """After any run (ok, failed, invalid, refused as busy, a study) nothing hidden is left
    beside the result directories: the lock exists only while a run writes."""
    from click.testing import CliRunner

    from planarkin.cli import main
    from planarkin.output.directory import ResultDirectory
    lock = tmp_path / "lock.yaml"
    lock.write_text(SLIDER.read_text().replace('{type: angle, body: crank, f: "2*pi*t"}',
                                               '{type: x, i: ground, j: slider, '
                                               'f: "0.35 + 0.1*t"}'))
    bad = tmp_path / "bad.yaml"
    bad.write_text(UNREACHABLE)
    r = CliRunner().invoke(main, ["run", str(SLIDER), str(lock), str(bad), "--no-plots",
                                  "--steps", "40", "--out", str(tmp_path / "out")])
    assert r.exit_code == 2, r.output
    busy = ResultDirectory(tmp_path / "out" / "slider-crank")
    try:
        assert CliRunner().invoke(main, ["run", str(SLIDER), "--no-plots", "--out",
                                         str(tmp_path / "out")]).exit_code == 2
    finally:
        busy.abandon()
    assert CliRunner().invoke(main, SWEEP + ["--out", str(tmp_path / "out")]).exit_code == 0
    hidden = [p.name for p in (tmp_path / "out").iterdir() if p.name.startswith(".")]
    assert hidden == []
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["four-bar", "lock",
                                                                     "slider-crank"]


# -- issue 33: a full disk, an --out that cannot be, the compiled code's cache ------------------

def _no_space(*args, **kwargs):
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


STUDY_ARGS = {
    "sweep": ["sweep", str(ROOT / "mechanisms" / "four-bar.yaml"), "--vary", "a=0.03:0.05:3",
              "--steps", "24", "--jobs", "1"],
    "tolerance": ["tolerance", str(ROOT / "mechanisms" / "four-bar.yaml"), "--sigma", "a=1e-4",
                  "--samples", "3", "--steps", "24", "--jobs", "1"]}


@pytest.mark.parametrize("command, patch, name", [
    ("sweep", "planarkin.studies.sweep.write_csv", "sweep.csv"),
    ("sweep", "planarkin.studies.plots.sweep_plot", "sweep.png"),
    ("tolerance", "planarkin.studies.tolerance.write_csv", "tolerance.csv"),
    ("tolerance", "planarkin.output.tables.CsvWriter.write", "sensitivities.csv"),
    ("tolerance", "planarkin.studies.plots.tolerance_plot", "tolerance.png")])
def test_a_full_disk_fails_a_study_in_one_line(tmp_path, monkeypatch, command, patch, name):
    """Any of a study's writes on a full disk: an OSError traceback (exit 1). Now exit 1 and
    one line naming the file, the earlier files as they were, nothing else left behind."""
    out = tmp_path / "out"
    assert run_cli(*STUDY_ARGS[command], "--out", out).returncode == 0
    d = out / "four-bar"
    before = {f.name: f.read_bytes() for f in d.iterdir()}
    monkeypatch.setattr(patch, _no_space)
    r = run_cli(*STUDY_ARGS[command], "--out", out)
    assert r.returncode == 1, (r.stdout, r.stderr)
    assert r.stderr == (f"{STUDY_ARGS[command][1]}: error: writing {name} failed: No space left "
                        f"on device; the earlier files in {d}/ are left as they were\n"), r.stderr
    assert {f.name: f.read_bytes() for f in d.iterdir()} == before
    no_leftovers(out)


@pytest.mark.parametrize("command", ["sweep", "tolerance"])
def test_a_file_size_limit_fails_a_study_in_one_line(tmp_path, command):
    """`ulimit -f` (here 1 kB: each study's first table passes it) in a real process (run:
    test_full_disk_leaves_the_previous_results)."""
    def small_files():
        resource.setrlimit(resource.RLIMIT_FSIZE, (1000, 1000))
    r = subprocess.run(ENTRY + STUDY_ARGS[command] + ["--out", str(tmp_path / "out")],
                       capture_output=True, text=True, timeout=120, env=_env(),
                       preexec_fn=small_files)
    assert r.returncode == 1, (r.stdout, r.stderr)
    assert "Traceback" not in r.stderr and r.stderr.count("\n") == 1, r.stderr
    assert ": error: writing " in r.stderr and " failed: File too large" in r.stderr, r.stderr
    no_leftovers(tmp_path / "out")


@pytest.mark.parametrize("moment", ["summary", "plots", "staging", "--out"])
def test_a_full_disk_fails_a_run_in_one_line(tmp_path, monkeypatch, moment):
    """summary.json, the plots, the staged directory, --out itself on a full disk: an
    internal error (please report), a usage error (exit 2) or a mere warning (exit 0). Now
    exit 1, one line, the earlier results as they were."""
    from pathlib import Path as P
    out = tmp_path / "out"
    assert run_cli("run", SLIDER, "--out", out, "--steps", "10", "--no-plots").returncode == 0
    d = out / "slider-crank"
    before = {f.name: f.read_bytes() for f in d.iterdir()}
    if moment == "summary":
        monkeypatch.setattr("planarkin.output.writer.write_json", _no_space)
    elif moment == "plots":
        monkeypatch.setattr("planarkin.output.plots.write_plots", _no_space)
    else:
        mkdir = P.mkdir
        full = ".tmp-" if moment == "staging" else ".planarkin-probe"

        def no_space(self, *a, **k):
            if full in self.name:
                _no_space()
            return mkdir(self, *a, **k)
        monkeypatch.setattr(P, "mkdir", no_space)
    r = run_cli("run", SLIDER, "--out", out, "--steps", "20",
                *(["--no-plots"] if moment != "plots" else []))
    assert r.returncode == 1, (r.stdout, r.stderr)
    what = {"summary": "writing summary.json failed: No space left on device",
            "plots": "writing the plots failed: No space left on device",
            "staging": f"cannot write into {out}/: No space left on device"}
    if moment == "--out":
        assert r.stderr == f"error: --out {out}: cannot write into {out}/: No space left on " \
                           f"device\n", r.stderr
    else:
        assert r.stderr == f"{SLIDER}: error: {what[moment]}; {d}/ is left as it was\n", r.stderr
    assert {f.name: f.read_bytes() for f in d.iterdir()} == before
    monkeypatch.undo()
    no_leftovers(out)


@pytest.mark.parametrize("command", ["run", "sweep", "tolerance"])
def test_an_out_that_is_a_link_to_nowhere_is_a_usage_error(tmp_path, command):
    """--out a dangling symbolic link: "File exists" (run) or a traceback (the studies)."""
    link = tmp_path / "results"
    link.symlink_to(tmp_path / "gone")
    args = STUDY_ARGS.get(command, ["run", str(SLIDER), "--steps", "10"])
    r = run_cli(*args, "--no-plots", "--out", link)
    assert r.returncode == 2, (r.stdout, r.stderr)
    assert r.stderr == (f"error: --out {link}: {link} is a symbolic link to {tmp_path / 'gone'}, "
                        f"which does not exist: create {tmp_path / 'gone'} or remove the link, "
                        f"or choose another --out\n"), r.stderr
    assert link.is_symlink() and not (tmp_path / "gone").exists()


@pytest.mark.parametrize("command", ["run", "sweep", "tolerance"])
def test_a_model_directory_that_is_a_link_to_nowhere_is_left_alone(tmp_path, command):
    """The model's directory in --out a dangling link: "internal error during the analysis:
    NotADirectoryError ... (please report)", exit 1 (run), a FileExistsError traceback (the
    studies)."""
    out = tmp_path / "out"
    out.mkdir()
    name = "slider-crank" if command == "run" else "four-bar"
    (out / name).symlink_to(tmp_path / "gone")
    args = STUDY_ARGS.get(command, ["run", str(SLIDER), "--steps", "10"])
    r = run_cli(*args, "--no-plots", "--out", out)
    assert r.returncode == 2, (r.stdout, r.stderr)
    assert r.stderr == (f"{args[1]}: error: {out / name} is a symbolic link to "
                        f"{tmp_path / 'gone'}, which does not exist: create {tmp_path / 'gone'} "
                        f"or remove the link, or choose another --out\n"), r.stderr
    assert (out / name).is_symlink() and not (tmp_path / "gone").exists()
    no_leftovers(out)


@pytest.fixture
def own_cache(monkeypatch, tmp_path):
    """planarkin.solver.compiled.jitcache as in a new process, its directory under tmp_path (this process's
    state put back after)."""
    numba = pytest.importorskip("numba")
    from planarkin.solver.compiled import jitcache
    saved = dict(jitcache._held)
    jitcache.forget()
    monkeypatch.setattr(jitcache, "_said", set())
    monkeypatch.setenv("PLANARKIN_CACHE", str(tmp_path / "cache"))
    monkeypatch.setenv("NUMBA_CACHE_DIR", os.environ.get("NUMBA_CACHE_DIR", ""))
    monkeypatch.setattr(numba.config, "CACHE_DIR", numba.config.CACHE_DIR)
    yield tmp_path / "cache"
    jitcache.forget()
    jitcache._held.update(saved)


def _hold_cache_lock(cache: Path):
    """The cache entry's lock, held here as another process would (its pid in the file)."""
    import fcntl

    from planarkin.solver.compiled import jitcache
    entry = cache / jitcache.tag()
    entry.mkdir(parents=True, mode=0o700)
    cache.chmod(0o700)
    lock = open(entry / ".lock", "a+")
    fcntl.flock(lock, fcntl.LOCK_EX)
    lock.write("4242")
    lock.flush()
    return lock


def test_a_cache_held_by_another_process_is_given_up_in_one_line(own_cache, monkeypatch,
                                                                 capsys):
    """A run suspended (Ctrl-Z) during its first compile held the lock, and every other run of
    300,000 points or more waited for it, silently, for as long. Now LOCK_WAIT s, then one
    line, and the process compiles without the cache."""
    from planarkin.solver.compiled import jitcache
    monkeypatch.setattr(jitcache, "LOCK_WAIT", 0.2)
    lock = _hold_cache_lock(own_cache)
    try:
        assert jitcache.prepare() is None
        assert jitcache.prepare() is None           # once given up, for the whole process
        jitcache.record()
    finally:
        lock.close()
    assert capsys.readouterr().err == (f"planarkin: the compiled code's cache "
                                       f"{own_cache / jitcache.tag()} is held by another "
                                       f"planarkin process (pid 4242) for more than 0.2 s "
                                       f"(suspended?): compiling without the cache\n")


def test_a_run_goes_on_while_another_holds_the_cache(tmp_path):
    """The real thing: a run of 300,000 points (the compiled route) while the test holds the
    lock; it says so and finishes. The timeout is a hang guard only. (The one-body crank of the
    cache's tests: the lock is the subject, and its kernel compiles in half the time.)"""
    pytest.importorskip("numba")
    from planarkin.solver.compiled import jitcache
    cache = tmp_path / "cache"
    lock = _hold_cache_lock(cache)
    try:
        r = subprocess.run(ENTRY + ["run", str(ROOT / "tests" / "data" / "crank.yaml"),
                                    "--steps", "300000", "--no-plots",
                                    "--out", str(tmp_path / "out"), "-q"],
                           capture_output=True, text=True, timeout=300,
                           env=dict(_env(), PLANARKIN_CACHE=str(cache)))
    finally:
        lock.close()
    assert r.returncode == 0, (r.stdout, r.stderr)
    assert r.stderr == (f"planarkin: the compiled code's cache {cache / jitcache.tag()} is held "
                        f"by another planarkin process (pid 4242) for more than 5 s "
                        f"(suspended?): compiling without the cache\n"), r.stderr
    s = assert_contract(tmp_path / "out" / "crank")
    assert s["time"]["rows_written"] == 300001
    assert sorted(p.name for p in (cache / jitcache.tag()).iterdir()) == [".lock"]


def test_a_cache_that_cannot_be_written_costs_only_the_caching(own_cache, monkeypatch,
                                                               capsys):
    """numba's save on a full disk (an OSError out of the compile) aborted the run. Now the
    compiled code is used from memory, one line says so, and later compiles skip the cache."""
    from numba.core import caching

    from planarkin.solver.compiled import kernels as compiled_grid, jitcache
    monkeypatch.setattr(caching.IndexDataCacheFile, "_save_data", _no_space)
    text = ("import numba\n\n\n@numba.njit(cache=CACHE)\ndef grid(x):\n    return x + 1\n")
    import numba
    fn = compiled_grid._build("pk_grid_issue33_full", text, "grid", (numba.int64,))
    assert fn(41) == 42
    entry = own_cache / jitcache.tag()
    assert capsys.readouterr().err == (f"planarkin: the compiled code's cache {entry} cannot be "
                                       f"written (No space left on device): compiling without "
                                       f"it (the results are the same)\n")
    assert jitcache.prepare() is None               # the rest of the process: no cache

    @numba.njit(cache=True)
    def twice(x):
        return 2 * x
    jitcache.compile_cached(twice, (numba.int64,))         # not under the lock: no cache at all
    assert twice(21) == 42 and capsys.readouterr().err == ""


def test_a_kernel_numba_cannot_load_compiles_outside_the_entrys_lock(own_cache, monkeypatch):
    """A kernel whose numba index is in the entry but cannot be loaded (its data file gone: a
    garbled one the check deleted, or written by another numba version or for another CPU) was
    compiled under the entry's lock, for seconds, while every other process gave up on the cache
    after LOCK_WAIT with a line on stderr. It compiles under its own lock, in a staging
    directory (jitcache.compiling), and is published again."""
    import numba

    from planarkin.solver.compiled import kernels as compiled_grid, jitcache
    text = "import numba\n\n\n@numba.njit(cache=CACHE)\ndef grid(x):\n    return x + 1\n"
    entry = own_cache / jitcache.tag()
    assert compiled_grid._build("pk_grid_stale", text, "grid", (numba.int64,))(41) == 42
    (data,) = entry.rglob("pk_grid_stale.grid-*.nbc")
    data.unlink()                              # the index stays: jitcache.has() finds it
    assert jitcache.has(entry, entry / "gen" / "pk_grid_stale.py", "grid")
    staged = []
    real = jitcache.compiling

    @contextlib.contextmanager
    def compiling(name):
        with real(name) as stage:
            staged.append(("lock held" if "lock" in jitcache._held else "free", name))
            yield stage
    monkeypatch.setattr(jitcache, "compiling", compiling)
    assert compiled_grid._build("pk_grid_stale", text, "grid", (numba.int64,))(41) == 42
    assert staged == [("free", "pk_grid_stale")]
    assert len(list(entry.rglob("pk_grid_stale.grid-*.nbc"))) == 1     # published again


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="no /proc: a stopped "
                    "holder is not seen, KERNEL_WAIT bounds the wait")
def test_a_kernel_lock_held_by_a_stopped_process_is_not_waited_for(own_cache, monkeypatch):
    """A process compiling a kernel and then stopped (Ctrl-Z) holds the kernel's lock as long
    as it stays stopped: another process needing the same kernel waited KERNEL_WAIT (300 s)
    without a word. Now it stops waiting as soon as it sees the holder stopped (its pid in the
    lock file, its state in /proc) and compiles the kernel itself; a holder that runs is waited
    for. The waits are counted in polls, not timed."""
    from planarkin.solver.compiled import jitcache
    own_cache.mkdir(mode=0o700)
    path = own_cache / f".{jitcache.tag()}.pk_grid_z.lock"
    holder = subprocess.Popen(
        [sys.executable, "-c", "import fcntl, os, sys, time\n"
         "f = open(sys.argv[1], 'a+')\nfcntl.flock(f, fcntl.LOCK_EX)\n"
         "f.seek(0)\nf.truncate()\nf.write(str(os.getpid()))\nf.flush()\n"
         "print('held', flush=True)\ntime.sleep(120)\n", str(path)],
        stdout=subprocess.PIPE, text=True)
    polls = []
    real_sleep = time.sleep

    def sleep(s):
        polls.append(s)
        real_sleep(s)
    try:
        assert holder.stdout.readline() == "held\n"
        monkeypatch.setattr(jitcache.time, "sleep", sleep)
        monkeypatch.setattr(jitcache, "KERNEL_WAIT", 0.5)
        with jitcache.compiling("pk_grid_z") as stage:     # a running holder: waited for
            assert stage is not None
        assert polls                                       # (how many: the machine's load)
        os.kill(holder.pid, signal.SIGSTOP)
        while not jitcache._stopped(holder.pid):
            real_sleep(0.01)
        monkeypatch.setattr(jitcache, "KERNEL_WAIT", 600.0)
        polls.clear()
        with jitcache.compiling("pk_grid_z") as stage:     # stopped: compiled here at once
            assert stage is not None
        assert polls == []
        assert path.read_text() == str(holder.pid)         # the holder's pid left alone
    finally:
        holder.kill()
        holder.wait()


def test_a_kernel_compiles_while_another_process_compiles_another(own_cache, monkeypatch,
                                                                  capsys):
    """A generated kernel compiles under a lock of its own, into a staging directory, and is
    published into the entry under the entry's lock: while another process compiles kernel X
    (holding X's lock), kernel Y compiles here at once, lands in the cache and is loaded from
    it by the next process; X, once its compiler is gone for KERNEL_WAIT seconds, is compiled
    here too and cached. Nothing is said: no one waited for the entry's lock."""
    import fcntl

    import numba

    from planarkin.solver.compiled import kernels as compiled_grid, jitcache
    monkeypatch.setattr(jitcache, "KERNEL_WAIT", 0.3)
    text = ("import numba\n\n\n@numba.njit(cache=CACHE)\ndef grid(x):\n    return x + {}\n")
    entry = own_cache / jitcache.tag()
    own_cache.mkdir(mode=0o700)
    x_lock = open(own_cache / f".{jitcache.tag()}.pk_grid_x.lock", "a+")
    fcntl.flock(x_lock, fcntl.LOCK_EX)          # another process compiling X
    try:
        fy = compiled_grid._build("pk_grid_y", text.format(2), "grid", (numba.int64,))
        assert fy(40) == 42
        assert jitcache.has(entry, entry / "gen" / "pk_grid_y.py", "grid")
        assert not list(own_cache.glob(".staging-*"))
        fx = compiled_grid._build("pk_grid_x", text.format(1), "grid", (numba.int64,))
        assert fx(41) == 42 and jitcache.has(entry, entry / "gen" / "pk_grid_x.py", "grid")
    finally:
        x_lock.close()
    assert capsys.readouterr().err == ""
    # every file in the entry vouched for: a new process's check keeps them all
    kept = sorted(p.name for p in entry.rglob("*.nb*"))
    jitcache.forget()
    assert jitcache.prepare() == entry
    jitcache.record()
    assert sorted(p.name for p in entry.rglob("*.nb*")) == kept and len(kept) == 4


def test_a_kernel_published_while_waiting_is_loaded_without_a_staging_directory(
        own_cache, monkeypatch):
    """A process that waited for another's compile of the same kernel finds it published
    when it gets the kernel's lock: it loads it without making a staging directory (seeding
    one copies the entry's files of the kinds' functions, ~0.5 s). Simulated: the kernel is
    in the cache, and the first look (before the lock) is told it is not there yet."""
    import numba

    from planarkin.solver.compiled import kernels as compiled_grid, jitcache
    text = "import numba\n\n\n@numba.njit(cache=CACHE)\ndef grid(x):\n    return x + 3\n"
    compiled_grid._build("pk_grid_w", text, "grid", (numba.int64,))   # the other's compile
    real, looks, seeded = compiled_grid._cached, [], []

    def cached(*args):
        looks.append(1)
        fn, path = real(*args)
        return (None, path) if len(looks) == 1 else (fn, path)
    monkeypatch.setattr(compiled_grid, "_cached", cached)
    monkeypatch.setattr(jitcache, "_seed", lambda stage: seeded.append(stage))
    made = tempfile.mkdtemp
    monkeypatch.setattr(jitcache.tempfile, "mkdtemp",
                        lambda *a, **kw: seeded.append("mkdtemp") or made(*a, **kw))
    fn = compiled_grid._build("pk_grid_w", text, "grid", (numba.int64,))
    assert fn(39) == 42 and len(looks) == 2
    assert seeded == [] and not list(own_cache.glob(".staging-*"))
