"""Matching and block-triangular form against scipy's graph routines on random sparse systems."""

import numpy as np
import pytest

from planarkin.solver.structure import (StructurallySingular, block_triangular, maximum_matching,
                                 strongly_connected)


def random_pattern(rng, n, density):
    A = rng.random((n, n)) < density
    perm = rng.permutation(n)
    A[np.arange(n), perm] = True        # structurally nonsingular
    return [np.nonzero(r)[0].tolist() for r in A], A


@pytest.mark.parametrize("seed", range(20))
def test_matching_size_matches_scipy(seed):
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import maximum_bipartite_matching
    rng = np.random.default_rng(seed)
    n = 40
    A = rng.random((n, n)) < 0.06
    rows = [np.nonzero(r)[0].tolist() for r in A]
    col_of_row, row_of_col = maximum_matching(rows, n)
    ref = maximum_bipartite_matching(csr_matrix(A.astype(float)), perm_type="column")
    assert sum(c >= 0 for c in col_of_row) == int((ref >= 0).sum())
    for r, c in enumerate(col_of_row):
        if c >= 0:
            assert A[r, c] and row_of_col[c] == r


@pytest.mark.parametrize("seed", range(20))
def test_block_triangular_is_triangular_and_fine(seed):
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components
    rng = np.random.default_rng(100 + seed)
    n = 30
    rows, A = random_pattern(rng, n, 0.05)
    B = block_triangular(rows, n)
    assert sorted(np.concatenate(B.cols).tolist()) == list(range(n))
    assert sorted(np.concatenate(B.rows).tolist()) == list(range(n))
    done = set()
    for r, c in zip(B.rows, B.cols):
        done |= set(c.tolist())
        for row in r:
            assert set(rows[row]) <= done, "a block uses a column of a later block"
    # number of fine blocks = number of strong components of the matched digraph
    from planarkin.solver.structure import maximum_matching as mm
    _, row_of_col = mm(rows, n)
    G = np.zeros((n, n))
    for c in range(n):
        for d in rows[row_of_col[c]]:
            G[c, d] = 1
    ncomp, _ = connected_components(csr_matrix(G), directed=True, connection="strong")
    assert len(B) == ncomp


def test_merge_keeps_order_and_size():
    rows = [[0], [0, 1], [1, 2], [2, 3], [3, 4]]
    B = block_triangular(rows, 5, merge_to=2)
    assert [c.tolist() for c in B.cols] == [[0, 1], [2, 3], [4]]


def test_structurally_singular_names_rows_and_columns():
    with pytest.raises(StructurallySingular) as e:
        block_triangular([[0], [0], [1, 2]], 3)
    assert len(e.value.rows_left) == 1 and len(e.value.cols_left) == 1


def test_tarjan_deep_chain_is_iterative():
    n = 20000
    succ = [[i - 1] if i else [] for i in range(n)]
    comps = strongly_connected(n, succ)
    assert comps[0] == [0] and len(comps) == n
