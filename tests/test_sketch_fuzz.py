"""Hostile sketch-form input (tests/test_fuzz.py knows only the body/joint form): a sketch with
links, ground pins, a slider, a distance driver between pins and measures, mutated at random
(fixed seed) in one to three places. Invalid input must be an InputError (FILE:LINE
diagnostics), never another exception; valid mutations must load, assemble or be refused."""

import copy
import random
from pathlib import Path

import yaml

import planarkin
from planarkin.solver.assembly import assemble
from planarkin.diagnostics import InputError

ROOT = Path(__file__).resolve().parent.parent
SEED = 20261201
VALUES = [None, 1, "x", [1], [1, 2], {"a": 1}, [[1, 2]], True, "A", ["A", "A"], ["A", "Q"],
          1e308, -0.0, [None, None], {}, "ground", ["ground", "C"], [0, 0]]


def _base():
    d = yaml.safe_load((ROOT / "mechanisms" / "klann-leg.yaml").read_text())
    d["sliders"] = {"s": {"link": "crank", "along": ["A", "C"]}}
    d["slots"] = {"k": {"link": "leg", "pin": "F", "along": ["F", "G"]}}
    d["measures"] = {"m1": {"distance": ["A", "G"]}, "m2": {"ratio": ["m1", "m1"]},
                     "m3": {"transmission": ["C", "H", "B"]}, "m4": {"joint": "H"},
                     "m5": {"transmission": ["C", "H"], "guide": "s"}}
    d["drivers"].append({"type": "distance", "between": ["B", "G"], "f": "1"})
    d["ground"] = ["A"]
    return d


def _paths(d, p=()):
    yield p
    if isinstance(d, dict):
        for k, v in d.items():
            yield from _paths(v, p + (k,))
    elif isinstance(d, list):
        for i, v in enumerate(d):
            yield from _paths(v, p + (i,))


def test_sketch_mutations_never_crash():
    base = _base()
    paths = list(_paths(base))[1:]
    rng = random.Random(SEED)
    crashes = []
    for n in range(100):
        d = copy.deepcopy(base)
        for _ in range(rng.randint(1, 3)):
            p = rng.choice(paths)
            try:
                x = d
                for k in p[:-1]:
                    x = x[k]
                x[p[-1]] = copy.deepcopy(rng.choice(VALUES))
            except (KeyError, IndexError, TypeError):
                pass                    # the path vanished with an earlier mutation
        text = yaml.safe_dump(d)
        try:
            assemble(planarkin.load("f.yaml", text=text))
        except InputError:
            pass
        except Exception as e:          # noqa: BLE001 - the point of the test
            crashes.append((n, f"{type(e).__name__}: {e}", text))
    assert not crashes, crashes[:3]
