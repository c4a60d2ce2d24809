"""Fuzz and hardening tests of the world model: worldgraph.model, scenes, franka.

Every public entry point gets nasty values (NaN, inf, +-1e308, 1e-300, negative, zero, huge
ints, bool, None, str, complex, wrong shapes, empty arrays, non-rigid poses, broken files) and
must either raise :class:`worldgraph.WorldGraphError` whose message names the argument, or
return a result that is finite and satisfies its own constraints.  Any other exception fails.
"""

from __future__ import annotations

import json
import os
import tempfile

import numpy as np
import pytest
import trimesh
from hypothesis import event, given
from hypothesis import strategies as st

import worldgraph as wg
from worldgraph import LinkTable, ObjectModel, WorldModel, box_vertices, scenes
from worldgraph.errors import WorldGraphError
from worldgraph.model import COINCIDENT_TOLERANCE, MAX_COORDINATE, room_from_trimesh

NASTY_SCALARS = [
    float("nan"),
    float("inf"),
    -float("inf"),
    1e308,
    -1e308,
    1e-300,
    -1.0,
    0.0,
    0,
    -3,
    10**400,
    True,
    False,
    None,
    "3",
    "",
    1 + 2j,
    [],
    [1.0],
    np.float64("nan"),
    np.int64(2),
]
nasty_scalar = st.sampled_from(NASTY_SCALARS)


def nasty_array(shape: tuple[int, ...]) -> st.SearchStrategy:
    """Arrays of ``shape`` with some nasty entries, or a wrong shape / kind altogether."""
    good = st.floats(0, 10, allow_nan=False).map(float)
    bad = st.sampled_from(
        [float("nan"), float("inf"), 1e308, -1e308, 1e155, 1e-300, 0.0, -1.0, 10**400, True, None, "x", 1j]
    )
    size = int(np.prod(shape))
    arrays = st.lists(good, min_size=size, max_size=size)

    @st.composite
    def one_bad(draw):
        v = draw(arrays)
        if size:
            v[draw(st.integers(0, size - 1))] = draw(bad)
        return v

    def shaped(v):
        return np.array(v, dtype=object).reshape(shape).tolist()

    wrong = st.sampled_from(
        [
            None,
            "abc",
            3.0,
            [],
            [[]],
            [[1, 2], [3]],
            np.zeros((0, 3)),
            np.zeros(shape + (1,)),
            np.ones(shape, dtype=complex),
            np.ones(shape, dtype=bool),
            {"a": 1},
        ]
    )
    return st.one_of(
        arrays.map(shaped), arrays.map(lambda v: np.array(v).reshape(shape)), one_bad().map(shaped), wrong
    )


def raises_named(call, *names):
    """Run ``call``: return its result, or ``None`` when it raised a WorldGraphError naming one of
    ``names``; any other exception (or an unnamed message) fails the test."""
    try:
        out = call()
    except wg.WorldGraphError as exc:
        assert any(n in str(exc) for n in names), f"message {str(exc)!r} names none of {names}"
        event(f"raised {type(exc).__name__}")
        return None
    event("returned")
    return out


def assert_rigid(pose):
    pose = np.asarray(pose)
    assert pose.shape == (4, 4) and np.all(np.isfinite(pose))
    R = pose[:3, :3]
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-6)
    assert abs(np.linalg.det(R) - 1.0) < 1e-6
    np.testing.assert_array_equal(pose[3], [0, 0, 0, 1])
    assert np.all(np.abs(pose[:3, 3]) <= MAX_COORDINATE)


def assert_valid_world(w: WorldModel):
    """Every invariant a WorldModel promises."""
    assert len(w) >= 1
    assert np.all(np.isfinite(w.positions)) and np.all(np.abs(w.positions) <= MAX_COORDINATE)
    ids = [o.id for o in w.objects]
    assert len(set(ids)) == len(ids) and all(isinstance(i, str) and i and "\x00" not in i for i in ids)
    for o in w.objects:
        assert_rigid(o.pose)
        assert np.all(np.isfinite(o.size)) and np.all(o.size >= 0)
        assert isinstance(o.type, str) and o.type and "\x00" not in o.type
        assert o.geometry in w.class_vertices
    assert list(w.types) == [o.type for o in w.objects]  # numpy kept every character
    radius = w.max_link_length + w.link_margin
    for (a, b), table in w.links.items():
        assert a <= b and len(table) > 0
        assert np.all(np.diff(table.length) >= 0) and np.all(table.length < radius)
        d = np.linalg.norm(w.positions[table.i] - w.positions[table.j], axis=1)
        np.testing.assert_allclose(d, table.length, atol=1e-9)
        assert all(w.types[i] == a and w.types[j] == b for i, j in zip(table.i, table.j, strict=True))
    for t, idx in w.type_index.items():
        pos = w.positions[idx]
        if len(pos) > 1:  # no two objects of one type coincide
            from scipy.spatial import cKDTree

            dist, _ = cKDTree(pos).query(pos, k=2)
            assert np.all(dist[:, 1] > COINCIDENT_TOLERANCE), t


def rotation(seed: int) -> np.ndarray:
    q = np.random.default_rng(seed).normal(size=4)
    q /= np.linalg.norm(q)
    w, x, y, z = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


@st.composite
def poses(draw):
    kind = draw(
        st.sampled_from(["rigid", "rigid", "scaled", "sheared", "reflected", "last_row", "nasty", "far"])
    )
    pose = np.eye(4)
    pose[:3, :3] = rotation(draw(st.integers(0, 1000)))
    pose[:3, 3] = draw(st.lists(st.floats(-100, 100), min_size=3, max_size=3))
    if kind == "scaled":
        pose[:3, :3] *= draw(st.sampled_from([0.0, 1e-3, 1.001, 2.0, 1e300]))
    elif kind == "sheared":
        pose[0, 1] += draw(st.sampled_from([1e-3, 0.5, 1e10]))
    elif kind == "reflected":
        pose[:3, 2] *= -1
    elif kind == "last_row":
        pose[3] = [0.0, 0.1, 0.0, 1.0]
    elif kind == "far":
        pose[draw(st.integers(0, 2)), 3] = draw(st.sampled_from([1e6 + 1, 1e155, -1e308]))
    elif kind == "nasty":
        return draw(nasty_array((4, 4)))
    return pose


names = st.one_of(
    st.sampled_from(["door", "handle", "knob"]),
    st.sampled_from(["door", "handle", "knob"]),
    st.sampled_from(["door", "handle", "knob", "a\x00", "", "x" * 300]),
    st.text(max_size=6),
    st.sampled_from([None, 5, b"door", 1.5, ["door"]]),
)


# ----------------------------------------------------------------------------------------------
# ObjectModel, box_vertices
# ----------------------------------------------------------------------------------------------
@given(names, names, poses(), nasty_array((3,)), names)
def test_fuzz_object_model(id_, type_, pose, size, geometry):
    obj = raises_named(
        lambda: ObjectModel(id_, type_, pose, size, geometry), "id", "type", "pose", "size", "geometry"
    )
    if obj is not None:
        assert_rigid(obj.pose)
        assert obj.size.shape == (3,) and np.all(np.isfinite(obj.size)) and np.all(obj.size >= 0)
        assert "\x00" not in obj.type and obj.type == type_


@given(nasty_array((3,)))
def test_fuzz_box_vertices(size):
    v = raises_named(lambda: box_vertices(size), "size")
    if v is not None:
        s = np.asarray(size, dtype=float)
        assert v.shape == (8, 3) and np.all(np.isfinite(v))
        np.testing.assert_allclose(v.max(axis=0) - v.min(axis=0), s, atol=1e-300)


# ----------------------------------------------------------------------------------------------
# WorldModel.from_arrays
# ----------------------------------------------------------------------------------------------
@st.composite
def array_worlds(draw):
    n = draw(st.integers(0, 6))
    valid_types = st.lists(st.sampled_from(["door", "handle", "knob"]), min_size=n, max_size=n)
    types = draw(
        st.one_of(
            valid_types,
            valid_types,
            st.lists(names, min_size=n, max_size=n),
            st.sampled_from([None, "door", 3]),
        )
    )
    positions = draw(
        st.one_of(
            st.lists(st.lists(st.floats(-20, 20), min_size=3, max_size=3), min_size=n, max_size=n),
            st.lists(st.lists(st.floats(-20, 20), min_size=3, max_size=3), min_size=n, max_size=n),
            nasty_array((n, 3)),
            nasty_array((max(n, 1), 2)),
        )
    )
    ids = draw(
        st.one_of(
            st.none(),
            st.none(),
            st.lists(names, min_size=n, max_size=n),
            st.just(["same"] * n),
            st.just([f"o{k}" for k in range(n + 1)]),
        )
    )
    sizes = draw(st.one_of(st.none(), st.none(), nasty_array((3,)), nasty_array((n, 3))))
    mll = draw(st.one_of(st.floats(0.1, 50), st.floats(0.1, 50), nasty_scalar))
    margin = draw(st.one_of(st.just(0.0), st.floats(0, 1), nasty_scalar))
    room = draw(
        st.one_of(
            st.none(),
            st.none(),
            st.none(),
            st.just(([-30, -30, -30], [30, 30, 30])),
            st.just(([1, 1, 1], [0, 0, 0])),
            st.tuples(nasty_array((3,)), nasty_array((3,))),
            nasty_scalar,
        )
    )
    return types, positions, ids, sizes, mll, margin, room


@given(array_worlds())
def test_fuzz_from_arrays(case):
    types, positions, ids, sizes, mll, margin, room = case
    w = raises_named(
        lambda: WorldModel.from_arrays(
            types, positions, max_link_length=mll, ids=ids, sizes=sizes, link_margin=margin, room=room
        ),
        "types",
        "positions",
        "ids",
        "sizes",
        "max_link_length",
        "link_margin",
        "room",
        "objects[",
        "coincide",
    )
    if w is not None:
        assert_valid_world(w)
        np.testing.assert_array_equal(w.positions, np.asarray(positions, dtype=float))


# ----------------------------------------------------------------------------------------------
# WorldModel.load / save
# ----------------------------------------------------------------------------------------------
def _valid_dict() -> dict:
    w = WorldModel.from_arrays(
        ["door", "handle", "handle"], [[0, 0, 0], [1, 0, 0], [0, 1, 0]], room=([-1, -1, -1], [2, 2, 2])
    )
    return w.to_dict()


JSON_NASTY = [
    None,
    True,
    0,
    -1,
    10**400,
    -(10**400),
    1e308,
    "x",
    "",
    "a\x00",
    [],
    {},
    [[1, 2, 3]] * 3,
    [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, -1, 0], [0, 0, 0, 1]],
    [[2, 0, 0, 0], [0, 2, 0, 0], [0, 0, 2, 0], [0, 0, 0, 1]],
    [[1, 0.5, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]],
    [[1, 0, 0, 1e155], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]],
    [1e7, 0, 0],
    [-1, 0.1, 0.1],
]


def _paths(d, prefix=()):
    yield prefix
    if isinstance(d, dict):
        for k, v in d.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(d, list):
        for k, v in enumerate(d):
            yield from _paths(v, prefix + (k,))


def _set(d, path, value):
    if not path:
        return value
    node = d
    for k in path[:-1]:
        node = node[k]
    node[path[-1]] = value
    return d


@st.composite
def file_bytes(draw):
    data = _valid_dict()
    kind = draw(
        st.sampled_from(
            [
                "mutate",
                "mutate",
                "mutate",
                "truncate",
                "deep",
                "bytes",
                "nonutf8",
                "nan",
                "dup_id",
                "valid",
                "number",
            ]
        )
    )
    if kind == "valid":
        return json.dumps(data).encode()
    if kind == "number":  # a numeric leaf changed to another number: may stay valid or break rigidity
        paths = [p for p in _paths(data) if len(p) > 1 and p[0] in ("objects", "class_vertices", "room")]
        path = draw(st.sampled_from(paths))
        node = data
        for k in path:
            node = node[k]
        if isinstance(node, int | float) and not isinstance(node, bool):
            _set(data, path, node + draw(st.sampled_from([0.5, -0.25, 3.0, 1e-12])))
        return json.dumps(data).encode()
    if kind == "mutate":
        paths = list(_paths(data))
        path = draw(st.sampled_from(paths))
        data = _set(data, path, draw(st.sampled_from(JSON_NASTY)))
        return json.dumps(data).encode()
    text = json.dumps(data).encode()
    if kind == "truncate":
        return text[: draw(st.integers(0, len(text) - 1))]
    if kind == "deep":
        return draw(st.sampled_from([b"[" * 100000, b'{"a":' * 50000, b"[" * 100000 + b"]" * 100000]))
    if kind == "nonutf8":
        k = draw(st.integers(0, len(text)))
        return text[:k] + draw(st.sampled_from([b"\xff", b"\xc3", b"\xed\xa0\x80"])) + text[k:]
    if kind == "nan":
        return text.replace(
            b"0.05", draw(st.sampled_from([b"NaN", b"Infinity", b"1e999", b"1" + b"0" * 400]))
        )
    if kind == "dup_id":
        data["objects"][1]["id"] = data["objects"][0]["id"]
        return json.dumps(data).encode()
    return draw(st.binary(max_size=200))


@given(file_bytes())
def test_fuzz_load(content):
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "world.json")
        with open(path, "wb") as fh:
            fh.write(content)
        try:
            w = WorldModel.load(path)
        except wg.MalformedFileError as exc:
            assert path in str(exc)
            event("raised MalformedFileError")
            return
        event("loaded")
        assert_valid_world(w)
        # what loads saves and loads back to the same model
        w.save(os.path.join(tmp, "back.json"))
        assert WorldModel.load(os.path.join(tmp, "back.json")) == w


@given(
    st.sampled_from(
        [None, 3, 1.5, b"/tmp/x\x00", "/tmp/a\x00b.json", "", "/nonexistent/dir/w.json", "/", ["a"], object()]
    )
)
def test_fuzz_load_paths(path):
    with pytest.raises(wg.MalformedFileError, match="path|/|cannot read"):
        WorldModel.load(path)


# ----------------------------------------------------------------------------------------------
# WorldModel.from_trimesh, room_from_trimesh
# ----------------------------------------------------------------------------------------------
@st.composite
def odd_scenes(draw):
    scene = trimesh.Scene()
    n = draw(st.integers(0, 5))
    for k in range(n):
        kind = draw(st.sampled_from(["box", "box", "empty", "cloud", "empty_cloud", "flat", "huge_vertex"]))
        if kind == "box":
            geom = trimesh.creation.box(extents=draw(st.sampled_from([(1, 1, 1), (0.1, 2, 0.3)])))
        elif kind == "empty":
            geom = trimesh.Trimesh()
        elif kind == "cloud":
            geom = trimesh.PointCloud(np.random.default_rng(k).uniform(-1, 1, (draw(st.integers(1, 4)), 3)))
        elif kind == "empty_cloud":
            geom = trimesh.PointCloud(np.zeros((0, 3)))
        elif kind == "flat":
            geom = trimesh.Trimesh(vertices=[[0, 0, 0], [1, 0, 0], [0, 1, 0]], faces=[[0, 1, 2]])
        else:
            geom = trimesh.Trimesh(
                vertices=[[0, 0, 0], [1e200, 0, 0], [0, 1, 0]],
                faces=[[0, 1, 2]],
                validate=False,
                process=False,
            )
        m = np.eye(4)
        tkind = draw(st.sampled_from(["id", "id", "move", "scale", "nan", "far", "zero"]))
        if tkind == "move":
            m[:3, 3] = [k * 2.0, 1.0, 0.0]
        elif tkind == "scale":
            m[:3, :3] *= 3.0
            m[:3, 3] = [k * 2.0, 0.0, 5.0]
        elif tkind == "nan":
            m[0, 3] = np.nan
        elif tkind == "far":
            m[1, 3] = 1e300
        elif tkind == "zero":
            m[:3, :3] = 0.0
            m[:3, 3] = [k * 2.0, 3.0, 0.0]
        name = draw(st.sampled_from([f"thing{k}", f"door_{k}", f"floor_{k}", f"wall:{k}", f"x{k}"]))
        scene.add_geometry(geom, node_name=name, geom_name=f"g{k}", transform=m)
    return scene


type_ofs = st.sampled_from(
    [
        None,
        lambda node, g: str(node)[:2],
        lambda node, g: None,
        lambda node, g: 7,
        lambda node, g: "",
        lambda node, g: 1 / 0,
        "not callable",
    ]
)


@given(odd_scenes(), type_ofs, st.one_of(st.just("auto"), st.none(), st.just("detect"), nasty_scalar))
def test_fuzz_from_trimesh(scene, type_of, room):
    w = raises_named(
        lambda: WorldModel.from_trimesh(scene, type_of=type_of, room=room),
        "scene",
        "type",
        "node",
        "vertices",
        "room",
        "coincide",
        "transform",
        "objects",
        "ObjectModel",
    )
    if w is not None:
        assert_valid_world(w)
        for o in w.objects:  # empty geometry never became an object
            assert len(np.asarray(scene.geometry[o.geometry].vertices)) > 0
    r = raises_named(lambda: room_from_trimesh(scene), "room", "vertices", "transform", "scene")
    if r is not None:
        assert np.all(np.isfinite(r.lower)) and np.all(r.lower <= r.upper)


@given(st.sampled_from([None, 3, "scene", trimesh.creation.box(), [trimesh.Scene()]]))
def test_fuzz_from_trimesh_not_a_scene(scene):
    with pytest.raises(WorldGraphError, match="scene must be a trimesh.Scene"):
        WorldModel.from_trimesh(scene)
    with pytest.raises(WorldGraphError, match="scene must be a trimesh.Scene"):
        room_from_trimesh(scene)
    with pytest.raises(WorldGraphError, match="scene must be a trimesh.Scene"):
        scenes.scene_statistics(scene)


# ----------------------------------------------------------------------------------------------
# LinkTable and world queries
# ----------------------------------------------------------------------------------------------
ints3 = st.one_of(
    st.lists(st.integers(0, 10), min_size=3, max_size=3),
    st.lists(st.integers(-1, 10), min_size=3, max_size=3),
)
sorted3 = st.lists(st.floats(0, 10), min_size=3, max_size=3).map(sorted)


@given(
    st.one_of(ints3, ints3, ints3, nasty_array((3,))),
    st.one_of(ints3, ints3, ints3, nasty_array((3,)), st.just([0.5, 1, 2])),
    st.one_of(sorted3, sorted3, nasty_array((3,)), st.just([0.3, 0.2, 0.1])),
    st.one_of(st.floats(-1, 11), nasty_scalar),
    st.one_of(st.floats(-1, 11), nasty_scalar),
)
def test_fuzz_link_table(i, j, length, lo, hi):
    table = raises_named(lambda: LinkTable(i, j, length), "LinkTable")
    if table is not None:
        assert table.i.dtype == np.intp and np.all(table.i >= 0) and np.all(table.j >= 0)
        assert np.all(np.isfinite(table.length)) and np.all(np.diff(table.length) >= 0)
        out = raises_named(lambda: table.in_range(lo, hi), "lo", "hi")
        if out is not None:
            assert np.all((out[2] > float(lo)) & (out[2] < float(hi)))


_QUERY_WORLD = WorldModel.from_arrays(
    ["door", "handle", "handle", "knob"], [[0, 0, 0], [1, 0, 0], [0, 1, 0], [40, 0, 0]], max_link_length=3.0
)


@given(
    st.one_of(names, st.sampled_from(["door", "handle", "knob"])),
    st.one_of(names, st.sampled_from(["door", "handle", "knob"])),
    st.one_of(st.floats(-1, 5), nasty_scalar),
    st.one_of(st.floats(-1, 5), nasty_scalar),
)
def test_fuzz_world_queries(a, b, lo, hi):
    w = _QUERY_WORLD
    out = raises_named(lambda: w.link_lengths(a, b, lo, hi), "type_a", "type_b", "lo", "hi")
    if out is not None:
        i, j, length = out
        assert np.all(w.types[i] == a) and np.all(w.types[j] == b)
        assert np.all((length > lo) & (length < hi))
    idx = raises_named(lambda: w.indices_of(a), "type_name")
    if idx is not None:
        assert np.all(w.types[idx] == a)
    sub = raises_named(lambda: w.subset([a, b]), "types[")
    if sub is not None:
        assert_valid_world(sub)
        assert set(sub.types) == {a, b}
    region = raises_named(lambda: w.region(lo), "margin")
    if region is not None:
        assert np.all(np.isfinite(region.lower)) and np.all(region.lower <= region.upper)


# ----------------------------------------------------------------------------------------------
# scenes
# ----------------------------------------------------------------------------------------------
BAD_SEEDS = [-1, 1.5, float("nan"), None, "1", True, np.float64(2.0), 1j, [0], np.random.default_rng(0)]


@given(st.sampled_from(BAD_SEEDS))
def test_fuzz_scene_seeds_rejected(seed):
    for call in (
        lambda: scenes.kitchen_scene(seed),
        lambda: scenes.kitchen(seed=seed),
        lambda: scenes.kitchen_layout_scene("galley", seed),
        lambda: scenes.kitchen_layout("l_shape", seed),
        lambda: scenes.corridor_scene(2, seed=seed),
        lambda: scenes.corridor(2, seed=seed),
        lambda: scenes.floor(5, seed=seed),
    ):
        with pytest.raises(wg.WorldGraphError, match="seed"):
            call()


@given(
    st.one_of(st.integers(-2, 4), nasty_scalar),
    st.one_of(st.none(), st.floats(0, 20), nasty_scalar),
    st.one_of(st.just(2.2), nasty_scalar),
    st.one_of(st.just(2.8), nasty_scalar),
    st.one_of(st.just(5.0), nasty_scalar),
    st.one_of(st.just(0.0), nasty_scalar),
)
def test_fuzz_corridor(n_doors, length, width, height, mll, margin):
    scene = raises_named(
        lambda: scenes.corridor_scene(n_doors, length, 0, width, height),
        "n_doors",
        "length",
        "width",
        "height",
    )
    if scene is not None:
        stats = scenes.scene_statistics(scene)
        assert stats["objects"] == len(scene.graph.nodes_geometry)
        assert_valid_world(WorldModel.from_trimesh(scene))
    w = raises_named(
        lambda: scenes.corridor(n_doors, length, 1, mll, margin),
        "n_doors",
        "length",
        "max_link_length",
        "link_margin",
    )
    if w is not None:
        assert_valid_world(w)


@given(
    st.one_of(st.integers(-2, 300), nasty_scalar),
    st.one_of(st.integers(0, 3), nasty_scalar),
    st.one_of(st.just(5.0), nasty_scalar),
)
def test_fuzz_floor(n_objects, seed, mll):
    w = raises_named(lambda: scenes.floor(n_objects, seed, mll), "n_objects", "seed", "max_link_length")
    if w is not None:
        assert len(w) == n_objects
        assert_valid_world(w)


@given(st.sampled_from(["galley", "x", "", None, 3, ["galley"], "GALLEY"]), nasty_scalar)
def test_fuzz_kitchen_arguments_rejected_before_building(kind, mll):
    # every case here is invalid in at least one argument, so each raises before any scene is built
    with pytest.raises(wg.WorldGraphError, match="kind|max_link_length"):
        scenes.kitchen_layout(kind if kind != "galley" else "x", 0, mll)
    if not (type(mll) in (int, float, np.float64, np.int64) and 0 < mll < 1e300):
        with pytest.raises(wg.WorldGraphError, match="max_link_length"):
            scenes.kitchen(0, mll)


# ----------------------------------------------------------------------------------------------
# deterministic cases of the issue
# ----------------------------------------------------------------------------------------------
def test_100k_coincident_same_type_objects_raise_at_first_pair():
    # the old all-pairs listing needed ~1.7 GB at 10,000 objects and failed at 30,000
    n = 100_000
    with pytest.raises(wg.WorldGraphError, match=r"objects\[0\].*objects\[1\].*\[0\.0, 0\.0, 0\.0\]"):
        WorldModel.from_arrays(["cup"] * n, np.zeros((n, 3)))


def test_near_coincident_same_type_objects_found():
    pos = np.array([[0.0, 0.0, 0.0], [5.0, 5.0, 5.0], [5.0, 5.0, 5.0 + 0.5e-9]])
    with pytest.raises(wg.WorldGraphError, match=r"objects\[1\] \('cup_1'\) and objects\[2\]"):
        WorldModel.from_arrays(["cup"] * 3, pos)
    # 1e-300 apart: the squared distance underflows to 0, the message still names two objects
    with pytest.raises(wg.WorldGraphError, match=r"objects\[0\] \('cup_0'\) and objects\[1\]"):
        WorldModel.from_arrays(["cup"] * 2, [[0, 0, 0], [1e-300, 0, 0]])
    with pytest.raises(wg.WorldGraphError, match=r"objects\[0\] \('cup_0'\) and objects\[1\]"):
        WorldModel.from_arrays(["cup"] * 2, [[1e-300, 0, 0], [0, 0, 0]])
    # different types may coincide, and 2e-9 apart is not coincident
    w = WorldModel.from_arrays(["cup", "cup", "jar"], [[0, 0, 0], [0, 0, 2e-9], [0, 0, 0]])
    assert w.links[("cup", "jar")].length.tolist() == [0.0, 2e-9]


def test_30000_types_build_with_sparse_link_tables():
    n = 30_000
    pos = np.random.default_rng(0).uniform(0, 100, (n, 3))
    w = WorldModel.from_arrays([f"t{k}" for k in range(n)], pos, max_link_length=1.0)
    assert len(w.type_index) == n
    radius_pairs = sum(len(t) for t in w.links.values())
    from scipy.spatial import cKDTree

    assert radius_pairs == len(cKDTree(pos).query_pairs(1.0))
    assert len(w.links) == radius_pairs  # one table per linked pair, none for the ~4.5e8 others
    empty = w.links[("t0", "t1")] if ("t0", "t1") not in w.links else w.links[("t0", "t0")]
    assert len(empty) == 0 and empty.in_range(-1, 2)[0].size == 0
    assert w.links.get(("t1", "t0")) is None and w.links.get(("zzz", "zzz")) is None
    with pytest.raises(KeyError):
        w.links[("nope", "t0")]
    assert w.link_lengths("t5", "t5")[0].size == 0


def test_trimesh_scene_names_without_separator_give_one_type_per_node():
    scene = trimesh.Scene()
    for k in range(300):
        scene.add_geometry(
            trimesh.creation.box(extents=(0.1, 0.1, 0.1)),
            node_name=f"thing{k}",
            transform=trimesh.transformations.translation_matrix([k * 10.0, 0, 0]),
        )
    w = WorldModel.from_trimesh(scene)
    assert len(w.type_index) == 300 and len(w.links) == 0
    assert len(w.links[("thing0", "thing1")]) == 0


@pytest.mark.parametrize(
    ("linear", "det"),
    [
        (np.diag([2.0, 1.0, 1.0]), "det R = 2"),
        (np.array([[1.0, 0.3, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]), "det R = 1,"),
        (np.diag([1.0, 1.0, -1.0]), "det R = -1"),
    ],
)
def test_non_rigid_poses_rejected(tmp_path, linear, det):
    pose = np.eye(4)
    pose[:3, :3] = linear
    with pytest.raises(WorldGraphError, match=rf"ObjectModel 'a' pose must be rigid.*{det}.*R\^T R - I"):
        ObjectModel("a", "door", pose, (1, 1, 1))
    data = _valid_dict()
    data["objects"][1]["pose"] = pose.tolist()
    path = tmp_path / "w.json"
    path.write_text(json.dumps(data))
    with pytest.raises(wg.MalformedFileError, match=rf"w.json.*objects\[1\].*{det}"):
        WorldModel.load(path)


def test_ids_and_types_validated():
    with pytest.raises(wg.WorldGraphError, match=r"ids\[0\] must be a non-empty string, got ''"):
        WorldModel.from_arrays(["a", "b"], [[0, 0, 0], [1, 1, 1]], ids=["", "y"])
    with pytest.raises(wg.WorldGraphError, match=r"'x' appears more than once, at ids\[0\] and ids\[1\]"):
        WorldModel.from_arrays(["a", "b"], [[0, 0, 0], [1, 1, 1]], ids=["x", "x"])
    with pytest.raises(wg.WorldGraphError, match=r"ids\[1\] must be a non-empty string, got 3"):
        WorldModel.from_arrays(["a", "b"], [[0, 0, 0], [1, 1, 1]], ids=["x", 3])
    # numpy would turn "a\0" into "a" and merge it with "a": NUL characters are rejected instead
    with pytest.raises(wg.WorldGraphError, match=r"types\[0\] must not contain NUL"):
        WorldModel.from_arrays(["a\x00", "a"], [[0, 0, 0], [0, 0, 0]])
    with pytest.raises(wg.WorldGraphError, match=r"types\[1\] must be a non-empty string, got None"):
        WorldModel.from_arrays(["a", None], [[0, 0, 0], [1, 1, 1]])


def test_written_file_always_loads(tmp_path):
    w = WorldModel.from_arrays(["dé", "a b"], [[0, 0, 0], [1, 1, 1]], ids=["ü\u2028", "y"])
    w.save(tmp_path / "w.json")
    assert WorldModel.load(tmp_path / "w.json") == w


@pytest.mark.parametrize("value", [1e155, -1e300, MAX_COORDINATE * 1.000001])
def test_coordinates_bounded(value):
    with pytest.raises(WorldGraphError, match=r"positions\[1, 2\] must be <= 1e\+06 in magnitude, got"):
        WorldModel.from_arrays(["a", "a"], [[0, 0, 0], [0, 0, value]])
    w = WorldModel.from_arrays(["a", "a"], [[0, 0, 0], [0, 0, MAX_COORDINATE]], max_link_length=1e6)
    assert w.links[("a", "a")].length.tolist() == []


@pytest.mark.parametrize(
    ("content", "match"),
    [
        (
            b'{"version": 1, "max_link_length": ' + b"1" * 400 + b', "objects": [], "class_vertices": {}}',
            "max_link_length.*does not fit a float64",
        ),
        (
            b'{"version": 1, "max_link_length": 5, "objects": [], "class_vertices": {"b": [['
            + b"9" * 400
            + b", 0, 0]]}}",
            r"class_vertices\['b'\]\[0, 0\].*does not fit a float64",
        ),
        (b"\xff\xfe{}", "not UTF-8"),
        (b"[" * 100000, "nested too deeply|not valid JSON"),
        (b'{"a":' * 100000, "nested too deeply|not valid JSON"),
    ],
)
def test_load_malformed_content(tmp_path, content, match):
    path = tmp_path / "w.json"
    path.write_bytes(content)
    with pytest.raises(wg.MalformedFileError, match=match) as info:
        WorldModel.load(path)
    assert str(path) in str(info.value)


@pytest.mark.parametrize(
    ("path", "match"),
    [
        (None, "path must be a str or os.PathLike, got None"),
        ("/tmp/a\x00b.json", "path must not contain NUL"),
        (b"/tmp/w.json", "path must be a str"),
        ("", "path must be a non-empty string"),
    ],
)
def test_load_bad_paths(path, match):
    with pytest.raises(wg.MalformedFileError, match=match):
        WorldModel.load(path)


def test_save_bad_path(tmp_path):
    w = _QUERY_WORLD
    with pytest.raises(wg.WorldGraphError, match="NUL"):
        w.save(str(tmp_path / "a\x00b"))
    with pytest.raises(wg.WorldGraphError, match="cannot write"):
        w.save(tmp_path / "missing" / "w.json")


def test_from_trimesh_skips_empty_geometry():
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.Trimesh(), node_name="empty_0")
    scene.add_geometry(trimesh.PointCloud(np.zeros((0, 3))), node_name="cloud_0")
    with pytest.raises(wg.WorldGraphError, match=r"scene has no typed geometry nodes with vertices"):
        WorldModel.from_trimesh(scene)
    scene.add_geometry(trimesh.PointCloud([[0, 0, 0], [1, 2, 3]]), node_name="cloud_1")
    scene.add_geometry(
        trimesh.creation.box(extents=(1, 1, 1)),
        node_name="box_1",
        transform=trimesh.transformations.translation_matrix([5, 0, 0]),
    )
    w = WorldModel.from_trimesh(scene)
    assert sorted(o.id for o in w.objects) == ["box_1", "cloud_1"]
    cloud = next(o for o in w.objects if o.id == "cloud_1")
    np.testing.assert_allclose(cloud.position, [0.5, 1.0, 1.5])
    np.testing.assert_allclose(cloud.size, [1, 2, 3])
    assert room_from_trimesh(scene) is None


def test_from_trimesh_bad_type_of():
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.box(), node_name="box_1")
    with pytest.raises(wg.WorldGraphError, match=r"type_of\('box_1', geometry\) raised ZeroDivisionError"):
        WorldModel.from_trimesh(scene, type_of=lambda n, g: 1 / 0)
    with pytest.raises(wg.WorldGraphError, match="type of node 'box_1' must be a non-empty string, got 7"):
        WorldModel.from_trimesh(scene, type_of=lambda n, g: 7)
    with pytest.raises(WorldGraphError, match="type_of must be a callable"):
        WorldModel.from_trimesh(scene, type_of="door")


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: scenes.kitchen(seed="a"), "seed must be an integer, got 'a'"),
        (lambda: scenes.kitchen(seed=-1), "seed must be >= 0, got -1"),
        (lambda: scenes.kitchen_scene(seed=2.0), "seed must be an integer, got 2.0"),
        (lambda: scenes.kitchen_layout("galley", seed=None), "seed must be an integer, got None"),
        (lambda: scenes.kitchen_layout("nope", 0), "kind must be one of"),
        (lambda: scenes.kitchen_layout(["galley"], 0), "kind must be one of"),
        (lambda: scenes.corridor(n_doors=True), "n_doors must be an integer, got True"),
        (lambda: scenes.corridor(n_doors=3.0), "n_doors must be an integer, got 3.0"),
        (lambda: scenes.corridor(n_doors=10**9), "n_doors must be <= 10000"),
        (lambda: scenes.corridor_scene(2, width=float("nan")), "width must be finite, got nan"),
        (lambda: scenes.corridor_scene(2, length=1e300), "length must be <= 500000, got 1e\\+300"),
        (lambda: scenes.floor(n_objects=float("nan")), "n_objects must be an integer, got nan"),
        (lambda: scenes.floor(n_objects=None), "n_objects must be an integer, got None"),
        (lambda: scenes.floor(n_objects=0), "n_objects must be >= 1, got 0"),
        (lambda: scenes.floor(10, max_link_length="5"), "max_link_length must be a real number, got '5'"),
        (lambda: scenes.kitchen(0, link_margin=-1.0), "link_margin must be >= 0, got -1.0"),
        (
            lambda: WorldModel.from_arrays(["a"], [[0, 0, 0]], room="kitchen"),
            "room must be a radialopt.Region",
        ),
        (
            lambda: WorldModel.from_arrays(["a"], [[0, 0, 0]], room=([0, 0, 0], [1, 1, 1j])),
            "room upper\\[2\\] must be real, got complex values",
        ),
        (
            lambda: WorldModel.from_arrays(["a"], [[0, 0, 0]], max_link_length=1e300),
            "max_link_length must be <= 1e\\+07, got 1e\\+300",
        ),
        (lambda: _QUERY_WORLD.region(-10.0), "margin = -10.0 shrinks"),
        (lambda: _QUERY_WORLD.indices_of(["door"]), "type_name must be a type name"),
        (lambda: _QUERY_WORLD.subset(None), "types must be an iterable"),
    ],
)
def test_bad_arguments_named(call, match):
    with pytest.raises(wg.WorldGraphError, match=match):
        call()


def test_franka_bad_paths(tmp_path):
    from worldgraph.importers import franka

    with pytest.raises(WorldGraphError, match="path must be None, a str or an os.PathLike, got 3"):
        franka.franka_kitchen_scene(3)
    with pytest.raises(WorldGraphError, match=r"path must not contain.*NUL"):
        franka.load_franka_kitchen("a\x00b")
    with pytest.raises(wg.WorldGraphError, match="max_link_length"):
        franka.load_franka_kitchen(tmp_path, max_link_length=float("nan"))
    bad = tmp_path / "kitchen_env_model.xml"
    bad.write_bytes(b"<mujoco>" + b"<worldbody><body>" * 3000 + b"</body></worldbody>" * 3000 + b"</mujoco>")
    with pytest.raises(wg.MalformedFileError, match="kitchen_env_model.xml"):
        franka.franka_kitchen_scene(tmp_path)


_AUDIT_WORLD = WorldModel.from_arrays(["a", "b", "a"], np.eye(3))


@pytest.mark.parametrize(("call", "name"), [
    # a 0-d array escaped as TypeError (iteration over a 0-d array)
    (lambda: _AUDIT_WORLD.subset(np.array(2.0)), "types"),
    # from_dict named neither the argument nor the value ("<dict>: top level ...")
    (lambda: WorldModel.from_dict(2.5), "data"),
    (lambda: WorldModel.from_dict(None), "data"),
])
def test_audit_cases_are_named_errors(call, name):
    """Cases found by the independent audit: a WorldGraphError whose message names the argument."""
    with pytest.raises(wg.WorldGraphError, match=name):
        call()


@pytest.mark.parametrize("types", [[], (), iter([])])
def test_subset_of_no_types_names_types(types):
    """Audit: subset([]) raised "objects must hold at least one object", naming no argument of subset."""
    with pytest.raises(wg.WorldGraphError, match="types"):
        _AUDIT_WORLD.subset(types)
