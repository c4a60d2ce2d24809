"""perception's rotation matrices (scipy's Rotation underneath) against the explicit formulas."""

from __future__ import annotations

import math

import numpy as np
import pytest

from perception.head.chain import rotation
from perception.simulation.render import _rot_z

RNG_SEED = 20261204


def explicit_axis_rotation(axis: str, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return {"x": np.array([[1.0, 0, 0], [0, c, -s], [0, s, c]]),
            "y": np.array([[c, 0, s], [0, 1.0, 0], [-s, 0, c]]),
            "z": np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])}[axis]


@pytest.mark.parametrize("axis", ["x", "y", "z"])
def test_rotation_is_the_explicit_right_handed_turn(axis: str) -> None:
    for angle in np.random.default_rng(RNG_SEED).uniform(-10.0, 10.0, 200):
        M = rotation(axis, float(angle))
        assert M.shape == (4, 4)
        np.testing.assert_allclose(M[:3, :3], explicit_axis_rotation(axis, float(angle)), atol=1e-14)
        np.testing.assert_array_equal(M[3], [0.0, 0.0, 0.0, 1.0])
        np.testing.assert_array_equal(M[:3, 3], 0.0)


def test_rotation_by_a_quarter_turn_maps_the_next_axis_to_the_one_after() -> None:
    e = np.eye(3)
    for i, axis in enumerate("xyz"):
        R = rotation(axis, math.pi / 2)[:3, :3]
        np.testing.assert_allclose(R @ e[(i + 1) % 3], e[(i + 2) % 3], atol=1e-15)
        np.testing.assert_allclose(R @ e[i], e[i], atol=1e-15)


def test_rotation_of_an_unknown_axis_is_a_key_error() -> None:
    with pytest.raises(KeyError):
        rotation("w", 0.1)


def test_rot_z_is_the_explicit_yaw() -> None:
    for angle in np.random.default_rng(RNG_SEED).uniform(-10.0, 10.0, 200):
        want = explicit_axis_rotation("z", float(angle))
        np.testing.assert_allclose(_rot_z(float(angle)), want, atol=1e-14)


def test_mesh_vertices_come_back_in_the_asset_frame() -> None:
    """MuJoCo stores a mesh in its inertia frame (mesh_pos, mesh_quat (w, x, y, z)); geom_mesh
    turns the stored vertices back into the ones the MJCF file gave."""
    mujoco = pytest.importorskip("mujoco")
    import trimesh

    from perception.mujoco.geometry import geom_mesh

    rng = np.random.default_rng(RNG_SEED)
    verts = rng.normal(size=(8, 3)) * [0.5, 0.2, 0.1] + [0.3, -0.2, 0.1]
    hull = trimesh.Trimesh(vertices=verts).convex_hull
    xml = f"""<mujoco><asset><mesh name="m" vertex="{' '.join(map(str, hull.vertices.ravel()))}"/></asset>
    <worldbody><geom type="mesh" mesh="m"/></worldbody></mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    assert not np.allclose(model.mesh_quat[0], [1.0, 0.0, 0.0, 0.0])  # a turned inertia frame
    mesh, geom_from_mesh = geom_mesh(model, 0)
    np.testing.assert_allclose(np.sort(mesh.vertices, axis=0), np.sort(hull.vertices, axis=0),
                               atol=1e-6)  # MuJoCo stores float32 vertices
    np.testing.assert_allclose(geom_from_mesh[:3, :3] @ geom_from_mesh[:3, :3].T, np.eye(3), atol=1e-12)
