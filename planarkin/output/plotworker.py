"""Plots drawn in background processes, so that `planarkin run` does not wait for matplotlib.

Importing matplotlib costs 0.3-0.5 s, as much as the whole analysis of an example model, and
drawing the four figures of a model as much again. `start()` (the first thing `planarkin run`
does when it will plot) forks one server process that imports matplotlib at once, behind the
parent's own start-up, model loading, solve and CSV writing, and then waits for jobs. `draw()`
sends it a job (model, plot rows and run info, pickled: a few hundred kB) and waits for the file
names. When a core is idle the server splits the job's figures between itself and one child it
forks for the job (the child inherits the imported matplotlib), so a model's figures take about
half the time of drawing them one after the other; on a busy machine it draws them all itself.
In a batch the same server serves every model: matplotlib is imported once per call.

Processes: at most two draw at any time (the server and its child of the current job); the child
is waited for by the server before it answers, the server by `stop()` (called by the CLI when the
batch ends, and at exit as a safety net). Without fork (or when the server has died) `draw()`
returns None and the caller draws in its own process.
"""

from __future__ import annotations

import atexit
import json
import os
import signal

_server = None          # (process, connection) of the running server of this process, if any
_pending = False        # a job was sent and its answer not read yet
_jobs = 0               # jobs sent to the running server


def start(early: bool = False) -> None:
    """Fork the plot server (once per process; nothing where fork does not exist).

    early=True: called by `planarkin.__main__` as its first act when the command line asks for
    plots, before click and numpy are imported, so that the server's 0.5 s of importing
    overlaps the parent's own start-up too; only when a core is free (else the server would
    import numpy and planarkin's modules a second time, 0.1-0.3 s of CPU, for nothing).
    `planarkin run` calls it again (a no-op when the server runs)."""
    global _server, _jobs
    if _server is not None or (early and not _idle_core()):
        return
    import multiprocessing as mp

    # numpy before the fork when the machine is busy: the parent needs it anyway, and the
    # server then does not import it a second time (CPU a busy machine does not have to spare);
    # with a core free both import it at once, and the server is ready 0.2 s sooner
    if not _idle_core():
        import numpy  # noqa: F401
    try:
        ctx = mp.get_context("fork")
    except ValueError:
        return
    parent, child = ctx.Pipe()
    proc = ctx.Process(target=_serve, args=(child, parent), daemon=True, name="planarkin-plots")
    proc.start()
    child.close()
    _server = (proc, parent)
    _jobs = 0
    atexit.register(stop)


def wanted(argv: list[str]) -> bool:
    """Whether a command line (sys.argv[1:]) is a `planarkin run` that will draw: a guess made
    before parsing it, so that the server can start first. A wrong guess costs nothing: `run`
    stops a server it does not need, and one that never had a job is killed at exit."""
    return bool(argv) and argv[0] == "run" and not {"--no-plots", "--help", "-h"} & set(argv)


def running() -> bool:
    return _server is not None


def draw(cm, data, info, out, fmt: str | None, animate, x: str = "time"):
    """Draw the figures (fmt: png, svg, pdf or None for none; x: their abscissa) and
    animation.gif of one run into directory out (animate: False, True or the keyword arguments
    of plots.write_animation), in the server; returns the files written (Paths, in figure
    order), or None when there is no server (the caller then draws in its own process). Raises
    RuntimeError when the drawing itself failed."""
    return collect() if submit(cm, data, info, out, fmt, animate, x) else None


def submit(cm, data, info, out, fmt: str | None, animate, x: str = "time",
           waits: bool = True) -> bool:
    """Send a job (arguments as for draw) and return at once: True when the server has it
    (its answer is then read by `collect`), False when there is no server. waits: the caller
    waits for the answer next (False: it goes on solving the next model of a batch)."""
    global _pending, _jobs
    if _server is None:
        return False
    if _pending:                    # a job whose caller gave up on it (an error in between)
        try:
            collect()
        except RuntimeError:
            pass
        if _server is None:
            return False
    try:
        _server[1].send((cm, data, info, str(out), fmt, animate, x, waits))
    except OSError:
        stop()
        return False
    _pending = True
    _jobs += 1
    return True


def collect():
    """Wait for the answer to the job sent by `submit`: the files written, or None when the
    server died meanwhile (the caller draws in its own process; later jobs too)."""
    global _pending
    if _server is None or not _pending:
        return None
    _pending = False
    try:
        status, payload = _server[1].recv()
    except (EOFError, OSError):
        stop()                  # killed, out of memory: draw here from now on
        return None
    if status != "ok":
        raise RuntimeError(f"drawing the plots failed: {payload}")
    from pathlib import Path
    return [Path(p) for p in payload]


def stop() -> None:
    """Tell the server to finish and wait for it (terminate it if it does not end). A server
    that never had a job is killed at once: it may still be importing matplotlib (a command
    line error, or `run` without plots after the guess of `wanted`), and nothing of it is
    written anywhere."""
    global _server, _pending
    if _server is None:
        return
    proc, conn = _server
    _server = None
    _pending = False
    if not _jobs:
        proc.kill()
        proc.join()
        conn.close()
        return
    try:
        conn.send(None)
    except OSError:
        pass
    conn.close()
    proc.join(timeout=30)
    if proc.is_alive():
        proc.terminate()
        proc.join()


# -- in the server -------------------------------------------------------------------------------

def _serve(conn, parent_end) -> None:
    """Body of the server: import matplotlib, then draw jobs until None or the parent is gone."""
    parent_end.close()
    # a Ctrl-C is the parent's to handle; the server ends when the parent closes the pipe
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    from .directory import close_inherited
    close_inherited((conn.fileno(),), keep_stderr=True)
    _warm_up()
    while True:
        try:
            job = conn.recv()
        except (EOFError, OSError):
            break
        if job is None:
            break
        try:
            reply = ("ok", [str(p) for p in _draw(*job)])
        except BaseException as e:  # noqa: BLE001 - reported by the parent
            reply = ("error", f"{type(e).__name__}: {e}")
        try:
            conn.send(reply)
        except OSError:
            break


def _warm_up() -> None:
    """What the parent should not wait for: importing matplotlib, and the first drawing (the
    font file opened, the first glyphs rendered, the png encoder loaded), here on a tiny
    figure that is thrown away."""
    import io
    import sys
    import warnings

    # matplotlib.projections imports the 3-D axes (mpl_toolkits.mplot3d, 0.05-0.09 s of the
    # 0.5 s import) only to register them, and goes on without them when that import fails;
    # no figure of planarkin is 3-D. Where a later matplotlib would need them, import again.
    sys.modules.setdefault("mpl_toolkits.mplot3d", None)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            from matplotlib.figure import Figure
    except ImportError:
        for name in [m for m in sys.modules if m.startswith(("matplotlib", "mpl_toolkits"))]:
            del sys.modules[name]
        from matplotlib.figure import Figure
    if sys.modules.get("mpl_toolkits.mplot3d", 0) is None:
        del sys.modules["mpl_toolkits.mplot3d"]

    from . import plots  # noqa: F401 - numpy, the tables module
    fig = Figure(figsize=(1, 1))
    ax = fig.add_subplot()
    ax.plot([0, 1], [0, 1])
    ax.set_xlabel("t [s]")
    fig.savefig(io.BytesIO(), format="png", dpi=30)


def split(names: list[str], animate: bool) -> tuple[list[str], list[str], bool]:
    """(figures for the child, figures for the server, whether the child draws the animation):
    about equal halves of the drawing time. bodies.png (six axes) costs about what the other
    three together cost; the animation about what all four cost."""
    if not names:                   # the animation alone: no one to share it with
        return [], [], False
    if animate:
        return [], names, True
    return names[:1], names[1:], False


def _idle_core(patient: bool = False) -> bool:
    """Whether a second drawing process would find a core to run on: fewer processes runnable
    now, besides this server, than cores. On a machine already busy it would only add the cost
    of the fork and of the work both processes repeat, and finish no sooner (measured at load
    6 on 2 cores: 10-25 % more CPU, no sooner).

    Counted now (/proc/loadavg's runnable count), not by the 1-minute load average alone, which
    still counts this run's own start-up and the runs before it: on a quiet 2-core machine that
    average (1.5-2 after a few runs) kept the split from ever happening. The average only rules
    out a machine busy for a while (at least one more than the cores), whose run queue empties
    for an instant now and then. patient: the parent is
    about to wait for this job, but is still closing its tables (20-45 ms): look again, 3 ms
    apart, for up to 30 ms (in a batch the parent goes on solving: one look).
    """
    cores = _cores()
    if cores < 2:
        return False
    import time
    looks = 10 if patient else 1
    for k in range(looks):
        runnable = _runnable()
        if runnable is None:
            try:
                return os.getloadavg()[0] < cores - 0.5
            except OSError:
                return True
        if runnable - 1 < cores - 1 and _load() < cores + 1:
            return True
        if k + 1 < looks:
            time.sleep(0.003)
    return False


def _load() -> float:
    try:
        return os.getloadavg()[0]
    except OSError:
        return 0.0


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def _runnable() -> int | None:
    """Processes runnable on the machine now, this one included (None where not known)."""
    try:
        with open("/proc/loadavg") as f:
            return int(f.read().split()[3].partition("/")[0])
    except (OSError, ValueError, IndexError):
        return None


def _draw(cm, data, info, out, fmt, animate, x, waits=True):
    """The model's figures, then the rooms' (forces.png, measures.png ...), all in the server:
    the parent never imports matplotlib."""
    files = _draw_model(cm, data, info, out, fmt, animate, x, waits)
    if fmt:
        from pathlib import Path

        from ..derived import derived_tables
        for d in derived_tables(cm, info.options):
            if d.plot is not None:
                files += d.plot(cm, d.compute(data), info, Path(out), fmt)
    return files


def _draw_model(cm, data, info, out, fmt, animate, x, waits=True):
    from pathlib import Path

    from . import plots
    out = Path(out)
    names = plots.figure_names(cm) if fmt else []
    mine_child, mine, child_anim = split(names, animate) if _idle_core(patient=waits) \
        else ([], names, False)

    def part(figs, anim):
        files = plots.write_plots(cm, data, info, out, fmt, only=figs, x=x) if figs and fmt \
            else []
        if anim:
            opts = animate if isinstance(animate, dict) else {}
            files.append(plots.write_animation(cm, data, out, **opts))
        return files

    if not (mine_child or child_anim):
        return part(mine, animate)
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:                                        # the job's child
        code = 0
        try:
            os.close(r)
            msg = {"ok": [str(p) for p in part(mine_child, child_anim)]}
        except BaseException as e:  # noqa: BLE001 - reported through the server
            msg = {"error": f"{type(e).__name__}: {e}"}
            code = 1
        try:
            os.write(w, json.dumps(msg).encode())
        finally:
            os._exit(code)              # no atexit handlers, no flushing of the parent's buffers
    os.close(w)
    try:
        files = part(mine, animate and not child_anim)
    finally:
        with os.fdopen(r, "rb") as f:
            raw = f.read()
        os.waitpid(pid, 0)
    msg = json.loads(raw or b'{"error": "the plot process ended without an answer"}')
    if "error" in msg:
        raise RuntimeError(msg["error"])
    theirs = [Path(p) for p in msg["ok"]]
    order = {n: k for k, n in enumerate(names)}
    figs = sorted((p for p in theirs + files if p.name != "animation.gif"),
                  key=lambda p: order.get(p.stem, len(order)))
    return figs + [p for p in theirs + files if p.name == "animation.gif"]
