"""JUnit XML reports (`planarkin run --junit FILE`, `planarkin compare --junit FILE`): the
format CI systems read (Jenkins, GitLab, GitHub's test reporters ...), as their common schema
has it:

    <testsuites name tests failures errors time>
      <testsuite name tests failures errors skipped time>
        <testcase name classname time>            one per model, in order
          <failure message="...">text</failure>   or <error ...>, <skipped ...>, or nothing
          <system-out>text</system-out>           (a case that passed: its terminal line)

times in seconds (3 decimals). The file is written whole or not at all: into a temporary file
beside it, renamed over it; a failure leaves FILE as it was and no temporary behind.
"""

from __future__ import annotations

import os
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

KINDS = ("failure", "error", "skipped")
# characters XML 1.0 cannot hold (control characters, lone surrogates of undecodable names)
_NOT_XML = re.compile("[^\t\n\r\u0020-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")


@dataclass
class Case:
    """One test case: kind None (passed) or one of KINDS, with its one-line message and text."""

    name: str
    classname: str
    seconds: float
    kind: str | None = None
    message: str = ""
    text: str = ""


def _clean(s: str) -> str:
    return _NOT_XML.sub("\ufffd", str(s))


def _seconds(x: float) -> str:
    return f"{max(float(x), 0.0):.3f}"


def render(suite: str, cases: list[Case], seconds: float) -> bytes:
    """The report as UTF-8 bytes: one testsuite named suite holding cases."""
    n = {k: sum(1 for c in cases if c.kind == k) for k in KINDS}
    counts = {"tests": str(len(cases)), "failures": str(n["failure"]),
              "errors": str(n["error"])}
    top = ET.Element("testsuites", {"name": _clean(suite), **counts, "time": _seconds(seconds)})
    ts = ET.SubElement(top, "testsuite", {"name": _clean(suite), **counts,
                                          "skipped": str(n["skipped"]),
                                          "time": _seconds(seconds)})
    for c in cases:
        if c.kind is not None and c.kind not in KINDS:
            raise ValueError(f"unknown test case kind {c.kind!r}")
        tc = ET.SubElement(ts, "testcase", {"name": _clean(c.name),
                                            "classname": _clean(c.classname),
                                            "time": _seconds(c.seconds)})
        if c.kind is not None:
            e = ET.SubElement(tc, c.kind, {"message": _clean(" ".join(c.message.split()))})
            e.text = _clean(c.text or c.message)
        elif c.text:
            ET.SubElement(tc, "system-out").text = _clean(c.text)
    ET.indent(top)
    return ET.tostring(top, encoding="utf-8", xml_declaration=True) + b"\n"


def problem(path) -> str | None:
    """Why a report cannot be written at path (a usage error, said before anything runs),
    naming the fix; None when it can (its missing folders are made as it is written)."""
    path = Path(path)
    if path.is_dir():
        return f"{path} is a folder: give a file name, e.g. {path / 'junit.xml'}"
    if os.path.lexists(path) and path.exists() and not path.is_file():
        return f"{path} is not a regular file (a device or FIFO): give a file name"
    for p in path.parents:
        if p.is_dir():
            if not os.access(p, os.W_OK | os.X_OK):
                return f"cannot write into {p}/ (permission denied): choose another path"
            return None
        if os.path.lexists(p):
            return f"{p} is not a folder: choose another path"
    return None


def write(path, suite: str, cases: list[Case], seconds: float) -> None:
    """Write the report at path, whole or not at all (missing folders are made). Raises
    OSError when it cannot be written; path is then left as it was."""
    data = render(suite, cases, seconds)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o666)
        try:
            view = memoryview(data)
            while view:
                view = view[os.write(fd, view):]
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
