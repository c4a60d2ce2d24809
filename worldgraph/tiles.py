"""Tiled localisation: a large world split into tiles (buildings, storeys) localised in parallel.

:func:`split` cuts a :class:`~worldgraph.model.WorldModel` into tiles by a label per object (the
building or storey of :class:`worldgraph.scenes.Site`), each tile a world model of its objects
plus, with ``halo > 0``, the objects of other labels within ``halo`` metres of them (so that a
robot at a tile's border still finds the landmarks it sees).  :func:`localize_tiled` runs
:func:`~worldgraph.localize.localize` on every tile at once -- on local processes by default,
on a Dask cluster with ``scheduler="tcp://host:8786"`` or a ``distributed.Client`` (as
:func:`radialopt.comparison.compare_solvers` does) -- maps the answers back to global object
indices and ranks the tiles' best poses together by the rule of :func:`localize`:

* every tile answer with a pose (status ``"ok"``, ``"weak"`` or ``"ambiguous"``) gets the robust
  cost of its validated fit, ``sum_p min(d_p^2, CHI2_3_GATE)`` over the percepts of the world's
  types (:func:`~worldgraph.pose.validation.fit_hypothesis` re-run from the tile's pose on its
  inliers; a percept whose type the tile lacks counts the cap, as it would against a far-away
  object of the whole world);
* the cheapest answer wins; another tile's answer whose cost is within
  ``tol.ambiguity_margin`` at a distinct pose (outside the winner's 3-sigma ellipsoid,
  6D NEES > ``CHI2_6_GATE``) makes the result ``"ambiguous"`` (its pose joins
  ``alternatives``);
* tiles without a pose drop out; when no tile has one, the most informative failure is
  returned (see :data:`FAILURE_ORDER`).

When the tiles are far apart compared with the sensor range (or the halo covers it), the
tiled answer equals the answer of :func:`localize` on the whole world, at the cost of one
world per tile in memory.  What the whole world sees that tiles cannot: a clique of percepts
spanning two tiles (use a halo), and the default region (each tile's own bounds, not the
whole world's, unless ``region`` is given).
"""

from __future__ import annotations

import math
import multiprocessing
import os
import time
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from perception import Percept

from . import _checks
from .association.hypotheses import AssociationHypothesis
from .errors import ArgumentTypeError, EmptyWorldError, ShapeError, UnknownTypeError, WorldGraphError
from .localize.pipeline import (
    LOCALIZE_METHODS,
    _answered_by_free_search,
    _gravity_unsupported,
    _tilt_checked,
    localize,
)
from .localize.result import POSE_STATUSES, UNIQUE_STATUSES, LocalizationResult
from .model import WorldModel
from .pose.gravity import Gravity, _check_gravity, _check_up_sigma
from .pose.validation import (
    CHI2_3_GATE,
    CHI2_6_GATE,
    NearestObjects,
    _pose_nees,
    fit_hypothesis,
    percept_covariances,
)
from .tolerances import ASSOCIATION_TOLERANCES, HALO_SLACK, AssociationTolerances, _tol_argument

__all__ = ["FAILURE_ORDER", "MAX_TILES", "Tile", "TilePool", "localize_tiled", "split"]

#: Most tiles :func:`split` makes.
MAX_TILES = 100_000
#: Failure statuses from the most to the least informative: when no tile has a pose, the
#: result of the first tile with the earliest status in this order is returned.
FAILURE_ORDER = ("outside_region", "inconsistent", "degenerate_coplanar", "degenerate_collinear",
                 "degenerate", "not_converged", "no_association", "too_few_percepts")
_WITH_POSE = POSE_STATUSES


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
        raise ArgumentTypeError(f"world must be a WorldModel, got {_checks._short(world)}")
    n = len(world)
    lab = _checks.int_array("labels", labels, (n,), minimum=0)
    halo = _checks.positive_float("halo", halo, allow_zero=True)
    names, codes = np.unique(lab, return_inverse=True)
    if len(names) > MAX_TILES:
        raise ShapeError(f"labels must hold at most {MAX_TILES} distinct values, got {len(names)}")
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


# ----------------------------------------------------------------------------------------------
# one tile (runs in a worker)
# ----------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _TileAnswer:
    """What a worker sends back: the tile's result (or the error it raised) and, for a result
    with a pose, the robust cost of its validated fit and that fit's pose covariance."""

    result: LocalizationResult | None
    error: WorldGraphError | None
    cost: float = math.inf
    fit_covariance: NDArray[np.float64] | None = None


def _fit_cost(world: WorldModel, percepts: list[Percept], result: LocalizationResult, n_missing: int
              ) -> tuple[float, NDArray[np.float64] | None]:
    """The robust cost (and pose covariance) of :func:`fit_hypothesis` on the result's inliers,
    from its pose, over the percepts of the tile's types, plus the cap for each of the
    ``n_missing`` percepts of world types the tile lacks."""
    known = [i for i, p in enumerate(percepts) if p.type in world.type_index]
    used = [percepts[i] for i in known]
    local = {g: k for k, g in enumerate(known)}
    pairs = tuple((local[p], o) for p, o in result.correspondences if p in local)
    ego = np.array([p.position for p in used])
    covs = percept_covariances(used)
    nearest = NearestObjects(world, [p.type for p in used])
    fit = fit_hypothesis(world, ego, covs, nearest, pairs, result.transformation, max_rounds=1)
    if fit is None:
        return math.inf, None
    return float(fit.cost) + n_missing * CHI2_3_GATE, fit.pose_covariance


def _run_tile(world: WorldModel, percepts: list[Percept], world_types: frozenset[str], method: str,
              tol: AssociationTolerances, region: Any, rng: np.random.Generator | None,
              gravity: NDArray[np.float64] | None, up_sigma: float | None = None) -> _TileAnswer:
    try:
        result = localize(world, percepts, method, tol=tol, region=region, rng=rng, gravity=gravity,
                          up_sigma=up_sigma)
    except UnknownTypeError as exc:  # the tile has none of the percepts' types
        return _TileAnswer(None, exc)
    if result.status not in _WITH_POSE:
        return _TileAnswer(result, None)
    n_missing = sum(1 for p in percepts if p.type in world_types and p.type not in world.type_index)
    cost, cov = _fit_cost(world, percepts, result, n_missing)
    return _TileAnswer(result, None, cost, cov)


#: Tiles handed to forked worker processes by reference (no pickling of the worlds): a
#: :class:`TilePool` registers them under a token before it forks and removes them on close.
_SHARED: dict[int, tuple[Tile, ...]] = {}


def _run_shared(token: int, k: int, *args: Any) -> _TileAnswer:
    return _run_tile(_SHARED[token][k].world, *args)


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
            workers = _checks.strict_int("workers", workers, minimum=1, maximum=1024)
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

    def _map(self, args: list[tuple[Any, ...]]) -> list[_TileAnswer]:
        if self._executor is None:
            raise WorldGraphError("pool is closed (TilePool.close was called): make a new TilePool")
        return list(self._executor.map(_run_shared, [self._token] * len(self.tiles), range(len(self.tiles)),
                                       *zip(*args, strict=True)))

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


# ----------------------------------------------------------------------------------------------
# ranking
# ----------------------------------------------------------------------------------------------
def _to_global(h: AssociationHypothesis, index: NDArray[np.intp]) -> AssociationHypothesis:
    return replace(h, pairs=tuple((p, int(index[o])) for p, o in h.pairs),
                   validated=tuple((p, int(index[o])) for p, o in h.validated))


def _globalised(result: LocalizationResult, tile: Tile) -> LocalizationResult:
    return replace(result, correspondences=tuple((p, int(tile.index[o])) for p, o in result.correspondences),
                   hypotheses=tuple(_to_global(h, tile.index) for h in result.hypotheses))


def _combine(tiles: Sequence[Tile], answers: list[_TileAnswer], tol: AssociationTolerances,
             t_start: float) -> LocalizationResult:
    results = {k: a.result for k, a in enumerate(answers) if a.result is not None}
    with_pose = [k for k, r in results.items() if r.status in _WITH_POSE]
    posed = sorted(with_pose, key=lambda k: (answers[k].cost, k))
    if not posed:
        failed = list(results)
        if not failed:
            errors = [a.error for a in answers if a.error is not None]
            raise UnknownTypeError(f"no tile has a type of the percepts: {errors[0]}")
        rank = {s: i for i, s in enumerate(FAILURE_ORDER)}
        k = min(failed, key=lambda j: (rank.get(results[j].status, len(rank)), j))
        res = _globalised(results[k], tiles[k])
        timings = dict(res.timings, tiles_total=time.perf_counter() - t_start)
        return replace(res, message=f"no tile found a pose ({len(tiles)} tiles); tile {tiles[k].label}: "
                       f"{res.message}", timings=timings)
    best_k = posed[0]
    best = answers[best_k]
    res = _globalised(results[best_k], tiles[best_k])
    pose = res.transformation
    runners = [k for k in posed[1:] if answers[k].cost - best.cost < tol.ambiguity_margin
               and _pose_nees(pose, best.fit_covariance, results[k].transformation) > CHI2_6_GATE]
    notes = [res.message] if res.message else []
    notes.append(f"tile {tiles[best_k].label} of {len(tiles)} (robust cost {best.cost:.3g})")
    status = res.status
    if runners:
        first = answers[runners[0]]
        gap = float(np.linalg.norm(results[runners[0]].transformation[:3, 3] - pose[:3, 3]))
        notes.append(f"tiles ambiguous: best robust cost {best.cost:.3g} in tile {tiles[best_k].label}, next "
                     f"{first.cost:.3g} in tile {tiles[runners[0]].label} at a pose {gap:.3g} m away")
        if status in UNIQUE_STATUSES:
            status = "ambiguous"
    llr = res.log_likelihood_ratio
    if len(posed) > 1:
        llr = min(llr, 0.5 * (answers[posed[1]].cost - best.cost))
    others = tuple(h for k in posed[1:] for h in _globalised(results[k], tiles[k]).hypotheses)
    alternatives = res.alternatives + tuple(results[k].transformation.copy() for k in runners)
    timings = dict(res.timings, tiles_total=time.perf_counter() - t_start)
    return replace(res, status=status, ambiguous=res.ambiguous or bool(runners), alternatives=alternatives,
                   hypotheses=res.hypotheses + others, log_likelihood_ratio=llr, message="; ".join(notes),
                   timings=timings)


# ----------------------------------------------------------------------------------------------
# dispatch
# ----------------------------------------------------------------------------------------------
def _check_tiles(tiles: object) -> tuple[Tile, ...]:
    items = _checks.as_list("tiles", tiles, "Tile (from worldgraph.tiles.split)")
    if not items:
        raise EmptyWorldError("tiles must hold at least one Tile, got none")
    for k, t in enumerate(items):
        if not isinstance(t, Tile):
            raise ArgumentTypeError(f"tiles[{k}] must be a Tile (from worldgraph.tiles.split), "
                                    f"got {_checks._short(t)}")
    return tuple(items)


def _client(scheduler: object) -> tuple[Any, bool]:
    """A ``distributed.Client`` for ``scheduler`` and whether this call opened it."""
    try:
        from distributed import Client
    except ImportError as exc:  # pragma: no cover - distributed is in the test extra
        raise WorldGraphError("scheduler needs Dask distributed: pip install distributed") from exc
    if isinstance(scheduler, Client):
        return scheduler, False
    if isinstance(scheduler, str):
        _checks.name_string("scheduler", scheduler)
        return Client(scheduler), True
    raise ArgumentTypeError(f"scheduler must be None, a scheduler address such as 'tcp://host:8786' or a "
                            f"distributed.Client, got {_checks._short(scheduler)}")


def localize_tiled(tiles: Sequence[Tile], percepts: Sequence[Percept], method: str = "ml", *,
                   scheduler: Any = None, workers: int | None = None, pool: TilePool | None = None,
                   tol: AssociationTolerances | None = None, rng: np.random.Generator | None = None,
                   region: Any = None, gravity: Gravity = "auto", up_sigma: float | None = None,
                   tolerances: AssociationTolerances | None = None) -> LocalizationResult:
    """:func:`~worldgraph.localize.localize` on every tile in parallel, the answers ranked together.

    Parameters
    ----------
    tiles : sequence of Tile
        From :func:`split`.
    percepts : sequence of perception.Percept
        Fused percepts in the ego frame (sent to every tile).
    method : str
        One of :data:`~worldgraph.localize.LOCALIZE_METHODS`.
    scheduler : str or distributed.Client, optional
        A Dask scheduler address (``"tcp://host:8786"``) or a client: every tile is scattered to
        the cluster and localised there.  Default: local processes.
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
        As in :func:`~worldgraph.localize.localize`.  ``"auto"`` decides on the combined
        answer: every tile runs the gravity search, and only when the best tile's answer has no
        pose, too few inliers or a tilted pose do all tiles run the free search.
    up_sigma : float, optional
        Gravity's tilt prior of the pose (radians), as in :func:`~worldgraph.localize.localize`.
    tolerances : AssociationTolerances, optional
        Deprecated alias of ``tol`` (a :class:`DeprecationWarning`; both at once raise
        :class:`~worldgraph.errors.ArgumentTypeError`).

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
    UnknownTypeError
        No tile has any of the percepts' types.
    WorldGraphError
        Bad tiles, method, scheduler or workers; errors of :func:`localize` on bad percepts.
    """
    t_start = time.perf_counter()
    tiles = _check_tiles(tiles)
    if not isinstance(method, str) or method not in LOCALIZE_METHODS:
        raise WorldGraphError(f"method must be one of {LOCALIZE_METHODS}, got {method!r}")
    percepts = _checks.as_list("percepts", percepts, "perception.Percept")
    for k, p in enumerate(percepts):
        if not isinstance(p, Percept):
            raise ArgumentTypeError(f"percepts[{k}] must be a perception.Percept, got {_checks._short(p)}")
    tol = _tol_argument("localize_tiled", tol, tolerances)
    tol = ASSOCIATION_TOLERANCES if tol is None else tol
    if not isinstance(tol, AssociationTolerances):
        raise ArgumentTypeError(f"tol must be AssociationTolerances, got {_checks._short(tol)}")
    if workers is not None:
        workers = _checks.strict_int("workers", workers, minimum=1, maximum=1024)
    if pool is not None:
        if not isinstance(pool, TilePool):
            raise ArgumentTypeError(f"pool must be None or a TilePool, got {_checks._short(pool)}")
        if scheduler is not None or workers is not None:
            raise ArgumentTypeError("pool cannot be combined with scheduler or workers (it has its own)")
        if not pool.serves(tiles):
            raise WorldGraphError(f"pool serves other tiles ({len(pool.tiles)} tiles) than the {len(tiles)} "
                                  "given: make a TilePool of these tiles")
    plan = _check_gravity(gravity, tol)
    sigma = _check_up_sigma(up_sigma, tol)
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
    why = _gravity_unsupported(answer, plan, tol, method, n_used)
    if why:
        free = _run_tiles(tiles, [(percepts, world_types, method, tol, region, r, None, sigma) for r in rngs],
                          scheduler, workers, pool, tol, t_start)
        answer = _answered_by_free_search(free, answer, why)
    return _tilt_checked(answer, plan, tol)


def _run_tiles(tiles: tuple[Tile, ...], args: list[tuple[Any, ...]], scheduler: Any, workers: int | None,
               pool: TilePool | None, tol: AssociationTolerances, t_start: float) -> LocalizationResult:
    """Every tile's :func:`_run_tile` with its ``args`` (on the pool, the cluster or local
    processes), combined."""
    if pool is not None:
        answers = pool._map(args)
    elif scheduler is not None:
        client, opened = _client(scheduler)
        try:
            remote = client.scatter([t.world for t in tiles], hash=False)
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
    return _combine(tiles, list(answers), tol, t_start)
