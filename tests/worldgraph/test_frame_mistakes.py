"""Frame and gravity mistakes get messages, never "ok"/"weak" at a wrong pose:
percepts in a camera frame instead of the ego frame, and a gravity vector passed where the up
vector is meant."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

import perception as pc
import worldgraph as wg
from worldgraph.pose.gravity import tilt_angle
from worldgraph.tolerances import MAX_EGO_TILT

#: ego -> OpenCV camera axes: camera x = -ego y (right), camera y = -ego z (down), camera z = ego x
#: (ahead); the mistake is to hand localize percepts in these axes.
CAMERA_FROM_EGO = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])


@pytest.fixture(scope="module")
def kitchen_scan():
    """The README's quick start: the kitchen, a pose we know, fused percepts of a 10-view scan."""
    rng = np.random.default_rng(0)
    world = wg.scenes.kitchen(seed=0)
    seen = np.isin(world.types, ("door", "handle", "drawer", "knob"))
    truth = np.eye(4)
    lower, upper = world.bounds
    truth[:3, 3] = [(lower[0] + upper[0]) / 2, (lower[1] + upper[1]) / 2, 1.6]
    raw = pc.simulate_scan(world.types[seen].tolist(), world.positions[seen], truth, rng, n_views=10)
    percepts = pc.fuse_percepts(raw, bandwidth={"door": 0.3, "drawer": 0.3, "handle": 0.1, "knob": 0.1})
    return world, percepts, truth


def _in_camera_axes(percepts):
    R = CAMERA_FROM_EGO
    return [pc.Percept(p.type, R @ p.position, p.sigma, covariance=R @ p.covariance @ R.T, views=p.views,
                       shared=tuple((v, R @ S) for v, S in p.shared)) for p in percepts]


def test_the_right_input_is_ok_at_the_true_pose(kitchen_scan):
    world, percepts, truth = kitchen_scan
    res = wg.localize(world, percepts)
    assert res.status == "ok", res.summary()
    assert np.linalg.norm(res.position - truth[:3, 3]) < 0.05
    assert math.degrees(tilt_angle(res.transformation)) < 1.0


@pytest.mark.parametrize("method", ["ml", "spheres"])
def test_camera_frame_percepts_are_no_success_and_named(kitchen_scan, method):
    world, percepts, _ = kitchen_scan
    res = wg.localize(world, _in_camera_axes(percepts), method=method)
    assert res.status not in ("ok", "weak", "ambiguous"), res.summary()
    assert res.status == "inconsistent"
    assert "camera frame" in res.message and "ego_from_camera" in res.message, res.message
    assert "90 deg from world up" in res.message
    # the pose that was set aside is kept for diagnosis: the ego z axis lies flat
    assert math.degrees(tilt_angle(res.transformation)) == pytest.approx(90.0, abs=2.0)
    assert math.degrees(tilt_angle(res.transformation)) > math.degrees(MAX_EGO_TILT)


def test_camera_frame_percepts_with_an_up_vector_are_no_success(kitchen_scan):
    world, percepts, _ = kitchen_scan
    res = wg.localize(world, _in_camera_axes(percepts), gravity=[0.0, 0.0, 1.0])
    assert res.status not in ("ok", "weak", "ambiguous"), res.summary()
    assert "the up vector given" in res.message and "ego_from_camera" in res.message, res.message


def test_without_gravity_any_tilt_is_answered(kitchen_scan):
    world, percepts, truth = kitchen_scan
    res = wg.localize(world, _in_camera_axes(percepts), gravity=None)
    assert res.status == "ok", res.summary()
    # the camera-axes pose of the same robot: world_from_camera = world_from_ego @ ego_from_camera
    np.testing.assert_allclose(res.position, truth[:3, 3], atol=0.05)
    np.testing.assert_allclose(res.transformation[:3, :3], truth[:3, :3] @ CAMERA_FROM_EGO.T, atol=0.02)


@pytest.mark.parametrize("down", [[0.0, 0.0, -9.81], [0.5, 0.0, -1.0]])
def test_a_gravity_vector_for_the_up_vector_raises_before_any_search(kitchen_scan, down, monkeypatch):
    world, percepts, _ = kitchen_scan
    from worldgraph.localization import pipeline

    def no_search(*args, **kwargs):
        raise AssertionError("searched")

    monkeypatch.setattr(pipeline, "_localize", no_search)
    shown = r"\[" + r", ".join(re.escape(repr(float(x))) for x in down) + r"\]"
    negative = r"\[" + r", ".join(re.escape(repr(-float(x) + 0.0)) for x in down) + r"\]"
    with pytest.raises(wg.WorldGraphError, match=rf"gravity = {shown} points .*gravity vector.*"
                                                       rf"pass its negative, {negative}.*9\.81"):
        wg.localize(world, percepts, gravity=down)
    with pytest.raises(wg.WorldGraphError, match=r"points 1[58][03] deg from the ego \+z axis"):
        wg.associate(world, percepts, gravity=down)


def test_an_up_vector_tilted_less_than_90_degrees_is_accepted(kitchen_scan):
    world, percepts, truth = kitchen_scan
    res = wg.localize(world, percepts, gravity=[0.0, 0.0, 9.81])  # an accelerometer's reading at rest
    assert res.status == "ok" and np.linalg.norm(res.position - truth[:3, 3]) < 0.05
