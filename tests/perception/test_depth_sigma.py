"""Eq. 6 in one place: ``perception.depth_sigma`` (arrays, the ``min_sigma`` floor) and its callers.

Every expected value here is the formula ``max(min_sigma, rho^2 / depth_factor)`` written out
independently of the code under test (the formula used to be written inline four times).
"""

from __future__ import annotations

import numpy as np
import pytest

from perception import (
    PerceptionError,
    default_head,
    depth_sigma,
    simulate_percepts,
    simulate_scan,
)
from perception.simulation.simulate import scan_angles
from tests.worlds import yaw_pose


def test_depth_sigma_arrays_and_floor_hand_computed() -> None:
    rho = np.array([0.5, 1.0, 2.0, 4.0])
    # rho^2 / 100 = 0.0025, 0.01, 0.04, 0.16 (by hand)
    np.testing.assert_allclose(depth_sigma(rho, 100.0), [0.0025, 0.01, 0.04, 0.16], rtol=1e-15)
    np.testing.assert_allclose(depth_sigma(rho, 100.0, min_sigma=0.02), [0.02, 0.02, 0.04, 0.16], rtol=1e-15)
    assert depth_sigma(3.0, 1000.0, min_sigma=0.0) == pytest.approx(0.009, rel=1e-15)
    assert isinstance(depth_sigma(3.0, 1000.0, min_sigma=0.001), float)
    out = depth_sigma(np.zeros(0), 10.0)
    assert isinstance(out, np.ndarray) and out.shape == (0,)


def test_depth_sigma_zero_depth_only_with_a_floor() -> None:
    assert depth_sigma(0.0, 1000.0, min_sigma=1e-4) == 1e-4
    np.testing.assert_array_equal(depth_sigma([0.0, 0.0], 5.0, min_sigma=0.5), [0.5, 0.5])
    with pytest.raises(PerceptionError, match=r"rho must be > 0, got 0\.0"):
        depth_sigma(0.0, 1000.0)
    with pytest.raises(PerceptionError, match=r"rho\[2\] must be >= 0"):
        depth_sigma([1.0, 0.0, -0.5], 1000.0, min_sigma=1e-3)


@pytest.mark.parametrize("bad", [-1e-3, np.nan, np.inf])
def test_depth_sigma_rejects_bad_floor(bad: float) -> None:
    with pytest.raises(PerceptionError, match="min_sigma"):
        depth_sigma(1.0, 1000.0, min_sigma=bad)


def test_depth_sigma_overflow_names_the_depth() -> None:
    with pytest.raises(PerceptionError, match=r"overflows for rho\[1\]"):
        depth_sigma([1.0, 1e160], 1.0, min_sigma=1e-3)


@pytest.mark.parametrize("depth_factor, min_sigma", [(1000.0, 1e-4), (20.0, 0.05), (5.0, 1e-6)])
def test_simulate_percepts_sigmas_follow_eq6(depth_factor: float, min_sigma: float) -> None:
    rng = np.random.default_rng(3)
    n = 30
    X = np.column_stack([rng.uniform(-6, 6, n), rng.uniform(-6, 6, n), rng.uniform(0, 2, n)])
    types = [["door", "handle", "knob"][i % 3] for i in range(n)]
    M = yaw_pose(0.4, (0.5, -1.0, 1.1))
    percepts, truth = simulate_percepts(types, X, M, np.random.default_rng(4), depth_factor=depth_factor,
                                        min_sigma=min_sigma, n_false=5)
    ego_from_world = np.linalg.inv(M)
    checked = 0
    for p, i in zip(percepts, truth, strict=True):
        if i >= 0:
            e = ego_from_world[:3, :3] @ X[i] + ego_from_world[:3, 3]
            rho = float(np.sqrt(e @ e))
        else:  # a false percept's sigma comes from its own (noise-free) position
            rho = float(np.sqrt(p.position @ p.position))
        assert p.sigma == pytest.approx(max(min_sigma, rho * rho / depth_factor), rel=1e-12)
        checked += 1
    assert checked == len(truth) >= 10


def test_simulate_scan_sigmas_follow_eq6() -> None:
    """One view: each detection's sigma is eq. 6 of its depth along the left optical axis."""
    rng = np.random.default_rng(8)
    n = 40
    X = np.column_stack([rng.uniform(-5, 5, n), rng.uniform(-5, 5, n), rng.uniform(0, 2, n)])
    types = ["handle"] * n
    M = yaw_pose(0.2, (0.0, 0.0, 1.0))
    chain = default_head()
    df, floor = 300.0, 2e-3
    percepts, truth = simulate_scan(types, X, M, np.random.default_rng(9), chain=chain, n_views=1,
                                    depth_factor=df, min_sigma=floor, miss_rate=0.0, false_rate=0.0,
                                    return_truth=True)
    (q,) = list(scan_angles(chain, 1))
    cam_from_world = np.linalg.inv(M @ chain.ego_from_camera(q))
    assert len(percepts) >= 3
    for p, i in zip(percepts, truth, strict=True):
        z = float(cam_from_world[2, :3] @ X[i] + cam_from_world[2, 3])
        assert p.sigma == pytest.approx(max(floor, z * z / df), rel=1e-12)


def test_simulate_overflow_keeps_its_error() -> None:
    """An eq. 6 overflow in a simulation is still the simulation's sigma-range error."""
    with pytest.raises(PerceptionError, match=r"simulated sigma inf .*outside \[1e-150, 1e150\]"):
        simulate_percepts(["a", "a", "a"], [[1e140, 0, 0], [0, 1e140, 0], [0, 0, 1e140]], np.eye(4),
                          np.random.default_rng(0), depth_factor=1e-30, max_range=1e150)


def test_active_gate_uses_eq6() -> None:
    from worldgraph.active import _gate

    rho = np.array([0.0, 0.5, 3.0])
    # max(0.01, rho^2 / 100) = 0.01, 0.01, 0.09; gate = 3 * sqrt(2) * sigma + 0.02
    expected = 3.0 * np.sqrt(2.0) * np.array([0.01, 0.01, 0.09]) + 0.02
    np.testing.assert_allclose(_gate(rho, 100.0, 0.01, 3.0, 0.02), expected, rtol=1e-14)


def test_comparison_problems_follow_eq6() -> None:
    """radialopt's problem generator writes eq. 6 out (radialopt does not import perception):
    its well-scaled feasible problems (noise-free ranges) have depth_sigma's sigmas."""
    from perception import depth_sigma
    from radialopt.comparison import benchmark_problems

    probs = [p for p in benchmark_problems(np.random.default_rng(2), per_case=2, sizes=[3, 5])
             if p.feasible and p.scaling == "well"]
    assert len(probs) == 4
    for p in probs:
        np.testing.assert_allclose(p.sigmas, depth_sigma(p.radii, 50.0, min_sigma=1e-3), rtol=1e-12)
