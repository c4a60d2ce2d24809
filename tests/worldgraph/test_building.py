"""Tests of scenes.building_site / building and campus_site / campus: sizes, labels from the
geometry, storey-to-storey repetition, determinism, argument checks."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

import worldgraph as wg
from worldgraph import scenes


@pytest.fixture(scope="module")
def site() -> scenes.Site:
    return scenes.building_site(storeys=3, n_objects=6000, seed=0, storey_height=3.5)


def test_building_size_types_and_storeys(site):
    w = site.world
    assert len(w) == 6000 and len(site.storey) == len(site.building) == 6000
    assert set(w.type_names) >= {"door", "handle", "window", "table", "chair", "stair", "elevator"}
    z = w.positions[:, 2]
    assert z.min() >= 0.0  # z up, ground floor at 0
    # the storey of every object from its height alone: storey s spans [3.5 s, 3.5 (s + 1))
    np.testing.assert_array_equal(site.storey, np.floor(z / 3.5).astype(int))
    assert set(site.storey.tolist()) == {0, 1, 2}
    assert (site.building == 0).all()
    # every door stands on its storey's floor: centre 1.025 m above it (a 2.05 m door)
    doors = w.types == "door"
    np.testing.assert_allclose(z[doors] - 3.5 * site.storey[doors], 1.025, atol=1e-9)
    assert scenes.building(storeys=3, n_objects=6000, seed=0) == w


def test_storeys_repeat_the_plan_below_with_variation(site):
    w = site.world
    for typ in ("door", "window"):
        sel = w.types == typ
        low = w.positions[sel & (site.storey == 0)]
        up = w.positions[sel & (site.storey == 1)] - [0.0, 0.0, 3.5]
        d, _ = cKDTree(low).query(up)
        same = float(np.mean(d < 1e-9))
        # module kinds are copied with probability 0.9; a redrawn kind may equal the old one
        assert 0.85 <= same < 1.0, (typ, same)


def test_identical_room_modules(site):
    # along a corridor wall, neighbouring doors are one 3.6 m module apart, give or take the
    # 0.2 m door shift of the double-window module
    w = site.world
    doors = w.positions[(w.types == "door") & (site.storey == 0)]
    steps = []
    for y in np.unique(doors[:, 1]):
        x = np.sort(doors[doors[:, 1] == y, 0])
        d = np.diff(x)
        steps.append(d[d < 6.0])  # larger steps cross the 8 m gap between wings
    steps = np.concatenate(steps)
    assert len(steps) > 100
    assert np.all(np.min(np.abs(steps[:, None] - np.array([3.4, 3.6, 3.8])), axis=1) < 1e-9)
    assert np.mean(np.abs(steps - 3.6) < 1e-9) > 0.6  # most modules are the same office
    # the room furniture is drawn per room: tables are not on a grid
    tables = w.positions[(w.types == "table") & (site.storey == 0)]
    assert len(np.unique(np.round(np.mod(tables[:, 0], 3.6), 6))) > 0.9 * len(tables)


def test_building_seeds_differ_and_repeat():
    a = scenes.building_site(storeys=2, n_objects=2000, seed=4)
    b = scenes.building_site(storeys=2, n_objects=2000, seed=4)
    c = scenes.building_site(storeys=2, n_objects=2000, seed=5)
    assert a.world == b.world and np.array_equal(a.storey, b.storey)
    assert a.world != c.world


def test_campus_labels_are_disjoint_buildings():
    s = scenes.campus_site(buildings=3, storeys=2, n_objects=4501, seed=2, gap=30.0)
    w = s.world
    assert len(w) == 4501
    assert np.bincount(s.building).tolist() == [1501, 1500, 1500]
    boxes = [(w.positions[s.building == b].min(axis=0), w.positions[s.building == b].max(axis=0))
             for b in range(3)]
    for i in range(3):
        for j in range(i + 1, 3):
            (lo_i, hi_i), (lo_j, hi_j) = boxes[i], boxes[j]
            gap_xy = np.maximum(lo_j[:2] - hi_i[:2], lo_i[:2] - hi_j[:2]).max()
            assert gap_xy >= 30.0  # footprints at least the gap apart
    np.testing.assert_array_equal(s.storey, np.floor(w.positions[:, 2] / 3.5).astype(int))
    by_storey = s.labels("storey")
    assert len(np.unique(by_storey)) == 6
    np.testing.assert_array_equal(by_storey, s.building * 2 + s.storey)
    with pytest.raises(wg.WorldGraphError, match="by"):
        s.labels("room")
    assert scenes.campus(buildings=3, storeys=2, n_objects=4501, seed=2) == w


@pytest.mark.parametrize("kwargs, error, name", [
    ({"storeys": 0}, wg.WorldGraphError, "storeys must be >= 1"),
    ({"storeys": 2.0}, wg.WorldGraphError, "storeys must be an integer, got 2.0"),
    ({"storeys": True}, wg.WorldGraphError, "storeys must be an integer, got True"),
    ({"n_objects": 0}, wg.WorldGraphError, "n_objects must be >= 1"),
    ({"n_objects": 10.5}, wg.WorldGraphError, "n_objects must be an integer"),
    ({"seed": -1}, wg.WorldGraphError, "seed must be >= 0"),
    ({"seed": None}, wg.WorldGraphError, "seed must be an integer, got None"),
    ({"storey_height": 2.0}, wg.WorldGraphError, "storey_height must be >= 3 m"),
    ({"storey_height": float("nan")}, wg.WorldGraphError, "storey_height must be finite"),
    ({"max_link_length": 0.0}, wg.WorldGraphError, "max_link_length must be > 0"),
])
def test_building_checks_its_arguments(kwargs, error, name):
    args = {"storeys": 2, "n_objects": 500, **kwargs}
    with pytest.raises(error, match=name):
        scenes.building_site(**args)


def test_campus_checks_its_arguments():
    with pytest.raises(wg.WorldGraphError, match=r"buildings must be >= 1, got 0"):
        scenes.campus_site(buildings=0, n_objects=100)
    with pytest.raises(wg.WorldGraphError, match=r"buildings must be an integer, got '2'"):
        scenes.campus_site(buildings="2", n_objects=100)
    with pytest.raises(wg.WorldGraphError, match=r"n_objects = 4 must be >= buildings = 5"):
        scenes.campus_site(buildings=5, storeys=1, n_objects=4)
    with pytest.raises(wg.WorldGraphError, match=r"gap must be > 0, got 0\.0"):
        scenes.campus_site(buildings=2, storeys=1, n_objects=100, gap=0.0)
