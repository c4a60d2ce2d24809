"""Corridors, floors, buildings and campuses.

* :func:`corridor_scene` / :func:`corridor`: a building corridor with doors on both sides, a
  handle on each door at one height (a coplanar landmark case), light switches and lamps.
* :func:`floor`: a large floor of many corridors and rooms, built from arrays, for the
  20,000-object association benchmark.
* :func:`building` / :func:`building_site` and :func:`campus` / :func:`campus_site`:
  multi-storey office buildings (identical room modules along corridors, stair cores, each
  storey nearly the plan of the one below) and campuses of them, built from arrays, with the
  building and storey of every object (:class:`Site`) for :func:`worldgraph.tiles.tiling`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import trimesh
from numpy.typing import NDArray

from .. import _checks
from ..errors import WorldGraphError
from ..model import MAX_COORDINATE, WorldModel
from .builder import _UP, _Builder, _frame, _link_args, _seed, _translate
from .furniture import _handle

__all__ = [
    "MAX_BUILDINGS",
    "MAX_CORRIDOR_DOORS",
    "MAX_FLOOR_OBJECTS",
    "MAX_SITE_OBJECTS",
    "MAX_STOREYS",
    "MIN_STOREY_HEIGHT",
    "Site",
    "building",
    "building_site",
    "campus",
    "campus_site",
    "corridor",
    "corridor_scene",
    "floor",
]

#: Largest ``n_doors`` of :func:`corridor_scene` / :func:`corridor`.
MAX_CORRIDOR_DOORS = 10_000
#: Largest ``n_objects`` of :func:`floor`.
MAX_FLOOR_OBJECTS = 1_000_000


# ----------------------------------------------------------------------------------------------
# corridor
# ----------------------------------------------------------------------------------------------
def corridor_scene(n_doors: int = 40, length: float | None = None, seed: int = 0, width: float = 2.2,
                   height: float = 2.8) -> trimesh.Scene:
    """A building corridor along x with ``n_doors`` doors split over both walls.

    Each door (type ``"door"``, 0.9 x 2.05 m) has a handle (``"handle"``) at 1.05 m, all at one
    height: a coplanar landmark configuration.  Next to each door is a light switch
    (``"switch"``); lamps (``"lamp"``, cylinders) hang along the centre line.  Door positions
    are drawn from ``seed`` with at least 0.3 m between neighbouring doors on one wall.

    Parameters
    ----------
    n_doors : int
        ``1 <= n_doors <=`` :data:`MAX_CORRIDOR_DOORS`.
    length : float, optional
        Corridor length (m); default ``1.8 * n_doors / 2 + 2``.  Must leave 1.5 m per door, at
        most :data:`~worldgraph.model.MAX_COORDINATE`.
    seed : int
        Non-negative.
    width, height : float
        Corridor width and height (m), ``> 0`` and at most 100.
    """
    n_doors = _checks.integer("n_doors", n_doors, minimum=1, maximum=MAX_CORRIDOR_DOORS)
    per_side = [(n_doors + 1) // 2, n_doors // 2]
    if length is None:
        length = 1.8 * per_side[0] + 2.0
    length = _checks.real_scalar("length", length, positive=True, maximum=MAX_COORDINATE / 2)
    if length < 1.5 * per_side[0] + 0.5:
        raise WorldGraphError(f"length {length!r} is too short for {per_side[0]} doors per side")
    width = _checks.real_scalar("width", width, positive=True, maximum=100.0)
    height = _checks.real_scalar("height", height, positive=True, maximum=100.0)
    seed = _seed(seed)
    rng = np.random.default_rng(seed)
    b = _Builder()
    b.box("floor", (length, width, 0.05), _translate(length / 2, 0.0, -0.025))
    b.box("ceiling", (length, width, 0.05), _translate(length / 2, 0.0, height + 0.025))
    b.box("wall", (length, 0.1, height), _translate(length / 2, -width / 2 - 0.05, height / 2))
    b.box("wall", (length, 0.1, height), _translate(length / 2, width / 2 + 0.05, height / 2))
    for side, n in zip((-1.0, 1.0), per_side, strict=True):
        if n == 0:
            continue
        # a wall run whose local y points into the corridor
        normal = np.array([0.0, -side, 0.0])
        along = np.cross(normal, _UP)
        origin = np.array([0.0 if along[0] > 0 else length, side * width / 2, 0.0])
        run = _frame(origin, normal)
        slot = (length - 0.5) / n
        gaps = rng.uniform(0.0, slot - 1.3, size=n)
        for k in range(n):
            x0 = 0.25 + k * slot + gaps[k]
            b.local_box("door", run, (x0, 0.0, 0.0), (x0 + 0.9, 0.04, 2.05), key="corridor_door")
            hinge_right = bool(rng.random() < 0.5)
            hx = x0 + 0.8 if hinge_right else x0 + 0.1
            _handle(b, run, hx, 0.04, 1.05, vertical=False)
            sx = x0 + 1.05 if hinge_right else x0 - 0.15
            b.local_box("switch", run, (sx - 0.04, 0.0, 1.06), (sx + 0.04, 0.012, 1.14))
    n_lamps = max(1, int(length // 4))
    for k in range(n_lamps):
        b.cylinder("lamp", 0.15, 0.05, _translate((k + 0.5) * length / n_lamps, 0.0, height - 0.025))
    b.scene.metadata["primitive_counts"] = dict(b.primitives)
    b.scene.metadata["seed"] = int(seed)
    return b.scene


def corridor(n_doors: int = 40, length: float | None = None, seed: int = 0, max_link_length: float = 5.0,
             link_margin: float = 0.0) -> WorldModel:
    """The corridor of :func:`corridor_scene` as a :class:`WorldModel`."""
    _link_args(max_link_length, link_margin)
    return WorldModel.from_trimesh(corridor_scene(n_doors, length, seed), max_link_length=max_link_length,
                                   link_margin=link_margin)


# ----------------------------------------------------------------------------------------------
# large floor from arrays
# ----------------------------------------------------------------------------------------------
_FLOOR_SIZES = {
    "door": (0.9, 0.04, 2.05), "handle": (0.16, 0.03, 0.012), "switch": (0.08, 0.012, 0.08),
    "sign": (0.25, 0.01, 0.15), "lamp": (0.3, 0.3, 0.05), "window": (1.2, 0.08, 1.2),
    "radiator": (1.0, 0.1, 0.6), "table": (1.4, 0.8, 0.04), "chair": (0.42, 0.42, 0.04),
    "extinguisher": (0.15, 0.15, 0.5), "cabinet": (0.8, 0.4, 1.8),
}


def _columns(x: NDArray[np.floating], y: float | NDArray[np.floating], z: float | NDArray[np.floating],
             ) -> NDArray[np.float64]:
    """Stack coordinates into ``(k, 3)`` points, broadcasting scalars."""
    x = np.asarray(x, dtype=np.float64)
    return np.column_stack([x, np.broadcast_to(y, x.shape), np.broadcast_to(z, x.shape)])


def floor(n_objects: int = 20000, seed: int = 0, max_link_length: float = 5.0,
          link_margin: float = 0.0) -> WorldModel:
    """A large building floor of many corridors and rooms, built with :meth:`WorldModel.from_arrays`.

    Corridors run along x, 60 m long, 16 m apart in y, in a grid of blocks; along each wall of a
    corridor a door every ~3 m (jittered), each with a handle at 1.05 m, a switch and a room
    sign; behind each door a 6 m deep room with a window, a radiator, a ceiling lamp, a table,
    two to four chairs and sometimes a cabinet; fire extinguishers along the corridors.  Objects
    are generated corridor by corridor until ``n_objects`` are reached (the last corridor is cut).

    Returns a :class:`WorldModel` with exactly ``n_objects`` objects (``1 <= n_objects <=``
    :data:`MAX_FLOOR_OBJECTS`); ``seed`` is a non-negative integer.
    """
    n_objects = _checks.integer("n_objects", n_objects, minimum=1, maximum=MAX_FLOOR_OBJECTS)
    _link_args(max_link_length, link_margin)
    seed = _seed(seed)
    rng = np.random.default_rng(seed)
    col = _columns
    corridor_len, spacing, per_row = 60.0, 16.0, 5
    types: list[NDArray[np.str_]] = []
    points: list[NDArray[np.float64]] = []
    total = 0
    c = 0
    while total < n_objects:
        ox = (c % per_row) * (corridor_len + 8.0)
        oy = (c // per_row) * spacing
        c += 1
        for side in (-1.0, 1.0):
            n = int(corridor_len // 3.0)
            x = ox + 0.5 + np.arange(n) * 3.0 + rng.uniform(0.0, 1.2, n)
            wall_y = oy + side * 1.1
            room_y = wall_y + side * 3.0
            hinge = np.where(rng.random(n) < 0.5, 0.8, 0.1)
            blocks = [
                ("door", col(x + 0.45, wall_y, 1.025)),
                ("handle", col(x + hinge, wall_y - side * 0.055, 1.05)),
                ("switch", col(x + np.where(hinge > 0.5, 1.05, -0.15), wall_y - side * 0.006, 1.1)),
                ("sign", col(x + 0.45, wall_y - side * 0.005, 2.3)),
                ("window", col(x + 1.2, wall_y + side * 6.0, 1.6)),
                ("radiator", col(x + 1.2, wall_y + side * 5.85, 0.5)),
                ("lamp", col(x + 1.2, room_y, 2.75)),
                ("table", col(x + 1.2 + rng.uniform(-0.3, 0.3, n), room_y + rng.uniform(-0.5, 0.5, n), 0.74)),
            ]
            n_chairs = rng.integers(2, 5, n)
            table_xy = blocks[-1][1][:, :2]
            owner = np.repeat(np.arange(n), n_chairs)
            ang = rng.uniform(0, 2 * math.pi, owner.size)
            chairs = col(table_xy[owner, 0] + 0.8 * np.cos(ang), table_xy[owner, 1] + 0.8 * np.sin(ang), 0.45)
            blocks.append(("chair", chairs))
            has_cab = rng.random(n) < 0.4
            cab = col(x[has_cab] + 2.2, wall_y + side * 0.3, 0.9)
            blocks.append(("cabinet", cab))
            for typ, p in blocks:
                types.append(np.full(len(p), typ))
                points.append(p)
                total += len(p)
        n_ext = int(corridor_len // 15)
        ext = col(ox + 7.5 + 15.0 * np.arange(n_ext), oy - 1.0, 0.6)
        types.append(np.full(n_ext, "extinguisher"))
        points.append(ext)
        total += n_ext
    all_types = np.concatenate(types)[:n_objects]
    all_points = np.concatenate(points)[:n_objects]
    sizes = np.array([_FLOOR_SIZES[t] for t in all_types])
    return WorldModel.from_arrays(all_types, all_points, max_link_length=max_link_length, sizes=sizes,
                                  link_margin=link_margin)


# ----------------------------------------------------------------------------------------------
# multi-storey buildings and campuses from arrays
# ----------------------------------------------------------------------------------------------
#: Largest ``storeys`` of :func:`building` / :func:`campus`.
MAX_STOREYS = 200
#: Largest ``buildings`` of :func:`campus`.
MAX_BUILDINGS = 1000
#: Largest ``n_objects`` of :func:`building` and :func:`campus`.
MAX_SITE_OBJECTS = 10_000_000
#: Lowest ``storey_height`` (m): the highest object of a storey (a ceiling lamp) hangs at 2.75 m.
MIN_STOREY_HEIGHT = 3.0

_BUILDING_SIZES = {**_FLOOR_SIZES, "stair": (1.2, 2.6, 0.2), "elevator": (1.0, 0.05, 2.1),
                   "button": (0.05, 0.02, 0.1)}
_BUILDING_TYPES = tuple(sorted(_BUILDING_SIZES))
_CODE = {t: c for c, t in enumerate(_BUILDING_TYPES)}
_SIZE_TABLE = np.array([_BUILDING_SIZES[t] for t in _BUILDING_TYPES])
# one storey: corridors along x, ``_MODULES`` identical room modules on each side
_CORRIDOR_LEN, _MODULE_W, _MODULES, _WING_GAP, _ROW_SPACING = 57.6, 3.6, 16, 8.0, 16.0
#: Room module kinds: 0 office (hinge left), 1 office (hinge right), 2 double-window office,
#: 3 store room (no window, no table, always a cabinet).
_MODULE_KINDS = 4
_KIND_P = np.array([0.4, 0.35, 0.15, 0.1])
#: A module keeps the kind of the module below it with this probability.
_STOREY_KEEP = 0.9
# objects per corridor and storey besides the rooms: lamps every 3.6 m, 4 extinguishers,
# two stair cores of 5 objects each
_CORRIDOR_LAMPS, _EXTINGUISHERS, _CORE_OBJECTS = _MODULES, 4, 10
# expected objects per module (door, handle, switch, sign, lamp, radiator; windows, table,
# chairs and cabinet by kind), used to size the plan before it is cut to n_objects
_PER_MODULE = 6 + float(_KIND_P @ [1 + 1 + 3 + 0.4, 1 + 1 + 3 + 0.4, 2 + 1 + 3 + 0.4, 1 - 1 + 0])


@dataclass(frozen=True, eq=False)
class Site:
    """A world model with the building and storey of every object.

    Attributes
    ----------
    world : WorldModel
    building : (n,) int
        Building index of each object (0 for :func:`building`), read-only.
    storey : (n,) int
        Storey of each object (0 = ground floor), read-only.
    """

    world: WorldModel
    building: NDArray[np.intp]
    storey: NDArray[np.intp]

    def labels(self, by: str = "building") -> NDArray[np.intp]:
        """Tile labels for :func:`worldgraph.tiles.tiling`: ``"building"`` or ``"storey"`` (one
        label per building and storey, ``building * (max storey + 1) + storey``)."""
        if by == "building":
            return self.building
        if by == "storey":
            return self.building * (int(self.storey.max()) + 1) + self.storey
        raise WorldGraphError(f"by must be 'building' or 'storey', got {by!r}")


def _site_args(storeys: object, n_objects: object, storey_height: object, max_link_length: object,
               link_margin: object) -> tuple[int, int, float]:
    storeys = _checks.integer("storeys", storeys, minimum=1, maximum=MAX_STOREYS)
    n_objects = _checks.integer("n_objects", n_objects, minimum=1, maximum=MAX_SITE_OBJECTS)
    height = _checks.real_scalar("storey_height", storey_height, positive=True, maximum=100.0)
    if height < MIN_STOREY_HEIGHT:
        raise WorldGraphError(f"storey_height must be >= {MIN_STOREY_HEIGHT:g} m (lamps hang at 2.75 m), "
                              f"got {height!r}")
    _link_args(max_link_length, link_margin)
    return storeys, n_objects, height


def _building_arrays(rng: np.random.Generator, storeys: int, n_objects: int, height: float,
                     origin: NDArray[np.float64]) -> tuple[NDArray[np.intp], NDArray[np.float64],
                                                           NDArray[np.intp]]:
    """Type codes, positions and storeys of one building of exactly ``n_objects`` objects.

    All storeys share one corridor grid; the module kinds of a storey copy the storey below
    with probability ``_STOREY_KEEP``; the furniture is drawn for every room.  Objects are
    generated storey by storey, corridor by corridor; the plan is sized so that it holds at
    least ``n_objects`` and the top storey is cut (its last corridors) to the exact count.
    """
    per_corridor = 2 * _MODULES * _PER_MODULE + _CORRIDOR_LAMPS + _EXTINGUISHERS + _CORE_OBJECTS
    n_corr = max(1, math.ceil(1.05 * n_objects / (storeys * per_corridor)))
    per_row = max(1, round(math.sqrt(n_corr / 4.0)))
    corr = np.arange(n_corr)
    cx = origin[0] + (corr % per_row) * (_CORRIDOR_LEN + _WING_GAP)
    cy = origin[1] + (corr // per_row) * _ROW_SPACING
    # module slots of one storey: (corridor, side, k)
    c_i = np.repeat(corr, 2 * _MODULES)
    side = np.tile(np.repeat([-1.0, 1.0], _MODULES), n_corr)
    k_i = np.tile(np.arange(_MODULES), 2 * n_corr)
    n_mod = c_i.size
    kinds = np.empty((storeys, n_mod), dtype=np.intp)
    kinds[0] = rng.choice(_MODULE_KINDS, size=n_mod, p=_KIND_P)
    for s in range(1, storeys):
        redraw = rng.random(n_mod) >= _STOREY_KEEP
        kinds[s] = np.where(redraw, rng.choice(_MODULE_KINDS, size=n_mod, p=_KIND_P), kinds[s - 1])
    # every room of every storey, storey-major then corridor order
    st = np.repeat(np.arange(storeys), n_mod)
    kind = kinds.reshape(-1)
    ci, sd, kk = np.tile(c_i, storeys), np.tile(side, storeys), np.tile(k_i, storeys)
    z0 = origin[2] + st * height
    x0 = cx[ci] + kk * _MODULE_W                     # left edge of the module along the corridor
    wall_y = cy[ci] + sd * 1.1
    room_y = wall_y + sd * 3.0
    door_x = x0 + np.where(kind == 2, 0.3, 0.5)
    hinge = np.where(kind == 1, 0.8, 0.1)
    n_rooms = kind.size
    blocks: list[tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.float64]]] = []

    def add(typ: str, rows: NDArray[np.intp], pts: NDArray[np.float64]) -> None:
        # rows: the room (or corridor-storey) each object belongs to, for the generation order
        blocks.append((np.full(len(pts), _CODE[typ], dtype=np.intp), rows, pts))

    rooms = np.arange(n_rooms)
    add("door", rooms, np.column_stack([door_x + 0.45, wall_y, z0 + 1.025]))
    add("handle", rooms, np.column_stack([door_x + hinge, wall_y - sd * 0.055, z0 + 1.05]))
    add("switch", rooms, np.column_stack([door_x + np.where(kind == 1, 1.05, -0.15), wall_y - sd * 0.006,
                                          z0 + 1.1]))
    add("sign", rooms, np.column_stack([door_x + 0.45, wall_y - sd * 0.005, z0 + 2.3]))
    add("lamp", rooms, np.column_stack([x0 + 1.8, room_y, z0 + 2.75]))
    add("radiator", rooms, np.column_stack([x0 + 1.8, wall_y + sd * 5.85, z0 + 0.5]))
    win = kind != 3
    add("window", rooms[win], np.column_stack([x0[win] + np.where(kind[win] == 2, 0.9, 1.8),
                                               wall_y[win] + sd[win] * 6.0, z0[win] + 1.6]))
    two = kind == 2
    add("window", rooms[two], np.column_stack([x0[two] + 2.7, wall_y[two] + sd[two] * 6.0, z0[two] + 1.6]))
    tab = rooms[win]
    tx = x0[tab] + 1.8 + rng.uniform(-0.4, 0.4, tab.size)
    ty = room_y[tab] + rng.uniform(-0.6, 0.6, tab.size)
    add("table", tab, np.column_stack([tx, ty, z0[tab] + 0.74]))
    n_chairs = rng.integers(2, 5, tab.size)
    owner = np.repeat(np.arange(tab.size), n_chairs)
    ang = rng.uniform(0.0, 2 * math.pi, owner.size)
    add("chair", tab[owner], np.column_stack([tx[owner] + 0.8 * np.cos(ang), ty[owner] + 0.8 * np.sin(ang),
                                              z0[tab][owner] + 0.45]))
    cab = (kind == 3) | (rng.random(n_rooms) < 0.4)
    add("cabinet", rooms[cab], np.column_stack([x0[cab] + np.where(kind[cab] == 3, 1.8, 3.0),
                                                wall_y[cab] + sd[cab] * np.where(kind[cab] == 3, 3.0, 0.3),
                                                z0[cab] + 0.9]))
    # corridor furniture and stair cores, one group per (storey, corridor); ordered after the
    # rooms of that corridor by giving them the row of its last room
    cs_st = np.repeat(np.arange(storeys), n_corr)
    cs_c = np.tile(corr, storeys)
    last_room = cs_st * n_mod + (cs_c + 1) * 2 * _MODULES - 1
    zc = origin[2] + cs_st * height
    lamp_k = np.arange(_CORRIDOR_LAMPS)
    rows = np.repeat(last_room, _CORRIDOR_LAMPS)
    add("lamp", rows, np.column_stack([np.repeat(cx[cs_c], _CORRIDOR_LAMPS) + np.tile(lamp_k, cs_c.size)
                                       * _MODULE_W + 1.8, np.repeat(cy[cs_c], _CORRIDOR_LAMPS),
                                       np.repeat(zc, _CORRIDOR_LAMPS) + 2.75]))
    ext_k = np.arange(_EXTINGUISHERS)
    rows = np.repeat(last_room, _EXTINGUISHERS)
    add("extinguisher", rows, np.column_stack([np.repeat(cx[cs_c], _EXTINGUISHERS)
                                               + np.tile(ext_k, cs_c.size) * 14.4 + 7.2,
                                               np.repeat(cy[cs_c], _EXTINGUISHERS) - 1.0,
                                               np.repeat(zc, _EXTINGUISHERS) + 0.6]))
    for end, xoff in ((0, -2.0), (1, _CORRIDOR_LEN + 2.0)):
        xs, ys = cx[cs_c] + xoff, cy[cs_c]
        flip = 1.0 if end == 0 else -1.0
        add("stair", last_room, np.column_stack([xs - flip * 0.8, ys + 1.5, zc + 0.1]))
        add("stair", last_room, np.column_stack([xs + flip * 0.8, ys + 1.5, zc + 0.5 * height]))
        add("elevator", last_room, np.column_stack([xs, ys - 1.6, zc + 1.05]))
        add("button", last_room, np.column_stack([xs + flip * 0.7, ys - 1.58, zc + 1.1]))
        add("sign", last_room, np.column_stack([xs, ys - 1.6, zc + 2.4]))
    codes = np.concatenate([b[0] for b in blocks])
    rows = np.concatenate([b[1] for b in blocks])
    pts = np.concatenate([b[2] for b in blocks])
    order = np.argsort(rows, kind="stable")[:n_objects]
    if order.size < n_objects:  # pragma: no cover - the plan is sized with 5 % to spare
        raise WorldGraphError(f"building plan holds {order.size} objects, fewer than n_objects = {n_objects}")
    return codes[order], pts[order], st[rows[order]]


def _site_world(codes: NDArray[np.intp], pts: NDArray[np.float64], max_link_length: float,
                link_margin: float) -> WorldModel:
    names = np.array(_BUILDING_TYPES, dtype=object)[codes]
    # the robots of a building localise with a levelled base: storey-aware association by default
    return WorldModel.from_arrays(names, pts, max_link_length=max_link_length, sizes=_SIZE_TABLE[codes],
                                  link_margin=link_margin, gravity_aligned=True)


def building_site(storeys: int = 5, n_objects: int = 100_000, seed: int = 0, storey_height: float = 3.5,
                  max_link_length: float = 5.0, link_margin: float = 0.0) -> Site:
    """A multi-storey office building as a :class:`Site` (world model, building and storey labels).

    Every storey has the same corridor grid: corridors along x, 57.6 m long, 16 m apart in y,
    8 m between wings, each with 16 identical 3.6 m room modules on either side.  A module is
    an office (a door with a handle, a switch and a sign on the corridor wall, a ceiling lamp,
    a radiator and a window on the outer wall, a table with two to four chairs, sometimes a
    cabinet), a double-window office (door shifted) or a store room (no window, no table, a
    cabinet).  Corridors have ceiling lamps every 3.6 m and four fire extinguishers; both ends
    of every corridor hold a stair core (two stair landings, an elevator door with its button,
    a storey sign).  Storey ``s`` stands at ``z = s * storey_height`` (world z up, REP 103; the
    world is marked ``gravity_aligned``; association is storey-aware by default in every world,
    ``gravity="auto"``);
    each storey's module kinds copy the storey below with probability 0.9, its furniture is
    drawn anew.  The top storey is cut (its last corridors) to exactly ``n_objects`` objects.

    Parameters
    ----------
    storeys : int
        ``1 <= storeys <=`` :data:`MAX_STOREYS`.
    n_objects : int
        ``1 <= n_objects <=`` :data:`MAX_SITE_OBJECTS`.
    seed : int
        Non-negative.
    storey_height : float
        Metres, ``MIN_STOREY_HEIGHT <= storey_height <= 100``.
    max_link_length, link_margin : float
        See :class:`WorldModel`.
    """
    storeys, n_objects, height = _site_args(storeys, n_objects, storey_height, max_link_length, link_margin)
    rng = np.random.default_rng(_seed(seed))
    codes, pts, st = _building_arrays(rng, storeys, n_objects, height, np.zeros(3))
    world = _site_world(codes, pts, max_link_length, link_margin)
    building_labels = np.zeros(len(codes), dtype=np.intp)
    st = st.astype(np.intp)
    building_labels.setflags(write=False)
    st.setflags(write=False)
    return Site(world, building_labels, st)


def building(storeys: int = 5, n_objects: int = 100_000, seed: int = 0, storey_height: float = 3.5,
             max_link_length: float = 5.0, link_margin: float = 0.0) -> WorldModel:
    """The world model of :func:`building_site` (its labels dropped)."""
    return building_site(storeys, n_objects, seed, storey_height, max_link_length, link_margin).world


def campus_site(buildings: int = 10, storeys: int = 5, n_objects: int = 1_000_000, seed: int = 0,
                storey_height: float = 3.5, max_link_length: float = 5.0, link_margin: float = 0.0,
                gap: float = 30.0) -> Site:
    """``buildings`` buildings of :func:`building_site` on a square grid, ``gap`` metres apart.

    The objects are split as evenly as possible (the first ``n_objects % buildings`` buildings
    get one more); building ``b`` is drawn from its own generator (seeded by ``seed`` and
    ``b``), so its plan and furniture differ from the others'.  ``1 <= buildings <=``
    :data:`MAX_BUILDINGS` and ``buildings <= n_objects``; ``gap`` in metres, ``> 0`` and at most
    10,000; the other arguments as for :func:`building_site`.
    """
    buildings = _checks.integer("buildings", buildings, minimum=1, maximum=MAX_BUILDINGS)
    storeys, n_objects, height = _site_args(storeys, n_objects, storey_height, max_link_length, link_margin)
    if buildings > n_objects:
        raise WorldGraphError(f"n_objects = {n_objects} must be >= buildings = {buildings}")
    gap = _checks.real_scalar("gap", gap, positive=True, maximum=10_000.0)
    seed = _seed(seed)
    per = np.full(buildings, n_objects // buildings)
    per[: n_objects % buildings] += 1
    per_side = math.ceil(math.sqrt(buildings))
    parts = []
    x_next, row_y, row_h = 0.0, 0.0, 0.0
    for b in range(buildings):  # one loop step per building, the objects are arrays
        if b and b % per_side == 0:
            x_next, row_y, row_h = 0.0, row_y + row_h + gap, 0.0
        rng = np.random.default_rng([seed, b])
        codes, pts, st = _building_arrays(rng, storeys, int(per[b]), height, np.array([x_next, row_y, 0.0]))
        # the next building starts beyond this one's footprint
        x_next = float(pts[:, 0].max()) + _WING_GAP + gap
        row_h = max(row_h, float(pts[:, 1].max()) - row_y + 8.0)
        parts.append((codes, pts, st, np.full(len(codes), b, dtype=np.intp)))
    codes = np.concatenate([p[0] for p in parts])
    pts = np.concatenate([p[1] for p in parts])
    st = np.concatenate([p[2] for p in parts]).astype(np.intp)
    labels = np.concatenate([p[3] for p in parts])
    world = _site_world(codes, pts, max_link_length, link_margin)
    labels.setflags(write=False)
    st.setflags(write=False)
    return Site(world, labels, st)


def campus(buildings: int = 10, storeys: int = 5, n_objects: int = 1_000_000, seed: int = 0,
           storey_height: float = 3.5, max_link_length: float = 5.0, link_margin: float = 0.0,
           gap: float = 30.0) -> WorldModel:
    """The world model of :func:`campus_site` (its labels dropped)."""
    return campus_site(buildings, storeys, n_objects, seed, storey_height, max_link_length, link_margin,
                       gap).world
