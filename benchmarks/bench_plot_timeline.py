"""Where the time of a `planarkin run` with plots goes, process by process: a timeline.

    python benchmarks/bench_plot_timeline.py [--force-idle] [MODEL.yaml ...] [-- RUN OPTIONS]

Runs `planarkin run` in this process (the early fork included) with the plot server's steps
wrapped so that every process appends a time stamp to one file: the fork, matplotlib imported,
each job received, each figure saved, each answer sent and read, each directory put in place,
the process's exit. Times are seconds since this script started (about 0.03 s after the
interpreter did). Default: mechanisms/four-bar.yaml; give several models for a batch.
--force-idle: the plot processes act as on a quiet machine (a core free for each drawer), to
see their structure on a busy one (the times are then those of a busy machine).
"""

from __future__ import annotations

import time

T0 = time.perf_counter()

import os  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

LOG = None


def mark(what: str) -> None:
    line = f"{time.perf_counter() - T0:8.3f} {os.getpid():>7} {what}\n"
    fd = os.open(LOG, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
    try:
        os.write(fd, line.encode())
    finally:
        os.close(fd)


def wrap(module, name: str, before=None, after=None) -> None:
    fn = getattr(module, name)

    def wrapper(*a, **k):
        if before:
            mark(before(*a, **k) if callable(before) else before)
        r = fn(*a, **k)
        if after:
            mark(after(r, *a, **k) if callable(after) else after)
        return r
    wrapper.__wrapped__ = fn
    setattr(module, name, wrapper)


_LATER = {}        # module name -> wrapping to do once it is imported (not before: the
                   # run's own imports must happen where they happen in a real run)


class _AfterImport:
    """A meta-path finder that wraps functions of a module right after it is executed."""

    def find_spec(self, name, path=None, target=None):
        if name not in _LATER:
            return None
        import importlib.machinery
        spec = importlib.machinery.PathFinder.find_spec(name, path)
        if spec is None or spec.loader is None:
            return None
        loader = spec.loader
        run = loader.exec_module

        def exec_module(module):
            run(module)
            _LATER.pop(name)(module)
        loader.exec_module = exec_module
        return spec


def instrument() -> None:
    import atexit
    atexit.register(lambda: mark("exit (atexit, last handler)"))
    def plots(m):
        wrap(m, "_save", after=lambda r, fig, path: f"saved {Path(path).name} "
             f"({Path(path).parent.name[-22:]})")

    def directory(m):
        wrap(m.ResultDirectory, "commit", after=lambda r, self: f"commit {self.final.name}")

    def writer(m):
        wrap(m.DirectoryWriter, "finish", before="parent: finish begins",
             after="parent: finish returns")
        wrap(m.DirectoryWriter, "_close_tables", after="parent: tables closed")
        wrap(m.DirectoryWriter, "_plots", before="parent: plots begin", after="parent: plots done")

    def results(m):
        wrap(m, "stream", before="parent: solve (stream) begins", after="parent: solve done")

    def cli(m):
        mark("cli imported (click, numpy ...)")

    _LATER.update({"planarkin.output.plots": plots, "planarkin.output.directory": directory,
                   "planarkin.output.writer": writer, "planarkin.analysis": results,
                   "planarkin.cli": cli})
    sys.meta_path.insert(0, _AfterImport())
    _os_exit = os._exit

    def exiting(code):
        mark(f"os._exit({code})")
        _os_exit(code)
    os._exit = exiting


def main() -> None:
    global LOG
    args = sys.argv[1:]
    extra = []
    if "--" in args:
        k = args.index("--")
        args, extra = args[:k], args[k + 1:]
    models = args or [str(ROOT / "mechanisms" / "four-bar.yaml")]
    tmp = tempfile.mkdtemp(prefix="plot-timeline-")
    LOG = os.path.join(tmp, "timeline.log")
    instrument()
    mark("instrumented")
    sys.argv = ["planarkin", "run", *models, "-q", "--out", os.path.join(tmp, "out"), *extra]
    pid = os.fork()
    if pid == 0:
        from planarkin.__main__ import entry
        try:
            entry()
        except SystemExit as e:
            mark(f"SystemExit({e.code})")
            raise
    _, status = os.waitpid(pid, 0)
    mark("the run's process was reaped")
    time.sleep(0.2)
    with open(LOG) as f:
        lines = f.read().splitlines()
    lines.sort(key=lambda s: float(s.split()[0]))
    pids = []
    for line in lines:
        p = line.split()[1]
        if p not in pids:
            pids.append(p)
    names = {p: f"P{k}" for k, p in enumerate(pids)}
    for line in lines:
        t, p, what = line.split(None, 2)
        print(f"{t} {names[p]:>3}  {what}")
    print(f"({tmp}; P0 this script, P1 the run, then in order of appearance)")


if __name__ == "__main__":
    main()
