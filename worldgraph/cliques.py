"""Exact maximum (and near-maximum) cliques of a k-partite graph, with Python-int bitsets."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ._checks import strict_int
from .errors import (
    ArgumentTypeError,
    OutOfRangeError,
    ShapeError,
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


def _csr(key: tuple[int, int], pairs: tuple, sizes: list[int], forward: bool
         ) -> tuple[NDArray[np.intp], NDArray[np.intp], int] | NDArray[np.uint8] | int:
    """Sparse adjacency ``(rows, cols)`` of parts ``key = (p, q)`` as rows of p's vertices
    (``forward``) or of q's: packed bit rows when small (:data:`DENSE_BITS`), else CSR
    ``(indptr, cols, size of the other part)``; 0 without edges."""
    if len(pairs) != 2:
        raise ShapeError(f"adjacency[{key}] must be a bool matrix or a pair (rows, cols) of index "
                         f"arrays, got a tuple of length {len(pairs)}")
    p, q = key
    rows, cols = (np.asarray(x) for x in pairs)
    for name, arr, size in (("rows", rows, sizes[p]), ("cols", cols, sizes[q])):
        if arr.ndim != 1 or (arr.size and arr.dtype.kind not in "iu"):
            raise ArgumentTypeError(f"adjacency[{key}] {name} must be a 1-D integer array, got dtype "
                                    f"{arr.dtype} and shape {arr.shape}")
        if arr.size and (arr.min() < 0 or arr.max() >= size):
            bad = int(np.flatnonzero((arr < 0) | (arr >= size))[0])
            raise OutOfRangeError(f"adjacency[{key}] {name}[{bad}] = {int(arr[bad])} is outside "
                                  f"[0, {size})")
    if rows.shape != cols.shape:
        raise ShapeError(f"adjacency[{key}] rows and cols must have equal length, got {rows.shape} "
                         f"and {cols.shape}")
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
    compatible with the chosen ones (an AND of Python-int bitsets), then skipping the part,
    and prunes when the chosen count plus the number of later parts with a compatible vertex
    cannot reach the threshold ``max(best - near_maximum, min_size)``.

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
        raise ArgumentTypeError(f"sizes must be a sequence of non-negative integers, got {sizes!r}")
    sizes = [strict_int(f"sizes[{i}]", s, minimum=0, maximum=10**7) for i, s in enumerate(sizes)]
    if not isinstance(adjacency, dict):
        raise ArgumentTypeError(f"adjacency must be a dict (p, q) -> bool array or None, got "
                                f"{type(adjacency).__name__}")
    for key in adjacency:
        if not (isinstance(key, tuple) and len(key) == 2 and all(isinstance(v, int | np.integer)
                                                                  and not isinstance(v, bool) for v in key)
                and 0 <= key[0] < key[1] < len(sizes)):
            raise WorldGraphError(f"adjacency keys must be (p, q) with 0 <= p < q < {len(sizes)}, "
                                  f"got {key!r}")
    min_size = strict_int("min_size", min_size, minimum=0)
    near_maximum = strict_int("near_maximum", near_maximum, minimum=0)
    max_nodes = strict_int("max_nodes", max_nodes, minimum=1)
    if max_cliques is not None:
        max_cliques = strict_int("max_cliques", max_cliques, minimum=1)
    if stop_at is not None:
        stop_at = strict_int("stop_at", stop_at, minimum=1)
    if allowed is not None:
        allowed = [np.asarray(a) for a in allowed]
        if len(allowed) != len(sizes) or any(a.dtype != np.bool_ or a.shape != (s,)
                                             for a, s in zip(allowed, sizes, strict=False)):
            raise ShapeError(f"allowed must hold one bool array of shape (sizes[p],) per part ({len(sizes)})")
    k = len(sizes)
    full = [(1 << int(s)) - 1 for s in sizes]
    start = list(full) if allowed is None else [_bits(np.flatnonzero(a)) & f for a, f in zip(allowed, full,
                                                                                             strict=True)]
    order = sorted(range(k), key=lambda p: (start[p].bit_count(), p))
    order = [p for p in order if start[p]] + [p for p in order if not start[p]]
    # packed[d][e]: rows of vertex a of part order[d] against part order[e], packed little-endian
    # (or an int for "all" / "none"); turned into Python-int bitsets lazily, per visited vertex
    packed: list[list[NDArray[np.uint8] | int | tuple[NDArray[np.intp], NDArray[np.intp], int]]] = [
        [0] * k for _ in range(k)]
    for d, p in enumerate(order):
        for e, q in enumerate(order):
            if p == q:
                continue
            key = (min(p, q), max(p, q))
            if key not in adjacency:
                packed[d][e] = 0
                continue
            mat = adjacency[key]
            if mat is None:
                packed[d][e] = full[q]
                continue
            if isinstance(mat, tuple):
                packed[d][e] = _csr(key, mat, sizes, p < q)
                continue
            mat = np.asarray(mat)
            if mat.dtype != np.bool_:
                raise ArgumentTypeError(f"adjacency[{key}] must be a bool array, got dtype {mat.dtype}")
            if mat.shape != (sizes[key[0]], sizes[key[1]]):
                raise WorldGraphError(f"adjacency[{key}] must have shape ({sizes[key[0]]}, {sizes[key[1]]}), "
                                      f"got shape {mat.shape}")
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
    floor = max(int(min_size), 1)

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
    thr = threshold()
    cliques = sorted({c for s, c in found if s >= thr}, key=lambda c: (-len(c), c))
    return CliqueSearch(cliques=cliques, maximum=best[0] if best[0] >= floor else 0,
                        complete=complete[0], nodes=nodes[0])


