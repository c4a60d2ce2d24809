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

from .geometry import VISIBLE_GROUPS, body_meshes, geom_mesh, import_mujoco, object_geoms, visual_geoms
from .records import (
    CALIBRATION_POSES,
    CALIBRATION_SEED,
    CENTRE_LATERAL_FLOOR,
    DEFAULT_DEPTH_NOISE,
    DEFAULT_MAX_RANGE,
    DEPTH_NOISE_BLOCK,
    DEPTH_NOISE_IID,
    MAX_RENDER_SIDE,
    SENSORS,
    MujocoScan,
    RenderedView,
    ScanTimings,
    ScanView,
    SceneObject,
    StereoCalibration,
)
from .scanning import LOOK_SPREAD_DEG, LOOK_VIEWS, NECK_REACH_DEG
from .scene import MujocoScene

__all__ = [
    "CALIBRATION_POSES",
    "CALIBRATION_SEED",
    "CENTRE_LATERAL_FLOOR",
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
