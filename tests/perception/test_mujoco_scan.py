"""Tests of perception.mujoco: simulated head scans of MJCF scenes (rendering headless with EGL).

Expected values come from the scene files (hand-placed boxes and spheres), from the pinhole model
written out here, or from worldgraph's own reader of the same file; never from the module.
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before anything imports mujoco

import importlib.util  # noqa: E402
import sys  # noqa: E402

import numpy as np  # noqa: E402
import pytest  # noqa: E402

import perception as pc  # noqa: E402

mujoco = pytest.importorskip("mujoco")
from perception.mujoco import CENTRE_LATERAL_FLOOR, MujocoScene  # noqa: E402

needs_kitchen = pytest.mark.skipif(importlib.util.find_spec("gymnasium_robotics") is None,
                                   reason="gymnasium-robotics not installed")

SMALL = (160, 120)

ROOM = """\
<mujoco model="test room">
  <visual><headlight active="1"/></visual>
  <worldbody>
    <geom name="floor" type="plane" size="0 0 1" pos="0 0 -1" rgba=".3 .3 .3 1"/>
    <body name="knob_1" pos="2 0.3 0.2"><geom type="sphere" size="0.02"/></body>
    <body name="knob_2" pos="2.5 -0.6 -0.3"><geom type="sphere" size="0.02"/></body>
    <body name="knob_3" pos="1.8 -0.2 0.4"><geom type="sphere" size="0.02"/></body>
    <body name="knob_4" pos="2.2 0.5 -0.35"><geom type="sphere" size="0.02"/></body>
    <body name="door_1" pos="4 0 0" euler="0 0 30">
      <geom type="box" size="0.05 3 3" contype="0" conaffinity="0"/>
      <geom type="box" size="0.5 0.5 0.5" pos="0 0 5" group="3"/>
      <body name="hinge">
        <geom type="box" size="0.02 0.02 0.3" pos="-0.1 -0.5 0" contype="0" conaffinity="0"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""
# the camera: at the origin looking along world +x (OpenCV z = world x, x = -world y, y = -world z)
LOOK_X = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])


def _rot(axis, deg):
    a = np.radians(deg)
    c, s = np.cos(a), np.sin(a)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    R = np.eye(3)
    R[i, i] = R[j, j] = c
    R[i, j], R[j, i] = -s, s
    return R


def _pose(R, t):
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, t
    return T


@pytest.fixture(scope="module")
def room(tmp_path_factory):
    path = tmp_path_factory.mktemp("room") / "room.xml"
    path.write_text(ROOM)
    return path


@pytest.fixture(scope="module")
def room_scene(room):
    return MujocoScene(room)


# ----------------------------------------------------------------------------------------------
# camera model
# ----------------------------------------------------------------------------------------------
def test_camera_matrix_from_fovy(room_scene):
    K = room_scene.camera_matrix((640, 480))
    f = 240.0 / np.tan(np.radians(45.0) / 2)  # MuJoCo's default fovy is 45 degrees
    np.testing.assert_allclose(K, [[f, 0, 319.5], [0, f, 239.5], [0, 0, 1]], rtol=1e-12)


@pytest.mark.parametrize("roll, pitch, yaw", [(0.0, 0.0, 0.0), (25.0, -8.0, 5.0), (-40.0, 6.0, -4.0)])
def test_a_projected_point_lands_where_mujoco_draws_it(room_scene, roll, pitch, yaw):
    """Each small sphere's silhouette centroid is its centre projected with K and the OpenCV pose
    (a sphere 2 cm across at 2 m: the perspective shift of the centroid is below 0.05 px)."""
    R = _rot(2, yaw) @ _rot(1, pitch) @ LOOK_X @ _rot(2, roll)  # roll about the optical axis
    world_from_camera = _pose(R, [0.1, 0.05, 0.0])
    size = (320, 240)
    view = room_scene.render(world_from_camera, size)
    K = room_scene.camera_matrix(size)
    centres = {"knob_1": [2, 0.3, 0.2], "knob_2": [2.5, -0.6, -0.3], "knob_3": [1.8, -0.2, 0.4],
               "knob_4": [2.2, 0.5, -0.35]}
    names = [o.name for o in room_scene.objects]
    errors = []
    for name, X in centres.items():
        Xc = np.linalg.inv(world_from_camera) @ np.append(X, 1.0)
        uv = (K @ Xc[:3])[:2] / Xc[2]
        v, u = np.nonzero(view.objects == names.index(name))
        assert len(u) > 10, name
        errors.append(np.hypot(u.mean() - uv[0], v.mean() - uv[1]))
    print(f"projection error (px): max {max(errors):.3f}")
    assert max(errors) < 1.0


def test_depth_is_the_z_depth_of_a_tilted_face(room_scene):
    """door_1 is a thin box turned 30 degrees about z: at every pixel of its front face the depth
    is the OpenCV z of the ray's intersection with the face plane, to a millimetre."""
    R = _rot(2, 10.0) @ LOOK_X @ _rot(2, 15.0)
    world_from_camera = _pose(R, [0.0, 0.2, 0.1])
    view = room_scene.render(world_from_camera, SMALL)
    K = room_scene.camera_matrix(SMALL)
    door = [o.name for o in room_scene.objects].index("door_1")
    normal = np.array([np.cos(np.radians(30.0)), np.sin(np.radians(30.0)), 0.0])  # box x axis
    point = np.array([4.0, 0.0, 0.0]) - 0.05 * normal  # the face towards the camera
    v, u = np.nonzero(view.objects == door)
    rays = np.linalg.inv(K) @ np.stack([u, v, np.ones_like(u)]).astype(float)  # z = 1
    rays_world = R @ rays
    origin = world_from_camera[:3, 3]
    z = (point - origin) @ normal / (normal @ rays_world)  # z-depth: the ray has unit z
    hinge = np.isin(view.geoms[v, u], room_scene.objects[door].geoms[-1:])  # the handle bar
    assert len(u) > 1000
    np.testing.assert_allclose(view.depth[v, u][~hinge], z[~hinge], atol=1e-3)
    assert np.isnan(view.depth[view.geoms < 0]).all()  # nothing rendered: the sky box


# ----------------------------------------------------------------------------------------------
# objects
# ----------------------------------------------------------------------------------------------
def test_objects_are_visual_geometry_of_typed_bodies(room_scene):
    by_name = {o.name: o for o in room_scene.objects}
    assert sorted(by_name) == ["door_1", "knob_1", "knob_2", "knob_3", "knob_4"]
    # door_1: its visual box (the group-3 box left out) and the untyped child "hinge": in the body
    # frame x -0.12..0.05, y -3..3, z -3..3 -> centre (-0.035, 0, 0), turned 30 degrees about z
    c = np.array([-0.035 * np.cos(np.radians(30)), -0.035 * np.sin(np.radians(30)), 0.0])
    np.testing.assert_allclose(by_name["door_1"].position, [4.0, 0.0, 0.0] + c, atol=1e-9)
    assert room_scene.centre_depths()["door"] == pytest.approx(0.5 * 0.17)


def test_accepts_an_mjmodel_and_leaves_it_alone(room, room_scene):
    model = mujoco.MjModel.from_xml_path(str(room))
    samples = int(model.vis.quality.offsamples)
    scene = MujocoScene(model)
    np.testing.assert_array_equal(scene.positions, room_scene.positions)
    assert scene.types == room_scene.types
    assert int(model.vis.quality.offsamples) == samples
    view = scene.render(_pose(LOOK_X, [0, 0, 0]), SMALL, rgb=False, depth=False)
    assert view.rgb is None and view.depth is None and (view.objects >= 0).any()
    scene.close()  # frees the renderer; the next render makes a new one
    again = scene.render(_pose(LOOK_X, [0, 0, 0]), SMALL, rgb=False, depth=False)
    np.testing.assert_array_equal(again.objects, view.objects)


KITCHEN_TYPES = {r"^knob": "knob", r"^Burner": "burner",
                 r"^(hingeleftdoor|hingerightdoor|slidelink)$": "door", r"^microwave$": "microwave",
                 r"^kettle$": "kettle", r"^lightswitchroot$": "switch"}
#: the robot 1.2 m in front of the stove, ego x along world +y
FACING_STOVE = _pose(np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]]), [-0.3, -1.2, 1.7])


@pytest.fixture(scope="module")
def kitchen():
    import worldgraph as wg

    path = wg.franka_kitchen_path() / "kitchen_env_model.xml"
    return MujocoScene(path, type_of=KITCHEN_TYPES), wg.WorldModel.from_file(path, type_of=KITCHEN_TYPES)


@needs_kitchen
def test_kitchen_objects_equal_from_file_and_segmentation_types(kitchen):
    scene, world = kitchen
    ids = [o.id for o in world.objects]
    assert sorted(ids) == sorted(o.name for o in scene.objects)
    for o in scene.objects:
        np.testing.assert_allclose(o.position, world.positions[ids.index(o.name)], atol=1e-9, err_msg=o.name)
        assert o.type == world.objects[ids.index(o.name)].type
    expected = world.centre_depths()
    assert scene.centre_depths().keys() == expected.keys()
    for typ, d in scene.centre_depths().items():
        assert d == pytest.approx(expected[typ], abs=1e-9)
    pose = FACING_STOVE
    # the default rule too: oven, knobs, burners, microwave, kettle (the oven takes its untyped
    # children, the hood and the light switch among them)
    default = MujocoScene(world.scene.metadata["mujoco_model"])
    import worldgraph as wg

    plain = wg.WorldModel.from_file(wg.franka_kitchen_path() / "kitchen_env_model.xml")
    plain_ids = [o.id for o in plain.objects]
    assert sorted(plain_ids) == sorted(o.name for o in default.objects)
    np.testing.assert_allclose(default.positions, plain.positions[[plain_ids.index(o.name)
                                                                    for o in default.objects]], atol=1e-9)
    # the stove seen from the room: every detection's pixels are geoms of its body or of the
    # body's untyped descendants (walked here on the model), and of its type
    model = scene.model
    typed = {o.body: o for o in scene.objects}
    scan = scene.scan(pose, "rgbd", 5, rng=np.random.default_rng(1), image_size=SMALL, percepts=False)
    seen_types = set()
    for view in scan.views:
        for det, k in zip(view.detections, view.truth, strict=True):
            obj = scene.objects[k]
            assert det.type == obj.type
            ids_under = np.unique(scene.render(pose @ view.ego_from_camera, SMALL, rgb=False,
                                               depth=False).geoms[det.mask])
            for g in ids_under.tolist():
                b = int(model.geom_bodyid[g])
                while b not in typed:
                    b = int(model.body_parentid[b])
                assert b == obj.body, (obj.name, model.body(int(model.geom_bodyid[g])).name)
            seen_types.add(det.type)
    assert {"knob", "kettle", "microwave", "door"} <= seen_types


# ----------------------------------------------------------------------------------------------
# scans and degradations
# ----------------------------------------------------------------------------------------------
def _scan(scene, **kw):
    kw.setdefault("rng", np.random.default_rng(3))
    kw.setdefault("image_size", SMALL)
    kw.setdefault("percepts", False)
    return scene.scan(np.eye(4), kw.pop("sensor", "rgbd"), kw.pop("n_views", 3), **kw)


def test_exact_scan_detects_every_visible_object(room_scene):
    scan = _scan(room_scene)
    assert len(scan.views) == 3 and scan.timings.n_views == 3
    for view in scan.views:
        visible = sorted(set(np.unique(view.segmentation).tolist()) - {-1})
        assert sorted(view.truth) == visible and view.missed == ()
        for det, k in zip(view.detections, view.truth, strict=True):
            np.testing.assert_array_equal(det.mask, view.segmentation == k)
    print(f"render {1000 * scan.timings.render_per_view:.0f} ms/view at {SMALL}")


def test_miss_rate_one_drops_everything_and_min_pixels(room_scene):
    scan = _scan(room_scene, miss_rate=1.0)
    assert all(v.detections == () for v in scan.views) and any(len(v.missed) > 0 for v in scan.views)
    scan = _scan(room_scene, min_pixels=200)
    for view in scan.views:
        present = set(view.segmentation.ravel().tolist()) - {-1}
        counts = {k: int((view.segmentation == k).sum()) for k in present}
        assert sorted(view.truth) == sorted(k for k, c in counts.items() if c >= 200)
        assert sorted(view.missed) == sorted(k for k, c in counts.items() if c < 200)
    assert len(scan.views[1].missed) == 4  # the middle view sees the four knobs, each < 20 px


def test_false_detections_are_labelled_minus_one_with_a_wrong_or_background_mask(room_scene):
    scan = _scan(room_scene, false_rate=1.0, n_views=4, rng=np.random.default_rng(5))
    n_false = 0
    for view in scan.views:
        for det, k in zip(view.detections, view.truth, strict=True):
            if k >= 0:
                continue
            n_false += 1
            assert det.type in {"door", "knob"}
            owners = set(np.unique(view.segmentation[det.mask]).tolist())
            if owners != {-1}:  # a relabelled true mask: one object of another type
                assert len(owners) == 1 and room_scene.types[owners.pop()] != det.type
        assert sum(k < 0 for k in view.truth) <= len(view.missed) + sum(k >= 0 for k in view.truth)
    assert n_false >= 3


def test_mask_jitter_moves_edges_by_at_most_the_bound(room_scene):
    import cv2

    scan = _scan(room_scene, mask_jitter_px=2)
    kernel = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))
    changed = 0
    for view in scan.views:
        for det, k in zip(view.detections, view.truth, strict=True):
            exact = (view.segmentation == k).astype(np.uint8)
            outer = cv2.dilate(exact, kernel, iterations=2).astype(bool)
            inner = cv2.erode(exact, kernel, iterations=2).astype(bool)
            assert not (det.mask & ~outer).any() and not (inner & ~det.mask).any()
            changed += int(not np.array_equal(det.mask, exact.astype(bool)))
    assert changed > 0


def test_same_seed_same_scan(room_scene):
    kw = dict(miss_rate=0.3, false_rate=0.5, mask_jitter_px=1)
    a = _scan(room_scene, rng=np.random.default_rng(9), **kw)
    b = _scan(room_scene, rng=np.random.default_rng(9), **kw)
    for va, vb in zip(a.views, b.views, strict=True):
        assert va.truth == vb.truth and va.missed == vb.missed
        np.testing.assert_array_equal(va.depth, vb.depth)
        for da, db in zip(va.detections, vb.detections, strict=True):
            assert da.type == db.type and np.array_equal(da.mask, db.mask)


def test_depth_noise_has_the_stated_sigma_blocks_and_range(room_scene):
    c = 0.02
    scan = _scan(room_scene, depth_noise=c, max_range=4.5, n_views=1)
    view = scan.views[0]
    exact = room_scene.render(np.eye(4) @ view.ego_from_camera, SMALL, rgb=False, segmentation=False).depth
    ok = np.isfinite(exact) & (exact <= 4.5)
    assert ok.sum() > 1000
    assert np.isnan(view.depth[~ok]).all() and np.isfinite(view.depth[ok]).all()
    assert (exact > 4.5).any()  # the door reaches beyond the range
    e = (view.depth - exact) / (c * exact ** 2)
    assert 0.85 < np.nanstd(e) < 1.15
    # within an 8x8 block the errors share their main part: horizontal neighbours in one block
    # correlate with 1 / (1 + 0.25^2) = 0.94, across block borders not at all
    left, right = e[:, 0:-1:2], e[:, 1::2]  # pairs (0, 1), (2, 3), ...: same block
    same = np.isfinite(left) & np.isfinite(right)
    assert np.corrcoef(left[same], right[same])[0, 1] > 0.85
    left, right = e[:, 7:-1:8], e[:, 8::8]  # pairs across a block border
    same = np.isfinite(left) & np.isfinite(right)
    assert abs(np.corrcoef(left[same], right[same])[0, 1]) < 0.3


def test_stereo_renders_both_cameras(room_scene):
    scan = _scan(room_scene, sensor="stereo", n_views=3)
    for view in scan.views:
        assert view.depth is None and view.right_rgb is not None and view.right_rgb.shape == (120, 160, 3)
        left_from_right = np.linalg.inv(view.ego_from_camera) @ view.ego_from_right_camera
        np.testing.assert_allclose(left_from_right[:3, 3], [0.093, 0.0, 0.0], atol=1e-12)
        assert len(view.right_detections) == len(view.right_truth)
        assert sorted(view.right_truth) == sorted(set(view.right_segmentation.ravel().tolist()) - {-1})
    middle = scan.views[1]  # looking ahead at the room's objects
    assert len(middle.right_truth) > 0 and not np.array_equal(middle.segmentation, middle.right_segmentation)


# ----------------------------------------------------------------------------------------------
# bad input
# ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("kw, error, match", [
    (dict(sensor="lidar"), pc.PerceptionError, r"sensor must be one of .*'lidar'"),
    (dict(n_views=0), pc.PerceptionError, "n_views must be >= 1, got 0"),
    (dict(image_size=(0, 120)), pc.PerceptionError, r"image_size\[0\] \(width\) must be >= 1, got 0"),
    (dict(image_size=(160, 0)), pc.PerceptionError, r"image_size\[1\] \(height\) must be >= 1, got 0"),
    (dict(miss_rate=1.5), pc.PerceptionError, r"miss_rate must be <= 1, got 1.5"),
    (dict(false_rate=-0.1), pc.PerceptionError, r"false_rate must be >= 0, got -0.1"),
    (dict(mask_jitter_px=-1), pc.PerceptionError, "mask_jitter_px must be >= 0"),
    (dict(min_pixels=0), pc.PerceptionError, "min_pixels must be >= 1"),
    (dict(depth_noise=-1e-3), pc.PerceptionError, "depth_noise must be >= 0"),
    (dict(rng=0), pc.PerceptionError, "rng must be a numpy.random.Generator"),
    (dict(centre_offset={"door": "deep"}), pc.PerceptionError,
     r"centre_offset\['door'\] must be a real number"),
    (dict(centre_offset=0.1), pc.PerceptionError, "centre_offset must be a mapping type -> CentreOffset"),
    (dict(percepts="yes"), pc.PerceptionError, "percepts must be a bool, got str 'yes'"),
    (dict(chain="head"), pc.PerceptionError, "chain must be a KinematicChain or None, got str"),
])
def test_bad_scan_arguments(room_scene, kw, error, match):
    with pytest.raises(error, match=match):
        _scan(room_scene, **kw)


def test_non_rigid_pose(room_scene):
    bad = np.eye(4)
    bad[0, 0] = 2.0
    with pytest.raises(pc.PerceptionError, match="world_from_ego must be a rigid transform"):
        room_scene.scan(bad, rng=np.random.default_rng(0), image_size=SMALL, percepts=False)
    with pytest.raises(pc.PerceptionError, match=r"world_from_camera must be a rigid transform"):
        room_scene.render(bad, SMALL)


def test_bad_scenes(tmp_path, room):
    with pytest.raises(pc.RobotFileError, match="path_or_model: .*nothing.xml: no such file"):
        MujocoScene(tmp_path / "nothing.xml")
    bad = tmp_path / "bad.xml"
    bad.write_text("<mujoco><worldbody>")
    with pytest.raises(pc.RobotFileError, match="bad.xml: MuJoCo cannot compile it"):
        MujocoScene(bad)
    with pytest.raises(pc.RobotFileError, match="path_or_model must be a non-empty str"):
        MujocoScene(42)
    with pytest.raises(pc.RobotFileError, match="no body or world geom gets a type"):
        MujocoScene(room, type_of={"^nothing": "x"})
    with pytest.raises(pc.PerceptionError, match=r"type_of\('knob_1'\) raised ZeroDivisionError"):
        MujocoScene(room, type_of=lambda name: 1 / 0 if name == "knob_1" else None)
    with pytest.raises(pc.PerceptionError, match="type_of must be None, a callable"):
        MujocoScene(room, type_of=3)


def test_missing_mujoco_names_the_extra(room, monkeypatch):
    monkeypatch.setitem(sys.modules, "mujoco", None)
    with pytest.raises(pc.MissingExtraError, match=r"pip install gaussian-spheres\[mujoco\]"):
        MujocoScene(room)


# ----------------------------------------------------------------------------------------------
# percepts (the front ends of perception.frontend)
# ----------------------------------------------------------------------------------------------
@needs_kitchen
@pytest.mark.parametrize("sensor, tolerance", [("rgbd", 0.12), ("stereo", 0.15)])
def test_kitchen_percepts_sit_at_their_objects_in_the_ego_frame(kitchen, sensor, tolerance):
    """With exact images the percepts of true detections lie near their objects (the world
    model's positions mapped into the ego frame by hand); the doors' centres are 8 cm behind
    their fronts (centre_depths), the kettle's visible side is not its box centre."""
    scene, world = kitchen
    scan = scene.scan(FACING_STOVE, sensor, 7, rng=np.random.default_rng(2), image_size=(320, 240),
                      depth_noise=0.0)
    ids = [o.id for o in world.objects]
    ego_from_world = np.linalg.inv(FACING_STOVE)
    assert len(scan.percepts) == len(scan.percept_views) == len(scan.percept_truth) >= 8
    assert len(scan.dropped) == 7
    errors = []
    for p, view, k in zip(scan.percepts, scan.percept_views, scan.percept_truth, strict=True):
        assert 0 <= view < 7 and k >= 0  # no false detections were asked for
        assert p.type == scene.objects[k].type
        X = world.positions[ids.index(scene.objects[k].name)]
        errors.append(np.linalg.norm(p.position - (ego_from_world[:3, :3] @ X + ego_from_world[:3, 3])))
    print(f"{sensor}: percept errors (m) median {np.median(errors):.3f}, max {max(errors):.3f}")
    # stereo pairs same-typed doors by the epipolar line alone: one may be matched to another door
    assert np.median(errors) < 0.05 and np.mean(np.array(errors) < tolerance) >= 0.9
    assert all(d.reason in ("cut_off", "occluded", "too_few_pixels", "no_depth", "no_stereo_match",
                            "behind_camera") for view in scan.dropped for d in view)
    assert scan.timings.percepts > 0 and scan.timings.render > 0


def test_percepts_of_false_detections_carry_their_truth(room_scene):
    """The room's knobs are larger at 640x480 (about 80 px each): with false detections on, every
    percept's truth is its detection's, the false ones -1."""
    scan = _scan(room_scene, percepts=True, false_rate=1.0, image_size=(640, 480), n_views=3,
                 rng=np.random.default_rng(4))
    truths = [t for view in scan.views for t in view.truth]
    assert len(scan.percepts) > 0 and set(scan.percept_truth) <= set(truths)
    for p, k in zip(scan.percepts, scan.percept_truth, strict=True):
        if k >= 0:
            assert p.type == room_scene.types[k]


OFFSETS = """\
<mujoco model="centre offsets">
  <worldbody>
    <body name="door_1" pos="3 0 0.25"><geom type="box" size="0.03 0.3 0.4"/></body>
    <body name="knob_1" pos="2 0.9 0.25"><geom type="sphere" size="0.1"/></body>
  </worldbody>
</mujoco>
"""


def test_centre_offsets_of_a_flat_front_and_a_sphere(tmp_path):
    """A box seen face-on: its centre lies half its thickness (3 cm) behind the visible face,
    along the face's normal.  A sphere of radius r: the pixels' mean depth on the visible
    hemisphere (uniform over the disk of its outline) is the mean of sqrt(r^2 - rho^2), 2r/3, so
    the centre lies 2r/3 = 6.7 cm behind the visible centroid along the ray (orthographic view;
    the camera 2 m away sees a smaller cap in perspective, to within 4 mm of it)."""
    path = tmp_path / "offsets.xml"
    path.write_text(OFFSETS)
    scene = MujocoScene(path)
    offsets = scene.centre_offsets(np.eye(4), n_views=9, image_size=(320, 240))
    assert sorted(offsets) == ["door", "knob"]
    assert offsets["door"].depth == pytest.approx(0.03, abs=1e-3)
    assert offsets["knob"].depth == pytest.approx(2 * 0.1 / 3, abs=4e-3)
    # a sphere's extent is centred on it from every side: below the floor, which is reported
    assert offsets["knob"].lateral_sd == pytest.approx(CENTRE_LATERAL_FLOOR)
    with pytest.raises(pc.PerceptionError, match=r"world_from_egos must be a \(4, 4\) or \(m, 4, 4\) array"):
        scene.centre_offsets(np.eye(3))


CROWDED = """\
<mujoco model="no room to stand">
  <worldbody>
    <geom name="slab" type="box" size="20 20 1" pos="0 0 0"/>
    <body name="knob_1" pos="1 0 1.2"><geom type="sphere" size="0.03"/></body>
  </worldbody>
</mujoco>
"""


def test_default_centre_offsets_fall_back_to_the_geometry_where_no_robot_can_stand(tmp_path):
    path = tmp_path / "crowded.xml"
    path.write_text(CROWDED)
    scene = MujocoScene(path)
    with pytest.raises(pc.PerceptionError, match="no free floor point"):
        scene.robot_poses(1, np.random.default_rng(0))
    with pytest.warns(UserWarning, match=r"centre offsets not measured .* centre_depths\(\)"):
        offsets = scene.default_centre_offsets()
    assert list(offsets) == ["knob"] and offsets["knob"].lateral_sd is None
    assert offsets["knob"].depth == pytest.approx(0.03, abs=1e-3)  # half the sphere's 6 cm extent


def _reference_detections(types, seed, miss, false, jitter, min_pixels, objects):
    """The detector model written the obvious way: every object's mask from the whole image."""
    import cv2

    rng = np.random.default_rng(seed)
    seen = np.unique(objects[objects >= 0]).tolist()
    out, truth, missed, masks = [], [], [], {}
    for k in seen:
        mask = objects == k
        if jitter:
            step = int(rng.integers(-jitter, jitter + 1))
            if step:
                kernel = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))
                img = mask.astype(np.uint8)
                img = cv2.dilate(img, kernel, iterations=step) if step > 0 else cv2.erode(img, kernel,
                                                                                         iterations=-step)
                mask = img.astype(bool)
        masks[k] = mask
        if int(mask.sum()) < min_pixels or (miss > 0 and rng.random() < miss):
            missed.append(k)
            continue
        out.append((types[k], mask))
        truth.append(k)
    return out, truth, missed, rng


@pytest.mark.parametrize("jitter", [0, 1, 2])
def test_detector_model_matches_the_whole_image_reference(jitter):
    """Masks made in each object's padded box equal those made on the whole image: objects
    touching the border and each other, one of a single pixel, one split in two."""
    import cv2

    from perception.mujoco.detector import _Degrade

    objects = np.full((60, 80), -1, dtype=np.int32)
    objects[0:20, 0:15] = 0  # the image's corner
    objects[10:30, 15:40] = 1  # touching object 0
    cv2.ellipse(objects, (60, 40), (12, 8), 30.0, 0.0, 360.0, 2, -1)
    objects[59, 79] = 3  # one pixel in the far corner
    objects[45:55, 5:10] = 4
    objects[45:55, 20:25] = 4  # the same object in two parts
    objects[2:6, 70:80] = 5  # the right border
    types = ("door", "handle", "knob", "knob", "drawer", "door")
    for seed in range(5):
        got = _Degrade(types, np.random.default_rng(seed), 0.2, 0.0, jitter, 3)(objects)
        want, truth, missed, _ = _reference_detections(types, seed, 0.2, 0.0, jitter, 3, objects)
        assert got[1] == tuple(truth) and got[2] == tuple(missed)
        for det, (typ, mask) in zip(got[0], want, strict=True):
            assert det.type == typ
            np.testing.assert_array_equal(det.mask, mask)
