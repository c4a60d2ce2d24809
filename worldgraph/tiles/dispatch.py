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
from ..errors import WorldGraphError
from ..localization.pipeline import (
    LOCALIZE_METHODS,
    answered_by_free_search,
    gravity_unsupported,
    tilt_checked,
)
from ..localization.result import LocalizationResult
from ..pose.gravity import Gravity, check_gravity, check_up_sigma
from ..tolerances import AssociationTolerances, _resolved_tol
from .pool import TilePool
from .ranking import _combine, _globalised_answer, _run_tile
from .tiling import Tile, _check_tiles


def _client(scheduler: object, name: str = "scheduler", what: str = "None, ") -> tuple[Any, bool]:
    """A ``distributed.Client`` for ``scheduler`` (an address or a client; the argument's
    ``name`` and the other values it takes, ``what``, for messages) and whether this call opened
    it."""
    try:
        from distributed import Client
    except ImportError as exc:  # pragma: no cover - distributed is in the test extra
        raise WorldGraphError(f"{name} needs Dask distributed: pip install distributed") from exc
    if isinstance(scheduler, Client):
        return scheduler, False
    if isinstance(scheduler, str):
        _checks.name_string(name, scheduler)
        return Client(scheduler), True
    raise WorldGraphError(f"{name} must be {what}a scheduler address such as 'tcp://host:8786' or a "
                          f"distributed.Client, got {_checks._short(scheduler)}")


def localize_tiled(tiles: Sequence[Tile], percepts: Sequence[Percept], method: str = "ml", *,
                   scheduler: Any = None, workers: int | None = None, pool: TilePool | None = None,
                   tol: AssociationTolerances | None = None, rng: np.random.Generator | None = None,
                   region: Any = None, gravity: Gravity = "auto", up_sigma: float | None = None
                   ) -> LocalizationResult:
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
    if not isinstance(method, str) or method not in LOCALIZE_METHODS:
        raise WorldGraphError(f"method must be one of {LOCALIZE_METHODS}, got {method!r}")
    percepts = _checks.as_list("percepts", percepts, "perception.Percept")
    for k, p in enumerate(percepts):
        if not isinstance(p, Percept):
            raise WorldGraphError(f"percepts[{k}] must be a perception.Percept, got {_checks._short(p)}")
    tol = _resolved_tol(tol)
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
    plan = check_gravity(gravity, tol)
    sigma = check_up_sigma(up_sigma, tol)
    rngs: list[np.random.Generator | None] = [None] * len(tiles)
    if rng is not None:
        rngs = list(_checks.generator("rng", rng).spawn(len(tiles)))
    world_types = frozenset(t for tile in tiles for t in tile.world.type_names)
    # the tiles run one search each (an explicit up vector or None): "auto" decides on the
    # combined answer, not per tile (the tiles without the robot find nothing in either search)
    up = None if plan.up is None else plan.up.copy()
    answer = _run_tiles(tiles, [(percepts, world_types, method, tol, region, r, up, sigma) for r in rngs],
                        scheduler, workers, pool, tol, t_start)
    n_used = sum(1 for p in percepts if p.type in world_types)
    why = gravity_unsupported(answer, plan, tol, method, n_used)
    if why:
        free = _run_tiles(tiles, [(percepts, world_types, method, tol, region, r, None, sigma) for r in rngs],
                          scheduler, workers, pool, tol, t_start)
        answer = answered_by_free_search(free, answer, why)
    return tilt_checked(answer, plan, tol)


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


def _run_tiles(tiles: tuple[Tile, ...], args: list[tuple[Any, ...]], scheduler: Any, workers: int | None,
               pool: TilePool | None, tol: AssociationTolerances, t_start: float) -> LocalizationResult:
    """Every tile's ``_run_tile`` with its ``args`` (on the pool, the cluster or local
    processes), combined."""
    if pool is not None:
        answers = pool._map(args)
    elif scheduler is not None:
        client, opened = _client(scheduler)
        try:
            remote = _on_cluster(client, tiles)
            futures = [client.submit(_run_tile, w, *a, pure=False) for w, a in zip(remote, args, strict=True)]
            answers = client.gather(futures)
        finally:
            if opened:
                client.close()
    else:
        n_workers = min(len(tiles), workers or os.cpu_count() or 1)
        if n_workers == 1:
            answers = [_run_tile(t.world, *a) for t, a in zip(tiles, args, strict=True)]
        elif "fork" in multiprocessing.get_all_start_methods():
            with TilePool(tiles, n_workers) as one_call:  # forked for this call only
                answers = one_call._map(args)
        else:  # pragma: no cover - spawn-only platforms pickle the tiles
            with ProcessPoolExecutor(n_workers) as ex:
                answers = list(ex.map(_run_tile, [t.world for t in tiles], *zip(*args, strict=True)))
    answers = [_globalised_answer(a, t) for a, t in zip(answers, tiles, strict=True)]
    return _combine([t.label for t in tiles], answers, tol, t_start)
