"""MJCF geometry both packages read: which geoms MuJoCo draws, which belong to each typed
object, and their meshes (:mod:`worldgraph`'s :meth:`~worldgraph.WorldModel.from_file` places
objects with these too)."""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from ..errors import (
    MissingExtraError,
)

if TYPE_CHECKING:  # pragma: no cover
    import trimesh

_PIP = "pip install gaussian-spheres[mujoco]"
#: Geom groups MuJoCo renders by default (``mjvOption.geomgroup`` is 1, 1, 1, 0, 0, 0).
VISIBLE_GROUPS = (0, 1, 2)
#: MuJoCo's default geom colour: a geom with a material and this rgba takes the material's colour.
_DEFAULT_RGBA = (0.5, 0.5, 0.5, 1.0)


def import_mujoco() -> Any:
    """The ``mujoco`` module, imported on first use.

    Headless (no ``DISPLAY`` in the environment) it sets ``MUJOCO_GL=egl`` first unless the
    variable is set, so that ``mujoco.Renderer`` gets an offscreen context.

    Returns
    -------
    module
        ``mujoco``.

    Raises
    ------
    MissingExtraError
        ``mujoco`` is not installed; the message names the pip command.
    """
    if "DISPLAY" not in os.environ:
        os.environ.setdefault("MUJOCO_GL", "egl")
    try:
        import mujoco
    except ImportError as exc:
        raise MissingExtraError(f"perception.mujoco needs the mujoco package: {_PIP}") from exc
    return mujoco


# ----------------------------------------------------------------------------------------------
# the objects of a model (no rendering; shared with worldgraph.WorldModel.from_file)
# ----------------------------------------------------------------------------------------------
def visual_geoms(model: Any) -> NDArray[np.bool_]:
    """Which geoms MuJoCo draws by default.

    Parameters
    ----------
    model : mujoco.MjModel
        A compiled model.

    Returns
    -------
    (model.ngeom,) bool
        Geom group in :data:`VISIBLE_GROUPS` and a colour with alpha > 0: the geom's ``rgba``,
        or its material's when it has one and its own ``rgba`` is MuJoCo's default (as MuJoCo
        colours it).
    """
    n = int(model.ngeom)
    group = np.asarray(model.geom_group, dtype=np.int64).reshape(n)
    rgba = np.asarray(model.geom_rgba, dtype=np.float64).reshape(n, 4)
    matid = np.asarray(model.geom_matid, dtype=np.int64).reshape(n)
    alpha = rgba[:, 3].copy()
    if int(model.nmat) > 0:
        mat_rgba = np.asarray(model.mat_rgba, dtype=np.float64).reshape(-1, 4)
        default = np.all(rgba == np.array(_DEFAULT_RGBA), axis=1)  # 0.5 and 1 are exact in float32
        use_mat = (matid >= 0) & default
        alpha[use_mat] = mat_rgba[matid[use_mat], 3]
    return np.isin(group, VISIBLE_GROUPS) & (alpha > 0)


def _own_selection(model: Any, body: int, visible: NDArray[np.bool_]) -> list[int]:
    """The visual geoms of ``body`` (the non-colliding ones when it has both kinds)."""
    start, count = int(model.body_geomadr[body]), int(model.body_geomnum[body])
    own = [g for g in range(start, start + count) if visible[g]]  # count 0 when start is -1
    quiet = [g for g in own if int(model.geom_contype[g]) == 0 and int(model.geom_conaffinity[g]) == 0]
    return quiet if quiet and len(quiet) < len(own) else own


def object_geoms(model: Any, rule: Callable[[str], str | None] | None = None) -> dict[int, list[int]]:
    """The geoms that make up each named body's geometry.

    Parameters
    ----------
    model : mujoco.MjModel
        A compiled model.
    rule : callable, optional
        ``name -> type or None`` (:func:`perception.type_rules.type_rule`).  Without it every
        body holds only its own geoms.

    Returns
    -------
    dict
        Body id (>= 1) -> geom ids, ascending.  A body's own visual geoms (module docstring:
        the non-colliding ones when it has both kinds); for a body whose name ``rule`` types,
        also those of its untyped descendants (recursively, stopping at typed ones).  A body
        with none of these keeps all its own geoms (possibly none).
    """
    visible = visual_geoms(model)
    nbody = int(model.nbody)
    parent = np.asarray(model.body_parentid, dtype=np.int64).reshape(nbody)
    children: list[list[int]] = [[] for _ in range(nbody)]
    for b in range(1, nbody):
        children[int(parent[b])].append(b)
    typed = [False] * nbody
    if rule is not None:
        for b in range(1, nbody):
            name = model.body(b).name
            typed[b] = bool(name) and rule(name) is not None
    out: dict[int, list[int]] = {}
    for b in range(1, nbody):
        geoms = list(_own_selection(model, b, visible))
        if typed[b]:
            stack = list(children[b])
            while stack:
                c = stack.pop()
                if typed[c]:
                    continue
                geoms.extend(_own_selection(model, c, visible))
                stack.extend(children[c])
        if not geoms:
            start, count = int(model.body_geomadr[b]), int(model.body_geomnum[b])
            geoms = list(range(start, start + count))
        out[b] = sorted(geoms)
    return out


def geom_mesh(model: Any, g: int) -> tuple[trimesh.Trimesh, NDArray[np.float64]] | None:
    """The shape of a geom as a triangle mesh.

    Parameters
    ----------
    model : mujoco.MjModel
        A compiled model.
    g : int
        Geom id.

    Returns
    -------
    (trimesh.Trimesh, (4, 4) float) or None
        The mesh and ``geom_from_mesh``; ``None`` for an infinite plane.  Boxes, spheres,
        ellipsoids, cylinders and capsules as trimesh primitives of the geom's size; meshes with
        their vertices as written in the asset file (MuJoCo's re-centring on the mesh's inertia
        frame undone with ``mesh_pos`` / ``mesh_quat``); finite planes as flat rectangles; other
        types (height fields, SDFs) as their bounding box ``geom_aabb``.
    """
    import trimesh

    mujoco = import_mujoco()
    kind = int(model.geom_type[g])
    size = np.asarray(model.geom_size[g], dtype=np.float64)
    T = mujoco.mjtGeom
    eye = np.eye(4)
    if kind == int(T.mjGEOM_BOX):
        return trimesh.creation.box(extents=2.0 * size), eye
    if kind == int(T.mjGEOM_SPHERE):
        return trimesh.creation.icosphere(subdivisions=1, radius=size[0]), eye
    if kind == int(T.mjGEOM_ELLIPSOID):
        mesh = trimesh.creation.icosphere(subdivisions=1, radius=1.0)
        mesh.apply_scale(size)
        return mesh, eye
    if kind == int(T.mjGEOM_CYLINDER):
        return trimesh.creation.cylinder(radius=size[0], height=2.0 * size[1], sections=24), eye
    if kind == int(T.mjGEOM_CAPSULE):
        return trimesh.creation.capsule(height=2.0 * size[1], radius=size[0], count=[12, 12]), eye
    if kind == int(T.mjGEOM_PLANE):
        if size[0] <= 0 or size[1] <= 0:
            return None  # infinite plane: no box
        sx, sy = size[0], size[1]
        quad = np.array([[-sx, -sy, 0.0], [sx, -sy, 0.0], [sx, sy, 0.0], [-sx, sy, 0.0]])
        return trimesh.Trimesh(vertices=quad, faces=[[0, 1, 2], [0, 2, 3]], process=False), eye
    if kind == int(T.mjGEOM_MESH) and int(model.geom_dataid[g]) >= 0:
        k = int(model.geom_dataid[g])
        v0, nv = int(model.mesh_vertadr[k]), int(model.mesh_vertnum[k])
        f0, nf = int(model.mesh_faceadr[k]), int(model.mesh_facenum[k])
        verts = np.asarray(model.mesh_vert[v0:v0 + nv], dtype=np.float64)
        faces = np.asarray(model.mesh_face[f0:f0 + nf], dtype=np.int64)
        geom_from_mesh = np.eye(4)
        if hasattr(model, "mesh_pos") and hasattr(model, "mesh_quat"):
            # MuJoCo stores vertices in the mesh's inertia frame: asset = R @ stored + pos
            rot = Rotation.from_quat(model.mesh_quat[k], scalar_first=True).as_matrix()  # (w, x, y, z)
            pos = np.asarray(model.mesh_pos[k], dtype=np.float64)
            verts = verts @ rot.T + pos
            geom_from_mesh[:3, :3] = rot.T
            geom_from_mesh[:3, 3] = -rot.T @ pos
        return trimesh.Trimesh(vertices=verts, faces=faces, process=False), geom_from_mesh
    aabb = np.asarray(model.geom_aabb[g], dtype=np.float64)
    centre, half = aabb[:3], aabb[3:]
    box = trimesh.creation.box(extents=2.0 * half)
    box.apply_translation(centre)
    return box, eye


def body_meshes(model: Any, data: Any, body: int, geoms: Sequence[int]) -> list[trimesh.Trimesh]:
    """The meshes of ``geoms`` (:func:`geom_mesh`, infinite planes left out) in the frame of
    ``body``, at the pose of ``data`` (after ``mj_forward``): a body's geometry as
    ``WorldModel.from_file`` and :class:`MujocoScene` both place it."""
    world_from_body = _pose(data.xpos[body], data.xmat[body])
    body_from_world = np.linalg.inv(world_from_body)
    out = []
    for g in geoms:
        shape = geom_mesh(model, g)
        if shape is None:
            continue
        mesh, geom_from_mesh = shape
        mesh = mesh.copy()
        mesh.apply_transform(body_from_world @ _pose(data.geom_xpos[g], data.geom_xmat[g]) @ geom_from_mesh)
        out.append(mesh)
    return out


def _pose(position: ArrayLike, xmat: ArrayLike) -> NDArray[np.float64]:
    m = np.eye(4)
    m[:3, :3] = np.asarray(xmat, dtype=np.float64).reshape(3, 3)
    m[:3, 3] = np.asarray(position, dtype=np.float64)
    return m
