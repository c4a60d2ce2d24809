"""The networkx views of the association equal its array internals (design card: "the world model
is a networkx graph filtered by proximity and orientation signatures")."""

from __future__ import annotations

import itertools

import networkx as nx
import numpy as np
import pytest

from perception import Percept
from worldgraph.association import associate
from worldgraph.association.cliques import maximum_cliques
from worldgraph.association.consistency import _consistency_graph, _prune
from worldgraph.association.filters import consistency_graph, orientation_filter, proximity_filter
from worldgraph.model import WorldModel
from worldgraph.tolerances import ASSOCIATION_TOLERANCES


def scene(seed: int, n_objects: int = 45, n_true: int = 5, n_false: int = 1
          ) -> tuple[WorldModel, list[Percept]]:
    rng = np.random.default_rng(seed)
    types = rng.choice(["door", "handle", "knob"], n_objects)
    world = WorldModel.from_arrays(types, rng.uniform([0, 0, 0], [6, 5, 2.5], (n_objects, 3)),
                                   max_link_length=4.0)
    robot = np.array([3.0, 2.5, 1.5])
    idx = rng.choice(n_objects, n_true, replace=False)
    percepts = [Percept(str(types[o]), world.positions[o] - robot + rng.normal(0, 0.005, 3), 0.005)
                for o in idx]
    percepts += [Percept(str(rng.choice(types)), rng.uniform(-2, 2, 3), 0.005) for _ in range(n_false)]
    return world, percepts


def gate(p: Percept, q: Percept) -> float:
    return float(ASSOCIATION_TOLERANCES.pair_tolerance(p.sigma, q.sigma))


@pytest.mark.parametrize("seed", range(4))
def test_consistency_graph_edges_are_exactly_the_consistent_pairs(seed: int) -> None:
    world, percepts = scene(seed)
    g = consistency_graph(world, percepts, min_size=2)  # no pruning beyond "has a neighbour"
    X = world.positions
    x = [p.position for p in percepts]
    # brute force over every pair of (percept, same-type object) nodes
    nodes = [(p, int(o)) for p, pc in enumerate(percepts) for o in world.type_index[pc.type]]
    expected = set()
    for (p, o), (q, u) in itertools.combinations(nodes, 2):
        if p == q or o == u:
            continue
        if abs(np.linalg.norm(x[p] - x[q]) - np.linalg.norm(X[o] - X[u])) < gate(percepts[p], percepts[q]):
            expected.add(frozenset([(p, o), (q, u)]))
    got = {frozenset(e) for e in g.edges}
    assert got == expected
    assert all(g.nodes[n]["type"] == percepts[n[0]].type for n in g.nodes)


@pytest.mark.parametrize("seed", range(4))
def test_maximum_cliques_of_the_networkx_graph_equal_the_array_search(seed: int) -> None:
    world, percepts = scene(seed)
    g = consistency_graph(world, percepts)
    nx_cliques = [frozenset(c) for c in nx.find_cliques(g)]
    best = max(len(c) for c in nx_cliques)
    nx_max = {c for c in nx_cliques if len(c) == best}
    graph = _consistency_graph(world, percepts, ASSOCIATION_TOLERANCES)
    objects, adjacency = graph.dense(_prune(graph, best))
    search = maximum_cliques([len(o) for o in objects], adjacency, min_size=best)
    assert search.maximum == best
    arr_max = {frozenset((p, int(objects[p][a])) for p, a in c) for c in search.cliques if len(c) == best}
    assert arr_max == nx_max
    # the association's best hypothesis is built from one of those cliques (or a subset of one)
    hyps = associate(world, percepts)
    assert any(set(hyps[0].pairs) <= set(c) for c in nx_cliques)


@pytest.mark.parametrize("seed", range(3))
def test_filters_return_subgraph_views_of_the_world_graph(seed: int) -> None:
    world, percepts = scene(seed, n_false=0, n_true=4)
    for result in (prox := proximity_filter(world, percepts), orientation_filter(world, percepts, prox)):
        view = result["graph"]
        assert nx.is_frozen(view)
        assert set(view.nodes) == {int(o) for c in result["candidates"] for o in c}
        assert set(view.nodes) <= set(world.graph.nodes)
        linked = {frozenset(map(int, pair)) for pairs in result["links"].values() for pair in pairs}
        for u, v, data in view.edges(data=True):
            assert world.graph.has_edge(u, v)
            assert data["length"] < world.max_link_length
            assert frozenset((u, v)) in linked
        # every surviving link within the link length is an edge of the view
        for pair in linked:
            u, v = tuple(pair)
            if np.linalg.norm(world.positions[u] - world.positions[v]) < world.max_link_length:
                assert view.has_edge(u, v)
