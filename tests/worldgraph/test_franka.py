"""Tests of worldgraph.importers.franka: the gymnasium-robotics Franka kitchen as a world model."""

from __future__ import annotations

import importlib.util
import math

import numpy as np
import pytest

import worldgraph as wg
from worldgraph.importers import franka

HAVE_GYMNASIUM_ROBOTICS = importlib.util.find_spec("gymnasium_robotics") is not None
SKIP_REASON = "gymnasium-robotics not installed (pip install --no-deps gymnasium-robotics)"
needs_kitchen = pytest.mark.skipif(not HAVE_GYMNASIUM_ROBOTICS, reason=SKIP_REASON)


@pytest.fixture(scope="module")
def world() -> wg.WorldModel:
    return wg.load_franka_kitchen()


def _rx(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _rz(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


@needs_kitchen
def test_path_points_at_the_mjcf():
    path = wg.franka_kitchen_path()
    assert (path / "kitchen_env_model.xml").is_file()
    assert path.name == "kitchen_assets"


@needs_kitchen
def test_typed_objects(world):
    counts = {t: len(v) for t, v in world.type_index.items()}
    assert counts["knob"] == 4
    assert counts["handle"] >= 2
    assert counts["microwave"] == 1
    assert counts["door"] >= 3  # two hinge doors, the slide door, the microwave door
    assert counts["switch"] == 1 and counts["burner"] == 4
    assert world.max_link_length == 5.0


@needs_kitchen
def test_positions_inside_the_kitchen(world):
    scene = world.scene
    corners = []
    for node in scene.graph.nodes_geometry:  # union of every geom's box except the floor plane
        matrix, name = scene.graph[node]
        lo, hi = scene.geometry[name].bounds
        if np.ptp([lo[0], hi[0]]) > 9.0:
            continue
        box = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        corners.append(box @ matrix[:3, :3].T + matrix[:3, 3])
    pts = np.vstack(corners)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    assert np.all(world.positions >= lo - 1e-9) and np.all(world.positions <= hi + 1e-9)
    assert np.all(hi - lo < [4.0, 4.0, 4.0])


@needs_kitchen
def test_microwave_handle_position_by_hand(world):
    # kitchen_env_model.xml: body desk pos (-0.1, 0.75, 0) > body microwave pos (-0.750, -0.025, 1.6)
    # euler (0, 0, 0.3) rad > microwave_chain.xml: body microdoorroot pos (-0.345, -0.176, 0.192) >
    # capsule geom pos (0.475, -0.108, 0), no rotation: its centre is the handle's position.
    desk = np.array([-0.1, 0.75, 0.0])
    micro = np.array([-0.750, -0.025, 1.6])
    door = np.array([-0.345, -0.176, 0.192])
    capsule = np.array([0.475, -0.108, 0.0])
    expected = desk + micro + _rz(0.3) @ (door + capsule)
    handles = world.positions[world.type_index["handle"]]
    assert np.min(np.linalg.norm(handles - expected, axis=1)) < 1e-9


@needs_kitchen
def test_knob_position_by_hand(world):
    # desk (-0.1, 0.75, 0) > ovenroot (0.115, -0.2921, 0.9834) > body "knob 1" pos (-0.148, 0.22,
    # 1.243) euler (1.57, 0, 0) rad > dial cylinder pos (0, 0, 0.013)
    expected = (np.array([-0.1, 0.75, 0.0]) + np.array([0.115, -0.2921, 0.9834])
                + np.array([-0.148, 0.22, 1.243]) + _rx(1.57) @ np.array([0.0, 0.0, 0.013]))
    knobs = world.positions[world.type_index["knob"]]
    assert np.min(np.linalg.norm(knobs - expected, axis=1)) < 1e-9


def test_missing_package_raises_importer_error(monkeypatch):
    monkeypatch.setattr(franka.importlib.util, "find_spec", lambda name: None)
    with pytest.raises(wg.ImporterError, match="pip install --no-deps gymnasium-robotics"):
        franka.franka_kitchen_path()
    with pytest.raises(ImportError):
        wg.load_franka_kitchen()


def test_bad_directory_and_bad_xml(tmp_path):
    with pytest.raises(wg.ImporterError, match="not found"):
        wg.load_franka_kitchen(tmp_path)
    (tmp_path / "kitchen_env_model.xml").write_text("<mujoco><worldbody>")
    with pytest.raises(wg.MalformedFileError, match="not valid XML"):
        wg.load_franka_kitchen(tmp_path)


def test_small_mjcf_with_degrees_and_includes(tmp_path):
    """Angle units, include files, childclass defaults and collision geoms, on a hand-made file."""
    (tmp_path / "part.xml").write_text(
        '<mujocoinclude><body name="hingeleftdoor" pos="1 0 0" euler="0 0 90">'
        '<geom type="box" size="0.2 0.02 0.3" pos="0.2 0 0"/>'
        '<geom type="cylinder" size="0.01 0.1" pos="0.35 -0.05 0"/>'
        '<geom class="door_collision" type="box" size="0.2 0.02 0.3"/>'
        "</body></mujocoinclude>")
    (tmp_path / "kitchen_env_model.xml").write_text(
        '<mujoco><compiler angle="degree"/>'
        '<default><default class="door"><geom group="1"/>'
        '<default class="door_collision"><geom group="4"/></default></default></default>'
        '<worldbody><body name="cab" pos="0 2 1" childclass="door"><include file="part.xml"/></body>'
        "</worldbody></mujoco>")
    w = wg.load_franka_kitchen(tmp_path)
    assert sorted(w.types) == ["door", "handle"]
    door = w.positions[w.type_index["door"][0]]
    handle = w.positions[w.type_index["handle"][0]]
    # cab (0, 2, 1) + door body (1, 0, 0) + Rz(90 deg) @ geom pos
    np.testing.assert_allclose(door, [1.0, 2.2, 1.0], atol=1e-12)
    np.testing.assert_allclose(handle, [1.05, 2.35, 1.0], atol=1e-12)
    assert len(w.scene.graph.nodes_geometry) == 2  # the collision geom is left out
    assert w.room is None  # no floor plane in this file


@needs_kitchen
def test_room_over_the_mjcf_floor(world):
    # basic_scene.xml: <geom name='floor' pos='0 0 0' size='5 5 .1' type='plane'/>
    np.testing.assert_allclose(world.room.lower, [-5.0, -5.0, 0.0])
    np.testing.assert_allclose(world.room.upper, [5.0, 5.0, 3.0])
    assert world.room.contains(world.positions).all()
