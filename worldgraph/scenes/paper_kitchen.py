"""The paper's kitchen: :func:`kitchen_scene` / :func:`kitchen`.

A kitchen with the statistics of the paper's model (section 4: 611 rectangular prisms, 124
cylinders, 18 general polyhedra, 13,853 vertices, 753 objects) in a 10 x 8 x 3 m room: runs of
base and wall cabinets along two walls, each with doors (one handle per door) or drawer stacks
(a handle, or a knob, per drawer), tall pantry units, an island, a stove with knobs, appliances,
a table with chairs, a room door, and clutter (boxes, jars, cups) on counters and shelves.  The
layout (cabinet widths, door or drawer fronts, shelves, clutter) is drawn from ``seed``; the
primitive counts are the paper's for every seed (clutter fills the difference).

Every object is a geometry node of a :class:`trimesh.Scene` named ``f"{type}_{k:03d}"`` whose
node metadata holds ``{"type": type}``; each mesh's metadata holds ``{"primitive": "box" |
"cylinder" | "polyhedron"}``.  Walls, floor and ceiling are typed ``"wall"``, ``"floor"`` and
``"ceiling"`` (see :data:`~worldgraph.scenes.furniture.STRUCTURAL_TYPES`).  World frame: z up,
the floor at z = 0, the room in ``[0, 10] x [0, 8] x [0, 3]`` metres.
"""

from __future__ import annotations

import numpy as np
import trimesh
from numpy.typing import NDArray

from ..errors import WorldGraphError
from ..model import WorldModel
from ..tolerances import FIT_SLACK
from .builder import _UP, _Builder, _frame, _link_args, _seed, _translate
from .furniture import _appliance, _appliance_meshes, _base_unit, _handle, _knob, _room, _wall_unit

__all__ = ["KITCHEN_ROOM", "KITCHEN_TARGETS", "kitchen", "kitchen_scene"]

#: Extents (x, y, z) of the kitchen room in metres.
KITCHEN_ROOM = (10.0, 8.0, 3.0)
#: The paper's kitchen model (section 4).
KITCHEN_TARGETS = {"box": 611, "cylinder": 124, "polyhedron": 18, "vertices": 13853, "objects": 753}

_BASE_WIDTHS = np.array([0.4, 0.45, 0.5, 0.6, 0.6, 0.8])
_WALL_WIDTHS = np.array([0.4, 0.5, 0.6, 0.6, 0.8])
_CYLINDER_CLUTTER = ((0.04, 0.1, "cup"), (0.05, 0.14, "jar"), (0.035, 0.3, "bottle"))


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
