"""The link look-up table of a world model: :class:`LinkTable` (the object pairs of one type
pair, sorted by length), the mapping of all of them (``_LinkTables``), how the world
builds it (``_build_links``) and its limits :data:`MAX_LINK_LENGTH`, :data:`MAX_LINKS` and
:data:`MAX_GRAPH_EDGES`."""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from .. import _checks
from ..errors import MalformedFileError, WorldGraphError
from ..tolerances import QUERY_WIDEN

#: Largest allowed ``max_link_length + link_margin`` (metres): above every distance in a world
#: that respects :data:`MAX_COORDINATE`.
MAX_LINK_LENGTH = 1e7


#: Most object pairs a world's link table may hold (about 1 GB of link arrays; a 1M-object campus
#: at 5 m holds about 28 million).
MAX_LINKS = 40_000_000
#: Most edges :attr:`WorldModel.graph <worldgraph.model.WorldModel.graph>` builds: a networkx edge
#: with its attribute dict costs about 0.5 kB and 12 us to add (12.5 million edges, 5,000 objects
#: at one point: 144 s), so more is refused up front; the link tables hold any number as arrays.
MAX_GRAPH_EDGES = 1_000_000


# ----------------------------------------------------------------------------------------------
# link table
# ----------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class LinkTable:
    """Object pairs of one type pair, sorted by length: the paper's distance look-up table.

    For a type pair ``(a, b)`` with ``a < b`` each row holds ``(object of type a, object of
    type b)``; for ``(a, a)`` each unordered pair appears once with ``i < j``.  Indices are
    indices into :attr:`WorldModel.objects` (global object indices).

    Parameters
    ----------
    i, j : (k,) int
    length : (k,) float
        ``|positions[i] - positions[j]|``, non-decreasing.
    """

    i: NDArray[np.intp]
    j: NDArray[np.intp]
    length: NDArray[np.float64]

    def __post_init__(self) -> None:
        i = _checks.int_array("LinkTable i", self.i, (None,), minimum=0)
        j = _checks.int_array("LinkTable j", self.j, (None,), minimum=0)
        length = _checks.real_array("LinkTable length", self.length, (None,))
        if not (i.shape == j.shape == length.shape):
            raise WorldGraphError(f"LinkTable i, j, length must have one shape (k,), got {i.shape}, "
                                  f"{j.shape}, {length.shape}")
        if (length < 0).any():
            k = int(np.argmax(length < 0))
            raise WorldGraphError(f"LinkTable length[{k}] must be >= 0, got {float(length[k])!r}")
        if length.size > 1 and (np.diff(length) < 0).any():
            k = int(np.argmax(np.diff(length) < 0))
            raise WorldGraphError(f"LinkTable length must be sorted ascending, but length[{k + 1}] = "
                                  f"{float(length[k + 1])!r} < length[{k}] = {float(length[k])!r}")
        for a in (i, j, length):
            a.setflags(write=False)
        object.__setattr__(self, "i", i)
        object.__setattr__(self, "j", j)
        object.__setattr__(self, "length", length)

    def __len__(self) -> int:
        return int(self.length.size)

    @classmethod
    def _trusted(cls, i: NDArray[np.intp], j: NDArray[np.intp], length: NDArray[np.float64]) -> LinkTable:
        """Build without validation from read-only arrays the caller has checked."""
        table = object.__new__(cls)
        object.__setattr__(table, "i", i)
        object.__setattr__(table, "j", j)
        object.__setattr__(table, "length", length)
        return table

    def in_range(self, lo: float, hi: float,
                 ) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.float64]]:
        """Links with ``lo < length < hi`` (metres; infinite bounds allowed, NaN not) by binary
        search, as ``(i, j, length)`` views."""
        lo = _checks.real_float("lo", lo)
        hi = _checks.real_float("hi", hi)
        start = int(np.searchsorted(self.length, lo, side="right"))
        stop = int(np.searchsorted(self.length, hi, side="left"))
        stop = max(stop, start)
        return self.i[start:stop], self.j[start:stop], self.length[start:stop]


def _link_order(pi: NDArray[np.intp], pj: NDArray[np.intp], length: NDArray[np.float64],
                key: NDArray[np.int64], n: int) -> NDArray[np.intp]:
    """``np.lexsort((pj, pi, length, key))`` (by type pair, then length, then the object
    indices) as three stable sorts, the last on the small type-pair key (a radix sort when it
    fits 16 bits): half the time of the lexsort's four passes (5.5M links: 2.6 s against 5.0 s)."""
    order = np.argsort(pi.astype(np.int64) * n + pj, kind="stable")
    order = order[np.argsort(length[order], kind="stable")]
    small = key.astype(np.int16) if len(key) and int(key.max()) < 2**15 else key
    return order[np.argsort(small[order], kind="stable")]


def _pair_lengths(positions: NDArray[np.float64], i: NDArray[np.intp], j: NDArray[np.intp],
                  chunk: int = 1 << 20) -> NDArray[np.float64]:
    """``|positions[i] - positions[j]|`` in chunks, so that no ``(m, 3)`` temporary is made."""
    out = np.empty(len(i))
    for lo in range(0, len(i), chunk):
        a, b = i[lo:lo + chunk], j[lo:lo + chunk]
        d = positions[a] - positions[b]
        out[lo:lo + chunk] = np.sqrt(np.einsum("ij,ij->i", d, d))
    return out


def _empty_table() -> LinkTable:
    return LinkTable(np.zeros(0, np.intp), np.zeros(0, np.intp), np.zeros(0))


_EMPTY_TABLE = _empty_table()


class _LinkTables(Mapping[tuple[str, str], LinkTable]):
    """``(type_a, type_b) -> LinkTable`` over the type pairs with at least one link.

    All links live in three arrays sorted by type pair, then length; a table is a view of its
    slice, made on access.  Memory is linear in the number of links, whatever the number of
    types (no table per pair of types, no Python object per stored pair).  Iteration yields the
    linked pairs only; looking up a sorted pair ``(a, b)``, ``a <= b``, of types of the model
    that has no links returns an empty :class:`LinkTable`; any other key is a ``KeyError``.
    """

    def __init__(self, names: list[str], pi: NDArray[np.intp], pj: NDArray[np.intp],
                 length: NDArray[np.float64], present: NDArray[np.int64], first: NDArray[np.intp],
                 last: NDArray[np.intp]) -> None:
        self._names = names
        self._code = {t: c for c, t in enumerate(names)}
        self._pi, self._pj, self._length = pi, pj, length
        self._present, self._first, self._last = present, first, last
        for a in (pi, pj, length, present, first, last):
            a.setflags(write=False)

    def _slot(self, key: Any) -> int | None:
        """Index into ``present`` of a linked pair; ``None`` for a sorted pair of known types
        without links; ``KeyError`` otherwise."""
        if not (isinstance(key, tuple) and len(key) == 2 and all(isinstance(t, str) for t in key)):
            raise KeyError(key)
        ca, cb = self._code.get(key[0]), self._code.get(key[1])
        if ca is None or cb is None or ca > cb:
            raise KeyError(key)
        k = ca * len(self._names) + cb
        pos = int(np.searchsorted(self._present, k))
        return pos if pos < len(self._present) and self._present[pos] == k else None

    def __getitem__(self, key: Any) -> LinkTable:
        pos = self._slot(key)
        if pos is None:
            return _EMPTY_TABLE
        s, e = int(self._first[pos]), int(self._last[pos])
        return LinkTable._trusted(self._pi[s:e], self._pj[s:e], self._length[s:e])

    def __contains__(self, key: object) -> bool:
        try:
            return self._slot(key) is not None
        except KeyError:
            return False

    def get(self, key: Any, default: Any = None) -> Any:
        try:
            return self[key]
        except KeyError:
            return default

    def __iter__(self) -> Iterator[tuple[str, str]]:
        nt = len(self._names)
        for k in self._present.tolist():
            a, b = divmod(k, nt)
            yield (self._names[a], self._names[b])

    def __len__(self) -> int:
        return len(self._present)

    def count_shorter(self, hi: float) -> int:
        """How many links, of every type pair, are shorter than ``hi`` (m)."""
        return int(np.count_nonzero(self._length < hi))

    def __repr__(self) -> str:
        return f"<link tables: {len(self)} linked type pairs, {len(self._length)} links>"


def _build_world_links(world: Any, stored: tuple[NDArray[Any], ...] | None = None,
                       source: str = "file") -> None:
    """The type index, link tables and k-d tree of a world, set on it: the body of
    :meth:`WorldModel._build_links <worldgraph.model.WorldModel._build_links>`; ``world`` is a
    :class:`~worldgraph.model.WorldModel` (not imported: the world module imports this one).

    ``stored``: the link rows ``(i, j, length)`` of a binary world file (the arrays of the link tables
    in their order, ``_stored_links``), used instead of the pair search and sorts when they
    pass its checks (``source`` names the file in its errors)."""
    types = world._types
    positions = world._positions
    table = world.objects
    if (hasattr(table, "type_names") and hasattr(table, "codes")  # an ObjectTable: its codes, no string sort
            and list(table.type_names) == sorted(table.type_names)):
        used = np.flatnonzero(np.bincount(table.codes, minlength=len(table.type_names)))
        names = np.asarray(table.type_names, dtype=str)[used]
        recode = np.zeros(len(table.type_names), dtype=np.intp)
        recode[used] = np.arange(len(used))
        codes = recode[table.codes]
    else:
        names, codes = np.unique(types, return_inverse=True)
        codes = codes.reshape(-1).astype(np.intp)
    by_type = np.argsort(codes, kind="stable")
    starts = np.searchsorted(codes[by_type], np.arange(len(names) + 1))
    type_index = {str(t): by_type[starts[c]:starts[c + 1]] for c, t in enumerate(names)}
    for v in type_index.values():
        v.setflags(write=False)

    tree = cKDTree(positions)
    if stored is not None:
        links = _stored_links(world, [str(t) for t in names], codes, tree, stored, source)
    else:
        world._check_coincident(codes)
        links = _search_links(world, [str(t) for t in names], codes, tree)
    object.__setattr__(world, "_type_index", type_index)
    object.__setattr__(world, "_links", links)
    object.__setattr__(world, "_tree", tree)


def _search_links(world: Any, names: list[str], codes: NDArray[np.intp], tree: cKDTree) -> _LinkTables:
    """The link tables of a world: refused beyond :data:`MAX_LINKS` (estimated on a sample before
    anything is built), by enumeration when every pair is within reach (``_dense_links``),
    else by the k-d tree's pair search (``_tree_links``)."""
    positions = world._positions

    radius = world.max_link_length + world.link_margin
    n = len(positions)
    if n > 1000:  # a strided sample says how many links the table would hold before it is built
        counts = np.asarray(tree.query_ball_point(positions[:: n // 1000], radius, return_length=True))
        estimate = (float(counts.mean()) - 1.0) * n / 2.0
        if estimate > MAX_LINKS:
            raise WorldGraphError(
                f"max_link_length = {world.max_link_length:g} m (+ link_margin {world.link_margin:g} m) "
                f"would link about {estimate:,.0f} object pairs ({n:,} objects, about "
                f"{counts.mean() - 1:,.0f} within reach of each), more than {MAX_LINKS:,}: lower "
                "max_link_length or thin the world")
    if n > 1 and _within_reach(positions, radius):
        return _dense_links(names, codes, positions, radius)
    return _tree_links(names, codes, positions, tree, radius)


def _tree_links(names: list[str], codes: NDArray[np.intp], positions: NDArray[np.float64], tree: cKDTree,
                radius: float) -> _LinkTables:
    """The link tables (pairs closer than ``radius``) by the k-d tree's pair search and sorts."""
    n = len(positions)
    # query slightly wide, then filter with the exact strict test below
    pairs = tree.query_pairs(radius * (1.0 + QUERY_WIDEN), output_type="ndarray")
    if pairs.size == 0:
        pairs = np.zeros((0, 2), np.intp)
    pi, pj = pairs[:, 0].astype(np.intp), pairs[:, 1].astype(np.intp)
    del pairs
    length = _pair_lengths(positions, pi, pj)
    keep = length < radius
    if not keep.all():
        pi, pj, length = pi[keep], pj[keep], length[keep]
    del keep
    # orient rows: (type a, type b) with a < b, or i < j for one type
    nt = len(names)
    small = codes.astype(np.int32)
    ci, cj = small[pi], small[pj]
    swap = (ci > cj) | ((ci == cj) & (pi > pj))
    pi, pj = np.where(swap, pj, pi), np.where(swap, pi, pj)
    del swap
    key = np.minimum(ci, cj).astype(np.int64) * nt + np.maximum(ci, cj)
    del ci, cj
    if nt == n:  # one object per type: every type pair has at most one link, the key alone orders them
        order = np.argsort(key, kind="stable")
    else:
        order = _link_order(pi, pj, length, key, n)
    pi, pj, length, key = pi[order], pj[order], length[order], key[order]
    del order
    return _sorted_tables(names, pi, pj, length, key)


def _sorted_tables(names: list[str], pi: NDArray[np.intp], pj: NDArray[np.intp], length: NDArray[np.float64],
                   key: NDArray[np.int64]) -> _LinkTables:
    """The link tables of rows already in their final order (``key`` non-decreasing): the type
    pairs present and their slices from the places where ``key`` changes (``np.unique`` of a
    sorted key without its sort)."""
    m = len(key)
    change = np.flatnonzero(key[1:] != key[:-1]) + 1 if m else np.zeros(0, np.intp)
    if len(change) == m - 1:  # one row per type pair (one object per type): no gather
        first = np.arange(m, dtype=np.intp)
        present = key.astype(np.int64, copy=False)
        last = first + 1
    else:
        first = np.concatenate([np.zeros(min(m, 1), np.intp), change]).astype(np.intp, copy=False)
        present = key[first].astype(np.int64, copy=False)
        last = np.append(first[1:], m)[: len(first)].astype(np.intp, copy=False)
    return _LinkTables(names, pi, pj, length, present, first, last)


def _within_reach(positions: NDArray[np.float64], radius: float) -> bool:
    """Whether every pair of objects may be a link: the diagonal of the objects' bounding box
    is below ``radius`` (objects packed in one place, e.g. the parts of one machine, or a test
    world at one point)."""
    extent = positions.max(axis=0) - positions.min(axis=0)
    return bool(math.sqrt(float(extent @ extent)) < radius)


def _dense_links(names: list[str], codes: NDArray[np.intp], positions: NDArray[np.float64],
                 radius: float) -> _LinkTables:
    """The link tables of a world whose objects lie within reach of each other: every pair
    enumerated row by row (object ``a`` against the objects after it: contiguous slices, no
    gathers), without the k-d tree's pair search and, in the common cases, without sorting (the
    tables ``_tree_links`` builds, row for row).

    The objects are put in type order (ascending index within a type), so that a pair ``(a, b)``
    with ``a < b`` in that order is already oriented (lower type first, lower index first within
    one type) and the row-major enumeration is in object order within every type pair.  With one
    object per type the enumeration is in type-pair order too; with repeated types one stable sort
    by type pair groups them, and the lengths are sorted within each pair only when they are not
    already (all objects at one point: equal lengths).
    """
    n = len(positions)
    nt = len(names)
    perm = np.argsort(codes, kind="stable").astype(np.intp)
    pos = positions[perm]
    code = codes[perm].astype(np.int64)
    total = n * (n - 1) // 2  # at most; filled row by row (contiguous slices, no gathers)
    pi, pj = np.empty(total, np.intp), np.empty(total, np.intp)
    length, key = np.empty(total), np.empty(total, np.int64)
    m = 0
    for a in range(n - 1):
        d = pos[a] - pos[a + 1:]
        dist = np.sqrt(np.einsum("ij,ij->i", d, d))  # as _pair_lengths computes it
        keep = dist < radius
        if keep.all():
            k = n - 1 - a
            pj[m:m + k] = perm[a + 1:]
            length[m:m + k] = dist
            np.add(code[a + 1:], code[a] * nt, out=key[m:m + k])
        else:
            sel = np.flatnonzero(keep) + (a + 1)
            k = len(sel)
            pj[m:m + k] = perm[sel]
            length[m:m + k] = dist[keep]
            np.add(code[sel], code[a] * nt, out=key[m:m + k])
        pi[m:m + k] = perm[a]
        m += k
    pi, pj, length, key = pi[:m], pj[:m], length[:m], key[:m]
    if len(key) > 1 and (key[1:] < key[:-1]).any():
        order = np.argsort(key, kind="stable")
        pi, pj, length, key = pi[order], pj[order], length[order], key[order]
        del order
    if len(key) > 1 and ((key[1:] == key[:-1]) & (length[1:] < length[:-1])).any():
        order = np.argsort(length, kind="stable")  # rows in (type pair, object) order: stable twice
        order = order[np.argsort(key[order], kind="stable")]
        pi, pj, length, key = pi[order], pj[order], length[order], key[order]
        del order
    return _sorted_tables(names, pi, pj, length, key)


#: Objects whose links (and link rows whose lengths) a binary file's link tables are checked
#: against on load: a k-d tree query and the lengths recomputed from the positions.
STORED_LINKS_SAMPLE = 1000
#: Rows per chunk of the stored link tables' checks.
_CHECK_CHUNK = 1 << 20


def _stored_links(world: Any, names: list[str], codes: NDArray[np.intp], tree: cKDTree,
                  stored: tuple[NDArray[Any], ...], source: str) -> _LinkTables:
    """The link tables of a world from the rows ``(i, j, length)`` a binary file stores, checked.

    Vectorised checks over every row: indices in range, rows oriented as ``_search_links``
    orients them, grouped by type pair, sorted by length, below ``max_link_length +
    link_margin``, ties in object order (so no row repeats).  On samples: the lengths of
    :data:`STORED_LINKS_SAMPLE` rows spread over the table equal those recomputed from the
    positions (as the pair search computes them: recomputing all, a random gather over the
    positions, took 4 s of a 1M-object load), and for :data:`STORED_LINKS_SAMPLE` objects
    spread over the world the number of links equals a k-d tree's count of objects within
    reach.  A file damaged in transit fails the archive's CRC; the samples catch files whose
    tables were made for other positions or settings.
    Same-type links shorter than :data:`~worldgraph.tolerances.COINCIDENT_TOLERANCE` raise
    :class:`~worldgraph.errors.WorldGraphError` (the pair search's coincidence check).
    """
    def bad(msg: str) -> MalformedFileError:
        return MalformedFileError(f"{source}: stored link tables: {msg}")

    from ..tolerances import COINCIDENT_TOLERANCE

    positions = world._positions
    n = len(positions)
    radius = world.max_link_length + world.link_margin
    si, sj, length = stored
    if si.ndim != 1 or not si.shape == sj.shape == length.shape:
        raise bad(f"link_i, link_j and link_length must have one shape (k,), got {si.shape}, {sj.shape} "
                  f"and {length.shape}")
    if len(si) > MAX_LINKS:
        raise bad(f"{len(si):,} links, more than MAX_LINKS = {MAX_LINKS:,}")
    m = len(si)
    if m and (min(int(si.min()), int(sj.min())) < 0 or max(int(si.max()), int(sj.max())) >= n):
        k = int(np.argmax((si < 0) | (si >= n) | (sj < 0) | (sj >= n)))
        raise bad(f"row {k} = ({int(si[k])}, {int(sj[k])}) is not a pair of object indices 0..{n - 1}")
    if m and (float(length.max()) >= radius or float(length.min()) < 0):
        k = int(np.argmax((length >= radius) | (length < 0)))
        raise bad(f"row {k} has length {float(length[k])!r} m, not in 0 <= length < max_link_length + "
                  f"link_margin = {radius!r}")
    nt = len(names)
    small = codes.astype(np.int32)
    key_type = np.int32 if nt * nt < 2**31 else np.int64
    sample = np.arange(0, n, max(1, n // STORED_LINKS_SAMPLE))
    in_sample = np.zeros(n, dtype=bool)
    in_sample[sample] = True
    hits: list[NDArray[Any]] = []  # the rows' ends that are sampled objects
    starts_parts = [np.zeros(min(m, 1), dtype=np.intp)]
    present_parts = []
    # in chunks (one row of overlap for the differences): every temporary stays small, where
    # whole-table temporaries (27.8M rows at 1M objects) made the checks twice as slow
    for lo in range(0, m, _CHECK_CHUNK):
        hi = min(lo + _CHECK_CHUNK, m)
        first = max(lo - 1, 0)
        a, b, length_c = si[first:hi], sj[first:hi], length[first:hi]
        ca, cb = small[a], small[b]
        wrong = (ca > cb) | ((ca == cb) & (a >= b))
        if wrong.any():
            k = first + int(np.argmax(wrong))
            raise bad(f"row {k} = ({int(si[k])}, {int(sj[k])}) is not oriented (lower type first, or the "
                      "lower index first within one type)")
        close = (ca == cb) & (length_c <= COINCIDENT_TOLERANCE)
        if close.any():
            k = first + int(np.argmax(close))
            raise world._coincident(si[k], sj[k], float(length[k]))
        key = ca.astype(key_type) * key_type(nt) + cb
        dk = np.diff(key)
        if (dk < 0).any():
            k = first + int(np.argmax(dk < 0))
            raise bad(f"rows {k} and {k + 1} are not grouped by type pair in order")
        same = dk == 0
        dl = np.diff(length_c)
        unsorted = same & (dl < 0)
        if unsorted.any():
            k = first + int(np.argmax(unsorted))
            raise bad(f"rows {k} and {k + 1} of one type pair are not sorted by length")
        ties = np.flatnonzero(same & (dl == 0))
        if ties.size:
            before = a[ties].astype(np.int64) * n + b[ties]
            after = a[ties + 1].astype(np.int64) * n + b[ties + 1]
            if (after <= before).any():
                k = first + int(ties[int(np.argmax(after <= before))])
                raise bad(f"rows {k} and {k + 1} of equal length are not in object order (or repeat)")
        new = np.flatnonzero(~same) + 1
        starts_parts.append(new + first)
        if lo == 0:
            present_parts.append(key[:1])
        present_parts.append(key[new])
        own = slice(lo - first, None)  # this chunk's rows (the overlap row counted in the last)
        hits.extend(side[in_sample[side]] for side in (a[own], b[own]))
    degree = np.bincount(np.concatenate(hits), minlength=n) if hits else np.zeros(n, dtype=np.intp)
    starts = np.concatenate(starts_parts).astype(np.intp)
    present = (np.concatenate(present_parts).astype(np.int64) if present_parts
               else np.zeros(0, dtype=np.int64))
    rows_checked = np.arange(0, m, max(1, m // STORED_LINKS_SAMPLE))
    differ = _pair_lengths(positions, si[rows_checked], sj[rows_checked]) != length[rows_checked]
    if differ.any():
        k = int(rows_checked[int(np.argmax(differ))])
        raise bad(f"row {k} has length {float(length[k])!r} m, but its objects are "
                  f"{float(_pair_lengths(positions, si[k:k + 1], sj[k:k + 1])[0])!r} m apart")
    # completeness on a sample: the links of each sampled object against the tree's neighbours
    found = tree.query_ball_point(positions[sample], radius * (1.0 + QUERY_WIDEN))
    lens = np.fromiter((len(f) for f in found), dtype=np.intp, count=len(found))
    rows = np.repeat(np.arange(len(sample)), lens)
    cols = np.fromiter((x for f in found for x in f), dtype=np.intp, count=int(lens.sum()))
    near = _pair_lengths(positions, sample[rows], cols) < radius
    near &= cols != sample[rows]
    want = np.bincount(rows[near], minlength=len(sample))
    have = degree[sample]
    if (want != have).any():
        k = int(np.argmax(want != have))
        raise bad(f"object {int(sample[k])} has {int(have[k])} links, but {int(want[k])} objects lie "
                  f"within max_link_length + link_margin = {radius!r} of it")
    last = np.append(starts[1:], m)[: len(starts)]
    return _LinkTables(names, si.astype(np.intp, copy=False), sj.astype(np.intp, copy=False), length, present,
                       starts, last)
