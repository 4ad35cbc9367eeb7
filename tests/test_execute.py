"""Parallel and distributed studies: local processes and a Dask LocalCluster give the serial
run's results bit for bit; run --jobs gives the same directories."""

import subprocess
import sys

import pytest

from clitools import run_cli
from planarkin.studies.execute import executor, run_dask
from planarkin.studies.warm import chains
from planarkin.studies.sweep import Range, factorial
from planarkin.studies.variants import Study

FB = "mechanisms/four-bar.yaml"


@pytest.fixture(scope="module")
def study():
    s = Study(FB, analysis={"steps": 12}, metrics=["max:rocker.phi", "dev:P", "min:P.y"])
    s.chain = 4
    return s


@pytest.fixture(scope="module")
def variants():
    # 12 variants in three chains, with invalid (a = 0.08) and failed (lock-up) ones among them
    return factorial([Range("a", 0.03, 0.08, 6), Range("b", 0.12, 0.12, 1)]) + \
        factorial([Range("a", 0.17, 0.30, 2), Range("b", 0.12, 0.13, 2)]) + \
        factorial([Range("a", 0.035, 0.045, 2)])


@pytest.fixture(scope="module")
def serial(study, variants):
    return study.run(variants)


def test_chains_cut_the_variants_independently_of_the_workers():
    assert [list(c) for c in chains(5, 2)] == [[0, 1], [2, 3], [4]]


def test_local_processes_equal_the_serial_run_bit_for_bit(study, variants, serial):
    assert {o.status for o in serial} == {"ok", "failed", "invalid"}
    par = executor(2)(study, variants)
    assert repr(par) == repr(serial)          # repr: nan == nan, and every bit of the floats


@pytest.mark.slow
def test_dask_local_cluster_equals_the_serial_run_bit_for_bit(study, variants, serial):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  host="127.0.0.1", dashboard_address=None) as cluster:
        got = run_dask(study, variants, cluster.scheduler_address)
    assert repr(got) == repr(serial)


@pytest.mark.slow
def test_run_jobs_writes_the_same_directories(tmp_path):
    models = [FB, "mechanisms/slider-crank.yaml", "mechanisms/trammel.yaml"]
    r1 = run_cli("run", *models, "--out", tmp_path / "1", "--no-plots", "--steps", "24")
    r2 = run_cli("run", *models, "--out", tmp_path / "2", "--no-plots", "--steps", "24", "-j",
                 "2")
    assert r1.returncode == r2.returncode == 0
    strip = lambda s: [line.split(" rows")[0] for line in s.splitlines()]
    assert strip(r1.stdout) == strip(r2.stdout)
    for m in ("four-bar", "slider-crank", "trammel"):
        r = run_cli("compare", tmp_path / "1" / m, tmp_path / "2" / m, "--rtol", "0", "--atol",
                    "0")
        assert r.returncode == 0, r.stdout


_WORKER = r"""
import os, signal
from planarkin.__main__ import _quiet_exit
for s in (signal.SIGINT, signal.SIGTERM):      # as the command's start-up installs them
    signal.signal(s, _quiet_exit)
from planarkin.studies import execute
codes = []
for sig in (signal.SIGTERM, signal.SIGINT):
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:                                # a study worker: the pool's initializer
        execute._init_study(None)
        os.write(w, b"x")
        while True:
            signal.pause()
    os.read(r, 1)
    os.kill(pid, sig)
    codes.append(os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]))
print("exit codes", codes)
"""


def test_study_workers_end_quietly_on_the_pools_terminate_and_on_ctrl_c():
    # the pool's terminate() at the end of every --jobs study sends its workers SIGTERM, and a
    # Ctrl-C reaches them all; they used to inherit the command's start-up handler and print
    # "interrupted while starting: nothing was written" beside a finished sweep (3 of 8 runs)
    import subprocess
    import sys
    r = subprocess.run([sys.executable, "-c", _WORKER], capture_output=True, text=True,
                       timeout=60)
    assert r.returncode == 0, r.stderr
    assert r.stdout == "exit codes [143, 130]\n" and r.stderr == "", (r.stdout, r.stderr)


def _cpu(pid):
    """CPU ticks used so far (utime + stime)."""
    try:
        return sum(int(x) for x in open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1]
                   .split()[11:13])
    except OSError:
        return 0


def _children(pid):
    try:
        return [int(k) for k in open(f"/proc/{pid}/task/{pid}/children").read().split()]
    except OSError:
        return []


def _forkserver(pid):
    try:
        return b"forkserver" in open(f"/proc/{pid}/cmdline", "rb").read()
    except OSError:
        return False


def _running(pid):
    """Not ended: neither gone nor a zombie (an orphan's zombie waits for PID 1 to reap it,
    which here may take a while)."""
    try:
        state = open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state not in ("Z", "X")


def _busy_sweep(tmp_path, extra=()):
    """`sweep --jobs 2` of 3,600 variants, started; returns (process, its two workers) once
    both workers are inside a unit (the workers: the children of the forkserver, itself a
    child of the command, or the command's own children where they are forked)."""
    import subprocess
    import sys
    import time
    p = subprocess.Popen([sys.executable, "-m", "planarkin", "sweep", FB, "--vary",
                          "a=0.03:0.05:60", "--vary", "b=0.11:0.13:60", "--metric",
                          "max:rocker.phi", "--jobs", "2", "--no-plots", "--steps", "2880",
                          "--out", str(tmp_path), *extra], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 60
    kids = []
    while time.time() < deadline and p.poll() is None:
        kids = [w for c in _children(p.pid) for w in ([c] if not _forkserver(c) else
                                                      _children(c))]
        kids = [k for k in kids if _cpu(k) >= 30]          # inside a unit (not the resource
        if len(kids) >= 2:                                  # tracker, idle)
            break
        time.sleep(0.01)
    if len(kids) < 2 or p.poll() is not None:
        p.kill()
        pytest.fail(f"the workers did not start: {p.communicate()}")
    return p, kids


def test_a_sigterm_to_the_parent_alone_ends_the_workers_quietly(tmp_path):
    # the parent of `sweep --jobs 2` ends at once on SIGTERM, with its workers, quietly
    import signal
    import time
    p, kids = _busy_sweep(tmp_path)
    p.send_signal(signal.SIGTERM)
    out, err = p.communicate(timeout=60)
    deadline = time.time() + 30             # a hang guard: they end in a moment
    while any(_running(k) for k in kids) and time.time() < deadline:
        time.sleep(0.05)
    alive = [k for k in kids if _running(k)]
    assert p.returncode == 128 + signal.SIGTERM and alive == [], (p.returncode, alive)
    assert "Traceback" not in err and "Traceback" not in out, err[-2000:]
    assert not list(tmp_path.rglob("sweep.csv"))
    assert not [f for f in tmp_path.rglob("*") if ".tmp-" in f.name or f.name.endswith(".lock")]


def test_a_worker_that_dies_ends_the_sweep_within_seconds(tmp_path):
    """A worker killed inside a unit (the OOM killer, a crash): the sweep fails that unit with
    a message naming it and ends with exit 1 at once (it used to wait for ever), quietly, and
    the earlier files stay as they were (no unit was solved: both workers were in their
    first)."""
    import os
    import signal
    import subprocess
    import time
    p, kids = _busy_sweep(tmp_path)
    os.kill(kids[0], signal.SIGKILL)
    try:
        out, err = p.communicate(timeout=60)      # a hang guard: it ends in a moment
    except subprocess.TimeoutExpired:
        p.kill()
        p.communicate()
        for k in kids:
            if _running(k):
                os.kill(k, signal.SIGKILL)
        pytest.fail("the sweep did not end after its worker died")
    assert p.returncode == 1, (out, err)
    assert "Traceback" not in err, err[-2000:]
    assert "a worker process died" in err and "variants" in err, err
    assert not list(tmp_path.rglob("sweep.csv"))
    deadline = time.time() + 30             # a hang guard: they end in a moment
    while any(_running(k) for k in kids) and time.time() < deadline:
        time.sleep(0.05)
    assert not [k for k in kids if _running(k)]


def test_a_malformed_scheduler_address_is_refused_at_once_in_one_line():
    """Exit 2 with one line, before the model is read (no Dask needed: it used to raise a
    traceback from inside distributed)."""
    from click.testing import CliRunner

    from planarkin.cli import main
    for bad in ("foo", "tcp://", "tcp://host", "127.0.0.1:8786", "tcp://h:0", "tcp://h:99999",
                "http://h:80"):
        r = CliRunner().invoke(main, ["sweep", FB, "--vary", "a=0.03:0.05:2", "--scheduler",
                                      bad, "--out", "/nonexistent/never-written"])
        assert r.exit_code == 2, (bad, r.output)
        assert r.output.count("\n") == 1 and "--scheduler" in r.output, r.output
        assert "Traceback" not in r.output


def test_an_unreachable_scheduler_fails_within_seconds_in_one_line(tmp_path):
    """A closed port: exit 1 within a few seconds and one line (it used to wait 30 s and print
    50 lines of traceback)."""
    pytest.importorskip("distributed")
    import socket
    import subprocess
    import sys
    with socket.socket() as s:                  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    # timeout: a hang guard, ten times the 5 s the message promises
    r = subprocess.run([sys.executable, "-m", "planarkin", "sweep", FB, "--vary",
                        "a=0.03:0.05:2", "--steps", "12", "--scheduler",
                        f"tcp://127.0.0.1:{port}", "--out", str(tmp_path)],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 1, (r.stdout, r.stderr)
    assert r.stderr.count("\n") == 1 and "cannot reach the Dask scheduler" in r.stderr, r.stderr
    assert "within 5 s" in r.stderr and "Connection refused" in r.stderr, r.stderr
    assert not list(tmp_path.rglob("sweep.csv"))


def test_a_dead_worker_keeps_the_units_solved(study, variants, serial):
    """Issue 33: units lost with their worker fail those variants only (status failed, kind
    lost); the others are kept, as the house keeps what an analysis failure computed."""
    from concurrent.futures import Future
    from concurrent.futures.process import BrokenProcessPool

    from planarkin.studies.execute import LOST, WorkerDied, _collect
    units = study.units(variants)
    assert len(units) == 3
    futures = [Future() for _ in units]
    futures[0].set_result(study.run_unit(units[0]))
    futures[1].set_exception(BrokenProcessPool("a worker died"))
    futures[2].set_result(study.run_unit(units[2]))
    with pytest.raises(WorkerDied) as e:
        _collect(futures, units, study)
    assert str(e.value).startswith("a worker process died (killed by a signal, out of memory "
                                   "or a crash) while variants 5-8 were being solved; 4 of 12 "
                                   "variants were not solved")
    got = e.value.outcomes
    assert repr(got[:4] + got[8:]) == repr(serial[:4] + serial[8:])
    assert [(o.status, o.kind) for o in got[4:8]] == [("failed", LOST)] * 4


@pytest.mark.parametrize("command", ["sweep", "tolerance"])
def test_a_study_that_lost_units_writes_what_was_solved(tmp_path, study, command):
    """The study writes its files from the outcomes kept, then raises the error saying where
    they are (the command line's one line, exit 1)."""
    import csv

    from planarkin.studies.execute import LOST, WorkerDied, _lost
    from planarkin.studies.sweep import run_sweep
    from planarkin.studies.tolerance import run_tolerance

    def execute(study, variants):
        kept = study.run(variants[:2])
        raise WorkerDied("a worker process died", kept + _lost(study, [variants[2:]], "died"))
    with pytest.raises(WorkerDied) as e:
        if command == "sweep":
            run_sweep(study, [Range("a", 0.03, 0.05, 3)], tmp_path, plots=None,
                      execute=execute)
        else:
            run_tolerance(study, {"a": 1e-4}, tmp_path, 3, plots=None, execute=execute)
    table = tmp_path / ("sweep.csv" if command == "sweep" else "samples.csv")
    assert str(e.value) == (f"a worker process died; the variants solved are in {table} (the "
                            f"others: status failed, kind lost)")
    rows = list(csv.DictReader(table.open()))
    assert [r["kind"] for r in rows] == ["", "", LOST] and rows[0]["status"] == "ok"
    assert e.value.outcomes is None


_PROBE = r"""
import sys
from concurrent.futures import ProcessPoolExecutor
from planarkin.processes import context

def probe():
    from planarkin.solver.compiled import kernel
    lib = kernel._state.get("lib")
    return "numba" in sys.modules, lib is not None and {"points", "study"} <= lib._ready

if __name__ == "__main__":
    with ProcessPoolExecutor(1, mp_context=context(engine=sys.argv[1] == "1")) as pool:
        print(pool.submit(probe).result())
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="the forkserver: Linux")
@pytest.mark.parametrize("engine", [True, False])
def test_workers_of_a_study_on_the_compiled_route_start_with_it_loaded(tmp_path, engine):
    """A study on the compiled route with --jobs: the workers' server loads numba and the
    route's entry points once (planarkin.solver.compiled.preload), so a worker forked from it
    starts with them instead of loading them itself (while the others wait for the cache's
    lock); other pools' workers (run --jobs, small studies) never import numba. In a fresh
    process: the server is started once per process."""
    from routes import skip_without_numba
    if engine:
        skip_without_numba()
    script = tmp_path / "probe.py"
    script.write_text(_PROBE)
    r = subprocess.run([sys.executable, str(script), "1" if engine else "0"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == str((engine, engine)), (r.stdout, r.stderr)
