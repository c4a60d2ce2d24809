"""WorldModel.from_trimesh and the file loaders: node names, unusable paths, skipped geometry.

From the second adversarial audit of worldgraph: each case raised something else than
the package's error, or was accepted silently.
"""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

import worldgraph as wg


def test_scene_node_name_that_is_not_unicode_text_is_named() -> None:
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.box((1, 1, 1)), node_name="door\udcff")
    with pytest.raises(wg.ImporterError, match=r"scene node name 'door\\udcff'.*UTF-8"):
        wg.WorldModel.from_trimesh(scene)


@pytest.mark.parametrize("path", ["x" * 5000, "kitchen\udcff.xml"])
def test_unusable_paths_are_named(path: str) -> None:
    with pytest.raises(wg.WorldGraphError, match="path"):
        wg.load_franka_kitchen(path)
    with pytest.raises(wg.WorldGraphError, match="path"):
        wg.WorldModel.load(path)


def test_from_trimesh_says_what_it_skipped_or_changed() -> None:
    scene = trimesh.Scene()
    nan_mesh = trimesh.Trimesh(vertices=np.full((3, 3), np.nan), faces=[[0, 1, 2]])
    scene.add_geometry(nan_mesh, node_name="door_0")
    scene.add_geometry(trimesh.creation.box((1, 1, 1)), node_name="door_1")
    with pytest.warns(UserWarning, match=r"1 geometry node\(s\) without vertices skipped.*door_0"):
        world = wg.WorldModel.from_trimesh(scene)
    assert [o.id for o in world.objects] == ["door_1"]
    mirror = np.array([[-1.0, 0, 0, 3], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.box((1, 2, 3)), node_name="door_1", transform=mirror)
    with pytest.warns(UserWarning, match=r"reflecting transform.*door_1"):
        world = wg.WorldModel.from_trimesh(scene)
    pose = world.objects[0].pose
    np.testing.assert_allclose(pose[:3, 3], [3.0, 0.0, 0.0], atol=1e-12)
    assert np.linalg.det(pose[:3, :3]) == pytest.approx(1.0)
    np.testing.assert_allclose(world.objects[0].size, [1.0, 2.0, 3.0], atol=1e-12)
