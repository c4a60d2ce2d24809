"""Tiles of a world: :class:`Tile` and :func:`split` (one tile per label, with a halo), and the
check of a tile sequence."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from .. import _checks
from ..errors import WorldGraphError
from ..model import WorldModel
from ..tolerances import HALO_SLACK

#: Most tiles :func:`split` makes.
MAX_TILES = 100_000


@dataclass(frozen=True, eq=False)
class Tile:
    """One tile of a world.

    Attributes
    ----------
    world : WorldModel
        The tile's objects (its own and its halo), in ascending global order.
    index : (m,) int
        Global object index of each tile object (``index[k]`` is tile object ``k``), read-only.
    label : int
        The label whose objects the tile holds.
    own : (m,) bool
        True for the tile's own objects, False for halo objects of other labels, read-only.
    """

    world: WorldModel
    index: NDArray[np.intp]
    label: int
    own: NDArray[np.bool_]

    def __sizeof__(self) -> int:  # Dask weighs an object by sys.getsizeof before it moves it
        return object.__sizeof__(self) + self.world.__sizeof__() + int(self.index.nbytes + self.own.nbytes)


def _halo_members(positions: NDArray[np.float64], own: NDArray[np.intp], others: NDArray[np.intp],
                  halo: float) -> NDArray[np.intp]:
    """Objects of ``others`` within ``halo`` of an object of ``own`` (a box prefilter, then one
    nearest-neighbour query per candidate in a k-d tree of the own objects)."""
    if halo <= 0 or not others.size:
        return np.zeros(0, np.intp)
    p_own = positions[own]
    lo, hi = p_own.min(axis=0) - halo, p_own.max(axis=0) + halo
    p = positions[others]
    near = others[np.all((p >= lo) & (p <= hi), axis=1)]
    if not near.size:
        return near
    dist, _ = cKDTree(p_own).query(positions[near], k=1, distance_upper_bound=halo * (1 + HALO_SLACK))
    return near[dist <= halo]


def split(world: WorldModel, labels: ArrayLike, halo: float = 0.0) -> tuple[Tile, ...]:
    """Tiles of ``world``, one per distinct label, in ascending label order.

    Parameters
    ----------
    world : WorldModel
    labels : (n,) int
        One integer label per object of ``world`` (``>= 0``), e.g. :meth:`Site.labels
        <worldgraph.scenes.Site.labels>`; at most :data:`MAX_TILES` distinct labels.
    halo : float
        Metres, ``>= 0``: a tile also holds every object of another label within ``halo`` of
        one of its own objects (Euclidean distance).

    Returns
    -------
    tuple of Tile
        Each with the world's link settings and room.
    """
    if not isinstance(world, WorldModel):
        raise WorldGraphError(f"world must be a WorldModel, got {_checks._short(world)}")
    n = len(world)
    lab = _checks.int_array("labels", labels, (n,), minimum=0)
    halo = _checks.real_scalar("halo", halo, minimum=0.0)
    names, codes = np.unique(lab, return_inverse=True)
    if len(names) > MAX_TILES:
        raise WorldGraphError(f"labels must hold at most {MAX_TILES} distinct values, got {len(names)}")
    order = np.argsort(codes, kind="stable")
    starts = np.searchsorted(codes[order], np.arange(len(names) + 1))
    every = np.arange(n)
    tiles = []
    for c, label in enumerate(names.tolist()):
        own = order[starts[c]:starts[c + 1]]
        extra = _halo_members(world.positions, own, every[codes != c] if halo > 0 else every[:0], halo)
        index = np.union1d(own, extra).astype(np.intp)
        is_own = codes[index] == c
        sub = world.take(index)
        index.setflags(write=False)
        is_own.setflags(write=False)
        tiles.append(Tile(sub, index, int(label), is_own))
    return tuple(tiles)


def _check_tiles(tiles: object) -> tuple[Tile, ...]:
    items = _checks.as_list("tiles", tiles, "Tile (from worldgraph.tiles.tiling)")
    if not items:
        raise WorldGraphError("tiles must hold at least one Tile, got none")
    for k, t in enumerate(items):
        if not isinstance(t, Tile):
            raise WorldGraphError(f"tiles[{k}] must be a Tile (from worldgraph.tiles.tiling), "
                                  f"got {_checks._short(t)}")
    return tuple(items)
