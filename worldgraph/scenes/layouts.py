"""Kitchens of the :data:`LAYOUT_KINDS` (after RoboCasa's kitchen layouts):
:func:`kitchen_layout_scene` / :func:`kitchen_layout`, and the planning of their runs (the
repeated cabinet modules, the slots of a run, the run built from its slots).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh
from numpy.typing import NDArray

from .. import _checks
from ..errors import WorldGraphError
from ..model import WorldModel
from ..model.scene_nodes import default_type
from ..tolerances import FIT_SLACK
from .builder import _UP, _Builder, _frame, _link_args, _seed, _translate
from .furniture import (
    STRUCTURAL_TYPES,
    _appliance,
    _appliance_meshes,
    _base_unit,
    _handle,
    _knob,
    _room,
    _wall_unit,
)

__all__ = ["LAYOUT_KINDS", "LAYOUT_TYPES", "VARIED_LAYOUT_KINDS", "kitchen_layout", "kitchen_layout_scene"]

#: The layouts of :func:`kitchen_layout_scene` (after RoboCasa's kitchen layouts), each repeating
#: 2-3 cabinet modules in banks along its runs.
LAYOUT_KINDS = ("one_wall", "galley", "l_shape", "u_shape", "island")
#: Layouts of :func:`kitchen_layout_scene` that repeat less: their runs are single units of mixed
#: widths, each with fronts of its own (a one-wall kitchen, an L-shaped one, one with an island).
VARIED_LAYOUT_KINDS = ("mixed_wall", "mixed_l", "mixed_island")
#: Object types of a layout's world model.
LAYOUT_TYPES = ("door", "drawer", "handle", "knob", "panel", "oven", "stove", "fridge", "dishwasher",
                "microwave", "sink")
# builder types that are structure in a layout (in the scene, not objects)
_LAYOUT_SCENE_TYPES: dict[str, str | None] = {"cabinet": None, "shelf": None, "plinth": None,
                                              "countertop": None, "backsplash": None}
_MODULE_WIDTHS = (0.45, 0.5, 0.6, 0.8)  # widths of the repeated cabinet modules
_MIXED_WIDTHS = (0.3, 0.4, 0.45, 0.5, 0.6, 0.7, 0.8)  # widths of the units of a varied run
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
              optional: tuple[str, ...] = (), banks: bool = True) -> list[tuple[str, float, _Module | None]]:
    """Slots ``(kind, width, module)`` filling a run of ``length`` metres.

    The appliances (a fridge goes first), the optional ones if a bank of two of the widest modules
    still fits, then banks of 2-4 identical modules (``banks=False``: single units of mixed widths,
    each a module of its own), in a random order; the rest is one narrow door unit (>= 0.3 m) or a
    filler panel.
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
    while not banks:
        room = [width for width in _MIXED_WIDTHS if width <= free + FIT_SLACK]
        if not room or free < 0.6:
            break
        width = float(room[int(rng.integers(len(room)))])
        blocks.append([("unit", width, _Module(width, "drawers" if rng.random() < 0.4 else "doors",
                                                int(rng.integers(2**31))))])
        free -= width
    while banks:
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
    dishwasher.  Each layout of :data:`LAYOUT_KINDS` repeats 2-3 cabinet modules (same width,
    same fronts) in banks of 2-4 along all its runs, so many objects have identical
    neighbourhoods.  The room has a floor,
    a ceiling and 4 walls (types ``"floor"``, ``"ceiling"``, ``"wall"``) and a room door.

    * ``"one_wall"``: one run along the back wall of a 4-5.5 m wide, 3-5 m deep room (the robot
      can stand 2-3 m in front of it);
    * ``"galley"``: two parallel runs 1.2-2.5 m apart;
    * ``"l_shape"``: runs along the back and left walls meeting in a corner;
    * ``"u_shape"``: runs along the back, left and right walls, the side runs 1.8-2.8 m apart;
    * ``"island"``: a run along the back wall and an island of two back-to-back runs (a sink
      on the side facing the wall) 1-1.3 m in front of it;
    * ``"mixed_wall"``, ``"mixed_l"``, ``"mixed_island"`` (:data:`VARIED_LAYOUT_KINDS`): the rooms
      and runs of ``"one_wall"``, ``"l_shape"`` and ``"island"``, but every cabinet a unit of
      its own (widths 0.3-0.8 m, its own fronts, handles and knobs), so that few objects share a
      neighbourhood.

    Cabinet carcasses, shelves, plinths, countertops and backsplashes are in the scene with node
    metadata type ``None`` (not objects); every other node is typed (:data:`LAYOUT_TYPES` and the
    room types).  z up, the floor top at z = 0, the room in ``[0, rx] x [0, ry] x [0, rz]``.

    Parameters
    ----------
    kind : str
        One of :data:`LAYOUT_KINDS` or :data:`VARIED_LAYOUT_KINDS`.
    seed : int
        Draws the room size, the run lengths, the modules, the order of units and appliances;
        the same seed gives the same scene.

    Returns
    -------
    trimesh.Scene
        ``scene.metadata`` holds ``"kind"``, ``"seed"``, ``"room_size"`` ``(rx, ry, rz)`` and
        ``"primitive_counts"``.
    """
    if not isinstance(kind, str) or kind not in LAYOUT_KINDS + VARIED_LAYOUT_KINDS:
        raise WorldGraphError(f"kind must be one of {LAYOUT_KINDS + VARIED_LAYOUT_KINDS}, "
                              f"got {_checks._short(kind)}")
    banks = kind in LAYOUT_KINDS
    shape = {"mixed_wall": "one_wall", "mixed_l": "l_shape", "mixed_island": "island"}.get(kind, kind)
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
        slots = _plan_run(rng, length - room_for_panel, modules, appliances, optional, banks)
        _build_run(b, rng, apps, frame, slots, rz, **kw)  # type: ignore[arg-type]

    if shape == "one_wall":
        rx, ry = _uniform(rng, 4.0, 5.5), _uniform(rng, 3.0, 5.0)
        run((rx, ry), back, rx - _uniform(rng, 0.0, 0.5), ("fridge", "range", "sink"), ("dishwasher",))
        door = ((0.0, 0.0), front, _uniform(rng, 0.3, rx - 1.2))
    elif shape == "galley":
        rx, aisle = _uniform(rng, 3.0, 5.0), _uniform(rng, 1.2, 2.5)
        ry = 2 * d + aisle
        run((rx, ry), back, rx - _uniform(rng, 0.0, 0.5), ("fridge", "range"))
        run((0.0, 0.0), front, rx - _uniform(rng, 0.0, 0.5), ("sink",), ("dishwasher",))
        door = ((rx, 0.0), right, round(ry / 2 - 0.45, 3))
    elif shape == "l_shape":
        rx, ry = _uniform(rng, 3.2, 4.5), _uniform(rng, 3.0, 4.5)
        run((rx, ry), back, rx - d, ("fridge", "range"), end_panel=False)
        run((0.0, ry - d), left, ry - d - _uniform(rng, 0.3, 1.0), ("sink",), ("dishwasher",),
            counter=(d, 0.0))
        door = ((0.0, 0.0), front, _uniform(rng, 0.9, rx - 1.1))
    elif shape == "u_shape":
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
            slots = _plan_run(rng, length, modules, appliances, banks=banks)
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
        typ = default_type(scene, node, geometry)
        return None if typ in STRUCTURAL_TYPES else typ

    return WorldModel.from_trimesh(scene, type_of=type_of, max_link_length=max_link_length,
                                   link_margin=link_margin)
