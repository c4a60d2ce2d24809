"""Worker processes that keep a split world's tiles between calls: :class:`TilePool`."""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor

from .. import _checks
from ..errors import WorldGraphError
from .ranking import _run_tile, _TileAnswer, _TileQuery
from .tiling import Tile, _check_tiles

#: Tiles handed to forked worker processes by reference (no pickling of the worlds): a
#: :class:`TilePool` registers them under a token before it forks and removes them on close.
_SHARED: dict[int, tuple[Tile, ...]] = {}


def _run_shared(token: int, k: int, query: _TileQuery) -> _TileAnswer:
    return _run_tile(_SHARED[token][k].world, query)


class TilePool:
    """Worker processes that keep a split world's tiles between :func:`localize_tiled` calls.

    :func:`localize_tiled` without a pool forks its workers on every call (about half a second
    for the five storeys of a 100k building); a pool forks them once, on its first call, and
    each later call sends only the percepts and receives the answers.  Use it as a context
    manager, or call :meth:`close`::

        with TilePool(tiles, workers=2) as pool:
            for percepts in scans:
                result = localize_tiled(tiles, percepts, pool=pool)

    Parameters
    ----------
    tiles : sequence of Tile
        From :func:`split`; the pool serves these tiles only (the same sequence object, or one
        with the same Tile objects in the same order).
    workers : int, optional
        Processes (default ``min(len(tiles), os.cpu_count())``, at least 1).

    Raises
    ------
    WorldGraphError
        Bad tiles or workers, or a platform without the ``fork`` start method (there, every
        call pickles the tiles anyway: use :func:`localize_tiled` without a pool).
    """

    def __init__(self, tiles: Sequence[Tile], workers: int | None = None) -> None:
        self.tiles = _check_tiles(tiles)
        if workers is not None:
            workers = _checks.integer("workers", workers, minimum=1, maximum=1024)
        if "fork" not in multiprocessing.get_all_start_methods():  # pragma: no cover - spawn-only
            raise WorldGraphError("TilePool needs the 'fork' start method (Linux, macOS): use "
                                  "localize_tiled without pool on this platform")
        self.workers = min(len(self.tiles), workers or os.cpu_count() or 1)
        self._token = id(self)
        # registered before the executor forks its workers (on its first task), kept until close
        _SHARED[self._token] = self.tiles
        self._executor: ProcessPoolExecutor | None = ProcessPoolExecutor(
            self.workers, mp_context=multiprocessing.get_context("fork"))

    def serves(self, tiles: Sequence[Tile]) -> bool:
        """Whether ``tiles`` are the tiles of this pool (the same Tile objects, in order)."""
        return len(tiles) == len(self.tiles) and all(a is b for a, b in zip(tiles, self.tiles, strict=True))

    @property
    def closed(self) -> bool:
        """True after :meth:`close`."""
        return self._executor is None

    def _map(self, queries: list[_TileQuery]) -> list[_TileAnswer]:
        """Tile ``k``'s answer to ``queries[k]``, for every tile."""
        if self._executor is None:
            raise WorldGraphError("pool is closed (TilePool.close was called): make a new TilePool")
        return list(self._executor.map(_run_shared, [self._token] * len(self.tiles), range(len(self.tiles)),
                                       queries))

    def close(self) -> None:
        """Stop the workers (idempotent)."""
        if self._executor is not None:
            self._executor.shutdown(wait=True)
            self._executor = None
        _SHARED.pop(self._token, None)

    def __enter__(self) -> TilePool:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        state = "closed" if self.closed else f"{self.workers} workers"
        return f"TilePool({len(self.tiles)} tiles, {state})"
