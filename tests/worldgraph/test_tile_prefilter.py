"""The tile pre-filter (worldgraph.tiles.prefilter): a skipped tile never holds an answer (every tile
is visited as the reference), the summaries are the link tables' bins, and the position prior."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import worldgraph as wg
from perception import Percept
from perception.simulation.simulate import simulate_percepts
from tests.problems import robot_at_a_table
from worldgraph import scenes
from worldgraph.errors import WorldGraphError
from worldgraph.localization.result import POSE_STATUSES
from worldgraph.tiles import TileSummary, localize_tiled, split, summarize, tiles_to_visit


@pytest.fixture(scope="module")
def campus() -> tuple[scenes.Site, tuple]:
    site = scenes.campus_site(buildings=4, storeys=2, n_objects=6000, seed=3)
    tiles = split(site.world, site.labels("storey"))
    return site, tiles


@pytest.fixture(scope="module")
def summaries(campus) -> tuple[TileSummary, ...]:
    return tuple(summarize(t) for t in campus[1])


@pytest.fixture(scope="module")
def mixed() -> tuple[wg.WorldModel, np.ndarray, tuple, tuple[TileSummary, ...]]:
    """A varied site: the campus's storeys (offices: doors, lamps, signs, ...) and five kitchens of
    other layouts 200 m away (drawers, knobs, ovens, ...), a few sparse landmark groups."""
    site = scenes.campus_site(buildings=2, storeys=2, n_objects=3000, seed=5)
    types, pos = [list(site.world.types)], [site.world.positions]
    labels = [site.labels("storey")]
    for k, kind in enumerate(scenes.LAYOUT_KINDS):
        kitchen = scenes.kitchen_layout(kind, seed=k)
        types.append(list(kitchen.types))
        pos.append(kitchen.positions + [200.0 + 10.0 * k, 0.0, 0.0])
        labels.append(np.full(len(kitchen), 100 + k))
    rng = np.random.default_rng(0)
    for k in range(3):  # sparse groups: four landmarks of kitchen and office types
        types.append(["door", "handle", "knob", "lamp"])
        pos.append(rng.uniform([0.0, 0.0, 0.5], [6.0, 6.0, 2.5], (4, 3)) + [0.0, 300.0 + 20.0 * k, 0.0])
        labels.append(np.full(4, 200 + k))
    world = wg.WorldModel.from_arrays(sum(types, []), np.vstack(pos))
    lab = np.concatenate(labels)
    tiles = split(world, lab)
    return world, lab, tiles, tuple(summarize(t) for t in tiles)


def _robot_in(world: wg.WorldModel, lab: np.ndarray, seed: int) -> tuple[int, np.ndarray, list[Percept]]:
    """A robot 1.5 m above a random object's floor point in a random tile, random yaw, 5 true
    percepts of its tile within 7 m and 1 false one."""
    rng = np.random.default_rng(seed)
    while True:
        o = int(rng.integers(len(world)))
        mask = lab == lab[o]
        pose = np.eye(4)
        pose[:3, :3] = Rotation.from_euler("z", rng.uniform(0, 2 * np.pi)).as_matrix()
        pose[:3, 3] = world.positions[o] * [1.0, 1.0, 0.0] + [0.3, 0.3, world.positions[mask, 2].min() + 1.5]
        types, pos = list(world.types[mask]), world.positions[mask]
        percepts, truth = simulate_percepts(types, pos, pose, rng, depth_factor=1000.0, max_range=7.0,
                                            n_false=1, false_types=sorted(set(types)))
        true_idx = np.flatnonzero(truth >= 0)
        if len(true_idx) >= 4:
            pick = np.concatenate([rng.choice(true_idx, min(5, len(true_idx)), replace=False),
                                   np.flatnonzero(truth < 0)])
            return int(lab[o]), pose, [percepts[i] for i in rng.permutation(pick)]


def _robot(site: scenes.Site, seed: int) -> tuple[np.ndarray, list[Percept]]:
    return robot_at_a_table(site, seed, 6)


def test_summary_bins_hold_every_link(campus, summaries) -> None:
    _, tiles = campus
    for tile, s in zip(tiles, summaries, strict=True):
        assert s.label == tile.label and s.n_objects == len(tile.world)
        assert sum(s.type_counts.values()) == len(tile.world)
        for key, table in tile.world.links.items():
            occupied = set(s.link_bins[(min(key), max(key))].tolist())
            assert {int(v) for v in np.floor(table.length / s.bin_width)} == occupied
        lo, hi = tile.world.bounds
        pos = tile.world.positions
        assert np.all(pos >= s.lower - 1e-9) and np.all(pos <= s.upper + 1e-9)
        np.testing.assert_allclose(s.lower, lo)


@settings(max_examples=25)
@given(seed=st.integers(0, 100_000))
def test_a_skipped_tile_never_holds_an_answer(mixed, seed) -> None:
    """Every tile is visited as the reference: a tile the pre-filter skips finds no pose."""
    world, lab, tiles, summaries = mixed
    _, _, percepts = _robot_in(world, lab, seed)
    visits = tiles_to_visit(summaries, percepts)
    assert len(visits) == len(tiles)
    for tile, v in zip(tiles, visits, strict=True):
        if v.visit:
            continue
        assert v.reason in ("no_types", "no_consistent_triple") and v.detail
        try:
            res = wg.localize(tile.world, percepts)
        except WorldGraphError:
            continue
        assert res.status not in POSE_STATUSES, (v, res.status, res.message)


def test_the_pre_filter_skips_tiles_on_a_varied_site(mixed) -> None:
    """The premise of the test above: on the varied site most tiles are skipped, for both reasons."""
    world, lab, tiles, summaries = mixed
    reasons: dict[str | None, int] = {}
    for seed in range(20):
        _, _, percepts = _robot_in(world, lab, seed)
        for v in tiles_to_visit(summaries, percepts):
            reasons[v.reason] = reasons.get(v.reason, 0) + 1
    assert reasons.get("no_types", 0) > 0 and reasons.get("no_consistent_triple", 0) > 0
    assert reasons.get(None, 0) < 0.5 * sum(reasons.values())


def test_the_distance_filter_skips_a_tile_whose_links_cannot_explain_the_percepts() -> None:
    """Two sparse tiles: the robot's (three landmarks 1.0, 1.5 and 2.1 m apart) and one whose
    landmarks of the same types lie 4 m apart: only the robot's tile is visited."""
    here = np.array([[2.0, 0.0, 1.0], [2.0, 1.0, 1.0], [3.2, 0.4, 1.3]])
    there = np.array([[40.0, 0.0, 1.0], [44.0, 0.0, 1.0], [42.0, 3.5, 1.0]])
    types = ["door", "handle", "knob"]
    world = wg.WorldModel.from_arrays(types * 2, np.vstack([here, there]))
    tiles = split(world, [0, 0, 0, 1, 1, 1])
    percepts = [Percept(t, x - [0.0, 0.0, 1.5], 0.01) for t, x in zip(types, here, strict=True)]
    visits = tiles_to_visit([summarize(t) for t in tiles], percepts)
    assert [v.visit for v in visits] == [True, False]
    assert visits[1].reason == "no_consistent_triple"
    # the premise: the skipped tile finds no pose, the visited one does
    assert wg.localize(tiles[1].world, percepts).status not in POSE_STATUSES
    assert wg.localize(tiles[0].world, percepts).status in POSE_STATUSES
    # a tile without the percepts' types
    other = wg.WorldModel.from_arrays(["lamp", "sign", "chair"], there)
    v, = tiles_to_visit([summarize(split(other, [5, 5, 5])[0])], percepts)
    assert (v.visit, v.reason, v.label) == (False, "no_types", 5)


def test_the_visited_tiles_give_the_answer_of_every_tile(campus, summaries) -> None:
    site, tiles = campus
    for seed in (1, 2):
        pose, percepts = _robot(site, seed)
        visits = tiles_to_visit(summaries, percepts)
        chosen = [t for t, v in zip(tiles, visits, strict=True) if v.visit]
        every = localize_tiled(tiles, percepts, workers=1)
        some = localize_tiled(chosen, percepts, workers=1)
        assert some.status == every.status
        np.testing.assert_allclose(some.transformation, every.transformation)
        assert some.correspondences == every.correspondences


def test_a_position_prior_skips_the_far_tiles(campus, summaries) -> None:
    site, tiles = campus
    pose, percepts = _robot(site, 7)
    near = pose[:3, 3] + [1.0, -1.0, 0.0]
    visits = tiles_to_visit(summaries, percepts, near=near, radius=2.0)
    reach = max(np.linalg.norm(p.position) + 3 * p.sigma for p in percepts) + 2.0
    for s, v in zip(summaries, visits, strict=True):
        gap = np.linalg.norm(np.maximum(np.maximum(s.lower - near, near - s.upper), 0.0))
        if gap > reach:
            assert not v.visit and v.reason == "outside_prior"
    # the robot's own tile (the tile of its storey and building) is visited
    res = localize_tiled([t for t, v in zip(tiles, visits, strict=True) if v.visit], percepts, workers=1)
    assert res.status not in POSE_STATUSES or np.linalg.norm(res.position - pose[:3, 3]) < 0.5
    assert sum(not v.visit for v in visits) >= len(tiles) // 2  # the campus is larger than the prior


def test_bad_arguments_are_named(summaries) -> None:
    p = [Percept("door", np.array([1.0, 0.0, 0.0]), 0.01)] * 3
    with pytest.raises(WorldGraphError, match="near and radius"):
        tiles_to_visit(summaries, p, near=[0.0, 0.0, 0.0])
    with pytest.raises(WorldGraphError, match=r"summaries\[0\]"):
        tiles_to_visit([object()], p)
    with pytest.raises(WorldGraphError, match="tile must be a Tile"):
        summarize("tile")
    assert math.isfinite(summaries[0].reach)
