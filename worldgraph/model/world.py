"""The :class:`WorldModel`: typed objects, their proximity graph, link look-up table, k-d trees
and far-pair indices (see :mod:`worldgraph.model` for the overview and the file format)."""

from __future__ import annotations

import itertools
import math
import os
import warnings
from collections.abc import Callable, Collection, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any

import networkx as nx
import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from .. import _checks
from ..errors import (
    MalformedFileError,
    WorldGraphError,
)
from . import ring_join
from .construction import (
    _check_coincident,
    _coincident,
    _from_arrays,
    _from_file,
    _from_trimesh,
    _init_world,
)
from .far_pairs import (
    FarPairIndex,
    _build_world_far_pairs,
    _world_far_pair_index,
)
from .links import MAX_GRAPH_EDGES, MAX_LINK_LENGTH, LinkTable, _build_world_links, _LinkTables
from .objects import (
    ObjectModel,
    ObjectTable,
    _object_index,
)
from .persistence import _world_from_dict, load_world, save_world, world_from_dict, world_to_dict

if TYPE_CHECKING:  # pragma: no cover
    import trimesh

    import radialopt


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
        ``"auto"``, :mod:`worldgraph.pose.gravity`) whatever this flag says; only the networkx views
        and the paper's filters (:func:`~worldgraph.association.filters.consistency_graph`, ...) follow it
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
        _init_world(self)

    # -- construction helpers ------------------------------------------------------------------
    def _coincident(self, a: int, b: int, distance: float) -> WorldGraphError:
        return _coincident(self, a, b, distance)

    def _check_coincident(self, codes: NDArray[np.intp]) -> None:
        """Raise at the first pair of same-type objects closer than :data:`COINCIDENT_TOLERANCE`.

        Memory O(n): exact duplicates by one lexicographic sort, then near duplicates by a
        nearest-neighbour query in a 4D tree whose 4th axis separates the types by more than
        any distance in the world.
        """
        _check_coincident(self, codes)

    def _build_links(self) -> None:
        # the binary loader (binary_files.load_binary) sets "_stored_links" = (i, j, length, path) on the
        # instance before __init__: the link rows its file holds, checked instead of searched
        stored = self.__dict__.pop("_stored_links", None)
        if stored is None:
            _build_world_links(self)
        else:
            _build_world_links(self, stored[:3], stored[3])

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
        return _from_arrays(cls, types, positions, max_link_length, ids, sizes, link_margin, room,
                            gravity_aligned)._warn_units()

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
        return _from_trimesh(cls, scene, type_of, max_link_length, link_margin, room)._warn_units()

    @classmethod
    def from_file(cls, path: str | os.PathLike[str], type_of: Any = None, *, max_link_length: float = 5.0,
                  link_margin: float = 0.0, room: Any = "auto", mjcf_objects: str = "bodies",
                  file_format: str | None = None, up_axis: str | None = None) -> WorldModel:
        """World model from a scene file: GLB/GLTF/OBJ/PLY/STL/OFF/DAE through trimesh, MJCF through
        MuJoCo (``mjcf`` extra); see :func:`worldgraph.importers.world_from_file` for ``type_of``
        (``None``, a callable ``name -> type or None``, or a mapping ``regex -> type``) and the
        options (``max_link_length``, ``link_margin``, ``room``, ``mjcf_objects``, ``file_format``).

        The world is z up (against gravity).  ``up_axis`` (``"+x"``, ``"-x"``, ``"+y"``, ``"-y"``,
        ``"+z"``, ``"-z"``) names the file axis that points up; default ``None``, the format's
        convention: glTF/GLB +Y (the glTF 2.0 specification; Blender writes it so), COLLADA
        (``.dae``) its ``<up_axis>`` element (``Y_UP`` when absent), MJCF +Z, and +Z for OBJ,
        PLY, STL and OFF, which carry no up axis (read as written); a +Y-up file is turned by
        ``(x, y, z) -> (x, -z, y)`` (:func:`worldgraph.importers.z_up_from`).  A world that
        looks like a room on its side (a flat floor whose thin axis is horizontal, or objects
        spread along z far more than sideways) gets a :class:`UserWarning` naming the likely
        ``up_axis=``; with ``room="auto"``, a room box its sideways floor and walls cannot give
        is left unset (the warning says so), and an error building such a world says the same.
        A bad ``up_axis`` raises
        :class:`~worldgraph.errors.WorldGraphError`."""
        return _from_file(cls, path, type_of, max_link_length, link_margin, room, mjcf_objects, file_format,
                          up_axis)

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
        pair closer than ``max_link_length`` (attribute ``length``).  A graph of more than
        :data:`~worldgraph.model.links.MAX_GRAPH_EDGES` edges is refused
        (:class:`~worldgraph.errors.WorldGraphError`): :attr:`links` holds them as arrays."""
        edges = self._links.count_shorter(self.max_link_length)
        if edges > MAX_GRAPH_EDGES:
            raise WorldGraphError(
                f"world.graph would hold {edges:,} edges ({len(self):,} objects, max_link_length = "
                f"{self.max_link_length:g} m), more than MAX_GRAPH_EDGES = {MAX_GRAPH_EDGES:,} (a networkx "
                "edge costs about 0.5 kB and 12 us): read the pairs from world.links (arrays per type "
                "pair) or lower max_link_length")
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
            raise WorldGraphError(f"{what} must be a type name (str), got {_checks._short(t)}")
        if t not in self._type_index:
            raise WorldGraphError(f"{what} = {t!r} is not in the world model; "
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
        z_scale = _checks.real_scalar("z_scale", z_scale, positive=True)
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
        """A :class:`~worldgraph.model.ring_join.RingGrid` of one type's objects (in the order of
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
            raise WorldGraphError(f"gravity_aligned must be a bool, got {_checks._short(gravity_aligned)}")
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
        or the k-d trees, and no call pays for building an index
        (docs/design.md#defaults)."""
        return _world_far_pair_index(self, type_a, type_b, gravity, lazy)

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
        """Warn (:class:`~worldgraph.model.units.UnitsWarning`) if :attr:`units_hint` says
        its positions look like millimetres, and return this world (the ``from_*`` builders call it)."""
        if self.units_hint is not None:
            from .units import UnitsWarning  # units imports this module
            warnings.warn(self.units_hint, UnitsWarning, stacklevel=3)
        return self

    @cached_property
    def units_hint(self) -> str | None:
        """:func:`worldgraph.model.units.world_units_hint` of this world, computed once (``localize``
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
            raise WorldGraphError(f"gravity_aligned must be a bool, got {_checks._short(gravity_aligned)}")
        gravity = bool(gravity_aligned)
        return _build_world_far_pairs(self, gravity)

    def centre_depths(self) -> dict[str, float]:
        """Per type, how far an object's centre lies behind its visible surface: the median over
        the type's objects of half the thinnest extent of its box (metres).

        A camera sees an object's front; the map places it at the centre of its geometry.  Pass
        this to the detection front ends (``perception.rgbd_percepts(...,
        centre_offset=world.centre_depths())``, :func:`perception.stereo_percepts`) so that a
        percept and its object refer to the same point.  A door 3 cm thick gives 1.5 cm, a
        cylindrical handle its radius; objects of no extent give 0.

        Returns
        -------
        dict of str to float
            Keyed by every type of the model.
        """
        sizes = (self.objects.sizes if isinstance(self.objects, ObjectTable)
                 else np.array([o.size for o in self.objects]).reshape(-1, 3))
        thinnest = 0.5 * sizes.min(axis=1)
        return {t: float(np.median(thinnest[idx])) for t, idx in self._type_index.items()}

    def indices_of(self, type_name: str) -> NDArray[np.intp]:
        """Object indices of one type (``WorldGraphError`` if absent)."""
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

        margin = _checks.real_scalar("margin", margin, max_abs=MAX_LINK_LENGTH)
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
            raise WorldGraphError(f"types must be an iterable of type names, got {_checks._short(types)}")
        keep: Collection[str] = list(types)
        for k, t in enumerate(keep):
            self._check_known_type(t, f"types[{k}]")
        keep = set(keep)
        index = np.flatnonzero(np.isin(self._types, sorted(keep)))
        if not index.size:
            raise WorldGraphError(f"types must name at least one type of the world, got "
                                  f"{_checks._short(types)}")
        return self.take(index)

    def take(self, index: ArrayLike) -> WorldModel:
        """A world model holding the objects at ``index`` (distinct ints, in that order) with the
        same link settings, room and ``gravity_aligned`` flag; a table stays a table."""
        idx = _object_index(index, len(self), 0)
        if not idx.size:
            raise WorldGraphError("index must select at least one object, got 0")
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

    @property
    def nbytes(self) -> int:
        """Bytes held by the world's arrays: positions, types, the objects' table, the link tables,
        the type index and the k-d tree (an estimate of its nodes); what a process holding it
        pays, and what Dask (which sizes objects by ``sys.getsizeof``) weighs before moving it."""
        total = 0
        seen: set[int] = set()

        def add(value: object) -> None:
            nonlocal total
            if isinstance(value, np.ndarray) and id(value) not in seen:
                seen.add(id(value))
                total += int(value.nbytes)

        for name in ("_types", "_positions"):
            add(getattr(self, name, None))
        table = self.objects
        for name in ("codes", "positions", "sizes", "rotations", "numbers"):
            add(getattr(table, name, None))
        links = getattr(self, "_links", None)
        for name in ("_pi", "_pj", "_length", "_present", "_first", "_last"):
            add(getattr(links, name, None))
        for v in getattr(self, "_type_index", {}).values():
            add(v)
        tree = getattr(self, "_tree", None)
        if tree is not None:
            add(tree.data)
            total += 3 * int(tree.data.nbytes)  # its index and nodes, about as large again (twice)
        return total

    def __sizeof__(self) -> int:
        return object.__sizeof__(self) + self.nbytes

    # -- files -----------------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary in the documented file format."""
        return world_to_dict(self)

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write the model as JSON, or in the binary format when the name ends in ``.npz`` (an
        uncompressed numpy archive of columnar arrays with the link tables, fast to load; see
        :mod:`worldgraph.model` for both formats); a path that cannot be written raises
        :class:`~worldgraph.errors.WorldGraphError` naming it."""
        save_world(self, path)

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> WorldModel:
        """Read a model written by :meth:`save` (or by hand), JSON or binary: a file starting with
        the zip magic bytes is read as the binary ``.npz`` format whatever its name, any other as
        JSON.

        Every problem is a :class:`~worldgraph.errors.MalformedFileError` naming the path and the
        problem: a path that is not a ``str``/``PathLike`` or holds a NUL character, a file that
        cannot be read, is not UTF-8, not JSON, nested too deeply, or holds a bad value (numbers
        beyond float64, non-rigid poses, coordinates above :data:`MAX_COORDINATE`, ...); for a
        binary file also a truncated or corrupt archive, a missing entry, a wrong dtype or
        shape, an object array (never unpickled), or stored link tables that do not match the
        positions.
        """
        return load_world(cls, path)

    @classmethod
    def from_dict(cls, data: Any, source: str = "data") -> WorldModel:
        """Build from the dictionary of the file format, validating every entry."""
        return world_from_dict(cls, data, source)

    @classmethod
    def _from_dict(cls, data: Any, bad: Callable[[str], MalformedFileError]) -> WorldModel:
        return _world_from_dict(cls, data, bad)
