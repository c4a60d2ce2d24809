"""Hypothesis validation: robust ML fits, 6D pose covariance, self-checks (paper section 2.3).

An association hypothesis (a set of percept-object pairs) is *validated* by fitting the pose
to it and asking every percept whether it agrees.  This module holds the pieces that
:func:`worldgraph.localize` uses for that, as plain functions:

* :func:`percept_covariances`: the (k, 3, 3) ego-frame covariance of each percept (its full
  covariance when known, else ``sigma^2 I``).
* :func:`ros_pose_covariance`: the 6x6 covariance in the order of ROS
  ``geometry_msgs/PoseWithCovariance`` ``(x, y, z, rx, ry, rz)`` from the Fisher information of
  :func:`~worldgraph.pose.refine_pose` (order ``(dtheta, dt)``).  Error convention: translation
  ``t_true - t_est`` in world axes, rotation the rotation vector of ``R_true @ R_est.T`` (world
  axes).  Flipping the sign of both errors leaves the covariance unchanged, so it is the
  inverse information up to the reordering.
* :func:`placed_mahalanobis`: the squared Mahalanobis distance of each percept, placed in the
  world by a pose, from a model point, with covariance ``R C R^T + H Sigma H^T`` (percept noise
  plus the pose's own uncertainty, ``H = [-I, skew(R x)]`` in ROS order).
* :func:`fit_hypothesis`: iteratively re-weighted ML fit of a hypothesis: the ML pose of its
  inliers, then every percept re-associated to its nearest same-type object by Mahalanobis
  distance, inliers inside the chi-square gate, until the inlier set is stable.  Its robust
  cost ``sum_p min(d_p^2, gate)`` is minus twice the log-likelihood of an inlier/outlier
  mixture up to a constant, so cost differences are log-likelihood ratios.
* :func:`laplace_inflate`: where the linearised covariance is poor (weak rotation about a
  nearly collinear or flat landmark set) the cost is evaluated along the profile line of the
  weakest rotation and position directions at +-3 sigma; where it rises less than the quadratic
  model's 9 the variance along that line is widened to where it really reaches 9 (a Laplace fit
  along the weak direction).
* :func:`rotation_only_covariance`: the 6x6 covariance of the range-only methods (position from
  the Gaussian spheres, then the rotation fitted with the translation fixed), by the sandwich
  formula of that two-stage estimator.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation
from scipy.stats import chi2

from perception import OBJECT_VIEW, Percept

from .._checks import as_list, integer, percept_list, real_array, real_scalar
from .._rigid import rigid_transform
from ..errors import PoseError, WorldGraphError
from ..model import WorldModel
from ..tolerances import (
    CONSTRAINED_VARIANCE_RATIO,
    INFORMATION_SYMMETRY_RTOL,
    PSD_RTOL,
    QUERY_FLOOR,
    QUERY_WIDEN,
    RANK_RTOL,
    RISE_FLOOR,
    SIGNIFICANCE,
    TINY,
)
from .frames import (
    MAX_POSE_COORDINATE,
    _covariances,
    _expm,
    _logm,
    _points,
    _refine_pose,
    _skew,
    pose_information,
)
from .gravity import TiltPrior, _check_tilt_prior

__all__ = [
    "CHI2_3_GATE",
    "CHI2_6_GATE",
    "FALSE_PERCEPT_RATE",
    "MIN_FALSE_PERCEPT_RANGE",
    "NearestObjects",
    "PoseFit",
    "Refinement",
    "calibrated_pose_covariance",
    "constrained_directions",
    "curved_pose_covariance",
    "fit_hypothesis",
    "false_percept_costs",
    "laplace_inflate",
    "percept_covariances",
    "placed_mahalanobis",
    "pose_cost",
    "rotation_only_covariance",
    "ros_pose_covariance",
    "self_check",
    "shared_view_covariance",
]

#: 3-sigma gate (probability 0.9973) of the squared Mahalanobis distance of one 3D percept.
CHI2_3_GATE = float(chi2.ppf(0.9973002039, 3))
#: 3-sigma gate of a 6D pose error ``e^T C^-1 e``.
CHI2_6_GATE = float(chi2.ppf(0.9973002039, 6))
#: Reorders the ``(dtheta, dt)`` parameters of :func:`~worldgraph.pose.pose_information` to
#: ROS ``(x, y, z, rx, ry, rz)``.
_ROS = np.array([3, 4, 5, 0, 1, 2])


_ABSENT = object()  # world_points not taken by the caller (None is an invalid value, not "absent")


@overload
def _inputs(world_from_ego: Any, ego: Any, covs: Any, world_points: Any,
            pose_name: str = ...) -> tuple[NDArray, NDArray, NDArray, NDArray]: ...
@overload
def _inputs(world_from_ego: Any, ego: Any, covs: Any, *,
            pose_name: str = ...) -> tuple[NDArray, NDArray, NDArray, None]: ...
def _inputs(world_from_ego: Any, ego: Any, covs: Any, world_points: Any = _ABSENT,
            pose_name: str = "world_from_ego") -> tuple[NDArray, NDArray, NDArray, NDArray | None]:
    """Validated ``(world_from_ego (4, 4) rigid, ego (k, 3), covs (k, 3, 3) SPD, world_points (k, 3))``."""
    T = rigid_transform(pose_name, world_from_ego, max_translation=MAX_POSE_COORDINATE)
    x = _points("ego", ego)
    C = _covariances(covs, len(x), "covs", "ego")
    y = None if world_points is _ABSENT else _points("world_points", world_points, len(x), "ego")
    return T, x, C, y


def _matrix_or_unknown(name: str, value: object, n: int) -> NDArray[np.float64]:
    """A real (n, n) matrix; NaN/inf entries are allowed (they mean "unknown")."""
    if value is None or isinstance(value, str | bytes):
        raise WorldGraphError(f"{name} must be a ({n}, {n}) real array, got {value!r}")
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError) as exc:
        raise WorldGraphError(f"{name} must be a ({n}, {n}) real array") from exc
    if arr.dtype.kind not in "fiu" or arr.shape != (n, n):
        raise WorldGraphError(f"{name} must be a ({n}, {n}) real array, got dtype {arr.dtype} shape "
                              f"{arr.shape}")
    return arr.astype(np.float64)


def _covariance_or_unknown(name: str, value: object, n: int) -> NDArray[np.float64]:
    """A real (n, n) covariance: symmetric positive semi-definite when finite (non-finite entries
    mean "unknown" and are passed through)."""
    arr = _matrix_or_unknown(name, value, n)
    if np.all(np.isfinite(arr)):
        scale = max(float(np.abs(arr).max()), TINY)
        if np.abs(arr - arr.T).max() > INFORMATION_SYMMETRY_RTOL * scale:
            raise PoseError(f"{name} must be symmetric, got {arr.tolist()}")
        low = float(np.linalg.eigvalsh(0.5 * (arr + arr.T))[0])
        if low < -PSD_RTOL * scale:
            raise PoseError(f"{name} must be positive semi-definite (smallest eigenvalue {low:.3g})")
    return arr


def percept_covariances(percepts: list[Percept]) -> NDArray[np.float64]:
    """``(k, 3, 3)`` ego-frame covariances (m^2): ``covariance`` when given, else ``sigma^2 I``."""
    percepts = percept_list("percepts", percepts)
    out = np.empty((len(percepts), 3, 3))
    for k, p in enumerate(percepts):
        if p.covariance is None and not p.sigma < 1e150:
            raise WorldGraphError(f"percepts[{k}].sigma = {p.sigma!r} m: its variance sigma^2 overflows")
        out[k] = p.covariance if p.covariance is not None else p.sigma**2 * np.eye(3)
    return out


def constrained_directions(covs: NDArray[np.float64]) -> NDArray[np.intp]:
    """How many directions each percept constrains, ``(k,)`` from its ``(k, 3, 3)`` covariance.

    The eigen-directions whose variance is at most
    :data:`~worldgraph.tolerances.CONSTRAINED_VARIANCE_RATIO` times the percept's smallest
    variance (3 for an isotropic or a stereo-shaped percept, 2 for a needle, 1 for a pancake).
    The inlier count of an answer sums these rather than counting percepts: a needle agrees
    with any pose that puts its object anywhere along its long axis, so it checks a pose in two
    directions only.
    """
    C = real_array("covs", covs, (None, 3, 3))
    C = _covariances(C, len(C), "covs")
    if not len(C):
        return np.zeros(0, dtype=np.intp)
    ev = np.linalg.eigvalsh(0.5 * (C + np.swapaxes(C, 1, 2)))
    return np.sum(ev <= CONSTRAINED_VARIANCE_RATIO * ev[:, :1], axis=1).astype(np.intp)


def ros_pose_covariance(information: NDArray[np.float64]) -> NDArray[np.float64]:
    """6x6 covariance in ROS order from the ``(dtheta, dt)`` Fisher information.

    Raises
    ------
    PoseError
        The information is singular (the landmarks do not fix a 6D pose).
    """
    J = real_array("information", information, (6, 6))
    if np.abs(J - J.T).max() > INFORMATION_SYMMETRY_RTOL * max(np.abs(J).max(), TINY):
        raise PoseError(f"information must be symmetric, got {J.tolist()}")
    w, V = np.linalg.eigh(0.5 * (J + J.T))
    if not np.all(np.isfinite(w)) or w[0] <= RANK_RTOL * max(w[-1], TINY):
        raise PoseError("the pose information is singular: the matched landmarks do not fix a 6D pose")
    cov = (V / w) @ V.T
    cov = 0.5 * (cov + cov.T)
    return cov[np.ix_(_ROS, _ROS)]


def _placement_jacobian(world_from_ego: NDArray, ego: NDArray) -> NDArray[np.float64]:
    """``(k, 3, 6)`` derivative of a placed percept's residual by the ROS-order pose error."""
    Rx = ego @ world_from_ego[:3, :3].T
    return np.concatenate([np.broadcast_to(-np.eye(3), (len(ego), 3, 3)), _skew(Rx)], axis=2)


def placed_mahalanobis(world_from_ego: NDArray, ego: NDArray, covs: NDArray, world_points: NDArray,
                       pose_covariance: NDArray | None = None) -> NDArray[np.float64]:
    """Squared Mahalanobis distance of each percept, placed by the pose, from its model point.

    ``ego (k, 3)``, ``covs (k, 3, 3)`` (ego frame), ``world_points (k, 3)``; the residual
    covariance is ``R C R^T`` plus, when ``pose_covariance`` (ROS order) is given, the pose's
    own uncertainty ``H Sigma H^T`` (ignored when it is not finite).
    """
    world_from_ego, ego, covs, world_points = _inputs(world_from_ego, ego, covs, world_points)
    if pose_covariance is not None:
        pose_covariance = _matrix_or_unknown("pose_covariance", pose_covariance, 6)
    R = world_from_ego[:3, :3]
    r = ego @ R.T + world_from_ego[:3, 3] - world_points
    S = np.einsum("ij,kjl,ml->kim", R, covs, R)
    if pose_covariance is not None and np.all(np.isfinite(pose_covariance)):
        H = _placement_jacobian(world_from_ego, ego)
        S = S + np.einsum("kai,ij,kbj->kab", H, pose_covariance, H)
    try:
        return np.einsum("ka,ka->k", r, np.linalg.solve(S, r[..., None])[..., 0])
    except np.linalg.LinAlgError as exc:
        raise PoseError("placed_mahalanobis: a residual covariance is singular (pose_covariance not "
                        "positive semi-definite?)") from exc


def pose_cost(world_from_ego: NDArray, ego: NDArray, covs: NDArray, world_points: NDArray) -> float:
    """ML cost ``sum_i r_i^T C_i^-1 r_i``, ego-frame residual ``r_i = x_i - R^T (X_i - t)``."""
    world_from_ego, ego, covs, world_points = _inputs(world_from_ego, ego, covs, world_points)
    return _pose_cost(world_from_ego, ego, covs, world_points)


def _pose_cost(world_from_ego: NDArray, ego: NDArray, covs: NDArray, world_points: NDArray) -> float:
    R, t = world_from_ego[:3, :3], world_from_ego[:3, 3]
    r = ego - (world_points - t) @ R
    return float(np.einsum("ka,ka->", r, np.linalg.solve(covs, r[..., None])[..., 0]))


def pose_difference(reference: NDArray, other: NDArray) -> NDArray[np.float64]:
    """``other - reference`` in ROS order: translation, then the rotation vector of
    ``R_other R_reference^T`` (the convention of every ``pose_covariance``)."""
    return np.concatenate([other[:3, 3] - reference[:3, 3], _logm(other[:3, :3] @ reference[:3, :3].T)])


def pose_nees(pose: NDArray, covariance: NDArray | None, other: NDArray) -> float:
    """``e^T C^-1 e`` of ``other`` against ``pose`` and its covariance ``C`` (ROS order; inf
    without a covariance or with a singular one): a pose inside another's 3-sigma ellipsoid
    is the same answer, not an ambiguity."""
    if covariance is None:
        return math.inf
    e = pose_difference(pose, other)
    try:
        return float(e @ np.linalg.solve(covariance, e))
    except np.linalg.LinAlgError:
        return math.inf


@dataclass(frozen=True)
class PoseFit:
    """The validated ML fit of one hypothesis.

    Attributes
    ----------
    world_from_ego : (4, 4) float
    information : (6, 6) float
        Fisher information, ``(dtheta, dt)`` order (:func:`~worldgraph.pose.pose_information`).
    pose_covariance : (6, 6) float
        ROS order, :func:`ros_pose_covariance` (inf when the inliers fix no pose).
    pairs : tuple of (percept, object)
        The inliers the pose was fitted to (indices into the fitted percepts and the world).
    mahalanobis2 : (k,) float
        Squared Mahalanobis distance of every percept from its nearest same-type object under
        the pose.
    nearest : (k,) int
        That object, or -1.
    cost : float
        Robust cost ``sum_p min(mahalanobis2_p, CHI2_3_GATE)``.
    """

    world_from_ego: NDArray[np.float64]
    information: NDArray[np.float64]
    pose_covariance: NDArray[np.float64]
    pairs: tuple[tuple[int, int], ...]
    mahalanobis2: NDArray[np.float64]
    nearest: NDArray[np.intp]
    cost: float

    @property
    def inliers(self) -> int:
        """Number of (percept, object) pairs in the fit."""
        return len(self.pairs)


#: :class:`NearestObjects` compares a percept with every object of its type when the type has at
#: most this many objects (a kitchen's doors or handles): cheaper than the k-d tree's queries
#: and the ball queries that make them exact; more objects go through the tree.
BRUTE_FORCE_OBJECTS = 256


class NearestObjects:
    """Nearest same-type model objects by Mahalanobis distance (k-d tree per type, ``k`` candidates)."""

    def __init__(self, world: WorldModel, types: list[str], k: int = 4) -> None:
        if not isinstance(world, WorldModel):
            raise WorldGraphError(f"world must be a WorldModel, got {type(world).__name__}")
        types = as_list("types", types, "type names")
        for i, t in enumerate(types):
            if not isinstance(t, str) or t not in world.type_index:
                raise WorldGraphError(f"types[{i}] = {t!r} is not a type of the world model")
        k = integer("k", k, minimum=1, maximum=1000)
        self.world = world
        self.k = k
        self.groups = {t: np.array([i for i, s in enumerate(types) if s == t]) for t in sorted(set(types))}
        self.objects = {t: world.type_index[t] for t in self.groups}
        self.trees = {t: world.type_tree(t) for t in self.objects}  # kept with the world
        # a type with few objects is searched by brute force (exact, no tree or ball queries)
        self.points = {t: world.positions[o] for t, o in self.objects.items()
                       if len(o) <= BRUTE_FORCE_OBJECTS}

    def query(self, world_from_ego: NDArray, ego: NDArray, covs: NDArray, pose_covariance: NDArray | None
              ) -> tuple[NDArray[np.float64], NDArray[np.intp], NDArray[np.float64]]:
        """``(d2, object, d2 of the runner-up object)`` of every percept, ``(k,)`` each; ``inf``
        (object -1) where no object of the type exists.  Exact over all objects of the type for
        any covariance (:func:`placed_mahalanobis`' covariance ``S``, computed once): the ``k``
        Euclidean nearest objects are the first candidates, and since ``r^T S^-1 r >= |r|^2 /
        lambda_max(S)``, every object that could beat the runner-up among them lies within
        ``sqrt(d2_runner_up * lambda_max(S))`` of the placed percept; a ball query of that radius
        adds them where it reaches beyond the ``k`` nearest (a needle-shaped covariance: the
        nearest object by Mahalanobis distance may lie far along the needle)."""
        n = len(ego)
        d2 = np.full(n, np.inf)
        second = np.full(n, np.inf)
        obj = np.full(n, -1, dtype=np.intp)
        R = world_from_ego[:3, :3]
        pred = ego @ R.T + world_from_ego[:3, 3]
        S = np.einsum("ij,kjl,ml->kim", R, covs, R)
        if pose_covariance is not None and np.all(np.isfinite(pose_covariance)):
            H = _placement_jacobian(world_from_ego, ego)
            S = S + np.einsum("kai,ij,kbj->kab", H, pose_covariance, H)
        S_inv = np.linalg.inv(S)
        for t, idx in self.groups.items():
            objs = self.objects[t]
            if t in self.points:  # every object of the type
                r = self.points[t][None, :, :] - pred[idx][:, None, :]
                m2 = np.einsum("mca,mab,mcb->mc", r, S_inv[idx], r)
                order = np.argsort(m2, axis=1, kind="stable")
                rows = np.arange(len(idx))
                d2[idx], obj[idx] = m2[rows, order[:, 0]], objs[order[:, 0]]
                if min(self.k, len(objs)) > 1:  # as the tree's candidates: a runner-up from k >= 2
                    second[idx] = m2[rows, order[:, 1]]
                continue
            kk = min(self.k, len(objs))
            tree = self.trees[t]
            dist, j = tree.query(pred[idx], k=kk)
            cand = objs[np.asarray(j).reshape(len(idx), kk)]
            r = self.world.positions[cand] - pred[idx][:, None, :]
            m2 = np.einsum("mca,mab,mcb->mc", r, S_inv[idx], r)
            order = np.argsort(m2, axis=1)
            rows = np.arange(len(idx))
            d2[idx] = m2[rows, order[:, 0]]
            obj[idx] = cand[rows, order[:, 0]]
            if kk > 1:
                second[idx] = m2[rows, order[:, 1]]
            if kk == len(objs):
                continue  # every object of the type was a candidate
            bound = m2[rows, order[:, min(1, kk - 1)]]
            reach = np.sqrt(bound * np.linalg.eigvalsh(S[idx])[:, -1]) * (1.0 + QUERY_WIDEN) + QUERY_FLOOR
            kth = np.asarray(dist).reshape(len(idx), kk)[:, -1]
            for m in np.flatnonzero(reach > kth):
                more = objs[np.asarray(tree.query_ball_point(pred[idx[m]], reach[m]), dtype=np.intp)]
                rm = self.world.positions[more] - pred[idx[m]]
                mm = np.einsum("ca,ab,cb->c", rm, S_inv[idx[m]], rm)
                top = np.argsort(mm, kind="stable")[:2]
                d2[idx[m]], obj[idx[m]] = mm[top[0]], more[top[0]]
                if kk > 1:
                    second[idx[m]] = mm[top[1]]
        return d2, obj, second


#: A percept whose second-nearest object of its type is also inside the gate still counts as an
#: inlier of its nearest when the second is farther by more than this squared Mahalanobis
#: distance: twice the log of a likelihood ratio of 100, so the nearest is at least 100 times as
#: likely (kitchen, 150 views: 7 instead of 12 "weak" answers, the same 2 NEES outliers).
UNIQUE_MARGIN = 2.0 * math.log(100.0)


def _unique_inliers(d2: NDArray, obj: NDArray, second: NDArray, gate: float) -> tuple[tuple[int, int], ...]:
    """Percepts inside the gate whose object is the only one of its type inside it, or at least
    :data:`UNIQUE_MARGIN` nearer than the second; one percept per object (the closest wins),
    sorted by percept.  A percept halfway between two objects of its type (knobs in a row)
    tells nothing certain and would bias the pose: it is left out."""
    taken: dict[int, int] = {}
    for p in np.argsort(d2, kind="stable"):
        if d2[p] > gate or obj[p] < 0:
            break
        clear = second[p] > gate or second[p] - d2[p] > UNIQUE_MARGIN
        if clear and int(obj[p]) not in taken:
            taken[int(obj[p])] = int(p)
    return tuple(sorted((p, o) for o, p in taken.items()))


#: :func:`false_percept_costs` takes this as the chance that a percept is false: an upper bound
#: (a recogniser that is wrong half the time), so that a pose explaining fewer percepts is charged
#: the least its unexplained percepts can cost.
FALSE_PERCEPT_RATE = 0.5
#: ... and a false percept to lie anywhere within the farthest percept's range of the head, at
#: least this (m).
MIN_FALSE_PERCEPT_RANGE = 1.0


def false_percept_costs(ego: ArrayLike, covs: ArrayLike, gate: float = CHI2_3_GATE) -> NDArray[np.float64]:
    """What leaving each percept unexplained costs a pose beyond the robust cost's cap ``gate``.

    The robust cost of a fit (:attr:`PoseFit.cost`) charges a percept that no object of its type
    explains the same ``gate`` whatever its covariance.  As twice a negative log-likelihood of a
    mixture -- a percept is true with probability ``1 - eps`` (a normal density about its object,
    its covariance ``C``) or false with probability ``eps`` (uniform over the ball of volume ``V``
    the percepts were seen in) -- leaving it unexplained costs ``2 log(V / eps) + 2 log(1 - eps)
    - 3 log(2 pi) - log det C`` more than explaining it exactly, far above ``gate`` for a percept
    known to a few centimetres.  Returned is that excess over ``gate`` (never negative), with
    ``eps`` = :data:`FALSE_PERCEPT_RATE` and ``V`` the ball through the farthest percept (at least
    :data:`MIN_FALSE_PERCEPT_RANGE`): a pose that explains fewer percepts than another is then a
    rival only when its missing percepts are likely enough to be false.

    Parameters
    ----------
    ego : (k, 3) float
        Percept positions (ego frame, m).
    covs : (k, 3, 3) float
        Their covariances (m^2).
    gate : float
        The robust cost's cap (default :data:`CHI2_3_GATE`).

    Returns
    -------
    (k,) float
        Zero for a percept whose covariance is so wide (a needle, a far stereo point) that the cap
        already charges it as much.
    """
    x = real_array("ego", ego, (None, 3))
    c = real_array("covs", covs, (len(x), 3, 3))
    gate = real_scalar("gate", gate, positive=True)
    if len(x) == 0:
        return np.zeros(0)
    r = max(float(np.linalg.norm(x, axis=1).max()), MIN_FALSE_PERCEPT_RANGE)
    volume = 4.0 / 3.0 * math.pi * r**3
    eps = FALSE_PERCEPT_RATE
    sign, logdet = np.linalg.slogdet(c)
    logdet = np.where(sign > 0, logdet, np.inf)  # a singular covariance: no density to compare
    normal = 3.0 * math.log(2.0 * math.pi) + logdet  # -2 log of a normal density's peak, less 0
    excess = 2.0 * math.log(volume / eps) + 2.0 * math.log1p(-eps) - normal - gate
    return np.maximum(excess, 0.0)


#: What :func:`fit_hypothesis` keeps of one refinement of an inlier set, for its ``memo``: the
#: fit and the inliers it re-associates (None: the set fixes no pose).
Refinement = tuple[PoseFit, tuple[tuple[int, int], ...]] | None


def fit_hypothesis(world: WorldModel, ego: NDArray, covs: NDArray, nearest: NearestObjects,
                   pairs: tuple[tuple[int, int], ...], start: NDArray, max_rounds: int = 4,
                   gate: float = CHI2_3_GATE, *,
                   memo: dict[tuple[tuple[int, int], ...], Refinement] | None = None) -> PoseFit | None:
    """ML pose of ``pairs`` from ``start``, then re-associated inliers until stable.

    Returns None when fewer than three inliers remain or they fix no pose.

    ``memo`` (a dict shared by the calls of one localisation: the same world, percepts,
    covariances, nearest-object index and gate) holds every inlier set refined so far; a set
    refined before is not refined again, its first refinement is reused.  The fits of one
    localisation's hypotheses mostly converge to a few inlier sets, each refined once: the pose
    of a reused refinement was started elsewhere and differs from a fresh one by the
    refinement's own convergence (about 1e-7).
    """
    if not isinstance(world, WorldModel):
        raise WorldGraphError(f"world must be a WorldModel, got {type(world).__name__}")
    if not isinstance(nearest, NearestObjects):
        raise WorldGraphError(f"nearest must be a NearestObjects, got {type(nearest).__name__}")
    if memo is not None and not isinstance(memo, dict):
        raise WorldGraphError(f"memo must be None or a dict, got {type(memo).__name__}")
    T, ego, covs, _ = _inputs(start, ego, covs, pose_name="start")
    max_rounds = integer("max_rounds", max_rounds, minimum=1, maximum=1000)
    gate = real_scalar("gate", gate, positive=True)
    try:
        pairs = tuple((int(p), int(o)) for p, o in pairs)
    except (TypeError, ValueError) as exc:
        raise WorldGraphError(f"pairs must be (percept, object) index pairs, got {pairs!r:.200}") from exc
    for i, (p, o) in enumerate(pairs):
        if not (0 <= p < len(ego) and 0 <= o < len(world)):
            raise WorldGraphError(f"pairs[{i}] = {(p, o)} is out of range ({len(ego)} percepts, "
                                  f"{len(world)} objects)")
    current = tuple(sorted(pairs))
    fit: PoseFit | None = None
    for _ in range(max_rounds):
        if len(current) < 3:
            break
        if memo is not None and current in memo:
            done = memo[current]
        else:
            done = _refinement(world, ego, covs, nearest, current, T, gate)
            if memo is not None:
                memo[current] = done
        if done is None:
            break
        fit, new = done
        T = fit.world_from_ego
        if new == current or len(new) < 3:
            break
        current = new
    return fit


def _refinement(world: WorldModel, ego: NDArray, covs: NDArray, nearest: NearestObjects,
                current: tuple[tuple[int, int], ...], start: NDArray, gate: float) -> Refinement:
    """One round of :func:`fit_hypothesis`: the ML pose of the inlier set ``current`` from
    ``start`` and the inliers re-associated under it (None when the set fixes no pose)."""
    p_rows = np.array([a for a, _ in current])
    o_rows = np.array([b for _, b in current])
    try:
        T_new, info = _refine_pose(ego[p_rows], world.positions[o_rows], covs[p_rows], start)
        cov6 = ros_pose_covariance(info)
    except PoseError:
        return None
    d2, obj, second = nearest.query(T_new, ego, covs, cov6)
    fit = PoseFit(T_new, info, cov6, current, d2, obj, float(np.minimum(d2, gate).sum()))
    return fit, _unique_inliers(d2, obj, second, gate)


def laplace_inflate(world_from_ego: NDArray, ego: NDArray, covs: NDArray, world_points: NDArray,
                    pose_covariance: NDArray, n_sigma: float = 3.0, rounds: int = 4, *,
                    tilt_prior: TiltPrior | None = None) -> NDArray[np.float64]:
    """Widen ``pose_covariance`` (ROS order) where the cost is flatter than its quadratic model.

    For the weakest rotation direction ``u`` (largest eigenvalue of the rotation block) and the
    weakest position direction, the pose is moved along the profile line of ``f = u^T e``
    (``delta = Sigma a f / (a^T Sigma a)``: the other parameters at their conditional optimum) to
    ``f = +-n_sigma sigma_f``.  The quadratic model says the ML cost rises by ``n_sigma^2``;
    where it rises by less on the worse side, the point where it does reach ``n_sigma^2`` is
    found by secant steps and the variance of ``f`` set to ``(f / n_sigma)^2`` by a rank-one
    update that keeps the correlations.  Never narrows.  With ``tilt_prior`` the cost is that of
    the data and the prior (the covariance of a fit with the prior).
    """
    world_from_ego, ego, covs, world_points = _inputs(world_from_ego, ego, covs, world_points)
    n_sigma = real_scalar("n_sigma", n_sigma, positive=True, maximum=1e3)
    rounds = integer("rounds", rounds, minimum=0, maximum=1000)
    cov = _covariance_or_unknown("pose_covariance", pose_covariance, 6).copy()
    return _laplace_inflate(world_from_ego, ego, covs, world_points, cov, n_sigma, rounds,
                            _check_tilt_prior(tilt_prior))


def _laplace_inflate(world_from_ego: NDArray, ego: NDArray, covs: NDArray, world_points: NDArray,
                     cov: NDArray, n_sigma: float, rounds: int, tilt_prior: TiltPrior | None = None
                     ) -> NDArray[np.float64]:
    if not np.all(np.isfinite(cov)):
        return cov

    def _cost(pose: NDArray) -> float:
        prior = tilt_prior.cost(pose[:3, :3]) if tilt_prior is not None else 0.0
        return _pose_cost(pose, ego, covs, world_points) + prior

    base = _cost(world_from_ego)
    target = n_sigma**2

    def moved(delta: NDArray) -> NDArray:
        # delta in ROS order is the error (true - est); the true pose is est moved by it
        out = np.eye(4)
        out[:3, :3] = _expm(delta[3:]) @ world_from_ego[:3, :3]
        out[:3, 3] = world_from_ego[:3, 3] + delta[:3]
        return out

    for block in (slice(3, 6), slice(0, 3)):
        w, V = np.linalg.eigh(cov[block, block])
        a = np.zeros(6)
        a[block] = V[:, -1]
        var_f = float(a @ cov @ a)
        if not var_f > 0:
            continue
        line = cov @ a / var_f          # delta per unit of f
        s = n_sigma * math.sqrt(var_f)
        rises = []
        for sign in (1.0, -1.0):
            rise = _cost(moved(sign * s * line)) - base
            rises.append((rise, sign))
        rise, sign = min(rises)
        if rise >= 0.8 * target:
            continue
        f = s
        for _ in range(rounds):  # secant in f^2 (rise ~ c f^2 locally)
            f = f * math.sqrt(target / max(rise, RISE_FLOOR * target))
            f = min(f, 100.0 * s)
            rise = _cost(moved(sign * f * line)) - base
            if abs(rise - target) < 0.1 * target:
                break
        new_var = max((f / n_sigma) ** 2, var_f)
        b = cov @ a
        cov = cov + (new_var - var_f) * np.outer(b, b) / var_f**2
    return 0.5 * (cov + cov.T)


#: Gauss-Hermite cubature in 6D, 3 nodes per axis (exact for polynomials of degree 5 in each
#: coordinate, so for the fourth moments of the curved term below): nodes (729, 6), weights (729,).
_GH_NODES = np.array(np.meshgrid(*([np.array([-math.sqrt(3.0), 0.0, math.sqrt(3.0)])] * 6),
                                 indexing="ij")).reshape(6, -1).T
_GH_WEIGHTS = np.prod(np.where(_GH_NODES == 0.0, 2.0 / 3.0, 1.0 / 6.0), axis=1)
#: Above this rotation standard deviation (rad) the error is not propagated through the curve.
MAX_CURVED_ROTATION_SD = 0.35
#: A fixed standard-normal sample (6D) for the tail share of a curved error, and that share.
_TAIL_SAMPLE = np.random.default_rng(20261130).standard_normal((8192, 6))
_TAIL_SHARE = 0.9973002039


def curved_pose_covariance(world_from_ego: NDArray, ego: NDArray, covs: NDArray, pose_covariance: NDArray
                           ) -> NDArray[np.float64]:
    """The second-moment matrix of the ROS-order pose error, with the curvature of a rotation
    about the landmarks' centre (sigma points).

    A pose fitted to landmarks is known linearly in the landmarks' own frame: the world position
    ``X_c`` of their (information-weighted) centre and the rotation.  The robot position is
    ``t = X_c - R c`` with ``c`` the centre in the ego frame, so a rotation error ``theta`` about
    the centre moves the robot along a circle of radius ``|c|``: ``e_t = e_c - (exp(theta) - I)
    R c``, which is second order in ``theta`` and large where the rotation is weak (a row of
    handles seen from a few metres).  The linear covariance is moved to ``(e_c, theta)``
    (``e_c = e_t - skew(R c) theta``), and ``E[e e^T]`` of the exact error is integrated by
    Gauss-Hermite cubature (3^6 nodes).  Where the rotation is well determined this equals the
    linear covariance to within a fraction of a percent.  Where the rotation is not determined
    at all (standard deviation above :data:`MAX_CURVED_ROTATION_SD`) the linear covariance is
    returned unchanged: no Gaussian describes such an error, and ``localize`` calls it weak.
    """
    world_from_ego, ego, covs, _ = _inputs(world_from_ego, ego, covs)
    cov = _covariance_or_unknown("pose_covariance", pose_covariance, 6)
    try:
        return _curved(world_from_ego, ego, covs, cov)
    except np.linalg.LinAlgError as exc:
        raise PoseError("pose_covariance is singular: the curved covariance is not defined") from exc


def _curved(world_from_ego: NDArray, ego: NDArray, covs: NDArray, cov: NDArray) -> NDArray[np.float64]:
    if not np.all(np.isfinite(cov)) or np.linalg.eigvalsh(cov[3:, 3:])[-1] > MAX_CURVED_ROTATION_SD**2:
        return cov
    # the centre about which rotation and position decouple: skew(v) = Sigma_t,theta Sigma_theta^-1
    # (least squares over the 9 entries; for isotropic percepts the weighted centroid)
    try:
        K = cov[:3, 3:] @ np.linalg.inv(cov[3:, 3:])
        v = 0.5 * np.array([K[2, 1] - K[1, 2], K[0, 2] - K[2, 0], K[1, 0] - K[0, 1]])
    except np.linalg.LinAlgError:
        w = 1.0 / np.trace(covs, axis1=1, axis2=2)
        v = (w / w.sum()) @ ego @ world_from_ego[:3, :3].T
    A = np.eye(6)
    A[:3, 3:] = -_skew(v)
    cov_c = A @ cov @ A.T
    vals, vecs = np.linalg.eigh(0.5 * (cov_c + cov_c.T))
    root = vecs * np.sqrt(np.clip(vals, 0.0, None))
    pts = _GH_NODES @ root.T                                   # (729, 6): (e_c, theta) samples
    theta = pts[:, 3:]
    turned = Rotation.from_rotvec(theta).apply(v) - v          # (exp(theta) - I) v
    err = np.concatenate([pts[:, :3] - turned, theta], axis=1)
    second = np.einsum("k,ki,kj->ij", _GH_WEIGHTS, err, err)
    second = 0.5 * (second + second.T)
    # a curved error is not elliptical: where the curvature matters, widen the ellipsoid until its
    # 3-sigma gate holds the 3-sigma share of the propagated distribution (a fixed normal sample)
    try:
        L = np.linalg.cholesky(cov + TINY * np.eye(6))
    except np.linalg.LinAlgError as exc:
        raise PoseError("pose_covariance must be positive definite for the curved covariance") from exc
    ratio = np.linalg.eigvalsh(np.linalg.solve(L, np.linalg.solve(L, second).T))  # of L^-1 S L^-T
    if np.max(np.abs(ratio - 1.0)) > 0.01:
        pts = _TAIL_SAMPLE @ root.T
        turned = Rotation.from_rotvec(pts[:, 3:]).apply(v) - v
        err = np.concatenate([pts[:, :3] - turned, pts[:, 3:]], axis=1)
        q = np.einsum("ki,ki->k", err, np.linalg.solve(second, err.T).T)
        scale = float(np.quantile(q, _TAIL_SHARE)) / CHI2_6_GATE
        if scale > 1.0:
            second = second * scale
    return second


def calibrated_pose_covariance(world_from_ego: NDArray, ego: NDArray, covs: NDArray, world_points: NDArray,
                               pose_covariance: NDArray, *, tilt_prior: TiltPrior | None = None
                               ) -> NDArray[np.float64]:
    """:func:`laplace_inflate` (a cost flatter than its quadratic model; with ``tilt_prior``, the
    cost of the data and the prior), then :func:`curved_pose_covariance` (the circle a weak
    rotation drives the robot along): the 6x6 covariance ``localize`` returns for its ML pose."""
    world_from_ego, ego, covs, world_points = _inputs(world_from_ego, ego, covs, world_points)
    cov = _covariance_or_unknown("pose_covariance", pose_covariance, 6).copy()
    widened = _laplace_inflate(world_from_ego, ego, covs, world_points, cov, 3.0, 4,
                               _check_tilt_prior(tilt_prior))
    try:
        return _curved(world_from_ego, ego, covs, widened)
    except np.linalg.LinAlgError as exc:
        raise PoseError("pose_covariance is singular: the curved covariance is not defined") from exc


def shared_view_covariance(world_from_ego: NDArray, ego: NDArray, covs: NDArray,
                           shared: Sequence[Sequence[tuple[int, NDArray]]], *,
                           tilt_prior: TiltPrior | None = None) -> NDArray[np.float64]:
    """The 6x6 pose covariance (ROS order) that errors shared between percepts add to the
    inverse Fisher information of the ML pose, which treats the percepts as independent.

    Percept ``i`` carries loadings ``S_iv`` (``shared[i]``, pairs ``(view, S)`` as in
    :class:`perception.Percept`): errors ``S_iv e_v`` with one ``e_v ~ N(0, I)`` per view.  The
    ML pose weighs percept ``i`` by ``W_i = (R C_i R^T)^-1`` (``C_i`` its total covariance), so
    to first order its error is ``H^-1 sum_i J_i^T W_i R eps_i`` with ``J_i`` the placement
    Jacobian and ``H = sum J_i^T W_i J_i``.  The covariance of that sum is ``H`` plus the
    cross terms of percepts sharing a view (the sandwich):

        ``H^-1 (sum_v G_v G_v^T - sum_{i,v} g_iv g_iv^T) H^-1``,
        ``g_iv = J_i^T W_i R S_iv``, ``G_v = sum_i g_iv``,

    which is what this returns (zero when no two percepts share a view); add it to the pose
    covariance.  When one view's encoder error dominates, every percept of that view moves
    together and the independent bound is overconfident by the factor this corrects.  With
    ``tilt_prior`` (the fit's), ``H`` includes the prior's information (the prior's error is
    independent of the percepts').
    """
    world_from_ego, ego, covs, _ = _inputs(world_from_ego, ego, covs)
    tilt_prior = _check_tilt_prior(tilt_prior)
    shared = _check_shared(shared, len(ego))
    R = world_from_ego[:3, :3]
    J = _placement_jacobian(world_from_ego, ego)
    W = np.linalg.inv(np.einsum("ij,kjl,ml->kim", R, covs, R))
    JW = np.einsum("kai,kab->kib", J, W)  # (k, 6, 3)
    M = _shared_sandwich(JW @ R, shared)
    if not M.any():
        return np.zeros((6, 6))
    information = pose_information(world_from_ego, ego, covs)
    if tilt_prior is not None:
        information = information + tilt_prior.information(world_from_ego[:3, :3])
    Hinv = ros_pose_covariance(information)  # H^-1, ROS order
    out = Hinv @ M @ Hinv
    return 0.5 * (out + out.T)


def _check_shared(shared: object, k: int) -> Sequence[Sequence[tuple[int, NDArray]]]:
    if (shared is None or isinstance(shared, str | bytes) or not isinstance(shared, Sequence | np.ndarray)
            or (isinstance(shared, np.ndarray) and shared.ndim == 0) or len(shared) != k):
        raise WorldGraphError(f"shared must hold one sequence of (view, loading) pairs per percept "
                              f"({k}), got {shared!r:.80}")
    return shared  # type: ignore[return-value]


def _shared_sandwich(L: NDArray[np.float64], shared: Sequence[Sequence[tuple[int, NDArray]]]
                     ) -> NDArray[np.float64]:
    """``sum_v G_v G_v^T - sum_{i,v} g_iv g_iv^T`` with ``g_iv = L_i S_iv`` and ``G_v = sum_i
    g_iv``: the cross terms that percepts sharing view ``v`` add to the covariance of the linear
    estimate ``sum_i L_i eps_i`` (``L (k, d, 3)``), whose independent part counts each percept's
    own total covariance already."""
    d = L.shape[1]
    G: dict[int, NDArray[np.float64]] = {}
    own = np.zeros((d, d))
    for i, pairs in enumerate(shared):
        for j, (view, S) in enumerate(pairs):
            if int(view) == OBJECT_VIEW:  # shared by one object's views only: never across percepts
                continue
            S = real_array(f"shared[{i}][{j}] loading", S, (3, None))
            g = L[i] @ S
            G[int(view)] = G[int(view)] + g if int(view) in G else g
            own += g @ g.T
    return sum((g @ g.T for g in G.values()), np.zeros((d, d))) - own


def _rotation_terms(R: NDArray, ego: NDArray, w: NDArray
                    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """``A_i = skew(R x_i)``, ``M = sum_i w_i A_i^T A_i`` and ``S = sum_i w_i A_i`` of the rotation
    fitted with the translation fixed (:func:`rotation_only_covariance`)."""
    A = _skew(ego @ R.T)
    return A, np.einsum("k,kai,kaj->ij", w, A, A), np.einsum("k,kij->ij", w, A)


def shared_range_covariance(world_from_ego: NDArray, ego: NDArray, covs: NDArray, centers: NDArray,
                            sigmas: NDArray, weights: NDArray,
                            shared: Sequence[Sequence[tuple[int, NDArray]]]) -> NDArray[np.float64]:
    """What errors shared between percepts add to :func:`rotation_only_covariance` (ROS order).

    The range-only position weighs range ``rho_i = |x_i|`` by ``1 / sigma_i^2``: to first order
    ``dt = H^-1 sum_i u_i x_i^T eps_i / (|x_i| sigma_i^2)`` with ``u_i`` the unit vector from
    centre ``i`` to the position and ``H = sum_i u_i u_i^T / sigma_i^2`` (the ML position; the
    other range-only estimators are taken at this first order too).  The rotation fitted with the
    position fixed moves by ``dphi = M^-1 (S^T dt + sum_i w_i A_i^T R eps_i)`` (``A_i``, ``M``,
    ``S`` as in :func:`rotation_only_covariance`).  With ``L_i`` the 6x3 map of percept ``i``'s
    ego error onto ``(dt, dphi)``, the cross terms of the percepts of each view are
    ``sum_v G_v G_v^T - sum_{i,v} g_iv g_iv^T``, ``g_iv = L_i S_iv``.  A head rotation about the
    ego origin leaves every range unchanged: such shared errors reach the position not at all and
    the rotation in full.  Zero when no two percepts share a view; inf when the geometry fixes no
    position or rotation.
    """
    world_from_ego, ego, covs, _ = _inputs(world_from_ego, ego, covs)
    k = len(ego)
    centers = real_array("centers", centers, (k, 3))
    sig = real_array("sigmas", sigmas, (k,))
    w = real_array("weights", weights, (k,))
    for name, arr in (("sigmas", sig), ("weights", w)):
        if np.any(arr <= 0):
            i = int(np.argmax(arr <= 0))
            raise PoseError(f"{name}[{i}] must be > 0, got {arr[i]!r}")
    shared = _check_shared(shared, k)
    R, t = world_from_ego[:3, :3], world_from_ego[:3, 3]
    rng_ = np.linalg.norm(ego, axis=1)
    toward = t - centers
    dist = np.linalg.norm(toward, axis=1)
    out = np.full((6, 6), np.inf)
    if np.any(rng_ == 0) or np.any(dist == 0):
        return out
    u = toward / dist[:, None]
    H = np.einsum("k,ka,kb->ab", 1.0 / sig**2, u, u)
    A, M, S = _rotation_terms(R, ego, w)
    try:
        Hi, Mi = np.linalg.inv(H), np.linalg.inv(M)
    except np.linalg.LinAlgError:
        return out
    Lt = np.einsum("ab,kb,kc->kac", Hi, u / (sig**2 * rng_)[:, None], ego)  # (k, 3, 3)
    Lr = np.einsum("ab,cb,kcd->kad", Mi, S, Lt) + \
        np.einsum("ab,k,kcb,cd->kad", Mi, w, A, R)  # (k, 3, 3)
    out = _shared_sandwich(np.concatenate([Lt, Lr], axis=1), shared)
    if not np.all(np.isfinite(out)):
        return np.full((6, 6), np.inf)
    return 0.5 * (out + out.T)


def rotation_only_covariance(world_from_ego: NDArray, ego: NDArray, covs: NDArray, weights: NDArray,
                             position_covariance: NDArray) -> NDArray[np.float64]:
    """6x6 covariance (ROS order) of a range-only position followed by a fixed-translation rotation.

    The rotation minimises ``sum_i w_i |R x_i - (X_i - t)|^2`` with ``t`` the range-only
    position (covariance ``Sigma_t``).  Linearised about the estimate with ``A_i = skew(R x_i)``
    and ``M = sum_i w_i A_i^T A_i``, the rotation error is ``e_r = M^-1 sum_i w_i A_i^T (e_t -
    R n_i)``: the percept's noise enters only through its component across the line of sight
    (``A_i^T`` removes the component along ``R x_i``), the range only through ``e_t``, so the two
    are uncorrelated for isotropic percepts and ``Cov(e_r) = M^-1 (sum w_i^2 A_i^T R C_i R^T A_i)
    M^-1 + M^-1 S^T Sigma_t S M^-1``, ``Cov(e_t, e_r) = Sigma_t S M^-1`` with ``S = sum w_i A_i``.
    """
    world_from_ego, ego, covs, _ = _inputs(world_from_ego, ego, covs)
    w = real_array("weights", weights, (len(ego),))
    if np.any(w < 0):
        i = int(np.argmax(w < 0))
        raise PoseError(f"weights[{i}] must be >= 0, got {w[i]!r}")
    position_covariance = _matrix_or_unknown("position_covariance", position_covariance, 3)
    R = world_from_ego[:3, :3]
    A, M, S = _rotation_terms(R, ego, w)
    RC = np.einsum("ij,kjl,ml->kim", R, covs, R)
    N = np.einsum("k,kai,kab,kbj->ij", w**2, A, RC, A)
    St = np.asarray(position_covariance, dtype=np.float64)
    out = np.full((6, 6), np.inf)
    try:
        Mi = np.linalg.inv(M)
    except np.linalg.LinAlgError:
        return out
    if not np.all(np.isfinite(St)) or not np.all(np.isfinite(Mi)):
        return out
    out[:3, :3] = St
    cross = St @ S @ Mi
    out[:3, 3:] = cross
    out[3:, :3] = cross.T
    out[3:, 3:] = Mi @ N @ Mi + Mi @ S.T @ St @ S @ Mi
    return 0.5 * (out + out.T)


def self_check(world_from_ego: NDArray, ego: NDArray, covs: NDArray, world_points: NDArray,
               pose_covariance: NDArray, alpha: float = SIGNIFICANCE
               ) -> tuple[bool, NDArray[np.float64], str]:
    """Chi-square test of matched percepts placed by their own pose.

    Fails when the sum of the squared Mahalanobis distances (residual covariance ``R C R^T + H
    Sigma H^T``) exceeds the ``1 - alpha`` quantile of chi-square with ``3 k`` degrees of freedom,
    or one of them exceeds the Bonferroni quantile ``1 - alpha / k`` of chi-square with 3.

    Returns
    -------
    passed : bool
    mahalanobis2 : (k,) float
    message : str
        Empty when passed.
    """
    alpha = real_scalar("alpha", alpha, positive=True, maximum=0.5)
    world_from_ego, ego, covs, world_points = _inputs(world_from_ego, ego, covs, world_points)
    k = len(ego)
    d2 = placed_mahalanobis(world_from_ego, ego, covs, world_points, pose_covariance)
    total, worst = float(d2.sum()), int(np.argmax(d2)) if k else -1
    lim_total = float(chi2.ppf(1 - alpha, 3 * k))
    lim_one = float(chi2.ppf(1 - alpha / max(k, 1), 3))
    if not np.all(np.isfinite(d2)) or total > lim_total or (k and d2[worst] > lim_one):
        dist = float(np.linalg.norm(ego[worst] @ world_from_ego[:3, :3].T + world_from_ego[:3, 3]
                                    - world_points[worst])) if k else math.nan
        return False, d2, (f"the pose contradicts its own matches: chi-square {total:.3g} over {k} matched "
                           f"percepts (limit {lim_total:.3g}); the worst lands {dist:.3g} m from its object "
                           f"(squared Mahalanobis {d2[worst]:.3g}, limit {lim_one:.3g})")
    return True, d2, ""
