"""Issue 25, second round: needle-shaped covariances in the inlier and rank tests.

A percept whose covariance has variances (1e-8, 1e-6, 1e4) m^2 constrains two directions, not
three.  The tests here build such percepts with random orientations and check what ``localize``
counts and decides against quantities computed here, independently of the library: the eigen
decomposition of each covariance and the Fisher information ``sum_i J_i^T C_i^-1 J_i`` of the 6D
pose, ``J_i`` the derivative of the ego point by the pose.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import worldgraph as wg
from perception import Percept
from worldgraph.localize import UNIQUE_STATUSES
from worldgraph.validation import constrained_directions

NEEDLE = (1e-8, 1e-6, 1e4)


def _covariance(axes_var: tuple[float, float, float], rng: np.random.Generator) -> np.ndarray:
    Q = Rotation.random(random_state=rng).as_matrix()
    C = Q @ np.diag(axes_var) @ Q.T
    return 0.5 * (C + C.T)


def _scene(k: int, variances: list[tuple[float, float, float]], seed: int):
    """``k`` landmarks of distinct types on a well-spread (non-collinear, non-flat) set, a
    truth pose and one percept each with the given covariance shape, noise drawn from it."""
    rng = np.random.default_rng(seed)
    pos = np.array([[0, 0, 0], [4, 0, 0.5], [0, 3, 1.0], [3, 3, 0.2], [1.5, 5, 1.5], [2, 1, 2.5]], float)[:k]
    types = [f"t{i}" for i in range(k)]
    world = wg.WorldModel.from_arrays(types, pos)
    truth = np.eye(4)
    truth[:3, :3] = Rotation.from_euler("z", 0.3).as_matrix()
    truth[:3, 3] = [1.0, -2.0, 0.5]
    ego = (pos - truth[:3, 3]) @ truth[:3, :3]
    percepts = []
    for i in range(k):
        C = _covariance(variances[i], rng)
        x = ego[i] + np.linalg.cholesky(C) @ rng.standard_normal(3)
        percepts.append(Percept(types[i], x, float(np.sqrt(max(variances[i]))), covariance=C))
    return world, percepts, truth


@pytest.mark.parametrize(("variances", "expected"), [
    ((1.0, 1.0, 1.0), 3),
    ((0.01, 0.01, 0.09), 3),           # stereo-shaped: depth 3x the lateral sigma
    (NEEDLE, 2),
    ((1e-8, 1e4, 1e4), 1),             # a pancake
    ((1e-6, 1e-6 * 9e5, 1e-6 * 2e6), 2),
])
def test_constrained_directions_of_a_covariance(variances, expected) -> None:
    rng = np.random.default_rng(1)
    covs = np.array([_covariance(variances, rng) for _ in range(4)])
    np.testing.assert_array_equal(constrained_directions(covs), np.full(4, expected))


def test_constrained_directions_rejects_a_bad_covariance() -> None:
    with pytest.raises(wg.WorldGraphError, match=r"covs\[1\]"):
        constrained_directions(np.array([np.eye(3), np.diag([1.0, -1.0, 1.0])]))
    with pytest.raises(wg.WorldGraphError, match="covs"):
        constrained_directions(np.eye(3))


@pytest.mark.parametrize("seed", range(4))
def test_three_needles_are_no_unique_answer(seed: int) -> None:
    """Three needles constrain 6 directions: they may fix the 6D pose, but nothing is left to
    check it (three isotropic percepts leave 3).  localize said "ok" on them; the inlier count
    is in constrained directions now, and 6 < 9."""
    world, percepts, _ = _scene(3, [NEEDLE] * 3, seed)
    res = wg.localize(world, percepts)
    assert res.status not in UNIQUE_STATUSES, res.summary()
    assert "constraining 6 directions" in res.message


@pytest.mark.parametrize("seed", range(4))
def test_three_needles_and_an_isotropic_percept_count_nine(seed: int) -> None:
    """2 + 2 + 2 + 3 = 9 constrained directions: as many as three isotropic percepts."""
    world, percepts, truth = _scene(4, [NEEDLE] * 3 + [(1e-4, 1e-4, 1e-4)], seed)
    res = wg.localize(world, percepts)
    assert res.status in UNIQUE_STATUSES, res.summary()
    assert np.linalg.norm(res.position - truth[:3, 3]) < 0.05


@pytest.mark.parametrize("seed", range(4))
def test_three_isotropic_percepts_still_suffice(seed: int) -> None:
    world, percepts, truth = _scene(3, [(1e-4, 1e-4, 1e-4)] * 3, seed)
    res = wg.localize(world, percepts)
    assert res.status == "ok", res.summary()
    assert np.linalg.norm(res.position - truth[:3, 3]) < 0.05
