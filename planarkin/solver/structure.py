"""Structure of the constraint Jacobian: matching and block-triangular form (Dulmage-Mendelsohn).

Most mechanisms decompose: a driven crank is fixed by its driver and pin alone, then the dyad it
carries, then the next dyad, and so on. Permuting Phi_q to block lower-triangular form lets the
solver handle a sequence of small square blocks instead of one large system: for the N-four-bar
chain the work per time step grows linearly with N, and every block is small enough to be
factored for a whole time chunk at once.

Pure Python on purpose: importing scipy.sparse.csgraph costs more start-up than the whole
analysis of a typical model (benchmarks/README.md, "Figures moved from the code's comments");
these graphs have at most a few thousand nodes of degree <= 9.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def maximum_matching(rows: list[list[int]], ncols: int):
    """Maximum bipartite matching of equations to unknowns (Hopcroft-Karp-style augmenting paths).

    rows: for each equation the unknowns it depends on. Returns (col_of_row, row_of_col) with -1
    for unmatched entries.
    """
    m = len(rows)
    col_of_row = [-1] * m
    row_of_col = [-1] * ncols
    # greedy start: most equations get their match here
    for r, cols in enumerate(rows):
        for c in cols:
            if row_of_col[c] < 0:
                row_of_col[c] = r
                col_of_row[r] = c
                break
    for r0 in range(m):
        if col_of_row[r0] >= 0:
            continue
        # iterative DFS for an augmenting path from r0
        seen = set()
        stack = [(r0, iter(rows[r0]))]
        parent: dict[int, tuple[int, int]] = {}
        found = -1
        while stack and found < 0:
            r, it = stack[-1]
            advanced = False
            for c in it:
                if c in seen:
                    continue
                seen.add(c)
                parent[c] = (r, -1)
                r2 = row_of_col[c]
                if r2 < 0:
                    found = c
                    break
                stack.append((r2, iter(rows[r2])))
                advanced = True
                break
            if found >= 0:
                break
            if not advanced:
                stack.pop()
        if found < 0:
            continue
        # flip the path
        c = found
        while True:
            r = parent[c][0]
            prev = col_of_row[r]
            col_of_row[r] = c
            row_of_col[c] = r
            if r == r0:
                break
            c = prev
    return col_of_row, row_of_col


def strongly_connected(nnodes: int, succ: list[list[int]]) -> list[list[int]]:
    """Tarjan's algorithm, iterative. Returns components with every component listed after all
    components it has edges to (dependencies first when edges point to dependencies)."""
    index = [-1] * nnodes
    low = [0] * nnodes
    onstack = [False] * nnodes
    stack: list[int] = []
    out: list[list[int]] = []
    counter = 0
    for root in range(nnodes):
        if index[root] >= 0:
            continue
        work = [(root, 0)]
        while work:
            v, i = work.pop()
            if i == 0:
                index[v] = low[v] = counter
                counter += 1
                stack.append(v)
                onstack[v] = True
            recurse = False
            edges = succ[v]
            while i < len(edges):
                w = edges[i]
                i += 1
                if index[w] < 0:
                    work.append((v, i))
                    work.append((w, 0))
                    recurse = True
                    break
                if onstack[w]:
                    low[v] = min(low[v], index[w])
            if recurse:
                continue
            if low[v] == index[v]:
                comp = []
                while True:
                    w = stack.pop()
                    onstack[w] = False
                    comp.append(w)
                    if w == v:
                        break
                out.append(sorted(comp))
            if work:
                u = work[-1][0]
                low[u] = min(low[u], low[v])
    return out


@dataclass(frozen=True)
class Blocks:
    """Block lower-triangular order of a square system.

    rows[b], cols[b]: equation rows and unknown columns of block b (equal lengths); solving the
    blocks in order, block b depends only on columns of blocks <= b.
    """

    rows: tuple
    cols: tuple

    def __len__(self) -> int:
        return len(self.rows)


class StructurallySingular(Exception):
    """No perfect matching: rows_left are equations and cols_left unknowns left unmatched."""

    def __init__(self, rows_left, cols_left):
        self.rows_left = rows_left
        self.cols_left = cols_left
        super().__init__(f"unmatched rows {rows_left}, columns {cols_left}")


def block_triangular(rows: list[list[int]], ncols: int, merge_to: int = 1) -> Blocks:
    """Dulmage-Mendelsohn fine decomposition of a square, structurally nonsingular system.

    rows: for each equation the unknowns it depends on (len(rows) == ncols). Consecutive blocks
    are merged while the merged block has at most ``merge_to`` unknowns (fewer, larger blocks
    cost fewer Python-level calls; merging never breaks the triangular order).
    """
    col_of_row, row_of_col = maximum_matching(rows, ncols)
    rows_left = [r for r, c in enumerate(col_of_row) if c < 0]
    cols_left = [c for c, r in enumerate(row_of_col) if r < 0]
    if rows_left or cols_left:
        raise StructurallySingular(rows_left, cols_left)
    # column c's equation is row_of_col[c]; it depends on the columns of that row
    succ = [[d for d in rows[row_of_col[c]] if d != c] for c in range(ncols)]
    comps = strongly_connected(ncols, succ)
    out_rows, out_cols = [], []
    cur: list[int] = []
    for comp in comps:
        if cur and len(cur) + len(comp) > merge_to:
            out_cols.append(np.array(sorted(cur), dtype=np.intp))
            cur = []
        cur.extend(comp)
    if cur:
        out_cols.append(np.array(sorted(cur), dtype=np.intp))
    for cols in out_cols:
        out_rows.append(np.array(sorted(row_of_col[c] for c in cols), dtype=np.intp))
    return Blocks(tuple(out_rows), tuple(out_cols))
