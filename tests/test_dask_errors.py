"""`--scheduler` when the cluster cannot be used or fails (issue 33): one line, never a traceback,
the right exit status: 2 for an address this installation cannot use, 1 within the promised
seconds for a scheduler that cannot be reached, answers garbage or never answers, or has no
worker; 1 for units lost with a worker or the scheduler, the variants solved written. Servers
on 127.0.0.1 only, each stopping by itself; Dask's tests skip where the extra is missing."""

import csv
import math
import socket
import subprocess
import sys
import threading
from concurrent.futures import CancelledError, Future

import pytest

from clitools import ROOT, run_cli

FB = "mechanisms/four-bar.yaml"
SWEEP = ["sweep", FB, "--vary", "a=0.03:0.05:3", "--steps", "12", "--no-plots"]


class Server:
    """A TCP server on 127.0.0.1 in a thread, for a bounded time and count of connections:
    'garbage' answers every connection with bytes that are not Dask's protocol, 'silent'
    accepts and never answers (holding the connections open until it stops)."""

    def __init__(self, kind: str, lifetime: float = 120.0, connections: int = 20):
        self.kind, self.connections = kind, connections
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(8)
        self.sock.settimeout(0.2)
        self.port = self.sock.getsockname()[1]
        self.stop = threading.Event()
        self.held: list = []
        self.thread = threading.Thread(target=self._serve, args=(lifetime,), daemon=True)

    def _serve(self, lifetime):
        import time
        end = time.monotonic() + lifetime
        while not self.stop.is_set() and time.monotonic() < end and \
                len(self.held) < self.connections:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                continue
            self.held.append(conn)
            if self.kind == "garbage":
                try:
                    conn.sendall(b"HTTP/1.1 200 OK\r\nContent-Length: 5\r\n\r\nhello" * 4)
                except OSError:
                    pass

    def __enter__(self):
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self.stop.set()
        self.thread.join(5)
        for c in self.held:
            c.close()
        self.sock.close()


@pytest.mark.slow       # Dask's import, a server, a process
def test_a_server_answering_garbage_is_refused_in_one_line(tmp_path):
    """Dask read the answer as a frame length: a traceback ending in an attempt to allocate
    3.07 EiB."""
    pytest.importorskip("distributed")
    with Server("garbage") as srv:
        r = run_cli(*SWEEP, "--scheduler", f"tcp://127.0.0.1:{srv.port}", "--out", tmp_path)
    assert r.returncode == 1, (r.stdout, r.stderr)
    assert r.stderr == (f"{FB}: error: cannot use tcp://127.0.0.1:{srv.port} as a Dask "
                        f"scheduler: what answers there does not speak Dask's protocol "
                        f"(MemoryError)\n"), r.stderr
    assert not list(tmp_path.rglob("sweep.csv"))


@pytest.mark.slow       # Dask's import, a server, a process
def test_a_port_that_never_answers_is_refused_within_the_seconds_promised(tmp_path):
    """A port that accepts and never answers held the command for ever (still waiting after
    150 s, where the message promises 5 s). The process is the subject: its timeout is the
    hang guard, ten times the figure promised."""
    pytest.importorskip("distributed")
    with Server("silent") as srv:
        r = subprocess.run([sys.executable, "-m", "planarkin", *SWEEP, "--scheduler",
                            f"tcp://127.0.0.1:{srv.port}", "--out", str(tmp_path)], cwd=ROOT,
                           capture_output=True, text=True, timeout=60)
    assert r.returncode == 1, (r.stdout, r.stderr)
    assert r.stderr == (f"{FB}: error: cannot reach the Dask scheduler at tcp://127.0.0.1:"
                        f"{srv.port} within 5 s (it accepts connections but does not answer: "
                        f"is it a Dask scheduler?)\n"), r.stderr
    assert not list(tmp_path.rglob("sweep.csv"))


@pytest.mark.parametrize("address", ["", " ", "tls://", "tcp://:8786"])
def test_a_malformed_address_is_a_usage_error(tmp_path, address):
    """'' was taken for no --scheduler by one check and for one by the next: a ValueError
    traceback."""
    r = run_cli(*SWEEP, "--scheduler", address, "--out", tmp_path / "never")
    assert r.returncode == 2, (r.stdout, r.stderr)
    assert r.stderr.startswith("error: --scheduler: ") and r.stderr.count("\n") == 1, r.stderr
    assert "write tcp://HOST:PORT" in r.stderr and not (tmp_path / "never").exists()


def test_tls_without_dask_tls_settings_is_a_usage_error(tmp_path):
    """A TypeError traceback from inside Dask ("TLS expects a `ssl_context` argument")."""
    pytest.importorskip("distributed")
    from distributed.security import Security
    if Security().get_connection_args("client").get("ssl_context") is not None:
        pytest.skip("this machine's Dask configuration has TLS settings")
    r = run_cli(*SWEEP, "--scheduler", "tls://127.0.0.1:8786", "--out", tmp_path / "never")
    assert r.returncode == 2, (r.stdout, r.stderr)
    assert r.stderr.startswith("error: --scheduler: 'tls://127.0.0.1:8786': tls:// needs "
                               "Dask's TLS settings") and r.stderr.count("\n") == 1, r.stderr


def test_without_dask_the_scheduler_option_names_the_extra(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)         # import fails
    monkeypatch.setitem(sys.modules, "distributed.security", None)
    r = run_cli(*SWEEP, "--scheduler", "tcp://127.0.0.1:8786", "--out", tmp_path / "never")
    assert r.returncode == 2, (r.stdout, r.stderr)
    assert r.stderr == "error: --scheduler: needs Dask: pip install 'planarkin[dask]'\n"


@pytest.mark.slow       # Dask's import, a server, a process
def test_a_scheduler_without_workers_is_refused_in_one_line(tmp_path, monkeypatch):
    """A real scheduler (in this process) with no worker: a TimeoutError traceback ("No valid
    workers found") from inside Dask."""
    distributed = pytest.importorskip("distributed")
    from planarkin.studies import execute
    monkeypatch.setattr(execute, "DASK_TIMEOUT", 1.0)
    with distributed.LocalCluster(n_workers=0, processes=False, protocol="tcp://",
                                  host="127.0.0.1", dashboard_address=None) as cluster:
        address = cluster.scheduler_address
        r = run_cli(*SWEEP, "--scheduler", address, "--out", tmp_path)
    assert r.returncode == 1, (r.stdout, r.stderr)
    assert r.stderr == (f"{FB}: error: the Dask scheduler at {address} has no worker (none "
                        f"within 1 s): start one, e.g. dask worker {address}\n"), r.stderr
    assert not list(tmp_path.rglob("sweep.csv"))


# -- units lost during the study: what was solved is kept -------------------------------------

class _Client:
    """What _collect_dask asks of a distributed.Client: the workers the scheduler knows."""

    def __init__(self, workers: int):
        self.workers = workers

    def scheduler_info(self, n_workers=-1):
        return {"workers": {f"w{k}": {} for k in range(self.workers)}}


@pytest.fixture(scope="module")
def study():
    from planarkin.studies.variants import Study
    s = Study(FB, analysis={"steps": 12}, metrics=["max:rocker.phi"])
    s.chain = 2
    return s


def _units(study, n):
    from planarkin.studies.sweep import Range, factorial
    variants = factorial([Range("a", 0.03, 0.05, n)])
    return variants, study.units(variants)


def test_units_lost_with_the_cluster_keep_the_units_solved(study):
    """A killed worker or scheduler: the cluster cancels the tasks it had, or fails them
    (KilledWorker); each was a traceback. Now the units solved are kept, the others marked."""
    from planarkin.studies.execute import LOST, SchedulerError, _collect_dask
    variants, units = _units(study, 6)           # three units of two
    assert len(units) == 3
    futures = [Future() for _ in units]
    futures[0].set_result(study.run_unit(units[0]))
    futures[1].set_exception(CancelledError())
    futures[2].set_exception(RuntimeError("Attempted to run task on 4 different workers, but "
                                          "all those workers died while running it\nmore"))
    with pytest.raises(SchedulerError) as e:
        _collect_dask(_Client(1), futures, units, study, "tcp://127.0.0.1:1")
    assert str(e.value) == ("the Dask cluster at tcp://127.0.0.1:1 lost units (cancelled: the "
                            "scheduler, or every worker holding the study, is gone) while "
                            "variants 3-4 were being solved; 4 of 6 variants were not solved")
    got = e.value.outcomes
    assert repr(got[:2]) == repr(study.run(variants[:2]))
    assert [(o.status, o.kind) for o in got[2:]] == [("failed", LOST)] * 4
    assert all(math.isnan(x) for o in got[2:] for x in o.metrics)


def test_units_waiting_on_a_cluster_without_workers_are_lost(study, monkeypatch):
    """Tasks that would wait for ever: the cluster has had no worker for DASK_TIMEOUT s."""
    from planarkin.studies import execute
    monkeypatch.setattr(execute, "DASK_TIMEOUT", 0.1)
    variants, units = _units(study, 4)
    futures = [Future() for _ in units]
    futures[0].set_result(study.run_unit(units[0]))
    with pytest.raises(execute.SchedulerError) as e:
        execute._collect_dask(_Client(0), futures, units, study, "tcp://127.0.0.1:1")
    assert "lost units (no worker left) while variants 3-4 were being solved" in str(e.value)
    assert [o.kind for o in e.value.outcomes] == ["", "", execute.LOST, execute.LOST]
    assert futures[1].cancelled()


def test_nothing_solved_writes_nothing(study):
    from planarkin.studies.execute import SchedulerError, _collect_dask
    variants, units = _units(study, 4)
    futures = [Future() for _ in units]
    for f in futures:
        f.set_exception(CancelledError())
    with pytest.raises(SchedulerError) as e:
        _collect_dask(_Client(1), futures, units, study, "tcp://127.0.0.1:1")
    assert e.value.outcomes is None


def test_a_sweep_that_lost_units_writes_what_was_solved(tmp_path, monkeypatch):
    """On the command line: exit 1, one line saying what was lost and where the rest is;
    sweep.csv holds every variant, the lost ones marked."""
    pytest.importorskip("distributed")
    from planarkin.studies import execute

    def half(study, variants, scheduler):
        done = study.run(variants[:2])
        lost = execute._lost(study, [variants[2:]], "the Dask cluster lost it")
        raise execute.SchedulerError("the Dask cluster at tcp://127.0.0.1:1 lost units "
                                     "(cancelled) while variant 3 was being solved", done + lost)
    monkeypatch.setattr(execute, "run_dask", half)
    r = run_cli(*SWEEP, "--scheduler", "tcp://127.0.0.1:1", "--out", tmp_path)
    table = tmp_path / "four-bar" / "sweep.csv"
    assert r.returncode == 1, (r.stdout, r.stderr)
    assert r.stderr == (f"{FB}: error: the Dask cluster at tcp://127.0.0.1:1 lost units "
                        f"(cancelled) while variant 3 was being solved; the variants solved "
                        f"are in {table} (the others: status failed, kind lost)\n"), r.stderr
    rows = list(csv.DictReader(table.open()))
    assert [(r["status"], r["kind"]) for r in rows] == [("ok", ""), ("ok", ""),
                                                        ("failed", "lost")]
    assert rows[2]["message"] == "not solved: the Dask cluster lost it"
