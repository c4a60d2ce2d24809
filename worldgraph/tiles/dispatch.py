"""Tiled localisation: :func:`localize_tiled` on local processes, a :class:`~worldgraph.tiles.TilePool`
or a Dask cluster."""

from __future__ import annotations

import multiprocessing
import os
import time
import weakref
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from typing import Any

import numpy as np

from perception import Percept

from .. import _checks
from ..association.consistency import check_percepts
from ..errors import WorldGraphError
from ..localization.pipeline import searched
from ..localization.result import LocalizationResult
from ..localization.settings import LocalizeSettings, settings_of
from ..pose.gravity import Gravity
from ..tolerances import AssociationTolerances
from .pool import TilePool
from .ranking import _combine, _globalised_answer, _run_tile, _TileQuery
from .tiling import Tile, _check_tiles


def _client(scheduler: object, name: str = "scheduler", what: str = "None, ", timeout: float | None = None
            ) -> tuple[Any, bool]:
    """A ``distributed.Client`` for ``scheduler`` (an address or a client; the argument's
    ``name`` and the other values it takes, ``what``, for messages) and whether this call opened
    it; an address where no scheduler answers within ``timeout`` seconds (None: distributed's
    connect timeout) raises :class:`WorldGraphError`."""
    try:
        from distributed import Client
    except ImportError as exc:  # pragma: no cover - distributed is in the test extra
        raise WorldGraphError(f"{name} needs Dask distributed: pip install distributed") from exc
    if isinstance(scheduler, Client):
        return scheduler, False
    if isinstance(scheduler, str):
        _checks.name_string(name, scheduler)
        try:
            return Client(scheduler, **({} if timeout is None else {"timeout": timeout})), True
        except (OSError, TimeoutError) as exc:
            waited = "distributed's connect timeout" if timeout is None else f"timeout = {timeout:g} s"
            raise WorldGraphError(f"{name} = {scheduler!r}: no Dask scheduler answered there within "
                                  f"{waited} ({type(exc).__name__}: {exc})") from exc
    raise WorldGraphError(f"{name} must be {what}a scheduler address such as 'tcp://host:8786' or a "
                          f"distributed.Client, got {_checks._short(scheduler)}")


def localize_tiled(tiles: Sequence[Tile], percepts: Sequence[Percept], method: str = "ml", *,
                   scheduler: Any = None, workers: int | None = None, pool: TilePool | None = None,
                   tol: AssociationTolerances | None = None, rng: np.random.Generator | None = None,
                   region: Any = None, gravity: Gravity = "auto", up_sigma: float | None = None,
                   settings: LocalizeSettings | None = None) -> LocalizationResult:
    """:func:`~worldgraph.localize` on every tile in parallel, the answers ranked together.

    Parameters
    ----------
    tiles : sequence of Tile
        From :func:`split`.
    percepts : sequence of perception.Percept
        Fused percepts in the ego frame (sent to every tile).
    method : str
        One of :data:`~worldgraph.LOCALIZE_METHODS`.
    scheduler : str or distributed.Client, optional
        A Dask scheduler address (``"tcp://host:8786"``) or a client: every tile is localised on
        the cluster.  With a client, the tiles are scattered on the first call and stay on the
        cluster while the tiles and the client live (later calls send only the percepts); an
        address opens a client per call, which scatters them again.  For a map that should never
        be in the calling process (larger than it, or shared by many robots), write it with
        :func:`~worldgraph.tiles.save_tiles` and serve it with :class:`~worldgraph.tiles.ClusterTiles`.
        Default: local processes.
    workers : int, optional
        Local worker processes (default ``min(len(tiles), os.cpu_count())``); 1 runs the tiles
        one after another in this process.  Ignored with ``scheduler``.  On platforms with
        ``fork`` the workers inherit the tiles (nothing is pickled but the percepts and the
        answers); elsewhere every tile is pickled to its worker on each call.  Forking a
        process that runs threads (an in-process Dask cluster, a GUI) can deadlock: use
        ``workers=1`` or ``scheduler`` there.
    pool : TilePool, optional
        Worker processes made for these tiles and kept between calls (forked once); not with
        ``scheduler`` or ``workers``.
    tol : AssociationTolerances, optional
        Default :data:`~worldgraph.tolerances.ASSOCIATION_TOLERANCES`.
    rng : numpy.random.Generator, optional
        Split into one child generator per tile (:meth:`numpy.random.Generator.spawn`).
    region : radialopt.Region or (lower, upper), optional
        Passed to every tile's :func:`localize` (default: each tile's default region).
    gravity : "auto", (3,) float or None
        As in :func:`~worldgraph.localize`.  ``"auto"`` decides on the combined
        answer: every tile runs the gravity search, and only when the best tile's answer has no
        pose, too few inliers or a tilted pose do all tiles run the free search.
    up_sigma : float, optional
        Gravity's tilt prior of the pose (radians), as in :func:`~worldgraph.localize`.
    settings : LocalizeSettings, optional
        Every setting of :func:`~worldgraph.localize` in one object (also those this function
        has no keyword for, such as ``max_position_3sigma``); a keyword given with a value other
        than its default replaces that field.

    Returns
    -------
    LocalizationResult
        The best tile's answer with object indices of the whole world: ``correspondences`` and
        ``hypotheses`` mapped back, the other tiles' hypotheses after the winner's, status
        ``"ambiguous"`` (the runner-up poses in ``alternatives``) when another tile's answer is
        within ``tol.ambiguity_margin``; ``timings["tiles_total"]`` is the wall time of
        the whole call.  When no tile finds a pose, the most informative failure
        (:data:`FAILURE_ORDER`).

    Raises
    ------
    WorldGraphError
        - No tile has any of the percepts' types.
        - Bad tiles, method, scheduler or workers; errors of :func:`localize` on bad percepts.
    """
    t_start = time.perf_counter()
    tiles = _check_tiles(tiles)
    settings = settings_of(settings, method=method, tol=tol, region=region, gravity=gravity,
                           up_sigma=up_sigma)
    percepts = check_percepts(percepts)
    if workers is not None:
        workers = _checks.integer("workers", workers, minimum=1, maximum=1024)
    if pool is not None:
        if not isinstance(pool, TilePool):
            raise WorldGraphError(f"pool must be None or a TilePool, got {_checks._short(pool)}")
        if scheduler is not None or workers is not None:
            raise WorldGraphError("pool cannot be combined with scheduler or workers (it has its own)")
        if not pool.serves(tiles):
            raise WorldGraphError(f"pool serves other tiles ({len(pool.tiles)} tiles) than the {len(tiles)} "
                                  "given: make a TilePool of these tiles")
    rngs: list[np.random.Generator | None] = [None] * len(tiles)
    if rng is not None:
        rngs = list(_checks.generator("rng", rng).spawn(len(tiles)))
    world_types = frozenset(t for tile in tiles for t in tile.world.type_names)
    n_used = sum(1 for p in percepts if p.type in world_types)

    def run(one: LocalizeSettings, _: list[int]) -> list[LocalizationResult]:
        # every tile runs the same one search: "auto" decides on the combined answer, not per
        # tile (the tiles without the robot find nothing in either search)
        queries = [_TileQuery(percepts, world_types, one, r) for r in rngs]
        return [_run_tiles(tiles, queries, scheduler, workers, pool, one.tol, t_start)]

    return searched(run, settings, [n_used])[0]


#: The worlds of tiles scattered to a cluster by :func:`localize_tiled`, kept while the Tile lives:
#: a later call with the same tiles and client sends only its percepts.
_SCATTERED: weakref.WeakKeyDictionary[Tile, dict[int, Any]] = weakref.WeakKeyDictionary()


def _on_cluster(client: Any, tiles: tuple[Tile, ...]) -> list[Any]:
    """Futures of the tiles' worlds on ``client``'s cluster: scattered on the first call with
    these tiles and this client, reused after (a future the cluster lost is scattered again)."""
    key = id(client)
    for t in tiles:  # futures of closed clients are dead: forget them
        held = _SCATTERED.get(t, {})
        dead = [k for k, f in held.items() if getattr(f.client, "status", "closed") in ("closed", "closing")]
        for k in dead:
            del held[k]
    missing = [t for t in tiles if _SCATTERED.get(t, {}).get(key) is None
               or _SCATTERED[t][key].status in ("lost", "error", "cancelled")
               or _SCATTERED[t][key].client is not client]
    if missing:
        remote = client.scatter([t.world for t in missing], hash=False)
        for t, f in zip(missing, remote, strict=True):
            _SCATTERED.setdefault(t, {})[key] = f
    return [_SCATTERED[t][key] for t in tiles]


def _run_tiles(tiles: tuple[Tile, ...], queries: list[_TileQuery], scheduler: Any, workers: int | None,
               pool: TilePool | None, tol: AssociationTolerances, t_start: float) -> LocalizationResult:
    """Every tile's ``_run_tile`` of its query (on the pool, the cluster or local processes),
    combined."""
    if pool is not None:
        answers = pool._map(queries)
    elif scheduler is not None:
        client, opened = _client(scheduler)
        try:
            remote = _on_cluster(client, tiles)
            futures = [client.submit(_run_tile, w, q, pure=False)
                       for w, q in zip(remote, queries, strict=True)]
            answers = client.gather(futures)
        finally:
            if opened:
                client.close()
    else:
        n_workers = min(len(tiles), workers or os.cpu_count() or 1)
        if n_workers == 1:
            answers = [_run_tile(t.world, q) for t, q in zip(tiles, queries, strict=True)]
        elif "fork" in multiprocessing.get_all_start_methods():
            with TilePool(tiles, n_workers) as one_call:  # forked for this call only
                answers = one_call._map(queries)
        else:  # pragma: no cover - spawn-only platforms pickle the tiles
            with ProcessPoolExecutor(n_workers) as ex:
                answers = list(ex.map(_run_tile, [t.world for t in tiles], queries))
    answers = [_globalised_answer(a, t) for a, t in zip(answers, tiles, strict=True)]
    return _combine([t.label for t in tiles], answers, tol, t_start)
