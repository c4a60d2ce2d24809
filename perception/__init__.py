"""perception: stereo camera, uncertainty model, ego chain, fusion and recognition."""

from .errors import (
    BehindCameraError,
    NonFiniteError,
    NonPositiveSigmaError,
    PerceptionError,
    ShapeError,
    UnknownClassError,
)
from .percept import Percept

__all__ = [
    "BehindCameraError",
    "NonFiniteError",
    "NonPositiveSigmaError",
    "Percept",
    "PerceptionError",
    "ShapeError",
    "UnknownClassError",
]
