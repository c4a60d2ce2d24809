"""Synthetic box scenes and their stereo rendering (the image source of :mod:`perception.recognition`).

:func:`scene_boxes` and :func:`random_scene` build scenes of coloured boxes (doors, handles,
clutter); :func:`render_stereo` draws a scene into a stereo pair with OpenCV: corners
projected by ``cv2.projectPoints``, back faces culled, faces filled by ``cv2.fillConvexPoly``
far to near (painter's algorithm with a plane-side ordering test), Lambertian shading and
seeded lighting noise. :func:`render_labels` and :func:`visible_mask` give the ground truth
(box index per pixel, boxes visible in both images) for the same geometry.

Every public name here is also importable from :mod:`perception.recognition` and
:mod:`perception`.

Frames follow ``docs/conventions.md``: the scene (world) frame has z up; cameras are OpenCV
(x right, y down, z forward); the stereo rig maps ``X_right = R X_left + T``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from .._checks import generator as check_rng
from .._checks import integer, name_string, real_array, real_scalar, rotation_defect, sequence
from ..errors import (
    PerceptionError,
)
from ..head.chain import check_transform
from ..head.stereo import as_stereo_rig
from ..tolerances import NEAR_PLANE, PLANE_EPS, RIGID_TOLERANCE

__all__ = [
    "BOX_DEFAULTS",
    "DEFAULT_BACKGROUND",
    "MAX_COORD",
    "MAX_RENDER_PIXELS",
    "Box",
    "random_scene",
    "render_labels",
    "render_stereo",
    "scene_boxes",
    "visible_mask",
]

# --------------------------------------------------------------------------------------------
# Scene geometry
# --------------------------------------------------------------------------------------------

#: Default (size (3,) metres, colour BGR) per box type. Box axes: x width, y depth, z height.
BOX_DEFAULTS: Mapping[str, tuple[tuple[float, float, float], tuple[int, int, int]]] = {
    "door": ((0.9, 0.04, 2.0), (40, 85, 150)),  # brown wood
    "handle": ((0.15, 0.03, 0.03), (210, 210, 215)),  # bright metal
    "drawer": ((0.6, 0.02, 0.25), (40, 85, 150)),  # same wood as the doors
    "knob": ((0.04, 0.04, 0.04), (210, 210, 215)),  # same metal as the handles
    "clutter": ((0.2, 0.2, 0.2), (60, 160, 60)),  # green
}

#: Default scene background (BGR): a bluish grey wall, outside every colour range below.
DEFAULT_BACKGROUND: tuple[int, int, int] = (150, 120, 95)

# Unit cube corners (signs) and the six faces as corner indices ordered counter-clockwise when
# seen from outside (so the right-hand normal points outwards).
_SIGNS = np.array(
    [[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1], [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]],
    dtype=np.float64,
)
_FACES = np.array(
    [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [2, 3, 7, 6], [1, 2, 6, 5], [0, 4, 7, 3]], dtype=np.intp
)
_FACE_NORMALS = np.array(
    [[0, 0, -1], [0, 0, 1], [0, -1, 0], [0, 1, 0], [1, 0, 0], [-1, 0, 0]], dtype=np.float64
)


def _check_rotation(name: str, rot: NDArray[np.float64], atol: float = RIGID_TOLERANCE) -> None:
    why = rotation_defect(rot, atol)
    if why is not None:
        raise PerceptionError(f"{name} must be a proper rotation (R^T R = I, det R = +1), but it {why}")


@dataclass(frozen=True)
class Box:
    """A coloured box in the scene (world) frame.

    Parameters
    ----------
    center : (3,) float
        Box centre, metres.
    size : (3,) float
        Edge lengths along the box's own x (width), y (depth) and z (height) axes, > 0.
    rotation : (3, 3) float
        ``world_from_box`` rotation; its columns are the box axes in the world frame.
    color : (3,) int
        BGR colour in [0, 255] before shading.
    type : str
        Object class, e.g. ``"door"``, ``"handle"``, ``"clutter"``.
    """

    center: NDArray[np.float64]
    size: NDArray[np.float64]
    rotation: NDArray[np.float64]
    color: NDArray[np.float64]
    type: str

    def __post_init__(self) -> None:
        center = real_array("center", self.center, (3,))
        size = real_array("size", self.size, (3,))
        if np.any(size <= 0):
            raise PerceptionError(f"size must be > 0 along every axis, got {size.tolist()}")
        if np.any(np.abs(center) > MAX_COORD) or np.any(size > MAX_COORD):
            raise PerceptionError(
                f"center and size must be at most {MAX_COORD:g} m, got {center.tolist()} and {size.tolist()}"
            )
        rot = real_array("rotation", self.rotation, (3, 3))
        _check_rotation("rotation", rot)
        color = real_array("color", self.color, (3,))
        if np.any(color < 0) or np.any(color > 255):
            raise PerceptionError(f"color must be BGR values in [0, 255], got {color.tolist()}")
        name_string("type", self.type)
        for name, arr in (("center", center), ("size", size), ("rotation", rot), ("color", color)):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    def corners(self) -> NDArray[np.float64]:
        """The 8 corners in the world frame, shape (8, 3)."""
        return self.center + (_SIGNS * (0.5 * self.size)) @ self.rotation.T


MAX_COORD = 1e150
"""Largest box coordinate or size accepted, metres."""
MAX_RENDER_PIXELS = 50_000_000
"""Largest image (width * height) rendered or segmented."""


def _int_range(name: str, value: Any, low: int, high: int) -> tuple[int, int]:
    try:
        pair = list(value)
    except TypeError as exc:
        raise PerceptionError(f"{name} must be a pair (low, high) of integers, got {value!r}") from exc
    if isinstance(value, (str, bytes)) or len(pair) != 2:
        raise PerceptionError(f"{name} must be a pair (low, high) of integers, got {value!r}")
    value = pair
    a = integer(f"{name}[0]", value[0], minimum=low, maximum=high)
    b = integer(f"{name}[1]", value[1], minimum=low, maximum=high)
    if a > b:
        raise PerceptionError(f"{name} must have {name}[0] <= {name}[1], got {value!r}")
    return a, b


def scene_boxes(
    types: Sequence[str],
    positions: ArrayLike,
    rotations: ArrayLike | None = None,
    sizes: ArrayLike | None = None,
    colors: ArrayLike | None = None,
) -> list[Box]:
    """Boxes from plain arrays, with per-type default sizes and colours (:data:`BOX_DEFAULTS`).

    Parameters
    ----------
    types : (n,) str
        Box types; without ``sizes``/``colors`` each must be a key of :data:`BOX_DEFAULTS`.
    positions : (n, 3) float
        Box centres in the world frame.
    rotations : (n, 3, 3) float, optional
        ``world_from_box`` rotations; identity when omitted.
    sizes, colors : (n, 3), optional
        Overrides of the defaults.

    Returns
    -------
    list of Box
    """
    types = sequence("types", types)
    n = len(types)
    pos = real_array("positions", positions)
    if pos.shape != (n, 3):
        raise PerceptionError(
            f"positions must have one row per entry of types, shape ({n}, 3), got shape {pos.shape}"
        )
    rots = np.broadcast_to(np.eye(3), (n, 3, 3)) if rotations is None else rotations
    rots = real_array("rotations", rots, (n, 3, 3))
    if sizes is not None:
        sizes = real_array("sizes", sizes, (n, 3))
    if colors is not None:
        colors = real_array("colors", colors, (n, 3))
    boxes = []
    for i, kind in enumerate(types):
        if (sizes is None or colors is None) and kind not in BOX_DEFAULTS:
            raise PerceptionError(
                f"no default size/colour for box type {kind!r}; known: {sorted(BOX_DEFAULTS)}"
            )
        # Box.__post_init__ validates these and stores them as float arrays.
        size: Any = sizes[i] if sizes is not None else BOX_DEFAULTS[kind][0]
        color: Any = colors[i] if colors is not None else BOX_DEFAULTS[kind][1]
        try:
            boxes.append(Box(center=pos[i], size=size, rotation=rots[i], color=color, type=kind))
        except PerceptionError as exc:
            raise type(exc)(f"box {i} from positions[{i}], rotations[{i}], sizes, colors: {exc}") from exc
    return boxes


def _rot_z(angle: float) -> NDArray[np.float64]:
    """The 3x3 rotation by ``angle`` (radians) about z."""
    return Rotation.from_euler("z", angle).as_matrix()


def _camera_from_world_look(position: NDArray[np.float64], yaw: float, pitch: float) -> NDArray[np.float64]:
    """OpenCV camera at ``position`` looking along world yaw/pitch (world z up)."""
    forward = np.array([np.cos(yaw) * np.cos(pitch), np.sin(yaw) * np.cos(pitch), -np.sin(pitch)])
    right = np.cross(forward, (0.0, 0.0, 1.0))
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    world_from_camera = np.eye(4)
    world_from_camera[:3, :3] = np.column_stack([right, down, forward])
    world_from_camera[:3, 3] = position
    camera_from_world = np.eye(4)
    camera_from_world[:3, :3] = world_from_camera[:3, :3].T
    camera_from_world[:3, 3] = -world_from_camera[:3, :3].T @ position
    return camera_from_world


_CLUTTER_PALETTE = np.array(
    [[60, 160, 60], [170, 60, 40], [40, 40, 190], [40, 200, 220], [40, 85, 150], [210, 210, 215]],
    dtype=np.float64,
)


def random_scene(
    rng: np.random.Generator,
    *,
    n_doors: tuple[int, int] = (1, 3),
    n_clutter: tuple[int, int] = (0, 2),
    distance: tuple[float, float] = (2.5, 5.0),
    max_door_yaw_deg: float = 35.0,
) -> tuple[list[Box], NDArray[np.float64]]:
    """A seeded scene of doors with handles (and clutter) in front of a camera.

    The camera stands near the world origin at eye height, looking roughly along world +x;
    doors stand on the floor (z = 0) at ``distance`` metres, each turned by a random yaw, with
    a handle on the side facing the camera. Clutter boxes take colours from a palette that
    includes the door and handle colours, so some clutter survives the colour segmentation and
    must be rejected by the classifier.

    Parameters
    ----------
    rng : numpy.random.Generator
    n_doors, n_clutter : (int, int)
        Inclusive ranges of the number of doors and clutter boxes.
    distance : (float, float)
        Range of door distances along world x, metres.
    max_door_yaw_deg : float
        Largest door yaw away from facing the camera, degrees.

    Returns
    -------
    boxes : list of Box
    camera_from_world : (4, 4) float
        Pose of the left camera.
    """
    rng = check_rng("rng", rng)
    n_doors = _int_range("n_doors", n_doors, 0, 100)
    n_clutter = _int_range("n_clutter", n_clutter, 0, 100)
    dist = real_array("distance", distance, (2,))
    if not 0.0 < dist[0] <= dist[1] <= 1e4:
        raise PerceptionError(
            f"distance must satisfy 0 < distance[0] <= distance[1] <= 1e4 m, got {dist.tolist()}"
        )
    distance = (float(dist[0]), float(dist[1]))
    max_door_yaw_deg = real_scalar("max_door_yaw_deg", max_door_yaw_deg, minimum=0.0,
                                   maximum=90.0) + 0.0  # not -0.0
    cam_pos = np.array([0.0, rng.uniform(-0.2, 0.2), rng.uniform(1.2, 1.6)])
    camera_from_world = _camera_from_world_look(
        cam_pos, np.deg2rad(rng.uniform(-8.0, 8.0)), np.deg2rad(rng.uniform(-4.0, 8.0))
    )
    k = int(rng.integers(n_doors[0], n_doors[1] + 1))
    lateral: list[float] = []
    for _ in range(50 * max(k, 1)):
        if len(lateral) == k:
            break
        y = rng.uniform(-1.8, 1.8)
        if all(abs(y - other) > 1.15 for other in lateral):
            lateral.append(y)
    types: list[str] = []
    positions: list[NDArray[np.float64]] = []
    rotations: list[NDArray[np.float64]] = []
    door_w, door_d, _ = BOX_DEFAULTS["door"][0]
    handle_d = BOX_DEFAULTS["handle"][0][1]
    for y in lateral:
        x = rng.uniform(*distance)
        # door axes: x (width) along world y, y (thickness) towards the camera (world -x), z up
        rot = _rot_z(np.pi / 2 + np.deg2rad(rng.uniform(-max_door_yaw_deg, max_door_yaw_deg)))
        center = np.array([x, y, 1.0])
        side = rng.choice((-1.0, 1.0))
        local = np.array(
            [side * rng.uniform(0.28, 0.36), door_d / 2 + 0.04 + handle_d / 2, rng.uniform(-0.1, 0.1)]
        )
        types += ["door", "handle"]
        positions += [center, center + rot @ local]
        rotations += [rot, rot]
    sizes = [np.array(BOX_DEFAULTS[t][0]) for t in types]
    colors = [np.array(BOX_DEFAULTS[t][1], dtype=np.float64) for t in types]
    for _ in range(int(rng.integers(n_clutter[0], n_clutter[1] + 1))):
        types.append("clutter")
        positions.append(np.array([rng.uniform(1.5, 5.0), rng.uniform(-2.0, 2.0), rng.uniform(0.1, 2.0)]))
        rotations.append(_rot_z(rng.uniform(0, np.pi)))
        sizes.append(rng.uniform(0.12, 0.4) * rng.uniform(0.8, 1.25, size=3))
        colors.append(_CLUTTER_PALETTE[rng.integers(len(_CLUTTER_PALETTE))])
    if not types:
        return [], camera_from_world
    boxes = scene_boxes(types, np.array(positions), np.array(rotations), np.array(sizes), np.array(colors))
    return boxes, camera_from_world


# --------------------------------------------------------------------------------------------
# Rendering
# --------------------------------------------------------------------------------------------

_SHIFT = 4  # fixed-point bits for cv2.fillConvexPoly (sub-pixel vertices)


def _rig_views(rig: Any, camera_from_world: NDArray[np.float64]) -> list[tuple[Any, ...]]:
    """(camera_from_world, K, D) of the left and the right camera."""
    right_from_left = np.eye(4)
    right_from_left[:3, :3] = np.asarray(rig.R, dtype=np.float64)
    right_from_left[:3, 3] = np.asarray(rig.T, dtype=np.float64).reshape(3)
    return [
        (camera_from_world, np.asarray(rig.K1, dtype=np.float64), np.asarray(rig.D1, dtype=np.float64)),
        (
            right_from_left @ camera_from_world,
            np.asarray(rig.K2, dtype=np.float64),
            np.asarray(rig.D2, dtype=np.float64),
        ),
    ]


def rig_render_size(rig: Any) -> tuple[int, int]:
    """``rig.image_size`` as ``(width, height)``, refused when it is too large to render."""
    width, height = (int(v) for v in as_stereo_rig(rig).image_size)
    if width * height > MAX_RENDER_PIXELS:
        raise PerceptionError(
            f"rig.image_size {rig.image_size} has more than {MAX_RENDER_PIXELS} pixels; too large to render"
        )
    return width, height


def _face_order(
    verts: NDArray[np.float64], normals: NDArray[np.float64], bbox: NDArray[np.float64]
) -> list[int]:
    """Painter's order (far to near) of camera-facing convex faces.

    A face j lying wholly behind the plane of face i (on the side away from the camera) is
    drawn before i; a face wholly on the camera side of i's plane is drawn after i. Those
    constraints form a graph that is sorted topologically, taking the farthest free face
    first; pairs the plane tests cannot decide (and cycles) fall back to depth order.
    """
    n = len(verts)
    if n == 0:
        return []
    offsets = np.einsum("ij,ij->i", normals, verts[:, 0])
    # dist[i, j, k]: signed distance of vertex k of face j to the plane of face i (camera side > 0)
    # (the camera at the origin has n.0 - offset = -offset > 0 because visible faces have n.c < 0)
    dist = np.einsum("id,jkd->ijk", normals, verts) - offsets[:, None, None]
    eps = PLANE_EPS
    behind = np.all(dist <= eps, axis=2)
    front = np.all(dist >= -eps, axis=2)
    coplanar = behind & front
    before = np.zeros((n, n), dtype=bool)  # before[a, b]: a must be drawn before b
    before |= (behind & ~coplanar).T  # j behind plane i -> j before i
    before |= front & ~coplanar  # j in front of plane i -> i before j
    overlap = (
        (bbox[:, None, 0] <= bbox[None, :, 2])
        & (bbox[None, :, 0] <= bbox[:, None, 2])
        & (bbox[:, None, 1] <= bbox[None, :, 3])
        & (bbox[None, :, 1] <= bbox[:, None, 3])
    )
    before &= overlap
    conflict = before & before.T
    before &= ~conflict
    np.fill_diagonal(before, False)
    depth = -np.linalg.norm(verts.mean(axis=1), axis=1)  # sort key: farthest first
    indegree = before.sum(axis=0)
    done = np.zeros(n, dtype=bool)
    order: list[int] = []
    for _ in range(n):
        free = np.flatnonzero(~done & (indegree == 0))
        if free.size == 0:  # cycle: take the farthest remaining face with the fewest blockers
            rest = np.flatnonzero(~done)
            free = rest[indegree[rest] == indegree[rest].min()]
        pick = int(free[np.argmin(depth[free])])
        order.append(pick)
        done[pick] = True
        indegree = indegree - before[pick]
    return order


def _visible_faces(
    boxes: Sequence[Box], camera_from_world: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.intp], NDArray[np.intp]]:
    """Camera-facing faces in front of the near plane.

    Returns face vertices (f, 4, 3) and normals (f, 3) in the camera frame, the box index
    (f,) and the face index 0..5 (f,) of each face.
    """
    if not boxes:
        return np.zeros((0, 4, 3)), np.zeros((0, 3)), np.zeros(0, np.intp), np.zeros(0, np.intp)
    rot_c, t_c = camera_from_world[:3, :3], camera_from_world[:3, 3]
    corners = np.stack([b.corners() for b in boxes]) @ rot_c.T + t_c  # (m, 8, 3)
    normals = np.einsum("cd,mde,fe->mfc", rot_c, np.stack([b.rotation for b in boxes]), _FACE_NORMALS)
    verts = corners[:, _FACES]  # (m, 6, 4, 3)
    centers = verts.mean(axis=2)
    facing = np.einsum("mfc,mfc->mf", normals, centers) < 0
    in_front = np.all(verts[..., 2] > NEAR_PLANE, axis=2)
    keep = facing & in_front
    box_idx, face_idx = np.nonzero(keep)
    return verts[keep], normals[keep], box_idx, face_idx


def _draw_view(
    boxes: Sequence[Box],
    camera_from_world: NDArray[np.float64],
    K: NDArray[np.float64],
    D: NDArray[np.float64],
    size: tuple[int, int],
    face_colors: NDArray[np.float64] | None,
    canvas: NDArray[Any],
) -> NDArray[Any]:
    """Fill the visible faces into ``canvas`` (colours per (box, face), or box index labels)."""
    import cv2
    verts, normals, box_idx, face_idx = _visible_faces(boxes, camera_from_world)
    if len(verts) == 0:
        return canvas
    uv, _ = cv2.projectPoints(verts.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), K, D)
    uv = uv.reshape(-1, 4, 2)
    ok = np.all(np.isfinite(uv), axis=(1, 2)) & np.all(np.abs(uv) < 1e6, axis=(1, 2))
    verts, normals, box_idx, face_idx, uv = verts[ok], normals[ok], box_idx[ok], face_idx[ok], uv[ok]
    bbox = np.concatenate([uv.min(axis=1), uv.max(axis=1)], axis=1)
    width, height = size
    on_screen = (bbox[:, 2] >= -1) & (bbox[:, 0] <= width) & (bbox[:, 3] >= -1) & (bbox[:, 1] <= height)
    verts, normals, box_idx, face_idx, uv, bbox = (
        a[on_screen] for a in (verts, normals, box_idx, face_idx, uv, bbox)
    )
    fixed = np.round(uv * (1 << _SHIFT)).astype(np.int32)
    for f in _face_order(verts, normals, bbox):
        if face_colors is None:
            value: Any = int(box_idx[f])
        else:
            value = face_colors[box_idx[f], face_idx[f]].tolist()
        cv2.fillConvexPoly(canvas, fixed[f], value, lineType=cv2.LINE_8, shift=_SHIFT)
    return canvas


def render_stereo(
    rig: Any,
    camera_from_world: ArrayLike,
    boxes: Sequence[Box],
    rng: np.random.Generator,
    *,
    background: ArrayLike = DEFAULT_BACKGROUND,
    light_noise: float = 0.05,
    pixel_noise: float = 2.0,
    ambient: float = 0.45,
    light_direction: ArrayLike = (-0.8, -0.25, 0.55),
) -> tuple[NDArray[np.uint8], NDArray[np.uint8]]:
    """Render a box scene into a stereo pair.

    Every box face that faces the camera and lies wholly in front of the near plane (5 cm) is
    projected with ``cv2.projectPoints`` (left camera pose ``camera_from_world``; the right
    camera is ``R, T`` further) and filled with ``cv2.fillConvexPoly`` far to near. A face's
    colour is ``color * (ambient + (1 - ambient) max(0, n . l)) * gain``: Lambertian shading
    for a distant light, times a per-face gain ``1 + light_noise N(0, 1)`` (the same in both
    views); each image then gets independent pixel noise ``pixel_noise N(0, 1)``.

    Parameters
    ----------
    rig : StereoRig
        Provides ``K1, D1, K2, D2, R, T, image_size`` (width, height).
    camera_from_world : (4, 4) float
        Rigid pose of the left camera.
    boxes : sequence of Box
    rng : numpy.random.Generator
        Source of the lighting and pixel noise.
    background : (3,) BGR or (height, width, 3) uint8
        Background colour or image.
    light_noise : float
        Standard deviation of the per-face gain, >= 0.
    pixel_noise : float
        Standard deviation of the per-pixel noise, grey levels, >= 0.
    ambient : float
        Ambient share of the shading, in [0, 1].
    light_direction : (3,) float
        Direction towards the light in the world frame (z up).

    Returns
    -------
    left, right : (height, width, 3) uint8
        BGR images.
    """
    pose = check_transform("camera_from_world", camera_from_world)
    boxes = sequence("boxes", boxes, Box)
    width, height = rig_render_size(rig)
    rng = check_rng("rng", rng)
    light_noise = real_scalar("light_noise", light_noise, minimum=0.0, maximum=1e6)
    pixel_noise = real_scalar("pixel_noise", pixel_noise, minimum=0.0, maximum=1e6)
    ambient = real_scalar("ambient", ambient, minimum=0.0, maximum=1.0)
    light = real_array("light_direction", light_direction, (3,))
    norm = np.linalg.norm(light)
    if norm == 0:
        raise PerceptionError(f"light_direction must be non-zero, got {light.tolist()}")
    light = light / norm
    if isinstance(background, np.ndarray) and background.dtype == np.uint8:
        bg = background
    else:
        bg = real_array("background", background)
    if bg.shape == (3,) and np.any((bg < 0) | (bg > 255)):
        raise PerceptionError(f"background colour must lie in [0, 255], got {bg.tolist()}")
    if bg.shape == (3,):
        canvas0 = np.empty((height, width, 3), dtype=np.float32)
        canvas0[:] = real_array("background", bg, (3,))
    elif bg.shape == (height, width, 3) and bg.dtype == np.uint8:
        canvas0 = bg.astype(np.float32)
    else:
        raise PerceptionError(
            f"background must be a BGR triple or a ({height}, {width}, 3) uint8 image, "
            f"got shape {bg.shape} dtype {bg.dtype}"
        )
    if boxes:
        world_normals = np.einsum("mde,fe->mfd", np.stack([b.rotation for b in boxes]), _FACE_NORMALS)
        shade = ambient + (1.0 - ambient) * np.clip(world_normals @ light, 0.0, None)  # (m, 6)
        gain = 1.0 + light_noise * rng.standard_normal(shade.shape)
        colors = np.stack([b.color for b in boxes])[:, None, :] * (shade * gain)[:, :, None]
        colors = np.clip(colors, 0.0, 255.0)
    else:
        colors = np.zeros((0, 6, 3))
    images = []
    for view_pose, K, D in _rig_views(rig, pose):
        canvas = _draw_view(boxes, view_pose, K, D, (width, height), colors, canvas0.copy())
        if pixel_noise > 0:
            canvas += np.float32(pixel_noise) * rng.standard_normal(canvas.shape, dtype=np.float32)
        images.append(np.clip(np.rint(canvas), 0, 255).astype(np.uint8))
    return images[0], images[1]


def render_labels(
    rig: Any, camera_from_world: ArrayLike, boxes: Sequence[Box]
) -> tuple[NDArray[np.int32], NDArray[np.int32]]:
    """Index of the box seen at each pixel (-1 for background), left and right.

    The same geometry and face order as :func:`render_stereo`, without shading or noise: the
    ground truth for visibility and occlusion.

    Returns
    -------
    left, right : (height, width) int32
    """
    pose = check_transform("camera_from_world", camera_from_world)
    boxes = sequence("boxes", boxes, Box)
    width, height = rig_render_size(rig)
    out = []
    for view_pose, K, D in _rig_views(rig, pose):
        canvas = np.full((height, width), -1, dtype=np.int32)
        out.append(_draw_view(boxes, view_pose, K, D, (width, height), None, canvas))
    return out[0], out[1]


def visible_mask(
    rig: Any,
    camera_from_world: ArrayLike,
    boxes: Sequence[Box],
    *,
    min_area: float = 20.0,
    labels: tuple[NDArray[np.int32], NDArray[np.int32]] | None = None,
) -> NDArray[np.bool_]:
    """Which boxes are visible in both images.

    Visible means: the box centre projects inside both images onto a pixel showing that box
    (not occluded) and the box covers at least ``min_area`` pixels in each image.

    Returns
    -------
    (m,) bool
    """
    import cv2
    pose = check_transform("camera_from_world", camera_from_world)
    boxes = sequence("boxes", boxes, Box)
    min_area = real_scalar("min_area", min_area, minimum=0.0)
    rig_render_size(rig)
    if not boxes:
        return np.zeros(0, dtype=bool)
    width, height = rig_render_size(rig)
    if labels is None:
        labels = render_labels(rig, pose, boxes)
    centers = np.stack([b.center for b in boxes])
    visible = np.ones(len(boxes), dtype=bool)
    for (view_pose, K, D), lab in zip(_rig_views(rig, pose), labels, strict=True):
        cam = centers @ view_pose[:3, :3].T + view_pose[:3, 3]
        front = cam[:, 2] > NEAR_PLANE
        uv, _ = cv2.projectPoints(cam.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), K, D)
        px = np.rint(uv.reshape(-1, 2)).astype(np.int64)
        inside = front & (px[:, 0] >= 0) & (px[:, 0] < width) & (px[:, 1] >= 0) & (px[:, 1] < height)
        seen = np.zeros(len(boxes), dtype=bool)
        idx = np.flatnonzero(inside)
        seen[idx] = lab[px[idx, 1], px[idx, 0]] == idx
        area = np.bincount(lab[lab >= 0].ravel(), minlength=len(boxes))
        visible &= seen & (area >= min_area)
    return visible
