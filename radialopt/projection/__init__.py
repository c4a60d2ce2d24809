"""The normalised radial projection (paper section 4.4, docs/design.md#m4, #m5, #m6).

Given measured radii ``r`` (ranges of the percepts) that do not make every pair of spheres
meet, find the adjusted radii ``r'`` in the restriction polytope ``A r' <= b`` that lose the
least density, i.e. minimise ``|H (r' - r)|^2`` with ``H = diag(1/sigma)`` (eqs. 16-19).
All methods solve it in whitened variables ``z = H (r' - r)``::

    minimise |z|^2  subject to  (A H^-1) z <= b - A r

which is a least-distance problem.  Four methods, one entry point :func:`project_radii`:

``"active_set"`` (default, the fast path)
    Up to ``SMALL_CORE_SPHERES`` spheres: Goldfarb and Idnani's dual active-set method on
    the two-nonzero rows of the pairs, in plain Python (numpy's per-call cost dominates arrays
    this small), ending on a certified KKT point (``_ldp_pairs``).  Beyond that, or when
    that loop does not certify: Lawson and Hanson's least-distance programming, a non-negative
    least squares problem (Solving Least Squares Problems, 1974, ch. 23) solved by
    :func:`scipy.optimize.nnls` in compiled code, then polished by an exact equality-
    constrained solve on the active rows and a KKT check.  Both give the unique optimum.
``"cvxpy"``
    The reference formulation of the design card, compiled once per (sphere count, solver)
    with DPP parameters and re-used; Clarabel with tight tolerances by default, any installed
    cvxpy solver by name.
``"vertices"``
    Explicit vertex enumeration of the polyhedron and the projection solved in V-form
    (:mod:`radialopt.vertices`).
``"paper"``
    Eq. 17 restricted to the VIOLATED hyperplanes: project the measured configuration
    perpendicularly onto each hyperplane of ``Sd^n`` that it violates and keep the closest
    projection that satisfies every row (eq. 16); when none is feasible, continue to ridges
    (flats of 2, 3, ... violated hyperplanes), as the paper's words "the closest point ... on
    the cells or ridges" suggest; only when no flat of violated rows is feasible does it try
    flats of any rows.  Why violated rows only: the optimum lies on a face of violated rows
    in practice, while projecting onto a hyperplane the radii already satisfy can land on a
    feasible but far point (centres (4,3,0), (2,1,0), (2,3,2), radii (2,5,5),
    sigma 1 gave cost 25.7 against the optimum 0.0196).  A feasible single violated-
    hyperplane projection is provably optimal (its distance is a lower bound on every
    feasible point's); on a ridge the rule can lose, and then reports
    ``"optimal_inaccurate"``: the status is ``"optimal"`` only when the answer's KKT
    multipliers are >= 0, i.e. it IS the optimum.  The work is bounded by
    :data:`PAPER_MAX_FLATS` flats (D1); beyond it :class:`~radialopt.errors.RadialError`.

Every method's answer is checked against ``A r' <= b`` in metres: a violation above
``tol.feasibility * scale`` turns ``"optimal"`` into ``"optimal_inaccurate"``, one above
``tol.agreement * scale`` raises :class:`~radialopt.errors.SolverError` (``scale`` = the
largest of the centre distances, the radii and 1 m).

:func:`project_radii` takes spheres or, by keyword, arrays (``centers=, radii=, sigmas=``) and
checks its input (:func:`~radialopt.spheres.sphere_arrays`, :func:`~radialopt.spheres.checked_arrays`);
internal callers whose data were checked where they were made (worldgraph's ``localize``, the
range-only estimators) call ``project_radii_unchecked`` with arrays: the same computation
and answer without the checks.  :func:`project_radii_batch` solves many instances of the same
sphere count at once: the small-instance dual active set vectorised across the instances
(``_batch_dual_active_set``), tested against the loop of single solves
(``_project_radii_batch_reference``).

``check=True`` verifies any method's answer against the vertex enumeration (V-form optimality
certificate and the V-form optimum) and raises :class:`~radialopt.errors.VerificationError`
on disagreement; ``check="exact"`` does the same in exact rational arithmetic with pycddlib's
GMP mode (:func:`verify_solution_exact`).

The cvxpy path rescales the whitened problem for the solver (unit rows, ``z`` in units of the
largest violation), then polishes the answer exactly on the rows the solver reports active;
it reports ``"optimal"`` only when the polish ends on an exact KKT point and the solver said
``optimal``, otherwise ``"optimal_inaccurate"``.

Its modules: :mod:`radialopt.projection.project` (the entry points and the small-instance
route), :mod:`radialopt.projection.backends` (the four methods), :mod:`radialopt.projection.batch`
(:func:`project_radii_batch`) and :mod:`radialopt.projection.verify` (``check=``); the types the
methods share with :mod:`radialopt.formulation` and :mod:`radialopt.comparison` (the whitened
instance ``_Problem``, :class:`RadialSolution`, the status set) are in
``radialopt._projection_types``.  The least-distance solvers live in ``radialopt._ldp`` (the
NNLS route and its polish) and ``radialopt._dual_active_set`` (the small-instance core), the
rational arithmetic of ``check="exact"`` in ``radialopt._exact_check``; the package imports them.
"""

from __future__ import annotations

from .._dual_active_set import SMALL_CORE_SPHERES as SMALL_CORE_SPHERES
from .._ldp import CONSTRAINT_GENERATION_ROWS as CONSTRAINT_GENERATION_ROWS
from .._ldp import least_distance as least_distance
from .._projection_types import STATUSES, RadialSolution, RadialStatus
from ..tolerances import CLARABEL_TIGHT as CLARABEL_TIGHT  # re-exported: radialopt.projection.CLARABEL_TIGHT
from ..tolerances import FARKAS_LAST_ZERO as FARKAS_LAST_ZERO  # re-exported (._ldp uses them)
from ..tolerances import FARKAS_ZERO as FARKAS_ZERO
from ..tolerances import ROUNDING_RTOL as ROUNDING_RTOL
from ..tolerances import SOLVER_OPTIONS as SOLVER_OPTIONS
from .backends import (
    METHODS,
    PAPER_MAX_FLATS,
    fresh_cvxpy_problem,
    installed_cvxpy_solvers,
    solver_options,
)
from .batch import BATCH_CHUNK, BatchSolution, project_radii_batch
from .project import project_radii
from .project import project_radii_unchecked as project_radii_unchecked
from .verify import verify_solution, verify_solution_exact

__all__ = [
    "BATCH_CHUNK",
    "BatchSolution",
    "CLARABEL_TIGHT",
    "CONSTRAINT_GENERATION_ROWS",
    "FARKAS_LAST_ZERO",
    "FARKAS_ZERO",
    "METHODS",
    "PAPER_MAX_FLATS",
    "ROUNDING_RTOL",
    "RadialSolution",
    "RadialStatus",
    "SMALL_CORE_SPHERES",
    "SOLVER_OPTIONS",
    "STATUSES",
    "fresh_cvxpy_problem",
    "installed_cvxpy_solvers",
    "least_distance",
    "project_radii",
    "project_radii_batch",
    "solver_options",
    "verify_solution",
    "verify_solution_exact",
]
