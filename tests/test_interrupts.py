"""Interrupted parallel commands (issue 33): a Ctrl-C, a CI timeout or `docker stop` signals
every process of the group, the forkserver and the resource tracker of the pool included.
Exit 130 / 143 with the command's own lines only (never a traceback, never the tracker's
"leaked semaphore" warning), lines that say what each model's directory holds, and no process
of the command left once it has ended (its group is empty: a zombie waiting for init to reap
it has ended)."""

import contextlib
import json
import os
import signal
import subprocess
import time
from pathlib import Path

import pytest

from clitools import PLAIN_SLIDER_CRANK, ROOT, command, start_held

pytestmark = pytest.mark.slow       # real processes and their signals (tests/conftest.py)

FB = str(ROOT / "mechanisms" / "four-bar.yaml")
GUARD = 30.0        # seconds: a hang guard (the group empties in a moment once the command ends)


def members(pgid: int) -> list[int]:
    """The processes of group pgid that have not ended."""
    out = []
    for proc in Path("/proc").iterdir():
        if not proc.name.isdigit():
            continue
        try:
            state, _, group = (proc / "stat").read_text().rsplit(")", 1)[1].split()[:3]
        except (OSError, ValueError):
            continue
        if int(group) == pgid and state not in ("Z", "X"):
            out.append(int(proc.name))
    return out


def left_after(p) -> list[int]:
    """The processes of p's group (a session of its own) still there GUARD s after p ended."""
    deadline = time.monotonic() + GUARD
    while members(p.pid) and time.monotonic() < deadline:
        time.sleep(0.05)
    return members(p.pid)


def end_group(p) -> None:
    """Whatever the test found, nothing of it outlives the test."""
    with contextlib.suppress(ProcessLookupError):
        os.killpg(p.pid, signal.SIGKILL)
    if p.poll() is None:
        p.kill()
    p.communicate()


def _models(tmp_path, n):
    out = []
    for k in range(n):
        m = tmp_path / f"m{k}.yaml"
        m.write_text(PLAIN_SLIDER_CRANK)
        out.append(str(m))
    return out


def test_sigterm_to_the_group_of_run_jobs_leaves_nothing_running(tmp_path):
    """`docker stop` of `run --jobs 2` while both workers write rows: the forkserver was
    killed with the group, which broke the pool under workers still stopping in order: each
    model was reported "failed ... left as it was" while its directory held its interrupted
    rows, and 3 pool processes stayed (5 of 6 tries). Now each line says what is on disk and
    the group is empty."""
    models = _models(tmp_path, 4)
    out = tmp_path / "out"
    p = start_held(["run", *models, "--jobs", "2", "--out", out, "--no-plots", "--steps",
                    20000], "rows:*", tmp_path / "ready", count=2, start_new_session=True)
    try:
        os.killpg(p.pid, signal.SIGTERM)
        stdout, stderr = p.communicate(timeout=60)
        left = left_after(p)
    finally:
        end_group(p)
    assert left == [], left
    assert p.returncode == 143, (stdout, stderr)
    assert stderr == "", stderr
    assert "failed" not in stdout, stdout
    for d in ("m0", "m1"):
        s = json.loads((out / d / "summary.json").read_text())
        assert s["status"] == "interrupted" and s["time"]["rows_written"] == 8192
        assert f"interrupted {tmp_path / d}.yaml: 8192 complete rows" in stdout, stdout
    assert sorted(d.name for d in out.iterdir()) == ["m0", "m1"]
    assert stdout.strip().splitlines()[-1] == "0 models analysed: 0 ok, interrupted by SIGTERM"


def test_run_jobs_interrupted_before_the_directories_says_so(tmp_path):
    """Interrupted while its models are prepared (no directory staged): each running model
    has its line, saying nothing was written (it had none)."""
    models = _models(tmp_path, 3)
    out = tmp_path / "out"
    p = start_held(["run", *models, "--jobs", "2", "--out", out, "--no-plots"], "prepare:*",
                   tmp_path / "ready", count=2, start_new_session=True)
    try:
        os.killpg(p.pid, signal.SIGTERM)
        stdout, stderr = p.communicate(timeout=60)
        left = left_after(p)
    finally:
        end_group(p)
    assert left == [] and p.returncode == 143 and stderr == "", (left, stdout, stderr)
    lines = stdout.strip().splitlines()
    assert lines[:2] == [f"interrupted {tmp_path / d}.yaml: nothing was written, {out / d}/ is "
                         f"left as it was" for d in ("m0", "m1")], stdout
    assert not out.exists() or not list(out.iterdir())


# multiprocessing's forkserver held as it imports planarkin (its preload, where the signal of
# the traceback arrived), until the test removes the file it writes
FORKSERVER_HOOK = '''
import os, sys, time
READY = os.environ.get("PLANARKIN_TEST_FORKSERVER")


def _is_forkserver():
    try:
        with open("/proc/self/cmdline", "rb") as f:
            return b"multiprocessing.forkserver" in f.read()
    except OSError:
        return False


class _Hold:
    def find_spec(self, name, path, target=None):
        if name == "planarkin.studies.variants":
            sys.meta_path.remove(self)
            marker = os.path.join(READY, "forkserver-%d" % os.getpid())
            open(marker, "w").close()
            deadline = time.time() + 60
            while os.path.exists(marker) and time.time() < deadline:
                time.sleep(0.005)
        return None


if READY and _is_forkserver():
    sys.meta_path.insert(0, _Hold())
'''

# 600 variants: two units of work (512 each at most), so the pool is used
SWEEP = ["sweep", FB, "--vary", "a=0.03:0.05:30", "--vary", "b=0.11:0.13:20", "--metric",
         "max:rocker.phi", "--jobs", "2", "--no-plots", "--steps", "24"]


def test_ctrl_c_as_the_forkserver_starts_prints_only_the_interruption(tmp_path):
    """A Ctrl-C to `sweep --jobs 2` as its forkserver imports the modules it preloads: the
    server printed a KeyboardInterrupt traceback. Now: exit 130, the one line."""
    hook, ready = tmp_path / "hook", tmp_path / "ready"
    hook.mkdir()
    ready.mkdir()
    (hook / "sitecustomize.py").write_text(FORKSERVER_HOOK)
    env = dict(os.environ, MPLBACKEND="Agg", PLANARKIN_TEST_FORKSERVER=str(ready))
    env["PYTHONPATH"] = os.pathsep.join([str(hook), str(ROOT), env.get("PYTHONPATH", "")])
    p = subprocess.Popen(command() + SWEEP + ["--out", str(tmp_path / "out")], env=env,
                         cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         start_new_session=True)
    try:
        deadline = time.monotonic() + 120
        while not list(ready.iterdir()) and p.poll() is None and time.monotonic() < deadline:
            time.sleep(0.005)
        assert list(ready.iterdir()), "the forkserver never started"
        os.killpg(p.pid, signal.SIGINT)
        for f in ready.iterdir():
            f.unlink()                  # the server goes on
        stdout, stderr = p.communicate(timeout=60)
        left = left_after(p)
    finally:
        end_group(p)
    assert left == [], left
    assert p.returncode == 130, (stdout, stderr)
    assert stderr == "", stderr
    assert stdout == (f"interrupted {FB}: the study's files in {tmp_path / 'out' / 'four-bar'}/ "
                      f"are the earlier run's or this one's\n"), stdout


def _parent(pid):
    try:
        return int((Path("/proc") / str(pid) / "stat").read_text().rsplit(")", 1)[1].split()[1])
    except (OSError, ValueError):
        return None


def _cpu(pid):
    try:
        return sum(int(x) for x in (Path("/proc") / str(pid) / "stat").read_text()
                   .rsplit(")", 1)[1].split()[11:13])
    except OSError:
        return 0


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_signal_to_the_group_of_a_busy_sweep(tmp_path, sig):
    """Ctrl-C or `docker stop` while both workers solve: exit 130 / 143 with the one line (the
    resource tracker used to add a "leaked semaphore objects" warning as it ended after the
    command, the pool's queues never released), nothing written, the group empty."""
    args = ["sweep", FB, "--vary", "a=0.03:0.05:60", "--vary", "b=0.11:0.13:60", "--metric",
            "max:rocker.phi", "--jobs", "2", "--no-plots", "--steps", "2880", "--out",
            str(tmp_path / "out")]
    env = dict(os.environ, MPLBACKEND="Agg")
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")])
    p = subprocess.Popen(command() + args, env=env, cwd=ROOT, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        deadline = time.monotonic() + 120
        busy = []
        while len(busy) < 2 and p.poll() is None and time.monotonic() < deadline:
            # the workers (the forkserver's children, where the tracker and the forkserver
            # are the command's), inside a unit
            busy = [k for k in members(p.pid) if k != p.pid
                    and _parent(k) not in (p.pid, None) and _cpu(k) >= 30]
            time.sleep(0.01)
        assert len(busy) >= 2, "the workers did not start"
        os.killpg(p.pid, sig)
        stdout, stderr = p.communicate(timeout=60)
        left = left_after(p)
    finally:
        end_group(p)
    assert left == [], left
    assert p.returncode == 128 + sig, (stdout, stderr)
    # nothing but the line that says numba is missing (the suite's run without it)
    assert [x for x in stderr.splitlines()
            if not x.startswith("planarkin: numba cannot be imported")] == [], stderr
    assert stdout.startswith(f"interrupted {FB}: ") and stdout.count("\n") == 1, stdout
    assert not list((tmp_path / "out").rglob("sweep.csv"))


def test_what_a_dead_workers_directory_holds(tmp_path):
    """The line of a model whose worker died (or hung) says what its directory holds: its
    earlier results untouched, or the ones put in place before the worker ended."""
    from planarkin.run import on_disk
    d = tmp_path / "m"
    assert on_disk(d, time.time()) == f"{d}/ is left as it was"
    d.mkdir()
    (d / "summary.json").write_text(json.dumps({"status": "interrupted",
                                                "time": {"rows_written": 8192}}))
    assert on_disk(d, time.time() + 60) == f"{d}/ is left as it was"
    assert on_disk(d, time.time() - 60) == (f"{d}/ holds its interrupted results (8192 rows, "
                                            f"as its summary.json says)")
