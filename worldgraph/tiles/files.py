"""Tile files: a split map written one file per tile plus a small index, so that no process needs
the whole map (:func:`save_tiles`, :func:`read_index`, :func:`load_tile`).

A folder holds ``index.npz`` and ``tile-<label>.npz`` per tile.  A tile file is the binary world
file of the tile's world (:mod:`worldgraph.model.binary_files`: columnar numpy arrays, link tables
included, read without unpickling) with three more entries: ``tile_label``, ``tile_index`` (the
global object index of each tile object) and ``tile_own`` (its own objects, not the halo).  The
index holds, per tile, what :func:`~worldgraph.tiles.tiles_to_visit` needs
(:class:`~worldgraph.tiles.TileSummary`: label, object count, bounds, objects per type, the link
reach and the occupied link-length bins per type pair, as bit sets) and the tile's file name.

A site too large for one process is written tile by tile: :func:`save_tiles` takes any iterable
of tiles (a generator that builds each tile and lets it go), and :func:`append_tiles` adds tiles
to a folder written before.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .. import _checks
from ..errors import MalformedFileError, WorldGraphError
from ..model import WorldModel
from ..model.binary_files import load_binary, read_entries, world_arrays, write_entries
from .prefilter import LINK_BIN, TileSummary, summarize
from .tiling import Tile

__all__ = ["INDEX_FILE", "TileEntry", "TileIndex", "append_tiles", "load_tile", "read_index", "save_tiles"]

#: The index file of a tile folder.
INDEX_FILE = "index.npz"
#: ``format`` entry of an index file.
INDEX_FORMAT = "worldgraph.tiles.index"
INDEX_VERSION = 1
#: The entries a tile file adds to the binary world file.
TILE_ENTRIES = ("tile_label", "tile_index", "tile_own")


@dataclass(frozen=True)
class TileEntry:
    """One tile of an index: its label, its file and its pre-filter summary."""

    label: int
    path: str
    summary: TileSummary


@dataclass(frozen=True)
class TileIndex:
    """The index of a tile folder (:func:`read_index`)."""

    folder: str
    tiles: tuple[TileEntry, ...]


def _tile_file(label: int) -> str:
    return f"tile-{label}.npz"


def _write_tile(tile: Tile, path: str) -> None:
    arrays = world_arrays(tile.world)
    arrays["tile_label"] = np.array(tile.label, dtype=np.int64)
    arrays["tile_index"] = np.asarray(tile.index, dtype=np.int64)
    arrays["tile_own"] = np.asarray(tile.own, dtype=bool)
    write_entries(path, arrays)


def load_tile(path: str | os.PathLike[str]) -> Tile:
    """The :class:`~worldgraph.tiles.Tile` of a tile file (what a worker runs to hold its tile).

    Raises
    ------
    MalformedFileError
        The file is missing, unreadable, corrupt or not a tile file (it is named).
    """
    path = _checks.file_path("path", path)
    data = read_entries(path, extra=TILE_ENTRIES)
    for key in TILE_ENTRIES:
        if key not in data:
            raise MalformedFileError(f"{path}: missing entry {key!r}: not a tile file (a world file?)")
    world = load_binary(WorldModel, path, data)
    n = len(world)
    label, index, own = data["tile_label"], data["tile_index"], data["tile_own"]
    if label.shape != () or label.dtype.kind not in "iu" or int(label) < 0:
        raise MalformedFileError(f"{path}: entry 'tile_label' must be one integer >= 0, got {label!r:.80}")
    if index.shape != (n,) or index.dtype.kind not in "iu" or (n and int(index.min()) < 0):
        raise MalformedFileError(f"{path}: entry 'tile_index' must hold {n} integers >= 0 (one per object)")
    if n > 1 and (np.diff(index) <= 0).any():
        raise MalformedFileError(f"{path}: entry 'tile_index' must be strictly ascending (global order)")
    if own.shape != (n,) or own.dtype != bool:
        raise MalformedFileError(f"{path}: entry 'tile_own' must hold {n} booleans (one per object)")
    index = index.astype(np.intp)
    index.setflags(write=False)
    own = own.copy()
    own.setflags(write=False)
    return Tile(world, index, int(label), own)


# ----------------------------------------------------------------------------------------------
# index
# ----------------------------------------------------------------------------------------------
def _pack_bins(summary: TileSummary, pairs: list[tuple[str, str]], n_bins: int) -> NDArray[np.uint8]:
    bits = np.zeros((len(pairs), n_bins), dtype=bool)
    for p, key in enumerate(pairs):
        occupied = summary.link_bins.get(key)
        if occupied is not None and occupied.size:
            bits[p, occupied[occupied < n_bins]] = True
    return np.packbits(bits, axis=1)


def _write_index(folder: str, summaries: list[TileSummary], files: list[str]) -> None:
    types = sorted({t for s in summaries for t in s.type_counts})
    pairs = sorted({key for s in summaries for key in s.link_bins})
    bin_width = summaries[0].bin_width if summaries else LINK_BIN
    n_bins = max([int(b.max()) + 1 for s in summaries for b in s.link_bins.values() if b.size] + [1])
    t_code = {t: k for k, t in enumerate(types)}
    counts = np.zeros((len(summaries), len(types)), dtype=np.int64)
    for i, s in enumerate(summaries):
        for t, c in s.type_counts.items():
            counts[i, t_code[t]] = c
    arrays = {
        "format": np.array(INDEX_FORMAT), "version": np.array(INDEX_VERSION),
        "labels": np.array([s.label for s in summaries], dtype=np.int64),
        "files": np.array(files, dtype=np.str_),
        "n_objects": np.array([s.n_objects for s in summaries], dtype=np.int64),
        "lower": np.array([s.lower for s in summaries], dtype=np.float64).reshape(-1, 3),
        "upper": np.array([s.upper for s in summaries], dtype=np.float64).reshape(-1, 3),
        "reach": np.array([s.reach for s in summaries], dtype=np.float64),
        "bin_width": np.array(bin_width, dtype=np.float64),
        "types": np.array(types, dtype=np.str_), "type_counts": counts,
        "pair_a": np.array([a for a, _ in pairs], dtype=np.str_), "pair_b": np.array([b for _, b in pairs],
                                                                                     dtype=np.str_),
        "n_bins": np.array(n_bins, dtype=np.int64),
        "bins": np.array([_pack_bins(s, pairs, n_bins) for s in summaries], dtype=np.uint8).reshape(
            len(summaries), len(pairs), -1),
    }
    write_entries(os.path.join(folder, INDEX_FILE), arrays)


def read_index(folder: str | os.PathLike[str]) -> TileIndex:
    """The :class:`TileIndex` of a folder written by :func:`save_tiles`.

    Raises
    ------
    MalformedFileError
        No index, or an unreadable or inconsistent one (the file is named).
    """
    folder = _checks.file_path("folder", folder)
    path = os.path.join(folder, INDEX_FILE)
    if not os.path.isfile(path):
        raise MalformedFileError(f"{path}: no tile index (write the folder with worldgraph.tiles.save_tiles)")
    try:
        with np.load(path, allow_pickle=False) as data:
            d = {k: data[k] for k in data.files}
    except Exception as exc:  # noqa: BLE001 - any failure of the archive is a malformed index
        raise MalformedFileError(f"{path}: not a readable tile index: {type(exc).__name__}: {exc}") from exc
    try:
        if str(d["format"]) != INDEX_FORMAT or int(d["version"]) != INDEX_VERSION:
            raise MalformedFileError(f"{path}: format {str(d['format'])!r} version {int(d['version'])}, "
                                     f"this reader reads {INDEX_FORMAT!r} version {INDEX_VERSION}")
        labels, files = d["labels"], d["files"]
        n = len(labels)
        types = [str(t) for t in d["types"]]
        pairs = list(zip((str(a) for a in d["pair_a"]), (str(b) for b in d["pair_b"]), strict=True))
        n_bins, bin_width = int(d["n_bins"]), float(d["bin_width"])
        bits = np.unpackbits(d["bins"], axis=2, count=n_bins).astype(bool) if n else np.zeros((0, 0, 0), bool)
        entries = []
        for i in range(n):
            counts = {t: int(c) for t, c in zip(types, d["type_counts"][i], strict=True) if c > 0}
            link_bins = {key: np.flatnonzero(bits[i, p]).astype(np.int64) for p, key in enumerate(pairs)
                         if bits[i, p].any()}
            summary = TileSummary(int(labels[i]), int(d["n_objects"][i]), d["lower"][i].copy(),
                                  d["upper"][i].copy(), counts, float(d["reach"][i]), bin_width, link_bins)
            entries.append(TileEntry(int(labels[i]), os.path.join(folder, str(files[i])), summary))
    except MalformedFileError:
        raise
    except (KeyError, IndexError, ValueError, TypeError) as exc:
        raise MalformedFileError(f"{path}: an inconsistent tile index: {type(exc).__name__}: {exc}") from exc
    return TileIndex(folder, tuple(entries))


def save_tiles(tiles: Iterable[Tile], folder: str | os.PathLike[str]) -> TileIndex:
    """Write ``tiles`` to ``folder`` (created if needed): one file per tile, then the index.

    ``tiles`` may be any iterable, e.g. a generator that builds one tile at a time: each tile is
    written and let go before the next, so the whole map is never in this process.  An existing
    index in the folder is replaced (use :func:`append_tiles` to add to it).
    """
    folder = _checks.file_path("folder", folder)
    try:
        os.makedirs(folder, exist_ok=True)
    except OSError as exc:
        raise WorldGraphError(f"{folder}: cannot create the folder: {exc}") from exc
    return _write_tiles(tiles, folder, [], [])


def append_tiles(tiles: Iterable[Tile], folder: str | os.PathLike[str]) -> TileIndex:
    """Add ``tiles`` to a folder written by :func:`save_tiles` (their labels must be new)."""
    index = read_index(folder)
    return _write_tiles(tiles, index.folder, [e.summary for e in index.tiles],
                        [os.path.basename(e.path) for e in index.tiles])


def _write_tiles(tiles: Iterable[Tile], folder: str, summaries: list[TileSummary], files: list[str]
                 ) -> TileIndex:
    if isinstance(tiles, Tile | str | bytes) or not isinstance(tiles, Iterable):
        raise WorldGraphError(f"tiles must be an iterable of Tile, got {_checks._short(tiles)}")
    labels = {s.label for s in summaries}
    for k, tile in enumerate(tiles):
        if not isinstance(tile, Tile):
            raise WorldGraphError(f"tiles[{k}] must be a Tile (from worldgraph.tiles.tiling), "
                                  f"got {_checks._short(tile)}")
        if tile.label in labels:
            raise WorldGraphError(f"tiles[{k}]: label {tile.label} is already in {folder}")
        labels.add(tile.label)
        name = _tile_file(tile.label)
        _write_tile(tile, os.path.join(folder, name))
        summaries.append(summarize(tile))
        files.append(name)
    if not summaries:
        raise WorldGraphError(f"tiles is empty: no tile to write to {folder} (no index written)")
    _write_index(folder, summaries, files)
    return TileIndex(folder, tuple(TileEntry(sm.label, os.path.join(folder, f), sm)
                                   for sm, f in zip(summaries, files, strict=True)))
