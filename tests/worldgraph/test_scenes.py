"""Tests of worldgraph.scenes: the paper-sized kitchen, the corridor and the large floor."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree

import worldgraph as wg
from worldgraph import scenes

PAPER = {"box": 611, "cylinder": 124, "polyhedron": 18, "objects": 753, "vertices": 13853}


@pytest.fixture(scope="module")
def kitchen0() -> wg.WorldModel:
    return scenes.kitchen(0)


def _classify(mesh: trimesh.Trimesh) -> str:
    """Primitive kind from the geometry itself, not from the builder's metadata."""
    v = mesh.vertices
    ext = v.max(axis=0) - v.min(axis=0)
    if len(v) == 8 and np.isclose(mesh.volume, np.prod(ext), rtol=1e-9):
        return "box"
    # a cylinder along z: every vertex on the axis or on one circle, on two caps
    c = 0.5 * (v.max(axis=0) + v.min(axis=0))
    r = np.linalg.norm(v[:, :2] - c[:2], axis=1)
    on_circle = np.isclose(r, r.max(), rtol=1e-9) | np.isclose(r, 0.0, atol=1e-12)
    caps = np.isclose(v[:, 2], v[:, 2].min()) | np.isclose(v[:, 2], v[:, 2].max())
    if on_circle.all() and caps.all() and np.isclose(r.max(), ext[0] / 2, rtol=1e-6):
        return "cylinder"
    return "polyhedron"


def test_kitchen_has_the_papers_statistics(kitchen0):
    scene = kitchen0.scene
    counts = {"box": 0, "cylinder": 0, "polyhedron": 0}
    vertices = 0
    kinds: dict[str, str] = {}
    for node in scene.graph.nodes_geometry:
        name = scene.graph[node][1]
        if name not in kinds:
            kinds[name] = _classify(scene.geometry[name])
        counts[kinds[name]] += 1
        vertices += len(scene.geometry[name].vertices)
    assert counts == {k: PAPER[k] for k in counts}
    assert sum(counts.values()) == PAPER["objects"] == len(kitchen0)
    assert abs(vertices - PAPER["vertices"]) <= 0.1 * PAPER["vertices"]
    for name, kind in kinds.items():  # the builder's own label agrees with the geometry
        assert scene.geometry[name].metadata["primitive"] == kind
    for name, kind in kinds.items():
        if kind == "polyhedron":
            mesh = scene.geometry[name]
            assert mesh.is_watertight and mesh.is_convex and mesh.volume > 0
    assert scenes.scene_statistics(scene)["vertices"] == vertices


def test_kitchen_room_and_types(kitchen0):
    lo, hi = kitchen0.bounds
    np.testing.assert_allclose(hi - lo, [10.2, 8.2, 3.1], atol=0.05)  # room plus wall thickness
    inside = (kitchen0.positions >= [-0.1, -0.1, -0.05]) & (kitchen0.positions <= [10.1, 8.1, 3.05])
    assert inside.all()
    counts = {t: len(v) for t, v in kitchen0.type_index.items()}
    for t in ("door", "handle", "drawer", "knob", "cabinet", "countertop", "wall", "appliance", "shelf"):
        assert counts.get(t, 0) >= 1, t
    assert counts["wall"] == 4 and counts["floor"] == 1
    assert counts["knob"] >= 5  # the stove
    assert counts["handle"] >= 40 and counts["door"] >= 20  # repetition


def test_kitchen_every_door_has_a_handle_and_every_drawer_a_pull(kitchen0):
    pos, idx = kitchen0.positions, kitchen0.type_index
    handles = cKDTree(pos[idx["handle"]])
    pulls = cKDTree(np.vstack([pos[idx["handle"]], pos[idx["knob"]]]))
    for k in idx["door"]:
        obj = kitchen0.objects[k]
        reach = 0.5 * float(np.linalg.norm(obj.size)) + 0.05
        assert handles.query_ball_point(pos[k], reach), obj.id
    for k in idx["drawer"]:
        obj = kitchen0.objects[k]
        assert pulls.query_ball_point(pos[k], 0.5 * float(np.linalg.norm(obj.size)) + 0.05), obj.id
    assert len(idx["handle"]) >= len(idx["door"])


def test_kitchen_is_deterministic_and_seed_dependent(kitchen0):
    again = scenes.kitchen(0)
    assert again == kitchen0
    a, b = scenes.kitchen_scene(0), scenes.kitchen_scene(0)
    assert list(a.graph.nodes_geometry) == list(b.graph.nodes_geometry)
    for node in a.graph.nodes_geometry:
        np.testing.assert_array_equal(a.graph[node][0], b.graph[node][0])
    other = scenes.kitchen(1)
    assert other != kitchen0
    assert len(other) == PAPER["objects"]
    assert not np.allclose(other.positions, kitchen0.positions)


def test_kitchen_link_index_is_dense(kitchen0):
    n_links = sum(len(t) for t in kitchen0.links.values())
    assert n_links == kitchen0.graph.number_of_edges() > 10 * len(kitchen0)
    i, j, length = kitchen0.link_lengths("handle", "door", 0.0, 0.5)
    assert set(j.tolist()) == set(kitchen0.type_index["door"].tolist())  # a handle near every door
    assert set(i.tolist()) <= set(kitchen0.type_index["handle"].tolist())
    np.testing.assert_allclose(length, np.linalg.norm(kitchen0.positions[i] - kitchen0.positions[j], axis=1))


def test_corridor_handles_at_one_height_on_both_sides():
    w = scenes.corridor(n_doors=12, seed=4)
    idx = w.type_index
    assert len(idx["door"]) == 12 and len(idx["handle"]) == 12 and len(idx["switch"]) == 12
    handles = w.positions[idx["handle"]]
    np.testing.assert_allclose(handles[:, 2], 1.05, atol=1e-12)  # the coplanar case
    sides = np.sign(w.positions[idx["door"]][:, 1])
    assert (sides > 0).sum() == 6 and (sides < 0).sum() == 6
    doors = w.positions[idx["door"]]
    for h in handles:  # each handle sits on a door
        assert np.min(np.linalg.norm(doors[:, [0, 1]] - h[[0, 1]], axis=1)) < 0.5
    again = scenes.corridor(n_doors=12, seed=4)
    assert again == w
    assert scenes.corridor(n_doors=12, seed=5) != w


def test_corridor_bad_input():
    with pytest.raises(wg.WorldGraphError, match="n_doors"):
        scenes.corridor_scene(0)
    with pytest.raises(wg.WorldGraphError, match="too short"):
        scenes.corridor_scene(10, length=3.0)


def test_floor_size_types_and_determinism():
    w = scenes.floor(n_objects=20000, seed=0)
    assert len(w) == 20000
    for t in ("door", "handle", "switch", "window", "chair", "table"):
        assert len(w.type_index[t]) > 500, t
    handles = w.positions[w.type_index["handle"]]
    np.testing.assert_allclose(handles[:, 2], 1.05)
    small = scenes.floor(n_objects=1500, seed=0)
    np.testing.assert_array_equal(small.positions, w.positions[:1500])
    assert scenes.floor(n_objects=1500, seed=1) != small
    with pytest.raises(wg.WorldGraphError, match="n_objects"):
        scenes.floor(n_objects=0)


def test_kitchen_objects_match_the_scene_transforms(kitchen0):
    scene = kitchen0.scene
    edge_data = scene.graph.transforms.edge_data
    base = scene.graph.base_frame
    for obj in kitchen0.objects:
        matrix, name = scene.graph[obj.id]
        world_mesh = scene.geometry[name].copy()
        world_mesh.apply_transform(matrix)
        np.testing.assert_allclose(obj.position, world_mesh.bounds.mean(axis=0), atol=1e-9)
        assert obj.type == edge_data[(base, obj.id)]["metadata"]["type"] == obj.id.rsplit("_", 1)[0]
        local = (world_mesh.vertices - obj.position) @ obj.pose[:3, :3]
        np.testing.assert_allclose(local.max(axis=0) - local.min(axis=0), obj.size, atol=1e-9)


# ----------------------------------------------------------------------------------------------
# kitchen layouts
# ----------------------------------------------------------------------------------------------
def _base_widths(scene: trimesh.Scene) -> list[float]:
    """Widths of the base cabinet carcasses (untyped boxes 0.76 m high named cabinet_*)."""
    out = []
    for node in scene.graph.nodes_geometry:
        ext = scene.geometry[scene.graph[node][1]].extents
        if node.startswith("cabinet_") and abs(ext[2] - 0.76) < 1e-9:
            out.append(round(float(ext[0]), 3))
    return out


@pytest.mark.parametrize("kind", scenes.LAYOUT_KINDS + scenes.VARIED_LAYOUT_KINDS)
def test_layout_builds_with_room_and_landmarks_only(kind):
    w = scenes.kitchen_layout(kind, seed=0)
    types = set(w.type_names)
    assert types <= set(scenes.LAYOUT_TYPES)
    assert not types & {"floor", "wall", "ceiling"}
    for t in ("door", "handle", "knob", "panel", "fridge", "oven", "stove", "sink", "microwave"):
        assert t in types, t
    assert 40 <= len(w) <= 400
    # the scene holds the room structure; the room box is the walls' outer faces, floor to ceiling
    scene = w.scene
    nodes = list(scene.graph.nodes_geometry)
    assert sum(n.startswith("wall_") for n in nodes) == 4
    assert "floor_000" in nodes and "ceiling_000" in nodes
    rx, ry, rz = scene.metadata["room_size"]
    np.testing.assert_allclose(w.room.lower, [-0.1, -0.1, 0.0], atol=1e-12)
    np.testing.assert_allclose(w.room.upper, [rx + 0.1, ry + 0.1, rz], atol=1e-12)
    lo, hi = w.bounds  # every object's box lies in the room, above the floor
    assert np.all(lo >= w.room.lower - 1e-9) and np.all(hi <= w.room.upper + 1e-9)
    assert np.all(lo >= [0.0, 0.0, 0.0]) and np.all(hi <= [rx, ry, rz])


@pytest.mark.parametrize("kind", scenes.LAYOUT_KINDS)
def test_layout_repeats_identical_units(kind):
    for seed in range(4):
        scene = scenes.kitchen_layout_scene(kind, seed)
        widths = _base_widths(scene)
        counts = {x: widths.count(x) for x in widths}
        assert max(counts.values()) >= 2, (seed, widths)
        w = scenes.kitchen_layout(kind, seed)
        # identical fronts: at least two doors (or drawers) of one size
        sizes = [tuple(np.round(o.size, 4)) for o in w.objects if o.type in ("door", "drawer")]
        assert len(sizes) > len(set(sizes))


def _shared_neighbourhoods(world) -> float:
    """The fraction of objects whose type and 3 nearest neighbours (type, distance to 1 cm) are
    another object's too."""
    from collections import Counter

    from scipy.spatial import cKDTree

    _, idx = cKDTree(world.positions).query(world.positions, 4)
    sig = [(str(world.types[i]),) + tuple((str(world.types[j]), round(float(np.linalg.norm(
        world.positions[j] - world.positions[i])) / 0.01)) for j in row[1:]) for i, row in enumerate(idx)]
    counts = Counter(sig)
    return float(np.mean([counts[x] > 1 for x in sig]))


def test_varied_layouts_repeat_less():
    repeated = [_shared_neighbourhoods(scenes.kitchen_layout(k, s))
                for k in scenes.LAYOUT_KINDS for s in range(4)]
    varied = [_shared_neighbourhoods(scenes.kitchen_layout(k, s))
              for k in scenes.VARIED_LAYOUT_KINDS for s in range(4)]
    assert np.mean(varied) <= 0.75 * np.mean(repeated), (np.mean(varied), np.mean(repeated))
    for kind in scenes.VARIED_LAYOUT_KINDS:  # no bank: a width repeats only where two units drew it
        for seed in range(4):
            widths = _base_widths(scenes.kitchen_layout_scene(kind, seed))
            assert max(widths.count(x) for x in widths) <= len(widths) // 2 + 1, (kind, seed, widths)


@pytest.mark.parametrize("kind", scenes.LAYOUT_KINDS + scenes.VARIED_LAYOUT_KINDS)
def test_layout_is_deterministic_and_seed_dependent(kind):
    a, b = scenes.kitchen_layout(kind, 3), scenes.kitchen_layout(kind, 3)
    assert a == b
    assert [o.id for o in a.objects] == [o.id for o in b.objects]
    sizes = {scenes.kitchen_layout_scene(kind, s).metadata["room_size"] for s in range(4)}
    assert len(sizes) == 4  # the room changes with the seed
    c = scenes.kitchen_layout(kind, 4)
    assert c != a


def test_layout_room_dimensions_follow_the_kind():
    for seed in range(10):
        rx, ry, rz = scenes.kitchen_layout_scene("one_wall", seed).metadata["room_size"]
        assert 3.0 <= ry <= 5.0 and 2.6 <= rz <= 3.0
        w = scenes.kitchen_layout("one_wall", seed)
        cabinets = w.positions[np.isin(w.types, ["door", "drawer"]) & (w.positions[:, 2] < 1.0)]
        assert np.all(cabinets[:, 1] > ry - 0.7)  # one run, along the back wall
        rx, ry, _ = scenes.kitchen_layout_scene("galley", seed).metadata["room_size"]
        assert 1.2 <= ry - 2 * 0.62 <= 2.5 + 1e-9  # the aisle between the two runs
        w = scenes.kitchen_layout("island", seed)
        mid = w.positions[(w.positions[:, 1] > 1.0) & (w.positions[:, 1] < w.room.upper[1] - 1.5)]
        assert len(mid) >= 10  # the island in the middle of the room


def test_layout_builds_fast_and_bad_kind():
    import time

    for kind in scenes.LAYOUT_KINDS:
        best = np.inf
        for _ in range(2):
            t0 = time.perf_counter()
            scenes.kitchen_layout(kind, 1)
            best = min(best, time.perf_counter() - t0)
        assert best < 0.5, kind
    with pytest.raises(wg.WorldGraphError, match="kind must be one of"):
        scenes.kitchen_layout_scene("studio")


def test_kitchen_room_is_set(kitchen0):
    np.testing.assert_allclose(kitchen0.room.lower, [-0.1, -0.1, 0.0], atol=1e-12)
    np.testing.assert_allclose(kitchen0.room.upper, [10.1, 8.1, 3.0], atol=1e-12)
    assert len(kitchen0) == 753 and "wall" in kitchen0.type_names
