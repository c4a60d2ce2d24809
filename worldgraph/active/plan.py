"""The planner: :func:`plan_view` and the scores of given directions (:mod:`worldgraph.active`,
step 5).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any, Literal, cast, get_args

import numpy as np
from numpy.typing import NDArray

from perception import KinematicChain, Percept

from .._checks import generator, integer, percept_list, real_array, real_scalar
from ..errors import WorldGraphError
from ..localization.result import LocalizationResult
from ..model import WorldModel
from ..tolerances import (
    NORM_FLOOR,
)
from .gaze import GAZE_TOLERANCE, _check_limits, gaze_angles
from .predict import (
    DEFAULT_DEPTH_FACTOR,
    SIGMA_FLOOR,
    _aimable,
    _cos_limits,
    _in_view,
    _look_values,
    _predict,
    _Prediction,
    _unit_rows,
)

ViewStatus = Literal[
    "ok",                  # a direction whose look can rule out hypotheses (score > 0)
    "not_discriminating",  # no candidate direction tells the hypotheses apart (score 0)
    "single_hypothesis",   # the result has one hypothesis: nothing to tell apart (score 0)
]
VIEW_STATUSES: tuple[str, ...] = get_args(ViewStatus)


#: Fixed candidate directions spread over the sphere (Fibonacci lattice) added to the
#: object directions.
N_FIXED_DIRECTIONS = 64
#: The planner recentres its candidates on the objects they would see this many times
#: (``_recentred``; the first time on those within the full view angle).
RECENTRE_STEPS = 2
#: Random candidate directions added when ``rng`` is given.
N_RANDOM_DIRECTIONS = 32



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


def _depth_factor(value: object) -> float:
    """The eq. 6 factor (1/m), in [0.001, 1e12]."""
    depth_factor = real_scalar("depth_factor", value, positive=True, maximum=1e12)
    if depth_factor < 1e-3:
        raise WorldGraphError(f"depth_factor = {depth_factor!r} is out of range: must be >= 0.001 (1/m)")
    return depth_factor


def _check_common(world: object, result: object, fov_deg: object, max_range: object, detection: object,
                  depth_factor: object, min_sigma: object, n_sigma: object, margin: object
                  ) -> tuple[float, float, float, float, float, float, float]:
    if not isinstance(world, WorldModel):
        raise WorldGraphError(f"world must be a WorldModel, got {type(world).__name__}")
    if not isinstance(result, LocalizationResult):
        raise WorldGraphError(f"result must be a LocalizationResult, got {type(result).__name__}")
    depth_factor = _depth_factor(depth_factor)
    return (real_scalar("fov_deg", fov_deg, positive=True, maximum=360.0),
            real_scalar("max_range", max_range, positive=True, maximum=1e6),
            real_scalar("detection", detection, positive=True, maximum=1.0), depth_factor,
            real_scalar("min_sigma", min_sigma, positive=True, maximum=1e3),
            real_scalar("n_sigma", n_sigma, positive=True, maximum=1e3),
            real_scalar("margin", margin, minimum=0.0, maximum=1e3))


def _directions(name: str, value: object) -> NDArray[np.float64]:
    arr = real_array(name, value, (None, 3), max_abs=1e12)
    zero = np.flatnonzero(np.linalg.norm(arr, axis=1) == 0)
    if zero.size:
        raise WorldGraphError(f"{name}[{int(zero[0])}] = {arr[zero[0]].tolist()} is no direction "
                              "(zero length)")
    return _unit_rows(arr)


def _view_values(world: object, result: object, directions: object, fov_deg: object, max_range: object,
                 types: object, detection: object, depth_factor: object, min_sigma: object, n_sigma: object,
                 margin: object, max_sights: object, percepts: object
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    fov, max_r, det, df, floor, ns, mg = _check_common(world, result, fov_deg, max_range, detection,
                                                       depth_factor, min_sigma, n_sigma, margin)
    D = _directions("directions", directions)
    cap = None if max_sights is None else integer("max_sights", max_sights, minimum=1, maximum=10**9)
    pred = _predict(cast(WorldModel, world), cast(LocalizationResult, result), types, fov, max_r, df, floor,
                    ns, mg, _percepts_in_hand(percepts))
    score, information, _ = _look_values(pred, D, det, cap)
    return score, information


def _percepts_in_hand(percepts: object) -> list[Percept]:
    if percepts is None:
        return []
    return percept_list("percepts", percepts)


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
    WorldGraphError
        - The result holds no pose.
        - Bad arguments (the subclass and the message name the argument and the value).
    """
    fov, max_range, detection, depth_factor, min_sigma, n_sigma, margin = _check_common(
        world, result, fov_deg, max_range, detection, depth_factor, min_sigma, n_sigma, margin)
    if head is not None and not isinstance(head, KinematicChain):
        raise WorldGraphError(f"head must be a perception.KinematicChain or None, "
                              f"got {type(head).__name__}")
    extra = np.zeros((0, 3)) if candidates is None else _directions("candidates", candidates)
    if rng is not None:
        rng = generator("rng", rng)
    if head is not None and joint_limits is not None:
        _check_limits(head, joint_limits)
    if max_sights is not None:
        max_sights = integer("max_sights", max_sights, minimum=1, maximum=10**9)
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
