"""What a MuJoCo scan returns and the simulated camera's constants: objects, views, timings,
scans and the stereo front end's measured settings."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from .._checks import (
    image_size,
)
from ..frontend.detection import Detection
from ..frontend.detection_percepts import DEPTH_CORRELATION_PX, DEPTH_NOISE, CentreOffset
from ..frontend.outline import DisparityError

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
#: two off moves the extent of a door seen at 2-3 m by 0.5-1 cm; docs/design.md#defaults).
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


def _image_size(value: Any) -> tuple[int, int]:
    return image_size(value, MAX_RENDER_SIDE)
