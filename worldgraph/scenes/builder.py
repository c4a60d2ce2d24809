"""The scene builder shared by the procedural scenes: seed and link checks, the mesh helpers
(prisms, rounded boxes, frustums), run frames and ``_Builder``, which adds typed box,
cylinder and polyhedron nodes to a :class:`trimesh.Scene`; and :func:`scene_statistics`, the
primitive, object and vertex counts of a scene.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import trimesh
from numpy.typing import NDArray

from .. import _checks
from ..model.scene_nodes import check_scene

__all__ = ["scene_statistics"]


def _seed(seed: object) -> int:
    """A scene seed: a non-negative integer (not bool, float, None, str or a Generator)."""
    return _checks.integer("seed", seed, minimum=0)


def _link_args(max_link_length: object, link_margin: object) -> None:
    """Check the link settings before a scene is built (:class:`WorldModel` checks them again)."""
    _checks.real_scalar("max_link_length", max_link_length, positive=True)
    _checks.real_scalar("link_margin", link_margin, minimum=0.0)


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


def scene_statistics(scene: trimesh.Scene) -> dict[str, int]:
    """Geometry nodes per primitive kind, objects, and vertices counted per instance."""
    check_scene(scene)
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
