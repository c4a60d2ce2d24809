"""Exact maximum (and near-maximum) cliques of a k-partite graph.

Two implementations of one branch and bound, with identical answers (cliques in the same order,
maximum, complete flag, node count):

* ``_python_search``: candidate sets as Python-int bitsets; the slow obvious reference.
* ``_search_kernel``: compiled by numba (a main dependency), iterative with an explicit
  stack; the candidates of each part are sorted index lists, intersected with the visited
  vertex's CSR neighbour list (a merge, or a binary search per neighbour for the big first
  lists), so memory stays linear in the vertices and edges: no dense ``n_p x n_q`` matrix.
  Every adjacency form (bool matrix, ``(rows, cols)``, None, missing key) is turned into one
  CSR layout per ordered part pair first.

:func:`maximum_cliques` runs the compiled search on graphs of at least
:data:`COMPILED_MIN_VERTICES` usable vertices when numba can be imported, else the Python one.
``benchmarks/cliques.py`` (one run, 2-core machine shared with other jobs): on 9-partite graphs
with a planted clique, the compiled search is 1.5-6x faster at 200 vertices per part, 2.5-22x
at 2,000 and 6-12x at 20,000 (at degree 50, building the CSR rows of every part pair is most of its
time); on small dense graphs 1.1-1.7x below 30 vertices, 2-7x from 36 on.  The first compiled
call of a process costs about 0.45 s (numba import 0.2 s, loading the cached kernels 0.25 s; the
first compile, once per installation, 6 s).  That load is paid only where it pays back: the
graphs that association searches (``benchmarks/scaling.py`` views, Python search) have
below 500 usable vertices in the kitchen (40 views: 78 graphs below 128, 2 of 128 - 500 at 2 ms
each, none above) and the 20k floor, while in the 100k building 8 of 41 graphs have more than
2,000 (92 ms median, 239 ms at most, 93 % of its search time) and in the campus the searches
with near-maximum cliques have 24k - 148k (0.2 - 0.7 s each in Python, 14 - 24 ms compiled,
the same answers).  Hence 500.
"""

from __future__ import annotations

import importlib.util
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._checks import integer
from ..errors import (
    WorldGraphError,
)


@dataclass(frozen=True)
class CliqueSearch:
    """Result of :func:`maximum_cliques`.

    Attributes
    ----------
    cliques : list of tuple of (part, vertex)
        Maximal cliques of size ``>= max(maximum - near_maximum, min_size)``, as (part index,
        vertex index within the part) sorted by part; largest first.
    maximum : int
        Size of the maximum clique (0 when none reaches ``min_size``).
    complete : bool
        False when the node budget ran out (the answer may then miss cliques).
    nodes : int
        Branch-and-bound nodes visited.
    """

    cliques: list[tuple[tuple[int, int], ...]]
    maximum: int
    complete: bool
    nodes: int


# ----------------------------------------------------------------------------------------------
# exact maximum cliques of a k-partite graph (bitsets)
# ----------------------------------------------------------------------------------------------
def _bits(indices: NDArray[np.intp] | Sequence[int]) -> int:
    out = 0
    for b in indices:
        out |= 1 << int(b)
    return out


#: Sparse adjacency between two parts of at most this many vertex pairs is packed into bit rows
#: up front (8 MiB at most); larger ones keep CSR rows, turned into bitsets per visited vertex.
DENSE_BITS = 1 << 26

_Entry = None | NDArray[np.bool_] | tuple[NDArray[np.integer], NDArray[np.integer]]


def _check_entry(key: tuple[int, int], mat: object, sizes: list[int]) -> _Entry:
    """``adjacency[key]`` checked: None (all compatible), a ``(sizes[p], sizes[q])`` bool matrix,
    or ``(rows, cols)`` equal-length 1-D integer arrays inside the parts."""
    if mat is None:
        return None
    p, q = key
    if isinstance(mat, tuple):
        if len(mat) != 2:
            raise WorldGraphError(f"adjacency[{key}] must be a bool matrix or a pair (rows, cols) of index "
                                  f"arrays, got a tuple of length {len(mat)}")
        rows, cols = (np.asarray(x) for x in mat)
        for name, arr, size in (("rows", rows, sizes[p]), ("cols", cols, sizes[q])):
            if arr.ndim != 1 or (arr.size and arr.dtype.kind not in "iu"):
                raise WorldGraphError(f"adjacency[{key}] {name} must be a 1-D integer array, got dtype "
                                      f"{arr.dtype} and shape {arr.shape}")
            if arr.size and (arr.min() < 0 or arr.max() >= size):
                bad = int(np.flatnonzero((arr < 0) | (arr >= size))[0])
                raise WorldGraphError(f"adjacency[{key}] {name}[{bad}] = {int(arr[bad])} is outside "
                                      f"[0, {size})")
        if rows.shape != cols.shape:
            raise WorldGraphError(f"adjacency[{key}] rows and cols must have equal length, got {rows.shape} "
                                  f"and {cols.shape}")
        return rows, cols
    mat = np.asarray(mat)
    if mat.dtype != np.bool_:
        raise WorldGraphError(f"adjacency[{key}] must be a bool array, got dtype {mat.dtype}")
    if mat.shape != (sizes[p], sizes[q]):
        raise WorldGraphError(f"adjacency[{key}] must have shape ({sizes[p]}, {sizes[q]}), "
                              f"got shape {mat.shape}")
    return mat


def _csr(key: tuple[int, int], pairs: tuple[NDArray[np.integer], NDArray[np.integer]], sizes: list[int],
         forward: bool) -> tuple[NDArray[np.intp], NDArray[np.intp], int] | NDArray[np.uint8] | int:
    """Checked sparse adjacency ``(rows, cols)`` of parts ``key = (p, q)`` as rows of p's vertices
    (``forward``) or of q's: packed bit rows when small (:data:`DENSE_BITS`), else CSR
    ``(indptr, cols, size of the other part)``; 0 without edges."""
    p, q = key
    rows, cols = pairs
    if rows.size == 0:
        return 0
    src, dst, n_src, n_dst = (rows, cols, sizes[p], sizes[q]) if forward else (cols, rows, sizes[q], sizes[p])
    if n_src * n_dst <= DENSE_BITS:  # small: packed bit rows, cheaper per visited vertex
        mat = np.zeros((n_src, n_dst), dtype=bool)
        mat[src, dst] = True
        return np.packbits(mat, axis=1, bitorder="little")
    order = np.argsort(src, kind="stable")
    indptr = np.searchsorted(src[order], np.arange(n_src + 1)).astype(np.intp)
    return indptr, dst[order].astype(np.intp), n_dst


# ----------------------------------------------------------------------------------------------
# the same search, compiled (numba), on sorted candidate lists and CSR neighbour lists
# ----------------------------------------------------------------------------------------------
#: Graphs with at least this many usable vertices (all parts, after ``allowed``) are searched by
#: the compiled kernel when numba is installed; smaller ones by the Python search, which then
#: never imports numba.  Chosen by ``benchmarks/cliques.py`` and the association benchmark's
#: graphs; see the module notes.
COMPILED_MIN_VERTICES = 500

_NONE, _ALL, _ROWS = 0, 1, 2  # kinds of an ordered part pair: no edge, every pair, CSR rows

# The compiled kernels, built on first use by _kernels(); False once numba was found unusable.
_COMPILED: dict[str, Callable[..., Any] | None | bool] = {"search": None, "rows": None}


def _intersect(pool: Any, c_at: int, c_len: int, cols: Any, r0: int, r1: int, out: int) -> int:
    """Write the sorted intersection of the candidates ``pool[c_at:c_at + c_len]`` and the
    neighbours ``cols[r0:r1]`` (both sorted, unique) at ``pool[out:]``; returns its length
    (compiled with the kernel).  A merge, or a binary search per neighbour when the candidates
    are many more than the neighbours (the first choices in a part of 20k vertices)."""
    m = 0
    if c_len == 0 or r1 == r0:
        return 0
    end = c_at + c_len
    if c_len > 8 * (r1 - r0):
        lo = c_at
        for j in range(r0, r1):
            v = cols[j]
            hi = end
            while lo < hi:
                mid = (lo + hi) >> 1
                if pool[mid] < v:
                    lo = mid + 1
                else:
                    hi = mid
            if lo == end:
                break
            if pool[lo] == v:
                pool[out + m] = v
                m += 1
                lo += 1
        return m
    i, j = c_at, r0
    while i < end and j < r1:
        x, y = pool[i], cols[j]
        if x == y:
            pool[out + m] = x
            m += 1
            i += 1
            j += 1
        elif x < y:
            i += 1
        else:
            j += 1
    return m


def _search_kernel(kind: Any, row_at: Any, indptr: Any, cols: Any, start_at: Any, start_len: Any,
                   pool0: Any, floor: int, near_maximum: int, max_nodes: int, max_cliques: int,
                   stop_at: int) -> tuple[Any, Any, int, int, bool]:
    """The branch and bound of ``_python_search``, iterative (compiled by numba; plain Python
    otherwise).  Parts are numbered by depth.  The candidates of part e at depth d are
    ``pool[at[d, e]:at[d, e] + size[d, e]]``, sorted; choosing vertex a at depth d writes the
    candidates of depth d + 1 (each intersected with a's CSR neighbour list, or kept for an
    all-compatible pair) above ``top[d]``, so backtracking frees them.  ``max_cliques`` and
    ``stop_at`` are 0 for none.  Returns the sizes of the recorded cliques and their vertices
    by depth (-1: part skipped), in discovery order, the best size, the nodes and the complete
    flag."""
    k = kind.shape[0]
    pool = np.empty(max(2 * pool0.size, 64), np.int64)
    pool[:pool0.size] = pool0
    at = np.zeros((k + 1, k), np.int64)
    size = np.zeros((k + 1, k), np.int64)
    at[0, :] = start_at
    size[0, :] = start_len
    top = np.zeros(k + 1, np.int64)
    top[0] = pool0.size
    cursor = np.zeros(k + 1, np.int64)
    skipping = np.zeros(k + 1, np.bool_)  # frame d runs its skip branch
    skipped = np.zeros(k + 1, np.bool_)  # part d skipped with candidates left (maximality test)
    chosen = np.full(k + 1, -1, np.int64)
    n_chosen = 0
    found_size = np.empty(64, np.int64)
    found = np.empty((64, k), np.int64)
    n_found = 0
    best, nodes, complete = 0, 0, True
    d, entering = 0, True
    while d >= 0:
        if entering:  # rec(d) begins
            entering = False
            if nodes >= max_nodes:
                complete = False
                break
            nodes += 1
            possible = 0
            for e in range(d, k):
                if size[d, e] > 0:
                    possible += 1
            if n_chosen + possible < max(best - near_maximum, floor):
                d -= 1
                continue
            if d == k:
                maximal = True
                for s in range(k):
                    if skipped[s] and size[k, s] > 0:
                        maximal = False  # a skipped part still has a compatible vertex
                        break
                if maximal:
                    best = max(best, n_chosen)
                    if n_found == found_size.size:
                        grown_size = np.empty(2 * n_found, np.int64)
                        grown_size[:n_found] = found_size
                        grown = np.empty((2 * n_found, k), np.int64)
                        grown[:n_found] = found
                        found_size, found = grown_size, grown
                    found_size[n_found] = n_chosen
                    found[n_found, :] = chosen[:k]
                    n_found += 1
                    if stop_at > 0 and n_chosen >= stop_at:
                        break
                    if max_cliques > 0 and n_found >= max_cliques:
                        complete = False
                        break
                d -= 1
                continue
            cursor[d] = 0
            skipping[d] = False
        # frame d (< k) resumes: at its start or after a child returned
        if skipping[d]:
            skipped[d] = False
            d -= 1
            continue
        if chosen[d] >= 0:
            chosen[d] = -1
            n_chosen -= 1
        if cursor[d] < size[d, d]:
            a = pool[at[d, d] + cursor[d]]
            cursor[d] += 1
            need = top[d]
            for e in range(k):
                if kind[d, e] == _ROWS:
                    r = row_at[d, e] + a
                    need += min(size[d, e], indptr[r + 1] - indptr[r])
            if need > pool.size:
                grown_pool = np.empty(2 * need, np.int64)
                grown_pool[:top[d]] = pool[:top[d]]
                pool = grown_pool
            t = top[d]
            for e in range(k):
                n = size[d, e]
                if e == d or n == 0 or kind[d, e] == _NONE:
                    at[d + 1, e] = t
                    size[d + 1, e] = 0
                elif kind[d, e] == _ALL:
                    at[d + 1, e] = at[d, e]
                    size[d + 1, e] = n
                else:
                    r = row_at[d, e] + a
                    m = _intersect(pool, at[d, e], n, cols, indptr[r], indptr[r + 1], t)
                    at[d + 1, e] = t
                    size[d + 1, e] = m
                    t += m
            top[d + 1] = t
            chosen[d] = a
            n_chosen += 1
            d += 1
            entering = True
            continue
        skipping[d] = True  # then skipping the part
        skipped[d] = size[d, d] > 0
        at[d + 1, :] = at[d, :]
        size[d + 1, :] = size[d, :]
        top[d + 1] = top[d]
        d += 1
        entering = True
    return found_size[:n_found].copy(), found[:n_found].copy(), best, nodes, complete


def _rows_kernel(src: Any, dst: Any, n_rows: int) -> tuple[Any, Any]:
    """CSR rows of the pairs ``(src, dst)`` (``src < n_rows``): ``indptr`` (n_rows + 1,) and the
    neighbours, sorted and unique within each row (compiled by numba; plain Python otherwise).
    A counting sort by row, then each row sorted on its own (rows are short) and its repeats
    dropped: linear in the pairs, where one sort of all of them was the most of a search."""
    indptr = np.zeros(n_rows + 1, np.int64)
    for i in range(src.size):
        indptr[src[i] + 1] += 1
    for r in range(n_rows):
        indptr[r + 1] += indptr[r]
    fill = indptr[:-1].copy()
    cols = np.empty(src.size, np.int64)
    for i in range(src.size):
        cols[fill[src[i]]] = dst[i]
        fill[src[i]] += 1
    out, start = 0, 0
    for r in range(n_rows):
        end = indptr[r + 1]
        if end - start > 16:
            cols[start:end].sort()
        else:  # insertion sort
            for j in range(start + 1, end):
                v, i = cols[j], j
                while i > start and cols[i - 1] > v:
                    cols[i] = cols[i - 1]
                    i -= 1
                cols[i] = v
        indptr[r] = out
        for j in range(start, end):
            if j == start or cols[j] != cols[j - 1]:
                cols[out] = cols[j]
                out += 1
        start = end
    indptr[n_rows] = out
    return indptr, cols[:out].copy()


def _kernels() -> dict[str, Callable[..., Any]] | None:
    """The compiled search and row builder, compiled (or loaded from numba's cache) on first use;
    None without a working numba (``pip install numba``): the Python search is
    used then."""
    search, rows = _COMPILED["search"], _COMPILED["rows"]
    if search is False:
        return None
    if search is not None and rows is not None:
        return {"search": search, "rows": rows}  # type: ignore[dict-item]
    if importlib.util.find_spec("numba") is None:
        _COMPILED["search"] = False
        return None
    try:
        import numba
    except ImportError:  # found but broken (e.g. an llvmlite that does not match)
        _COMPILED["search"] = False
        return None
    global _intersect
    jit = numba.njit(cache=True, nogil=True)
    if not hasattr(_intersect, "py_func"):  # the kernel calls it by its global name: compiled first
        _intersect = jit(_intersect)
    _COMPILED["search"] = search = jit(_search_kernel)
    _COMPILED["rows"] = rows = jit(_rows_kernel)
    return {"search": search, "rows": rows}


def _compiled_search(kernels: dict[str, Callable[..., Any]], sizes: list[int],
                     checked: dict[tuple[int, int], _Entry], order: list[int], usable: list[NDArray[np.intp]],
                     limits: tuple[int, int, int, int | None, int | None]
                     ) -> tuple[int, list[tuple[int, tuple[tuple[int, int], ...]]], int, bool]:
    """``_python_search`` by the compiled kernel: every adjacency form turned into one CSR
    layout per ordered part pair (by depth; "all" and "none" pairs hold no rows)."""
    floor, near_maximum, max_nodes, max_cliques, stop_at = limits
    k = len(sizes)
    depth = {p: d for d, p in enumerate(order)}
    kind = np.zeros((k, k), np.int64)
    row_at = np.zeros((k, k), np.int64)  # rows of the vertices of part d against part e start here
    sources: list[NDArray[np.int64]] = []
    targets: list[NDArray[np.int64]] = []
    n_rows = 0
    for (p, q), mat in checked.items():
        d, e = depth[p], depth[q]
        if mat is None:
            kind[d, e] = kind[e, d] = _ALL
            continue
        pairs = mat if isinstance(mat, tuple) else np.nonzero(mat)
        rows, cols = (np.asarray(x, dtype=np.int64) for x in pairs)
        if rows.size == 0:
            continue
        for src_d, dst_d, src, dst, n_src in ((d, e, rows, cols, sizes[p]), (e, d, cols, rows, sizes[q])):
            kind[src_d, dst_d] = _ROWS
            row_at[src_d, dst_d] = n_rows
            sources.append(src + n_rows)
            targets.append(dst)
            n_rows += n_src
    empty = np.zeros(0, np.int64)
    indptr_all, cols_all = kernels["rows"](np.concatenate(sources) if sources else empty,
                                           np.concatenate(targets) if targets else empty, n_rows)
    start_len = np.array([len(usable[p]) for p in order], np.int64)
    start_at = np.zeros(k, np.int64)
    np.cumsum(start_len[:-1], out=start_at[1:])
    pool0 = np.concatenate([usable[p] for p in order]).astype(np.int64) if k else empty
    found_size, found, best, nodes, complete = kernels["search"](
        kind, row_at, indptr_all, cols_all, start_at, start_len, pool0, floor, near_maximum, max_nodes,
        0 if max_cliques is None else max_cliques, 0 if stop_at is None else stop_at)
    by_part = np.full_like(found, -1)
    by_part[:, order] = found
    recorded = [(int(s), tuple((p, int(v)) for p, v in enumerate(row) if v >= 0))
                for s, row in zip(found_size.tolist(), by_part.tolist(), strict=True)]
    return int(best), recorded, int(nodes), bool(complete)


def maximum_cliques(
    sizes: Sequence[int],
    adjacency: Mapping[tuple[int, int],
                       NDArray[np.bool_] | tuple[NDArray[np.integer], NDArray[np.integer]] | None],
    min_size: int = 1,
    near_maximum: int = 0,
    max_nodes: int = 1_000_000,
    allowed: Sequence[NDArray[np.bool_]] | None = None,
    max_cliques: int | None = None,
    stop_at: int | None = None,
) -> CliqueSearch:
    """Exact maximum (and near-maximum maximal) cliques of a k-partite graph.

    Parts are the percepts; part p has ``sizes[p]`` vertices.  No edge joins two vertices of
    one part, so a clique holds at most one vertex per part.  The branch and bound visits the
    parts in order of increasing candidate count; at each part it tries every vertex
    compatible with the chosen ones (in increasing index), then skipping the part, and prunes
    when the chosen count plus the number of later parts with a compatible vertex cannot reach
    the threshold ``max(best - near_maximum, min_size)``.  Graphs of at least
    :data:`COMPILED_MIN_VERTICES` usable vertices are searched by a numba kernel when numba is
    installed (``pip install numba``; sorted candidate lists and CSR
    neighbour lists), smaller ones with Python-int bitsets: the same search, the same answer.

    Parameters
    ----------
    sizes : (k,) int
    adjacency : dict (p, q) -> (sizes[p], sizes[q]) bool, (rows, cols) int arrays, or None
        For ``p < q``: a boolean matrix, or the compatible pairs as two equal-length integer
        arrays (vertex ``rows[i]`` of part p with vertex ``cols[i]`` of part q; sparse, memory
        linear in the edges); ``None`` means every pair is compatible; a missing key means none
        is.
    min_size : int
    near_maximum : int
        Also return maximal cliques down to ``maximum - near_maximum``.
    max_nodes : int
    allowed : sequence of (sizes[p],) bool, optional
        Vertices that may be used (default all).
    max_cliques : int, optional
        Stop (``complete=False``) once this many cliques are recorded.
    stop_at : int, optional
        Stop (``complete=True``) at the first clique of at least this size, for a caller that
        knows no larger clique exists.

    Returns
    -------
    CliqueSearch
    """
    if sizes is None or isinstance(sizes, str | bytes):
        raise WorldGraphError(f"sizes must be a sequence of non-negative integers, got {sizes!r}")
    sizes = [integer(f"sizes[{i}]", s, minimum=0, maximum=10**7) for i, s in enumerate(sizes)]
    if not isinstance(adjacency, dict):
        raise WorldGraphError(f"adjacency must be a dict (p, q) -> bool array or None, got "
                              f"{type(adjacency).__name__}")
    for key in adjacency:
        if not (isinstance(key, tuple) and len(key) == 2 and all(isinstance(v, int | np.integer)
                                                                  and not isinstance(v, bool) for v in key)
                and 0 <= key[0] < key[1] < len(sizes)):
            raise WorldGraphError(f"adjacency keys must be (p, q) with 0 <= p < q < {len(sizes)}, "
                                  f"got {key!r}")
    min_size = integer("min_size", min_size, minimum=0)
    near_maximum = integer("near_maximum", near_maximum, minimum=0)
    max_nodes = integer("max_nodes", max_nodes, minimum=1)
    if max_cliques is not None:
        max_cliques = integer("max_cliques", max_cliques, minimum=1)
    if stop_at is not None:
        stop_at = integer("stop_at", stop_at, minimum=1)
    if allowed is not None:
        allowed = [np.asarray(a) for a in allowed]
        if len(allowed) != len(sizes) or any(a.dtype != np.bool_ or a.shape != (s,)
                                             for a, s in zip(allowed, sizes, strict=False)):
            raise WorldGraphError(f"allowed must hold one bool array of shape (sizes[p],) per part "
                                  f"({len(sizes)})")
    checked = {(int(key[0]), int(key[1])): _check_entry((int(key[0]), int(key[1])), mat, sizes)
               for key, mat in adjacency.items()}
    k = len(sizes)
    usable = ([np.arange(s, dtype=np.intp) for s in sizes] if allowed is None
              else [np.flatnonzero(a).astype(np.intp) for a in allowed])
    counts = [len(u) for u in usable]
    order = sorted(range(k), key=lambda p: (counts[p], p))
    order = [p for p in order if counts[p]] + [p for p in order if not counts[p]]
    floor = max(int(min_size), 1)
    limits = (floor, near_maximum, max_nodes, max_cliques, stop_at)
    if sum(counts) >= COMPILED_MIN_VERTICES:
        kernels = _kernels()
        if kernels is not None:
            best, found, nodes, complete = _compiled_search(kernels, sizes, checked, order, usable, limits)
            return _result(best, found, nodes, complete, floor, near_maximum)
    best, found, nodes, complete = _python_search(sizes, checked, order, usable, allowed is None, limits)
    return _result(best, found, nodes, complete, floor, near_maximum)


def _result(best: int, found: list[tuple[int, tuple[tuple[int, int], ...]]], nodes: int, complete: bool,
            floor: int, near_maximum: int) -> CliqueSearch:
    """The search's answer: the recorded cliques that reach the final threshold, largest first."""
    thr = max(best - near_maximum, floor)
    cliques = sorted({c for s, c in found if s >= thr}, key=lambda c: (-len(c), c))
    return CliqueSearch(cliques=cliques, maximum=best if best >= floor else 0, complete=complete, nodes=nodes)


def _python_search(sizes: list[int], checked: dict[tuple[int, int], _Entry], order: list[int],
                   usable: list[NDArray[np.intp]], everything: bool, limits: tuple[int, int, int, int | None,
                                                                                  int | None]
                   ) -> tuple[int, list[tuple[int, tuple[tuple[int, int], ...]]], int, bool]:
    """The branch and bound on Python-int bitsets (the reference of the compiled kernel):
    ``(best size, recorded (size, clique) in discovery order, nodes, complete)``."""
    floor, near_maximum, max_nodes, max_cliques, stop_at = limits
    k = len(sizes)
    full = [(1 << int(s)) - 1 for s in sizes]
    start = list(full) if everything else [_bits(u) for u in usable]
    # packed[d][e]: rows of vertex a of part order[d] against part order[e], packed little-endian
    # (or an int for "all" / "none"); turned into Python-int bitsets lazily, per visited vertex
    packed: list[list[NDArray[np.uint8] | int | tuple[NDArray[np.intp], NDArray[np.intp], int]]] = [
        [0] * k for _ in range(k)]
    for d, p in enumerate(order):
        for e, q in enumerate(order):
            if p == q:
                continue
            key = (min(p, q), max(p, q))
            if key not in checked:
                continue  # no edges
            mat = checked[key]
            if mat is None:
                packed[d][e] = full[q]
            elif isinstance(mat, tuple):
                packed[d][e] = _csr(key, mat, sizes, p < q)
            else:
                mat = mat if p < q else mat.T
                packed[d][e] = np.packbits(mat, axis=1, bitorder="little") if mat.shape[1] else 0
    cache: dict[tuple[int, int], list[int]] = {}
    # per part, its rows by kind: constants (int), packed bit rows, CSR rows
    fixed = [[(e, pk) for e, pk in enumerate(packed[d]) if isinstance(pk, int)] for d in range(k)]
    bit_rows = [[(e, pk) for e, pk in enumerate(packed[d]) if isinstance(pk, np.ndarray)] for d in range(k)]
    csr_rows = [[(e, pk) for e, pk in enumerate(packed[d]) if isinstance(pk, tuple)] for d in range(k)]

    def rows_of(d: int, a: int) -> list[int]:
        got = cache.get((d, a))
        if got is None:
            got = [0] * k
            for e, pk in fixed[d]:
                got[e] = pk
            for e, bits in bit_rows[d]:
                got[e] = int.from_bytes(bits[a].tobytes(), "little")
            for e, (indptr, cols, _) in csr_rows[d]:  # sparse: (indptr, cols, size of the other part)
                row = 0
                for c in cols[indptr[a]:indptr[a + 1]].tolist():
                    row |= 1 << c
                got[e] = row
            cache[(d, a)] = got
        return got

    best = [0]
    found: list[tuple[int, tuple[tuple[int, int], ...]]] = []
    nodes = [0]
    complete = [True]

    def threshold() -> int:
        return max(best[0] - near_maximum, floor)

    done = [False]

    def rec(depth: int, masks: list[int], chosen: list[tuple[int, int]], skipped: list[int]) -> None:
        if done[0]:
            return
        if nodes[0] >= max_nodes:
            complete[0] = False
            done[0] = True
            return
        nodes[0] += 1
        possible = sum(1 for e in range(depth, k) if masks[e])
        if len(chosen) + possible < threshold():
            return
        if depth == k:
            for s in skipped:
                if masks[s]:
                    return  # not maximal: a skipped part still has a compatible vertex
            size = len(chosen)
            if size > best[0]:
                best[0] = size
            found.append((size, tuple(sorted((order[d], a) for d, a in chosen))))
            if stop_at is not None and size >= stop_at:
                done[0] = True
            elif max_cliques is not None and len(found) >= max_cliques:
                done[0] = True
                complete[0] = False
            return
        m = masks[depth]
        while m:
            low = m & -m
            a = low.bit_length() - 1
            m ^= low
            rows = rows_of(depth, a)
            new = [x & r for x, r in zip(masks, rows, strict=True)]
            new[depth] = 0
            chosen.append((depth, a))
            rec(depth + 1, new, chosen, skipped)
            chosen.pop()
        if masks[depth]:
            skipped.append(depth)
            rec(depth + 1, masks, chosen, skipped)
            skipped.pop()
        else:
            rec(depth + 1, masks, chosen, skipped)

    rec(0, [start[p] for p in order], [], [])
    return best[0], found, nodes[0], complete[0]
