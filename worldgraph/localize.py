"""Global self-localisation: association -> validation -> 6D pose with its covariance.

:func:`localize` runs the pipeline of the paper (sections 2.2-2.3, 4) on fused percepts:

1. association (:func:`worldgraph.association.associate`; ``method="paper"`` uses the paper's
   proximity and orientation filters, every other method the typed consistency-graph cliques);
2. hypothesis validation (:mod:`worldgraph.pose.validation`; every method but ``"paper"``): the
   best association hypotheses are fitted by maximum likelihood, every percept is re-associated
   to its nearest same-type object by Mahalanobis distance and the fit repeated on the inliers;
   the fits are ranked by their robust cost (a log-likelihood ratio), poses outside the region
   give way to poses inside it, and a runner-up within ``ambiguity_margin`` at another pose
   makes the answer ``"ambiguous"`` (its pose is in ``alternatives``); runners-up at the same
   pose (a percept matched to one of two neighbouring objects of its type; closer than a third
   of the tolerances) widen ``pose_covariance`` by their likelihood-weighted spread instead;
3. the pose of the chosen hypothesis: ``method="ml"`` (default) is the validated ML 6D pose of the
   matched percepts' full 3D positions and covariances; the range-only methods (``"spheres"``,
   ``"paper"``, ``"srls"``, ``"gradient"``) put one Gaussian sphere per matched pair (centre =
   model object, radius = ``|percept|``, sigma = percept sigma), estimate the position with
   ``radialopt.estimate_position`` and then the orientation (``"paper"``: eq. 5 from the
   best-conditioned matched triple; the others: the proper rotation minimising ``sum w_p |R x_p
   - (X_o - t)|^2``, ``w_p = 1 / (sigma_p^2 + var_t)``);
4. the 6x6 ``pose_covariance`` (ROS order): the inverse Fisher information for ``"ml"``, widened
   where the cost is flatter than its quadratic model (:func:`~worldgraph.pose.validation.laplace_inflate`),
   and the sandwich covariance of the two-stage estimator for the range-only methods;
5. the answer checks itself: a chi-square test of its matched percepts placed by its pose
   (``"inconsistent"`` when it fails), at least 3 inliers (counted in constrained directions,
   :data:`~worldgraph.tolerances.MIN_INLIER_DIRECTIONS` = 9: a needle-shaped percept counts two
   thirds), and the 3-sigma rotation and position bounds against ``max_rotation_3sigma`` and
   ``max_position_3sigma`` (``"weak"`` beyond them).

The default region is where the robot could stand and see what it saw: the room when the world
knows a plausible one (``world.room``, from an importer's floor and walls, holding the objects),
otherwise the objects' bounds grown sideways by the largest percept range and by
:data:`REGION_MARGIN` up and down.  The default region chooses between candidates (a pose inside
it beats a better-fitting one outside) but never fails a unique answer; a region given by the
caller also rejects poses outside it (``"outside_region"``).

Percepts whose type the world does not have are ignored (named in the result's message);
when no percept type is known, :class:`~worldgraph.errors.UnknownTypeError` is raised.
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field, fields, replace
from typing import Any, Literal, cast, get_args

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation
from scipy.stats import chi2

import radialopt as ro
from perception import Percept
from radialopt.projection import _project_radii_trusted

from ._checks import float_array, generator, positive_float, strict_int
from .association.associate import _associate_searched
from .association.consistency import MAX_COORDINATE, check_world_and_percepts
from .association.hypotheses import AssociationHypothesis, is_ambiguous
from .errors import ArgumentTypeError, OutOfRangeError, PoseError, UnknownTypeError, WorldGraphError
from .model import WorldModel
from .pose.certificate import certify_pose, solve_pose_sdp
from .pose.frames import percept_frame, pose_from_frames, transformation, weighted_rotation
from .pose.gravity import (
    _FREE,
    Gravity,
    SearchKind,
    _check_gravity,
    _Plan,
    _unsupported,
)
from .pose.validation import (
    CHI2_3_GATE,
    CHI2_6_GATE,
    NearestObjects,
    PoseFit,
    _pose_error,
    _pose_nees,
    calibrated_pose_covariance,
    constrained_directions,
    fit_hypothesis,
    percept_covariances,
    pose_cost,
    rotation_only_covariance,
    self_check,
    shared_range_covariance,
    shared_view_covariance,
)
from .tolerances import (
    ASSOCIATION_TOLERANCES,
    COST_ROUNDING,
    DUPLICATE_DISTANCE,
    MIN_INLIER_DIRECTIONS,
    REGION_SLACK,
    RIGID_TOLERANCE,
    SIGNIFICANCE,
    AssociationTolerances,
    _tol_argument,
)
from .units import units_hint

__all__ = [
    "LOCALIZE_METHODS",
    "LOCALIZE_STATUSES",
    "MAX_POSITION_3SIGMA",
    "MAX_ROTATION_3SIGMA",
    "REGION_MARGIN",
    "LocalizationResult",
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

#: ``"ml"``: the maximum-likelihood 6D pose from the full 3D percepts (their covariances);
#: ``"spheres"``: the range-only maximum-likelihood position of the Gaussian spheres
#: (``radialopt`` method ``"ml"``), then the rotation; ``"paper"``: the paper's association and
#: its radial-projection position; ``"srls"``, ``"gradient"``: other range-only estimators.
LOCALIZE_METHODS = ("ml", "spheres", "paper", "srls", "gradient")
#: Range-only position estimator of ``radialopt.estimate_position`` behind each method.
_SPHERE_ESTIMATOR = {"spheres": "ml", "paper": "paper", "srls": "srls", "gradient": "gradient"}
#: Metres added above and below the objects' bounds by the default region (sideways it grows by
#: the largest percept range).
REGION_MARGIN = 1.0
#: A room narrower than this (m) in x or y is no room (a lone wall node, a floor tile).
MIN_ROOM_SIZE = 1.5
#: Position candidates with at least this fraction of the best density are told apart by the
#: validated 3D pose.
CANDIDATE_DENSITY_RATIO = 0.01
#: Default largest 3-sigma position bound (m, along the worst direction) of an "ok" pose, and ...
MAX_POSITION_3SIGMA = 0.25
#: ... of the rotation (rad, about the worst axis).  Chosen for a mobile manipulator's global
#: localisation: good enough to drive to a cabinet and turn the head to the handle it wants
#: (5 degrees move a handle 2 m away by 17 cm, which the head camera then finds and servoes on);
#: tighten both for grasping from the global pose alone.
MAX_ROTATION_3SIGMA = math.radians(5.0)
#: Validation stops after this many distinct fits (hypotheses that converge to the same inliers
#: count once) ...
MAX_VALIDATED = 8
#: ... among at most this many association hypotheses.
ASSOCIATION_CANDIDATES = 32

#: Statuses of a unique answer (:attr:`LocalizationResult.unique`).
UniqueStatus = Literal[
    "ok",                    # a unique pose, well determined, consistent with its matches
    "weak",                  # unique and consistent, but a 3-sigma bound exceeds the tolerance
]
#: Statuses that come with a trusted pose: finite, rigid, with a finite covariance.
PoseStatus = Literal[
    UniqueStatus,
    "ambiguous",             # another association or position candidate is about as good
]
#: Statuses without a trusted pose (``"inconsistent"``, ``"outside_region"`` and the range-only
#: ``"degenerate_coplanar"`` and ``"not_converged"`` still fill in the pose that failed, for
#: diagnosis).
FailureStatus = Literal[
    "inconsistent",          # the pose contradicts its own matches (chi-square self-check)
    "no_association",        # no consistent set of >= 3 percept-object pairs
    "too_few_percepts",      # fewer than 3 percepts of known types
    "degenerate",            # the matched landmarks cannot fix a pose (collinear, ...)
    "outside_region",        # the pose lies outside the region the caller gave
    "degenerate_coplanar",   # range-only methods: coplanar landmarks, position on their plane
    "degenerate_collinear",  # range-only methods: collinear landmarks
    "not_converged",         # range-only methods: the position estimator stopped at its iteration cap
]
LocalizeStatus = Literal[PoseStatus, FailureStatus]
#: Statuses of :class:`LocalizationResult`; only ``"ok"`` and ``"weak"`` are unique answers.
LOCALIZE_STATUSES: tuple[str, ...] = get_args(LocalizeStatus)
#: ``"ok"`` and ``"weak"``: the unique answers.
UNIQUE_STATUSES: tuple[str, ...] = get_args(UniqueStatus)
#: ``"ok"``, ``"weak"`` and ``"ambiguous"``: a finite rigid pose and covariance, checked.
POSE_STATUSES: tuple[str, ...] = get_args(PoseStatus)


@dataclass(frozen=True)
class LocalizationResult:
    """Result of :func:`localize`.

    Attributes
    ----------
    transformation : (4, 4) float
        ``world_from_ego``: maps ego coordinates into the world, ``x_world = R @ x_ego + t``
        with ``R = transformation[:3, :3]`` (:attr:`rotation`) and ``t = position``; NaN
        everywhere when no pose could be determined.
    position : (3,) float
        Robot (ego origin) position in the world, ``transformation[:3, 3]``.
    covariance : (3, 3) float
        Position block of ``pose_covariance`` (NaN when no pose).
    correspondences : tuple of (percept_index, object_index)
        The inliers the pose rests on; indices into the ``percepts`` passed in and into
        ``world.objects``.
    hypotheses : tuple of AssociationHypothesis
        The association's hypotheses, the validated ones first in their validated order;
        percept indices refer to the ``percepts`` passed in.  Each carries its radial solution
        (``radial``, see ``solver`` and ``check`` of :func:`localize`).
    ambiguous : bool
    status : LocalizeStatus
        One of :data:`LOCALIZE_STATUSES`.
    message : str
    timings : dict str -> float
        Seconds per stage: ``"association"``, ``"validation"``, ``"position"``,
        ``"orientation"``, ``"total"``.
    position_estimate : radialopt.PositionEstimate or None
        The range-only estimate (range-only methods).
    pose_covariance : (6, 6) float
        ROS ``PoseWithCovariance`` order ``(x, y, z, rx, ry, rz)``: translation error ``t_true -
        t_est`` in world axes, rotation error the rotation vector of ``R_true @ R_est.T`` (world
        axes).  NaN when no pose.
    fitness : float
        Fraction of the percepts passed in that are inliers of the pose (Open3D's ``fitness``).
    inlier_rmse : float
        Root-mean-square distance (m) of the inliers from their objects (Open3D's
        ``inlier_rmse``); NaN without inliers.
    residuals : (k,) float
        Mahalanobis distance of every percept passed in, placed by the pose, from its nearest
        same-type object (percept and pose covariance); inf when none is in reach, NaN for
        percepts of unknown type or when no pose.
    alternatives : tuple of (4, 4) float
        ``world_from_ego`` of the validated runner-ups within ``ambiguity_margin`` of the best.
    log_likelihood_ratio : float
        Half the robust-cost difference between the best validated fit at another pose and the
        chosen pose (inf when there is none).  Fits at the same pose (closer than a third of
        ``max_position_3sigma`` and ``max_rotation_3sigma``, and than ``distinct_translation``
        and ``distinct_angle``: a percept matched to one of two neighbouring objects of its
        type) do not make the answer ambiguous: their likelihood-weighted spread is part of
        ``pose_covariance``.
    certificate : radialopt.Certificate or None
        With ``certify=True``: whether the pose is proven the global minimum of the ML cost of
        its matches (the rotation SDP of :mod:`worldgraph.pose.certificate`), with the proven
        lower bound and the gap.  None otherwise.
    near_best_costs : tuple of float
        Robust costs (twice a negative log-likelihood up to a constant) of the validated fits
        behind ``transformation`` and each of ``alternatives``, in that order (empty for the
        ``"paper"`` method and when no pose was determined); what
        :func:`worldgraph.active.plan_view` weights the near-best hypotheses with.
    search : {"gravity", "free"}
        Which search answered (:mod:`worldgraph.pose.gravity`): the storey-aware gravity search or
        the free 3D search (``gravity=None``, the paper's method, or ``"auto"``'s fallback,
        whose reason the message gives; ``timings["gravity_pass"]`` is then the gravity pass's
        time).
    """

    transformation: NDArray[np.float64]
    position: NDArray[np.float64]
    covariance: NDArray[np.float64]
    correspondences: tuple[tuple[int, int], ...]
    hypotheses: tuple[AssociationHypothesis, ...]
    ambiguous: bool
    status: LocalizeStatus
    message: str = ""
    timings: dict[str, float] = field(default_factory=dict)
    position_estimate: ro.PositionEstimate | None = None
    pose_covariance: NDArray[np.float64] = field(default_factory=lambda: np.full((6, 6), np.nan))
    fitness: float = 0.0
    inlier_rmse: float = math.nan
    residuals: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    alternatives: tuple[NDArray[np.float64], ...] = ()
    log_likelihood_ratio: float = math.inf
    certificate: ro.Certificate | None = None
    near_best_costs: tuple[float, ...] = ()
    search: SearchKind = "free"

    @property
    def unique(self) -> bool:
        """A unique, consistent pose (status ``"ok"`` or ``"weak"``)."""
        return self.status in UNIQUE_STATUSES

    @property
    def has_pose(self) -> bool:
        """``transformation`` is finite: every status of :data:`POSE_STATUSES`, and the failed
        poses that ``"inconsistent"``, ``"outside_region"``, ... keep for diagnosis."""
        return bool(np.all(np.isfinite(self.transformation)))

    @property
    def rotation(self) -> Rotation:
        """The rotation of ``transformation`` (``world_from_ego``) as a scipy ``Rotation``.

        It maps ego-frame vectors to world axes (``v_world = rotation.apply(v_ego)``, so
        ``transformation[:3, :3] == rotation.as_matrix()``); ``rotation.as_rotvec()`` is the
        ego frame's orientation in the world, radians.

        Raises
        ------
        PoseError
            The result has no pose (``transformation`` is NaN).
        """
        if not self.has_pose:
            raise PoseError(f"LocalizationResult with status={self.status!r} has no pose: its "
                            "transformation is NaN, so it has no rotation")
        return Rotation.from_matrix(self.transformation[:3, :3])

    @property
    def position_3sigma(self) -> NDArray[np.float64]:
        """(3,) float: three standard deviations of ``position`` along the world x, y, z axes
        (m, from the diagonal of ``covariance``); NaN without a pose or a covariance."""
        var = np.diagonal(self.covariance)
        return 3.0 * np.sqrt(np.where(var >= 0, var, np.nan))

    @property
    def rotation_3sigma(self) -> float:
        """Three standard deviations of the rotation about its worst axis (rad, the largest
        eigenvalue of the rotation block of ``pose_covariance``; what the ``"weak"`` test
        compares with ``max_rotation_3sigma``); NaN without a finite covariance."""
        block = self.pose_covariance[3:, 3:]
        if not np.all(np.isfinite(block)):
            return math.nan
        return _worst_3sigma(block)

    @property
    def n_near_best(self) -> int:
        """Validated poses within the ambiguity margin of the best: the pose itself and its
        ``alternatives`` (0 without a pose)."""
        return 1 + len(self.alternatives) if self.has_pose else 0

    def summary(self) -> str:
        """A short human-readable account, one fact a line.

        Returns
        -------
        str
            Lines: the status (and whether the pose is unique); the position with its 3-sigma
            bound per axis (m) and the rotation of ``world_from_ego`` as an angle (deg) about
            a unit axis (world axes) with its worst-axis 3-sigma bound, or ``no pose``; the
            matched percepts (of all passed in), fitness and inlier RMSE; the number of
            hypotheses and of near-best validated poses; the total time; the message.
        """
        lines = [f"status: {self.status}" + (" (unique pose)" if self.unique else "")]
        if self.has_pose:
            x3 = self.position_3sigma
            lines.append("position: " + ", ".join(
                f"{axis} = {v:.3f} ± {_fmt(s)}" for axis, v, s in zip("xyz", self.position, x3, strict=True))
                + " m (3 sigma)")
            angle, axis = _angle_axis(self.rotation)
            axis = np.round(axis, 3) + 0.0  # no "-0.000"
            r3 = self.rotation_3sigma
            lines.append(f"rotation: {math.degrees(angle):.2f} deg about [{axis[0]:.3f}, {axis[1]:.3f}, "
                         f"{axis[2]:.3f}] (world_from_ego), 3-sigma bound {_fmt(math.degrees(r3))} deg")
        else:
            lines.append("no pose")
        rmse = f", inlier RMSE {self.inlier_rmse:.3g} m" if math.isfinite(self.inlier_rmse) else ""
        lines.append(f"matches: {len(self.correspondences)} of {len(self.residuals)} percepts "
                     f"(fitness {self.fitness:.2f}{rmse})")
        lines.append(f"hypotheses: {len(self.hypotheses)}, near-best poses: {self.n_near_best}")
        total = self.timings.get("total")
        lines.append(f"time: {total:.3f} s total" if total is not None else "time: not recorded")
        if self.message:
            lines.append(f"message: {self.message}")
        return "\n".join(lines)

    def __repr__(self) -> str:
        """One line: status, position (m), rotation angle (deg) and the number of matches."""
        if self.has_pose:
            x, y, z = self.position
            angle, _ = _angle_axis(self.rotation)
            pose = f"position=[{x:.3f}, {y:.3f}, {z:.3f}] m, angle={math.degrees(angle):.1f} deg"
        else:
            pose = "no pose"
        return f"LocalizationResult(status={self.status!r}, {pose}, matches={len(self.correspondences)})"

    def to_dict(self) -> dict[str, Any]:
        """The main fields as plain JSON types (``json.dumps(result.to_dict(), allow_nan=False)``
        works).

        Returns
        -------
        dict
            ``status``, ``message``, ``unique``, ``ambiguous``, ``has_pose``;
            ``transformation`` (4x4 nested lists, ``world_from_ego``), ``position`` (m),
            ``rotation_vector`` (rad, world_from_ego), ``position_3sigma`` (m per axis),
            ``rotation_3sigma`` (rad), ``covariance`` (3x3), ``pose_covariance`` (6x6, ROS
            order); ``correspondences`` (``[percept_index, object_index]`` pairs),
            ``n_hypotheses``, ``n_near_best``, ``alternatives`` (4x4 each), ``near_best_costs``,
            ``log_likelihood_ratio``, ``fitness``, ``inlier_rmse`` (m), ``residuals``,
            ``timings`` (s), ``search``, ``position_estimate`` (its method, status, message and position)
            and ``certificate`` (certified, method, lower bound, gap, message), each None when
            absent.  Lists instead of arrays; every NaN or infinite number becomes None.
        """
        est, cert = self.position_estimate, self.certificate
        out = {
            "status": self.status,
            "message": self.message,
            "unique": self.unique,
            "ambiguous": bool(self.ambiguous),
            "has_pose": self.has_pose,
            "transformation": self.transformation,
            "position": self.position,
            "rotation_vector": self.rotation.as_rotvec() if self.has_pose else None,
            "position_3sigma": self.position_3sigma,
            "rotation_3sigma": self.rotation_3sigma,
            "covariance": self.covariance,
            "pose_covariance": self.pose_covariance,
            "correspondences": [[int(p), int(o)] for p, o in self.correspondences],
            "n_hypotheses": len(self.hypotheses),
            "n_near_best": self.n_near_best,
            "alternatives": list(self.alternatives),
            "near_best_costs": list(self.near_best_costs),
            "log_likelihood_ratio": self.log_likelihood_ratio,
            "fitness": self.fitness,
            "inlier_rmse": self.inlier_rmse,
            "residuals": self.residuals,
            "timings": dict(self.timings),
            "search": self.search,
            "position_estimate": None if est is None else {
                "method": est.method, "status": est.status, "message": est.message,
                "position": est.position},
            "certificate": None if cert is None else {
                "certified": bool(cert.certified), "method": cert.method, "lower_bound": cert.lower_bound,
                "gap": cert.gap, "message": cert.message},
        }
        return _jsonable(out)


def _fmt(value: float) -> str:
    """Three significant digits, or ``undetermined`` for NaN and inf."""
    return f"{value:.3g}" if math.isfinite(value) else "undetermined"


def _angle_axis(rotation: Rotation) -> tuple[float, NDArray[np.float64]]:
    """Angle (rad, in [0, pi]) and unit axis of a rotation; the axis is z for no rotation."""
    rotvec = rotation.as_rotvec()
    angle = float(np.linalg.norm(rotvec))
    return angle, (rotvec / angle if angle > 0 else np.array([0.0, 0.0, 1.0]))


def _jsonable(value: Any) -> Any:
    """``value`` with arrays as lists, numpy scalars as Python numbers, NaN and inf as None."""
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist())
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    return value


def _failed(status: LocalizeStatus, message: str, n: int, hyps: tuple = (), timings: dict | None = None,
            ambiguous: bool = False) -> LocalizationResult:
    nan3 = np.full(3, np.nan)
    return LocalizationResult(np.full((4, 4), np.nan), nan3, np.full((3, 3), np.nan), (), hyps,
                              ambiguous, status, message, timings or {}, residuals=np.full(n, np.nan))


def _remap(h: AssociationHypothesis, idx: NDArray[np.intp]) -> AssociationHypothesis:
    return AssociationHypothesis(
        pairs=tuple((int(idx[p]), o) for p, o in h.pairs), cost=h.cost, size=h.size,
        world_from_ego=h.world_from_ego, validated=tuple((int(idx[p]), o) for p, o in h.validated),
        inliers=h.inliers, complete=h.complete)


def default_region(world: WorldModel, percepts: Sequence[Percept]) -> ro.Region:
    """Where the robot could stand and see ``percepts``: ``world.room`` when it is a plausible
    room (at least :data:`MIN_ROOM_SIZE` wide both ways and holding the objects' positions to
    within :data:`REGION_MARGIN`; a scene whose only "wall" node is one wall is not), else the
    objects' bounds grown sideways by the largest percept range and by :data:`REGION_MARGIN` up
    and down."""
    percepts = check_world_and_percepts(world, percepts)
    room = getattr(world, "room", None)
    if room is not None:
        size = room.upper - room.lower
        if size[0] >= MIN_ROOM_SIZE and size[1] >= MIN_ROOM_SIZE and bool(
                np.all(room.contains(world.positions, tol=REGION_MARGIN))):
            return room
    lo, hi = world.bounds
    reach = max((p.range for p in percepts), default=0.0)
    grow = np.array([reach + REGION_MARGIN, reach + REGION_MARGIN, REGION_MARGIN])
    return ro.Region(lo - grow, hi + grow)


def localize(world: WorldModel, percepts: Sequence[Percept], method: str = "ml", *,
             tol: AssociationTolerances | None = None, region: ro.Region | None = None,
             rng: np.random.Generator | None = None, max_position_3sigma: float = MAX_POSITION_3SIGMA,
             max_rotation_3sigma: float = MAX_ROTATION_3SIGMA, solver: str = "active_set",
             check: bool = False, certify: bool = False, gravity: Gravity = "auto",
             tolerances: AssociationTolerances | None = None) -> LocalizationResult:
    """Pose of the robot (``world_from_ego``) from percepts of known world objects.

    Parameters
    ----------
    world : WorldModel
    percepts : sequence of perception.Percept
        Fused percepts in the ego frame.
    method : {"ml", "spheres", "paper", "srls", "gradient"}
        ``"ml"`` (default): the maximum-likelihood 6D pose of the validated matches, using the
        percepts' full 3D positions and covariances.  ``"spheres"``: the range-only ML position
        of the Gaussian spheres (``radialopt`` ``"ml"``), then the rotation; right when the
        percept directions are unreliable (space-to-ego errors rotate percepts about the ego
        origin, ranges survive them).  ``"paper"``: the paper's proximity + orientation filters,
        its radial-projection position and eq. 5; ``"srls"``, ``"gradient"``: other range-only
        estimators, for comparison.
    tol : AssociationTolerances, optional
        Default :data:`~worldgraph.tolerances.ASSOCIATION_TOLERANCES`.
    region : radialopt.Region or (lower, upper), optional
        Valid robot positions (a box, metres; a pair of 3-vectors is turned into a Region);
        poses outside it are rejected.  Default :func:`default_region`.
    rng : numpy.random.Generator, optional
        Passed to the position estimator (extra random seeds).
    max_position_3sigma : float
        Metres; a unique pose whose 3-sigma position bound (worst direction) is larger is
        ``"weak"``.
    max_rotation_3sigma : float
        Radians; likewise for the rotation (worst axis).
    solver : str
        How every returned hypothesis' radial problem (the design card's convex problem: its
        Gaussian spheres projected onto their restriction polytope, kept as
        ``AssociationHypothesis.radial``) is solved: ``"active_set"`` (exact, default) or the
        name of an installed cvxpy solver (``"CLARABEL"``, ...), compiled once per sphere count.
        Every hypothesis in ``hypotheses`` carries its solution (None only when its matches
        have fewer than two distinct model positions).
    check : bool
        Verify the radial solutions the pose steps use (those of the validated hypotheses, the
        ones behind an ML fit; with ``method="paper"`` every hypothesis) of at most
        ``radialopt.MAX_VERTEX_SPHERES`` spheres against explicit vertex enumeration (raises
        :class:`~worldgraph.errors.WorldGraphError` from ``radialopt.VerificationError`` on
        disagreement); larger ones are solved unchecked and the message says so (enumeration
        grows combinatorially: 8 spheres take ~20 s).  The other hypotheses' solutions are
        solved by the same solver unchecked, so that ``check=True`` costs one enumeration per
        validated hypothesis, not one per hypothesis.
    certify : bool
        Fill ``certificate``: the rotation SDP's proof (or not) that the returned pose is the
        global minimum of the ML cost of its matched percepts.  With 3 or 4 matches the SDP is
        also the solver (``"ml"``).
    gravity : "auto", (3,) float or None
        Which way is up in the ego frame (:mod:`worldgraph.pose.gravity`).  ``"auto"`` (default): the
        storey-aware gravity search about the ego z axis, within ``tol.tilt_allowance`` (a level
        base); when its answer has no pose, explains fewer than
        :data:`~worldgraph.pose.gravity.MIN_GRAVITY_SUPPORT` (three quarters) of the percepts (its
        matches, or the percepts within the chi-square gate of an object of their type when
        more), or has a pose that tilts the ego z axis beyond the allowance (plus 1 degree), the
        free 3D search answers instead.  A (3,) up vector (an IMU's, in the ego frame): the gravity search
        about it, no fallback.
        ``None``: the free 3D search.  :attr:`LocalizationResult.search` says which search
        answered.  The paper's method uses no gravity.
    tolerances : AssociationTolerances, optional
        Deprecated alias of ``tol`` (a :class:`DeprecationWarning`; both at once raise
        :class:`~worldgraph.errors.ArgumentTypeError`).

    Returns
    -------
    LocalizationResult
        Never a silently wrong pose: "ok" only for a unique, well-determined pose that passes
        its own chi-square check with at least 3 inliers (9 constrained directions: a
        needle-shaped percept counts 2 of 3); otherwise the status says why (the
        best pose is still returned for "ambiguous", "weak", "inconsistent" and
        "outside_region"; NaN when no pose can be determined).

    Raises
    ------
    EmptyWorldError
        The world has no objects.
    UnknownTypeError
        Percepts were given but none has a type of the world.
    WorldGraphError
        Unknown method, something other than Percepts, a bad region or bound.
    """
    t_start = time.perf_counter()
    tol = _tol_argument("localize", tol, tolerances)
    percepts, settings = _check_arguments(world, percepts, method, tol, region, rng,
                                          max_position_3sigma, max_rotation_3sigma, solver, check, certify,
                                          gravity)
    with _raised_as_worldgraph_errors(settings.method):
        result = _localize(world, percepts, settings, t_start)
        n_used = sum(1 for p in percepts if p.type in world.type_index)
        why = _gravity_unsupported(result, settings.plan, settings.tol, settings.method, n_used)
        if why:
            free = _localize(world, percepts, replace(settings, plan=_FREE), t_start)
            result = _answered_by_free_search(free, result, why)
    return _sane(result, len(percepts))


def _gravity_unsupported(result: LocalizationResult, plan: _Plan, tol: AssociationTolerances, method: str,
                         n_used: int) -> str:
    """Why ``gravity="auto"`` falls back from the gravity pass's ``result`` (of ``n_used``
    percepts of known types) to the free search, "" when it keeps it
    (:func:`~worldgraph.pose.gravity._unsupported`, with the pass's status)."""
    if not plan.fallback or plan.up is None or method == "paper" or result.search != "gravity":
        return ""
    if result.status == "too_few_percepts":
        return ""  # the free search has no more percepts
    # support: the percepts the pose explains (chi-square inliers of the answer, whether or not
    # its fit rests on them: a percept between two neighbouring objects of its type is explained
    # but not matched), at least its matches
    explained = int(np.count_nonzero(result.residuals ** 2 <= CHI2_3_GATE))
    support = max(len(result.correspondences), explained)
    why = _unsupported(result.transformation, support, n_used, plan.up, tol)
    return f"{why} ({result.status})" if why else ""


def _answered_by_free_search(free: LocalizationResult, gravity_pass: LocalizationResult, why: str
                             ) -> LocalizationResult:
    """The free search's answer, its message saying why the gravity pass was not kept and its
    timings holding the gravity pass's total as ``"gravity_pass"``."""
    note = f"gravity search: {why}; answered by the free 3D search"
    timings = dict(free.timings)
    timings["gravity_pass"] = gravity_pass.timings.get("total", math.nan)
    return replace(free, message="; ".join(m for m in (note, free.message) if m), timings=timings)


@dataclass(frozen=True)
class _Settings:
    """The checked arguments of one :func:`localize` call (all but the world and the percepts)."""

    method: str
    tol: AssociationTolerances
    region: ro.Region | None  # the caller's region; None: the default region
    rng: np.random.Generator | None
    pos_tol: float  # max_position_3sigma, metres
    rot_tol: float  # max_rotation_3sigma, radians
    solver: str  # "active_set" or an installed cvxpy solver's name, upper case
    check: bool
    certify: bool
    plan: _Plan  # the search: gravity (about which up vector) or free, and whether "auto" may fall back


def _check_arguments(world: WorldModel, percepts: Sequence[Percept], method: str,
                     tol: object, region: object, rng: object,
                     max_position_3sigma: float, max_rotation_3sigma: float, solver: object, check: object,
                     certify: object, gravity: object = "auto") -> tuple[list[Percept], _Settings]:
    """Step 1: every argument of :func:`localize` checked (specific errors), as the percepts and
    the call's settings."""
    if not isinstance(method, str) or method not in LOCALIZE_METHODS:
        raise WorldGraphError(f"method must be one of {LOCALIZE_METHODS}, got {method!r}")
    checked = check_world_and_percepts(world, percepts)
    tol = ASSOCIATION_TOLERANCES if tol is None else tol
    if not isinstance(tol, AssociationTolerances):
        raise ArgumentTypeError(f"tol must be AssociationTolerances, got {type(tol).__name__}")
    box = _check_region(region)
    gen = None if rng is None else generator("rng", rng)
    if not isinstance(solver, str):
        raise ArgumentTypeError(f"solver must be 'active_set' or a cvxpy solver name, got {solver!r}")
    solver_name = solver if solver == "active_set" else solver.upper()
    if solver_name != "active_set" and solver_name not in ro.installed_cvxpy_solvers():
        raise WorldGraphError(f"solver {solver!r} is neither 'active_set' nor an installed cvxpy solver "
                              f"({', '.join(ro.installed_cvxpy_solvers())})")
    if not isinstance(check, bool | np.bool_):
        raise ArgumentTypeError(f"check must be a bool, got {check!r}")
    if not isinstance(certify, bool | np.bool_):
        raise ArgumentTypeError(f"certify must be a bool, got {certify!r}")
    pos_tol = positive_float("max_position_3sigma", max_position_3sigma)
    rot_tol = positive_float("max_rotation_3sigma", max_rotation_3sigma)
    if rot_tol > math.pi:
        raise OutOfRangeError(f"max_rotation_3sigma = {rot_tol!r} is an angle in radians and must be <= pi; "
                              f"did you mean degrees? np.radians({rot_tol:g}) = {math.radians(rot_tol):.4g}")
    big = float(np.max(np.abs(world.positions)))
    if not big <= MAX_COORDINATE:
        raise OutOfRangeError(f"world positions reach {big:.3g} m; localize handles coordinates up to "
                              f"{MAX_COORDINATE:g} m (shift the world's origin)")
    plan = _check_gravity(gravity, tol)
    return checked, _Settings(method, tol, box, gen, pos_tol, rot_tol, solver_name, bool(check),
                              bool(certify), plan)


@contextmanager
def _raised_as_worldgraph_errors(method: str) -> Iterator[None]:
    """Failures of the numerical steps (radialopt's, numpy's) raised as WorldGraphError."""
    try:
        yield
    except WorldGraphError:
        raise
    except ro.VerificationError as exc:
        raise WorldGraphError(f"check=True: a radial solution failed its verification: {exc}") from exc
    except ro.RadialError as exc:
        raise WorldGraphError(f"localize: radialopt rejected the Gaussian spheres built from the percepts "
                              f"(method={method!r}): {exc}") from exc
    except (ArithmeticError, ValueError, TypeError, IndexError, np.linalg.LinAlgError) as exc:
        raise WorldGraphError(f"localize failed numerically on these percepts (method={method!r}): "
                              f"{type(exc).__name__}: {exc}") from exc


def _check_region(region: object) -> ro.Region | None:
    """None, a radialopt.Region, or a ``(lower, upper)`` pair of 3-vectors (metres)."""
    if region is None or isinstance(region, ro.Region):
        return region
    if isinstance(region, tuple | list) and len(region) == 2:
        lo = float_array("region[0]", region[0], (3,))
        hi = float_array("region[1]", region[1], (3,))
        try:
            return ro.Region(lo, hi)
        except ro.RadialError as exc:
            raise WorldGraphError(f"region (lower, upper) is not a box: {exc}") from exc
    raise ArgumentTypeError(f"region must be None, a radialopt.Region or a (lower, upper) pair of 3-vectors, "
                            f"got {type(region).__name__}")


def _sane(result: LocalizationResult, n: int) -> LocalizationResult:
    """A success status only with a finite rigid pose and covariance; a listed status."""
    status = result.status
    if status not in LOCALIZE_STATUSES:
        return replace(result, status="degenerate", message=f"{result.message}; internal status {status!r} "
                       "is not a localisation status".lstrip("; "))
    if status in POSE_STATUSES:
        T = result.transformation
        finite = bool(np.all(np.isfinite(T)) and np.all(np.isfinite(result.pose_covariance))
                      and np.all(np.isfinite(result.covariance)))
        rigid = finite and bool(np.allclose(T[:3, :3].T @ T[:3, :3], np.eye(3), atol=RIGID_TOLERANCE)
                                and np.linalg.det(T[:3, :3]) > 0)
        if not rigid:
            why = "non-finite pose or covariance" if not finite else "a pose that is not rigid"
            return replace(result, status="degenerate", ambiguous=False,
                           message="; ".join(m for m in (result.message, f"numerical breakdown: {why}") if m))
    return result


def _units_hints(world: WorldModel, used: list[Percept]) -> list[str]:
    """Sentences for the message when positions look like millimetres (docs/design.md#units)."""
    hint = units_hint(world, used)
    return [hint] if hint else []


def _localize(world: WorldModel, percepts: list[Percept], settings: _Settings, t_start: float
              ) -> LocalizationResult:
    """The pipeline on checked arguments: known percepts, association, measurements, then the
    validated pose (or the paper's)."""
    call = _known_percepts_step(world, percepts, settings, t_start)
    need = max(3, settings.tol.min_clique_size)
    if len(call.used) < need:
        return call.failed("too_few_percepts", f"localisation needs at least {need} percepts of known types, "
                           f"got {len(call.used)}")
    search: SearchKind = "free" if settings.method == "paper" else settings.plan.search
    hyps_local = _associate_step(call)
    if not hyps_local:
        return replace(call.failed("no_association",
                                   "no consistent association of >= 3 percepts with the world model"),
                       search=search)
    ctx = _measurement_step(call)
    if settings.method == "paper":
        return _paper(ctx, hyps_local)
    return replace(_validated(ctx, hyps_local), search=search)


@dataclass
class _Call:
    """One call's settings, its percepts of known types and what it has noted and timed so far."""

    world: WorldModel
    settings: _Settings
    used: list[Percept]
    idx: NDArray[np.intp]               # used -> index in the percepts passed in
    n_all: int
    notes: list[str]
    timings: dict[str, float]
    t_start: float

    def remap(self, pairs: Sequence[tuple[int, int]]) -> tuple[tuple[int, int], ...]:
        return tuple((int(self.idx[p]), int(o)) for p, o in pairs)

    def failed(self, status: LocalizeStatus, message: str, hyps: tuple = (), ambiguous: bool = False
               ) -> LocalizationResult:
        self.timings["total"] = time.perf_counter() - self.t_start
        return _failed(status, "; ".join(self.notes + [message]), self.n_all, hyps, self.timings, ambiguous)


@dataclass
class _Context(_Call):
    """A call with the measurements its steps share: the region, the percept positions and
    covariances in the ego frame and the nearest-object index."""

    region: ro.Region
    explicit_region: bool
    ego: NDArray[np.float64]
    covs: NDArray[np.float64]
    nearest: NearestObjects
    ranges: NDArray[np.float64]  # each percept's Gaussian-sphere radius (Percept.range)
    sigmas: NDArray[np.float64]  # and its sigma


def _known_percepts_step(world: WorldModel, percepts: list[Percept], settings: _Settings, t_start: float
                         ) -> _Call:
    """Step 2: the percepts of types the world has (the others are named in a note)."""
    known = np.array([p.type in world.type_index for p in percepts], dtype=bool)
    unknown = sorted({p.type for p, ok in zip(percepts, known, strict=True) if not ok})
    if percepts and not known.any():
        raise UnknownTypeError(f"no percept type is in the world model: percept types {unknown}, "
                               f"world types {list(world.type_index)}")
    notes = [f"ignored {int((~known).sum())} percept(s) of unknown type(s) {unknown}"] if unknown else []
    idx = np.flatnonzero(known)
    used = [percepts[i] for i in idx]
    notes += _units_hints(world, used)
    timings = {"association": 0.0, "validation": 0.0, "radial": 0.0, "position": 0.0, "orientation": 0.0}
    return _Call(world, settings, used, idx, len(percepts), notes, timings, t_start)


def _associate_step(call: _Call) -> list[AssociationHypothesis]:
    """Step 3: association hypotheses (the paper's filters for ``"paper"``, else typed cliques)."""
    t0 = time.perf_counter()
    tol = call.settings.tol
    how = "paper" if call.settings.method == "paper" else "clique"
    hyps = _associate_searched(call.world, call.used, tol, how,
                               max(int(tol.max_hypotheses), ASSOCIATION_CANDIDATES), call.settings.plan)
    call.timings["association"] = time.perf_counter() - t0
    return hyps


def _measurement_step(call: _Call) -> _Context:
    """Step 4: the region (the caller's or :func:`default_region`) and the percepts' positions,
    covariances and nearest same-type objects, shared by the steps after it."""
    given = call.settings.region
    explicit = given is not None
    region = given if given is not None else default_region(call.world, call.used)
    ego = np.array([p.position for p in call.used])
    covs = percept_covariances(call.used)
    nearest = NearestObjects(call.world, [p.type for p in call.used])
    return _Context(**{f.name: getattr(call, f.name) for f in fields(_Call)}, region=region,
                    explicit_region=explicit, ego=ego, covs=covs, nearest=nearest,
                    ranges=np.array([p.range for p in call.used], dtype=np.float64),
                    sigmas=np.array([p.sigma for p in call.used], dtype=np.float64))


def _distinct_centres(world: WorldModel, pairs: Sequence[tuple[int, int]]) -> tuple[tuple[int, int], ...]:
    """One pair per distinct model position (a sphere per centre): the first of the pairs whose
    objects lie within 1e-9 m of each other (a k-d tree, not all pairs)."""
    pairs = list(pairs)
    if len(pairs) < 2:
        return tuple(sorted(pairs))
    pos = world.positions[np.array([o for _, o in pairs], dtype=np.intp)]
    keep = np.ones(len(pairs), dtype=bool)
    for i, j in sorted(cKDTree(pos).query_pairs(DUPLICATE_DISTANCE)):
        if keep[i]:
            keep[j] = False
    return tuple(sorted(p for p, k in zip(pairs, keep, strict=True) if k))


def _validated(ctx: _Context, hyps_local: list[AssociationHypothesis]) -> LocalizationResult:
    """Validate the best hypotheses by ML fits, rank and choose, then the pose of the method."""
    fits = _fit_step(ctx, hyps_local)
    distinct, hyps = _range_step(ctx, hyps_local, fits)
    incomplete = not hyps_local[0].complete
    if not distinct and fits:  # fits exist, but the range test rejected every one of them
        return ctx.failed("inconsistent", "every hypothesis fit was rejected by the range test: no "
                          "pose fits the matched percepts' ranges", hyps, incomplete)
    if not distinct:
        return ctx.failed("degenerate", "no hypothesis keeps 3 inliers whose pose information is "
                          "regular: the matched landmarks fix no 6D pose (collinear, or their "
                          "percepts constrain too few directions)", hyps, incomplete)
    best, choice = _choose_step(ctx, distinct, incomplete)
    if ctx.settings.method == "ml":
        return _finish(ctx, _widened(_ml_pose_step(ctx, best), choice), hyps, choice)
    answer = _range_only_pose_step(ctx, best)
    if answer.status_hint in ("degenerate", "degenerate_collinear"):  # no position, so no pose
        message = answer.est.message if answer.est is not None else ""
        return ctx.failed(cast(LocalizeStatus, answer.status_hint),
                          message or "the matched landmarks fix no position", hyps, choice.ambiguous)
    return _finish(ctx, _widened(answer, choice), hyps, choice)


def _widened(answer: _Answer, choice: _Choice) -> _Answer:
    """The answer with the spread of the fits at the same pose added to its covariance."""
    if choice.spread is None:
        return answer
    return replace(answer, cov6=answer.cov6 + choice.spread)


_Fits = dict[tuple[tuple[int, int], ...], tuple[PoseFit, int]]
"""Validated fits by their inlier pairs, each with the index of the hypothesis it came from."""


def _fit_step(ctx: _Context, hyps_local: list[AssociationHypothesis]) -> _Fits:
    """Step 5: ML fits of the best hypotheses (at most :data:`MAX_VALIDATED` distinct ones)."""
    t0 = time.perf_counter()
    fits: _Fits = {}
    for h_i, h in enumerate(hyps_local):
        if len(fits) >= MAX_VALIDATED:
            break
        if any(_pose_nees(f.world_from_ego, f.pose_covariance, h.world_from_ego) <= CHI2_6_GATE
               for f, _ in fits.values()):
            continue  # its pose lies inside a fit's 3-sigma ellipsoid: it would converge there
        # from the clique alone, and from the clique with the association's validated matches:
        # those were taken at the clique's pose without its uncertainty, and a wrong one (an
        # object one module over, far from a compact clique) can pull the fit away for good
        starts = (h.pairs,) if h.all_pairs == h.pairs else (h.pairs, h.all_pairs)
        for start in starts:
            fit = fit_hypothesis(ctx.world, ctx.ego, ctx.covs, ctx.nearest, start, h.world_from_ego)
            if fit is not None and fit.pairs not in fits:  # converged to the same inliers: one answer
                fits[fit.pairs] = (fit, h_i)
    ctx.timings["validation"] = time.perf_counter() - t0
    return fits


def _range_step(ctx: _Context, hyps_local: list[AssociationHypothesis], fits: _Fits
                ) -> tuple[list[tuple[PoseFit, int]], tuple[AssociationHypothesis, ...]]:
    """Step 6: the fits whose ranges meet, best first, and every hypothesis with its radial
    solution (the ranked ones first).

    Every returned hypothesis carries the radial projection of its matches' spheres (clique and
    validated percepts, :attr:`AssociationHypothesis.all_pairs`), solved by the call's
    ``solver``; with ``check=True`` the validated ones (those behind a fit, the ones the range
    test and the ranking use) are verified against vertex enumeration, the others are solved
    unchecked (the active set's answer is a certified KKT point; enumeration on every
    hypothesis would multiply the time of ``check=True``)."""
    # the card's convex problem for every validated hypothesis: the Gaussian spheres of its
    # matches (clique and validated percepts, one per distinct centre) projected
    # onto their restriction polytope; a displacement beyond the chi-square gate means ranges
    # that cannot belong to one robot position (the paper's range-consistency test)
    t0 = time.perf_counter()
    fitted = sorted({h_i for _, h_i in fits.values()})
    of_hyp = {h_i: _radial(ctx, hyps_local[h_i].all_pairs) for h_i in fitted}
    radial = {key: of_hyp[h_i] for key, (_, h_i) in fits.items()}
    ctx.timings["radial"] = time.perf_counter() - t0
    consistent = {key: v for key, v in fits.items() if _range_consistent(radial[key])}
    if len(consistent) < len(fits):
        ctx.notes.append(f"{len(fits) - len(consistent)} hypothesis fit(s) rejected: their ranges do not "
                         "meet (radial projection beyond the chi-square gate)")
    distinct = sorted(consistent.values(), key=lambda f: (f[0].cost, _radial_score(radial[f[0].pairs]),
                                                           -f[0].inliers, f[1]))
    order = [h_i for _, h_i in distinct]
    sol_of = dict(of_hyp)
    t0 = time.perf_counter()
    by_pairs = {hyps_local[i].all_pairs: sol for i, sol in sol_of.items()}
    for i, h in enumerate(hyps_local):  # the hypotheses without a fit: solved, not verified
        if i not in sol_of:
            if h.all_pairs not in by_pairs:
                by_pairs[h.all_pairs] = _radial(ctx, h.all_pairs, check=False)
            sol_of[i] = by_pairs[h.all_pairs]
    ctx.timings["radial"] += time.perf_counter() - t0
    hyps = tuple(replace(_remap(hyps_local[i], ctx.idx), radial=sol_of[i]) for i in order) + tuple(
        replace(_remap(h, ctx.idx), radial=sol_of[i]) for i, h in enumerate(hyps_local) if i not in order)
    return distinct, hyps


@dataclass(frozen=True)
class _Choice:
    """What the runners-up say about the chosen hypothesis."""

    ambiguous: bool
    alternatives: tuple[NDArray[np.float64], ...] = ()
    llr: float = math.inf  # log-likelihood ratio to the best fit at a distinct pose
    near_best_costs: tuple[float, ...] = ()
    # (6, 6) ROS order: the likelihood-weighted spread of the fits at the same pose (see
    # _same_pose), added to the pose covariance
    spread: NDArray[np.float64] | None = None


@dataclass(frozen=True)
class _Answer:
    """A pose step's pose, before the answer checks itself (:func:`_finish`)."""

    pose: NDArray[np.float64]
    cov6: NDArray[np.float64]
    pairs: tuple[tuple[int, int], ...]  # matches behind the pose (used-percept, object)
    est: ro.PositionEstimate | None = None  # the range-only position estimate, if any
    self_check: bool = True  # run the chi-square self-check of the matches
    status_hint: str = "ok"  # the position estimator's status


def _choose_step(ctx: _Context, distinct: list[tuple[PoseFit, int]], incomplete: bool
                 ) -> tuple[PoseFit, _Choice]:
    """Step 7: the best fit (inside the region when that costs little or the region is the
    caller's), its runners-up within the ambiguity margin and its log-likelihood ratio."""
    inside = [f for f in distinct if _in_region(ctx.region, f[0].world_from_ego, f[0].pose_covariance)]
    if inside and len(inside) < len(distinct):
        worse_by = inside[0][0].cost - distinct[0][0].cost
        if ctx.explicit_region or worse_by < ctx.settings.tol.ambiguity_margin:
            if inside[0] is not distinct[0]:
                ctx.notes.append(f"{len(distinct) - len(inside)} better-fitting pose(s) outside the region "
                                 "were set aside")
            distinct = inside
        else:  # the default region chooses between comparable fits, never for a far worse one
            ctx.notes.append(f"the best fit lies outside the default region; the best pose inside it fits "
                             f"worse by a robust cost of {worse_by:.3g}, so it was not preferred")
    best = distinct[0][0]
    tol = ctx.settings.tol
    same: list[PoseFit] = []
    others: list[PoseFit] = []
    for f, _ in distinct[1:]:
        (same if _same_pose(best.world_from_ego, f.world_from_ego, ctx.settings) else others).append(f)
    runners = [f for f in others if f.cost - best.cost < tol.ambiguity_margin
               and _pose_nees(best.world_from_ego, best.pose_covariance, f.world_from_ego) > CHI2_6_GATE]
    spread = _same_pose_spread(best, same)
    if spread is not None:
        ctx.notes.append(f"{len(same)} other fit(s) at the same pose (other objects of the percepts' "
                         "types nearby) widen its covariance by their likelihood-weighted spread")
    ambiguous = bool(runners) or incomplete
    if incomplete:
        ctx.notes.append("clique search truncated (max_nodes/max_cliques): the world repeats itself "
                         "around these percepts, other associations may be as good")
    if runners:
        gap = float(np.linalg.norm(runners[0].world_from_ego[:3, 3] - best.world_from_ego[:3, 3]))
        ctx.notes.append(f"association ambiguous: best robust cost {best.cost:.3g} "
                         f"({best.inliers} inliers), next {runners[0].cost:.3g} ({runners[0].inliers} "
                         f"inliers) at a pose {gap:.3g} m away")
    llr = 0.5 * (others[0].cost - best.cost) if others else math.inf
    alternatives = tuple(f.world_from_ego.copy() for f in runners)
    near_best_costs = (float(best.cost), *(float(f.cost) for f in runners))
    return best, _Choice(ambiguous, alternatives, llr, near_best_costs, spread)


def _same_pose(a: NDArray, b: NDArray, settings: _Settings) -> bool:
    """Whether two poses are one answer, as fits are that differ only in which of two
    neighbouring objects of its type a percept matched: closer than a third of the tolerances
    (``max_position_3sigma``, ``max_rotation_3sigma``; their likelihood-weighted spread then adds
    at most ``(0.71 d)^2`` to the variance, which keeps the 3-sigma bound of a sharp fit inside
    the tolerance) and than the association's ``distinct_translation`` and ``distinct_angle``
    (so lenient tolerances never merge two places into one wide answer)."""
    e = _pose_error(a, b)
    tol = settings.tol
    return bool(np.linalg.norm(e[:3]) < min(settings.pos_tol / 3.0, tol.distinct_translation)
                and np.linalg.norm(e[3:]) < min(settings.rot_tol / 3.0, tol.distinct_angle))


def _same_pose_spread(best: PoseFit, same: list[PoseFit]) -> NDArray[np.float64] | None:
    """``sum_i w_i d_i d_i^T`` over the fits at the same pose as ``best``: ``d_i`` their pose
    minus the best's (ROS order), ``w_i`` their likelihood ``exp(-cost_i / 2)`` normalised over
    them and the best.  Added to the best's covariance, the sum is the mean square error of
    reporting the best pose when the truth is one of these fits (None without such fits)."""
    if not same:
        return None
    w = np.exp(-0.5 * np.array([f.cost - best.cost for f in same]))
    w = w / (1.0 + w.sum())
    d = np.array([_pose_error(best.world_from_ego, f.world_from_ego) for f in same])
    return (d * w[:, None]).T @ d


def _ml_pose_step(ctx: _Context, best: PoseFit) -> _Answer:
    """Step 8 (``"ml"``): the validated 6D pose (or the rotation SDP's, when better) and its
    calibrated covariance."""
    pairs = best.pairs
    p_i = np.array([p for p, _ in pairs])
    centers = ctx.world.positions[np.array([o for _, o in pairs])]
    t0 = time.perf_counter()
    pose = best.world_from_ego
    if ctx.settings.certify and len(pairs) <= 4:  # few matches: the rotation SDP is a global solver
        sdp_pose, _ = solve_pose_sdp(ctx.ego[p_i], centers, ctx.covs[p_i])
        if pose_cost(sdp_pose, ctx.ego[p_i], ctx.covs[p_i], centers) < \
                pose_cost(pose, ctx.ego[p_i], ctx.covs[p_i], centers) - COST_ROUNDING:
            pose = sdp_pose
            ctx.notes.append("the rotation SDP found a better pose than the local fit")
    cov6 = calibrated_pose_covariance(pose, ctx.ego[p_i], ctx.covs[p_i], centers, best.pose_covariance)
    shared = [ctx.used[i].shared for i in p_i]
    if any(shared):  # errors common to the percepts of one view (head encoders)
        cov6 = cov6 + shared_view_covariance(pose, ctx.ego[p_i], ctx.covs[p_i], shared)
    ctx.timings["position"] = time.perf_counter() - t0
    return _Answer(pose, cov6, pairs, self_check=False)


def _range_only_pose_step(ctx: _Context, best: PoseFit) -> _Answer:
    """Step 8 (range-only methods): the position of the validated matches' Gaussian spheres,
    then the weighted rotation and the two-stage covariance (no pose when the position is
    degenerate: ``status_hint`` says so)."""
    pairs = best.pairs
    estimator = _SPHERE_ESTIMATOR[ctx.settings.method]
    sph = _sphere_position(ctx, pairs, estimator, best.world_from_ego[:3, 3], ctx.settings.rng)
    sp, s_centers, sig, est, position, status, pos_cov = sph
    if status in ("degenerate", "degenerate_collinear"):
        nan = np.full((4, 4), np.nan)
        return _Answer(nan, np.full((6, 6), np.nan), pairs, est, status_hint=status)
    t0 = time.perf_counter()
    pos_var = float(np.trace(pos_cov)) / 3.0 if np.all(np.isfinite(pos_cov)) else float(np.max(sig) ** 2)
    w = 1.0 / (sig**2 + pos_var)
    rot = weighted_rotation(ctx.ego[sp], s_centers - position, w)
    pose = transformation(rot, position)
    cov6 = rotation_only_covariance(pose, ctx.ego[sp], ctx.covs[sp], w, pos_cov)
    shared = [ctx.used[i].shared for i in sp]
    if any(shared):  # errors common to the percepts of one view (head encoders)
        cov6 = cov6 + shared_range_covariance(pose, ctx.ego[sp], ctx.covs[sp], s_centers, sig, w, shared)
    ctx.timings["orientation"] = time.perf_counter() - t0
    return _Answer(pose, cov6, pairs, est, status_hint=status)


def match_spheres(world: WorldModel, percepts: Sequence[Percept], pairs: Sequence[tuple[int, int]]
                  ) -> tuple[NDArray[np.intp], NDArray[np.intp], list[ro.GaussianSphere]]:
    """The Gaussian spheres of matched pairs ``(percept index, object index)``: one per distinct
    model position (centre = object, radius = percept range, sigma = percept sigma), sorted by
    percept; with the percept and object index of each."""
    percepts = check_world_and_percepts(world, percepts)
    return _match_spheres(world, percepts, _check_pairs(pairs, len(percepts), len(world)))


def _match_spheres(world: WorldModel, percepts: Sequence[Percept], pairs: Sequence[tuple[int, int]]
                   ) -> tuple[NDArray[np.intp], NDArray[np.intp], list[ro.GaussianSphere]]:
    sph = _distinct_centres(world, pairs)
    p_i = np.array([p for p, _ in sph], dtype=np.intp)
    o_i = np.array([o for _, o in sph], dtype=np.intp)
    spheres = ro.make_spheres(world.positions[o_i], [percepts[p].range for p in p_i],
                              [percepts[p].sigma for p in p_i]) if len(sph) else []
    return p_i, o_i, spheres


#: Most spheres radialopt's restriction polytope (active set, range-only estimators) and its
#: cvxpy formulation accept; localize keeps the most certain ones beyond that.
MAX_RADIAL_SPHERES = int(getattr(getattr(ro, "polytope", None), "MAX_POLYTOPE_SPHERES", 128))
MAX_CVXPY_SPHERES = int(getattr(getattr(ro, "formulation", None), "MAX_SPHERES", 64))


def _most_certain(ctx: _Context, p_i: NDArray[np.intp], o_i: NDArray[np.intp], spheres: list, limit: int
                  ) -> tuple[NDArray[np.intp], NDArray[np.intp], list]:
    """At most ``limit`` spheres: the smallest sigmas (ties by percept index), in percept order."""
    if len(spheres) <= limit:
        return p_i, o_i, spheres
    sig = np.array([ctx.used[p].sigma for p in p_i])
    keep = np.sort(np.lexsort((p_i, sig))[:limit])
    note = (f"{len(spheres)} matched spheres: the {limit} most certain are used for the range-only "
            "computations (radialopt's limit)")
    if note not in ctx.notes:
        ctx.notes.append(note)
    return p_i[keep], o_i[keep], [spheres[i] for i in keep]


def _check_pairs(pairs: object, n_percepts: int, n_objects: int) -> list[tuple[int, int]]:
    """``(percept, object)`` index pairs in range."""
    if pairs is None or isinstance(pairs, str | bytes):
        raise ArgumentTypeError(f"pairs must be a sequence of (percept, object) index pairs, got {pairs!r}")
    out = []
    try:
        items = list(pairs)  # type: ignore[call-overload]
    except TypeError as exc:
        raise ArgumentTypeError("pairs must be a sequence of (percept, object) index pairs, "
                                f"got {pairs!r}") from exc
    for i, pair in enumerate(items):
        try:
            p, o = pair
        except (TypeError, ValueError) as exc:
            raise ArgumentTypeError(f"pairs[{i}] must be a (percept, object) index pair, "
                                    f"got {pair!r}") from exc
        p = strict_int(f"pairs[{i}][0]", p, minimum=0, maximum=n_percepts - 1)
        o = strict_int(f"pairs[{i}][1]", o, minimum=0, maximum=n_objects - 1)
        out.append((p, o))
    return out


def _radial(ctx: _Context, pairs: Sequence[tuple[int, int]], check: bool | None = None
            ) -> ro.RadialSolution | None:
    """:func:`radialopt.project_radii` of the spheres of ``pairs`` (as :func:`match_spheres` makes
    them) with the solver asked for; None with fewer than two spheres.

    ``check`` (default: the call's ``check``) verifies the answer against vertex enumeration up
    to ``radialopt.MAX_VERTEX_SPHERES`` spheres.  The world and the percepts were checked on
    entry (:func:`check_world_and_percepts`), so the spheres' arrays go to radialopt's unchecked
    route (``radialopt.projection._project_radii_trusted``): the same answer as
    ``project_radii(match_spheres(...)[2], ...)`` without validating them again per hypothesis.
    """
    sph = _distinct_centres(ctx.world, pairs)
    if len(sph) < 2:
        return None
    p_i = np.array([p for p, _ in sph], dtype=np.intp)
    o_i = np.array([o for _, o in sph], dtype=np.intp)
    limit = MAX_RADIAL_SPHERES if ctx.settings.solver == "active_set" else MAX_CVXPY_SPHERES
    p_i, o_i, _ = _most_certain(ctx, p_i, o_i, list(sph), limit)
    check = ctx.settings.check if check is None else check
    if check and len(p_i) > ro.MAX_VERTEX_SPHERES:  # enumeration would take minutes
        check = False
        note = (f"the vertex-enumeration check ran only on hypotheses of at most {ro.MAX_VERTEX_SPHERES} "
                "spheres (radialopt.MAX_VERTEX_SPHERES); larger ones were solved unchecked")
        if note not in ctx.notes:
            ctx.notes.append(note)
    centers, radii, sigmas = ctx.world.positions[o_i], ctx.ranges[p_i], ctx.sigmas[p_i]
    if ctx.settings.solver == "active_set":
        return _project_radii_trusted(centers, radii, sigmas, method="active_set", check=check)
    return _project_radii_trusted(centers, radii, sigmas, method="cvxpy", solver=ctx.settings.solver,
                                  check=check)


def _radial_score(sol: ro.RadialSolution | None) -> float:
    """Minus twice the log density kept by the radial projection (0 when the ranges meet)."""
    return 0.0 if sol is None else float(sol.normalized_displacement) ** 2


def _range_consistent(sol: ro.RadialSolution | None, alpha: float = SIGNIFICANCE) -> bool:
    """The radial displacement is within the ``1 - alpha`` chi-square gate (n degrees of freedom)."""
    return sol is None or _radial_score(sol) <= float(chi2.ppf(1.0 - alpha, len(sol.radii)))


def _sphere_position(ctx: _Context, pairs: tuple[tuple[int, int], ...], estimator: str, t_ref: NDArray,
                     rng: np.random.Generator | None) -> tuple:
    """One Gaussian sphere per distinct matched centre and the range-only position.

    Returns the percepts used, the centres, sigmas, the estimate, the chosen position (mirror
    candidates told apart by ``t_ref``), its status and its CRLB.
    """
    t0 = time.perf_counter()
    sp, o_i, spheres = _match_spheres(ctx.world, ctx.used, pairs)
    sp, o_i, spheres = _most_certain(ctx, sp, o_i, spheres, MAX_RADIAL_SPHERES)
    centers = ctx.world.positions[o_i]
    sig = np.array([ctx.used[p].sigma for p in sp])
    est = ro.estimate_position(spheres, method=estimator, region=ctx.region, rng=rng)
    ctx.timings["position"] = time.perf_counter() - t0
    position, status = _choose_candidate(ctx, est, t_ref)
    return sp, centers, sig, est, position, status, _position_covariance(est, position, centers, sig)


def _position_covariance(est: ro.PositionEstimate, position: NDArray, centers: NDArray, sig: NDArray
                         ) -> NDArray[np.float64]:
    """The range-only CRLB at the chosen candidate (the estimator's own when it is its estimate)."""
    if np.array_equal(position, est.position):
        return est.covariance
    try:
        return ro.crlb(centers, sig, position)
    except ro.RadialError:
        return np.full((3, 3), np.inf)


def _choose_candidate(ctx: _Context, est: ro.PositionEstimate, t_ref: NDArray) -> tuple[NDArray, str]:
    """The range-only position, its mirror ambiguity resolved by the 3D pose ``t_ref``."""
    position = est.position
    if est.status in ("too_few_spheres", "degenerate_collinear") or not np.all(np.isfinite(position)):
        return position, "degenerate_collinear" if est.status == "degenerate_collinear" else "degenerate"
    cands = np.asarray(est.candidates, dtype=np.float64).reshape(-1, 3)
    dens = np.asarray(est.candidate_density, dtype=np.float64).reshape(-1)
    status = est.status
    if len(cands) > 1 and len(dens) == len(cands):
        close = cands[dens >= CANDIDATE_DENSITY_RATIO * dens.max()] if dens.max() > 0 else cands
        d = np.linalg.norm(close - t_ref, axis=1)
        order = np.argsort(d)
        if len(close) == 1 or d[order[0]] < 0.5 * d[order[1]]:
            if not np.array_equal(close[order[0]], position):
                ctx.notes.append("position candidate chosen by the validated 3D pose (mirror ambiguity)")
            position = close[order[0]]
            if status == "ambiguous":
                status = "ok"
    if status == "outside_region" and not ctx.explicit_region:
        status = "ok"
    if status != "ok":
        ctx.notes.append(est.message)
    return position, status


def _worst_3sigma(block: NDArray[np.float64]) -> float:
    """Three standard deviations along the worst axis of a finite (3, 3) covariance block."""
    return 3.0 * math.sqrt(max(float(np.linalg.eigvalsh(block)[-1]), 0.0))


def _in_region(region: ro.Region, pose: NDArray, cov6: NDArray) -> bool:
    """Whether the pose's position lies in ``region`` up to its own 3-sigma uncertainty: a robot
    standing at the region's edge is not turned away because noise put its estimate just outside."""
    block = cov6[:3, :3]
    slack = 0.0
    if np.all(np.isfinite(block)):
        slack = _worst_3sigma(block)
    return bool(region.contains(pose[:3, 3], tol=REGION_SLACK + slack))


def _finish(ctx: _Context, answer: _Answer, hyps: tuple, choice: _Choice) -> LocalizationResult:
    """Step 9: the answer checks itself (its matches' chi-square, its inliers, the region, how
    well it is determined) and is certified when asked; the result."""
    p_i = np.array([p for p, _ in answer.pairs])
    centers = ctx.world.positions[np.array([o for _, o in answer.pairs])]
    status = _self_check_step(ctx, answer, p_i, centers)
    n_inl, n_dir, rmse, residuals = _inlier_step(ctx, answer)
    ambiguous = choice.ambiguous or answer.status_hint == "ambiguous"
    status = _status_step(ctx, answer, status, n_inl, n_dir, ambiguous)
    certificate = _certificate_step(ctx, answer, p_i, centers)
    ctx.timings["total"] = time.perf_counter() - ctx.t_start
    pose, cov6 = answer.pose, answer.cov6
    return LocalizationResult(
        transformation=pose.copy(), position=pose[:3, 3].copy(), covariance=cov6[:3, :3].copy(),
        correspondences=ctx.remap(answer.pairs), hypotheses=hyps,
        ambiguous=ambiguous or status == "ambiguous",
        status=status, message="; ".join(n for n in ctx.notes if n), timings=ctx.timings,  # type: ignore[arg-type]
        position_estimate=answer.est, pose_covariance=cov6, fitness=n_inl / max(ctx.n_all, 1),
        inlier_rmse=rmse, residuals=residuals, alternatives=choice.alternatives,
        log_likelihood_ratio=choice.llr, certificate=certificate, near_best_costs=choice.near_best_costs)


def _self_check_step(ctx: _Context, answer: _Answer, p_i: NDArray, centers: NDArray) -> str:
    """``"inconsistent"`` when the matched percepts placed by the pose fail their chi-square test
    (only when ``answer.self_check``), else ``"ok"``."""
    status = "ok"
    if answer.self_check:
        passed, _, msg = self_check(answer.pose, ctx.ego[p_i], ctx.covs[p_i], centers, answer.cov6)
        if not passed:
            status = "inconsistent"
            ctx.notes.append(msg)
    return status


def _inlier_step(ctx: _Context, answer: _Answer) -> tuple[int, int, float, NDArray[np.float64]]:
    """Every percept against its nearest same-type object under the pose: the number of inliers
    (chi-square gate, 3 dof), the directions they constrain
    (:func:`~worldgraph.pose.validation.constrained_directions`: 3 per isotropic percept, 2 per
    needle), their RMS distance (m) and every percept's Mahalanobis residual."""
    pose, cov6 = answer.pose, answer.cov6
    finite_cov = np.all(np.isfinite(cov6))
    d2, obj, _ = ctx.nearest.query(pose, ctx.ego, ctx.covs, cov6 if finite_cov else None)
    inl = d2 <= CHI2_3_GATE
    pred = ctx.ego @ pose[:3, :3].T + pose[:3, 3]
    dist = np.linalg.norm(pred[inl] - ctx.world.positions[obj[inl]], axis=1) if inl.any() else np.zeros(0)
    n_inl = int(inl.sum())
    n_dir = int(constrained_directions(ctx.covs[inl]).sum())
    residuals = np.full(ctx.n_all, np.nan)
    residuals[ctx.idx] = np.sqrt(d2)
    return n_inl, n_dir, float(np.sqrt(np.mean(dist**2))) if n_inl else math.nan, residuals


def _status_step(ctx: _Context, answer: _Answer, status: str, n_inl: int, n_dir: int, ambiguous: bool
                 ) -> str:
    """The status: the self-check's, then too few inliers (``n_inl`` percepts constraining
    ``n_dir`` directions, fewer than :data:`~worldgraph.tolerances.MIN_INLIER_DIRECTIONS`), the
    estimator's, ambiguity, the region, and the 3-sigma bounds against the tolerances
    (``"weak"``), first failure wins."""
    pose, cov6 = answer.pose, answer.cov6
    if status == "ok" and n_dir < MIN_INLIER_DIRECTIONS:
        status = "inconsistent"
        ctx.notes.append(f"only {n_inl} percept(s) agree with the pose, constraining {n_dir} directions "
                         f"({MIN_INLIER_DIRECTIONS} needed: three isotropic percepts' worth; a needle-shaped "
                         "covariance constrains two)")
    if status == "ok" and answer.status_hint not in ("ok", "ambiguous"):
        # a radialopt status that localize does not know is no success
        status = answer.status_hint if answer.status_hint in LOCALIZE_STATUSES else "degenerate"
    if status == "ok" and ambiguous:
        status = "ambiguous"
    position = pose[:3, 3]
    in_region = _in_region(ctx.region, pose, cov6)
    if status == "ok" and ctx.explicit_region and not in_region:
        status = "outside_region"
        ctx.notes.append(f"the pose {position.tolist()} lies outside the valid region")
    elif not in_region:
        ctx.notes.append(f"the pose {position.tolist()} lies outside the default region")
    if status == "ok":
        if not np.all(np.isfinite(cov6)):
            status = "weak"
            ctx.notes.append("the matched landmarks do not determine the pose (infinite covariance)")
        else:
            pos3, rot3 = _worst_3sigma(cov6[:3, :3]), _worst_3sigma(cov6[3:, 3:])
            if pos3 > ctx.settings.pos_tol or rot3 > ctx.settings.rot_tol:
                status = "weak"
                ctx.notes.append(f"weakly determined: 3-sigma bounds {pos3:.3g} m (tolerance "
                                 f"{ctx.settings.pos_tol:.3g})"
                                 f" and {math.degrees(rot3):.3g} deg (tolerance "
                                 f"{math.degrees(ctx.settings.rot_tol):.3g})")
    return status


def _certificate_step(ctx: _Context, answer: _Answer, p_i: NDArray, centers: NDArray
                      ) -> ro.Certificate | None:
    """With ``certify=True``: the rotation SDP's certificate of the pose (None, with a note, when
    the match set admits none)."""
    if not ctx.settings.certify:
        return None
    certificate = None
    t0 = time.perf_counter()
    try:
        certificate = certify_pose(ctx.ego[p_i], centers, ctx.covs[p_i], answer.pose)
    except WorldGraphError as exc:  # e.g. a degenerate match set: no certificate, say why
        ctx.notes.append(f"no certificate: {exc}")
    ctx.timings["certificate"] = time.perf_counter() - t0
    return certificate


def _paper(ctx: _Context, hyps_local: list[AssociationHypothesis]) -> LocalizationResult:
    """The paper's pipeline: its association's best hypothesis, radial position, eq. 5."""
    t0 = time.perf_counter()
    hyps = tuple(replace(_remap(h, ctx.idx), radial=_radial(ctx, h.pairs + h.validated)) for h in hyps_local)
    ctx.timings["radial"] = time.perf_counter() - t0
    ambiguous = is_ambiguous(hyps_local, ctx.settings.tol) or not hyps_local[0].complete
    best = hyps_local[0]
    if ambiguous and len(hyps_local) > 1:
        second = hyps_local[1]
        gap = float(np.linalg.norm(second.world_from_ego[:3, 3] - best.world_from_ego[:3, 3]))
        ctx.notes.append(f"association ambiguous: best cost {best.cost:.3g}, next {second.cost:.3g} "
                         f"at a pose {gap:.3g} m away")
    pairs = _distinct_centres(ctx.world, best.pairs + best.validated)
    pi, centers, sig, est, position, status, pos_cov = _sphere_position(
        ctx, pairs, "paper", best.world_from_ego[:3, 3], None)
    if status in ("degenerate", "degenerate_collinear"):
        return ctx.failed(status, est.message or "the matched landmarks fix no position", hyps, ambiguous)
    t0 = time.perf_counter()
    try:
        rot, triple = _eq5_rotation(ctx.ego[pi], centers, sig)
    except PoseError as exc:  # every matched triple of percepts (or of objects) is collinear
        return ctx.failed("degenerate", f"the paper's eq. 5 needs three matched percepts that span a "
                          f"plane; percepts {[int(ctx.idx[k]) for k in pi]} (of the percepts passed in) "
                          f"give none: {exc}", hyps, ambiguous)
    pose = transformation(rot, position)
    w = np.zeros(len(pi))
    w[triple] = 1.0
    cov6 = rotation_only_covariance(pose, ctx.ego[pi], ctx.covs[pi], w, pos_cov)
    ctx.timings["orientation"] = time.perf_counter() - t0
    if status == "ambiguous":
        ambiguous = True
    alternatives = tuple(h.world_from_ego.copy() for h in hyps_local[1:2]) if ambiguous else ()
    return _finish(ctx, _Answer(pose, cov6, pairs, est, status_hint=status), hyps,
                   _Choice(ambiguous, alternatives))


def _eq5_rotation(ego: NDArray, centers: NDArray, sigmas: NDArray, limit: int = 10
                  ) -> tuple[NDArray, NDArray[np.intp]]:
    """Rotation of eq. 5 from the matched triple whose model triangle has the largest area,
    among the ``limit`` most certain matches, trying the next largest while the percept triangle
    defines no frame; and that triple.  :class:`~worldgraph.errors.PoseError` when no triple of
    the pool has both."""
    pool = np.sort(np.argsort(sigmas, kind="stable")[:limit])
    triples = np.array(list(itertools.combinations(pool.tolist(), 3)))
    a, b, c = (centers[triples[:, i]] for i in range(3))
    areas = np.linalg.norm(np.cross(b - a, c - a), axis=1)
    error: PoseError | None = None
    for k in np.argsort(-areas, kind="stable"):
        best = triples[int(k)]
        try:
            model = percept_frame(*centers[best])
            seen = percept_frame(*ego[best])
        except PoseError as exc:
            error = error or exc
            continue
        return pose_from_frames(model, seen)[:3, :3], best
    assert error is not None  # at least one triple was tried
    raise error
