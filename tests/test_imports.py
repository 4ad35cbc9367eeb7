"""The import graph of planarkin, read with ast so that function-level imports count as well as
module-level ones:

1. no import cycles between modules of the package;
2. no private name (``_x``) of one module imported or used by another module;
3. no module over 800 lines (a longer one holds more than one idea: split it);
4. at most MAX_TOP modules at the package's top level (the stages live in packages: model/,
   functions/, elements/, solver/, results/, output/, and the rooms fed by the Result);
5. no chain of module-level imports longer than MAX_CHAIN modules (what `import planarkin.cli`
   walks through before the first line of work runs);
6. no function over MAX_FUNCTION lines (one that long holds more than one step: name them).

Imports under ``if TYPE_CHECKING:`` (annotations only) never run and are left out. The layers
(model, elements, system, solver, results, output, cli) are import-linter's contract in
pyproject.toml, which .ci/run checks.

``python tests/test_imports.py`` prints the cycles and private names it finds.
"""

from __future__ import annotations

import ast
import functools
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "planarkin"

@functools.lru_cache(maxsize=None)
def _parsed(path: Path, mtime: int):
    return ast.parse(path.read_text(), str(path))


def parsed(path: Path):
    """The file's syntax tree, parsed once per test process (the tests below each walk every
    module of the package)."""
    return _parsed(path, path.stat().st_mtime_ns)


def module_name(path: Path, root: Path = PACKAGE) -> str:
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def modules(root: Path = PACKAGE) -> dict[str, Path]:
    return {module_name(p, root): p for p in sorted(root.rglob("*.py"))}


def _resolve(mod: str, is_package: bool, level: int, target: str | None) -> str:
    """The absolute name of a relative import `from .target import ...` written in mod."""
    if level == 0:
        return target or ""
    base = mod.split(".")
    if not is_package:
        base = base[:-1]
    if level > 1:
        base = base[:len(base) - (level - 1)]
    return ".".join(base + ([target] if target else []))


def _type_only(tree) -> set[int]:
    """ids of the nodes under ``if TYPE_CHECKING:``: imports for annotations, never run."""
    out: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and isinstance(node.test, ast.Name) \
                and node.test.id == "TYPE_CHECKING":
            out.update(id(n) for b in node.body for n in ast.walk(b))
    return out


def imports(mods: dict[str, Path], top_level: bool = False):
    """Every import of a package module that runs, at any depth of the file (functions too;
    not those under ``if TYPE_CHECKING:``): a list of (importer, imported module, names taken
    from it, line). top_level: only the statements of the module's own body (and of its
    module-level if/try blocks)."""
    out = []
    for mod, path in mods.items():
        tree = parsed(path)
        pkg = path.name == "__init__.py"
        skip = _type_only(tree)
        for node in (_body_level(tree) if top_level else ast.walk(tree)):
            if id(node) in skip:
                continue
            if isinstance(node, ast.Import):
                for a in node.names:
                    if a.name.split(".")[0] == "planarkin":
                        out.append((mod, a.name, (), node.lineno))
            elif isinstance(node, ast.ImportFrom):
                src = _resolve(mod, pkg, node.level, node.module)
                if src.split(".")[0] != "planarkin":
                    continue
                names = tuple(a.name for a in node.names)
                # `from pkg import sub`: an import of the submodule sub
                subs = [n for n in names if f"{src}.{n}" in mods]
                rest = tuple(n for n in names if f"{src}.{n}" not in mods)
                for n in subs:
                    out.append((mod, f"{src}.{n}", (), node.lineno))
                if rest or not subs:
                    out.append((mod, src, rest, node.lineno))
    return out


def _body_level(tree):
    """The statements a module runs when imported: its body, into if/try/with blocks, not into
    functions or classes."""
    todo = list(tree.body)
    while todo:
        node = todo.pop()
        yield node
        if isinstance(node, (ast.If, ast.Try, ast.With)):
            for name in ("body", "orelse", "finalbody", "handlers"):
                todo.extend(getattr(node, name, []))
        elif isinstance(node, ast.ExceptHandler):
            todo.extend(node.body)


def longest_chain(g: dict[str, set[str]]) -> list[str]:
    """The longest chain of imports a -> b -> ... without repeating a module."""
    sys.setrecursionlimit(max(10000, sys.getrecursionlimit()))
    memo: dict[str, list[str]] = {}

    def walk(v, seen):
        if v in memo:
            return memo[v]
        best = [v]
        for w in sorted(g[v]):
            if w not in seen:
                c = walk(w, seen | {w})
                if len(c) + 1 > len(best):
                    best = [v] + c
        if not (g[v] & seen):        # no cycle back through the path: the answer holds anywhere
            memo[v] = best
        return best

    return max((walk(v, {v}) for v in sorted(g)), key=len, default=[])


def graph(mods: dict[str, Path], top_level: bool = False) -> dict[str, set[str]]:
    """importer -> imported modules; top_level: only the imports a module runs when it is
    imported (its own body's statements, not those inside functions or classes)."""
    g: dict[str, set[str]] = {m: set() for m in mods}
    for a, b, _, _ in imports(mods, top_level):
        if b in mods and b != a:
            g[a].add(b)
    return g


def cycles(g: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out = []
    sys.setrecursionlimit(max(10000, sys.getrecursionlimit()))

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(g[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(g):
        if v not in index:
            visit(v)
    return out


def _private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def private_imports(mods: dict[str, Path]) -> list[str]:
    """`from m import _x`, and `m._x` where m names a package module imported by the file."""
    found = []
    for a, b, names, line in imports(mods):
        for n in names:
            if _private(n) and b != a:
                found.append(f"{a}:{line}: {n} from {b}")
    for mod, path in mods.items():
        tree = parsed(path)
        pkg = path.name == "__init__.py"
        aliases: dict[str, str] = {}
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                for a in node.names:
                    if a.name.startswith("planarkin") and a.asname:
                        aliases[a.asname] = a.name
            elif isinstance(node, ast.ImportFrom):
                src = _resolve(mod, pkg, node.level, node.module)
                for a in node.names:
                    if f"{src}.{a.name}" in mods:
                        aliases[a.asname or a.name] = f"{src}.{a.name}"
        for node in ast.walk(tree):
            if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name)
                    and node.value.id in aliases and _private(node.attr)
                    and aliases[node.value.id] != mod):
                found.append(f"{mod}:{node.lineno}: {node.attr} of {aliases[node.value.id]}")
    return sorted(set(found))


# -- the tests --------------------------------------------------------------------------------

def test_no_import_cycles():
    found = cycles(graph(modules()))
    assert not found, "import cycles (function-level imports count):\n" + "\n".join(
        " <-> ".join(c) for c in found)


MAX_LINES = 800


def test_no_module_is_over_800_lines():
    long = {module_name(p): n for p in sorted(PACKAGE.rglob("*.py"))
            if (n := len(p.read_text().splitlines())) > MAX_LINES}
    assert long == {}, f"modules over {MAX_LINES} lines: {long}"


MAX_TOP = 15
MAX_CHAIN = 12


def test_few_modules_at_the_top_level():
    top = sorted(p.name for p in PACKAGE.glob("*.py"))
    assert len(top) <= MAX_TOP, f"{len(top)} modules at the top level: {top}"


def test_no_long_chain_of_module_level_imports():
    chain = longest_chain(graph(modules(), top_level=True))
    assert len(chain) <= MAX_CHAIN, f"{len(chain)} modules: {' -> '.join(chain)}"


MAX_FUNCTION = 120


def test_no_function_is_over_120_lines():
    long = {}
    for mod, path in modules().items():
        for node in ast.walk(parsed(path)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > MAX_FUNCTION:
                    long[f"{mod}.{node.name}"] = n
    assert long == {}, f"functions over {MAX_FUNCTION} lines: {long}"


def test_no_private_names_across_modules():
    found = private_imports(modules())
    assert not found, "private names used across modules:\n" + "\n".join(found)


# -- the checks themselves, on small packages written here -------------------------------------

def _package(tmp_path, files: dict[str, str]) -> dict[str, Path]:
    root = tmp_path / "planarkin"
    for name, text in files.items():
        p = root / name
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text)
    return modules(root)


@pytest.mark.parametrize("files, expected", [
    # a function-level import closes the cycle
    ({"__init__.py": "", "a.py": "from . import b\n",
      "b.py": "def f():\n    from .a import g\n"}, [["planarkin.a", "planarkin.b"]]),
    # a package and its submodule
    ({"__init__.py": "", "m/__init__.py": "def f():\n    from .plot import p\n",
      "m/plot.py": "from . import columns\n"}, [["planarkin.m", "planarkin.m.plot"]]),
    # an import for annotations only is no edge
    ({"__init__.py": "", "a.py": "from . import b\n",
      "b.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from .a import A\n"}, []),
    # three modules, absolute and relative
    ({"__init__.py": "", "a.py": "import planarkin.b\n", "b.py": "from .c import x\n",
      "c.py": "from planarkin import a\n"}, [["planarkin.a", "planarkin.b", "planarkin.c"]]),
    ({"__init__.py": "", "a.py": "from . import b\n", "b.py": "import os\n"}, []),
])
def test_cycles_are_found(tmp_path, files, expected):
    assert cycles(graph(_package(tmp_path, files))) == expected


def test_the_longest_chain_counts_module_level_imports_only(tmp_path):
    mods = _package(tmp_path, {
        "__init__.py": "", "a.py": "from . import b\n", "b.py": "def f():\n    from . import c\n",
        "c.py": "if True:\n    from . import d\n", "d.py": "x = 1\n"})
    assert longest_chain(graph(mods, top_level=True)) == ["planarkin.a", "planarkin.b"] or \
        longest_chain(graph(mods, top_level=True)) == ["planarkin.c", "planarkin.d"]
    assert longest_chain(graph(mods)) == ["planarkin.a", "planarkin.b", "planarkin.c",
                                          "planarkin.d"]


def test_private_names_are_found(tmp_path):
    mods = _package(tmp_path, {
        "__init__.py": "", "a.py": "def _h():\n    pass\n_K = 1\n",
        "b.py": "def f():\n    from .a import _h\n",
        "c.py": "from . import a\nx = a._K\n",
        "d.py": "from .a import __doc__\n_own = 1\ny = _own\n"})
    found = private_imports(mods)
    assert [f.split(": ", 1)[1] for f in found] == ["_h from planarkin.a", "_K of planarkin.a"]


if __name__ == "__main__":
    mods = modules()
    for c in cycles(graph(mods)):
        print("cycle:", " <-> ".join(c))
    for p in private_imports(mods):
        print("private:", p)
