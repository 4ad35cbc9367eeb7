"""Shared helpers of the benchmark scripts: machine header, the planarkin command, timing."""

from __future__ import annotations

import datetime
import os
import platform
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent          # the checkout holding planarkin/
sys.path.insert(0, str(ROOT))                           # import the checkout's planarkin


def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def git_revision() -> str:
    try:
        rev = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
                             capture_output=True, text=True, timeout=10).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "--",
                                "planarkin"], capture_output=True, text=True,
                               timeout=10).stdout.strip()
        return rev + (" (planarkin/ has uncommitted changes)" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def source_digest() -> str:
    """sha256 (first 12 hex digits) of every planarkin/**/*.py: identifies the code measured,
    uncommitted changes included."""
    import hashlib
    h = hashlib.sha256()
    for f in sorted((ROOT / "planarkin").rglob("*.py")):
        h.update(str(f.relative_to(ROOT)).encode())
        h.update(f.read_bytes())
    return h.hexdigest()[:12]


def machine_info() -> dict:
    import numpy
    import planarkin
    return {
        "date": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
        "platform": platform.platform(),
        "cpu": cpu_model(),
        "cpus": os.cpu_count(),
        "python": platform.python_version(),
        "numpy": numpy.__version__,
        "planarkin": planarkin.__version__,
        "planarkin_path": str(Path(planarkin.__file__).parent),
        "git": git_revision(),
        "source_sha256": source_digest(),
        "loadavg_start": os.getloadavg(),
    }


def print_header(info: dict, title: str) -> None:
    print(f"{title}")
    print(f"date       {info['date']}")
    print(f"platform   {info['platform']}")
    print(f"cpu        {info['cpu']} x {info['cpus']}")
    print(f"python     {info['python']}   numpy {info['numpy']}")
    print(f"planarkin  {info['planarkin']} from {info['planarkin_path']} (git {info['git']}; "
          f"sources sha256 {info['source_sha256']})")
    la = info["loadavg_start"]
    print(f"load avg   {la[0]:.2f} {la[1]:.2f} {la[2]:.2f} (1/5/15 min) at start"
          + ("   ** machine busy: timings are noisy **" if la[0] > 0.5 * (info['cpus'] or 1)
             else ""))
    print(f"command    {' '.join(planarkin_command()[0])}")
    print()


def planarkin_command() -> tuple[list[str], dict]:
    """(argv prefix, environment) of the planarkin CLI: the console script if on PATH (a pyenv
    shim is resolved to the real script, so the shim's bash start-up is not timed), else
    `python -m planarkin` with PYTHONPATH = the checkout."""
    env = dict(os.environ)
    exe = shutil.which("planarkin")
    if exe:
        if "/shims/" in exe and shutil.which("pyenv"):
            try:
                real = subprocess.run(["pyenv", "which", "planarkin"], capture_output=True,
                                      text=True, timeout=20).stdout.strip()
                if real and os.access(real, os.X_OK):
                    exe = real
            except (OSError, subprocess.SubprocessError):
                pass
        return [exe], env
    env["PYTHONPATH"] = str(ROOT) + (os.pathsep + env["PYTHONPATH"]
                                     if env.get("PYTHONPATH") else "")
    return [sys.executable, "-m", "planarkin"], env


def run_cli(args: list[str], timeout: float = 3600):
    """Run planarkin ARGS; returns (wall seconds around subprocess.run, CPU seconds of the
    child (user + sys, from RUSAGE_CHILDREN), completed process)."""
    import resource
    cmd, env = planarkin_command()
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run(cmd + list(args), capture_output=True, text=True, env=env, cwd=ROOT,
                       timeout=timeout)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    if p.returncode != 0:
        raise RuntimeError(f"planarkin {' '.join(args)} exited with {p.returncode}:\n"
                           f"{p.stdout}\n{p.stderr}")
    return wall, cpu, p


def best_of(fn, repeat: int) -> tuple[float, object]:
    """Best wall time of `repeat` calls of fn() and the result of the best call."""
    best, out = float("inf"), None
    for _ in range(repeat):
        t0 = time.perf_counter()
        r = fn()
        dt = time.perf_counter() - t0
        if dt < best:
            best, out = dt, r
    return best, out
