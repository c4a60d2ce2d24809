"""The adjacency step of the double-description method in :mod:`radialopt.vertices`.

Zero sets are uint64 bitsets over the processed rows; ``_adjacent_combinations`` makes the
new rays of the pairs that pass the combinatorial adjacency test (Fukuda and Prodon 1996,
Prop. 7), ``_only_two_contain`` is that test, ``_unpack_bits`` and ``_popcount``
read the bitsets.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

#: Double description counts common zero sets with a float32 matrix product (BLAS) once
#: more than this many ray pairs are compared in one step, bitwise below.
_PRODUCT_MIN_PAIRS = 50_000


if hasattr(np, "bitwise_count"):  # numpy >= 2

    def _popcount(x: NDArray[np.uint64]) -> NDArray[np.intp]:
        """Number of set bits over the last axis of a uint64 array."""
        return np.bitwise_count(x).sum(axis=-1, dtype=np.intp)

else:  # pragma: no cover - numpy 1.x
    _POP8 = np.array([bin(i).count("1") for i in range(256)], dtype=np.intp)

    def _popcount(x: NDArray[np.uint64]) -> NDArray[np.intp]:
        """Number of set bits over the last axis of a uint64 array."""
        as_bytes = np.ascontiguousarray(x).view(np.uint8)
        return _POP8[as_bytes].sum(axis=-1)


def _adjacent_combinations(
    R: NDArray[np.float64],
    Z: NDArray[np.uint64],
    s: NDArray[np.float64],
    P: NDArray[np.intp],
    Q: NDArray[np.intp],
    d: int,
    block: int = 1_000_000,
) -> tuple[NDArray[np.float64], NDArray[np.uint64]]:
    """New rays ``s_p r_q - s_q r_p`` for adjacent pairs (p in P: s > 0, q in Q: s < 0).

    Combinatorial adjacency test (Fukuda and Prodon 1996, Prop. 7): with ``I = Z_p & Z_q``,
    the rays are adjacent iff ``|I| >= d - 2`` and no ray other than p and q has a zero set
    containing ``I``.  Zero sets are uint64 bitsets; the work is done in blocks of about
    ``block`` word operations.
    """
    out_R: list[NDArray[np.float64]] = []
    out_Z: list[NDArray[np.uint64]] = []
    if P.size == 0:
        return np.zeros((0, R.shape[1])), np.zeros((0, Z.shape[1]), dtype=np.uint64)
    ZQ = Z[Q]
    # |Z_p & Z_q| for all pairs: bitwise for small P x Q, a float32 product of the 0/1
    # matrices (exact below 2**24) for large ones, where it is much faster
    use_product = P.size * Q.size > _PRODUCT_MIN_PAIRS
    if use_product:
        bits = _unpack_bits(Z).astype(np.float32)
        bits_QT = bits[Q].T.copy()
    rows_per_block = max(1, block // max(1, Q.size * Z.shape[1]))
    for start in range(0, P.size, rows_per_block):
        Pb = P[start : start + rows_per_block]
        if use_product:
            common = bits[Pb] @ bits_QT  # (|Pb|, |Q|)
        else:
            common = _popcount(Z[Pb][:, None, :] & ZQ[None, :, :])  # (|Pb|, |Q|)
        pi, qi = np.nonzero(common >= d - 2.5)
        if pi.size == 0:
            continue
        p, q = Pb[pi], Q[qi]
        inter = Z[p] & Z[q]  # (c, words)
        adjacent = _only_two_contain(Z, inter, block)
        p, q = p[adjacent], q[adjacent]
        if p.size == 0:
            continue
        new = s[p, None] * R[q] - s[q, None] * R[p]
        new /= np.linalg.norm(new, axis=1)[:, None]
        out_R.append(new)
        out_Z.append(inter[adjacent])
    if not out_R:
        return np.zeros((0, R.shape[1])), np.zeros((0, Z.shape[1]), dtype=np.uint64)
    return np.concatenate(out_R), np.concatenate(out_Z)


def _unpack_bits(Z: NDArray[np.uint64]) -> NDArray[np.bool_]:
    """Bitsets ``(N, words)`` -> booleans ``(N, 64 * words)`` (bit j of word w is column 64 w + j)."""
    as_bytes = np.ascontiguousarray(Z.astype("<u8")).view(np.uint8)
    return np.unpackbits(as_bytes, axis=1, bitorder="little").astype(bool)


def _only_two_contain(Z: NDArray[np.uint64], inter: NDArray[np.uint64], block: int) -> NDArray[np.bool_]:
    """For each bitset ``inter[c]`` (the common zero set of a candidate pair), whether exactly
    two rows of ``Z`` (the pair itself) contain it.

    Only rays that are zero on the rarest row of ``inter[c]`` can contain it, so candidates are
    grouped by that row and compared with those rays only.
    """
    bits = _unpack_bits(Z)  # (N, 64 w)
    zeros_per_row = bits.sum(axis=0)
    inter_bits = _unpack_bits(inter)  # (c, 64 w)
    rarest = np.argmin(np.where(inter_bits, zeros_per_row[None, :], np.iinfo(np.intp).max), axis=1)
    adjacent = np.empty(inter.shape[0], dtype=bool)
    empty = ~inter_bits.any(axis=1)  # every ray contains the empty set
    adjacent[empty] = Z.shape[0] == 2
    rarest[empty] = -1
    order = np.argsort(rarest, kind="stable")
    order = order[rarest[order] >= 0]
    rows, starts = np.unique(rarest[order], return_index=True)
    ends = np.append(starts[1:], order.size)[: starts.size]
    for row, a, e in zip(rows, starts, ends, strict=True):
        cand = order[a:e]
        Zr = Z[bits[:, row]]  # rays zero on this row
        cb = max(1, block // max(1, Zr.shape[0] * Z.shape[1]))
        for c0 in range(0, cand.size, cb):
            idx = cand[c0 : c0 + cb]
            blk = inter[idx][:, None, :]
            contains = np.all((Zr[None, :, :] & blk) == blk, axis=2)  # (c, N_row)
            adjacent[idx] = np.count_nonzero(contains, axis=1) == 2
    return adjacent
