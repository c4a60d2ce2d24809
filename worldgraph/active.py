"""Active validation: where to look next when the pose is ambiguous (paper, section 2.3).

The paper ends an ambiguous association with "an active validation [...] selecting objects from
the model and then localizing them in the visual space", choosing the object with the maximal
pose difference between two hypotheses (:func:`worldgraph.association.discriminator`).  A large
predicted difference does not make a look informative, though: under the other hypothesis the
same ego spot may hold another object of the same type, and then both hypotheses predict the
same sight.  :func:`plan_view` scores gaze directions by what would actually be seen:

1. The near-best hypotheses are the chosen pose and every ``alternatives`` pose of the
   :class:`~worldgraph.localize.LocalizationResult` (all validated fits within the ambiguity
   margin, not only two), weighted ``w_h ∝ exp(-cost_h / 2)`` with their robust costs
   (``near_best_costs``, twice a negative log-likelihood).
2. Under hypothesis ``h`` every recognisable object ``o`` is predicted at the ego point
   ``p_ho = R_h^T (X_o - t_h)``.  It *tells h from j* when hypothesis ``j`` predicts no object
   of its type within the gate ``n_sigma sqrt(2) sigma(|p_ho|) + margin`` of ``p_ho`` (eq. 6
   noise ``sigma(rho) = max(min_sigma, rho^2 / depth_factor)``).  This flag does not depend on
   the gaze, so it is computed once per hypothesis pair (a k-d tree per hypothesis whose fourth
   coordinate separates the types).
3. A look in direction ``d`` sees the objects whose direction lies within ``fov_deg / 2`` of
   ``d`` and whose range is at most ``max_range``; each comes back with probability
   ``detection`` (with a cap of ``max_sights`` percepts per look, about ``min(detection,
   max_sights / n_in_view)``).  If ``h`` is true, the look rules out ``j`` when at least one
   object that tells h from j comes back.  The *score* is the probability that the look rules
   out every other hypothesis: ``sum_h w_h prod_{j != h} (1 - (1 - detection)^{n_hj(d)})``.
   The product is exact for two hypotheses and a lower bound for more (the events increase
   with the detections, so they are positively correlated: Harris' inequality).
4. The look also refines the pose.  Each sight of an object that would be matched to it alone
   (no other object of its type within the gate) adds the Fisher information
   ``J^T J / sigma^2`` about the 6D pose (:func:`sight_information`).  The planner maximises
   the *expected information* of the look (nats): the expected drop in half the log-determinant
   of the pose's covariance, the mixture of the hypotheses treated as one Gaussian (its
   covariance the result's ``pose_covariance`` plus the hypotheses' scatter), with the
   hypotheses ruled out with the score's probability (:func:`_information`).  For a unique
   answer this is the D-optimal gain ``0.5 log det (I + C dI)``: a look at a tight cluster of
   objects pins the cluster's position but hardly the rotation, while objects spread across
   the view pin both.  For hypotheses far apart, telling them apart dominates; for close ones,
   refining the pose counts as much.
5. Candidates are the directions to every object that tells any two hypotheses apart, under
   every hypothesis, to every informative object under the chosen pose, a fixed set of
   directions spread over the sphere and any given by the caller; one matrix product per
   hypothesis scores them all.

:func:`active_localize` is the loop: localise, plan, look (a user callback returning new
percepts in the same ego frame), localise again with the old and new percepts, until the
answer is unique or the looks run out.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any, Literal, cast, get_args

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares
from scipy.spatial import cKDTree

from perception import KinematicChain, Percept, PerceptionError, depth_sigma

from ._checks import as_list, float_array, generator, positive_float, strict_int
from .consistency import check_world_and_percepts
from .errors import ArgumentTypeError, NonFiniteError, OutOfRangeError, UnknownTypeError
from .gravity import Gravity, _check_gravity
from .localize import LocalizationResult, PoseStatus, localize
from .model import WorldModel
from .tolerances import (
    AIM_LSQ_TOL,
    AIM_REGULARISATION,
    ASSOCIATION_TOLERANCES,
    COSINE_ROUNDING,
    JOINT_LIMIT_MARGIN,
    NORM_FLOOR,
    PD_RTOL,
    POSE_VARIANCE_FLOOR,
    AssociationTolerances,
    _tol_argument,
)
from .validation import _pose_error

__all__ = [
    "ActiveLocalization",
    "VIEW_STATUSES",
    "GOAL_ROTATION_3SIGMA",
    "ViewPlan",
    "LookStatus",
    "ViewStatus",
    "active_localize",
    "depth_factor_of",
    "gaze_angles",
    "merge_percepts",
    "plan_view",
    "sight_information",
    "tells_apart",
    "view_information",
    "view_scores",
]

ViewStatus = Literal[
    "ok",                  # a direction whose look can rule out hypotheses (score > 0)
    "not_discriminating",  # no candidate direction tells the hypotheses apart (score 0)
    "single_hypothesis",   # the result has one hypothesis: nothing to tell apart (score 0)
]
VIEW_STATUSES: tuple[str, ...] = get_args(ViewStatus)

#: Fixed candidate directions spread over the sphere (Fibonacci lattice) added to the
#: object directions.
N_FIXED_DIRECTIONS = 64
#: Standard deviation (m and rad) of the vague pose prior the planner adds to the result's pose
#: information (and uses alone when the result has no finite covariance): a look is worth what
#: it adds beyond a pose known to about a metre and a radian.
VAGUE_POSE_STD = 1.0
#: :func:`depth_factor_of` reads the eq. 6 factor from percepts at least this far (m) ...
MIN_FACTOR_RANGE = 1.0
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
#: The planner recentres its candidates on the objects they would see this many times
#: (:func:`_recentred`; the first time on those within the full view angle).
RECENTRE_STEPS = 2
#: ``active_localize`` infers a cap on percepts per look only from a look whose plan expected at
#: least this many detections.
MIN_CAP_EVIDENCE = 4.0
#: Default eq. 6 floor (m) of the predicted sights' sigma (``min_sigma``), as the simulators use.
SIGMA_FLOOR = 1e-4
#: Random candidate directions added when ``rng`` is given.
N_RANDOM_DIRECTIONS = 32
#: Largest pointing error (rad) of the head's optical axis at which ``gaze_reached`` is True.
GAZE_TOLERANCE = math.radians(1.0)
#: Localisation statuses that come with a pose to plan a view from (the trusted ones and the
#: poses that failed their own check or the caller's region): what ``look_while`` may hold.
LookStatus = Literal[PoseStatus, "inconsistent", "outside_region"]
_LOOK_STATUSES: tuple[str, ...] = get_args(LookStatus)
#: :func:`active_localize` also looks while an "ok" answer's 3-sigma rotation bound is wider than
#: this (radians): 2 degrees, what a pose judged correct may be off by in the benchmarks.
GOAL_ROTATION_3SIGMA = math.radians(2.0)


@dataclass(frozen=True)
class ViewPlan:
    """Result of :func:`plan_view`.

    Attributes
    ----------
    direction : (3,) float
        Unit gaze direction in the ego frame (from the ego origin).
    target : (3,) float
        The ego point looked at: on ``direction``, at the median range of the discriminating
        objects expected in view (of all expected objects when none discriminates).
    score : float
        Probability, in [0, 1], that the look rules out every hypothesis but the true one
        (a lower bound with more than two hypotheses; see the module docstring).  0 when the
        status is not ``"ok"``.
    expected : tuple of (m_h,) int
        Per hypothesis, the indices into ``world.objects`` of the recognisable objects expected
        in view.
    discriminating : tuple of (m_h,) bool
        Per hypothesis, which of ``expected`` would tell it from at least one other hypothesis.
    hypotheses : tuple of (4, 4) float
        ``world_from_ego`` of the hypotheses considered: the result's pose first, then its
        alternatives.
    weights : (H,) float
        Prior probability of each hypothesis (``exp(-cost / 2)`` normalised).
    status : ViewStatus
    information : float
        Expected information (nats) of the look about the 6D pose, what the direction maximises
        (see :func:`plan_view`).
    joint_angles : (n_joints,) float or None
        With a ``head``: joint angles (radians, in ``head.names`` order, the right eye parallel
        to the left) that point the left camera's optical axis (+z of the OpenCV camera frame)
        at ``target``.
    pointing_error : float
        Angle (rad) between the optical axis at ``joint_angles`` and the ray from the camera to
        ``target``; NaN without a head.
    gaze_reached : bool or None
        ``pointing_error <= 1 deg`` (within the joint limits, when given); None without a head.
    within_limits : bool or None
        Whether ``joint_angles`` respect ``joint_limits`` and the head's own joint limits;
        **None when neither gives any** (the angles are then unchecked).
    candidates : int
        Number of candidate directions scored.
    """

    direction: NDArray[np.float64]
    target: NDArray[np.float64]
    score: float
    expected: tuple[NDArray[np.intp], ...]
    discriminating: tuple[NDArray[np.bool_], ...]
    hypotheses: tuple[NDArray[np.float64], ...]
    weights: NDArray[np.float64]
    status: ViewStatus
    information: float = 0.0
    joint_angles: NDArray[np.float64] | None = None
    pointing_error: float = math.nan
    gaze_reached: bool | None = None
    within_limits: bool | None = None
    candidates: int = 0


def _fibonacci_sphere(n: int) -> NDArray[np.float64]:
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    r = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    phi = math.pi * (3.0 - math.sqrt(5.0)) * i
    return np.column_stack([r * np.cos(phi), r * np.sin(phi), z])


_FIXED = _fibonacci_sphere(N_FIXED_DIRECTIONS)


def _recentred(pred: _Prediction, directions: NDArray[np.float64], cos_kernel: float | None = None
               ) -> NDArray[np.float64]:
    """For each direction, the mean direction of the objects it would see under every hypothesis
    (weighted by the hypotheses' weights; a mean-shift step on the candidates), where it has any;
    with ``cos_kernel``, of the objects in range within that cosine of it instead (a wider
    kernel gathers objects that no one view of an object's direction holds together)."""
    total = np.zeros((len(directions), 3))
    for h in range(len(pred.poses)):
        if cos_kernel is None:
            view = _in_view(pred, h, directions).astype(np.float64)    # (C, n)
        else:
            view = ((directions @ pred.unit[h].T >= cos_kernel) & pred.in_range[h]).astype(np.float64)
        total += pred.weights[h] * (view @ pred.unit[h])
    norm = np.linalg.norm(total, axis=1)
    keep = norm > NORM_FLOOR
    return total[keep] / norm[keep, None]


def _distinct_directions(D: NDArray[np.float64]) -> NDArray[np.float64]:
    """The rows of ``D`` (unit directions) without repeats closer than about half a degree (the
    first of each cell of a 1/128 grid on the unit cube), in their order."""
    _, first = np.unique(np.round(D * 128.0).astype(np.int64), axis=0, return_index=True)
    return D[np.sort(first)]


def _unit_rows(v: NDArray[np.float64]) -> NDArray[np.float64]:
    n = np.linalg.norm(v, axis=1, keepdims=True)
    return v / np.where(n > 0, n, 1.0)


def _hypotheses(result: LocalizationResult) -> tuple[list[NDArray[np.float64]], NDArray[np.float64]]:
    """The poses of the near-best hypotheses and their weights."""
    T = np.asarray(result.transformation, dtype=np.float64)
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        raise NonFiniteError(f"result.transformation must be a finite pose to plan a view from, but the "
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
            raise UnknownTypeError("types: the result has no correspondences to take the recognisable "
                                   "types from; pass types=")
        return out
    out = as_list("types", types, "object type names")
    for i, t in enumerate(out):
        if not isinstance(t, str) or t not in world.type_index:
            raise UnknownTypeError(f"types[{i}] = {t!r} is not a type of the world "
                                   f"(types: {sorted(world.type_index)})")
    return out


def _gate(rho: NDArray[np.float64], depth_factor: float, min_sigma: float, n_sigma: float,
          margin: float) -> NDArray[np.float64]:
    """Distance (m) within which two predicted points of one type look the same at range rho."""
    try:
        sigma = np.asarray(depth_sigma(rho, depth_factor, min_sigma=min_sigma), dtype=np.float64)
    except PerceptionError as exc:  # a predicted range the eq. 6 model refuses (NaN, overflow)
        raise NonFiniteError(f"predicted percept sigma (eq. 6) failed: {exc}") from exc
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


def _gaze_fk(head: KinematicChain, q: NDArray[np.float64]) -> NDArray[np.float64]:
    """``ego_from_camera`` of the left camera for the serial angles q (plain numpy)."""
    M = np.array(head.ego_from_base, dtype=np.float64)
    for joint, angle in zip(head.joints, q, strict=True):
        c, s = math.cos(angle), math.sin(angle)
        i = "xyz".index(joint.axis)
        j, k = (i + 1) % 3, (i + 2) % 3
        rot = np.eye(4)
        rot[j, j], rot[j, k], rot[k, j], rot[k, k] = c, -s, s, c
        M = M @ joint.origin @ rot
    return M @ head.tip_from_camera


def _check_limits(head: KinematicChain, joint_limits: object) -> tuple[NDArray, NDArray] | None:
    """``(lower, upper)`` of the serial joints: the chain's own limits narrowed by ``joint_limits``;
    None when neither gives any."""
    n = len(head.joints)
    own_lo, own_hi = head.limits[:n].T
    if joint_limits is None:
        if np.all(np.isinf(own_lo)) and np.all(np.isinf(own_hi)):
            return None
        return own_lo.copy(), own_hi.copy()
    if not isinstance(joint_limits, Mapping):
        raise ArgumentTypeError(f"joint_limits must be a mapping joint name -> (lower, upper) radians, got "
                                f"{type(joint_limits).__name__}")
    names = [j.name for j in head.joints]
    unknown = sorted(set(joint_limits) - set(head.names))
    if unknown:
        raise UnknownTypeError(f"joint_limits names unknown joints {unknown}; the head has "
                               f"{list(head.names)}")
    lo = np.full(len(names), -np.inf)
    hi = np.full(len(names), np.inf)
    for i, name in enumerate(names):
        if name in joint_limits:
            pair = float_array(f"joint_limits[{name!r}]", joint_limits[name], (2,))
            if not pair[0] < pair[1]:
                raise OutOfRangeError(f"joint_limits[{name!r}] must be (lower, upper) with lower < upper, "
                                      f"got {pair.tolist()}")
            lo[i], hi[i] = pair
            if not max(lo[i], own_lo[i]) <= min(hi[i], own_hi[i]):
                raise OutOfRangeError(f"joint_limits[{name!r}] = {pair.tolist()} does not meet the joint's "
                                      f"own limits {[float(own_lo[i]), float(own_hi[i])]}")
    return np.maximum(lo, own_lo), np.minimum(hi, own_hi)


def gaze_angles(head: KinematicChain, target: object, *, joint_limits: Mapping[str, Any] | None = None
                ) -> tuple[NDArray[np.float64], float, bool | None]:
    """Joint angles pointing the left camera's optical axis at an ego point.

    The optical axis is +z of the OpenCV left camera frame, ``head.ego_from_camera(q)[:3, 2]``;
    the angles minimise ``|axis(q) - unit(target - centre(q))|^2 + 1e-6 |q|^2`` (the small
    term picks the solution nearest the zero pose) by bounded least squares from a few starts
    (zero; the first yaw joint at the target's azimuth with the next pitch joint at its
    elevation).

    Parameters
    ----------
    head : perception.KinematicChain
    target : (3,) float
        Ego point (m).
    joint_limits : mapping joint name -> (lower, upper), optional
        Radians; they narrow the chain's own limits (``head.limits``, e.g. from a URDF), and
        joints named in neither are free.

    Returns
    -------
    angles : (n_joints,) float
        In ``head.names`` order (the right eye parallel to the left).
    pointing_error : float
        Angle (rad) between the optical axis and the ray from the camera centre to ``target``,
        measured with ``head.ego_from_camera``.
    within_limits : bool or None
        None when no limits were given.
    """
    if not isinstance(head, KinematicChain):
        raise ArgumentTypeError(f"head must be a perception.KinematicChain, got {type(head).__name__}")
    tgt = float_array("target", target, (3,), max_abs=1e6)
    bounds = _check_limits(head, joint_limits)
    n = len(head.joints)
    lo, hi = bounds if bounds is not None else (np.full(n, -np.inf), np.full(n, np.inf))

    def residual(q: NDArray[np.float64]) -> NDArray[np.float64]:
        M = _gaze_fk(head, q)
        ray = tgt - M[:3, 3]
        norm = np.linalg.norm(ray)
        return np.concatenate([M[:3, 2] - ray / max(float(norm), NORM_FLOOR), AIM_REGULARISATION * q])

    starts = [np.zeros(n)]
    axes = [j.axis for j in head.joints]
    if "z" in axes:
        iz = axes.index("z")
        q0 = np.zeros(n)
        q0[iz] = math.atan2(tgt[1], tgt[0])
        if "y" in axes[iz + 1:]:
            iy = iz + 1 + axes[iz + 1:].index("y")
            q0[iy] = -math.atan2(tgt[2], math.hypot(tgt[0], tgt[1]))
        starts.insert(0, q0)
    best_q, best_err = None, math.inf
    for q0 in starts:
        q0 = np.clip(q0, np.where(np.isfinite(lo), lo + JOINT_LIMIT_MARGIN, -np.inf),
                     np.where(np.isfinite(hi), hi - JOINT_LIMIT_MARGIN, np.inf))
        sol = least_squares(residual, q0, bounds=(lo, hi), xtol=AIM_LSQ_TOL, ftol=AIM_LSQ_TOL,
                            gtol=AIM_LSQ_TOL)
        q = sol.x
        M = head.ego_from_camera(q)
        ray = tgt - M[:3, 3]
        cosang = float(M[:3, 2] @ ray / max(np.linalg.norm(ray), NORM_FLOOR))
        err = math.acos(min(1.0, max(-1.0, cosang)))
        if err < best_err:
            best_q, best_err = q, err
        if best_err < 0.01 * GAZE_TOLERANCE:  # good enough: skip the other starts
            break
    assert best_q is not None
    within = None if bounds is None else bool(np.all((best_q >= lo - JOINT_LIMIT_MARGIN)
                                                      & (best_q <= hi + JOINT_LIMIT_MARGIN)))
    return head.angle_vector(np.clip(best_q, lo, hi)), best_err, within


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
    ``half`` less its direction's uncertainty under the pose (``blur``, :func:`_view_blur`): the
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
    dev = np.array([_pose_error(T0, T) for T in poses])
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
    :func:`_information`), and the expected number of objects in view (weighted over the
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
    :data:`VAGUE_POSE_STD`, :func:`_prior`); as a Gaussian it has covariance ``C + S`` (``S`` the
    weighted scatter of the hypotheses).  If ``h`` is true, a look adds the information ``dI_h(d)``:
    the sights in view (:func:`sight_information`, objects that would be matched to one
    object only) times the probability that each comes back (:func:`_kept`); and with
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


def _depth_factor(value: object) -> float:
    """The eq. 6 factor (1/m), in [0.001, 1e12]."""
    depth_factor = positive_float("depth_factor", value, maximum=1e12)
    if depth_factor < 1e-3:
        raise OutOfRangeError(f"depth_factor = {depth_factor!r} is out of range: must be >= 0.001 (1/m)")
    return depth_factor


def _check_common(world: object, result: object, fov_deg: object, max_range: object, detection: object,
                  depth_factor: object, min_sigma: object, n_sigma: object, margin: object
                  ) -> tuple[float, float, float, float, float, float, float]:
    if not isinstance(world, WorldModel):
        raise ArgumentTypeError(f"world must be a WorldModel, got {type(world).__name__}")
    if not isinstance(result, LocalizationResult):
        raise ArgumentTypeError(f"result must be a LocalizationResult, got {type(result).__name__}")
    depth_factor = _depth_factor(depth_factor)
    return (positive_float("fov_deg", fov_deg, maximum=360.0),
            positive_float("max_range", max_range, maximum=1e6),
            positive_float("detection", detection, maximum=1.0), depth_factor,
            positive_float("min_sigma", min_sigma, maximum=1e3),
            positive_float("n_sigma", n_sigma, maximum=1e3),
            positive_float("margin", margin, allow_zero=True, maximum=1e3))


def _directions(name: str, value: object) -> NDArray[np.float64]:
    arr = float_array(name, value, (None, 3), max_abs=1e12)
    zero = np.flatnonzero(np.linalg.norm(arr, axis=1) == 0)
    if zero.size:
        raise OutOfRangeError(f"{name}[{int(zero[0])}] = {arr[zero[0]].tolist()} is no direction "
                              "(zero length)")
    return _unit_rows(arr)


def _view_values(world: object, result: object, directions: object, fov_deg: object, max_range: object,
                 types: object, detection: object, depth_factor: object, min_sigma: object, n_sigma: object,
                 margin: object, max_sights: object, percepts: object
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    fov, max_r, det, df, floor, ns, mg = _check_common(world, result, fov_deg, max_range, detection,
                                                       depth_factor, min_sigma, n_sigma, margin)
    D = _directions("directions", directions)
    cap = None if max_sights is None else strict_int("max_sights", max_sights, minimum=1, maximum=10**9)
    pred = _predict(cast(WorldModel, world), cast(LocalizationResult, result), types, fov, max_r, df, floor,
                    ns, mg, _percepts_in_hand(percepts))
    score, information, _ = _look_values(pred, D, det, cap)
    return score, information


def _percepts_in_hand(percepts: object) -> list[Percept]:
    if percepts is None:
        return []
    out = as_list("percepts", percepts, "perception.Percept", exclude=(Percept,))
    for i, p in enumerate(out):
        if not isinstance(p, Percept):
            raise ArgumentTypeError(f"percepts[{i}] must be a perception.Percept, got {type(p).__name__}")
    return out


def view_scores(world: WorldModel, result: LocalizationResult, directions: object, *, fov_deg: float = 60.0,
                max_range: float = 8.0, types: Sequence[str] | None = None, detection: float = 0.9,
                depth_factor: float = DEFAULT_DEPTH_FACTOR, min_sigma: float = SIGMA_FLOOR,
                n_sigma: float = 3.0, margin: float = 0.05, max_sights: int | None = None,
                percepts: Sequence[Percept] | None = None) -> NDArray[np.float64]:
    """The probability that a look rules out every hypothesis but the true one (``ViewPlan.score``)
    for each of the given ego directions (m, 3); arguments as for :func:`plan_view`.
    0 for every direction when the result has a single hypothesis."""
    return _view_values(world, result, directions, fov_deg, max_range, types, detection, depth_factor,
                        min_sigma, n_sigma, margin, max_sights, percepts)[0]


def view_information(world: WorldModel, result: LocalizationResult, directions: object, *,
                     fov_deg: float = 60.0, max_range: float = 8.0, types: Sequence[str] | None = None,
                     detection: float = 0.9, depth_factor: float = DEFAULT_DEPTH_FACTOR,
                     min_sigma: float = SIGMA_FLOOR, n_sigma: float = 3.0, margin: float = 0.05,
                     max_sights: int | None = None, percepts: Sequence[Percept] | None = None
                     ) -> NDArray[np.float64]:
    """The expected information (nats) of a look about the 6D pose (``ViewPlan.information``, what
    :func:`plan_view` maximises) for each of the given ego directions (m, 3); arguments as for
    :func:`plan_view`."""
    return _view_values(world, result, directions, fov_deg, max_range, types, detection, depth_factor,
                        min_sigma, n_sigma, margin, max_sights, percepts)[1]


def plan_view(world: WorldModel, result: LocalizationResult, *, fov_deg: float = 60.0, max_range: float = 8.0,
              head: KinematicChain | None = None, candidates: object = None,
              rng: np.random.Generator | None = None, types: Sequence[str] | None = None,
              detection: float = 0.9, depth_factor: float = DEFAULT_DEPTH_FACTOR,
              min_sigma: float = SIGMA_FLOOR, n_sigma: float = 3.0, margin: float = 0.05,
              joint_limits: Mapping[str, Any] | None = None, max_sights: int | None = None,
              percepts: Sequence[Percept] | None = None) -> ViewPlan:
    """The gaze direction whose look is expected to tell the most about the pose: it tells the
    near-best hypotheses of ``result`` apart and refines the pose.

    See the module docstring for the model.  The direction maximises the expected information
    (``ViewPlan.information``, nats); ties go to the higher probability of ruling the other
    hypotheses out (``ViewPlan.score``), then to more objects in view.  A result with a single
    hypothesis (a unique answer: no ``alternatives``) gives status ``"single_hypothesis"`` and
    score 0: the look only refines the pose, where the sights pin it best (objects spread
    across the view, near ones first, rather than the most objects).  When no candidate tells
    several hypotheses apart, status ``"not_discriminating"`` and score 0.

    Parameters
    ----------
    world : WorldModel
    result : LocalizationResult
        From :func:`~worldgraph.localize`; it must hold a finite pose (``"ambiguous"``, ``"ok"``,
        ``"weak"``, ...).
    fov_deg : float
        Full cone angle of a look, degrees, in (0, 360] (at 360 a look sees everything in range).
    max_range : float
        Largest range (m) at which objects are recognised.
    head : perception.KinematicChain, optional
        Fill ``joint_angles`` (:func:`gaze_angles`) for ``target``.
    candidates : (m, 3) float, optional
        Extra candidate directions (ego frame, any non-zero length).
    rng : numpy.random.Generator, optional
        Adds :data:`N_RANDOM_DIRECTIONS` random candidate directions.
    types : sequence of str, optional
        The recognisable object types; default the types of the result's matched objects.
    detection : float
        Probability, in (0, 1], that an object in view is recognised.
    depth_factor, min_sigma : float
        Eq. 6 percept noise ``sigma = max(min_sigma, rho^2 / depth_factor)`` (m).
    n_sigma, margin : float
        Two predicted same-type points closer than ``n_sigma sqrt(2) sigma + margin`` look the
        same; ``margin`` (m) covers the pose error of the hypotheses and the model's inaccuracy.
    joint_limits : mapping joint name -> (lower, upper), optional
        Radians, for ``head``; they narrow the head's own limits (``head.limits``).
    max_sights : int, optional
        At most this many percepts come back from a look (a random subset of those detected);
        default no cap.
    percepts : sequence of perception.Percept, optional
        The percepts in hand (ego frame): a predicted sight that repeats one of them
        (:func:`merge_percepts`) adds nothing, as the loop merges it away.

    Returns
    -------
    ViewPlan

    Raises
    ------
    NonFiniteError
        The result holds no pose.
    WorldGraphError
        Bad arguments (the subclass and the message name the argument and the value).
    """
    fov, max_range, detection, depth_factor, min_sigma, n_sigma, margin = _check_common(
        world, result, fov_deg, max_range, detection, depth_factor, min_sigma, n_sigma, margin)
    if head is not None and not isinstance(head, KinematicChain):
        raise ArgumentTypeError(f"head must be a perception.KinematicChain or None, "
                                f"got {type(head).__name__}")
    extra = np.zeros((0, 3)) if candidates is None else _directions("candidates", candidates)
    if rng is not None:
        rng = generator("rng", rng)
    if head is not None and joint_limits is not None:
        _check_limits(head, joint_limits)
    if max_sights is not None:
        max_sights = strict_int("max_sights", max_sights, minimum=1, maximum=10**9)
    in_hand = _percepts_in_hand(percepts)
    pred = _predict(world, result, types, fov, max_range, depth_factor, min_sigma, n_sigma, margin, in_hand)
    if not _aimable(pred):
        # the pose is known too poorly to be sure of any object in view: aim at the predicted
        # directions as they are (a look where the objects should be beats a look at nothing)
        pred = replace(pred, cos_lim=_cos_limits(pred.rho, math.radians(fov / 2.0), (0.0, 0.0)))
    H = len(pred.poses)
    disc = np.asarray(pred.tells.any(axis=1))                        # (H, n): tells h from some j
    informative = np.any(pred.info[0] != 0.0, axis=1)                # matchable sights, chosen pose
    dirs = [_FIXED, extra, pred.unit[0][informative]] + [pred.unit[h][disc[h] & pred.in_range[h]]
                                                         for h in range(H)]
    if rng is not None:
        dirs.append(_unit_rows(rng.standard_normal((N_RANDOM_DIRECTIONS, 3))))
    D = _distinct_directions(np.vstack(dirs))
    score, gain, seen = _look_values(pred, D, detection, max_sights)
    shifted = D
    kernels = [math.cos(min(math.pi, math.radians(fov)))] + [None] * (RECENTRE_STEPS - 1)
    for kernel in kernels:  # recentre the candidates on what they would see (mean shift)
        shifted = _distinct_directions(_recentred(pred, shifted, kernel))
        if not len(shifted):
            break
        D = np.vstack([D, shifted])
        more = _look_values(pred, shifted, detection, max_sights)
        score, gain, seen = (np.concatenate([a, b]) for a, b in zip((score, gain, seen), more, strict=True))
    status: ViewStatus = ("single_hypothesis" if H == 1 else
                          "not_discriminating" if float(score.max()) <= 0.0 else "ok")
    # the most expected information; ties by the probability of ruling the others out, then by
    # the expected number of objects in view
    best = int(np.lexsort((-seen, -np.round(score, 12), -np.round(gain, 9)))[0])
    d = D[best]
    expected, disc_in_view = [], []
    ranges: list[list[NDArray[np.float64]]] = [[], [], []]  # discriminating, informative, all in view
    for h in range(H):
        view = _in_view(pred, h, d[None])[0]
        expected.append(pred.objects[view])
        disc_in_view.append(disc[h][view])
        ranges[0].append(pred.rho[h][view & disc[h]])
        ranges[1].append(pred.rho[h][view & np.any(pred.info[h] != 0.0, axis=1)])
        ranges[2].append(pred.rho[h][view])
    dist = 0.5 * max_range
    for group in ranges:
        r = np.concatenate(group)
        if r.size:
            dist = float(np.median(r))
            break
    target = d * dist
    angles, err, within, reached = None, math.nan, None, None
    if head is not None:
        angles, err, within = gaze_angles(head, target, joint_limits=joint_limits)
        reached = bool(err <= GAZE_TOLERANCE and within is not False)
    return ViewPlan(direction=d.copy(), target=target, score=float(score[best]) if status == "ok" else 0.0,
                    information=float(gain[best]),
                    expected=tuple(expected), discriminating=tuple(disc_in_view),
                    hypotheses=tuple(p.copy() for p in pred.poses), weights=pred.weights, status=status,
                    joint_angles=angles, pointing_error=err, gaze_reached=reached, within_limits=within,
                    candidates=len(D))


@dataclass(frozen=True)
class ActiveLocalization:
    """Result of :func:`active_localize`.

    Attributes
    ----------
    result : LocalizationResult
        The last localisation (of ``percepts``).
    results : tuple of LocalizationResult
        Before any look, then after each look.
    plans : tuple of ViewPlan
        One per look.
    directions : tuple of (3,) float
        The gaze direction of each look (ego frame).
    percepts : tuple of Percept
        The percepts passed in followed by the new ones each look added.
    looks : int
    """

    result: LocalizationResult
    results: tuple[LocalizationResult, ...]
    plans: tuple[ViewPlan, ...]
    directions: tuple[NDArray[np.float64], ...]
    percepts: tuple[Percept, ...]
    looks: int


def merge_percepts(old: Sequence[Percept], new: Sequence[Percept], n_sigma: float = MERGE_SIGMAS,
                   floor: float = MERGE_FLOOR) -> list[Percept]:
    """``old`` followed by the percepts of ``new`` that are not a second sight of an old one: a new
    percept within ``n_sigma sqrt(s_old^2 + s_new^2) + floor`` (m) of an old percept of its type
    is dropped (an object seen again; the association matches one percept per object)."""
    old, new = list(old), list(new)
    if not new:
        return old
    again = _repeats(np.array([q.position for q in new], dtype=np.float64), np.array([q.type for q in new]),
                     np.array([q.sigma for q in new], dtype=np.float64), old, n_sigma, floor)
    return old + [q for q, rep in zip(new, again, strict=True) if not rep]


def depth_factor_of(percepts: Sequence[Percept], default: float = DEFAULT_DEPTH_FACTOR) -> float:
    """The eq. 6 factor of percepts (1/m): the median of ``rho^2 / sigma`` over those at least
    :data:`MIN_FACTOR_RANGE` from the ego origin (nearer ones may sit on the sigma floor);
    ``default`` when there are none."""
    values = [float(p.position @ p.position) / p.sigma for p in percepts
              if float(np.linalg.norm(p.position)) >= MIN_FACTOR_RANGE and p.sigma > 0]
    return float(np.median(values)) if values else default


def _learned_cap(cap: int | None, plan: ViewPlan, returned: int, detection: float) -> int | None:
    """The cap on percepts per look that the looks so far reveal: a look that returned fewer than
    half the detections its plan expected (:data:`MIN_CAP_EVIDENCE` at least) caps at the most
    any look returned."""
    expected = detection * float(np.mean([len(e) for e in plan.expected])) if plan.expected else 0.0
    if expected >= MIN_CAP_EVIDENCE and returned < 0.5 * expected:
        return max(returned, cap or 0, 1)
    if cap is not None and returned > cap:
        return returned
    return cap


def _imprecise(result: LocalizationResult, goal_rotation_3sigma: float | None) -> bool:
    """An "ok" result whose 3-sigma rotation bound exceeds the goal (or is not finite)."""
    if goal_rotation_3sigma is None or result.status != "ok":
        return False
    return not result.rotation_3sigma <= goal_rotation_3sigma  # NaN: not finite


def active_localize(world: WorldModel, percepts: Sequence[Percept],
                    look: Callable[[NDArray[np.float64]], Sequence[Percept]], *, max_looks: int = 2,
                    planner: Callable[[LocalizationResult], NDArray[np.float64] | ViewPlan] | None = None,
                    method: str = "ml", tol: AssociationTolerances | None = None,
                    fov_deg: float = 60.0, max_range: float = 8.0, types: Sequence[str] | None = None,
                    head: KinematicChain | None = None, look_while: Sequence[str] = ("ambiguous", "weak"),
                    goal_rotation_3sigma: float | None = GOAL_ROTATION_3SIGMA, gravity: Gravity = "auto",
                    depth_factor: float | None = None, detection: float = 0.9, max_sights: int | None = None,
                    tolerances: AssociationTolerances | None = None) -> ActiveLocalization:
    """Localise; while the status is in ``look_while`` (default ``"ambiguous"`` and ``"weak"``) and
    looks remain:
    plan a view, look, and localise again with the old and new percepts (:func:`merge_percepts`
    drops second sights).

    Parameters
    ----------
    world : WorldModel
    percepts : sequence of perception.Percept
        Ego frame.
    look : callable direction -> sequence of Percept
        Turns the head to the (3,) ego direction and returns what it recognises, in the same
        ego frame (the robot does not move).
    max_looks : int
        At most this many looks (>= 0).
    planner : callable result -> ViewPlan or (3,) direction, optional
        Default :func:`plan_view` with ``fov_deg``, ``max_range``, ``types`` and ``head``.
    method, tol
        Passed to :func:`~worldgraph.localize`.
    look_while : sequence of str
        Statuses that call for another look, among those that come with a pose (``"ambiguous"``,
        ``"weak"``, ``"inconsistent"``, ``"outside_region"``, ``"ok"``); with ``"weak"`` (the
        default) a unique but poorly determined pose also gets looks (plan_view's
        ``"single_hypothesis"`` view, where the most objects are expected): in the kitchen at 5
        percepts (1 false) that lifts unique-correct after two looks from 87.5 % to 99 %.
    goal_rotation_3sigma : float or None
        Radians (default :data:`GOAL_ROTATION_3SIGMA`, 2 degrees). An ``"ok"`` answer whose 3-sigma
        rotation bound (about the worst axis, from ``pose_covariance``) is wider than this also
        gets looks, to add landmarks that pin the rotation; the final status is still the one
        ``localize`` gives. ``None`` looks only while the status is in ``look_while``.
    gravity : "auto", (3,) float or None
        Passed to every :func:`~worldgraph.localize` call (:mod:`worldgraph.gravity`; the head
        turns, the ego frame does not, so one up vector holds for all the looks).
    depth_factor : float, optional
        Eq. 6 noise of the predicted sights for the default planner (``sigma = rho^2 /
        depth_factor``); default estimated from the percepts passed in (:func:`depth_factor_of`).
    detection, max_sights
        The default planner's look model (:func:`plan_view`): the probability that an object in
        view is recognised, and at most how many percepts a look returns.  Default: no cap until
        a look returns fewer than half the detections its plan expected; from then on the most
        any look returned (a recogniser that reports a few objects per view).
    tolerances : AssociationTolerances, optional
        Deprecated alias of ``tol`` (a :class:`DeprecationWarning`; both at once raise
        :class:`~worldgraph.errors.ArgumentTypeError`).

    Returns
    -------
    ActiveLocalization
        Stops early when the status is not in ``look_while`` (a unique answer, or a failure no
        look is planned for).
    """
    if not callable(look):
        raise ArgumentTypeError(f"look must be a callable direction -> list of Percept, "
                                f"got {type(look).__name__}")
    if planner is not None and not callable(planner):
        raise ArgumentTypeError(f"planner must be None or a callable result -> ViewPlan or direction, got "
                                f"{type(planner).__name__}")
    max_looks = strict_int("max_looks", max_looks, minimum=0, maximum=1000)
    statuses = as_list("look_while", look_while, "status names")
    if goal_rotation_3sigma is not None:
        goal_rotation_3sigma = positive_float("goal_rotation_3sigma", goal_rotation_3sigma)
        g = goal_rotation_3sigma
        if g > math.pi:
            raise OutOfRangeError(f"goal_rotation_3sigma = {g!r} is an angle in radians and must be <= pi; "
                                  f"did you mean degrees? np.radians({g:g}) = {math.radians(g):.4g}")
    for i, st in enumerate(statuses):
        if st not in _LOOK_STATUSES:
            raise OutOfRangeError(f"look_while[{i}] = {st!r} is not a status that comes with a pose; "
                                  f"choose among {_LOOK_STATUSES}")
    tol = _tol_argument("active_localize", tol, tolerances)
    tol = ASSOCIATION_TOLERANCES if tol is None else tol
    current = check_world_and_percepts(world, percepts)
    _check_gravity(gravity, tol)  # a bad gravity fails before the first look
    learn_cap = max_sights is None
    cap = None if max_sights is None else strict_int("max_sights", max_sights, minimum=1, maximum=10**9)
    detection = positive_float("detection", detection, maximum=1.0)
    if depth_factor is None:
        depth_factor = depth_factor_of(current)
    else:
        depth_factor = _depth_factor(depth_factor)
    result = localize(world, current, method, tol=tol, gravity=gravity)
    results, plans = [result], []
    directions: list[NDArray[np.float64]] = []
    while len(directions) < max_looks and (result.status in statuses
                                           or _imprecise(result, goal_rotation_3sigma)):
        if planner is None:
            plan: ViewPlan | NDArray[np.float64] = plan_view(world, result, fov_deg=fov_deg,
                                                             max_range=max_range, types=types, head=head,
                                                             depth_factor=depth_factor, detection=detection,
                                                             max_sights=cap, percepts=current)
        else:
            plan = planner(result)
        if isinstance(plan, ViewPlan):
            plans.append(plan)
            d = plan.direction
        else:
            d = float_array("planner(result)", plan, (3,))
            if not np.linalg.norm(d) > 0:
                raise OutOfRangeError(f"planner(result) returned a zero direction {d.tolist()}")
            d = d / np.linalg.norm(d)
        new = as_list("look(direction)", look(d.copy()), "perception.Percept", exclude=(Percept,))
        for i, p in enumerate(new):
            if not isinstance(p, Percept):
                raise ArgumentTypeError(f"look(direction)[{i}] must be a perception.Percept, "
                                        f"got {type(p).__name__}")
        directions.append(d)
        if planner is None and learn_cap and isinstance(plan, ViewPlan):
            cap = _learned_cap(cap, plan, len(new), detection)
        current = merge_percepts(current, new)
        result = localize(world, current, method, tol=tol, gravity=gravity)
        results.append(result)
    return ActiveLocalization(result=result, results=tuple(results), plans=tuple(plans),
                              directions=tuple(directions), percepts=tuple(current), looks=len(directions))
