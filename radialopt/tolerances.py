"""Every numerical tolerance of :mod:`radialopt`, in one module (docs/design.md#tolerances).

The user-tunable sets are frozen dataclasses passed as ``tol=``: :class:`Tolerances` (the
radial projection and the restriction polytope), :class:`VertexTolerances` (vertex
enumeration) and :class:`MeetTolerances` (the conformal meet), with their default instances.
The module constants below are the fixed internal thresholds (rounding margins, rank and
convergence tests); each says what it guards.  Changing one changes results: they are named
here so that they are found, not so that they are tuned.
"""

from __future__ import annotations

from dataclasses import dataclass

from ._checks import dataclass_fields

__all__ = [
    "CLARABEL_TIGHT",
    "MEET_TOLERANCES",
    "SOLVER_OPTIONS",
    "TOLERANCES",
    "VERTEX_TOLERANCES",
    "MeetTolerances",
    "Tolerances",
    "VertexTolerances",
]


@dataclass(frozen=True)
class Tolerances:
    """Numerical tolerances of radialopt, in one place (metres unless said otherwise).

    Attributes
    ----------
    coincident : float
        Two centres closer than this are the same point.
    feasibility : float
        Slack allowed in ``A r <= b`` when testing membership.
    agreement : float
        Largest difference between an answer and the vertex-enumeration reference that
        ``check=True`` accepts.
    """

    coincident: float = 1e-9
    feasibility: float = 1e-9
    agreement: float = 1e-6

    def __post_init__(self) -> None:
        dataclass_fields(self, {}, {"coincident": (0.0, 1.0, True), "feasibility": (0.0, 1.0, False),
                                    "agreement": (0.0, 1.0, True)})


TOLERANCES = Tolerances()


@dataclass(frozen=True)
class VertexTolerances:
    """Tolerances of vertex enumeration, relative to the scale ``max(1, max |b_i| / |A_i|)``.

    Attributes
    ----------
    feasibility : float
        A point with ``A_i x <= b_i + feasibility * scale`` (unit rows) is feasible.
    active : float
        Row i is tight at x when ``|b_i - A_i x| <= active * scale`` (unit rows).
    zero : float
        Double description: ``|h . r| <= zero`` (unit h, unit r) counts as zero.
    singular : float
        Brute force: an n-subset of unit rows with ``|det| <= singular`` is singular.
    merge : float
        Vertices closer than ``merge * scale`` are one vertex.
    """

    feasibility: float = 1e-9
    active: float = 1e-9
    zero: float = 1e-10
    singular: float = 1e-10
    merge: float = 1e-10

    def __post_init__(self) -> None:
        dataclass_fields(self, {}, {k: (0.0, 1.0, False) for k in
                                    ("feasibility", "active", "zero", "singular", "merge")})


VERTEX_TOLERANCES = VertexTolerances()


@dataclass(frozen=True)
class MeetTolerances:
    """Tolerances of the meet, relative to the size ``L`` of the configuration.

    ``L`` is the largest of the distances of the centres from their centroid and of the
    absolute radii.

    Attributes
    ----------
    tangent : float
        A squared radius (circle, half point-pair distance) or a residual with absolute
        value ``<= tangent * L**2`` counts as zero: tangent (or, for four spheres, real).
    coincident : float
        Two centres closer than ``coincident * L`` coincide.
    collinear : float
        Three centres are collinear when the sine of the angle at the first one is below
        this (``|a x b| <= collinear |a| |b|``); also the singular-value ratio below which
        four centres are collinear.
    coplanar : float
        Four centres are coplanar when the smallest singular value of the centred centres is
        below ``coplanar`` times the largest.
    """

    tangent: float = 1e-10
    coincident: float = 1e-12
    collinear: float = 1e-9
    coplanar: float = 1e-9

    def __post_init__(self) -> None:
        dataclass_fields(self, {}, {k: (0.0, 1.0, False) for k in
                                    ("tangent", "coincident", "collinear", "coplanar")})


MEET_TOLERANCES = MeetTolerances()


# --- solver settings ---------------------------------------------------------------------

#: Clarabel settings that make the QP agree with the exact answer (docs/design.md#solver-tolerances).
CLARABEL_TIGHT = {
    "tol_gap_abs": 1e-10,
    "tol_gap_rel": 1e-10,
    "tol_feas": 1e-10,
    "tol_ktratio": 1e-8,
}

#: One table of per-solver options: tight tolerances, so that every solver is compared at the
#: accuracy the exact methods reach (a solver not listed runs with its defaults).
SOLVER_OPTIONS: dict[str, dict] = {
    "CLARABEL": CLARABEL_TIGHT,
    "OSQP": {"eps_abs": 1e-10, "eps_rel": 1e-10, "max_iter": 200_000, "polishing": True},
    "SCS": {"eps_abs": 1e-9, "eps_rel": 1e-9, "max_iters": 200_000},
    "ECOS": {"abstol": 1e-10, "reltol": 1e-10, "feastol": 1e-10},
}


# --- fixed internal thresholds ---------------------------------------------------------------
# Relative ones multiply the scale named in their comment; none of them is a physical size.

#: Floor of a denominator, norm or scale that may be exactly zero (keeps a quotient finite).
TINY = 1e-300
#: Default ``tol`` of the exact common-point test, relative to the squared configuration scale.
COMMON_POINT_TOL = 1e-9
#: Default slack (metres) of :meth:`~radialopt.hypotheses.Region.contains`.
REGION_SLACK = 1e-9
#: Centres whose triangle area (volume) is below this times scale^2 (scale^3) are degenerate.
DEGENERATE_CENTRES = 1e-12
#: Singular values (eigenvalues, Gram determinants of unit rows) below this times the largest
#: count as zero when a rank or a solvable system is decided.
RANK_RTOL = 1e-12
#: Rounding of a float64 computation relative to its magnitude: a residual, cost increase or
#: constraint value within this is zero.
ROUNDING_RTOL = 1e-12
#: Rounding of the radii (times the largest radius) added to the stated feasibility bound.
RADIUS_ROUNDING = 1e-15
#: Lower-bound certificates: relative rounding margin subtracted from every computed bound.
CERTIFICATE_ROUNDING = 1e-11
#: Lower-bound certificates: rounding subtracted from the Hessian's smallest eigenvalue, times
#: the sum of the Hessian's absolute entries.
HESSIAN_ROUNDING = 1e-12
#: Default relative and absolute optimality gaps of the lower-bound certificates.
CERTIFICATE_GAP = 1e-6
#: Solver comparison: largest constraint violation of an answer counted as a success.
COMPARISON_VIOLATION = 1e-6
#: A conformal vector whose e0 coefficient is below this times its largest one is a plane.
E0_RELATIVE = 1e-14
#: Projection: a row whose slack is below this (times the problem scale) is active.
ACTIVE_SLACK = 1e-7
#: Projection (cvxpy): a row with slack below this is in the support of the polished answer.
SUPPORT_SLACK = 1e-9
#: Projection (cvxpy): a row whose dual exceeds this times the largest dual is in the support.
SUPPORT_DUAL_RTOL = 1e-7
#: Projection (cvxpy): floor of the largest dual when duals decide the support.
DUAL_FLOOR = 1e-12
#: Projection (paper): KKT multipliers above this times the largest one are not of the right sign.
KKT_RTOL = 1e-9
#: Projection: the last entry of an NNLS (Farkas) residual at most this is zero: infeasible.
FARKAS_LAST_ZERO = 1e-14
#: Projection: an NNLS (Farkas) residual norm at most this is zero: infeasible.
FARKAS_ZERO = 1e-12
#: Vertex enumeration: a unit vector with a residual above this is independent of a basis.
INDEPENDENT_RTOL = 1e-8
#: Default convergence tolerance of the V-form projection (:func:`~radialopt.vertices.project_vform`).
VFORM_TOL = 1e-14
#: Default tolerance of the generator-based optimality check
#: (:func:`~radialopt.vertices.certify_projection`).
VERTEX_CERTIFICATE_TOL = 1e-6
#: Position: a point closer to a centre than this times the centres' spread sits on it.
ON_CENTRE_RTOL = 1e-12
#: Position: Fisher information with smallest/largest eigenvalue below this is singular.
FISHER_SINGULAR = 1e-13
#: Position (LM): the Hessian is used when its smallest eigenvalue exceeds this times its scale.
CONVEXITY_RTOL = 1e-9
#: Position (LM): starting damping (times the Gauss-Newton scale).
LM_DAMPING_START = 1e-6
#: Position (LM): the floor the damping never shrinks below.
LM_DAMPING_MIN = 1e-12
#: Position (SR-LS): the root bracket starts this fraction of its width inside the pole.
POLE_OFFSET = 1e-12
#: Position (SR-LS): the root's absolute tolerance, times ``max(1, |upper bracket|)``.
ROOT_XTOL = 1e-15
#: Position: mirror triples whose normal is shorter than this times spread^2 are collinear.
COLLINEAR_RTOL = 1e-9
#: Position: ``xtol``, ``ftol`` and ``gtol`` of the trust-region polish (run to convergence).
POLISH_TOL = 1e-15
