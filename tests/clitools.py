"""Running `planarkin`: in this process through click's CliRunner (run_cli: quick, and a bug
surfaces as its own traceback), or as the installed console script (run_process, start_held:
where the process itself, its exit status, its signals or its children are the subject)."""

import contextlib
import os
import shutil
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

ROOT = Path(__file__).resolve().parent.parent


def command() -> list[str]:
    exe = shutil.which("planarkin")
    return [exe] if exe else [sys.executable, "-m", "planarkin"]


@contextlib.contextmanager
def chdir(path):
    """contextlib.chdir (Python 3.11) for 3.10."""
    old = os.getcwd()
    os.chdir(path)
    try:
        yield
    finally:
        os.chdir(old)


def run_cli(*args, cwd=ROOT):
    """`planarkin ARGS` in this process (from cwd): returncode, stdout and stderr as a process
    would give them. An exception the command lets through (a traceback for the user) is raised
    here, so a test that expects a clean message fails on it."""
    from click.testing import CliRunner

    from planarkin.cli import main
    with chdir(cwd):
        r = CliRunner(env={"MPLBACKEND": "Agg"}).invoke(main, [str(a) for a in args])
    if r.exception is not None and not isinstance(r.exception, SystemExit):
        raise r.exception
    return SimpleNamespace(returncode=r.exit_code, stdout=r.stdout, stderr=r.stderr)


def run_process(*args, cwd=ROOT, timeout=120):
    """`planarkin ARGS` as the installed console script, in a new process."""
    env = dict(os.environ)
    env.setdefault("MPLBACKEND", "Agg")
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    return subprocess.run(command() + [str(a) for a in args], cwd=cwd, capture_output=True,
                          text=True, timeout=timeout, env=env)


# A plain slider-crank for the tests that edit a model's text (the examples may change)
PLAIN_SLIDER_CRANK = """\
name: slider-crank
units: {length: m, angle: rad}
parameters:
  a: 0.1
  b: 3*a
bodies:
  crank:  {q: [0.05, 0.0, 0.3]}
  rod:    {q: [0.2, 0.02, -0.1]}
  slider: {q: [0.4, 0.0, 0.0]}
joints:
  - {type: revolute, i: ground, j: crank, si: [0, 0], sj: [0, 0]}
  - {type: revolute, i: crank, j: rod, si: [a, 0], sj: [0, 0]}
  - {type: revolute, i: rod, j: slider, si: [b, 0], sj: [0, 0]}
  - {type: translational, i: ground, j: slider, si: [0, 0], sj: [0, 0], vi: [1, 0], vj: [1, 0]}
drivers:
  - {type: angle, body: crank, f: "2*pi*t"}
points:
  B: {body: rod, s: [b, 0]}
analysis: {start: 0, end: 1, steps: 360}
"""


HOLD = Path(__file__).resolve().parent / "hold"


def start_held(args, moment: str, ready: Path, cwd=ROOT, count=1, timeout=120, **popen):
    """Start `planarkin ARGS` held at `moment` (tests/hold/sitecustomize.py) and return the
    process once `count` of its processes wait there for a signal: what an interruption test
    interrupts is then always what it says. ready: an empty directory for the hook's files."""
    import time
    ready.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ)
    env.setdefault("MPLBACKEND", "Agg")
    env["PYTHONPATH"] = os.pathsep.join([str(HOLD), str(ROOT), env.get("PYTHONPATH", "")])
    env["PLANARKIN_HOLD"], env["PLANARKIN_HOLD_READY"] = moment, str(ready)
    p = subprocess.Popen(command() + [str(a) for a in args], cwd=cwd, env=env, text=True,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, **popen)
    deadline = time.time() + timeout
    while len(list(ready.iterdir())) < count and p.poll() is None and time.time() < deadline:
        time.sleep(0.005)
    if len(list(ready.iterdir())) < count:
        p.kill()
        raise AssertionError(f"planarkin never reached {moment}: {p.communicate()}")
    return p
