"""MujocoScene.look and active_localize on pixels: a look towards a direction sees what a scan
centred there sees; a look behind the robot turns its base and comes back in the starting ego
frame; a robot whose first scan sees too little (or nothing) looks elsewhere until it knows.

The room is written here: a 6 x 5 m box with two typed objects in front of the robot and
thirteen behind it and along the rear of the side walls.  Expected values come from that layout
(world positions of the bodies) and from scans of the same renderer, never from ``look``.
"""

from __future__ import annotations

import functools
import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before anything imports mujoco

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from scipy.spatial.transform import Rotation  # noqa: E402

import perception as pc  # noqa: E402
import worldgraph as wg  # noqa: E402

mujoco = pytest.importorskip("mujoco")
from perception.mujoco import MujocoScene  # noqa: E402

SIZE = (320, 240)
DOOR, WHITE, DARK, RED = ".55 .35 .2 1", ".8 .8 .75 1", ".2 .2 .25 1", ".7 .1 .1 1"
# name, geom, position, size, colour
BODIES = [
    ("door_1", "box", (2.97, 1.2, 1.1), (0.02, 0.35, 0.45), DOOR),        # in front of the robot
    ("handle_1", "box", (2.93, 0.95, 1.1), (0.02, 0.02, 0.12), DARK),
    ("door_2", "box", (-2.97, -0.8, 1.1), (0.02, 0.35, 0.45), DOOR),      # behind it
    ("handle_2", "box", (-2.93, -0.55, 1.1), (0.02, 0.02, 0.12), DARK),
    ("drawer_1", "box", (-2.97, 0.9, 0.4), (0.02, 0.3, 0.15), WHITE),
    ("handle_3", "box", (-2.93, 0.9, 0.48), (0.02, 0.1, 0.015), DARK),
    ("drawer_2", "box", (-2.97, 0.9, 0.75), (0.02, 0.3, 0.15), WHITE),
    ("handle_4", "box", (-2.93, 0.9, 0.83), (0.02, 0.1, 0.015), DARK),
    ("drawer_3", "box", (-2.97, 1.6, 0.4), (0.02, 0.3, 0.15), WHITE),
    ("handle_5", "box", (-2.93, 1.6, 0.48), (0.02, 0.1, 0.015), DARK),
    ("knob_1", "sphere", (-2.2, 2.45, 1.0), (0.03,), RED),
    ("knob_2", "sphere", (-1.7, 2.45, 1.0), (0.03,), RED),
    ("knob_3", "sphere", (-1.2, 2.45, 1.05), (0.03,), RED),
    ("drawer_4", "box", (-1.8, -2.47, 0.5), (0.3, 0.02, 0.15), WHITE),
    ("handle_6", "box", (-1.8, -2.43, 0.58), (0.1, 0.02, 0.015), DARK),
]
WALLS = """
    <geom name="floor" type="plane" size="3 2.5 0.1" rgba=".4 .4 .4 1"/>
    <geom name="wall_e" type="box" pos="3.02 0 1.3" size="0.03 2.5 1.3" rgba=".9 .9 .9 1"/>
    <geom name="wall_w" type="box" pos="-3.02 0 1.3" size="0.03 2.5 1.3" rgba=".9 .9 .9 1"/>
    <geom name="wall_n" type="box" pos="0 2.52 1.3" size="3 0.03 1.3" rgba=".85 .9 .9 1"/>
    <geom name="wall_s" type="box" pos="0 -2.52 1.3" size="3 0.03 1.3" rgba=".9 .85 .9 1"/>"""


def room_xml() -> str:
    bodies = "\n".join(
        f'    <body name="{n}" pos="{" ".join(map(str, p))}"><geom type="{g}" size="{" ".join(map(str, s))}" '
        f'rgba="{c}"/></body>' for n, g, p, s, c in BODIES)
    return ('<mujoco model="look test room">\n'
            '  <visual><headlight active="1" ambient=".4 .4 .4"/></visual>\n'
            f"  <worldbody>{WALLS}\n{bodies}\n  </worldbody>\n</mujoco>\n")


def robot(x: float, y: float, yaw_deg: float) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("z", yaw_deg, degrees=True).as_matrix()
    T[:3, 3] = [x, y, 1.5]
    return T


@pytest.fixture(scope="module")
def room(tmp_path_factory):
    path = tmp_path_factory.mktemp("look_room") / "room.xml"
    path.write_text(room_xml())
    scene = MujocoScene(path)
    yield path, scene
    scene.close()


def fused(percepts) -> list[pc.Percept]:
    raw = list(percepts)
    return list(pc.fuse_percepts(raw, bandwidth=pc.percept_bandwidths(raw))) if raw else []


def truth_set(scan) -> set[int]:
    return {o for v in scan.views for o in v.truth if o >= 0}


def test_a_look_sees_what_a_scan_centred_there_sees(room):
    _, scene = room
    pose = robot(0.3, -0.2, 10.0)
    direction = np.array([np.cos(np.radians(-170)), np.sin(np.radians(-170)), 0.0])
    # the same three views as a scan from the robot turned to face -170 deg; exact depth, no
    # degradation, so both draw nothing at random
    turned = pose @ robot(0.0, 0.0, -170.0)
    turned[:3, 3] = pose[:3, 3]
    scan = scene.scan(turned, n_views=3, rng=np.random.default_rng(0), image_size=SIZE, depth_noise=0.0,
                      yaw_deg=(-20.0, 20.0), pitch_deg=(-10.0, 10.0))
    seen = fused(scan.percepts)
    assert len(truth_set(scan)) >= 4  # the layout: the door and drawer behind, with their handles
    got = scene.look(pose, direction, rng=np.random.default_rng(1), image_size=SIZE, depth_noise=0.0,
                     # the fan fits the reach only centred: the base makes the whole turn
                     pitch_deg=(-10.0, 10.0), neck_reach_deg=20.0, min_views=2)
    R = Rotation.from_euler("z", -170.0, degrees=True).as_matrix()
    assert sorted(p.type for p in got) == sorted(p.type for p in seen)
    expect = np.array(sorted((R @ p.position).tolist() for p in seen))
    np.testing.assert_allclose(np.array(sorted(p.position.tolist() for p in got)), expect, atol=1e-9)
    # covariances turn with the percepts
    by_pos = {tuple(np.round(R @ p.position, 6)): R @ p.covariance @ R.T for p in seen}
    for p in got:
        np.testing.assert_allclose(p.covariance, by_pos[tuple(np.round(p.position, 6))], atol=1e-12)


@pytest.mark.parametrize("sensor", ["rgbd", "stereo"])
def test_a_look_behind_returns_the_objects_behind_in_the_starting_ego_frame(room, sensor):
    _, scene = room
    pose = robot(0.3, -0.2, 10.0)
    got = scene.look(pose, [-1.0, 0.1, -0.25], sensor=sensor, rng=np.random.default_rng(2), image_size=SIZE)
    assert len(got) >= 6  # the door and drawers behind the robot, with their handles
    world = {n: np.array(p) for n, _, p, _, _ in BODIES}
    behind = [n for n, p in world.items() if p[0] < 0]
    close = 0
    for q in got:
        w = pose[:3, :3] @ q.position + pose[:3, 3]
        same = [n for n in behind if n.split("_")[0] == q.type]
        near = min(same, key=lambda n: np.linalg.norm(world[n] - w))
        e = w - world[near]
        C = pose[:3, :3] @ q.covariance @ pose[:3, :3].T
        assert float(e @ np.linalg.solve(C, e)) < 25.0, (q.type, e, C)  # within its own covariance
        close += float(np.linalg.norm(e)) < 0.1
    assert close >= 5  # most of them also close to their object


def test_look_names_its_bad_arguments(room):
    _, scene = room
    pose = robot(0.0, 0.0, 0.0)
    rng = np.random.default_rng(0)
    with pytest.raises(pc.PerceptionError, match="direction"):
        scene.look(pose, [0.0, 0.0, 0.0], rng=rng)
    with pytest.raises(pc.PerceptionError, match="direction"):
        scene.look(pose, [1.0, np.nan, 0.0], rng=rng)
    with pytest.raises(pc.PerceptionError, match="spread_deg"):
        scene.look(pose, [1.0, 0.0, 0.0], rng=rng, spread_deg=60.0, neck_reach_deg=20.0)
    with pytest.raises(pc.PerceptionError, match="n_views"):
        scene.look(pose, [1.0, 0.0, 0.0], rng=rng, n_views=0)
    with pytest.raises(pc.PerceptionError, match="miss_rate"):
        scene.look(pose, [1.0, 0.0, 0.0], rng=rng, miss_rate=1.5)
    with pytest.raises(pc.PerceptionError, match="sensor"):
        scene.look(pose, [1.0, 0.0, 0.0], rng=rng, sensor="lidar")


def test_explore_direction_turns_to_the_widest_arc_not_looked_at():
    down = np.radians(wg.active.loop.EXPLORE_PITCH_DEG)
    first = wg.active.explore_direction([], (-70.0, 70.0), 60.0)
    np.testing.assert_allclose(first, [-np.cos(down), 0.0, np.sin(down)], atol=1e-12)
    second = wg.active.explore_direction([first], (-70.0, 70.0), 60.0)
    # looked: yaw [-100, 100] and [150, 210]; the gaps' middles are +-125 degrees
    assert abs(abs(np.degrees(np.arctan2(second[1], second[0]))) - 125.0) <= 2.5
    assert np.isclose(second[2], np.sin(down)) and np.isclose(np.linalg.norm(second), 1.0)
    # nothing looked at: ahead; the whole circle looked at: away from every look
    np.testing.assert_allclose(wg.active.explore_direction([], None, 60.0), [np.cos(down), 0.0, np.sin(down)],
                               atol=1e-12)  # straight ahead
    looks = [np.array([np.cos(a), np.sin(a), 0.0]) for a in np.radians([0.0, 90.0, 180.0])]
    last = wg.active.explore_direction(looks, (-180.0, 180.0), 60.0)
    assert abs(np.degrees(np.arctan2(last[1], last[0])) + 90.0) <= 2.5


@pytest.mark.parametrize("first_scan", [True, False])
def test_active_localize_on_pixels_finds_the_pose_from_too_little(room, first_scan):
    path, scene = room
    world = wg.WorldModel.from_file(path)
    pose = robot(0.3, -0.2, 10.0)
    rng = np.random.default_rng(5)
    degrade = {"miss_rate": 0.05, "false_rate": 0.02, "mask_jitter_px": 1}
    if first_scan:
        scan = scene.scan(pose, n_views=6, rng=rng, image_size=SIZE, **degrade)
        start = fused(scan.percepts)
        assert wg.localize(world, start).status in wg.active.EXPLORE_STATUSES  # sees too little
        scanned = (-70.0, 70.0)
    else:
        start, scanned = [], None  # nothing recognised yet
    look = functools.partial(scene.look, pose, rng=rng, image_size=SIZE, **degrade)
    out = wg.active_localize(world, start, look, max_looks=3, scanned_yaw_deg=scanned)
    assert out.result.status == "ok", [r.status for r in out.results]
    assert out.reasons[0] == "explore" and 1 <= out.looks <= 3
    e = out.result.transformation[:3, 3] - pose[:3, 3]
    assert float(np.linalg.norm(e)) < 0.05
    R = out.result.transformation[:3, :3].T @ pose[:3, :3]
    assert np.degrees(Rotation.from_matrix(R).magnitude()) < 1.0


def test_active_localize_checks_its_new_arguments():
    world = wg.scenes.kitchen(seed=0)
    with pytest.raises(wg.WorldGraphError, match=r"explore_while\[0\]"):
        wg.active_localize(world, [], lambda d: [], explore_while=("ok",))
    with pytest.raises(wg.WorldGraphError, match="scanned_yaw_deg"):
        wg.active_localize(world, [], lambda d: [], scanned_yaw_deg=(70.0, -70.0))
    # explore_while=() keeps the old behaviour: no pose, no look
    assert wg.active_localize(world, [], lambda d: [], explore_while=()).looks == 0
