"""Far object pairs of a world model, beyond its link table: :class:`FarPairIndex` (the pairs of
one type pair up to :data:`FAR_PAIR_RANGE` apart, sorted by distance), how they are estimated
and built, and the budgets (:data:`FAR_PAIR_MAX_PAIRS`, :data:`FAR_PAIR_BUDGET`,
:data:`FAR_PAIR_BUILD_ON_USE`); :meth:`WorldModel.far_pairs
<worldgraph.model.WorldModel.far_pairs>` and :meth:`WorldModel.build_far_pairs
<worldgraph.model.WorldModel.build_far_pairs>` call them."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from ..tolerances import FAR_PAIR_SLACK, QUERY_WIDEN

#: :meth:`WorldModel.far_pairs` holds the pairs up to this far apart (m): two 8 m sensor ranges.
FAR_PAIR_RANGE = 16.0
#: ... and, gravity-aligned, up to this far apart in z (m): the objects of one storey.
FAR_PAIR_HEIGHT = 4.0
#: The association builds a missing far-pair index on first use when True; by default (False)
#: it uses only those built (:meth:`WorldModel.build_far_pairs`) and sends the other far pairs
#: to the compiled ring join (see ``WorldModel._far_pair_index`` for the measurements).
FAR_PAIR_BUILD_ON_USE = False
#: One far-pair index holds at most this many pairs (about 16 bytes each) ...
FAR_PAIR_MAX_PAIRS = 30_000_000
#: ... and the indices of one world at most this many together (about 770 MB; beyond: k-d tree
#: queries): a 100k-object building holds all its type pairs (34M pairs), a 1M campus a part.
FAR_PAIR_BUDGET = 48_000_000


@dataclass(frozen=True)
class FarPairIndex:
    """Ordered pairs ``(i[k], j[k])`` (global indices of a type-a and a type-b object, no object
    with itself) sorted by ``key``: the distance, or gravity-aligned the horizontal distance
    with ``dz = z[j] - z[i]``.  float32 keys: callers widen their windows by
    :data:`FAR_PAIR_SLACK` and test the candidates again in float64."""

    key: NDArray[np.float32]
    i: NDArray[np.int32]
    j: NDArray[np.int32]
    dz: NDArray[np.float32] | None

    @property
    def gravity_aligned(self) -> bool:
        """Keyed by the horizontal distance (with ``dz``), not the 3D distance."""
        return self.dz is not None

    def window(self, lo: float, hi: float) -> slice:
        """The slice of the pairs with ``lo - slack <= key <= hi + slack``."""
        # float32 bounds: a float64 one would make numpy convert the whole key array
        a = int(np.searchsorted(self.key, np.float32(lo - FAR_PAIR_SLACK), side="left"))
        b = int(np.searchsorted(self.key, np.float32(hi + FAR_PAIR_SLACK), side="right"))
        return slice(a, max(a, b))


def _far_pair_query(gravity: bool) -> tuple[float, float]:
    """``(z scale, radius)`` of the k-d tree query that holds every far pair."""
    scale = FAR_PAIR_RANGE / FAR_PAIR_HEIGHT if gravity else 1.0
    return scale, FAR_PAIR_RANGE * (math.sqrt(2.0) if gravity else 1.0) * (1.0 + QUERY_WIDEN)


def _far_pair_estimate(world: Any, a: str, b: str, gravity: bool) -> float:
    """How many pairs the query of ``_build_far_pairs`` returns, from a strided sample of
    ``a``'s objects (at most about 2000), before anything is built (kept with the world:
    :meth:`WorldModel.build_far_pairs` orders by it, then each build checks it)."""
    estimates = world._far_estimates
    if (a, b, gravity) not in estimates:
        scale, radius = _far_pair_query(gravity)
        ta, tb = world.type_tree(a, scale), world.type_tree(b, scale)
        stride = max(1, len(ta.data) // 2000)
        estimates[(a, b, gravity)] = float(cKDTree(ta.data[::stride]).count_neighbors(tb, radius)) * stride
    return estimates[(a, b, gravity)]


#: Objects per block of ``_far_type_pairs``' pair enumeration (bounds its memory).
FAR_TYPE_BLOCK = 2048


def _far_type_pairs(world: Any, gravity: bool) -> list[tuple[str, str]]:
    """The type pairs ``(a, b)``, ``a <= b``, with two distinct objects inside the far-pair
    query of each other (``_far_pair_query``): the only ones whose :class:`FarPairIndex`
    is not empty.  One k-d tree over all objects, queried in blocks of :data:`FAR_TYPE_BLOCK`
    objects; its cost follows the object pairs within reach, not the number of type pairs."""
    names = sorted(world.type_index)
    n_types = len(names)
    code = np.empty(len(world), dtype=np.int64)
    for k, t in enumerate(names):
        code[world.type_index[t]] = k
    scale, radius = _far_pair_query(gravity)
    pts = world.positions * np.array([1.0, 1.0, scale])
    tree = cKDTree(pts)
    found: set[int] = set()
    for start in range(0, len(pts), FAR_TYPE_BLOCK):
        near = cKDTree(pts[start:start + FAR_TYPE_BLOCK]).sparse_distance_matrix(tree, radius,
                                                                                  output_type="ndarray")
        i, j = near["i"].astype(np.int64) + start, near["j"].astype(np.int64)
        keep = i != j
        ca, cb = code[i[keep]], code[j[keep]]
        found.update(np.unique(np.minimum(ca, cb) * n_types + np.maximum(ca, cb)).tolist())
    return [(names[k // n_types], names[k % n_types]) for k in sorted(found)]


def _empty_far_pairs(gravity: bool) -> FarPairIndex:
    """The index of a type pair without objects in reach of each other."""
    return FarPairIndex(key=np.zeros(0, np.float32), i=np.zeros(0, np.int32), j=np.zeros(0, np.int32),
                        dz=np.zeros(0, np.float32) if gravity else None)


def _build_far_pairs(world: Any, a: str, b: str, gravity: bool) -> FarPairIndex | None:
    """The :class:`FarPairIndex` of types ``a <= b`` (see :meth:`WorldModel.far_pairs`)."""
    # gravity: z scaled so that the ball of radius R sqrt(2) holds every pair with horizontal
    # distance <= R and |dz| <= H; then the exact box is kept
    scale, radius = _far_pair_query(gravity)
    ta, tb = world.type_tree(a, scale), world.type_tree(b, scale)
    ia, ib = world.indices_of(a), world.indices_of(b)
    estimate = _far_pair_estimate(world, a, b, gravity)
    used = world._far_pairs_held[0]  # the pairs the cache holds (a running total, not a sum)
    if estimate > FAR_PAIR_MAX_PAIRS or used + estimate > FAR_PAIR_BUDGET:
        return None
    pairs = ta.sparse_distance_matrix(tb, radius, output_type="ndarray")
    gi, gj = ia[pairs["i"]], ib[pairs["j"]]
    pos = world.positions
    if gravity:
        dv = pos[gj] - pos[gi]
        key = np.hypot(dv[:, 0], dv[:, 1])
        keep = (key <= FAR_PAIR_RANGE) & (np.abs(dv[:, 2]) <= FAR_PAIR_HEIGHT) & (gi != gj)
        dz = dv[keep, 2]
    else:
        key = pairs["v"]
        keep = gi != gj
        dz = None
    key = key[keep]
    order = np.argsort(key, kind="stable")
    return FarPairIndex(key=key[order].astype(np.float32), i=gi[keep][order].astype(np.int32),
                        j=gj[keep][order].astype(np.int32),
                        dz=None if dz is None else dz[order].astype(np.float32))


def _world_far_pair_index(world: Any, type_a: str, type_b: str, gravity: bool, lazy: bool = False
                          ) -> tuple[FarPairIndex | None, bool]:
    """The body of :meth:`WorldModel._far_pair_index <worldgraph.model.WorldModel._far_pair_index>`
    (see there); ``world`` is a :class:`~worldgraph.model.WorldModel` (not imported: the world
    module imports this one)."""
    flip = type_a > type_b
    a, b = (type_b, type_a) if flip else (type_a, type_b)
    cache = world._far_pairs
    key = (a, b, gravity)
    if key not in cache:
        if gravity in world._far_pairs_complete:  # build_far_pairs found no objects in reach
            return _empty_far_pairs(gravity), flip
        if lazy and not FAR_PAIR_BUILD_ON_USE:
            return None, flip
        index = cache[key] = _build_far_pairs(world, a, b, gravity)
        if index is not None:
            world._far_pairs_held[0] += len(index.key)
    return cache[key], flip


def _build_world_far_pairs(world: Any, gravity: bool) -> int:
    """The body of :meth:`WorldModel.build_far_pairs <worldgraph.model.WorldModel.build_far_pairs>`
    after its argument check (see there); ``world`` is a :class:`~worldgraph.model.WorldModel`
    (not imported: the world module imports this one)."""
    pairs = _far_type_pairs(world, gravity)
    sizes = [_far_pair_estimate(world, a, b, gravity) for a, b in pairs]
    for _, (a, b) in sorted(zip(sizes, pairs, strict=True)):
        world.far_pairs(a, b, gravity)
    world._far_pairs_complete.add(gravity)
    return world._far_pairs_held[0]
