"""A test hook: hold a `planarkin` process at a chosen moment until a signal stops it, so that an
interruption test interrupts what it says, every time (a run timed to be "long enough" may end
before the signal, and the test then passes without exercising its subject).

Active only when PLANARKIN_HOLD is set: the interruption tests put this directory on the
PYTHONPATH of the processes they start, and Python imports sitecustomize in each of them (the
command, and the forkserver and workers of `--jobs`, which inherit the environment). Nothing of
planarkin is imported here: the moment's function is wrapped as its module is first imported.

PLANARKIN_HOLD, the moment (NAMES: result directory names, comma-separated, or *):
  starting        the command has started (its start-up signal handlers are installed), its
                  modules are being imported
  prepare:NAMES   before the analysis is prepared (no directory staged yet; NAMES: the models'
                  names, name: in the YAML)
  staged:NAMES    the model's new directory is staged, as its writer is made
  opened:NAMES    the model's new directory is staged, its first rows solved but not written
  rows:NAMES[:K]  the model's first block of rows (its first K blocks) is in its tables
  finish:NAMES    every row is in the tables, before they are closed
  figure:NAMES:F  the model's figure F (bodies.png ...) is drawn, the others not yet
  sweep-plot      a sweep's tables are staged, its plot not drawn
PLANARKIN_HOLD_READY: a directory; the held process writes a file there (NAME-PID) as it
starts to wait, and goes on when the test deletes it (or when the signal came where planarkin
defers it, in a critical block: the block raises it as it ends). It waits in the interruptible way the run
itself does (a sleep, and the checkpoint between blocks of rows that a `--jobs` worker is
stopped by), at most 120 s, then exits 97 (a test that waits for nothing fails rather than
hangs).
"""

import importlib.abc
import importlib.machinery
import os
import sys
import time

SPEC = os.environ.get("PLANARKIN_HOLD", "")
READY = os.environ.get("PLANARKIN_HOLD_READY", "")


def _wanted(name: str) -> bool:
    names = SPEC.split(":")[1].split(",") if ":" in SPEC else ["*"]
    return "*" in names or name in names


_HELD = []


def hold(name: str, stop=None) -> None:
    """Say so (a file in READY), then wait for the signal that raises Interrupted here; once
    a process (the run's own handling of the interruption may pass the moment again)."""
    if _HELD:
        return
    _HELD.append(name)
    if name == "starting":              # planarkin's start-up handler exits in the sleep
        def checkpoint(stop):
            pass

        def stop_requested():
            return None
    else:
        from planarkin.output.directory import checkpoint, stop_requested
    marker = os.path.join(READY or ".", f"{name}-{os.getpid()}")
    with open(marker, "w") as f:
        f.write(SPEC)
    deadline = time.time() + 120
    while time.time() < deadline:
        time.sleep(0.005)
        checkpoint(stop)
        # released, or the signal came inside a critical block (which raises it as it ends)
        if not os.path.exists(marker) or stop_requested() is not None:
            return
    os._exit(97)


def _model_of(path) -> str:
    """The model's name of a staged directory .NAME.tmp-XXXX."""
    d = os.path.basename(os.path.dirname(str(path)))
    return d[1:].split(".tmp-")[0] if d.startswith(".") else d


def _patch_writer(mod):
    W = mod.DirectoryWriter
    moment = SPEC.split(":")[0]
    init, add, finish = W.__init__, W.add, W.finish

    def staged(self, *a, **k):
        init(self, *a, **k)
        if moment == "staged" and _wanted(self.final.name):
            hold(self.final.name, self.stop)

    blocks = int(SPEC.split(":")[2]) if moment == "rows" and SPEC.count(":") > 1 else 1
    added = {}

    def rows(self, ch):
        if moment == "opened" and _wanted(self.final.name):
            hold(self.final.name, self.stop)
        add(self, ch)
        added[self.final] = added.get(self.final, 0) + 1
        if moment == "rows" and _wanted(self.final.name) and added[self.final] >= blocks:
            hold(self.final.name, self.stop)

    def finishing(self, *a, **k):
        if moment == "finish" and _wanted(self.final.name):
            hold(self.final.name, self.stop)
        return finish(self, *a, **k)
    W.__init__, W.add, W.finish = staged, rows, finishing


def _patch_results(mod):
    prepare = mod.prepare

    def preparing(model, *a, **k):
        if _wanted(model.spec.name):
            hold(model.spec.name)
        return prepare(model, *a, **k)
    mod.prepare = preparing


def _patch_plots(mod):
    save = mod.save_figure
    figure = SPEC.split(":")[2]

    def saving(fig, path):
        out = save(fig, path)
        name = _model_of(path)
        if os.path.basename(str(path)) == figure and _wanted(name):
            hold(name)
        return out
    mod.save_figure = saving


def _patch_study_plots(mod):
    plot = mod.sweep_plot

    def plotting(path, *a, **k):
        hold("sweep")
        return plot(path, *a, **k)
    mod.sweep_plot = plotting


def _starting(mod):
    hold("starting")


PATCHES = {"starting": ("planarkin.cli", _starting),
           "staged": ("planarkin.output.writer", _patch_writer),
           "opened": ("planarkin.output.writer", _patch_writer),
           "rows": ("planarkin.output.writer", _patch_writer),
           "finish": ("planarkin.output.writer", _patch_writer),
           "prepare": ("planarkin.analysis", _patch_results),
           "figure": ("planarkin.output.plots.render", _patch_plots),
           "sweep-plot": ("planarkin.studies.plots", _patch_study_plots)}


class _Finder(importlib.abc.MetaPathFinder):
    """Wraps the moment's module's loader so that the patch runs once the module is loaded."""

    def __init__(self, module, patch):
        self.module, self.patch = module, patch

    def find_spec(self, name, path, target=None):
        if name != self.module:
            return None
        spec = importlib.machinery.PathFinder.find_spec(name, path)
        if spec is None:
            return None
        loader, patch = spec.loader, self.patch
        run = loader.exec_module

        def exec_module(module):
            if patch is _starting:
                patch(module)
            run(module)
            if patch is not _starting:
                patch(module)
        loader.exec_module = exec_module
        return spec


if SPEC:
    _module, _patch = PATCHES[SPEC.split(":")[0]]
    sys.meta_path.insert(0, _Finder(_module, _patch))
