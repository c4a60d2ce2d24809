"""Simulated head scans of any MuJoCo (MJCF) scene: RGB, depth, segmentation, detections, percepts.

:class:`MujocoScene` types the bodies of an MJCF model by name (the rule of
:mod:`perception.type_rules`, the same as :meth:`WorldModel.from_file
<worldgraph.WorldModel.from_file>`), renders the views of a head scan with MuJoCo and turns the
segmentation into :class:`~perception.Detection` s of the typed bodies.

Objects: every named body whose name the rule types, and every named geom of the world body that
it types (static geometry).  An object's geometry is its *visual* geoms (:func:`visual_geoms`:
those MuJoCo draws by default, geom group 0, 1 or 2 with a visible colour; when a body has
visual geoms that do not collide (``contype == 0`` and ``conaffinity == 0``) besides colliding
ones, only the non-colliding ones: the usual visual/collision split) plus those of its untyped
descendant bodies, recursively, down to the typed descendants (their own objects).  A body
without any visual geometry keeps all its own geoms.  The object's centre is the world position
of the centre of that geometry's bounding box in the body frame, as ``WorldModel.from_file``
computes it (:func:`object_geoms` is shared with it).

Rendering needs an OpenGL context: headless (no ``DISPLAY``) this module sets ``MUJOCO_GL=egl``
before it first imports ``mujoco`` unless the variable is set (``MUJOCO_GL=osmesa`` works too);
``mujoco`` reads the variable once, when it is first imported, so set it before anything imports
``mujoco`` when you want another backend.  Needs the ``mujoco`` extra
(``pip install gaussian-spheres[mujoco]``).
"""

from __future__ import annotations

import copy
import math
import os
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from ._checks import (
    _short,
    boolean,
    check_transform,
    file_path,
    integer,
    name_string,
    real_array,
    real_scalar,
)
from ._checks import generator as check_rng
from .chain import KinematicChain, default_head
from .detection import Detection
from .errors import (
    MissingExtraError,
    PerceptionError,
    RobotFileError,
)
from .frontend import DEPTH_CORRELATION_PX, DEPTH_NOISE, CentreOffset, _offset_of, rgbd_percepts
from .outline import DisparityError
from .percept import Percept
from .simulate import scan_angles
from .tolerances import ANGLE_SLACK
from .type_rules import type_rule

if TYPE_CHECKING:  # pragma: no cover
    import trimesh

__all__ = [
    "DEFAULT_DEPTH_NOISE",
    "DEFAULT_MAX_RANGE",
    "DEPTH_NOISE_BLOCK",
    "DEPTH_NOISE_IID",
    "LOOK_SPREAD_DEG",
    "LOOK_VIEWS",
    "MAX_RENDER_SIDE",
    "NECK_REACH_DEG",
    "SENSORS",
    "VISIBLE_GROUPS",
    "MujocoScan",
    "MujocoScene",
    "RenderedView",
    "SceneObject",
    "StereoCalibration",
    "ScanTimings",
    "ScanView",
    "body_meshes",
    "geom_mesh",
    "import_mujoco",
    "object_geoms",
    "visual_geoms",
]

_PIP = "pip install gaussian-spheres[mujoco]"
#: Views of one :meth:`MujocoScene.look`.
LOOK_VIEWS = 3
#: Neck yaw of a look's outer views either side of its direction (degrees): with the default
#: camera's 58-degree horizontal field of view, three views cover about 80 degrees and see the middle
#: 38 in every view.
LOOK_SPREAD_DEG = 10.0
#: How far the neck yaws either side of the base (degrees) in :meth:`MujocoScene.look`: the reach
#: of :meth:`MujocoScene.scan`'s default sweep; beyond it the base turns.
NECK_REACH_DEG = 70.0
#: Geom groups MuJoCo renders by default (``mjvOption.geomgroup`` is 1, 1, 1, 0, 0, 0).
VISIBLE_GROUPS = (0, 1, 2)
#: MuJoCo's default geom colour: a geom with a material and this rgba takes the material's colour.
_DEFAULT_RGBA = (0.5, 0.5, 0.5, 1.0)


def import_mujoco() -> Any:
    """The ``mujoco`` module, imported on first use.

    Headless (no ``DISPLAY`` in the environment) it sets ``MUJOCO_GL=egl`` first unless the
    variable is set, so that ``mujoco.Renderer`` gets an offscreen context.

    Returns
    -------
    module
        ``mujoco``.

    Raises
    ------
    MissingExtraError
        ``mujoco`` is not installed; the message names the pip command.
    """
    if "DISPLAY" not in os.environ:
        os.environ.setdefault("MUJOCO_GL", "egl")
    try:
        import mujoco
    except ImportError as exc:
        raise MissingExtraError(f"perception.mujoco needs the mujoco package: {_PIP}") from exc
    return mujoco


def _quat_matrix(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotation matrix of a quaternion ``(w, x, y, z)`` (MuJoCo's order; normalised here)."""
    w, x, y, z = np.asarray(q, dtype=np.float64) / np.linalg.norm(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


# ----------------------------------------------------------------------------------------------
# the objects of a model (no rendering; shared with worldgraph.WorldModel.from_file)
# ----------------------------------------------------------------------------------------------
def visual_geoms(model: Any) -> NDArray[np.bool_]:
    """Which geoms MuJoCo draws by default.

    Parameters
    ----------
    model : mujoco.MjModel
        A compiled model.

    Returns
    -------
    (model.ngeom,) bool
        Geom group in :data:`VISIBLE_GROUPS` and a colour with alpha > 0: the geom's ``rgba``,
        or its material's when it has one and its own ``rgba`` is MuJoCo's default (as MuJoCo
        colours it).
    """
    n = int(model.ngeom)
    group = np.asarray(model.geom_group, dtype=np.int64).reshape(n)
    rgba = np.asarray(model.geom_rgba, dtype=np.float64).reshape(n, 4)
    matid = np.asarray(model.geom_matid, dtype=np.int64).reshape(n)
    alpha = rgba[:, 3].copy()
    if int(model.nmat) > 0:
        mat_rgba = np.asarray(model.mat_rgba, dtype=np.float64).reshape(-1, 4)
        default = np.all(rgba == np.array(_DEFAULT_RGBA), axis=1)  # 0.5 and 1 are exact in float32
        use_mat = (matid >= 0) & default
        alpha[use_mat] = mat_rgba[matid[use_mat], 3]
    return np.isin(group, VISIBLE_GROUPS) & (alpha > 0)


def _own_selection(model: Any, body: int, visible: NDArray[np.bool_]) -> list[int]:
    """The visual geoms of ``body`` (the non-colliding ones when it has both kinds)."""
    start, count = int(model.body_geomadr[body]), int(model.body_geomnum[body])
    own = [g for g in range(start, start + count) if visible[g]]  # count 0 when start is -1
    quiet = [g for g in own if int(model.geom_contype[g]) == 0 and int(model.geom_conaffinity[g]) == 0]
    return quiet if quiet and len(quiet) < len(own) else own


def object_geoms(model: Any, rule: Callable[[str], str | None] | None = None) -> dict[int, list[int]]:
    """The geoms that make up each named body's geometry.

    Parameters
    ----------
    model : mujoco.MjModel
        A compiled model.
    rule : callable, optional
        ``name -> type or None`` (:func:`perception.type_rules.type_rule`).  Without it every
        body holds only its own geoms.

    Returns
    -------
    dict
        Body id (>= 1) -> geom ids, ascending.  A body's own visual geoms (module docstring:
        the non-colliding ones when it has both kinds); for a body whose name ``rule`` types,
        also those of its untyped descendants (recursively, stopping at typed ones).  A body
        with none of these keeps all its own geoms (possibly none).
    """
    visible = visual_geoms(model)
    nbody = int(model.nbody)
    parent = np.asarray(model.body_parentid, dtype=np.int64).reshape(nbody)
    children: list[list[int]] = [[] for _ in range(nbody)]
    for b in range(1, nbody):
        children[int(parent[b])].append(b)
    typed = [False] * nbody
    if rule is not None:
        for b in range(1, nbody):
            name = model.body(b).name
            typed[b] = bool(name) and rule(name) is not None
    out: dict[int, list[int]] = {}
    for b in range(1, nbody):
        geoms = list(_own_selection(model, b, visible))
        if typed[b]:
            stack = list(children[b])
            while stack:
                c = stack.pop()
                if typed[c]:
                    continue
                geoms.extend(_own_selection(model, c, visible))
                stack.extend(children[c])
        if not geoms:
            start, count = int(model.body_geomadr[b]), int(model.body_geomnum[b])
            geoms = list(range(start, start + count))
        out[b] = sorted(geoms)
    return out


def geom_mesh(model: Any, g: int) -> tuple[trimesh.Trimesh, NDArray[np.float64]] | None:
    """The shape of a geom as a triangle mesh.

    Parameters
    ----------
    model : mujoco.MjModel
        A compiled model.
    g : int
        Geom id.

    Returns
    -------
    (trimesh.Trimesh, (4, 4) float) or None
        The mesh and ``geom_from_mesh``; ``None`` for an infinite plane.  Boxes, spheres,
        ellipsoids, cylinders and capsules as trimesh primitives of the geom's size; meshes with
        their vertices as written in the asset file (MuJoCo's re-centring on the mesh's inertia
        frame undone with ``mesh_pos`` / ``mesh_quat``); finite planes as flat rectangles; other
        types (height fields, SDFs) as their bounding box ``geom_aabb``.
    """
    import trimesh

    mujoco = import_mujoco()
    kind = int(model.geom_type[g])
    size = np.asarray(model.geom_size[g], dtype=np.float64)
    T = mujoco.mjtGeom
    eye = np.eye(4)
    if kind == int(T.mjGEOM_BOX):
        return trimesh.creation.box(extents=2.0 * size), eye
    if kind == int(T.mjGEOM_SPHERE):
        return trimesh.creation.icosphere(subdivisions=1, radius=size[0]), eye
    if kind == int(T.mjGEOM_ELLIPSOID):
        mesh = trimesh.creation.icosphere(subdivisions=1, radius=1.0)
        mesh.apply_scale(size)
        return mesh, eye
    if kind == int(T.mjGEOM_CYLINDER):
        return trimesh.creation.cylinder(radius=size[0], height=2.0 * size[1], sections=24), eye
    if kind == int(T.mjGEOM_CAPSULE):
        return trimesh.creation.capsule(height=2.0 * size[1], radius=size[0], count=[12, 12]), eye
    if kind == int(T.mjGEOM_PLANE):
        if size[0] <= 0 or size[1] <= 0:
            return None  # infinite plane: no box
        sx, sy = size[0], size[1]
        quad = np.array([[-sx, -sy, 0.0], [sx, -sy, 0.0], [sx, sy, 0.0], [-sx, sy, 0.0]])
        return trimesh.Trimesh(vertices=quad, faces=[[0, 1, 2], [0, 2, 3]], process=False), eye
    if kind == int(T.mjGEOM_MESH) and int(model.geom_dataid[g]) >= 0:
        k = int(model.geom_dataid[g])
        v0, nv = int(model.mesh_vertadr[k]), int(model.mesh_vertnum[k])
        f0, nf = int(model.mesh_faceadr[k]), int(model.mesh_facenum[k])
        verts = np.asarray(model.mesh_vert[v0:v0 + nv], dtype=np.float64)
        faces = np.asarray(model.mesh_face[f0:f0 + nf], dtype=np.int64)
        geom_from_mesh = np.eye(4)
        if hasattr(model, "mesh_pos") and hasattr(model, "mesh_quat"):
            # MuJoCo stores vertices in the mesh's inertia frame: asset = R @ stored + pos
            rot = _quat_matrix(model.mesh_quat[k])
            pos = np.asarray(model.mesh_pos[k], dtype=np.float64)
            verts = verts @ rot.T + pos
            geom_from_mesh[:3, :3] = rot.T
            geom_from_mesh[:3, 3] = -rot.T @ pos
        return trimesh.Trimesh(vertices=verts, faces=faces, process=False), geom_from_mesh
    aabb = np.asarray(model.geom_aabb[g], dtype=np.float64)
    centre, half = aabb[:3], aabb[3:]
    box = trimesh.creation.box(extents=2.0 * half)
    box.apply_translation(centre)
    return box, eye


def body_meshes(model: Any, data: Any, body: int, geoms: Sequence[int]) -> list[trimesh.Trimesh]:
    """The meshes of ``geoms`` (:func:`geom_mesh`, infinite planes left out) in the frame of
    ``body``, at the pose of ``data`` (after ``mj_forward``): a body's geometry as
    ``WorldModel.from_file`` and :class:`MujocoScene` both place it."""
    world_from_body = _pose(data.xpos[body], data.xmat[body])
    body_from_world = np.linalg.inv(world_from_body)
    out = []
    for g in geoms:
        shape = geom_mesh(model, g)
        if shape is None:
            continue
        mesh, geom_from_mesh = shape
        mesh = mesh.copy()
        mesh.apply_transform(body_from_world @ _pose(data.geom_xpos[g], data.geom_xmat[g]) @ geom_from_mesh)
        out.append(mesh)
    return out


# ----------------------------------------------------------------------------------------------
# the simulated camera
# ----------------------------------------------------------------------------------------------
#: Depth noise factor ``c`` of :meth:`MujocoScene.scan` (1/m): ``sigma_z = c z^2``, about 1.5 mm
#: at 1 m and 2.4 cm at 4 m, the Kinect's axial noise (Khoshelham and Elberink 2012, "Accuracy and
#: resolution of Kinect depth data for indoor mapping applications", Sensors 12(2)); the front
#: end's :data:`perception.frontend.DEPTH_NOISE`, so that the simulated noise is the modelled one.
DEFAULT_DEPTH_NOISE = DEPTH_NOISE
#: Largest depth (metres) the simulated depth camera measures; farther pixels are invalid (NaN).
DEFAULT_MAX_RANGE = 6.0
#: Side (pixels) of the blocks over which the depth error is one draw (spatial correlation): the
#: front end's correlation length :data:`perception.frontend.DEPTH_CORRELATION_PX`.
DEPTH_NOISE_BLOCK = int(DEPTH_CORRELATION_PX)
#: Standard deviation of the per-pixel (independent) part of the depth error, relative to the
#: blockwise part; the sum is rescaled so that the total standard deviation is ``c z^2``.
DEPTH_NOISE_IID = 0.25
#: The sensors :meth:`MujocoScene.scan` simulates.
SENSORS = ("rgbd", "stereo")
#: Largest image side (pixels) rendered.
MAX_RENDER_SIDE = 8192
#: Depths at or beyond this fraction of the far clipping plane are "nothing rendered".
_FAR_FRACTION = 0.999

#: Smallest ``lateral_sd`` (m) :meth:`MujocoScene.centre_offsets` reports: exact renders place
#: objects across the view to a few millimetres, a detector's masks do not (an edge a pixel or
#: two off moves the extent of a door seen at 2-3 m by 0.5-1 cm; measured on the Franka kitchen
#: with 1 px of mask jitter, a 5 mm floor left doors' percept NEES at 34 in the 90th percentile).
CENTRE_LATERAL_FLOOR = 0.01
#: Poses and seed of the renders :meth:`MujocoScene.default_centre_offsets` measures on.
CALIBRATION_POSES = 12
#: The seed of those poses.
CALIBRATION_SEED = 20261202

Sensor = Literal["rgbd", "stereo"]


@dataclass(frozen=True)
class SceneObject:
    """A typed object of a :class:`MujocoScene`.

    Attributes
    ----------
    index : int
        Its index in :attr:`MujocoScene.objects` (the truth labels of the detections).
    name : str
        Body name (or the name of a typed geom of the world body).
    type : str
        Its type by the scene's rule.
    body : int
        MuJoCo body id; -1 for a geom of the world body.
    geoms : tuple of int
        The geoms of its geometry (module docstring).
    position : (3,) float
        World centre of its geometry's bounding box in the body frame (as ``WorldModel.from_file``).
    size : (3,) float
        Extents of that bounding box, metres.
    """

    index: int
    name: str
    type: str
    body: int
    geoms: tuple[int, ...]
    position: NDArray[np.float64]
    size: NDArray[np.float64]


@dataclass(frozen=True)
class RenderedView:
    """One rendered camera image: what :meth:`MujocoScene.render` returns.

    Attributes
    ----------
    rgb : (h, w, 3) uint8 or None
        The colour image.
    depth : (h, w) float or None
        Depth in metres along the optical axis (OpenCV z, not the distance along the ray);
        NaN where nothing is rendered (the sky box, beyond the far plane).
    objects : (h, w) int32 or None
        Index of the typed object (:attr:`MujocoScene.objects`) seen at each pixel, -1 for none.
    geoms : (h, w) int32 or None
        MuJoCo geom id seen at each pixel, -1 for none.
    """

    rgb: NDArray[np.uint8] | None
    depth: NDArray[np.float64] | None
    objects: NDArray[np.int32] | None
    geoms: NDArray[np.int32] | None


@dataclass(frozen=True)
class StereoCalibration:
    """What :meth:`MujocoScene.stereo_offsets` measures: the stereo front end's settings per type.

    Attributes
    ----------
    centre_offset : dict of str to CentreOffset
        Where each type's centre lies from the triangulated point (its chosen source's).
    disparity_error : dict of str to DisparityError
        The outline disparity's error beyond its own (types whose source is the outline).
    disparity_from : dict of str to str
        ``"outline"`` or ``"centroids"``: the source that places the type better.
    """

    centre_offset: dict[str, CentreOffset]
    disparity_error: dict[str, DisparityError]
    disparity_from: dict[str, str]

    def keywords(self) -> dict[str, Any]:
        """The keyword arguments of :func:`perception.stereo_percepts` these settings are."""
        return {"centre_offset": dict(self.centre_offset), "disparity_error": dict(self.disparity_error),
                "disparity_from": dict(self.disparity_from)}


@dataclass(frozen=True)
class ScanView:
    """One view of a :class:`MujocoScan`.

    Attributes
    ----------
    head_angles : (n_joints,) float
        Joint angles of the head (radians, order of the chain's names).
    ego_from_camera : (4, 4) float
        Left (or the depth) camera in the ego frame, OpenCV axes.
    K : (3, 3) float
        Camera matrix of the (both) camera(s).
    rgb : (h, w, 3) uint8
        The left (or the depth camera's) colour image.
    segmentation : (h, w) int32
        Object index per pixel (-1: no typed object).
    detections : tuple of Detection
        The (degraded) detections of the image.
    truth : tuple of int
        Per detection the object index it comes from, -1 for a false detection.
    depth : (h, w) float or None
        ``sensor="rgbd"``: the noisy depth (metres, OpenCV z; NaN invalid).
    right_rgb : (h, w, 3) uint8 or None
        ``sensor="stereo"``: the right camera's colour image.
    right_segmentation : (h, w) int32 or None
        ``sensor="stereo"``: object index per pixel of the right image.
    right_detections : tuple of Detection
        ``sensor="stereo"``: the detections of the right image.
    right_truth : tuple of int
        ``sensor="stereo"``: their object indices (-1 false).
    ego_from_right_camera : (4, 4) float or None
        ``sensor="stereo"``: the right camera in the ego frame.
    missed : tuple of int
        Object indices visible in the image whose detection the degradation dropped (``miss_rate``,
        ``min_pixels``, a mask eroded away).
    right_missed : tuple of int
        The same for the right image.
    """

    head_angles: NDArray[np.float64]
    ego_from_camera: NDArray[np.float64]
    K: NDArray[np.float64]
    rgb: NDArray[np.uint8]
    segmentation: NDArray[np.int32]
    detections: tuple[Detection, ...]
    truth: tuple[int, ...]
    depth: NDArray[np.float64] | None = None
    right_rgb: NDArray[np.uint8] | None = None
    right_segmentation: NDArray[np.int32] | None = None
    right_detections: tuple[Detection, ...] = ()
    right_truth: tuple[int, ...] = ()
    ego_from_right_camera: NDArray[np.float64] | None = None
    missed: tuple[int, ...] = ()
    right_missed: tuple[int, ...] = ()


@dataclass(frozen=True)
class ScanTimings:
    """Seconds spent per stage of a scan, summed over the views.

    Attributes
    ----------
    render : float
        MuJoCo rendering (RGB, depth, segmentation; both cameras for stereo) and the depth noise.
    detect : float
        Detections from the segmentation, with their degradation.
    percepts : float
        The front end (detections to percepts).
    n_views : int
        Number of views.
    """

    render: float
    detect: float
    percepts: float
    n_views: int

    @property
    def render_per_view(self) -> float:
        """Rendering seconds per view."""
        return self.render / max(self.n_views, 1)


@dataclass(frozen=True)
class MujocoScan:
    """The result of :meth:`MujocoScene.scan`.

    Attributes
    ----------
    sensor : {"rgbd", "stereo"}
        The simulated sensor.
    views : tuple of ScanView
        The views, in the order of the sweep.
    percepts : tuple of Percept
        Every view's percepts, ego frame, not fused.
    percept_views : tuple of int
        The view of each percept.
    percept_truth : tuple of int
        The object index of each percept (-1: from a false detection).
    dropped : tuple of tuple
        Per view, what the front end dropped (its :class:`~perception.Dropped` records).
    timings : ScanTimings
        Seconds per stage.
    """

    sensor: Sensor
    views: tuple[ScanView, ...]
    percepts: tuple[Any, ...] = ()
    percept_views: tuple[int, ...] = ()
    percept_truth: tuple[int, ...] = ()
    dropped: tuple[tuple[Any, ...], ...] = ()
    timings: ScanTimings = field(default_factory=lambda: ScanTimings(0.0, 0.0, 0.0, 0))


def _pose(position: ArrayLike, xmat: ArrayLike) -> NDArray[np.float64]:
    m = np.eye(4)
    m[:3, :3] = np.asarray(xmat, dtype=np.float64).reshape(3, 3)
    m[:3, 3] = np.asarray(position, dtype=np.float64)
    return m


def _image_size(value: Any) -> tuple[int, int]:
    if value is None or isinstance(value, (str, bytes)):
        raise PerceptionError(f"image_size must be (width, height), got {_short(value)}")
    try:
        items = list(value)
    except TypeError as exc:
        raise PerceptionError(f"image_size must be (width, height), got {_short(value)}") from exc
    if len(items) != 2:
        raise PerceptionError(f"image_size must be two integers (width, height), got {_short(value)}")
    return (integer("image_size[0] (width)", items[0], minimum=1, maximum=MAX_RENDER_SIDE),
            integer("image_size[1] (height)", items[1], minimum=1, maximum=MAX_RENDER_SIDE))



class MujocoScene:
    """A MuJoCo scene whose typed bodies a simulated head sees.

    Parameters
    ----------
    path_or_model : str, os.PathLike or mujoco.MjModel
        An MJCF file (any file MuJoCo compiles) or a compiled model (copied: the scene changes
        rendering settings of its own copy).  The scene is posed at the model's reference
        configuration ``qpos0``, as ``WorldModel.from_file``.
    type_of : None, callable or mapping
        The type rule (:func:`perception.type_rules.type_rule`), as for ``WorldModel.from_file``:
        ``None`` types a body by the leading word of its name when it is a known type.

    Raises
    ------
    RobotFileError
        A file MuJoCo cannot compile, an argument that is neither, or no typed object.
    PerceptionError
        A bad ``type_of``, or a rule that raises or gives a type that is not a string.
    MissingExtraError
        ``mujoco`` is not installed.

    Notes
    -----
    Rendering is set up for speed: no multisampling (``vis.quality.offsamples = 0``), no
    shadows, no reflections.  The camera is MuJoCo's free camera with its vertical field of view
    ``vis.global_.fovy`` and square pixels, placed at the pose of an OpenCV camera frame
    (MuJoCo cameras look along their -z with y up).  One renderer per image size is kept.
    """

    def __init__(self, path_or_model: Any, type_of: Any = None) -> None:
        mujoco = import_mujoco()
        self._mj = mujoco
        if isinstance(path_or_model, mujoco.MjModel):
            model = copy.deepcopy(path_or_model)
            self.path: str | None = None
        else:
            text = file_path("path_or_model", path_or_model, RobotFileError)
            if not os.path.isfile(text):
                raise RobotFileError(f"path_or_model: {text}: no such file")
            try:
                model = mujoco.MjModel.from_xml_path(text)
            except ValueError as exc:
                raise RobotFileError(f"path_or_model: {text}: MuJoCo cannot compile it: {exc}") from exc
            self.path = text
        model.vis.quality.offsamples = 0
        self._model = model
        self._data = mujoco.MjData(model)
        mujoco.mj_forward(model, self._data)
        self._rule = type_rule(type_of)
        self._objects, self._geom_object = self._build_objects()
        if not self._objects:
            names = [model.body(b).name for b in range(1, model.nbody) if model.body(b).name][:20]
            raise RobotFileError(f"path_or_model: no body or world geom gets a type (body names {names}); "
                                 "pass type_of= to type them")
        self._renderers: dict[tuple[int, int], Any] = {}
        self._default_offsets: dict[str, CentreOffset] | None = None
        self._default_stereo: dict[tuple[tuple[int, int], int], StereoCalibration] = {}
        self._camera = mujoco.MjvCamera()  # a free camera; its pose is overwritten per view
        mujoco.mjv_defaultFreeCamera(model, self._camera)

    # -- objects ---------------------------------------------------------------------------------
    def _type(self, name: str) -> str | None:
        try:
            typ = self._rule(name)
        except Exception as exc:
            raise PerceptionError(f"type_of({name!r}) raised {type(exc).__name__}: {exc}") from exc
        if typ is None:
            return None
        return name_string(f"type_of({name!r})", typ)

    def _build_objects(self) -> tuple[tuple[SceneObject, ...], NDArray[np.intp]]:
        model, data = self._model, self._data
        nbody, ngeom = int(model.nbody), int(model.ngeom)
        body_type: list[str | None] = [None] * nbody
        for b in range(1, nbody):
            name = model.body(b).name
            body_type[b] = self._type(name) if name else None
        geoms_of = object_geoms(model, lambda name: self._type(name) if name else None)
        objects: list[SceneObject] = []
        geom_object = np.full(ngeom, -1, dtype=np.intp)
        first, count = int(model.body_geomadr[0]), int(model.body_geomnum[0])
        for g in range(first, first + count):  # named geoms of the world body: their own objects
            name = model.geom(g).name
            typ = self._type(name) if name else None
            shape = geom_mesh(model, g) if typ is not None else None
            if typ is None or shape is None:
                continue
            world = _pose(data.geom_xpos[g], data.geom_xmat[g]) @ shape[1]
            lo, hi = shape[0].bounds
            position = world[:3, :3] @ (0.5 * (lo + hi)) + world[:3, 3]
            geom_object[g] = len(objects)
            objects.append(SceneObject(len(objects), name, typ, -1, (g,), position, hi - lo))
        body_object = np.full(nbody, -1, dtype=np.intp)
        for b in range(1, nbody):
            typ = body_type[b]
            if typ is None:
                continue
            world_from_body = _pose(data.xpos[b], data.xmat[b])
            points = [np.asarray(mesh.vertices, dtype=np.float64)
                      for mesh in body_meshes(model, data, b, geoms_of[b])]
            cloud = np.concatenate(points) if points else np.zeros((1, 3))
            lo, hi = cloud.min(axis=0), cloud.max(axis=0)
            position = world_from_body[:3, :3] @ (0.5 * (lo + hi)) + world_from_body[:3, 3]
            body_object[b] = len(objects)
            objects.append(SceneObject(len(objects), model.body(b).name, typ, b, tuple(geoms_of[b]),
                                       position, hi - lo))
        parent = np.asarray(model.body_parentid, dtype=np.intp).reshape(nbody)
        for g in range(ngeom):  # a geom's pixels belong to its typed ancestor-or-self body
            b = int(model.geom_bodyid[g])
            if b == 0:
                continue
            while b != 0 and body_type[b] is None:
                b = int(parent[b])
            geom_object[g] = body_object[b] if b != 0 else -1
        for o in objects:
            o.position.setflags(write=False)
            o.size.setflags(write=False)
        return tuple(objects), geom_object

    @property
    def model(self) -> Any:
        """The scene's ``mujoco.MjModel`` (its own copy)."""
        return self._model

    @property
    def objects(self) -> tuple[SceneObject, ...]:
        """The typed objects: the typed geoms of the world body, then the typed bodies by body id."""
        return self._objects

    @property
    def positions(self) -> NDArray[np.float64]:
        """Object centres ``(n, 3)``, world frame."""
        return np.array([o.position for o in self._objects], dtype=np.float64).reshape(-1, 3)

    @property
    def types(self) -> tuple[str, ...]:
        """Object types, in the order of :attr:`objects`."""
        return tuple(o.type for o in self._objects)

    def centre_depths(self) -> dict[str, float]:
        """Per type, the depth of an object's centre behind its visible surface, metres.

        Returns
        -------
        dict
            Type -> the median over the objects of that type of half the thinnest extent of the
            object's geometry (its bounding box in the body frame): a ``centre_offset`` of the
            front ends (:func:`perception.rgbd_percepts`, :func:`perception.stereo_percepts`), the
            default of :meth:`scan`.
        """
        out: dict[str, float] = {}
        for typ in sorted(set(self.types)):
            half = [0.5 * float(np.min(o.size)) for o in self._objects if o.type == typ]
            out[typ] = float(np.median(half))
        return out

    def _obstacle_boxes(self) -> NDArray[np.float64]:
        """World axis-aligned boxes ``(k, 2, 3)`` of every geom but planes and the robot-free
        floor: what a robot standing in the scene must keep clear of."""
        model, data = self._model, self._data
        plane = int(self._mj.mjtGeom.mjGEOM_PLANE)
        boxes = []
        for g in range(model.ngeom):
            if int(model.geom_type[g]) == plane:
                continue
            R = np.asarray(data.geom_xmat[g], dtype=np.float64).reshape(3, 3)
            centre = R @ np.asarray(model.geom_aabb[g, :3]) + np.asarray(data.geom_xpos[g])
            half = np.abs(R) @ np.asarray(model.geom_aabb[g, 3:])
            boxes.append([centre - half, centre + half])
        return np.array(boxes).reshape(-1, 2, 3)

    def _floor(self) -> tuple[float, NDArray[np.float64], NDArray[np.float64]]:
        """Floor height and the ``(x, y)`` rectangle a robot may stand in: the extent of the
        scene's finite floor planes (else the typed objects' extent and 3 m around it), within
        3 m of the typed objects."""
        model, data = self._model, self._data
        plane = int(self._mj.mjtGeom.mjGEOM_PLANE)
        pos = self.positions
        lo, hi = pos[:, :2].min(axis=0) - 3.0, pos[:, :2].max(axis=0) + 3.0
        floors = [g for g in range(model.ngeom) if int(model.geom_type[g]) == plane]
        z = 0.0
        if floors:
            g = min(floors, key=lambda g: float(data.geom_xpos[g][2]))
            z = float(data.geom_xpos[g][2])
            size = np.asarray(model.geom_size[g][:2], dtype=np.float64)
            if np.all(size > 0):
                centre = np.asarray(data.geom_xpos[g][:2], dtype=np.float64)
                lo, hi = np.maximum(lo, centre - size), np.minimum(hi, centre + size)
        return z, lo, hi

    def robot_poses(self, n: int, rng: np.random.Generator, *, clearance: float = 0.4,
                    head_height: tuple[float, float] = (1.2, 1.7), max_distance: float = 2.5,
                    yaw_spread_deg: float = 30.0) -> NDArray[np.float64]:
        """Random poses of a level robot standing in the scene's free space, facing its objects.

        The head (ego origin) stands ``head_height`` above the floor (the lowest plane geom,
        else z = 0) at a floor point within ``max_distance`` of a random typed object, whose
        vertical column from the floor to the head keeps ``clearance`` from every geom's
        bounding box and that sees a typed object first when looking at it (no wall between);
        the robot faces that object, give or take ``yaw_spread_deg``.  For
        benchmarks and for measuring :meth:`centre_offsets`.

        Parameters
        ----------
        n : int
            Number of poses.
        rng : numpy.random.Generator
        clearance, max_distance : float
            Metres, > 0.
        head_height : (float, float)
            Range of the head's height above the floor, metres.
        yaw_spread_deg : float
            Largest deviation of the heading from the direction of the object, degrees.

        Returns
        -------
        (n, 4, 4) float
            ``world_from_ego`` (ego: x forward, y left, z up).

        Raises
        ------
        PerceptionError
            No free floor point near the objects after ``1000 n`` tries.
        """
        n = integer("n", n, minimum=1, maximum=100_000)
        gen = check_rng("rng", rng)
        clearance = real_scalar("clearance", clearance, positive=True, maximum=100.0)
        max_distance = real_scalar("max_distance", max_distance, positive=True, maximum=1e3)
        spread = np.radians(real_scalar("yaw_spread_deg", yaw_spread_deg, nonnegative=True, maximum=180.0))
        heights = real_array("head_height", head_height, (2,))
        if not 0 < heights[0] <= heights[1] <= 100.0:
            raise PerceptionError(f"head_height must be (low, high) with 0 < low <= high <= 100 m, got "
                                  f"{heights.tolist()}")
        floor, lo, hi = self._floor()
        boxes = self._obstacle_boxes()
        pos = self.positions
        out = np.zeros((n, 4, 4))
        k = tries = 0
        while k < n:
            tries += 1
            if tries > 1000 * n:
                raise PerceptionError(f"no free floor point within {max_distance:g} m of the objects keeps "
                                      f"{clearance:g} m from every geom (found {k} of {n})")
            target = pos[int(gen.integers(len(pos)))]
            r, a = max_distance * np.sqrt(gen.uniform(0.04, 1.0)), gen.uniform(0.0, 2.0 * np.pi)
            xy = target[:2] + r * np.array([np.cos(a), np.sin(a)])
            if np.any(xy < lo) or np.any(xy > hi):
                continue
            head = floor + gen.uniform(heights[0], heights[1])
            near = ((boxes[:, 0, 0] < xy[0] + clearance) & (boxes[:, 1, 0] > xy[0] - clearance)
                    & (boxes[:, 0, 1] < xy[1] + clearance) & (boxes[:, 1, 1] > xy[1] - clearance)
                    & (boxes[:, 0, 2] < head + clearance) & (boxes[:, 1, 2] > floor + 0.05))
            if near.any() or not self._sees(np.array([xy[0], xy[1], head]), target):
                continue
            yaw = np.arctan2(target[1] - xy[1], target[0] - xy[0]) + gen.uniform(-spread, spread)
            c, s_ = np.cos(yaw), np.sin(yaw)
            out[k] = [[c, -s_, 0.0, xy[0]], [s_, c, 0.0, xy[1]], [0.0, 0.0, 1.0, head], [0.0, 0.0, 0.0, 1.0]]
            k += 1
        return out

    def _sees(self, eye: NDArray[np.float64], target: NDArray[np.float64]) -> bool:
        """Whether the first visible geom on the ray from ``eye`` to an object's centre ``target``
        belongs to a typed object (the robot stands in the room of what it faces, not behind a
        wall)."""
        geomid = np.full((1, 1), -1, dtype=np.int32)
        groups = np.array([1, 1, 1, 0, 0, 0], dtype=np.uint8)
        direction = target - eye
        dist = self._mj.mj_ray(self._model, self._data, eye, direction / np.linalg.norm(direction), groups, 1,
                               -1, geomid)
        g = int(geomid[0, 0])
        return dist < 0 or (g >= 0 and int(self._geom_object[g]) >= 0)

    def default_centre_offsets(self) -> dict[str, CentreOffset]:
        """The centre offsets :meth:`scan` uses by default: :meth:`centre_offsets` measured on
        exact renders (320x240, 8 views each) from :data:`CALIBRATION_POSES` poses of
        :meth:`robot_poses` drawn with a fixed
        seed (:data:`CALIBRATION_SEED`), once per scene; types never seen whole fall back to
        :meth:`centre_depths`.  The analogue of measuring a detector's classes on its training
        objects: the poses are not those of any scan.  A scene with no free floor to stand on
        warns and uses :meth:`centre_depths` alone."""
        if self._default_offsets is None:
            fallback = {t: CentreOffset(d) for t, d in self.centre_depths().items()}
            try:
                poses = self.robot_poses(CALIBRATION_POSES, np.random.default_rng(CALIBRATION_SEED))
            except PerceptionError as exc:  # nowhere to stand: the geometry's guess alone, said aloud
                warnings.warn(f"centre offsets not measured ({exc}); using centre_depths()", stacklevel=2)
                measured = {}
            else:
                measured = self.centre_offsets(poses, n_views=8, image_size=(320, 240))
            self._default_offsets = fallback | measured
        return dict(self._default_offsets)

    def centre_offsets(self, world_from_egos: Any, *, n_views: int = 20, image_size: Any = (320, 240),
                       chain: KinematicChain | None = None, min_pixels: int = 20) -> dict[str, CentreOffset]:
        """Measure on renders where each type's centre lies from its visible part.

        Exact scans (no noise, no degradation) from the given robot poses; for every object
        the depth front end keeps (:func:`perception.rgbd_percepts`: not cut off by the image
        border, not occluded, at least ``min_pixels`` pixels with depth), the visible part is its
        pixels back-projected with their depth, and the offset
        is the object's centre (:attr:`objects`) minus the part's centroid, split as the front
        ends split it (:mod:`perception.frontend`): along the direction away from the camera
        (the visible surface's normal when it is flat, its smallest variance below
        :data:`~perception.frontend.FLAT_RATIO` times the middle one, else the viewing ray)
        and across it.

        Parameters
        ----------
        world_from_egos : (4, 4) or (m, 4, 4) float
            Robot poses to scan from (in free space, seeing the objects as the robot would).
        n_views : int
            Views per pose (:meth:`scan`).
        image_size : (int, int)
            ``(width, height)``, pixels.
        chain : KinematicChain, optional
            The head; :func:`perception.default_head` by default.
        min_pixels : int
            Fewest pixels of a view of an object to measure it.

        Returns
        -------
        dict of str to CentreOffset
            Per type seen: ``depth`` the median of the offsets along the direction, ``depth_sd``
            their root mean square about it and ``lateral_sd`` the root mean square per axis of
            the offsets across it (the odd badly seen view included: a prior that covers the
            views the front end keeps, tails and all; at least
            :data:`~perception.frontend.CENTRE_DEPTH_FLOOR` and :data:`CENTRE_LATERAL_FLOOR`).
            Types never measured are left out (the front ends then use the visible relief).

        Raises
        ------
        PerceptionError
            - A pose that is not a rigid transform.
            - (a subclass) a bad ``n_views``, ``image_size``, ``chain`` or ``min_pixels``.
        """
        from .frontend import CENTRE_DEPTH_FLOOR, DEPTH_NOISE, _depth_windows, _visible_anchor

        checked = self._calibration_poses(world_from_egos)
        min_px = integer("min_pixels", min_pixels, minimum=1)
        along: dict[str, list[float]] = {}
        across: dict[str, list[float]] = {}
        for pose in checked:
            scan = self.scan(pose, "rgbd", n_views, rng=np.random.default_rng(0), image_size=image_size,
                             chain=chain, depth_noise=0.0, percepts=False, max_range=1e6)
            for view in scan.views:
                assert view.depth is not None
                h, w = view.depth.shape
                Kinv = np.linalg.inv(view.K)
                camera_from_world = np.linalg.inv(pose @ view.ego_from_camera)
                up = view.ego_from_camera[:3, :3].T @ np.array([0.0, 0.0, 1.0])
                # only what the front end keeps (not cut off, not occluded, enough depth)
                kept = set(rgbd_percepts(view.detections, view.depth, view.K, np.eye(4), centre_offset=0.0,
                                         min_pixels=min_px).sources)
                for i, (det, k) in enumerate(zip(view.detections, view.truth, strict=True)):
                    if i not in kept or k < 0:
                        continue
                    assert det.mask is not None  # the renderer's detections carry masks
                    v, u = np.nonzero(det.mask)
                    z = view.depth[v, u]
                    ok = np.isfinite(z)
                    if int(ok.sum()) < min_px:
                        continue
                    box = np.array([u.min(), v.min(), u.max(), v.max()], dtype=np.float64)
                    _, (lo, hi) = _depth_windows(det.mask, box, view.depth, DEPTH_NOISE, z[ok])
                    fg = ok & (z >= lo) & (z <= hi)  # the object's depths, as the front end takes them
                    pts = (Kinv @ np.stack([u[fg], v[fg], np.ones(int(fg.sum()))])).T * z[fg, None]
                    anchor, direction, _ = _visible_anchor(pts, up)  # as the front end places it
                    centre = camera_from_world[:3, :3] @ self._objects[k].position + camera_from_world[:3, 3]
                    offset = centre - anchor
                    d = float(offset @ direction)
                    typ = self._objects[k].type
                    along.setdefault(typ, []).append(d)
                    across.setdefault(typ, []).append(float(np.linalg.norm(offset - d * direction)))
        out: dict[str, CentreOffset] = {}
        for typ in sorted(along):
            d_all = np.array(along[typ])
            median = float(np.median(d_all))
            depth_sd = float(np.sqrt(np.mean(np.square(d_all - median))))
            lateral = float(np.sqrt(np.mean(np.square(across[typ])) / 2.0))
            out[typ] = CentreOffset(median, max(depth_sd, CENTRE_DEPTH_FLOOR),
                                    max(lateral, CENTRE_LATERAL_FLOOR))
        return out

    def default_stereo_offsets(self, image_size: Any = (640, 480), mask_jitter_px: int = 0
                               ) -> StereoCalibration:
        """The stereo front end's settings a stereo :meth:`scan` uses by default:
        :meth:`stereo_offsets` measured from the poses :meth:`default_centre_offsets` uses (8 views
        each) at the scan's image size and mask jitter (an outline's errors depend on both: the
        analogue of measuring a detector's classes on its training objects), once per scene and
        setting; types never measured take :meth:`default_centre_offsets` and the centroids."""
        key = (_image_size(image_size), integer("mask_jitter_px", mask_jitter_px, minimum=0, maximum=1000))
        if key not in self._default_stereo:
            try:
                poses = self.robot_poses(CALIBRATION_POSES, np.random.default_rng(CALIBRATION_SEED))
            except PerceptionError as exc:
                warnings.warn(f"stereo offsets not measured ({exc}); using default_centre_offsets()",
                              stacklevel=2)
                measured = StereoCalibration({}, {}, {})
            else:
                measured = self.stereo_offsets(poses, n_views=8, image_size=key[0], mask_jitter_px=key[1])
            self._default_stereo[key] = StereoCalibration(
                self.default_centre_offsets() | measured.centre_offset, measured.disparity_error,
                measured.disparity_from)
        return self._default_stereo[key]

    def stereo_offsets(self, world_from_egos: Any, *, n_views: int = 20, image_size: Any = (320, 240),
                       chain: KinematicChain | None = None, min_pixels: int = 20, mask_jitter_px: int = 0
                       ) -> StereoCalibration:
        """Measure on stereo renders, per type, where its centre lies from the point the stereo
        front end triangulates, how the disparity errs, and which disparity (the centroids' or
        the outline's) places it better.

        Exact stereo scans from the given poses; every pair :func:`perception.stereo_percepts`
        would keep (same object in both images, not cut off, extents that agree, an outline
        disparity: :func:`perception.outline_disparity` at the middle of the left mask's extent)
        gives, for each source, the offset ``o`` of the object's centre from the triangulated
        point (outline: the extent's middle at the outline's disparity; centroids: the two
        centroids), along the viewing ray and across it.  Per type and source: the centre
        offset's ``depth`` is the median of ``o`` along the ray.  The residuals about it, in
        pixels of disparity, beyond what the front end already models (outline: each pair's
        standard error and :data:`~perception.DISPARITY_ENDS_FRACTION` times its ends'
        difference; centroids: ``DISPARITY_STD_PX``), split into the part the views of one
        object in one scan share (``depth_sd``, metres: it does not average out when the views
        are fused) and the part that varies from view to view (the outline's
        :class:`~perception.DisparityError` ``sd_px``; for the centroids it is counted as
        shared), each the spread at which the residuals' mean squared standard score is 1; with
        no object seen twice in a scan all of it is shared.  The ``lateral_sd`` is the root mean
        square per axis of ``o`` across the ray.  The source whose views place the centre with the
        smaller mean squared error (along the ray about the median, and across it) is the type's
        ``disparity_from``.

        Parameters and errors as :meth:`centre_offsets`; ``mask_jitter_px`` moves the masks' edges
        as :meth:`scan` does (the detector the offsets are for), with a fixed seed.

        Returns
        -------
        StereoCalibration
            Per type measured in at least two views.
        """
        from .frontend import CENTRE_DEPTH_FLOOR, _extent_middle, _extents_differ, _touches_border
        from .outline import _split_spread, outline_disparity
        from .recognition import DISPARITY_STD_PX, match_stereo

        checked = self._calibration_poses(world_from_egos)
        min_px = integer("min_pixels", min_pixels, minimum=1)
        # per type and source: (object-in-scan id, along, px per m, own sd px, ends px, across)
        rows: dict[tuple[str, str], list[tuple[int, float, float, float, float, float]]] = {}
        group = 0
        for pose in checked:
            scan = self.scan(pose, "stereo", n_views, rng=np.random.default_rng(0), image_size=image_size,
                             chain=chain, percepts=False, max_range=1e6, mask_jitter_px=mask_jitter_px)
            groups: dict[int, int] = {}
            for view in scan.views:
                h, w = view.segmentation.shape
                rig = _view_rig(view)
                rect = rig.rectify()
                camera_from_world = np.linalg.inv(pose @ view.ego_from_camera)
                for m in match_stereo(rig, view.detections, view.right_detections, min_depth=0.3):
                    dl, dr = view.detections[m.left], view.right_detections[m.right]
                    k = view.truth[m.left]
                    if (k < 0 or k != view.right_truth[m.right] or dl.box is None or dr.box is None
                            or dl.area is None or dr.area is None or dl.area < min_px or dr.area < min_px
                            or _touches_border(dl.box, w, h) or _touches_border(dr.box, w, h)
                            or _extents_differ(dl, dr)):
                        continue
                    at = _extent_middle(dl)
                    od = outline_disparity(rig, dl, dr, rect, at=at)
                    if od is None or od.disparity <= 0.0:
                        continue
                    centre = camera_from_world[:3, :3] @ self._objects[k].position + camera_from_world[:3, 3]
                    measured = []
                    try:
                        for source, uv_l, uv_r, duv, sd, ends in (
                                ("outline", at, od.uv_right, od.duv_right, od.sd, od.ends_differ_px),
                                ("centroids", np.asarray(dl.centroid_uv), np.asarray(dr.centroid_uv),
                                 od.duv_right, DISPARITY_STD_PX, 0.0)):
                            X = rig.triangulate(uv_l[None, :], uv_r[None, :])[0]
                            # pixels of disparity per metre along the ray, at this depth
                            X2 = rig.triangulate(uv_l[None, :], (uv_r + duv)[None, :])[0]
                            measured.append((source, X, 1.0 / float(np.linalg.norm(X - X2)), sd, ends))
                    except PerceptionError:  # at infinity: nothing to learn from this pair
                        continue
                    g = groups.setdefault(k, group + len(groups))
                    for source, X, per_m, sd, ends in measured:
                        ray = X / np.linalg.norm(X)
                        offset = centre - X
                        along = float(offset @ ray)
                        rows.setdefault((self._objects[k].type, source), []).append(
                            (g, along, per_m, sd, ends, float(np.linalg.norm(offset - along * ray))))
            group += len(groups)
        offsets: dict[str, CentreOffset] = {}
        errors: dict[str, DisparityError] = {}
        sources: dict[str, str] = {}
        for typ in sorted({t for t, _ in rows}):
            best = None
            for source in ("outline", "centroids"):
                r = np.array(rows[typ, source])
                if len(r) < 2:
                    continue
                g, along, per_m, sd, ends, across = r.T
                depth = float(np.median(along))
                res_px = (along - depth) * per_m  # the sign does not matter for the spreads
                sd_px, shared_px = _split_spread(g.astype(np.int64), res_px, sd, ends)
                if source == "centroids":  # the front end adds nothing per view to the centroids
                    sd_px, shared_px = 0.0, float(np.hypot(sd_px, shared_px))
                depth_sd = max(shared_px / float(np.median(per_m)), CENTRE_DEPTH_FLOOR)
                lateral = max(float(np.sqrt(np.mean(across ** 2) / 2.0)), CENTRE_LATERAL_FLOOR)
                # the views' mean squared error about the centre, along the ray and across it
                expected = float(np.mean((along - depth) ** 2 + across ** 2))
                if best is None or expected < best[0]:
                    best = (expected, source, CentreOffset(depth, depth_sd, lateral),
                            DisparityError(0.0, sd_px))
            if best is not None:
                _, sources[typ], offsets[typ], errors[typ] = best
        return StereoCalibration(offsets, errors, sources)

    def _calibration_poses(self, world_from_egos: Any) -> list[NDArray[np.float64]]:
        poses = real_array("world_from_egos", world_from_egos)
        if poses.shape[-2:] != (4, 4) or poses.ndim not in (2, 3) or poses.size == 0:
            raise PerceptionError(f"world_from_egos must be a (4, 4) or (m, 4, 4) array, got shape "
                                  f"{poses.shape}")
        return [check_transform(f"world_from_egos[{i}]", T) for i, T in enumerate(poses.reshape(-1, 4, 4))]

    # -- rendering -------------------------------------------------------------------------------
    def camera_matrix(self, image_size: Any = (640, 480)) -> NDArray[np.float64]:
        """The OpenCV camera matrix of the rendered images.

        Parameters
        ----------
        image_size : (int, int)
            ``(width, height)``, pixels.

        Returns
        -------
        (3, 3) float
            ``f = (h / 2) / tan(fovy / 2)`` for both axes (square pixels; ``fovy`` is the model's
            ``vis.global_.fovy``), principal point ``((w - 1) / 2, (h - 1) / 2)`` (pixel centres
            at integer coordinates).
        """
        w, h = _image_size(image_size)
        f = 0.5 * h / math.tan(math.radians(float(self._model.vis.global_.fovy)) / 2.0)
        return np.array([[f, 0.0, (w - 1) / 2.0], [0.0, f, (h - 1) / 2.0], [0.0, 0.0, 1.0]])

    def _renderer(self, size: tuple[int, int]) -> Any:
        renderer = self._renderers.get(size)
        if renderer is None:
            w, h = size
            vis = self._model.vis.global_
            vis.offwidth, vis.offheight = max(int(vis.offwidth), w), max(int(vis.offheight), h)
            try:
                renderer = self._mj.Renderer(self._model, h, w)
            except Exception as exc:  # no OpenGL: the message says which backend failed
                raise PerceptionError(f"cannot render {w}x{h} images ({type(exc).__name__}: {exc}); headless "
                                      "rendering needs MUJOCO_GL=egl (or osmesa) set before mujoco is "
                                      "imported") from exc
            self._renderers[size] = renderer
        return renderer

    def close(self) -> None:
        """Free the renderers (their OpenGL contexts); the next render makes new ones."""
        for renderer in self._renderers.values():
            renderer.close()
        self._renderers.clear()

    def render(self, world_from_camera: ArrayLike, image_size: Any = (640, 480), *, rgb: bool = True,
               depth: bool = True, segmentation: bool = True) -> RenderedView:
        """Render one view from a camera pose.

        Parameters
        ----------
        world_from_camera : (4, 4) float
            The camera in the world, OpenCV axes (x right, y down, z forward).
        image_size : (int, int)
            ``(width, height)``, pixels.
        rgb, depth, segmentation : bool
            Which images to render.

        Returns
        -------
        RenderedView
            Noise-free images; the pixel ``(u, v)`` of a world point ``X`` is
            ``K @ (camera_from_world @ X)`` with ``K = camera_matrix(image_size)``.

        Raises
        ------
        PerceptionError
            - ``world_from_camera`` is not a rigid transform.
            - A bad ``image_size``.
            - No OpenGL context (set ``MUJOCO_GL=egl``).
        """
        pose = check_transform("world_from_camera", world_from_camera)
        size = _image_size(image_size)
        return self._render(pose, size, boolean("rgb", rgb), boolean("depth", depth),
                            boolean("segmentation", segmentation))

    def _render(self, world_from_camera: NDArray[np.float64], size: tuple[int, int], want_rgb: bool,
                want_depth: bool, want_seg: bool) -> RenderedView:
        mj = self._mj
        r = self._renderer(size)
        r.update_scene(self._data, self._camera)
        scene = r.scene
        pos = world_from_camera[:3, 3]
        forward = world_from_camera[:3, 2]  # OpenCV z: the optical axis
        up = -world_from_camera[:3, 1]  # OpenCV y points down
        for k in range(2):  # both eyes of MuJoCo's (mono) stereo pair: the same camera
            scene.camera[k].pos[:] = pos
            scene.camera[k].forward[:] = forward
            scene.camera[k].up[:] = up
        if bool(self._model.vis.headlight.active) and int(scene.nlight) > 0:
            scene.lights[0].pos[:] = pos  # the headlight follows the camera
            scene.lights[0].dir[:] = forward
        scene.flags[mj.mjtRndFlag.mjRND_SHADOW] = False
        scene.flags[mj.mjtRndFlag.mjRND_REFLECTION] = False
        rgb = r.render().copy() if want_rgb else None
        depth = None
        if want_depth:
            r.enable_depth_rendering()
            try:
                z = r.render().astype(np.float64)
            finally:
                r.disable_depth_rendering()
            far = float(self._model.vis.map.zfar) * float(self._model.stat.extent)
            z[~(z < _FAR_FRACTION * far)] = np.nan
            depth = z
        objects = geoms = None
        if want_seg:
            r.enable_segmentation_rendering()
            try:
                seg = r.render()
            finally:
                r.disable_segmentation_rendering()
            is_geom = seg[..., 1] == int(mj.mjtObj.mjOBJ_GEOM)
            geoms = np.where(is_geom, seg[..., 0], -1).astype(np.int32)
            objects = np.where(geoms >= 0, self._geom_object[np.maximum(geoms, 0)], -1).astype(np.int32)
        return RenderedView(rgb, depth, objects, geoms)

    # -- scans -----------------------------------------------------------------------------------
    def scan(self, world_from_ego: ArrayLike, sensor: str = "rgbd", n_views: int = 20, *,
             rng: np.random.Generator, image_size: Any = (640, 480), chain: KinematicChain | None = None,
             miss_rate: float = 0.0, false_rate: float = 0.0, mask_jitter_px: int = 0, min_pixels: int = 1,
             depth_noise: float = DEFAULT_DEPTH_NOISE, max_range: float = DEFAULT_MAX_RANGE,
             centre_offset: Mapping[str, Any] | None = None, percepts: bool = True,
             yaw_deg: tuple[float, float] = (-70.0, 70.0),
             pitch_deg: tuple[float, float] = (-10.0, 10.0)) -> MujocoScan:
        """Sweep a head over the scene and detect the typed objects in every view.

        Parameters
        ----------
        world_from_ego : (4, 4) float
            The robot pose (ego frame: x forward, y left, z up).
        sensor : {"rgbd", "stereo"}
            ``"rgbd"``: one camera with RGB, noisy depth and segmentation; ``"stereo"``: the left
            and right cameras of the head, RGB and segmentation each.
        n_views : int
            Views of the sweep, :func:`perception.simulate.scan_angles` (neck yaw from -70 to 70
            degrees, neck pitch alternating -10 / 10 degrees).
        rng : numpy.random.Generator
            Draws the depth noise and the degradations.
        image_size : (int, int)
            ``(width, height)``, pixels.
        chain : KinematicChain, optional
            The head; :func:`perception.default_head` by default.  The cameras are at
            ``world_from_ego @ chain.ego_from_camera(q)`` (and ``ego_from_right_camera``).
        miss_rate : float
            Probability that a visible object's detection is dropped.
        false_rate : float
            Per image, ``Binomial(n_visible, false_rate)`` false detections (truth -1): half of
            them (when there is another type in the scene) the mask of a true detection labelled
            with another type of the scene, the others an elliptic blob of pixels where no typed
            object is, labelled with a type of the scene.
        mask_jitter_px : int
            Every mask's edge moves by a random whole number of pixels in
            ``[-mask_jitter_px, mask_jitter_px]`` (erosion or dilation by a 3x3 cross).
        min_pixels : int
            Detections (true or false) with fewer pixels are dropped.
        depth_noise : float
            ``c`` (1/m) of the depth error ``sigma_z = c z^2`` (:data:`DEFAULT_DEPTH_NOISE`); 0
            for exact depth.  The normalised error is one draw per block of
            :data:`DEPTH_NOISE_BLOCK` pixels plus an independent part per pixel
            (:data:`DEPTH_NOISE_IID`).  The front end models the same ``c`` (the default
            :data:`perception.frontend.DEPTH_NOISE` for exact depth).
        max_range : float
            Depths beyond it are invalid (NaN), as are pixels where nothing is rendered.
        centre_offset : mapping, optional
            Type -> :class:`~perception.CentreOffset` (or its depth in metres) for the front end:
            where an object's centre lies from its visible part; by default
            :meth:`default_centre_offsets` (measured on renders from other poses; stereo:
            :meth:`default_stereo_offsets`, with the outline's disparity errors); pass
            :meth:`centre_depths` (half the thinnest extent, as the map's
            :meth:`worldgraph.WorldModel.centre_depths`) to use the geometry's guess alone.
        yaw_deg, pitch_deg : (float, float)
            The sweep (:func:`perception.simulate.scan_angles`): neck yaw from the first to the
            second value over the views, neck pitch alternating between the two (degrees;
            negative pitch looks up).  The defaults are the paper's scan.
        percepts : bool
            Run the front end (``False``: images and detections only): per view
            :func:`perception.rgbd_percepts` on the detections and the noisy depth, or
            :func:`perception.stereo_percepts` on the left and right detections with the rig of
            the two cameras (``X_right = R X_left + T`` from ``inv(ego_from_right) @
            ego_from_left``, both with ``K``, no distortion), ``disparity_from="outline"`` and
            the disparity errors :meth:`default_stereo_offsets` measures.

        Returns
        -------
        MujocoScan
            The views, the percepts of all views (ego frame, not fused), what the front end
            dropped per view, and the seconds spent per stage.

        Raises
        ------
        PerceptionError
            - ``world_from_ego`` is not a rigid transform.
            - An unknown ``sensor``.
            - (a subclass) naming the argument: ``n_views`` < 1, a bad ``image_size``, a rate
              outside [0, 1], a negative ``mask_jitter_px``, ``min_pixels`` < 1, a negative
              ``depth_noise``, a non-positive ``max_range``, ``rng`` not a Generator.
        """
        pose = check_transform("world_from_ego", world_from_ego)
        kind = _sensor(sensor)
        n = integer("n_views", n_views, minimum=1, maximum=100_000)
        gen, size, head, degrade, noise, far = self._sweep_arguments(
            rng, image_size, chain, miss_rate, false_rate, mask_jitter_px, min_pixels, depth_noise, max_range)
        run_front_end = boolean("percepts", percepts)
        centres = (self._centre_offset(centre_offset, kind, size, degrade.jitter)
                   if run_front_end or centre_offset is not None else StereoCalibration({}, {}, {}))
        Q = scan_angles(head, n, yaw_deg, pitch_deg)
        return self._sweep(pose, Q, head, kind, gen, size, degrade, noise, far, run_front_end, centres)

    def _sweep_arguments(self, rng: Any, image_size: Any, chain: Any, miss_rate: Any, false_rate: Any,
                         mask_jitter_px: Any, min_pixels: Any, depth_noise: Any, max_range: Any
                         ) -> tuple[np.random.Generator, tuple[int, int], KinematicChain, _Degrade, float,
                                    float]:
        """The checked arguments :meth:`scan` and :meth:`look` share: the generator, the image size,
        the head, the detector model, the depth noise and the range."""
        gen = check_rng("rng", rng)
        size = _image_size(image_size)
        head = default_head() if chain is None else chain
        if not isinstance(head, KinematicChain):
            raise PerceptionError(f"chain must be a KinematicChain or None, got {type(chain).__name__}")
        degrade = _Degrade(self.types, gen, real_scalar("miss_rate", miss_rate, minimum=0.0, maximum=1.0),
                           real_scalar("false_rate", false_rate, minimum=0.0, maximum=1.0),
                           integer("mask_jitter_px", mask_jitter_px, minimum=0, maximum=1000),
                           integer("min_pixels", min_pixels, minimum=1))
        noise = real_scalar("depth_noise", depth_noise, nonnegative=True)
        far = real_scalar("max_range", max_range, positive=True)
        return gen, size, head, degrade, noise, far

    def look(self, world_from_ego: ArrayLike, direction: ArrayLike, *, sensor: str = "rgbd",
             rng: np.random.Generator, n_views: int = LOOK_VIEWS, spread_deg: float = LOOK_SPREAD_DEG,
             neck_reach_deg: float = NECK_REACH_DEG, image_size: Any = (640, 480),
             chain: KinematicChain | None = None, miss_rate: float = 0.0, false_rate: float = 0.0,
             mask_jitter_px: int = 0, min_pixels: int = 1, depth_noise: float = DEFAULT_DEPTH_NOISE,
             max_range: float = DEFAULT_MAX_RANGE, centre_offset: Mapping[str, Any] | None = None,
             pitch_deg: tuple[float, float] = (-10.0, 10.0), min_views: int = 1) -> list[Percept]:
        """The percepts of one look towards an ego-frame direction, fused, in the ego frame of
        ``world_from_ego``.

        The head turns its neck (yaw and pitch) towards ``direction``; ``n_views`` views fan out
        over neck yaws ``spread_deg`` either side of it, the pitch alternating by ``pitch_deg``
        about the direction's (as :meth:`scan` does), so that the look spans from low drawers to
        wall cabinets.  Where the fan reaches past
        ``neck_reach_deg`` (or the chain's ``neck_yaw`` limits, if tighter), the base turns in
        place about ego z by the least angle that brings every view within reach, and the
        percepts are rotated back into the ego frame the look started from (the turn taken as
        known exactly: a turn in place measured by the wheel encoders).  The views' percepts are
        fused (:func:`perception.fuse_percepts` with :func:`perception.percept_bandwidths`), so
        the list plugs into :func:`worldgraph.active_localize` as its ``look``::

            look = functools.partial(scene.look, world_from_ego, sensor="stereo", rng=rng)
            wg.active_localize(world, fused, look, max_looks=3)

        Parameters
        ----------
        world_from_ego : (4, 4) float
            The robot pose when the look starts.
        direction : (3,) float
            Where to look, ego frame (x forward, y left, z up); any non-zero length.
        sensor, rng, image_size, chain, miss_rate, false_rate, mask_jitter_px, min_pixels, \
depth_noise, max_range, centre_offset
            As for :meth:`scan` (the detector model and the front end are the same).
        n_views : int
            Views of the look (>= 1, default :data:`LOOK_VIEWS`).
        spread_deg : float
            Neck yaw of the outer views either side of the direction (degrees, >= 0, default
            :data:`LOOK_SPREAD_DEG`).
        neck_reach_deg : float
            How far the neck yaws either side of the base (degrees, > 0, default
            :data:`NECK_REACH_DEG`, the reach of :meth:`scan`'s sweep).
        pitch_deg : (float, float)
            The pitch zigzag about the direction's pitch (degrees; negative looks up).
        min_views : int
            Fusion keeps objects seen complete in at least this many of the look's views
            (default 1: near the fan's edges an object is seen whole once, and its percept's
            covariance says how well; 2 also drops false detections that do not repeat).

        Returns
        -------
        list of Percept
            Fused over the look's views, ego frame of ``world_from_ego``; empty when nothing
            typed was recognised.

        Raises
        ------
        PerceptionError
            Naming the argument: a zero or non-finite ``direction``, ``n_views`` < 1, a negative
            ``spread_deg``, a non-positive ``neck_reach_deg``, ``spread_deg`` beyond the reach
            (no base turn brings the fan within it), and every error of :meth:`scan`.
        """
        pose = check_transform("world_from_ego", world_from_ego)
        d = real_array("direction", direction, shape=(3,))
        if not float(np.linalg.norm(d)) > 0.0:
            raise PerceptionError(f"direction must be a non-zero ego-frame vector, got {d.tolist()}")
        kind = _sensor(sensor)
        n = integer("n_views", n_views, minimum=1, maximum=1000)
        spread = math.radians(real_scalar("spread_deg", spread_deg, nonnegative=True, maximum=180.0))
        reach = math.radians(real_scalar("neck_reach_deg", neck_reach_deg, positive=True, maximum=180.0))
        gen, size, head, degrade, noise, far = self._sweep_arguments(
            rng, image_size, chain, miss_rate, false_rate, mask_jitter_px, min_pixels, depth_noise, max_range)
        for need in ("neck_yaw", "neck_pitch"):
            if need not in head.names:
                raise PerceptionError(f"look needs a joint named {need!r}; the chain has {list(head.names)}")
        pitch = _pitch_pair(pitch_deg)
        centres = self._centre_offset(centre_offset, kind, size, degrade.jitter)
        fuse_min = integer("min_views", min_views, minimum=1, maximum=n)
        yaw_index, pitch_index = head.names.index("neck_yaw"), head.names.index("neck_pitch")
        lower, upper = head.limits[yaw_index]
        lo_reach, hi_reach = max(-reach, lower), min(reach, upper)
        target = math.atan2(d[1], d[0])
        yaws = target + (np.linspace(-spread, spread, n) if n > 1 else np.zeros(1))
        if yaws[-1] - yaws[0] > hi_reach - lo_reach + ANGLE_SLACK:
            fan = math.degrees(yaws[-1] - yaws[0])
            raise PerceptionError(f"spread_deg = {spread_deg!r}: a fan of {fan:g} degrees does not fit the "
                                  f"neck's reach of "
                                  f"{math.degrees(hi_reach - lo_reach):g} degrees")
        # the least base turn that brings every view's neck yaw into [lo_reach, hi_reach]
        base = min(max(0.0, yaws[-1] - hi_reach), yaws[0] - lo_reach)
        Q = np.zeros((n, head.n_joints))
        Q[:, yaw_index] = yaws - base
        up = math.atan2(d[2], math.hypot(d[0], d[1]))
        Q[:, pitch_index] = -up + np.radians(np.where(np.arange(n) % 2 == 0, pitch[0], pitch[1]))
        turn = np.eye(4)
        turn[:3, :3] = Rotation.from_euler("z", base).as_matrix()
        seen = self._sweep(pose @ turn, Q, head, kind, gen, size, degrade, noise, far, True, centres)
        raw = [_rotated(p, turn[:3, :3]) for p in seen.percepts] if base != 0.0 else list(seen.percepts)
        if not raw:
            return []
        from .fusion import fuse_percepts, percept_bandwidths

        return list(fuse_percepts(raw, bandwidth=percept_bandwidths(raw), min_views=fuse_min))

    def _sweep(self, pose: NDArray[np.float64], Q: NDArray[np.float64], head: KinematicChain, sensor: Sensor,
               gen: np.random.Generator, size: tuple[int, int], degrade: _Degrade, noise: float, far: float,
               run_front_end: bool, centres: StereoCalibration) -> MujocoScan:
        """Render, detect and (with ``run_front_end``) perceive the views of head angles ``Q`` (one row
        per view) from the robot pose ``pose``; the arguments checked by the caller."""
        kind = sensor
        n = Q.shape[0]
        K = self.camera_matrix(size)
        t_render = t_detect = t_percepts = 0.0
        views: list[ScanView] = []
        for q in Q:
            ego_left = head.ego_from_camera(q)
            ego_right = head.ego_from_right_camera(q) if sensor == "stereo" else None
            t0 = time.perf_counter()
            left = self._render(pose @ ego_left, size, True, sensor == "rgbd", True)
            right = self._render(pose @ ego_right, size, True, False, True) if ego_right is not None else None
            depth = None
            if left.depth is not None:
                depth = _noisy_depth(left.depth, noise, far, gen)
            t1 = time.perf_counter()
            assert left.objects is not None and left.rgb is not None
            dets, truth, missed = degrade(left.objects)
            r_dets: tuple[Detection, ...] = ()
            r_truth: tuple[int, ...] = ()
            r_missed: tuple[int, ...] = ()
            if right is not None:
                assert right.objects is not None
                r_dets, r_truth, r_missed = degrade(right.objects)
            t2 = time.perf_counter()
            t_render += t1 - t0
            t_detect += t2 - t1
            views.append(ScanView(
                head_angles=np.array(q, dtype=np.float64), ego_from_camera=ego_left, K=K.copy(), rgb=left.rgb,
                segmentation=left.objects, detections=dets, truth=truth, depth=depth,
                right_rgb=None if right is None else right.rgb,
                right_segmentation=None if right is None else right.objects,
                right_detections=r_dets, right_truth=r_truth, ego_from_right_camera=ego_right,
                missed=missed, right_missed=r_missed))
        out_percepts: list[Any] = []
        out_views: list[int] = []
        out_truth: list[int] = []
        dropped: list[tuple[Any, ...]] = []
        if run_front_end:
            t0 = time.perf_counter()
            for k, view in enumerate(views):
                found, sources, lost = self._percepts(view, sensor, centres, noise)
                out_percepts.extend(found)
                out_views.extend([k] * len(found))
                out_truth.extend(view.truth[i] for i in sources)
                dropped.append(lost)
            t_percepts = time.perf_counter() - t0
        return MujocoScan(kind, tuple(views), tuple(out_percepts), tuple(out_views), tuple(out_truth),
                          tuple(dropped), ScanTimings(t_render, t_detect, t_percepts, n))

    def _centre_offset(self, centre_offset: Mapping[str, Any] | None, sensor: str, size: tuple[int, int],
                       jitter: int) -> StereoCalibration:
        """The front end's settings of a sweep: ``centre_offset`` (with the centroids, for stereo),
        else those measured for the sensor (:meth:`default_centre_offsets`,
        :meth:`default_stereo_offsets`)."""
        if centre_offset is None:
            if sensor == "stereo":
                return self.default_stereo_offsets(size, jitter)
            return StereoCalibration(self.default_centre_offsets(), {}, {})
        if not isinstance(centre_offset, Mapping):
            raise PerceptionError("centre_offset must be a mapping type -> CentreOffset or metres, or None, "
                                  f"got {_short(centre_offset)}")
        return StereoCalibration({name_string("centre_offset key", k): _offset_of(f"centre_offset[{k!r}]", v)
                                  for k, v in centre_offset.items()}, {}, {})

    def _percepts(self, view: ScanView, sensor: str, settings: StereoCalibration, depth_noise: float
                  ) -> tuple[tuple[Any, ...], tuple[int, ...], tuple[Any, ...]]:
        """The front end on one view: ``(percepts, detection index of each, dropped)``."""
        from .frontend import DEPTH_NOISE, rgbd_percepts, stereo_percepts

        if sensor == "rgbd":
            assert view.depth is not None
            out = rgbd_percepts(view.detections, view.depth, view.K, view.ego_from_camera,
                                depth_noise=depth_noise if depth_noise > 0 else DEPTH_NOISE,
                                centre_offset=settings.centre_offset)
        else:
            out = stereo_percepts(view.detections, view.right_detections, _view_rig(view),
                                  view.ego_from_camera, **settings.keywords())
        return out.percepts, out.sources, out.dropped



def _view_rig(view: ScanView) -> Any:
    """The stereo rig of a stereo view: both cameras with its ``K``, no distortion, the right one
    where ``ego_from_right_camera`` puts it (``X_right = R X_left + T``), its image size."""
    from .stereo import StereoRig

    assert view.ego_from_right_camera is not None
    right_from_left = np.linalg.inv(view.ego_from_right_camera) @ view.ego_from_camera
    h, w = view.segmentation.shape
    return StereoRig(view.K, np.zeros(0), view.K, np.zeros(0), right_from_left[:3, :3],
                     right_from_left[:3, 3], (w, h))

def _noisy_depth(z: NDArray[np.float64], c: float, max_range: float, rng: np.random.Generator
                 ) -> NDArray[np.float64]:
    """``z`` plus the blockwise-correlated error ``c z^2 e`` (``e`` of unit variance); NaN where
    ``z`` is NaN, beyond ``max_range`` or not positive after the noise."""
    h, w = z.shape
    b = DEPTH_NOISE_BLOCK
    coarse = rng.standard_normal((-(-h // b), -(-w // b)))
    e = np.repeat(np.repeat(coarse, b, axis=0), b, axis=1)[:h, :w]
    e = (e + DEPTH_NOISE_IID * rng.standard_normal((h, w))) / math.sqrt(1.0 + DEPTH_NOISE_IID ** 2)
    with np.errstate(invalid="ignore"):
        out = z + c * z * z * e
        out[~(z <= max_range) | ~(out > 0)] = np.nan
    return out


class _Degrade:
    """Detections of the typed objects in an object-index image, degraded as asked."""

    def __init__(self, types: tuple[str, ...], rng: np.random.Generator, miss: float, false: float,
                 jitter: int, min_pixels: int) -> None:
        self.types = types
        self.scene_types = sorted(set(types))
        self.rng = rng
        self.miss, self.false, self.jitter, self.min_pixels = miss, false, jitter, min_pixels

    def _jittered(self, mask: NDArray[np.bool_]) -> NDArray[np.bool_]:
        if self.jitter == 0:
            return mask
        import cv2

        k = int(self.rng.integers(-self.jitter, self.jitter + 1))
        if k == 0:
            return mask
        kernel = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))
        img = mask.astype(np.uint8)
        out = cv2.dilate(img, kernel, iterations=k) if k > 0 else cv2.erode(img, kernel, iterations=-k)
        return np.asarray(out).astype(bool)

    def _blob(self, background: NDArray[np.bool_]) -> NDArray[np.bool_] | None:
        import cv2

        v, u = np.nonzero(background)
        if len(u) == 0:
            return None
        h, w = background.shape
        i = int(self.rng.integers(len(u)))
        top = max(3.0, 0.08 * min(w, h))
        axes = (int(round(self.rng.uniform(2.0, top))), int(round(self.rng.uniform(2.0, top))))
        angle = float(self.rng.uniform(0.0, 180.0))
        canvas = np.zeros((h, w), dtype=np.uint8)
        cv2.ellipse(canvas, (int(u[i]), int(v[i])), axes, angle, 0.0, 360.0, 1, -1)
        blob = canvas.astype(bool) & background
        return blob if blob.any() else None

    def __call__(self, objects: NDArray[np.int32]) -> tuple[tuple[Detection, ...], tuple[int, ...],
                                                            tuple[int, ...]]:
        from scipy import ndimage

        rng = self.rng
        seen = np.unique(objects[objects >= 0]).tolist()
        dets: list[Detection] = []
        truth: list[int] = []
        missed: list[int] = []
        masks: dict[int, NDArray[np.bool_]] = {}
        # each object's mask is made in its bounding box grown by the jitter (a dilation stays
        # inside, an erosion sees the background around it): the whole image's result, at a
        # fraction of the cost when an image holds dozens of objects
        h, w = objects.shape
        pad = self.jitter
        boxes = ndimage.find_objects(objects + 1)
        for k in seen:
            rows, cols = boxes[k]
            r0, r1 = max(0, rows.start - pad), min(h, rows.stop + pad)
            c0, c1 = max(0, cols.start - pad), min(w, cols.stop + pad)
            crop = self._jittered(objects[r0:r1, c0:c1] == k)
            mask = np.zeros((h, w), dtype=bool)
            mask[r0:r1, c0:c1] = crop
            masks[k] = mask
            if int(crop.sum()) < self.min_pixels or (self.miss > 0 and rng.random() < self.miss):
                missed.append(k)
                continue
            dets.append(Detection(type=self.types[k], mask=mask, score=1.0))
            truth.append(k)
        n_false = int(rng.binomial(len(seen), self.false)) if self.false > 0 and seen else 0
        background = objects < 0
        for _ in range(n_false):
            k = int(seen[int(rng.integers(len(seen)))])
            others = [t for t in self.scene_types if t != self.types[k]]
            fake: NDArray[np.bool_] | None
            if others and rng.random() < 0.5:
                fake, typ = masks[k], others[int(rng.integers(len(others)))]
            else:
                fake = self._blob(background)
                typ = self.scene_types[int(rng.integers(len(self.scene_types)))]
            if fake is None or int(fake.sum()) < self.min_pixels:
                continue
            dets.append(Detection(type=typ, mask=fake, score=1.0))
            truth.append(-1)
        return tuple(dets), tuple(truth), tuple(missed)


def _sensor(value: Any) -> Sensor:
    if not isinstance(value, str) or value not in SENSORS:
        raise PerceptionError(f"sensor must be one of {SENSORS}, got {_short(value)}")
    return "rgbd" if value == "rgbd" else "stereo"


def _pitch_pair(value: Any) -> tuple[float, float]:
    arr = real_array("pitch_deg", value, shape=(2,))
    if np.any(np.abs(arr) > 90.0):
        raise PerceptionError(f"pitch_deg must lie within [-90, 90] degrees, got {arr.tolist()}")
    return float(arr[0]), float(arr[1])


def _rotated(p: Percept, R: NDArray[np.float64]) -> Percept:
    """``p`` seen from a frame turned by ``R`` (``x_old = R x_new``): position, covariance and
    shared loadings rotated; the range and its sigma are unchanged."""
    cov = None if p.covariance is None else R @ p.covariance @ R.T
    return Percept(p.type, R @ p.position, p.sigma, covariance=cov, views=p.views,
                   shared=tuple((v, R @ S) for v, S in p.shared))
