"""How a :class:`~worldgraph.model.WorldModel` is made: the checks and derived arrays of a new
world (``__post_init__``), the test for coincident same-type objects its link tables run, and
the builders :meth:`~worldgraph.model.WorldModel.from_arrays` (bare typed positions),
:meth:`~worldgraph.model.WorldModel.from_trimesh` (a :class:`trimesh.Scene`) and
:meth:`~worldgraph.model.WorldModel.from_file` (a scene file) call; ``world`` and ``cls`` are
a WorldModel and its class (not imported: the world module imports this one)."""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import TYPE_CHECKING, Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from .. import _checks
from ..errors import WorldGraphError
from ..tolerances import COINCIDENT_TOLERANCE
from .links import MAX_LINK_LENGTH
from .objects import (
    DEFAULT_SIZE,
    MAX_COORDINATE,
    ObjectModel,
    ObjectTable,
    _check_type_name,
    _check_unique_ids,
    _name_list,
    box_vertices,
)
from .scene_files import typed_scene, z_up_from
from .scene_nodes import (
    ROOM_TYPES,
    _check_room,
    _fast_vertex_bounds,
    _geometry_nodes,
    _likely_up,
    _room_from_bounds,
    _scene_nodes,
    _trimesh_table,
    _world_bounds,
    check_scene,
    default_type,
)

if TYPE_CHECKING:  # pragma: no cover
    import trimesh

    import radialopt


def _init_world(world: Any) -> None:
    """The body of ``WorldModel.__post_init__``."""
    object.__setattr__(world, "room", _check_room(world.room))
    if not isinstance(world.gravity_aligned, bool | np.bool_):
        raise WorldGraphError(f"gravity_aligned must be a bool, "
                              f"got {_checks._short(world.gravity_aligned)}")
    object.__setattr__(world, "gravity_aligned", bool(world.gravity_aligned))
    table = world.objects if isinstance(world.objects, ObjectTable) else None
    objects: Sequence[ObjectModel]
    if table is not None:  # checked when the table was made
        objects = table
    else:
        if isinstance(world.objects, str | bytes | Mapping) or not isinstance(world.objects, Iterable):
            raise WorldGraphError("objects must be a sequence of ObjectModel, got "
                                  f"{_checks._short(world.objects)}")
        try:
            objects = tuple(world.objects)
        except TypeError as exc:
            raise WorldGraphError("objects must be a sequence of ObjectModel, got "
                                  f"{_checks._short(world.objects)}") from exc
    if not len(objects):
        raise WorldGraphError("objects must hold at least one object (an ObjectModel), got 0")
    if world.scene is not None:
        check_scene(world.scene)
    if table is None:
        for k, obj in enumerate(objects):
            if not isinstance(obj, ObjectModel):
                raise WorldGraphError(f"objects[{k}] must be an ObjectModel, got {type(obj).__name__}")
        _check_unique_ids([o.id for o in objects], "objects")
    mll = _checks.real_scalar("max_link_length", world.max_link_length, positive=True,
                              maximum=MAX_LINK_LENGTH)
    margin = _checks.real_scalar("link_margin", world.link_margin, minimum=0.0, maximum=MAX_LINK_LENGTH)
    if mll + margin > MAX_LINK_LENGTH:
        raise WorldGraphError(f"max_link_length + link_margin = {mll + margin!r} must be "
                              f"<= {MAX_LINK_LENGTH:g}")
    if not isinstance(world.class_vertices, Mapping):
        raise WorldGraphError("class_vertices must be a mapping geometry key -> (k, 3) vertices, got "
                              f"{_checks._short(world.class_vertices)}")
    cv: dict[str, NDArray[np.float64]] = {}
    for key, verts in world.class_vertices.items():
        _checks.name_string(f"class_vertices key {key!r}", key)
        v = _checks.real_array(f"class_vertices[{key!r}]", verts, (None, 3), max_abs=MAX_COORDINATE,
                               min_size=1)
        v.setflags(write=False)
        cv[key] = v
    if table is not None and table.geometry_names is None:  # a table's geometry keys are its types
        used = np.flatnonzero(np.bincount(table.codes)).tolist()  # (not np.unique: 1M codes, 0.4 s)
        missing = [(table.id(int(np.argmax(table.codes == c))), table.type_names[c])
                   for c in used if table.type_names[c] not in cv]
    elif table is not None:
        gnames, gcodes = table.geometry_names, table.geometry_codes
        assert gnames is not None and gcodes is not None  # set together
        missing = [(table.id(int(np.argmax(gcodes == c))), gnames[c])
                   for c in np.flatnonzero(np.bincount(gcodes)).tolist() if gnames[c] not in cv]
    else:
        missing = [(o.id, o.geometry) for o in objects if o.geometry not in cv]
    if missing:
        oid, geometry = missing[0]
        raise WorldGraphError(f"object {oid!r} has geometry {geometry!r}, which is not "
                              f"a key of class_vertices {sorted(cv)[:10]}")
    object.__setattr__(world, "objects", objects)
    object.__setattr__(world, "max_link_length", mll)
    object.__setattr__(world, "link_margin", margin)
    object.__setattr__(world, "class_vertices", cv)

    if table is not None:
        types = table.types
        positions = table.positions
    else:
        types = np.array([o.type for o in objects], dtype=str)
        positions = np.array([o.pose[:3, 3] for o in objects], dtype=np.float64).reshape(len(objects), 3)
    types.setflags(write=False)
    positions.setflags(write=False)
    object.__setattr__(world, "_types", types)
    object.__setattr__(world, "_positions", positions)
    world._build_links()


def _coincident(world: Any, a: int, b: int, distance: float) -> WorldGraphError:
    """The body of ``WorldModel._coincident``."""
    a, b = sorted((int(a), int(b)))
    return WorldGraphError(
        f"objects[{a}] ({world.objects[a].id!r}) and objects[{b}] ({world.objects[b].id!r}) of type "
        f"{world.objects[a].type!r} coincide at position {world._positions[a].tolist()} (distance "
        f"{distance:.3g} m <= {COINCIDENT_TOLERANCE:g} m)")


def _check_coincident(world: Any, codes: NDArray[np.intp]) -> None:
    """The body of ``WorldModel._check_coincident``."""
    pos = world._positions
    n = len(pos)
    if n < 2:
        return
    order = np.lexsort((pos[:, 2], pos[:, 1], pos[:, 0], codes))
    same = (codes[order[1:]] == codes[order[:-1]]) & np.all(pos[order[1:]] == pos[order[:-1]], axis=1)
    if same.any():
        k = int(np.argmax(same))
        raise world._coincident(order[k], order[k + 1], 0.0)
    lifted = np.column_stack([pos, codes.astype(np.float64) * (4.0 * MAX_COORDINATE)])
    dist, idx = cast(tuple[NDArray[np.float64], NDArray[np.intp]],  # k=2: arrays, not scalars
                     cKDTree(lifted).query(lifted, k=2, distance_upper_bound=2 * COINCIDENT_TOLERANCE))
    hit = dist[:, 1] <= COINCIDENT_TOLERANCE
    if hit.any():
        a = int(np.argmax(hit))
        # both neighbours may be at distance 0 (underflow), so the first is not always ``a``
        b = int(idx[a, 0]) if int(idx[a, 1]) == a else int(idx[a, 1])
        raise world._coincident(a, b, float(dist[a, 1]))


def _from_arrays(cls: Any, types: Sequence[str] | ArrayLike, positions: ArrayLike, max_link_length: float,
                 ids: Sequence[str] | None, sizes: ArrayLike | None, link_margin: float, room: Any,
                 gravity_aligned: bool) -> Any:
    """The body of :meth:`WorldModel.from_arrays <worldgraph.model.WorldModel.from_arrays>` before
    its units warning."""
    pos = _checks.real_array("positions", positions, (None, 3), max_abs=MAX_COORDINATE)
    n = pos.shape[0]
    if n == 0:
        raise WorldGraphError("positions must hold at least one object, got shape (0, 3)")
    type_list = _name_list("types", types, n)
    if sizes is None:
        sz = np.full((n, 3), DEFAULT_SIZE)
    else:
        sz = _checks.real_array("sizes", sizes, None, max_abs=MAX_COORDINATE)
        if sz.shape == (3,):
            sz = np.broadcast_to(sz, (n, 3))
        if sz.shape != (n, 3):
            raise WorldGraphError(f"sizes must have shape ({n}, 3) or (3,), got shape {sz.shape}")
        if np.any(sz < 0):
            bad = np.argwhere(sz < 0)[0]
            raise WorldGraphError(f"sizes[{bad[0]}, {bad[1]}] must be >= 0, "
                                  f"got {float(sz[tuple(bad)])!r}")
    id_list: tuple[str, ...] | None = None
    if ids is not None:  # the default ids f"{type}_{k}" are unique: k is
        id_list = tuple(_name_list("ids", ids, n))
        _check_unique_ids(list(id_list), "ids")
    names, codes = np.unique(np.array(type_list, dtype=object), return_inverse=True)
    codes = codes.reshape(-1)
    by_type = np.argsort(codes, kind="stable")
    starts = np.searchsorted(codes[by_type], np.arange(len(names) + 1))
    class_vertices = {}
    for c, t in enumerate(names.tolist()):
        rows = by_type[starts[c]:starts[c + 1]]
        class_vertices[t] = box_vertices(DEFAULT_SIZE * np.ones(3) if sizes is None
                                         else np.median(sz[rows], axis=0))
    table = ObjectTable._trusted(tuple(str(t) for t in names), codes, np.array(pos, dtype=np.float64),
                                 np.array(sz, dtype=np.float64), id_list)
    world = cls(table, max_link_length=max_link_length, class_vertices=class_vertices,
                link_margin=link_margin, room=room, gravity_aligned=gravity_aligned)
    return world


def _from_trimesh(cls: Any, scene: trimesh.Scene, type_of: Callable[[str, Any], str | None] | None,
                  max_link_length: float, link_margin: float, room: radialopt.Region | str | None) -> Any:
    """The body of :meth:`WorldModel.from_trimesh <worldgraph.model.WorldModel.from_trimesh>`
    before its units warning (its warnings, at stacklevel 3, name the method's caller)."""
    check_scene(scene)
    if type_of is not None and not callable(type_of):
        raise WorldGraphError(f"type_of must be a callable or None, got {_checks._short(type_of)}")
    auto = isinstance(room, str)
    region: radialopt.Region | None = None
    if auto:
        if room != "auto":
            raise WorldGraphError(f"room must be 'auto', a radialopt.Region or None, got {room!r}")
        meta = getattr(scene, "metadata", None) or {}
        if isinstance(meta, Mapping) and meta.get("room") is not None:
            region, auto = _check_room(meta["room"], 'scene.metadata["room"]'), False
    else:
        region = _check_room(room)
    nodes, matrices, geom_names, geometries = _scene_nodes(scene)
    # one pass over the nodes for what needs Python (types, vertex bounds per geometry), then arrays
    found: dict[str, list[NDArray[np.float64]]] = {t: [] for t in ROOM_TYPES}
    bounds_of: dict[str, NDArray[np.float64] | None] = {}
    keep: list[int] = []
    types: list[str] = []
    checked_types: set[str] = set()
    empty: list[str] = []
    for k, (node, geom_name, geometry) in enumerate(zip(nodes, geom_names, geometries, strict=True)):
        if geom_name in bounds_of:
            bounds = bounds_of[geom_name]
        else:
            bounds = bounds_of[geom_name] = _fast_vertex_bounds(f"vertices of geometry {geom_name!r}",
                                                                geometry)
        default = default_type(scene, node, geometry) if auto or type_of is None else None
        if auto and bounds is not None and isinstance(default, str) and default in found:
            found[default].append(_world_bounds(matrices[k], bounds))
        if bounds is None:  # an empty Trimesh or PointCloud: nothing to perceive
            empty.append(str(node))
            continue
        if type_of is not None:
            try:
                typ = type_of(node, geometry)
            except Exception as exc:
                raise WorldGraphError(f"type_of({node!r}, geometry) raised "
                                      f"{type(exc).__name__}: {exc}") from exc
        else:
            typ = default
        if typ is None:
            continue
        if type(typ) is not str or typ not in checked_types:
            checked_types.add(_check_type_name(typ, f"type of node {node!r}"))
        keep.append(k)
        types.append(typ)
    if auto:
        region = _room_from_bounds(found)
    if empty:
        warnings.warn(f"from_trimesh: {len(empty)} geometry node(s) without vertices skipped (trimesh "
                      f"drops non-finite vertices when a mesh is made): {empty[:5]}", UserWarning,
                      stacklevel=3)
    table, class_vertices, mirrored = _trimesh_table(nodes, matrices, geom_names, geometries, bounds_of,
                                                     keep, types)
    if mirrored:
        warnings.warn(f"from_trimesh: {len(mirrored)} node(s) with a reflecting transform taken as the "
                      "proper rotation with one axis mirrored (position and size exact, class vertices "
                      f"not mirrored): {mirrored[:5]}", UserWarning, stacklevel=3)
    if table is None:
        raise WorldGraphError("scene has no typed geometry nodes with vertices (a WorldModel needs one)")
    world = cls(table, max_link_length=max_link_length, class_vertices=class_vertices, scene=scene,
                link_margin=link_margin, room=region)
    return world


def _from_file(cls: Any, path: str | os.PathLike[str], type_of: Any, max_link_length: float,
               link_margin: float, room: Any, mjcf_objects: str, file_format: str | None,
               up_axis: str | None) -> Any:
    """The body of :meth:`WorldModel.from_file <worldgraph.model.WorldModel.from_file>` (its
    warning, at stacklevel 3, names the method's caller)."""
    scene, types = typed_scene(path, type_of, mjcf_objects=mjcf_objects, file_format=file_format,
                               up_axis=up_axis)
    def build(room: Any) -> Any:
        return cls.from_trimesh(scene, type_of=lambda node, _geometry: types.get(str(node)),
                                max_link_length=max_link_length, link_margin=link_margin, room=room)

    hint = _on_its_side(scene, _typed_origins(scene, types), str(path))
    if hint is None:
        return build(room)
    try:
        world = build(room)
    except WorldGraphError as exc:
        if not (isinstance(room, str) and room == "auto"):
            raise type(exc)(f"{exc}; {hint}") from exc
        world = build(None)  # the room of floor and walls on their side is no box
        hint += "; the world's room is left unset (its floor and walls give no valid box this way up)"
    warnings.warn(hint, UserWarning, stacklevel=3)
    return world


def _typed_origins(scene: trimesh.Scene, types: Mapping[str, Any]) -> NDArray[np.float64]:
    """World origins ``(n, 3)`` of the typed nodes of ``scene`` (before a world is built)."""
    rows = [m[:3, 3] for node, m, _, _ in _geometry_nodes(scene) if str(node) in types]
    return np.array(rows, dtype=np.float64).reshape(-1, 3)


def _on_its_side(scene: trimesh.Scene, positions: NDArray[np.float64], path: str) -> str | None:
    """The warning of :meth:`WorldModel.from_file` for a world that looks like a room on its
    side (``_likely_up``), naming the ``up_axis`` to pass;
    ``None`` when z looks up."""
    found = _likely_up(scene, positions)
    if found is None:
        return None
    up, why = found
    read = str(scene.metadata.get("up_axis", "+z"))
    in_file = z_up_from(read)[:3, :3].T @ up
    k = int(np.argmax(np.abs(in_file)))
    axis = ("+" if in_file[k] > 0 else "-") + "xyz"[k]
    sure = "" if "floor" in why else f" (or {'-' if axis[0] == '+' else '+'}{axis[1]})"
    return (f"{path}: read with up_axis={read!r}, the world looks like a room on its side: {why}; the "
            f"file's up axis is probably {axis!r}{sure}: pass up_axis={axis!r} to WorldModel.from_file "
            "(glTF files are +Y up by the specification, but some exporters write z up)")
