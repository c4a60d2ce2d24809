"""Procedural scenes: the embedded default data of the examples and benchmarks.

* :func:`kitchen_scene` / :func:`kitchen`: a kitchen with the statistics of the paper's model
  (section 4: 611 rectangular prisms, 124 cylinders, 18 general polyhedra, 13,853 vertices,
  753 objects) in a 10 x 8 x 3 m room: runs of base and wall cabinets along two walls, each
  with doors (one handle per door) or drawer stacks (a handle, or a knob, per drawer), tall
  pantry units, an island, a stove with knobs, appliances, a table with chairs, a room door,
  and clutter (boxes, jars, cups) on counters and shelves.  The layout (cabinet widths, door or
  drawer fronts, shelves, clutter) is drawn from ``seed``; the primitive counts are the
  paper's for every seed (clutter fills the difference).
* :func:`corridor_scene` / :func:`corridor`: a building corridor with doors on both sides, a
  handle on each door at one height (a coplanar landmark case), light switches and lamps.
* :func:`floor`: a large floor of many corridors and rooms, built from arrays, for the
  20,000-object association benchmark.
* :func:`building` / :func:`building_site` and :func:`campus` / :func:`campus_site`:
  multi-storey office buildings (identical room modules along corridors, stair cores, each
  storey nearly the plan of the one below) and campuses of them, built from arrays, with the
  building and storey of every object (:class:`Site`) for :func:`worldgraph.tiles.tiling`.

Every object of a scene is a geometry node of a :class:`trimesh.Scene` named
``f"{type}_{k:03d}"`` whose node metadata holds ``{"type": type}``; each mesh's metadata
holds ``{"primitive": "box" | "cylinder" | "polyhedron"}``.  Meshes are shared by reference
between nodes of one size class.  Walls, floor and ceiling are typed ``"wall"``, ``"floor"``
and ``"ceiling"`` (they are objects of the model like in the paper's CAD scene graph; drop them
with ``world.subset(...)`` if they are not wanted as landmarks, see :data:`STRUCTURAL_TYPES`).

World frame: z up, the floor at z = 0, the room in ``[0, 10] x [0, 8] x [0, 3]`` metres.

Where things live: :mod:`.builder` (the mesh helpers, the scene builder, :func:`scene_statistics`),
:mod:`.furniture` (handles, knobs, cabinets, appliances, the room shell, :data:`STRUCTURAL_TYPES`),
:mod:`.paper_kitchen` (:func:`kitchen_scene`, :func:`kitchen`), :mod:`.layouts` (:data:`LAYOUT_KINDS`,
:data:`VARIED_LAYOUT_KINDS`, :func:`kitchen_layout_scene`, :func:`kitchen_layout`, the planning of
their runs) and
:mod:`.buildings` (:func:`corridor`, :func:`floor`, :func:`building`, :func:`campus`, :class:`Site`)
and :mod:`.mjcf` (:func:`scene_mjcf`, :func:`write_mjcf`: a kitchen or layout as a textured MuJoCo
scene, for simulated head scans).
"""

from .builder import scene_statistics
from .buildings import (
    MAX_BUILDINGS,
    MAX_CORRIDOR_DOORS,
    MAX_FLOOR_OBJECTS,
    MAX_SITE_OBJECTS,
    MAX_STOREYS,
    MIN_STOREY_HEIGHT,
    Site,
    building,
    building_site,
    campus,
    campus_site,
    corridor,
    corridor_scene,
    floor,
)
from .furniture import STRUCTURAL_TYPES
from .layouts import LAYOUT_KINDS, LAYOUT_TYPES, VARIED_LAYOUT_KINDS, kitchen_layout, kitchen_layout_scene
from .mjcf import scene_mjcf, write_mjcf
from .paper_kitchen import KITCHEN_ROOM, KITCHEN_TARGETS, kitchen, kitchen_scene

__all__ = [
    "KITCHEN_ROOM",
    "KITCHEN_TARGETS",
    "LAYOUT_KINDS",
    "LAYOUT_TYPES",
    "MAX_CORRIDOR_DOORS",
    "MAX_BUILDINGS",
    "MAX_FLOOR_OBJECTS",
    "MAX_SITE_OBJECTS",
    "MAX_STOREYS",
    "MIN_STOREY_HEIGHT",
    "STRUCTURAL_TYPES",
    "Site",
    "VARIED_LAYOUT_KINDS",
    "building",
    "building_site",
    "campus",
    "campus_site",
    "corridor",
    "corridor_scene",
    "floor",
    "kitchen",
    "kitchen_layout",
    "kitchen_layout_scene",
    "kitchen_scene",
    "scene_statistics",
    "scene_mjcf",
    "write_mjcf",
]
