"""What a look would show under each near-best hypothesis: the predicted sights, the hypotheses
they tell apart, their Fisher information about the pose, and the value of a look
(:mod:`worldgraph.active`, steps 1-4).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from perception import Percept, PerceptionError, depth_sigma

from .._checks import as_list
from ..errors import WorldGraphError
from ..localization.result import LocalizationResult
from ..model import WorldModel
from ..pose.validation import pose_difference
from ..tolerances import (
    COSINE_ROUNDING,
    NORM_FLOOR,
    PD_RTOL,
    POSE_VARIANCE_FLOOR,
)

#: Standard deviation (m and rad) of the vague pose prior the planner adds to the result's pose
#: information (and uses alone when the result has no finite covariance): a look is worth what
#: it adds beyond a pose known to about a metre and a radian.
VAGUE_POSE_STD = 1.0
#: ... and falls back to this one (1/m; ``plan_view``'s default).
DEFAULT_DEPTH_FACTOR = 1000.0
#: A predicted object counts as in view when its direction lies within the half angle less this
#: many standard deviations of its direction under the result's pose (position and rotation):
#: a near object's direction is uncertain, a far one's hardly.
VIEW_MARGIN_SIGMAS = 2.0
#: ... its rotation's share at most this fraction of the half angle.
MAX_VIEW_MARGIN = 0.5
#: Cosine limit of an object that is in no view (its direction too uncertain).
NEVER_IN_VIEW = 2.0
#: :func:`merge_percepts`' defaults: a new percept within ``MERGE_SIGMAS sqrt(s_old^2 + s_new^2)
#: + MERGE_FLOOR`` (m) of an old one of its type is a second sight.
MERGE_SIGMAS = 3.0
MERGE_FLOOR = 0.01
#: Default eq. 6 floor (m) of the predicted sights' sigma (``min_sigma``), as the simulators use.
SIGMA_FLOOR = 1e-4



def _unit_rows(v: NDArray[np.float64]) -> NDArray[np.float64]:
    n = np.linalg.norm(v, axis=1, keepdims=True)
    return v / np.where(n > 0, n, 1.0)


def _hypotheses(result: LocalizationResult) -> tuple[list[NDArray[np.float64]], NDArray[np.float64]]:
    """The poses of the near-best hypotheses and their weights."""
    T = np.asarray(result.transformation, dtype=np.float64)
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        raise WorldGraphError(f"result.transformation must be a finite pose to plan a view from, but the "
                              f"result (status {result.status!r}) has none")
    poses = [T] + [np.asarray(a, dtype=np.float64) for a in result.alternatives]
    costs = np.asarray(result.near_best_costs, dtype=np.float64)
    if costs.shape != (len(poses),) or not np.all(np.isfinite(costs)):
        costs = np.zeros(len(poses))  # no costs (e.g. method "paper"): equal weights
    w = np.exp(-(costs - costs.min()) / 2.0)
    return poses, w / w.sum()


def _check_types(world: WorldModel, types: object, result: LocalizationResult) -> list[str]:
    if types is None:
        objs = [o for _, o in result.correspondences]
        out = sorted({str(world.types[o]) for o in objs})
        if not out:
            raise WorldGraphError("types: the result has no correspondences to take the recognisable "
                                  "types from; pass types=")
        return out
    out = as_list("types", types, "object type names")
    for i, t in enumerate(out):
        if not isinstance(t, str) or t not in world.type_index:
            raise WorldGraphError(f"types[{i}] = {t!r} is not a type of the world "
                                  f"(types: {sorted(world.type_index)})")
    return out


def _gate(rho: NDArray[np.float64], depth_factor: float, min_sigma: float, n_sigma: float,
          margin: float) -> NDArray[np.float64]:
    """Distance (m) within which two predicted points of one type look the same at range rho."""
    try:
        sigma = np.asarray(depth_sigma(rho, depth_factor, min_sigma=min_sigma), dtype=np.float64)
    except PerceptionError as exc:  # a predicted range the eq. 6 model refuses (NaN, overflow)
        raise WorldGraphError(f"predicted percept sigma (eq. 6) failed: {exc}") from exc
    return n_sigma * math.sqrt(2.0) * sigma + margin


def tells_apart(ego: Sequence[NDArray[np.float64]], type_codes: NDArray[np.intp],
                in_range: Sequence[NDArray[np.bool_]], gate: Sequence[NDArray[np.float64]]
                ) -> NDArray[np.bool_]:
    """``u[h, j, o]``: object o, in range under hypothesis h, has no object of its type within
    ``gate[h][o]`` of its ego point ``ego[h][o]`` under hypothesis j (False for j = h)."""
    H, n = len(ego), len(type_codes)
    u = np.zeros((H, H, n), dtype=bool)
    if n == 0:
        return u
    span = max(float(max(np.abs(e).max() for e in ego)), 1.0)
    sep = 10.0 * span + 10.0 * float(max(g.max() for g in gate))  # types never closer than this
    code = type_codes.astype(np.float64)[:, None] * sep
    trees = [cKDTree(np.hstack([e, code])) for e in ego]
    for h in range(H):
        idx = np.flatnonzero(in_range[h])
        if idx.size == 0:
            continue
        pts = np.hstack([ego[h][idx], code[idx]])
        for j in range(H):
            if j == h:
                continue
            d, _ = trees[j].query(pts, k=1)
            u[h, j, idx] = d > gate[h][idx]
    return u


@dataclass(frozen=True)
class _Prediction:
    """The hypotheses' predictions of the recognisable objects (see the module docstring)."""

    poses: list[NDArray[np.float64]]
    weights: NDArray[np.float64]
    objects: NDArray[np.intp]             # indices into world.objects of the recognisable ones
    ego: list[NDArray[np.float64]]        # per hypothesis (n, 3)
    unit: list[NDArray[np.float64]]       # per hypothesis (n, 3) directions
    rho: list[NDArray[np.float64]]        # per hypothesis (n,) ranges
    in_range: list[NDArray[np.bool_]]     # per hypothesis (n,)
    tells: NDArray[np.bool_]              # (H, H, n): see tells_apart
    cos_lim: list[NDArray[np.float64]]    # per hypothesis (n,): in view when cos(angle) >= this
    info: list[NDArray[np.float64]]       # per hypothesis (n, 36): Fisher information of a sight
    prior: NDArray[np.float64]            # (6, 6) the result's pose information
    spread: NDArray[np.float64]           # (6, 6) weighted scatter of the hypotheses' poses


def _predict(world: WorldModel, result: LocalizationResult, types: object, fov: float, max_range: float,
             depth_factor: float, min_sigma: float, n_sigma: float, margin: float,
             percepts: Sequence[Percept] = ()) -> _Prediction:
    recog = _check_types(world, types, result)
    poses, weights = _hypotheses(result)
    # only objects within reach of some hypothesis matter: one farther from every hypothesis than
    # max_range + the largest gate is in no view and no nearer than a gate to any predicted point
    # (large worlds: the arrays below are per hypothesis and per object)
    reach = max_range + float(_gate(np.array([max_range]), depth_factor, min_sigma, n_sigma, margin)[0])
    near = world.tree.query_ball_point(np.array([T[:3, 3] for T in poses]), reach + 1.0)  # 1 m to spare
    cand = np.unique(np.concatenate([np.asarray(x, dtype=np.intp) for x in near]))
    obj = cand[np.isin(world.types[cand], recog)]
    X = world.positions[obj]
    codes = np.unique(world.types[obj], return_inverse=True)[1].astype(np.intp)
    ego = [(X - T[:3, 3]) @ T[:3, :3] for T in poses]
    rho = [np.linalg.norm(e, axis=1) for e in ego]
    in_range = [(r <= max_range) & (r > 0) for r in rho]
    gate = [_gate(r, depth_factor, min_sigma, n_sigma, margin) for r in rho]
    neighbour = _same_type_neighbour(X, codes)
    tells = tells_apart(ego, codes, in_range, gate)
    type_names = world.types[obj]
    info = []
    for h, (T, r, g, inr) in enumerate(zip(poses, rho, gate, in_range, strict=True)):
        sigma = np.asarray(depth_sigma(np.maximum(r, min_sigma), depth_factor, min_sigma=min_sigma),
                           dtype=np.float64)
        repeat = _repeats(ego[h], type_names, sigma, percepts)
        tells[h, :, repeat] = False            # a second sight is merged away: it tells nothing
        matchable = inr & (neighbour > g) & ~repeat  # lands near one object of its type only
        info.append(sight_information(X - T[:3, 3], sigma) * matchable[:, None])
    cos_lim = _cos_limits(rho, math.radians(fov / 2.0), _view_blur(result))
    prior, spread = _prior(result, poses, weights)
    return _Prediction(poses, weights, obj, ego, [_unit_rows(e) for e in ego], rho, in_range, tells, cos_lim,
                       info, prior, spread)


def _cos_limits(rho: Sequence[NDArray[np.float64]], half: float, blur: tuple[float, float]
                ) -> list[NDArray[np.float64]]:
    """Per hypothesis, the cosine above which each object is surely in view: within the half angle
    ``half`` less its direction's uncertainty under the pose (``blur``, ``_view_blur``): the
    position's share (an object as near as the position is uncertain is in no view), and the
    rotation's, at most a share of the half angle (the same for every object: a pose whose
    rotation is known too poorly to aim at anything still aims at the objects)."""
    out = []
    for r in rho:
        left = half - np.arctan2(blur[0], np.maximum(r, NORM_FLOOR)) - min(blur[1], MAX_VIEW_MARGIN * half)
        out.append(np.where(left > 0, np.cos(np.clip(left, 0.0, math.pi)), NEVER_IN_VIEW))
    return out




def _aimable(pred: _Prediction) -> bool:
    """Whether some object that would tell something (information or a hypothesis ruled out) can
    be in view at all under some hypothesis."""
    for h in range(len(pred.poses)):
        useful = np.any(pred.info[h] != 0.0, axis=1) | pred.tells[h].any(axis=0)
        if np.any(useful & (pred.cos_lim[h] < NEVER_IN_VIEW) & pred.in_range[h]):
            return True
    return False


def _view_blur(result: LocalizationResult) -> tuple[float, float]:
    """:data:`VIEW_MARGIN_SIGMAS` times the largest standard deviation of the result's position
    (m) and of its rotation (rad), from ``pose_covariance`` (0 when it holds none): what a
    predicted object's direction may be off by."""
    cov = np.asarray(result.pose_covariance, dtype=np.float64)
    if cov.shape != (6, 6) or not np.all(np.isfinite(cov)):
        return 0.0, 0.0
    top = [float(np.linalg.eigvalsh(0.5 * (b + b.T))[-1]) for b in (cov[:3, :3], cov[3:, 3:])]
    return (VIEW_MARGIN_SIGMAS * math.sqrt(max(top[0], 0.0)),
            min(math.pi, VIEW_MARGIN_SIGMAS * math.sqrt(max(top[1], 0.0))))


def _repeats(ego: NDArray[np.float64], type_names: NDArray, sigma: NDArray[np.float64],
             percepts: Sequence[Percept], n_sigma: float = MERGE_SIGMAS, floor: float = MERGE_FLOOR
             ) -> NDArray[np.bool_]:
    """(n,): the sight (ego point, sigma) repeats one of ``percepts`` of its type: it lies within
    ``n_sigma sqrt(s^2 + s_percept^2) + floor`` (m) of it.  The one rule of :func:`merge_percepts`
    and of the planner (a predicted sight that repeats a percept in hand adds nothing)."""
    out = np.zeros(len(ego), dtype=bool)
    by_type: dict[str, list[Percept]] = {}
    for p in percepts:
        by_type.setdefault(p.type, []).append(p)
    for t, ps in by_type.items():
        idx = np.flatnonzero(type_names == t)
        if idx.size == 0:
            continue
        P = np.array([p.position for p in ps])
        s = np.array([p.sigma for p in ps])
        d = np.linalg.norm(ego[idx, None, :] - P[None, :, :], axis=2)
        lim = n_sigma * np.hypot(sigma[idx, None], s[None, :]) + floor
        out[idx] = np.any(d <= lim, axis=1)
    return out


def _same_type_neighbour(X: NDArray[np.float64], codes: NDArray[np.intp]) -> NDArray[np.float64]:
    """Distance (m) from each object to the nearest other object of its type (inf if none)."""
    out = np.full(len(X), np.inf)
    for c in np.unique(codes):
        idx = np.flatnonzero(codes == c)
        if idx.size > 1:
            d, _ = cKDTree(X[idx]).query(X[idx], k=2)
            out[idx] = np.asarray(d)[:, 1]
    return out


def sight_information(offsets: object, sigma: object) -> NDArray[np.float64]:
    """Fisher information about the 6D pose of one sight of each object, flattened (n, 36).

    A sight is the object's ego position ``p = R^T (X - t)`` with isotropic noise ``sigma``.
    In the order and axes of ``LocalizationResult.pose_covariance`` (translation error ``dt``
    and rotation vector ``dtheta`` of ``R_true R^T``, both in world axes),
    ``dp = R^T (-dt + [q]_x dtheta)`` with ``q = X - t``, so the information is
    ``[-I, [q]_x]^T [-I, [q]_x] / sigma^2 = [[I, -[q]_x], [[q]_x, |q|^2 I - q q^T]] / sigma^2``
    (``R`` drops out: the noise is isotropic).

    Parameters
    ----------
    offsets : (n, 3) float
        ``X - t``: each object's position relative to the ego origin, world axes (m).
    sigma : (n,) float
        Each sight's standard deviation (m), > 0.
    """
    q = np.asarray(offsets, dtype=np.float64).reshape(-1, 3)
    w = 1.0 / np.asarray(sigma, dtype=np.float64).reshape(-1) ** 2
    n = len(q)
    A = np.zeros((n, 6, 6))
    Q = np.zeros((n, 3, 3))
    Q[:, 0, 1], Q[:, 0, 2], Q[:, 1, 2] = -q[:, 2], q[:, 1], -q[:, 0]
    Q[:, 1, 0], Q[:, 2, 0], Q[:, 2, 1] = q[:, 2], -q[:, 1], q[:, 0]
    eye = np.eye(3)
    A[:, :3, :3] = eye
    A[:, :3, 3:] = -Q
    A[:, 3:, :3] = Q
    A[:, 3:, 3:] = (q * q).sum(axis=1)[:, None, None] * eye - q[:, :, None] * q[:, None, :]
    return (A * w[:, None, None]).reshape(n, 36)


def _prior(result: LocalizationResult, poses: list[NDArray[np.float64]], weights: NDArray[np.float64]
           ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The result's pose information (the inverse of ``pose_covariance``, floored at
    :data:`VAGUE_POSE_STD` when it holds none) and the weighted scatter of the hypotheses' poses
    about their mean (6D, at the chosen pose, in the order and axes of ``pose_covariance``)."""
    vague = np.diag(np.full(6, 1.0 / VAGUE_POSE_STD**2))
    cov = np.asarray(result.pose_covariance, dtype=np.float64)
    prior = vague
    if cov.shape == (6, 6) and np.all(np.isfinite(cov)):
        vals, vecs = np.linalg.eigh(0.5 * (cov + cov.T))
        top = float(vals.max())
        if top > 0:  # (a covariance without a positive variance holds nothing to plan with)
            vals = np.clip(vals, max(top * PD_RTOL, POSE_VARIANCE_FLOOR), None)
            prior = (vecs / vals) @ vecs.T + vague
    T0 = poses[0]
    dev = np.array([pose_difference(T0, T) for T in poses])
    centred = dev - weights @ dev
    return 0.5 * (prior + prior.T), (centred * weights[:, None]).T @ centred


def _in_view(pred: _Prediction, h: int, directions: NDArray[np.float64]) -> NDArray[np.bool_]:
    """(C, n): object in view of each direction under hypothesis h."""
    # element-wise, not BLAS: these thin products (inner size 3) ran 10-100x slower through a
    # multithreaded OpenBLAS on a loaded 2-core machine
    u = pred.unit[h]
    cosines = directions[:, 0:1] * u[:, 0] + directions[:, 1:2] * u[:, 1] + directions[:, 2:3] * u[:, 2]
    return (cosines >= pred.cos_lim[h] - COSINE_ROUNDING) & pred.in_range[h]


def _kept(view: NDArray[np.bool_], detection: float, max_sights: int | None) -> NDArray[np.float64]:
    """(C,): the probability that an object in view comes back from the look: ``detection``, or
    with a cap of ``max_sights`` percepts per look (a random subset of those detected) about
    ``min(detection, max_sights / n_view)``."""
    if max_sights is None:
        return np.full(len(view), detection)
    n_view = np.count_nonzero(view, axis=1).astype(np.float64)
    return np.minimum(detection, max_sights / np.maximum(n_view, 1.0))


def _look_values(pred: _Prediction, directions: NDArray[np.float64], detection: float,
                 max_sights: int | None) -> tuple[NDArray[np.float64], ...]:
    """Per candidate direction: the probability that the look rules out all but the true
    hypothesis (module docstring, step 3), its expected information about the 6D pose (nats,
    ``_information``), and the expected number of objects in view (weighted over the
    hypotheses)."""
    H, C = len(pred.poses), len(directions)
    per_h = np.zeros((H, C))
    seen = np.zeros(C)
    covs = np.empty((H, C, 6, 6))
    for h in range(H):
        view = _in_view(pred, h, directions)                               # (C, n)
        kept = _kept(view, detection, max_sights)                          # (C,)
        n_hj = np.stack([np.count_nonzero(view & pred.tells[h, j], axis=1) for j in range(H)],
                        axis=1).astype(np.float64)                          # (C, H)
        ruled_out = 1.0 - (1.0 - kept[:, None]) ** n_hj
        ruled_out[:, h] = 1.0
        if H > 1:
            per_h[h] = np.prod(ruled_out, axis=1)
        seen += pred.weights[h] * np.count_nonzero(view, axis=1)
        added = kept[:, None] * (view.astype(np.float64) @ pred.info[h])     # (C, 36)
        covs[h] = np.linalg.inv(pred.prior + added.reshape(C, 6, 6))
    score = pred.weights @ per_h
    return score, _information(pred, covs, per_h), seen


def _logdet(M: NDArray[np.float64]) -> NDArray[np.float64]:
    """Log det of a stack of symmetric positive definite matrices."""
    sign, value = np.linalg.slogdet(M)
    return np.where(sign > 0, value, -np.inf)


def _information(pred: _Prediction, covs: NDArray[np.float64], per_h: NDArray[np.float64]
                 ) -> NDArray[np.float64]:
    """Expected information (nats) of a look in each direction about the 6D pose.

    The pose's belief is the mixture of the hypotheses (weights ``w_h``) with the covariance
    ``C`` each (``C^-1``: the result's pose information plus the vague prior of
    :data:`VAGUE_POSE_STD`, ``_prior``); as a Gaussian it has covariance ``C + S`` (``S`` the
    weighted scatter of the hypotheses).  If ``h`` is true, a look adds the information ``dI_h(d)``:
    the sights in view (:func:`sight_information`, objects that would be matched to one
    object only) times the probability that each comes back (``_kept``); and with
    probability ``s_h(d)`` (``per_h``) it rules out every other hypothesis.  The expected
    posterior log-determinant is ``sum_h w_h [s_h log det C_h+ + (1 - s_h) log det (sum_j w_j
    C_j+ + S)]`` with ``C_h+ = (C^-1 + dI_h)^-1`` (``covs``, (H, C, 6, 6)); the information
    is half its drop from ``log det (C + S)``.  With one hypothesis it is the D-optimal gain
    ``0.5 log det (I + C dI)``; for hypotheses far apart ruling them out dominates, for close
    ones refining the pose counts as much."""
    H = len(pred.poses)
    logdet_h = _logdet(covs)                                                     # (H, C)
    before = float(_logdet(np.linalg.inv(pred.prior) + pred.spread))
    if H == 1:
        return 0.5 * (before - logdet_h[0])
    mixed = _logdet(np.einsum("h,hcij->cij", pred.weights, covs) + pred.spread)  # (C,)
    after = (pred.weights[:, None] * (per_h * logdet_h + (1.0 - per_h) * mixed[None, :])).sum(axis=0)
    return 0.5 * (before - after)


