"""The parts the kitchens and the corridor are built of: bar handles, knobs, base and wall
cabinets, the appliance meshes (the kitchen's general polyhedra) and the room shell (floor,
ceiling, walls: :data:`STRUCTURAL_TYPES`).
"""

from __future__ import annotations

import numpy as np
import trimesh
from numpy.typing import NDArray

from .builder import _ROT_X90, _Builder, _frustum, _rounded_box, _translate

__all__ = ["STRUCTURAL_TYPES"]

#: Types of the room structure (not landmarks a robot would pick).
STRUCTURAL_TYPES = ("wall", "floor", "ceiling")

_HANDLE = (0.16, 0.03, 0.012)  # bar handle: length, depth (out of the front), thickness
_KNOB_R, _KNOB_H = 0.015, 0.025


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
