"""Hostile-input fuzz test of the command line (`planarkin check` / `planarkin run`).

The contract under test: for invalid input planarkin prints compiler-style diagnostics
``FILE:LINE: error: message`` (``FILE: error: message`` for whole-file problems) on stderr, exits
with status 2, never prints a Python traceback (nor its own "internal error" fallback) and finishes
within seconds; expressions are parsed, never evaluated as Python. A valid model exits 0 or 1.

Every case is generated deterministically (fixed seeds) from the example models in mechanisms/:

* structured mutations: the file is read with ``yaml.safe_load``, one thing is broken, and it is
  written back with ``yaml.safe_dump``: wrong types, missing required keys, unknown names, bad
  numbers, semantic errors and expression attacks. Each mutation is invalid *by construction*, so
  exit 2 is the only right answer;
* raw-text mutations for syntax-level damage: truncation (kept only when the cut leaves the YAML
  unreadable or a required key missing), tabs, non-UTF-8 / NUL / control bytes, stray syntax
  characters (kept only when ``yaml.safe_load`` rejects the result), duplicate keys, several
  documents, unsupported tags, aliases, empty files, odd paths;
* hang-prone inputs (alias bombs, deep nesting, megabyte scalars and expressions, huge files) and
  a sample of the rest run as real subprocesses under a 10 s timeout; the bulk runs in-process
  through `click.testing.CliRunner` (a non-SystemExit exception escaping the command fails);
* valid mutations (numbers perturbed slightly, harmless re-formatting) must exit 0 or 1;
* extreme but finite numbers (1e300, 5e-324, 1.8e308, ...) may exit 0, 1 or 2, but everything
  else in the contract still holds.

Minimised inputs of bugs found by this fuzzer live in tests/fuzz_corpus/ and run as regression
cases (`test_corpus`), with the same assertions.
"""

from __future__ import annotations

import copy
import math
import os
import random
import resource
import re
import subprocess
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import pytest
import yaml
from click.testing import CliRunner

from clitools import ROOT, command
from planarkin.cli import main

SEED = 20240611
# per case: a bound on CPU seconds that only a runaway case reaches (a case costs well under a
# second; CPU, not wall time, which varies tenfold on a shared CI machine), and a wall-clock
# limit that only a hang reaches
TIMEOUT = 60.0
HANG = 120.0
# the mutations below know the body/joint form and aim at f: drivers: sketch-form examples
# (links:) and examples driven by motion: or table: (whose CSV lies beside the model and would not
# be copied) are covered by test_sketch_fuzz.py, test_motion.py, test_inputtable.py and cases/
EXAMPLES = sorted(p for p in (ROOT / "mechanisms").glob("*.yaml")
                  if "\nlinks:" not in p.read_text(encoding="utf-8")
                  and not any(k in p.read_text(encoding="utf-8") for k in ("motion:", "table:")))
TEXT = {p.stem: p.read_text(encoding="utf-8") for p in EXAMPLES}
DATA = {name: yaml.safe_load(text) for name, text in TEXT.items()}
CORPUS = ROOT / "tests" / "fuzz_corpus"

# Files that a successful code-injection payload would create. The unique marker is used by the
# payloads below; /tmp/pwned (the classic) is checked too, unless it already existed.
MARK = Path(tempfile.gettempdir()) / f"planarkin-fuzz-pwned-{os.getpid()}"
PWNED = Path("/tmp/pwned")
PWNED_BEFORE = PWNED.exists()

MB = 1024 * 1024
_BREAKS = re.compile("\r\n|[\n\r\x85\u2028\u2029]")   # line breaks as YAML counts them


# ------------------------------------------------------------------------------------------------
# Cases
# ------------------------------------------------------------------------------------------------


@dataclass
class Case:
    id: str
    content: bytes | None = None     # the model file (None for the odd-path kinds)
    kind: str = "file"               # file | dir | missing | notdir | longname | multi
    via: str = "inproc"              # inproc (CliRunner) | subproc (the console script)
    cmd: str = "check"               # check | run
    valid: bool | None = False       # False: exit 2; True: exit 0 or 1; None: any of 0, 1, 2
    others: list = field(default_factory=list)   # multi: further file contents (bytes)


# libyaml's emitter where pyyaml has it: the cases are written at collection, in every worker,
# and the pure-Python emitter took half the suite's collection time (5 s)
_DUMPER = getattr(yaml, "CSafeDumper", yaml.SafeDumper)


def _dump(data) -> str:
    return yaml.dump(data, Dumper=_DUMPER, sort_keys=False, default_flow_style=None,
                     allow_unicode=True, width=2**30)


def _enc(text: str) -> bytes:
    return text.encode("utf-8")


def _get(d, path):
    for k in path:
        d = d[k]
    return d


def _set(d, path, value):
    if not path:
        return value
    _get(d, path[:-1])[path[-1]] = value
    return d


def _delete(d, path):
    del _get(d, path[:-1])[path[-1]]
    return d


def _raw(d, path, raw: str) -> bytes:
    """Dump d with the value at path replaced by raw YAML text (e.g. 1.0e+400, a 400-digit int)."""
    d = _set(d, path, "RAWSENTINEL")
    text = _dump(d)
    assert text.count("RAWSENTINEL") == 1
    return _enc(text.replace("RAWSENTINEL", raw))


def _bodies(d) -> list[str]:
    return list(d.get("bodies") or {})


def _params(d) -> list[str]:
    return list(d.get("parameters") or {})


def _elements(d):
    for role in ("joints", "drivers"):
        for k, el in enumerate(d.get(role) or []):
            yield role, k, el


def slots(d) -> list[tuple[str, tuple]]:
    """(slot type, path) of every place of the model whose expected type is known."""
    s = [("root", ())]
    for sec in ("bodies", "joints", "drivers", "parameters", "points", "analysis", "units"):
        if sec in d:
            s.append(("section", (sec,)))
    for b in _bodies(d):
        s += [("entry", ("bodies", b)), ("vec3", ("bodies", b, "q"))]
        s += [("number", ("bodies", b, "q", k)) for k in range(3)]
    s += [("number", ("parameters", p)) for p in _params(d)]
    for role, k, el in _elements(d):
        s += [("entry", (role, k)), ("type", (role, k, "type"))]
        for key in el:
            path = (role, k, key)
            if key in ("i", "j", "body"):
                s.append(("name", path))
            elif key in ("si", "sj", "at", "vi", "vj", "axis"):
                s.append(("point", path))
                s += [("number", path + (n,)) for n in range(2)]
            elif key == "c":
                s.append(("number", path))
            elif key == "f":
                s.append(("f", path))
    for pt, v in (d.get("points") or {}).items():
        s += [("entry", ("points", pt)), ("name", ("points", pt, "body"))]
        for key in ("s", "at"):
            if key in v:
                s.append(("point", ("points", pt, key)))
                s += [("number", ("points", pt, key, n)) for n in range(2)]
    for key in (d.get("analysis") or {}):
        s.append(("number", ("analysis", key)))
    return s


def _pick_slot(rng, d, *types):
    cands = [sl for sl in slots(d) if sl[0] in types]
    return rng.choice(cands)


def _unknown_name(rng, d) -> str:
    taken = set(_bodies(d)) | {"ground"}
    while True:
        base = rng.choice(_bodies(d) + ["ground"])
        c = rng.choice([base + "x", base[:-1], base.capitalize(), base.upper(), "grund",
                        "ground2", base + "_2", "".join(rng.choice("bcdfgkmpqvwxz")
                                                         for _ in range(6))])
        if c and c not in taken:
            return c


# -- wrong types ------------------------------------------------------------------------------

WRONG = {
    "number": [[1, 2], {"x": 1}, True, False, None, "not a number", [], {}, "", "1,5"],
    "vec3": [5, "0 0 0", {"x": 0}, True, None, [0, 0], [0, 0, 0, 0], [], [[0, 0, 0]]],
    "point": [5, "0 0", {"x": 0, "y": 0}, True, None, [0], [0, 0, 0], [], [[0, 0], [0, 0]]],
    "name": [["ground"], {"body": "x"}, None, "", 7, True],
    "type": [["revolute"], {"revolute": None}, None, True, 3],
    "f": [["2*pi*t"], {"t": 1}, True, None],
    "entry": [[1, 2], "x", 5, True, None],
    "root": [["bodies"], "text", 5, None],
}
WRONG_SECTION = {
    "bodies": [[{"crank": {"q": [0, 0, 0]}}], "crank", 5, True, None],
    "joints": [{}, {"type": "revolute"}, "x", 5, True, None],
    "drivers": [{}, {"type": "angle"}, "x", 5, True, None],
}


def mut_wrong_type(rng, d):
    typ, path = _pick_slot(rng, d, *WRONG, "section")
    pool = WRONG_SECTION.get(path[0], [[1], "x", 5, True, None]) if typ == "section" else WRONG[typ]
    return _set(d, path, copy.deepcopy(rng.choice(pool)))


# -- missing required keys --------------------------------------------------------------------

def required_paths(d) -> list[tuple]:
    req = [("bodies",), ("joints",)]
    req += [("bodies", b, "q") for b in _bodies(d)]
    for role, k, el in _elements(d):
        req += [(role, k, "type")]
        if role == "joints":
            req += [(role, k, "i"), (role, k, "j")]
            if "at" in el:
                req.append((role, k, "at"))
                if "axis" in el:
                    req.append((role, k, "axis"))
            elif el["type"] == "revolute":
                req += [(role, k, "si"), (role, k, "sj")]
            elif el["type"] == "translational":
                req += [(role, k, key) for key in ("si", "sj", "vi", "vj")]
        else:
            req.append((role, k, "f"))
            if "body" in el and "i" not in el and "j" not in el:
                req.append((role, k, "body"))
    for pt, v in (d.get("points") or {}).items():
        req.append(("points", pt, "body"))
        req += [("points", pt, key) for key in ("s", "at") if key in v]
    return req


def mut_missing(rng, d):
    return _delete(d, rng.choice(required_paths(d)))


# -- unknown names ----------------------------------------------------------------------------

JOINT_TYPES_BAD = ["revolut", "hinge", "prismatic", "Revolute", "slide", "", "revolute ", "pin_slot"]
DRIVER_TYPES_BAD = ["angel", "rotation", "revolute", "translational", "gear", "pin-slot", "Angle"]
BAD_KEYS = ["radius", "mass", "foo", "jj", "sii", "type2", "I", "Si", "angle"]
BAD_TOP = ["bodys", "solver", "joint", "Bodies", "driver", "parameter", "time"]
UNKNOWN_PARAMS = ["zz", "aa", "alpha", "L0x", "x", "nan", "inf", "e2", "pii", "T", "crank", "ground"]


def mut_unknown(rng, d):
    what = rng.choice(["ref", "ref", "type", "key", "top", "param", "param"])
    if what == "ref":
        _, path = _pick_slot(rng, d, "name")
        return _set(d, path, _unknown_name(rng, d))
    if what == "type":
        _, path = _pick_slot(rng, d, "type")
        pool = JOINT_TYPES_BAD if path[0] == "joints" else DRIVER_TYPES_BAD
        return _set(d, path, rng.choice(pool))
    if what == "key":
        _, path = _pick_slot(rng, d, "entry")
        target = _get(d, path)
        keys = BAD_KEYS if path[0] != "bodies" else BAD_KEYS + ["q0", "phi"]
        target[rng.choice([k for k in keys if k not in target])] = rng.choice([1, [0, 0], "x"])
        return d
    if what == "top":
        d[rng.choice(BAD_TOP)] = rng.choice([{}, [], 1, "x"])
        return d
    # a parameter name that does not exist, in a constant or in a driver function
    unk = rng.choice([n for n in UNKNOWN_PARAMS if n not in _params(d)])
    typ, path = _pick_slot(rng, d, "number", "f")
    form = rng.choice(["{}", "{}*2", "2*{} + 1", "sin({})", "({})**2"])
    if typ == "f":
        form = rng.choice(["{}*t", "2*pi*t + {}", "sin({}*t)"])
    return _set(d, path, form.format(unk))


# -- bad numbers ------------------------------------------------------------------------------

BIG_INT = "1" + "0" * 400
BAD_NUMBERS = [math.nan, math.inf, -math.inf, "1e400", "-1e400", "10**400", "-10**400", "1e308*10",
               ("raw", ".NaN"), ("raw", "1.0e+400"), ("raw", "-1.0e+400"), ("raw", BIG_INT),
               ("raw", "-" + BIG_INT), ("raw", "0x" + "f" * 300), "nan", "inf", "1/0", "0**-1",
               "sqrt(-1)", "log(0)", "exp(1000)", "acos(2)"]
BAD_F = [math.nan, math.inf, "1e400*t", "10**400*t", ("raw", BIG_INT), ("raw", "1.0e+400"),
         "t/0", "exp(1000)*t", "inf*t", "nan + t"]
BAD_ANALYSIS = {
    "steps": [0, -1, -360, 1e12, 2.5, "10**12", 10**10, "1e9 + 1", 0.5],
    "tol": [0, -1e-10, 1, 1e-20, 0.5],
    "iterations": [0, 101, 2.5, -3],
    "path_tol": [0, 1, -1e-4],
    "max_step": [0, -0.1, "-1/8"],
}


def _bad_value(rng, d, path, pool):
    v = rng.choice(pool)
    if isinstance(v, tuple):
        return _raw(d, path, v[1])
    return _set(d, path, v)


def mut_bad_number(rng, d):
    what = rng.choice(["number", "number", "number", "f", "analysis", "analysis", "end", "c",
                       "zero-vector", "gear", "ground"])
    if what == "number":
        _, path = _pick_slot(rng, d, "number")
        return _bad_value(rng, d, path, BAD_NUMBERS)
    if what == "f":
        _, path = _pick_slot(rng, d, "f")
        return _bad_value(rng, d, path, BAD_F)
    a = d.setdefault("analysis", {})
    if what == "analysis":
        key = rng.choice(list(BAD_ANALYSIS))
        a[key] = rng.choice(BAD_ANALYSIS[key])
        return d
    if what == "end":
        start = a.get("start", 0)
        choice = rng.randrange(3)
        if choice == 0:
            a["end"] = start
        elif choice == 1:
            a["end"] = start - 1
        else:
            a["start"], a["end"] = 2, 1.5
        return d
    body = rng.choice(_bodies(d))
    if what == "c":            # a distance joint with a distance that is not positive
        d["joints"].append({"type": "distance", "i": "ground", "j": body, "si": [0, 0],
                            "sj": [0, 0], "c": rng.choice([0, -0.1, "-a" if "a" in _params(d)
                                                           else -2, -1e-9])})
        return d
    if what == "zero-vector":  # a translational joint's axis of length zero
        trans = [k for k, el in enumerate(d["joints"]) if el.get("type") == "translational"
                 and "vi" in el]
        zero = rng.choice([[0, 0], [0.0, -0.0], ["1-1", "0*5"], [0, "0"]])
        if trans and rng.random() < 0.7:
            d["joints"][rng.choice(trans)][rng.choice(["vi", "vj"])] = zero
        else:
            d["joints"].append({"type": "translational", "i": "ground", "j": body, "si": [0, 0],
                                "sj": [0, 0], "vi": zero, "vj": [1, 0]})
        return d
    if what == "gear":         # a pitch radius of zero
        d["joints"].append({"type": "gear", "i": "ground", "j": body,
                            "ri": 0, "rj": 1} if rng.random() < 0.5 else
                           {"type": "gear", "i": "ground", "j": body, "ri": 1, "rj": "0*2"})
        return d
    # a body named ground
    d["bodies"]["ground"] = {"q": [0, 0, 0]}
    return d


# -- semantic errors --------------------------------------------------------------------------

def mut_semantic(rng, d):
    bodies = _bodies(d)
    what = rng.choice(["bad-body-name", "bad-param-name", "self", "driver-ground", "body-and-i",
                       "at-and-si", "dup-element-name", "point-s-and-at", "branch", "output",
                       "units", "no-bodies", "enum", "point-body-ground"])
    if what == "bad-body-name":
        old = rng.choice(bodies)
        new = rng.choice(["1" + old, old + " rod", "cr@nk", "-" + old, old + ".x"])
        d["bodies"] = {(new if k == old else k): v for k, v in d["bodies"].items()}
        return d
    if what == "bad-param-name":
        p = d.setdefault("parameters", {})
        p[rng.choice(["2a", "pi", "t", "sin", "ground", "a b", "sqrt", "exp"])] = 1
        return d
    if what == "self":
        k = rng.randrange(len(d["joints"]))
        el = d["joints"][k]
        b = rng.choice(bodies)
        el["i"], el["j"] = b, b
        return d
    if what == "driver-ground":
        drv = d["drivers"][0]
        drv.pop("i", None)
        drv.pop("j", None)
        drv["body"] = "ground"
        return d
    if what == "body-and-i":
        drv = d["drivers"][0]
        drv["body"], drv["i"] = bodies[0], "ground"
        return d
    if what == "at-and-si":
        el = rng.choice([el for el in d["joints"] if el["type"] == "revolute"])
        el["at"] = [0.1, 0.2]
        el["si"] = [0, 0]
        return d
    if what == "dup-element-name":
        d["joints"][0]["name"] = "pin"
        (d["joints"][1] if len(d["joints"]) > 1 else d["drivers"][0])["name"] = "pin"
        return d
    if what == "point-s-and-at":
        d.setdefault("points", {})["Q"] = {"body": bodies[-1], "s": [0, 0], "at": [1, 1]}
        return d
    if what == "branch":
        d["assembly"] = rng.choice([{"branch": {_unknown_name(rng, d): "+"}},
                                    {"branch": {bodies[0]: "*"}}, {"branch": [bodies[0]]},
                                    {"branch": {bodies[0]: 2}}, {"mode": 1}])
        return d
    if what == "output":
        d["output"] = rng.choice([{"bodies": [_unknown_name(rng, d)]}, {"up_to": "snap"},
                                  {"points": ["nowhere"]}, {"bodies": bodies[0]},
                                  {"format": "csv"}])
        return d
    if what == "units":
        d["units"] = rng.choice([{"angle": "grad"}, {"angle": "degrees"}, {"time": "s"},
                                 {"length": None}, ["m", "rad"]])
        return d
    if what == "no-bodies":
        d["bodies"] = {}
        return d
    if what == "point-body-ground":
        d.setdefault("points", {})["Q"] = {"body": "ground", "s": [0, 0]}
        return d
    a = d.setdefault("analysis", {})
    key, val = rng.choice([("interpolate", "maybe"), ("interpolate", 1), ("newton", "sometimes"),
                           ("bifurcation", "ignore"), ("newton", True)])
    a[key] = val
    return d


# -- expression attacks ----------------------------------------------------------------------

ATTACKS = [
    "9**9**9**9", "9**9**9", "2**1024", "10**400", "(-8)**(1/3)",
    f"__import__('os').system('touch {MARK}')", "__import__('os').system('touch /tmp/pwned')",
    "().__class__.__bases__", "().__class__.__bases__[0].__subclasses__()",
    "open('/etc/passwd')", "open('/etc/passwd').read()", f"open('{MARK}', 'w')",
    "lambda: 1", "(lambda x: x)(1)", "f'{1+1}'", f"f\"{{__import__('os').system('touch {MARK}')}}\"",
    "'a'*10**9", "[0]*10**9", "__builtins__", "exec('1')", "eval('1')", "globals()",
    "sin.__self__", "getattr(pi, 'real')", "pi.real", "where(1, 2)", "[1, 2]", "{1: 2}", "{1}",
    "(1, 2)", "1 is 2", "min(1)", "mod(1, 0)", "~1", "7 // 2", "80mm", "1 @ 2", "1 << 2", "1 ^ 2",
    "(a := 1)", "[i for i in (1,)]", "*a", "b'x'", "1j", "None", "True", "...", "'1'",
    "sin(1, 2)", "atan2(1)", "sin(x=1)", "sin", "foo(1)", "import os", "1; 2", "yield 1",
    "1__0", "0x", "1 2", "1e", ".", "", "   ", "-" * 990 + "1", "sin(" * 70 + "1" + ")" * 70,
    "2**" * 300 + "2", "1+" * 400 + "1", "(" * 100 + "1" + ")" * 100, "x" * 1001,
    "\\N{DIGIT ONE}", "１", "sin(1)(2)", "(sin)(1)(2)", "sin[1]",
]
CONST_ONLY = ["t**t**t**t**t", "t", "2*pi*t", "sin(t)"]


def mut_attack(rng, d):
    typ, path = _pick_slot(rng, d, "number", "number", "f")
    pool = ATTACKS + (CONST_ONLY if typ == "number" else [])
    return _set(d, path, rng.choice(pool))


STRUCTURED = {
    "wrong-type": (mut_wrong_type, 8),
    "missing-key": (mut_missing, 5),
    "unknown-name": (mut_unknown, 7),
    "bad-number": (mut_bad_number, 8),
    "semantic": (mut_semantic, 5),
    "expr-attack": (mut_attack, 8),
}


def structured_cases() -> list[Case]:
    out = []
    for cls, (mutate, n) in STRUCTURED.items():
        for name in DATA:
            rng = random.Random(f"{SEED}-{cls}-{name}")
            for k in range(n):
                r = mutate(rng, copy.deepcopy(DATA[name]))
                out.append(Case(f"{cls}-{name}-{k}", r if isinstance(r, bytes) else _enc(_dump(r))))
    return out


# -- raw-text mutations -----------------------------------------------------------------------

def _none_anywhere(x) -> bool:
    if x is None:
        return True
    if isinstance(x, dict):
        return any(_none_anywhere(v) for v in x.values())
    if isinstance(x, list):
        return any(_none_anywhere(v) for v in x)
    return False


def _vec(x, n=2) -> bool:
    return isinstance(x, list) and len(x) == n


def surely_invalid(data) -> bool:
    """A required key missing or of the wrong shape (in planarkin every null value is an error)."""
    if not isinstance(data, dict) or _none_anywhere(data):
        return True
    if not isinstance(data.get("bodies"), dict) or not data["bodies"]:
        return True
    if not isinstance(data.get("joints"), list):
        return True
    for v in data["bodies"].values():
        if not isinstance(v, dict) or not _vec(v.get("q"), 3):
            return True
    for role in ("joints", "drivers"):
        els = data.get(role, [])
        if not isinstance(els, list):
            return True
        for el in els:
            if not isinstance(el, dict) or "type" not in el:
                return True
            if role == "joints":
                if "i" not in el or "j" not in el:
                    return True
                if el["type"] == "revolute" and "at" not in el and not (
                        _vec(el.get("si")) and _vec(el.get("sj"))):
                    return True
                if el["type"] == "translational" and "at" not in el and not all(
                        _vec(el.get(k)) for k in ("si", "sj", "vi", "vj")):
                    return True
            elif "f" not in el or not ("body" in el or "i" in el or "j" in el):
                return True
    for v in (data.get("points") or {}).values():
        if not isinstance(v, dict) or "body" not in v or not ("s" in v or "at" in v):
            return True
    return False


def yaml_rejects(text: str) -> bool:
    try:
        yaml.safe_load(text)
    except yaml.YAMLError:
        return True
    except Exception:   # e.g. a timestamp safe_load cannot construct: not a clear verdict
        return False
    return False


def _truncations(rng, name, n) -> list[Case]:
    text = TEXT[name]
    out, tries, seen = [], 0, set()
    while len(out) < n and tries < 500:
        tries += 1
        cut = rng.randrange(1, len(text))
        if rng.random() < 0.3:   # a cut at a line end
            cut = text.rfind("\n", 0, cut) + 1 or cut
        t = text[:cut]
        if not t.strip() or cut in seen:
            continue
        seen.add(cut)
        if not yaml_rejects(t):
            try:
                data = yaml.safe_load(t)
            except Exception:
                continue
            if not surely_invalid(data):
                continue
        out.append(Case(f"truncated-{name}-at-{cut}", _enc(t)))
    return out


def _tab_cases(rng, name, n) -> list[Case]:
    lines = TEXT[name].split("\n")
    idx = [k for k, ln in enumerate(lines) if ln.startswith("  ")]
    out = []
    for k in rng.sample(idx, min(len(idx), 3 * n)):
        new = list(lines)
        new[k] = "\t" + new[k].lstrip(" ")
        t = "\n".join(new)
        if yaml_rejects(t) and len(out) < n:
            out.append(Case(f"tab-{name}-line{k + 1}", _enc(t)))
    return out


BAD_BYTES = [b"\xff", b"\xfe", b"\x80", b"\xc3", b"\xed\xa0\x80", b"\xc0\xaf", b"\xe9t\xe9",
             b"\x00", b"\x00\x00", b"\x01", b"\x07", b"\x0b", b"\x0c", b"\x1b", b"\x1f", b"\x7f",
             b"\xc2\x80", b"\xef\xbf\xbe", b"\xef\xbf\xbf"]


def _byte_cases(rng, name, n) -> list[Case]:
    data = _enc(TEXT[name])
    out = []
    for k in range(n):
        pos = rng.randrange(len(data) + 1)
        bad = rng.choice(BAD_BYTES)
        out.append(Case(f"bytes-{name}-{k}-{bad.hex()}-at-{pos}", data[:pos] + bad + data[pos:]))
    return out


SYNTAX_CHARS = ["[", "]", "{", "}", ":", '"', "'", "&", "*", "!", "%", "@", "`", "|", ">", ",",
                "- ", ": ", "? ", "\n  ", "\n-", "#{", "&a *a", "!!int "]


def _syntax_cases(rng, name, n) -> list[Case]:
    text = TEXT[name]
    out, tries = [], 0
    while len(out) < n and tries < 300:
        tries += 1
        pos = rng.randrange(len(text) + 1)
        ch = rng.choice(SYNTAX_CHARS)
        t = text[:pos] + ch + text[pos:] if rng.random() < 0.7 else text[:pos] + ch + text[pos + 1:]
        if yaml_rejects(t):
            out.append(Case(f"syntax-{name}-{len(out)}-{ch.strip()!r}-at-{pos}", _enc(t)))
    return out


def _dup_key_cases(name) -> list[Case]:
    text = TEXT[name]
    lines = text.split("\n")
    out = []
    # a top-level key twice (the name line, or the analysis line)
    for key in ("name:", "analysis:", "units:"):
        k = next((k for k, ln in enumerate(lines) if ln.startswith(key)), None)
        if k is not None:
            out.append(Case(f"dup-top-{key[:-1]}-{name}",
                            _enc("\n".join(lines[:k + 1] + [lines[k]] + lines[k + 1:]))))
            break
    # a body listed twice (raw text: duplicated body names as keys)
    start = lines.index(next(ln for ln in lines if ln.startswith("bodies:")))
    body = start + 1
    out.append(Case(f"dup-body-{name}",
                    _enc("\n".join(lines[:body + 1] + [lines[body]] + lines[body + 1:]))))
    # a key twice inside a flow mapping of a joint
    k = next(k for k, ln in enumerate(lines) if ln.lstrip().startswith("- {type:"))
    ln = lines[k]
    close = ln.rindex("}")
    out.append(Case(f"dup-flow-key-{name}",
                    _enc("\n".join(lines[:k] + [ln[:close] + ", i: ground" + ln[close:]]
                                   + lines[k + 1:]))))
    return out


def _multi_doc_cases(name) -> list[Case]:
    text = TEXT[name]
    return [Case(f"multidoc-twice-{name}", _enc("---\n" + text + "---\n" + text)),
            Case(f"multidoc-trailing-{name}", _enc(text + "\n--- \n")),
            Case(f"multidoc-end-{name}", _enc(text + "...\n---\nfoo: 1\n"))]


TAG_ATTACKS = [
    f"!!python/object/apply:os.system ['touch {MARK}']",
    "!!python/object/apply:os.system ['touch /tmp/pwned']",
    "!!python/name:os.system", f"!!python/object/new:os.system ['touch {MARK}']",
    f"!<tag:yaml.org,2002:python/object/apply:os.system> ['touch {MARK}']",
    "!!python/module:os", "!custom 1", "!!binary aGVsbG8=", "!!timestamp 2001-12-14",
    "!!set {a, b}", "!!omap [a: 1]", "!!pairs [a: 1]", "!!str {a: 1}", "!!int abc",
    "!!float x", "!!bool maybe", "!!map [1]", "!!seq {a: 1}", "!!null 3", "!!int 1.5",
]


def _tag_cases() -> list[Case]:
    out = []
    rng = random.Random(f"{SEED}-tags")
    for k, tag in enumerate(TAG_ATTACKS):
        name = rng.choice(list(DATA))
        d = copy.deepcopy(DATA[name])
        _, path = _pick_slot(rng, d, "number", "point", "name", "f", "entry")
        out.append(Case(f"tag-{k}-{name}", _raw(d, path, tag)))
    out.append(Case("tag-root", _enc(f"!!python/object/apply:os.system ['touch {MARK}']\n")))
    out.append(Case("tag-directive", _enc(
        "%TAG !p! tag:yaml.org,2002:python/\n---\n"
        f"bodies: !p!object/apply:os.system ['touch {MARK}']\njoints: []\n")))
    out.append(Case("tag-on-root-map", _enc("--- !!python/object:planarkin.X\n" + TEXT["boom"])))
    return out


EMPTY = {
    "empty": b"", "newlines": b"\n\n\n", "spaces": b"   ", "comment": b"# only a comment\n",
    "doc-start": b"---\n", "doc-start-end": b"---\n...\n", "tilde": b"~\n", "null": b"null\n",
    "bom": b"\xef\xbb\xbf", "bom-newline": b"\xef\xbb\xbf\n", "empty-map": b"{}\n",
    "empty-list": b"[]\n", "number": b"42\n", "string": b"'text'\n", "crlf": b"\r\n\r\n",
    "utf16": "bodies: {}\n".encode("utf-16"), "utf32": "joints: []\n".encode("utf-32"),
    "only-bodies": b"bodies:\n  crank: {q: [0, 0, 0]}\n", "only-joints": b"joints: []\n",
}

MISC = {
    "merge-key": "base: &b {q: [0, 0, 0]}\nbodies:\n  crank:\n    <<: *b\n"
                 "joints:\n  - {type: revolute, i: ground, j: crank, si: [0, 0], sj: [0, 0]}\n",
    "undefined-alias": "bodies:\n  crank: *nope\njoints: []\n",
    "recursive-alias": "bodies: &a\n  crank: *a\njoints: []\n",
    "recursive-seq": "bodies: {crank: {q: &a [0, *a, 0]}}\njoints: []\n",
    "complex-key": "bodies:\n  ? [a, b]\n  : {q: [0, 0, 0]}\njoints: []\n",
    "map-key": "? {a: 1}\n: 2\nbodies: {}\njoints: []\n",
    "anchor-only": "&a\n",
    "alias-root": "*a\n",
    "directive-only": "%YAML 1.1\n",
    "bad-directive": "%YAML 2.0\n---\nbodies: {}\n",
    "unclosed-quote": "bodies: {crank: {q: [0, 0, 0]}}\njoints: \"[\n",
    "mixed-indent": "bodies:\n  crank: {q: [0, 0, 0]}\n   rod: {q: [0, 0, 0]}\njoints: []\n",
    "lone-colon": ":\n",
    "block-scalar": "bodies: |\n  crank: {q: [0, 0, 0]}\njoints: []\n",
    "nested-name-null": "bodies:\n  crank:\njoints:\n  -\n",
    "cr-only": "bodies:\r  crank: {q: [0, 0]}\rjoints: []\r",
    "nel-breaks": "bodies:\x85  crank: {q: [0, 0]}\x85joints: []\x85",
    "ls-breaks": "bodies:\u2028  crank: {q: [0, 0]}\u2028joints: []\u2028",
    "quoted-nul-escape": 'bodies:\n  crank: {q: [0, 0, 0]}\njoints:\n'
                         '  - {type: revolute, i: ground, j: "cr\\0ank", si: [0, 0], sj: [0, 0]}\n',
    "quoted-nul-expr": 'parameters: {a: "1\\0"}\nbodies: {crank: {q: [0, 0, 0]}}\njoints: []\n',
    "surrogate-escape": 'parameters: {a: "\\ud800"}\nbodies: {crank: {q: [0, 0, 0]}}\njoints: []\n',
    "huge-escape": 'parameters: {a: "\\U0011ffff"}\nbodies: {crank: {q: [0, 0, 0]}}\njoints: []\n',
}


def raw_cases() -> list[Case]:
    out = []
    for name in DATA:
        rng = random.Random(f"{SEED}-raw-{name}")
        out += _truncations(rng, name, 5)
        out += _tab_cases(rng, name, 2)
        out += _byte_cases(rng, name, 4)
        out += _syntax_cases(rng, name, 4)
        out += _dup_key_cases(name)
        out += _multi_doc_cases(name)[:1 if name not in ("boom", "six-bar") else 3]
    out += _tag_cases()
    out += [Case(f"empty-{k}", v) for k, v in EMPTY.items()]
    out += [Case(f"misc-{k}", _enc(v)) for k, v in MISC.items()]
    out += [Case("path-directory", kind="dir"), Case("path-missing", kind="missing"),
            Case("path-not-a-directory", kind="notdir"), Case("path-name-too-long", kind="longname")]
    # several files at once: one invalid file makes the batch invalid
    bad = _enc(TEXT["four-bar"].replace("j: rocker", "j: rockr", 1))
    out += [Case("multi-valid-then-invalid", _enc(TEXT["four-bar"]), kind="multi", others=[bad]),
            Case("multi-invalid-then-valid", bad, kind="multi", others=[_enc(TEXT["trammel"])]),
            Case("multi-two-invalid", bad, kind="multi", others=[b"bodies: [\n"])]
    return out


# -- hang-prone inputs (subprocess) -----------------------------------------------------------

def _billion_laughs(levels=9, width=10, key="lol") -> str:
    lines = [f'{key}0: &{key}0 "lol"']
    for k in range(1, levels + 1):
        refs = ", ".join([f"*{key}{k - 1}"] * width)
        lines.append(f"{key}{k}: &{key}{k} [{refs}]")
    return "\n".join(lines) + "\n"


def _with_param(expr: str, where="parameters") -> bytes:
    d = copy.deepcopy(DATA["four-bar"])
    if where == "parameters":
        d["parameters"]["a"] = expr
    elif where == "f":
        d["drivers"][0]["f"] = expr
    else:
        d["bodies"]["crank"]["q"][0] = expr
    return _enc(_dump(d))


def heavy_cases() -> list[Case]:
    model = TEXT["slider-crank"]
    bomb_map = "a0: &a0 {x: 1, y: 2}\n" + "".join(
        f"a{k}: &a{k} {{{', '.join(f'k{j}: *a{k - 1}' for j in range(10))}}}\n" for k in range(1, 9))
    big_list = "[" + ", ".join(["0"] * 300_000) + "]"
    block_deep = "".join("  " * k + f"k{k}:\n" for k in range(1000)) + "  " * 1000 + "1\n"
    mb_name = "x" * MB
    cases = {
        "alias-bomb-classic": _billion_laughs(),
        "alias-bomb-in-model": model.replace("parameters:", _billion_laughs(key="p") + "parameters:"),
        "alias-bomb-as-q": _billion_laughs() + model.replace("{q: [0.05, 0.0, 0.3]}", "{q: *lol9}"),
        "alias-bomb-maps": bomb_map,
        "alias-bomb-wide": "a: &a [" + ", ".join(["x"] * 5000) + "]\nb: [" +
                           ", ".join(["*a"] * 100) + "]\n",
        "deep-flow-seq": "[" * 10_000 + "]" * 10_000,
        "deep-flow-seq-unclosed": "[" * 10_000,
        "deep-flow-map": "{a: " * 10_000 + "1" + "}" * 10_000,
        "deep-block-seq": "- " * 10_000 + "x\n",
        "deep-flow-100k": "[" * 100_000 + "]" * 100_000,
        "deep-block-map": block_deep,
        "deep-in-q": model.replace("{q: [0.05, 0.0, 0.3]}",
                                   "{q: " + "[" * 10_000 + "]" * 10_000 + "}"),
        "deep-parens-param": _with_param("(" * 10_000 + "1" + ")" * 10_000).decode(),
        "deep-parens-f": _with_param("(" * 10_000 + "t" + ")" * 10_000, "f").decode(),
        "deep-parens-unclosed": _with_param("(" * 100_000 + "1").decode(),
        "expr-1mb-param": _with_param("1+" * (MB // 2) + "1").decode(),
        "expr-1mb-f": _with_param("t*" * (MB // 2) + "t", "f").decode(),
        "expr-1mb-q": _with_param("9" * MB, "q").decode(),
        "expr-power-tower-param": _with_param("9**9**9**9").decode(),
        "expr-power-tower-f": _with_param("9**9**9**9*t", "f").decode(),
        "expr-string-repeat": _with_param("'a'*10**9").decode(),
        "expr-list-repeat-f": _with_param("[t]*10**9", "f").decode(),
        "expr-t-tower-const": _with_param("t**t**t**t**t").decode(),
        "expr-import": _with_param(f"__import__('os').system('touch {MARK}')", "f").decode(),
        "expr-fstring": _with_param(f"f\"{{__import__('os').system('touch {MARK}')}}\"").decode(),
        "tag-apply": model.replace("a: 0.1", f"a: !!python/object/apply:os.system "
                                             f"['touch {MARK}']"),
        "name-1mb-plain-key": model.replace("  crank:  {q:", f"  {mb_name}:  {{q:"),
        "name-1mb-explicit-key": model.replace("  crank:  {q: [0.05, 0.0, 0.3]}",
                                               f"  ? {mb_name}!\n  : {{q: [0.05, 0.0, 0.3]}}"),
        "name-1mb-reference": model.replace("i: crank, j: rod", f"i: {mb_name}, j: rod"),
        "name-1mb-type": model.replace("type: revolute", f"type: r{mb_name}", 1),
        "file-over-10mb": "# " + "x" * (10 * MB + 10) + "\n" + model,
        "file-over-1m-lines": model + "\n" * 1_000_001,
        "nodes-300k": f"bodies: {{crank: {{q: {big_list}}}}}\njoints: []\n",
        "many-documents": model + "---\nx: 1\n" * 20_000,
        "many-errors": "bodies:\n" + "".join(f"  b{k}: {{q: [0, 0]}}\n" for k in range(3000))
                       + "joints: []\n",
        # 60,000 bodies without a pose (a 600 kB file): the body-name checks must stay linear
        "many-null-bodies": "bodies: {" + ", ".join(f"b{k}: " for k in range(60_000)) + "}\n"
                            "joints: []\n",
        "long-line-scalar": "bodies: {crank: {q: [0, 0, " + "1" * (5 * MB) + "]}}\njoints: []\n",
    }
    out = [Case(f"heavy-{k}", _enc(v), via="subproc") for k, v in cases.items()]
    out.append(Case("heavy-non-utf8-5mb", b"# " + b"\xff" * (5 * MB) + b"\n", via="subproc"))
    out.append(Case("heavy-nul-5mb", b"\x00" * (5 * MB), via="subproc"))
    out.append(Case("heavy-run-alias-bomb", _enc(_billion_laughs()), via="subproc", cmd="run"))
    out.append(Case("heavy-run-expr-1mb", _with_param("1+" * (MB // 2) + "1"), via="subproc",
                    cmd="run"))
    return out


# -- valid mutations --------------------------------------------------------------------------

def _perturb(rng, d):
    """Numbers perturbed slightly (relative 1e-4 .. 1e-3): pose estimates, parameters, points."""
    def nudge(x):
        if isinstance(x, bool) or not isinstance(x, (int, float)) or x == 0:
            return x
        return x * (1 + rng.choice([-1, 1]) * rng.uniform(1e-4, 1e-3))
    for b in d["bodies"].values():
        b["q"] = [nudge(v) for v in b["q"]]
    for p in _params(d):
        d["parameters"][p] = nudge(d["parameters"][p])
    for v in (d.get("points") or {}).values():
        if "s" in v:
            v["s"] = [nudge(x) for x in v["s"]]
    return d


def valid_cases() -> list[Case]:
    out = []
    for name in DATA:
        rng = random.Random(f"{SEED}-valid-{name}")
        # the unmutated round trip that every structured mutation starts from must be valid
        out.append(Case(f"valid-baseline-{name}", _enc(_dump(DATA[name])), valid=True))
        for k in range(2):
            out.append(Case(f"valid-perturbed-{name}-{k}", _enc(_dump(_perturb(rng, copy.deepcopy(
                DATA[name])))), valid=True, cmd="run" if k == 0 else "check"))
        text = TEXT[name]
        out.append(Case(f"valid-block-style-{name}", _enc(yaml.safe_dump(
            DATA[name], sort_keys=False, default_flow_style=False)), valid=True))
        out.append(Case(f"valid-crlf-bom-{name}", b"\xef\xbb\xbf" + _enc(text.replace("\n", "\r\n")),
                        valid=True))
        if name in ("boom", "trammel", "quick-return"):
            out.append(Case(f"valid-no-final-newline-{name}",
                            _enc(text.rstrip("\n") + "  # end"), valid=True))
    return out


# -- extreme but finite numbers --------------------------------------------------------------

EXTREME = [1e300, -1e300, 1e-300, 5e-324, 1e154, 1e-154, 1.7976931348623157e308, 1e20, -1e-20,
           1e15, 0]


def extreme_cases() -> list[Case]:
    """Finite numbers at the edges of the float range in poses, points, lengths and parameters.
    Such a model may be valid, unassemblable or fail in the analysis, so any of the exit statuses
    0, 1, 2 is accepted; what is checked is everything else (no traceback, no internal error,
    diagnostics only, in time). The analysis block is left alone: `end: 1e154` is a valid request
    for an analysis that cannot finish."""
    out = []
    for name in DATA:
        rng = random.Random(f"{SEED}-extreme-{name}")
        for k in range(4):
            d = copy.deepcopy(DATA[name])
            for _ in range(rng.randint(1, 2)):
                _, path = rng.choice([sl for sl in slots(d) if sl[0] == "number"
                                      and sl[1][0] != "analysis"])
                _set(d, path, rng.choice(EXTREME))
            out.append(Case(f"extreme-{name}-{k}", _enc(_dump(d)), valid=None))
    return out


# -- the case lists ---------------------------------------------------------------------------

INPROC = structured_cases() + raw_cases()
# every 20th in-process case also through `planarkin run`, every 120th also as a real process
# (its exit status through the console script: the same path for every invalid input, and a
# second of start-up each; the heavy cases all run as processes)
RUN_SAMPLE = [Case(c.id + "-run", c.content, c.kind, "inproc", "run", c.valid, c.others)
              for c in INPROC[::20]]
SUBPROC_SAMPLE = [Case(c.id + "-subproc", c.content, c.kind, "subproc", c.cmd, c.valid, c.others)
                  for c in INPROC[5::120]]
HEAVY = heavy_cases()
VALID = valid_cases()
EXTREME_CASES = extreme_cases()
ALL = INPROC + RUN_SAMPLE + SUBPROC_SAMPLE + HEAVY + VALID + EXTREME_CASES


# ------------------------------------------------------------------------------------------------
# Running a case and checking the contract
# ------------------------------------------------------------------------------------------------


def _line_count(content: bytes) -> int:
    text = content.decode("utf-8", errors="replace")
    # the position just after a final line break counts as a line (where "end of file" points)
    return len(_BREAKS.findall(text)) + 1


def _setup(case: Case, tmp_path: Path) -> tuple[list[str], dict[str, int]]:
    """Write the case's files; return the paths to pass and each path's line count."""
    path = tmp_path / "model.yaml"
    lines: dict[str, int] = {}
    paths = [str(path)]
    if case.kind in ("file", "multi"):
        path.write_bytes(case.content)
        lines[str(path)] = _line_count(case.content)
        for k, other in enumerate(case.others):
            p = tmp_path / f"other{k}.yaml"
            p.write_bytes(other)
            paths.append(str(p))
            lines[str(p)] = _line_count(other)
    elif case.kind == "dir":
        path.mkdir()
    elif case.kind == "notdir":
        path.write_text("bodies: {}\n")
        paths = [str(path / "model.yaml")]
    elif case.kind == "longname":
        paths = [str(tmp_path / ("m" * 5000 + ".yaml"))]
    for p in paths:
        lines.setdefault(p, 1)
    return paths, lines


def _args(case: Case, paths: list[str], tmp_path: Path) -> list[str]:
    if case.cmd == "run":
        return ["run", *paths, "--out", str(tmp_path / "out"), "--no-plots", "--steps", "8"]
    return ["check", *paths]


def _invoke_inproc(args: list[str]) -> tuple[int, str, float]:
    t0 = time.process_time()
    r = CliRunner().invoke(main, args, catch_exceptions=True)
    dt = time.process_time() - t0
    if r.exit_code != 0 or r.exception is not None:
        # the command always ends with sys.exit: anything else escaped the CLI's handling
        assert isinstance(r.exception, SystemExit), (
            f"exception escaped the CLI: {r.exception!r}\nstderr:\n{r.stderr[:3000]}")
    return r.exit_code, r.stderr, dt


def _invoke_subproc(args: list[str], tmp_path: Path) -> tuple[int, str, float]:
    env = dict(os.environ)
    env.setdefault("MPLBACKEND", "Agg")
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    try:
        p = subprocess.run(command() + args, cwd=tmp_path, capture_output=True, timeout=HANG,
                           env=env)
    except subprocess.TimeoutExpired:
        pytest.fail(f"planarkin {args[0]} did not finish within {HANG:g} s (hang)")
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    dt = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    return p.returncode, p.stderr.decode("utf-8", errors="replace"), dt


def _short(s: str, n: int = 300) -> str:
    return repr(s) if len(s) <= n else repr(s[:n]) + f"... ({len(s)} characters)"


def check_contract(case: Case, lines: dict[str, int], code: int, stderr: str, dt: float) -> None:
    where = f"case {case.id} ({case.cmd}, {case.via}): exit {code}, {dt:.2f} s"
    assert dt < TIMEOUT, f"{where}: too slow (CPU seconds)"
    assert "Traceback" not in stderr, f"{where}: traceback on stderr:\n{stderr[-3000:]}"
    assert "internal error" not in stderr, f"{where}: internal error:\n{stderr[:3000]}"
    assert not MARK.exists(), f"{where}: an expression or tag ran code (created {MARK})"
    assert PWNED_BEFORE or not PWNED.exists(), f"{where}: an expression or tag created {PWNED}"
    pats = [(re.compile(rf"{re.escape(p)}(?::([0-9]+))?: (error|warning): .+", re.S), n)
            for p, n in lines.items()]
    n_errors = 0
    for line in stderr.split("\n"):
        if not line.strip():
            continue
        for pat, nlines in pats:
            m = pat.fullmatch(line)
            if m:
                break
        else:
            pytest.fail(f"{where}: stderr line is not a 'FILE[:LINE]: error|warning: message' "
                        f"diagnostic: {_short(line)}\nstderr: {_short(stderr, 2000)}")
        if m.group(1) is not None:
            ln = int(m.group(1))
            assert 1 <= ln <= nlines, f"{where}: line {ln} outside the file's {nlines} lines: " \
                                      f"{_short(line)}"
        n_errors += m.group(2) == "error"
    if case.valid is None:
        assert code in (0, 1, 2), f"{where}: exit status must be 0, 1 or 2"
    elif case.valid:
        assert code in (0, 1), f"{where}: a valid model must exit 0 or 1\n{_short(stderr, 3000)}"
    else:
        assert code == 2, f"{where}: invalid input must exit 2\n{_short(stderr, 3000)}"
        assert n_errors >= 1, f"{where}: no 'error:' diagnostic on stderr: {_short(stderr, 2000)}"


def run_case(case: Case, tmp_path: Path) -> None:
    paths, lines = _setup(case, tmp_path)
    args = _args(case, paths, tmp_path)
    if case.via == "subproc":
        code, stderr, dt = _invoke_subproc(args, tmp_path)
    else:
        code, stderr, dt = _invoke_inproc(args)
    check_contract(case, lines, code, stderr, dt)


# ------------------------------------------------------------------------------------------------
# Tests
# ------------------------------------------------------------------------------------------------


def _params_of(cases):
    return [pytest.param(c, id=c.id) for c in cases]


@pytest.mark.parametrize("case", _params_of(INPROC + RUN_SAMPLE))
def test_invalid_inproc(case, tmp_path):
    run_case(case, tmp_path)


@pytest.mark.parametrize("case", _params_of(SUBPROC_SAMPLE + HEAVY))
def test_invalid_subprocess(case, tmp_path):
    run_case(case, tmp_path)


@pytest.mark.parametrize("case", _params_of(VALID))
def test_valid_mutations(case, tmp_path):
    run_case(case, tmp_path)


@pytest.mark.parametrize("case", _params_of(EXTREME_CASES))
def test_extreme_numbers(case, tmp_path):
    run_case(case, tmp_path)


CORPUS_FILES = sorted(CORPUS.glob("*.yaml")) if CORPUS.is_dir() else []


def _corpus_expectation(data: bytes) -> bool | None:
    """A corpus file is invalid (exit 2) unless a header line says '# exit: 0 1 2'."""
    m = re.search(rb"^# exit: ([0-9 ]+)$", data, re.M)
    if m is None or m.group(1).split() == [b"2"]:
        return False
    assert m.group(1).split() == [b"0", b"1", b"2"], "unsupported '# exit:' header"
    return None


@pytest.mark.parametrize("path", CORPUS_FILES, ids=[p.stem for p in CORPUS_FILES])
@pytest.mark.parametrize("via,cmd", [("inproc", "run"), ("subproc", "check")])
def test_corpus(path, via, cmd, tmp_path):
    """Minimised failing inputs found by this fuzzer, kept as regression cases."""
    data = path.read_bytes()
    run_case(Case(f"corpus-{path.stem}", data, via=via, cmd=cmd,
                  valid=_corpus_expectation(data)), tmp_path)


def test_case_counts():
    """The fuzzer generates what it claims (guards against a generator silently going empty)."""
    ids = [c.id for c in ALL]
    assert len(ids) == len(set(ids)), "duplicate case ids"
    classes = {c.id.split("-")[0] for c in ALL}
    for cls in ("wrong", "missing", "unknown", "bad", "semantic", "expr", "truncated", "tab",
                "bytes", "syntax", "dup", "multidoc", "tag", "empty", "misc", "path", "heavy",
                "valid", "extreme"):
        assert cls in classes, cls
    assert 300 <= len(ALL) <= 1100, len(ALL)     # grows with the examples in mechanisms/


def test_no_code_ran():
    assert not MARK.exists()
    assert PWNED_BEFORE or not PWNED.exists()
