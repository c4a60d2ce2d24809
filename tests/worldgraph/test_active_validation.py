"""Active validation: plan_view, gaze_angles, view_scores, active_localize.

The two-room world: room 1 at the world origin (robot pose A = identity), room 2 at pose B (yaw
180 deg, 20 m away), each holding the same ego layout of four handles in front and a knob
behind, so both poses predict those at the same ego spots; the door of room 1 is at ego (0, -3,
0), the door of room 2 at ego (0.8, -3, 0), and beyond them both rooms have a knob at ego (0.3,
-5, 0).  Only the doors (to the right) tell the rooms apart.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import perception as pc
import worldgraph as wg
from worldgraph.active import (
    VAGUE_POSE_STD,
    depth_factor_of,
    gaze_angles,
    merge_percepts,
    sight_information,
    tells_apart,
    view_information,
    view_scores,
)
from worldgraph.association.filters import discriminator
from worldgraph.association.hypotheses import AssociationHypothesis
from worldgraph.errors import (
    WorldGraphError,
)
from worldgraph.localization import LocalizationResult

HANDLES = np.array([[3.0, -1.0, 0.0], [3.0, 0.0, 0.5], [3.0, 1.0, 0.0], [3.0, 0.5, -0.5]])
KNOB = np.array([-3.0, 0.0, 0.0])
DOOR_A = np.array([0.0, -3.0, 0.0])
DOOR_B = np.array([0.8, -3.0, 0.0])
SIDE_KNOB = np.array([0.3, -5.0, 0.0])  # beyond the doors, at the same ego spot in both rooms
HALF_FOV = math.radians(30.0)


def _pose_b() -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = [[-1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]]
    m[:3, 3] = [20.0, 0.0, 0.0]
    return m


def _two_rooms() -> wg.WorldModel:
    B = _pose_b()
    room1 = np.vstack([HANDLES, KNOB, DOOR_A, SIDE_KNOB])
    room2 = np.vstack([HANDLES, KNOB, DOOR_B, SIDE_KNOB]) @ B[:3, :3].T + B[:3, 3]
    types = ["handle"] * 4 + ["knob", "door", "knob"]
    return wg.WorldModel.from_arrays(types * 2, np.vstack([room1, room2]), max_link_length=8.0,
                                     link_margin=0.5)


def _result(poses: list[np.ndarray], costs: list[float], world: wg.WorldModel) -> LocalizationResult:
    """An ambiguous result over ``poses`` (the first chosen), matched to room 1's handles."""
    T = poses[0]
    return LocalizationResult(T, T[:3, 3].copy(), 1e-4 * np.eye(3), ((0, 0), (1, 1), (2, 2), (3, 3)), (),
                              len(poses) > 1, "ambiguous" if len(poses) > 1 else "ok",
                              alternatives=tuple(poses[1:]), near_best_costs=tuple(costs))


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    return math.acos(float(np.clip(a @ b / (np.linalg.norm(a) * np.linalg.norm(b)), -1.0, 1.0)))


def _look_at(world: wg.WorldModel, pose: np.ndarray, half_fov: float = HALF_FOV, max_range: float = 8.0):
    """What a look from ``pose`` sees: exact percepts of the objects in the cone (eq. 6 sigma)."""
    ego = (world.positions - pose[:3, 3]) @ pose[:3, :3]

    def look(d: np.ndarray) -> list[pc.Percept]:
        out = []
        for t, x in zip(world.types, ego, strict=True):
            rho = float(np.linalg.norm(x))
            if 0 < rho <= max_range and _angle(x, d) <= half_fov:
                s = max(1e-3, rho**2 / 1000.0)
                out.append(pc.Percept(str(t), x, s, covariance=s**2 * np.eye(3)))
        return out
    return look


def test_plan_view_looks_at_the_doors_not_at_the_shared_knob():
    world = _two_rooms()
    res = _result([np.eye(4), _pose_b()], [0.0, 0.0], world)
    plan = wg.plan_view(world, res, types=["handle", "knob", "door"])
    assert plan.status == "ok"
    # both doors in view, nothing that both rooms show at one spot
    assert _angle(plan.direction, DOOR_A) <= HALF_FOV and _angle(plan.direction, DOOR_B) <= HALF_FOV
    assert _angle(plan.direction, KNOB) > HALF_FOV
    assert all(_angle(plan.direction, h) > HALF_FOV for h in HANDLES)
    # by hand: each room sees its door, which the other room lacks there; detection 0.9 each
    assert plan.score == pytest.approx(0.9, abs=1e-12)
    assert np.linalg.norm(plan.direction) == pytest.approx(1.0)
    assert [list(world.types[e]) for e in plan.expected] == [["door", "knob"], ["door", "knob"]]
    assert [d.tolist() for d in plan.discriminating] == [[True, False], [True, False]]
    assert plan.target @ plan.direction == pytest.approx(np.linalg.norm(plan.target))
    # the target is on the gaze at the median range of the doors (3 m and |(0.8, -3, 0)|), not of
    # everything in view (the shared knob is 5 m away)
    assert np.linalg.norm(plan.target) == pytest.approx(np.median([3.0, math.hypot(0.8, 3.0)]))
    # the paper's discriminator (largest predicted difference) is the knob behind, which both
    # rooms predict at the same ego spot: a look there tells nothing
    hyps = [AssociationHypothesis((), 0.0, 0, np.eye(4)), AssociationHypothesis((), 0.0, 0, _pose_b())]
    assert world.types[discriminator(world, hyps)] == "knob"
    scores = view_scores(world, res, [KNOB, HANDLES.mean(axis=0), DOOR_A], types=["handle", "knob", "door"])
    assert scores.tolist() == pytest.approx([0.0, 0.0, 0.9])


def test_weights_follow_the_costs():
    world = _two_rooms()
    res = _result([np.eye(4), _pose_b()], [0.0, 2.0 * math.log(3.0)], world)  # A three times as likely
    plan = wg.plan_view(world, res, types=["handle", "knob", "door"])
    assert plan.weights.tolist() == pytest.approx([0.75, 0.25])
    assert plan.score == pytest.approx(0.9)


def test_same_door_spot_tells_nothing():
    """Move room 2's door onto room 1's ego spot: no direction tells the rooms apart."""
    B = _pose_b()
    room = np.vstack([HANDLES, KNOB, DOOR_A])
    world = wg.WorldModel.from_arrays(["handle"] * 4 + ["knob", "door"] + ["handle"] * 4 + ["knob", "door"],
                                      np.vstack([room, room @ B[:3, :3].T + B[:3, 3]]), max_link_length=8.0)
    plan = wg.plan_view(world, _result([np.eye(4), B], [0.0, 0.0], world), types=["handle", "knob", "door"])
    assert plan.status == "not_discriminating" and plan.score == 0.0


def test_unique_result_plans_a_single_hypothesis_view():
    world = _two_rooms()
    plan = wg.plan_view(world, _result([np.eye(4)], [0.0], world), types=["handle", "knob", "door"])
    assert plan.status == "single_hypothesis" and plan.score == 0.0 and len(plan.hypotheses) == 1
    # with nothing known but a vague prior, the four handles in front (3 m, spread over 2 m) tell the
    # most about the pose
    assert all(_angle(plan.direction, h) <= HALF_FOV for h in HANDLES)
    assert plan.information > 0


KINDS = ["handle", "knob", "door", "drawer"]


def _cluster_and_spread() -> tuple[wg.WorldModel, np.ndarray, np.ndarray]:
    """Eight objects in a 0.1 m x 0.3 m patch 3 m ahead (+x; same types 0.1 m apart, beyond the
    matching gate), four spread over a 40 deg cone 2.5-3.5 m behind (-x)."""
    cluster = np.array([[3.0, y, z] for y in (-0.05, 0.05) for z in (-0.15, -0.05, 0.05, 0.15)])
    spread = np.array([[-3.0, -1.1, 0.0], [-3.0, 1.0, 0.5], [-2.5, 0.0, -0.9], [-3.5, 0.5, 1.0]])
    world = wg.WorldModel.from_arrays(KINDS * 3, np.vstack([cluster, spread]), max_link_length=8.0)
    return world, cluster, spread


def _weak(pose_cov: np.ndarray) -> LocalizationResult:
    T = np.eye(4)
    return LocalizationResult(T, T[:3, 3].copy(), pose_cov[:3, :3].copy(), ((0, 8), (1, 9), (2, 10)), (),
                              False, "weak", pose_covariance=pose_cov)


def test_a_weak_answer_looks_at_spread_objects_not_at_a_cluster():
    """A unique but weak answer: the cluster has twice the objects, but they pin the rotation about
    the axis through them hardly at all; the spread ones pin every direction."""
    world, cluster, spread = _cluster_and_spread()
    res = _weak(np.diag([0.02**2] * 3 + [math.radians(2.0) ** 2] * 3))
    plan = wg.plan_view(world, res, types=KINDS)
    assert plan.status == "single_hypothesis"
    assert all(_angle(plan.direction, x) <= HALF_FOV for x in spread)
    assert all(_angle(plan.direction, x) > HALF_FOV for x in cluster)
    ahead, behind = view_information(world, res, [[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]], types=KINDS)
    assert ahead > 5.0  # the cluster is informative (not dropped as ambiguous), less so
    assert behind > ahead + 0.5
    # counting objects (the planner before) would look at the cluster: eight in view against four
    assert view_scores(world, res, [[1.0, 0.0, 0.0]], types=KINDS).tolist() == [0.0]
    n_ahead = sum(_angle(np.array([1.0, 0.0, 0.0]), x) <= HALF_FOV for x in np.vstack([cluster, spread]))
    assert n_ahead == 8 and len(plan.expected[0]) == 4


def test_sights_that_repeat_percepts_in_hand_add_nothing():
    """The loop merges a second sight of a percept away: looking again at the spread objects, whose
    percepts are in hand, tells nothing; the planner turns to the cluster."""
    world, cluster, spread = _cluster_and_spread()
    res = _weak(np.diag([0.02**2] * 3 + [math.radians(2.0) ** 2] * 3))
    seen = [pc.Percept(t, x, 0.01) for t, x in zip(KINDS, spread, strict=True)]
    behind = np.array([[-1.0, 0.0, 0.0]])
    assert view_information(world, res, behind, types=KINDS)[0] > 5.0
    again = view_information(world, res, behind, types=KINDS, percepts=seen)[0]
    assert again == pytest.approx(0.0, abs=1e-12)
    plan = wg.plan_view(world, res, types=KINDS, percepts=seen)
    assert all(_angle(plan.direction, x) <= HALF_FOV for x in cluster)
    # one percept of another type at a spread object's spot repeats nothing
    other = [pc.Percept("knob", spread[0], 0.01)]
    assert view_information(world, res, behind, types=KINDS, percepts=other)[0] == pytest.approx(
        view_information(world, res, behind, types=KINDS)[0])
    with pytest.raises(WorldGraphError, match=r"percepts\[1\] must be a perception\.Percept, got str"):
        wg.plan_view(world, res, types=KINDS, percepts=[seen[0], "door"])


def test_a_near_object_counts_in_view_only_when_the_pose_pins_its_direction():
    """An object 0.4 m ahead: with a 5 cm (1 sigma) position uncertainty its direction may be off
    by some 14 deg (2 sigma), so a look 20 deg off it need not see it; with 5 mm it would."""
    world = wg.WorldModel.from_arrays(["door", "knob", "handle"], [[0.4, 0.0, 0.0], [-3.0, 2.0, 0.0],
                                                                   [-3.0, -2.0, 1.0]], max_link_length=8.0)
    d = [[math.cos(math.radians(20.0)), math.sin(math.radians(20.0)), 0.0]]
    tight = _weak(np.diag([0.005**2] * 3 + [math.radians(0.2) ** 2] * 3))
    loose = _weak(np.diag([0.05**2] * 3 + [math.radians(0.2) ** 2] * 3))
    assert view_information(world, tight, d, types=["door"])[0] > 1.0
    assert view_information(world, loose, d, types=["door"])[0] == pytest.approx(0.0, abs=1e-12)
    assert view_information(world, loose, [[1.0, 0.0, 0.0]], types=["door"])[0] > 1.0  # straight at it


@pytest.mark.parametrize("cov", [np.zeros((6, 6)), -np.eye(6), 1e-30 * np.eye(6), 1e30 * np.eye(6),
                                 np.diag([1.0, 1.0, 1.0, 0.0, 0.0, 0.0]), np.triu(np.ones((6, 6))),
                                 np.full((6, 6), np.nan)])
def test_odd_pose_covariances_plan_finite_looks(cov):
    """Zero, negative, tiny, huge, singular, asymmetric or NaN covariances: a finite plan, no
    overflow (the planner floors the variances, and ignores a covariance with none positive)."""
    world, cluster, spread = _cluster_and_spread()
    res = _weak(np.asarray(cov, dtype=float))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        plan = wg.plan_view(world, res, types=KINDS)
    assert np.isfinite(plan.information) and plan.information >= -1e-9
    assert np.linalg.norm(plan.direction) == pytest.approx(1.0)


def test_a_pose_known_too_poorly_to_aim_still_looks_at_the_objects():
    """Position known to 3 m (1 sigma): no object is surely in any view, so the plan aims at the
    predicted directions as they are rather than at nothing."""
    world, cluster, spread = _cluster_and_spread()
    res = _weak(np.diag([3.0**2] * 3 + [math.radians(30.0) ** 2] * 3))
    plan = wg.plan_view(world, res, types=KINDS)
    assert len(plan.expected[0]) >= 4 and plan.information > 0
    assert all(_angle(plan.direction, x) <= HALF_FOV for x in world.positions[plan.expected[0]])


def test_active_localize_learns_a_cap_on_percepts_per_look(monkeypatch):
    """A looker that reports at most one object of the many in view: after its first look the
    default planner models the cap; a given max_sights is used from the start and kept."""
    import worldgraph.active.loop as active

    calls = []
    real = active.plan_view

    def spy(*args, **kwargs):
        calls.append(kwargs.get("max_sights"))
        return real(*args, **kwargs)

    monkeypatch.setattr(active, "plan_view", spy)
    world, cluster, spread = _cluster_and_spread()
    look_all = _look_at(world, np.eye(4))
    percepts = [pc.Percept(t, x, 0.002, covariance=0.002**2 * np.eye(3))
                for t, x in zip(KINDS[:3], spread[:3], strict=True)]

    def one(d):
        return look_all(d)[:1]

    goal = math.radians(0.001)  # never met: both looks are taken
    out = wg.active_localize(world, percepts, one, types=KINDS, max_looks=2, goal_rotation_3sigma=goal)
    assert out.looks == 2 and len(out.plans) == 2
    assert 0.9 * len(out.plans[0].expected[0]) >= 4  # the first plan expected many, one came back
    assert calls == [None, 1]
    calls.clear()
    wg.active_localize(world, percepts, one, types=KINDS, max_looks=2, max_sights=3,
                       goal_rotation_3sigma=goal)
    assert calls == [3, 3]
    calls.clear()
    wg.active_localize(world, percepts, look_all, types=KINDS, max_looks=2, goal_rotation_3sigma=goal)
    assert calls == [None, None]  # a looker that returns what is in view is not capped


@pytest.mark.parametrize("kwargs, error, name", [
    (dict(depth_factor=1e-6), WorldGraphError, "depth_factor = 1e-06 is out of range"),
    (dict(depth_factor=float("nan")), WorldGraphError, "depth_factor must be finite"),
    (dict(detection=1.5), WorldGraphError, "detection must be <= 1, got 1.5"),
    (dict(detection=0.0), WorldGraphError, "detection must be > 0"),
    (dict(max_sights=0), WorldGraphError, "max_sights must be >= 1"),
    (dict(max_sights=2.5), WorldGraphError, "max_sights must be an integer"),
])
def test_active_localize_checks_its_look_model_before_the_first_look(kwargs, error, name):
    world, cluster, spread = _cluster_and_spread()
    percepts = [pc.Percept(t, x, 0.01) for t, x in zip(KINDS[:3], spread[:3], strict=True)]
    looked = []
    with pytest.raises(error, match=name):
        wg.active_localize(world, percepts, lambda d: looked.append(d) or [], types=KINDS, **kwargs)
    assert looked == []


def _skew(q):
    return np.array([[0.0, -q[2], q[1]], [q[2], 0.0, -q[0]], [-q[1], q[0], 0.0]])


def _expm(w):
    """Rotation matrix of a rotation vector (Rodrigues)."""
    a = float(np.linalg.norm(w))
    if a == 0:
        return np.eye(3)
    K = _skew(w / a)
    return np.eye(3) + math.sin(a) * K + (1 - math.cos(a)) * K @ K


def _numeric_jacobian(pose, X, eps=1e-6):
    """d(ego point)/d(dt, dtheta): t -> t + dt, R -> expm(dtheta) R (pose_covariance's axes), by
    central differences."""
    J = np.zeros((3, 6))
    for k in range(6):
        for sign in (1.0, -1.0):
            d = np.zeros(6)
            d[k] = sign * eps
            R = _expm(d[3:]) @ pose[:3, :3]
            J[:, k] += sign * (R.T @ (X - pose[:3, 3] - d[:3])) / (2 * eps)
    return J


def _rotvec(R):
    c = np.clip((np.trace(R) - 1) / 2, -1, 1)
    a = math.acos(c)
    if a < 1e-12:
        return np.zeros(3)
    return a / (2 * math.sin(a)) * np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])


def _slow_information(world, poses, weights, pose_cov, types, directions, fov_deg, max_range, detection,
                      margin, depth_factor=1000.0, max_sights=None):
    """The expected information of the module docstring by loops: numeric Jacobians, brute-force
    matchability and rule-out counts, the mixture's log-determinants one direction at a time."""
    objs = [o for o in range(len(world)) if world.types[o] in types]
    prior = np.linalg.inv(pose_cov) + np.eye(6) / VAGUE_POSE_STD**2
    H = len(poses)
    mu = np.array([np.concatenate([p[:3, 3] - poses[0][:3, 3], _rotvec(p[:3, :3] @ poses[0][:3, :3].T)])
                   for p in poses])
    mean = weights @ mu
    S = sum(w * np.outer(m - mean, m - mean) for w, m in zip(weights, mu, strict=True))
    before = np.linalg.slogdet(np.linalg.inv(prior) + S)[1]  # no look: no information
    # an object is in view when within the half angle less 2 sigma of its direction's uncertainty
    blur_t = 2 * math.sqrt(np.linalg.eigvalsh(pose_cov[:3, :3])[-1])
    blur_r = 2 * math.sqrt(np.linalg.eigvalsh(pose_cov[3:, 3:])[-1])
    half = math.radians(fov_deg / 2)
    out = []
    for d in directions:
        d = d / np.linalg.norm(d)
        covs, ruled = [], []
        for h, pose in enumerate(poses):
            info = np.zeros((6, 6))
            view = []
            for o in objs:
                x = pose[:3, :3].T @ (world.positions[o] - pose[:3, 3])
                rho = float(np.linalg.norm(x))
                left = half - math.atan2(blur_t, rho) - min(blur_r, half / 2)  # rotation's share <= half
                if 0 < rho <= max_range and left > 0 and x @ d >= math.cos(left) * rho - 1e-12:
                    view.append((o, x, rho))
            kept = detection if max_sights is None else min(detection, max_sights / max(len(view), 1))
            prob = 1.0
            counts = np.zeros(H)
            for o, x, rho in view:
                sigma = max(1e-4, rho**2 / depth_factor)
                gate = 3 * math.sqrt(2) * sigma + margin
                twins = [q for q in objs if q != o and world.types[q] == world.types[o]]
                if all(np.linalg.norm(world.positions[q] - world.positions[o]) > gate for q in twins):
                    J = _numeric_jacobian(pose, world.positions[o])
                    info += kept * J.T @ J / sigma**2
                for j, other in enumerate(poses):
                    ego_j = {q: other[:3, :3].T @ (world.positions[q] - other[:3, 3]) for q in objs}
                    if j != h and all(world.types[q] != world.types[o] or np.linalg.norm(ego_j[q] - x) > gate
                                      for q in objs):
                        counts[j] += 1
            for j in range(H):
                if j != h:
                    prob *= 1 - (1 - kept) ** counts[j]
            covs.append(np.linalg.inv(prior + info))
            ruled.append(prob)
        if H == 1:
            out.append(0.5 * (before - np.linalg.slogdet(covs[0])[1]))
            continue
        mixed = np.linalg.slogdet(sum(w * c for w, c in zip(weights, covs, strict=True)) + S)[1]
        after = sum(w * (r * np.linalg.slogdet(c)[1] + (1 - r) * mixed)
                    for w, r, c in zip(weights, ruled, covs, strict=True))
        out.append(0.5 * (before - after))
    return np.array(out)


@pytest.mark.parametrize("n_hyp, max_sights", [(1, None), (3, None), (3, 2)])
def test_view_information_matches_a_slow_reference(n_hyp, max_sights):
    rng = np.random.default_rng(40 + n_hyp)
    world = _random_world(rng)
    poses = [_random_pose(rng, [4.5, 3.5, 1.2]) for _ in range(n_hyp)]
    costs = [0.0, 1.0, 3.0][:n_hyp]
    A = rng.standard_normal((6, 6))
    pose_cov = 1e-3 * (A @ A.T + 0.1 * np.eye(6))
    T = poses[0]
    res = LocalizationResult(T, T[:3, 3].copy(), pose_cov[:3, :3].copy(), ((0, 0),), (), n_hyp > 1,
                             "ambiguous" if n_hyp > 1 else "weak", alternatives=tuple(poses[1:]),
                             near_best_costs=tuple(costs), pose_covariance=pose_cov)
    types = ["door", "handle", "knob"]
    dirs = rng.standard_normal((25, 3))
    kw = dict(types=types, fov_deg=50.0, max_range=5.0, detection=0.7, margin=0.3, max_sights=max_sights)
    fast = view_information(world, res, dirs, **kw)
    w = np.exp(-np.array(costs) / 2)
    slow = _slow_information(world, poses, w / w.sum(), pose_cov, types, dirs, 50.0, 5.0, 0.7, 0.3,
                             max_sights=max_sights)
    assert np.allclose(fast, slow, rtol=1e-6, atol=1e-6)
    assert fast.max() > 1.0 and fast.min() < fast.max()  # the check compares something
    if n_hyp == 1:  # one hypothesis: the D-optimal gain 0.5 log det (I + C dI) >= 0
        assert fast.min() >= -1e-9


def test_sight_information_is_the_numeric_fisher_information():
    rng = np.random.default_rng(7)
    pose = _random_pose(rng, [1.0, 2.0, 0.5])
    X = rng.uniform(-4, 4, (5, 3))
    sigma = rng.uniform(0.01, 0.1, 5)
    fast = sight_information(X - pose[:3, 3], sigma).reshape(5, 6, 6)
    for k in range(5):
        J = _numeric_jacobian(pose, X[k])
        assert np.allclose(fast[k], J.T @ J / sigma[k] ** 2, rtol=1e-6, atol=1e-3)


def test_depth_factor_of_reads_eq6_from_percepts():
    ps = [pc.Percept("door", [r, 0.0, 0.0], r**2 / 500.0) for r in (0.5, 2.0, 3.0, 6.0)]
    assert depth_factor_of(ps) == pytest.approx(500.0)  # 0.5 m is left out (below 1 m)
    assert depth_factor_of(ps[:1]) == 1000.0  # none far enough: the default
    assert depth_factor_of([pc.Percept("door", [0.0, 3.0, 4.0], 25.0 / 250.0)]) == pytest.approx(250.0)


def test_localize_then_one_look_resolves_the_two_rooms():
    world = _two_rooms()
    look = _look_at(world, np.eye(4))
    percepts = look(np.array([1.0, 0.0, 0.0])) + look(np.array([-1.0, 0.0, 0.0]))  # handles and knob
    assert sorted(p.type for p in percepts) == ["handle"] * 4 + ["knob"]  # the knob behind
    first = wg.localize(world, percepts)
    assert first.status == "ambiguous" and len(first.alternatives) == 1
    assert len(first.near_best_costs) == 2
    # the default recognisable types are the matched ones (handle, knob): no door, no difference
    assert wg.plan_view(world, first).status == "not_discriminating"
    plan = wg.plan_view(world, first, types=["handle", "knob", "door"])
    assert plan.status == "ok" and _angle(plan.direction, DOOR_A) <= HALF_FOV
    out = wg.active_localize(world, percepts, look, types=["handle", "knob", "door"])
    assert out.looks == 1 and [r.status for r in out.results] == ["ambiguous", "ok"]
    assert np.allclose(out.result.transformation, np.eye(4), atol=1e-2)
    assert sorted(p.type for p in out.percepts) == ["door"] + ["handle"] * 4 + ["knob"] * 2


def test_active_localize_stops_at_max_looks_and_takes_a_planner():
    world = _two_rooms()
    look = _look_at(world, np.eye(4))
    percepts = look(np.array([1.0, 0.0, 0.0])) + look(np.array([-1.0, 0.0, 0.0]))
    # a planner that looks behind (at the shared knob) every time: never resolves
    out = wg.active_localize(world, percepts, look, planner=lambda r: np.array([-2.0, 0.0, 0.0]), max_looks=2)
    assert out.looks == 2 and [r.status for r in out.results] == ["ambiguous"] * 3
    assert len(out.percepts) == len(percepts)  # the knob seen again is merged away
    assert wg.active_localize(world, percepts, look, max_looks=0).looks == 0


def test_merge_percepts_drops_second_sights_only():
    a = pc.Percept("door", [1.0, 0.0, 0.0], 0.01)
    again = pc.Percept("door", [1.02, 0.0, 0.0], 0.01)       # 2 cm < 3 sqrt(2) 1 cm + 1 cm
    other_type = pc.Percept("knob", [1.0, 0.0, 0.0], 0.01)
    far = pc.Percept("door", [1.1, 0.0, 0.0], 0.01)          # 10 cm > 5.2 cm
    merged = merge_percepts([a], [again, other_type, far])
    assert merged == [a, other_type, far]


def _slow_scores(world, poses, weights, types, directions, fov_deg, max_range, detection, margin):
    """The score of the module docstring by plain loops over objects (no k-d tree, no matrices)."""
    cos_half = math.cos(math.radians(fov_deg / 2))
    objs = [o for o in range(len(world)) if world.types[o] in types]
    ego = [{o: pose[:3, :3].T @ (world.positions[o] - pose[:3, 3]) for o in objs} for pose in poses]
    out = []
    for d in directions:
        d = d / np.linalg.norm(d)
        total = 0.0
        for h in range(len(poses)):
            prob = 1.0
            for j in range(len(poses)):
                if j == h:
                    continue
                n = 0
                for o in objs:
                    x = ego[h][o]
                    rho = float(np.linalg.norm(x))
                    if not (0 < rho <= max_range and x @ d >= cos_half * rho - 1e-12):
                        continue
                    gate = 3 * math.sqrt(2) * max(1e-4, rho**2 / 1000) + margin
                    if all(world.types[q] != world.types[o] or np.linalg.norm(ego[j][q] - x) > gate
                           for q in objs):
                        n += 1
                prob *= 1 - (1 - detection) ** n
            total += weights[h] * prob
        out.append(total)
    return np.array(out)


def _random_world(rng):
    types = rng.choice(["door", "handle", "knob", "lamp"], 70)
    return wg.WorldModel.from_arrays(types, rng.uniform([0, 0, 0], [9, 7, 2.5], (70, 3)), max_link_length=4.0)


def _random_pose(rng, centre):
    m = np.eye(4)
    a = rng.uniform(0, 2 * np.pi)
    m[:3, :3] = [[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]]
    m[:3, 3] = centre + rng.normal(0, 0.3, 3)
    return m


def test_view_scores_match_a_slow_reference():
    rng = np.random.default_rng(4)
    world = _random_world(rng)
    poses = [_random_pose(rng, [4.5, 3.5, 1.2]) for _ in range(3)]
    costs = [0.0, 1.0, 3.0]
    res = _result(poses, costs, world)
    types = ["door", "handle", "knob"]
    dirs = rng.standard_normal((40, 3))
    fast = view_scores(world, res, dirs, types=types, fov_deg=50.0, max_range=5.0, detection=0.7, margin=0.3)
    w = np.exp(-np.array(costs) / 2)
    slow = _slow_scores(world, poses, w / w.sum(), types, dirs, 50.0, 5.0, 0.7, 0.3)
    assert np.allclose(fast, slow, atol=1e-12)
    assert fast.max() > 0.1 and fast.min() < fast.max()  # the check compares something
    plan = wg.plan_view(world, res, types=types, fov_deg=50.0, max_range=5.0, detection=0.7, margin=0.3,
                        candidates=dirs)
    # the plan maximises the expected information over its candidates, the given ones among them
    given = view_information(world, res, dirs, types=types, fov_deg=50.0, max_range=5.0, detection=0.7,
                             margin=0.3)
    assert plan.information >= given.max() - 1e-9
    at_plan = view_scores(world, res, [plan.direction], types=types, fov_deg=50.0, max_range=5.0,
                          detection=0.7, margin=0.3)
    assert plan.score == pytest.approx(float(at_plan[0]))


def test_score_is_a_lower_bound_of_the_monte_carlo_probability():
    """With three hypotheses the product is a lower bound (Harris); sample the detections."""
    rng = np.random.default_rng(5)
    world = _random_world(rng)
    poses = [_random_pose(rng, [4.5, 3.5, 1.2]) for _ in range(3)]
    res = _result(poses, [0.0, 0.0, 0.0], world)
    types = ["door", "handle", "knob"]
    kw = dict(types=types, fov_deg=70.0, max_range=5.0, detection=0.5, margin=0.3)
    plan = wg.plan_view(world, res, **kw)
    objs = np.flatnonzero(np.isin(world.types, types))
    ego = [(world.positions[objs] - p[:3, 3]) @ p[:3, :3] for p in poses]
    rho = [np.linalg.norm(e, axis=1) for e in ego]
    gate = [3 * math.sqrt(2) * np.maximum(1e-4, r**2 / 1000) + 0.3 for r in rho]
    codes = np.unique(world.types[objs], return_inverse=True)[1]
    u = tells_apart(ego, codes, [(r > 0) & (r <= 5.0) for r in rho], gate)
    trials, hits = 20000, 0.0
    for h in range(3):
        view = (ego[h] @ plan.direction >= math.cos(math.radians(35.0)) * rho[h] - 1e-12) & (rho[h] <= 5.0)
        det = rng.random((trials, len(objs))) < 0.5
        seen = det & view
        ok = np.ones(trials, dtype=bool)
        for j in range(3):
            if j != h:
                ok &= (seen & u[h, j]).any(axis=1)
        hits += ok.mean() / 3
    se = math.sqrt(0.25 / (3 * trials))
    assert plan.score <= hits + 4 * se
    assert plan.score > 0.2


def test_default_head_points_the_camera_at_targets():
    head = pc.default_head()
    rng = np.random.default_rng(6)
    targets = rng.standard_normal((12, 3)) * [3, 3, 1]
    targets = np.vstack([targets, [[-4.0, 0.1, 0.0], [0.5, 0.0, -3.0], [2.0, -2.0, 2.0]]])
    for t in targets:
        q, err, within = gaze_angles(head, t)
        M = head.ego_from_camera(q)
        assert _angle(M[:3, 2], t - M[:3, 3]) <= math.radians(1.0)
        assert err == pytest.approx(_angle(M[:3, 2], t - M[:3, 3]), abs=1e-9)
        assert within is None and q.shape == (head.n_joints,)


def test_plan_view_with_the_default_head():
    world = _two_rooms()
    head = pc.default_head()
    plan = wg.plan_view(world, _result([np.eye(4), _pose_b()], [0.0, 0.0], world), head=head,
                        types=["handle", "knob", "door"])
    M = head.ego_from_camera(plan.joint_angles)
    assert _angle(M[:3, 2], plan.target - M[:3, 3]) <= math.radians(1.0)
    assert plan.gaze_reached is True and plan.within_limits is None


def test_joint_limits_are_kept_and_an_unreachable_gaze_is_flagged():
    head = pc.default_head()
    limits = {j.name: (-0.2, 0.2) for j in head.joints}
    q, err, within = gaze_angles(head, [-4.0, 0.0, 0.0], joint_limits=limits)  # straight behind
    assert within is True and np.all(np.abs(q[:len(head.joints)]) <= 0.2 + 1e-9)
    assert err > math.radians(90.0)
    world = _two_rooms()
    plan = wg.plan_view(world, _result([np.eye(4), _pose_b()], [0.0, 0.0], world), head=head,
                        types=["handle", "knob", "door"], joint_limits=limits)
    assert plan.gaze_reached is False and plan.within_limits is True  # the doors are 90 deg to the right


@pytest.mark.parametrize(("kwargs", "error", "name"), [
    ({"fov_deg": -1.0}, WorldGraphError, "fov_deg must be > 0"),
    ({"fov_deg": 400.0}, WorldGraphError, "fov_deg must be <= 360, got 400.0"),
    ({"max_range": float("nan")}, WorldGraphError, "max_range must be finite"),
    ({"detection": 1.5}, WorldGraphError, "detection must be <= 1, got 1.5"),
    ({"margin": -0.1}, WorldGraphError, "margin must be >= 0"),
    ({"candidates": [[1.0, 0.0]]}, WorldGraphError, r"candidates must have shape \(n, 3\)"),
    ({"candidates": [[1.0, 0.0, 0.0], [0.0, 0.0, 0.0]]}, WorldGraphError,
     r"candidates\[1\] = .* is no direction"),
    ({"types": ["door", "sofa"]}, WorldGraphError,
     r"types\[1\] = 'sofa' is not a type of the world"),
    ({"types": "door"}, WorldGraphError, "types must be a sequence of object type names"),
    ({"rng": 42}, WorldGraphError, "rng must be a numpy.random.Generator"),
    ({"head": "armar"}, WorldGraphError, "head must be a perception.KinematicChain or None"),
    ({"head": pc.default_head(), "joint_limits": {"neck": (0, 1)}}, WorldGraphError,
     r"joint_limits names unknown joints \['neck'\]"),
    ({"head": pc.default_head(), "joint_limits": {"neck_yaw": (1, 0)}}, WorldGraphError,
     r"joint_limits\['neck_yaw'\] must be \(lower, upper\) with lower < upper"),
])
def test_bad_arguments_raise_named_errors(kwargs, error, name):
    world = _two_rooms()
    res = _result([np.eye(4), _pose_b()], [0.0, 0.0], world)
    with pytest.raises(error, match=name):
        wg.plan_view(world, res, **kwargs)


def test_bad_world_result_and_loop_arguments():
    world = _two_rooms()
    res = _result([np.eye(4), _pose_b()], [0.0, 0.0], world)
    with pytest.raises(WorldGraphError, match=r"world must be a WorldModel, got str"):
        wg.plan_view("kitchen", res)
    with pytest.raises(WorldGraphError, match=r"result must be a LocalizationResult, got dict"):
        wg.plan_view(world, {"status": "ambiguous"})
    no_pose = LocalizationResult(np.full((4, 4), np.nan), np.full(3, np.nan), np.full((3, 3), np.nan), (), (),
                                 False, "no_association")
    with pytest.raises(WorldGraphError, match=r"result\.transformation must be a.*no_association"):
        wg.plan_view(world, no_pose, types=["door"])
    look = _look_at(world, np.eye(4))
    percepts = look(np.array([1.0, 0.0, 0.0])) + look(np.array([-1.0, 0.0, 0.0]))
    with pytest.raises(WorldGraphError, match=r"look must be a callable direction \-> list of"):
        wg.active_localize(world, percepts, "look")
    with pytest.raises(WorldGraphError, match=r"max_looks must be >= 0, got \-1"):
        wg.active_localize(world, percepts, look, max_looks=-1)
    with pytest.raises(WorldGraphError, match=r"look\(direction\)\[0\] must be a perception\.Percept,"):
        wg.active_localize(world, percepts, lambda d: ["door"])
    with pytest.raises(WorldGraphError, match="zero direction"):
        wg.active_localize(world, percepts, look, planner=lambda r: np.zeros(3))


def _rotation_3sigma_deg(res: LocalizationResult) -> float:
    return 3.0 * math.degrees(math.sqrt(np.linalg.eigvalsh(res.pose_covariance[3:, 3:])[-1]))


def test_an_ok_answer_with_a_wide_rotation_bound_gets_a_look():
    # room 1 alone: four handles seen with 1 cm noise pin the pose uniquely ("ok") but the rotation
    # only to about 2.5 deg (3 sigma); a look that finds the door and the knobs narrows it
    world = wg.WorldModel.from_arrays(["handle"] * 4 + ["knob", "door", "knob"],
                                      np.vstack([HANDLES, KNOB, DOOR_A, SIDE_KNOB]), max_link_length=8.0,
                                      link_margin=0.5)
    s = 0.01
    percepts = [pc.Percept("handle", h, s, covariance=s**2 * np.eye(3)) for h in HANDLES]
    looked = []

    def look(d: np.ndarray) -> list[pc.Percept]:
        looked.append(d)
        return [pc.Percept(t, x, 0.002, covariance=0.002**2 * np.eye(3))
                for t, x in (("knob", KNOB), ("door", DOOR_A), ("knob", SIDE_KNOB))]

    first = wg.localize(world, percepts)
    assert first.status == "ok" and 2.0 < _rotation_3sigma_deg(first) < 5.0
    assert wg.active_localize(world, percepts, look, goal_rotation_3sigma=None).looks == 0
    assert looked == []
    assert wg.active_localize(world, percepts, look, goal_rotation_3sigma=math.radians(3.0)).looks == 0
    out = wg.active_localize(world, percepts, look)  # default goal: 2 degrees
    assert out.looks == 1 and len(looked) == 1 and out.result.status == "ok"
    assert _rotation_3sigma_deg(out.result) < 2.0
    with pytest.raises(WorldGraphError, match="goal_rotation_3sigma.*degrees"):
        wg.active_localize(world, percepts, look, goal_rotation_3sigma=5.0)
    with pytest.raises(WorldGraphError, match=r"goal_rotation_3sigma must be > 0, got 0\.0"):
        wg.active_localize(world, percepts, look, goal_rotation_3sigma=0.0)


def test_far_objects_are_left_out_of_the_prediction_without_changing_the_scores():
    """Objects beyond max_range + the largest gate of every hypothesis are left out (large worlds);
    the scores still equal the slow reference over every object."""
    from worldgraph.active import _predict

    rng = np.random.default_rng(14)
    types = rng.choice(["door", "handle", "knob", "lamp"], 400)
    pos = rng.uniform([0, 0, 0], [80, 7, 2.5], (400, 3))
    world = wg.WorldModel.from_arrays(types, pos, max_link_length=4.0)
    poses = [_random_pose(rng, [4.5, 3.5, 1.2]) for _ in range(3)]
    costs = [0.0, 1.0, 3.0]
    res = _result(poses, costs, world)
    kinds = ["door", "handle", "knob"]
    pred = _predict(world, res, kinds, 50.0, 5.0, 1000.0, 1e-4, 3.0, 0.3)
    assert 0 < len(pred.objects) < np.count_nonzero(np.isin(world.types, kinds)) // 4
    dirs = rng.standard_normal((30, 3))
    fast = view_scores(world, res, dirs, types=kinds, fov_deg=50.0, max_range=5.0, detection=0.7, margin=0.3)
    w = np.exp(-np.array(costs) / 2)
    slow = _slow_scores(world, poses, w / w.sum(), kinds, dirs, 50.0, 5.0, 0.7, 0.3)
    assert np.allclose(fast, slow, atol=1e-12)
    assert fast.max() > 0.1


def test_a_first_view_the_percepts_contradict_explores():
    # 30 objects of 10 types on a 3 m ring around a level robot; the first view's three percepts
    # are rotated 90 deg about the ego x axis (no level pose explains them), the looks are true
    rng = np.random.default_rng(3)
    kinds = ["door", "handle", "knob", "drawer", "oven", "sink", "panel", "tap", "hob", "fridge"]
    ang = np.linspace(0.0, 2.0 * np.pi, 30, endpoint=False)
    world = wg.WorldModel.from_arrays([kinds[i % 10] for i in range(30)],
                                      np.column_stack([3 * np.cos(ang), 3 * np.sin(ang),
                                                       rng.uniform(0.3, 2.0, 30)]))
    pose = np.eye(4)
    pose[2, 3] = 1.5
    ego = (world.positions - pose[:3, 3]) @ pose[:3, :3]
    flip = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
    first = [pc.Percept(str(world.types[i]), flip @ ego[i], 0.01) for i in range(3)]

    def look(d: np.ndarray) -> list[pc.Percept]:
        seen = ego @ d >= math.cos(HALF_FOV) * np.linalg.norm(ego, axis=1)
        return [pc.Percept(str(t), x, 0.01) for t, x in zip(world.types[seen], ego[seen], strict=True)]

    out = wg.active_localize(world, first, look)
    assert out.results[0].status == "inconsistent"
    assert out.reasons[0] == "explore"
    assert out.result.status == "ok", out.result.message
    assert np.linalg.norm(out.result.position - pose[:3, 3]) < 0.05
    assert _angle(out.result.transformation[:3, 0], np.array([1.0, 0.0, 0.0])) < math.radians(2.0)
    # told not to explore it, the loop stops at the first answer
    stays = wg.active_localize(world, first, look,
                               explore_while=[s for s in wg.active.EXPLORE_STATUSES if s != "inconsistent"])
    assert stays.looks == 0 and stays.result.status == "inconsistent"
