"""Compiled grid joins for far object pairs: a horizontal ring with a height band, a 3D shell.

:func:`ring_pairs` returns every pair ``(a_i, b_j)`` whose horizontal distance lies in
``[h_lo, h_hi]`` and whose height offset ``b_z - a_z`` lies in ``[z_lo, z_hi]``;
:func:`shell_pairs` every pair whose 3D distance lies in ``[r_lo, r_hi]``.  Both bucket ``b`` into
a grid sorted by an int64 cell key and visit, for each point of ``a``, only the cells the ring
(or shell) can reach, testing the candidates exactly.  A k-d tree ball query returns the whole disk
(or ball) of radius ``h_hi``; a thin ring of radius 6 m and width 0.2 m holds about 4 % of it.

For many joins against one set (a type's objects, far percept pairs of a big map),
:func:`ring_grid` sorts it once into a :class:`RingGrid` (kept with the world by
:meth:`~worldgraph.model.WorldModel.type_grid`) and :func:`ring_pairs_in` joins against it, with a
mask for the chosen points: no sort per call.  :func:`ring_pairs` and :func:`shell_pairs` put
their grid on the smaller side (``b - a = -(a - b)`` exactly, so swapping the sides with the
height band negated gives the same pairs).

numba is a main dependency; this module does not import it until
the first call, which compiles the kernels (``cache=True``: later processes load them from the
cache).  Without a working numba both functions raise :class:`~worldgraph.errors.ImporterError`.

Grid (ring)
    Columns of width ``cell`` in x and bands of height ``zcell`` in z; ``b`` is sorted by
    ``(column, band)`` (a *row* of the grid, found through a dense table of row starts when
    there are at most ``4 (n + m) + 65536`` rows, else by binary search) and, within a row, by
    its exact y.  For a point of ``a`` and a column, the ring reaches at most two y ranges (one
    when the column misses the disk of radius ``h_lo``), each found by one binary search on y
    and scanned; ``a`` is processed in grid order so consecutive points visit the same rows.
    ``cell = max(h_hi / 4, 2 (h_hi - h_lo))`` (at most 9 columns per point) and
    ``zcell = max(z_hi - z_lo, cell / 8)`` (two bands per point): on the campus benchmark
    (``h = 6 m``, width 0.2 m, band 0.2 m; ``benchmarks/ring_join.py --cells``) 1.5 m columns
    were the fastest (0.25 m: twice the time, 0.75 m: 10 - 25 % more, 2 m: about equal), and
    bands of 1.5 - 3 times the band thickness cost 10 - 25 % more: the per-point overhead
    (binary searches) outweighs the extra candidates of wider columns.

Grid (shell)
    Square columns of side ``cell = max(r_hi / 4, 2 (r_hi - r_lo))`` in x and y, ``b`` sorted by
    column, then by z; per reachable column the shell reaches at most two z ranges (r = 6 m,
    width 0.2 m, 50k uniform points: 1.5 m columns 0.91 s, 0.75 m 1.34 s, 3 m 1.08 s).

Exactness
    The column and y (z) ranges are widened by 4096 float64 roundings of ``1 + largest
    |coordinate|`` (about 1e-12 of it), far above the rounding of their arithmetic, so rounding
    never drops a pair; the final test uses the documented expressions in float64
    (``math.hypot(bx - ax, by - ay)``, ``bz - az``, ``sqrt(dx*dx + dy*dy + dz*dz)``), the same
    as a brute-force numpy reference.

Memory: the sorted copy of ``b`` and its keys (O(m)), a row table of at most ``4 (n + m) + 65536``
entries (else a binary search over all keys), and the output, grown by doubling and returned at
its exact size.
"""

from __future__ import annotations

import importlib.util
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .. import _checks
from ..errors import ImporterError, WorldGraphError

__all__ = ["HAVE_NUMBA", "MAX_ABS_COORDINATE", "RingGrid", "ring_grid", "ring_pairs", "ring_pairs_in",
           "shell_pairs"]

#: Whether numba can be imported (checked without importing it).
HAVE_NUMBA: bool = importlib.util.find_spec("numba") is not None

#: Largest absolute coordinate or bound accepted (m): far beyond any world model, small enough
#: that cell indices fit an int64.
MAX_ABS_COORDINATE = 1e12

_PIP = "pip install numba"
_KEY_LIMIT = 2.0**62  # cell keys stay below this (int64)
_ULP = float(np.finfo(np.float64).eps)
# Exactness margins, in units of float64 rounding (not tolerances: any margin above the rounding
# of the arithmetic gives the same pairs; a larger one only visits a few more candidates):
_RANGE_ULPS = 4096.0  # the column / y / z ranges, relative to the largest |coordinate|
_SQUARE_WIDEN = 2.0**20 * _ULP  # the squared-distance pre-test, relative to the squared bounds

# The compiled kernels, built on first use by _kernels(); tests may replace the entry with None
# to see the missing-numba error.
_COMPILED: dict[str, Callable[..., Any] | None] = {"ring": None, "shell": None}


def _first_key(keys: Any, lo: int, hi: int, row: int, after: bool) -> int:
    """The first index in ``[lo, hi)`` of the sorted ``keys`` with a key ``> row`` (``after``)
    or ``>= row`` (binary search; compiled with the kernels)."""
    while lo < hi:
        mid = (lo + hi) >> 1
        if keys[mid] < row or (after and keys[mid] == row):
            lo = mid + 1
        else:
            hi = mid
    return lo


def _row_span(keys: Any, rowstart: Any, use_rows: bool, row: int) -> tuple[int, int]:
    """``(s, e)``: the sorted points of grid row ``row``, from the row table or by binary search."""
    if use_rows:
        return rowstart[row], rowstart[row + 1]
    m = keys.shape[0]
    return _first_key(keys, 0, m, row, False), _first_key(keys, 0, m, row, True)


def _first_at_least(bs: Any, axis: int, lo: int, hi: int, value: float) -> int:
    """The first index in ``[lo, hi)`` with ``bs[k, axis] >= value`` (sorted along ``axis``)."""
    while lo < hi:
        mid = (lo + hi) >> 1
        if bs[mid, axis] < value:
            lo = mid + 1
        else:
            hi = mid
    return lo


def _gap(d0: float, cell: float, eps: float) -> tuple[float, float]:
    """The nearest and farthest distance from a coordinate to a cell ``[d0, d0 + cell)`` given
    relative to it, widened by ``eps`` (the nearest not below 0)."""
    d1 = d0 + cell
    near = d0 if d0 > 0.0 else (-d1 if d1 < 0.0 else 0.0)
    return max(near - eps, 0.0), max(abs(d0), abs(d1)) + eps


def _push(out_i: Any, out_j: Any, cnt: int, i: int, j: int) -> tuple[Any, Any]:
    """Store pair ``cnt``, doubling the output arrays when full; returns them."""
    if cnt == out_i.shape[0]:
        grown_i = np.empty(2 * cnt, np.int64)
        grown_i[:cnt] = out_i[:cnt]
        grown_j = np.empty(2 * cnt, np.int64)
        grown_j[:cnt] = out_j[:cnt]
        out_i, out_j = grown_i, grown_j
    out_i[cnt] = i
    out_j[cnt] = j
    return out_i, out_j


def _ring_kernel(a: Any, a_order: Any, bs: Any, order: Any, keys: Any, rowstart: Any, use_rows: bool,
                 origin: Any, cell: float, zcell: float, nx: int, nz: int,
                 h_lo: float, h_hi: float, z_lo: float, z_hi: float, eps: float,
                 b_mask: Any, use_mask: bool) -> Any:
    """Ring join of ``a`` against the sorted ``bs`` (compiled by numba; plain Python otherwise);
    with ``use_mask``, only the points ``k`` of ``bs`` with ``b_mask[order[k]]``."""
    n = a.shape[0]
    x0, z0 = origin[0], origin[2]
    out_i = np.empty(max(1024, 4 * n), np.int64)
    out_j = np.empty(max(1024, 4 * n), np.int64)
    cnt = 0
    hh = h_hi + eps
    hl = h_lo - eps
    sq_hi = hh * hh * (1.0 + _SQUARE_WIDEN)
    sq_lo = max(hl, 0.0) ** 2 * (1.0 - _SQUARE_WIDEN)
    for p in range(n):
        ax = a[p, 0]
        ay = a[p, 1]
        az = a[p, 2]
        tz0 = (az + z_lo - eps - z0) / zcell
        tz1 = (az + z_hi + eps - z0) / zcell
        if tz1 < 0.0 or tz0 >= nz:
            continue
        izlo = max(int(math.floor(tz0)), 0)
        izhi = min(int(math.floor(tz1)), nz - 1)
        tx0 = (ax - hh - x0) / cell
        tx1 = (ax + hh - x0) / cell
        if tx1 < 0.0 or tx0 >= nx:
            continue
        ixlo = max(int(math.floor(tx0)), 0)
        ixhi = min(int(math.floor(tx1)), nx - 1)
        for ix in range(ixlo, ixhi + 1):
            dmin, dmax = _gap(x0 + ix * cell - ax, cell, eps)
            if dmin > hh:
                continue
            ymax = math.sqrt(hh * hh - dmin * dmin) + eps
            ymin = 0.0
            if hl > dmax:
                ymin = max(math.sqrt(hl * hl - dmax * dmax) - eps, 0.0)
            ylo1 = ay - ymax
            yhi1 = ay - ymin
            ylo2 = ay + ymin
            yhi2 = ay + ymax
            nint = 2
            if ylo2 <= yhi1:  # the two y ranges overlap: one scan
                yhi1 = yhi2
                nint = 1
            for iz in range(izlo, izhi + 1):
                row = ix * nz + iz
                s, e = _row_span(keys, rowstart, use_rows, row)
                if s == e:
                    continue
                for q in range(nint):
                    ylo = ylo1 if q == 0 else ylo2
                    yhi = yhi1 if q == 0 else yhi2
                    k = _first_at_least(bs, 1, s, e, ylo)  # the row is sorted by y
                    while k < e and bs[k, 1] <= yhi:
                        if use_mask and not b_mask[order[k]]:
                            k += 1
                            continue
                        dz = bs[k, 2] - az
                        dx = bs[k, 0] - ax
                        dy = bs[k, 1] - ay
                        d2 = dx * dx + dy * dy
                        # a cheap squared test, widened far beyond its rounding, first
                        if z_lo <= dz <= z_hi and sq_lo <= d2 <= sq_hi:
                            h = math.hypot(dx, dy)
                            if h_lo <= h <= h_hi:
                                out_i, out_j = _push(out_i, out_j, cnt, a_order[p], order[k])
                                cnt += 1
                        k += 1
    return out_i[:cnt].copy(), out_j[:cnt].copy()


def _shell_kernel(a: Any, a_order: Any, bs: Any, order: Any, keys: Any, rowstart: Any, use_rows: bool,
                  origin: Any, cell: float, nx: int, ny: int, nz: int,
                  r_lo: float, r_hi: float, eps: float) -> Any:
    """Shell join of ``a`` against the sorted ``bs`` (compiled by numba; plain Python otherwise)."""
    n = a.shape[0]
    x0, y0, z0 = origin[0], origin[1], origin[2]
    out_i = np.empty(max(1024, 4 * n), np.int64)
    out_j = np.empty(max(1024, 4 * n), np.int64)
    cnt = 0
    rh = r_hi + eps
    rl = r_lo - eps
    for p in range(n):
        ax = a[p, 0]
        ay = a[p, 1]
        az = a[p, 2]
        tx0 = (ax - rh - x0) / cell
        tx1 = (ax + rh - x0) / cell
        ty0 = (ay - rh - y0) / cell
        ty1 = (ay + rh - y0) / cell
        tz0 = (az - rh - z0) / cell
        tz1 = (az + rh - z0) / cell
        if tx1 < 0.0 or tx0 >= nx or ty1 < 0.0 or ty0 >= ny or tz1 < 0.0 or tz0 >= nz:
            continue
        ixlo = max(int(math.floor(tx0)), 0)
        ixhi = min(int(math.floor(tx1)), nx - 1)
        iylo = max(int(math.floor(ty0)), 0)
        iyhi = min(int(math.floor(ty1)), ny - 1)
        for ix in range(ixlo, ixhi + 1):
            xmin, xmax = _gap(x0 + ix * cell - ax, cell, eps)
            if xmin > rh:
                continue
            for iy in range(iylo, iyhi + 1):
                ymin, ymax = _gap(y0 + iy * cell - ay, cell, eps)
                near2 = xmin * xmin + ymin * ymin
                if near2 > rh * rh:
                    continue
                far2 = xmax * xmax + ymax * ymax
                zmax = math.sqrt(rh * rh - near2) + eps
                zmin = 0.0
                if rl > 0.0 and rl * rl > far2:
                    zmin = max(math.sqrt(rl * rl - far2) - eps, 0.0)
                zlo1 = az - zmax
                zhi1 = az - zmin
                zlo2 = az + zmin
                zhi2 = az + zmax
                nint = 2
                if zlo2 <= zhi1:
                    zhi1 = zhi2
                    nint = 1
                row = ix * ny + iy
                s, e = _row_span(keys, rowstart, use_rows, row)
                if s == e:
                    continue
                for q in range(nint):
                    zlo = zlo1 if q == 0 else zlo2
                    zhi = zhi1 if q == 0 else zhi2
                    k = _first_at_least(bs, 2, s, e, zlo)  # the column is sorted by z
                    while k < e and bs[k, 2] <= zhi:
                        dx = bs[k, 0] - ax
                        dy = bs[k, 1] - ay
                        dz = bs[k, 2] - az
                        r = math.sqrt(dx * dx + dy * dy + dz * dz)
                        if r_lo <= r <= r_hi:
                            out_i, out_j = _push(out_i, out_j, cnt, a_order[p], order[k])
                            cnt += 1
                        k += 1
    return out_i[:cnt].copy(), out_j[:cnt].copy()


def _kernels() -> dict[str, Callable[..., Any]]:
    """The compiled kernels, compiled (or loaded from numba's cache) on first use."""
    ring, shell = _COMPILED["ring"], _COMPILED["shell"]
    if ring is not None and shell is not None:
        return {"ring": ring, "shell": shell}
    if not HAVE_NUMBA:
        raise ImporterError(f"ring_pairs and shell_pairs need numba: {_PIP}")
    try:
        import numba
    except ImportError as exc:  # found but broken (e.g. an llvmlite that does not match)
        raise ImporterError(f"ring_pairs and shell_pairs need a working numba: {_PIP}") from exc
    jit = numba.njit(cache=True, nogil=True)
    # the kernels call the helpers by their global names: compiled first, put in their place
    for name in ("_first_key", "_row_span", "_first_at_least", "_gap", "_push"):
        if not hasattr(globals()[name], "py_func"):  # not compiled yet
            globals()[name] = jit(globals()[name])
    _COMPILED["ring"] = ring = jit(_ring_kernel)
    _COMPILED["shell"] = shell = jit(_shell_kernel)
    return {"ring": ring, "shell": shell}


def _points(name: str, value: Any) -> NDArray[np.float64]:
    return _checks.real_array(name, value, (None, 3), max_abs=MAX_ABS_COORDINATE)


def _band(lo_name: str, lo: Any, hi_name: str, hi: Any, *, nonnegative: bool) -> tuple[float, float]:
    if nonnegative:
        low = _checks.real_scalar(lo_name, lo, minimum=0.0, maximum=MAX_ABS_COORDINATE)
    else:
        low = _checks.real_scalar(lo_name, lo, max_abs=MAX_ABS_COORDINATE)
    high = _checks.real_scalar(hi_name, hi, max_abs=MAX_ABS_COORDINATE)
    if low > high:
        raise WorldGraphError(f"{lo_name} = {low!r} must be <= {hi_name} = {high!r}")
    return low, high


def _empty() -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    return np.empty(0, np.int64), np.empty(0, np.int64)


def _largest(points: NDArray[np.float64]) -> float:
    return float(np.abs(points).max())


def _margin(*magnitudes: float) -> float:
    """A widening of the cell ranges far above the rounding of the cell arithmetic on
    coordinates and bounds up to the largest of ``magnitudes`` (absolute values)."""
    return _RANGE_ULPS * _ULP * (1.0 + max(abs(x) for x in magnitudes))


def _grid(b: NDArray[np.float64], cell: float, zcell: float,
          min_size: float) -> tuple[NDArray[np.float64], float, float, tuple[int, int, int]]:
    """Origin, cell sizes (x and y share ``cell``) and cell counts covering ``b``.

    A size is at least ``min_size`` and 2**-24 of the extent; both are doubled until the number
    of cells (the largest key) fits an int64.
    """
    origin = b.min(axis=0)
    ex, ey, ez = (float(e) for e in b.max(axis=0) - origin)
    cell = max(cell, min_size, max(ex, ey) * 2.0**-24)
    zcell = max(zcell, min_size, ez * 2.0**-24)
    while True:
        nx, ny, nz = (int(math.floor(e / c)) + 1 for e, c in ((ex, cell), (ey, cell), (ez, zcell)))
        if float(nx) * float(ny) * float(nz) < _KEY_LIMIT:
            return origin, cell, zcell, (nx, ny, nz)
        cell, zcell = 2.0 * cell, 2.0 * zcell


def _cells(b: NDArray[np.float64], origin: NDArray[np.float64], sizes: tuple[float, float, float],
           counts: tuple[int, int, int]) -> NDArray[np.int64]:
    """Per point of ``b`` its cell index along each axis, ``(m, 3)`` int64."""
    idx = np.floor((b - origin) / np.asarray(sizes)).astype(np.int64)
    return np.clip(idx, 0, np.asarray(counts, dtype=np.int64) - 1)


_Sorted = tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.int64], NDArray[np.int64], bool]


def _sorted(b: NDArray[np.float64], rows: NDArray[np.int64], within: int, nrows: int, n: int) -> _Sorted:
    """``b`` sorted by grid row, then by coordinate ``within``; the order, the sorted row ids and
    the row-start table (when it is small enough, else the kernels binary-search the row ids)."""
    order = np.lexsort((b[:, within], rows))
    rows = rows[order]
    use_rows = nrows <= 4 * (n + len(b)) + 65536
    if use_rows:
        rowstart = np.searchsorted(rows, np.arange(nrows + 1, dtype=np.int64)).astype(np.int64)
    else:
        rowstart = np.zeros(1, np.int64)
    return np.ascontiguousarray(b[order]), order.astype(np.int64), rows, rowstart, use_rows


def _locality_order(a: NDArray[np.float64], origin: NDArray[np.float64], sizes: tuple[float, float, float],
                    counts: tuple[int, int, int], axes: tuple[int, int, int]) -> NDArray[np.int64]:
    """An order of ``a`` by the grid cells of ``b`` (the slowest axis first): consecutive rows
    visit the same cells of ``b``, which stay in the processor's cache."""
    idx = _cells(a, origin, sizes, counts)
    return np.lexsort((a[:, axes[2]], idx[:, axes[1]], idx[:, axes[0]])).astype(np.int64)


def _ring_cell(h_lo: float, h_hi: float, z_lo: float, z_hi: float,
               cell: float | None) -> tuple[float, float]:
    if cell is None:
        # cost per row ~ (binary searches ~ h_hi / cell) + (candidates ~ h_hi * (width + cell));
        # about h_hi / 4 wins for thin rings (docs/design.md#defaults)
        cell = max(h_hi / 4.0, 2.0 * (h_hi - h_lo))
    return cell, max(z_hi - z_lo, cell / 8.0)


def ring_pairs(a: Any, b: Any, *, h_lo: float, h_hi: float, z_lo: float, z_hi: float,
               _cell: float | None = None) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Every pair ``(i, j)`` of rows of ``a`` and ``b`` in a horizontal ring and a height band.

    A pair is returned when ``h_lo <= hypot(b[j,0] - a[i,0], b[j,1] - a[i,1]) <= h_hi`` and
    ``z_lo <= b[j,2] - a[i,2] <= z_hi`` (inclusive, in float64 exactly as written), through a
    compiled grid join (numba).

    Parameters
    ----------
    a : (n, 3) array_like of float
        First points (m); finite, ``|x| <= 1e12``.
    b : (m, 3) array_like of float
        Second points (m); may be the same array as ``a`` (then ``i == j`` pairs appear when
        the ring contains 0 and the band contains 0).
    h_lo, h_hi : float
        Horizontal distance band (m), ``0 <= h_lo <= h_hi``.
    z_lo, z_hi : float
        Height offset band ``b_z - a_z`` (m), ``z_lo <= z_hi``.

    Returns
    -------
    i, j : (k,) ndarray of int64
        Row indices into ``a`` and ``b`` of every such pair, in no particular order.

    Raises
    ------
    ImporterError
        numba is not installed (``pip install numba``).
    WorldGraphError
        A bad array (naming the argument, index and value) or bound (``h_lo < 0``,
        ``lo > hi``, non-finite).
    """
    pa, pb = _points("a", a), _points("b", b)
    h_lo, h_hi = _band("h_lo", h_lo, "h_hi", h_hi, nonnegative=True)
    z_lo, z_hi = _band("z_lo", z_lo, "z_hi", z_hi, nonnegative=False)
    kernel = _kernels()["ring"]
    if len(pa) == 0 or len(pb) == 0:
        return _empty()
    if len(pa) < len(pb):
        # the grid goes on the smaller side (sorting it is the per-call cost; rows of the larger
        # side that miss its extent cost O(1)); b - a = -(a - b) exactly in float64, so the
        # swapped join with the negated height band gives the same pairs
        j, i = _ring(pb, pa, h_lo, h_hi, -z_hi, -z_lo, _cell, kernel)
        return i, j
    return _ring(pa, pb, h_lo, h_hi, z_lo, z_hi, _cell, kernel)


def _ring(pa: NDArray[np.float64], pb: NDArray[np.float64], h_lo: float, h_hi: float, z_lo: float,
          z_hi: float, _cell: float | None, kernel: Callable[..., Any]
          ) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    eps = _margin(_largest(pa), _largest(pb), h_hi, z_lo, z_hi)
    cell, zcell = _ring_cell(h_lo, h_hi, z_lo, z_hi, _cell)
    grid = _ring_grid(pb, cell, zcell, 1e3 * eps, len(pa))
    sizes = (grid.cell, grid.cell, grid.zcell)
    a_order = _locality_order(pa, grid.origin, sizes, (grid.nx, grid.ny, grid.nz), (0, 2, 1))
    return _ring_join(kernel, pa[a_order], a_order, grid, (h_lo, h_hi, z_lo, z_hi), eps, None)


def _ring_join(kernel: Callable[..., Any], pa: NDArray[np.float64], a_order: NDArray[np.int64],
               grid: RingGrid, bounds: tuple[float, float, float, float], eps: float,
               b_mask: NDArray[np.bool_] | None) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The ring kernel on rows ``pa`` (row ``k`` reported as ``a_order[k]``) against ``grid``."""
    return kernel(pa, a_order, grid.sorted_points, grid.order, grid.keys, grid.rowstart, grid.use_rows,
                  grid.origin, grid.cell, grid.zcell, grid.nx, grid.nz, *bounds, eps,
                  _NO_MASK if b_mask is None else b_mask, b_mask is not None)


_NO_MASK = np.zeros(1, dtype=bool)

#: Cell sizes (m) of the grids kept with a world (:meth:`WorldModel.type_grid`): 2 m columns
#: suit rings of 5-16 m (6-17 columns per point), 0.5 m bands the height bands of 0.1-0.7 m
#: (docs/design.md#defaults).
KEPT_GRID_CELL = 2.0
KEPT_GRID_ZCELL = 0.5


@dataclass(frozen=True, eq=False)
class RingGrid:
    """Points bucketed once for many :func:`ring_pairs_in` calls (one type's objects, kept with
    the world like its k-d trees): columns of width ``cell`` in x and bands of ``zcell`` in z,
    the points sorted by (column, band) and by y within, as :func:`ring_pairs` builds them per
    call."""

    origin: NDArray[np.float64]
    cell: float
    zcell: float
    nx: int
    ny: int
    nz: int
    sorted_points: NDArray[np.float64]
    order: NDArray[np.int64]
    keys: NDArray[np.int64]
    rowstart: NDArray[np.int64]
    use_rows: bool
    largest: float  # the largest |coordinate|

    def __len__(self) -> int:
        return len(self.order)


def ring_grid(points: Any, *, cell: float = KEPT_GRID_CELL, zcell: float = KEPT_GRID_ZCELL) -> RingGrid:
    """A :class:`RingGrid` of ``points`` ((m, 3) finite floats) with columns of ``cell`` and
    bands of ``zcell`` metres (both > 0)."""
    pb = _points("points", points)
    cell = _checks.real_scalar("cell", cell, positive=True, maximum=MAX_ABS_COORDINATE)
    zcell = _checks.real_scalar("zcell", zcell, positive=True, maximum=MAX_ABS_COORDINATE)
    if len(pb) == 0:
        empty = np.zeros(0, np.int64)
        return RingGrid(np.zeros(3), cell, zcell, 1, 1, 1, np.zeros((0, 3)), empty, empty,
                        np.zeros(2, np.int64), True, 0.0)
    return _ring_grid(pb, cell, zcell, 1e3 * _margin(_largest(pb)), len(pb))


def _ring_grid(pb: NDArray[np.float64], cell: float, zcell: float, min_size: float, n_rows: int) -> RingGrid:
    """The grid of ``pb`` (non-empty) with cells of at least ``min_size``; a row-start table when
    it is small against ``n_rows`` (the rows to join) and the points."""
    origin, cx, cz, (nx, ny, nz) = _grid(pb, cell, zcell, min_size)
    idx = _cells(pb, origin, (cx, cx, cz), (nx, ny, nz))
    bs, order, keys, rowstart, use_rows = _sorted(pb, idx[:, 0] * nz + idx[:, 2], 1, nx * nz, n_rows)
    return RingGrid(origin, cx, cz, nx, ny, nz, bs, order, keys, rowstart, use_rows, _largest(pb))


def ring_pairs_in(a: Any, grid: RingGrid, *, h_lo: float, h_hi: float, z_lo: float, z_hi: float,
                  b_mask: Any = None) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """:func:`ring_pairs` of ``a`` against the points of a kept :class:`RingGrid` (``j`` indexes
    the points the grid was built from), only those where ``b_mask`` (bool, one per point) is
    True when given: no sort per call."""
    if not isinstance(grid, RingGrid):
        raise WorldGraphError(f"grid must be a RingGrid, got {type(grid).__name__}")
    pa = _points("a", a)
    h_lo, h_hi = _band("h_lo", h_lo, "h_hi", h_hi, nonnegative=True)
    z_lo, z_hi = _band("z_lo", z_lo, "z_hi", z_hi, nonnegative=False)
    if b_mask is not None:
        b_mask = np.asarray(b_mask)
        if b_mask.dtype != np.bool_ or b_mask.shape != (len(grid),):
            raise WorldGraphError(f"b_mask must be a bool array of shape ({len(grid)},), got dtype "
                                  f"{b_mask.dtype} and shape {b_mask.shape}")
    kernel = _kernels()["ring"]
    if len(pa) == 0 or len(grid) == 0:
        return _empty()
    eps = _margin(_largest(pa), grid.largest, h_hi, z_lo, z_hi)
    return _ring_join(kernel, pa, np.arange(len(pa), dtype=np.int64), grid, (h_lo, h_hi, z_lo, z_hi), eps,
                      b_mask)


def shell_pairs(a: Any, b: Any, *, r_lo: float, r_hi: float,
                _cell: float | None = None) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Every pair ``(i, j)`` of rows of ``a`` and ``b`` whose 3D distance lies in a shell.

    A pair is returned when ``r_lo <= sqrt(dx*dx + dy*dy + dz*dz) <= r_hi`` with
    ``(dx, dy, dz) = b[j] - a[i]`` (inclusive, float64 exactly as written), through a compiled
    grid join (numba).

    Parameters
    ----------
    a : (n, 3) array_like of float
        First points (m); finite, ``|x| <= 1e12``.
    b : (m, 3) array_like of float
        Second points (m); may be the same array as ``a``.
    r_lo, r_hi : float
        Distance band (m), ``0 <= r_lo <= r_hi``.

    Returns
    -------
    i, j : (k,) ndarray of int64
        Row indices into ``a`` and ``b`` of every such pair, in no particular order.

    Raises
    ------
    ImporterError
        numba is not installed (``pip install numba``).
    WorldGraphError
        A bad array (naming the argument, index and value) or bound.
    """
    pa, pb = _points("a", a), _points("b", b)
    r_lo, r_hi = _band("r_lo", r_lo, "r_hi", r_hi, nonnegative=True)
    kernel = _kernels()["shell"]
    if len(pa) == 0 or len(pb) == 0:
        return _empty()
    if len(pa) < len(pb):  # the grid on the smaller side, as in ring_pairs
        j, i = _shell(pb, pa, r_lo, r_hi, _cell, kernel)
        return i, j
    return _shell(pa, pb, r_lo, r_hi, _cell, kernel)


def _shell(pa: NDArray[np.float64], pb: NDArray[np.float64], r_lo: float, r_hi: float,
           _cell: float | None, kernel: Callable[..., Any]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    eps = _margin(_largest(pa), _largest(pb), r_hi)
    cell = _cell if _cell is not None else max(r_hi / 4.0, 2.0 * (r_hi - r_lo))
    origin, c, cz, (nx, ny, nz) = _grid(pb, cell, cell, 1e3 * eps)
    while c != cz:  # cubic cells: both the larger
        origin, c, cz, (nx, ny, nz) = _grid(pb, max(c, cz), max(c, cz), 1e3 * eps)
    idx = _cells(pb, origin, (c, c, c), (nx, ny, nz))
    bs, order, keys, rowstart, use_rows = _sorted(pb, idx[:, 0] * ny + idx[:, 1], 2, nx * ny, len(pa))
    a_order = _locality_order(pa, origin, (c, c, c), (nx, ny, nz), (0, 1, 2))
    return kernel(pa[a_order], a_order, bs, order, keys, rowstart, use_rows, origin, c, nx, ny, nz,
                  r_lo, r_hi, eps)
