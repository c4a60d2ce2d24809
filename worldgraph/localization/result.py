"""The answer of :func:`~worldgraph.localize`: :class:`LocalizationResult`, the status
literals and tuples, and the helpers of its summary and ``to_dict``."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any, Literal, get_args

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

import radialopt as ro

from ..association.hypotheses import AssociationHypothesis
from ..errors import PoseError
from ..pose.gravity import SearchKind

__all__ = [
    "FailureStatus",
    "LOCALIZE_STATUSES",
    "LocalizationResult",
    "LocalizeStatus",
    "POSE_STATUSES",
    "PoseStatus",
    "UNIQUE_STATUSES",
    "UniqueStatus",
]

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
    "inconsistent",          # the pose contradicts its own matches (chi-square self-check) or gravity
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
#: The failure statuses that keep no pose, not even for diagnosis: ``transformation``,
#: ``position`` and the covariances are NaN (``_without_pose``); the other failures
#: (``"inconsistent"``, ``"outside_region"``, ``"degenerate_coplanar"``, ``"not_converged"``)
#: keep the pose that failed.
_POSELESS_STATUSES: tuple[str, ...] = ("degenerate", "degenerate_collinear", "no_association",
                                       "too_few_percepts")


@dataclass(frozen=True)
class LocalizationResult:
    """Result of :func:`~worldgraph.localize`.

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
        (``radial``, see ``solver`` and ``check`` of :func:`~worldgraph.localize`).
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
        Half the cost difference between the best validated fit at another pose and the chosen
        pose (inf when there is none): robust costs with every percept a fit leaves unexplained
        charged as a false percept (:func:`~worldgraph.pose.validation.false_percept_costs`).
        Fits at the same pose (closer than a third of ``max_position_3sigma`` and
        ``max_rotation_3sigma``, and than ``distinct_translation`` and ``distinct_angle``: a
        percept matched to one of two neighbouring objects of its type) do not make the answer
        ambiguous: their likelihood-weighted spread is part of ``pose_covariance``.
    certificate : radialopt.Certificate or None
        With ``certify=True``: whether the pose is proven the global minimum of the ML cost of
        its matches (the rotation SDP of :mod:`worldgraph.pose.certificate`), with the proven
        lower bound and the gap.  None otherwise.
    near_best_costs : tuple of float
        Costs (twice a negative log-likelihood up to a constant, as in ``log_likelihood_ratio``)
        of the validated fits behind ``transformation`` and each of ``alternatives``, in that
        order (empty for the ``"paper"`` method and when no pose was determined); what
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


def poseless_result(status: LocalizeStatus, message: str, n: int, hyps: tuple = (),
                    timings: dict | None = None, ambiguous: bool = False) -> LocalizationResult:
    """A result without a pose: ``status`` and ``message``, NaN pose and covariances, ``n``
    NaN residuals, the hypotheses tried."""
    nan3 = np.full(3, np.nan)
    return LocalizationResult(np.full((4, 4), np.nan), nan3, np.full((3, 3), np.nan), (), hyps,
                              ambiguous, status, message, timings or {}, residuals=np.full(n, np.nan))


def _without_pose(result: LocalizationResult) -> LocalizationResult:
    """``result`` with every field that a pose determines as ``poseless_result`` leaves it (NaN
    transformation, position and covariances, NaN residuals, no inliers, no alternatives, no
    certificate); the matches, hypotheses, position estimate, message and timings stay for
    diagnosis.  What a status of ``_POSELESS_STATUSES`` gets whatever built it."""
    nan3 = np.full(3, np.nan)
    return replace(result, transformation=np.full((4, 4), np.nan), position=nan3,
                   covariance=np.full((3, 3), np.nan), pose_covariance=np.full((6, 6), np.nan),
                   ambiguous=False, fitness=0.0, inlier_rmse=math.nan,
                   residuals=np.full(len(result.residuals), np.nan), alternatives=(),
                   log_likelihood_ratio=math.inf, certificate=None, near_best_costs=())


def _worst_3sigma(block: NDArray[np.float64]) -> float:
    """Three standard deviations along the worst axis of a finite (3, 3) covariance block."""
    return 3.0 * math.sqrt(max(float(np.linalg.eigvalsh(block)[-1]), 0.0))
