"""One tile's answer (run in a worker: ``_run_tile``) and the ranking of the tiles' answers
together (``_combine``, the rule of :func:`~worldgraph.localize`)."""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from perception import Percept

from ..association.hypotheses import AssociationHypothesis
from ..errors import WorldGraphError
from ..localization.pipeline import check_world_scale, one_search, tilt_checked
from ..localization.result import POSE_STATUSES, UNIQUE_STATUSES, LocalizationResult
from ..localization.settings import LocalizeSettings
from ..model import WorldModel
from ..pose.validation import (
    CHI2_3_GATE,
    CHI2_6_GATE,
    NearestObjects,
    fit_hypothesis,
    percept_covariances,
    pose_nees,
)
from ..tolerances import AssociationTolerances
from .tiling import Tile

#: Failure statuses from the most to the least informative: when no tile has a pose, the
#: result of the first tile with the earliest status in this order is returned.
FAILURE_ORDER = ("outside_region", "inconsistent", "degenerate_coplanar", "degenerate_collinear",
                 "degenerate", "not_converged", "no_association", "too_few_percepts")
_WITH_POSE = POSE_STATUSES


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


@dataclass(frozen=True)
class _TileQuery:
    """What a worker needs besides its tile to answer one query: the checked percepts, the whole
    map's types (a percept of a map type the tile lacks costs the ranking its cap), one search's
    settings and the tile's own generator."""

    percepts: list[Percept]
    world_types: frozenset[str]
    settings: LocalizeSettings
    rng: np.random.Generator | None = None


def _run_tile(world: WorldModel, query: _TileQuery) -> _TileAnswer:
    """One tile's answer to ``query`` (one search, its tilt checked; object indices of the tile)."""
    percepts, settings = query.percepts, query.settings
    if percepts and not any(p.type in world.type_index for p in percepts):  # nothing to match here
        return _TileAnswer(None, WorldGraphError(
            f"no percept type is in the tile: percept types {sorted({p.type for p in percepts})}, "
            f"tile types {list(world.type_index)}"))
    check_world_scale(world)
    result = one_search(world, percepts, settings, query.rng, time.perf_counter())
    result = tilt_checked(result, settings.plan, settings.tol)
    if result.status not in _WITH_POSE:
        return _TileAnswer(result, None)
    n_missing = sum(1 for p in percepts if p.type in query.world_types and p.type not in world.type_index)
    cost, cov = _fit_cost(world, percepts, result, n_missing)
    return _TileAnswer(result, None, cost, cov)


# ----------------------------------------------------------------------------------------------
# ranking
# ----------------------------------------------------------------------------------------------
def _to_global(h: AssociationHypothesis, index: NDArray[np.intp]) -> AssociationHypothesis:
    return replace(h, pairs=tuple((p, int(index[o])) for p, o in h.pairs),
                   validated=tuple((p, int(index[o])) for p, o in h.validated))


def _globalised(result: LocalizationResult, tile: Tile) -> LocalizationResult:
    return replace(result, correspondences=tuple((p, int(tile.index[o])) for p, o in result.correspondences),
                   hypotheses=tuple(_to_global(h, tile.index) for h in result.hypotheses))


def _globalised_answer(answer: _TileAnswer, tile: Tile) -> _TileAnswer:
    """``answer`` with its result's object indices mapped to the whole world's (``tile.index``)."""
    if answer.result is None:
        return answer
    return replace(answer, result=_globalised(answer.result, tile))


def _posed(answers: Sequence[_TileAnswer]) -> list[int]:
    """The answers with a pose, best (lowest robust cost, then first) first."""
    with_pose = [k for k, a in enumerate(answers) if a.result is not None and a.result.status in _WITH_POSE]
    return sorted(with_pose, key=lambda k: (answers[k].cost, k))


def _chosen(answers: Sequence[_TileAnswer]) -> int | None:
    """The answer whose result :func:`_combine` builds on: the best with a pose, else the first
    with the most informative failure (:data:`FAILURE_ORDER`); None when no tile has a result."""
    posed = _posed(answers)
    if posed:
        return posed[0]
    failed = [k for k, a in enumerate(answers) if a.result is not None]
    if not failed:
        return None
    rank = {s: i for i, s in enumerate(FAILURE_ORDER)}
    return min(failed, key=lambda j: (rank.get(answers[j].result.status, len(rank)), j))  # type: ignore[union-attr]


def _summary(answer: _TileAnswer) -> _TileAnswer:
    """``answer`` with what the ranking reads and nothing more: its result without the
    association hypotheses (the bulk of a result; the chosen tile's are fetched apart)."""
    if answer.result is None or not answer.result.hypotheses:
        return answer
    return replace(answer, result=replace(answer.result, hypotheses=()))


def _combine(labels: Sequence[int], answers: list[_TileAnswer], tol: AssociationTolerances,
             t_start: float) -> LocalizationResult:
    """The tiles' answers (``answers[k]`` of the tile labelled ``labels[k]``, object indices
    already global: ``_globalised_answer``) ranked together."""
    results = {k: a.result for k, a in enumerate(answers) if a.result is not None}
    posed = _posed(answers)
    if not posed:
        k = _chosen(answers)
        if k is None:
            errors = [a.error for a in answers if a.error is not None]
            raise WorldGraphError(f"no tile has a type of the percepts: {errors[0]}")
        res = results[k]
        timings = dict(res.timings, tiles_total=time.perf_counter() - t_start)
        return replace(res, message=f"no tile found a pose ({len(labels)} tiles); tile {labels[k]}: "
                       f"{res.message}", timings=timings)
    best_k = posed[0]
    best = answers[best_k]
    res = results[best_k]
    pose = res.transformation
    runners = [k for k in posed[1:] if answers[k].cost - best.cost < tol.ambiguity_margin
               and pose_nees(pose, best.fit_covariance, results[k].transformation) > CHI2_6_GATE]
    notes = [res.message] if res.message else []
    notes.append(f"tile {labels[best_k]} of {len(labels)} (robust cost {best.cost:.3g})")
    status = res.status
    if runners:
        first = answers[runners[0]]
        gap = float(np.linalg.norm(results[runners[0]].transformation[:3, 3] - pose[:3, 3]))
        notes.append(f"tiles ambiguous: best robust cost {best.cost:.3g} in tile {labels[best_k]}, next "
                     f"{first.cost:.3g} in tile {labels[runners[0]]} at a pose {gap:.3g} m away")
        if status in UNIQUE_STATUSES:
            status = "ambiguous"
    llr = res.log_likelihood_ratio
    if len(posed) > 1:
        llr = min(llr, 0.5 * (answers[posed[1]].cost - best.cost))
    others = tuple(h for k in posed[1:] for h in results[k].hypotheses)
    alternatives = res.alternatives + tuple(results[k].transformation.copy() for k in runners)
    timings = dict(res.timings, tiles_total=time.perf_counter() - t_start)
    return replace(res, status=status, ambiguous=res.ambiguous or bool(runners), alternatives=alternatives,
                   hypotheses=res.hypotheses + others, log_likelihood_ratio=llr, message="; ".join(notes),
                   timings=timings)
