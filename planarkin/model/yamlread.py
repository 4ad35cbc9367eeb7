"""Read a YAML model file into a tree of `Node`s that remember their line numbers.

This is the first stage of the pipeline (read -> validate -> compile -> solve -> write). It turns
YAML text into plain data (maps, sequences, scalars) where every node carries the 1-based line it
starts on, so that the validator can report ``FILE:LINE: error: ...`` at the offending node.

Only data is produced, never objects: the text is parsed into YAML *events* by PyYAML's pure-Python
parser (the same scanner/parser as ``yaml.SafeLoader``, so syntax is accepted or rejected exactly as
``yaml.safe_load`` would) and the node tree is built from those events by an iterative composer in
this module. Building the tree ourselves (instead of ``yaml.compose``) means:

* no recursion: nesting deeper than `MAX_DEPTH` levels stops the read at the offending line, so a
  100,000-deep ``[[[[`` file fails in a fraction of a second and cannot overflow the stack;
* aliases are expanded while counting: every node produced is counted (an alias as many times as
  it is used) and the read stops once the count would exceed `MAX_NODES`; since the expanded size
  of every anchored node is known, an alias bomb ("billion laughs") is refused at the first alias
  that would overflow, before copying it;
* only the standard tags (str, int, float, bool, null, seq, map and the non-specific ``!``) are
  accepted; any other tag (``!!python/object/apply:os.system``) is an error, and nothing is
  ever constructed from a tag.

Scalars are typed with YAML 1.1 implicit resolution, as ``yaml.safe_load`` does (``yes`` is True,
``0x1F`` is 31, ``1e-10`` is a *string*, ``.inf`` is a float), and keep their source text in
`Node.text`; the only differences from safe_load are that dates (``2001-12-14``) and a plain ``=``
stay strings. Map keys are the *source text* of the key scalar (a body named ``yes`` stays
``"yes"``); duplicate keys and merge keys (``<<``) are errors.

Limits: `MAX_FILE_BYTES` (10 MB), `MAX_LINES`, `MAX_NODES`, `MAX_DEPTH`, low enough that the
pure-Python parser settles even a file at the size limit within seconds (its rate:
benchmarks/README.md, "Figures moved from the code's comments"). Only a regular file is read
(`read_file`): a FIFO would wait for a writer for ever, a device such as /dev/zero never ends;
both are refused before they are read.

Every problem becomes a `planarkin.diagnostics.Diagnostic`; as many as can be found are collected
and raised together as one `InputError`. `read_yaml` and `read_file` raise nothing else.
"""

from __future__ import annotations

import os
import re
import stat
from dataclasses import dataclass
from typing import Any, Iterator

import yaml
from yaml.events import (
    AliasEvent,
    DocumentStartEvent,
    MappingEndEvent,
    MappingStartEvent,
    ScalarEvent,
    SequenceEndEvent,
    SequenceStartEvent,
    StreamEndEvent,
)
from yaml.nodes import ScalarNode

from planarkin.diagnostics import Collector, Diagnostic, InputError

__all__ = [
    "Node",
    "read_yaml",
    "read_file",
    "MAX_FILE_BYTES",
    "MAX_NODES",
    "MAX_DEPTH",
    "MAX_LINES",
]

#: Largest accepted file (bytes). A real model is a few kilobytes.
MAX_FILE_BYTES = 10 * 1024 * 1024
#: Most YAML nodes (keys included, aliases counted each time they are used) in one document.
MAX_NODES = 200_000
#: Deepest accepted nesting of collections (the root map is level 1).
MAX_DEPTH = 100
#: Most lines in a file (the pure-Python scanner needs about a second per million blank lines).
MAX_LINES = 1_000_000

EMPTY_MESSAGE = "the file is empty: a model needs at least 'bodies' and 'joints'"
TAB_HINT = "tabs are not allowed for indentation in YAML; use spaces"


# --------------------------------------------------------------------------------------------
# The node tree
# --------------------------------------------------------------------------------------------


@dataclass(eq=False)
class Node:
    """One YAML node with the line it starts on.

    kind: ``"map"``, ``"seq"`` or ``"scalar"``.
    value: map -> ``dict[str, Node]`` (file order); seq -> ``list[Node]``;
        scalar -> ``None | bool | int | float | str`` (YAML 1.1 implicit typing, as safe_load).
    line: 1-based line where the node starts (for an alias: the line of the ``*alias``).
    text: scalars only: the scalar's text as written (without quotes, escapes resolved),
        e.g. ``"yes"``, ``"1e-10"``, ``"0x1F"``, ``""`` for an empty value.
    key_lines: maps only: 1-based line of each key.
    """

    kind: str
    value: Any
    line: int
    text: str | None = None
    key_lines: dict[str, int] | None = None

    # -- small helpers ---------------------------------------------------------------------

    @property
    def is_map(self) -> bool:
        return self.kind == "map"

    @property
    def is_seq(self) -> bool:
        return self.kind == "seq"

    @property
    def is_scalar(self) -> bool:
        return self.kind == "scalar"

    def get(self, key: str, default: "Node | None" = None) -> "Node | None":
        """The value node of ``key`` in a map (``default`` if absent or if this is not a map)."""
        if self.kind != "map":
            return default
        return self.value.get(key, default)

    def items(self) -> Iterator[tuple[str, "Node"]]:
        """``(key, node)`` pairs of a map in file order (nothing for other kinds)."""
        if self.kind == "map":
            return iter(self.value.items())
        return iter(())

    def key_line(self, key: str) -> int:
        """Line of ``key`` in a map; the map's own line when unknown."""
        if self.key_lines and key in self.key_lines:
            return self.key_lines[key]
        return self.line

    def to_python(self) -> Any:
        """Plain Python data (dict / list / scalars), without line numbers."""
        if self.kind == "map":
            return {k: v.to_python() for k, v in self.value.items()}
        if self.kind == "seq":
            return [v.to_python() for v in self.value]
        return self.value


# --------------------------------------------------------------------------------------------
# Public entry points
# --------------------------------------------------------------------------------------------


def read_file(path: "str | os.PathLike", display_name: str | None = None) -> Node:
    """Read a model file (at most `MAX_FILE_BYTES`) and return its root node.

    ``display_name`` is the file name used in diagnostics (default: the path as given).
    Raises `InputError` (and nothing else) for an unreadable or invalid file.
    """
    try:
        name = display_name if display_name is not None else os.fsdecode(path)
    except (TypeError, ValueError):
        name = str(path)
    try:
        kind = _not_regular(path)
        if kind is not None:
            raise InputError([Diagnostic(name, None, f"cannot read file: it is {kind}, not a "
                                                     f"regular file (a FIFO, device or socket is "
                                                     f"not read): give a YAML file")])
        # without blocking: a FIFO swapped in after the look would wait in open() for a writer
        with open(path, "rb", opener=_open_nonblocking) as f:
            if _not_regular(f.fileno()) is not None:     # replaced between the looks
                raise InputError([Diagnostic(name, None, "cannot read file: it is not a "
                                                         "regular file: give a YAML file")])
            data = f.read(MAX_FILE_BYTES + 1)
    except OSError as e:
        reason = e.strerror or str(e) or type(e).__name__
        raise InputError([Diagnostic(name, None, f"cannot read file: {reason}")]) from None
    except (ValueError, TypeError) as e:  # e.g. a path with a NUL character
        raise InputError([Diagnostic(name, None, f"cannot read file: {e}")]) from None
    return read_yaml(data, name)


def _not_regular(path) -> str | None:
    """What path (or an open descriptor) is when it is a FIFO, a device or a socket; None for
    a regular file, and for anything os.stat cannot look at (open says why). A folder is
    left to open and read, which name it ("Is a directory")."""
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError, TypeError):
        return None
    if stat.S_ISREG(mode) or stat.S_ISDIR(mode):
        return None
    return ("a FIFO" if stat.S_ISFIFO(mode) else "a device" if stat.S_ISCHR(mode)
            or stat.S_ISBLK(mode) else "a socket" if stat.S_ISSOCK(mode) else "no regular file")


def _open_nonblocking(path, flags):
    return os.open(path, flags | getattr(os, "O_NONBLOCK", 0))


def read_yaml(text: "str | bytes", filename: str) -> Node:
    """Parse YAML text (``str``, or ``bytes`` that must be UTF-8) into a `Node` tree.

    Returns the root node, whatever its kind (the validator checks that it is a map).
    Raises `InputError` carrying every problem found, and never any other exception.
    """
    try:
        return _read_yaml(text, filename)
    except InputError:
        raise
    except RecursionError:
        raise InputError([Diagnostic(filename, 1, "nesting too deep")]) from None
    except MemoryError:
        raise InputError([Diagnostic(filename, None, "out of memory while reading the YAML")]) from None
    except Exception as e:  # pragma: no cover - a safety net: the contract is "InputError only"
        msg = f"cannot read the YAML (internal error: {type(e).__name__}: {_clip(str(e))})"
        raise InputError([Diagnostic(filename, None, msg)]) from None


# --------------------------------------------------------------------------------------------
# Implementation
# --------------------------------------------------------------------------------------------

_STD = "tag:yaml.org,2002:"
_T_STR = _STD + "str"
_T_INT = _STD + "int"
_T_FLOAT = _STD + "float"
_T_BOOL = _STD + "bool"
_T_NULL = _STD + "null"
_T_SEQ = _STD + "seq"
_T_MAP = _STD + "map"
_T_MERGE = _STD + "merge"
_SCALAR_TAGS = frozenset({_T_STR, _T_INT, _T_FLOAT, _T_BOOL, _T_NULL})
_KIND_WORD = {"scalar": "scalar", "seq": "sequence", "map": "mapping"}

# Characters YAML does not allow in a stream (the same set as PyYAML's Reader.NON_PRINTABLE).
_NON_PRINTABLE = re.compile("[^\x09\x0A\x0D\x20-\x7E\x85\xA0-\uD7FF\uE000-\uFFFD\U00010000-\U0010FFFF]")
# Line breaks as YAML (and PyYAML's marks) count them.
_BREAK = re.compile("\r\n|[\n\r\x85\u2028\u2029]")
# A comment runs to the end of the line. Removing everything from the first '#' of each line
# leaves only white space exactly when the file holds nothing but comments and blank lines.
_COMMENT = re.compile("#[^\r\n\x85\u2028\u2029]*")
_YAML_SPACE = " \t\r\n\x85\u2028\u2029"


class _Abort(Exception):
    """Stop reading: the problem was recorded in the collector and nothing sensible follows."""


class _EventParser(yaml.reader.Reader, yaml.scanner.Scanner, yaml.parser.Parser):
    """PyYAML's pure-Python reader/scanner/parser (as in SafeLoader), without composer/constructor."""

    def __init__(self, stream: str):
        yaml.reader.Reader.__init__(self, stream)
        yaml.scanner.Scanner.__init__(self)
        yaml.parser.Parser.__init__(self)


_RESOLVER = yaml.resolver.Resolver()
_CONSTRUCTOR = yaml.constructor.SafeConstructor()
_CONVERT = {
    _T_INT: _CONSTRUCTOR.construct_yaml_int,
    _T_FLOAT: _CONSTRUCTOR.construct_yaml_float,
    _T_BOOL: _CONSTRUCTOR.construct_yaml_bool,
}


def _line_of(text: str, pos: int) -> int:
    """1-based line of character ``pos`` (line breaks counted as YAML counts them)."""
    return len(_BREAK.findall(text, 0, pos)) + 1


def _clip(s: str, limit: int = 60) -> str:
    """A string made safe and short enough to quote in a message."""
    s = s if len(s) <= limit else s[: limit - 3] + "..."
    if _NON_PRINTABLE.search(s) or any(c in s for c in "\n\r\t\x85\u2028\u2029"):
        s = s.encode("unicode_escape", "backslashreplace").decode("ascii")
    return s


def _show_tag(tag: str) -> str:
    return "!!" + tag[len(_STD):] if tag.startswith(_STD) else tag


def _fail(col: Collector, line: int | None, message: str) -> None:
    col.error(line, message)
    col.raise_if_any()


def _decode(data: bytes, col: Collector) -> str:
    """UTF-8 bytes -> text; NUL bytes and invalid UTF-8 are errors at their line."""
    nul = data.find(b"\0")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        if nul != -1 and nul < e.start:
            prefix = data[:nul].decode("utf-8")
            _fail(col, _line_of(prefix, len(prefix)), "the file contains a NUL byte (binary data?)")
        prefix = data[: e.start].decode("utf-8")
        _fail(col, _line_of(prefix, len(prefix)), f"the file is not UTF-8 text (byte 0x{data[e.start]:02x})")
        raise AssertionError("unreachable") from None  # pragma: no cover
    if nul != -1:
        pos = len(data[:nul].decode("utf-8"))
        _fail(col, _line_of(text, pos), "the file contains a NUL byte (binary data?)")
    return text


def _check_characters(text: str, col: Collector) -> None:
    m = _NON_PRINTABLE.search(text)
    if m is None:
        return
    c = m.group()
    line = _line_of(text, m.start())
    code = ord(c)
    if c == "\0":
        _fail(col, line, "the file contains a NUL byte (binary data?)")
    if 0xDC80 <= code <= 0xDCFF:  # a byte smuggled in by errors="surrogateescape"
        _fail(col, line, f"the file is not UTF-8 text (byte 0x{code - 0xDC00:02x})")
    if code < 0x20 or 0x7F <= code <= 0x9F:
        _fail(col, line, f"the file contains the control character U+{code:04X}, which YAML does not allow")
    _fail(col, line, f"the file contains the character U+{code:04X}, which YAML does not allow")


def _read_yaml(text: "str | bytes", filename: str) -> Node:
    col = Collector(filename)
    too_large = "the file is too large (more than 10 MB)"
    if isinstance(text, (bytes, bytearray, memoryview)):
        data = bytes(text)
        if len(data) > MAX_FILE_BYTES:
            _fail(col, None, too_large)
        text = _decode(data, col)
    elif not isinstance(text, str):
        _fail(col, None, f"cannot read the YAML: expected text, got {type(text).__name__}")
    elif len(text) > MAX_FILE_BYTES or (
        len(text) * 4 > MAX_FILE_BYTES and len(text.encode("utf-8", "surrogatepass")) > MAX_FILE_BYTES
    ):
        _fail(col, None, too_large)
    if text.startswith("\ufeff"):
        text = text[1:]
    _check_characters(text, col)
    if max(text.count("\n"), text.count("\r")) >= MAX_LINES:
        _fail(col, None, f"the file has more than {MAX_LINES} lines; a model file must be far smaller")
    if not _COMMENT.sub("", text).strip(_YAML_SPACE):  # fast path: nothing but comments and blanks
        _fail(col, None, EMPTY_MESSAGE)

    parser = _EventParser(text)
    root: Node | None = None
    try:
        parser.get_event()  # StreamStartEvent
        if parser.check_event(StreamEndEvent):
            _fail(col, None, EMPTY_MESSAGE)
        parser.get_event()  # DocumentStartEvent
        composer = _Composer(parser, col)
        root = composer.compose()
        parser.get_event()  # DocumentEndEvent
        _count_documents(parser, col)
    except _Abort:
        pass
    except yaml.MarkedYAMLError as e:
        line, message = _syntax_error(e, text)
        col.error(line, message)
    except yaml.reader.ReaderError as e:  # pragma: no cover - _check_characters comes first
        col.error(_line_of(text, e.position), f"YAML error: {_clip(str(e), 200)}")
    except yaml.YAMLError as e:
        col.error(None, f"YAML error: {_clip(str(e), 200)}")
    except (ValueError, OverflowError) as e:
        # PyYAML's scanner lets chr() fail on escapes such as "\U0011ffff"
        col.error(getattr(parser, "line", 0) + 1,
                  f"YAML syntax error: invalid escape or character code ({_clip(str(e), 120)})")
    finally:
        parser.dispose()
    col.raise_if_any()
    if root is None:  # pragma: no cover - every path without a root records an error
        _fail(col, None, "cannot read the YAML (internal error: no document)")
    if root.kind == "scalar" and root.value is None and root.text == "":
        _fail(col, None, EMPTY_MESSAGE)  # only '---' / comments / an empty document
    return root


_DOC_COUNT_EVENTS = 10_000  # events read to count further documents before saying "at least"


def _count_documents(parser: _EventParser, col: Collector) -> None:
    """After the first document: more documents are an error (counted within an event budget)."""
    if parser.check_event(StreamEndEvent):
        return
    ndocs, line, events = 1, None, 0
    budget = _DOC_COUNT_EVENTS
    while not parser.check_event(StreamEndEvent):
        if events > budget:
            col.error(line, f"the file holds at least {ndocs} YAML documents; a model is one document")
            return
        event = parser.get_event()
        events += 1
        if isinstance(event, DocumentStartEvent):
            ndocs += 1
            if line is None:
                line = event.start_mark.line + 1
    col.error(line, f"the file holds {ndocs} YAML documents; a model is one document")


def _syntax_error(e: "yaml.MarkedYAMLError", text: str) -> tuple[int | None, str]:
    problem = e.problem if e.problem is not None else e.context
    context = e.context if e.problem is not None else None
    message = "YAML syntax error: " + (_clip(str(problem), 200) if problem else "invalid YAML")
    if context:
        message += f" ({_clip(str(context), 200)})"
    mark = e.problem_mark if e.problem_mark is not None else e.context_mark
    if mark is None:
        return None, message
    if _tab_related(text, mark.index, str(problem or "")):
        message += "; " + TAB_HINT
    return mark.line + 1, message


def _tab_related(text: str, index: int, problem: str) -> bool:
    """Is the error about a tab: at the error position or in the indentation of its line?"""
    if "'\\t'" in problem:
        return True
    if 0 <= index < len(text) and text[index] == "\t":
        return True
    index = min(max(index, 0), len(text))
    start = max(text.rfind(c, 0, index) for c in "\n\r\x85\u2028\u2029") + 1
    j = start
    while j < len(text) and text[j] in " \t":
        j += 1
    return "\t" in text[start:j]


class _Frame:
    """An open collection while its events are read."""

    __slots__ = ("node", "anchor", "count0", "height", "is_map", "want_key", "key", "key_line")

    def __init__(self, node: Node, anchor: str | None, count0: int):
        self.node = node
        self.anchor = anchor
        self.count0 = count0  # node count before this collection
        self.height = 0  # collection levels below this one (max over children)
        self.is_map = node.kind == "map"
        self.want_key = True
        self.key: str | None = None
        self.key_line = 0


_OPEN = object()  # anchors[name] while the anchored collection is still being read


class _Composer:
    """Builds the `Node` tree of one document from parser events, iteratively."""

    def __init__(self, parser: _EventParser, col: Collector):
        self.parser = parser
        self.col = col
        self.count = 0  # nodes produced so far (keys included, aliases expanded)
        self.used_alias = False
        # anchor name -> (node, expanded size, height) or _OPEN
        self.anchors: dict[str, Any] = {}

    # -- limits ------------------------------------------------------------------------------

    def _abort(self, line: int, message: str) -> None:
        self.col.error(line, message)
        raise _Abort

    def _too_many(self, line: int) -> None:
        if self.used_alias:
            self._abort(line, f"the document expands to more than {MAX_NODES} YAML nodes (aliases referring to aliases?)")
        self._abort(line, f"the document has more than {MAX_NODES} YAML nodes; a model this large is not supported")

    def _too_deep(self, line: int) -> None:
        self._abort(line, f"nesting deeper than {MAX_DEPTH} levels")

    # -- the event loop ----------------------------------------------------------------------

    def compose(self) -> Node:
        get_event = self.parser.get_event
        stack: list[_Frame] = []
        while True:
            event = get_event()
            cls = event.__class__
            if cls is ScalarEvent:
                node, merge = self._scalar(event)
                done = self._attach(stack, node, 0, merge)
                if event.anchor is not None:
                    self.anchors[event.anchor] = (node, 1, 0)
            elif cls is SequenceStartEvent or cls is MappingStartEvent:
                line = event.start_mark.line + 1
                if len(stack) >= MAX_DEPTH:
                    self._too_deep(line)
                if self.count >= MAX_NODES:
                    self._too_many(line)
                count0 = self.count
                self.count += 1
                if cls is SequenceStartEvent:
                    node = Node("seq", [], line)
                    self._check_collection_tag(event.tag, _T_SEQ, "seq", line)
                else:
                    node = Node("map", {}, line, key_lines={})
                    self._check_collection_tag(event.tag, _T_MAP, "map", line)
                if event.anchor is not None:
                    self.anchors[event.anchor] = _OPEN
                stack.append(_Frame(node, event.anchor, count0))
                continue
            elif cls is SequenceEndEvent or cls is MappingEndEvent:
                frame = stack.pop()
                node = frame.node
                height = frame.height + 1
                if frame.anchor is not None:
                    self.anchors[frame.anchor] = (frame.node, self.count - frame.count0, height)
                done = self._attach(stack, node, height, False)
            elif cls is AliasEvent:
                node, height = self._alias(event, len(stack))
                done = self._attach(stack, node, height, False)
            else:  # pragma: no cover - the parser only emits node events inside a document
                raise yaml.YAMLError(f"unexpected YAML event {cls.__name__}")
            if done:
                return node

    def _attach(self, stack: list[_Frame], node: Node, height: int, merge: bool) -> bool:
        """Hand a finished node to the open collection; True when it is the document root."""
        if not stack:
            return True
        frame = stack[-1]
        if height > frame.height:
            frame.height = height
        if not frame.is_map:
            frame.node.value.append(node)
        elif frame.want_key:
            frame.want_key = False
            frame.key = self._key(frame, node, merge)
            frame.key_line = node.line
        else:
            frame.want_key = True
            if frame.key is not None:
                frame.node.value[frame.key] = node
                frame.node.key_lines[frame.key] = frame.key_line
        return False

    def _key(self, frame: _Frame, key: Node, merge: bool) -> str | None:
        """The key string (source text of the key scalar), or None after reporting a bad key."""
        if key.kind != "scalar":
            self.col.error(key.line, f"a mapping key must be a name or a number, not a {_KIND_WORD[key.kind]}")
            return None
        if merge:
            self.col.error(key.line, "YAML merge keys ('<<') are not supported; write the keys out")
            return None
        name = key.text if key.text is not None else ""
        first = frame.node.key_lines.get(name)
        if first is not None:
            self.col.error(key.line, f"duplicate key '{_clip(name)}' (first given at line {first})")
            return None
        return name

    # -- nodes ---------------------------------------------------------------------------------

    def _scalar(self, event: ScalarEvent) -> tuple[Node, bool]:
        line = event.start_mark.line + 1
        if self.count >= MAX_NODES:
            self._too_many(line)
        self.count += 1
        text = event.value
        tag = event.tag
        if tag is None or tag == "!":
            tag = _RESOLVER.resolve(ScalarNode, text, event.implicit)
        elif tag not in _SCALAR_TAGS:
            self._bad_tag(tag, "scalar", line)
            tag = _T_STR
        merge = tag == _T_MERGE
        if tag == _T_NULL:
            value: Any = None
        elif tag in _CONVERT:
            try:
                value = _CONVERT[tag](yaml.ScalarNode(tag, text))
            except Exception:  # ValueError, KeyError, IndexError: not a valid int/float/bool
                self.col.error(line, f"cannot read '{_clip(text)}' as {_show_tag(tag)}")
                value = text
        else:  # str, and implicit timestamp / merge / value tags: keep the text
            value = text
        return Node("scalar", value, line, text=text), merge

    def _check_collection_tag(self, tag: str | None, expected: str, kind: str, line: int) -> None:
        if tag is None or tag == "!" or tag == expected:
            return
        self._bad_tag(tag, kind, line)

    def _bad_tag(self, tag: str, kind: str, line: int) -> None:
        if tag in _SCALAR_TAGS or tag in (_T_SEQ, _T_MAP):
            self.col.error(line, f"YAML tag '{_show_tag(tag)}' cannot be used on a {_KIND_WORD[kind]}")
        else:
            self.col.error(line, f"unsupported YAML tag '{_clip(_show_tag(tag), 100)}'")

    def _alias(self, event: AliasEvent, depth: int) -> tuple[Node, int]:
        """Expand ``*name``: a copy of the anchored node (line = the alias's line) and its height."""
        line = event.start_mark.line + 1
        name = event.anchor
        entry = self.anchors.get(name)
        if entry is None or entry is _OPEN:
            if entry is None:
                msg = f"undefined YAML alias '*{_clip(name)}' (the anchor '&{_clip(name)}' must come before it)"
            else:
                msg = f"YAML alias '*{_clip(name)}' refers to a node that contains it (recursive structure)"
            self.col.error(line, msg)
            if self.count >= MAX_NODES:
                self._too_many(line)
            self.count += 1
            return Node("scalar", None, line, text=""), 0
        target, size, height = entry
        self.used_alias = True
        if self.count + size > MAX_NODES:
            self._too_many(line)
        if depth + height > MAX_DEPTH:
            self._too_deep(line)
        self.count += size
        return _copy(target, line), height


def _copy(node: Node, line: int) -> Node:
    """Deep copy of a node tree (iterative), the root placed at ``line``."""

    def shallow(n: Node, at: int) -> Node:
        if n.kind == "scalar":
            return Node("scalar", n.value, at, text=n.text)
        if n.kind == "seq":
            return Node("seq", [], at)
        return Node("map", {}, at, key_lines=dict(n.key_lines or {}))

    root = shallow(node, line)
    todo = [(node, root)] if node.kind != "scalar" else []
    while todo:
        src, dst = todo.pop()
        if src.kind == "seq":
            for child in src.value:
                c = shallow(child, child.line)
                dst.value.append(c)
                if child.kind != "scalar":
                    todo.append((child, c))
        else:
            for key, child in src.value.items():
                c = shallow(child, child.line)
                dst.value[key] = c
                if child.kind != "scalar":
                    todo.append((child, c))
    return root


def type_name(node: Node) -> str:
    """What a node is, for messages: 'a mapping', 'the number 3', 'empty (null)' ..."""
    if node.kind == "map":
        return "a mapping"
    if node.kind == "seq":
        return "a list"
    v = node.value
    if v is None:
        return "empty (null)"
    if isinstance(v, bool):
        return f"a boolean ({node.text})"
    return f"'{node.text}'" if isinstance(v, str) else f"the number {node.text}"


def raw_text(node: Node) -> str:
    """A scalar's text as written, for labels ('?' for anything else)."""
    if node.kind == "scalar" and node.value is not None:
        return str(node.text if node.text is not None else node.value)
    return "?"
