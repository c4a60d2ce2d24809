"""Cases from the second adversarial audit of worldgraph (issue 12): each raised something else
than the package's error, or was accepted silently."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

import perception as pc
import worldgraph as wg


def _world() -> tuple[wg.WorldModel, list[pc.Percept]]:
    pos = np.random.default_rng(0).uniform([0, 0, 0], [6, 6, 2], (20, 3))
    world = wg.WorldModel.from_arrays([f"t{i % 4}" for i in range(20)], pos)
    return world, [pc.Percept(f"t{i % 4}", pos[i] - [2, 3, 0.5], 0.02) for i in range(10)]


def test_scene_node_name_that_is_not_unicode_text_is_named() -> None:
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.box((1, 1, 1)), node_name="door\udcff")
    with pytest.raises(wg.ImporterError, match=r"scene node name 'door\\udcff'.*UTF-8"):
        wg.WorldModel.from_trimesh(scene)


@pytest.mark.parametrize("path", ["x" * 5000, "kitchen\udcff.xml"])
def test_unusable_paths_are_named(path: str) -> None:
    with pytest.raises(wg.ArgumentTypeError, match="path"):
        wg.load_franka_kitchen(path)
    with pytest.raises(wg.WorldGraphError, match="path"):
        wg.WorldModel.load(path)


def test_world_model_of_a_scalar_and_bad_scene_or_source() -> None:
    world, _ = _world()
    with pytest.raises(wg.ArgumentTypeError, match="objects must be a sequence of ObjectModel"):
        wg.WorldModel(np.array(1.0))
    with pytest.raises(wg.ArgumentTypeError, match="scene must be a trimesh.Scene"):
        wg.WorldModel(world.objects, scene=float("nan"), class_vertices=world.class_vertices)
    with pytest.raises(wg.ArgumentTypeError, match="source must be a str"):
        wg.WorldModel.from_dict(world.to_dict(), source=object())


@pytest.mark.parametrize("sigma, error, text", [
    (None, wg.ArgumentTypeError, "sigma_p"),
    (float("nan"), wg.NonFiniteError, "sigma_p"),
    (-1.0, wg.NonPositiveError, "sigma_p must be >= 0, got -1.0"),
    (1j, wg.ArgumentTypeError, "sigma_p must be real"),
    (1e300, wg.OutOfRangeError, "sigma_p"),
])
def test_pair_tolerance_checks_its_sigmas(sigma: object, error: type, text: str) -> None:
    with pytest.raises(error, match=text):
        wg.ASSOCIATION_TOLERANCES.pair_tolerance(sigma, 0.1)


def test_pair_tolerance_value_and_broadcasting() -> None:
    tol = wg.AssociationTolerances(n_sigma=3.0, pair_factor=1.0, min_tolerance=0.01)
    assert tol.pair_tolerance(0.3, 0.4) == pytest.approx(3.0 * 0.5 + 0.01)
    np.testing.assert_allclose(tol.pair_tolerance(np.array([0.3, 0.0]), 0.4), [1.51, 1.21])
    with pytest.raises(wg.ShapeError, match="broadcast"):
        tol.pair_tolerance(np.ones(2), np.ones(3))


def test_rotation_gate_in_degrees_is_refused_with_a_hint() -> None:
    world, percepts = _world()
    with pytest.raises(wg.OutOfRangeError, match=r"max_rotation_3sigma = 45.0 .*radians.*np.radians"):
        wg.localize(world, percepts, max_rotation_3sigma=45.0)
    assert wg.localize(world, percepts, max_rotation_3sigma=0.5).status in wg.LOCALIZE_STATUSES


def test_min_clique_size_above_the_search_size_names_both_fields() -> None:
    with pytest.raises(wg.OutOfRangeError, match="min_clique_size = 30 exceeds max_search_percepts = 10"):
        wg.AssociationTolerances(min_clique_size=30)
    assert wg.AssociationTolerances(min_clique_size=30, max_search_percepts=40).min_clique_size == 30


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


def test_a_link_table_beyond_its_budget_is_refused_before_it_is_built(monkeypatch) -> None:
    """20,000 objects of one type in a 10 m cube would link about 56 million pairs (1.2 GB and
    more while sorting): refused at once, naming max_link_length; the count estimated from a
    strided sample agrees with the exact count on a smaller world."""
    import worldgraph.model.links as links

    rng = np.random.default_rng(0)
    with pytest.raises(wg.OutOfRangeError, match=r"max_link_length = 5 m .* about 5\d,\d{3},\d{3} object"):
        wg.WorldModel.from_arrays(["door"] * 20_000, rng.uniform(0, 10, (20_000, 3)))
    pos = rng.uniform(0, 40, (3000, 3))
    exact = wg.WorldModel.from_arrays(["door"] * 3000, pos)
    n_links = len(exact.links[("door", "door")])
    monkeypatch.setattr(links, "MAX_LINKS", int(0.8 * n_links))
    with pytest.raises(wg.OutOfRangeError, match="lower max_link_length"):
        wg.WorldModel.from_arrays(["door"] * 3000, pos)
    monkeypatch.setattr(links, "MAX_LINKS", int(1.25 * n_links))
    assert len(wg.WorldModel.from_arrays(["door"] * 3000, pos).links[("door", "door")]) == n_links


def test_localize_check_skips_hypotheses_beyond_the_enumeration_limit_and_says_so() -> None:
    """check=True with 10 matched percepts: vertex enumeration of 10 spheres would run for minutes;
    localize solves those unchecked and its message names the limit."""
    import radialopt as ro

    world, percepts = _world()
    res = wg.localize(world, percepts, check=True)
    assert res.status in wg.LOCALIZE_STATUSES
    assert len(res.correspondences) > ro.MAX_VERTEX_SPHERES
    assert "MAX_VERTEX_SPHERES" in res.message
    small = wg.localize(world, percepts[:5], check=True)
    assert "MAX_VERTEX_SPHERES" not in small.message
