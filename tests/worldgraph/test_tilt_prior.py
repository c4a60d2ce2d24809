"""Gravity in the pose fit: the tilt prior (worldgraph.pose.gravity.TiltPrior), the ML pose
with it (refine_pose(tilt_prior=), checked against scipy's least squares on the same residuals),
localize's up_sigma, and "ambiguous" only for a rival the gravity search can stand for."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

import radialopt as ro
import worldgraph as wg
from perception import Percept
from worldgraph.errors import WorldGraphError
from worldgraph.localization import localize, validate
from worldgraph.pose import refine_pose
from worldgraph.pose.gravity import FREE_SEARCH, TILT_GATE, TiltPrior
from worldgraph.pose.validation import PoseFit
from worldgraph.tolerances import ASSOCIATION_TOLERANCES

EZ = np.array([0.0, 0.0, 1.0])

# a wall of typed landmarks, not symmetric, 2-6 m ahead of a robot at the origin (head 1.5 m)
LANDMARKS = np.array([[3.0, -1.2, 0.9], [3.4, 0.3, 1.6], [4.1, 1.5, 0.4], [5.2, -0.4, 2.1],
                      [5.8, 1.1, 1.0], [4.6, -1.9, 1.3], [3.7, 2.2, 2.0]])
TYPES = ["door", "handle", "drawer", "knob", "door", "handle", "drawer"]


def _pose(yaw_deg: float, tilt_deg: float = 0.0, tilt_axis: float = 0.3) -> np.ndarray:
    T = np.eye(4)
    level = Rotation.from_euler("z", yaw_deg, degrees=True)
    axis = np.array([math.cos(tilt_axis), math.sin(tilt_axis), 0.0])
    T[:3, :3] = (Rotation.from_rotvec(math.radians(tilt_deg) * axis) * level).as_matrix()
    T[:3, 3] = [0.2, -0.1, 1.5]
    return T


def _percepts(pose: np.ndarray, rng: np.random.Generator | None, n: int = 5, depth_factor: float = 1000.0
              ) -> list[Percept]:
    ego = (LANDMARKS[:n] - pose[:3, 3]) @ pose[:3, :3]
    out = []
    for t, x in zip(TYPES[:n], ego, strict=True):
        s = float(x @ x) / depth_factor
        noise = rng.normal(0.0, s, 3) if rng is not None else np.zeros(3)
        out.append(Percept(t, x + noise, s))
    return out


@pytest.fixture(scope="module")
def world() -> wg.WorldModel:
    return wg.WorldModel.from_arrays(TYPES, LANDMARKS, max_link_length=8.0)


def test_tilt_prior_residual_and_jacobian_match_finite_differences() -> None:
    rng = np.random.default_rng(3)
    prior = TiltPrior(np.array([0.1, -0.2, 1.0]), math.radians(2.0))
    assert np.linalg.norm(prior.up) == pytest.approx(1.0)
    R = Rotation.from_rotvec(rng.normal(0.0, 0.3, 3)).as_matrix()
    J = prior.jacobian(R)
    h = 1e-7
    for j in range(3):
        d = np.zeros(3)
        d[j] = h
        numeric = (prior.residual(Rotation.from_rotvec(d).as_matrix() @ R)
                   - prior.residual(Rotation.from_rotvec(-d).as_matrix() @ R)) / (2 * h)
        np.testing.assert_allclose(J[:, j], numeric, atol=1e-6)
    # a level pose: the prior pins roll and pitch (world x, y) by 1 / sd^2, yaw not at all
    level = Rotation.from_euler("z", 40, degrees=True).as_matrix()
    info = TiltPrior(EZ, 0.02).information(level)
    np.testing.assert_allclose(info[:3, :3], np.diag([2500.0, 2500.0, 0.0]), atol=1e-9)
    assert not info[3:].any() and not info[:, 3:].any()
    # a tilt of theta costs sin(theta)^2 / sd^2
    tilted = Rotation.from_rotvec([0.1, 0.0, 0.0]).as_matrix()
    assert TiltPrior(EZ, 0.05).cost(tilted) == pytest.approx(math.sin(0.1) ** 2 / 0.05**2)


@pytest.mark.parametrize("sd", [0.0, -1.0, math.inf, math.nan, True, "1"])
def test_tilt_prior_rejects_a_bad_sd(sd) -> None:
    with pytest.raises(WorldGraphError, match="TiltPrior.sd"):
        TiltPrior(EZ, sd)


def test_refine_pose_with_the_prior_is_the_least_squares_optimum() -> None:
    """The reference: scipy's least_squares on the whitened data residuals and the prior's."""
    rng = np.random.default_rng(5)
    truth = _pose(25.0, tilt_deg=2.0)
    ego = (LANDMARKS[:5] - truth[:3, 3]) @ truth[:3, :3]
    covs = np.array([np.diag(rng.uniform(0.01, 0.05, 3)) ** 2 for _ in ego])
    ego = ego + np.array([rng.multivariate_normal(np.zeros(3), c) for c in covs])
    prior = TiltPrior(EZ, math.radians(1.0))
    T, info = refine_pose(ego, LANDMARKS[:5], covs, np.eye(4), tilt_prior=prior)
    L = np.linalg.cholesky(np.linalg.inv(covs))  # C^-1 = L L^T: whitened r = L^T r

    def residuals(p: np.ndarray) -> np.ndarray:
        R = Rotation.from_rotvec(p[:3]).as_matrix()
        r = ego - (LANDMARKS[:5] - p[3:]) @ R
        data = np.einsum("kab,ka->kb", L, r).ravel()
        return np.concatenate([data, (R @ EZ)[:2] / prior.sd])

    start = np.concatenate([Rotation.from_matrix(T[:3, :3]).as_rotvec() + 0.05, T[:3, 3] + 0.1])
    ref = least_squares(residuals, start, xtol=1e-14, ftol=1e-14, gtol=1e-14)
    np.testing.assert_allclose(T[:3, 3], ref.x[3:], atol=1e-6)
    assert Rotation.from_matrix(T[:3, :3] @ Rotation.from_rotvec(ref.x[:3]).as_matrix().T).magnitude() < 1e-6
    # the information is the data's plus the prior's
    data_only = wg.pose.pose_information(T, ego, covs)
    np.testing.assert_allclose(info, data_only + prior.information(T[:3, :3]), rtol=1e-9, atol=1e-9)


def test_the_prior_shrinks_roll_and_pitch_and_leaves_yaw(world) -> None:
    rng = np.random.default_rng(11)
    truth = _pose(10.0)
    percepts = _percepts(truth, rng, depth_factor=150.0)  # a noisy sensor: sigma = rho^2 / 150
    free6d = localize(world, percepts, up_sigma=math.inf)
    prior = localize(world, percepts)  # default: tilt_allowance / 3
    assert free6d.status in ("ok", "weak") and prior.status in ("ok", "weak"), (free6d.message, prior.message)
    assert free6d.correspondences == prior.correspondences
    sd = ASSOCIATION_TOLERANCES.tilt_allowance / 3.0
    var6, varp = np.diag(free6d.pose_covariance)[3:], np.diag(prior.pose_covariance)[3:]
    # the premise: these percepts alone know roll and pitch worse than gravity does
    assert max(var6[0], var6[1]) > sd**2
    assert varp[0] <= sd**2 and varp[1] <= sd**2  # roll and pitch (world x, y): at most the prior's
    assert varp[0] < 0.7 * var6[0] and varp[1] < 0.7 * var6[1]
    assert varp[2] == pytest.approx(var6[2], rel=0.25)  # yaw: the percepts'
    # the answer is level to within the prior, and its NEES is that of a calibrated answer
    e = np.concatenate([truth[:3, 3] - prior.position,
                        Rotation.from_matrix(truth[:3, :3] @ prior.transformation[:3, :3].T).as_rotvec()])
    assert e @ np.linalg.solve(prior.pose_covariance, e) < 20.06


def test_a_level_robot_with_exact_percepts_keeps_its_position(world) -> None:
    truth = _pose(-30.0)
    percepts = _percepts(truth, None)
    a = localize(world, percepts, up_sigma=math.inf)
    b = localize(world, percepts)
    assert a.status == b.status == "ok"
    assert np.linalg.norm(a.position - b.position) < 1e-3
    assert np.linalg.norm(b.position - truth[:3, 3]) < 1e-3


def test_an_imu_up_vector_on_a_tilted_robot_carries_the_prior(world) -> None:
    rng = np.random.default_rng(2)
    truth = _pose(50.0, tilt_deg=15.0)
    percepts = _percepts(truth, rng, n=6)
    up = truth[:3, :3].T @ EZ
    res = localize(world, percepts, gravity=up, up_sigma=math.radians(0.5))
    assert res.status == "ok", res.message
    assert res.search == "gravity"
    tilt_sd = np.sqrt(np.linalg.eigvalsh(res.pose_covariance[3:5, 3:5]))
    assert tilt_sd.max() <= math.radians(0.5) + 1e-12
    assert wg.pose.gravity.tilt_angle(res.transformation, up) < math.radians(0.5)


def test_an_up_vector_the_percepts_contradict_keeps_the_6d_fit(world) -> None:
    """An IMU 10 degrees off, stated to 0.5: the percepts' tilt is far outside the prior, so the 6D
    fit stands (note), and its tilt from the up vector given makes the answer inconsistent."""
    rng = np.random.default_rng(4)
    truth = _pose(0.0)
    percepts = _percepts(truth, rng, n=6)
    wrong_up = Rotation.from_rotvec([math.radians(10.0), 0.0, 0.0]).apply(EZ)
    res = localize(world, percepts, gravity=wrong_up, up_sigma=math.radians(0.5))
    assert "the 6D fit stands" in res.message
    assert res.status == "inconsistent", res.message


def test_tilt_gate_is_the_three_sigma_quantile_of_chi_square_with_two_dof() -> None:
    from scipy.stats import chi2
    assert TILT_GATE == pytest.approx(chi2.ppf(0.9973002039, 2))


@pytest.mark.parametrize("bad, err, text", [
    (0.0, WorldGraphError, "must be > 0"), (-0.1, WorldGraphError, "must be > 0"),
    (10.0, WorldGraphError, "did you mean degrees"), ("0.1", WorldGraphError, "up_sigma must be"),
    (True, WorldGraphError, "up_sigma must be"), (math.nan, WorldGraphError, "must be > 0")])
def test_bad_up_sigma_is_named(world, bad, err, text) -> None:
    with pytest.raises(err, match=text):
        localize(world, _percepts(_pose(0.0), None), up_sigma=bad)


# --- "ambiguous" only for a rival the gravity search can stand for -------------------------------

def _fit(pose: np.ndarray, cost: float) -> PoseFit:
    cov = np.diag([1e-4, 1e-4, 1e-4, 1e-5, 1e-5, 1e-5])
    return PoseFit(pose, np.linalg.inv(cov), cov, ((0, 0), (1, 1), (2, 2), (3, 3)), np.zeros(4),
                   np.arange(4), cost)


def _ctx(gravity: object) -> SimpleNamespace:
    settings = wg.LocalizeSettings(max_position_3sigma=0.25, max_rotation_3sigma=math.radians(5.0),
                                   gravity=gravity)
    return SimpleNamespace(region=ro.Region(np.full(3, -50.0), np.full(3, 50.0)), explicit_region=False,
                           settings=settings, notes=[], false_costs=np.zeros(4))


def test_a_rival_tilted_beyond_the_allowance_does_not_make_a_gravity_answer_ambiguous() -> None:
    best = _fit(_pose(0.0), 10.0)
    on_its_side = _pose(30.0, tilt_deg=90.0)
    on_its_side[:3, 3] += [1.0, 2.0, 0.0]
    rival = _fit(on_its_side, 11.0)
    gravity = "auto"
    plan = _ctx(gravity).settings.plan  # the premise: the gravity search about +z
    assert np.array_equal(plan.up, EZ) and plan.fallback
    assert _ctx(None).settings.plan is FREE_SEARCH
    chosen, choice = validate._choose_step(_ctx(gravity), [(best, 0), (rival, 1)], False)
    assert chosen is best and not choice.ambiguous
    # the free search knows no up: the same rival is a rival
    _, choice = validate._choose_step(_ctx(None), [(best, 0), (rival, 1)], False)
    assert choice.ambiguous
    # and a level rival is one for the gravity search too
    level = _pose(30.0)
    level[:3, 3] += [1.0, 2.0, 0.0]
    _, choice = validate._choose_step(_ctx(gravity), [(best, 0), (_fit(level, 11.0), 1)], False)
    assert choice.ambiguous


def test_two_identical_modules_are_still_ambiguous() -> None:
    module = LANDMARKS[:5]
    copy = module + [0.0, 7.0, 0.0]  # the same module, 7 m to the left: a genuine rival
    world = wg.WorldModel.from_arrays(TYPES[:5] * 2, np.vstack([module, copy]), max_link_length=8.0)
    res = localize(world, _percepts(_pose(0.0), np.random.default_rng(8)))
    assert res.status == "ambiguous", res.message
    assert res.search == "gravity"
    assert any(abs(np.linalg.norm(a[:3, 3] - res.position) - 7.0) < 0.1 for a in res.alternatives)


def test_active_localize_and_tiles_pass_up_sigma_on(world) -> None:
    rng = np.random.default_rng(21)
    percepts = _percepts(_pose(15.0), rng, depth_factor=300.0)
    plain = localize(world, percepts, up_sigma=math.inf)
    prior = localize(world, percepts)
    assert plain.status in ("ok", "weak") and prior.status in ("ok", "weak")
    assert not np.allclose(plain.pose_covariance, prior.pose_covariance)  # the premise: the prior shows
    active = wg.active_localize(world, percepts, lambda d: [], max_looks=0, up_sigma=math.inf)
    np.testing.assert_allclose(active.result.pose_covariance, plain.pose_covariance)
    with pytest.raises(WorldGraphError, match=r"up_sigma = \-1\.0 must be > 0"):
        wg.active_localize(world, percepts, lambda d: [], up_sigma=-1.0)
    tiles = wg.tiles.split(world, np.zeros(len(world), dtype=int))
    tiled = wg.localize_tiled(tiles, percepts, workers=1, up_sigma=math.inf)
    np.testing.assert_allclose(tiled.pose_covariance, plain.pose_covariance)
    np.testing.assert_allclose(wg.localize_tiled(tiles, percepts, workers=1).pose_covariance,
                               prior.pose_covariance)
    with pytest.raises(WorldGraphError, match=r"up_sigma = 0\.0 must be > 0"):
        wg.localize_tiled(tiles, percepts, workers=1, up_sigma=0.0)


def test_the_certificate_proves_the_pose_with_the_prior() -> None:
    """The rotation SDP with the prior's quadratic form: it certifies the MAP pose, not the data's
    own optimum (which the prior makes suboptimal), and its global solve finds the MAP pose."""
    from worldgraph.pose.certificate import certify_pose, solve_pose_sdp

    rng = np.random.default_rng(9)
    truth = _pose(70.0, tilt_deg=1.0)
    ego = (LANDMARKS[:4] - truth[:3, 3]) @ truth[:3, :3] + rng.normal(0.0, 0.03, (4, 3))
    covs = np.broadcast_to(0.03**2 * np.eye(3), (4, 3, 3)).copy()
    prior = TiltPrior(EZ, math.radians(0.5))
    data_only, _ = refine_pose(ego, LANDMARKS[:4], covs, np.eye(4))
    map_pose, _ = refine_pose(ego, LANDMARKS[:4], covs, data_only, tilt_prior=prior)
    assert Rotation.from_matrix(map_pose[:3, :3] @ data_only[:3, :3].T).magnitude() > 1e-3  # the premise
    assert certify_pose(ego, LANDMARKS[:4], covs, map_pose, tilt_prior=prior).certified
    assert not certify_pose(ego, LANDMARKS[:4], covs, data_only, tilt_prior=prior).certified
    assert certify_pose(ego, LANDMARKS[:4], covs, data_only).certified
    sdp, lower = solve_pose_sdp(ego, LANDMARKS[:4], covs, tilt_prior=prior)
    np.testing.assert_allclose(sdp, map_pose, atol=1e-6)
    with pytest.raises(WorldGraphError, match=r"tilt_prior must be a TiltPrior or None, got float"):
        certify_pose(ego, LANDMARKS[:4], covs, map_pose, tilt_prior=0.1)
