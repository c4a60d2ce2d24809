"""LocalizationResult's reading aids: summary(), the one-line repr, rotation, to_dict().

The "ok" result is built by hand (a 30 deg yaw, covariances whose 3-sigma bounds are round
numbers) so every expected number below is computed here, not taken from the code; real
results from :func:`worldgraph.localize` check the same contracts on what the pipeline returns.
"""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from perception import Percept
from worldgraph import LocalizationResult, localize
from worldgraph.association.hypotheses import AssociationHypothesis
from worldgraph.errors import PoseError, WorldGraphError
from worldgraph.model import WorldModel

YAW = math.radians(30.0)
C, S = math.cos(YAW), math.sin(YAW)
# world_from_ego: a 30 deg turn about the world z axis, ego origin at (1, 2, 0.5)
T = np.array([[C, -S, 0.0, 1.0],
              [S, C, 0.0, 2.0],
              [0.0, 0.0, 1.0, 0.5],
              [0.0, 0.0, 0.0, 1.0]])


def _pose_covariance() -> np.ndarray:
    cov = np.zeros((6, 6))
    cov[:3, :3] = np.diag([0.01**2, 0.02**2, 0.03**2])  # 3 sigma: 0.03, 0.06, 0.09 m
    # rotation sigmas 0.5, 1.0, 0.25 deg about x, y, z: worst-axis 3 sigma is 3 deg
    cov[3:, 3:] = np.diag(np.radians([0.5, 1.0, 0.25]) ** 2)
    return cov


def ok_result(n_hypotheses: int = 3) -> LocalizationResult:
    hyps = tuple(AssociationHypothesis(pairs=((0, 0), (1, 1), (2, 2)), cost=float(k), size=3)
                 for k in range(n_hypotheses))
    cov6 = _pose_covariance()
    return LocalizationResult(
        transformation=T.copy(), position=T[:3, 3].copy(), covariance=cov6[:3, :3].copy(),
        correspondences=((0, 4), (1, 7), (2, 9), (4, 11)), hypotheses=hyps, ambiguous=False,
        status="ok", message="", timings={"association": 0.05, "total": 0.25},
        pose_covariance=cov6, fitness=0.8, inlier_rmse=0.012,
        residuals=np.array([0.5, 1.0, 0.2, np.inf, 0.7]), alternatives=(np.eye(4),),
        log_likelihood_ratio=math.inf, near_best_costs=(3.0, 4.5))


def failed_result() -> LocalizationResult:
    world = WorldModel.from_arrays(["door", "door", "knob", "handle"],
                                   np.array([[0, 0, 1], [3, 0, 1], [0, 2, 1], [2, 2, 1.2]], float))
    res = localize(world, [Percept("door", [1.0, 0.0, 0.0], 0.01), Percept("knob", [0.0, 1.0, 0.0], 0.01)])
    assert res.status == "too_few_percepts"
    return res


def _walk(value):
    yield value
    if isinstance(value, dict):
        for v in value.values():
            yield from _walk(v)
    elif isinstance(value, list):
        for v in value:
            yield from _walk(v)


# ------------------------------------------------------------------------------ rotation

def test_rotation_is_world_from_ego():
    res = ok_result()
    rot = res.rotation
    assert isinstance(rot, Rotation)
    np.testing.assert_allclose(rot.as_matrix(), T[:3, :3], atol=1e-12)
    np.testing.assert_allclose(rot.as_rotvec(), [0.0, 0.0, YAW], atol=1e-12)
    # direction: an ego point maps to the world as R x + t (the ego x axis points 30 deg left of world x)
    ego = np.array([1.0, 0.0, 0.0])
    np.testing.assert_allclose(rot.apply(ego) + res.position, [1.0 + C, 2.0 + S, 0.5], atol=1e-12)


def test_rotation_of_a_failed_result_raises():
    res = failed_result()
    with pytest.raises(PoseError, match="too_few_percepts") as info:
        _ = res.rotation
    assert isinstance(info.value, WorldGraphError)


def test_rotation_of_a_real_result_matches_the_true_pose():
    rng = np.random.default_rng(7)
    pos = rng.uniform([0, 0, 0], [8.0, 6.0, 2.5], (40, 3))
    world = WorldModel.from_arrays(rng.choice(["door", "handle", "knob"], 40), pos, max_link_length=5.0)
    truth = np.eye(4)
    truth[:3, :3] = Rotation.from_euler("z", 1.1).as_matrix()
    truth[:3, 3] = [4.0, 3.0, 1.5]
    idx = np.argsort(np.linalg.norm(pos - truth[:3, 3], axis=1))[:6]
    ego = (pos[idx] - truth[:3, 3]) @ truth[:3, :3]
    res = localize(world, [Percept(str(world.types[o]), e, 1e-3) for o, e in zip(idx, ego, strict=True)])
    assert res.status == "ok", res.message
    np.testing.assert_allclose(res.rotation.as_matrix(), truth[:3, :3], atol=1e-3)
    assert abs(res.rotation.magnitude() - 1.1) < 1e-3
    text = res.summary()
    assert f"x = {res.position[0]:.3f}" in text and f"y = {res.position[1]:.3f}" in text
    assert f"{math.degrees(1.1):.1f}" in repr(res)  # 63.0 deg
    assert json.loads(json.dumps(res.to_dict(), allow_nan=False))["status"] == "ok"


# ------------------------------------------------------------------------------- summary

def test_summary_of_an_ok_result_holds_its_numbers():
    text = ok_result().summary()
    lines = text.splitlines()
    assert lines[0] == "status: ok (unique pose)"
    assert "x = 1.000 ± 0.03, y = 2.000 ± 0.06, z = 0.500 ± 0.09 m (3 sigma)" in text
    assert "30.00 deg about [0.000, 0.000, 1.000]" in text
    assert "3-sigma bound 3 deg" in text
    assert "matches: 4 of 5 percepts (fitness 0.80, inlier RMSE 0.012 m)" in text
    assert "hypotheses: 3, near-best poses: 2" in text
    assert "time: 0.250 s total" in text
    assert "no pose" not in text
    assert 5 <= len(lines) <= 8


def test_summary_of_a_failed_result_says_no_pose():
    res = failed_result()
    assert np.all(np.isnan(res.transformation))
    text = res.summary()
    assert text.splitlines()[0] == "status: too_few_percepts"
    assert "no pose" in text
    assert "position:" not in text and "rotation:" not in text
    assert "matches: 0 of 2 percepts" in text
    assert res.message and f"message: {res.message}" in text


def test_summary_without_a_covariance_says_undetermined():
    res = ok_result()
    weak = replace(res, status="weak", covariance=np.full((3, 3), np.nan),
                   pose_covariance=np.full((6, 6), np.nan))
    text = weak.summary()
    assert "x = 1.000 ± undetermined" in text
    assert "3-sigma bound undetermined deg" in text
    assert math.isnan(weak.rotation_3sigma)


# ---------------------------------------------------------------------------------- repr

def test_repr_is_one_short_line():
    res = ok_result(n_hypotheses=50)
    text = repr(res)
    assert text == ("LocalizationResult(status='ok', position=[1.000, 2.000, 0.500] m, angle=30.0 deg, "
                    "matches=4)")
    assert "\n" not in text and len(text) <= 120
    failed = repr(failed_result())
    assert failed == "LocalizationResult(status='too_few_percepts', no pose, matches=0)"


# ------------------------------------------------------------------------------- to_dict

def test_to_dict_of_an_ok_result_round_trips_through_json():
    d = ok_result().to_dict()
    back = json.loads(json.dumps(d, allow_nan=False))
    assert back == d
    assert not any(isinstance(v, (np.ndarray, np.generic, tuple)) for v in _walk(d))
    assert d["status"] == "ok" and d["unique"] is True and d["has_pose"] is True
    assert d["transformation"] == T.tolist()
    assert d["position"] == [1.0, 2.0, 0.5]
    np.testing.assert_allclose(d["rotation_vector"], [0.0, 0.0, YAW], atol=1e-12)
    np.testing.assert_allclose(d["position_3sigma"], [0.03, 0.06, 0.09], rtol=1e-12)
    assert d["rotation_3sigma"] == pytest.approx(math.radians(3.0), rel=1e-12)
    assert d["correspondences"] == [[0, 4], [1, 7], [2, 9], [4, 11]]
    assert d["n_hypotheses"] == 3 and d["n_near_best"] == 2
    assert d["log_likelihood_ratio"] is None  # inf
    assert d["residuals"] == [0.5, 1.0, 0.2, None, 0.7]
    assert d["alternatives"] == [np.eye(4).tolist()]
    assert d["timings"] == {"association": 0.05, "total": 0.25}
    assert d["position_estimate"] is None and d["certificate"] is None


def test_to_dict_of_a_failed_result_has_no_numbers_for_the_pose():
    d = failed_result().to_dict()
    back = json.loads(json.dumps(d, allow_nan=False))
    assert back == d
    assert d["status"] == "too_few_percepts" and d["has_pose"] is False and d["unique"] is False
    assert d["transformation"] == [[None] * 4] * 4
    assert d["position"] == [None] * 3
    assert d["rotation_vector"] is None and d["rotation_3sigma"] is None
    assert d["correspondences"] == [] and d["n_near_best"] == 0


# -- the status contract of every method ----------------------------------------------
_POSELESS = ("degenerate", "degenerate_collinear", "no_association", "too_few_percepts")
_METHODS = ("ml", "spheres", "paper", "srls", "gradient")


def _check_status_contract(res: LocalizationResult) -> None:
    """A success status comes with a finite rigid pose and covariance; a status that keeps no
    pose returns none (NaN transformation, position and covariances), as the failures built by
    the pipeline's own failure path do."""
    from worldgraph.localization import LOCALIZE_STATUSES, POSE_STATUSES

    assert res.status in LOCALIZE_STATUSES
    if res.status in POSE_STATUSES:
        T = res.transformation
        assert np.all(np.isfinite(T)) and np.all(np.isfinite(res.pose_covariance))
        assert np.all(np.isfinite(res.covariance)) and np.array_equal(res.position, T[:3, 3])
        assert np.allclose(T[:3, :3].T @ T[:3, :3], np.eye(3), atol=1e-6) and np.linalg.det(T[:3, :3]) > 0
    if res.status in _POSELESS:
        assert np.all(np.isnan(res.transformation)) and np.all(np.isnan(res.position))
        assert np.all(np.isnan(res.covariance)) and np.all(np.isnan(res.pose_covariance))
        assert not res.has_pose and res.alternatives == () and res.certificate is None
        assert "no pose" in res.summary() and res.to_dict()["transformation"][0][0] is None


def test_gradient_degenerate_returns_no_pose() -> None:
    """An adversarial case: three coplanar landmarks with the robot 5 cm below their
    plane.  The gradient ascent's position is resolved to its mirror candidate by the validated
    3D pose, where the range-only CRLB is singular: an infinite covariance, so "weak", which the
    final check turns into "degenerate" -- and that result still carried the finite pose."""
    pos = np.array([[4.62712084, 0.45422056, 0.0],
                    [1.65944892, 2.87415614, 0.0],
                    [4.05734831, 3.8755705, 0.0]])
    ego = np.array([[-0.81682678, 3.95818654, 0.05216828],
                    [-2.0447911, 0.31621408, 0.06331194],
                    [-3.8093695, 2.22654249, 0.06151075]])
    world = WorldModel.from_arrays(["t0", "t1", "t2"], pos)
    res = localize(world, [Percept(f"t{k}", ego[k], 0.02) for k in range(3)], method="gradient")
    assert res.status == "degenerate"
    assert "infinite covariance" in res.message and "numerical breakdown" in res.message
    _check_status_contract(res)
    assert res.correspondences  # the matches stay for diagnosis


@pytest.mark.parametrize("layout", ["coplanar", "collinear", "nearly coplanar", "spread"])
def test_every_method_keeps_the_status_contract(layout: str) -> None:
    """Property over the five methods on small worlds of three to five landmarks (one object
    per type) laid out to provoke the degenerate paths: every result keeps the status contract."""
    rng = np.random.default_rng(["coplanar", "collinear", "nearly coplanar", "spread"].index(layout))
    for _ in range(12):
        n = int(rng.integers(3, 6))
        if layout == "coplanar":
            pos = np.column_stack([rng.uniform(0, 6, (n, 2)), np.zeros(n)])
        elif layout == "collinear":
            pos = np.outer(rng.uniform(0, 6, n), [1.0, 0.0, 0.0]) + rng.normal(0, 0.05, (n, 3))
        elif layout == "nearly coplanar":
            pos = np.column_stack([rng.uniform(0, 6, (n, 2)), rng.normal(0, 0.02, n)])
        else:
            pos = rng.uniform(0, 6, (n, 3))
        types = [f"t{k}" for k in range(n)]
        world = WorldModel.from_arrays(types, pos)
        yaw = rng.uniform(0, 2 * math.pi)
        R = Rotation.from_euler("z", yaw).as_matrix()
        t = np.r_[rng.uniform(0, 6, 2), rng.uniform(-1, 2)]
        sigma = float(rng.choice([0.001, 0.02, 0.1]))
        percepts = [Percept(types[k], R.T @ (pos[k] - t) + sigma * rng.standard_normal(3), sigma)
                    for k in range(n)]
        for method in _METHODS:
            _check_status_contract(localize(world, percepts, method=method))
