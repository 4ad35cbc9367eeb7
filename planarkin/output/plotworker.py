"""Plots drawn in background processes, so that `planarkin run` does not wait for matplotlib.

Importing matplotlib costs 0.3-0.5 s, as much as the whole analysis of an example model, and
drawing the four figures of a model about 1 s of CPU. `start()` (the first thing `planarkin run`
does when it will plot, or, when no core is free then, once its first model is loaded) forks
the plot server, which imports matplotlib (and the modules a job needs to be unpickled) at
once, behind the parent's own start-up, model loading, solve and CSV writing. On a machine
with two cores or more the server then forks one helper, which inherits the imported
matplotlib (a fork, not a second import). They are the two drawers; each reads jobs from its
own pipe to the parent and answers in order.

A job (model, plot rows, run info, pickled once: a few hundred kB) is a model's figures, its
animation and its rooms' figures (forces.png ...), units of known relative cost. `submit()`
sends it and returns a ticket; `collect(ticket)` waits for the files.

- The parent waits for the job (a single run, the last model of a batch) and both drawers are
  free and find a core each: the job goes to both, each draws its half of the units (by cost);
- else (a batch: the parent goes on solving the next model) the job goes whole to a free
  drawer, and the CLI leaves up to `capacity()` jobs in flight: two models are drawn while the
  next one solves, one when the machine has no core to spare for the second drawer (then the
  batch is drawn as by a single server) and never more drawers than cores.

Processes: the server is the parent's child (joined by `stop()`: called by the CLI when the
batch ends, and at exit as a safety net), the helper the server's (the server waits for it
before it ends). Both end on end of file when the parent dies. Without fork (or when both
drawers have died) `submit()` returns None and the caller draws in its own process.
"""

from __future__ import annotations

import atexit
import os
import signal

_pool = None            # the running drawers of this process (a _Pool), if any
_HELLO = "hello"        # the helper's first message on its pipe: ("hello", its pid)

# relative drawing cost of a job's units (CPU measured on the examples, 2026-12-01:
# bodies.png 0.36-0.42 s, points 0.18-0.20, trajectories 0.14-0.23, mechanism 0.17-0.25,
# animation.gif 0.77-0.98, forces.png 0.45-0.6); only the split of a job between the two
# drawers depends on them
COST = {"bodies": 1.9, "points": 1.0, "trajectories": 1.0, "mechanism": 1.1, "animation": 4.6,
        "room": 2.5}


class _Drawer:
    """The parent's end of one drawer: its pipe, its pid once known, its tickets in flight."""

    def __init__(self, conn, pid=None):
        self.conn = conn
        self.pid = pid
        self.alive = True
        self.queue: list[int] = []      # tickets whose answers this drawer still owes, in order


class _Pool:
    def __init__(self, proc, drawers):
        self.proc = proc                # the server (a multiprocessing Process)
        self.drawers = drawers          # [server, helper] or [server]
        self.jobs = 0                   # jobs sent
        self.parts: dict[int, list[_Drawer]] = {}       # ticket -> drawers of its parts
        self.answers: dict[int, list] = {}              # ticket -> answers read so far
        self.forgotten: set[int] = set()                # tickets whose caller gave up
        self.next_ticket = 1


def start(early: bool = False) -> None:
    """Fork the plot server (once per process; nothing where fork does not exist).

    early=True: called by `planarkin.__main__` as its first act when the command line asks for
    plots, before click and numpy are imported, so that the server's 0.5 s of importing
    overlaps the parent's own start-up too; only when a core is free (else the server would
    import numpy and planarkin's modules a second time, 0.3-0.5 s of CPU, for nothing).
    Otherwise `planarkin run` calls it once the first model is loaded: the server then inherits
    numpy and the modules a job needs, and imports matplotlib alone."""
    global _pool
    if _pool is not None or (early and not _idle_core()):
        return
    import multiprocessing as mp
    try:
        ctx = mp.get_context("fork")
    except ValueError:
        return
    pipes = [ctx.Pipe() for _ in range(2 if _cores() >= 2 else 1)]
    proc = ctx.Process(target=_serve, args=([c for _, c in pipes], [p for p, _ in pipes]),
                       daemon=True, name="planarkin-plots")
    proc.start()
    for _, child in pipes:
        child.close()
    drawers = [_Drawer(p) for p, _ in pipes]
    drawers[0].pid = proc.pid
    _pool = _Pool(proc, drawers)
    atexit.register(stop)


def wanted(argv: list[str]) -> bool:
    """Whether a command line (sys.argv[1:]) is a `planarkin run` that will draw: a guess made
    before parsing it, so that the server can start first. A wrong guess costs nothing: `run`
    stops a server it does not need, and one that never had a job is killed at exit."""
    return bool(argv) and argv[0] == "run" and not {"--no-plots", "--help", "-h"} & set(argv)


def running() -> bool:
    return _pool is not None and any(d.alive for d in _pool.drawers)


def capacity() -> int:
    """How many jobs a caller that goes on working (a batch) may have in flight: 2 when both
    drawers live and a core is free for the second one beside the other processes of the
    machine, else 1."""
    if not running():
        return 1
    alive = [d for d in _pool.drawers if d.alive]
    return 2 if len(alive) >= 2 and _idle_core() else 1


def draw(cm, data, info, out, fmt: str | None, animate, x: str = "time"):
    """Draw the figures (fmt: png, svg, pdf or None for none; x: their abscissa) and
    animation.gif of one run into directory out (animate: False, True or the keyword arguments
    of plots.write_animation), in the drawers; returns the files written (Paths, in figure
    order), or None when there is no server (the caller then draws in its own process). Raises
    RuntimeError when the drawing itself failed."""
    ticket = submit(cm, data, info, out, fmt, animate, x)
    return collect(ticket) if ticket else None


def submit(cm, data, info, out, fmt: str | None, animate, x: str = "time",
           waits: bool = True) -> int | None:
    """Send a job (arguments as for draw) and return at once: its ticket (for `collect`), or
    None when there is no server. waits: the caller waits for the answer next (its units are
    then shared by both drawers when both are free and the machine has a core for each;
    False: the caller goes on solving the next model of a batch, the job goes whole to one
    drawer)."""
    if not running():
        return None
    pool = _pool
    for d in pool.drawers:
        _drain(d)
    free = [d for d in pool.drawers if d.alive and not d.queue]
    if not free:            # (the caller exceeded capacity(): wait on the least busy one)
        free = sorted((d for d in pool.drawers if d.alive), key=lambda d: len(d.queue))[:1]
    use = free[:2] if waits and len(free) >= 2 and _idle_core() else free[:1]
    import pickle
    blob = pickle.dumps((cm, data, info, str(out), fmt, animate, x),
                        protocol=pickle.HIGHEST_PROTOCOL)
    ticket = pool.next_ticket
    pool.next_ticket += 1
    sent = []
    for k, d in enumerate(use):
        try:
            d.conn.send((blob, k, len(use)))
        except OSError:
            _dead(d)
            continue
        d.queue.append(ticket)
        sent.append(d)
    if len(sent) < len(use):    # a drawer died before it had its part: no half jobs
        pool.forgotten.add(ticket)
        return submit(cm, data, info, out, fmt, animate, x, waits) if running() else None
    pool.parts[ticket] = sent
    pool.answers[ticket] = []
    pool.jobs += 1
    return ticket


def collect(ticket: int | None):
    """Wait for the answers of a job sent by `submit`: the files written, in figure order, or
    None when a drawer died meanwhile (killed, out of memory: the caller draws in its own
    process). Raises RuntimeError when the drawing failed."""
    if _pool is None or ticket not in _pool.parts:
        return None
    pool = _pool
    drawers = pool.parts[ticket]
    try:
        for d in drawers:
            while ticket in d.queue:
                _read(d)
    finally:
        if all(ticket not in d.queue for d in drawers):
            del pool.parts[ticket]
    answers = pool.answers.pop(ticket, [])
    if len(answers) < len(drawers) or any(a is None for a in answers):
        return None
    errors = [payload for status, payload in answers if status != "ok"]
    if errors:
        raise RuntimeError(f"drawing the plots failed: {errors[0]}")
    from pathlib import Path
    units = sorted(u for _, payload in answers for u in payload)
    return [Path(p) for _, files in units for p in files]


def forget(ticket: int | None) -> None:
    """The caller gives up on a job (its directory abandoned): its answers are read and
    dropped whenever they come."""
    if _pool is not None and ticket in _pool.parts:
        _pool.forgotten.add(ticket)
        del _pool.parts[ticket]
        _pool.answers.pop(ticket, None)


def finish_job(ticket: int | None) -> None:
    """Wait until nothing draws into the job's directory any more (its answers are dropped):
    an interrupted caller puts the directory in place right after."""
    if _pool is None or ticket not in _pool.parts:
        return
    drawers = _pool.parts[ticket]
    forget(ticket)
    for d in drawers:
        while d.alive and ticket in d.queue:
            _read(d)


def _read(d: _Drawer) -> None:
    """Read one message of drawer d: its hello, or the answer for the head of its queue. The
    wait may be interrupted (a signal raises there); the reading itself is not, so that a
    message is never half read."""
    from .directory import held_signals
    pool = _pool
    try:
        d.conn.poll(None)
        with held_signals():
            msg = d.conn.recv()
    except (EOFError, OSError):
        _dead(d)
        return
    if isinstance(msg, tuple) and msg and msg[0] == _HELLO:
        d.pid = msg[1]
        return
    ticket = d.queue.pop(0)
    if ticket in pool.answers:
        pool.answers[ticket].append(msg)
    elif not any(ticket in o.queue for o in pool.drawers):
        pool.forgotten.discard(ticket)          # the last answer of a job given up


def _drain(d: _Drawer) -> None:
    """Read, without waiting, what drawer d has sent of its hello (its pid) and of its answers
    to jobs whose callers gave up."""
    while d.alive and (d.pid is None or (d.queue and d.queue[0] in _pool.forgotten)):
        try:
            if not d.conn.poll():
                return
        except (EOFError, OSError):
            pass                                # _read finds it dead
        _read(d)


def _dead(d: _Drawer) -> None:
    """A drawer died (or its pipe broke): its jobs in flight get no answer (None)."""
    d.alive = False
    for ticket in d.queue:
        if ticket in _pool.answers:
            _pool.answers[ticket].append(None)
    d.queue.clear()
    try:
        d.conn.close()
    except OSError:
        pass


def stop() -> None:
    """Tell the drawers to finish (the jobs in flight are drawn to their end, so that nothing
    draws into a directory after this returns) and wait for them (terminate them if they do not
    end). A server that never had a job is killed at once: it may still be importing
    matplotlib (a command line error, or `run` without plots after the guess of `wanted`),
    and nothing of it is written anywhere."""
    global _pool
    if _pool is None:
        return
    pool, _pool = _pool, None
    proc = pool.proc
    if not pool.jobs:
        proc.kill()
        proc.join()
        for d in pool.drawers:
            if d.alive:
                d.conn.close()
        return
    import time
    for d in pool.drawers:
        if d.alive:
            try:
                d.conn.send(None)
            except OSError:
                pass
    deadline = time.monotonic() + 30
    for d in pool.drawers:
        ended = not d.alive
        while not ended:            # what it still sends, then end of file once it has exited
            left = deadline - time.monotonic()
            try:
                if left <= 0 or not d.conn.poll(left):
                    break
                d.conn.recv()
            except (EOFError, OSError):
                ended = True
        if not ended and d is not pool.drawers[0] and d.pid is not None:
            try:                    # a helper that does not end (an orphan if the server died)
                os.kill(d.pid, signal.SIGKILL)
            except OSError:
                pass
        try:
            d.conn.close()
        except OSError:
            pass
    proc.join(timeout=max(0.0, deadline - time.monotonic()))
    if proc.is_alive():
        proc.terminate()
        proc.join()


# -- in the drawers ------------------------------------------------------------------------------

def _serve(conns, parent_ends) -> None:
    """Body of the server: import matplotlib, fork the helper (two pipes), then draw jobs until
    None or the parent is gone; wait for the helper."""
    for c in parent_ends:
        c.close()
    # a Ctrl-C is the parent's to handle; the drawers end when the parent closes the pipes
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    from .directory import close_inherited
    close_inherited([c.fileno() for c in conns], keep_stderr=True)
    _warm_up()
    helper = None
    if len(conns) > 1:
        helper = os.fork()
        if helper == 0:
            conns[0].close()
            code = 0
            try:
                conns[1].send((_HELLO, os.getpid()))
                _loop(conns[1])
            except BaseException:  # noqa: BLE001 - the parent sees end of file
                code = 1
            finally:
                os._exit(code)      # no atexit handlers, no flushing of the parent's buffers
        conns[1].close()
    try:
        _loop(conns[0])
    finally:
        if helper:
            os.waitpid(helper, 0)


def _loop(conn) -> None:
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):
            break
        if msg is None:
            break
        blob, part, parts = msg
        try:
            import pickle
            reply = ("ok", _draw(*pickle.loads(blob), part=part, parts=parts))
        except BaseException as e:  # noqa: BLE001 - reported by the parent
            reply = ("error", f"{type(e).__name__}: {e}")
        try:
            conn.send(reply)
        except OSError:
            break


def _warm_up() -> None:
    """What the parent should not wait for: importing matplotlib and the modules a job's
    unpickling imports (the compiled model's, the solver's chunk, the run info: 0.1-0.2 s),
    and the first drawing (the font file opened, the first glyphs rendered, the png encoder
    loaded), here on a tiny figure that is thrown away."""
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
    from .. import derived, results  # noqa: F401 - what unpickling a job imports
    from ..model import compile  # noqa: F401
    fig = Figure(figsize=(1, 1))
    ax = fig.add_subplot()
    ax.plot([0, 1], [0, 1])
    ax.set_xlabel("t [s]")
    fig.savefig(io.BytesIO(), format="png", dpi=30)


def units(cm, info, fmt, animate) -> list[tuple]:
    """A job's units, in the order of its files: the model's figures, the animation, the rooms'
    figures: ("figure", name) | ("animation",) | ("room", k) (k: index in derived_tables)."""
    out: list[tuple] = []
    if fmt:
        from . import plots
        out += [("figure", n) for n in plots.figure_names(cm)]
    if animate:
        out.append(("animation",))
    if fmt:
        from ..derived import derived_tables
        out += [("room", k) for k, d in enumerate(derived_tables(cm, info.options))
                if d.plot is not None]
    return out


def _cost(unit: tuple) -> float:
    return COST.get(unit[1] if unit[0] == "figure" else unit[0], 1.0)


def split(units_: list[tuple], parts: int) -> list[list[int]]:
    """The units' indices in `parts` groups of about equal cost (COST): the grouping with the
    smallest largest group (exhaustive for up to 12 units, else largest first to the lightest);
    every drawer computes the same."""
    n = len(units_)
    if parts <= 1 or n <= 1:
        return [list(range(n))] + [[] for _ in range(max(parts, 1) - 1)]
    costs = [_cost(u) for u in units_]
    if parts == 2 and n <= 12:
        total = sum(costs)
        best = None
        for mask in range(1 << (n - 1)):      # unit n-1 always in the second group
            a = sum(c for k, c in enumerate(costs) if mask >> k & 1)
            worst = max(a, total - a)
            if best is None or worst < best[0] - 1e-9:
                best = (worst, mask)
        mask = best[1]
        return [[k for k in range(n) if mask >> k & 1],
                [k for k in range(n) if not mask >> k & 1]]
    groups: list[list[int]] = [[] for _ in range(parts)]
    load = [0.0] * parts
    for k in sorted(range(n), key=lambda k: -costs[k]):
        g = load.index(min(load))
        groups[g].append(k)
        load[g] += costs[k]
    return [sorted(g) for g in groups]


def _draw(cm, data, info, out, fmt, animate, x, part=0, parts=1):
    """Draw this drawer's share of a job: [(unit index, [file names])...]. The parent never
    imports matplotlib."""
    from pathlib import Path

    from . import plots
    out = Path(out)
    todo = units(cm, info, fmt, animate)
    mine = [todo[k] for k in split(todo, parts)[part]] if parts > 1 else todo
    index = {u: k for k, u in enumerate(todo)}
    done = []
    figs = [u[1] for u in mine if u[0] == "figure"]
    if figs:
        files = plots.write_plots(cm, data, info, out, fmt, only=figs, x=x)
        by_stem = {p.stem: p for p in files}
        done += [(index[("figure", f)], [str(by_stem[f])] if f in by_stem else [])
                 for f in figs]
    if ("animation",) in mine:
        opts = animate if isinstance(animate, dict) else {}
        done.append((index[("animation",)], [str(plots.write_animation(cm, data, out,
                                                                        **opts))]))
    rooms = [u[1] for u in mine if u[0] == "room"]
    if rooms:
        from ..derived import derived_tables
        tables = derived_tables(cm, info.options)
        for k in rooms:
            d = tables[k]
            done.append((index[("room", k)],
                         [str(p) for p in d.plot(cm, d.compute(data), info, out, fmt)]))
    return done


def _idle_core() -> bool:
    """Whether a second process of ours would find a core to run on: the processes runnable
    now that are not ours (this one, its children, the plot helper) leave at least two cores.
    On a machine already busy a second drawer (or the early server) would only add the cost of
    the fork and of the work both processes repeat, and finish no sooner (measured at load 6 on
    2 cores: 10-25 % more CPU, no sooner).

    Counted now (/proc/loadavg's runnable count, less the runnable threads of our own
    processes: the parent's BLAS threads spin for a while after a solve, and a drawer or writer
    at work is no other process), the fewest of three looks 2 ms apart (a shell starting a
    command for an instant is no busy machine), not by the 1-minute load average alone, which
    counts this run's own start-up and the runs before it. The average only rules out a
    machine busy for a while (above twice the cores: more than our own processes make)."""
    cores = _cores()
    if cores < 2:
        return False
    import time
    fewest = None
    for k in range(3):
        runnable = _runnable()
        if runnable is None:
            try:
                return os.getloadavg()[0] < cores - 0.5
            except OSError:
                return True
        others = runnable - _ours_running()
        fewest = others if fewest is None else min(fewest, others)
        if fewest <= cores - 2:
            break
        if k < 2:
            time.sleep(0.002)
    return fewest <= cores - 2 and _load() < 2 * cores + 1


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


def _our_pids() -> set[int]:
    """This process, its multiprocessing children (table writers, the plot server) and the
    plot helper."""
    import sys
    pids = {os.getpid()}
    mp = sys.modules.get("multiprocessing")
    if mp is not None:
        pids |= {p.pid for p in mp.active_children() if p.pid}
    if _pool is not None:
        pids |= {d.pid for d in _pool.drawers if d.pid and d.alive}
    return pids


def _ours_running() -> int:
    """Runnable threads of our processes (at least 1: this one, reading)."""
    n = 0
    for pid in _our_pids():
        try:
            tasks = os.listdir(f"/proc/{pid}/task")
        except OSError:
            continue
        for t in tasks:
            try:
                with open(f"/proc/{pid}/task/{t}/stat", "rb") as f:
                    state = f.read().rpartition(b")")[2].split(None, 1)[0]
            except (OSError, IndexError):
                continue
            n += state == b"R"
    return max(n, 1)
