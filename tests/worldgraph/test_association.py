"""Tests of worldgraph.association: exact cliques, filters, hypotheses, ranking, bad input."""

from __future__ import annotations

import contextlib
import itertools
from collections.abc import Iterator

import networkx as nx
import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from perception import Percept
from perception.simulation.simulate import simulate_percepts
from worldgraph.association import associate
from worldgraph.association.cliques import maximum_cliques
from worldgraph.association.consistency import _Graph, _prune_by_pairs, _prune_vectorised
from worldgraph.association.filters import discriminator, orientation_filter, proximity_filter
from worldgraph.association.hypotheses import is_ambiguous
from worldgraph.errors import TooFewPerceptsError, WorldGraphError
from worldgraph.model import WorldModel
from worldgraph.tolerances import AssociationTolerances

TYPES = ("door", "handle", "knob", "drawer")
seeds = st.integers(0, 2**32 - 1)


# ----------------------------------------------------------------------------------------------
# helpers (independent of the code under test)
# ----------------------------------------------------------------------------------------------
@contextlib.contextmanager
def far_path(path: str) -> Iterator[None]:
    """Far percept pairs through the far-pair index ("index"), the k-d trees ("tree": the index
    budget at zero, the ring join off) or the compiled ring join ("ring": numba, every size)."""
    import worldgraph.association.consistency as consistency
    import worldgraph.model.far_pairs as far_pairs

    saved = far_pairs.FAR_PAIR_MAX_PAIRS, consistency.RING_JOIN_MIN_PAIRS, far_pairs.FAR_PAIR_BUILD_ON_USE
    far_pairs.FAR_PAIR_MAX_PAIRS = saved[0] if path == "index" else 0
    far_pairs.FAR_PAIR_BUILD_ON_USE = path == "index"  # the association builds the index it needs
    consistency.RING_JOIN_MIN_PAIRS = 0 if path == "ring" else None
    try:
        yield
    finally:
        far_pairs.FAR_PAIR_MAX_PAIRS, consistency.RING_JOIN_MIN_PAIRS, far_pairs.FAR_PAIR_BUILD_ON_USE = saved


FAR_PATHS = ["index", "tree", "ring"]


def random_world(rng: np.random.Generator, n: int = 120, room=(12.0, 10.0, 2.5)) -> WorldModel:
    pos = rng.uniform([0, 0, 0], room, (n, 3))
    types = rng.choice(TYPES, n)
    return WorldModel.from_arrays(types, pos, max_link_length=5.0, link_margin=0.5)


def random_pose(rng: np.random.Generator, world: WorldModel, yaw_only: bool = False) -> np.ndarray:
    lo, hi = world.bounds
    m = np.eye(4)
    if yaw_only:
        m[:3, :3] = Rotation.from_euler("z", rng.uniform(0, 2 * np.pi)).as_matrix()
    else:
        m[:3, :3] = Rotation.random(random_state=rng).as_matrix()
    m[:3, 3] = rng.uniform(lo + 1.0, hi - 1.0) if np.all(hi - lo > 2.0) else 0.5 * (lo + hi)
    return m


def nearest_objects(world: WorldModel, world_from_ego: np.ndarray, k: int) -> np.ndarray:
    d = np.linalg.norm(world.positions - world_from_ego[:3, 3], axis=1)
    return np.argsort(d)[:k]


def exact_percepts(world: WorldModel, world_from_ego: np.ndarray, idx, sigma: float = 0.01) -> list[Percept]:
    inv_r = world_from_ego[:3, :3].T
    ego = (world.positions[idx] - world_from_ego[:3, 3]) @ inv_r.T
    return [Percept(str(world.types[o]), e, sigma) for o, e in zip(idx, ego, strict=True)]


def assert_true_links_survive(result: dict, truth: np.ndarray) -> None:
    for p, o in enumerate(truth):
        assert o in result["candidates"][p]
    for (p, q), links in result["links"].items():
        assert np.any((links[:, 0] == truth[p]) & (links[:, 1] == truth[q])), (p, q)


# ----------------------------------------------------------------------------------------------
# exact maximum cliques vs networkx
# ----------------------------------------------------------------------------------------------
@st.composite
def kpartite(draw):
    k = draw(st.integers(2, 6))
    sizes = [draw(st.integers(0, 4)) for _ in range(k)]
    density = draw(st.floats(0.2, 0.95))
    rng = np.random.default_rng(draw(seeds))
    adjacency = {}
    for p, q in itertools.combinations(range(k), 2):
        kind = rng.uniform()
        if kind < 0.1:
            continue  # missing key: no edges
        if kind < 0.2:
            adjacency[(p, q)] = None  # all compatible
        else:
            adjacency[(p, q)] = rng.uniform(size=(sizes[p], sizes[q])) < density
    return sizes, adjacency


def to_networkx(sizes, adjacency) -> nx.Graph:
    g = nx.Graph()
    g.add_nodes_from((p, a) for p, s in enumerate(sizes) for a in range(s))
    for (p, q), mat in adjacency.items():
        for a in range(sizes[p]):
            for b in range(sizes[q]):
                if mat is None or mat[a, b]:
                    g.add_edge((p, a), (q, b))
    return g


@given(kpartite(), st.integers(0, 2), st.integers(1, 3), st.sampled_from(["dense", "packed", "csr"]))
def test_maximum_cliques_match_networkx(graph, near: int, min_size: int, form: str) -> None:
    """Dense boolean matrices, or sparse (rows, cols) index pairs packed into bit rows up front or
    kept as CSR rows: the same cliques as networkx."""
    import worldgraph.association.cliques as assoc

    sizes, adjacency = graph
    g = to_networkx(sizes, adjacency)
    if form != "dense":
        adjacency = {key: m if m is None else tuple(np.nonzero(m)) for key, m in adjacency.items()}
    cliques = [tuple(sorted(c)) for c in nx.find_cliques(g)] if g.number_of_nodes() else []
    best = max((len(c) for c in cliques), default=0)
    old = assoc.DENSE_BITS
    assoc.DENSE_BITS = 0 if form == "csr" else old
    try:
        res = maximum_cliques(sizes, adjacency, min_size=min_size, near_maximum=near)
    finally:
        assoc.DENSE_BITS = old
    assert res.complete
    expected_max = best if best >= min_size else 0
    assert res.maximum == expected_max
    if g.number_of_nodes():
        _, weight = nx.max_weight_clique(g, weight=None)
        assert weight == best
    thr = max(best - near, min_size)
    expected = {c for c in cliques if len(c) >= thr} if best >= min_size else set()
    assert set(res.cliques) == expected


@pytest.mark.parametrize("prune", [_prune_by_pairs, _prune_vectorised])
@given(graph=kpartite(), need=st.integers(1, 6), start=st.integers(0, 2**32 - 1))
def test_prune_matches_node_by_node_reference_on_networkx(prune, graph, need: int, start: int) -> None:
    """The vectorised pruning equals the obvious loop: drop, until nothing changes, every vertex
    whose alive neighbours lie in fewer than ``need - 1`` distinct other parts.  Both forms of
    the pruning; started from every vertex, and from the reference's survivors plus a random
    subset of the others (a superset of the answer gives the same answer)."""
    sizes, adjacency = graph
    g = to_networkx(sizes, adjacency)
    alive = set(g.nodes)
    changed = True
    while changed:
        changed = False
        for node in sorted(alive):
            parts = {q for q, _ in g.neighbors(node) if (q, _) in alive}
            if len(parts) < need - 1:
                alive.discard(node)
                changed = True
    edges = {key: (None if mat is None else tuple(np.nonzero(mat))) for key, mat in adjacency.items()}
    objects = [np.arange(s, dtype=np.intp) for s in sizes]
    got = prune(_Graph(objects, edges), need)
    assert [a.shape for a in got] == [(s,) for s in sizes]
    assert {(p, a) for p, al in enumerate(got) for a in np.flatnonzero(al)} == alive
    rng = np.random.default_rng(start)
    superset = [rng.random(s) < 0.5 for s in sizes]
    for p, a in alive:
        superset[p][a] = True
    got = prune(_Graph(objects, edges), need, superset)
    assert {(p, a) for p, al in enumerate(got) for a in np.flatnonzero(al)} == alive


def test_maximum_cliques_sparse_adjacency_bad_input_is_named() -> None:
    with pytest.raises(WorldGraphError, match=r"adjacency\[\(0, 1\)\] cols\[1\] = 5 is outside \[0, 2\)"):
        maximum_cliques([2, 2], {(0, 1): (np.array([0, 1]), np.array([0, 5]))})
    with pytest.raises(WorldGraphError, match="equal length"):
        maximum_cliques([2, 2], {(0, 1): (np.array([0, 1]), np.array([0]))})
    with pytest.raises(WorldGraphError, match="integer"):
        maximum_cliques([2, 2], {(0, 1): (np.array([0.5]), np.array([0]))})
    with pytest.raises(WorldGraphError, match="length 3"):
        maximum_cliques([2, 2], {(0, 1): (np.array([0]), np.array([0]), np.array([0]))})


def test_maximum_cliques_by_hand() -> None:
    # parts of one vertex each; edges 0-1, 1-2, 0-2 (triangle), 2-3
    sizes = [1, 1, 1, 1]
    t, f = np.ones((1, 1), bool), np.zeros((1, 1), bool)
    adjacency = {(0, 1): t, (0, 2): t, (1, 2): t, (2, 3): t, (0, 3): f, (1, 3): f}
    res = maximum_cliques(sizes, adjacency, near_maximum=1)
    assert res.maximum == 3
    assert set(res.cliques) == {((0, 0), (1, 0), (2, 0)), ((2, 0), (3, 0))}
    with pytest.raises(WorldGraphError, match="shape"):
        maximum_cliques([2, 2], {(0, 1): np.ones((3, 2), bool)})


# ----------------------------------------------------------------------------------------------
# soundness of the filters and the top hypothesis
# ----------------------------------------------------------------------------------------------
@settings(max_examples=15)
@given(seeds, st.integers(4, 8))
def test_true_association_survives_and_wins_noise_free(seed: int, k: int) -> None:
    rng = np.random.default_rng(seed)
    world = random_world(rng)
    pose = random_pose(rng, world)
    truth = nearest_objects(world, pose, k)
    percepts = exact_percepts(world, pose, truth)
    prox = proximity_filter(world, percepts)
    assert_true_links_survive(prox, truth)
    orient = orientation_filter(world, percepts, prox)
    assert_true_links_survive(orient, truth)
    for a, b in zip(orient["candidates"], prox["candidates"], strict=True):
        assert set(a.tolist()) <= set(b.tolist())
    for method in ("clique", "paper"):
        hyps = associate(world, percepts, method=method)
        assert hyps, method
        assert hyps[0].pairs == tuple((p, int(o)) for p, o in enumerate(truth)), method
        assert np.allclose(hyps[0].world_from_ego, pose, atol=1e-8)
        assert hyps[0].cost < 1e-6


@settings(max_examples=8)
@given(seeds)
def test_clutter_with_a_type_per_object_associates_as_one_clutter_type(seed: int) -> None:
    """Objects no percept names may each have their own type (CAD node names, a link
    table only for the type pairs with links); association answers as on the same world with
    those types merged into one (reference), since it matches percepts by type only."""
    rng = np.random.default_rng(seed)
    n = 120
    pos = rng.uniform([0, 0, 0], (12.0, 10.0, 2.5), (n, 3))
    clutter = rng.uniform(size=n) < 0.5
    kinds = rng.choice(TYPES, n)
    merged_types = np.where(clutter, "clutter", kinds)
    split_types = np.array([f"part{k}" if c else str(t) for k, (c, t) in enumerate(zip(clutter, kinds,
                                                                                          strict=True))])
    merged = WorldModel.from_arrays(merged_types, pos, max_link_length=5.0, link_margin=0.5)
    split = WorldModel.from_arrays(split_types, pos, max_link_length=5.0, link_margin=0.5)
    assert len(split.type_index) == int(clutter.sum()) + len(set(kinds[~clutter].tolist()))
    pose = random_pose(rng, merged)
    d = np.linalg.norm(pos - pose[:3, 3], axis=1)
    truth = [int(o) for o in np.argsort(d) if not clutter[o]][:6]
    percepts = exact_percepts(merged, pose, truth)
    a, b = associate(merged, percepts), associate(split, percepts)
    assert a and a[0].pairs == tuple(enumerate(truth))
    assert len(a) == len(b)
    for ha, hb in zip(a, b, strict=True):
        assert ha.pairs == hb.pairs
        assert np.isclose(ha.cost, hb.cost)
        assert np.allclose(ha.world_from_ego, hb.world_from_ego, atol=1e-9)


@settings(max_examples=10)
@given(seeds)
def test_result_does_not_depend_on_percept_order(seed: int) -> None:
    rng = np.random.default_rng(seed)
    world = random_world(rng)
    pose = random_pose(rng, world)
    percepts, truth = simulate_percepts(list(world.types), world.positions, pose, rng, max_range=4.5,
                                        depth_factor=1000.0, n_false=1)
    percepts, truth = percepts[:8], truth[:8]
    if len(percepts) < 4:
        percepts = exact_percepts(world, pose, nearest_objects(world, pose, 6))
    perm = rng.permutation(len(percepts))
    a = associate(world, percepts)
    b = associate(world, [percepts[i] for i in perm])
    assert len(a) == len(b)
    for ha, hb in zip(a, b, strict=True):
        assert sorted(ha.pairs) == sorted((int(perm[p]), o) for p, o in hb.pairs)
        assert np.isclose(ha.cost, hb.cost)
        assert np.allclose(ha.world_from_ego, hb.world_from_ego, atol=1e-9)


@settings(max_examples=10)
@given(seeds)
def test_rigid_motion_of_world_moves_pose(seed: int) -> None:
    rng = np.random.default_rng(seed)
    world = random_world(rng)
    pose = random_pose(rng, world)
    percepts = exact_percepts(world, pose, nearest_objects(world, pose, 6))
    move = np.eye(4)
    move[:3, :3] = Rotation.random(random_state=rng).as_matrix()
    move[:3, 3] = rng.uniform(-20, 20, 3)
    moved = WorldModel.from_arrays(world.types, world.positions @ move[:3, :3].T + move[:3, 3],
                                   max_link_length=5.0, link_margin=0.5)
    # the free search is invariant under any rigid motion of the world ...
    a = associate(world, percepts, gravity=None)[0]
    b = associate(moved, percepts, gravity=None)[0]
    assert a.pairs == b.pairs
    assert np.allclose(move @ a.world_from_ego, b.world_from_ego, atol=1e-8)
    # ... the gravity search (the default) under those that keep the world's z axis
    move[:3, :3] = Rotation.from_euler("z", rng.uniform(0, 2 * np.pi)).as_matrix()
    level = WorldModel.from_arrays(world.types, world.positions @ move[:3, :3].T + move[:3, 3],
                                   max_link_length=5.0, link_margin=0.5)
    a = associate(world, percepts)[0]
    c = associate(level, percepts)[0]
    assert a.pairs == c.pairs and a.search == c.search
    assert np.allclose(move @ a.world_from_ego, c.world_from_ego, atol=1e-8)


@settings(max_examples=15)
@given(seeds, st.integers(1, 2))
def test_false_percepts_do_not_break_association(seed: int, n_false: int) -> None:
    rng = np.random.default_rng(seed)
    world = random_world(rng)
    pose = random_pose(rng, world, yaw_only=True)
    truth = nearest_objects(world, pose, 6)
    percepts = exact_percepts(world, pose, truth, sigma=0.02)
    noisy = [Percept(p.type, p.position + rng.normal(scale=0.02, size=3), 0.02) for p in percepts]
    # false percepts of known types, placed among the true ones
    ego = np.array([p.position for p in percepts])
    for _ in range(n_false):
        noisy.append(Percept(str(rng.choice(TYPES)), rng.uniform(ego.min(0) - 1, ego.max(0) + 1), 0.02))
    hyps = associate(world, noisy)
    assert hyps
    # the robust cost, recomputed by brute force for every hypothesis
    tol = AssociationTolerances()
    for h in hyps:
        expected = 0.0
        for per in noisy:
            pred = h.world_from_ego[:3, :3] @ per.position + h.world_from_ego[:3, 3]
            same = world.positions[world.types == per.type]
            d2 = np.min(np.sum((same - pred) ** 2, axis=1)) / (tol.residual_factor * per.sigma) ** 2
            expected += min(d2, tol.cost_cap)
        assert np.isclose(h.cost, expected, rtol=1e-9, atol=1e-9)
    costs = [h.cost for h in hyps]
    assert costs == sorted(costs)
    truth_of = dict(enumerate(truth.tolist()))
    top = hyps[0]
    assert all(p in truth_of and truth_of[p] == o for p, o in top.all_pairs), (top.pairs, truth)
    assert top.size >= 5
    assert np.linalg.norm(top.world_from_ego[:3, 3] - pose[:3, 3]) < 0.2


@settings(max_examples=10)
@given(seeds)
def test_gravity_aligned_invariant(seed: int) -> None:
    rng = np.random.default_rng(seed)
    world = random_world(rng)
    pose = random_pose(rng, world, yaw_only=True)
    truth = nearest_objects(world, pose, 6)
    percepts = exact_percepts(world, pose, truth)
    tol = AssociationTolerances(gravity_aligned=True)
    hyps = associate(world, percepts, tol)
    assert hyps[0].pairs == tuple((p, int(o)) for p, o in enumerate(truth))
    # a pose tilted by 30 degrees breaks the gravity assumption: the true match is no clique
    tilt = pose.copy()
    tilt[:3, :3] = pose[:3, :3] @ Rotation.from_euler("x", 30, degrees=True).as_matrix()
    tilted = exact_percepts(world, tilt, truth)
    bad = associate(world, tilted, tol)
    assert all(h.pairs != tuple((p, int(o)) for p, o in enumerate(truth)) for h in bad)


# ----------------------------------------------------------------------------------------------
# mirror matches, symmetric worlds, the discriminator
# ----------------------------------------------------------------------------------------------
def test_mirror_copy_is_rejected_by_chirality() -> None:
    rng = np.random.default_rng(7)
    base = rng.uniform([0, 0, 0], [4, 4, 2.5], (6, 3))
    types = np.array(["door", "handle", "knob", "drawer", "handle", "knob"])
    mirror = base * np.array([-1.0, 1.0, 1.0]) + np.array([40.0, 0.0, 0.0])
    world = WorldModel.from_arrays(np.concatenate([types, types]), np.vstack([base, mirror]),
                                   max_link_length=6.0)
    pose = np.eye(4)
    pose[:3, 3] = [2.0, 2.0, 1.2]
    percepts = exact_percepts(world, pose, np.arange(6))
    hyps = associate(world, percepts)
    assert hyps[0].pairs == tuple((p, p) for p in range(6))
    assert all(o < 6 for h in hyps for _, o in h.pairs)  # no hypothesis in the mirrored copy
    assert not is_ambiguous(hyps)


def test_symmetric_world_is_ambiguous_and_discriminator_tells_apart() -> None:
    rng = np.random.default_rng(11)
    base = rng.uniform([0, 0, 0], [4, 4, 2.5], (6, 3))
    types = np.array(["door", "handle", "knob", "drawer", "handle", "knob"])
    shift = np.array([30.0, 0.0, 0.0])
    extra = np.array([[2.0, 8.0, 1.0]])  # breaks the symmetry away from the percepts
    world = WorldModel.from_arrays(np.concatenate([types, types, ["door"]]),
                                   np.vstack([base, base + shift, extra]), max_link_length=6.0)
    pose = np.eye(4)
    pose[:3, 3] = [2.0, 2.0, 1.2]
    percepts = exact_percepts(world, pose, np.arange(6))
    hyps = associate(world, percepts)
    assert len(hyps) >= 2
    assert is_ambiguous(hyps)
    expected = {tuple((p, p) for p in range(6)), tuple((p, p + 6) for p in range(6))}
    assert {h.pairs for h in hyps[:2]} == expected
    obj = discriminator(world, hyps)
    # brute force: predicted ego position of every object under both poses
    diffs = []
    for o in range(len(world)):
        pe = [np.linalg.solve(h.world_from_ego, np.append(world.positions[o], 1.0))[:3] for h in hyps[:2]]
        diffs.append(np.linalg.norm(pe[0] - pe[1]))
    assert np.isclose(diffs[obj], max(diffs))
    with pytest.raises(TooFewPerceptsError):
        discriminator(world, hyps[:1])


# ----------------------------------------------------------------------------------------------
# the paper's method and bad input
# ----------------------------------------------------------------------------------------------
def test_paper_method_fails_with_a_false_percept_clique_does_not() -> None:
    rng = np.random.default_rng(5)
    world = random_world(rng)
    pose = random_pose(rng, world, yaw_only=True)
    truth = nearest_objects(world, pose, 6)
    percepts = exact_percepts(world, pose, truth)
    far = Percept("door", np.array([0.0, 0.0, 30.0]), 0.01)  # nothing in the model is that far above
    assert associate(world, percepts + [far], method="paper") == []
    hyps = associate(world, percepts + [far])
    assert hyps[0].pairs == tuple((p, int(o)) for p, o in enumerate(truth))


def test_bad_input() -> None:
    rng = np.random.default_rng(0)
    world = random_world(rng, n=30)
    percepts = exact_percepts(world, np.eye(4), np.arange(4))
    with pytest.raises(WorldGraphError, match=r"percepts\[4\] has type 'window', which is not in"):
        associate(world, percepts + [Percept("window", [1.0, 0, 0], 0.01)])
    with pytest.raises(TooFewPerceptsError, match="got 2"):
        associate(world, percepts[:2])
    with pytest.raises(WorldGraphError, match="Percept"):
        associate(world, percepts[:3] + [np.zeros(3)])  # type: ignore[list-item]
    with pytest.raises(WorldGraphError, match="method"):
        associate(world, percepts, method="ransac")
    with pytest.raises(WorldGraphError, match="WorldModel"):
        associate(world.positions, percepts)  # type: ignore[arg-type]
    with pytest.raises(WorldGraphError, match="n_sigma"):
        AssociationTolerances(n_sigma=-1.0)
    with pytest.raises(WorldGraphError, match="mu_max"):
        AssociationTolerances(mu_max=float("nan"))
    with pytest.raises(WorldGraphError, match="min_clique_size"):
        AssociationTolerances(min_clique_size=1)


@settings(max_examples=8)
@given(seeds)
def test_ball_query_path_equals_brute_force_path(seed: int) -> None:
    """Percepts farther apart than the link table reaches: k-d tree annulus vs all pairs."""
    rng = np.random.default_rng(seed)
    world = WorldModel.from_arrays(rng.choice(TYPES, 150), rng.uniform([0, 0, 0], [14, 12, 2.5], (150, 3)),
                                   max_link_length=2.0)
    pose = random_pose(rng, world, yaw_only=True)
    truth = nearest_objects(world, pose, 7)
    percepts = exact_percepts(world, pose, truth, sigma=0.02)
    brute = associate(world, percepts, AssociationTolerances(dense_pair_limit=10**9))
    tree = associate(world, percepts, AssociationTolerances(dense_pair_limit=0))
    assert [h.pairs for h in brute] == [h.pairs for h in tree]
    assert [h.cost for h in brute] == pytest.approx([h.cost for h in tree])
    assert tree[0].pairs == tuple((p, int(o)) for p, o in enumerate(truth))


@pytest.mark.parametrize("path", FAR_PATHS)
@settings(max_examples=8)
@given(seed=seeds, gravity=st.booleans())
def test_tree_pair_candidates_equal_all_pairs_also_across_storeys(path: str, seed: int,
                                                                  gravity: bool) -> None:
    """Every percept pair's model candidates beyond the link table: the world's far-pair index
    (sorted distances, or horizontal distances and dz), the k-d tree queries (plain, and with
    z scaled for gravity-aligned worlds; forced by a zero index budget) and the compiled ring
    and shell joins give exactly the pairs an all-pairs test gives, on a three-storey world where
    other storeys hold pairs of the same 3D length (percept pairs up to 17 m apart and 3.5 m in
    z: some beyond the index's reach)."""
    with far_path(path):
        _check_pair_candidates(seed, gravity, path == "index")


def storey_world(rng: np.random.Generator, n: int, k: int, spread: float) -> tuple[WorldModel, list[Percept]]:
    """``n`` objects on three storeys 3 m apart (a 1.5 m link table) and ``k`` random percepts
    within ``spread`` m sideways: pairs beyond the link table, some across storeys."""
    storey = rng.integers(0, 3, n)
    pos = np.column_stack([rng.uniform(0, 14, n), rng.uniform(0, 12, n),
                           3.0 * storey + rng.uniform(0, 2.5, n)])
    world = WorldModel.from_arrays(rng.choice(TYPES, n), pos, max_link_length=1.5)
    percepts = [Percept(str(t), rng.uniform([-spread, -spread, -1], [spread, spread, 2.5]),
                        float(rng.uniform(0.01, 0.08))) for t in rng.choice(TYPES, k)]
    return world, percepts


def _check_pair_candidates(seed: int, gravity: bool, index: bool) -> None:
    from worldgraph.association.consistency import _consistency_graph

    rng = np.random.default_rng(seed)
    world, percepts = storey_world(rng, 240, 7, 6.0)
    brute = _consistency_graph(world, percepts, AssociationTolerances(dense_pair_limit=10**9,
                                                                      gravity_aligned=gravity))
    tree = _consistency_graph(world, percepts, AssociationTolerances(dense_pair_limit=0,
                                                                     gravity_aligned=gravity))
    assert brute.edges.keys() == tree.edges.keys()
    for key, e in brute.edges.items():
        got = tree.edges[key]
        assert {tuple(x) for x in np.column_stack(e)} == {tuple(x) for x in np.column_stack(got)}, key
    built = [x for x in world._far_pairs.values() if x is not None]
    assert bool(built) == index  # the path under test was taken


@pytest.mark.parametrize("path", FAR_PATHS)
@settings(max_examples=8)
@given(seed=seeds, gravity=st.booleans())
def test_far_pair_candidates_between_chosen_rows_and_columns(path: str, seed: int, gravity: bool,
                                                            ) -> None:
    """Far percept pair candidates restricted to some of p's objects (``rows``) and some of q's
    (``cols``; few enough for a k-d tree of their own, or most of q's against the type's kept
    tree) are exactly the all-pairs candidates whose ends are both chosen, through the far-pair
    index, the k-d trees (the index budget at zero) and the compiled ring join."""
    from worldgraph.association.consistency import _consistency_graph, _pair_candidates

    rng = np.random.default_rng(seed)
    world, percepts = storey_world(rng, 300, 5, 5.0)
    tol = AssociationTolerances(dense_pair_limit=0, gravity_aligned=gravity)
    brute = _consistency_graph(world, percepts, AssociationTolerances(dense_pair_limit=10**9,
                                                                      gravity_aligned=gravity))
    objects = [world.type_index[p.type] for p in percepts]
    with far_path(path):
        for (p, q), e in brute.edges.items():
            tau = float(tol.pair_tolerance(percepts[p].sigma, percepts[q].sigma))
            for frac_p, frac_q in ((0.3, 0.2), (0.9, 0.8), (1.0, 0.1)):
                rows = np.flatnonzero(rng.random(len(objects[p])) < frac_p)
                cols = np.flatnonzero(rng.random(len(objects[q])) < frac_q)
                got = _pair_candidates(world, percepts, p, q, tau, tol, objects, rows, cols)
                want = {(a, b) for a, b in np.column_stack(e) if a in set(rows) and b in set(cols)}
                assert {tuple(x) for x in np.column_stack(got)} == want, (p, q, frac_p, frac_q)


@pytest.mark.parametrize("path", FAR_PATHS)
@settings(max_examples=10)
@given(seed=seeds, gravity=st.booleans(), n_false=st.integers(0, 2))
@example(seed=24, gravity=False, n_false=1)  # smaller clique sizes revive q objects
@example(seed=19, gravity=True, n_false=2)
def test_lazy_far_pairs_give_the_hypotheses_of_the_full_graph(path: str, seed: int, gravity: bool,
                                                              n_false: int) -> None:
    """Far percept pairs filled only between the objects that survive the near pairs' pruning
    (through the far-pair index, the k-d trees or the ring join): the same hypotheses (pairs and
    costs) as the graph with every far pair computed up front."""
    with far_path(path):
        _check_lazy_far_pairs(seed, gravity, n_false)


def _check_lazy_far_pairs(seed: int, gravity: bool, n_false: int) -> None:
    import worldgraph.association.consistency as assoc

    rng = np.random.default_rng(seed)
    world = WorldModel.from_arrays(rng.choice(TYPES, 300), rng.uniform([0, 0, 0], [20, 16, 2.5], (300, 3)),
                                   max_link_length=2.0)
    pose = random_pose(rng, world, yaw_only=True)
    truth = nearest_objects(world, pose, 7)
    percepts = exact_percepts(world, pose, truth, sigma=0.02)
    for _ in range(n_false):
        percepts.append(Percept(str(rng.choice(TYPES)), rng.uniform(-4, 4, 3), 0.02))
    tol = AssociationTolerances(dense_pair_limit=0, gravity_aligned=gravity)
    lazy = associate(world, percepts, tol)
    real = assoc._is_far
    assoc._is_far = lambda *args: False  # every pair computed eagerly, for all objects
    try:
        eager = associate(world, percepts, tol)
    finally:
        assoc._is_far = real
    assert [h.pairs for h in lazy] == [h.pairs for h in eager]
    assert [h.cost for h in lazy] == pytest.approx([h.cost for h in eager])
    assert [h.complete for h in lazy] == [h.complete for h in eager]


def test_orientation_filter_names_percepts_when_they_do_not_match_the_proximity_result() -> None:
    from worldgraph.errors import WorldGraphError

    rng = np.random.default_rng(5)
    world = random_world(rng)
    pose = random_pose(rng, world)
    percepts = exact_percepts(world, pose, nearest_objects(world, pose, 5))
    prox = proximity_filter(world, percepts)
    with pytest.raises(WorldGraphError, match=r"percepts has 4 percepts but proximity\['objects'\] has 5"):
        orientation_filter(world, percepts[:4], prox)


@pytest.mark.parametrize("gravity", [False, True])
def test_far_pair_cost_estimate_counts_the_query_hits(gravity: bool, monkeypatch) -> None:
    """The rounds' cost per row (k-d tree path, the far-pair index off) is the mean number of
    objects the query of a sampled row visits, counted here by brute force over all objects."""
    import worldgraph.model.far_pairs as far_pairs
    from worldgraph.association.consistency import FAR_COST_SAMPLE, GRAVITY_Z_SCALE, _far_hits_per_row

    monkeypatch.setattr(far_pairs, "FAR_PAIR_BUDGET", 0)

    rng = np.random.default_rng(3)
    world = WorldModel.from_arrays(rng.choice(["a", "b"], 400), rng.uniform([0, 0, 0], [30, 20, 6], (400, 3)),
                                   max_link_length=1.0)
    percepts = [Percept("a", np.array([0.0, 0.0, 0.5]), 0.02), Percept("b", np.array([6.0, 2.0, 1.5]), 0.03)]
    tol = AssociationTolerances(gravity_aligned=gravity, tilt_allowance=0.0)  # the level gates
    objects = [world.type_index["a"], world.type_index["b"]]
    got = _far_hits_per_row(world, percepts, 0, 1, 0.1, tol, objects)
    assert not [x for x in world._far_pairs.values() if x is not None]  # the tree path was taken
    op, oq = objects
    pick = op[np.unique(np.linspace(0, len(op) - 1, min(len(op), FAR_COST_SAMPLE)).astype(int))]
    diff = percepts[1].position - percepts[0].position
    s = GRAVITY_Z_SCALE if gravity else 1.0
    counts = []
    for a in pick:
        v = world.positions[oq] - world.positions[a] - ([0.0, 0.0, diff[2]] if gravity else 0.0)
        v = v * [1.0, 1.0, s]
        if gravity:
            radius = np.hypot(np.hypot(diff[0], diff[1]) + 0.1, s * 0.1)
        else:
            radius = np.linalg.norm(diff) + 0.1
        counts.append(np.count_nonzero(np.linalg.norm(v, axis=1) <= radius))
    assert got == pytest.approx(max(1.0, float(np.mean(counts))), rel=1e-12)
    assert got > 1.0


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_truncated_near_maximum_search_keeps_every_maximum_clique(seed: int) -> None:
    """When the near-maximum enumeration stops at ``max_cliques``, the maximum cliques are
    searched apart (in the graph pruned for their size) and all of them still become
    hypotheses: the same largest hypotheses as an enumeration with room for every clique, and
    the answer flagged incomplete."""
    rng = np.random.default_rng(seed)
    module = rng.uniform([0, 0, 0], [3.0, 2.5, 2.0], (6, 3))
    types = list(rng.choice(TYPES, 6))
    # six rooms with one object moved (maximal cliques of five; first in the object order, so
    # the enumeration meets them first), then four identical rooms 4 m apart (four maximum
    # cliques of the six true percepts), plus clutter
    moved = [module + np.where(np.arange(6)[:, None] == r, [0.0, 0.0, 0.9], 0.0) for r in range(6)]
    pos = np.concatenate([m + [4.0 * r, 0.0, 0.0] for r, m in enumerate(moved)] +
                         [module + [4.0 * (6 + r), 0.0, 0.0] for r in range(4)] +
                         [rng.uniform([0, 3.0, 0], [40, 6, 2.0], (40, 3))])
    world = WorldModel.from_arrays(types * 10 + list(rng.choice(TYPES, 40)), pos, max_link_length=5.0)
    pose = np.eye(4)
    pose[:3, 3] = [24.0 + 1.5, -1.0, 1.0]
    percepts = exact_percepts(world, pose, np.arange(36, 42), sigma=0.01)
    percepts.append(Percept(str(rng.choice(TYPES)), np.array([0.3, 2.5, 0.4]), 0.01))
    roomy = associate(world, percepts, AssociationTolerances(max_hypotheses=1000), max_hypotheses=1000)
    tight_tol = AssociationTolerances(max_cliques=5, max_hypotheses=1000)
    tight = associate(world, percepts, tight_tol, max_hypotheses=1000)
    assert all(h.complete for h in roomy)
    assert tight and not any(h.complete for h in tight)  # the enumeration was cut short
    size = max(len(h.pairs) for h in roomy)
    assert size == 6
    largest = {tuple(h.pairs) for h in roomy if len(h.pairs) == size}
    assert len(largest) >= 4  # one per room (and no more than fits in max_cliques)
    assert {tuple(h.pairs) for h in tight if len(h.pairs) == size} == largest


@settings(max_examples=10)
@given(seed=seeds)
def test_gravity_link_window_keeps_every_pair_of_the_exact_test(seed: int) -> None:
    """Percept pairs within the link table of a gravity-aligned world: the candidates (through
    the 3D-length window that the horizontal and height tolerances allow) are exactly the
    object pairs of the two types that pass |h_m - h| < tau + wh, |dz_m - dz| < ztol + wz and
    |d_m - d| < tau (a tilt keeps 3D lengths), computed here over all pairs, with the tilt
    allowance t's widening wh = h (1 - cos t) + |dz| sin t, wz = h sin t + |dz| (1 - cos t)
    (t = 0: the level gates); percepts placed at true objects, so that pairs sit on the window."""
    from worldgraph.association.consistency import _pair_candidates

    rng = np.random.default_rng(seed)
    n = 260
    storey = rng.integers(0, 3, n)
    pos = np.column_stack([rng.uniform(0, 10, n), rng.uniform(0, 8, n),
                           3.0 * storey + rng.uniform(0, 2.5, n)])
    world = WorldModel.from_arrays(rng.choice(TYPES, n), pos, max_link_length=4.0)
    first = int(rng.integers(n))  # and the four objects nearest to it: pairs within the link table
    picks = np.argsort(np.linalg.norm(world.positions - world.positions[first], axis=1))[:5]
    percepts = [Percept(str(world.types[k]), world.positions[k] - world.positions[picks[0]]
                        + rng.normal(0, 0.02, 3), float(rng.uniform(0.01, 0.08))) for k in picks]
    tilt = float(rng.choice([0.0, np.radians(5.0)]))
    tol = AssociationTolerances(gravity_aligned=True, height_tolerance=float(rng.choice([0.05, 0.3])),
                                tilt_allowance=tilt)
    objects = [world.type_index[p.type] for p in percepts]
    checked = 0
    for p, q in itertools.combinations(range(5), 2):
        diff = percepts[q].position - percepts[p].position
        tau = float(tol.pair_tolerance(percepts[p].sigma, percepts[q].sigma))
        h = np.hypot(diff[0], diff[1])
        htol = tau + h * (1 - np.cos(tilt)) + abs(diff[2]) * np.sin(tilt)
        ztol = tol.height_tolerance + h * np.sin(tilt) + abs(diff[2]) * (1 - np.cos(tilt))
        if np.linalg.norm(diff) + tau >= world.max_link_length + world.link_margin:
            continue  # beyond the link table: other tests cover those
        checked += 1
        a, b = _pair_candidates(world, percepts, p, q, tau, tol, objects)
        op, oq = objects[p], objects[q]
        dv = world.positions[oq][None, :, :] - world.positions[op][:, None, :]
        ok = (np.abs(dv[..., 2] - diff[2]) < ztol) & \
            (np.abs(np.hypot(dv[..., 0], dv[..., 1]) - h) < htol) & \
            (np.abs(np.linalg.norm(dv, axis=-1) - np.linalg.norm(diff)) < tau) & \
            (op[:, None] != oq[None, :])
        want = set(zip(*np.nonzero(ok), strict=True))
        assert {tuple(x) for x in np.column_stack([a, b])} == want, (p, q)
    assert checked


@given(st.integers(0, 2**32 - 1), st.integers(1, 40), st.integers(1, 12))
def test_rank_merges_as_same_pose_one_pair_at_a_time(seed: int, n: int, limit: int) -> None:
    """``_rank`` compares a hypothesis with every kept one at once; the reference here walks
    the kept ones with the pose test written out (translation norm, ``rotation_angle``) and
    checks ``same_pose`` against it on the way (clusters of nearby poses, some matching a
    percept to another object, so that both the merge and the keep branch run)."""
    from scipy.spatial.transform import Rotation

    from worldgraph.association import AssociationTolerances, same_pose
    from worldgraph.association.hypotheses import AssociationHypothesis, _rank

    rng = np.random.default_rng(seed)
    tol = AssociationTolerances()
    centres = [Rotation.random(random_state=rng).as_matrix() for _ in range(3)]
    hyps = []
    for _ in range(n):
        T = np.eye(4)
        step = rng.choice([0.1, 1.0, 3.0]) * tol.distinct_angle
        T[:3, :3] = Rotation.from_rotvec(step * rng.normal(size=3) / 3).as_matrix() @ centres[rng.integers(3)]
        T[:3, 3] = rng.choice([0.1, 1.0, 3.0]) * tol.distinct_translation * rng.normal(size=3) / 3
        pairs = tuple((p, int(rng.integers(2))) for p in range(3))
        hyps.append(AssociationHypothesis(pairs, float(rng.integers(5)), 3, T))
    from worldgraph.pose import rotation_angle

    def close(a: np.ndarray, b: np.ndarray) -> bool:
        out = bool(np.linalg.norm(a[:3, 3] - b[:3, 3]) < tol.distinct_translation
                   and rotation_angle(a[:3, :3], b[:3, :3]) < tol.distinct_angle)
        assert same_pose(a, b, tol) == out
        return out

    kept: list = []
    for h in sorted(hyps, key=lambda h: (h.cost, -h.size, h.pairs)):
        if any(close(h.world_from_ego, g.world_from_ego)
               and all(dict(g.all_pairs).get(p, o) == o for p, o in h.all_pairs) for g in kept):
            continue
        kept.append(h)
        if len(kept) >= limit:
            break
    got = _rank(hyps, tol, limit)
    assert [id(h) for h in got] == [id(h) for h in kept]
