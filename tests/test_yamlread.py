"""Tests for planarkin.model.yamlread: YAML text -> Node tree with line numbers, or InputError."""

from __future__ import annotations

import os
import random
import re
import time
import tracemalloc

import pytest
import yaml

from planarkin.diagnostics import InputError
from planarkin.model import yamlread
from planarkin.model.yamlread import MAX_FILE_BYTES, Node, read_file, read_yaml

F = "model.yaml"
DIAG_RE = re.compile(r"^model\.yaml(:[1-9][0-9]*)?: error: \S.*$", re.S)


def errors(text, filename=F) -> list[str]:
    """Read ``text``, expect an InputError, check every diagnostic's format, return the lines."""
    with pytest.raises(InputError) as info:
        read_yaml(text, filename)
    diags = info.value.diagnostics
    assert diags, "an InputError must carry at least one diagnostic"
    out = [d.format() for d in diags]
    for d, line in zip(diags, out):
        assert d.severity == "error"
        assert d.line is None or (isinstance(d.line, int) and d.line >= 1)
        assert "\n" not in line and "Traceback" not in line
        if filename == F:
            assert DIAG_RE.match(line), line
    # line order (file-level problems, with no line, first)
    keys = [(d.line is not None, d.line or 0) for d in diags]
    assert keys == sorted(keys)
    assert str(info.value) == "\n".join(out)
    return out


def one_error(text) -> str:
    out = errors(text)
    assert len(out) == 1, out
    return out[0]


def timed_errors(text, limit=1.0) -> tuple[list[str], float]:
    """The errors and the CPU seconds they took. limit: a generous figure for the quiet case;
    the test fails only at 10 times it, where only a blow-up (an alias bomb, a quadratic scan)
    gets: CPU, not wall, and the margin, so that a loaded CI machine never fails it."""
    t0 = time.process_time()
    out = errors(text)
    elapsed = time.process_time() - t0
    assert elapsed < 10 * limit, f"took {elapsed:.2f}s, a blow-up"
    return out, elapsed


# ---------------------------------------------------------------------------------------------
# Lines
# ---------------------------------------------------------------------------------------------

MODEL = """\
# a four-bar linkage
bodies:
  ground: {fixed: true}
  crank:
    length: 0.1
    points:
      A: [0, 0]
      B: [0.1, 0]
joints:
  - type: revolute
    bodies: [ground, crank]

  - type: revolute
    bodies:
      - crank
      - rod
"""


def test_lines_of_keys_values_and_items():
    root = read_yaml(MODEL, F)
    assert root.kind == "map" and root.line == 2
    assert list(root.value) == ["bodies", "joints"]
    assert root.key_lines == {"bodies": 2, "joints": 9}
    bodies = root.get("bodies")
    assert bodies.kind == "map" and bodies.line == 3  # a block map starts at its first key
    assert bodies.key_lines == {"ground": 3, "crank": 4}
    ground = bodies.get("ground")
    assert ground.kind == "map" and ground.line == 3 and ground.key_lines == {"fixed": 3}
    crank = bodies.get("crank")
    assert crank.line == 5 and crank.key_lines == {"length": 5, "points": 6}
    assert crank.get("length").line == 5
    points = crank.get("points")
    assert points.line == 7 and points.key_lines == {"A": 7, "B": 8}
    b = points.get("B")
    assert b.kind == "seq" and b.line == 8 and [x.line for x in b.value] == [8, 8]
    joints = root.get("joints")
    assert joints.kind == "seq" and joints.line == 10
    assert [j.line for j in joints.value] == [10, 13]
    j2 = joints.value[1]
    assert j2.key_lines == {"type": 13, "bodies": 14}
    assert j2.get("bodies").line == 15
    assert [x.line for x in j2.get("bodies").value] == [15, 16]
    assert [x.value for x in j2.get("bodies").value] == ["crank", "rod"]


def test_lines_multiline_flow_block_scalars_and_line_endings():
    text = "a: [1,\n  2,\n  3]\nb: |\n  text\n  more\nc: >-\n  x\nd: 'q\n  r'\ne: 5\n"
    root = read_yaml(text, F)
    assert [n.line for n in root.get("a").value] == [1, 2, 3]
    assert root.get("b").value == "text\nmore\n" and root.get("b").line == 4
    assert root.get("c").value == "x"
    assert root.get("d").value == "q r" and root.get("d").line == 9
    assert root.key_lines["e"] == 11
    crlf = read_yaml("a: 1\r\nb: 2\r\n\r\nc: 3\r\n", F)
    assert crlf.key_lines == {"a": 1, "b": 2, "c": 4}
    cr = read_yaml("a: 1\rb: 2\rc: 3\r", F)  # old Mac line ends count as YAML line breaks
    assert cr.key_lines == {"a": 1, "b": 2, "c": 3}


def test_node_helpers():
    root = read_yaml("a: {b: [1, x]}\nc: ~\n", F)
    assert root.is_map and not root.is_seq and not root.is_scalar
    assert root.get("zzz") is None
    assert root.get("a").get("b").get("b") is None  # get on a seq: None
    assert [k for k, _ in root.items()] == ["a", "c"]
    assert list(root.get("c").items()) == []
    assert root.key_line("c") == 2 and root.key_line("nope") == root.line
    assert root.to_python() == {"a": {"b": [1, "x"]}, "c": None}


# ---------------------------------------------------------------------------------------------
# Scalars
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "src, value, text",
    [
        ("yes", True, "yes"),
        ("No", False, "No"),
        ("on", True, "on"),
        ("true", True, "true"),
        ("1e-10", "1e-10", "1e-10"),  # YAML 1.1: no dot, so a string
        ("1.0e-10", 1.0e-10, "1.0e-10"),
        ("0.1", 0.1, "0.1"),
        ('"0.1"', "0.1", "0.1"),
        ("'yes'", "yes", "yes"),
        ("~", None, "~"),
        ("null", None, "null"),
        ("", None, ""),
        ("2*a", "2*a", "2*a"),
        ("0x1F", 31, "0x1F"),
        ("017", 15, "017"),
        ("1_000", 1000, "1_000"),
        ("-3", -3, "-3"),
        ("1:30", 90, "1:30"),
        ("2001-12-14", "2001-12-14", "2001-12-14"),  # timestamps stay text
        ("!!str 12", "12", "12"),
        ("!!float '1'", 1.0, "1"),
        ("! 12", 12, "12"),
        ("pi/2", "pi/2", "pi/2"),
    ],
)
def test_scalar_typing_and_text(src, value, text):
    node = read_yaml(f"v: {src}\n", F).get("v")
    assert node.kind == "scalar"
    assert type(node.value) is type(value) and node.value == value
    assert node.text == text
    assert node.key_lines is None


def test_inf_and_nan_are_floats():
    root = read_yaml("a: .inf\nb: -.Inf\nc: .nan\n", F)
    assert root.get("a").value == float("inf") and root.get("a").text == ".inf"
    assert root.get("b").value == float("-inf")
    c = root.get("c").value
    assert isinstance(c, float) and c != c


def test_flow_sequence_value():
    node = read_yaml("p: [0, 0]\n", F).get("p")
    assert node.kind == "seq" and node.line == 1
    assert [(n.kind, n.value, n.text) for n in node.value] == [("scalar", 0, "0"), ("scalar", 0, "0")]


def test_keys_are_source_text():
    root = read_yaml("yes: 1\non: 2\nno: 3\n1: 4\n0x1F: 5\n~: 6\n'': 7\n\"quoted\": 8\n", F)
    assert list(root.value) == ["yes", "on", "no", "1", "0x1F", "~", "", "quoted"]
    assert root.get("yes").value == 1 and root.get("0x1F").value == 5


def test_root_can_be_any_kind():
    assert read_yaml("- a\n- b\n", F).kind == "seq"
    s = read_yaml("hello\n", F)
    assert s.kind == "scalar" and s.value == "hello"


# ---------------------------------------------------------------------------------------------
# Keys: duplicates, merge keys, non-scalar keys
# ---------------------------------------------------------------------------------------------


def test_duplicate_keys_all_reported_at_second_occurrence():
    text = "a: 1\nb:\n  i: 1\n  j: 2\n  i: 3\na: 4\nc: {x: 1, x: 2}\n"
    assert errors(text) == [
        "model.yaml:5: error: duplicate key 'i' (first given at line 3)",
        "model.yaml:6: error: duplicate key 'a' (first given at line 1)",
        "model.yaml:7: error: duplicate key 'x' (first given at line 7)",
    ]


def test_duplicate_key_spelled_differently_is_still_the_same_text_only():
    # keys compare by source text: 1 and 01 are different keys, yes and yes are the same
    root = read_yaml("1: a\n01: b\n", F)
    assert list(root.value) == ["1", "01"]
    assert errors("yes: 1\nyes: 2\n") == ["model.yaml:2: error: duplicate key 'yes' (first given at line 1)"]


def test_merge_keys_rejected():
    text = "base: &b {x: 1}\nd:\n  <<: *b\n  y: 2\n"
    assert errors(text) == ["model.yaml:3: error: YAML merge keys ('<<') are not supported; write the keys out"]
    # a quoted '<<' is an ordinary key
    assert list(read_yaml("'<<': 1\n", F).value) == ["<<"]


def test_non_scalar_keys_rejected():
    assert errors("? [a, b]\n: 1\nc: 2\n? {x: 1}\n: 3\n") == [
        "model.yaml:1: error: a mapping key must be a name or a number, not a sequence",
        "model.yaml:4: error: a mapping key must be a name or a number, not a mapping",
    ]


# ---------------------------------------------------------------------------------------------
# Tags
# ---------------------------------------------------------------------------------------------


def test_unknown_tags_rejected_and_nothing_runs(tmp_path, monkeypatch):
    calls = []
    monkeypatch.setattr(os, "system", lambda *a, **k: calls.append(a) or 0)
    marker = tmp_path / "ran"
    text = (
        "a: !!python/object/apply:os.system ['echo hi']\n"
        f"b: !!python/object/apply:subprocess.call [['touch', '{marker}']]\n"
        "c: !!python/name:os.system\n"
        "d: !foo bar\n"
        "e: !!binary aGk=\n"
        "f: !<tag:example.com,2000:x> 1\n"
    )
    assert errors(text) == [
        "model.yaml:1: error: unsupported YAML tag '!!python/object/apply:os.system'",
        "model.yaml:2: error: unsupported YAML tag '!!python/object/apply:subprocess.call'",
        "model.yaml:3: error: unsupported YAML tag '!!python/name:os.system'",
        "model.yaml:4: error: unsupported YAML tag '!foo'",
        "model.yaml:5: error: unsupported YAML tag '!!binary'",
        "model.yaml:6: error: unsupported YAML tag 'tag:example.com,2000:x'",
    ]
    assert calls == []
    assert not marker.exists()


def test_standard_tags_accepted_and_misused_ones_rejected():
    root = read_yaml("a: !!seq [1]\nb: !!map {x: 1}\nc: !!int '7'\nd: !!null ''\ne: !!bool 'yes'\n", F)
    assert root.to_python() == {"a": [1], "b": {"x": 1}, "c": 7, "d": None, "e": True}
    assert errors("a: !!map x\nb: !!str [1]\nc: !!set {x}\nd: !!int abc\ne: !!bool maybe\n") == [
        "model.yaml:1: error: YAML tag '!!map' cannot be used on a scalar",
        "model.yaml:2: error: YAML tag '!!str' cannot be used on a sequence",
        "model.yaml:3: error: unsupported YAML tag '!!set'",
        "model.yaml:4: error: cannot read 'abc' as !!int",
        "model.yaml:5: error: cannot read 'maybe' as !!bool",
    ]


def test_several_kinds_of_problem_collected_in_line_order():
    text = "a: 1\nb: !!python/object:x {}\nc: {<<: {}}\na: 2\n? [k]\n: v\n"
    assert errors(text) == [
        "model.yaml:2: error: unsupported YAML tag '!!python/object:x'",
        "model.yaml:3: error: YAML merge keys ('<<') are not supported; write the keys out",
        "model.yaml:4: error: duplicate key 'a' (first given at line 1)",
        "model.yaml:5: error: a mapping key must be a name or a number, not a sequence",
    ]


# ---------------------------------------------------------------------------------------------
# Anchors and aliases
# ---------------------------------------------------------------------------------------------


def test_aliases_are_expanded_as_independent_copies_at_the_alias_line():
    text = "p: &p [1, 2]\nq: *p\nr:\n  - *p\n  - &s hello\n  - *s\n"
    root = read_yaml(text, F)
    assert root.to_python() == {"p": [1, 2], "q": [1, 2], "r": [[1, 2], "hello", "hello"]}
    p, q = root.get("p"), root.get("q")
    assert p.line == 1 and q.line == 2 and root.get("r").value[0].line == 4
    assert q is not p and q.value[0] is not p.value[0]
    assert root.get("r").value[2].line == 6 and root.get("r").value[2].text == "hello"


def test_alias_keys_and_redefined_anchors():
    root = read_yaml("&k name: 1\nother: &v 1\nlater: &v 2\nx: *v\n", F)
    assert root.get("x").value == 2
    assert errors("&k name: 1\n*k : 2\n") == ["model.yaml:2: error: duplicate key 'name' (first given at line 1)"]


def test_undefined_and_recursive_aliases():
    assert errors("a: &x [1, *x]\nb: *nope\n") == [
        "model.yaml:1: error: YAML alias '*x' refers to a node that contains it (recursive structure)",
        "model.yaml:2: error: undefined YAML alias '*nope' (the anchor '&nope' must come before it)",
    ]


def billion_laughs(levels=9, width=10) -> str:
    lines = ['a: &a ["' + '","'.join(["lol"] * width) + '"]']
    names = "abcdefghijklmnopqrstuvwxyz"
    for i in range(1, levels):
        lines.append(f"{names[i]}: &{names[i]} [" + ", ".join([f"*{names[i - 1]}"] * width) + "]")
    return "\n".join(lines) + "\n"


def test_billion_laughs_fails_fast():
    out, _ = timed_errors(billion_laughs(), limit=1.0)
    assert len(out) == 1
    assert re.fullmatch(
        r"model\.yaml:\d+: error: the document expands to more than 200000 YAML nodes "
        r"\(aliases referring to aliases\?\)",
        out[0],
    )


def test_small_alias_use_is_fine():
    root = read_yaml(billion_laughs(levels=3, width=5), F)
    assert len(root.get("c").value) == 5 and len(root.get("c").value[0].value) == 5


def test_node_limit_without_aliases(monkeypatch):
    monkeypatch.setattr(yamlread, "MAX_NODES", 1000)
    ok = "a: [" + ", ".join(["0"] * 997) + "]\n"  # root map + key + seq + 997 items = 1000 nodes
    assert len(read_yaml(ok, F).get("a").value) == 997
    assert errors("a: [" + ", ".join(["0"] * 998) + "]\n") == [
        "model.yaml:1: error: the document has more than 1000 YAML nodes; a model this large is not supported"
    ]


def test_node_limit_counts_alias_expansions(monkeypatch):
    monkeypatch.setattr(yamlread, "MAX_NODES", 100)
    text = "a: &a [" + ", ".join(["0"] * 20) + "]\nb: [*a, *a, *a, *a, *a]\n"
    assert errors(text) == [
        "model.yaml:2: error: the document expands to more than 100 YAML nodes (aliases referring to aliases?)"
    ]


# ---------------------------------------------------------------------------------------------
# Nesting
# ---------------------------------------------------------------------------------------------


def test_nesting_limit_is_100_levels():
    assert read_yaml("[" * 100 + "]" * 100, F).kind == "seq"
    assert errors("[" * 101 + "]" * 101) == ["model.yaml:1: error: nesting deeper than 100 levels"]
    # the line is the one where the 101st level starts
    assert errors("[\n" * 101 + "]" * 101) == ["model.yaml:101: error: nesting deeper than 100 levels"]
    assert errors("a:\n" + "  [\n" * 100 + "]" * 100) == ["model.yaml:101: error: nesting deeper than 100 levels"]
    block = "".join(" " * i + "k:\n" for i in range(150))
    assert errors(block) == ["model.yaml:101: error: nesting deeper than 100 levels"]


def test_nesting_through_aliases_is_counted():
    deep = "[" * 99 + "]" * 99
    assert read_yaml(f"a: &a {deep}\nb: *a\n", F).kind == "map"  # root + 99 = 100 levels
    assert errors(f"a: &a {deep}\nb: [*a]\n") == ["model.yaml:2: error: nesting deeper than 100 levels"]


@pytest.mark.parametrize("depth", [10_000, 100_000])
@pytest.mark.parametrize("opener", ["[", "{a: ", "- "])
def test_absurd_nesting_fails_fast(opener, depth):
    out, _ = timed_errors(opener * depth, limit=2.0)
    assert out == ["model.yaml:1: error: nesting deeper than 100 levels"]


def test_absurd_nesting_closed_and_multiline_fails_fast():
    timed_errors("[" * 100_000 + "]" * 100_000, limit=2.0)
    timed_errors("{a: " * 50_000 + "}" * 50_000, limit=2.0)
    out, _ = timed_errors("[\n" * 100_000, limit=2.0)
    assert out == ["model.yaml:101: error: nesting deeper than 100 levels"]


# ---------------------------------------------------------------------------------------------
# Size
# ---------------------------------------------------------------------------------------------


def big_valid_yaml(size: int) -> str:
    row = '  - "' + "a long description of some part of the mechanism " * 2 + '"\n'
    return "notes:\n" + row * (size // len(row))


def test_5mb_valid_file(tmp_path):
    path = tmp_path / "big.yaml"
    text = big_valid_yaml(5_000_000)
    path.write_text(text, encoding="utf-8")
    assert 4_900_000 < path.stat().st_size < MAX_FILE_BYTES
    root = read_file(path)
    assert root.get("notes").kind == "seq"
    assert len(root.get("notes").value) == text.count("\n") - 1
    assert root.get("notes").value[-1].line == text.count("\n")


def test_11mb_file_rejected_fast(tmp_path):
    path = tmp_path / "huge.yaml"
    data = ("# " + "x" * 97 + "\n").encode() * (11 * 1024 * 1024 // 100 + 1)
    path.write_bytes(data)
    with pytest.raises(InputError) as info:
        read_file(path, display_name=F)
    assert [d.format() for d in info.value.diagnostics] == ["model.yaml: error: the file is too large (more than 10 MB)"]
    # the same limit applies to text handed to read_yaml directly, str or bytes
    assert errors(data) == ["model.yaml: error: the file is too large (more than 10 MB)"]
    assert errors(data.decode()) == ["model.yaml: error: the file is too large (more than 10 MB)"]


def test_a_huge_file_is_refused_having_read_no_more_than_the_budget(tmp_path):
    # a bound on bytes, not on seconds: a sparse 1 GB file read whole would take a gigabyte
    path = tmp_path / "sparse.yaml"
    with open(path, "wb") as f:
        f.truncate(10**9)
    tracemalloc.start()
    with pytest.raises(InputError, match="the file is too large"):
        read_file(path, display_name=F)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 3 * MAX_FILE_BYTES


# ---------------------------------------------------------------------------------------------
# Encoding and characters
# ---------------------------------------------------------------------------------------------


def test_non_utf8_bytes():
    assert errors(b"a: 1\nb: 2\nc: caf\xe9\n") == ["model.yaml:3: error: the file is not UTF-8 text (byte 0xe9)"]
    assert errors(b"a: 1\n\xff\xfe") == ["model.yaml:2: error: the file is not UTF-8 text (byte 0xff)"]
    utf16 = "a: 1\n".encode("utf-16")
    assert errors(utf16) == ["model.yaml:1: error: the file is not UTF-8 text (byte 0xff)"]
    # text decoded with errors='surrogateescape' keeps the bad byte: same message
    assert errors(b"a: 1\nb: \x80\n".decode("utf-8", "surrogateescape")) == [
        "model.yaml:2: error: the file is not UTF-8 text (byte 0x80)"
    ]


def test_utf8_with_bom_and_unicode_names():
    root = read_yaml("\ufeffbodies:\n  stößel: {m: 1}\n".encode("utf-8"), F)
    assert list(root.get("bodies").value) == ["stößel"]
    assert root.key_lines == {"bodies": 1}


def test_nul_and_control_characters():
    assert errors(b"a: 1\n\nb: x\x00y\n") == ["model.yaml:3: error: the file contains a NUL byte (binary data?)"]
    assert errors("a: 1\nb: \x00\n") == ["model.yaml:2: error: the file contains a NUL byte (binary data?)"]
    # a NUL byte before an invalid byte is the first problem
    assert errors(b"\x00\xff") == ["model.yaml:1: error: the file contains a NUL byte (binary data?)"]
    assert errors("a: 1\nb: \x07\n") == [
        "model.yaml:2: error: the file contains the control character U+0007, which YAML does not allow"
    ]


def test_binary_garbage():
    rng = random.Random(20240601)
    png = b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR" + bytes(rng.randrange(256) for _ in range(200))
    out = errors(png)
    assert len(out) == 1 and out[0].startswith("model.yaml:1: error: the file is not UTF-8 text (byte 0x89)")
    for _ in range(200):
        blob = bytes(rng.randrange(256) for _ in range(rng.randrange(1, 300)))
        try:
            read_yaml(blob, F)
        except InputError as e:
            assert all(DIAG_RE.match(d.format()) for d in e.diagnostics)


def test_mutated_models_never_raise_anything_but_input_error():
    rng = random.Random(7)
    alphabet = "[]{}:,-?&*!|>'\"#%@` \t\n\\~0aZ<="
    for _ in range(1500):
        chars = list(MODEL)
        for _ in range(rng.randrange(1, 6)):
            i = rng.randrange(len(chars))
            op = rng.randrange(3)
            if op == 0:
                chars[i] = rng.choice(alphabet)
            elif op == 1:
                chars.insert(i, rng.choice(alphabet))
            else:
                del chars[i]
        text = "".join(chars)
        try:
            yaml.safe_load(text)
            syntax_ok = True
        except (yaml.scanner.ScannerError, yaml.parser.ParserError):
            syntax_ok = False
        except Exception:  # constructor problems: not about syntax
            syntax_ok = True
        try:
            node = read_yaml(text, F)
        except InputError as e:
            assert all(DIAG_RE.match(d.format()) for d in e.diagnostics), e
            if not syntax_ok:  # the same syntax as yaml.safe_load
                assert any(": error: YAML syntax error: " in d.format() for d in e.diagnostics), e
        else:
            assert isinstance(node, Node)
            assert syntax_ok, text


# ---------------------------------------------------------------------------------------------
# Syntax errors, tabs, empty files, several documents
# ---------------------------------------------------------------------------------------------


def test_yaml_syntax_error_format():
    assert errors("a: 1\nb: 'unclosed\n") == [
        "model.yaml:3: error: YAML syntax error: found unexpected end of stream (while scanning a quoted scalar)"
    ]
    assert errors("a: b: c\n") == ["model.yaml:1: error: YAML syntax error: mapping values are not allowed here"]
    assert errors("a: [1, 2\nb: 3\n") == [
        "model.yaml:2: error: YAML syntax error: expected ',' or ']', but got ':' (while parsing a flow sequence)"
    ]


def test_problems_before_a_syntax_error_are_kept():
    assert errors("a: 1\na: 2\nb: [\n") == [
        "model.yaml:2: error: duplicate key 'a' (first given at line 1)",
        "model.yaml:4: error: YAML syntax error: expected the node content, but found '<stream end>' "
        "(while parsing a flow node)",
    ]


def test_tabs():
    assert errors("bodies:\n\tcrank: {}\n") == [
        "model.yaml:2: error: YAML syntax error: found character '\\t' that cannot start any token "
        "(while scanning for the next token); tabs are not allowed for indentation in YAML; use spaces"
    ]
    out = one_error("a:\n  b: 1\n  c:\n \t d: 2\n")
    assert out.startswith("model.yaml:4: error: YAML syntax error:") and "tabs are not allowed" in out
    # a tab inside a quoted string is fine
    assert read_yaml('a: "x\ty"\n', F).get("a").value == "x\ty"


@pytest.mark.parametrize("text", ["", "   \n\n", "# only a comment\n# and another\n", "---\n", "--- # empty\n...\n", b""])
def test_empty_file(text):
    assert errors(text) == ["model.yaml: error: the file is empty: a model needs at least 'bodies' and 'joints'"]


def test_comment_fast_path_is_exact():
    # YAML line breaks beyond \n and \r end a comment too
    assert read_yaml("# c\u2028a: 1\n", F).to_python() == {"a": 1}
    assert read_yaml("# c\x85a: 1\n", F).to_python() == {"a": 1}
    assert read_yaml("  # c\nb: x#y # z\n", F).to_python() == {"b": "x#y"}


def test_huge_files_of_nothing_fail_fast():
    out, _ = timed_errors("\n" * 1_000_000, limit=1.0)
    assert out == ["model.yaml: error: the file has more than 1000000 lines; a model file must be far smaller"]
    out, _ = timed_errors(("# " + "x" * 98 + "\n") * 100_000, limit=1.0)
    assert out == ["model.yaml: error: the file is empty: a model needs at least 'bodies' and 'joints'"]
    read_yaml("\n" * 999_990 + "a: 1\n", F)  # just under the line limit


def test_several_documents():
    assert errors("bodies: {}\n---\njoints: []\n") == [
        "model.yaml:2: error: the file holds 2 YAML documents; a model is one document"
    ]
    assert errors("--- \na: 1\n--- \nb: 2\n---\nc: 3\n") == [
        "model.yaml:3: error: the file holds 3 YAML documents; a model is one document"
    ]
    assert errors("a: 1\n...\n--- b\n") == ["model.yaml:3: error: the file holds 2 YAML documents; a model is one document"]


def test_several_documents_counting_is_bounded():
    text = "a: 1\n---\n" + "- x\n" * 300_000 + "---\nb: 2\n"
    out, _ = timed_errors(text, limit=3.0)
    assert out == ["model.yaml:2: error: the file holds at least 2 YAML documents; a model is one document"]


# ---------------------------------------------------------------------------------------------
# read_file
# ---------------------------------------------------------------------------------------------


def test_read_file_ok_and_display_name(tmp_path):
    path = tmp_path / "m.yaml"
    path.write_bytes(MODEL.encode())
    assert read_file(path).get("bodies").line == 3
    assert read_file(str(path)).key_lines == {"bodies": 2, "joints": 9}
    path.write_bytes(b"a: 1\na: 2\n")
    with pytest.raises(InputError) as info:
        read_file(path, display_name="shown.yaml")
    assert [d.format() for d in info.value.diagnostics] == [
        "shown.yaml:2: error: duplicate key 'a' (first given at line 1)"
    ]
    with pytest.raises(InputError) as info:
        read_file(path)
    assert info.value.diagnostics[0].file == str(path)


def test_read_file_unreadable(tmp_path):
    cases = [(tmp_path / "missing.yaml", "No such file or directory"), (tmp_path, "Is a directory")]
    for path, reason in cases:
        with pytest.raises(InputError) as info:
            read_file(path, display_name=F)
        assert [d.format() for d in info.value.diagnostics] == [f"model.yaml: error: cannot read file: {reason}"]
        assert info.value.diagnostics[0].line is None


def test_read_file_permission_denied_simulated(tmp_path, monkeypatch):
    def deny(*args, **kwargs):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(yamlread, "open", deny, raising=False)
    with pytest.raises(InputError) as info:
        read_file(tmp_path / "x.yaml", display_name=F)
    assert [d.format() for d in info.value.diagnostics] == ["model.yaml: error: cannot read file: Permission denied"]


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() == 0, reason="root can read anything")
def test_read_file_permission_denied(tmp_path):
    path = tmp_path / "secret.yaml"
    path.write_text("a: 1\n")
    path.chmod(0)
    try:
        with pytest.raises(InputError) as info:
            read_file(path, display_name=F)
        assert [d.format() for d in info.value.diagnostics] == ["model.yaml: error: cannot read file: Permission denied"]
    finally:
        path.chmod(0o600)


# ---------------------------------------------------------------------------------------------
# The contract: InputError and nothing else
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "exc, expected",
    [
        (RecursionError, "model.yaml:1: error: nesting too deep"),
        (MemoryError, "model.yaml: error: out of memory while reading the YAML"),
        (ZeroDivisionError("boom"), "model.yaml: error: cannot read the YAML (internal error: ZeroDivisionError: boom)"),
    ],
)
def test_unexpected_exceptions_become_input_errors(monkeypatch, exc, expected):
    def explode(self):
        raise exc

    monkeypatch.setattr(yamlread._Composer, "compose", explode)
    assert errors("a: 1\n") == [expected]


def test_wrong_argument_type():
    assert errors(12345) == ["model.yaml: error: cannot read the YAML: expected text, got int"]
