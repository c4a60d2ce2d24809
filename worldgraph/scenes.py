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
  building and storey of every object (:class:`Site`) for :func:`worldgraph.tiles.split`.

Every object of a scene is a geometry node of a :class:`trimesh.Scene` named
``f"{type}_{k:03d}"`` whose node metadata holds ``{"type": type}``; each mesh's metadata
holds ``{"primitive": "box" | "cylinder" | "polyhedron"}``.  Meshes are shared by reference
between nodes of one size class.  Walls, floor and ceiling are typed ``"wall"``, ``"floor"``
and ``"ceiling"`` (they are objects of the model like in the paper's CAD scene graph; drop them
with ``world.subset(...)`` if they are not wanted as landmarks, see :data:`STRUCTURAL_TYPES`).

World frame: z up, the floor at z = 0, the room in ``[0, 10] x [0, 8] x [0, 3]`` metres.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import trimesh
from numpy.typing import NDArray

from . import _checks
from .errors import WorldGraphError
from .model import MAX_COORDINATE, WorldModel
from .model.scene_nodes import _check_scene, _default_type
from .tolerances import FIT_SLACK

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
]

#: Extents (x, y, z) of the kitchen room in metres.
KITCHEN_ROOM = (10.0, 8.0, 3.0)
#: The paper's kitchen model (section 4).
KITCHEN_TARGETS = {"box": 611, "cylinder": 124, "polyhedron": 18, "vertices": 13853, "objects": 753}
#: Types of the room structure (not landmarks a robot would pick).
STRUCTURAL_TYPES = ("wall", "floor", "ceiling")

#: Largest ``n_doors`` of :func:`corridor_scene` / :func:`corridor`.
MAX_CORRIDOR_DOORS = 10_000
#: Largest ``n_objects`` of :func:`floor`.
MAX_FLOOR_OBJECTS = 1_000_000


def _seed(seed: object) -> int:
    """A scene seed: a non-negative integer (not bool, float, None, str or a Generator)."""
    return _checks.strict_int("seed", seed, minimum=0)


def _link_args(max_link_length: object, link_margin: object) -> None:
    """Check the link settings before a scene is built (:class:`WorldModel` checks them again)."""
    _checks.positive_float("max_link_length", max_link_length)
    _checks.positive_float("link_margin", link_margin, allow_zero=True)


_CYLINDER_SECTIONS = 32  # 2 * 32 + 2 = 66 vertices per cylinder
_UP = np.array([0.0, 0.0, 1.0])


# ----------------------------------------------------------------------------------------------
# meshes
# ----------------------------------------------------------------------------------------------
def _prism(bottom: NDArray[np.float64], top: NDArray[np.float64], z0: float, z1: float) -> trimesh.Trimesh:
    """Convex polyhedron between two convex polygons ``(k, 2)`` (counter-clockwise) at heights z0 < z1."""
    k = bottom.shape[0]
    verts = np.vstack([np.column_stack([bottom, np.full(k, z0)]), np.column_stack([top, np.full(k, z1)])])
    idx = np.arange(k)
    nxt = (idx + 1) % k
    sides = np.vstack([np.column_stack([idx, nxt, nxt + k]), np.column_stack([idx, nxt + k, idx + k])])
    fan = np.column_stack([np.zeros(k - 2, int), np.arange(2, k), np.arange(1, k - 1)])  # bottom, facing down
    cap = np.column_stack([np.full(k - 2, k), k + np.arange(1, k - 1), k + np.arange(2, k)])
    mesh = trimesh.Trimesh(verts, np.vstack([sides, fan, cap]), process=False)
    return mesh


def _rounded_rect(width: float, depth: float, radius: float, segments: int) -> NDArray[np.float64]:
    """Counter-clockwise rounded rectangle ``(4 * (segments + 1), 2)`` centred at 0."""
    pts = []
    hx, hy = width / 2 - radius, depth / 2 - radius
    corners = [(hx, hy, 0.0), (-hx, hy, 0.5), (-hx, -hy, 1.0), (hx, -hy, 1.5)]
    for cx, cy, start in corners:
        ang = math.pi * (start + 0.5 * np.linspace(0.0, 1.0, segments + 1))
        pts.append(np.column_stack([cx + radius * np.cos(ang), cy + radius * np.sin(ang)]))
    return np.vstack(pts)


def _rounded_box(size: tuple[float, float, float], radius: float, segments: int = 4,
                 taper: float = 1.0) -> trimesh.Trimesh:
    """A rounded (and optionally tapered) box centred at 0: 8 * (segments + 1) vertices."""
    w, d, h = size
    base = _rounded_rect(w, d, radius, segments)
    return _prism(base, base * taper, -h / 2, h / 2)


def _frustum(radius: float, height: float, sides: int, taper: float) -> trimesh.Trimesh:
    """A regular ``sides``-gon frustum (top radius ``taper * radius``): 2 * sides vertices."""
    ang = np.linspace(0.0, 2 * math.pi, sides, endpoint=False)
    ring = radius * np.column_stack([np.cos(ang), np.sin(ang)])
    return _prism(ring, ring * taper, -height / 2, height / 2)


# ----------------------------------------------------------------------------------------------
# scene builder
# ----------------------------------------------------------------------------------------------
def _frame(origin: NDArray[np.float64], normal: NDArray[np.float64]) -> NDArray[np.float64]:
    """``world_from_run``: x along the run, y out of the wall (``normal``), z up."""
    n = np.asarray(normal, dtype=np.float64)
    u = np.cross(n, _UP)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = u, n, _UP, origin
    return m


def _translate(x: float, y: float, z: float) -> NDArray[np.float64]:
    m = np.eye(4)
    m[:3, 3] = (x, y, z)
    return m


_ROT_X90 = np.array([[1.0, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]])  # local z axis -> -y


@dataclass
class _Builder:
    scene: trimesh.Scene = field(default_factory=trimesh.Scene)
    counts: dict[str, int] = field(default_factory=dict)
    primitives: dict[str, int] = field(default_factory=lambda: {"box": 0, "cylinder": 0, "polyhedron": 0})
    #: node metadata type of a builder type when it differs (``None``: in the scene, not an object)
    types: dict[str, str | None] = field(default_factory=dict)
    #: surfaces clutter can stand on: (world_from_run, (x0, x1), (y0, y1), z)
    surfaces: list[tuple[NDArray[np.float64], tuple[float, float], tuple[float, float], float]] = field(
        default_factory=list)

    def _geometry(self, key: str, make: trimesh.Trimesh | Callable[[], trimesh.Trimesh],
                  primitive: str) -> str:
        if key not in self.scene.geometry:
            mesh = make() if callable(make) else make
            mesh.metadata["primitive"] = primitive
            self.scene.geometry.update({key: mesh})
        return key

    def _node(self, typ: str, key: str, matrix: NDArray[np.float64], primitive: str) -> str:
        k = self.counts.get(typ, 0)
        self.counts[typ] = k + 1
        name = f"{typ}_{k:03d}"
        self.scene.graph.update(frame_to=name, frame_from=self.scene.graph.base_frame, matrix=matrix,
                                geometry=key, metadata={"type": self.types.get(typ, typ)})
        self.primitives[primitive] += 1
        return name

    def box(self, typ: str, size: tuple[float, float, float], world_from_box: NDArray[np.float64],
            key: str | None = None) -> str:
        """Box of extents ``size`` whose centre frame is ``world_from_box``."""
        size = tuple(round(float(s), 4) for s in size)  # type: ignore[assignment]
        gkey = self._geometry(key or f"box_{size[0]:g}x{size[1]:g}x{size[2]:g}",
                              lambda: trimesh.creation.box(extents=size), "box")
        return self._node(typ, gkey, world_from_box, "box")

    def cylinder(self, typ: str, radius: float, height: float, world_from_cyl: NDArray[np.float64]) -> str:
        """Cylinder along its local z axis, centred at the frame origin."""
        radius, height = round(float(radius), 4), round(float(height), 4)
        gkey = self._geometry(f"cylinder_r{radius:g}_h{height:g}",
                              lambda: trimesh.creation.cylinder(radius=radius, height=height,
                                                                sections=_CYLINDER_SECTIONS), "cylinder")
        return self._node(typ, gkey, world_from_cyl, "cylinder")

    def polyhedron(self, typ: str, key: str, mesh: trimesh.Trimesh,
                   world_from_mesh: NDArray[np.float64]) -> str:
        gkey = self._geometry(key, mesh, "polyhedron")
        return self._node(typ, gkey, world_from_mesh, "polyhedron")

    def local_box(self, typ: str, run: NDArray[np.float64], lo: tuple[float, float, float],
                  hi: tuple[float, float, float], key: str | None = None) -> str:
        """Axis-aligned box between corners ``lo`` and ``hi`` of a run frame."""
        lo_a, hi_a = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
        c = 0.5 * (lo_a + hi_a)
        size = (float(hi_a[0] - lo_a[0]), float(hi_a[1] - lo_a[1]), float(hi_a[2] - lo_a[2]))
        return self.box(typ, size, run @ _translate(*c), key)


# ----------------------------------------------------------------------------------------------
# kitchen
# ----------------------------------------------------------------------------------------------
_BASE_WIDTHS = np.array([0.4, 0.45, 0.5, 0.6, 0.6, 0.8])
_WALL_WIDTHS = np.array([0.4, 0.5, 0.6, 0.6, 0.8])
_HANDLE = (0.16, 0.03, 0.012)  # bar handle: length, depth (out of the front), thickness
_KNOB_R, _KNOB_H = 0.015, 0.025
_CYLINDER_CLUTTER = ((0.04, 0.1, "cup"), (0.05, 0.14, "jar"), (0.035, 0.3, "bottle"))


def _handle(b: _Builder, run: NDArray[np.float64], x: float, y_front: float, z: float,
            vertical: bool) -> None:
    length, depth, thick = _HANDLE
    size = (thick, depth, length) if vertical else (length, depth, thick)
    b.box("handle", size, run @ _translate(x, y_front + depth / 2, z), key="handle_bar_v" if vertical
          else "handle_bar_h")


def _knob(b: _Builder, run: NDArray[np.float64], x: float, y_front: float, z: float,
          typ: str = "knob") -> None:
    b.cylinder(typ, _KNOB_R, _KNOB_H, run @ _translate(x, y_front + _KNOB_H / 2, z) @ _ROT_X90)


def _base_unit(b: _Builder, rng: np.random.Generator, run: NDArray[np.float64], x0: float, w: float,
               depth: float, front: str, knobs: bool | None = None) -> None:
    """Base cabinet: carcass, shelf, doors or a drawer stack, a handle (or knob) per front."""
    z0, z1 = 0.1, 0.86
    b.local_box("cabinet", run, (x0 + 0.002, 0.0, z0), (x0 + w - 0.002, depth - 0.02, z1))
    b.local_box("plinth", run, (x0, depth - 0.08, 0.0), (x0 + w, depth - 0.06, z0))
    yf = depth
    if front == "drawers":
        n = int(rng.integers(3, 5))
        h = (z1 - z0) / n
        with_knobs = bool(rng.random() < 0.3) if knobs is None else knobs
        for k in range(n):
            zb = z0 + k * h
            b.local_box("drawer", run, (x0 + 0.003, yf - 0.02, zb + 0.003),
                        (x0 + w - 0.003, yf, zb + h - 0.003))
            if with_knobs:
                _knob(b, run, x0 + w / 2, yf, zb + h - 0.06)
            else:
                _handle(b, run, x0 + w / 2, yf, zb + h - 0.06, vertical=False)
    else:
        b.local_box("shelf", run, (x0 + 0.02, 0.02, 0.47), (x0 + w - 0.02, depth - 0.04, 0.49))
        b.surfaces.append((run, (x0 + 0.06, x0 + w - 0.06), (0.08, depth - 0.12), 0.49))
        ndoor = 1 if w <= 0.6 else 2
        dw = w / ndoor
        for k in range(ndoor):
            xa = x0 + k * dw
            b.local_box("door", run, (xa + 0.003, yf - 0.02, z0 + 0.003), (xa + dw - 0.003, yf, z1 - 0.003))
            hinge_left = (k == 1) if ndoor == 2 else bool(rng.random() < 0.5)
            hx = xa + 0.05 if not hinge_left else xa + dw - 0.05
            _handle(b, run, hx, yf, z1 - 0.12, vertical=True)


def _wall_unit(b: _Builder, rng: np.random.Generator, run: NDArray[np.float64], x0: float, w: float,
               z0: float = 1.45, z1: float = 2.2, depth: float = 0.35) -> None:
    b.local_box("cabinet", run, (x0 + 0.002, 0.0, z0), (x0 + w - 0.002, depth - 0.02, z1))
    zm = 0.5 * (z0 + z1)
    b.local_box("shelf", run, (x0 + 0.02, 0.02, zm - 0.01), (x0 + w - 0.02, depth - 0.04, zm + 0.01))
    b.surfaces.append((run, (x0 + 0.06, x0 + w - 0.06), (0.06, depth - 0.1), zm + 0.01))
    b.surfaces.append((run, (x0 + 0.06, x0 + w - 0.06), (0.06, depth - 0.1), z0 + 0.02))
    ndoor = 1 if w <= 0.6 else 2
    dw = w / ndoor
    for k in range(ndoor):
        xa = x0 + k * dw
        b.local_box("door", run, (xa + 0.003, depth - 0.02, z0 + 0.003), (xa + dw - 0.003, depth, z1 - 0.003))
        hinge_left = (k == 1) if ndoor == 2 else bool(rng.random() < 0.5)
        hx = xa + 0.05 if not hinge_left else xa + dw - 0.05
        _handle(b, run, hx, depth, z0 + 0.12, vertical=True)


def _fill_widths(rng: np.random.Generator, length: float, widths: NDArray[np.float64]) -> list[float]:
    """Cabinet widths (from ``widths``) that fill ``length`` up to < 0.4 m."""
    out: list[float] = []
    left = length
    while left >= widths.min() - FIT_SLACK:
        fit = widths[widths <= left + FIT_SLACK]
        w = float(rng.choice(fit))
        out.append(w)
        left -= w
    return out


def _appliance_meshes() -> dict[str, tuple[str, trimesh.Trimesh]]:
    """The 18 general polyhedra: key -> (type, mesh centred at its bounding-box centre)."""
    m: dict[str, tuple[str, trimesh.Trimesh]] = {}
    m["fridge"] = ("appliance", _rounded_box((0.88, 0.66, 2.0), 0.04, 4))
    m["oven"] = ("appliance", _rounded_box((0.58, 0.56, 0.58), 0.02, 4))
    m["steam_oven"] = ("appliance", _rounded_box((0.58, 0.56, 0.45), 0.02, 4))
    m["cooktop"] = ("appliance", _rounded_box((0.58, 0.5, 0.05), 0.03, 4))
    m["hood"] = ("appliance", _rounded_box((0.9, 0.5, 0.4), 0.03, 4, taper=0.45))
    m["dishwasher"] = ("appliance", _rounded_box((0.58, 0.56, 0.76), 0.01, 4))
    m["microwave"] = ("appliance", _rounded_box((0.5, 0.38, 0.3), 0.03, 4))
    m["wine_cooler"] = ("appliance", _rounded_box((0.58, 0.56, 0.76), 0.015, 4))
    m["washer"] = ("appliance", _rounded_box((0.58, 0.56, 0.76), 0.05, 4))
    m["coffee_machine"] = ("appliance", _rounded_box((0.25, 0.4, 0.38), 0.05, 4))
    m["toaster"] = ("appliance", _rounded_box((0.3, 0.18, 0.2), 0.06, 4))
    m["kettle"] = ("appliance", _frustum(0.1, 0.25, 20, 0.7))
    m["blender"] = ("appliance", _rounded_box((0.16, 0.16, 0.4), 0.05, 4, taper=0.8))
    m["mixer"] = ("appliance", _rounded_box((0.22, 0.36, 0.35), 0.08, 4))
    m["trash_bin"] = ("appliance", _frustum(0.15, 0.6, 20, 1.15))
    m["sink"] = ("sink", _rounded_box((0.5, 0.4, 0.2), 0.06, 4, taper=0.85))
    m["sink_island"] = ("sink", _rounded_box((0.4, 0.4, 0.2), 0.08, 4, taper=0.85))
    m["radio"] = ("appliance", _rounded_box((0.3, 0.12, 0.18), 0.04, 4))
    return m


def _appliance(b: _Builder, apps: dict[str, tuple[str, trimesh.Trimesh]], name: str, run: NDArray[np.float64],
               centre: tuple[float, float, float], typ: str | None = None) -> str:
    """Place appliance mesh ``name`` centred at ``centre`` of a run frame (type: its default or ``typ``)."""
    default, mesh = apps[name]
    return b.polyhedron(typ or default, name, mesh, run @ _translate(*centre))


def _room(b: _Builder, rx: float, ry: float, rz: float) -> None:
    """Floor (top at z = 0), ceiling (bottom at ``rz``) and 4 walls 0.1 m thick around
    ``[0, rx] x [0, ry]``: 6 boxes."""
    b.box("floor", (rx, ry, 0.05), _translate(rx / 2, ry / 2, -0.025))
    b.box("ceiling", (rx, ry, 0.05), _translate(rx / 2, ry / 2, rz + 0.025))
    b.box("wall", (rx, 0.1, rz), _translate(rx / 2, -0.05, rz / 2))
    b.box("wall", (rx, 0.1, rz), _translate(rx / 2, ry + 0.05, rz / 2))
    b.box("wall", (0.1, ry, rz), _translate(-0.05, ry / 2, rz / 2))
    b.box("wall", (0.1, ry, rz), _translate(rx + 0.05, ry / 2, rz / 2))


def kitchen_scene(seed: int = 0) -> trimesh.Scene:
    """A procedurally generated kitchen as a :class:`trimesh.Scene` (see the module docstring).

    Parameters
    ----------
    seed : int
        Draws the cabinet widths, fronts, handle sides, clutter; the same seed gives the same
        scene, node names and transforms.

    Returns
    -------
    trimesh.Scene
        753 geometry nodes: 611 boxes, 124 cylinders, 18 general polyhedra; ``scene.metadata``
        holds ``"primitive_counts"`` and ``"seed"``.
    """
    seed = _seed(seed)
    rng = np.random.default_rng(seed)
    b = _Builder()
    rx, ry, rz = KITCHEN_ROOM
    _room(b, rx, ry, rz)
    # room door in the right wall (x = rx), facing -x
    door_run = _frame(np.array([rx, 1.0, 0.0]), np.array([-1.0, 0.0, 0.0]))
    b.local_box("door", door_run, (0.0, 0.0, 0.0), (0.9, 0.04, 2.05))
    b.local_box("frame", door_run, (-0.06, 0.0, 0.0), (0.0, 0.06, 2.1))
    b.local_box("frame", door_run, (0.9, 0.0, 0.0), (0.96, 0.06, 2.1))
    b.local_box("frame", door_run, (-0.06, 0.0, 2.05), (0.96, 0.06, 2.1))
    _handle(b, door_run, 0.8, 0.04, 1.05, vertical=False)
    b.local_box("switch", door_run, (1.05, 0.0, 1.02), (1.13, 0.012, 1.1))
    # windows in the front wall (y = 0)
    win_run = _frame(np.array([0.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]))
    n_win = 2
    for k in range(n_win):
        xc = (k + 1) * rx / (n_win + 1) + rng.uniform(-0.3, 0.3)
        b.local_box("window", win_run, (xc - 0.6, 0.0, 1.0), (xc + 0.6, 0.08, 2.2))
        b.local_box("windowsill", win_run, (xc - 0.65, 0.0, 0.95), (xc + 0.65, 0.2, 1.0))
        b.local_box("radiator", win_run, (xc - 0.5, 0.05, 0.2), (xc + 0.5, 0.15, 0.8))

    apps = _appliance_meshes()

    def appliance(name: str, run: NDArray[np.float64], centre: tuple[float, float, float]) -> None:
        _appliance(b, apps, name, run, centre)

    # --- run A along the back wall (y = ry), facing -y, from x = rx (right) to x = 0 (left)
    run_a = _frame(np.array([rx, ry, 0.0]), np.array([0.0, -1.0, 0.0]))
    x = 0.0
    # tall units at the right end: fridge, oven tower (steam oven + oven + microwave), pantry
    appliance("fridge", run_a, (x + 0.45, 0.34, 1.0))
    x += 0.9
    b.local_box("cabinet", run_a, (x, 0.0, 0.0), (x + 0.6, 0.58, 2.2))
    appliance("steam_oven", run_a, (x + 0.3, 0.3, 1.55))
    appliance("oven", run_a, (x + 0.3, 0.3, 0.95))
    b.local_box("drawer", run_a, (x + 0.003, 0.56, 0.1), (x + 0.597, 0.58, 0.62))
    _handle(b, run_a, x + 0.3, 0.58, 0.56, vertical=False)
    b.local_box("door", run_a, (x + 0.003, 0.56, 1.8), (x + 0.597, 0.58, 2.2))
    _handle(b, run_a, x + 0.3, 0.58, 1.85, vertical=False)
    x += 0.6
    n_pantry = 2
    for _ in range(n_pantry):
        b.local_box("cabinet", run_a, (x, 0.0, 0.0), (x + 0.6, 0.58, 2.2))
        for zs in (0.5, 0.9, 1.3, 1.7):
            b.local_box("shelf", run_a, (x + 0.02, 0.02, zs), (x + 0.58, 0.54, zs + 0.02))
            b.surfaces.append((run_a, (x + 0.08, x + 0.52), (0.08, 0.45), zs + 0.02))
        b.local_box("door", run_a, (x + 0.003, 0.56, 0.1), (x + 0.597, 0.58, 2.197))
        _handle(b, run_a, x + 0.05, 0.58, 1.0, vertical=True)
        x += 0.6
    # base run with sink, dishwasher, cooktop over oven-free drawers
    base_len_a = rx - x - 0.62  # leave the corner to run B
    widths = _fill_widths(rng, base_len_a - 0.6 * 2, _BASE_WIDTHS)  # two 0.6 slots: dishwasher, sink
    slots: list[tuple[str, float]] = [("base", w) for w in widths]
    pos_dw = int(rng.integers(0, len(slots) + 1))
    slots.insert(pos_dw, ("dishwasher", 0.6))
    slots.insert(pos_dw + int(rng.integers(0, 2)), ("sink", 0.6))
    cook_slot = next(k for k, (kind, w) in enumerate(slots) if kind == "base" and w >= 0.6)
    slots[cook_slot] = ("cooktop", slots[cook_slot][1])
    run_a_start = x
    for kind, w in slots:
        if kind == "dishwasher":
            appliance("dishwasher", run_a, (x + 0.3, 0.3, 0.48))
            _handle(b, run_a, x + 0.3, 0.58, 0.8, vertical=False)
        elif kind == "sink":
            _base_unit(b, rng, run_a, x, w, 0.58, "doors")
            appliance("sink", run_a, (x + 0.3, 0.3, 0.8))
            b.cylinder("faucet", 0.015, 0.3, run_a @ _translate(x + 0.3, 0.08, 1.05))
        elif kind == "cooktop":
            _base_unit(b, rng, run_a, x, w, 0.58, "drawers", knobs=False)
            appliance("cooktop", run_a, (x + w / 2, 0.3, 0.925))
            appliance("hood", run_a, (x + w / 2, 0.25, 1.9))
            for k in range(5):
                _knob(b, run_a, x + w / 2 - 0.2 + 0.1 * k, 0.58, 0.835)
            for k in range(4):  # pots and pans on the burners
                b.cylinder("pot", 0.09 + 0.02 * (k % 2), 0.12, run_a @ _translate(
                    x + w / 2 + (-0.14 if k % 2 == 0 else 0.14), 0.18 + 0.24 * (k // 2), 1.01))
        else:
            _base_unit(b, rng, run_a, x, w, 0.58, "drawers" if rng.random() < 0.35 else "doors")
        x += w
    b.local_box("countertop", run_a, (run_a_start, 0.0, 0.86), (rx - 0.62, 0.62, 0.9))
    b.local_box("backsplash", run_a, (run_a_start, 0.0, 0.9), (rx - 0.01, 0.01, 1.45))
    # wall cabinets over run A (except over the hood)
    cook_x = run_a_start + sum(w for _, w in slots[:cook_slot])
    cook_w = slots[cook_slot][1]
    for xa, xb in ((run_a_start, cook_x), (cook_x + cook_w, rx - 0.35)):
        xw = xa
        for w in _fill_widths(rng, xb - xa, _WALL_WIDTHS):
            _wall_unit(b, rng, run_a, xw, w)
            xw += w

    # --- run B along the left wall (x = 0), facing +x, from y = ry - 0.62 down
    run_b = _frame(np.array([0.0, ry - 0.62, 0.0]), np.array([1.0, 0.0, 0.0]))
    # along run B, local x goes in direction n x up = (0, -1, 0): from the back wall towards y = 0
    len_b = ry - 0.62 - 1.8
    widths_b = _fill_widths(rng, len_b - 0.6, _BASE_WIDTHS)
    pos_w = int(rng.integers(0, len(widths_b) + 1))
    slots_b: list[tuple[str, float]] = [("base", w) for w in widths_b]
    slots_b.insert(pos_w, ("washer", 0.6))
    x = 0.0
    for kind, w in slots_b:
        if kind == "washer":
            appliance("washer", run_b, (x + 0.3, 0.3, 0.48))
        else:
            _base_unit(b, rng, run_b, x, w, 0.58, "drawers" if rng.random() < 0.4 else "doors")
        x += w
    end_b = x
    b.local_box("countertop", run_b, (-0.62, 0.0, 0.86), (end_b, 0.62, 0.9))
    b.local_box("backsplash", run_b, (0.0, 0.0, 0.9), (end_b, 0.01, 1.45))
    xw = 0.35
    for w in _fill_widths(rng, end_b - 0.35, _WALL_WIDTHS):
        _wall_unit(b, rng, run_b, xw, w)
        xw += w
    # open shelves over the rest of run B wall
    for zs in (1.5, 1.9):
        b.local_box("shelf", run_b, (end_b + 0.2, 0.0, zs), (end_b + 1.4, 0.3, zs + 0.03))

    # --- island: two back-to-back runs of base units, centred in the room
    isl_len = float(rng.choice([2.4, 2.6, 2.8]))
    isl_c = np.array([rx / 2 + rng.uniform(-0.3, 0.3), ry / 2 + rng.uniform(-0.2, 0.2)])
    for side in (-1.0, 1.0):
        normal = np.array([0.0, side, 0.0])
        origin_along = np.cross(normal, _UP)  # run direction
        start = np.array([isl_c[0], isl_c[1], 0.0]) - origin_along * isl_len / 2
        run_i = _frame(start, normal)  # the "wall" of each side is the island's mid plane
        xi = 0.0
        wi = _fill_widths(rng, isl_len, _BASE_WIDTHS)
        for k, w in enumerate(wi):
            if side > 0 and k == 0:
                appliance("wine_cooler", run_i, (xi + w / 2, 0.28, 0.48))
            elif side > 0 and k == len(wi) - 1:
                _base_unit(b, rng, run_i, xi, w, 0.48, "doors")
                appliance("sink_island", run_i, (xi + w / 2, 0.3, 0.8))
                b.cylinder("faucet", 0.015, 0.3, run_i @ _translate(xi + w / 2, 0.05, 1.05))
            else:
                _base_unit(b, rng, run_i, xi, w, 0.48, "drawers" if rng.random() < 0.5 else "doors")
            xi += w
    b.box("countertop", (isl_len + 0.1, 1.1, 0.04), _translate(isl_c[0], isl_c[1], 0.88))
    # pendant lamps over the island, ceiling lamps
    for k in range(3):
        b.cylinder("lamp", 0.12, 0.15, _translate(isl_c[0] + (k - 1) * 0.8, isl_c[1], 2.0))
        b.cylinder("cable", 0.004, 0.92, _translate(isl_c[0] + (k - 1) * 0.8, isl_c[1], 2.54))
    for lx, ly in ((2.5, 2.0), (7.5, 2.0), (2.5, 6.0), (7.5, 6.0)):
        b.cylinder("lamp", 0.2, 0.06, _translate(lx, ly, rz - 0.03))

    # --- table with chairs near the window wall
    tc = np.array([7.2 + rng.uniform(-0.3, 0.3), 1.9 + rng.uniform(-0.2, 0.2)])
    b.box("table", (1.6, 0.9, 0.04), _translate(tc[0], tc[1], 0.74))
    for sx in (-1, 1):
        for sy in (-1, 1):
            b.cylinder("table_leg", 0.025, 0.72, _translate(tc[0] + sx * 0.72, tc[1] + sy * 0.38, 0.36))
    for k in range(6):
        off_x = (k % 3 - 1) * 0.5
        off_y = -0.7 if k < 3 else 0.7
        cx, cy = tc[0] + off_x + rng.uniform(-0.05, 0.05), tc[1] + off_y + rng.uniform(-0.05, 0.05)
        b.box("chair", (0.42, 0.42, 0.04), _translate(cx, cy, 0.45), key="chair_seat")
        by = cy + (0.2 if off_y > 0 else -0.2)
        b.box("chair_back", (0.42, 0.03, 0.45), _translate(cx, by, 0.7))
        for lx in (-0.18, 0.18):
            for ly in (-0.18, 0.18):
                b.cylinder("chair_leg", 0.015, 0.43, _translate(cx + lx, cy + ly, 0.215))

    # --- small appliances on the countertops
    small = ["microwave", "coffee_machine", "toaster", "kettle", "blender", "mixer", "radio"]
    ca_lo, ca_hi = run_a_start + 0.2, rx - 0.6
    xs = ca_lo + (np.arange(len(small)) + 0.5) * (ca_hi - ca_lo) / len(small)
    xs = xs + rng.uniform(-0.05, 0.05, len(small))
    for name, xa in zip(small, xs, strict=True):
        _, mesh = apps[name]
        h = float(mesh.bounds[1, 2] - mesh.bounds[0, 2])
        appliance(name, run_a, (float(xa), 0.25, 0.9 + h / 2))
    appliance("trash_bin", run_b, (end_b + 0.3, 0.25, 0.3))

    # --- clutter: fill the paper's primitive counts with boxes (packages, books) and cylinders
    # (jars, cups, bottles) on the open shelves, the island and the counters
    n_box = KITCHEN_TARGETS["box"] - b.primitives["box"]
    n_cyl = KITCHEN_TARGETS["cylinder"] - b.primitives["cylinder"]
    if n_box < 0 or n_cyl < 0 or b.primitives["polyhedron"] != KITCHEN_TARGETS["polyhedron"]:
        raise WorldGraphError(f"kitchen layout for seed {seed} overshoots the paper's counts: {b.primitives}")
    surfaces = list(b.surfaces) + [  # open shelves, the island, the counters
        (run_b, (end_b + 0.25, end_b + 1.35), (0.05, 0.25), 1.53),
        (run_b, (end_b + 0.25, end_b + 1.35), (0.05, 0.25), 1.93),
        (_translate(isl_c[0] - isl_len / 2, isl_c[1] - 0.45, 0.0), (0.1, isl_len - 0.1), (0.1, 0.8), 0.9),
        (run_b, (0.4, end_b - 0.2), (0.05, 0.45), 0.9),
        (run_a, (run_a_start + 0.1, rx - 0.7), (0.45, 0.58), 0.9),
    ]
    weights = np.ones(len(surfaces))
    weights[-5:] = 4.0
    weights /= weights.sum()
    for kind, n in (("box", n_box), ("cylinder", n_cyl)):
        which = rng.choice(len(surfaces), size=n, p=weights)
        for k in range(n):
            frame, (xa, xb), (ya, yb), zs = surfaces[which[k]]
            px, py = rng.uniform(xa, xb), rng.uniform(ya, yb)
            if kind == "box":
                sz = (0.06, 0.2, 0.28) if rng.random() < 0.5 else (0.16, 0.06, 0.24)
                typ = "package" if sz[0] > 0.1 else "book"
                b.box(typ, sz, frame @ _translate(px, py, zs + sz[2] / 2))
            else:
                r, h, typ = _CYLINDER_CLUTTER[int(rng.integers(len(_CYLINDER_CLUTTER)))]
                b.cylinder(typ, r, h, frame @ _translate(px, py, zs + h / 2))
    b.scene.metadata["primitive_counts"] = dict(b.primitives)
    b.scene.metadata["seed"] = int(seed)
    return b.scene


def kitchen(seed: int = 0, max_link_length: float = 5.0, link_margin: float = 0.0) -> WorldModel:
    """The kitchen of :func:`kitchen_scene` as a :class:`WorldModel` (753 objects)."""
    _link_args(max_link_length, link_margin)
    return WorldModel.from_trimesh(kitchen_scene(seed), max_link_length=max_link_length,
                                   link_margin=link_margin)


# ----------------------------------------------------------------------------------------------
# kitchen layouts
# ----------------------------------------------------------------------------------------------
#: The layouts of :func:`kitchen_layout_scene` (after RoboCasa's kitchen layouts).
LAYOUT_KINDS = ("one_wall", "galley", "l_shape", "u_shape", "island")
#: Object types of a layout's world model.
LAYOUT_TYPES = ("door", "drawer", "handle", "knob", "panel", "oven", "stove", "fridge", "dishwasher",
                "microwave", "sink")
# builder types that are structure in a layout (in the scene, not objects)
_LAYOUT_SCENE_TYPES: dict[str, str | None] = {"cabinet": None, "shelf": None, "plinth": None,
                                              "countertop": None, "backsplash": None}
_MODULE_WIDTHS = (0.45, 0.5, 0.6, 0.8)  # widths of the repeated cabinet modules
_SLOT_WIDTHS = {"fridge": 0.9, "range": 0.6, "sink": 0.6, "dishwasher": 0.6}
_COUNTER_DEPTH = 0.62
_END_PANEL = 0.02  # thickness of the panel closing a run's free end


@dataclass(frozen=True)
class _Module:
    """A cabinet repeated along the runs: every copy has the same width, fronts, handles."""

    width: float
    front: str  # "doors" | "drawers"
    seed: int  # draws the drawer count, knobs and hinge sides, the same for every copy


def _modules(rng: np.random.Generator) -> list[_Module]:
    """The 2 or 3 cabinet modules (distinct widths) a layout repeats in all its runs."""
    n = int(rng.integers(2, 4))
    widths = rng.choice(_MODULE_WIDTHS, size=n, replace=False)
    return [_Module(float(w), "drawers" if rng.random() < 0.4 else "doors", int(rng.integers(2**31)))
            for w in widths]


def _plan_run(rng: np.random.Generator, length: float, modules: list[_Module], appliances: tuple[str, ...],
              optional: tuple[str, ...] = ()) -> list[tuple[str, float, _Module | None]]:
    """Slots ``(kind, width, module)`` filling a run of ``length`` metres.

    The appliances (a fridge goes first), the optional ones if a bank of two of the widest modules
    still fits, then banks of 2-4 identical modules, in a random order; the rest is one narrow door unit
    (>= 0.3 m) or a filler panel.
    """
    free = length - sum(_SLOT_WIDTHS[a] for a in appliances)
    widest = max(m.width for m in modules)
    chosen = [a for a in appliances if a != "fridge"]
    for a in optional:
        if free - _SLOT_WIDTHS[a] >= 2 * widest:
            chosen.append(a)
            free -= _SLOT_WIDTHS[a]
    if free < -FIT_SLACK:
        raise WorldGraphError(f"run of {length:.2f} m is too short for {appliances}")
    blocks: list[list[tuple[str, float, _Module | None]]] = [[(a, _SLOT_WIDTHS[a], None)] for a in chosen]
    while True:
        fits = [m for m in modules if 2 * m.width <= free + FIT_SLACK]
        if not fits:
            break
        m = fits[int(rng.integers(len(fits)))]
        n = int(rng.integers(2, min(4, int((free + FIT_SLACK) // m.width)) + 1))
        blocks.append([("unit", m.width, m)] * n)
        free -= n * m.width
    slots = [s for k in rng.permutation(len(blocks)) for s in blocks[k]]
    free = round(free, 3)
    if free >= 0.3:
        narrow = _Module(free, "doors", int(rng.integers(2**31)))
        slots.insert(int(rng.integers(len(slots) + 1)), ("unit", free, narrow))
    elif free >= 0.03:
        slots.append(("filler", free, None))
    if "fridge" in appliances:
        slots.insert(0, ("fridge", _SLOT_WIDTHS["fridge"], None))
    return slots


def _build_run(b: _Builder, rng: np.random.Generator, apps: dict[str, tuple[str, trimesh.Trimesh]],
               run: NDArray[np.float64], slots: list[tuple[str, float, _Module | None]], rz: float,
               depth: float = 0.58, wall_units: bool = True, counter: tuple[float, float] | None = (0.0, 0.0),
               end_panel: bool = True) -> float:
    """Base units, appliances and (``wall_units``) wall units of ``slots`` from x = 0 of a run frame.

    ``counter`` extends the countertop before the first / after the last counter slot (corners),
    ``None`` leaves it out; ``end_panel`` closes the run's far end.  Returns the run length.
    """
    x = 0.0
    counter_x: list[float] = []
    for kind, w, m in slots:
        xc = x + w / 2
        if kind == "unit" and m is not None:
            _base_unit(b, np.random.default_rng(m.seed), run, x, w, depth, m.front)
            if wall_units:
                _wall_unit(b, np.random.default_rng(m.seed + 1), run, x, w)
        elif kind == "sink":
            _base_unit(b, rng, run, x, w, depth, "doors")
            _appliance(b, apps, "sink", run, (xc, depth / 2, 0.8), "sink")
        elif kind == "dishwasher":
            _appliance(b, apps, "dishwasher", run, (xc, 0.3, 0.48), "dishwasher")
            _handle(b, run, xc, 0.58, 0.8, vertical=False)
            if wall_units:
                _wall_unit(b, rng, run, x, w)
        elif kind == "range":  # oven below, stove on top, 4 stove knobs and an oven knob in between
            _appliance(b, apps, "oven", run, (xc, 0.3, 0.39), "oven")
            _handle(b, run, xc, 0.58, 0.62, vertical=False)
            b.local_box("cabinet", run, (x + 0.002, 0.0, 0.68), (x + w - 0.002, 0.58, 0.86))
            for k in range(5):
                _knob(b, run, xc + 0.1 * (k - 2), 0.58, 0.77)
            _appliance(b, apps, "cooktop", run, (xc, 0.3, 0.925), "stove")
            if wall_units:  # over-the-range microwave under a short wall unit
                _appliance(b, apps, "microwave", run, (xc, 0.19, 1.6), "microwave")
                _handle(b, run, xc + 0.2, 0.38, 1.6, vertical=True)
                _wall_unit(b, rng, run, x, w, z0=1.8)
        elif kind == "fridge":
            _appliance(b, apps, "fridge", run, (xc, 0.34, 1.0), "fridge")
            _handle(b, run, x + w - 0.1, 0.67, 1.3, vertical=True)
            _handle(b, run, xc, 0.67, 0.7, vertical=False)
            if wall_units and rz - 0.05 - 2.05 >= 0.3:
                _wall_unit(b, rng, run, x, w, z0=2.05, z1=min(2.45, rz - 0.05))
        else:  # filler panel
            b.local_box("panel", run, (x + 0.003, depth - 0.02, 0.1), (x + w - 0.003, depth, 0.86))
        if kind != "fridge":
            counter_x.extend((x, x + w))
        x += w
    if counter is not None and counter_x:
        x0, x1 = min(counter_x) - counter[0], max(counter_x) + counter[1]
        b.local_box("countertop", run, (x0, 0.0, 0.86), (x1, depth + 0.04, 0.9))
        if wall_units:
            b.local_box("backsplash", run, (x0, 0.0, 0.9), (x1, 0.01, 1.45))
    if end_panel:
        b.local_box("panel", run, (x, 0.0, 0.0), (x + _END_PANEL, depth + 0.04, 0.9))
    return x


def _uniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    """A length drawn in ``[lo, hi]`` rounded to the centimetre."""
    return round(float(rng.uniform(lo, hi)), 2)


def kitchen_layout_scene(kind: str, seed: int = 0) -> trimesh.Scene:
    """A kitchen of one of the :data:`LAYOUT_KINDS` as a :class:`trimesh.Scene`.

    Like RoboCasa's kitchen layouts: runs of base cabinets (doors with handles, drawer stacks
    with handles or knobs) under wall cabinets, filler and end panels, and appliances: a fridge,
    a range (oven with its handle, stove top, five knobs) under a microwave, a sink unit, a
    dishwasher.  Each layout repeats 2-3 cabinet modules (same width, same fronts) in banks of
    2-4 along all its runs, so many objects have identical neighbourhoods.  The room has a floor,
    a ceiling and 4 walls (types ``"floor"``, ``"ceiling"``, ``"wall"``) and a room door.

    * ``"one_wall"``: one run along the back wall of a 4-5.5 m wide, 3-5 m deep room (the robot
      can stand 2-3 m in front of it);
    * ``"galley"``: two parallel runs 1.2-2.5 m apart;
    * ``"l_shape"``: runs along the back and left walls meeting in a corner;
    * ``"u_shape"``: runs along the back, left and right walls, the side runs 1.8-2.8 m apart;
    * ``"island"``: a run along the back wall and an island of two back-to-back runs (a sink
      on the side facing the wall) 1-1.3 m in front of it.

    Cabinet carcasses, shelves, plinths, countertops and backsplashes are in the scene with node
    metadata type ``None`` (not objects); every other node is typed (:data:`LAYOUT_TYPES` and the
    room types).  z up, the floor top at z = 0, the room in ``[0, rx] x [0, ry] x [0, rz]``.

    Parameters
    ----------
    kind : str
        One of :data:`LAYOUT_KINDS`.
    seed : int
        Draws the room size, the run lengths, the modules, the order of units and appliances;
        the same seed gives the same scene.

    Returns
    -------
    trimesh.Scene
        ``scene.metadata`` holds ``"kind"``, ``"seed"``, ``"room_size"`` ``(rx, ry, rz)`` and
        ``"primitive_counts"``.
    """
    if not isinstance(kind, str) or kind not in LAYOUT_KINDS:
        raise WorldGraphError(f"kind must be one of {LAYOUT_KINDS}, got {_checks._short(kind)}")
    seed = _seed(seed)
    rng = np.random.default_rng(seed)
    b = _Builder(types=dict(_LAYOUT_SCENE_TYPES))
    apps = _appliance_meshes()
    modules = _modules(rng)
    rz = _uniform(rng, 2.6, 3.0)
    d = _COUNTER_DEPTH
    back, left, front, right = (np.array(v, dtype=np.float64)
                                for v in ((0, -1, 0), (1, 0, 0), (0, 1, 0), (-1, 0, 0)))

    def run(origin: tuple[float, float], normal: NDArray[np.float64], length: float,
            appliances: tuple[str, ...], optional: tuple[str, ...] = (), **kw: object) -> None:
        frame = _frame(np.array([origin[0], origin[1], 0.0]), normal)
        room_for_panel = _END_PANEL if kw.get("end_panel", True) else 0.0
        slots = _plan_run(rng, length - room_for_panel, modules, appliances, optional)
        _build_run(b, rng, apps, frame, slots, rz, **kw)  # type: ignore[arg-type]

    if kind == "one_wall":
        rx, ry = _uniform(rng, 4.0, 5.5), _uniform(rng, 3.0, 5.0)
        run((rx, ry), back, rx - _uniform(rng, 0.0, 0.5), ("fridge", "range", "sink"), ("dishwasher",))
        door = ((0.0, 0.0), front, _uniform(rng, 0.3, rx - 1.2))
    elif kind == "galley":
        rx, aisle = _uniform(rng, 3.0, 5.0), _uniform(rng, 1.2, 2.5)
        ry = 2 * d + aisle
        run((rx, ry), back, rx - _uniform(rng, 0.0, 0.5), ("fridge", "range"))
        run((0.0, 0.0), front, rx - _uniform(rng, 0.0, 0.5), ("sink",), ("dishwasher",))
        door = ((rx, 0.0), right, round(ry / 2 - 0.45, 3))
    elif kind == "l_shape":
        rx, ry = _uniform(rng, 3.2, 4.5), _uniform(rng, 3.0, 4.5)
        run((rx, ry), back, rx - d, ("fridge", "range"), end_panel=False)
        run((0.0, ry - d), left, ry - d - _uniform(rng, 0.3, 1.0), ("sink",), ("dishwasher",),
            counter=(d, 0.0))
        door = ((0.0, 0.0), front, _uniform(rng, 0.9, rx - 1.1))
    elif kind == "u_shape":
        rx, ry = round(2 * d + _uniform(rng, 1.8, 2.8), 2), _uniform(rng, 3.0, 4.5)
        run((rx - d, ry), back, rx - 2 * d, ("range",), counter=(d, d), end_panel=False)
        run((0.0, ry - d), left, ry - d - _uniform(rng, 0.3, 1.0), ("sink",), ("dishwasher",))
        gap = _uniform(rng, 0.3, 1.0)
        run((rx, gap), right, ry - d - gap, ("fridge",), end_panel=False)
        door = ((0.0, 0.0), front, round(rx / 2 - 0.45, 3))
    else:  # island
        rx, ry = _uniform(rng, 4.0, 5.5), _uniform(rng, 4.0, 5.5)
        run((rx, ry), back, rx - _uniform(rng, 0.0, 0.5), ("fridge", "range"), ("dishwasher",))
        length = _uniform(rng, 1.8, 2.8)
        centre = np.array([rx / 2 + _uniform(rng, -0.3, 0.3), ry - d - _uniform(rng, 1.0, 1.3) - 0.55, 0.0])
        for side, appliances in ((1.0, ()), (-1.0, ("sink",))):  # side -1 faces the back run
            normal = np.array([0.0, side, 0.0])
            start = centre - np.cross(normal, _UP) * length / 2
            frame = _frame(start, normal)
            slots = _plan_run(rng, length, modules, appliances)
            _build_run(b, rng, apps, frame, slots, rz, depth=0.48, wall_units=False, counter=None,
                       end_panel=False)
        b.box("countertop", (length + 0.1, 1.1, 0.04), _translate(centre[0], centre[1], 0.88))
        door = ((0.0, 0.0), front, _uniform(rng, 0.3, rx - 1.2))
    _room(b, rx, ry, rz)
    (ox, oy), normal, x0 = door
    door_run = _frame(np.array([ox, oy, 0.0]), normal)
    b.local_box("door", door_run, (x0, 0.0, 0.0), (x0 + 0.9, 0.04, 2.05))
    _handle(b, door_run, x0 + 0.8, 0.04, 1.05, vertical=False)
    b.scene.metadata.update(kind=kind, seed=int(seed), room_size=(rx, ry, rz),
                            primitive_counts=dict(b.primitives))
    return b.scene


def kitchen_layout(kind: str, seed: int = 0, max_link_length: float = 5.0,
                   link_margin: float = 0.0) -> WorldModel:
    """The kitchen of :func:`kitchen_layout_scene` as a :class:`WorldModel`.

    Its objects are the typed nodes without the room structure (:data:`STRUCTURAL_TYPES`); the
    room is :attr:`WorldModel.room` instead, found from the floor, wall and ceiling nodes.
    """
    _link_args(max_link_length, link_margin)
    scene = kitchen_layout_scene(kind, seed)

    def type_of(node: str, geometry: object) -> str | None:
        typ = _default_type(scene, node, geometry)
        return None if typ in STRUCTURAL_TYPES else typ

    return WorldModel.from_trimesh(scene, type_of=type_of, max_link_length=max_link_length,
                                   link_margin=link_margin)


def scene_statistics(scene: trimesh.Scene) -> dict[str, int]:
    """Geometry nodes per primitive kind, objects, and vertices counted per instance."""
    _check_scene(scene)
    out = {"box": 0, "cylinder": 0, "polyhedron": 0, "other": 0, "vertices": 0, "objects": 0}
    for node in scene.graph.nodes_geometry:
        geom = scene.geometry[scene.graph[node][1]]
        meta = getattr(geom, "metadata", None)
        kind = meta.get("primitive", "other") if isinstance(meta, dict) else "other"
        out[kind if isinstance(kind, str) and kind in out else "other"] += 1
        verts = getattr(geom, "vertices", None)
        out["vertices"] += 0 if verts is None else len(verts)
        out["objects"] += 1
    return out


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
    n_doors = _checks.strict_int("n_doors", n_doors, minimum=1, maximum=MAX_CORRIDOR_DOORS)
    per_side = [(n_doors + 1) // 2, n_doors // 2]
    if length is None:
        length = 1.8 * per_side[0] + 2.0
    length = _checks.positive_float("length", length, maximum=MAX_COORDINATE / 2)
    if length < 1.5 * per_side[0] + 0.5:
        raise WorldGraphError(f"length {length!r} is too short for {per_side[0]} doors per side")
    width = _checks.positive_float("width", width, maximum=100.0)
    height = _checks.positive_float("height", height, maximum=100.0)
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
    n_objects = _checks.strict_int("n_objects", n_objects, minimum=1, maximum=MAX_FLOOR_OBJECTS)
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
        """Tile labels for :func:`worldgraph.tiles.split`: ``"building"`` or ``"storey"`` (one
        label per building and storey, ``building * (max storey + 1) + storey``)."""
        if by == "building":
            return self.building
        if by == "storey":
            return self.building * (int(self.storey.max()) + 1) + self.storey
        raise WorldGraphError(f"by must be 'building' or 'storey', got {by!r}")


def _site_args(storeys: object, n_objects: object, storey_height: object, max_link_length: object,
               link_margin: object) -> tuple[int, int, float]:
    storeys = _checks.strict_int("storeys", storeys, minimum=1, maximum=MAX_STOREYS)
    n_objects = _checks.strict_int("n_objects", n_objects, minimum=1, maximum=MAX_SITE_OBJECTS)
    height = _checks.positive_float("storey_height", storey_height, maximum=100.0)
    if height < MIN_STOREY_HEIGHT:
        from .errors import OutOfRangeError
        raise OutOfRangeError(f"storey_height must be >= {MIN_STOREY_HEIGHT:g} m (lamps hang at 2.75 m), "
                              f"got {height!r}")
    _link_args(max_link_length, link_margin)
    return storeys, n_objects, height


def _building_arrays(rng: np.random.Generator, storeys: int, n_objects: int, height: float,
                     origin: NDArray[np.float64]) -> tuple[NDArray[np.intp], NDArray[np.float64],
                                                           NDArray[np.intp]]:
    """Type codes, positions and storeys of one building of exactly ``n_objects`` objects.

    All storeys share one corridor grid; the module kinds of a storey copy the storey below
    with probability :data:`_STOREY_KEEP`; the furniture is drawn for every room.  Objects are
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
    buildings = _checks.strict_int("buildings", buildings, minimum=1, maximum=MAX_BUILDINGS)
    storeys, n_objects, height = _site_args(storeys, n_objects, storey_height, max_link_length, link_margin)
    if buildings > n_objects:
        from .errors import OutOfRangeError
        raise OutOfRangeError(f"n_objects = {n_objects} must be >= buildings = {buildings}")
    gap = _checks.positive_float("gap", gap, maximum=10_000.0)
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
