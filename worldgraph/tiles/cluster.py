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


def _worker_address() -> str:
    from distributed import get_worker

    return str(get_worker().address)


def _hold(path: str, key: str) -> str:
    """Read the tile file ``path`` onto this worker's shelf under ``key``; the worker's address."""
    address = _worker_address()
    _SHELF[(address, key)] = load_tile(path)
    return address


def _answers(keys: list[str], loaded: list[str], query: _TileQuery) -> list[_TileAnswer] | None:
    """The answers of this worker's held tiles ``keys`` to ``query``, object indices mapped to the
    whole map's (``loaded``: the tiles' hold results, which order this task after their loads);
    None when this worker does not hold them all (it was restarted, or a tile moved away)."""
    del loaded
    address = _worker_address()
    tiles = [_SHELF.get((address, key)) for key in keys]  # all taken at once: a move may drop them
    if any(tile is None for tile in tiles):
        return None
    return [_globalised_answer(_run_tile(tile.world, query), tile) for tile in tiles if tile is not None]


def _summaries(answers: list[_TileAnswer] | None) -> list[_TileAnswer] | None:
    """What comes back of a worker's answers: each without its hypotheses (``ranking._summary``)."""
    return None if answers is None else [_summary(a) for a in answers]


def _pick(answers: list[_TileAnswer], i: int) -> list[_TileAnswer]:
    """The ``i``-th of a worker's answers, whole."""
    return [answers[i]]


def _forget(key: str) -> bool:
    """Let go of this worker's copy of the tile ``key`` (it moved to another worker)."""
    return _SHELF.pop((_worker_address(), key), None) is not None


def _drop(token: str, dask_worker: Any = None) -> int:
    """Let go of this worker's tiles of the ClusterTiles ``token``; how many there were."""
    address = str(dask_worker.address) if dask_worker is not None else _worker_address()
    keys = [k for k in _SHELF if k[0] == address and k[1].endswith(token)]
    for k in keys:
        del _SHELF[k]
    return len(keys)


@dataclass(eq=False)  # a job is itself: compared and hashed by identity
class _Job:
    """One query's tiles on one worker (``query``: its index in the batch): the future of their
    answers (kept on that worker) and of their summaries (what comes back), or, for a query that
    asks one tile only (``whole``), no summaries: its answer comes back whole."""

    query: int
    tiles: list[int]
    home: str
    whole: bool = False
    answers: Any = None
    summaries: Any = None
    resubmitted: int = 0

    @property
    def result(self) -> Any:
        """The future whose result comes back to the client."""
        return self.answers if self.whole else self.summaries


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
        self._queries: list[_TileQuery] = []  # the batch being answered
        workers = self._workers()
        homes = _spread(dict(enumerate(self._sizes)), dict.fromkeys(workers, 0)) if workers else {}
        for k in range(len(self.index.tiles)):
            self._load(k, homes.get(k))  # no worker yet: the scheduler places the load

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

    def _jobs(self, q: int, tiles: list[int], whole: bool = False, resubmitted: int = 0) -> list[_Job]:
        """Query ``q``'s jobs for ``tiles``: one per home worker, submitted."""
        by_home: dict[str, list[int]] = {}
        for k in tiles:
            by_home.setdefault(self._where(k), []).append(k)
        jobs = [_Job(q, ks, home, whole, resubmitted=resubmitted) for home, ks in sorted(by_home.items())]
        for job in jobs:
            self._submit(job)
        return jobs

    def _submit(self, job: _Job) -> None:
        at = {"workers": [job.home], "allow_other_workers": False}
        tag = uuid.uuid4().hex[:12]
        job.answers = self._client.submit(_answers, [self._key(k) for k in job.tiles],
                                          [self._loads[k] for k in job.tiles], self._queries[job.query],
                                          key=f"worldgraph-answers-{tag}", **at)
        if not job.whole:
            job.summaries = self._client.submit(_summaries, job.answers, key=f"worldgraph-summaries-{tag}",
                                                **at)

    @staticmethod
    def _release(jobs: list[_Job]) -> None:
        for job in jobs:
            job.answers.release()
            if job.summaries is not None:
                job.summaries.release()

    def _reload(self, tiles: set[int], live: list[str]) -> None:
        """Load ``tiles`` again from their files: each on its home worker when that one lives,
        else on the live worker holding the fewest objects, the largest tiles first."""
        load = self._load_of(live)
        new = _spread({k: self._sizes[k] for k in sorted(tiles) if self._home[k] not in load}, load)
        for k in sorted(tiles, key=lambda j: -self._sizes[j]):
            self._move(k, new.get(k) or str(self._home[k]), live)

    def _balance(self, live: list[str]) -> None:
        """Move tiles to the live workers that hold none (a worker that joined, or the one that
        replaced a dead worker), each time the largest tile of the most loaded worker that leaves
        the receiver no more loaded than the giver."""
        load = self._load_of(live)
        for w in [a for a in live if load[a] == 0]:
            while True:
                src = max(load, key=lambda a: (load[a], a))
                fits = [k for k, h in enumerate(self._home) if h == src
                        and load[w] + self._sizes[k] <= load[src] - self._sizes[k]]
                if src == w or not fits:
                    break
                k = max(fits, key=lambda j: (self._sizes[j], -j))
                load[src] -= self._sizes[k]
                load[w] += self._sizes[k]
                self._move(k, w, live)

    def _load_of(self, live: list[str]) -> dict[str, int]:
        load = dict.fromkeys(live, 0)
        for k, h in enumerate(self._home):
            if h in load:
                load[h] += self._sizes[k]
        return load

    def _move(self, k: int, worker: str, live: list[str]) -> None:
        """Tile ``k`` read from its file on ``worker`` (again, or anew); a live former home lets
        go of its copy."""
        from distributed import fire_and_forget

        old = self._home[k]
        self._loads[k].release()
        self._load(k, worker)
        if old is not None and old != worker and old in live:
            fire_and_forget(self._client.submit(_forget, self._key(k), pure=False, workers=[old],
                                                allow_other_workers=False))

    def _run(self, lists: list[list[Percept]], visits: list[tuple[TileVisit, ...]],
             settings: LocalizeSettings, timeout: float | None, t_start: float) -> list[LocalizationResult]:
        """Submit every query's tile tasks (one search of ``settings``), then gather and rank each
        query's answers."""
        self._queries = [_TileQuery(plist, self._types, settings) for plist in lists]
        self._balance(self._workers())  # workers that joined since the last call take tiles
        try:
            return self._ranked(lists, visits, settings, timeout, t_start)
        finally:
            self._queries = []

    def _ranked(self, lists: list[list[Percept]], visits: list[tuple[TileVisit, ...]],
                settings: LocalizeSettings, timeout: float | None, t_start: float
                ) -> list[LocalizationResult]:
        """Submit the queries' jobs, gather their summaries (a query of one tile: its answer),
        fetch each query's chosen answer whole and rank."""
        asked = [[k for k, v in enumerate(visit) if v.visit] for visit in visits]
        jobs = [job for q, tiles in enumerate(asked) for job in self._jobs(q, tiles, whole=len(tiles) == 1)]
        got, where = self._collect(jobs, timeout, t_start)
        chosen = [_chosen([got[(q, k)] for k in tiles]) if tiles else None for q, tiles in enumerate(asked)]
        # the chosen tile's whole answer (with its hypotheses), from the worker that keeps it
        picks = []
        for q, (tiles, c) in enumerate(zip(asked, chosen, strict=True)):
            if c is not None and not where[(q, tiles[c])][0].whole:
                job, i = where[(q, tiles[c])]
                pick = _Job(q, [tiles[c]], job.home, whole=True)
                pick.answers = self._client.submit(_pick, job.answers, i,
                                                   key=f"worldgraph-pick-{uuid.uuid4().hex[:12]}",
                                                   workers=[job.home], allow_other_workers=False)
                picks.append(pick)
        whole, _ = self._collect(picks, timeout, t_start)
        self._release(list({j for j, _ in where.values()}) + picks)
        out = []
        for q, (tiles, c, plist, visit) in enumerate(zip(asked, chosen, lists, visits, strict=True)):
            note = _visited_note(visit)
            if not tiles:
                few = all(v.reason == "no_types" for v in visit)
                status: LocalizeStatus = "too_few_percepts" if few else "no_association"
                res = poseless_result(status, f"no tile can answer these percepts: {note}", len(plist), (),
                                      {"total": time.perf_counter() - t_start}, False)
                out.append(res)
                continue
            answers = [whole.get((q, k), got[(q, k)]) if i == c else got[(q, k)] for i, k in enumerate(tiles)]
            labels = [self.index.tiles[k].label for k in tiles]
            out.append(_noted(_combine(labels, answers, settings.tol, t_start), note))
        return out

    def _collect(self, jobs: list[_Job], timeout: float | None, t_start: float
                 ) -> tuple[dict[tuple[int, int], _TileAnswer], dict[tuple[int, int], tuple[_Job, int]]]:
        """Every job's results (:attr:`_Job.result`) by (query, tile), and the job and place in it
        that holds each, polling the cluster: the tasks of tiles whose home worker died, or whose
        worker no longer holds them, are sent again after the tiles are loaded on live workers,
        and those waiting for a worker whose tiles moved (to a worker that joined) are sent to the
        tiles' new homes.  A task's own error (a corrupt tile file) is raised as it is."""
        from distributed import wait

        out: dict[tuple[int, int], _TileAnswer] = {}
        where: dict[tuple[int, int], tuple[_Job, int]] = {}
        pending = list(jobs)
        while pending:
            left = None if timeout is None else timeout - (time.perf_counter() - t_start)
            if left is not None and left <= 0:
                n = sum(len(j.tiles) for j in pending)
                raise WorldGraphError(f"the tile tasks of a query did not finish within timeout = "
                                      f"{timeout:g} s ({n} tile answers still missing)")
            step = POLL_SECONDS if left is None else min(POLL_SECONDS, left)
            try:
                wait([j.result for j in pending], timeout=step)
            except TimeoutError:
                pass
            running: list[_Job] = []
            failed: list[_Job] = []
            for j in pending:
                got = j.result.result() if j.result.status == "finished" else None
                if got is not None:
                    for i, (k, answer) in enumerate(zip(j.tiles, got, strict=True)):
                        out[(j.query, k)] = answer
                        where[(j.query, k)] = (j, i)
                    continue
                ended = j.result.status in ("finished", "error", "cancelled", "lost")  # finished: None,
                (failed if ended else running).append(j)  # the worker lacked a tile
            if not running and not failed:
                break
            live = self._workers()
            dead = {h for h in self._home if h is not None and h not in live}
            for j in failed:  # a task's own error, on a live worker that holds its tiles: raised
                exc = j.result.exception() if j.result.status == "error" else None
                if exc is not None and j.home not in dead:
                    raise exc
            if not live:  # nowhere to send anything yet: the next poll looks again
                pending = running + failed
                continue
            lost = {k for j in failed for k in j.tiles} | {k for k, h in enumerate(self._home) if h in dead}
            if lost:
                self._reload(lost, live)
            self._balance(live)
            stale = [j for j in running if j.home in dead or any(self._home[k] != j.home for k in j.tiles)]
            again = [j for j in running if j not in stale]
            if any(j.home not in dead for j in stale):  # tiles moved to a newcomer: what runs, stays
                started = self._executing()
                kept = [j for j in stale if j.home not in dead
                        and (j.answers.key in started or j.answers.status == "finished")]
                again += kept
                stale = [j for j in stale if j not in kept]
            for j in failed + stale:
                tries = j.resubmitted + (j.home in dead or j in failed)
                if tries > MAX_RESUBMITS:
                    labels = [self.index.tiles[k].label for k in j.tiles]
                    raise WorldGraphError(f"tiles {labels}: their task was sent {MAX_RESUBMITS} times and "
                                          "the worker lost them each time")
                self._release([j])
                again += self._jobs(j.query, j.tiles, j.whole, tries)
            pending = again
        return out, where

    def _executing(self) -> set[str]:
        """The keys of the tasks the workers are running now."""
        def running(dask_worker: Any) -> list[str]:
            return [str(ts.key) for ts in dask_worker.state.executing]

        return {k for keys in self._client.run(running).values() for k in keys}

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


def _spread(sizes: dict[int, int], load: dict[str, int]) -> dict[int, str]:
    """A home worker for each tile of ``sizes`` (tile -> objects): the largest tiles first, each to
    the worker of ``load`` (worker -> objects it holds already) holding the fewest objects."""
    load = dict(load)
    home: dict[int, str] = {}
    for k in sorted(sizes, key=lambda j: (-sizes[j], j)):
        w = min(load, key=lambda a: (load[a], a))
        home[k] = w
        load[w] += sizes[k]
    return home


def _noted(result: LocalizationResult, note: str) -> LocalizationResult:
    return replace(result, message="; ".join(m for m in (result.message, note) if m))
