"""Procedural scenes as MuJoCo (MJCF) files, so that a simulated head can render them
(:class:`perception.mujoco.MujocoScene`) and :meth:`WorldModel.from_file
<worldgraph.WorldModel.from_file>` can read them back as a map.

:func:`scene_mjcf` writes every geometry node of a scene's :class:`trimesh.Scene` as a static
body named after the node (``door_012``: typed by the default rule of
:mod:`perception.type_rules`, as MuJoCo scenes of other origins are): box primitives as MuJoCo
boxes, every other mesh as an inline mesh asset.  Materials carry procedural textures (MuJoCo's
built-in checker, gradient and random-dot textures, coloured per type with colours drawn from
``seed``), so that stereo matching has texture where real surfaces have it, and every export of
one scene with another seed looks different.  The file is self-contained (no mesh files).
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any
from xml.sax.saxutils import quoteattr

import numpy as np
from scipy.spatial.transform import Rotation

from .._checks import file_path, integer
from ..errors import WorldGraphError
from ..model import WorldModel
from ..tolerances import BOX_CORNER_RTOL

__all__ = ["TEXTURE_KINDS", "scene_mjcf", "write_mjcf"]

#: The texture of each material, by the type of the objects that wear it (others: ``"plain"``).
TEXTURE_KINDS: dict[str, str] = {
    "door": "checker", "drawer": "checker", "cabinet": "checker", "table": "checker",
    "wall": "gradient", "floor": "checker", "ceiling": "flat", "handle": "flat", "knob": "flat",
}
#: Base colour range (RGB, 0-1) per type family; each export draws its colours within them.
_PALETTE: dict[str, tuple[tuple[float, float, float], tuple[float, float, float]]] = {
    "door": ((0.45, 0.28, 0.12), (0.85, 0.75, 0.6)),
    "cabinet": ((0.5, 0.4, 0.3), (0.95, 0.92, 0.88)),
    "shelf": ((0.5, 0.4, 0.3), (0.95, 0.92, 0.88)),
    "drawer": ((0.45, 0.28, 0.12), (0.85, 0.75, 0.6)),
    "handle": ((0.05, 0.05, 0.05), (0.35, 0.35, 0.4)),
    "knob": ((0.05, 0.05, 0.05), (0.6, 0.2, 0.2)),
    "wall": ((0.7, 0.7, 0.65), (0.95, 0.95, 0.92)),
    "floor": ((0.3, 0.25, 0.2), (0.6, 0.55, 0.5)),
}
_DEFAULT_RANGE = ((0.25, 0.25, 0.25), (0.85, 0.85, 0.85))


def _fmt(values: Any) -> str:
    return " ".join(f"{float(v):.6g}" for v in np.ravel(values))


def _is_box(mesh: Any) -> bool:
    """A mesh of 8 vertices at the corners of its own axis-aligned bounding box."""
    v = np.asarray(mesh.vertices, dtype=np.float64)
    if v.shape != (8, 3):
        return False
    lo, hi = v.min(axis=0), v.max(axis=0)
    slack = BOX_CORNER_RTOL * max(1.0, float(np.abs(v).max()))
    at_corner = np.minimum(np.abs(v - lo), np.abs(v - hi)) <= slack
    return bool(np.all(at_corner)) and bool(np.all(hi - lo > 0))


def scene_mjcf(world: WorldModel | Any, *, seed: int = 0, model_name: str = "gaussian-spheres scene") -> str:
    """The MJCF text of a procedural scene.

    Parameters
    ----------
    world : WorldModel or trimesh.Scene
        A world from :mod:`worldgraph.scenes` (its ``scene``), or the scene itself.
    seed : int
        Draws the materials' colours (>= 0).
    model_name : str
        The ``<mujoco model=...>`` name.

    Returns
    -------
    str
        A self-contained MJCF document: one static body per geometry node, named by the node.

    Raises
    ------
    WorldGraphError
        ``world`` has no scene (a world built from arrays), or a bad ``seed``.
    """
    import trimesh

    scene = world.scene if isinstance(world, WorldModel) else world
    if not isinstance(scene, trimesh.Scene):
        raise WorldGraphError("world must be a WorldModel with a trimesh scene (worldgraph.scenes' kitchens "
                              f"and layouts) or a trimesh.Scene, got {type(world).__name__}"
                              + (" without a scene" if isinstance(world, WorldModel) else ""))
    seed = integer("seed", seed, minimum=0)
    rng = np.random.default_rng(seed)
    assets: list[str] = []
    bodies: list[str] = []
    materials: dict[str, str] = {}
    meshes: dict[int, str] = {}

    def material(kind: str) -> str:
        if kind in materials:
            return materials[kind]
        lo, hi = _PALETTE.get(kind, _DEFAULT_RANGE)
        base = rng.uniform(lo, hi)
        second = np.clip(base * rng.uniform(0.75, 0.9), 0.0, 1.0)
        texture = TEXTURE_KINDS.get(kind, "plain")
        name = f"mat_{kind}"
        if texture == "checker":
            assets.append(f'    <texture name="tex_{kind}" type="2d" builtin="checker" rgb1="{_fmt(base)}" '
                          f'rgb2="{_fmt(second)}" width="64" height="64" mark="random" random="0.03" '
                          f'markrgb="{_fmt(second * 0.8)}"/>')
            assets.append(f'    <material name="{name}" texture="tex_{kind}" texrepeat="8 8" '
                          'texuniform="true"/>')
        elif texture == "gradient":
            assets.append(f'    <texture name="tex_{kind}" type="2d" builtin="gradient" rgb1="{_fmt(base)}" '
                          f'rgb2="{_fmt(second)}" width="64" height="64" mark="random" random="0.02" '
                          f'markrgb="{_fmt(second * 0.9)}"/>')
            assets.append(f'    <material name="{name}" texture="tex_{kind}" texrepeat="2 2" '
                          'texuniform="true"/>')
        else:
            assets.append(f'    <material name="{name}" rgba="{_fmt(base)} 1"/>')
        materials[kind] = name
        return name

    for node in sorted(scene.graph.nodes_geometry):
        T, geom_name = scene.graph[node]
        mesh = scene.geometry[geom_name]
        if not len(mesh.vertices):
            continue
        kind = str(node).rsplit("_", 1)[0]  # nodes are named f"{type}_{k:03d}" (worldgraph.scenes)
        T = np.asarray(T, dtype=np.float64)
        quat = Rotation.from_matrix(T[:3, :3]).as_quat(scalar_first=True)
        body = f'    <body name={quoteattr(str(node))} pos="{_fmt(T[:3, 3])}" quat="{_fmt(quat)}">'
        if _is_box(mesh):
            lo, hi = mesh.bounds
            geom = (f'<geom type="box" pos="{_fmt((lo + hi) / 2)}" size="{_fmt((hi - lo) / 2)}" '
                    f'material="{material(kind)}"/>')
        else:
            key = id(mesh)
            if key not in meshes:
                meshes[key] = f"mesh_{len(meshes)}"
                assets.append(f'    <mesh name="{meshes[key]}" vertex="{_fmt(mesh.vertices)}" '
                              f'face="{" ".join(str(int(i)) for i in np.ravel(mesh.faces))}"/>')
            geom = f'<geom type="mesh" mesh="{meshes[key]}" material="{material(kind)}"/>'
        bodies.append(f"{body}{geom}</body>")
    head = (f"<mujoco model={quoteattr(model_name)}>\n"
            '  <compiler angle="radian"/>\n'
            '  <visual><headlight active="1" ambient="0.35 0.35 0.35" diffuse="0.5 0.5 0.5"/>'
            '<global offwidth="1280" offheight="960"/></visual>\n'
            '  <default><geom contype="0" conaffinity="0"/><mesh inertia="shell"/></default>\n')
    lights = _lights(scene)
    return (head + "  <asset>\n" + "\n".join(assets) + "\n  </asset>\n  <worldbody>\n" + lights
            + "\n".join(bodies) + "\n  </worldbody>\n</mujoco>\n")


def _lights(scene: Any) -> str:
    """Ceiling lights over the scene's floor plan: a grid about 3 m apart, 0.2 m below its top."""
    lo, hi = np.asarray(scene.bounds[0], dtype=np.float64), np.asarray(scene.bounds[1], dtype=np.float64)
    nx, ny = (max(1, math.ceil((hi[i] - lo[i]) / 3.0)) for i in (0, 1))
    out = []
    for i in range(nx):
        for j in range(ny):
            x = lo[0] + (i + 0.5) * (hi[0] - lo[0]) / nx
            y = lo[1] + (j + 0.5) * (hi[1] - lo[1]) / ny
            out.append(f'    <light pos="{x:.3f} {y:.3f} {hi[2] - 0.2:.3f}" dir="0 0 -1" '
                       'diffuse="0.35 0.35 0.35" castshadow="false"/>\n')
    return "".join(out)


def write_mjcf(world: WorldModel | Any, path: str | os.PathLike[str], *, seed: int = 0) -> Path:
    """:func:`scene_mjcf` written to ``path`` (UTF-8); returns the path.

    Raises
    ------
    WorldGraphError
        As :func:`scene_mjcf`, or a path that is not a file path.
    """
    target = Path(file_path("path", path))
    target.write_text(scene_mjcf(world, seed=seed, model_name=target.stem), encoding="utf-8")
    return target
