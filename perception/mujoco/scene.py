"""A MuJoCo scene of typed objects: its objects and free floor, robot poses on it, and its
renders (:class:`MujocoScene`; scans and calibration in the sibling modules)."""

from __future__ import annotations

import copy
import math
import os
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from .._checks import (
    boolean,
    check_transform,
    file_path,
    integer,
    name_string,
    real_array,
    real_scalar,
)
from .._checks import generator as check_rng
from ..errors import (
    PerceptionError,
    RobotFileError,
)
from ..frontend.detection_percepts import CentreOffset
from ..type_rules import type_rule
from . import calibration, scanning
from .geometry import _pose, body_meshes, geom_mesh, import_mujoco, object_geoms
from .records import _FAR_FRACTION, RenderedView, SceneObject, StereoCalibration, _image_size


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
        spread = np.radians(real_scalar("yaw_spread_deg", yaw_spread_deg, minimum=0.0, maximum=180.0))
        heights = real_array("head_height", head_height, (2,))
        if not 0 < heights[0] <= heights[1] <= 100.0:
            raise PerceptionError(f"head_height must be (low, high) with 0 < low <= high <= 100 m, got "
                                  f"{heights.tolist()}")
        floor, lo, hi = self._floor()
        boxes = self._obstacle_boxes()
        pos = self.positions
        out = np.tile(np.eye(4), (n, 1, 1))
        yaws = np.zeros(n)
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
            yaws[k] = np.arctan2(target[1] - xy[1], target[0] - xy[0]) + gen.uniform(-spread, spread)
            out[k, :3, 3] = (xy[0], xy[1], head)
            k += 1
        out[:, :3, :3] = Rotation.from_euler("z", yaws[:, None]).as_matrix()
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

    # measuring the front ends on the scene's own renders (perception.mujoco.calibration)
    default_centre_offsets = calibration.default_centre_offsets
    centre_offsets = calibration.centre_offsets
    default_stereo_offsets = calibration.default_stereo_offsets
    stereo_offsets = calibration.stereo_offsets
    _calibration_poses = calibration._calibration_poses

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

    # scans and looks (perception.mujoco.scanning)
    scan = scanning.scan
    _sweep_arguments = scanning._sweep_arguments
    look = scanning.look
    _sweep = scanning._sweep
    _centre_offset = scanning._centre_offset
    _percepts = scanning._percepts
