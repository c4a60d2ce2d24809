"""radialopt: Gaussian spheres, the restriction polytope in radial space, and position estimation."""

from importlib.metadata import PackageNotFoundError as _PackageNotFoundError
from importlib.metadata import version as _distribution_version

try:
    __version__: str = _distribution_version("gaussian-spheres")
except _PackageNotFoundError:  # run from a source tree that was never installed
    __version__ = "0.1.0"  # keep equal to pyproject.toml's [project] version (a test checks)

from .errors import RadialArgumentError, RadialError, SolverError, VerificationError
from .polytope import RestrictionPolytope, common_point_exists
from .projection import (
    METHODS,
    STATUSES,
    BatchSolution,
    RadialSolution,
    RadialStatus,
    installed_cvxpy_solvers,
    project_radii,
    project_radii_batch,
)
from .spheres import (
    TOLERANCES,
    GaussianSphere,
    Tolerances,
    conformal_inner,
    conformal_sphere,
    density,
    make_spheres,
    radial_density,
    total_density,
)

__all__ = [
    "METHODS",
    "STATUSES",
    "RadialStatus",
    "TOLERANCES",
    "BatchSolution",
    "RadialSolution",
    "RestrictionPolytope",
    "common_point_exists",
    "installed_cvxpy_solvers",
    "project_radii",
    "project_radii_batch",
    "GaussianSphere",
    "RadialArgumentError",
    "RadialError",
    "SolverError",
    "Tolerances",
    "VerificationError",
    "conformal_inner",
    "conformal_sphere",
    "density",
    "make_spheres",
    "radial_density",
    "total_density",
]

# --- geometry and position estimation (conformal meet, hypotheses, estimators) ---
from .conformal import (
    MEET_TOLERANCES,
    Circle,
    MeetStatus,
    MeetTolerances,
    Point,
    PointPair,
    meet,
    meet2_batch,
    meet3_batch,
    meet4_batch,
)
from .errors import SingularFisherError
from .hypotheses import Hypothesis, LevelSets, Region, generate_hypotheses
from .position import (
    ESTIMATOR_OPTIONS,
    POSITION_METHODS,
    POSITION_STATUSES,
    POSITION_SUCCESS,
    EstimatorOptions,
    PositionEstimate,
    PositionStatus,
    crlb,
    estimate_position,
    fisher_information,
    srls,
)

__all__ += [
    "MEET_TOLERANCES",
    "Circle",
    "MeetStatus",
    "MeetTolerances",
    "Point",
    "PointPair",
    "meet",
    "meet2_batch",
    "meet3_batch",
    "meet4_batch",
    "SingularFisherError",
    "Hypothesis",
    "LevelSets",
    "Region",
    "generate_hypotheses",
    "ESTIMATOR_OPTIONS",
    "POSITION_METHODS",
    "POSITION_STATUSES",
    "POSITION_SUCCESS",
    "PositionStatus",
    "EstimatorOptions",
    "PositionEstimate",
    "crlb",
    "estimate_position",
    "fisher_information",
    "srls",
]

# --- vertex enumeration (the independent check of the projection) ---
from .vertices import (  # noqa: E402
    MAX_VERTEX_SPHERES,
    VertexEnumeration,
    certify_projection,
    enumerate_vertices,
    project_vform,
)

__all__ += ["MAX_VERTEX_SPHERES", "VertexEnumeration", "certify_projection", "enumerate_vertices",
            "project_vform"]

# --- certificates of global optimality of the ML position ---
from .certificates import CERTIFICATE_METHODS, Certificate, certify_position  # noqa: E402

__all__ += ["CERTIFICATE_METHODS", "Certificate", "certify_position"]

# --- the reusable cvxpy formulation (l2 / l1 / Huber, added constraints) ---
from .formulation import OBJECTIVES, RadialProblem  # noqa: E402

__all__ += ["OBJECTIVES", "RadialProblem"]


def __getattr__(name: str) -> type[RadialError]:
    """0.1's error class names, deprecated: each warns and gives the class that replaced it
    (``radialopt.errors.DEPRECATED_NAMES``)."""
    from . import errors

    return errors._deprecated(__name__, name)
