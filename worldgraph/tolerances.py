"""Every numerical tolerance of :mod:`worldgraph`, in one module (docs/design.md#tolerances).

:class:`AssociationTolerances` (docs/design.md#association) holds the user-tunable gates and
budgets of the association; public functions take it as ``tol=`` (default
:data:`ASSOCIATION_TOLERANCES`).  The module constants below are fixed internal thresholds
(rounding margins, rank, symmetry and convergence tests, solver settings); each says what it
guards.  They are named here so that they are found, not so that they are tuned.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from ._checks import _short, integer, real_array, real_scalar
from .errors import (
    WorldGraphError,
)


class _GravityNoted(Protocol):
    """A world's own gravity note (:attr:`worldgraph.WorldModel.gravity_aligned`): what the
    tolerances read of a world (a protocol: the model imports this module)."""

    @property
    def gravity_aligned(self) -> bool: ...


# --- fixed internal thresholds ---------------------------------------------------------------
# Relative ones multiply the scale named in their comment; none of them is a physical size.

#: Floor of a denominator, norm or scale that may be exactly zero (keeps a quotient finite).
TINY = 1e-300
#: World model: two objects of one type closer than this (m) coincide (an error).
COINCIDENT_TOLERANCE = 1e-9
#: An up vector (``gravity=``) shorter than this (m, any unit) has no direction.
MIN_UP_NORM = 1e-9
#: An up vector whose horizontal part is below this (relative) is the z axis: no levelling.
LEVEL_TOLERANCE = 1e-12
#: With gravity known (``localize(gravity="auto")`` or an up vector), an answer whose pose tilts
#: the ego up vector more than this (rad) from world up is no success ("inconsistent", the message
#: naming the likely frame mistake): a level wheeled or humanoid robot never tilts 45 degrees,
#: while percepts in a camera frame (OpenCV: z ahead, y down) instead of the ego frame give a pose
#: tilted 90.  Below it, ``"auto"`` answers tilts beyond ``tilt_allowance`` by the free search (a
#: robot on a ramp); an explicit up vector (or ``gravity_aligned=True``) allows only
#: ``tilt_allowance`` plus :data:`~worldgraph.pose.gravity.TILT_SLACK`.  ``gravity=None`` (no
#: knowledge of gravity) answers any tilt.
MAX_EGO_TILT = math.radians(45.0)
#: Far-pair index: window slack (m) of the float32 keys, well above float32 rounding at 16 m (1e-6 m).
FAR_PAIR_SLACK = 1e-4
#: k-d tree queries are widened by this relative amount (and ``QUERY_FLOOR``), so that the exact
#: float64 test after them decides every pair near the edge.
QUERY_WIDEN = 1e-9
#: Absolute widening (m) of those queries, for radii near zero.
QUERY_FLOOR = 1e-12
#: Scenes: a module fits a free width when it is at most this much (m) wider (float sums).
FIT_SLACK = 1e-9
#: Largest allowed ``|R^T R - I|`` entry and ``|det R - 1|`` of a rigid transform's rotation.
RIGID_TOLERANCE = 1e-6
#: Three points whose triangle area is below this fraction of the squared longest side are
#: collinear (:func:`~worldgraph.pose.percept_frame`, the orientation filter's triples).
COLLINEAR_TOL = 1e-9
#: A percept constrains the eigen-directions of its covariance whose variance is at most this
#: times its smallest variance (a standard deviation at most 1000 times its best one).  Along the
#: others it carries less than a millionth of its best information and agrees with almost any
#: pose: a needle (variances 1e-8, 1e-6 and 1e4 m^2) constrains two directions, a pancake one,
#: an isotropic or stereo-shaped percept three.  Shape only: how large the variances are is the
#: pose covariance's business (``"weak"``).
CONSTRAINED_VARIANCE_RATIO = 1e6
#: An answer's inliers must constrain at least this many directions in all
#: (:data:`CONSTRAINED_VARIANCE_RATIO`): three isotropic percepts' worth, 6 to fix the 6D pose
#: and 3 more to check it.  Three needles (6 directions) fix a pose but leave nothing to check.
MIN_INLIER_DIRECTIONS = 9
#: Pose hypotheses: three matched points whose second singular value is below this times the
#: first are (nearly) collinear and fix no rotation.
PLANAR_RTOL = 1e-6
#: A matrix that should be symmetric (a covariance, a pose weight) is rejected when
#: ``|C - C^T|`` exceeds this times its largest entry.
SYMMETRY_RTOL = 1e-9
#: The same test for an information matrix or covariance built by validation (looser: sums).
INFORMATION_SYMMETRY_RTOL = 1e-8
#: A covariance whose smallest eigenvalue is below ``-PSD_RTOL`` times its scale is not PSD.
PSD_RTOL = 1e-9
#: A symmetric matrix whose smallest/largest eigenvalue is at most this is singular.
RANK_RTOL = 1e-12
#: A unit vector whose norm before normalising is below this has no direction.
NORM_FLOOR = 1e-12
#: Rotations by less than this (rad) are the identity (small-angle branch).
SMALL_ANGLE = 1e-12
#: Rounding of a float64 cost relative to its size: a decrease below this is none.
COST_ROUNDING = 1e-12
#: Objects closer than this (m) are at the same place (duplicate positions).
DUPLICATE_DISTANCE = 1e-9
#: Slack (m) of the region test, added to the pose's own 3-sigma slack.
REGION_SLACK = 1e-6
#: Chi-square self-checks: false-alarm probability (significance level) of the gates.
SIGNIFICANCE = 1e-3
#: Tiles: relative slack of the k-d tree's distance bound (the exact test follows).
HALO_SLACK = 1e-12
#: Plots: poses closer than this (m) are drawn once.
SAME_POSITION = 1e-3
#: Importers: a length that equals a reference value to this (m) matches it.
SIZE_MATCH = 1e-9
#: Importers: a plane whose z-axis has a z component above ``1 - UPRIGHT_TOL`` is horizontal.
UPRIGHT_TOL = 1e-9
#: View planning: joint angles stay this far (rad) inside finite joint limits.
JOINT_LIMIT_MARGIN = 1e-9
#: View planning: ``xtol``, ``ftol`` and ``gtol`` of the aiming least squares.
AIM_LSQ_TOL = 1e-10
#: View planning: weight of the joint-angle regulariser in the aiming residual.
AIM_REGULARISATION = 1e-3
#: View planning: rounding allowed in the cosine test of "inside the field of view".
COSINE_ROUNDING = 1e-12
#: Validation: floor of the rise (times the target) in the secant on the curvature factor.
RISE_FLOOR = 1e-3
#: Pose refinement (LM): a Hessian is positive definite when its smallest eigenvalue exceeds
#: this times its scale; otherwise it is shifted by :data:`LM_SHIFT` times the scale.
PD_RTOL = 1e-12
#: Active looks: the smallest pose variance (m^2, rad^2) the planner takes from a result's
#: covariance (a pose known exactly to the planner would overflow its information).
POSE_VARIANCE_FLOOR = 1e-24
#: Pose refinement (LM): the smallest diagonal shift, times the Hessian's scale.
LM_SHIFT = 1e-6
#: Pose refinement: converged when the cost falls by less than this relative amount.
COST_DECREASE_RTOL = 1e-14
#: Pose refinement: converged when the step is shorter than this (rad or m).
STEP_TOL = 1e-10
#: Default ``tol`` of :func:`~worldgraph.pose.refine_pose` (relative cost decrease).
REFINE_TOL = 1e-12
#: Pose: covariances equal to a multiple of the identity to this relative accuracy are isotropic.
ISOTROPIC_RTOL = 1e-9
#: Pose: rotations whose entries agree to this are the same start.
SAME_ROTATION = 1e-9
#: Scenes as MJCF (:mod:`worldgraph.scenes.mjcf`): a mesh of 8 vertices within this (relative to
#: its largest coordinate, at least 1 m) of its bounding box's corners is written as a box.
BOX_CORNER_RTOL = 1e-9
#: Pose: a start is better only when its cost is lower by this times ``max(cost, 1)``.
START_IMPROVEMENT = 1e-9
#: Pose (LM on the covariance-weighted cost): starting damping.
LM_LAMBDA_START = 1e-9
#: Pose (LM on the covariance-weighted cost): smallest damping.
LM_LAMBDA_MIN = 1e-12
#: Pose (LM): converged when the scaled gradient is below this times sqrt(cost).
GRADIENT_RTOL = 1e-9
#: Pose (LM): converged when the scaled step is below this times sqrt(max(cost, 1)).
STEP_RTOL = 1e-10
#: Pose certificate: relative rounding margin on the bound.
CERTIFICATE_ROUNDING = 4e-13
#: Pose certificate: rounding of the reference cost, relative to it.
CERTIFICATE_COST_ROUNDING = 1e-14
#: Pose certificate: a homogeneous coordinate below this cannot be divided by.
HOMOGENEOUS_ZERO = 1e-9
#: Default relative and absolute optimality gaps of the pose certificate.
CERTIFICATE_GAP = 1e-6
#: Clarabel options of the pose SDP: tight tolerances (the bound does not rely on them, its
#: tightness does).
CLARABEL_OPTIONS = {"tol_gap_abs": 1e-10, "tol_gap_rel": 1e-10, "tol_feas": 1e-10,
                    "tol_ktratio": 1e-8, "max_iter": 200}


@dataclass(frozen=True)
class AssociationTolerances:
    """Tolerances of the association, in one frozen place.

    Attributes
    ----------
    n_sigma : float
        Gate width in standard deviations.
    pair_factor : float
        Extra factor on the pair gate, ``tau_pq = n_sigma * pair_factor * sqrt(s_p^2 + s_q^2)
        + min_tolerance``; sqrt(2) keeps a true pair inside the gate with probability
        ~1 - 2e-5 at 3 sigma, so that all ~45 pairs of ten percepts pass together.
    min_tolerance : float
        Floor (metres) added to every distance gate (model inaccuracy).
    kappa_max : float
        Orientation filter, eq. 3: maximal angle (rad) between signature vectors.
    mu_max : float or None
        Orientation filter, eq. 2: maximal length (m) of the signature difference; ``None``
        derives it per triple like ``tau`` from the three sigmas.
    gravity_aligned : bool or None
        ``None`` (default): the call's ``gravity`` argument decides the search
        (:mod:`worldgraph.pose.gravity`; ``"auto"``: the gravity search, the free search when it finds
        no supported level answer).  ``True``: the gravity search about the ego z axis (REP 103
        ego with a levelled base: compare the horizontal distance and the height difference of
        pairs separately, so pairs across storeys drop out), without fallback; ``False``: the
        free 3D search.  An explicit ``gravity`` up vector or ``None`` overrides it.
    height_tolerance : float or None
        Gate (m) of the height difference in the gravity search; ``None`` uses ``tau``.
    tilt_allowance : float
        Radians: how far the ego up vector (z, or the ``gravity`` vector given) may be from the
        true vertical in the gravity search.  Folded into its gates (a pair's horizontal length
        and height difference may each move by what such a tilt can change,
        :func:`~worldgraph.pose.gravity.tilt_widening`); ``gravity="auto"`` falls back to the free
        search when the gravity pass's pose tilts beyond it.  Default 5 degrees.
    cost_cap : float
        Cap of a percept's squared normalised residual in the robust fit cost.
    residual_factor : float
        The residual of a percept under a fitted pose is normalised by ``residual_factor *
        sigma`` (the pose itself is uncertain).
    min_clique_size : int
        Smallest clique that makes a hypothesis (three points fix a pose).
    near_maximum : int
        Maximal cliques down to ``maximum size - near_maximum`` are kept.
    ambiguity_margin : float
        The best two (pose-distinct) hypotheses are ambiguous when their robust costs differ by
        less.  A cost difference is twice a log-likelihood ratio: the default 6 calls a runner-up
        ambiguous unless the best is 20 times as likely (at 4, chance fits of repeated cabinet
        modules were answered "ok" and wrong in our layouts).
    distinct_translation, distinct_angle : float
        Two hypotheses with translations closer than this (m) and rotations closer than this
        (rad) are the same pose: only the cheaper one is kept.
    chirality_sigmas : float
        A tetrahedron's signed volume decides chirality only when both volumes exceed this
        many standard deviations of the percept volume.
    max_nodes : int
        Node budget of one branch-and-bound search (the result says when it ran out).
    max_cliques : int
        At most this many cliques (largest first) are fitted and ranked.
    dense_pair_limit : int
        Percept pairs farther apart than the link table covers are matched by brute force when
        the two types have at most this many object pairs, otherwise by a k-d tree ball query.
    max_hypotheses : int
        Default number of hypotheses returned by :func:`associate`.
    max_search_percepts : int
        The clique search (and the paper's filters) use at most this many percepts, the most
        certain ones (smallest sigma); the others are validated against each hypothesis' pose
        and enter its cost (the paper generates candidates from at most 6 spheres and
        validates with the rest).  A search that hits ``max_nodes`` or ``max_cliques`` is
        retried on two fewer percepts (down to 6), so that a repetitive world around many
        percepts still gets a complete search (``AssociationHypothesis.complete``).
    """

    n_sigma: float = 3.0
    pair_factor: float = math.sqrt(2.0)
    min_tolerance: float = 0.01
    kappa_max: float = math.radians(20.0)
    mu_max: float | None = None
    gravity_aligned: bool | None = None
    height_tolerance: float | None = None
    tilt_allowance: float = math.radians(5.0)
    cost_cap: float = 9.0
    residual_factor: float = math.sqrt(2.0)
    min_clique_size: int = 3
    near_maximum: int = 1
    ambiguity_margin: float = 6.0
    distinct_translation: float = 0.25
    distinct_angle: float = math.radians(5.0)
    chirality_sigmas: float = 3.0
    max_nodes: int = 50_000
    max_cliques: int = 2000
    dense_pair_limit: int = 250_000
    max_hypotheses: int = 16
    max_search_percepts: int = 10

    def __post_init__(self) -> None:
        def put(name: str, value: object) -> None:
            object.__setattr__(self, name, value)

        for name in ("n_sigma", "pair_factor", "cost_cap", "residual_factor", "distinct_translation"):
            put(name, real_scalar(f"AssociationTolerances.{name}", getattr(self, name), positive=True,
                                  maximum=1e12))
        for name in ("min_tolerance", "ambiguity_margin", "chirality_sigmas"):
            put(name, real_scalar(f"AssociationTolerances.{name}", getattr(self, name), minimum=0.0,
                                  maximum=1e12))
        for name in ("kappa_max", "distinct_angle", "tilt_allowance"):
            v = real_scalar(f"AssociationTolerances.{name}", getattr(self, name), minimum=0.0,
                            positive=name != "tilt_allowance")
            if v > math.pi:
                raise WorldGraphError(f"AssociationTolerances.{name} = {v!r} is an angle in radians and must "
                                      f"be <= pi; degrees? use np.radians({v!r}) = {math.radians(v):.6g}")
            put(name, v)
        for name in ("mu_max", "height_tolerance"):
            v = getattr(self, name)
            if v is not None:
                put(name, real_scalar(f"AssociationTolerances.{name}", v, positive=True, maximum=1e12))
        if self.gravity_aligned is not None:
            if not isinstance(self.gravity_aligned, bool | np.bool_):
                raise WorldGraphError(f"AssociationTolerances.gravity_aligned must be a bool or None, "
                                      f"got {self.gravity_aligned!r}")
            put("gravity_aligned", bool(self.gravity_aligned))
        put("min_clique_size", integer("AssociationTolerances.min_clique_size", self.min_clique_size,
                                       minimum=2, maximum=64))
        put("max_search_percepts", integer("AssociationTolerances.max_search_percepts",
                                           self.max_search_percepts, minimum=2, maximum=100_000))
        if self.min_clique_size > self.max_search_percepts:
            raise WorldGraphError(f"AssociationTolerances.min_clique_size = {self.min_clique_size} exceeds "
                                  f"max_search_percepts = {self.max_search_percepts} (the clique search "
                                  "looks at that many percepts at most): raise max_search_percepts too")
        for name, lo in (("near_maximum", 0), ("max_nodes", 1), ("max_cliques", 1), ("dense_pair_limit", 0),
                         ("max_hypotheses", 1)):
            put(name, integer(f"AssociationTolerances.{name}", getattr(self, name), minimum=lo,
                              maximum=10**9))

    def pair_tolerance(self, sigma_p: float | NDArray, sigma_q: float | NDArray) -> float | NDArray:
        """``tau_pq = n_sigma * pair_factor * sqrt(s_p^2 + s_q^2) + min_tolerance`` (metres);
        sigmas are non-negative finite reals (scalars or arrays that broadcast)."""
        sp = real_array("sigma_p", sigma_p, None, max_abs=1e150)
        sq = real_array("sigma_q", sigma_q, None, max_abs=1e150)
        for name, arr in (("sigma_p", sp), ("sigma_q", sq)):
            if np.any(arr < 0):
                i = int(np.flatnonzero(np.ravel(arr) < 0)[0])
                raise WorldGraphError(f"{name}[{i}] must be >= 0, got {float(np.ravel(arr)[i])!r}"
                                      if arr.ndim else f"{name} must be >= 0, got {float(arr)!r}")
        try:
            out = self.n_sigma * self.pair_factor * np.hypot(sp, sq) + self.min_tolerance
        except ValueError as exc:
            raise WorldGraphError(f"sigma_p {sp.shape} and sigma_q {sq.shape} do not broadcast") from exc
        return float(out) if np.ndim(out) == 0 else out


ASSOCIATION_TOLERANCES = AssociationTolerances()


def _check_tolerances(tolerances: object, name: str = "tolerances", world: _GravityNoted | None = None
                      ) -> AssociationTolerances:
    """The tolerances, with ``gravity_aligned=None`` resolved to the world's flag when a world is
    given."""
    if not isinstance(tolerances, AssociationTolerances):
        raise WorldGraphError(f"{name} must be an AssociationTolerances, got {_short(tolerances)}")
    if world is not None and tolerances.gravity_aligned is None:
        return replace(tolerances, gravity_aligned=bool(world.gravity_aligned))
    return tolerances


def _resolved_tol(tol: object, world: _GravityNoted | None = None) -> AssociationTolerances:
    """The ``tol`` argument of a public function: ``None`` as :data:`ASSOCIATION_TOLERANCES`, then
    checked (and ``gravity_aligned`` resolved against ``world``) by ``_check_tolerances``."""
    return _check_tolerances(ASSOCIATION_TOLERANCES if tol is None else tol, "tol", world=world)
