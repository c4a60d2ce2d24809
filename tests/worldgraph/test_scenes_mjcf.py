"""worldgraph.scenes.mjcf: a procedural scene written as MJCF reads back as the same map
(WorldModel.from_file types the bodies by the default rule and finds every typed object's centre
where the procedural world has it) and renders in MuJoCo with its typed objects in view."""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before anything imports mujoco

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from perception.type_rules import default_type_of  # noqa: E402
from worldgraph import WorldGraphError, WorldModel, scenes  # noqa: E402

mujoco = pytest.importorskip("mujoco")


@pytest.fixture(scope="module")
def layout_file(tmp_path_factory):
    world = scenes.kitchen_layout("l_shape", seed=3)
    path = scenes.write_mjcf(world, tmp_path_factory.mktemp("mjcf") / "l_shape_03.xml", seed=3)
    return world, path


def test_an_exported_layout_reads_back_as_its_own_map(layout_file):
    world, path = layout_file
    back = WorldModel.from_file(path)
    graph = world.scene.graph
    # every geometry node the default rule types, objects of the procedural world or not (cabinets
    # and shelves are scenery there), at the centre of its mesh's bounding box
    expected = {n for n in graph.nodes_geometry if default_type_of(n) is not None}
    assert {o.id for o in back.objects} == expected
    assert sum(o.type in ("door", "drawer", "handle", "knob") for o in back.objects) >= 20
    for o in back.objects:
        assert o.type == default_type_of(o.id)
        T, geometry = graph[o.id]
        lo, hi = world.scene.geometry[geometry].bounds
        np.testing.assert_allclose(o.pose[:3, 3], (T @ np.append((lo + hi) / 2, 1.0))[:3], atol=1e-5)


def test_an_exported_layout_renders_with_its_typed_objects_in_view(layout_file):
    from perception.mujoco import MujocoScene

    _, path = layout_file
    scene = MujocoScene(path)
    try:
        pose = scene.robot_poses(1, np.random.default_rng(0))[0]
        scan = scene.scan(pose, n_views=4, rng=np.random.default_rng(1), image_size=(160, 120),
                          percepts=False)
        seen = {o for v in scan.views for o in v.truth if o >= 0}
        assert len(seen) >= 3
        rgb = scan.views[0].rgb
        assert rgb.shape == (120, 160, 3) and float(rgb.std()) > 5.0  # textured, lit, not blank
    finally:
        scene.close()


def test_two_seeds_give_two_looks_of_one_layout(tmp_path):
    world = scenes.kitchen_layout("galley", seed=1)
    a, b = scenes.scene_mjcf(world, seed=1), scenes.scene_mjcf(world, seed=2)
    assert a != b and a.count("<body") == b.count("<body")
    assert scenes.scene_mjcf(world, seed=1) == a  # seeded


def test_bad_input_is_named():
    with pytest.raises(WorldGraphError, match="without a scene"):
        scenes.scene_mjcf(WorldModel.from_arrays(["door", "door"], [[0.0, 0, 0], [1.0, 0, 0]]))
    with pytest.raises(WorldGraphError, match="seed"):
        scenes.scene_mjcf(scenes.kitchen_layout("galley", seed=1), seed=-1)
