"""perception: stereo camera, uncertainty model, ego chain, fusion and recognition."""

from .chain import (
    Joint,
    KinematicChain,
    check_transform,
    default_head,
    percept_covariance,
)
from .errors import (
    BehindCameraError,
    CalibrationError,
    CalibrationFileError,
    KinematicsError,
    NonFiniteError,
    NonPositiveSigmaError,
    PerceptionError,
    ShapeError,
    UnknownClassError,
)
from .fusion import fuse_percepts, mean_shift_modes
from .percept import Percept
from .simulate import simulate_percepts, simulate_scan
from .stereo import Rectification, StereoRig
from .uncertainty import (
    class_bandwidth,
    depth_sigma,
    disparity,
    perception_depth,
    pixel_footprint,
    triangulation_covariance,
)

__all__ = [
    "BehindCameraError",
    "CalibrationError",
    "CalibrationFileError",
    "Joint",
    "KinematicChain",
    "KinematicsError",
    "NonFiniteError",
    "NonPositiveSigmaError",
    "Percept",
    "PerceptionError",
    "Rectification",
    "ShapeError",
    "StereoRig",
    "UnknownClassError",
    "check_transform",
    "class_bandwidth",
    "default_head",
    "depth_sigma",
    "disparity",
    "fuse_percepts",
    "mean_shift_modes",
    "percept_covariance",
    "perception_depth",
    "pixel_footprint",
    "simulate_percepts",
    "simulate_scan",
    "triangulation_covariance",
]
