"""The generated kernels' names per loop (planarkin.solver.compiled.gen.per_loop_names): a name
a top-level loop computes afresh for each point gets a name of its own in that loop (numba's SSA
pass then has fewer variables assigned more than once to rewrite); a name whose value may flow
in or out of a loop keeps its name there. Checked on a small kernel as Python, without numba:
the renamed text computes what the original does, bit for bit."""

import re

import numpy as np
import pytest

from planarkin.solver.compiled.gen import per_loop_names

KERNEL = """\
def grid(N, Q, out):
    acc = 0.0
    for i in range(N):
        q0 = Q[i, 0]
        q0 -= 1.0
        out[i, 0] = q0
    for i in range(N):
        q0 = Q[i, 1]
        t = q0 * 2.0
        out[i, 1] = t  # a comment stays
    for i in range(N):
        if Q[i, 0] > 0:
            t = 1.0
        out[i, 2] = t
    for i in range(N):
        acc = acc + Q[i, 0]
        out[i, 3] = acc
    for it in range(2):
        for i in range(N):
            w = Q[i, 0] + it
        out[0, 4] = w
    for i in range(N):
        w = Q[i, 1]
        out[i, 5] = w
"""


def _run(text, Q):
    space: dict = {}
    exec(compile(text, "<kernel>", "exec"), space)
    out = np.zeros((len(Q), 6))
    space["grid"](len(Q), Q, out)
    return out


def test_names_computed_afresh_per_loop_are_renamed_and_the_others_kept():
    text = "\n".join(per_loop_names(KERNEL.splitlines())) + "\n"
    lines = text.splitlines()
    # every byte but the renamed names is the original's
    assert re.sub(r"__\d+", "", text) == KERNEL
    # loaded again in each of two loops: a name of its own in each
    assert lines[3] == "        q0__1 = Q[i, 0]" and lines[4] == "        q0__1 -= 1.0"
    assert lines[7] == "        q0__2 = Q[i, 1]"
    # t: the third loop may keep the second loop's t (its own assignment is conditional)
    assert "t = q0__2 * 2.0" in lines[8] and lines[12] == "            t = 1.0"
    # acc: carried from before the loop; it: a loop variable
    assert lines[15] == "        acc = acc + Q[i, 0]" and "__" not in lines[17]
    # w read after the inner loop that assigns it (no point: the value from before): kept;
    # assigned afresh in the last loop: renamed there
    assert lines[19] == "            w = Q[i, 0] + it" and lines[20] == "        out[0, 4] = w"
    assert lines[22] == "        w__6 = Q[i, 1]"
    Q = np.random.default_rng(3).normal(size=(7, 2))
    Q[2, 0] = -1.0       # the third loop's condition false at a point: t flows from the second
    assert np.array_equal(_run(text, Q), _run(KERNEL, Q))


# shapes the rule cannot read by lines and columns (the generators write none of them): left as
# they are; each, renamed, would change what the kernel computes
SECOND = """\
    for i in range(N):
        x = 2.0
        out[i] += x
"""
UNTOUCHED = {
    "a loop's else": """\
def grid(N, M, out):
    x = -1.0
    for i in range(N):
        for j in range(M):
            x = float(j)
        else:
            out[i] = x
""" + SECOND,
    "a statement over two lines": """\
def grid(N, M, out):
    x = 1.0
    for i in range(N):
        x = (2.0 +
             x)
        out[i] = x
""" + SECOND,
    "a line continued": """\
def grid(N, M, out):
    x = 1.0
    for i in range(N):
        x = \\
            x + 2.0
        out[i] = x
""" + SECOND,
    "text that is not ASCII": """\
def grid(N, M, out):
    for i in range(N):
        x = 1.0
        out[i] = len('\u00e9') + x
""" + SECOND,
}


@pytest.mark.parametrize("name", UNTOUCHED)
def test_shapes_the_rule_cannot_read_are_left_as_they_are(name):
    text = UNTOUCHED[name]
    got = "\n".join(per_loop_names(text.splitlines())) + "\n"
    if name == "text that is not ASCII":
        assert got == text
    else:      # the first loop as it was (the second may take names of its own)
        assert got.split("    for i in range(N):")[1] == text.split("    for i in range(N):")[1]
