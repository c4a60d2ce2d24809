"""Tests of WorldModel.from_file (worldgraph.importers): OBJ groups, GLB, MJCF through MuJoCo.

Expected positions are written by hand from the files below (box centres, body offsets and
rotations), not computed by the code under test.
"""

from __future__ import annotations

import importlib.util
import math
import sys
import warnings

import numpy as np
import pytest
import trimesh

import perception as pc
import worldgraph as wg
import worldgraph.importers.franka  # noqa: F401  (wg.franka below; the test ran only after test_franka imported it)
from worldgraph import importers

HAVE_GYMNASIUM_ROBOTICS = importlib.util.find_spec("gymnasium_robotics") is not None
needs_kitchen = pytest.mark.skipif(not HAVE_GYMNASIUM_ROBOTICS,
                                   reason="gymnasium-robotics not installed (pip install --no-deps "
                                          "gymnasium-robotics)")


# ----------------------------------------------------------------------------------------------
# OBJ
# ----------------------------------------------------------------------------------------------
# (directive, name, centre, half extents): 13 box parts; two more parts are written literally below
BOXES = [
    ("o", "door_1", (0.45, 0.02, 1.0), (0.45, 0.02, 1.0)),
    ("o", "door_2", (1.35, 0.02, 1.0), (0.45, 0.02, 1.0)),
    ("g", "door_3", (2.25, 0.02, 1.0), (0.45, 0.02, 1.0)),
    ("g", "Door.004", (3.15, 0.02, 1.0), (0.45, 0.02, 1.0)),
    ("o", "door_5", (4.05, 0.02, 1.0), (0.45, 0.02, 1.0)),
    ("g", "handle_1", (0.8, -0.03, 1.05), (0.01, 0.01, 0.1)),
    ("g", "handle_2", (1.7, -0.03, 1.05), (0.01, 0.01, 0.1)),
    ("o", "handle_3", (2.6, -0.03, 1.05), (0.01, 0.01, 0.1)),
    ("g", "handle_4", (3.5, -0.03, 1.05), (0.01, 0.01, 0.1)),
    ("g", "Handle_5", (4.4, -0.03, 1.05), (0.01, 0.01, 0.1)),
    ("o", "knob_1", (0.2, -0.3, 0.9), (0.02, 0.02, 0.02)),
    ("o", "knob_2", (0.4, -0.3, 0.9), (0.02, 0.02, 0.02)),
    ("g", "drawer_1", (5.0, 0.3, 0.4), (0.3, 0.3, 0.1)),
]
# literal parts: knob_3, a tetrahedron with x in [0.5, 0.7], y in [-0.4, -0.2], z in [0.8, 1.0]
# (box centre (0.6, -0.3, 0.9)), faces with negative (relative) indices; drawer_2, a single quad
# with x in [5, 6], y = 1, z in [0.2, 0.6] (centre (5.5, 1.0, 0.4)); then an untyped part.
LITERAL = """\
o knob_3
v 0.5 -0.4 0.8
v 0.7 -0.4 0.8
v 0.6 -0.2 0.8
v 0.6 -0.3 1.0
f -4 -3 -2
f -4 -3 -1
f -3 -2 -1
f -4 -2 -1
g drawer_2 shelf_area
v 5 1 0.2
v 6 1 0.2
v 6 1 0.6
v 5 1 0.6
f -4/1/1 -3/2/1 -2/3/1 -1/4/1
g plinth
v 9 9 0
v 9.5 9 0
v 9 9.5 0
f -3 -2 -1
"""
EXPECTED_OBJ = {name: np.array(centre) for _, name, centre, _ in BOXES}
EXPECTED_OBJ.update({"knob_3": np.array([0.6, -0.3, 0.9]), "drawer_2": np.array([5.5, 1.0, 0.4])})
EXPECTED_TYPES = {"door": 5, "handle": 5, "knob": 3, "drawer": 2}


def _box_text(directive: str, name: str, centre, half, offset: int) -> str:
    lines = [f"{directive} {name}"]
    c, h = np.array(centre), np.array(half)
    for sx in (-1, 1):
        for sy in (-1, 1):
            for sz in (-1, 1):
                x, y, z = c + h * np.array([sx, sy, sz])
                lines.append(f"v {x:.6f} {y:.6f} {z:.6f}")
    # corners k = 4 * (sx > 0) + 2 * (sy > 0) + (sz > 0), 1-based with the offset; quads
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    lines += ["f " + " ".join(str(offset + k + 1) for k in q) for q in quads]
    return "\n".join(lines) + "\n"


@pytest.fixture()
def obj_file(tmp_path):
    text = "# 15 objects by hand\nmtllib missing.mtl\n"
    for k, (directive, name, centre, half) in enumerate(BOXES):
        text += _box_text(directive, name, centre, half, 8 * k)
    text += LITERAL
    path = tmp_path / "kitchen.obj"
    path.write_text(text)
    return path


def test_obj_groups_become_objects(obj_file):
    world = wg.WorldModel.from_file(obj_file)
    assert len(world) == 15
    assert {t: len(v) for t, v in world.type_index.items()} == EXPECTED_TYPES
    ids = [o.id for o in world.objects]
    assert sorted(ids) == sorted(EXPECTED_OBJ)
    for obj in world.objects:
        np.testing.assert_allclose(obj.position, EXPECTED_OBJ[obj.id], atol=1e-9, err_msg=obj.id)
    door = world.objects[ids.index("door_1")]
    np.testing.assert_allclose(door.size, [0.9, 0.04, 2.0], atol=1e-9)
    assert isinstance(world.scene, trimesh.Scene)
    assert "plinth" in world.scene.graph.nodes_geometry  # kept in the scene, not an object


def test_obj_type_of_mapping_and_callable(obj_file):
    world = wg.WorldModel.from_file(obj_file, type_of={r"^door_\d$": "door", r"(?i)^handle": "handle"})
    assert {t: len(v) for t, v in world.type_index.items()} == {"door": 4, "handle": 5}  # not Door.004
    world = wg.WorldModel.from_file(obj_file, type_of=lambda name: "plinth" if name == "plinth" else None)
    assert [o.id for o in world.objects] == ["plinth"]
    np.testing.assert_allclose(world.positions[0], [9.25, 9.25, 0.0], atol=1e-12)


def test_obj_type_of_that_raises_names_the_node(obj_file):
    def boom(name):
        raise KeyError(name)

    with pytest.raises(wg.WorldGraphError, match=r"type_of\('[^']+'\) raised KeyError"):
        wg.WorldModel.from_file(obj_file, type_of=boom)


def test_bad_type_of(obj_file):
    with pytest.raises(wg.WorldGraphError, match=r"pattern '\(door' is not a valid regular"):
        wg.WorldModel.from_file(obj_file, type_of={"(door": "door"})
    with pytest.raises(wg.WorldGraphError, match="type_of must be None, a callable"):
        wg.WorldModel.from_file(obj_file, type_of=3)
    with pytest.raises(wg.WorldGraphError, match=r"type_of\['door'\] must be a non-empty string"):
        wg.WorldModel.from_file(obj_file, type_of={"door": ""})


def test_obj_bad_face_names_the_line(tmp_path):
    path = tmp_path / "bad.obj"
    path.write_text("o door_1\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n")
    with pytest.raises(wg.MalformedFileError, match=r"bad.obj:5: face refers to vertex 7, but 3 vertices"):
        wg.WorldModel.from_file(path)


# ----------------------------------------------------------------------------------------------
# GLB
# ----------------------------------------------------------------------------------------------
def test_glb_round_trip(tmp_path):
    scene = trimesh.Scene()
    box = trimesh.creation.box(extents=(0.2, 0.1, 0.4))
    box.apply_translation((0.1, 0.0, 0.0))  # box centre 0.1 m along the node's x axis
    rz90 = trimesh.transformations.rotation_matrix(math.pi / 2, (0, 0, 1))
    pose = trimesh.transformations.translation_matrix((1.0, 2.0, 3.0)) @ rz90
    scene.add_geometry(box, node_name="door_1", geom_name="leaf", transform=pose)
    scene.add_geometry(trimesh.creation.box(extents=(0.02, 0.02, 0.2)), node_name="handle_1", geom_name="bar",
                       transform=trimesh.transformations.translation_matrix((-0.5, 0.25, 1.0)))
    scene.add_geometry(trimesh.creation.box(extents=(1, 1, 1)), node_name="knob_9", geom_name="body",
                       metadata={"type": None})  # metadata type None: in the scene, not an object
    path = tmp_path / "scene.glb"
    wg.importers.write_scene(scene, path)  # +Y up, as glTF wants it
    # the file holds glTF's axes: (x, y, z) of the scene -> (x, z, -y)
    raw = trimesh.load_scene(path)
    np.testing.assert_allclose(raw.graph.get("handle_1")[0][:3, 3], [-0.5, 1.0, -0.25], atol=1e-6)
    world = wg.WorldModel.from_file(path)
    by_id = {o.id: o for o in world.objects}
    assert sorted(by_id) == ["door_1", "handle_1"]
    # Rz(90 deg) @ (0.1, 0, 0) = (0, 0.1, 0)
    np.testing.assert_allclose(by_id["door_1"].position, [1.0, 2.1, 3.0], atol=1e-6)
    np.testing.assert_allclose(by_id["handle_1"].position, [-0.5, 0.25, 1.0], atol=1e-6)
    np.testing.assert_allclose(by_id["door_1"].size, [0.2, 0.1, 0.4], atol=1e-6)
    assert by_id["door_1"].type == "door" and by_id["handle_1"].type == "handle"
    assert "knob_9" in world.scene.graph.nodes_geometry
    assert world.scene.metadata["up_axis"] == "+y"


def test_single_mesh_ply_is_named_after_the_file(tmp_path):
    mesh = trimesh.creation.box(extents=(0.5, 0.1, 2.0))
    mesh.apply_translation((3.0, -1.0, 1.0))
    path = tmp_path / "door_7.ply"
    mesh.export(path)
    world = wg.WorldModel.from_file(path)
    assert list(world.types) == ["door"]
    np.testing.assert_allclose(world.positions[0], [3.0, -1.0, 1.0], atol=1e-6)
    np.testing.assert_allclose(world.objects[0].size, [0.5, 0.1, 2.0], atol=1e-6)


# ----------------------------------------------------------------------------------------------
# MJCF
# ----------------------------------------------------------------------------------------------
MJCF = """\
<mujoco model="by hand">
  <compiler angle="radian"/>
  <worldbody>
    <geom name="floor" type="plane" size="3 4 0.1"/>
    <geom name="handle_wall" type="box" size="0.01 0.01 0.1" pos="-1 -2 1.5"/>
    <body name="door_1" pos="1 0 0.5">
      <joint name="hinge" type="hinge" axis="0 0 1"/>
      <geom type="box" size="0.4 0.02 1" pos="0.4 0 0"/>
      <geom type="box" size="0.4 0.02 0.05" pos="0.4 0 1.05"/>
      <body name="handle_1" pos="0.7 -0.05 0" euler="0 0 1.5707963267948966">
        <geom type="cylinder" size="0.01 0.1" pos="0.1 0 0"/>
      </body>
    </body>
    <body name="cabinet_1" pos="2 0 0" euler="0 0 1.5707963267948966">
      <geom type="box" size="0.3 0.3 0.3" pos="0 0 0.3"/>
      <body name="drawer_1" pos="0.5 0 0.2" euler="1.5707963267948966 0 0">
        <joint type="slide" axis="1 0 0"/>
        <geom type="box" size="0.2 0.1 0.05" pos="0 0.1 0.3"/>
      </body>
    </body>
    <body name="kettle_1" pos="0 2 1">
      <freejoint/>
      <geom type="sphere" size="0.1"/>
    </body>
    <body name="base" pos="5 5 0">
      <geom type="box" size="1 1 1"/>
    </body>
  </worldbody>
</mujoco>
"""
# by hand:
# door_1 body (1, 0, 0.5), its two boxes span x 0..0.8, z -1..1.1 in the body frame: centre
#   (0.4, 0, 0.05) -> (1.4, 0, 0.55); as geoms: (1.4, 0, 0.5) and (1.4, 0, 1.55)
# handle_1: (1, 0, 0.5) + (0.7, -0.05, 0) + Rz(90) (0.1, 0, 0) = (1.7, -0.05 + 0.1, 0.5)
# cabinet_1: (2, 0, 0) + Rz(90) (0, 0, 0.3) = (2, 0, 0.3)
# drawer_1: (2, 0, 0) + Rz(90) [(0.5, 0, 0.2) + Rx(90) (0, 0.1, 0.3)]
#   Rx(90) (0, 0.1, 0.3) = (0, -0.3, 0.1); sum (0.5, -0.3, 0.3); Rz(90) -> (0.3, 0.5, 0.3);
#   world (2.3, 0.5, 0.3)
# kettle_1: free body at its pos (qpos0) (0, 2, 1); handle_wall: a static geom (-1, -2, 1.5)
EXPECTED_BODIES = {
    "door_1": ("door", [1.4, 0.0, 0.55]),
    "handle_1": ("handle", [1.7, 0.05, 0.5]),
    "cabinet_1": ("cabinet", [2.0, 0.0, 0.3]),
    "drawer_1": ("drawer", [2.3, 0.5, 0.3]),
    "kettle_1": ("kettle", [0.0, 2.0, 1.0]),
    "handle_wall": ("handle", [-1.0, -2.0, 1.5]),
}


@pytest.fixture()
def mjcf_file(tmp_path):
    path = tmp_path / "room.xml"
    path.write_text(MJCF)
    return path


def test_mjcf_bodies(mjcf_file):
    import mujoco

    world = wg.WorldModel.from_file(mjcf_file)
    assert len(world) == 6
    by_id = {o.id: o for o in world.objects}
    assert sorted(by_id) == sorted(EXPECTED_BODIES)
    for name, (typ, pos) in EXPECTED_BODIES.items():
        assert by_id[name].type == typ
        np.testing.assert_allclose(by_id[name].position, pos, atol=1e-9, err_msg=name)
    np.testing.assert_allclose(by_id["drawer_1"].size, [0.4, 0.2, 0.1], atol=1e-9)
    # the floor plane (3 x 4 half sizes at z = 0) gives the room, 3 m high
    np.testing.assert_allclose(world.room.lower, [-3.0, -4.0, 0.0])
    np.testing.assert_allclose(world.room.upper, [3.0, 4.0, 3.0])
    model = world.scene.metadata["mujoco_model"]
    assert isinstance(model, mujoco.MjModel) and model.nbody == 7
    assert isinstance(world.scene.metadata["mujoco_data"], mujoco.MjData)


def test_mjcf_geoms_and_patterns(mjcf_file):
    world = wg.WorldModel.from_file(mjcf_file, mjcf_objects="geoms")
    by_id = {o.id: o for o in world.objects}
    # unnamed geoms are named body:k; the default rule types them by the body's leading word
    assert sorted(by_id) == ["cabinet_1:0", "door_1:0", "door_1:1", "drawer_1:0", "handle_1:0",
                             "handle_wall", "kettle_1:0"]
    np.testing.assert_allclose(by_id["door_1:0"].position, [1.4, 0.0, 0.5], atol=1e-9)
    np.testing.assert_allclose(by_id["door_1:1"].position, [1.4, 0.0, 1.55], atol=1e-9)
    np.testing.assert_allclose(by_id["drawer_1:0"].position, [2.3, 0.5, 0.3], atol=1e-9)
    world = wg.WorldModel.from_file(mjcf_file, type_of={r"^door_\d+:0$": "door", "^base": "box"},
                                    mjcf_objects="geoms")
    assert sorted(o.id for o in world.objects) == ["base:0", "door_1:0"]
    np.testing.assert_allclose(world.positions[world.type_index["box"][0]], [5.0, 5.0, 0.0], atol=1e-12)


def test_mjcf_bad_file_and_bad_mode(tmp_path, mjcf_file):
    path = tmp_path / "bad.xml"
    path.write_text("<mujoco><worldbody>")
    with pytest.raises(wg.MalformedFileError, match="bad.xml: MuJoCo cannot compile it"):
        wg.WorldModel.from_file(path)
    with pytest.raises(wg.WorldGraphError, match="mjcf_objects must be one of"):
        wg.WorldModel.from_file(mjcf_file, mjcf_objects="links")


def test_mjcf_without_mujoco_names_the_extra(mjcf_file, monkeypatch):
    monkeypatch.setitem(sys.modules, "mujoco", None)  # import mujoco -> ImportError
    with pytest.raises(wg.ImporterError, match=r"pip install gaussian-spheres\[mjcf\]"):
        wg.WorldModel.from_file(mjcf_file)


@needs_kitchen
def test_franka_kitchen_matches_the_hand_importer():
    """MuJoCo's compiler and worldgraph.importers.franka's own MJCF reader agree on every typed geom."""
    path = wg.franka_kitchen_path() / "kitchen_env_model.xml"
    _, types = wg.importers.franka.franka_kitchen_scene()
    hand = wg.load_franka_kitchen()
    world = wg.WorldModel.from_file(path, type_of=types.get, mjcf_objects="geoms")
    assert len(world) == len(hand) == 32
    mine = {o.id: o for o in world.objects}
    for obj in hand.objects:
        assert mine[obj.id].type == obj.type
        # float32 mesh vertices in MuJoCo: agreement to a micrometre
        np.testing.assert_allclose(mine[obj.id].position, obj.position, atol=1e-6, err_msg=obj.id)
        np.testing.assert_allclose(mine[obj.id].size, obj.size, atol=1e-6, err_msg=obj.id)
    np.testing.assert_allclose(world.room.lower, hand.room.lower)
    np.testing.assert_allclose(world.room.upper, hand.room.upper)


@needs_kitchen
def test_franka_kitchen_bodies_by_default_rule():
    world = wg.WorldModel.from_file(wg.franka_kitchen_path() / "kitchen_env_model.xml")
    counts = {t: len(v) for t, v in world.type_index.items()}
    # bodies "knob 1".."knob 4", "Burner 1".."Burner 4", "microwave", "oven", "kettle"
    assert counts == {"burner": 4, "kettle": 1, "knob": 4, "microwave": 1, "oven": 1}


# ----------------------------------------------------------------------------------------------
# errors
# ----------------------------------------------------------------------------------------------
def test_missing_file(tmp_path):
    with pytest.raises(wg.MalformedFileError, match="nothing.obj: no such file"):
        wg.WorldModel.from_file(tmp_path / "nothing.obj")


def test_unknown_suffix(tmp_path):
    path = tmp_path / "scene.xyz"
    path.write_text("1 2 3\n")
    with pytest.raises(wg.MalformedFileError,
                       match=r"scene.xyz: file suffix '.xyz' is not a known scene format"):
        wg.WorldModel.from_file(path)


def test_file_format_overrides_the_suffix(tmp_path):
    path = tmp_path / "scene.txt"
    path.write_text("o knob_1\nv 0 0 0\nv 1 0 0\nv 0 2 0\nf 1 2 3\n")
    world = wg.WorldModel.from_file(path, file_format="obj")
    np.testing.assert_allclose(world.positions, [[0.5, 1.0, 0.0]])


def test_no_recognisable_objects_names_path_and_names(tmp_path):
    path = tmp_path / "shapes.obj"
    path.write_text("o Cube\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\ng Sphere_001\nv 0 0 1\nf 1 2 4\n")
    with pytest.raises(wg.WorldGraphError, match=r"shapes.obj: no object recognised among the 2 names "
                                                 r"\['Cube', 'Sphere_001'\]"):
        wg.WorldModel.from_file(path)
    with pytest.raises(wg.WorldGraphError, match="type_of gave None for every name"):
        wg.WorldModel.from_file(path, type_of={"^door": "door"})


def test_unreadable_glb(tmp_path):
    path = tmp_path / "broken.glb"
    path.write_bytes(b"not a glb at all")
    with pytest.raises(wg.MalformedFileError, match="broken.glb: trimesh cannot read it as glb"):
        wg.WorldModel.from_file(path)


def test_dae_without_pycollada(tmp_path, monkeypatch):
    path = tmp_path / "scene.dae"
    path.write_text("<COLLADA/>")
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "collada" else real(name, *a))
    with pytest.raises(wg.ImporterError, match="pip install pycollada"):
        wg.WorldModel.from_file(path)


def test_default_type_of():
    assert importers.default_type_of("Knob 3") == "knob"
    assert importers.default_type_of("door.001") == "door"
    assert importers.default_type_of("handle:2") == "handle"
    assert importers.default_type_of("hingeleftdoor") is None
    assert importers.default_type_of("42") is None


# ----------------------------------------------------------------------------------------------
# MJCF bodies: visual geoms, untyped descendants
# ----------------------------------------------------------------------------------------------
VISUAL_MJCF = """\
<mujoco model="visual and collision">
  <asset>
    <material name="ghost" rgba="0 1 0 0"/>
  </asset>
  <worldbody>
    <body name="cabinet_7" pos="1 2 0">
      <geom type="box" size="0.2 0.3 0.4" pos="0 0 0.4" contype="0" conaffinity="0" group="1"/>
      <geom type="box" size="0.1 0.1 0.1" pos="-1 0 0"/>
      <geom type="box" size="0.5 0.5 0.5" pos="2 0 0" group="3"/>
      <body name="shelfboard" pos="0 0 1">
        <geom type="box" size="0.1 0.1 0.05" pos="0.3 0 0" contype="0" conaffinity="0"/>
        <geom type="box" size="0.3 0.3 0.3" pos="0 0 3" group="4"/>
        <body name="door_2" pos="0 0.5 0">
          <geom type="box" size="0.05 0.05 0.05"/>
        </body>
      </body>
    </body>
    <body name="drawer_3" pos="-1 0 0">
      <geom type="box" size="0.1 0.1 0.1" pos="0 0.5 0" group="3"/>
    </body>
    <body name="knob_5" pos="0 -1 1">
      <geom type="box" size="0.01 0.01 0.01" pos="0.2 0 0"/>
      <geom type="box" size="0.01 0.01 0.01" pos="0 0 0" rgba="1 0 0 0"/>
      <geom type="box" size="0.01 0.01 0.01" pos="-0.4 0 0" material="ghost"/>
    </body>
  </worldbody>
</mujoco>
"""
# by hand (body frame of cabinet_7, at (1, 2, 0)):
#   its visual box (group 1, not colliding): x -0.2..0.2, y -0.3..0.3, z 0..0.8; the colliding
#   group-0 box at x = -1 is left out (the body has non-colliding visual geoms), the group-3 box too;
#   the untyped child shelfboard (at z = 1): its visual box x 0.2..0.4, y -0.1..0.1, z 0.95..1.05
#   (its group-4 box left out); door_2 is typed: its own object.
#   union x -0.2..0.4, y -0.3..0.3, z 0..1.05: centre (0.1, 0, 0.525), size (0.6, 0.6, 1.05)
#   -> world (1.1, 2.0, 0.525)
# door_2: (1, 2, 0) + (0, 0, 1) + (0, 0.5, 0) = (1, 2.5, 1)
# drawer_3: no visual geom: its group-3 box, (-1, 0.5, 0)
# knob_5: the transparent boxes (rgba alpha 0, a material of alpha 0) left out: (0.2, -1, 1)
VISUAL_EXPECTED = {
    "cabinet_7": ([1.1, 2.0, 0.525], [0.6, 0.6, 1.05]),
    "door_2": ([1.0, 2.5, 1.0], [0.1, 0.1, 0.1]),
    "drawer_3": ([-1.0, 0.5, 0.0], [0.2, 0.2, 0.2]),
    "knob_5": ([0.2, -1.0, 1.0], [0.02, 0.02, 0.02]),
}


def test_mjcf_bodies_are_their_visual_geoms_and_untyped_descendants(tmp_path):
    path = tmp_path / "visual.xml"
    path.write_text(VISUAL_MJCF)
    world = wg.WorldModel.from_file(path)
    by_id = {o.id: o for o in world.objects}
    assert sorted(by_id) == sorted(VISUAL_EXPECTED)
    for name, (pos, size) in VISUAL_EXPECTED.items():
        np.testing.assert_allclose(by_id[name].position, pos, atol=1e-9, err_msg=name)
        np.testing.assert_allclose(sorted(by_id[name].size), sorted(size), atol=1e-9, err_msg=name)
    # the same file typed by a mapping that leaves door_2 untyped: the cabinet takes its box
    # (y up to 0.55 in the body frame: y -0.3..0.55, centre 0.125 -> 2.125)
    world = wg.WorldModel.from_file(path, type_of={"^cabinet": "cabinet"})
    assert [o.id for o in world.objects] == ["cabinet_7"]
    np.testing.assert_allclose(world.positions[0], [1.1, 2.125, 0.525], atol=1e-9)


def test_scene_from_file_without_types_keeps_each_bodys_own_visual_geoms(tmp_path):
    path = tmp_path / "visual.xml"
    path.write_text(VISUAL_MJCF)
    scene = importers.scene_from_file(path)
    transform, geometry = scene.graph["cabinet_7"]
    lo, hi = scene.geometry[geometry].bounds
    np.testing.assert_allclose(transform[:3, :3] @ (0.5 * (lo + hi)) + transform[:3, 3], [1.0, 2.0, 0.4],
                               atol=1e-9)


# ----------------------------------------------------------------------------------------------
# up axis
# ----------------------------------------------------------------------------------------------
def _galley() -> trimesh.Scene:
    return wg.scenes.kitchen_layout_scene("galley", seed=3)  # z up, floor, walls, 57 objects


def _same_world(a: wg.WorldModel, b: wg.WorldModel, atol: float) -> None:
    pos_a = {o.id: (o.type, o.position) for o in a.objects}
    pos_b = {o.id: (o.type, o.position) for o in b.objects}
    assert sorted(pos_a) == sorted(pos_b)
    for key, (typ, p) in pos_a.items():
        assert pos_b[key][0] == typ
        np.testing.assert_allclose(pos_b[key][1], p, rtol=0, atol=atol, err_msg=key)
    assert a.room is not None and b.room is not None
    np.testing.assert_allclose(a.room.lower, b.room.lower, rtol=0, atol=atol)
    np.testing.assert_allclose(a.room.upper, b.room.upper, rtol=0, atol=atol)


def test_a_y_up_glb_gives_the_world_of_the_same_scene_written_z_up(tmp_path):
    scene = _galley()
    y_up, z_up = tmp_path / "y_up.glb", tmp_path / "z_up.glb"
    wg.importers.write_scene(scene, y_up)
    scene.export(z_up)  # trimesh writes the coordinates as they are: z up, against the glTF convention
    # the files differ: height along y in one, along z in the other
    assert trimesh.load_scene(y_up).extents[1] == pytest.approx(2.99, abs=0.01)
    assert trimesh.load_scene(z_up).extents[2] == pytest.approx(2.99, abs=0.01)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # neither reading warns
        from_y = wg.WorldModel.from_file(y_up)
        from_z = wg.WorldModel.from_file(z_up, up_axis="+z")
    _same_world(from_y, from_z, atol=1e-9)
    assert len(from_y) == 57
    # and both are the scene itself (to the float32 of the file)
    _same_world(from_y, wg.WorldModel.from_trimesh(scene), atol=1e-6)
    # the room is upright: x 3.43 m, y 3.15 m (floor and walls), 2.89 m high
    np.testing.assert_allclose(from_y.room.upper - from_y.room.lower, [3.43, 3.15, 2.89], atol=1e-6)


def test_a_z_up_glb_read_as_gltf_warns_naming_plus_z(tmp_path):
    path = tmp_path / "z_up.glb"
    _galley().export(path)
    with pytest.warns(UserWarning, match=r"room on its side: the floor is flat along y.*"
                                         r"probably '\+z': pass up_axis='\+z'") as record:
        world = wg.WorldModel.from_file(path)
    assert len(record) == 1
    assert "room is left unset" in str(record[0].message)
    assert world.room is None
    # read as glTF, the z-up file's height (2.99 m) lies along -y
    assert world.bounds[1][1] - world.bounds[0][1] == pytest.approx(2.99, abs=0.01)


def test_a_y_up_file_read_as_z_up_warns_naming_plus_y(tmp_path):
    path = tmp_path / "y_up.glb"
    wg.importers.write_scene(_galley(), path)
    with pytest.warns(UserWarning, match=r"read with up_axis='\+z'.*probably '\+y'"):
        wg.WorldModel.from_file(path, up_axis="+z")


def test_a_room_upside_down_is_named(tmp_path):
    path = tmp_path / "down.glb"
    wg.importers.write_scene(_galley(), path, up_axis="-z")
    with pytest.warns(UserWarning, match=r"floor is flat along z .* above the objects.*probably '-z'"):
        wg.WorldModel.from_file(path, up_axis="+z")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        world = wg.WorldModel.from_file(path, up_axis="-z")
    _same_world(world, wg.WorldModel.from_trimesh(_galley()), atol=1e-6)


@pytest.mark.parametrize("bad", ["up", "+w", "y+", "", 1, 1.5, ("+", "y")])
def test_a_bad_up_axis_is_named(tmp_path, bad):
    path = tmp_path / "scene.glb"
    wg.importers.write_scene(_galley(), path)
    with pytest.raises(wg.WorldGraphError, match=r"up_axis must be None .* one of \('\+x'.*got "):
        wg.WorldModel.from_file(path, up_axis=bad)


def test_z_up_from_takes_each_axis_to_plus_z():
    for axis, vector in (("+x", [1, 0, 0]), ("-x", [-1, 0, 0]), ("+y", [0, 1, 0]), ("-y", [0, -1, 0]),
                         ("+z", [0, 0, 1]), ("-z", [0, 0, -1])):
        m = wg.importers.z_up_from(axis)
        np.testing.assert_array_equal(m[:3, :3] @ vector, [0, 0, 1])
        np.testing.assert_array_equal(m[:3, :3] @ m[:3, :3].T, np.eye(3))
        assert np.linalg.det(m[:3, :3]) == pytest.approx(1.0)
    # glTF: +Y up, +Z front -> (x, y, z) -> (x, -z, y)
    np.testing.assert_array_equal(wg.importers.z_up_from("+y")[:3, :3] @ [1, 2, 3], [1, -3, 2])


@pytest.mark.parametrize(("element", "expected"),
                         [("Z_UP", "+z"), ("Y_UP", "+y"), ("X_UP", "+x"), (None, "+y")])
def test_collada_up_axis_is_read_from_the_file(tmp_path, element, expected):
    path = tmp_path / "scene.dae"
    up = "" if element is None else f"<up_axis>{element}</up_axis>"
    path.write_text('<?xml version="1.0"?><COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" '
                    f'version="1.4.1"><asset>{up}</asset></COLLADA>')
    assert wg.importers.default_up_axis(path) == expected


@pytest.mark.parametrize(("name", "expected"), [("a.glb", "+y"), ("a.gltf", "+y"), ("a.obj", "+z"),
                                                ("a.ply", "+z"), ("a.stl", "+z"), ("a.off", "+z"),
                                                ("a.xml", "+z")])
def test_format_up_axes(name, expected):
    assert wg.importers.default_up_axis(name) == expected


def test_objects_spread_along_z_without_a_floor_warn(tmp_path):
    # a corridor of doors, 12 m long (x), 1.2 m wide (y), handles at 1 m; no floor nodes
    scene = trimesh.Scene()
    for k in range(7):
        for side, y in ((0, -0.6), (1, 0.6)):
            at = trimesh.transformations.translation_matrix((2.0 * k, y, 1.0))
            scene.add_geometry(trimesh.creation.box(extents=(0.9, 0.04, 2.0)), node_name=f"door_{k}{side}",
                               geom_name="leaf", transform=at)
    path = tmp_path / "corridor.glb"
    wg.importers.write_scene(scene, path, up_axis="+x")  # an exporter that put the corridor's length up
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        upright = wg.WorldModel.from_file(path, up_axis="+x")
    assert upright.bounds[1][0] - upright.bounds[0][0] == pytest.approx(12.9, abs=1e-6)
    # read +Y up (glTF's rule) the 12 m lie along z, the doors' common height along x: the axis of
    # least spread is named, its sign unknown
    expected = (r"the objects spread 12 m along z but 0 m along x and 1.2 m along y; "
                r"the file's up axis is probably '\+x' \(or -x\): pass up_axis='\+x'")
    with pytest.warns(UserWarning, match=expected):
        wg.WorldModel.from_file(path)


def test_a_y_up_glb_gives_the_pose_of_the_same_scene_written_z_up(tmp_path):
    scene = _galley()
    y_up, z_up = tmp_path / "y_up.glb", tmp_path / "z_up.glb"
    wg.importers.write_scene(scene, y_up)
    scene.export(z_up)
    from_y, from_z = wg.WorldModel.from_file(y_up), wg.WorldModel.from_file(z_up, up_axis="+z")
    truth = np.eye(4)
    truth[:3, 3] = 0.5 * (from_z.room.lower + from_z.room.upper)
    truth[2, 3] = 1.5
    seen = np.isin(from_z.types, ("door", "handle", "drawer", "knob"))
    percepts, _ = pc.simulate_percepts(from_z.types[seen].tolist(), from_z.positions[seen], truth,
                                       np.random.default_rng(5), hfov_deg=179.0, n_false=0, miss_rate=0.0)
    a, b = wg.localize(from_y, percepts), wg.localize(from_z, percepts)
    assert a.status == b.status == "ok"
    np.testing.assert_allclose(a.transformation, b.transformation, atol=1e-5)
    np.testing.assert_allclose(a.transformation[:3, 3], truth[:3, 3], atol=0.05)
