"""Tests of worldgraph.tiles: split against a brute-force reference, tiled localisation against
localize on the whole world, ambiguity between identical buildings, the Dask path."""

from __future__ import annotations

import distributed
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import worldgraph as wg
from perception import Percept
from perception.simulation.simulate import simulate_percepts
from worldgraph import scenes
from worldgraph.tiles import Tile, localize_tiled, split


def _percepts(world: wg.WorldModel, pose: np.ndarray, rng: np.random.Generator, n_true: int = 8,
              n_false: int = 1) -> list[Percept]:
    """n_true true percepts of random visible objects (sigma = rho^2 / 1000) and n_false false ones."""
    percepts, truth = simulate_percepts(list(world.types), world.positions, pose, rng, max_range=8.0,
                                        n_false=n_false)
    true_idx = np.flatnonzero(truth >= 0)
    pick = np.concatenate([rng.choice(true_idx, n_true, replace=False), np.flatnonzero(truth < 0)])
    return [percepts[i] for i in rng.permutation(pick)]


def _pose_at_table(world: wg.WorldModel, mask: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    tables = np.flatnonzero((world.types == "table") & mask)
    pose = np.eye(4)
    pose[:3, :3] = Rotation.from_euler("z", rng.uniform(0.0, 2 * np.pi)).as_matrix()
    pose[:3, 3] = world.positions[tables[rng.integers(len(tables))]] + [0.0, 0.0, 0.8]
    return pose


@pytest.fixture(scope="module")
def site() -> scenes.Site:
    return scenes.campus_site(buildings=2, storeys=2, n_objects=4000, seed=1)


@pytest.fixture(scope="module")
def tiles(site) -> tuple[Tile, ...]:
    return split(site.world, site.building)


# ----------------------------------------------------------------------------------------------
# split
# ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("halo", [0.0, 2.5])
def test_split_matches_brute_force(halo):
    rng = np.random.default_rng(3)
    pos = rng.uniform(0.0, 20.0, (300, 3))
    types = rng.choice(["a", "b", "c"], 300)
    world = wg.WorldModel.from_arrays(types, pos)
    labels = np.where(pos[:, 0] < 7.0, 4, np.where(pos[:, 0] < 13.0, 1, 9))
    tiles = split(world, labels, halo=halo)
    assert [t.label for t in tiles] == [1, 4, 9]
    dist = np.linalg.norm(pos[:, None, :] - pos[None, :, :], axis=2)  # all pairs: the slow reference
    covered = np.zeros(300, dtype=bool)
    for t in tiles:
        own = labels == t.label
        expect = np.flatnonzero(own | (dist[:, own].min(axis=1) <= halo))
        np.testing.assert_array_equal(t.index, expect)
        np.testing.assert_array_equal(t.own, own[expect])
        np.testing.assert_array_equal(t.world.positions, pos[expect])
        assert list(t.world.types) == list(types[expect])
        covered |= own
        if halo == 0.0:
            assert t.own.all()
        else:
            assert not t.own.all()  # the halo reaches across the cuts
    assert covered.all()


def test_split_checks_its_arguments(site):
    w = site.world
    with pytest.raises(wg.WorldGraphError, match=r"labels must have shape"):
        split(w, np.zeros(len(w) - 1, dtype=int))
    with pytest.raises(wg.WorldGraphError, match=r"labels must hold integers, got dtype float64"):
        split(w, np.zeros(len(w)))
    with pytest.raises(wg.WorldGraphError, match=r"labels\[0\] must be >= 0, got \-1"):
        split(w, np.full(len(w), -1))
    with pytest.raises(wg.WorldGraphError, match=r"halo must be >= 0, got \-1\.0"):
        split(w, site.building, halo=-1.0)
    with pytest.raises(wg.WorldGraphError, match="world"):
        split(w.positions, site.building)


# ----------------------------------------------------------------------------------------------
# localize_tiled
# ----------------------------------------------------------------------------------------------
def test_tiled_equals_whole_world(site, tiles):
    rng = np.random.default_rng(11)
    statuses = []
    for trial in range(5):
        pose = _pose_at_table(site.world, site.building == trial % 2, rng)
        percepts = _percepts(site.world, pose, rng)
        whole = wg.localize(site.world, percepts)
        tiled = localize_tiled(tiles, percepts, workers=1 if trial % 2 else 2)
        assert tiled.status == whole.status
        np.testing.assert_allclose(tiled.transformation, whole.transformation, rtol=0, atol=1e-9)
        assert tiled.correspondences == whole.correspondences
        for p, o in tiled.correspondences:  # global indices: the matched object is where the percept is
            seen = pose[:3, :3] @ percepts[p].position + pose[:3, 3]
            assert np.linalg.norm(site.world.positions[o] - seen) < 0.5
            assert site.world.types[o] == percepts[p].type
        statuses.append(tiled.status)
    assert statuses.count("ok") >= 3


def test_identical_buildings_are_ambiguous():
    one = scenes.building_site(storeys=1, n_objects=1200, seed=2).world
    shift = np.array([300.0, 0.0, 0.0])
    types = list(one.types) * 2
    world = wg.WorldModel.from_arrays(types, np.vstack([one.positions, one.positions + shift]))
    labels = np.repeat([0, 1], len(one))
    tiles = split(world, labels)
    rng = np.random.default_rng(5)
    pose = _pose_at_table(world, labels == 0, rng)
    percepts = _percepts(world, pose, rng, n_true=8, n_false=0)
    res = localize_tiled(tiles, percepts, workers=2)
    assert res.status == "ambiguous" and res.ambiguous and not res.unique
    assert wg.localize(world, percepts).status == "ambiguous"  # the whole world agrees
    # the two answers are the same pose in either copy: 300 m apart along x
    poses = [res.transformation, *res.alternatives]
    xs = sorted(p[0, 3] for p in poses)
    assert any(abs(b - a - 300.0) < 1e-6 for a in xs for b in xs)
    near = min(poses, key=lambda p: np.linalg.norm(p[:3, 3] - pose[:3, 3]))
    assert np.linalg.norm(near[:3, 3] - pose[:3, 3]) < 0.1


def test_no_pose_anywhere_gives_the_whole_worlds_failure(site, tiles):
    # three percepts of one type on a line 40 m long: no three objects of a tile (or of the
    # world) sit that way, so no association exists
    percepts = [Percept("door", np.array([x, 0.0, 0.0]), 0.01) for x in (1.0, 21.0, 41.0)]
    whole = wg.localize(site.world, percepts)
    tiled = localize_tiled(tiles, percepts, workers=1)
    assert whole.status == tiled.status == "no_association"
    assert np.isnan(tiled.transformation).all()


def test_unknown_types_raise(tiles):
    percepts = [Percept("spaceship", np.array([x, 1.0, 0.0]), 0.01) for x in (1.0, 2.0, 3.5)]
    with pytest.raises(wg.WorldGraphError, match=r"no percept type is in the tile: .*\['spaceship'\]"):
        localize_tiled(tiles, percepts, workers=1)


def test_localize_tiled_checks_its_arguments(tiles):
    p = [Percept("door", np.array([x, 1.0, 0.0]), 0.01) for x in (1.0, 2.0, 3.5)]
    with pytest.raises(wg.WorldGraphError, match=r"tiles\[0\] must be a Tile"):
        localize_tiled([tiles[0].world], p)
    with pytest.raises(wg.WorldGraphError, match=r"tiles must hold at least one Tile, got none"):
        localize_tiled([], p)
    with pytest.raises(wg.WorldGraphError, match="method"):
        localize_tiled(tiles, p, method="magic")
    with pytest.raises(wg.WorldGraphError, match=r"workers must be an integer, got 1\.5"):
        localize_tiled(tiles, p, workers=1.5)
    with pytest.raises(wg.WorldGraphError, match=r"workers must be >= 1, got 0"):
        localize_tiled(tiles, p, workers=0)
    with pytest.raises(wg.WorldGraphError, match=r"scheduler must be None, a scheduler address such"):
        localize_tiled(tiles, p, scheduler=8786)
    with pytest.raises(wg.WorldGraphError, match=r"percepts\[3\] must be a perception\.Percept, got"):
        localize_tiled(tiles, [*p, "door"])
    with pytest.raises(wg.WorldGraphError, match=r"rng must be a numpy\.random\.Generator, got 3"):
        localize_tiled(tiles, p, rng=3)


def test_dask_cluster_gives_the_local_answer(site, tiles):
    rng = np.random.default_rng(23)
    cases = []
    for b in (0, 1):
        pose = _pose_at_table(site.world, site.building == b, rng)
        cases.append(_percepts(site.world, pose, rng))
    local = [localize_tiled(tiles, p, workers=1) for p in cases]
    with distributed.LocalCluster(n_workers=1, processes=False, dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        by_client = [localize_tiled(tiles, p, scheduler=client) for p in cases]
        by_address = localize_tiled(tiles, cases[0], scheduler=cluster.scheduler_address)
    for a, b in zip(local, by_client, strict=True):
        assert a.status == b.status
        np.testing.assert_allclose(a.transformation, b.transformation, rtol=0, atol=1e-12)
        assert a.correspondences == b.correspondences
    assert by_address.correspondences == local[0].correspondences
    assert any(r.status == "ok" for r in local)


def test_pool_keeps_its_workers_and_gives_the_one_process_answer(site, tiles):
    rng = np.random.default_rng(12)
    scans = []
    for trial in range(4):
        pose = _pose_at_table(site.world, site.building == trial % 2, rng)
        scans.append(_percepts(site.world, pose, rng))
    with wg.TilePool(tiles, workers=2) as pool:
        assert not pool.closed and pool.workers == 2 and "2 workers" in repr(pool)
        pids = set()
        for percepts in scans:
            pooled = localize_tiled(tiles, percepts, pool=pool)
            alone = localize_tiled(tiles, percepts, workers=1)
            assert pooled.status == alone.status
            np.testing.assert_allclose(pooled.transformation, alone.transformation, rtol=0, atol=1e-12)
            assert pooled.correspondences == alone.correspondences
            pids |= {p.pid for p in pool._executor._processes.values()}  # type: ignore[union-attr]
        assert 1 <= len(pids) <= 2  # forked once: the same processes served all four calls
    assert pool.closed and "closed" in repr(pool)
    with pytest.raises(wg.WorldGraphError, match="closed"):
        localize_tiled(tiles, scans[0], pool=pool)
    pool.close()  # idempotent


def test_pool_arguments_are_checked(site, tiles):
    p = [Percept("door", np.array([x, 1.0, 0.0]), 0.01) for x in (1.0, 2.0, 3.5)]
    other = split(site.world, site.storey)
    with wg.TilePool(tiles, workers=1) as pool:
        assert pool.serves(list(tiles)) and not pool.serves(other)
        with pytest.raises(wg.WorldGraphError, match="other tiles"):
            localize_tiled(other, p, pool=pool)
        with pytest.raises(wg.WorldGraphError, match="pool cannot be combined"):
            localize_tiled(tiles, p, pool=pool, workers=2)
    with pytest.raises(wg.WorldGraphError, match="pool must be"):
        localize_tiled(tiles, p, pool="pool")
    with pytest.raises(wg.WorldGraphError, match=r"workers must be >= 1, got 0"):
        wg.TilePool(tiles, workers=0)
    with pytest.raises(wg.WorldGraphError, match=r"tiles\[0\] must be a Tile"):
        wg.TilePool([tiles[0].world])
