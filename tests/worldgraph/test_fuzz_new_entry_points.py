"""Fuzz tests of the entry points added after the first hardening pass: active validation
(``plan_view``, ``active_localize``), tiles (``split``, ``localize_tiled``), the building and
campus scenes, ``WorldModel.type_tree``, ``shared_range_covariance`` and sparse adjacency in
``maximum_cliques``.  As in the other fuzz files: a call either raises the package's error with
a message naming the argument, or returns a finite answer that satisfies its status.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import perception as pc
import worldgraph as wg
from worldgraph import scenes
from worldgraph.cliques import maximum_cliques
from worldgraph.tiles import split
from worldgraph.validation import shared_range_covariance

NASTY = [math.nan, math.inf, -math.inf, 1e308, -1e308, 1e-300, -1.0, 0.0, 0, -3, 10**30, True, False,
         None, "3", 1 + 2j, 2.5, [1.0], np.float32(2.0), b"x"]
nasty = st.sampled_from(NASTY)


def _two_rooms() -> tuple[wg.WorldModel, list[pc.Percept]]:
    rng = np.random.default_rng(2)
    room = rng.uniform([0, 0, 0], [5, 4, 2], (30, 3))
    types = [("door", "knob", "handle")[i % 3] for i in range(30)]
    world = wg.WorldModel.from_arrays(types * 2, np.vstack([room, room + [20.0, 0.0, 0.0]]))
    percepts = [pc.Percept(types[i], room[i] - [2.5, 2.0, 1.0], 0.01) for i in range(6)]
    return world, percepts


WORLD, PERCEPTS = _two_rooms()
RESULT = wg.localize(WORLD, PERCEPTS)


def _named(exc: Exception, *names: str) -> None:
    assert isinstance(exc, wg.WorldGraphError), repr(exc)
    assert any(n in str(exc) for n in names), str(exc)


def test_two_room_result_is_ambiguous_with_a_pose() -> None:
    assert RESULT.status == "ambiguous" and np.all(np.isfinite(RESULT.transformation))


@settings(max_examples=60)
@given(st.sampled_from(["fov_deg", "max_range", "detection", "depth_factor", "min_sigma", "n_sigma",
                        "margin", "types", "candidates", "rng", "head", "joint_limits"]), nasty)
def test_plan_view_arguments(arg: str, value: object) -> None:
    try:
        plan = wg.plan_view(WORLD, RESULT, **{arg: value})
    except Exception as exc:  # noqa: BLE001 - the test is about which exceptions escape
        _named(exc, arg)
        return
    assert plan.status in ("ok", "not_discriminating", "single_hypothesis")
    assert np.all(np.isfinite(plan.direction)) and abs(np.linalg.norm(plan.direction) - 1.0) < 1e-9
    assert 0.0 <= plan.score <= 1.0


@pytest.mark.parametrize("world, result", [(None, RESULT), (WORLD, None), (WORLD, "ok"), ("w", RESULT)])
def test_plan_view_wrong_objects(world: object, result: object) -> None:
    with pytest.raises(wg.WorldGraphError, match="world|result"):
        wg.plan_view(world, result)


@settings(max_examples=40)
@given(nasty, st.sampled_from(["max_looks", "look_while", "fov_deg", "max_range", "planner"]))
def test_active_localize_arguments(value: object, arg: str) -> None:
    def look(direction: np.ndarray) -> list[pc.Percept]:
        return []

    try:
        out = wg.active_localize(WORLD, PERCEPTS, look, **{arg: value})
    except Exception as exc:  # noqa: BLE001
        _named(exc, arg, "planner(result)")
        return
    assert out.result.status in wg.LOCALIZE_STATUSES


@pytest.mark.parametrize("answer", [None, 3, "percepts", [None], [1.0, 2.0],
                                    [pc.Percept("sofa", [1, 2, 3], 0.1)]])
def test_active_localize_bad_look_answers_are_named(answer: object) -> None:
    try:
        out = wg.active_localize(WORLD, PERCEPTS, lambda d: answer, max_looks=1)
    except Exception as exc:  # noqa: BLE001
        _named(exc, "look(direction)", "percepts", "sofa")
        return
    assert out.result.status in wg.LOCALIZE_STATUSES


@settings(max_examples=40)
@given(st.sampled_from(["labels", "halo"]), nasty)
def test_split_arguments(arg: str, value: object) -> None:
    kwargs = {"labels": np.repeat([0, 1], 30), "halo": 0.0}
    kwargs[arg] = value
    try:
        tiles = split(WORLD, **kwargs)
    except Exception as exc:  # noqa: BLE001
        _named(exc, arg)
        return
    assert sum(int(np.sum(t.own)) for t in tiles) == len(WORLD)


@settings(max_examples=30)
@given(st.sampled_from(["workers", "scheduler", "method", "rng", "region"]), nasty)
def test_localize_tiled_arguments(arg: str, value: object) -> None:
    tiles = split(WORLD, np.repeat([0, 1], 30))
    kwargs = {"workers": 1, arg: value}
    try:
        res = wg.localize_tiled(tiles, PERCEPTS, **kwargs)
    except Exception as exc:  # noqa: BLE001
        _named(exc, arg)
        return
    assert res.status in wg.LOCALIZE_STATUSES
    if res.status in ("ok", "weak", "ambiguous"):
        assert np.all(np.isfinite(res.transformation))


@settings(max_examples=40)
@given(st.sampled_from(["storeys", "n_objects", "seed", "storey_height", "max_link_length", "link_margin"]),
       nasty)
def test_building_site_arguments(arg: str, value: object) -> None:
    kwargs = {"storeys": 2, "n_objects": 400}
    kwargs[arg] = value
    try:
        site = scenes.building_site(**kwargs)
    except Exception as exc:  # noqa: BLE001
        _named(exc, arg)
        return
    assert len(site.world) == len(site.storey) == len(site.building)
    assert np.all(np.isfinite(site.world.positions))


@settings(max_examples=30)
@given(st.sampled_from(["buildings", "gap"]), nasty)
def test_campus_site_arguments(arg: str, value: object) -> None:
    kwargs = {"buildings": 2, "storeys": 1, "n_objects": 400}
    kwargs[arg] = value
    try:
        site = scenes.campus_site(**kwargs)
    except Exception as exc:  # noqa: BLE001
        _named(exc, arg)
        return
    assert np.all(np.isfinite(site.world.positions))


@settings(max_examples=30)
@given(st.one_of(nasty, st.text(max_size=5)), nasty)
def test_type_tree_arguments(type_name: object, z_scale: object) -> None:
    try:
        tree = WORLD.type_tree(type_name, z_scale)
    except Exception as exc:  # noqa: BLE001
        _named(exc, "type_name", "z_scale")
        return
    assert tree.n == len(WORLD.indices_of(type_name))


@settings(max_examples=40)
@given(st.sampled_from(["pose", "ego", "covs", "centers", "sigmas", "weights", "shared"]), nasty)
def test_shared_range_covariance_arguments(arg: str, value: object) -> None:
    rng = np.random.default_rng(1)
    kwargs = {"pose": np.eye(4), "ego": rng.uniform(1, 3, (4, 3)),
              "covs": np.broadcast_to(1e-4 * np.eye(3), (4, 3, 3)).copy(),
              "centers": rng.uniform(4, 6, (4, 3)), "sigmas": np.full(4, 0.01), "weights": np.ones(4),
              "shared": [((0, np.eye(3)[:, :1] * 1e-3),)] * 4}
    kwargs[arg] = value
    names = {"pose": "world_from_ego"}
    try:
        out = shared_range_covariance(kwargs["pose"], kwargs["ego"], kwargs["covs"], kwargs["centers"],
                                      kwargs["sigmas"], kwargs["weights"], kwargs["shared"])
    except Exception as exc:  # noqa: BLE001
        _named(exc, names.get(arg, arg))
        return
    assert out.shape == (6, 6) and not np.any(np.isnan(out))


@settings(max_examples=40)
@given(nasty, nasty)
def test_maximum_cliques_sparse_pairs(rows: object, cols: object) -> None:
    try:
        res = maximum_cliques([2, 3], {(0, 1): (rows, cols)})
    except Exception as exc:  # noqa: BLE001
        _named(exc, "adjacency")
        return
    assert res.maximum in (0, 1, 2)
