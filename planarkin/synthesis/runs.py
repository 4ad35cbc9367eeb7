"""A search's local runs: one run from its start (`run_from`), and runs computed ahead in worker
processes (`Ahead`, synthesize(jobs=N)) with the serial search's result.

A run's first leg -- the least squares from its start to its own budget (per_local trials,
Local.run), then its end's full check over the cycle (local.verified) -- reads nothing of the
search but its start, the goal (stop), the probe limits and the budgets: not the designs kept,
not the runs before it. While the evaluation budget left covers every leg of a batch whatever
each spends (LEG_MARGIN evaluations beyond per_local each), no leg can end on that budget, so a
leg computed in a worker from the search's state before the batch is the leg the serial search
computes after the runs before it. The search takes the legs in order as it would have run
them: a leg the serial search would not have started (the goal met, the draw's runs used up)
is dropped with its evaluations; of a leg abandoned behind the designs kept, only the run's
evaluations count (the serial search does not check it over the cycle); and at the moment
the search takes a leg, the budget then left must have given the serial run the same trials,
or the run is run here. The same holds for a later draw's starts (Synthesis.candidates of the
whole draw): analysed in a worker while this draw's runs go on, and taken, with their counts,
when those analyses end before the budget left. The designs, evaluations and messages of
`--jobs N` are the serial search's for the same seed (tests/test_synth_jobs.py); a time budget
ends a leg in a worker at the same deadline.
"""

from __future__ import annotations

import copy
import pickle
import time

from .local import verified
from .problem import Rejected

FALL = 1e-3           # a leading run cut by per_local goes on while it falls by this fraction
#                       over per_local trials (see run_from)
LEG_MARGIN = 64       # evaluations a leg may spend beyond per_local (its first trial, the
#                       check over the cycle and its bisection over the run's trail)
QUEUED = 3            # legs queued per worker (a worker never waits for this process to ask)


def run_from(syn, local, cfg, start, stop, probe, bounds, designs, rejected, halt, leg=None):
    """One local run from the fully evaluated design `start` and the design verified at its
    end (local.verified), or None when an abandoned or halted run is no better than the
    designs kept (not checked). A run cut by its own budget (per_local) whose verified end
    leads the search (below every design kept) goes on from there, per_local trials at a
    time, until it converges, falls by less than FALL of its sum of squares over per_local
    trials, falls behind or a budget of the search runs out: a run in a flat, curved valley
    converges linearly (five-point-curve.yaml: hundreds of trials from the best starts to
    the least sum of squares), and cut at per_local it would stop well above the valley's
    floor, however many runs the budget then pays for; one crawling (seed 6 of the same file)
    gives the budget back to other starts (benchmarks/README.md, "Figures moved from the
    code's comments"). leg: the run's first leg computed ahead (Ahead.take), or None."""
    e0, j0 = syn.model.evaluations + local.evaluations, syn.model.jacobians
    d, first = None, start
    while True:
        budget = cfg["evaluations"] - syn.model.evaluations - local.evaluations - 1
        if budget < 1:
            break
        if leg is not None:
            message, checked = leg.run(syn, local)
        else:
            xl, message, trail = local.run(first, min(budget, cfg["per_local"]), stop, probe,
                                           halt=halt)
        if message.startswith(("abandoned", "halted")) and len(designs) >= cfg["keep"] and \
                local.last_cost >= designs[-1].cost:
            break
        d = checked(rejected) if leg is not None else \
            verified(syn, local, xl, trail, *bounds, rejected, first)
        leg = None
        if isinstance(d, Rejected):         # nothing of the run passes the full check
            d = None
            break
        cut = message.startswith("The maximum number of function evaluations") and \
            not d.message
        d.message = d.message or message
        if not (cut and d.cost < (1 - FALL) * first.cost and
                all(d.cost < o.cost for o in designs)):
            break
        first = d
    if d is not None:
        d.nfev = syn.model.evaluations + local.evaluations - e0
        d.njev = syn.model.jacobians - j0
    return d


class Leg:
    """A run's first leg computed in a worker: its message, last cost and verified end, and
    what each part spent (evaluations of the model, trials, Jacobians)."""

    def __init__(self, message, last_cost, spent, end, spent_end, rejected):
        self.message, self.last_cost, self.spent = message, last_cost, spent
        self.end, self.spent_end, self.rejected = end, spent_end, rejected

    def run(self, syn, local):
        """The run's part taken into the search's counts: (message, a function rejected ->
        the verified end, which takes the check's part when the search asks for it)."""
        _count(syn, local, self.spent)
        local.last_cost = self.last_cost

        def checked(rejected):
            _count(syn, local, self.spent_end)
            rejected += self.rejected
            return self.end
        return self.message, checked


def _count(syn, local, spent) -> None:
    syn.model.evaluations += spent[0]
    local.evaluations += spent[1]
    syn.model.jacobians += spent[2]


class Ahead:
    """The first legs of the next runs, computed ahead: in jobs - 1 worker processes, and here
    while the leg the search needs next is still running in a worker (see the module
    docstring)."""

    def __init__(self, syn, cfg, jobs: int):
        self.syn, self.cfg, self.jobs = syn, cfg, jobs
        self.pool = None
        self.legs: dict = {}        # id of a start -> its Leg, or the Future of its Leg
        self.next: list = []        # the legs' arguments of the runs after the one at hand
        self.draws: dict = {}       # a later draw -> Future of its candidates (plan_draw)
        # a later draw's designs are held twice more (in a worker, and here once sent): only
        # where the memory budget has room for them (synthesis.settings.check_cost)
        from .problem import memory_problem
        held = 3 * min(cfg["starts"], cfg["local"]) + cfg["keep"] + 1
        self.draws_fit = memory_problem(syn.model, held, "", k=syn.k) is None

    def plan(self, starts, stop, probe, bounds, spent: int, deadline, designs) -> None:
        """The runs after the one the search is at (starts: fully evaluated designs, in
        order), as far as the budget left covers their legs and that run (spent: the
        evaluations so far; deadline: the time budget's end on time.perf_counter, or None;
        designs: those kept): each worker given the first QUEUED of them not yet computed.
        A leg abandoned no better than the worst design kept now is not checked over the
        cycle: the serial search would not check it then either (the worst design kept only
        improves)."""
        cfg = self.cfg
        room = (cfg["evaluations"] - spent - 1) // (cfg["per_local"] + LEG_MARGIN) - 1
        worst = designs[-1].cost if len(designs) >= cfg["keep"] else None
        self.next = [(d, cfg["per_local"], stop, probe, bounds, deadline, worst, self.syn.wrap)
                     for d in starts[:max(0, room)]]
        busy = sum(not isinstance(v, Leg) and not v.done() for v in self.legs.values())
        for args in self.next:
            if busy >= QUEUED * (self.jobs - 1):
                break
            if id(args[0]) not in self.legs:
                if self.pool is None:
                    self._start()
                self.legs[id(args[0])] = self.pool.submit(_leg, *args)
                busy += 1

    def take(self, start, spent: int, designs):
        """The Leg of start when it was computed ahead and it is the serial search's (the
        budget left now, spent evaluations so far, gives the run per_local trials and lets no
        trial of the leg reach it), else None: the run is run here. While a worker still
        computes it, the next leg nobody computes yet is computed here."""
        leg = self.legs.pop(id(start), None)
        if leg is None:
            return None
        if not isinstance(leg, Leg):
            while not leg.done() and self._compute_next():
                pass
            leg = leg.result()
        left = self.cfg["evaluations"] - spent - 1
        if left < max(self.cfg["per_local"], sum(leg.spent) + sum(leg.spent_end)) + 1:
            return None
        if leg.end is None and not (len(designs) >= self.cfg["keep"] and
                                    leg.last_cost >= designs[-1].cost):
            return None         # (not checked, and the search would check it: cannot be)
        return leg

    def _compute_next(self) -> bool:
        """Compute here the leg of the first run ahead that nobody computes (False: none)."""
        for args in self.next:
            if id(args[0]) in self.legs:
                continue
            syn = self.syn
            saved = _spent(syn, syn.local), syn.local.last_cost
            try:        # on a copy of the start, as a worker has (a run fills in its state)
                self.legs[id(args[0])] = _leg(copy.deepcopy(args[0]), *args[1:], syn=syn)
            finally:        # this process's counts as they were: taken with the leg
                (syn.model.evaluations, syn.local.evaluations, syn.model.jacobians), \
                    syn.local.last_cost = saved
            return True
        return False

    def plan_draw(self, draw: int, part) -> None:
        """Analyse the starts of a later draw in a worker (Synthesis.candidates of the whole
        draw, part: its rows) while the search runs this draw's local runs."""
        if draw in self.draws or not self.draws_fit:
            return
        if self.pool is None:
            self._start()
        cfg = self.cfg
        self.draws[draw] = self.pool.submit(_draw, cfg["starts"], cfg["seed"],
                                            bool(cfg["nominal"]), part, cfg["local"], draw,
                                            self.syn.wrap)

    def take_draw(self, draw: int, spent: int):
        """The candidates of a draw analysed ahead, taken into the search's counts, when its
        analyses end before the budget left (spent: the evaluations so far) as the serial
        search's would; else None (analysed here)."""
        fut = self.draws.pop(draw, None)
        if fut is None:
            return None
        got, counted, refusals, best, wrap = fut.result()
        if self.cfg["evaluations"] - spent - 1 < counted[0]:
            return None
        syn = self.syn
        syn.model.evaluations += counted[0]
        syn.model.jacobians += counted[1]
        syn.project_solves += counted[2]
        syn.refusals |= refusals
        syn.best = min(syn.best, best)
        if syn.wrap is None:
            syn.wrap = wrap
        return got

    def drop(self) -> None:
        """Forget the legs not taken (the search ended, or the draw's runs are used up)."""
        for v in self.legs.values():
            if not isinstance(v, Leg):
                v.cancel()
        self.legs.clear()
        self.next = []

    def _start(self) -> None:
        from concurrent.futures import ProcessPoolExecutor

        from ..processes import context
        syn = self.syn
        progress, syn.progress = syn.progress, None     # (a callback of this process)
        try:
            blob = pickle.dumps(syn)
        finally:
            syn.progress = progress
        self.pool = ProcessPoolExecutor(self.jobs - 1, mp_context=context(),
                                        initializer=_init, initargs=(blob,))

    def close(self) -> None:
        """End the workers (the search ended, or was interrupted)."""
        if self.pool is not None:
            from ..processes import stop_workers
            self.drop()
            stop_workers(self.pool)
            self.pool = None


_SYN = None         # the worker's Synthesis (set once by the initializer)


def _init(blob) -> None:
    global _SYN
    from ..processes import accept_signals
    _SYN = pickle.loads(blob)
    accept_signals()


def _leg(start, per_local, stop, probe, bounds, deadline, worst, wrap, syn=None) -> Leg:
    """A run's first leg: Local.run to per_local trials, then its end checked unless it was
    abandoned no better than worst (syn: the Synthesis to run it with; the worker's by
    default; wrap: the search's Synthesis.wrap, which the worker's copy may not know yet)."""
    syn = _SYN if syn is None else syn
    syn.wrap = wrap
    local = syn.local
    halt = None if deadline is None else \
        (lambda: "time" if time.perf_counter() >= deadline else None)
    before = _spent(syn, local)
    xl, message, trail = local.run(start, per_local, stop, probe, halt=halt)
    mid = _spent(syn, local)
    rejected: list = []
    end = None if message.startswith(("abandoned", "halted")) and worst is not None and \
        local.last_cost >= worst else verified(syn, local, xl, trail, *bounds, rejected, start)
    after = _spent(syn, local)
    return Leg(message, local.last_cost, tuple(b - a for a, b in zip(before, mid)), end,
               tuple(b - a for a, b in zip(mid, after)), rejected)


def _draw(starts, seed, nominal, part, limit, draw, wrap) -> tuple:
    """A draw's candidates in a worker: (candidates' result, (analyses, Jacobians,
    projection solves) it counted, the refusals it saw, the best cost, Synthesis.wrap).
    wrap: the search's, or None when not decided yet (the draw's first accepted start
    decides it, as the search's own would)."""
    syn = _SYN
    syn.wrap = wrap
    before = (syn.model.evaluations, syn.model.jacobians, syn.project_solves)
    syn.refusals, syn.best = set(), float("inf")
    got = syn.candidates(starts, seed, nominal, part, limit=limit, draw=draw)
    after = (syn.model.evaluations, syn.model.jacobians, syn.project_solves)
    return got, tuple(b - a for a, b in zip(before, after)), syn.refusals, syn.best, syn.wrap


def _spent(syn, local) -> tuple:
    return syn.model.evaluations, local.evaluations, syn.model.jacobians
