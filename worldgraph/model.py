"""The world model: typed objects, their proximity graph and the link look-up table.

A :class:`WorldModel` holds the landmarks the robot can perceive (doors, handles, knobs, ...),
each an :class:`ObjectModel` with a type, a pose ``world_from_object`` and the extents of its
bounding box.  From the object positions it builds

* ``links``: for every (sorted) pair of types with at least one link a :class:`LinkTable` of
  the object pairs closer than ``max_link_length + link_margin``, sorted by length -- the
  paper's distance look-up table (section 2.2, "Fast performance was achieved by using a
  distance lookup table"), queried with :meth:`LinkTable.in_range` by binary search; a sorted
  pair of types without links reads as an empty table (memory linear in the links, not
  quadratic in the number of types);
* ``graph``: a :mod:`networkx` graph, one node per object, one edge per pair closer than
  ``max_link_length`` (built lazily on first access);
* ``type_index``: the object indices of each type.

Limits (checked, :class:`~worldgraph.errors.WorldGraphError` subclasses naming the argument, the
index and the value): poses rigid; coordinates, sizes and vertices at most
:data:`MAX_COORDINATE` = 1e6 m in absolute value; ``max_link_length + link_margin`` at most
:data:`MAX_LINK_LENGTH` = 1e7 m; ids, types and geometry keys non-empty strings without NUL.
Two objects of one type closer than :data:`COINCIDENT_TOLERANCE` raise
:class:`~worldgraph.errors.CoincidentObjectsError` at the first such pair found (memory O(n)).

Object frame: the origin is the centre of the object's bounding box, so
``ObjectModel.position == pose[:3, 3]``; ``size`` is the box extents along the object axes.

File format (:meth:`WorldModel.save` / :meth:`WorldModel.load`), JSON, meant to be edited::

    {
      "format": "worldgraph.WorldModel",
      "version": 1,
      "max_link_length": 5.0,          # metres, > 0
      "link_margin": 0.0,              # metres, >= 0 (links are built up to the sum)
      "class_vertices": {              # geometry key -> list of [x, y, z] in the object frame
        "handle_bar": [[-0.06, -0.01, -0.01], ...]
      },
      "objects": [                     # one per landmark
        {"id": "handle_000", "type": "handle",
         "pose": [[1, 0, 0, 2.0], [0, 1, 0, 0.5], [0, 0, 1, 0.9], [0, 0, 0, 1]],
         "size": [0.12, 0.02, 0.02], "geometry": "handle_bar"}
      ],
      "room": {"lower": [0, 0, 0], "upper": [4, 3, 2.6]}   # optional, null or absent: no room
    }

Every object's ``geometry`` must be a key of ``class_vertices``.  ``room`` (the free space of the
room, an axis-aligned box, :attr:`WorldModel.room`) is written only when it is set; files
without it read as ``room = None``.
"""

from __future__ import annotations

import itertools
import json
import math
import os
import warnings
from collections.abc import Callable, Collection, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any, cast

import networkx as nx
import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from . import _checks, _rigid, ring_join
from .errors import (
    ArgumentTypeError,
    CoincidentObjectsError,
    EmptyWorldError,
    MalformedFileError,
    NonPositiveError,
    OutOfRangeError,
    ShapeError,
    UnknownGeometryError,
    UnknownTypeError,
    WorldGraphError,
)
from .scene_files import typed_scene
from .tolerances import COINCIDENT_TOLERANCE, FAR_PAIR_SLACK, QUERY_WIDEN, RIGID_TOLERANCE  # noqa: F401 - re-exported

if TYPE_CHECKING:  # pragma: no cover
    import trimesh

    import radialopt

__all__ = [
    "COINCIDENT_TOLERANCE",
    "DEFAULT_SIZE",
    "FILE_FORMAT",
    "FILE_VERSION",
    "DEFAULT_ROOM_HEIGHT",
    "MAX_COORDINATE",
    "MAX_LINK_LENGTH",
    "LinkTable",
    "ObjectModel",
    "ROOM_TYPES",
    "WorldModel",
    "box_vertices",
    "room_from_trimesh",
]

FILE_FORMAT = "worldgraph.WorldModel"
FILE_VERSION = 1
#: Bounding-box extents (metres) given to objects built from bare positions.
DEFAULT_SIZE = 0.05
#: Largest allowed ``|coordinate|`` (metres) of an object position, a box size, a class-geometry
#: vertex or a room corner: beyond it squared distances lose every digit (and overflow past 1e154).
MAX_COORDINATE = 1e6
#: Largest allowed ``max_link_length + link_margin`` (metres): above every distance in a world
#: that respects :data:`MAX_COORDINATE`.
MAX_LINK_LENGTH = 1e7
_LAST_ROW = np.array([0.0, 0.0, 0.0, 1.0])


def box_vertices(size: ArrayLike) -> NDArray[np.float64]:
    """The 8 corners ``(8, 3)`` of an axis-aligned box of extents ``size (3,)`` (metres, finite,
    ``>= 0``, at most :data:`MAX_COORDINATE`) centred at 0."""
    half = 0.5 * _check_size("size", size)
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=np.float64)
    return signs * half


def _check_size(name: str, value: Any) -> NDArray[np.float64]:
    """A box size ``(3,)`` in metres: finite, ``>= 0``, at most :data:`MAX_COORDINATE`."""
    size = _checks.float_array(name, value, (3,), max_abs=MAX_COORDINATE)
    if (size < 0).any():
        k = int(np.argmax(size < 0))
        raise NonPositiveError(f"{name}[{k}] must be >= 0, got {float(size[k])!r}")
    return size


def _rotation_errors(rot: NDArray[np.float64]
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """``(max |R^T R - I|, det R, improper)`` of each rotation of a stack ``(n, 3, 3)``;
    ``improper`` where either is off by more than :data:`~worldgraph.tolerances.RIGID_TOLERANCE`."""
    if not len(rot):
        return np.zeros(0), np.ones(0), np.zeros(0, dtype=bool)
    orth = np.abs(np.einsum("nji,njk->nik", rot, rot) - np.eye(3)).max(axis=(1, 2))
    det = np.linalg.det(rot)
    return orth, det, ~((orth <= RIGID_TOLERANCE) & (np.abs(det - 1.0) <= RIGID_TOLERANCE))


def _check_rotations(name: str, rot: NDArray[np.float64]) -> None:
    """Raise :class:`~worldgraph.errors.NonRigidError` naming the first rotation of a finite stack
    ``(n, 3, 3)`` that is not proper within :data:`~worldgraph.tolerances.RIGID_TOLERANCE`."""
    orth, det, bad = _rotation_errors(rot)
    if bad.any():
        from .errors import NonRigidError

        k = int(np.argmax(bad))
        kind = "a reflection" if det[k] < 0 else "scaled or sheared"
        raise NonRigidError(f"{name}[{k}] must be a rotation (R^T R = I, det R = +1), but it is {kind}: "
                            f"det R = {float(det[k]):.6g}, max |R^T R - I| = {float(orth[k]):.3g} "
                            f"(tolerance {RIGID_TOLERANCE:g})")


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
        raise ArgumentTypeError(f"{what} must be a radialopt.Region, a (lower, upper) pair or None, "
                                f"got {_checks._short(room)}")
    lower = _checks.float_array(f"{what} lower", lower, (3,), max_abs=MAX_COORDINATE)
    upper = _checks.float_array(f"{what} upper", upper, (3,), max_abs=MAX_COORDINATE)
    if isinstance(room, Region):
        return room
    try:
        return Region(lower, upper)
    except ro_errors.RadialError as exc:
        raise WorldGraphError(f"{what} = {_checks._short(room)} is not a valid box: {exc}") from exc


def _default_type(scene: trimesh.Scene, node: str, geometry: Any) -> Any:
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


def _check_scene(scene: Any) -> None:
    try:
        import trimesh as _trimesh
    except ImportError as exc:  # pragma: no cover
        from .errors import ImporterError
        raise ImporterError("from_trimesh needs trimesh: pip install trimesh") from exc
    if not isinstance(scene, _trimesh.Scene):
        raise ArgumentTypeError(f"scene must be a trimesh.Scene, got {_checks._short(scene)}")
    from .errors import ImporterError

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
        m = _checks.float_array(f"transform of scene node {node!r}", matrix, (4, 4), max_abs=MAX_COORDINATE)
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
    return _checks.float_array(name, raw, (None, 3), max_abs=MAX_COORDINATE, min_size=1)


def _scene_nodes(scene: trimesh.Scene) -> tuple[list[Any], NDArray[np.float64], list[str], list[Any]]:
    """What :func:`_geometry_nodes` yields, as lists and one ``(n, 4, 4)`` array of transforms
    checked together (the first bad one raises the error of :func:`_geometry_nodes`)."""
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
            _checks.float_array(f"transform of scene node {node!r}", matrix, (4, 4), max_abs=MAX_COORDINATE)
        raise WorldGraphError("scene node transforms must be finite (4, 4) arrays")  # pragma: no cover
    return nodes, stack, geom_names, geometries


def _fast_vertex_bounds(name: str, geometry: Any) -> NDArray[np.float64] | None:
    """:func:`_vertex_bounds` without copying float vertices: the bounds are checked instead of
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
    """:func:`_rotation_and_scale` of a stack ``(n, 3, 3)`` (the same numbers, batched)."""
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
    _check_scene(scene)
    meta = getattr(scene, "metadata", None) or {}
    if isinstance(meta, Mapping) and meta.get("room") is not None:
        return _check_room(meta["room"], 'scene.metadata["room"]')
    found: dict[str, list[NDArray[np.float64]]] = {t: [] for t in ROOM_TYPES}
    for node, matrix, geom_name, geometry in _geometry_nodes(scene):
        typ = _default_type(scene, node, geometry)
        if isinstance(typ, str) and typ in found:
            bounds = _vertex_bounds(f"vertices of geometry {geom_name!r}", geometry)
            if bounds is not None:
                found[typ].append(_world_bounds(matrix, bounds))
    return _room_from_bounds(found)


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


def _check_unique_ids(ids: list[str], what: str) -> None:
    """Raise naming the first repeated id and both of its indices."""
    first: dict[str, int] = {}
    for k, x in enumerate(ids):
        if x in first:
            raise WorldGraphError(f"ids must be unique: {x!r} appears more than once, at {what}[{first[x]}] "
                                  f"and {what}[{k}]")
        first[x] = k


def _name_list(name: str, value: Any, n: int, error: type[WorldGraphError]) -> list[str]:
    """``n`` names (non-empty ``str`` without NUL) from a sequence or array; one ``str`` is a list of one."""
    if isinstance(value, str):
        value = [value]
    if value is None or isinstance(value, bytes | Mapping) or not isinstance(value, Iterable):
        raise ArgumentTypeError(f"{name} must be a sequence of {n} strings, got {_checks._short(value)}")
    items = value.reshape(-1).tolist() if isinstance(value, np.ndarray) else list(value)
    if len(items) != n:
        raise ShapeError(f"{name} must have length {n} to match positions of shape ({n}, 3), "
                         f"got length {len(items)}")
    return [str(_checks.name_string(f"{name}[{k}]", x, error)) for k, x in enumerate(items)]


#: Most object pairs a world's link table may hold (about 1 GB of link arrays; a 1M-object campus
#: at 5 m holds about 28 million).
MAX_LINKS = 40_000_000


#: :meth:`WorldModel.far_pairs` holds the pairs up to this far apart (m): two 8 m sensor ranges.
FAR_PAIR_RANGE = 16.0
#: ... and, gravity-aligned, up to this far apart in z (m): the objects of one storey.
FAR_PAIR_HEIGHT = 4.0
#: The association builds a missing far-pair index on first use when True; by default (False)
#: it uses only those built (:meth:`WorldModel.build_far_pairs`) and sends the other far pairs
#: to the compiled ring join (see :meth:`WorldModel._far_pair_index` for the measurements).
FAR_PAIR_BUILD_ON_USE = False
#: One far-pair index holds at most this many pairs (about 16 bytes each) ...
FAR_PAIR_MAX_PAIRS = 30_000_000
#: ... and the indices of one world at most this many together (about 770 MB; beyond: k-d tree
#: queries): a 100k-object building holds all its type pairs (34M pairs), a 1M campus a part.
FAR_PAIR_BUDGET = 48_000_000


@dataclass(frozen=True)
class FarPairIndex:
    """Ordered pairs ``(i[k], j[k])`` (global indices of a type-a and a type-b object, no object
    with itself) sorted by ``key``: the distance, or gravity-aligned the horizontal distance
    with ``dz = z[j] - z[i]``.  float32 keys: callers widen their windows by
    :data:`FAR_PAIR_SLACK` and test the candidates again in float64."""

    key: NDArray[np.float32]
    i: NDArray[np.int32]
    j: NDArray[np.int32]
    dz: NDArray[np.float32] | None

    @property
    def gravity_aligned(self) -> bool:
        """Keyed by the horizontal distance (with ``dz``), not the 3D distance."""
        return self.dz is not None

    def window(self, lo: float, hi: float) -> slice:
        """The slice of the pairs with ``lo - slack <= key <= hi + slack``."""
        # float32 bounds: a float64 one would make numpy convert the whole key array
        a = int(np.searchsorted(self.key, np.float32(lo - FAR_PAIR_SLACK), side="left"))
        b = int(np.searchsorted(self.key, np.float32(hi + FAR_PAIR_SLACK), side="right"))
        return slice(a, max(a, b))


def _far_pair_query(gravity: bool) -> tuple[float, float]:
    """``(z scale, radius)`` of the k-d tree query that holds every far pair."""
    scale = FAR_PAIR_RANGE / FAR_PAIR_HEIGHT if gravity else 1.0
    return scale, FAR_PAIR_RANGE * (math.sqrt(2.0) if gravity else 1.0) * (1.0 + QUERY_WIDEN)


def _far_pair_estimate(world: WorldModel, a: str, b: str, gravity: bool) -> float:
    """How many pairs the query of :func:`_build_far_pairs` returns, from a strided sample of
    ``a``'s objects (at most about 2000), before anything is built (kept with the world:
    :meth:`WorldModel.build_far_pairs` orders by it, then each build checks it)."""
    estimates = world._far_estimates
    if (a, b, gravity) not in estimates:
        scale, radius = _far_pair_query(gravity)
        ta, tb = world.type_tree(a, scale), world.type_tree(b, scale)
        stride = max(1, len(ta.data) // 2000)
        estimates[(a, b, gravity)] = float(cKDTree(ta.data[::stride]).count_neighbors(tb, radius)) * stride
    return estimates[(a, b, gravity)]


#: Objects per block of :func:`_far_type_pairs`' pair enumeration (bounds its memory).
FAR_TYPE_BLOCK = 2048


def _far_type_pairs(world: WorldModel, gravity: bool) -> list[tuple[str, str]]:
    """The type pairs ``(a, b)``, ``a <= b``, with two distinct objects inside the far-pair
    query of each other (:func:`_far_pair_query`): the only ones whose :class:`FarPairIndex`
    is not empty.  One k-d tree over all objects, queried in blocks of :data:`FAR_TYPE_BLOCK`
    objects; its cost follows the object pairs within reach, not the number of type pairs."""
    names = sorted(world.type_index)
    n_types = len(names)
    code = np.empty(len(world), dtype=np.int64)
    for k, t in enumerate(names):
        code[world.type_index[t]] = k
    scale, radius = _far_pair_query(gravity)
    pts = world.positions * np.array([1.0, 1.0, scale])
    tree = cKDTree(pts)
    found: set[int] = set()
    for start in range(0, len(pts), FAR_TYPE_BLOCK):
        near = cKDTree(pts[start:start + FAR_TYPE_BLOCK]).sparse_distance_matrix(tree, radius,
                                                                                  output_type="ndarray")
        i, j = near["i"].astype(np.int64) + start, near["j"].astype(np.int64)
        keep = i != j
        ca, cb = code[i[keep]], code[j[keep]]
        found.update(np.unique(np.minimum(ca, cb) * n_types + np.maximum(ca, cb)).tolist())
    return [(names[k // n_types], names[k % n_types]) for k in sorted(found)]


def _empty_far_pairs(gravity: bool) -> FarPairIndex:
    """The index of a type pair without objects in reach of each other."""
    return FarPairIndex(key=np.zeros(0, np.float32), i=np.zeros(0, np.int32), j=np.zeros(0, np.int32),
                        dz=np.zeros(0, np.float32) if gravity else None)


def _build_far_pairs(world: WorldModel, a: str, b: str, gravity: bool) -> FarPairIndex | None:
    """The :class:`FarPairIndex` of types ``a <= b`` (see :meth:`WorldModel.far_pairs`)."""
    # gravity: z scaled so that the ball of radius R sqrt(2) holds every pair with horizontal
    # distance <= R and |dz| <= H; then the exact box is kept
    scale, radius = _far_pair_query(gravity)
    ta, tb = world.type_tree(a, scale), world.type_tree(b, scale)
    ia, ib = world.indices_of(a), world.indices_of(b)
    estimate = _far_pair_estimate(world, a, b, gravity)
    used = world._far_pairs_held[0]  # the pairs the cache holds (a running total, not a sum)
    if estimate > FAR_PAIR_MAX_PAIRS or used + estimate > FAR_PAIR_BUDGET:
        return None
    pairs = ta.sparse_distance_matrix(tb, radius, output_type="ndarray")
    gi, gj = ia[pairs["i"]], ib[pairs["j"]]
    pos = world.positions
    if gravity:
        dv = pos[gj] - pos[gi]
        key = np.hypot(dv[:, 0], dv[:, 1])
        keep = (key <= FAR_PAIR_RANGE) & (np.abs(dv[:, 2]) <= FAR_PAIR_HEIGHT) & (gi != gj)
        dz = dv[keep, 2]
    else:
        key = pairs["v"]
        keep = gi != gj
        dz = None
    key = key[keep]
    order = np.argsort(key, kind="stable")
    return FarPairIndex(key=key[order].astype(np.float32), i=gi[keep][order].astype(np.int32),
                        j=gj[keep][order].astype(np.int32),
                        dz=None if dz is None else dz[order].astype(np.float32))


def _check_path(path: Any) -> str:
    """A file path as ``str`` (:func:`worldgraph._checks.file_path`)."""
    return _checks.file_path("path", path)


def _check_type_name(value: Any, what: str) -> str:
    """A type name: a non-empty ``str`` without NUL characters (numpy string arrays would drop
    trailing NULs and merge types)."""
    return _checks.name_string(what, value, UnknownTypeError)


# ----------------------------------------------------------------------------------------------
# objects
# ----------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class ObjectModel:
    """One landmark of the world model.

    Parameters
    ----------
    id : str
        Unique name (e.g. the scene-graph node name).
    type : str
        Landmark class (``"door"``, ``"handle"``, ``"knob"``, ...); associations match types.
    pose : (4, 4) float
        ``world_from_object``, rigid (rotation orthonormal with determinant +1 within 1e-6, last
        row ``0 0 0 1``: scaled, sheared or reflected poses raise
        :class:`~worldgraph.errors.NonRigidError`); its origin (metres, ``|x| <=``
        :data:`MAX_COORDINATE`) is the centre of the object's bounding box.
    size : (3,) float
        Extents (metres) of the bounding box along the object axes, ``>= 0``, at most
        :data:`MAX_COORDINATE`.
    geometry : str
        Key of the class geometry in :attr:`WorldModel.class_vertices` (e.g. ``"box"``).

    ``id``, ``type`` and ``geometry`` are non-empty strings without NUL characters.
    """

    id: str
    type: str
    pose: NDArray[np.float64]
    size: NDArray[np.float64]
    geometry: str = "box"

    def __post_init__(self) -> None:
        _checks.name_string("ObjectModel.id", self.id)
        _check_type_name(self.type, f"ObjectModel {self.id!r} type")
        _checks.name_string(f"ObjectModel {self.id!r} geometry", self.geometry, UnknownGeometryError)
        pose = _rigid.rigid_transform(f"ObjectModel {self.id!r} pose", self.pose,
                                       max_translation=MAX_COORDINATE)
        pose[3] = _LAST_ROW
        size = _check_size(f"ObjectModel {self.id!r} size", self.size)
        pose.setflags(write=False)
        size.setflags(write=False)
        object.__setattr__(self, "pose", pose)
        object.__setattr__(self, "size", size)

    @classmethod
    def _trusted(cls, id: str, type: str, pose: NDArray[np.float64], size: NDArray[np.float64],
                 geometry: str) -> ObjectModel:
        """Build without validation from read-only float64 arrays the caller has checked."""
        obj = object.__new__(cls)
        fields = {"id": id, "type": type, "pose": pose, "size": size, "geometry": geometry}
        for name, value in fields.items():
            object.__setattr__(obj, name, value)
        return obj

    @property
    def position(self) -> NDArray[np.float64]:
        """Centre of the bounding box in the world frame, ``(3,)``."""
        return self.pose[:3, 3]

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, ObjectModel):
            return NotImplemented
        return (self.id == other.id and self.type == other.type and self.geometry == other.geometry
                and np.array_equal(self.pose, other.pose) and np.array_equal(self.size, other.size))

    __hash__ = None  # type: ignore[assignment]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (the ``objects`` entries of the file format)."""
        return {"id": self.id, "type": self.type, "pose": self.pose.tolist(), "size": self.size.tolist(),
                "geometry": self.geometry}


class ObjectTable(Sequence[ObjectModel]):
    """The objects of a world as arrays, without a Python object per landmark.

    What :meth:`WorldModel.from_arrays` (and so the building and campus scenes) stores: typed
    boxes with the identity rotation whose geometry key is their type; and what
    :meth:`WorldModel.from_trimesh` (and so :meth:`WorldModel.from_file`) stores: boxes with
    their node rotations and geometry keys.  Indexing makes the :class:`ObjectModel` on demand
    (``table[k]``); iterating makes them all, so hot paths read :attr:`codes`,
    :attr:`positions` and :attr:`sizes` instead.  An ``ObjectTable`` equals any sequence of the
    same objects.

    Parameters
    ----------
    type_names : sequence of str
        The distinct types, sorted; non-empty strings without NUL characters.
    codes : (n,) int
        ``type_names[codes[k]]`` is object ``k``'s type.
    positions, sizes : (n, 3) float
        Box centres (metres, ``|x| <=`` :data:`MAX_COORDINATE`) and extents (``>= 0``).
    ids : sequence of str, optional
        Unique object ids; default ``f"{type}_{number}"`` with ``number`` from ``numbers``.
    numbers : (n,) int, optional
        Distinct non-negative numbers of the default ids (default ``0 .. n-1``); ignored when
        ``ids`` is given.
    rotations : (n, 3, 3) float, optional
        ``world_from_object`` rotations (proper: ``R^T R = I`` and ``det R = 1`` within
        :data:`~worldgraph.tolerances.RIGID_TOLERANCE`); default the identity for every
        object (then :attr:`rotations` is ``None``).
    geometries : (n,) str, optional
        Geometry keys (non-empty strings without NUL); default each object's type.

    Attributes
    ----------
    rotations : (n, 3, 3) float ndarray or None
        ``None`` when every rotation is the identity.
    geometry_names : tuple of str or None
        The distinct geometry keys, sorted, with :attr:`geometry_codes` ``(n,)`` indexing them;
        both ``None`` when every object's geometry key is its type.
    """

    __slots__ = ("type_names", "codes", "positions", "sizes", "_ids", "_numbers", "rotations",
                 "geometry_names", "geometry_codes")
    type_names: tuple[str, ...]
    codes: NDArray[np.integer]
    positions: NDArray[np.float64]
    sizes: NDArray[np.float64]
    _ids: tuple[str, ...] | None
    _numbers: NDArray[np.int64] | None
    rotations: NDArray[np.float64] | None
    geometry_names: tuple[str, ...] | None
    geometry_codes: NDArray[np.integer] | None

    def __init__(self, type_names: Sequence[str], codes: ArrayLike, positions: ArrayLike, sizes: ArrayLike,
                 ids: Sequence[str] | None = None, numbers: ArrayLike | None = None, *,
                 rotations: ArrayLike | None = None, geometries: Sequence[str] | None = None) -> None:
        if isinstance(type_names, str | bytes) or not isinstance(type_names, Sequence):
            raise ArgumentTypeError(f"type_names must be a sequence of str, got {_checks._short(type_names)}")
        names = tuple(type_names)
        for k, t in enumerate(names):
            _check_type_name(t, f"type_names[{k}]")
        if list(names) != sorted(set(names)):
            raise WorldGraphError(f"type_names must be sorted and distinct, got {_checks._short(names)}")
        c = _checks.int_array("codes", codes, (None,), minimum=0)
        n = len(c)
        if n and int(c.max()) >= len(names):
            k = int(np.argmax(c >= len(names)))
            raise OutOfRangeError(f"codes[{k}] = {int(c[k])} must be < len(type_names) = {len(names)}")
        pos = _checks.float_array("positions", positions, (n, 3), max_abs=MAX_COORDINATE)
        sz = _checks.float_array("sizes", sizes, (n, 3), max_abs=MAX_COORDINATE)
        if np.any(sz < 0):
            bad = np.argwhere(sz < 0)[0]
            raise NonPositiveError(f"sizes[{bad[0]}, {bad[1]}] must be >= 0, got {float(sz[tuple(bad)])!r}")
        id_list: tuple[str, ...] | None = None
        num = None
        if ids is not None:
            id_list = tuple(_name_list("ids", ids, n, WorldGraphError))
            _check_unique_ids(list(id_list), "ids")
        elif numbers is not None:
            num = _checks.int_array("numbers", numbers, (n,), minimum=0)
            if len(np.unique(num)) != n:
                first = np.unique(num, return_index=True)[1]
                k = int(np.setdiff1d(np.arange(n), first)[0])
                raise WorldGraphError(f"numbers[{k}] = {int(num[k])} repeats an earlier number")
        rot = None
        if rotations is not None:
            rot = _checks.float_array("rotations", rotations, (n, 3, 3))
            _check_rotations("rotations", rot)
        geometry_names, geometry_codes = None, None
        if geometries is not None:
            keys = _name_list("geometries", geometries, n, UnknownGeometryError)
            uniq, inverse = np.unique(np.array(keys, dtype=object), return_inverse=True)
            geometry_names, geometry_codes = tuple(str(g) for g in uniq), inverse.reshape(-1)
        self._set(names, c, pos, sz, id_list, num, rot, geometry_names, geometry_codes)

    def _set(self, names: tuple[str, ...], codes: NDArray[np.integer], positions: NDArray[np.float64],
             sizes: NDArray[np.float64], ids: tuple[str, ...] | None,
             numbers: NDArray[np.integer] | None, rotations: NDArray[np.float64] | None = None,
             geometry_names: tuple[str, ...] | None = None,
             geometry_codes: NDArray[np.integer] | None = None) -> None:
        codes = np.asarray(codes, dtype=np.int32 if len(names) < 2**31 else np.int64)
        if ids is None and numbers is None:
            numbers = np.arange(len(codes), dtype=np.int64)
        if rotations is not None and np.array_equal(rotations, np.broadcast_to(np.eye(3), rotations.shape)):
            rotations = None  # identity everywhere: as from_arrays stores it
        if geometry_names is not None:
            assert geometry_codes is not None  # set together
            geometry_codes = np.asarray(geometry_codes, dtype=np.int32 if len(geometry_names) < 2**31
                                        else np.int64)
            if geometry_names == names and np.array_equal(geometry_codes, codes):
                geometry_names, geometry_codes = None, None  # every geometry key is the type
        optional = (numbers, rotations, geometry_codes)
        arrays = [codes, positions, sizes] + [a for a in optional if a is not None]
        for a in arrays:
            a.setflags(write=False)
        for name, value in (("type_names", names), ("codes", codes), ("positions", positions),
                            ("sizes", sizes), ("_ids", ids), ("_numbers", numbers), ("rotations", rotations),
                            ("geometry_names", geometry_names), ("geometry_codes", geometry_codes)):
            object.__setattr__(self, name, value)

    @classmethod
    def _trusted(cls, names: tuple[str, ...], codes: NDArray[np.integer], positions: NDArray[np.float64],
                 sizes: NDArray[np.float64], ids: tuple[str, ...] | None = None,
                 numbers: NDArray[np.integer] | None = None, rotations: NDArray[np.float64] | None = None,
                 geometry_names: tuple[str, ...] | None = None,
                 geometry_codes: NDArray[np.integer] | None = None) -> ObjectTable:
        """Build without validation from arrays the caller has checked (copies are not made)."""
        table = object.__new__(cls)
        table._set(names, codes, np.asarray(positions, dtype=np.float64), np.asarray(sizes, dtype=np.float64),
                   ids, None if numbers is None else np.asarray(numbers, dtype=np.int64),
                   None if rotations is None else np.asarray(rotations, dtype=np.float64),
                   geometry_names, geometry_codes)
        return table

    def __setattr__(self, name: str, value: Any) -> None:
        raise AttributeError(f"ObjectTable is read-only: cannot set {name!r}")

    def __reduce__(self) -> tuple[Any, ...]:
        # pickling (tiles sent to processes or a Dask cluster): rebuilt by _trusted, not setattr
        return (ObjectTable._trusted, (self.type_names, self.codes, self.positions, self.sizes, self._ids,
                                       self._numbers, self.rotations, self.geometry_names,
                                       self.geometry_codes))

    def __len__(self) -> int:
        return len(self.codes)

    def id(self, k: int) -> str:
        """The id of object ``k``."""
        if self._ids is not None:
            return self._ids[k]
        assert self._numbers is not None  # one of the two is always set
        return f"{self.type_names[int(self.codes[k])]}_{int(self._numbers[k])}"

    def __getitem__(self, key: Any) -> Any:
        if isinstance(key, slice):
            return self.take(np.arange(len(self))[key])
        try:
            k = int(key.__index__())
        except (AttributeError, TypeError):
            raise ArgumentTypeError(f"an ObjectTable index must be an int or a slice, "
                                    f"got {_checks._short(key)}") from None
        n = len(self)
        if not -n <= k < n:
            raise IndexError(f"object index {k} out of range for {n} objects")
        k %= n
        pose = np.eye(4)
        if self.rotations is not None:
            pose[:3, :3] = self.rotations[k]
        pose[:3, 3] = self.positions[k]
        pose.setflags(write=False)
        size = self.sizes[k].copy()
        size.setflags(write=False)
        t = self.type_names[int(self.codes[k])]
        return ObjectModel._trusted(self.id(k), t, pose, size, self._geometry(k))

    def _geometry(self, k: int) -> str:
        if self.geometry_names is None:
            return self.type_names[int(self.codes[k])]
        assert self.geometry_codes is not None  # set together
        return self.geometry_names[int(self.geometry_codes[k])]

    def take(self, index: ArrayLike) -> ObjectTable:
        """The objects at ``index`` (an int array, in that order) as a new table; ids kept."""
        n = len(self)
        idx = _object_index(index, n, -n) % max(n, 1)
        ids = None if self._ids is None else tuple(self._ids[k] for k in idx.tolist())
        numbers = None if self._numbers is None else self._numbers[idx]
        rotations = None if self.rotations is None else self.rotations[idx]
        gcodes = None if self.geometry_codes is None else self.geometry_codes[idx]
        return ObjectTable._trusted(self.type_names, self.codes[idx], self.positions[idx], self.sizes[idx],
                                    ids, numbers, rotations, self.geometry_names, gcodes)

    @property
    def types(self) -> NDArray[np.str_]:
        """``(n,)`` the objects' types."""
        return np.asarray(self.type_names, dtype=str)[self.codes]

    @property
    def geometries(self) -> NDArray[np.str_]:
        """``(n,)`` the objects' geometry keys."""
        if self.geometry_names is None:
            return self.types
        return np.asarray(self.geometry_names, dtype=str)[self.geometry_codes]

    def rotation_array(self) -> NDArray[np.float64]:
        """``(n, 3, 3)`` the objects' rotations (a new array; identities when :attr:`rotations`
        is ``None``)."""
        if self.rotations is None:
            return np.tile(np.eye(3), (len(self), 1, 1))
        return self.rotations.copy()

    def __eq__(self, other: object) -> bool:
        if isinstance(other, ObjectTable):
            if (len(self) != len(other) or not np.array_equal(self.positions, other.positions)
                    or not np.array_equal(self.sizes, other.sizes)
                    or not np.array_equal(self.types, other.types)
                    or not np.array_equal(self.geometries, other.geometries)):
                return False
            if (self.rotations is not None or other.rotations is not None) \
                    and not np.array_equal(self.rotation_array(), other.rotation_array()):
                return False
            if self._ids is None and other._ids is None and self._numbers is not None \
                    and other._numbers is not None:
                return bool(np.array_equal(self._numbers, other._numbers))
            return all(self.id(k) == other.id(k) for k in range(len(self)))
        if isinstance(other, Sequence) and not isinstance(other, str | bytes):
            return len(self) == len(other) and all(a == b for a, b in zip(self, other, strict=True))
        return NotImplemented

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return f"ObjectTable({len(self)} objects of {len(self.type_names)} types)"


# ----------------------------------------------------------------------------------------------
# link table
# ----------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class LinkTable:
    """Object pairs of one type pair, sorted by length: the paper's distance look-up table.

    For a type pair ``(a, b)`` with ``a < b`` each row holds ``(object of type a, object of
    type b)``; for ``(a, a)`` each unordered pair appears once with ``i < j``.  Indices are
    indices into :attr:`WorldModel.objects` (global object indices).

    Parameters
    ----------
    i, j : (k,) int
    length : (k,) float
        ``|positions[i] - positions[j]|``, non-decreasing.
    """

    i: NDArray[np.intp]
    j: NDArray[np.intp]
    length: NDArray[np.float64]

    def __post_init__(self) -> None:
        i = _checks.int_array("LinkTable i", self.i, (None,), minimum=0)
        j = _checks.int_array("LinkTable j", self.j, (None,), minimum=0)
        length = _checks.float_array("LinkTable length", self.length, (None,))
        if not (i.shape == j.shape == length.shape):
            raise ShapeError(f"LinkTable i, j, length must have one shape (k,), got {i.shape}, {j.shape}, "
                             f"{length.shape}")
        if (length < 0).any():
            k = int(np.argmax(length < 0))
            raise NonPositiveError(f"LinkTable length[{k}] must be >= 0, got {float(length[k])!r}")
        if length.size > 1 and (np.diff(length) < 0).any():
            k = int(np.argmax(np.diff(length) < 0))
            raise WorldGraphError(f"LinkTable length must be sorted ascending, but length[{k + 1}] = "
                                  f"{float(length[k + 1])!r} < length[{k}] = {float(length[k])!r}")
        for a in (i, j, length):
            a.setflags(write=False)
        object.__setattr__(self, "i", i)
        object.__setattr__(self, "j", j)
        object.__setattr__(self, "length", length)

    def __len__(self) -> int:
        return int(self.length.size)

    @classmethod
    def _trusted(cls, i: NDArray[np.intp], j: NDArray[np.intp], length: NDArray[np.float64]) -> LinkTable:
        """Build without validation from read-only arrays the caller has checked."""
        table = object.__new__(cls)
        object.__setattr__(table, "i", i)
        object.__setattr__(table, "j", j)
        object.__setattr__(table, "length", length)
        return table

    def in_range(self, lo: float, hi: float,
                 ) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.float64]]:
        """Links with ``lo < length < hi`` (metres; infinite bounds allowed, NaN not) by binary
        search, as ``(i, j, length)`` views."""
        lo = _checks.real_float("lo", lo)
        hi = _checks.real_float("hi", hi)
        start = int(np.searchsorted(self.length, lo, side="right"))
        stop = int(np.searchsorted(self.length, hi, side="left"))
        stop = max(stop, start)
        return self.i[start:stop], self.j[start:stop], self.length[start:stop]


def _link_order(pi: NDArray[np.intp], pj: NDArray[np.intp], length: NDArray[np.float64],
                key: NDArray[np.int64], n: int) -> NDArray[np.intp]:
    """``np.lexsort((pj, pi, length, key))`` (by type pair, then length, then the object
    indices) as three stable sorts, the last on the small type-pair key (a radix sort when it
    fits 16 bits): half the time of the lexsort's four passes (5.5M links: 2.6 s against 5.0 s)."""
    order = np.argsort(pi.astype(np.int64) * n + pj, kind="stable")
    order = order[np.argsort(length[order], kind="stable")]
    small = key.astype(np.int16) if len(key) and int(key.max()) < 2**15 else key
    return order[np.argsort(small[order], kind="stable")]


def _pair_lengths(positions: NDArray[np.float64], i: NDArray[np.intp], j: NDArray[np.intp],
                  chunk: int = 1 << 20) -> NDArray[np.float64]:
    """``|positions[i] - positions[j]|`` in chunks, so that no ``(m, 3)`` temporary is made."""
    out = np.empty(len(i))
    for lo in range(0, len(i), chunk):
        a, b = i[lo:lo + chunk], j[lo:lo + chunk]
        d = positions[a] - positions[b]
        out[lo:lo + chunk] = np.sqrt(np.einsum("ij,ij->i", d, d))
    return out


def _object_index(index: ArrayLike, n: int, minimum: int) -> NDArray[np.intp]:
    """``index`` as an int array of object indices ``minimum <= k < n`` (errors name the entry)."""
    idx = _checks.int_array("index", index, (None,), minimum=minimum)
    if idx.size and int(idx.max()) >= n:
        k = int(np.argmax(idx >= n))
        raise OutOfRangeError(f"index[{k}] = {int(idx[k])} must be < the number of objects, {n}")
    return idx


def _empty_table() -> LinkTable:
    return LinkTable(np.zeros(0, np.intp), np.zeros(0, np.intp), np.zeros(0))


_EMPTY_TABLE = _empty_table()


class _LinkTables(Mapping[tuple[str, str], LinkTable]):
    """``(type_a, type_b) -> LinkTable`` over the type pairs with at least one link.

    All links live in three arrays sorted by type pair, then length; a table is a view of its
    slice, made on access.  Memory is linear in the number of links, whatever the number of
    types (no table per pair of types, no Python object per stored pair).  Iteration yields the
    linked pairs only; looking up a sorted pair ``(a, b)``, ``a <= b``, of types of the model
    that has no links returns an empty :class:`LinkTable`; any other key is a ``KeyError``.
    """

    def __init__(self, names: list[str], pi: NDArray[np.intp], pj: NDArray[np.intp],
                 length: NDArray[np.float64], present: NDArray[np.int64], first: NDArray[np.intp],
                 last: NDArray[np.intp]) -> None:
        self._names = names
        self._code = {t: c for c, t in enumerate(names)}
        self._pi, self._pj, self._length = pi, pj, length
        self._present, self._first, self._last = present, first, last
        for a in (pi, pj, length, present, first, last):
            a.setflags(write=False)

    def _slot(self, key: Any) -> int | None:
        """Index into ``present`` of a linked pair; ``None`` for a sorted pair of known types
        without links; ``KeyError`` otherwise."""
        if not (isinstance(key, tuple) and len(key) == 2 and all(isinstance(t, str) for t in key)):
            raise KeyError(key)
        ca, cb = self._code.get(key[0]), self._code.get(key[1])
        if ca is None or cb is None or ca > cb:
            raise KeyError(key)
        k = ca * len(self._names) + cb
        pos = int(np.searchsorted(self._present, k))
        return pos if pos < len(self._present) and self._present[pos] == k else None

    def __getitem__(self, key: Any) -> LinkTable:
        pos = self._slot(key)
        if pos is None:
            return _EMPTY_TABLE
        s, e = int(self._first[pos]), int(self._last[pos])
        return LinkTable._trusted(self._pi[s:e], self._pj[s:e], self._length[s:e])

    def __contains__(self, key: object) -> bool:
        try:
            return self._slot(key) is not None
        except KeyError:
            return False

    def get(self, key: Any, default: Any = None) -> Any:
        try:
            return self[key]
        except KeyError:
            return default

    def __iter__(self) -> Iterator[tuple[str, str]]:
        nt = len(self._names)
        for k in self._present.tolist():
            a, b = divmod(k, nt)
            yield (self._names[a], self._names[b])

    def __len__(self) -> int:
        return len(self._present)

    def __repr__(self) -> str:
        return f"<link tables: {len(self)} linked type pairs, {len(self._length)} links>"


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
    ``tests/test_importers.py``); a value out of range makes that node's ``ObjectModel`` to
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
           | (sizes < 0).any(axis=1) | (sizes > MAX_COORDINATE).any(axis=1) | _rotation_errors(rot)[2])
    for i in np.flatnonzero(bad).tolist():  # the per-node construction raises its error
        pose = np.eye(4)
        pose[:3, :3], pose[:3, 3] = rot[i], positions[i]
        ObjectModel(ids[i], types[i], pose, sizes[i], keys[i])
    checked: set[str] = set()
    for oid, key in zip(ids, keys, strict=True):
        _checks.name_string("ObjectModel.id", oid)
        if key not in checked:
            checked.add(_checks.name_string(f"ObjectModel {oid!r} geometry", key, UnknownGeometryError))
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


# ----------------------------------------------------------------------------------------------
# world model
# ----------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class WorldModel:
    """Typed landmarks with their proximity graph and link look-up table.

    Parameters
    ----------
    objects : sequence of ObjectModel, or ObjectTable
        Non-empty; ids unique; no two objects of one type at the same position.  An
        :class:`ObjectTable` (what :meth:`from_arrays` gives) keeps large worlds in arrays.
    max_link_length : float
        Pairs closer than this (metres) are graph edges (the paper's ζ for links), ``> 0``;
        ``max_link_length + link_margin <=`` :data:`MAX_LINK_LENGTH`.
    class_vertices : mapping str -> (k, 3) float
        Vertices of each class geometry in the object frame; must hold every object's geometry.
    scene : trimesh.Scene or None
        The scene the model came from (not compared, not saved).
    link_margin : float
        The link tables hold pairs closer than ``max_link_length + link_margin`` (``>= 0``), so
        pairs just above ``max_link_length`` survive percept noise.
    room : radialopt.Region or None
        The room's free space (the robot is inside it): an axis-aligned box, finite, ``lower <=
        upper``; a ``(lower, upper)`` pair is turned into a Region.  Room structure (floor,
        walls, ceiling) need not be objects of the model when the room is known this way.
    gravity_aligned : bool
        The map's own note that its robots report percepts in a levelled ego frame (REP 103:
        base z up, along the world's z); kept and saved with the world.  Whether a call
        searches with gravity is a fact of the robot, given per call: ``associate``,
        ``localize``, ``active_localize`` and ``localize_tiled`` take ``gravity`` (default
        ``"auto"``, :mod:`worldgraph.gravity`) whatever this flag says; only the networkx views
        and the paper's filters (:func:`~worldgraph.filters.consistency_graph`, ...) follow it
        when ``AssociationTolerances.gravity_aligned`` is None.  Default False.

    Attributes
    ----------
    types : (n,) str ndarray
    positions : (n, 3) float ndarray, read-only
    links : dict (str, str) -> LinkTable, keyed by the sorted type pair; only pairs with at least
        one link are stored (iteration), looking up another sorted pair of the model's types
        returns an empty table
    type_index : dict str -> (k,) int, object indices of each type, ascending
    graph : networkx.Graph (lazy)
    """

    objects: Sequence[ObjectModel]
    max_link_length: float = 5.0
    class_vertices: Mapping[str, NDArray[np.float64]] = field(default_factory=dict)
    scene: Any = None
    link_margin: float = 0.0
    room: radialopt.Region | None = None
    gravity_aligned: bool = False
    if TYPE_CHECKING:  # derived data __post_init__ sets on the frozen instance; for the type checker only
        _types: NDArray[np.str_] = field(init=False)
        _positions: NDArray[np.float64] = field(init=False)
        _type_index: dict[str, NDArray[np.intp]] = field(init=False)
        _links: _LinkTables = field(init=False)
        _tree: cKDTree = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "room", _check_room(self.room))
        if not isinstance(self.gravity_aligned, bool | np.bool_):
            raise ArgumentTypeError(f"gravity_aligned must be a bool, "
                                    f"got {_checks._short(self.gravity_aligned)}")
        object.__setattr__(self, "gravity_aligned", bool(self.gravity_aligned))
        table = self.objects if isinstance(self.objects, ObjectTable) else None
        objects: Sequence[ObjectModel]
        if table is not None:  # checked when the table was made
            objects = table
        else:
            if isinstance(self.objects, str | bytes | Mapping) or not isinstance(self.objects, Iterable):
                raise ArgumentTypeError("objects must be a sequence of ObjectModel, got "
                                        f"{_checks._short(self.objects)}")
            try:
                objects = tuple(self.objects)
            except TypeError as exc:
                raise ArgumentTypeError("objects must be a sequence of ObjectModel, got "
                                        f"{_checks._short(self.objects)}") from exc
        if not len(objects):
            raise EmptyWorldError("objects must hold at least one object (an ObjectModel), got 0")
        if self.scene is not None:
            _check_scene(self.scene)
        if table is None:
            for k, obj in enumerate(objects):
                if not isinstance(obj, ObjectModel):
                    raise ArgumentTypeError(f"objects[{k}] must be an ObjectModel, got {type(obj).__name__}")
            _check_unique_ids([o.id for o in objects], "objects")
        mll = _checks.positive_float("max_link_length", self.max_link_length, maximum=MAX_LINK_LENGTH)
        margin = _checks.positive_float("link_margin", self.link_margin, allow_zero=True,
                                        maximum=MAX_LINK_LENGTH)
        if mll + margin > MAX_LINK_LENGTH:
            raise OutOfRangeError(f"max_link_length + link_margin = {mll + margin!r} must be "
                                  f"<= {MAX_LINK_LENGTH:g}")
        if not isinstance(self.class_vertices, Mapping):
            raise ArgumentTypeError("class_vertices must be a mapping geometry key -> (k, 3) vertices, got "
                                    f"{_checks._short(self.class_vertices)}")
        cv: dict[str, NDArray[np.float64]] = {}
        for key, verts in self.class_vertices.items():
            _checks.name_string(f"class_vertices key {key!r}", key, UnknownGeometryError)
            v = _checks.float_array(f"class_vertices[{key!r}]", verts, (None, 3), max_abs=MAX_COORDINATE,
                                    min_size=1)
            v.setflags(write=False)
            cv[key] = v
        if table is not None and table.geometry_names is None:  # a table's geometry keys are its types
            missing = [(table.id(int(np.argmax(table.codes == c))), table.type_names[c])
                       for c in np.unique(table.codes).tolist() if table.type_names[c] not in cv]
        elif table is not None:
            gnames, gcodes = table.geometry_names, table.geometry_codes
            assert gnames is not None and gcodes is not None  # set together
            missing = [(table.id(int(np.argmax(gcodes == c))), gnames[c])
                       for c in np.unique(gcodes).tolist() if gnames[c] not in cv]
        else:
            missing = [(o.id, o.geometry) for o in objects if o.geometry not in cv]
        if missing:
            oid, geometry = missing[0]
            raise UnknownGeometryError(f"object {oid!r} has geometry {geometry!r}, which is not "
                                       f"a key of class_vertices {sorted(cv)[:10]}")
        object.__setattr__(self, "objects", objects)
        object.__setattr__(self, "max_link_length", mll)
        object.__setattr__(self, "link_margin", margin)
        object.__setattr__(self, "class_vertices", cv)

        if table is not None:
            types = table.types
            positions = table.positions
        else:
            types = np.array([o.type for o in objects], dtype=str)
            positions = np.array([o.pose[:3, 3] for o in objects], dtype=np.float64).reshape(len(objects), 3)
        types.setflags(write=False)
        positions.setflags(write=False)
        object.__setattr__(self, "_types", types)
        object.__setattr__(self, "_positions", positions)
        self._build_links()

    # -- construction helpers ------------------------------------------------------------------
    def _coincident(self, a: int, b: int, distance: float) -> CoincidentObjectsError:
        a, b = sorted((int(a), int(b)))
        return CoincidentObjectsError(
            f"objects[{a}] ({self.objects[a].id!r}) and objects[{b}] ({self.objects[b].id!r}) of type "
            f"{self.objects[a].type!r} coincide at position {self._positions[a].tolist()} (distance "
            f"{distance:.3g} m <= {COINCIDENT_TOLERANCE:g} m)")

    def _check_coincident(self, codes: NDArray[np.intp]) -> None:
        """Raise at the first pair of same-type objects closer than :data:`COINCIDENT_TOLERANCE`.

        Memory O(n): exact duplicates by one lexicographic sort, then near duplicates by a
        nearest-neighbour query in a 4D tree whose 4th axis separates the types by more than
        any distance in the world.
        """
        pos = self._positions
        n = len(pos)
        if n < 2:
            return
        order = np.lexsort((pos[:, 2], pos[:, 1], pos[:, 0], codes))
        same = (codes[order[1:]] == codes[order[:-1]]) & np.all(pos[order[1:]] == pos[order[:-1]], axis=1)
        if same.any():
            k = int(np.argmax(same))
            raise self._coincident(order[k], order[k + 1], 0.0)
        lifted = np.column_stack([pos, codes.astype(np.float64) * (4.0 * MAX_COORDINATE)])
        dist, idx = cast(tuple[NDArray[np.float64], NDArray[np.intp]],  # k=2: arrays, not scalars
                         cKDTree(lifted).query(lifted, k=2, distance_upper_bound=2 * COINCIDENT_TOLERANCE))
        hit = dist[:, 1] <= COINCIDENT_TOLERANCE
        if hit.any():
            a = int(np.argmax(hit))
            # both neighbours may be at distance 0 (underflow), so the first is not always ``a``
            b = int(idx[a, 0]) if int(idx[a, 1]) == a else int(idx[a, 1])
            raise self._coincident(a, b, float(dist[a, 1]))

    def _build_links(self) -> None:
        types = self._types
        positions = self._positions
        names, codes = np.unique(types, return_inverse=True)
        codes = codes.reshape(-1).astype(np.intp)
        by_type = np.argsort(codes, kind="stable")
        starts = np.searchsorted(codes[by_type], np.arange(len(names) + 1))
        type_index = {str(t): by_type[starts[c]:starts[c + 1]] for c, t in enumerate(names)}
        for v in type_index.values():
            v.setflags(write=False)

        self._check_coincident(codes)
        tree = cKDTree(positions)

        radius = self.max_link_length + self.link_margin
        n = len(positions)
        if n > 1000:  # a strided sample says how many links the table would hold before it is built
            counts = np.asarray(tree.query_ball_point(positions[:: n // 1000], radius, return_length=True))
            estimate = (float(counts.mean()) - 1.0) * n / 2.0
            if estimate > MAX_LINKS:
                raise OutOfRangeError(
                    f"max_link_length = {self.max_link_length:g} m (+ link_margin {self.link_margin:g} m) "
                    f"would link about {estimate:,.0f} object pairs ({n:,} objects, about "
                    f"{counts.mean() - 1:,.0f} within reach of each), more than {MAX_LINKS:,}: lower "
                    "max_link_length or thin the world")
        # query slightly wide, then filter with the exact strict test below
        pairs = tree.query_pairs(radius * (1.0 + QUERY_WIDEN), output_type="ndarray")
        if pairs.size == 0:
            pairs = np.zeros((0, 2), np.intp)
        pi, pj = pairs[:, 0].astype(np.intp), pairs[:, 1].astype(np.intp)
        del pairs
        length = _pair_lengths(positions, pi, pj)
        keep = length < radius
        if not keep.all():
            pi, pj, length = pi[keep], pj[keep], length[keep]
        del keep
        # orient rows: (type a, type b) with a < b, or i < j for one type
        nt = len(names)
        small = codes.astype(np.int32)
        ci, cj = small[pi], small[pj]
        swap = (ci > cj) | ((ci == cj) & (pi > pj))
        pi, pj = np.where(swap, pj, pi), np.where(swap, pi, pj)
        del swap
        key = np.minimum(ci, cj).astype(np.int64) * nt + np.maximum(ci, cj)
        del ci, cj
        order = _link_order(pi, pj, length, key, n)
        pi, pj, length, key = pi[order], pj[order], length[order], key[order]
        del order
        present, first = np.unique(key, return_index=True)
        last = np.append(first[1:], len(key))[: len(first)]
        links = _LinkTables([str(t) for t in names], pi, pj, length, present.astype(np.int64),
                            first.astype(np.intp), last.astype(np.intp))
        object.__setattr__(self, "_type_index", type_index)
        object.__setattr__(self, "_links", links)
        object.__setattr__(self, "_tree", tree)

    @classmethod
    def from_arrays(cls, types: Sequence[str] | ArrayLike, positions: ArrayLike, max_link_length: float = 5.0,
                    ids: Sequence[str] | None = None, sizes: ArrayLike | None = None,
                    link_margin: float = 0.0, room: Any = None, gravity_aligned: bool = False) -> WorldModel:
        """World model from bare typed positions.

        Parameters
        ----------
        types : (n,) str
            Non-empty strings without NUL characters (kept as Python ``str``).
        positions : (n, 3) float
            World positions (metres), finite, ``|x| <=`` :data:`MAX_COORDINATE`; poses get the
            identity rotation.
        max_link_length, link_margin : float
            See :class:`WorldModel`.
        room : radialopt.Region or (lower, upper), optional
            See :class:`WorldModel`.
        gravity_aligned : bool
            See :class:`WorldModel`.
        ids : (n,) str, optional
            Unique non-empty strings without NUL characters; default ``f"{type}_{k}"`` with ``k``
            the object index.
        sizes : (n, 3) or (3,) float, optional
            Bounding-box extents (metres, ``>= 0``); default :data:`DEFAULT_SIZE` in every axis.

        Each type gets the class geometry of its own name: the corners of a box of the type's
        median size.
        """
        pos = _checks.float_array("positions", positions, (None, 3), max_abs=MAX_COORDINATE)
        n = pos.shape[0]
        if n == 0:
            raise EmptyWorldError("positions must hold at least one object, got shape (0, 3)")
        type_list = _name_list("types", types, n, UnknownTypeError)
        if sizes is None:
            sz = np.full((n, 3), DEFAULT_SIZE)
        else:
            sz = _checks.float_array("sizes", sizes, None, max_abs=MAX_COORDINATE)
            if sz.shape == (3,):
                sz = np.broadcast_to(sz, (n, 3))
            if sz.shape != (n, 3):
                raise ShapeError(f"sizes must have shape ({n}, 3) or (3,), got shape {sz.shape}")
            if np.any(sz < 0):
                bad = np.argwhere(sz < 0)[0]
                raise NonPositiveError(f"sizes[{bad[0]}, {bad[1]}] must be >= 0, "
                                       f"got {float(sz[tuple(bad)])!r}")
        id_list: tuple[str, ...] | None = None
        if ids is not None:  # the default ids f"{type}_{k}" are unique: k is
            id_list = tuple(_name_list("ids", ids, n, WorldGraphError))
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
        return world._warn_units()

    @classmethod
    def from_trimesh(cls, scene: trimesh.Scene, type_of: Callable[[str, Any], str | None] | None = None,
                     max_link_length: float = 5.0, link_margin: float = 0.0,
                     room: radialopt.Region | str | None = "auto") -> WorldModel:
        """World model from a :class:`trimesh.Scene`: one object per geometry node.

        The type of a node is, in this order: ``type_of(node_name, geometry)`` when given (its
        answer is final, ``None`` skips the node); else ``metadata["type"]`` of the node (set
        with ``scene.graph.update(..., metadata={"type": ...})`` or ``add_geometry(metadata=)``)
        or of the geometry; else the node-name prefix before the first ``"_"`` or ``":"`` (the
        whole name if it has neither).  A metadata type of ``None`` skips the node.

        The object frame is the node frame moved to the centre of the geometry's bounding box
        (scaling removed), so the position is the world transform applied to that centre;
        ``size`` is the geometry's extents in its own frame times the node's axis scales.  The
        geometry key is the scene's geometry name; ``class_vertices`` holds its vertices about
        the box centre (scaled by the first node that uses it).

        ``room="auto"`` sets :attr:`room` by :func:`room_from_trimesh` (from the floor, wall and
        ceiling nodes by the default typing rule, whether or not ``type_of`` skips them, or from
        ``scene.metadata["room"]``); ``None`` leaves it unset; a Region is used as is.

        Geometry without vertices (an empty :class:`trimesh.Trimesh` or
        :class:`trimesh.PointCloud`) is skipped; a point cloud with points is an object like a
        mesh (its box is the points' bounds).  Node transforms and vertices must be finite with
        ``|x| <=`` :data:`MAX_COORDINATE`.  An exception inside ``type_of`` is re-raised as a
        :class:`~worldgraph.errors.WorldGraphError` naming the node.
        """
        _check_scene(scene)
        if type_of is not None and not callable(type_of):
            raise ArgumentTypeError(f"type_of must be a callable or None, got {_checks._short(type_of)}")
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
            default = _default_type(scene, node, geometry) if auto or type_of is None else None
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
                          stacklevel=2)
        table, class_vertices, mirrored = _trimesh_table(nodes, matrices, geom_names, geometries, bounds_of,
                                                         keep, types)
        if mirrored:
            warnings.warn(f"from_trimesh: {len(mirrored)} node(s) with a reflecting transform taken as the "
                          "proper rotation with one axis mirrored (position and size exact, class vertices "
                          f"not mirrored): {mirrored[:5]}", UserWarning, stacklevel=2)
        if table is None:
            raise EmptyWorldError("scene has no typed geometry nodes with vertices (a WorldModel needs one)")
        world = cls(table, max_link_length=max_link_length, class_vertices=class_vertices, scene=scene,
                    link_margin=link_margin, room=region)
        return world._warn_units()

    @classmethod
    def from_file(cls, path: str | os.PathLike[str], type_of: Any = None, *, max_link_length: float = 5.0,
                  link_margin: float = 0.0, room: Any = "auto", mjcf_objects: str = "bodies",
                  file_format: str | None = None) -> WorldModel:
        """World model from a scene file: GLB/GLTF/OBJ/PLY/STL/OFF/DAE through trimesh, MJCF through
        MuJoCo (``mjcf`` extra); see :func:`worldgraph.importers.world_from_file` for ``type_of``
        (``None``, a callable ``name -> type or None``, or a mapping ``regex -> type``) and the
        options (``max_link_length``, ``link_margin``, ``room``, ``mjcf_objects``, ``file_format``)."""
        scene, types = typed_scene(path, type_of, mjcf_objects=mjcf_objects, file_format=file_format)
        return cls.from_trimesh(scene, type_of=lambda node, _geometry: types.get(str(node)),
                                max_link_length=max_link_length, link_margin=link_margin, room=room)

    # -- derived data ----------------------------------------------------------------------------
    @property
    def types(self) -> NDArray[np.str_]:
        """Object types ``(n,)``."""
        return self._types

    @property
    def positions(self) -> NDArray[np.float64]:
        """Object positions ``(n, 3)`` (read-only)."""
        return self._positions

    @property
    def links(self) -> Mapping[tuple[str, str], LinkTable]:
        """Link tables keyed by the sorted type pair: a read-only mapping over the linked pairs;
        another sorted pair of the model's types reads as an empty table."""
        return self._links

    @property
    def type_index(self) -> dict[str, NDArray[np.intp]]:
        """Object indices of each type, ascending."""
        return self._type_index

    @cached_property
    def type_rank(self) -> NDArray[np.intp]:
        """``(n,)``: the position of each object in its type's :attr:`type_index` array (read-only)."""
        rank = np.empty(len(self.objects), dtype=np.intp)
        for idx in self._type_index.values():
            rank[idx] = np.arange(len(idx))
        rank.setflags(write=False)
        return rank

    @property
    def tree(self) -> cKDTree:
        """A :class:`scipy.spatial.cKDTree` over :attr:`positions`."""
        return self._tree

    @property
    def type_names(self) -> tuple[str, ...]:
        """Sorted distinct types."""
        return tuple(self._type_index)

    @cached_property
    def graph(self) -> nx.Graph:
        """Proximity graph: node = object index (attributes id, type, position, size), edge =
        pair closer than ``max_link_length`` (attribute ``length``)."""
        g: nx.Graph[int] = nx.Graph()
        g.add_nodes_from((k, {"id": o.id, "type": o.type, "position": self._positions[k], "size": o.size})
                         for k, o in enumerate(self.objects))
        for table in self._links.values():
            i, j, length = table.in_range(-1.0, self.max_link_length)
            attrs = ({"length": x} for x in length.tolist())
            g.add_edges_from(zip(i.tolist(), j.tolist(), attrs, strict=True))
        return g

    def __len__(self) -> int:
        return len(self.objects)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, WorldModel):
            return NotImplemented
        if (self.max_link_length != other.max_link_length or self.link_margin != other.link_margin
                or self.gravity_aligned != other.gravity_aligned or self.objects != other.objects):
            return False
        if (self.room is None) != (other.room is None):
            return False
        if self.room is not None and other.room is not None and not (
                np.array_equal(self.room.lower, other.room.lower)
                and np.array_equal(self.room.upper, other.room.upper)):
            return False
        if self.class_vertices.keys() != other.class_vertices.keys():
            return False
        return all(np.array_equal(v, other.class_vertices[k]) for k, v in self.class_vertices.items())

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        counts = ", ".join(f"{t}={len(v)}" for t, v in self.type_index.items())
        return f"WorldModel({len(self)} objects: {counts}; max_link_length={self.max_link_length})"

    def _check_known_type(self, t: str, what: str = "type") -> None:
        if not isinstance(t, str):
            raise UnknownTypeError(f"{what} must be a type name (str), got {_checks._short(t)}")
        if t not in self._type_index:
            raise UnknownTypeError(f"{what} = {t!r} is not in the world model; "
                                   f"known types: {self._known_types()}")

    def _known_types(self, limit: int = 20) -> str:
        """The world's types for an error message: the first ``limit``, then how many more (a
        CAD model with a type per node has thousands)."""
        names = list(itertools.islice(self._type_index, limit))
        more = len(self._type_index) - len(names)
        return f"{names}" + (f" and {more:,} more" if more else "")

    def link_lengths(self, type_a: str, type_b: str, lo: float = -math.inf, hi: float = math.inf,
                     ) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.float64]]:
        """Links between ``type_a`` and ``type_b`` objects with ``lo < length < hi``.

        Returns ``(i, j, length)``, ``i`` global indices of ``type_a`` objects and ``j`` of
        ``type_b`` objects, sorted by length.  Only links shorter than ``max_link_length +
        link_margin`` exist.  For ``type_a == type_b`` each pair appears once (``i < j``).
        The defaults return every link (including zero-length ones between coincident objects
        of different types).
        """
        self._check_known_type(type_a, "type_a")
        self._check_known_type(type_b, "type_b")
        lo = _checks.real_float("lo", lo)
        hi = _checks.real_float("hi", hi)
        if type_a <= type_b:
            return self._links[(type_a, type_b)].in_range(lo, hi)
        i, j, length = self._links[(type_b, type_a)].in_range(lo, hi)
        return j, i, length

    def type_tree(self, type_name: str, z_scale: float = 1.0) -> cKDTree:
        """A :class:`scipy.spatial.cKDTree` over the positions of one type's objects, in the order
        of :meth:`indices_of`, with the z coordinate multiplied by ``z_scale`` (> 0; a large scale
        keeps the storeys of a gravity-aligned world apart in distance queries).  Built on first
        use, then kept with the world."""
        self._check_known_type(type_name, "type_name")
        z_scale = _checks.positive_float("z_scale", z_scale)
        trees = self._type_trees
        key = (type_name, z_scale)
        if key not in trees:
            pts = self._positions[self._type_index[type_name]]
            trees[key] = cKDTree(pts if z_scale == 1.0 else pts * np.array([1.0, 1.0, z_scale]))
        return trees[key]

    @cached_property
    def _type_trees(self) -> dict[tuple[str, float], cKDTree]:
        return {}

    def type_grid(self, type_name: str) -> ring_join.RingGrid:
        """A :class:`~worldgraph.ring_join.RingGrid` of one type's objects (in the order of
        :meth:`indices_of`) for the compiled ring joins of far percept pairs.  Built on first
        use (a sort, no numba needed), then kept with the world."""
        self._check_known_type(type_name, "type_name")
        grids = self._type_grids
        if type_name not in grids:
            grids[type_name] = ring_join.ring_grid(self._positions[self._type_index[type_name]])
        return grids[type_name]

    @cached_property
    def _type_grids(self) -> dict[str, ring_join.RingGrid]:
        return {}

    def far_pairs(self, type_a: str, type_b: str, gravity_aligned: bool = False) -> FarPairIndex | None:
        """The pairs of ``type_a`` and ``type_b`` objects up to :data:`FAR_PAIR_RANGE` apart,
        sorted by distance (:class:`FarPairIndex`), for percept pairs beyond the link table.

        ``gravity_aligned``: keyed by the horizontal distance and holding the pairs up to
        :data:`FAR_PAIR_HEIGHT` apart in z (the same storey), else by the 3D distance.  Built on
        first use for the (unordered) type pair and kept with the world; ``None`` when the pairs
        would exceed :data:`FAR_PAIR_MAX_PAIRS` (estimated from a sample before building), or the
        world's indices together :data:`FAR_PAIR_BUDGET`: the caller then queries k-d trees.
        """
        self._check_known_type(type_a, "type_a")
        self._check_known_type(type_b, "type_b")
        if not isinstance(gravity_aligned, bool | np.bool_):
            raise ArgumentTypeError(f"gravity_aligned must be a bool, got {_checks._short(gravity_aligned)}")
        index, flip = self._far_pair_index(type_a, type_b, bool(gravity_aligned))
        if index is None or not flip:
            return index
        return FarPairIndex(key=index.key, i=index.j, j=index.i, dz=None if index.dz is None else -index.dz)

    def _far_pair_index(self, type_a: str, type_b: str, gravity: bool, lazy: bool = False
                        ) -> tuple[FarPairIndex | None, bool]:
        """The kept index of the type pair in sorted order (built on first use) and whether
        ``(type_a, type_b)`` is that order flipped: the association reads it without the
        flipped view's copy of ``dz`` (types checked by the caller).  ``lazy`` (the
        association): only an index already built (by :meth:`far_pairs` or
        :meth:`build_far_pairs`), else None: the association then takes the compiled ring join
        or the k-d trees, and no call pays for building an index (measured on worlds from
        arrays, 20 views each: 100k building, median associate 150 ms with no index built on
        the way against 266 ms building those up to 2M pairs on first use (116 ms once all were
        built); 1M campus, 1.2 s against 2.1 s, first call 1.9 s against 3.4 s, 27 s building
        every index on first use)."""
        flip = type_a > type_b
        a, b = (type_b, type_a) if flip else (type_a, type_b)
        cache = self._far_pairs
        key = (a, b, gravity)
        if key not in cache:
            if gravity in self._far_pairs_complete:  # build_far_pairs found no objects in reach
                return _empty_far_pairs(gravity), flip
            if lazy and not FAR_PAIR_BUILD_ON_USE:
                return None, flip
            index = cache[key] = _build_far_pairs(self, a, b, gravity)
            if index is not None:
                self._far_pairs_held[0] += len(index.key)
        return cache[key], flip

    @cached_property
    def _far_pairs(self) -> dict[tuple[str, str, bool], FarPairIndex | None]:
        return {}

    @cached_property
    def _far_estimates(self) -> dict[tuple[str, str, bool], float]:
        return {}

    @cached_property
    def _far_pairs_held(self) -> list[int]:
        """``[number of pairs in the kept far-pair indices]``, kept up to date as they are built
        (summing over the indices at every build was quadratic in the number of type pairs)."""
        return [0]

    @cached_property
    def _far_pairs_complete(self) -> set[bool]:
        """The ``gravity_aligned`` values whose every non-empty index :meth:`build_far_pairs`
        has built (or found over the budget): the other type pairs have empty indices."""
        return set()

    def _warn_units(self) -> WorldModel:
        """Warn (:class:`~worldgraph.units.UnitsWarning`) if :attr:`units_hint` says
        its positions look like millimetres, and return this world (the ``from_*`` builders call it)."""
        if self.units_hint is not None:
            from .units import UnitsWarning  # units imports this module
            warnings.warn(self.units_hint, UnitsWarning, stacklevel=3)
        return self

    @cached_property
    def units_hint(self) -> str | None:
        """:func:`worldgraph.units.world_units_hint` of this world, computed once (``localize``
        adds it to its message; it samples the world and queries its k-d tree)."""
        from .units import world_units_hint  # units imports this module

        return world_units_hint(self)

    def build_far_pairs(self, gravity_aligned: bool = False) -> int:
        """Build :meth:`far_pairs` for every pair of types now, the smallest first (estimated from
        a sample), so that the budget :data:`FAR_PAIR_BUDGET` covers as many type pairs as it
        can; returns the number of pairs held.

        A tuning step for a long-running localiser on a big map: the association uses the
        indices built (``gravity_aligned=True`` for the default, gravity search), and never
        builds one itself (the compiled ring join takes those far pairs).  On the 100k building
        it costs about 15 s and takes the associate median from about 150 to 115 ms.

        Only the type pairs with two objects within reach of each other are visited (one k-d
        tree pass over all objects finds them); every other type pair's index is empty, and
        :meth:`far_pairs` and the association read it as built.  A world of 5,000 types, one
        per object, has 12.5M type pairs, but only those its objects' neighbourhoods hold."""
        if not isinstance(gravity_aligned, bool | np.bool_):
            raise ArgumentTypeError(f"gravity_aligned must be a bool, got {_checks._short(gravity_aligned)}")
        gravity = bool(gravity_aligned)
        pairs = _far_type_pairs(self, gravity)
        sizes = [_far_pair_estimate(self, a, b, gravity) for a, b in pairs]
        for _, (a, b) in sorted(zip(sizes, pairs, strict=True)):
            self.far_pairs(a, b, gravity)
        self._far_pairs_complete.add(gravity)
        return self._far_pairs_held[0]

    def indices_of(self, type_name: str) -> NDArray[np.intp]:
        """Object indices of one type (``UnknownTypeError`` if absent)."""
        self._check_known_type(type_name, "type_name")
        return self._type_index[type_name]

    @property
    def bounds(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(lower (3,), upper (3,))`` of the union of the objects' oriented bounding boxes
        (computed once per world)."""
        lo, hi = self._bounds
        return lo.copy(), hi.copy()

    @cached_property
    def _bounds(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        if isinstance(self.objects, ObjectTable) and self.objects.rotations is None:  # identity rotations
            half = self.objects.sizes * 0.5
        elif isinstance(self.objects, ObjectTable):
            half = np.einsum("nij,nj->ni", np.abs(self.objects.rotation_array()), self.objects.sizes * 0.5)
        else:
            rot = np.array([o.pose[:3, :3] for o in self.objects])
            half = np.einsum("nij,nj->ni", np.abs(rot), np.array([o.size for o in self.objects]) * 0.5)
        return (self.positions - half).min(axis=0), (self.positions + half).max(axis=0)

    def region(self, margin: float = 0.0) -> radialopt.Region:
        """Box of valid robot positions: above the floor (the lowest object point) and inside the model.

        ``margin`` (metres) widens the box in x and y on both sides and raises its top; the
        bottom stays at floor height.  A negative margin shrinks it.
        """
        from radialopt import Region
        from radialopt import errors as ro_errors

        margin = _checks.finite_float("margin", margin, max_abs=MAX_LINK_LENGTH)
        lo, hi = self.bounds
        lower = np.array([lo[0] - margin, lo[1] - margin, lo[2]])
        upper = np.array([hi[0] + margin, hi[1] + margin, hi[2] + margin])
        try:
            return Region(lower, upper)
        except ro_errors.RadialError as exc:
            raise WorldGraphError(f"margin = {margin!r} shrinks the model's box {lo.tolist()}..{hi.tolist()} "
                                  f"to nothing: {exc}") from exc

    def subset(self, types: Iterable[str]) -> WorldModel:
        """A world model holding only the objects of the given types (same link settings and room);
        a single string is one type."""
        if isinstance(types, str):
            types = [types]
        if (types is None or isinstance(types, bytes | Mapping) or not isinstance(types, Iterable)
                or (isinstance(types, np.ndarray) and types.ndim == 0)):
            raise ArgumentTypeError(f"types must be an iterable of type names, got {_checks._short(types)}")
        keep: Collection[str] = list(types)
        for k, t in enumerate(keep):
            self._check_known_type(t, f"types[{k}]")
        keep = set(keep)
        index = np.flatnonzero(np.isin(self._types, sorted(keep)))
        if not index.size:
            raise EmptyWorldError(f"types must name at least one type of the world, got "
                                  f"{_checks._short(types)}")
        return self.take(index)

    def take(self, index: ArrayLike) -> WorldModel:
        """A world model holding the objects at ``index`` (distinct ints, in that order) with the
        same link settings, room and ``gravity_aligned`` flag; a table stays a table."""
        idx = _object_index(index, len(self), 0)
        if not idx.size:
            raise EmptyWorldError("index must select at least one object, got 0")
        if len(np.unique(idx)) != len(idx):
            raise WorldGraphError(f"index must hold distinct object indices, got {_checks._short(index)}")
        objs: Sequence[ObjectModel]
        if isinstance(self.objects, ObjectTable):
            objs = self.objects.take(idx)
            geometries = set(np.unique(objs.geometries).tolist())
        else:
            objs = tuple(self.objects[k] for k in idx.tolist())
            geometries = {o.geometry for o in objs}
        cv = {g: self.class_vertices[g] for g in sorted(geometries)}
        return WorldModel(objs, self.max_link_length, cv, scene=None, link_margin=self.link_margin,
                          room=self.room, gravity_aligned=self.gravity_aligned)

    # -- files -----------------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary in the documented file format."""
        out: dict[str, Any] = {
            "format": FILE_FORMAT,
            "version": FILE_VERSION,
            "max_link_length": self.max_link_length,
            "link_margin": self.link_margin,
            "class_vertices": {k: v.tolist() for k, v in self.class_vertices.items()},
            "objects": [o.to_dict() for o in self.objects],
        }
        if self.room is not None:
            out["room"] = {"lower": self.room.lower.tolist(), "upper": self.room.upper.tolist()}
        if self.gravity_aligned:
            out["gravity_aligned"] = True
        return out

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write the model as JSON (see the module docstring for the format); a path that cannot be
        written raises :class:`~worldgraph.errors.WorldGraphError` naming it."""
        path = _check_path(path)
        try:
            with open(path, "w", encoding="utf-8") as fh:
                json.dump(self.to_dict(), fh, indent=1, allow_nan=False)
        except OSError as exc:
            raise WorldGraphError(f"{path}: cannot write: {exc}") from exc

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> WorldModel:
        """Read a model written by :meth:`save` (or by hand).

        Every problem is a :class:`~worldgraph.errors.MalformedFileError` naming the path and the
        problem: a path that is not a ``str``/``PathLike`` or holds a NUL character, a file that
        cannot be read, is not UTF-8, not JSON, nested too deeply, or holds a bad value (numbers
        beyond float64, non-rigid poses, coordinates above :data:`MAX_COORDINATE`, ...).
        """
        try:
            path = _check_path(path)
        except WorldGraphError as exc:
            raise MalformedFileError(str(exc)) from exc
        try:
            with open(path, encoding="utf-8") as fh:
                data = json.load(fh)
        except json.JSONDecodeError as exc:
            raise MalformedFileError(f"{path}: not valid JSON: {exc}") from exc
        except UnicodeDecodeError as exc:
            raise MalformedFileError(f"{path}: not UTF-8 text: {exc}") from exc
        except RecursionError as exc:
            raise MalformedFileError(f"{path}: JSON nested too deeply to read") from exc
        except (OSError, ValueError) as exc:
            raise MalformedFileError(f"{path}: cannot read: {exc}") from exc
        return cls.from_dict(data, source=path)

    @classmethod
    def from_dict(cls, data: Any, source: str = "data") -> WorldModel:
        """Build from the dictionary of the file format, validating every entry."""
        if not isinstance(source, str):
            raise ArgumentTypeError(f"source must be a str (the name used in messages), "
                                    f"got {type(source).__name__}")

        def bad(msg: str) -> MalformedFileError:
            return MalformedFileError(f"{source}: {msg}")

        try:
            return cls._from_dict(data, bad)
        except MalformedFileError:
            raise
        except WorldGraphError as exc:
            raise bad(str(exc)) from exc
        except RecursionError as exc:
            raise bad("nested too deeply") from exc
        except (TypeError, ValueError, KeyError, IndexError, AttributeError, OverflowError) as exc:
            # only reachable from hand-made dictionaries holding non-JSON objects
            raise bad(f"unreadable value ({type(exc).__name__}: {exc})") from exc

    @classmethod
    def _from_dict(cls, data: Any, bad: Callable[[str], MalformedFileError]) -> WorldModel:

        if not isinstance(data, dict):
            raise bad(f"top level must be a JSON object, got {type(data).__name__}")
        for key in ("version", "max_link_length", "objects", "class_vertices"):
            if key not in data:
                raise bad(f"missing key {key!r}")
        if data.get("format", FILE_FORMAT) != FILE_FORMAT:
            raise bad(f"format must be {FILE_FORMAT!r}, got {_checks._short(data['format'])}")
        if type(data["version"]) is not int or data["version"] != FILE_VERSION:
            raise bad(f"unsupported version {_checks._short(data['version'])}, this reader reads version "
                      f"{FILE_VERSION}")

        def number(value: Any, what: str) -> float:
            try:
                return _checks.finite_float(what, value)
            except WorldGraphError as exc:
                raise bad(f"{exc} (a finite number is needed)") from exc

        def array(value: Any, shape: tuple[int | None, ...], what: str) -> NDArray[np.float64]:
            try:
                return _checks.float_array(what, value, shape)
            except WorldGraphError as exc:
                raise bad(str(exc)) from exc

        mll = number(data["max_link_length"], "max_link_length")
        margin = number(data.get("link_margin", 0.0), "link_margin")
        if not isinstance(data["class_vertices"], dict):
            raise bad("class_vertices must be an object mapping geometry keys to vertex lists")
        cv = {k: array(v, (None, 3), f"class_vertices[{k!r}]") for k, v in data["class_vertices"].items()}
        if not isinstance(data["objects"], list):
            raise bad("objects must be a list")
        objs = []
        for k, entry in enumerate(data["objects"]):
            if not isinstance(entry, dict):
                raise bad(f"objects[{k}] must be an object, got {entry!r}")
            for key in ("id", "type", "pose", "size", "geometry"):
                if key not in entry:
                    raise bad(f"objects[{k}] is missing key {key!r}")
            name = f"objects[{k}] ({_checks._short(entry['id'], 60)})"
            for key in ("id", "type", "geometry"):
                try:
                    _checks.name_string(f"{name}.{key}", entry[key])
                except WorldGraphError as exc:
                    raise bad(str(exc)) from exc
            pose = array(entry["pose"], (4, 4), f"{name}.pose")
            size = array(entry["size"], (3,), f"{name}.size")
            try:
                objs.append(ObjectModel(entry["id"], entry["type"], pose, size, entry["geometry"]))
            except WorldGraphError as exc:
                raise bad(f"{name}: {exc}") from exc
        room: Any = data.get("room")  # the JSON value, then the (lower, upper) pair WorldModel checks
        if room is not None:
            if not isinstance(room, dict) or set(room) != {"lower", "upper"}:
                raise bad("room must be null or an object with keys 'lower' and 'upper', "
                          f"got {_checks._short(room)}")
            room = (array(room["lower"], (3,), "room.lower"), array(room["upper"], (3,), "room.upper"))
        gravity = data.get("gravity_aligned", False)
        if not isinstance(gravity, bool):
            raise bad(f"gravity_aligned must be true or false, got {_checks._short(gravity)}")
        try:
            return cls(tuple(objs), max_link_length=mll, class_vertices=cv, link_margin=margin, room=room,
                       gravity_aligned=gravity)
        except WorldGraphError as exc:
            raise bad(str(exc)) from exc
