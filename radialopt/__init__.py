"""radialopt: Gaussian spheres, the restriction polytope in radial space, and position estimation."""

from .errors import (
    CoincidentCentersError,
    NegativeRadiusError,
    NonFiniteError,
    NonPositiveSigmaError,
    RadialError,
    ShapeError,
    SolverError,
    TooFewSpheresError,
    UnknownMethodError,
    VerificationError,
)
from .polytope import RestrictionPolytope, common_point_exists
from .projection import METHODS, STATUSES, RadialSolution, installed_cvxpy_solvers, project_radii
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
    "TOLERANCES",
    "RadialSolution",
    "RestrictionPolytope",
    "common_point_exists",
    "installed_cvxpy_solvers",
    "project_radii",
    "CoincidentCentersError",
    "GaussianSphere",
    "NegativeRadiusError",
    "NonFiniteError",
    "NonPositiveSigmaError",
    "RadialError",
    "ShapeError",
    "SolverError",
    "Tolerances",
    "TooFewSpheresError",
    "UnknownMethodError",
    "VerificationError",
    "conformal_inner",
    "conformal_sphere",
    "density",
    "make_spheres",
    "radial_density",
    "total_density",
]
