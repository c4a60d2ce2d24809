"""Tests of worldgraph.association.cliques: the compiled clique search against the Python search (the slow
obvious reference) and against brute force; numba stays unimported for small graphs."""

from __future__ import annotations

import contextlib
import itertools
import subprocess
import sys
from collections.abc import Iterator

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import worldgraph.association.cliques as cliques
from worldgraph.association.cliques import CliqueSearch, maximum_cliques

seeds = st.integers(0, 2**32 - 1)


@contextlib.contextmanager
def search_path(path: str) -> Iterator[list[int]]:
    """Every graph through the compiled kernel ("compiled") or the Python search ("python");
    yields a list that counts the compiled searches run."""
    saved_min, saved_search = cliques.COMPILED_MIN_VERTICES, cliques._compiled_search
    calls = [0]

    def counted(*args, **kwargs):
        calls[0] += 1
        return saved_search(*args, **kwargs)

    cliques.COMPILED_MIN_VERTICES = 0 if path == "compiled" else 10**12
    cliques._compiled_search = counted
    try:
        yield calls
    finally:
        cliques.COMPILED_MIN_VERTICES, cliques._compiled_search = saved_min, saved_search


def both(*args, **kwargs) -> tuple[CliqueSearch, CliqueSearch]:
    """``maximum_cliques`` by the Python search and by the compiled kernel (checked to have run)."""
    with search_path("python") as calls:
        slow = maximum_cliques(*args, **kwargs)
    assert calls == [0]
    with search_path("compiled") as calls:
        fast = maximum_cliques(*args, **kwargs)
    assert calls == [1]
    return slow, fast


@st.composite
def graphs(draw, max_parts: int = 7, max_size: int = 14):
    """A k-partite graph mixing every adjacency form: bool matrices, (rows, cols) pairs (with
    repeated pairs, in random order), None (all compatible) and missing keys (none)."""
    k = draw(st.integers(0, max_parts))
    rng = np.random.default_rng(draw(seeds))
    sizes = rng.integers(0, max_size + 1, k).tolist()
    density = rng.uniform(0.1, 0.95)
    adjacency = {}
    for p, q in itertools.combinations(range(k), 2):
        form = rng.uniform()
        if form < 0.1:
            continue  # missing key: no edges
        if form < 0.2:
            adjacency[(p, q)] = None
            continue
        mat = rng.uniform(size=(sizes[p], sizes[q])) < density
        if form < 0.5:
            adjacency[(p, q)] = mat
        else:
            rows, cols = np.nonzero(mat)
            if rows.size:  # a third of the pairs again
                extra = rng.integers(0, rows.size, rows.size // 3)
                rows, cols = np.concatenate((rows, rows[extra])), np.concatenate((cols, cols[extra]))
            perm = rng.permutation(rows.size)
            dtype = (np.int32, np.int64, np.uint16)[rng.integers(3)]
            adjacency[(p, q)] = (rows[perm].astype(dtype), cols[perm].astype(dtype))
    allowed = None
    if draw(st.booleans()):
        keep = draw(st.floats(0.3, 1.0))
        allowed = [rng.uniform(size=s) < keep for s in sizes]
    return sizes, adjacency, allowed


options = st.fixed_dictionaries({  # budgets that trip now and then, not on most graphs
    "min_size": st.integers(0, 4),
    "near_maximum": st.integers(0, 3),
    "max_nodes": st.sampled_from([1_000_000] * 6 + [1, 4, 40, 300]),
    "max_cliques": st.sampled_from([None] * 6 + [1, 3, 10]),
    "stop_at": st.sampled_from([None] * 6 + [1, 2, 3, 5]),
})


@settings(max_examples=300)
@given(graphs(), options, st.sampled_from([cliques.DENSE_BITS, 0]))
def test_compiled_search_equals_python_search(graph, kwargs: dict, dense_bits: int) -> None:
    """The same cliques in the same order, the same maximum, complete flag and node count, with
    budgets that trip (``max_nodes``, ``max_cliques``, ``stop_at``); the Python search with its
    sparse pairs packed into bit rows or kept as CSR rows."""
    sizes, adjacency, allowed = graph
    saved = cliques.DENSE_BITS
    cliques.DENSE_BITS = dense_bits
    try:
        slow, fast = both(sizes, adjacency, allowed=allowed, **kwargs)
    finally:
        cliques.DENSE_BITS = saved
    assert fast == slow
    assert isinstance(fast.nodes, int) and isinstance(fast.complete, bool) and isinstance(fast.maximum, int)
    assert all(isinstance(v, int) for c in fast.cliques for pair in c for v in pair)


def brute_force(sizes, adjacency, allowed) -> list[tuple[tuple[int, int], ...]]:
    """Every maximal clique (at most one vertex per part), by trying every choice of a vertex or
    none in each part."""
    def compatible(u: tuple[int, int], v: tuple[int, int]) -> bool:
        (p, a), (q, b) = sorted((u, v))
        if (p, q) not in adjacency:
            return False
        mat = adjacency[(p, q)]
        if mat is None:
            return True
        if isinstance(mat, tuple):
            return any(int(r) == a and int(c) == b for r, c in zip(*mat, strict=True))
        return bool(mat[a, b])

    vertices = [[(p, a) for a in range(s) if allowed is None or allowed[p][a]] for p, s in enumerate(sizes)]
    found = []
    for choice in itertools.product(*[[None, *vs] for vs in vertices]):
        clique = tuple(v for v in choice if v is not None)
        if not clique or not all(compatible(u, v) for u, v in itertools.combinations(clique, 2)):
            continue
        used = {p for p, _ in clique}
        if any(all(compatible(w, v) for v in clique) for vs in vertices for w in vs if w[0] not in used):
            continue  # not maximal
        found.append(clique)
    return found


@settings(max_examples=150)
@given(graphs(max_parts=5, max_size=4), st.integers(0, 4), st.integers(0, 3))
def test_compiled_search_equals_brute_force(graph, min_size: int, near_maximum: int) -> None:
    sizes, adjacency, allowed = graph
    every = brute_force(sizes, adjacency, allowed)
    best = max((len(c) for c in every), default=0)
    floor = max(min_size, 1)
    with search_path("compiled") as calls:
        res = maximum_cliques(sizes, adjacency, min_size=min_size, near_maximum=near_maximum, allowed=allowed)
    assert calls == [1]
    assert res.complete
    assert res.maximum == (best if best >= floor else 0)
    expected = {c for c in every if len(c) >= max(best - near_maximum, floor)} if best >= floor else set()
    assert set(res.cliques) == expected
    assert len(res.cliques) == len(expected)
    assert [len(c) for c in res.cliques] == sorted((len(c) for c in res.cliques), reverse=True)


def test_compiled_search_by_hand() -> None:
    """A triangle (parts 0, 1, 2) and an edge 2-3, the same graph as sparse pairs: the triangle
    alone is maximum, the edge is maximal; stop_at 3 ends at the triangle found first."""
    one = (np.array([0]), np.array([0]))
    none = (np.zeros(0, int), np.zeros(0, int))
    adjacency = {(0, 1): one, (0, 2): one, (1, 2): one, (2, 3): one, (0, 3): none}
    with search_path("compiled"):
        res = maximum_cliques([1, 1, 1, 1], adjacency, near_maximum=1)
        assert res.maximum == 3 and res.complete
        assert res.cliques == [((0, 0), (1, 0), (2, 0)), ((2, 0), (3, 0))]
        first = maximum_cliques([1, 1, 1, 1], adjacency, stop_at=3)
        assert first.complete and first.cliques == [((0, 0), (1, 0), (2, 0))]
        short = maximum_cliques([1, 1, 1, 1], adjacency, max_nodes=1)
        assert not short.complete and short.nodes == 1 and short.cliques == [] and short.maximum == 0


def planted(rng: np.random.Generator, k: int, n: int, degree: int, clique: int
            ) -> tuple[list[int], dict, list[tuple[int, int]]]:
    """A sparse random k-partite graph (about ``degree`` neighbours per vertex over all other
    parts) with a clique planted on vertex ``v_p`` of each of the first ``clique`` parts."""
    sizes = [n] * k
    per_pair = max(1, n * degree // (k - 1))
    hidden = [(p, int(rng.integers(0, n))) for p in range(clique)]
    adjacency = {}
    for p, q in itertools.combinations(range(k), 2):
        rows, cols = rng.integers(0, n, per_pair), rng.integers(0, n, per_pair)
        if q < clique:
            rows, cols = np.append(rows, hidden[p][1]), np.append(cols, hidden[q][1])
        adjacency[(p, q)] = (rows, cols)
    return sizes, adjacency, hidden


def test_compiled_search_finds_a_planted_clique_in_large_sparse_parts() -> None:
    """Parts of 3,000 vertices (the candidate lists are binary-searched per neighbour there):
    the planted 6-clique is the maximum, both searches agree."""
    rng = np.random.default_rng(7)
    sizes, adjacency, hidden = planted(rng, k=6, n=3000, degree=3, clique=6)
    slow, fast = both(sizes, adjacency, min_size=4)
    assert fast == slow
    assert fast.complete and fast.maximum == 6
    assert fast.cliques == [tuple(hidden)]


def test_intersect_equals_numpy() -> None:
    """The compiled sorted-list intersection (both of its branches: merge, and a binary search
    per neighbour) against np.intersect1d."""
    assert cliques._kernels() is not None
    rng = np.random.default_rng(3)
    for n_cand, n_nbr in [(0, 5), (5, 0), (40, 30), (3000, 4), (9, 1), (1, 1), (500, 500)]:
        cand = np.unique(rng.integers(0, 4000, n_cand)).astype(np.int64)
        shared = rng.choice(cand, min(cand.size, n_nbr // 2), replace=False)
        nbr = np.unique(np.concatenate((shared, rng.integers(0, 4000, n_nbr - shared.size)))).astype(np.int64)
        pool = np.concatenate((cand, np.full(cand.size + 3, -7, np.int64)))
        m = cliques._intersect(pool, 0, cand.size, nbr, 0, nbr.size, cand.size)
        assert np.array_equal(pool[cand.size:cand.size + m], np.intersect1d(cand, nbr))


def test_small_graphs_do_not_import_numba() -> None:
    """A kitchen-sized search (below COMPILED_MIN_VERTICES) leaves numba unimported."""
    code = ("import sys, numpy as np\n"
            "from worldgraph.association.cliques import COMPILED_MIN_VERTICES, maximum_cliques\n"
            "n = COMPILED_MIN_VERTICES // 4 - 1\n"
            "same = np.eye(n, dtype=bool)\n"
            "res = maximum_cliques([n] * 4, {(0, 1): None, (0, 2): same, (1, 2): same})\n"
            "assert res.maximum == 3 and len(res.cliques) == n, res\n"
            "print('numba' in sys.modules)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_rows_equal_numpy() -> None:
    """The compiled CSR rows (a counting sort, each row sorted, repeats dropped) against a
    lexsort and np.unique per row: short rows (insertion sort), long rows, empty rows."""
    kernels = cliques._kernels()
    assert kernels is not None
    rng = np.random.default_rng(5)
    for n_rows, n_pairs, width in [(0, 0, 1), (5, 0, 3), (10, 40, 6), (7, 600, 50), (300, 2000, 20000)]:
        src = rng.integers(0, max(n_rows, 1), n_pairs).astype(np.int64)
        dst = rng.integers(0, width, n_pairs).astype(np.int64)
        indptr, cols = kernels["rows"](src, dst, n_rows)
        assert indptr.shape == (n_rows + 1,) and indptr[0] == 0 and indptr[-1] == cols.size
        for r in range(n_rows):
            assert np.array_equal(cols[indptr[r]:indptr[r + 1]], np.unique(dst[src == r]))


def test_without_numba_the_python_search_runs() -> None:
    """With numba unusable (as when not installed) every graph goes to the Python search."""
    saved = dict(cliques._COMPILED)
    cliques._COMPILED["search"] = False
    try:
        assert cliques._kernels() is None
        with search_path("compiled") as calls:
            res = maximum_cliques([2, 2], {(0, 1): np.array([[True, False], [False, True]])})
        assert calls == [0]
        assert res.cliques == [((0, 0), (1, 0)), ((0, 1), (1, 1))] and res.maximum == 2 and res.complete
    finally:
        cliques._COMPILED.update(saved)
