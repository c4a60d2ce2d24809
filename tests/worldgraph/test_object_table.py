"""The array-backed object table of large worlds (no Python object per landmark)."""

from __future__ import annotations

import gc
import pickle

import numpy as np
import pytest

from worldgraph import errors as we
from worldgraph.model import ObjectModel, ObjectTable, WorldModel, box_vertices
from worldgraph.model.links import _pair_lengths


def _arrays(rng: np.random.Generator, n: int = 300):
    names = np.array(["door", "handle", "knob", "lamp"])
    types = names[rng.integers(0, 4, n)]
    pos = rng.uniform(-8, 8, (n, 3))
    sizes = rng.uniform(0.01, 1.0, (n, 3))
    return types, pos, sizes


def _by_hand(types, pos, sizes, ids=None):
    """The same world built the slow, obvious way: one ObjectModel each, geometry = type."""
    objs = []
    for k, (t, p, s) in enumerate(zip(types.tolist(), pos, sizes, strict=True)):
        pose = np.eye(4)
        pose[:3, 3] = p
        objs.append(ObjectModel(f"{t}_{k}" if ids is None else ids[k], t, pose, s, t))
    cv = {t: box_vertices(np.median(sizes[types == t], axis=0)) for t in sorted(set(types.tolist()))}
    return objs, cv


def test_from_arrays_keeps_a_table_equal_to_the_objects_built_by_hand():
    rng = np.random.default_rng(3)
    types, pos, sizes = _arrays(rng)
    world = WorldModel.from_arrays(types, pos, sizes=sizes, gravity_aligned=True)
    assert isinstance(world.objects, ObjectTable)
    objs, cv = _by_hand(types, pos, sizes)
    ref = WorldModel(objs, 5.0, cv, gravity_aligned=True)
    assert isinstance(ref.objects, tuple)
    assert world == ref and ref == world
    assert world.objects == ref.objects and ref.objects == world.objects
    for k in (0, 17, len(objs) - 1, -1):
        assert world.objects[k] == objs[k]
    assert [o.id for o in world.objects] == [o.id for o in objs]
    np.testing.assert_array_equal(world.types, types)
    np.testing.assert_array_equal(world.positions, pos)
    lo, hi = ref.bounds
    np.testing.assert_array_equal(world.bounds[0], lo)
    np.testing.assert_array_equal(world.bounds[1], hi)
    for key, table in ref.links.items():  # same links, same order
        mine = world.links[key]
        np.testing.assert_array_equal(mine.i, table.i)
        np.testing.assert_array_equal(mine.j, table.j)
        np.testing.assert_array_equal(mine.length, table.length)
    # a changed object makes the worlds differ
    o5 = objs[5]
    moved = [*objs[:5], ObjectModel(o5.id, o5.type, np.eye(4), o5.size, o5.type), *objs[6:]]
    assert world.objects != tuple(moved)


def test_given_ids_and_take_and_subset_keep_ids_and_flags():
    rng = np.random.default_rng(4)
    types, pos, sizes = _arrays(rng, 120)
    ids = [f"obj-{k:03d}" for k in range(120)][::-1]
    world = WorldModel.from_arrays(types, pos, sizes=sizes, ids=ids, gravity_aligned=True)
    assert world.objects[0].id == "obj-119"
    sub = world.subset(["door", "knob"])
    keep = np.flatnonzero(np.isin(types, ["door", "knob"]))
    assert isinstance(sub.objects, ObjectTable)
    assert [o.id for o in sub.objects] == [ids[k] for k in keep.tolist()]
    assert sub.gravity_aligned
    objs, cv = _by_hand(types, pos, sizes, ids)
    ref = WorldModel(objs, 5.0, cv, gravity_aligned=True).subset(["door", "knob"])
    assert isinstance(ref.objects, tuple) and ref.gravity_aligned
    assert sub.objects == ref.objects
    picked = world.take([7, 3, 99])
    assert [o.id for o in picked.objects] == [ids[7], ids[3], ids[99]]
    default = WorldModel.from_arrays(types, pos, sizes=sizes).take([5, 2])
    assert [o.id for o in default.objects] == [f"{types[5]}_5", f"{types[2]}_2"]
    assert default.objects[1:][0].id == f"{types[2]}_2"  # a slice is a table too
    for bad, message in (([120], r"index\[0\] = 120 must be < the number of objects"),
                         ([1, 1], "index must hold distinct object indices"),
                         ([], "index must select at least one object"),
                         ([-1], r"index\[0\] must be >= 0")):
        with pytest.raises(we.WorldGraphError, match=message):
            world.take(bad)


def test_no_object_model_is_made_until_one_is_asked_for():
    rng = np.random.default_rng(5)
    types, pos, sizes = _arrays(rng, 20_000)
    gc.collect()
    before = sum(isinstance(o, ObjectModel) for o in gc.get_objects())
    world = WorldModel.from_arrays(types, pos * 10, sizes=sizes)
    world.subset(["door"])
    world.region()
    made = sum(isinstance(o, ObjectModel) for o in gc.get_objects()) - before
    assert made == 0
    obj = world.objects[123]
    assert isinstance(obj, ObjectModel) and obj.id == f"{types[123]}_123"


def test_table_arguments_are_checked():
    pos = np.zeros((2, 3))
    pos[1, 0] = 1.0
    size = np.ones((2, 3))
    good = ObjectTable(["a", "b"], [0, 1], pos, size)
    assert good[1].type == "b" and good[1].id == "b_1"
    with pytest.raises(we.WorldGraphError, match=r"codes\[1\] = 2"):
        ObjectTable(["a", "b"], [0, 2], pos, size)
    with pytest.raises(we.WorldGraphError, match="sorted"):
        ObjectTable(["b", "a"], [0, 1], pos, size)
    with pytest.raises(we.WorldGraphError, match=r"sizes\[1, 2\]"):
        ObjectTable(["a"], [0, 0], pos, np.array([[1, 1, 1], [1, 1, -1.0]]))
    with pytest.raises(we.WorldGraphError, match=r"numbers\[1\] = 4"):
        ObjectTable(["a"], [0, 0], pos, size, numbers=[4, 4])
    with pytest.raises(we.WorldGraphError, match=r"positions must have shape \(2, 3\)"):
        ObjectTable(["a"], [0, 0], pos[:1], size)
    with pytest.raises(IndexError):
        good[2]
    with pytest.raises(we.WorldGraphError, match="ObjectTable index must be an int or a slice"):
        good["x"]
    with pytest.raises(AttributeError):
        good.codes = np.zeros(2)  # type: ignore[misc]
    assert not good.positions.flags.writeable
    world = WorldModel(good, class_vertices={"a": np.zeros((1, 3)), "b": np.zeros((1, 3))})
    assert world.objects[0] == ObjectModel("a_0", "a", np.eye(4), np.ones(3), "a")
    with pytest.raises(we.WorldGraphError, match="'b_1' has geometry 'b'"):
        WorldModel(good, class_vertices={"a": np.zeros((1, 3))})


def test_a_table_world_pickles() -> None:
    """Tiles go to worker processes and Dask workers by pickle."""
    rng = np.random.default_rng(8)
    types, pos, sizes = _arrays(rng, 50)
    for ids in (None, [f"o{k}" for k in range(50)]):
        world = WorldModel.from_arrays(types, pos, sizes=sizes, ids=ids, gravity_aligned=True).take([3, 1, 7])
        back = pickle.loads(pickle.dumps(world))
        assert isinstance(back.objects, ObjectTable)
        assert back == world and back.gravity_aligned
        assert [o.id for o in back.objects] == [o.id for o in world.objects]


def test_chunked_pair_lengths_match_the_direct_formula():
    rng = np.random.default_rng(6)
    pos = rng.normal(size=(50, 3))
    i, j = rng.integers(0, 50, 1000), rng.integers(0, 50, 1000)
    direct = np.array([np.linalg.norm(pos[a] - pos[b]) for a, b in zip(i, j, strict=True)])
    np.testing.assert_allclose(_pair_lengths(pos, i, j, chunk=7), direct, rtol=1e-15, atol=0)


def test_build_far_pairs_fills_the_budget_smallest_first(monkeypatch) -> None:
    """200 'a', 60 'm', 60 'z' objects in an 8 m box: every pair is within the 16 m range, so
    a type pair's index holds n_a * n_b pairs (n (n - 1) for one type).  With a budget of 45,000
    pairs, the five small type pairs (3 x 3,600 or fewer, then 2 x 12,000) fit and (a, a), 39,800
    pairs, does not; built alphabetically, (a, a) would come first and take the budget."""
    import worldgraph.model.far_pairs as far_pairs

    monkeypatch.setattr(far_pairs, "FAR_PAIR_BUDGET", 45_000)
    monkeypatch.setattr(far_pairs, "FAR_PAIR_MAX_PAIRS", 10**9)
    rng = np.random.default_rng(9)
    types = ["a"] * 200 + ["m"] * 60 + ["z"] * 60
    world = WorldModel.from_arrays(types, rng.uniform(0, 8 / np.sqrt(3), (320, 3)), max_link_length=1.0)
    held = world.build_far_pairs()
    built = {k[:2] for k, v in world._far_pairs.items() if v is not None}
    assert built == {("m", "m"), ("m", "z"), ("z", "z"), ("a", "m"), ("a", "z")}
    assert world.far_pairs("a", "a") is None
    sizes = {("m", "m"): 60 * 59, ("z", "z"): 60 * 59, ("m", "z"): 3600, ("a", "m"): 12000, ("a", "z"): 12000}
    for (a, b), n in sizes.items():  # each index holds every ordered pair of distinct objects once
        index = world.far_pairs(a, b)
        assert index is not None
        pairs = set(zip(index.i.tolist(), index.j.tolist(), strict=True))
        assert len(pairs) == len(index.i) == n
    assert held == sum(len(world.far_pairs(a, b).i) for a, b in sizes)
