"""A map that lives on a Dask cluster: :class:`ClusterTiles`.

The client holds the tile index only (:func:`~worldgraph.tiles.read_index`: labels, files and the
pre-filter's :class:`~worldgraph.tiles.TileSummary` of every tile).  Each tile has a home worker
that reads its file (:func:`~worldgraph.tiles.load_tile`) into a shelf of its process, outside the
memory Dask manages, so the scheduler never moves, spills or steals it.  A query sends the
percepts to the tiles the pre-filter keeps (:func:`~worldgraph.tiles.tiles_to_visit`): each
tile's task runs on its home worker only, and there its answer is kept while a small summary (the
answer without its hypotheses) comes back; the client ranks the summaries as
:func:`~worldgraph.tiles.localize_tiled` does and fetches the chosen tile's whole answer.  When a
home worker dies, its tiles are read again from their files on the remaining workers and their
tasks submitted again.
"""

from __future__ import annotations

import os
import time
import uuid
from collections.abc import Sequence
from dataclasses import dataclass, replace
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
from .ranking import _chosen, _combine, _globalised_answer, _run_tile, _summary, _TileAnswer, _TileQuery
from .tiling import Tile

__all__ = ["ClusterTiles"]

#: Seconds between looks at the cluster while a query's tasks run (a dead home worker is noticed
#: within this time, and its tiles sent to live workers).
POLL_SECONDS = 0.5

#: Times one tile task is sent again after its worker lost the tile, before the query gives up.
MAX_RESUBMITS = 5

#: The tiles a worker process holds, keyed by (worker address, tile key); filled by ``_hold`` on
#: the tile's home worker, emptied by ``_drop`` when the :class:`ClusterTiles` closes.
_SHELF: dict[tuple[str, str], Tile] = {}


class _TileNotHeld(Exception):
    """A task ran on a worker whose shelf lacks its tile (the worker was restarted)."""


def _worker_address() -> str:
    from distributed import get_worker

    return str(get_worker().address)


def _hold(path: str, key: str) -> str:
    """Read the tile file ``path`` onto this worker's shelf under ``key``; the worker's address."""
    address = _worker_address()
    _SHELF[(address, key)] = load_tile(path)
    return address


def _answer(key: str, loaded: str, query: _TileQuery) -> _TileAnswer:
    """The held tile's answer to ``query``, object indices mapped to the whole map's (``loaded``:
    the hold task's result, which orders this task after the tile's load)."""
    del loaded
    tile = _SHELF.get((_worker_address(), key))
    if tile is None:
        raise _TileNotHeld(key)
    return _globalised_answer(_run_tile(tile.world, query), tile)


def _given(query: _TileQuery) -> _TileQuery:
    """``query`` itself, as a task result on the worker that runs it (the tile tasks of that
    worker then read it there: a query crosses the network once per worker, not once per tile)."""
    return query


def _drop(token: str, dask_worker: Any = None) -> int:
    """Let go of this worker's tiles of the ClusterTiles ``token``; how many there were."""
    address = str(dask_worker.address) if dask_worker is not None else _worker_address()
    keys = [k for k in _SHELF if k[0] == address and k[1].endswith(token)]
    for k in keys:
        del _SHELF[k]
    return len(keys)


@dataclass
class _Job:
    """One tile's task of one query (its index in the batch): the answer's future (kept on the
    home worker) and the future of its summary (what comes back)."""

    tile: int
    query: int
    answer: Any = None
    summary: Any = None
    resubmitted: int = 0


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

    Each tile lives on one home worker (the largest tiles first, each to the worker holding the
    fewest objects), in that worker process's memory but outside the data Dask manages: a query's
    task for a tile runs there and nowhere else, so no tile ever travels to answer a query, and
    only the percepts go out and small answers come back.  A worker that dies costs its tiles'
    reload from their files on the other workers, not answers.

    Parameters
    ----------
    folder : str or PathLike
        Written by :func:`~worldgraph.tiles.save_tiles` (its index and one file per tile); the
        workers read the tile files, so the folder must be visible to them at the same path.
    client : distributed.Client or str
        A client, or a scheduler address (``"tcp://host:8786"``; the client is then opened here
        and closed by :meth:`close`).
    timeout : float, optional
        Seconds to wait for the scheduler at an address (default: distributed's connect
        timeout, 30 s).

    Raises
    ------
    MalformedFileError
        The index or a tile file is missing or unreadable (the file is named); a tile file that
        turns out corrupt on its worker raises the same error from :meth:`wait` or the first
        query that visits it.
    WorldGraphError
        ``client`` is neither a client nor an address, or no scheduler answered at the address
        within ``timeout``.
    """

    def __init__(self, folder: str | os.PathLike[str], client: Any, *, timeout: float | None = None) -> None:
        if timeout is not None:
            timeout = _checks.real_scalar("timeout", timeout, positive=True)
        self.index: TileIndex = read_index(folder)
        for entry in self.index.tiles:
            if not os.path.isfile(entry.path):
                raise MalformedFileError(f"{entry.path}: tile file of tile {entry.label} is missing")
        self._client, self._owned = _client(client, "client", "", timeout)
        self._token = uuid.uuid4().hex[:12]
        self._sizes = [e.summary.n_objects for e in self.index.tiles]
        self._types = frozenset(t for entry in self.index.tiles for t in entry.summary.type_counts)
        self._home: list[str | None] = [None] * len(self.index.tiles)
        self._loads: list[Any] = [None] * len(self.index.tiles)
        self._closed = False
        self._queries: list[_TileQuery] = []  # the batch being answered, and where each query was sent
        self._sent: dict[tuple[int, str], Any] = {}
        workers = self._workers()
        for k, w in enumerate(_spread(self._sizes, workers)):
            self._load(k, w)

    # ------------------------------------------------------------------------------------------
    @property
    def closed(self) -> bool:
        """True after :meth:`close`."""
        return self._closed

    @property
    def homes(self) -> dict[int, str | None]:
        """Each tile's home worker (tile label -> worker address; None while a tile submitted to
        an empty cluster waits for a worker)."""
        return {e.label: h for e, h in zip(self.index.tiles, self._home, strict=True)}

    def wait(self, timeout: float | None = None) -> None:
        """Block until every tile is on its home worker (queries do not need this: a query waits
        for the tiles it visits); a tile file that fails to load raises its
        :class:`~worldgraph.errors.MalformedFileError` here."""
        from distributed import wait

        if timeout is not None:
            timeout = _checks.real_scalar("timeout", timeout, positive=True)
        try:
            wait(self._loads, timeout=timeout)
        except TimeoutError as exc:
            raise WorldGraphError(f"the tiles did not load within timeout = {timeout:g} s") from exc
        for k, f in enumerate(self._loads):
            if f.status == "error":
                f.result()  # raises the load's own error (naming the file)
            self._home[k] = f.result()

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
        the pre-filter (world frame, metres; none: every tile the percepts' types allow is
        asked, a global query); ``timeout`` seconds to wait for the workers (None: as long as it
        takes).  The message says how many tiles were visited and why the others were skipped.
        The result is :func:`localize_tiled`'s but for ``hypotheses``: those of the chosen tile
        only (the other tiles' stay on their workers).
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

    # ------------------------------------------------------------------------------------------
    def _workers(self) -> list[str]:
        return sorted(self._client.scheduler_info().get("workers", {}))

    def _load(self, k: int, worker: str | None) -> None:
        """Submit tile ``k``'s load to ``worker`` (None: wherever the scheduler likes; its home
        is then the worker that ran it)."""
        entry = self.index.tiles[k]
        self._home[k] = worker
        self._loads[k] = self._client.submit(
            _hold, entry.path, self._key(k), pure=False,
            key=f"worldgraph-hold-{entry.label}-{uuid.uuid4().hex[:8]}",
            **({} if worker is None else {"workers": [worker], "allow_other_workers": False}))

    def _key(self, k: int) -> str:
        return f"{self.index.tiles[k].label}-{self._token}"

    def _where(self, k: int) -> str:
        """Tile ``k``'s home worker, waiting for its load when it went to no worker in particular."""
        home = self._home[k]
        if home is None:
            home = self._home[k] = str(self._loads[k].result())
        return home

    def _submit(self, job: _Job) -> None:
        home = self._where(job.tile)
        at = {"workers": [home], "allow_other_workers": False}
        query = self._sent.get((job.query, home))
        if query is None:  # the query's first tile on this worker (or a tile moved here)
            query = self._sent[(job.query, home)] = self._client.submit(
                _given, self._queries[job.query], key=f"worldgraph-query-{uuid.uuid4().hex[:12]}", **at)
        tag = f"{self.index.tiles[job.tile].label}-{uuid.uuid4().hex[:8]}"
        job.answer = self._client.submit(_answer, self._key(job.tile), self._loads[job.tile], query,
                                         key=f"worldgraph-answer-{tag}", **at)
        job.summary = self._client.submit(_summary, job.answer, key=f"worldgraph-summary-{tag}", **at)

    def _reload(self, tiles: set[int], live: list[str]) -> None:
        """Load ``tiles`` again from their files: each on its home worker when that one lives,
        else on the live worker holding the fewest objects, the largest tiles first."""
        load = {w: sum(s for s, h in zip(self._sizes, self._home, strict=True) if h == w) for w in live}
        for k in sorted(tiles, key=lambda j: -self._sizes[j]):
            w = self._home[k]
            if w not in load:
                w = min(live, key=lambda a: (load[a], a))
                load[w] += self._sizes[k]
            self._loads[k].release()
            self._load(k, w)

    def _run(self, lists: list[list[Percept]], visits: list[tuple[TileVisit, ...]],
             settings: LocalizeSettings, timeout: float | None, t_start: float) -> list[LocalizationResult]:
        """Submit every query's tile tasks (one search of ``settings``), then gather and rank each
        query's answers."""
        self._queries = [_TileQuery(plist, self._types, settings) for plist in lists]
        batches = [[_Job(k, q) for k, v in enumerate(visit) if v.visit] for q, visit in enumerate(visits)]
        self._sent = {}  # each query goes once to each worker that holds a tile it visits (_submit)
        try:
            return self._ranked(batches, lists, visits, settings, timeout, t_start)
        finally:
            sent, self._sent, self._queries = self._sent, {}, []
            for f in sent.values():
                f.release()

    def _ranked(self, batches: list[list[_Job]], lists: list[list[Percept]],
                visits: list[tuple[TileVisit, ...]], settings: LocalizeSettings, timeout: float | None,
                t_start: float) -> list[LocalizationResult]:
        """Submit the batches' jobs, gather their summaries, fetch each query's chosen answer and
        rank."""
        for batch in batches:
            for job in batch:
                self._submit(job)
        summaries = self._collect([j for batch in batches for j in batch], "summary", timeout, t_start)
        chosen = [_chosen([summaries[id(j)] for j in batch]) if batch else None for batch in batches]
        # the chosen tile's whole answer (its hypotheses), from the worker that keeps it
        wanted = [batch[k] for batch, k in zip(batches, chosen, strict=True) if k is not None]
        whole = self._collect(wanted, "answer", timeout, t_start)
        out = []
        for batch, k, plist, visit in zip(batches, chosen, lists, visits, strict=True):
            note = _visited_note(visit)
            if not batch:
                few = all(v.reason == "no_types" for v in visit)
                status: LocalizeStatus = "too_few_percepts" if few else "no_association"
                res = poseless_result(status, f"no tile can answer these percepts: {note}", len(plist), (),
                                      {"total": time.perf_counter() - t_start}, False)
                out.append(res)
                continue
            answers = [whole[id(j)] if i == k else summaries[id(j)] for i, j in enumerate(batch)]
            for j in batch:
                j.answer.release()
                j.summary.release()
            labels = [self.index.tiles[j.tile].label for j in batch]
            out.append(_noted(_combine(labels, answers, settings.tol, t_start), note))
        return out

    def _collect(self, jobs: list[_Job], which: str, timeout: float | None, t_start: float
                 ) -> dict[int, _TileAnswer]:
        """Every job's ``which`` future's result (``"summary"`` or ``"answer"``, keyed by
        ``id(job)``), polling the cluster: the tasks of a tile whose home worker died, or whose
        worker no longer holds it, are sent again after the tile is loaded on a live worker.  A
        task's own error (a corrupt tile file) is raised as it is."""
        from distributed import wait

        out: dict[int, _TileAnswer] = {}
        pending = list(jobs)
        while pending:
            left = None if timeout is None else timeout - (time.perf_counter() - t_start)
            if left is not None and left <= 0:
                raise WorldGraphError(f"the tile tasks of a query did not finish within timeout = "
                                      f"{timeout:g} s ({len(pending)} of {len(jobs)} tile tasks left)")
            step = POLL_SECONDS if left is None else min(POLL_SECONDS, left)
            try:
                wait([getattr(j, which) for j in pending], timeout=step)
            except TimeoutError:
                pass
            again: list[_Job] = []
            failed: list[_Job] = []
            for j in pending:
                future = getattr(j, which)
                status = future.status
                if status == "finished":
                    out[id(j)] = future.result()
                    continue
                (failed if status in ("error", "cancelled", "lost") else again).append(j)
            if not again and not failed:
                break
            live = self._workers()
            dead = {h for h in self._home if h is not None and h not in live}
            for j in failed:  # a task's own error, on a live worker that holds its tile: raised
                future = getattr(j, which)
                exc = future.exception() if future.status == "error" else None
                if exc is not None and not isinstance(exc, _TileNotHeld) and self._home[j.tile] not in dead:
                    raise exc
            redo = failed + [j for j in again if self._home[j.tile] in dead]
            if redo and live:
                tiles = {j.tile for j in redo} | {k for k, h in enumerate(self._home) if h in dead}
                self._reload(tiles, live)
                for j in redo:
                    j.resubmitted += 1
                    if j.resubmitted > MAX_RESUBMITS:
                        raise WorldGraphError(f"tile {self.index.tiles[j.tile].label}: its task was sent "
                                              f"{MAX_RESUBMITS} times and its worker lost the tile each time")
                    j.answer.release()
                    j.summary.release()
                    self._submit(j)
                again = [j for j in again if j not in redo] + redo
            else:
                again += failed
            pending = again
        return out

    def close(self) -> None:
        """Release the tiles on the workers (and the client when this object opened it); idempotent."""
        if self._closed:
            return
        self._closed = True
        loads, self._loads = self._loads, []
        for f in loads:
            f.release()
        try:
            self._client.run(_drop, self._token)
        except Exception:  # noqa: BLE001 - a client or cluster going down has nothing left to drop
            pass
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


def _spread(sizes: list[int], workers: list[str]) -> list[str | None]:
    """A home worker for each tile: the largest tiles first, each to the worker holding the fewest
    objects (None for every tile when the cluster has no worker yet: the scheduler then places
    each load, and the worker that ran it is the tile's home)."""
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
