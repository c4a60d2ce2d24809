"""Tests of worldgraph.model: link index against brute force, graph, files, trimesh import, errors."""

from __future__ import annotations

import json
import math
from itertools import combinations

import networkx as nx
import numpy as np
import pytest
import trimesh
from hypothesis import given
from hypothesis import strategies as st

import worldgraph as wg
from worldgraph.model import LinkTable, ObjectModel, WorldModel

TYPES = ("door", "handle", "knob", "switch")
SPACING = 0.37  # grid spacing of the random worlds (m)


@st.composite
def worlds(draw):
    """Random typed worlds on a jittered grid: distinct positions, several types."""
    n = draw(st.integers(1, 40))
    cells = draw(st.lists(st.tuples(st.integers(-8, 8), st.integers(-8, 8), st.integers(0, 6)),
                          min_size=n, max_size=n, unique=True))
    jitter = draw(st.lists(st.floats(-0.1, 0.1), min_size=3 * n, max_size=3 * n))
    pos = np.array(cells, dtype=float) * SPACING + np.array(jitter).reshape(n, 3)
    types = draw(st.lists(st.sampled_from(TYPES), min_size=n, max_size=n))
    mll = draw(st.floats(0.2, 4.0))
    margin = draw(st.sampled_from([0.0, 0.0, 0.15]))
    return types, pos, mll, margin


def brute_links(types, pos, radius):
    """All pairs closer than radius, oriented by the LinkTable rule, computed pair by pair."""
    out: dict[tuple[str, str], dict[tuple[int, int], float]] = {}
    ambiguous = set()
    for a, b in combinations(range(len(types)), 2):
        d = math.dist(pos[a], pos[b])
        if abs(d - radius) < 1e-9:
            ambiguous.add((min(a, b), max(a, b)))
            continue
        if d >= radius:
            continue
        ta, tb = types[a], types[b]
        i, j = (a, b) if (ta, a) <= (tb, b) else (b, a)
        if ta == tb:
            i, j = min(a, b), max(a, b)
        key = (min(ta, tb), max(ta, tb))
        out.setdefault(key, {})[(i, j)] = d
    return out, ambiguous


def table_pairs(table: LinkTable, ambiguous):
    return {(int(i), int(j)): float(x) for i, j, x in zip(table.i, table.j, table.length, strict=True)
            if (min(i, j), max(i, j)) not in ambiguous}


@given(worlds())
def test_links_equal_brute_force(world):
    types, pos, mll, margin = world
    w = WorldModel.from_arrays(types, pos, max_link_length=mll, link_margin=margin)
    expected, ambiguous = brute_links(types, pos, mll + margin)
    present = sorted(set(types))
    # only type pairs with links are stored; every other sorted pair of present types reads empty
    stored = {key for key, table in expected.items() if set(table) - ambiguous}
    assert stored <= set(w.links) <= set(expected)
    every_pair = [(a, b) for a in present for b in present if a <= b]
    for key in every_pair:
        table = w.links[key]
        got = table_pairs(table, ambiguous)
        want = expected.get(key, {})
        assert got.keys() == want.keys(), key
        for pair, d in want.items():
            assert got[pair] == pytest.approx(d, abs=1e-12)
        assert np.all(np.diff(table.length) >= 0)
        a, b = key
        assert all(types[i] == a and types[j] == b for i, j in zip(table.i, table.j, strict=True))
        if a == b:
            assert np.all(table.i < table.j)


def test_many_types_store_exactly_the_linked_type_pairs():
    """A world of many distinct types (one per CAD node) stores a table for each type
    pair with a link and for no other (a table per type pair was 12.5M tables at 5,000 types);
    every other sorted pair reads as an empty table, an unsorted or unknown pair is a KeyError.
    Reference: the pair-by-pair brute force."""
    rng = np.random.default_rng(25)
    n, mll = 150, 2.0
    pos = rng.uniform(0, 12, (n, 3))
    types = [f"part{k % 120}" for k in range(n)]  # 120 types, 30 of them with two objects
    w = WorldModel.from_arrays(types, pos, max_link_length=mll)
    expected, ambiguous = brute_links(types, pos, mll)
    assert not ambiguous and expected
    assert list(w.links) == sorted(expected)  # iteration: the linked pairs, sorted
    assert len(w.links) == len(expected) < 120 * 121 // 2
    names = sorted(set(types))
    for k, a in enumerate(names):
        for b in names[k:]:
            table = w.links[(a, b)]
            assert ((a, b) in w.links) == ((a, b) in expected)
            assert table_pairs(table, ambiguous) == pytest.approx(expected.get((a, b), {}), abs=1e-12)
            assert np.all(np.diff(table.length) >= 0)
    a, b = next(iter(expected))
    if a != b:
        assert (b, a) not in w.links and w.links.get((b, a)) is None
        with pytest.raises(KeyError):
            w.links[(b, a)]
    with pytest.raises(KeyError):
        w.links[("part0", "nope")]
    # link_lengths reads any pair of known types, in either order
    i, j, length = w.link_lengths(b, a)
    assert sorted(zip(j.tolist(), i.tolist(), strict=True)) == sorted(expected[(a, b)])


def test_unknown_type_message_lists_the_first_twenty_types_of_many():
    w = WorldModel.from_arrays([f"part{k:02d}" for k in range(50)], np.arange(150.0).reshape(50, 3) * 0.02)
    first = [f"part{k:02d}" for k in range(20)]
    with pytest.raises(wg.WorldGraphError, match="type_name = 'nope' is not in the world model") as info:
        w.indices_of("nope")
    assert str(info.value) == (f"type_name = 'nope' is not in the world model; known types: {first} "
                               "and 30 more")
    few = WorldModel.from_arrays(["b", "a"], [[0, 0, 0], [1, 0, 0]])
    with pytest.raises(wg.WorldGraphError, match=r"type_a = 'c' .*; known types: \['a', 'b'\]$"):
        few.link_lengths("c", "a")


@given(worlds(), st.floats(0.0, 4.0), st.floats(0.0, 4.0))
def test_in_range_and_link_lengths_equal_filter(world, lo, width):
    types, pos, mll, margin = world
    w = WorldModel.from_arrays(types, pos, max_link_length=mll, link_margin=margin)
    hi = lo + width
    for (a, b), table in w.links.items():
        i, j, length = table.in_range(lo, hi)
        rows = zip(table.i, table.j, table.length, strict=True)
        keep = [(int(p), int(q)) for p, q, x in rows if lo < x < hi]
        assert list(zip(i.tolist(), j.tolist(), strict=True)) == keep
        # link_lengths orients rows by its arguments, whatever the lexicographic order
        i2, j2, len2 = w.link_lengths(b, a, lo, hi)
        if a == b:  # one type: each pair once, i < j, in either argument order
            assert np.array_equal(i2, i) and np.array_equal(j2, j)
        else:
            assert np.array_equal(i2, j) and np.array_equal(j2, i)
        assert np.array_equal(len2, length)
        assert all(types[k] == b for k in i2) and all(types[k] == a for k in j2)
        np.testing.assert_allclose(len2, np.linalg.norm(pos[i2] - pos[j2], axis=1), atol=1e-12)


@given(worlds())
def test_graph_edges_are_pairs_closer_than_max_link_length(world):
    types, pos, mll, margin = world
    w = WorldModel.from_arrays(types, pos, max_link_length=mll, link_margin=margin)
    g = w.graph
    assert isinstance(g, nx.Graph) and g.number_of_nodes() == len(types)
    dist = {(a, b): math.dist(pos[a], pos[b]) for a, b in combinations(range(len(types)), 2)}
    want = {pair for pair, d in dist.items() if d < mll - 1e-9}
    maybe = {pair for pair, d in dist.items() if abs(d - mll) <= 1e-9}
    got = {(min(a, b), max(a, b)) for a, b in g.edges}
    assert want <= got <= want | maybe
    for a, b, data in g.edges(data=True):
        assert data["length"] == pytest.approx(math.dist(pos[a], pos[b]), abs=1e-12)
    for k in range(len(types)):
        assert g.nodes[k]["type"] == types[k]
        np.testing.assert_array_equal(g.nodes[k]["position"], pos[k])


@given(worlds())
def test_type_index_and_arrays(world):
    types, pos, mll, margin = world
    w = WorldModel.from_arrays(types, pos, max_link_length=mll)
    assert len(w) == len(types)
    np.testing.assert_array_equal(w.positions, pos)
    assert list(w.types) == list(types)
    for t in set(types):
        assert w.type_index[t].tolist() == [k for k, x in enumerate(types) if x == t]
    with pytest.raises(ValueError):
        w.positions[0, 0] = 1.0  # read-only


def test_link_margin_keeps_pairs_just_above_max_link_length():
    pos = np.array([[0.0, 0, 0], [1.02, 0, 0]])
    tight = WorldModel.from_arrays(["door", "handle"], pos, max_link_length=1.0)
    loose = WorldModel.from_arrays(["door", "handle"], pos, max_link_length=1.0, link_margin=0.05)
    assert len(tight.links[("door", "handle")]) == 0
    assert loose.links[("door", "handle")].length.tolist() == pytest.approx([1.02])
    assert loose.graph.number_of_edges() == 0  # the graph keeps max_link_length itself


def test_link_lengths_unknown_type():
    w = WorldModel.from_arrays(["door", "handle"], [[0, 0, 0], [1, 0, 0]])
    with pytest.raises(wg.WorldGraphError, match=r"type_b = 'lamp' is not in the world model"):
        w.link_lengths("door", "lamp")
    with pytest.raises(wg.WorldGraphError, match=r"types\[0\] = 'lamp' is not in the world model"):
        w.subset(["lamp"])


def test_subset_bounds_region():
    pos = np.array([[0.0, 0, 0.5], [2, 1, 1], [4, 3, 2.5]])
    w = WorldModel.from_arrays(["door", "handle", "knob"], pos, sizes=[[0.2, 0.2, 0.2]] * 3)
    sub = w.subset(["door", "knob"])
    assert len(sub) == 2 and set(sub.types) == {"door", "knob"}
    np.testing.assert_allclose(sub.positions, pos[[0, 2]])
    lo, hi = w.bounds
    np.testing.assert_allclose(lo, [-0.1, -0.1, 0.4])
    np.testing.assert_allclose(hi, [4.1, 3.1, 2.6])
    region = w.region(margin=0.5)
    np.testing.assert_allclose(region.lower, [-0.6, -0.6, 0.4])
    np.testing.assert_allclose(region.upper, [4.6, 3.6, 3.1])
    assert region.contains(pos).all()


def test_bounds_use_rotated_boxes():
    rot = trimesh.transformations.rotation_matrix(math.pi / 2, [0, 0, 1])
    rot[:3, 3] = (1.0, 2.0, 3.0)
    obj = ObjectModel("door_0", "door", rot, (2.0, 0.2, 1.0), "box")
    w = WorldModel((obj,), class_vertices={"box": wg.box_vertices((2.0, 0.2, 1.0))})
    lo, hi = w.bounds
    np.testing.assert_allclose(lo, [0.9, 1.0, 2.5], atol=1e-12)
    np.testing.assert_allclose(hi, [1.1, 3.0, 3.5], atol=1e-12)


# ----------------------------------------------------------------------------------------------
# bad input
# ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("types", "positions", "kwargs", "error", "match"),
    [
        (["door"], [[0.0, np.nan, 0.0]], {}, wg.WorldGraphError, "nan"),
        (["door"], [[0.0, np.inf, 0.0]], {}, wg.WorldGraphError, "inf"),
        (["door", "door"], [[0.0, 0.0]] * 2, {}, wg.WorldGraphError, r"\(2, 2\)"),
        (["door"], [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]], {}, wg.WorldGraphError, "length 1"),
        ([], np.zeros((0, 3)), {}, wg.WorldGraphError, "0"),
        (["door", "door"], [[1.0, 2.0, 3.0]] * 2, {}, wg.WorldGraphError, "door_0"),
        (["door", ""], [[0.0, 0, 0], [1.0, 0, 0]], {}, wg.WorldGraphError, "types\\[1\\]"),
        (["door", 3], [[0.0, 0, 0], [1.0, 0, 0]], {}, wg.WorldGraphError, "3"),
        (["door"], [[0.0, 0, 0]], {"max_link_length": 0.0}, wg.WorldGraphError, "0.0"),
        (["door"], [[0.0, 0, 0]], {"max_link_length": np.nan}, wg.WorldGraphError, "nan"),
        (["door"], [[0.0, 0, 0]], {"link_margin": -1.0}, wg.WorldGraphError, "-1.0"),
        (["door"], [[0.0, 0, 0]], {"sizes": [[1.0, 1.0]]}, wg.WorldGraphError, r"\(1, 2\)"),
        (["door"], [[0.0, 0, 0]], {"sizes": [[1.0, -1.0, 1.0]]}, wg.WorldGraphError, "-1.0"),
        (["door"], [[0.0, 0, 0]], {"ids": ["a", "b"]}, wg.WorldGraphError, "2"),
    ],
)
def test_from_arrays_bad_input(types, positions, kwargs, error, match):
    with pytest.raises(error, match=match):
        WorldModel.from_arrays(types, positions, **kwargs)


def test_errors_are_value_errors():
    assert issubclass(wg.WorldGraphError, ValueError)
    for cls in (wg.MalformedFileError, wg.TooFewPerceptsError, wg.ImporterError, wg.PoseError):
        assert issubclass(cls, wg.WorldGraphError)


def test_coincident_objects_of_different_types_are_fine():
    w = WorldModel.from_arrays(["door", "handle"], [[1.0, 2.0, 3.0]] * 2)
    assert w.links[("door", "handle")].length.tolist() == [0.0]
    assert w.link_lengths("handle", "door")[0].tolist() == [1]


def test_object_model_validation():
    with pytest.raises(wg.WorldGraphError, match=r"\(3, 3\)"):
        ObjectModel("a", "door", np.eye(3), (1, 1, 1))
    with pytest.raises(wg.WorldGraphError, match="last row"):
        ObjectModel("a", "door", np.ones((4, 4)), (1, 1, 1))
    with pytest.raises(wg.WorldGraphError, match=r"ObjectModel 'a' size\[1\] must be finite, got nan"):
        ObjectModel("a", "door", np.eye(4), (1, np.nan, 1))
    with pytest.raises(wg.WorldGraphError, match="type must be a non-empty string"):
        ObjectModel("a", "", np.eye(4), (1, 1, 1))
    with pytest.raises(wg.WorldGraphError, match=r"object 'a' has geometry 'cone', which is not a"):
        WorldModel((ObjectModel("a", "door", np.eye(4), (1, 1, 1), "cone"),), class_vertices={})
    with pytest.raises(wg.WorldGraphError, match="objects must hold at least one object"):
        WorldModel(())
    dup = ObjectModel("a", "door", np.eye(4), (1, 1, 1))
    with pytest.raises(wg.WorldGraphError, match="'a'"):
        WorldModel((dup, dup), class_vertices={"box": wg.box_vertices((1, 1, 1))})
    obj = ObjectModel("a", "door", np.eye(4), (1, 1, 1))
    assert obj.position.tolist() == [0.0, 0.0, 0.0]
    with pytest.raises(ValueError):
        obj.pose[0, 0] = 2.0


# ----------------------------------------------------------------------------------------------
# files
# ----------------------------------------------------------------------------------------------
def _small_world() -> WorldModel:
    rng = np.random.default_rng(3)
    pos = rng.uniform(0, 5, (12, 3))
    types = rng.choice(list(TYPES), 12)
    sizes = rng.uniform(0.01, 0.5, (12, 3))
    return WorldModel.from_arrays(types, pos, max_link_length=2.5, sizes=sizes, link_margin=0.1)


def test_save_load_round_trip(tmp_path):
    w = _small_world()
    path = tmp_path / "world.json"
    w.save(path)
    back = WorldModel.load(path)
    assert back == w
    assert back is not w and back.scene is None
    for key, table in w.links.items():
        np.testing.assert_array_equal(back.links[key].i, table.i)
        np.testing.assert_array_equal(back.links[key].length, table.length)
    data = json.loads(path.read_text())
    assert data["version"] == 1 and len(data["objects"]) == 12
    assert set(data["objects"][0]) == {"id", "type", "pose", "size", "geometry"}


def test_round_trip_of_a_rotated_trimesh_world(tmp_path):
    w = WorldModel.from_trimesh(_hand_scene())
    w.save(tmp_path / "w.json")
    back = WorldModel.load(tmp_path / "w.json")
    assert back == w
    assert back != _small_world()


def test_equality_sees_changes():
    w = _small_world()
    objs = list(w.objects)
    pose = objs[0].pose.copy()
    pose[0, 3] += 1e-6
    objs[0] = ObjectModel(objs[0].id, objs[0].type, pose, objs[0].size, objs[0].geometry)
    other = WorldModel(tuple(objs), w.max_link_length, w.class_vertices, link_margin=w.link_margin)
    assert other != w


def _write(tmp_path, data, raw: str | None = None):
    path = tmp_path / "bad.json"
    path.write_text(raw if raw is not None else json.dumps(data))
    return path


@pytest.mark.parametrize(
    ("mutate", "match"),
    [
        (lambda d: d.pop("version"), "missing key 'version'"),
        (lambda d: d.pop("objects"), "missing key 'objects'"),
        (lambda d: d.update(version=2), "version 2"),
        (lambda d: d.update(format="mesh"), "format"),
        (lambda d: d.update(max_link_length="far"), "max_link_length"),
        (lambda d: d.update(objects={}), "objects must be a list"),
        (lambda d: d["objects"][1].pop("pose"), r"objects\[1\] is missing key 'pose'"),
        (lambda d: d["objects"][1].update(pose=[[1, 0, 0], [0, 1, 0], [0, 0, 1]]), r"shape \(4, 4\)"),
        (lambda d: d["objects"][2].update(size=[1, 2]), r"size must have shape \(3,\)"),
        (lambda d: d["objects"][2].update(type=""), "type must be a non-empty string"),
        (lambda d: d["objects"][2].update(geometry="cone"), "'cone'"),
        (lambda d: d["class_vertices"].update(door=[[1, 2]]), r"class_vertices\['door'\]"),
        (lambda d: d["objects"].__setitem__(3, dict(d["objects"][0])), "more than once"),
        (lambda d: d.update(objects=[]), "at least one object"),
    ],
)
def test_malformed_files(tmp_path, mutate, match):
    data = _small_world().to_dict()
    mutate(data)
    with pytest.raises(wg.MalformedFileError, match=match):
        WorldModel.load(_write(tmp_path, data))


def test_malformed_nan_and_bad_json(tmp_path):
    text = json.dumps(_small_world().to_dict())
    nan_text = text.replace('"size": [', '"size": [NaN, ', 1)
    with pytest.raises(wg.MalformedFileError, match=r"objects\[0\].*size"):
        WorldModel.load(_write(tmp_path, None, raw=nan_text))
    nan_pose = json.loads(text)
    nan_pose["objects"][0]["pose"][0][3] = float("nan")
    with pytest.raises(wg.MalformedFileError, match="finite"):
        WorldModel.load(_write(tmp_path, None, raw=json.dumps(nan_pose)))
    with pytest.raises(wg.MalformedFileError, match="not valid JSON"):
        WorldModel.load(_write(tmp_path, None, raw=text[:-10]))
    with pytest.raises(wg.MalformedFileError, match="cannot read"):
        WorldModel.load(tmp_path / "missing.json")
    with pytest.raises(wg.MalformedFileError, match="top level"):
        WorldModel.load(_write(tmp_path, [1, 2, 3]))


# ----------------------------------------------------------------------------------------------
# trimesh import
# ----------------------------------------------------------------------------------------------
def _hand_scene() -> trimesh.Scene:
    """Meshes offset from their origin, rotated and scaled node transforms, all ways of typing."""
    scene = trimesh.Scene()
    box = trimesh.creation.box(extents=(0.4, 0.1, 0.2))
    box.apply_translation((0.3, 0.0, 0.1))  # bounding-box centre away from the mesh origin
    cyl = trimesh.creation.cylinder(radius=0.05, height=0.3, sections=12)
    tagged = trimesh.creation.box(extents=(0.1, 0.1, 0.1))
    tagged.metadata["type"] = "switch"
    scene.geometry.update({"box": box, "cyl": cyl, "tagged": tagged})
    rot = trimesh.transformations.rotation_matrix(0.7, [0.3, 0.2, 0.9])
    nodes = [
        ("door_1", "box", trimesh.transformations.translation_matrix([1, 2, 0]) @ rot, None),
        ("door_2", "box", trimesh.transformations.translation_matrix([3, 2, 0]), None),
        ("handle:7", "cyl", trimesh.transformations.translation_matrix([1, 2.5, 1]) @ rot
         @ np.diag([2.0, 2.0, 0.5, 1.0]), None),
        ("thing", "cyl", trimesh.transformations.translation_matrix([0, 0, 2]), {"type": "knob"}),
        ("wall_0", "box", np.eye(4), {"type": None}),
        ("x_y", "tagged", trimesh.transformations.translation_matrix([5, 5, 1]), None),
        ("knobbly", "tagged", trimesh.transformations.translation_matrix([2, 5, 1]), {"type": "knob"}),
    ]
    for name, geom, matrix, meta in nodes:
        kwargs = {} if meta is None else {"metadata": meta}
        scene.graph.update(frame_to=name, frame_from=scene.graph.base_frame, matrix=matrix, geometry=geom,
                           **kwargs)
    return scene


def test_from_trimesh_types_positions_sizes():
    scene = _hand_scene()
    w = WorldModel.from_trimesh(scene, max_link_length=3.0)
    by_id = {o.id: o for o in w.objects}
    assert {k: o.type for k, o in by_id.items()} == {
        "door_1": "door", "door_2": "door", "handle:7": "handle", "thing": "knob", "x_y": "switch",
        "knobbly": "knob"}
    assert w.scene is scene
    for name, obj in by_id.items():
        matrix, geom_name = scene.graph[name]
        world_mesh = scene.geometry[geom_name].copy()
        world_mesh.apply_transform(matrix)
        # the object centre is the centre of the transformed mesh's own bounding box (a box and a
        # cylinder are centrally symmetric, so this is the vertex mean of their extreme points)
        centre = 0.5 * (world_mesh.vertices.max(axis=0) + world_mesh.vertices.min(axis=0))
        np.testing.assert_allclose(obj.position, centre, atol=1e-9)
        rot = obj.pose[:3, :3]
        np.testing.assert_allclose(rot @ rot.T, np.eye(3), atol=1e-12)
        # the world mesh fits the object's box exactly
        local = (world_mesh.vertices - obj.position) @ rot
        np.testing.assert_allclose(local.max(axis=0) - local.min(axis=0), obj.size, atol=1e-9)
        np.testing.assert_allclose(w.class_vertices[obj.geometry].shape[1], 3)
    np.testing.assert_allclose(by_id["handle:7"].size, [0.2, 0.2, 0.15], atol=1e-9)


def test_from_trimesh_type_of_overrides_and_skips():
    scene = _hand_scene()
    w = WorldModel.from_trimesh(scene, type_of=lambda name, geom: "door" if name.startswith("door") else None)
    assert sorted(o.id for o in w.objects) == ["door_1", "door_2"]
    with pytest.raises(wg.WorldGraphError, match="scene has no typed geometry nodes"):
        WorldModel.from_trimesh(scene, type_of=lambda name, geom: None)
    with pytest.raises(wg.WorldGraphError, match=r"type of node 'door_1' must be a non\-empty"):
        WorldModel.from_trimesh(scene, type_of=lambda name, geom: 5)


# ----------------------------------------------------------------------------------------------
# room
# ----------------------------------------------------------------------------------------------
def _room_scene(ceiling: bool = True, walls: bool = True) -> trimesh.Scene:
    """A 4 x 3 m room by hand: floor slab top at z = 0, two walls (one rotated), a ceiling."""
    scene = trimesh.Scene()
    scene.geometry.update({
        "slab": trimesh.creation.box(extents=(4.0, 3.0, 0.1)),
        "wall_long": trimesh.creation.box(extents=(4.0, 0.2, 2.5)),
        "wall_short": trimesh.creation.box(extents=(3.0, 0.2, 2.5)),
        "door": trimesh.creation.box(extents=(0.9, 0.04, 2.0)),
    })
    t = trimesh.transformations.translation_matrix
    rz90 = trimesh.transformations.rotation_matrix(np.pi / 2, [0, 0, 1])
    nodes = [("floor_0", "slab", t([2.0, 1.5, -0.05]), None),        # x 0..4, y 0..3, z -0.1..0
             ("door_0", "door", t([1.0, 0.02, 1.0]), None)]
    if walls:
        nodes += [("wall_0", "wall_long", t([2.0, -0.1, 1.25]), None),  # x 0..4, y -0.2..0, z 0..2.5
                  ("side", "wall_short", t([4.1, 1.5, 1.25]) @ rz90, {"type": "wall"})]  # x 4.0..4.2, y 0..3
    if ceiling:
        nodes.append(("ceiling_0", "slab", t([2.0, 1.5, 2.45]), None))  # z 2.4..2.5
    for name, geom, matrix, meta in nodes:
        kwargs = {} if meta is None else {"metadata": meta}
        scene.graph.update(frame_to=name, frame_from=scene.graph.base_frame, matrix=matrix, geometry=geom,
                           **kwargs)
    return scene


def test_from_trimesh_finds_the_room_box():
    w = WorldModel.from_trimesh(_room_scene())
    assert sorted(w.type_names) == ["ceiling", "door", "floor", "wall"]
    # x: floor 0..4 and the rotated wall up to 4.2; y: the long wall from -0.2, floor/side wall to 3
    np.testing.assert_allclose(w.room.lower, [0.0, -0.2, 0.0], atol=1e-12)
    np.testing.assert_allclose(w.room.upper, [4.2, 3.0, 2.4], atol=1e-12)  # z: under the ceiling
    # type_of skipping the room nodes keeps the room
    only_doors = WorldModel.from_trimesh(_room_scene(), type_of=lambda n, g: "door" if n.startswith("door")
                                         else None)
    assert len(only_doors) == 1
    np.testing.assert_allclose(only_doors.room.upper, [4.2, 3.0, 2.4], atol=1e-12)
    no_ceiling = WorldModel.from_trimesh(_room_scene(ceiling=False))
    np.testing.assert_allclose(no_ceiling.room.upper[2], 2.5)  # top of the walls
    floor_only = WorldModel.from_trimesh(_room_scene(ceiling=False, walls=False))
    np.testing.assert_allclose(floor_only.room.lower, [0.0, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(floor_only.room.upper, [4.0, 3.0, 3.0], atol=1e-12)  # floor + 3 m
    assert WorldModel.from_trimesh(_room_scene(), room=None).room is None
    assert WorldModel.from_trimesh(_hand_scene()).room is None  # its wall_0 has type None


def test_from_trimesh_room_given_or_from_scene_metadata():
    from radialopt import Region

    given = Region([1.0, 1.0, 0.0], [2.0, 2.0, 2.0])
    assert WorldModel.from_trimesh(_room_scene(), room=given).room is given
    scene = _room_scene()
    scene.metadata["room"] = ([-1.0, -1.0, 0.0], [5.0, 4.0, 2.0])
    w = WorldModel.from_trimesh(scene)
    np.testing.assert_allclose(w.room.lower, [-1.0, -1.0, 0.0])
    np.testing.assert_allclose(w.room.upper, [5.0, 4.0, 2.0])
    with pytest.raises(wg.WorldGraphError, match="room must be 'auto'"):
        WorldModel.from_trimesh(_room_scene(), room="detect")


@pytest.mark.parametrize(
    ("room", "error", "match"),
    [
        (([0, 0, 0], [1, 1]), wg.WorldGraphError, r"room upper must have shape \(3,\), got shape \(2,\)"),
        (([0, 0, float("nan")], [1, 1, 1]), wg.WorldGraphError, r"room lower\[2\] must be finite, got nan"),
        (([0, 0, 0], [1, -1, 1]), wg.WorldGraphError, r"room = \(\[0, 0, 0\], \[1, -1, 1\]\) is not a valid"),
        ("kitchen", wg.WorldGraphError, "room must be .*a radialopt.Region.*'kitchen'"),
        ((["a", "b", "c"], [1, 1, 1]), wg.WorldGraphError, "room lower must be an array of real numbers"),
        (([0, 0, 2e6], [1, 1, 3e6]), wg.WorldGraphError,
         r"room lower\[2\] must be <= 1e\+06 in magnitude, got 2000000.0"),
    ],
)
def test_bad_room(room, error, match):
    w = _small_world()
    with pytest.raises(error, match=match):
        WorldModel(w.objects, w.max_link_length, w.class_vertices, room=room)
    with pytest.raises(error, match=match):
        WorldModel.from_trimesh(_room_scene(), room=room)


def test_room_round_trip_equality_and_subset(tmp_path):
    from radialopt import Region

    w = _small_world()
    roomy = WorldModel(w.objects, w.max_link_length, w.class_vertices, link_margin=w.link_margin,
                       room=([-1.0, -1.0, 0.0], [6.0, 6.0, 3.0]))
    assert isinstance(roomy.room, Region)
    assert roomy != w and w != roomy
    moved = WorldModel(w.objects, w.max_link_length, w.class_vertices, link_margin=w.link_margin,
                       room=Region([-1.0, -1.0, 0.0], [6.0, 6.0, 3.5]))
    assert moved != roomy
    roomy.save(tmp_path / "r.json")
    data = json.loads((tmp_path / "r.json").read_text())
    assert data["room"] == {"lower": [-1.0, -1.0, 0.0], "upper": [6.0, 6.0, 3.0]}
    back = WorldModel.load(tmp_path / "r.json")
    assert back == roomy
    np.testing.assert_array_equal(back.room.upper, [6.0, 6.0, 3.0])
    assert "room" not in w.to_dict()  # files without a room stay as they were
    sub = roomy.subset(["door"])
    np.testing.assert_array_equal(sub.room.lower, [-1.0, -1.0, 0.0])
    data["room"] = {"lower": [0, 0, 0], "upper": [1, -1, 1]}
    with pytest.raises(wg.MalformedFileError, match="room = .*not a valid box"):
        WorldModel.load(_write(tmp_path, data))
    data["room"] = {"lower": [0, 0, 0]}
    with pytest.raises(wg.MalformedFileError, match="room must be null or an object"):
        WorldModel.load(_write(tmp_path, data))
    data["room"] = None
    assert WorldModel.load(_write(tmp_path, data)).room is None


def test_type_tree_holds_one_types_positions_in_index_order_and_is_kept() -> None:
    rng = np.random.default_rng(4)
    types = rng.choice(["door", "knob", "drawer"], 200)
    world = WorldModel.from_arrays(types, rng.uniform(0, 10, (200, 3)))
    for t in ("door", "knob", "drawer"):
        tree = world.type_tree(t)
        np.testing.assert_array_equal(tree.data, world.positions[types == t])
        np.testing.assert_array_equal(world.positions[world.indices_of(t)], tree.data)
        assert world.type_tree(t) is tree
    lo, hi = world.bounds
    before = lo.copy()
    lo[:] = 1e9  # a copy: the world's bounds do not change
    np.testing.assert_array_equal(world.bounds[0], before)
    assert np.all(before < world.positions.min(axis=0))
    with pytest.raises(wg.WorldGraphError, match="type_name = 'sofa'"):
        world.type_tree("sofa")


@pytest.mark.parametrize("gravity", [False, True])
def test_far_pairs_hold_exactly_the_pairs_within_reach(gravity: bool) -> None:
    """WorldModel.far_pairs against all pairs by brute force: the same ordered pairs (no object
    with itself), sorted keys equal to the distances (or horizontal distances and dz), for both
    orders of the types."""
    from worldgraph.model import FAR_PAIR_HEIGHT, FAR_PAIR_RANGE

    rng = np.random.default_rng(3)
    n = 400
    pos = np.column_stack([rng.uniform(0, 40, n), rng.uniform(0, 30, n), rng.uniform(0, 9, n)])
    types = rng.choice(["door", "knob", "lamp"], n)
    world = WorldModel.from_arrays(types, pos, max_link_length=2.0)
    for a, b in [("door", "knob"), ("knob", "door"), ("lamp", "lamp")]:
        idx = world.far_pairs(a, b, gravity)
        ia, ib = np.flatnonzero(types == a), np.flatnonzero(types == b)
        expected = set()
        for i in ia:
            for j in ib:
                if i == j:
                    continue
                v = pos[j] - pos[i]
                if gravity:
                    if math.hypot(v[0], v[1]) <= FAR_PAIR_RANGE and abs(v[2]) <= FAR_PAIR_HEIGHT:
                        expected.add((i, j))
                elif np.linalg.norm(v) <= FAR_PAIR_RANGE:
                    expected.add((i, j))
        got = list(zip(idx.i.tolist(), idx.j.tolist(), strict=True))
        assert len(got) == len(set(got)) and set(got) == expected
        assert np.all(np.diff(idx.key) >= 0)
        v = pos[idx.j] - pos[idx.i]
        key = np.hypot(v[:, 0], v[:, 1]) if gravity else np.linalg.norm(v, axis=1)
        assert np.allclose(idx.key, key, atol=1e-5)
        if gravity:
            assert np.allclose(idx.dz, v[:, 2], atol=1e-5)
        window = idx.window(10.0, 10.5)
        inside = np.flatnonzero((key >= 10.0) & (key <= 10.5))
        assert window.start <= inside.min() and window.stop > inside.max()
    with pytest.raises(wg.WorldGraphError, match=r"type_b = 'sofa' is not in the world model"):
        world.far_pairs("door", "sofa")
    with pytest.raises(wg.WorldGraphError, match=r"gravity_aligned must be a bool, got 'yes'"):
        world.far_pairs("door", "knob", "yes")


def test_build_far_pairs_builds_every_type_pair_within_the_budget(monkeypatch) -> None:
    import worldgraph.model.far_pairs as far_pairs

    rng = np.random.default_rng(5)
    world = WorldModel.from_arrays(rng.choice(["door", "knob", "lamp"], 300), rng.uniform(0, 30, (300, 3)))
    n = world.build_far_pairs()
    held = [world.far_pairs(a, b) for a in ("door", "knob", "lamp") for b in ("door", "knob", "lamp")]
    assert all(x is not None for x in held)
    # door-knob and knob-door share their pairs: count each unordered type pair once
    assert n == sum(len(world.far_pairs(a, b).key) for a, b in
                    [("door", "door"), ("door", "knob"), ("door", "lamp"), ("knob", "knob"),
                     ("knob", "lamp"), ("lamp", "lamp")]) > 0
    # over the budget: no index, the association falls back to k-d tree queries
    monkeypatch.setattr(far_pairs, "FAR_PAIR_BUDGET", 0)
    fresh = WorldModel.from_arrays(rng.choice(["door", "knob"], 100), rng.uniform(0, 30, (100, 3)))
    assert fresh.build_far_pairs() == 0 and fresh.far_pairs("door", "knob") is None


def test_the_association_uses_far_pair_indices_but_never_builds_them() -> None:
    from perception import Percept

    rng = np.random.default_rng(6)
    types = rng.choice(["door", "knob", "lamp"], 400)
    pos = rng.uniform([0, 0, 0], [40, 30, 3], (400, 3))
    anchor = pos[int(np.flatnonzero(types == "door")[0])]
    # three landmarks near each other plus two more than the 5 m link table away
    far = np.flatnonzero(np.linalg.norm(pos - anchor, axis=1) > 7.0)[:2]
    near = np.argsort(np.linalg.norm(pos - anchor, axis=1))[:3]
    percepts = [Percept(str(types[i]), pos[i] - anchor, 0.01) for i in np.concatenate([near, far])]
    world = WorldModel.from_arrays(types, pos)
    plain = [h.pairs for h in wg.associate(world, percepts)]  # through the ring join / k-d trees
    assert not world._far_pairs  # nothing built by the association
    assert world._far_pair_index("door", "knob", True, lazy=True) == (None, False)
    built = WorldModel.from_arrays(types, pos)
    assert built.build_far_pairs(True) > 0  # asked for: built ...
    assert built._far_pair_index("knob", "door", True, lazy=True)[0] is not None
    assert built._far_pair_index("knob", "door", True, lazy=True)[1] is True
    assert [h.pairs for h in wg.associate(built, percepts)] == plain  # ... used, same answers


def test_type_rank_is_the_position_in_the_type_index() -> None:
    rng = np.random.default_rng(9)
    types = rng.choice(["door", "knob", "lamp"], 200)
    world = WorldModel.from_arrays(types, rng.uniform(0, 30, (200, 3)))
    for k in range(200):
        assert world.type_index[types[k]][world.type_rank[k]] == k
    with pytest.raises(ValueError):
        world.type_rank[0] = 5


def test_gravity_aligned_flag_round_trips_and_drives_the_association_default(tmp_path) -> None:
    from dataclasses import replace

    from perception import Percept
    from worldgraph import scenes
    from worldgraph.association import ASSOCIATION_TOLERANCES, AssociationTolerances, consistency_graph

    rng = np.random.default_rng(11)
    # two storeys of the same plan 3.5 m apart: a percept pair seen on one storey has model pairs of
    # the same 3D length across the storeys, which gravity-aligned association drops
    plan = rng.uniform([0, 0, 0.5], [12, 10, 2.0], (60, 3))
    pos = np.vstack([plan, plan + [0.0, 0.0, 3.5]])
    types = list(rng.choice(["door", "knob", "lamp"], 60)) * 2
    flat = WorldModel.from_arrays(types, pos)
    level = WorldModel.from_arrays(types, pos, gravity_aligned=True)
    assert not flat.gravity_aligned and level.gravity_aligned and flat != level
    path = tmp_path / "w.json"
    level.save(path)
    assert WorldModel.load(path).gravity_aligned and WorldModel.load(path) == level
    flat.save(path)
    assert not WorldModel.load(path).gravity_aligned
    assert ASSOCIATION_TOLERANCES.gravity_aligned is None
    percepts = [Percept(t, x - plan[0], 0.01) for t, x in zip(types[:5], plan[:5], strict=True)]

    def edges(world: WorldModel, tol: AssociationTolerances) -> int:
        return consistency_graph(world, percepts, tol, min_size=1).number_of_edges()

    # None follows the world; an explicit value overrides it
    on, off = (replace(ASSOCIATION_TOLERANCES, gravity_aligned=g) for g in (True, False))
    assert edges(level, ASSOCIATION_TOLERANCES) == edges(flat, on)
    assert edges(flat, ASSOCIATION_TOLERANCES) == edges(level, off)
    assert edges(level, ASSOCIATION_TOLERANCES) < edges(flat, ASSOCIATION_TOLERANCES)
    with pytest.raises(wg.WorldGraphError, match=r"gravity_aligned must be a bool, got 'yes'"):
        WorldModel.from_arrays(types, pos, gravity_aligned="yes")
    assert scenes.building_site(storeys=2, n_objects=2000).world.gravity_aligned
    assert not scenes.kitchen().gravity_aligned


@pytest.mark.parametrize("m, n_keys", [(0, 5), (1, 5), (9, 3), (5000, 60), (5000, 40_000)])
def test_link_order_is_the_lexsort_of_pair_length_and_indices(m: int, n_keys: int) -> None:
    """The link table's order (three stable sorts) is numpy's lexsort over (type pair, length,
    i, j), the slow obvious reference, with many ties in length and type pair; keys above 16
    bits take the general sort."""
    from worldgraph.model.links import _link_order

    rng = np.random.default_rng(m + n_keys)
    pi, pj = rng.integers(0, 300, m), rng.integers(0, 300, m)
    length = np.round(rng.uniform(0.0, 5.0, m), 1)
    key = rng.integers(0, n_keys, m).astype(np.int64)
    assert np.array_equal(_link_order(pi, pj, length, key, 300), np.lexsort((pj, pi, length, key)))


def test_build_far_pairs_visits_only_type_pairs_within_reach(monkeypatch) -> None:
    """150 types, one object each, 40 m apart on a grid but for a cluster of five: 11,325 type
    pairs, of which 10 hold objects within the far-pair reach.  The per-pair estimate and build
    run for those, not for every type pair (they did: 11,325 calls each)."""
    import worldgraph.model.far_pairs as far_pairs

    g = np.arange(15) * 40.0
    pos = np.array([[x, y, 0.0] for x in g for y in g[:10]])
    pos[1:5] = pos[0] + np.array([[1.0, 0, 0], [0, 2.0, 0], [3.0, 3.0, 1.0], [5.0, 0, 2.0]])
    world = WorldModel.from_arrays([f"part{k:03d}" for k in range(150)], pos)
    calls = {"estimate": 0, "build": 0}
    estimate, build = far_pairs._far_pair_estimate, far_pairs._build_far_pairs

    def counted_estimate(*args, **kwargs):
        calls["estimate"] += 1
        return estimate(*args, **kwargs)

    def counted_build(*args, **kwargs):
        calls["build"] += 1
        return build(*args, **kwargs)

    monkeypatch.setattr(far_pairs, "_far_pair_estimate", counted_estimate)
    monkeypatch.setattr(far_pairs, "_build_far_pairs", counted_build)
    for gravity in (False, True):
        calls.update(estimate=0, build=0)
        held = world.build_far_pairs(gravity)
        assert calls["build"] == 10
        assert calls["estimate"] <= 2 * 10  # each estimated once to order, once on build (kept)
        assert held == 10 * (2 if gravity else 1)  # one ordered pair per type pair (and gravity)
        # the other type pairs read as built and empty, without a build
        far = world.far_pairs("part000", "part149", gravity)
        assert far is not None and len(far.key) == 0 and (far.dz is not None) == gravity
        assert world._far_pair_index("part149", "part005", gravity, lazy=True)[0] is not None
        assert calls["build"] == 10


def _far_reference(world: WorldModel, a: str, b: str, gravity: bool) -> set[tuple[int, int]]:
    """Every ordered pair (type-a object, type-b object), distinct objects, within the far-pair
    reach, by brute force (16 m apart, or gravity-aligned 16 m horizontally and 4 m in z)."""
    ia, ib = world.indices_of(a), world.indices_of(b)
    d = world.positions[ib][None, :, :] - world.positions[ia][:, None, :]
    if gravity:
        near = (np.hypot(d[..., 0], d[..., 1]) <= 16.0) & (np.abs(d[..., 2]) <= 4.0)
    else:
        near = np.linalg.norm(d, axis=2) <= 16.0
    i, j = np.nonzero(near)
    return {(int(ia[p]), int(ib[q])) for p, q in zip(i, j, strict=True) if ia[p] != ib[q]}


@pytest.mark.parametrize("gravity", [False, True])
def test_build_far_pairs_holds_what_brute_force_finds(gravity: bool) -> None:
    """A small mixed world (repeated types, one far-off group, single-object types): after
    build_far_pairs every type pair's index holds exactly the brute-force pairs within reach,
    with their distances, and the type pairs out of reach are empty, not missing."""
    rng = np.random.default_rng(12)
    types = list(rng.choice(["door", "knob", "lamp"], 120)) + ["tap", "sink", "door", "oven", "oven"]
    pos = np.vstack([rng.uniform([0, 0, 0], [40, 30, 9], (120, 3)),
                     [[200, 0, 0], [205, 3, 1], [300, 300, 0], [210, 5, 0.5], [212, 9, 0.0]]])
    world = WorldModel.from_arrays(types, pos)
    world.build_far_pairs(gravity)
    names = sorted(set(types))
    for a in names:
        for b in names:
            ref = _far_reference(world, a, b, gravity)
            index = world.far_pairs(a, b, gravity)
            assert index is not None, (a, b)
            got = set(zip(index.i.tolist(), index.j.tolist(), strict=True))
            assert got == ref and len(index.i) == len(ref), (a, b)
            d = world.positions[index.j] - world.positions[index.i]
            key = np.hypot(d[:, 0], d[:, 1]) if gravity else np.linalg.norm(d, axis=1)
            np.testing.assert_allclose(index.key, key, rtol=1e-6, atol=1e-5)
            assert np.all(np.diff(index.key) >= 0)


def test_centre_depths_are_the_median_half_thinnest_extent_per_type():
    def obj(k, typ, size):
        pose = np.eye(4)
        pose[:3, 3] = [k, 0.0, 1.0]
        return ObjectModel(f"o{k}", typ, pose, np.array(size, dtype=float))

    world = WorldModel([obj(0, "door", [0.5, 0.02, 0.8]), obj(1, "door", [0.6, 0.04, 0.7]),
                        obj(2, "door", [0.4, 0.03, 0.9]), obj(3, "handle", [0.03, 0.03, 0.2])],
                       class_vertices={"box": wg.box_vertices((1, 1, 1))})
    # by hand: doors' half thinnest extents 0.01, 0.02, 0.015 -> median 0.015; the handle's 0.015
    assert world.centre_depths() == pytest.approx({"door": 0.015, "handle": 0.015})
    table = wg.scenes.kitchen(seed=0)
    depths = table.centre_depths()
    assert set(depths) == set(table.type_names) and 0.0 < depths["door"] < 0.05


def _lexsort_tables(types: list[str], pos: np.ndarray, radius: float):
    """Slow obvious reference for the link arrays: every pair tested, oriented by the LinkTable
    rule, ordered by numpy's lexsort over (type pair, length, i, j)."""
    names = sorted(set(types))
    code = {t: c for c, t in enumerate(names)}
    rows = []
    for a, b in combinations(range(len(types)), 2):
        d = pos[a] - pos[b]
        length = float(np.sqrt(np.einsum("ij,ij->i", d[None], d[None]))[0])
        if length >= radius:
            continue
        i, j = (a, b) if (code[types[a]], a) <= (code[types[b]], b) else (b, a)
        rows.append((code[types[i]] * len(names) + code[types[j]], length, i, j))
    key, length, i, j = (np.array([r[k] for r in rows]) for k in range(4))
    order = np.lexsort((j, i, length, key)) if rows else np.zeros(0, np.intp)
    return key[order], length[order], i[order], j[order]


@pytest.mark.parametrize("case", ["one point, one object per type", "one point, repeated types",
                                  "packed, repeated types", "packed, one object per type",
                                  "five points, repeated types"])
def test_dense_links_equal_the_pair_search_and_the_reference(case: str) -> None:
    """Objects packed in one place (every pair within reach) take the enumeration of
    all pairs (_dense_links) instead of the k-d tree's pair search.  Both paths give the same
    arrays, row for row, as the lexsort of all pairs (ties in length at one point, equal type
    pairs, coincident objects of distinct types, pairs just beyond reach when packed)."""
    from worldgraph.model.links import _dense_links, _tree_links, _within_reach

    rng = np.random.default_rng(34)
    n = 120
    if "one point" in case:
        pos = np.tile([1.5, -2.0, 0.25], (n, 1))
    elif "five points" in case:  # 24 objects at each point, of 24 distinct types (ties in length)
        pos = rng.uniform(0.0, 1.0, (5, 3))[np.arange(n) // 24]
    else:
        pos = rng.uniform(0.0, 2.8, (n, 3))
    distinct = "one object per type" in case
    types = [f"t{k}" for k in rng.permutation(n)] if distinct else [f"t{k}" for k in rng.integers(0, 7, n)]
    if "one point" in case and not distinct:  # a type at most once at each point: two points
        types = [f"t{k % 60}" for k in range(n)]
        pos = pos + (np.arange(n) // 60)[:, None] * [0.0, 0.0, 0.5]
    if "five points" in case:
        types = [f"t{k}" for k in np.concatenate([rng.permutation(24) for _ in range(5)])]
    radius = 4.5 if "packed" not in case else 4.0  # packed: box diagonal 4.85 > 4, some pairs out
    w = WorldModel.from_arrays(types, pos, max_link_length=radius)
    names = list(w.type_names)
    codes = np.searchsorted(names, np.array(types)).astype(np.intp)
    key, length, i, j = _lexsort_tables(types, pos, radius)
    dense = _dense_links(names, codes, w.positions, radius)
    tree = _tree_links(names, codes, w.positions, w.tree, radius)
    assert _within_reach(w.positions, radius) == ("packed" not in case)
    for tables in (dense, tree, w.links):
        assert np.array_equal(tables._pi, i) and np.array_equal(tables._pj, j)
        assert np.array_equal(tables._length, length)  # bit for bit: the same arithmetic
        assert np.array_equal(tables._present, np.unique(key))
        assert list(tables) == list(tree) and len(tables) == len(np.unique(key))
        for pair in list(tree)[:50]:
            assert np.array_equal(tables[pair].i, tree[pair].i)
            assert np.array_equal(tables[pair].length, tree[pair].length)


def test_distinct_types_at_one_point_build_or_refuse_before_the_work() -> None:
    """2,000 objects of 2,000 distinct types at one point are a world of 1,999,000
    links, one per type pair (each of length 0); 10,000 such objects would be 49,995,000 links,
    beyond MAX_LINKS: refused by the sample estimate with the argument and the numbers named."""
    from worldgraph.model.links import MAX_LINKS

    n = 2000
    w = WorldModel.from_arrays([f"part{k}" for k in range(n)], np.zeros((n, 3)))
    assert len(w.links) == n * (n - 1) // 2
    table = w.links[("part0", "part1")]
    assert len(table) == 1 and table.length[0] == 0.0
    assert {int(table.i[0]), int(table.j[0])} == {0, 1}
    n = 10_000
    assert n * (n - 1) // 2 > MAX_LINKS
    with pytest.raises(wg.WorldGraphError, match=r"max_link_length = 5 m .*49,995,000 object pairs "
                                                 r"\(10,000 objects"):
        WorldModel.from_arrays([f"part{k}" for k in range(n)], np.zeros((n, 3)))


def test_a_graph_too_large_for_networkx_is_refused_up_front() -> None:
    from worldgraph.model.links import MAX_GRAPH_EDGES

    n = 1500  # at one point: every pair a link, 1,124,250 edges
    assert n * (n - 1) // 2 > MAX_GRAPH_EDGES
    world = WorldModel.from_arrays([f"t{i}" for i in range(n)], np.zeros((n, 3)))
    assert len(world.links) == n * (n - 1) // 2  # the link tables hold them all
    with pytest.raises(wg.WorldGraphError, match=r"1,124,250 edges .*MAX_GRAPH_EDGES.*world\.links"):
        _ = world.graph  # refused before a single edge is added
    small = WorldModel.from_arrays([f"t{i}" for i in range(300)], np.zeros((300, 3)))
    assert small.graph.number_of_edges() == 300 * 299 // 2
