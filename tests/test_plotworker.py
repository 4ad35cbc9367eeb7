"""The plot processes (planarkin.output.plotworker): the server and its helper draw the jobs of
a batch two at a time and the halves of a single run's job, with the same files as drawing in
process; the CLI keeps at most two jobs in flight and the lines in order; no drawing process
outlives a run, a stop or a killed parent; an interrupted batch with plots leaves every
directory consistent."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import planarkin
from planarkin.output import plots, plotworker

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = [ROOT / "mechanisms" / f"{n}.yaml" for n in ("slider-crank", "four-bar", "boom")]


def _env():
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    return env


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rpartition(")")[2].split()[0] != "Z"
    except OSError:
        return False


def _gone(pids, seconds=10.0) -> bool:
    deadline = time.time() + seconds
    while any(_alive(p) for p in pids) and time.time() < deadline:
        time.sleep(0.05)
    return not any(_alive(p) for p in pids)


@pytest.fixture
def idle(monkeypatch):
    """A machine taken as having a core free for each drawer."""
    monkeypatch.setattr(plotworker, "_idle_core", lambda: True)


def _helper_pid():
    """The helper's pid, once its hello has arrived."""
    helper = plotworker._pool.drawers[1]
    deadline = time.time() + 60
    while helper.pid is None and time.time() < deadline:
        plotworker._drain(helper)
        time.sleep(0.01)
    return helper.pid


def test_two_drawers_draw_the_same_files_as_one_process(idle, tmp_path):
    """Jobs drawn whole by the server and by the helper at once (a batch), and one split
    between them (a single run): byte for byte the files drawn in this process."""
    runs = []
    for path in EXAMPLES:
        cm = planarkin.load(path)
        r = planarkin.solve(cm, steps=60)
        runs.append((cm, r))
    plotworker.start()
    try:
        assert len(plotworker._pool.drawers) == 2
        tickets = []
        for k, (cm, r) in enumerate(runs[:2]):          # two in flight, one per drawer
            d = tmp_path / f"pool-{k}"
            d.mkdir()
            tickets.append(plotworker.submit(cm, r._chunk, r.info, d, "png", False,
                                             waits=False))
        assert [len(d.queue) for d in plotworker._pool.drawers] == [1, 1]
        files = [plotworker.collect(t) for t in tickets]
        cm, r = runs[2]
        d = tmp_path / "pool-2"
        d.mkdir()
        t = plotworker.submit(cm, r._chunk, r.info, d, "png", False, waits=True)
        assert len(plotworker._pool.parts[t]) == 2                       # split
        files.append(plotworker.collect(t))
    finally:
        plotworker.stop()
    for k, (cm, r) in enumerate(runs):
        here = tmp_path / f"here-{k}"
        here.mkdir()
        mine = plots.write_plots(cm, r._chunk, r.info, here, "png")
        from planarkin.derived import derived_tables
        for t in derived_tables(cm, r.info.options):
            if t.plot is not None:
                mine += t.plot(cm, t.compute(r._chunk), r.info, here, "png")
        assert [p.name for p in files[k]] == [p.name for p in mine]
        for a, b in zip(files[k], mine):
            assert a.read_bytes() == b.read_bytes(), a.name


def test_a_batch_keeps_two_jobs_in_flight_and_the_lines_in_order(idle, tmp_path,
                                                                  monkeypatch):
    """With a core free for each drawer, the next model solves while the two before it are
    drawn: the oldest job is collected (its directory put in place, its line printed) only
    when a third model needs a drawer; the lines keep the models' order."""
    from click.testing import CliRunner

    from clitools import record_batch_events
    from planarkin.cli import main
    events = record_batch_events(monkeypatch)
    r = CliRunner().invoke(main, ["run", *map(str, EXAMPLES), "--out", str(tmp_path),
                                  "--steps", "40"])
    assert r.exit_code == 0, r.output
    a, b, c = (planarkin.load(p).spec.name for p in EXAMPLES)
    # the last model is waited for at once (drawn by the free drawer, while b's drawing ends),
    # b's end (its line) comes before c's line is printed
    assert events == [("solve", a), ("submit", a), ("solve", b), ("submit", b),
                      ("solve", c), ("collect", 1), ("submit", c), ("collect", 3),
                      ("collect", 2)]
    lines = [ln for ln in r.output.splitlines() if ln.startswith("ok ")]
    assert [ln.split()[1] for ln in lines] == [f"{p}:" for p in EXAMPLES]
    assert not plotworker.running()
    for p in EXAMPLES:
        s = json.loads((tmp_path / p.stem / "summary.json").read_text())
        assert s["plots"][:4] == ["bodies.png", "points.png", "trajectories.png",
                                  "mechanism.png"]
        assert {f.name for f in (tmp_path / p.stem).iterdir()} == \
            set(s["files"]) | set(s["plots"]) | {"summary.json"}


def test_capacity_follows_the_free_cores(monkeypatch):
    """Two jobs in flight only with both drawers and a core free for the second: on a busy
    machine the batch is drawn by one process at a time, as by a single server."""
    assert plotworker.capacity() == 1                  # no server
    monkeypatch.setattr(plotworker, "_idle_core", lambda: True)
    plotworker.start()
    try:
        assert plotworker.capacity() == 2
        monkeypatch.setattr(plotworker, "_idle_core", lambda: False)
        assert plotworker.capacity() == 1
    finally:
        plotworker.stop()


def test_stop_leaves_no_drawer_behind(idle, tmp_path):
    cm = planarkin.load(EXAMPLES[0])
    r = planarkin.solve(cm, steps=20)
    plotworker.start()
    server = plotworker._pool.proc.pid
    try:
        assert plotworker.draw(cm, r._chunk, r.info, tmp_path, "png", False)
        helper = _helper_pid()
        assert helper and _alive(helper)
    finally:
        plotworker.stop()
    assert not _alive(server) and _gone([helper], 5)


KILLED_PARENT = """
import os, signal, sys, time
from pathlib import Path
import planarkin
from planarkin.output import plotworker
plotworker._idle_core = lambda: True
cm = planarkin.load(sys.argv[1])
r = planarkin.solve(cm, steps=200)
plotworker.start()
helper = plotworker._pool.drawers[1]
while helper.pid is None:
    plotworker._drain(helper)
    time.sleep(0.01)
if sys.argv[3] == "drawing":        # a job each: both drawers at work when the parent dies
    for k in range(2):
        plotworker.submit(cm, r._chunk, r.info, Path(sys.argv[2]), "png", True, waits=False)
print("pids", plotworker._pool.proc.pid, helper.pid, flush=True)
os.kill(os.getpid(), signal.SIGKILL)
"""


@pytest.mark.parametrize("moment", ["idle", "drawing"])
def test_killing_the_parent_leaves_no_plot_process_behind(tmp_path, moment):
    """The server and its helper end on end of file when the parent is killed, waiting for
    jobs or drawing them (with the animation, a second or more of work)."""
    p = subprocess.run([sys.executable, "-c", KILLED_PARENT, str(EXAMPLES[0]), str(tmp_path),
                        moment], capture_output=True, text=True, timeout=120, env=_env())
    assert p.returncode == -signal.SIGKILL, p.stderr
    pids = [int(x) for x in p.stdout.split()[1:]]
    assert len(pids) == 2
    assert _gone(pids, 30), f"plot processes left behind: {pids}"


INTERRUPTED = """
import sys
from planarkin.output import plotworker
plotworker._idle_core = lambda: True
from planarkin.__main__ import entry
sys.argv = ["planarkin"] + sys.argv[1:]
entry()
"""


# moments of a batch, as what is on disk then: the first model's first figure drawn (the
# next model solving), the first directories in place (two drawn, the third solving)
MOMENTS = [(".m0.tmp-*/bodies.png", signal.SIGINT), ("m0/summary.json", signal.SIGTERM),
           ("m2/summary.json", signal.SIGINT)]


@pytest.mark.parametrize("when, sig", MOMENTS, ids=[f"{w.split('/')[0]}-{s.name}"
                                                   for w, s in MOMENTS])
def test_interrupted_batch_with_plots_leaves_every_directory_consistent(tmp_path, when, sig):
    """A batch drawn two models at a time, stopped by a signal while models solve and are
    drawn: the run ends with the signal's status, every directory on disk holds exactly what
    its summary lists (whole PNG files: the plots drawn so far), the later models are not
    started, and no drawing or writing process is left."""
    from test_contract import assert_contract, no_leftovers
    models = []
    for k in range(9):
        m = tmp_path / f"m{k}.yaml"
        m.write_text(EXAMPLES[k % 3].read_text())
        models.append(str(m))
    out = tmp_path / "out"
    p = subprocess.Popen([sys.executable, "-c", INTERRUPTED, "run", *models, "--out", str(out),
                          "--steps", "200", "--animate"], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, env=_env(), cwd=ROOT)
    deadline = time.time() + 120
    while not list(out.glob(when)) and p.poll() is None and time.time() < deadline:
        time.sleep(0.005)
    assert p.poll() is None, "the batch ended before the moment"
    p.send_signal(sig)
    try:
        stdout, stderr = p.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        p.kill()
        pytest.fail("planarkin hung after the signal")
    assert "Traceback" not in stderr, stderr
    assert p.returncode == {signal.SIGINT: 130, signal.SIGTERM: 143}[sig], (stdout, stderr)
    done = [d for d in out.iterdir() if d.is_dir() and not d.name.startswith(".")]
    statuses = []
    for d in done:
        s = assert_contract(d, ("ok", "interrupted"))
        statuses.append(s["status"])
        for name in s["plots"]:
            data = (d / name).read_bytes()
            assert data[:6] in (b"\x89PNG\r\n", b"GIF89a"), (d, name)
            assert data.endswith(b"IEND\xaeB`\x82") or data.endswith(b";"), (d, name)
        assert f"{d.name}.yaml" in stdout, (d, stdout)
    assert "interrupted" in statuses and len(done) < 9
    assert f"{statuses.count('ok')} ok" in stdout.strip().splitlines()[-1], stdout
    no_leftovers(out)


def test_the_drawers_import_what_a_job_needs_and_not_the_csv_formatter():
    """The server's warm-up imports matplotlib and what unpickling a job imports (so that a job
    arriving finds them), but not the CSV formatter (0.06-0.12 s of tables built at import),
    which only the table writers use."""
    code = ("import sys, pickle\nfrom planarkin.output import plotworker\n"
            "plotworker._warm_up()\n"
            "print(sorted(m for m in ('matplotlib.figure', 'planarkin.model.compile', "
            "'planarkin.results', 'planarkin.solver', 'planarkin.output.fastcsv') "
            "if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=_env(), cwd=ROOT, timeout=120)
    assert out.stdout.split("\n")[-2] == str(["matplotlib.figure", "planarkin.model.compile",
                                              "planarkin.results", "planarkin.solver"]), \
        out.stdout + out.stderr


def test_a_model_in_place_gets_its_line_when_the_one_before_is_interrupted():
    """The last model of a batch is put in place while the one before still waits for its
    plots; printing the last one's line ends the one before first, and an interruption there
    (its line says so) must not swallow the last one's line: both are printed, in order, and
    the interruption goes on."""
    from planarkin.cli import _Later

    class Lines:
        def __init__(self):
            self.lines = []

        def ok(self, path, detail=""):
            self.lines.append(("ok", path))

        def interrupted(self, path, sig, detail=""):
            self.lines.append(("interrupted", path))

    rep = Lines()
    later = _Later(rep)

    def before():
        rep.interrupted("a.yaml", "SIGINT")
        raise KeyboardInterrupt
    later.waiting.append(before)
    with pytest.raises(KeyboardInterrupt):
        later.ok("b.yaml", "in place")
    assert rep.lines == [("interrupted", "a.yaml"), ("ok", "b.yaml")]
    assert not later.waiting
