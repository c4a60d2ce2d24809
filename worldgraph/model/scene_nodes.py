"""Reading a :class:`trimesh.Scene` into a world model: its geometry nodes (transforms, vertex
bounds, default types), the object table of :meth:`WorldModel.from_trimesh
<worldgraph.model.WorldModel.from_trimesh>` (``_trimesh_table``) and the room box
(:func:`room_from_trimesh`, :data:`ROOM_TYPES`, :data:`DEFAULT_ROOM_HEIGHT`)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from perception.head.chain import rotation_errors

from .. import _checks
from ..errors import (
    WorldGraphError,
)
from ..tolerances import RIGID_TOLERANCE
from .objects import MAX_COORDINATE, ObjectModel, ObjectTable, _check_unique_ids

__all__ = [
    "DEFAULT_ROOM_HEIGHT",
    "FLAT_FLOOR_RATIO",
    "ROOM_TYPES",
    "TALL_RATIO",
    "TALL_SPREAD",
    "room_from_trimesh",
]

if TYPE_CHECKING:  # pragma: no cover
    import trimesh

    import radialopt


def _check_room(room: Any, what: str = "room") -> radialopt.Region | None:
    """``None``, a :class:`radialopt.Region`, or a ``(lower, upper)`` pair made into one; a bad
    pair raises this package's errors (shape, finiteness, ``lower <= upper``) naming ``what``."""
    if room is None:
        return None
    from radialopt import Region
    from radialopt import errors as ro_errors

    if isinstance(room, Region):  # checked when it was made (finite, lower <= upper)
        lower, upper = room.lower, room.upper
    elif isinstance(room, tuple | list) and len(room) == 2:
        lower, upper = room
    else:
        raise WorldGraphError(f"{what} must be a radialopt.Region, a (lower, upper) pair or None, "
                              f"got {_checks._short(room)}")
    lower = _checks.real_array(f"{what} lower", lower, (3,), max_abs=MAX_COORDINATE)
    upper = _checks.real_array(f"{what} upper", upper, (3,), max_abs=MAX_COORDINATE)
    if isinstance(room, Region):
        return room
    try:
        return Region(lower, upper)
    except ro_errors.RadialError as exc:
        raise WorldGraphError(f"{what} = {_checks._short(room)} is not a valid box: {exc}") from exc


def default_type(scene: trimesh.Scene, node: str, geometry: Any) -> Any:
    """The type of a scene node by the default rule of :meth:`WorldModel.from_trimesh`."""
    meta = None
    parent = scene.graph.transforms.parents.get(node)
    if parent is not None:
        meta = scene.graph.transforms.edge_data.get((parent, node), {}).get("metadata")
    gmeta = getattr(geometry, "metadata", None) or {}
    if isinstance(meta, dict) and "type" in meta:
        return meta["type"]
    if "type" in gmeta:
        return gmeta["type"]
    return str(node).replace(":", "_").split("_", 1)[0]


#: Node types :meth:`WorldModel.from_trimesh` reads the room box from.
ROOM_TYPES = ("floor", "wall", "ceiling")
#: Room height (metres) assumed when a scene has a floor but neither ceiling nor walls.
DEFAULT_ROOM_HEIGHT = 3.0


def _world_bounds(matrix: NDArray[np.float64], bounds: NDArray[np.float64]) -> NDArray[np.float64]:
    """``(2, 3)`` axis-aligned bounds of a local box ``bounds (2, 3)`` moved by ``matrix``."""
    corners = np.array([[bounds[i, 0], bounds[j, 1], bounds[k, 2]]
                        for i in (0, 1) for j in (0, 1) for k in (0, 1)])
    world = corners @ matrix[:3, :3].T + matrix[:3, 3]
    return np.array([world.min(axis=0), world.max(axis=0)])


def check_scene(scene: Any) -> None:
    try:
        import trimesh as _trimesh
    except ImportError as exc:  # pragma: no cover
        from ..errors import ImporterError
        raise ImporterError("from_trimesh needs trimesh: pip install trimesh") from exc
    if not isinstance(scene, _trimesh.Scene):
        raise WorldGraphError(f"scene must be a trimesh.Scene, got {_checks._short(scene)}")
    from ..errors import ImporterError

    for node in list(getattr(scene.graph.transforms, "node_data", {})):
        if isinstance(node, str):
            _checks.name_string(f"scene node name {node!r}", node, ImporterError)


def _node_geometry(scene: trimesh.Scene, node: Any) -> tuple[Any, str, Any]:
    """``(world_from_node as stored, geometry name, geometry)`` of a geometry node (trimesh types
    the name ``Hashable | None``; it is a key of ``scene.geometry``, a str); a name the scene has
    no geometry for raises :class:`~worldgraph.errors.WorldGraphError`."""
    matrix, geom_name = scene.graph[node]
    geometry = scene.geometry.get(geom_name)
    if geometry is None:
        raise WorldGraphError(f"scene node {node!r} refers to geometry {geom_name!r}, which the scene lacks")
    return matrix, str(geom_name), geometry


def _geometry_nodes(scene: trimesh.Scene) -> Iterable[tuple[str, NDArray[np.float64], str, Any]]:
    """``(node, world_from_node (4, 4), geometry name, geometry)`` of each geometry node, the
    transform checked finite with ``|x| <=`` :data:`MAX_COORDINATE`."""
    for node in scene.graph.nodes_geometry:
        matrix, geom_name, geometry = _node_geometry(scene, node)
        m = _checks.real_array(f"transform of scene node {node!r}", matrix, (4, 4), max_abs=MAX_COORDINATE)
        yield node, m, geom_name, geometry


def _vertex_bounds(name: str, geometry: Any) -> NDArray[np.float64] | None:
    """``(2, 3)`` bounds of a geometry's vertices; ``None`` when it has none (empty Trimesh,
    empty PointCloud, or a geometry without vertices)."""
    verts = _vertices(name, geometry)
    if verts is None:
        return None
    return np.array([verts.min(axis=0), verts.max(axis=0)])


def _vertices(name: str, geometry: Any) -> NDArray[np.float64] | None:
    raw = getattr(geometry, "vertices", None)
    if raw is None or np.size(raw) == 0:
        return None
    return _checks.real_array(name, raw, (None, 3), max_abs=MAX_COORDINATE, min_size=1)


def _scene_nodes(scene: trimesh.Scene) -> tuple[list[Any], NDArray[np.float64], list[str], list[Any]]:
    """What ``_geometry_nodes`` yields, as lists and one ``(n, 4, 4)`` array of transforms
    checked together (the first bad one raises the error of ``_geometry_nodes``)."""
    nodes: list[Any] = []
    matrices: list[Any] = []
    geom_names: list[str] = []
    geometries: list[Any] = []
    for node in scene.graph.nodes_geometry:
        matrix, geom_name, geometry = _node_geometry(scene, node)
        nodes.append(node)
        matrices.append(matrix)
        geom_names.append(geom_name)
        geometries.append(geometry)
    try:
        stack = np.array(matrices, dtype=np.float64).reshape(len(nodes), 4, 4)
        ok = bool(np.isfinite(stack).all()) and (not stack.size
                                                 or float(np.abs(stack).max()) <= MAX_COORDINATE)
    except (TypeError, ValueError, OverflowError):
        ok = False
    if not ok:  # the first bad transform raises as in _geometry_nodes
        for node, matrix in zip(nodes, matrices, strict=True):
            _checks.real_array(f"transform of scene node {node!r}", matrix, (4, 4), max_abs=MAX_COORDINATE)
        raise WorldGraphError("scene node transforms must be finite (4, 4) arrays")  # pragma: no cover
    return nodes, stack, geom_names, geometries


def _fast_vertex_bounds(name: str, geometry: Any) -> NDArray[np.float64] | None:
    """``_vertex_bounds`` without copying float vertices: the bounds are checked instead of
    every vertex (a NaN or an infinity reaches them); anything unusual goes through the full check."""
    raw = getattr(geometry, "vertices", None)
    if raw is None or np.size(raw) == 0:
        return None
    if isinstance(raw, np.ndarray) and raw.ndim == 2 and raw.shape[1] == 3 and raw.dtype.kind == "f":
        bounds = np.array([raw.min(axis=0), raw.max(axis=0)], dtype=np.float64)
        if np.isfinite(bounds).all() and float(np.abs(bounds).max()) <= MAX_COORDINATE:
            return bounds
    return _vertex_bounds(name, geometry)


def _proper_rotations(lin: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``_rotation_and_scale`` of a stack ``(n, 3, 3)`` (the same numbers, batched)."""
    n = len(lin)
    rot = np.empty((n, 3, 3))
    scale = np.empty((n, 3))
    ident = np.all(lin == np.eye(3), axis=(1, 2))
    if ident.any():
        rot_i, scale_i = _rotation_and_scale(np.eye(4))
        rot[ident], scale[ident] = rot_i, scale_i
    rest = np.flatnonzero(~ident)
    if rest.size:
        sub = lin[rest]
        sc = np.linalg.norm(sub, axis=1)
        r = sub / np.where(sc > 0, sc, 1.0)[:, None, :]
        u, _, vt = np.linalg.svd(r)
        r = u @ vt
        neg = np.linalg.det(r) < 0
        if neg.any():
            u[neg, :, -1] *= -1
            r[neg] = u[neg] @ vt[neg]
        rot[rest], scale[rest] = r, sc
    return rot, scale


def room_from_trimesh(scene: trimesh.Scene) -> radialopt.Region | None:
    """The room box of a scene, or ``None`` when it has no room nodes.

    ``scene.metadata["room"]`` (a :class:`radialopt.Region` or a ``(lower, upper)`` pair) wins
    when present.  Else the room nodes are the geometry nodes whose type by the default rule of
    :meth:`WorldModel.from_trimesh` is ``"floor"``, ``"wall"`` or ``"ceiling"``: x and y span the
    union of the floor and wall nodes' world bounds (of the ceiling's if there are neither); the
    lower z is the top of the floor (the highest floor top), else the lowest point of the room
    nodes; the upper z is the bottom of the ceiling (the lowest), else the top of the walls, else
    the lower z + :data:`DEFAULT_ROOM_HEIGHT`.
    """
    check_scene(scene)
    meta = getattr(scene, "metadata", None) or {}
    if isinstance(meta, Mapping) and meta.get("room") is not None:
        return _check_room(meta["room"], 'scene.metadata["room"]')
    found: dict[str, list[NDArray[np.float64]]] = {t: [] for t in ROOM_TYPES}
    for node, matrix, geom_name, geometry in _geometry_nodes(scene):
        typ = default_type(scene, node, geometry)
        if isinstance(typ, str) and typ in found:
            bounds = _vertex_bounds(f"vertices of geometry {geom_name!r}", geometry)
            if bounds is not None:
                found[typ].append(_world_bounds(matrix, bounds))
    return _room_from_bounds(found)


#: A floor (the union box of the floor nodes) is flat when its thinnest extent is at most this
#: fraction of its middle one; a flat floor whose thin axis is not z is a room on its side.
FLAT_FLOOR_RATIO = 0.2
#: Without floor nodes: objects spread along z more than this many times their widest horizontal
#: extent, and more than :data:`TALL_SPREAD` metres, are a room on its side.
TALL_RATIO = 2.0
#: ... (metres): a storey is lower.
TALL_SPREAD = 4.0


def _likely_up(scene: trimesh.Scene, positions: NDArray[np.float64]
               ) -> tuple[NDArray[np.float64], str] | None:
    """``(up (3,), why)`` when the scene looks like a room on its side: the world direction that
    is probably up and the evidence; ``None`` when z looks up.

    The rule: the floor nodes (type ``"floor"`` by the default rule, as for the room) form a
    flat box (thinnest extent at most :data:`FLAT_FLOOR_RATIO` of the middle one); up is its
    thin axis, pointing from the floor towards the objects' mean ``positions``; anything but +z
    is a room on its side (or upside down).  Without floor nodes: the objects spread along z more than
    :data:`TALL_RATIO` times their widest horizontal extent and more than :data:`TALL_SPREAD`
    metres: up is the horizontal axis of the smaller spread, its sign unknown (+).
    """
    floors = []
    for node, matrix, geom_name, geometry in _geometry_nodes(scene):
        if default_type(scene, node, geometry) == "floor":
            bounds = _vertex_bounds(f"vertices of geometry {geom_name!r}", geometry)
            if bounds is not None:
                floors.append(_world_bounds(matrix, bounds))
    if floors:
        box = np.array(floors)
        lo, hi = box[:, 0].min(axis=0), box[:, 1].max(axis=0)
        ext = hi - lo
        order = np.argsort(ext, kind="stable")
        thin = int(order[0])
        if not ext[thin] <= FLAT_FLOOR_RATIO * ext[order[1]]:
            return None
        up = np.zeros(3)
        centre = 0.5 * (lo[thin] + hi[thin])
        up[thin] = -1.0 if len(positions) and float(np.mean(positions[:, thin])) < centre else 1.0
        if up[2] == 1.0:
            return None
        where = "below" if up[thin] > 0 else "above"
        return up, (f"the floor is flat along {'xyz'[thin]} ({ext[thin]:.3g} m thick, "
                    f"{ext[order[1]]:.3g} x {ext[order[2]]:.3g} m) and {where} the objects")
    if len(positions) < 2:
        return None
    ext = positions.max(axis=0) - positions.min(axis=0)
    if ext[2] > TALL_RATIO * max(ext[0], ext[1]) and ext[2] > TALL_SPREAD:
        up = np.zeros(3)
        up[int(np.argmin(ext[:2]))] = 1.0
        return up, (f"the objects spread {ext[2]:.3g} m along z but {ext[0]:.3g} m along x and "
                     f"{ext[1]:.3g} m along y")
    return None


def _room_from_bounds(found: Mapping[str, list[NDArray[np.float64]]]) -> radialopt.Region | None:
    """The room box of :func:`room_from_trimesh` from the world bounds ``(2, 3)`` of the floor,
    wall and ceiling nodes (``found[type]``)."""
    floors, walls, ceilings = (np.array(found[t]).reshape(-1, 2, 3) for t in ROOM_TYPES)
    every = np.concatenate([floors, walls, ceilings])
    if not len(every):
        return None
    planar = np.concatenate([floors, walls]) if len(floors) + len(walls) else ceilings
    lo_xy, hi_xy = planar[:, 0, :2].min(axis=0), planar[:, 1, :2].max(axis=0)
    z0 = floors[:, 1, 2].max() if len(floors) else every[:, 0, 2].min()
    if len(ceilings):
        z1 = ceilings[:, 0, 2].min()
    elif len(walls):
        z1 = walls[:, 1, 2].max()
    else:
        z1 = z0 + DEFAULT_ROOM_HEIGHT
    return _check_room((np.array([lo_xy[0], lo_xy[1], z0]), np.array([hi_xy[0], hi_xy[1], z1])),
                       "room found in the scene")


def _rotation_and_scale(matrix: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Split the linear part of a (4, 4) transform into a rotation and per-axis scales."""
    lin = matrix[:3, :3]
    scale = np.linalg.norm(lin, axis=0)
    safe = np.where(scale > 0, scale, 1.0)
    rot = lin / safe
    # orthonormalise (removes shear and rounding); keep a proper rotation
    u, _, vt = np.linalg.svd(rot)
    rot = u @ vt
    if np.linalg.det(rot) < 0:
        u[:, -1] *= -1
        rot = u @ vt
    return rot, scale


def _trimesh_table(nodes: list[Any], matrices: NDArray[np.float64], geom_names: list[str],
                   geometries: list[Any], bounds_of: Mapping[str, NDArray[np.float64] | None],
                   keep: list[int], types: list[str],
                   ) -> tuple[ObjectTable | None, dict[str, NDArray[np.float64]], list[str]]:
    """The objects of :meth:`WorldModel.from_trimesh` as an :class:`ObjectTable` (``None`` when
    there is none), its class vertices and the names of the mirrored nodes.

    Batched, with the numbers of the per-node construction (``ObjectModel`` per node: see
    ``tests/worldgraph/test_importers.py``); a value out of range makes that node's ``ObjectModel`` to
    raise its error.
    """
    if not keep:
        return None, {}, []
    idx = np.array(keep, dtype=np.intp)
    m = matrices[idx]
    lin = m[:, :3, :3]
    bounds = np.array([bounds_of[geom_names[k]] for k in keep], dtype=np.float64)
    lo, hi = bounds[:, 0], bounds[:, 1]
    centre = 0.5 * (lo + hi)
    rot, scale = _proper_rotations(lin)
    mirrored = [str(nodes[keep[i]]) for i in np.flatnonzero(np.linalg.det(lin) < 0).tolist()]
    positions = (lin @ centre[:, :, None])[:, :, 0] + m[:, :3, 3]
    sizes = (hi - lo) * scale
    ids = [str(nodes[k]) for k in keep]
    keys = [str(geom_names[k]) for k in keep]
    bad = ((np.abs(positions) > MAX_COORDINATE).any(axis=1) | ~np.isfinite(sizes).all(axis=1)
           | (sizes < 0).any(axis=1) | (sizes > MAX_COORDINATE).any(axis=1)
           | rotation_errors(rot, RIGID_TOLERANCE)[2])
    for i in np.flatnonzero(bad).tolist():  # the per-node construction raises its error
        pose = np.eye(4)
        pose[:3, :3], pose[:3, 3] = rot[i], positions[i]
        ObjectModel(ids[i], types[i], pose, sizes[i], keys[i])
    checked: set[str] = set()
    for oid, key in zip(ids, keys, strict=True):
        _checks.name_string("ObjectModel.id", oid)
        if key not in checked:
            checked.add(_checks.name_string(f"ObjectModel {oid!r} geometry", key))
    _check_unique_ids(ids, "objects")
    class_vertices: dict[str, NDArray[np.float64]] = {}
    for i, k in enumerate(keep):  # the first node of each geometry scales its class vertices
        key = keys[i]
        if key not in class_vertices:
            verts = np.asarray(geometries[k].vertices, dtype=np.float64)
            class_vertices[key] = (verts - centre[i]) * scale[i]
    type_names, codes = np.unique(np.array(types, dtype=object), return_inverse=True)
    geometry_names, geometry_codes = np.unique(np.array(keys, dtype=object), return_inverse=True)
    table = ObjectTable._trusted(tuple(str(t) for t in type_names), codes.reshape(-1), positions, sizes,
                                 tuple(ids), None, rot, tuple(str(g) for g in geometry_names),
                                 geometry_codes.reshape(-1))
    return table, class_vertices, mirrored
