"""perception: stereo camera, uncertainty model, ego chain, fusion and recognition."""

from importlib.metadata import PackageNotFoundError as _PackageNotFoundError
from importlib.metadata import version as _distribution_version

try:
    __version__: str = _distribution_version("gaussian-spheres")
except _PackageNotFoundError:  # run from a source tree that was never installed
    __version__ = "0.1.0"  # keep equal to pyproject.toml's [project] version (a test checks)

from .errors import (
    BehindCameraError,
    MissingExtraError,
    PerceptionError,
    RobotFileError,
    TooManyNeighboursError,
)
from .frontend.detection import Detection
from .frontend.detection_percepts import CentreOffset, DetectionPercepts, Dropped
from .frontend.fusion import (
    FusionDrop,
    FusionReport,
    fuse_percepts,
    fuse_percepts_report,
    mean_shift_modes,
    percept_bandwidths,
)
from .frontend.outline import (
    DISPARITY_ENDS_FRACTION,
    DISPARITY_SD_PX,
    DisparityError,
    OutlineDisparity,
    fit_disparity_errors,
    outline_disparity,
)
from .frontend.percept import OBJECT_VIEW, Percept
from .frontend.rgbd import rgbd_percepts
from .frontend.stereo_pairs import StereoMatch, match_stereo, stereo_percepts
from .head.chain import (
    Joint,
    KinematicChain,
    check_transform,
    default_head,
    percept_covariance,
)
from .head.stereo import Rectification, StereoRig
from .head.uncertainty import (
    class_bandwidth,
    depth_sigma,
    disparity,
    perception_depth,
    pixel_footprint,
    triangulation_covariance,
)
from .recognition.classifier import GaussianClassifier
from .recognition.pipeline import detect, recognize, train_classifier
from .simulation.render import Box, random_scene, render_stereo, scene_boxes
from .simulation.simulate import simulate_percepts, simulate_scan

__all__ = [
    "BehindCameraError",
    "Box",
    "CentreOffset",
    "DISPARITY_ENDS_FRACTION",
    "DISPARITY_SD_PX",
    "Detection",
    "DetectionPercepts",
    "DisparityError",
    "Dropped",
    "FusionDrop",
    "FusionReport",
    "GaussianClassifier",
    "Joint",
    "KinematicChain",
    "MissingExtraError",
    "OBJECT_VIEW",
    "OutlineDisparity",
    "Percept",
    "PerceptionError",
    "Rectification",
    "RobotFileError",
    "StereoMatch",
    "StereoRig",
    "TooManyNeighboursError",
    "check_transform",
    "class_bandwidth",
    "default_head",
    "detect",
    "depth_sigma",
    "disparity",
    "fit_disparity_errors",
    "fuse_percepts",
    "fuse_percepts_report",
    "match_stereo",
    "mean_shift_modes",
    "outline_disparity",
    "percept_bandwidths",
    "percept_covariance",
    "perception_depth",
    "pixel_footprint",
    "random_scene",
    "recognize",
    "render_stereo",
    "rgbd_percepts",
    "scene_boxes",
    "simulate_percepts",
    "simulate_scan",
    "stereo_percepts",
    "train_classifier",
    "triangulation_covariance",
]


def __getattr__(name: str) -> type[PerceptionError]:
    """0.1's error class names, deprecated: each warns and gives the class that replaced it
    (``perception.errors.DEPRECATED_NAMES``)."""
    from . import errors

    return errors._deprecated(__name__, name)
