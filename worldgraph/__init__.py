"""worldgraph: world model graph, association and pose."""

from importlib.metadata import PackageNotFoundError as _PackageNotFoundError
from importlib.metadata import version as _distribution_version

try:
    __version__: str = _distribution_version("gaussian-spheres")
except _PackageNotFoundError:  # run from a source tree that was never installed
    __version__ = "0.1.0"  # keep equal to pyproject.toml's [project] version (a test checks)

from . import figures, scenes, tiles
from .active import ActiveLocalization, ViewPlan, active_localize, plan_view
from .association import associate
from .association.filters import discriminator, orientation_filter, proximity_filter
from .association.hypotheses import AssociationHypothesis
from .errors import (
    ImporterError,
    MalformedFileError,
    PoseError,
    TooFewPerceptsError,
    WorldGraphError,
)
from .importers.franka import franka_kitchen_path, load_franka_kitchen
from .localization import LOCALIZE_METHODS, LOCALIZE_STATUSES, LocalizationResult, LocalizeSettings, localize
from .model import LinkTable, ObjectModel, ObjectTable, WorldModel, box_vertices
from .pose.frames import percept_frame, pose_from_frames, weighted_kabsch
from .tiles import Tile, TilePool, localize_tiled
from .tolerances import ASSOCIATION_TOLERANCES, AssociationTolerances

__all__ = [
    "ActiveLocalization",
    "ImporterError",
    "LinkTable",
    "MalformedFileError",
    "PoseError",
    "ObjectModel",
    "ObjectTable",
    "TooFewPerceptsError",
    "WorldGraphError",
    "ViewPlan",
    "WorldModel",
    "active_localize",
    "box_vertices",
    "franka_kitchen_path",
    "load_franka_kitchen",
    "figures",
    "scenes",
    "tiles",
]

__all__ += [
    "ASSOCIATION_TOLERANCES",
    "AssociationHypothesis",
    "AssociationTolerances",
    "LOCALIZE_METHODS",
    "LOCALIZE_STATUSES",
    "LocalizationResult",
    "LocalizeSettings",
    "associate",
    "discriminator",
    "localize",
    "orientation_filter",
    "percept_frame",
    "plan_view",
    "pose_from_frames",
    "proximity_filter",
    "weighted_kabsch",
    "Tile",
    "localize_tiled",
    "TilePool",
]


def __getattr__(name: str) -> type[WorldGraphError]:
    """0.1's error class names, deprecated: each warns and gives the class that replaced it
    (``worldgraph.errors.DEPRECATED_NAMES``)."""
    from . import errors

    return errors._deprecated(__name__, name)
