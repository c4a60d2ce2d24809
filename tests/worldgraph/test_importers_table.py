"""Tests of the compact world of ``WorldModel.from_file`` / ``from_trimesh``.

A multi-storey map read from a GLB or an OBJ file gives the world ``from_arrays`` gives for the
same objects (an :class:`~worldgraph.ObjectTable` behind both) with the same association
answers; the batched ``from_trimesh`` gives, object by object, what the per-node construction
(:func:`_reference_from_trimesh`, the code it replaced, kept here as the slow obvious reference)
gives, rotated, scaled, mirrored, shared and empty geometry included.
"""

from __future__ import annotations

import math
import pickle
import warnings

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

import worldgraph as wg
from perception.simulation.simulate import simulate_percepts
from worldgraph.errors import WorldGraphError
from worldgraph.model import ObjectModel, ObjectTable, room_from_trimesh
from worldgraph.model.objects import _check_type_name
from worldgraph.model.scene_nodes import _geometry_nodes, _rotation_and_scale, _vertices, default_type

SIZES = {"chair": (0.4375, 0.4375, 0.875), "door": (0.875, 0.0625, 2.0),
         "socket": (0.078125, 0.015625, 0.078125), "switch": (0.078125, 0.015625, 0.078125),
         "table": (1.25, 0.75, 0.0625), "window": (1.25, 0.125, 1.25)}


def _building(rooms_per_storey: int = 16, storeys: int = 3, seed: int = 0):
    """Types, positions (multiples of 1/256 m, exact in a GLB's float32 and an OBJ's 8 decimals),
    sizes and storeys of a small multi-storey building: per 4 m x 5 m room a door, a switch, a
    socket, a window, a table and 3 chairs around it, jittered."""
    rng = np.random.default_rng(seed)
    cols = 4
    types, pts, storey = [], [], []
    for s in range(storeys):
        for r in range(rooms_per_storey):
            x0, y0, z0 = (r % cols) * 4.0, (r // cols) * 5.0, s * 3.5
            tx, ty = x0 + 2 + rng.uniform(-0.4, 0.4), y0 + 2.5 + rng.uniform(-0.5, 0.5)
            room = [("door", (x0 + 0.6, y0 + 0.05, z0 + 1.0)), ("switch", (x0 + 1.2, y0 + 0.1, z0 + 1.1)),
                    ("socket", (x0 + 3.0, y0 + 0.1, z0 + 0.3)), ("window", (x0 + 2.0, y0 + 4.9, z0 + 1.5)),
                    ("table", (tx, ty, z0 + 0.74))]
            a0 = rng.uniform(0, 2 * math.pi)
            room += [("chair", (tx + 0.8 * math.cos(a0 + 2 * math.pi * j / 3),
                                ty + 0.8 * math.sin(a0 + 2 * math.pi * j / 3), z0 + 0.45)) for j in range(3)]
            for t, p in room:
                types.append(t)
                pts.append(p)
                storey.append(s)
    p = np.array(pts) + rng.normal(0, 0.02, (len(pts), 3))
    p = np.round(p * 256) / 256
    t = np.array(types)
    return t, p, np.array([SIZES[x] for x in types]), np.array(storey)


def _scene(types, positions) -> trimesh.Scene:
    scene = trimesh.Scene()
    for k, (t, p) in enumerate(zip(types.tolist(), positions, strict=True)):
        scene.add_geometry(trimesh.creation.box(extents=SIZES[t]), node_name=f"{t}_{k}", geom_name=f"{t}_{k}",
                           transform=trimesh.transformations.translation_matrix(p))
    return scene


def _draws(types, positions, storey, n: int, seed: int = 1):
    """Poses 0.8 m above a random table, 8 percepts of the robot's own storey within 8 m."""
    rng = np.random.default_rng(seed)
    tables = np.flatnonzero(types == "table")
    out = []
    while len(out) < n:
        table = tables[rng.integers(len(tables))]
        mask = storey == storey[table]
        pose = np.eye(4)
        pose[:3, :3] = Rotation.from_euler("z", rng.uniform(0, 2 * math.pi)).as_matrix()
        pose[:3, 3] = positions[table] + [0.0, 0.0, 0.8]
        percepts, _ = simulate_percepts(list(types[mask]), positions[mask], pose, rng, max_range=8.0)
        if len(percepts) >= 8:
            out.append([percepts[i] for i in rng.choice(len(percepts), 8, replace=False)])
    return out


@pytest.mark.parametrize("suffix", ["glb", "obj"])
def test_multi_storey_file_gives_the_world_and_answers_of_from_arrays(tmp_path, suffix):
    types, positions, sizes, storey = _building()
    path = tmp_path / f"building.{suffix}"
    wg.importers.write_scene(_scene(types, positions), path)  # glb: +Y up; obj: as it is
    world = wg.WorldModel.from_file(path)
    assert isinstance(world.objects, ObjectTable)
    assert world.objects.rotations is None  # translations only: stored as from_arrays stores them
    ids = [world.objects.id(k) for k in range(len(world))]
    order = np.array([int(i.rsplit("_", 1)[1]) for i in ids])
    assert sorted(order.tolist()) == list(range(len(types)))
    ref = wg.WorldModel.from_arrays(types[order], positions[order], ids=ids, sizes=sizes[order])
    np.testing.assert_array_equal(world.positions, ref.positions)
    np.testing.assert_array_equal(world.types, ref.types)
    np.testing.assert_array_equal(world.objects.sizes, ref.objects.sizes)
    assert [world.objects[k].geometry for k in range(3)] == ids[:3]
    for k in (0, len(world) // 2, len(world) - 1):
        o, r = world.objects[k], ref.objects[k]
        assert (o.id, o.type) == (r.id, r.type)
        np.testing.assert_array_equal(o.pose, r.pose)
        np.testing.assert_array_equal(o.size, r.size)
    tol = wg.AssociationTolerances(gravity_aligned=True)
    for percepts in _draws(types, positions, storey, 3):
        got = [h.pairs for h in wg.associate(world, percepts, tol=tol)]
        want = [h.pairs for h in wg.associate(ref, percepts, tol=tol)]
        assert got == want and got
        a, b = wg.localize(world, percepts, tol=tol), wg.localize(ref, percepts, tol=tol)
        assert a.status == b.status and a.correspondences == b.correspondences
        np.testing.assert_allclose(a.transformation, b.transformation, atol=1e-12)


# ----------------------------------------------------------------------------------------------
# the batched from_trimesh against the per-node construction it replaced
# ----------------------------------------------------------------------------------------------
def _reference_from_trimesh(scene, type_of=None):
    """The per-node construction of ``WorldModel.from_trimesh`` before the table: one
    ``ObjectModel`` per typed geometry node with vertices; returns (objects, class_vertices, room,
    empty nodes, mirrored nodes)."""
    room = room_from_trimesh(scene)
    objs, class_vertices, empty, mirrored = [], {}, [], []
    for node, matrix, geom_name, geometry in _geometry_nodes(scene):
        verts = _vertices(f"vertices of geometry {geom_name!r}", geometry)
        if verts is None:
            empty.append(str(node))
            continue
        typ = type_of(node, geometry) if type_of is not None else default_type(scene, node, geometry)
        if typ is None:
            continue
        _check_type_name(typ, f"type of node {node!r}")
        lo, hi = verts.min(axis=0), verts.max(axis=0)
        centre = 0.5 * (lo + hi)
        rot, scale = _rotation_and_scale(matrix)
        if np.linalg.det(matrix[:3, :3]) < 0:
            mirrored.append(str(node))
        pose = np.eye(4)
        pose[:3, :3] = rot
        pose[:3, 3] = matrix[:3, :3] @ centre + matrix[:3, 3]
        size = (hi - lo) * scale
        key = str(geom_name)
        if key not in class_vertices:
            class_vertices[key] = (verts - centre) * scale
        objs.append(ObjectModel(str(node), typ, pose, size, key))
    return tuple(objs), class_vertices, room, empty, mirrored


def _odd_scene(seed: int = 3) -> trimesh.Scene:
    """Rotated, scaled, sheared, mirrored and translated nodes, shared geometry, a point cloud,
    empty geometry, untyped nodes and room nodes."""
    rng = np.random.default_rng(seed)
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.box(extents=(6, 5, 0.1)), node_name="floor_0", geom_name="slab",
                       transform=trimesh.transformations.translation_matrix((2, 2, -0.05)))
    scene.add_geometry(trimesh.creation.box(extents=(6, 0.1, 2.8)), node_name="wall_0", geom_name="wall",
                       transform=trimesh.transformations.translation_matrix((2, -0.5, 1.4)))
    leaf = trimesh.creation.box(extents=(0.9, 0.04, 2.0))
    leaf.apply_translation((0.45, 0.0, 1.0))  # off-centre geometry
    knob = trimesh.creation.icosphere(subdivisions=1, radius=0.03)
    for k in range(40):
        m = Rotation.random(random_state=seed + k).as_matrix() if k % 4 else np.eye(3)
        if k % 5 == 1:
            m = m * rng.uniform(0.5, 2.0, 3)  # axis scales
        if k % 7 == 3:
            m = m @ np.diag([1.0, 1.0, -1.0])  # a reflection
        if k % 11 == 5:
            m = m @ np.array([[1.0, 0.2, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])  # shear
        t = np.eye(4)
        t[:3, :3], t[:3, 3] = m, rng.uniform(-3, 3, 3)
        geometry, key = (leaf, "leaf") if k % 2 else (knob, f"knob_mesh_{k}")
        name = f"{'door' if k % 2 else 'knob'}_{k}"
        scene.add_geometry(geometry, node_name=name, geom_name=key, transform=t)
    scene.add_geometry(trimesh.PointCloud(rng.uniform(0, 1, (20, 3))), node_name="handle_cloud",
                       geom_name="pc", transform=trimesh.transformations.translation_matrix((1, 1, 1)))
    scene.add_geometry(trimesh.Trimesh(), node_name="door_empty", geom_name="nothing")
    scene.add_geometry(trimesh.creation.box(extents=(1, 1, 1)), node_name="lamp_x", geom_name="lampbox",
                       transform=trimesh.transformations.translation_matrix((0, 0, 2.5)))
    return scene


@pytest.mark.parametrize("typed", [False, True])
def test_batched_from_trimesh_matches_the_per_node_reference(typed):
    scene = _odd_scene()

    def type_of(node, _geometry):
        return None if str(node).startswith("lamp") else str(node).split("_", 1)[0]

    rule = type_of if typed else None
    objs, cv, room, empty, mirrored = _reference_from_trimesh(scene, rule)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        world = wg.WorldModel.from_trimesh(scene, type_of=rule)
    messages = [str(w.message) for w in caught]
    assert any(f"{len(empty)} geometry node(s) without vertices" in m and "door_empty" in m for m in messages)
    assert mirrored and any(f"{len(mirrored)} node(s) with a reflecting transform" in m for m in messages)
    assert isinstance(world.objects, ObjectTable) and world.objects.rotations is not None
    assert len(world.objects) == len(objs)
    for k, ref in enumerate(objs):  # exact: same id, type, pose, size and geometry key
        assert world.objects[k] == ref, (k, ref.id)
    assert list(world.objects) == list(objs)
    assert list(world.class_vertices) == list(cv)
    for key, v in cv.items():
        np.testing.assert_array_equal(world.class_vertices[key], v)
    np.testing.assert_array_equal(world.room.lower, room.lower)
    np.testing.assert_array_equal(world.room.upper, room.upper)
    reference = wg.WorldModel(objs, class_vertices=cv, room=room)
    assert world == reference and reference == world
    np.testing.assert_array_equal(world.bounds[0], reference.bounds[0])
    np.testing.assert_array_equal(world.bounds[1], reference.bounds[1])
    # files: saved and loaded back (a tuple world), equal to the table world
    back = wg.WorldModel.from_dict(world.to_dict())
    assert back == world and world.to_dict() == reference.to_dict()
    # a subset keeps the rotations and geometry keys
    sub = world.take([3, 1, 4])
    assert isinstance(sub.objects, ObjectTable)
    assert list(sub.objects) == [objs[3], objs[1], objs[4]]
    assert set(sub.class_vertices) == {objs[k].geometry for k in (3, 1, 4)}
    assert list(pickle.loads(pickle.dumps(world.objects))) == list(objs)


def test_bad_values_raise_the_per_node_errors():
    # a box whose centre lands beyond MAX_COORDINATE: the ObjectModel error names the node
    scene = trimesh.Scene()
    box = trimesh.creation.box(extents=(1, 1, 1))
    box.apply_translation((6e5, 0, 0))
    scene.add_geometry(box, node_name="door_far", geom_name="far",
                       transform=trimesh.transformations.translation_matrix((6e5, 0, 0)))
    with pytest.raises(WorldGraphError, match=r"ObjectModel 'door_far' pose\[0, 3\] = 1200000\.0 is"):
        wg.WorldModel.from_trimesh(scene, room=None)
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.box(extents=(1, 1, 1)), node_name="door_nan", geom_name="g",
                       transform=np.diag([1.0, 1.0, np.inf, 1.0]))
    with pytest.raises(wg.errors.WorldGraphError, match=r"transform of scene node 'door_nan'\[2, 2\]"):
        wg.WorldModel.from_trimesh(scene, room=None)


def test_object_table_rotations_and_geometries():
    pos = np.array([[0.0, 0, 0], [1, 0, 0]])
    size = np.ones((2, 3))
    rz = Rotation.from_euler("z", 0.3).as_matrix()
    table = ObjectTable(["a"], [0, 0], pos, size, rotations=[np.eye(3), rz], geometries=["g1", "g0"])
    assert table[1].geometry == "g0" and table.geometry_names == ("g0", "g1")
    np.testing.assert_array_equal(table[1].pose[:3, :3], rz)
    np.testing.assert_array_equal(table.geometries, ["g1", "g0"])
    plain = ObjectTable(["a"], [0, 0], pos, size, rotations=[np.eye(3)] * 2, geometries=["a", "a"])
    assert plain.rotations is None and plain.geometry_names is None  # stored as from_arrays stores it
    assert plain == ObjectTable(["a"], [0, 0], pos, size) and table != plain
    with pytest.raises(WorldGraphError, match=r"rotations\[1\] must be a rotation"):
        ObjectTable(["a"], [0, 0], pos, size, rotations=[np.eye(3), 2 * rz])
    with pytest.raises(WorldGraphError, match=r"geometries\[0\] must be a non\-empty string, got ''"):
        ObjectTable(["a"], [0, 0], pos, size, geometries=["", "g"])
    with pytest.raises(WorldGraphError, match=r"object 'a_0' has geometry 'g1', which is not a key"):
        wg.WorldModel(table, class_vertices={"g0": np.zeros((1, 3))})
    world = wg.WorldModel(table, class_vertices={"g0": np.zeros((1, 3)), "g1": np.ones((1, 3))})
    assert wg.WorldModel.from_dict(world.to_dict()) == world
