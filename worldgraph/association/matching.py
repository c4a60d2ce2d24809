"""Data association: percepts (ego frame) to world-model objects (paper 2.2, docs/design.md#association).

Two methods share :func:`associate`:

``"clique"`` (default, beyond the paper)
    A typed consistency graph: a vertex is a pair (percept p, model object o) of one type; an
    edge joins (p, o) and (q, u), p != q, o != u, when the percept distance and the model
    distance agree, ``| |x_p - x_q| - |X_o - X_u| | < tau_pq`` (with ``gravity_aligned`` the
    horizontal distance and the height difference are compared separately).  Candidate model
    pairs come from the world's link look-up table (:meth:`WorldModel.link_lengths`), never
    from all pairs.  The graph is k-partite by percept, so an exact branch and bound over the
    percepts with Python-integer bitsets finds the maximum cliques and every maximal clique
    one smaller (false percepts make a wrong clique one larger than the true one possible).
    Cliques of four or more members whose percept and model tetrahedra have opposite signed
    volumes (mirror matches) are rejected.  Every surviving clique becomes a hypothesis:
    weighted Kabsch on its members, then a robust fit cost, the capped squared normalised
    residual of *every* percept against its nearest same-type model object under that pose,
    which also validates the hypothesis with the percepts not used to build it.
``"paper"``
    The paper's filters: proximity filtering (eq. 1, the intersection of the link sets of all
    percept pairs) and orientation filtering (eqs. 2-3, signature vectors of percept triples
    in the eq.-5 frame), then the complete assignments of the surviving links.  No percept
    may be false: one false percept empties the intersection.

Note on eqs. 2-3: the signature ``V = R^T (x_j - x_k)`` in the frame of the triple is a
function of the triangle's side lengths only (the third point always has a negative third
coordinate in that frame), so the orientation filter accepts nothing that the pairwise
distances reject; it is kept as the paper states it.  The signed volume used by the clique
method is what rejects mirror matches.

This module drives both methods and re-exports the public names of the modules that hold the
pieces: :mod:`worldgraph.tolerances` (:class:`AssociationTolerances`),
:mod:`worldgraph.association.consistency` (the typed consistency graph: candidate pairs, far
pairs, pruning), :mod:`worldgraph.association.cliques` (the clique search),
:mod:`worldgraph.association.hypotheses` (fits, mirror check, ranking) and
:mod:`worldgraph.association.filters` (the paper's filters, eqs. 1-3, and the discriminator).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from perception import Percept

from .._checks import integer
from ..errors import (
    TooFewPerceptsError,
    WorldGraphError,
)
from ..model import WorldModel
from ..model.units import UnitsWarning, units_hint
from ..pose.gravity import (
    FREE_SEARCH,
    Gravity,
    SearchPlan,
    check_gravity,
    levelled_percepts,
    tolerances_for_plan,
    unlevelled_pose,
    unsupported_reason,
)
from ..tolerances import ASSOCIATION_TOLERANCES, AssociationTolerances, _resolved_tol
from .cliques import CliqueSearch, maximum_cliques
from .consistency import _check_inputs, _LazyGraph, _local
from .filters import (
    consistency_graph,
    discriminator,
    filtered_graph_view,
    orientation_filter,
    proximity_filter,
)
from .hypotheses import AssociationHypothesis, _fit_all, _rank, is_ambiguous, same_pose

__all__ = [
    "ASSOCIATION_METHODS",
    "ASSOCIATION_TOLERANCES",
    "AssociationHypothesis",
    "AssociationTolerances",
    "CliqueSearch",
    "associate",
    "consistency_graph",
    "filtered_graph_view",
    "discriminator",
    "is_ambiguous",
    "maximum_cliques",
    "same_pose",
    "orientation_filter",
    "proximity_filter",
]

ASSOCIATION_METHODS = ("clique", "paper")



# ----------------------------------------------------------------------------------------------
# associate
# ----------------------------------------------------------------------------------------------
def _hypotheses_from_cliques(world: WorldModel, percepts: list[Percept],
                             graph_objects: list[NDArray[np.intp]],
                             cliques: list[tuple[tuple[int, int], ...]], tol: AssociationTolerances,
                             searched: NDArray[np.intp]) -> list[AssociationHypothesis]:
    """Fit every clique; ``searched[p]`` is the index in ``percepts`` of the graph's percept p."""
    sets = [tuple((int(searched[p]), int(graph_objects[p][a])) for p, a in clique)
            for clique in cliques[:tol.max_cliques]]
    return _fit_all(world, percepts, sets, tol)


#: A truncated clique search is retried on this many fewer percepts (the most certain ones) ...
RETRY_STEP = 2
#: ... while at least this many remain (and ``min_clique_size + RETRY_STEP``).
MIN_RETRY_PERCEPTS = 6


def _search_subset(percepts: list[Percept], limit: int) -> NDArray[np.intp]:
    """Indices of the ``limit`` most certain percepts (smallest sigma; ties by type and position,
    so the choice does not depend on the percept order), in increasing index order."""
    if len(percepts) <= limit:
        return np.arange(len(percepts))
    order = sorted(range(len(percepts)),
                   key=lambda i: (percepts[i].sigma, percepts[i].type, *percepts[i].position.tolist()))
    return np.sort(np.array(order[:limit], dtype=np.intp))


def associate(world: WorldModel, percepts: Sequence[Percept],
              tol: AssociationTolerances | None = None, method: str = "clique",
              max_hypotheses: int | None = None, *, gravity: Gravity = "auto") -> list[AssociationHypothesis]:
    """Ranked association hypotheses of ``percepts`` (ego frame) to the objects of ``world``.

    Parameters
    ----------
    world : WorldModel
    percepts : sequence of perception.Percept
        Every type must be a type of the world (filter unknown ones before; :func:`localize`
        does).
    tol : AssociationTolerances, optional
        Default :data:`~worldgraph.tolerances.ASSOCIATION_TOLERANCES`.
    method : {"clique", "paper"}
        See the module docstring.
    max_hypotheses : int, optional
        Default ``tol.max_hypotheses``.
    gravity : "auto", (3,) float or None
        Which way is up in the ego frame (:mod:`worldgraph.pose.gravity`): ``"auto"`` (default) the
        gravity search about the ego z axis within ``tol.tilt_allowance``, then the free search
        when its best hypothesis has too few inliers or tilts beyond the allowance; an up
        vector (an IMU's) levels the percepts for the gravity search; ``None`` the free 3D
        search.  Each hypothesis' ``search`` says which search made it.  The paper's filters
        use no gravity (``"free"``).

    Returns
    -------
    list of AssociationHypothesis
        By increasing robust cost; poses within ``distinct_translation``/``distinct_angle`` of
        a better hypothesis are merged into it.  Empty when no clique of ``min_clique_size``
        (or, for "paper", no complete assignment) exists; then a
        :class:`~worldgraph.model.units.UnitsWarning` says so when the percepts or the world look like
        millimetres (:func:`~worldgraph.model.units.units_hint`).

    Raises
    ------
    WorldGraphError
        A percept type the world does not have.
    TooFewPerceptsError
        Fewer than ``min_clique_size`` percepts.
    """
    if not isinstance(method, str) or method not in ASSOCIATION_METHODS:
        raise WorldGraphError(f"method must be one of {ASSOCIATION_METHODS}, got {method!r}")
    percepts = _check_inputs(world, percepts)
    tol = _resolved_tol(tol)
    plan = check_gravity(gravity, tol)
    hyps = associate_searched(world, percepts, tol, method, max_hypotheses, plan)
    if plan.fallback and plan.up is not None and method != "paper" and (
            not hyps
            or unsupported_reason(hyps[0].world_from_ego, hyps[0].inliers, len(percepts), plan.up, tol)):
        hyps = associate_searched(world, percepts, tol, method, max_hypotheses, FREE_SEARCH)
    if not hyps:
        hint = units_hint(world, percepts)
        if hint is not None:
            warnings.warn(f"associate found no hypothesis; {hint}", UnitsWarning, stacklevel=2)
    return hyps


def associate_searched(world: WorldModel, percepts: list[Percept], tol: AssociationTolerances, method: str,
                       max_hypotheses: int | None, plan: SearchPlan) -> list[AssociationHypothesis]:
    """``_associate`` with the plan's search: the percepts levelled for the gravity search,
    the hypotheses' poses of the ego frame as given, each marked with its search.  The paper's
    filters use no gravity: the free search."""
    if method == "paper":
        plan = FREE_SEARCH
    hyps = _associate(world, levelled_percepts(percepts, plan.level), tolerances_for_plan(plan, tol), method,
                      max_hypotheses)
    return [replace(h, world_from_ego=unlevelled_pose(h.world_from_ego, plan.level), search=plan.search)
            for h in hyps]


def _associate(world: WorldModel, percepts: list[Percept], tol: AssociationTolerances, method: str,
               max_hypotheses: int | None) -> list[AssociationHypothesis]:
    """:func:`associate` on checked inputs, without the units warning (``localize`` puts the
    hint in its message instead)."""
    k = len(percepts)
    if k < tol.min_clique_size:
        raise TooFewPerceptsError(f"association needs at least {tol.min_clique_size} percepts, got {k}")
    limit = tol.max_hypotheses if max_hypotheses is None else integer("max_hypotheses", max_hypotheses,
                                                                          minimum=1)
    searched = _search_subset(percepts, int(tol.max_search_percepts))
    sub = [percepts[i] for i in searched]
    k = len(sub)
    if method == "paper":
        prox = proximity_filter(world, sub, tol)
        filt = orientation_filter(world, sub, prox, tol)
        sizes = [len(o) for o in filt["objects"]]
        search = maximum_cliques(sizes, filt["adjacency"], min_size=k, near_maximum=0,
                                 max_nodes=tol.max_nodes, allowed=filt["alive"])
        hyps = _hypotheses_from_cliques(world, percepts, filt["objects"], search.cliques, tol, searched)
        return _rank(hyps, tol, limit)

    # a truncated search (a repetitive world around many percepts: the near-maximum cliques
    # explode) is retried on fewer, the most certain, percepts: the searched subset is what the
    # search is complete over in any case (max_search_percepts), every hypothesis is still fitted
    # to all percepts, and a complete search on fewer percepts beats a truncated one on more
    while True:
        fewer = len(searched) - RETRY_STEP
        last = fewer < max(tol.min_clique_size + RETRY_STEP, MIN_RETRY_PERCEPTS)
        hyps, complete = _clique_search(world, percepts, searched, tol, last)
        if complete or last:
            break
        searched = _search_subset(percepts, fewer)
    ranked = _rank(hyps, tol, limit)
    if not complete:
        ranked = [replace(h, complete=False) for h in ranked]
    return ranked


def _clique_search(world: WorldModel, percepts: list[Percept], searched: NDArray[np.intp],
                   tol: AssociationTolerances, last: bool) -> tuple[list[AssociationHypothesis], bool]:
    """The consistency-graph search over the percepts ``searched`` (indices into ``percepts``):
    the hypotheses of the maximum and near-maximum cliques and whether the search was
    complete (when it was not and this is not the ``last`` try, no hypotheses)."""
    sub = [percepts[i] for i in searched]
    k = len(sub)
    lazy = _LazyGraph(world, sub, tol)
    # find the maximum size with strong pruning first (the first clique found of size ``need``
    # is a maximum one: larger ones were ruled out before), then enumerate down to max - near
    best = 0
    for need in range(k, tol.min_clique_size - 1, -1):
        graph, alive = lazy.prune(need)
        if sum(bool(a.any()) for a in alive) < need:
            continue
        top_objects, top_adjacency = graph.compact(alive)
        search = maximum_cliques([len(o) for o in top_objects], top_adjacency, min_size=need, near_maximum=0,
                                 max_nodes=tol.max_nodes, stop_at=need)
        if search.maximum >= need:
            best = search.maximum
            break
    if best == 0:
        return [], True
    floor = max(best - tol.near_maximum, tol.min_clique_size)
    graph, alive = lazy.prune(floor)
    objects, adjacency = graph.compact(alive)
    search = maximum_cliques([len(o) for o in objects], adjacency, min_size=floor,
                             near_maximum=tol.near_maximum, max_nodes=tol.max_nodes,
                             max_cliques=tol.max_cliques)
    if not search.complete and not last:
        return [], False  # retried on fewer percepts: skip building its hypotheses
    cliques = search.cliques
    if not search.complete and best > floor:
        # truncated: make sure the maximum cliques themselves are among the candidates, searched
        # in the graph pruned for their size (which holds every one of them, and fewer vertices)
        # and renumbered into this graph's vertices
        top = maximum_cliques([len(o) for o in top_objects], top_adjacency, min_size=best, near_maximum=0,
                              max_nodes=tol.max_nodes, max_cliques=tol.max_cliques)
        renumbered = {tuple((p, int(_local(objects[p], top_objects[p][a]))) for p, a in c)
                      for c in top.cliques}
        cliques = sorted(renumbered | set(cliques), key=lambda c: (-len(c), c))
    hyps = _hypotheses_from_cliques(world, percepts, objects, cliques, tol, searched)
    if not hyps and floor > tol.min_clique_size:
        # every large clique was a mirror or degenerate: fall back to all sizes
        graph, alive = lazy.prune(tol.min_clique_size)
        objects, adjacency = graph.compact(alive)
        search = maximum_cliques([len(o) for o in objects], adjacency, min_size=tol.min_clique_size,
                                 near_maximum=k, max_nodes=tol.max_nodes, max_cliques=tol.max_cliques)
        hyps = _hypotheses_from_cliques(world, percepts, objects, search.cliques, tol, searched)
    return hyps, bool(search.complete)


