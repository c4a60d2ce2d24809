"""The loop: localise, plan, look, localise again (:func:`active_localize`)."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Literal, get_args

import numpy as np
from numpy.typing import NDArray

from perception import KinematicChain, Percept

from .._checks import as_list, integer, percept_list, real_array, real_scalar
from ..association.consistency import check_world_and_percepts
from ..errors import WorldGraphError
from ..localization.pipeline import localize
from ..localization.result import LocalizationResult, PoseStatus
from ..localization.settings import LocalizeSettings, settings_of
from ..model import WorldModel
from ..pose.gravity import Gravity
from ..tolerances import (
    AssociationTolerances,
)
from .plan import ViewPlan, _depth_factor, plan_view
from .predict import DEFAULT_DEPTH_FACTOR, MERGE_FLOOR, MERGE_SIGMAS, _repeats

#: :func:`depth_factor_of` reads the eq. 6 factor from percepts at least this far (m) ...
MIN_FACTOR_RANGE = 1.0
#: ``active_localize`` infers a cap on percepts per look only from a look whose plan expected at
#: least this many detections.
MIN_CAP_EVIDENCE = 4.0

#: Localisation statuses that come with a pose to plan a view from (the trusted ones and the
#: poses that failed their own check or the caller's region): what ``look_while`` may hold.
LookStatus = Literal[PoseStatus, "inconsistent", "outside_region"]
_LOOK_STATUSES: tuple[str, ...] = get_args(LookStatus)
#: :func:`active_localize` also looks while an "ok" answer's 3-sigma rotation bound is wider than
#: this (radians): 2 degrees, what a pose judged correct may be off by in the benchmarks.
GOAL_ROTATION_3SIGMA = math.radians(2.0)
#: Statuses without a pose to plan from that :func:`active_localize` answers by exploring: a look
#: where the robot has not looked yet.  ``"inconsistent"`` is among them: its pose (when it has
#: one) is one the percepts contradict, e.g. a free-search pose tilted on its side because the
#: few true percepts of a first view are far and bunched together; more percepts elsewhere
#: outvote a false one.
ExploreStatus = Literal["too_few_percepts", "no_association", "degenerate", "degenerate_coplanar",
                        "degenerate_collinear", "inconsistent"]
EXPLORE_STATUSES: tuple[str, ...] = get_args(ExploreStatus)
#: Why :func:`active_localize` took a look: ``"explore"``, no pose yet, towards the widest arc of
#: ego yaw not looked at; ``"plan"``, from the pose (:func:`plan_view` or the caller's planner).
LookReason = Literal["explore", "plan"]
#: The ego yaws (degrees) a default :meth:`perception.mujoco.MujocoScene.scan` or
#: :func:`perception.simulate_scan` sweeps its neck over: what the percepts passed to
#: :func:`active_localize` are taken to have covered, unless told otherwise.
SCANNED_YAW_DEG = (-70.0, 70.0)
#: Ego yaw step (degrees) of the directions :func:`explore_direction` considers.
EXPLORE_STEP_DEG = 5.0
#: Elevation (degrees, negative: down) of :func:`explore_direction`'s looks: recognisable objects
#: (handles, drawers, knobs, doors) sit mostly below a head at standing height; 5 degrees down,
#: with a look's pitch zigzag of 10 degrees and a 45-degree vertical field of view, spans from
#: knee height to wall cabinets at 2-3 m.
EXPLORE_PITCH_DEG = -5.0


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
    reasons : tuple of {"explore", "plan"}
        Why each look was taken (:data:`LookReason`): to explore (no pose yet) or planned from
        the pose.
    """

    result: LocalizationResult
    results: tuple[LocalizationResult, ...]
    plans: tuple[ViewPlan, ...]
    directions: tuple[NDArray[np.float64], ...]
    percepts: tuple[Percept, ...]
    looks: int
    reasons: tuple[LookReason, ...] = ()


def explore_direction(looked: Sequence[NDArray[np.float64]], scanned_yaw_deg: tuple[float, float] | None,
                      fov_deg: float) -> NDArray[np.float64]:
    """Where to look with no pose yet: the horizontal ego direction farthest in yaw from all that
    was looked at.

    Looked at: the sweep ``scanned_yaw_deg`` (neck yaws, degrees) widened by half the field of
    view either side, and each direction in ``looked`` widened by half the field of view.  The
    answer is the middle of the widest arc of yaw outside them; once the whole circle is covered,
    the yaw farthest from every direction in ``looked`` (a second chance where the looks were
    fewest); with nothing looked at, straight ahead.  With no pose, every yaw is as likely to
    face any part of the map, so the map cannot rank the directions: covering the circle in the
    fewest looks is what finds objects soonest.
    The look points :data:`EXPLORE_PITCH_DEG` below the horizon.

    Returns
    -------
    (3,) float
        A unit vector.
    """
    half = math.radians(fov_deg) / 2.0
    yaws = np.radians(np.arange(-180.0, 180.0, EXPLORE_STEP_DEG))
    looked_yaws = np.array([math.atan2(d[1], d[0]) for d in looked if math.hypot(d[0], d[1]) > 0.0])

    def gap(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.abs((a[:, None] - b[None, :] + np.pi) % (2.0 * np.pi) - np.pi)

    # the angular distance of every candidate yaw to the covered set (negative inside it)
    clearance = np.full(yaws.size, np.inf)
    if looked_yaws.size:
        clearance = np.minimum(clearance, (gap(yaws, looked_yaws) - half).min(axis=1))
    if scanned_yaw_deg is not None:
        lo, hi = math.radians(scanned_yaw_deg[0]) - half, math.radians(scanned_yaw_deg[1]) + half
        if hi - lo >= 2.0 * np.pi:
            clearance = np.minimum(clearance, -1.0)
        else:
            mid, width = (lo + hi) / 2.0, (hi - lo) / 2.0
            clearance = np.minimum(clearance, gap(yaws, np.array([mid]))[:, 0] - width)
    if not np.any(clearance > 0.0) and looked_yaws.size:
        clearance = gap(yaws, looked_yaws).min(axis=1)
    # nothing looked at yet: straight ahead
    yaw = 0.0 if np.all(np.isinf(clearance)) else float(yaws[int(np.argmax(clearance))])
    pitch = math.radians(EXPLORE_PITCH_DEG)
    return np.array([math.cos(pitch) * math.cos(yaw), math.cos(pitch) * math.sin(yaw), math.sin(pitch)])


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
                    up_sigma: float | None = None, depth_factor: float | None = None, detection: float = 0.9,
                    max_sights: int | None = None, explore_while: Sequence[str] = EXPLORE_STATUSES,
                    scanned_yaw_deg: tuple[float, float] | None = SCANNED_YAW_DEG,
                    settings: LocalizeSettings | None = None) -> ActiveLocalization:
    """Localise; while looks remain and there is no pose yet (a status in ``explore_while``) look
    where the robot has not looked (:func:`explore_direction`); while the status is in
    ``look_while`` (default ``"ambiguous"`` and ``"weak"``) plan a view from the pose and look;
    after each look localise again with the old and new percepts (:func:`merge_percepts` drops
    second sights).  ``percepts`` may be empty (nothing recognised yet).

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
        Passed to every :func:`~worldgraph.localize` call (:mod:`worldgraph.pose.gravity`; the head
        turns, the ego frame does not, so one up vector holds for all the looks).
    up_sigma : float, optional
        Gravity's tilt prior of the pose (radians), passed to every :func:`~worldgraph.localize`.
    depth_factor : float, optional
        Eq. 6 noise of the predicted sights for the default planner (``sigma = rho^2 /
        depth_factor``); default estimated from the percepts passed in (:func:`depth_factor_of`).
    detection, max_sights
        The default planner's look model (:func:`plan_view`): the probability that an object in
        view is recognised, and at most how many percepts a look returns.  Default: no cap until
        a look returns fewer than half the detections its plan expected; from then on the most
        any look returned (a recogniser that reports a few objects per view).

    explore_while : sequence of str
        Statuses without a pose to plan from that call for an exploring look (default
        :data:`EXPLORE_STATUSES`: too few percepts, no association, degenerate landmarks, a pose
        the percepts contradict); ``()`` never explores.  A status in both ``explore_while`` and
        ``look_while`` is explored.
    scanned_yaw_deg : (float, float) or None
        The neck yaws (degrees) the percepts passed in were swept over (default
        :data:`SCANNED_YAW_DEG`, the default scan's); exploring looks go elsewhere first.
        ``None``: nothing has been looked at yet.
    settings : LocalizeSettings, optional
        Every setting of :func:`~worldgraph.localize` in one object, used by every localisation
        of the loop; ``method``, ``tol``, ``gravity`` and ``up_sigma`` given with values other
        than their defaults replace its fields.

    Returns
    -------
    ActiveLocalization
        Stops early when the status is in neither ``look_while`` nor ``explore_while`` (a unique
        answer, or a failure no look is planned for).
    """
    if not callable(look):
        raise WorldGraphError(f"look must be a callable direction -> list of Percept, "
                              f"got {type(look).__name__}")
    if planner is not None and not callable(planner):
        raise WorldGraphError(f"planner must be None or a callable result -> ViewPlan or direction, got "
                              f"{type(planner).__name__}")
    max_looks = integer("max_looks", max_looks, minimum=0, maximum=1000)
    statuses = as_list("look_while", look_while, "status names")
    if goal_rotation_3sigma is not None:
        goal_rotation_3sigma = real_scalar("goal_rotation_3sigma", goal_rotation_3sigma, positive=True)
        g = goal_rotation_3sigma
        if g > math.pi:
            raise WorldGraphError(f"goal_rotation_3sigma = {g!r} is an angle in radians and must be <= pi; "
                                  f"did you mean degrees? np.radians({g:g}) = {math.radians(g):.4g}")
    for i, st in enumerate(statuses):
        if st not in _LOOK_STATUSES:
            raise WorldGraphError(f"look_while[{i}] = {st!r} is not a status that comes with a pose; "
                                  f"choose among {_LOOK_STATUSES}")
    explore = as_list("explore_while", explore_while, "status names")
    for i, st in enumerate(explore):
        if st not in EXPLORE_STATUSES:
            raise WorldGraphError(f"explore_while[{i}] = {st!r} is not a status without a pose that a look "
                                  f"can mend; choose among {EXPLORE_STATUSES}")
    if scanned_yaw_deg is not None:
        sweep = real_array("scanned_yaw_deg", scanned_yaw_deg, (2,))
        if not sweep[0] <= sweep[1]:
            raise WorldGraphError(f"scanned_yaw_deg = {sweep.tolist()} must be (lowest, highest) degrees")
        scanned: tuple[float, float] | None = (float(sweep[0]), float(sweep[1]))
    else:
        scanned = None
    fov_deg = real_scalar("fov_deg", fov_deg, positive=True, maximum=360.0)
    # checked once, before the first look (a bad gravity or up_sigma fails here)
    settings = settings_of(settings, method=method, tol=tol, gravity=gravity, up_sigma=up_sigma)
    current = check_world_and_percepts(world, percepts)
    learn_cap = max_sights is None
    cap = None if max_sights is None else integer("max_sights", max_sights, minimum=1, maximum=10**9)
    detection = real_scalar("detection", detection, positive=True, maximum=1.0)
    explicit_factor = depth_factor
    if depth_factor is None:
        depth_factor = depth_factor_of(current)
    else:
        depth_factor = _depth_factor(depth_factor)
    result = localize(world, current, settings=settings)
    results, plans = [result], []
    directions: list[NDArray[np.float64]] = []
    reasons: list[LookReason] = []
    while len(directions) < max_looks:
        plan: ViewPlan | NDArray[np.float64] | None = None
        if result.status in explore:
            reasons.append("explore")
            d = explore_direction(directions, scanned, fov_deg)
        elif result.status in statuses or _imprecise(result, goal_rotation_3sigma):
            reasons.append("plan")
            if planner is None:
                plan = plan_view(world, result, fov_deg=fov_deg, max_range=max_range, types=types, head=head,
                                 depth_factor=depth_factor, detection=detection, max_sights=cap,
                                 percepts=current)
            else:
                plan = planner(result)
            if isinstance(plan, ViewPlan):
                plans.append(plan)
                d = plan.direction
            else:
                d = real_array("planner(result)", plan, (3,))
                if not np.linalg.norm(d) > 0:
                    raise WorldGraphError(f"planner(result) returned a zero direction {d.tolist()}")
                d = d / np.linalg.norm(d)
        else:
            break
        new = percept_list("look(direction)", look(d.copy()))
        directions.append(d)
        if planner is None and learn_cap and isinstance(plan, ViewPlan):
            cap = _learned_cap(cap, plan, len(new), detection)
        current = merge_percepts(current, new)
        if reasons[-1] == "explore" and explicit_factor is None and new:
            depth_factor = depth_factor_of(current)
        result = localize(world, current, settings=settings)
        results.append(result)
    return ActiveLocalization(result=result, results=tuple(results), plans=tuple(plans),
                              directions=tuple(directions), percepts=tuple(current), looks=len(directions),
                              reasons=tuple(reasons))
