"""worldgraph: world model graph, association and pose."""

from . import scenes
from .errors import (
    CoincidentObjectsError,
    EmptyWorldError,
    ImporterError,
    MalformedFileError,
    NonFiniteError,
    NonPositiveError,
    ShapeError,
    TooFewPerceptsError,
    UnknownGeometryError,
    UnknownTypeError,
    WorldGraphError,
)
from .franka import franka_kitchen_path, load_franka_kitchen
from .model import LinkTable, ObjectModel, WorldModel, box_vertices

__all__ = [
    "CoincidentObjectsError",
    "EmptyWorldError",
    "ImporterError",
    "LinkTable",
    "MalformedFileError",
    "NonFiniteError",
    "NonPositiveError",
    "ObjectModel",
    "ShapeError",
    "TooFewPerceptsError",
    "UnknownGeometryError",
    "UnknownTypeError",
    "WorldGraphError",
    "WorldModel",
    "box_vertices",
    "franka_kitchen_path",
    "load_franka_kitchen",
    "scenes",
]

# association, pose and localize: exported by the lead
