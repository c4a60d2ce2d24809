"""Global self-localisation, the pipeline: association -> validation -> 6D pose with its covariance.

* :mod:`worldgraph.localization.pipeline`: :func:`localize` (the steps in order: the arguments, the
  percepts of known types, association, the measurements), ``searched`` (the gravity
  search's fall-back and the tilt check, for every entry point) and
  :func:`default_region`; its docstring describes the whole pipeline.
* :mod:`worldgraph.localization.settings`: :class:`LocalizeSettings`, the settings of one
  localisation checked once (the keywords of :func:`localize`), and the methods and bounds
  they default to.
* :mod:`worldgraph.localization.result`: :class:`LocalizationResult` and the status literals and
  tuples (:data:`LOCALIZE_STATUSES`, ...).
* :mod:`worldgraph.localization.context`: the state one call's steps share.
* :mod:`worldgraph.localization.validate`: the validated pose (ML fits, the range test, the choice
  among the fits, the pose of the method).
* :mod:`worldgraph.localization.radial`: :func:`match_spheres`, the radial projection of the matched
  Gaussian spheres and the range-only position.
* :mod:`worldgraph.localization.finish`: the answer checks itself and becomes the result.
* :mod:`worldgraph.localization.paper`: the paper's pipeline (``method="paper"``, eq. 5).

:func:`worldgraph.localize` is the pipeline's function (``localize`` here, re-exported by the
package); to patch a function the pipeline calls, patch it in the module that holds it.
"""

from .pipeline import MIN_ROOM_SIZE as MIN_ROOM_SIZE
from .pipeline import (
    REGION_MARGIN,
    default_region,
    localize,
)
from .radial import CANDIDATE_DENSITY_RATIO as CANDIDATE_DENSITY_RATIO
from .radial import MAX_CVXPY_SPHERES as MAX_CVXPY_SPHERES
from .radial import MAX_RADIAL_SPHERES as MAX_RADIAL_SPHERES
from .radial import match_spheres
from .result import (
    LOCALIZE_STATUSES,
    POSE_STATUSES,
    UNIQUE_STATUSES,
    FailureStatus,
    LocalizationResult,
    LocalizeStatus,
    PoseStatus,
    UniqueStatus,
)
from .settings import LOCALIZE_METHODS, MAX_POSITION_3SIGMA, MAX_ROTATION_3SIGMA, LocalizeSettings
from .validate import ASSOCIATION_CANDIDATES as ASSOCIATION_CANDIDATES
from .validate import MAX_VALIDATED as MAX_VALIDATED

__all__ = [
    "LOCALIZE_METHODS",
    "LOCALIZE_STATUSES",
    "MAX_POSITION_3SIGMA",
    "MAX_ROTATION_3SIGMA",
    "REGION_MARGIN",
    "LocalizationResult",
    "LocalizeSettings",
    "FailureStatus",
    "LocalizeStatus",
    "POSE_STATUSES",
    "PoseStatus",
    "UNIQUE_STATUSES",
    "UniqueStatus",
    "default_region",
    "localize",
    "match_spheres",
]
