"""The paper's association filters (section 2.2): proximity filtering (eq. 1), orientation
filtering (eqs. 2-3), the filtered graph views, and the discriminator of the active validation
(section 2.3)."""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import networkx as nx
import numpy as np
from numpy.typing import NDArray

from perception import Percept

from .._checks import integer, real_scalar
from .._rigid import rigid_transform
from ..errors import (
    TooFewPerceptsError,
    WorldGraphError,
)
from ..model import WorldModel
from ..pose.frames import invert_transformation
from ..tolerances import COLLINEAR_TOL, TINY, AssociationTolerances, _resolved_tol
from .consistency import _check_inputs, _consistency_graph, _Graph, _pair_candidates, _prune
from .hypotheses import AssociationHypothesis, _check_hypotheses


# ----------------------------------------------------------------------------------------------
# the paper's filters
# ----------------------------------------------------------------------------------------------
def proximity_filter(world: WorldModel, percepts: Sequence[Percept],
                     tol: AssociationTolerances | None = None) -> dict:
    """Proximity filtering (paper eq. 1 and the intersection ``psi_act``).

    For every percept pair (p, q) the model links of the same type pair whose length lies
    within ``tau`` of the percept distance (``tau`` from the largest sigma of the percepts of
    the two types, as the paper's ``tau = max eps_k``, widened to ``n_sigma`` standard
    deviations); then the intersection: a model object stays a candidate of percept p only
    while it has a link to a candidate of every other percept (iterated to a fixed point).

    Returns
    -------
    dict
        ``"candidates"``: list, per percept, of the surviving global object indices;
        ``"links"``: dict (p, q) -> (k, 2) int array of surviving (object of p, object of q);
        ``"adjacency"``: the same as boolean matrices over each percept's objects of its type;
        ``"graph"``: the surviving part of ``world.graph`` as a networkx subgraph view
        (:func:`filtered_graph_view`).
    """
    percepts = _check_inputs(world, percepts)
    tol = _resolved_tol(tol, world=world)
    objects = [world.type_index[p.type] for p in percepts]
    k = len(percepts)
    sig = np.array([p.sigma for p in percepts])
    types = [p.type for p in percepts]
    edges: dict[tuple[int, int], tuple[NDArray[np.intp], NDArray[np.intp]] | None] = {}
    for p, q in itertools.combinations(range(k), 2):
        theta = [s for s, t in zip(sig, types, strict=True) if t in (types[p], types[q])]
        smax = max(theta)
        tau = float(tol.pair_tolerance(smax, smax))
        edges[(p, q)] = _pair_candidates(world, percepts, p, q, tau, tol, objects)
    graph = _Graph(objects, edges)
    alive = _prune(graph, k)
    compact, dense = graph.dense(alive)
    adjacency = {key: np.ones((len(compact[key[0]]), len(compact[key[1]])), bool) if m is None else m
                 for key, m in dense.items()}
    return _filtered(world, compact, adjacency, [np.ones(len(o), bool) for o in compact])


def _sparse(objects: list[NDArray[np.intp]], adjacency: dict) -> _Graph:
    # each m is 2-D, so np.nonzero gives the (rows, cols) pair
    return _Graph(objects, {key: np.nonzero(m) for key, m in adjacency.items()})  # type: ignore[misc]


def _filtered(world: WorldModel, objects: list[NDArray[np.intp]], adjacency: dict,
              alive: list[NDArray[np.bool_]]) -> dict:
    adj = {key: mat & alive[key[0]][:, None] & alive[key[1]][None, :] for key, mat in adjacency.items()}
    links = {}
    for (p, q), mat in adj.items():
        a, b = np.nonzero(mat)
        links[(p, q)] = np.column_stack([objects[p][a], objects[q][b]])
    candidates = [o[al] for o, al in zip(objects, alive, strict=True)]
    return {"candidates": candidates, "links": links, "adjacency": adj, "objects": objects,
            "alive": alive, "graph": filtered_graph_view(world, candidates, links)}


def filtered_graph_view(world: WorldModel, candidates: Sequence[NDArray[np.intp]],
                        links: dict[tuple[int, int], NDArray[np.intp]]) -> nx.Graph:
    """The part of ``world.graph`` that survives a filter: a read-only subgraph view (networkx)
    of the candidate objects and of the proximity edges that some surviving link uses.

    ``world.graph`` holds the pairs closer than ``max_link_length``; links between percepts
    farther apart than that have no edge there and so do not show in the view (they are in
    the filter's ``"links"``).
    """
    if not isinstance(world, WorldModel):
        raise WorldGraphError(f"world must be a WorldModel, got {type(world).__name__}")
    if candidates is None or isinstance(candidates, str | bytes) or not isinstance(links, dict):
        raise WorldGraphError("candidates must be a sequence of object-index arrays and links a dict, got "
                              f"{type(candidates).__name__} and {type(links).__name__}")
    cand_arrays = []
    for i, c in enumerate(candidates):
        try:
            arr = np.asarray(c)
        except (TypeError, ValueError) as exc:
            raise WorldGraphError(f"candidates[{i}] must be an array of object indices") from exc
        if arr.ndim != 1 or (arr.size and (arr.dtype.kind not in "iu" or arr.min() < 0
                                           or arr.max() >= len(world))):
            raise WorldGraphError(f"candidates[{i}] must be object indices in [0, {len(world)}), "
                                  f"got {arr.tolist()!r:.200}")
        cand_arrays.append(arr)
    link_arrays = []
    for key, pairs in links.items():
        try:
            arr = np.asarray(pairs)
        except (TypeError, ValueError) as exc:
            raise WorldGraphError(f"links[{key!r}] must be a (n, 2) array of object indices") from exc
        if arr.size == 0:
            continue
        if arr.ndim != 2 or arr.shape[1] != 2 or arr.dtype.kind not in "iu" or arr.min() < 0 \
                or arr.max() >= len(world):
            raise WorldGraphError(f"links[{key!r}] must be a (n, 2) array of object indices, "
                                  f"got {arr.tolist()!r:.200}")
        link_arrays.append(arr)
    nodes = {int(o) for c in cand_arrays for o in c}
    edges: set[tuple[int, int]] = set()
    for pairs in link_arrays:
        for a, b in pairs.tolist():
            edges.add((a, b) if a <= b else (b, a))
    return nx.subgraph_view(world.graph, filter_node=nodes.__contains__,
                            filter_edge=lambda u, v: (min(u, v), max(u, v)) in edges)


def consistency_graph(world: WorldModel, percepts: Sequence[Percept],
                      tol: AssociationTolerances | None = None, min_size: int | None = None) -> nx.Graph:
    """The typed consistency graph of :func:`associate` ("clique") as a networkx graph.

    A node ``(p, o)`` pairs percept ``p`` with an object ``o`` of its type (attributes
    ``percept``, ``object``, ``type``); an edge joins two pairs whose percept and model distances
    agree within the gate (and that use different percepts and objects).  Only the pairs that can
    still be in a clique of ``min_size`` (default ``tol.min_clique_size``) are kept, as
    :func:`associate` prunes them.  Its maximal cliques are the association candidates (the array
    search in :func:`maximum_cliques` finds the largest of them without building this graph).
    """
    percepts = _check_inputs(world, percepts)
    tol = _resolved_tol(tol, world=world)
    need = tol.min_clique_size if min_size is None else integer("min_size", min_size, minimum=1)
    graph = _consistency_graph(world, percepts, tol)
    alive = _prune(graph, need)
    g: nx.Graph[tuple[int, int]] = nx.Graph()
    for p, (objs, al) in enumerate(zip(graph.objects, alive, strict=True)):
        g.add_nodes_from(((p, int(o)), {"percept": p, "object": int(o), "type": percepts[p].type})
                         for o in objs[al])
    for (p, q), e in graph.edges.items():
        if e is None:
            a, b = np.nonzero(np.outer(alive[p], alive[q]))
        else:
            a, b = e
            keep = alive[p][a] & alive[q][b]
            a, b = a[keep], b[keep]
        op, oq = graph.objects[p][a], graph.objects[q][b]
        diff = op != oq
        g.add_edges_from(zip(((p, int(o)) for o in op[diff]), ((q, int(o)) for o in oq[diff]), strict=True))
    return g


def _frames(a: NDArray, b: NDArray, c: NDArray) -> tuple[NDArray, NDArray]:
    """Rotations (m, 3, 3) of the eq.-5 frames of point triples (m, 3) each, and a validity mask."""
    ab = b - a
    nab = np.linalg.norm(ab, axis=1)
    d1 = ab / np.where(nab > 0, nab, 1.0)[:, None]
    cr = np.cross(d1, c - a)
    ncr = np.linalg.norm(cr, axis=1)
    ok = (nab > 0) & (ncr > COLLINEAR_TOL * np.maximum(nab, TINY))
    d2 = cr / np.where(ncr > 0, ncr, 1.0)[:, None]
    d3 = np.cross(d1, d2)
    return np.stack([d1, d2, d3], axis=2), ok


def _check_proximity(world: WorldModel, percepts: list[Percept], proximity: object
                     ) -> tuple[list[NDArray[np.intp]], dict[tuple[int, int], NDArray[np.bool_]]]:
    """The ``"objects"`` and a copy of the ``"adjacency"`` of a :func:`proximity_filter` result for
    these percepts, checked (shapes, keys, object types)."""
    k = len(percepts)
    if not isinstance(proximity, dict) or "objects" not in proximity or "adjacency" not in proximity:
        raise WorldGraphError("proximity must be the dict returned by proximity_filter (with 'objects' and "
                              f"'adjacency'), got {type(proximity).__name__}")
    objects_in, adjacency = proximity["objects"], proximity["adjacency"]
    if not isinstance(objects_in, list | tuple) or not isinstance(adjacency, dict):
        raise WorldGraphError("proximity['objects'] must be a list of object arrays and "
                              "proximity['adjacency'] a "
                              f"dict, got {type(objects_in).__name__} and {type(adjacency).__name__}")
    if len(objects_in) != k:
        raise WorldGraphError(f"percepts has {k} percepts but proximity['objects'] has {len(objects_in)} "
                              "entries: pass the percepts proximity_filter was given")
    objects = []
    for p, o in enumerate(objects_in):
        arr = np.asarray(o)
        if arr.ndim != 1 or (arr.size and arr.dtype.kind not in "iu") or \
                not np.all(np.isin(arr, world.type_index[percepts[p].type])):
            raise WorldGraphError(f"proximity['objects'][{p}] must be indices of the objects of type "
                                  f"{percepts[p].type!r}, got {arr.tolist()!r:.200}")
        objects.append(arr.astype(np.intp))
    adj = {}
    for p, q in itertools.combinations(range(k), 2):
        mat = np.asarray(adjacency.get((p, q)) if (p, q) in adjacency else np.zeros((0, 0)))
        if mat.dtype != np.bool_ or mat.shape != (len(objects[p]), len(objects[q])):
            raise WorldGraphError(f"proximity['adjacency'][({p}, {q})] must be a bool array of shape "
                                  f"({len(objects[p])}, {len(objects[q])}), got {mat.dtype} {mat.shape}")
        adj[(p, q)] = mat.copy()
    return objects, adj


def orientation_filter(world: WorldModel, percepts: Sequence[Percept], proximity: dict,
                       tol: AssociationTolerances | None = None) -> dict:
    """Orientation filtering (paper eqs. 2-3) of the output of :func:`proximity_filter`.

    For every non-collinear percept triple (i, j, k) the signature ``V = R_ijk^T (x_j - x_k)``
    (the displacement in the eq.-5 frame of the triple) is compared with the signatures of the
    model triples (u, v, w) linked in the proximity result: accepted when ``|V_p - V_m| <
    mu_max`` (eq. 2) and the angle between them is below ``kappa_max`` (eq. 3).  Links that no
    accepted triple uses are dropped, then the intersection is iterated again.

    Returns
    -------
    dict
        Same layout as :func:`proximity_filter`.
    """
    percepts = _check_inputs(world, percepts)
    tol = _resolved_tol(tol, world=world)
    k = len(percepts)
    objects, adj = _check_proximity(world, percepts, proximity)
    x = np.array([p.position for p in percepts])
    sig = np.array([p.sigma for p in percepts])
    X = world.positions
    if k >= 3:
        support = {key: np.zeros_like(m) for key, m in adj.items()}
        checked = {key: False for key in adj}
        for i, j, kk in itertools.combinations(range(k), 3):
            rp, okp = _frames(x[i][None], x[j][None], x[kk][None])
            if not okp[0]:
                continue
            for key in ((i, j), (i, kk), (j, kk)):
                checked[key] = True
            vp = rp[0].T @ (x[j] - x[kk])
            spread = math.sqrt(sig[i] ** 2 + sig[j] ** 2 + sig[kk] ** 2)
            mu = tol.mu_max if tol.mu_max is not None else float(
                tol.n_sigma * tol.pair_factor * spread + tol.min_tolerance)
            a_ij, a_ik, a_jk = adj[(i, j)], adj[(i, kk)], adj[(j, kk)]
            u, v = np.nonzero(a_ij)
            if len(u) == 0:
                continue
            cand = a_ik[u] & a_jk[v]
            rows, w = np.nonzero(cand)
            if len(rows) == 0:
                continue
            u, v = u[rows], v[rows]
            Xu, Xv, Xw = X[objects[i][u]], X[objects[j][v]], X[objects[kk][w]]
            rm, okm = _frames(Xu, Xv, Xw)
            vm = np.einsum("mji,mj->mi", rm, Xv - Xw)
            dist = np.linalg.norm(vm - vp, axis=1)
            cosang = (vm @ vp) / np.maximum(np.linalg.norm(vm, axis=1) * np.linalg.norm(vp), TINY)
            acc = okm & (dist < mu) & (np.arccos(np.clip(cosang, -1, 1)) < tol.kappa_max)
            u, v, w = u[acc], v[acc], w[acc]
            support[(i, j)][u, v] = True
            support[(i, kk)][u, w] = True
            support[(j, kk)][v, w] = True
        for key in adj:
            if checked[key]:
                adj[key] = adj[key] & support[key]
    alive = _prune(_sparse(objects, adj), k)
    return _filtered(world, objects, adj, alive)



def discriminator(world: WorldModel, hypotheses: Sequence[AssociationHypothesis],
                  max_range: float | None = None) -> int:
    """The model object whose predicted ego position differs most between the best two hypotheses.

    The paper's active validation (section 2.3, "Hypotheses Validation"): look for this object
    to tell the hypotheses apart.

    Parameters
    ----------
    world : WorldModel
    hypotheses : sequence of AssociationHypothesis
        At least two; the first two are compared.
    max_range : float, optional
        Only objects within this distance (m) of both hypothesised robot positions (visible
        from both); all objects when None or when none qualifies.

    Returns
    -------
    int
        Global object index.
    """
    if not isinstance(world, WorldModel):
        raise WorldGraphError(f"world must be a WorldModel, got {type(world).__name__}")
    hyps = _check_hypotheses(hypotheses)
    if len(hyps) < 2:
        raise TooFewPerceptsError(f"the discriminator needs two hypotheses, got {len(hyps)}")
    if max_range is not None:
        max_range = real_scalar("max_range", max_range, positive=True)
    poses = [rigid_transform(f"hypotheses[{i}].world_from_ego", h.world_from_ego)
             for i, h in enumerate(hyps[:2])]
    X = world.positions
    ego_from_world = [invert_transformation(m) for m in poses]
    pred = [X @ m[:3, :3].T + m[:3, 3] for m in ego_from_world]
    diff = np.linalg.norm(pred[0] - pred[1], axis=1)
    if max_range is not None:
        near = (np.linalg.norm(pred[0], axis=1) <= max_range) \
            & (np.linalg.norm(pred[1], axis=1) <= max_range)
        if near.any():
            diff = np.where(near, diff, -1.0)
    return int(np.argmax(diff))
