"""A map that lives on a Dask cluster: :class:`ClusterTiles`.

The client holds the tile index only (:func:`~worldgraph.tiles.read_index`: labels, files and the
pre-filter's :class:`~worldgraph.tiles.TileSummary` of every tile).  Each tile is loaded on a
worker by a task that reads its file (:func:`~worldgraph.tiles.load_tile`), and the client keeps
that task's future, so the tile stays in the worker's memory between queries and Dask recomputes
it on another worker when its worker dies.  A query sends the percepts and the small arguments
to the tiles the pre-filter keeps (:func:`~worldgraph.tiles.tiles_to_visit`), each worker answers
for its tile with indices mapped to the whole map's, and the client ranks the answers as
:func:`~worldgraph.tiles.localize_tiled` does.
"""

from __future__ import annotations

import os
import time
import uuid
from collections.abc import Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from perception import Percept

from .. import _checks
from ..association.consistency import check_percepts
from ..errors import MalformedFileError, WorldGraphError
from ..localization.pipeline import searched
from ..localization.result import LocalizationResult, LocalizeStatus, poseless_result
from ..localization.settings import LocalizeSettings, settings_of
from ..pose.gravity import Gravity
from ..tolerances import AssociationTolerances
from .dispatch import _client
from .files import TileIndex, load_tile, read_index
from .prefilter import TileVisit, tiles_to_visit
from .ranking import _combine, _globalised_answer, _run_tile, _TileAnswer, _TileQuery
from .tiling import Tile

__all__ = ["ClusterTiles"]


def _answer(tile: Tile, query: _TileQuery) -> _TileAnswer:
    """One tile's answer on the worker that holds it, its indices mapped to the whole map's."""
    return _globalised_answer(_run_tile(tile.world, query), tile)


def _visited_note(visits: Sequence[TileVisit]) -> str:
    skipped: dict[str, int] = {}
    for v in visits:
        if not v.visit:
            skipped[str(v.reason)] = skipped.get(str(v.reason), 0) + 1
    n = sum(v.visit for v in visits)
    why = ", ".join(f"{k} {c}" for k, c in sorted(skipped.items()))
    return f"visited {n} of {len(visits)} tiles" + (f" (skipped: {why})" if why else "")


class ClusterTiles:
    """Tiles that stay on the workers of a Dask cluster between queries.

    Parameters
    ----------
    folder : str or PathLike
        Written by :func:`~worldgraph.tiles.save_tiles` (its index and one file per tile); the
        workers read the tile files, so the folder must be visible to them at the same path.
    client : distributed.Client or str
        A client, or a scheduler address (``"tcp://host:8786"``; the client is then opened here
        and closed by :meth:`close`).

    Raises
    ------
    MalformedFileError
        The index or a tile file is missing or unreadable (the file is named); a tile file that
        turns out corrupt on its worker raises the same error from the first query.
    """

    def __init__(self, folder: str | os.PathLike[str], client: Any) -> None:
        self.index: TileIndex = read_index(folder)
        for entry in self.index.tiles:
            if not os.path.isfile(entry.path):
                raise MalformedFileError(f"{entry.path}: tile file of tile {entry.label} is missing")
        self._client, self._owned = _client(client, "client", "")
        token = uuid.uuid4().hex[:12]
        home = _spread([e.summary.n_objects for e in self.index.tiles], self._client)
        # each load goes to a worker of its own, the largest tiles first to the least loaded worker
        # (left to itself the scheduler puts quick independent tasks on one idle worker, and every
        # query would then run there); allow_other_workers: when that worker dies, the load runs
        # again elsewhere
        self._futures = [self._client.submit(load_tile, entry.path, pure=False,
                                             key=f"worldgraph-tile-{entry.label}-{token}",
                                             workers=None if w is None else [w], allow_other_workers=True)
                         for entry, w in zip(self.index.tiles, home, strict=True)]
        self._types = frozenset(t for entry in self.index.tiles for t in entry.summary.type_counts)
        self._closed = False

    # ------------------------------------------------------------------------------------------
    @property
    def closed(self) -> bool:
        """True after :meth:`close`."""
        return self._closed

    def wait(self, timeout: float | None = None) -> None:
        """Block until every tile is loaded on a worker (queries do not need this: a query waits
        for the tiles it visits); a tile file that fails to load raises its
        :class:`~worldgraph.errors.MalformedFileError` here."""
        from distributed import wait

        if timeout is not None:
            timeout = _checks.real_scalar("timeout", timeout, positive=True)
        try:
            wait(self._futures, timeout=timeout)
        except TimeoutError as exc:
            raise WorldGraphError(f"the tiles did not load within timeout = {timeout:g} s") from exc
        for f in self._futures:
            if f.status == "error":
                f.result()  # raises the load's own error (naming the file)

    def plan(self, percepts: Sequence[Percept], *, tol: AssociationTolerances | None = None,
             near: Any = None, radius: float | None = None) -> tuple[TileVisit, ...]:
        """The pre-filter's word on every tile for these percepts (:func:`tiles_to_visit`)."""
        summaries = [e.summary for e in self.index.tiles]
        return tiles_to_visit(summaries, percepts, tol=tol, near=near, radius=radius)

    def localize(self, percepts: Sequence[Percept], method: str = "ml", *,
                 tol: AssociationTolerances | None = None, region: Any = None, gravity: Gravity = "auto",
                 up_sigma: float | None = None, near: Any = None, radius: float | None = None,
                 timeout: float | None = None, settings: LocalizeSettings | None = None
                 ) -> LocalizationResult:
        """:func:`~worldgraph.localize` on the tiles that can answer, ranked together.

        ``method``, ``tol``, ``region``, ``gravity``, ``up_sigma`` and ``settings`` are those of
        :func:`~worldgraph.tiles.localize_tiled`; ``near`` and ``radius`` a position prior for
        the pre-filter (world frame, metres); ``timeout`` seconds to wait for the workers (None:
        as long as it takes; Dask re-runs the tasks of a worker that dies).  The message says
        how many tiles were visited and why the others were skipped.
        """
        return self.localize_many([percepts], method, tol=tol, region=region, gravity=gravity,
                                  up_sigma=up_sigma, near=near, radius=radius, timeout=timeout,
                                  settings=settings)[0]

    def localize_many(self, queries: Sequence[Sequence[Percept]], method: str = "ml", *,
                      tol: AssociationTolerances | None = None, region: Any = None, gravity: Gravity = "auto",
                      up_sigma: float | None = None, near: Any = None, radius: float | None = None,
                      timeout: float | None = None, settings: LocalizeSettings | None = None
                      ) -> list[LocalizationResult]:
        """:meth:`localize` of many robots' percepts at once (every query's tile tasks are
        submitted before any is awaited, so the workers share the batch).  ``near`` is one (3,)
        prior for all queries or ``(len(queries), 3)``, one per query (rows of NaN: no prior);
        ``radius`` one value or one per query."""
        if self._closed:
            raise WorldGraphError("ClusterTiles is closed (close was called): make a new ClusterTiles")
        settings = settings_of(settings, method=method, tol=tol, region=region, gravity=gravity,
                               up_sigma=up_sigma)
        if timeout is not None:
            timeout = _checks.real_scalar("timeout", timeout, positive=True)
        items = _checks.as_list("queries", queries, "sequences of perception.Percept")
        t_start = time.perf_counter()
        lists = [check_percepts(percepts, f"queries[{q}]") for q, percepts in enumerate(items)]
        nears, radii = _per_query(near, radius, len(lists))
        visits = [self.plan(p, tol=settings.tol, near=n, radius=r)
                  for p, n, r in zip(lists, nears, radii, strict=True)]

        def run(one: LocalizeSettings, qs: list[int]) -> list[LocalizationResult]:
            return self._run([lists[q] for q in qs], [visits[q] for q in qs], one, timeout, t_start)

        n_used = [sum(1 for p in plist if p.type in self._types) for plist in lists]
        return searched(run, settings, n_used)

    def _run(self, lists: list[list[Percept]], visits: list[tuple[TileVisit, ...]],
             settings: LocalizeSettings, timeout: float | None, t_start: float) -> list[LocalizationResult]:
        """Submit every query's tile tasks (one search of ``settings``), then gather and rank each
        query's answers."""
        jobs = []
        for plist, visit in zip(lists, visits, strict=True):
            ks = [k for k, v in enumerate(visit) if v.visit]
            query = _TileQuery(plist, self._types, settings)
            futures = [self._client.submit(_answer, self._futures[k], query, pure=False) for k in ks]
            jobs.append((ks, futures))
        out = []
        for (ks, futures), plist, visit in zip(jobs, lists, visits, strict=True):
            note = _visited_note(visit)
            if not ks:
                few = all(v.reason == "no_types" for v in visit)
                status: LocalizeStatus = "too_few_percepts" if few else "no_association"
                res = poseless_result(status, f"no tile can answer these percepts: {note}", len(plist), (),
                                      {"total": time.perf_counter() - t_start}, False)
                out.append(res)
                continue
            answers = self._gather(futures, timeout)
            labels = [self.index.tiles[k].label for k in ks]
            out.append(_noted(_combine(labels, answers, settings.tol, t_start), note))
        return out

    def _gather(self, futures: list[Any], timeout: float | None) -> list[_TileAnswer]:
        """The tasks' answers; a task's own error (a corrupt tile file) is raised as it is."""
        from distributed import wait

        if timeout is not None:
            try:
                wait(futures, timeout=timeout)
            except TimeoutError as exc:
                raise WorldGraphError(f"the tile tasks of a query did not finish within timeout = "
                                      f"{timeout:g} s (a worker lost, or a tile still loading?)") from exc
        return list(self._client.gather(futures))

    def close(self) -> None:
        """Release the tiles on the workers (and the client when this object opened it); idempotent."""
        if self._closed:
            return
        self._closed = True
        futures, self._futures = self._futures, []
        for f in futures:
            f.release()
        if self._owned:
            self._client.close()

    def __enter__(self) -> ClusterTiles:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        state = "closed" if self._closed else "open"
        return f"ClusterTiles({len(self.index.tiles)} tiles from {self.index.folder!r}, {state})"


def _per_query(near: Any, radius: Any, n: int) -> tuple[list[Any], list[Any]]:
    """Each query's position prior ``(near, radius)`` from one shared or one per query."""
    if near is None and radius is None:
        return [None] * n, [None] * n
    if near is None or radius is None:
        raise WorldGraphError("near and radius go together: pass both (a position prior) or neither")
    arr = np.asarray(near, dtype=np.float64) if not isinstance(near, str) else None
    if arr is None or arr.shape not in ((3,), (n, 3)):
        raise WorldGraphError(f"near must be a (3,) point or one per query ({n}, 3), "
                              f"got {_checks._short(near)}")
    rad = np.broadcast_to(np.asarray(radius, dtype=np.float64), (n,)) if np.ndim(radius) <= 1 else None
    if rad is None or np.size(radius) not in (1, n):
        raise WorldGraphError(f"radius must be one value or one per query ({n}), "
                              f"got {_checks._short(radius)}")
    points = [arr] * n if arr.ndim == 1 else list(arr)
    out_n = [None if not np.all(np.isfinite(p)) else p for p in points]
    return out_n, [None if p is None else float(r) for p, r in zip(out_n, rad, strict=True)]


def _spread(sizes: list[int], client: Any) -> list[str | None]:
    """A worker for each tile: greedy by object count onto the least loaded worker (None for every
    tile when the cluster has no worker yet: the scheduler then places them)."""
    workers = sorted(client.scheduler_info().get("workers", {}))
    if not workers:
        return [None] * len(sizes)
    load = dict.fromkeys(workers, 0)
    home: list[str | None] = [None] * len(sizes)
    for k in sorted(range(len(sizes)), key=lambda j: -sizes[j]):
        w = min(workers, key=lambda a: (load[a], a))
        home[k] = w
        load[w] += sizes[k]
    return home


def _noted(result: LocalizationResult, note: str) -> LocalizationResult:
    return replace(result, message="; ".join(m for m in (result.message, note) if m))
