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
:class:`~worldgraph.errors.WorldGraphError` at the first such pair found (memory O(n)).

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

Binary file format (:meth:`WorldModel.save` to a name ending in ``.npz``; :meth:`WorldModel.load`
reads either format whatever the name: a file starting with the zip signature, bytes ``50 4B 03 04``, is
binary), an uncompressed numpy ``.npz`` archive of columnar arrays, read with
``allow_pickle=False`` (:mod:`worldgraph.model.binary_files` says why npz and not Parquet)::

    format               0-d str     "worldgraph.WorldModel.npz"
    version              0-d int     1
    max_link_length      0-d float   as in JSON
    link_margin          0-d float
    gravity_aligned      0-d bool
    type_names           (b,) uint8  the sorted distinct types, UTF-8, joined by NUL
    codes                (n,) int32  object k's type is type_names[codes[k]]
    positions, sizes     (n, 3) f8   box centres (the poses' translations) and extents
    rotations            (n, 3, 3) f8, optional: the poses' rotations (absent: all identity)
    geometry_names       (b,) uint8, optional: sorted distinct geometry keys, as type_names
    geometry_codes       (n,) int32, optional (with geometry_names; absent: the key is the type)
    ids                  (b,) uint8  the ids in object order, UTF-8, joined by NUL; or instead
    id_numbers           (n,) int64  ids f"{type}_{number}" (worlds from arrays and the scenes)
    class_vertex_keys    (b,) uint8  geometry keys, UTF-8, joined by NUL
    class_vertex_offsets (g + 1,) int64, class_vertices (m, 3) f8: key c's vertices are rows
                                     offsets[c]:offsets[c + 1]
    room                 (2, 3) f8, optional: lower and upper corner
    link_i, link_j       (l,) int64, link_length (l,) f8, optional: every link table's rows in
                                     the order of the tables (by type pair, then length)

The link tables are derived data: stored so that a load does not search and sort the pairs again
(19 s of a 1M-object load), checked against the positions on load (vectorised over every row,
lengths and neighbour counts on samples), and rebuilt when absent.  Every entry is checked (dtype,
shape, finite, within :data:`MAX_COORDINATE`, rotations proper, codes in range, ids unique and
non-empty); a problem is a :class:`~worldgraph.errors.MalformedFileError` naming the file.

Where things live (the names are importable from here, as before):

* :mod:`worldgraph.model.world`: :class:`WorldModel`;
* :mod:`worldgraph.model.construction`: how a :class:`WorldModel` is made (the checks of a new
  world, the bodies of :meth:`WorldModel.from_arrays`, :meth:`WorldModel.from_trimesh` and
  :meth:`WorldModel.from_file`);
* :mod:`worldgraph.model.objects`: :class:`ObjectModel`, :class:`ObjectTable`,
  :func:`box_vertices`, :data:`DEFAULT_SIZE`, :data:`MAX_COORDINATE` and the value checks;
* :mod:`worldgraph.model.scene_nodes`: reading a :class:`trimesh.Scene`'s nodes into objects and
  the room (:func:`room_from_trimesh`, :data:`ROOM_TYPES`, :data:`DEFAULT_ROOM_HEIGHT`);
* :mod:`worldgraph.model.scene_files`: reading scene files (glTF, OBJ, PLY, STL, OFF, DAE, MJCF)
  into typed scenes, for :meth:`WorldModel.from_file` (the public names are in
  :mod:`worldgraph.importers`);
* :mod:`worldgraph.model.links`: :class:`LinkTable`, :data:`MAX_LINK_LENGTH`, :data:`MAX_LINKS`,
  :data:`MAX_GRAPH_EDGES`;
* :mod:`worldgraph.model.far_pairs`: :class:`FarPairIndex` and the ``FAR_PAIR_*`` limits (set
  them on that module: the far-pair code reads them there);
* :mod:`worldgraph.model.persistence`: the file format (:data:`FILE_FORMAT`, :data:`FILE_VERSION`);
* :mod:`worldgraph.model.binary_files`: the binary file format (``BINARY_FORMAT``, ``BINARY_VERSION``);
* :mod:`worldgraph.model.ring_join`: the compiled ring and shell joins;
* :mod:`worldgraph.model.units`: the millimetre hints.
"""

from ..tolerances import COINCIDENT_TOLERANCE, FAR_PAIR_SLACK, QUERY_WIDEN, RIGID_TOLERANCE  # noqa: F401 - re-exported
from .far_pairs import (  # noqa: F401 - re-exported
    FAR_PAIR_BUDGET,
    FAR_PAIR_BUILD_ON_USE,
    FAR_PAIR_HEIGHT,
    FAR_PAIR_MAX_PAIRS,
    FAR_PAIR_RANGE,
    FAR_TYPE_BLOCK,
    FarPairIndex,
)
from .links import MAX_GRAPH_EDGES, MAX_LINK_LENGTH, MAX_LINKS, LinkTable  # noqa: F401 - re-exported
from .objects import DEFAULT_SIZE, MAX_COORDINATE, ObjectModel, ObjectTable, box_vertices  # noqa: F401 - re-exported
from .persistence import FILE_FORMAT, FILE_VERSION
from .scene_nodes import DEFAULT_ROOM_HEIGHT, ROOM_TYPES, room_from_trimesh
from .world import WorldModel

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
