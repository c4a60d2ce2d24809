"""simulate_percepts and simulate_scan: truth, visibility, noise model, false percepts."""

from __future__ import annotations

import numpy as np
import pytest

from perception import (
    Percept,
    PerceptionError,
    StereoRig,
    default_head,
    simulate_percepts,
    simulate_scan,
)
from perception.simulation.simulate import scan_angles
from tests.worlds import yaw_pose


def scene(seed: int, n: int = 15) -> tuple[list[str], np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    types = [["door", "handle", "knob"][i % 3] for i in range(n)]
    X = np.column_stack([rng.uniform(-8, 8, n), rng.uniform(-8, 8, n), rng.uniform(0, 2, n)])
    return types, X, yaw_pose(0.7, (1.0, -0.5, 1.2))


def ego_coords(world_from_ego: np.ndarray, X: np.ndarray) -> np.ndarray:
    ego_from_world = np.linalg.inv(world_from_ego)
    return np.array([(ego_from_world @ np.append(x, 1.0))[:3] for x in X])


def test_noise_free_truth_and_positions() -> None:
    types, X, M = scene(0)
    percepts, truth = simulate_percepts(
        types, X, M, np.random.default_rng(1), depth_factor=1e15, min_sigma=1e-12, max_range=100.0
    )
    P = ego_coords(M, X)
    assert sorted(truth.tolist()) == list(range(len(types)))
    for p, i in zip(percepts, truth, strict=True):
        assert p.type == types[i]
        np.testing.assert_allclose(p.position, P[i], atol=1e-9)
        assert p.views == 1


def test_visibility_range_and_fov() -> None:
    types, X, M = scene(2, n=40)
    P = ego_coords(M, X)
    rho = np.sqrt((P**2).sum(axis=1))
    az = np.degrees(np.arctan2(P[:, 1], P[:, 0]))
    expected = [i for i in range(40) if rho[i] <= 6.0 and abs(az[i]) <= 45.0]
    assert 0 < len(expected) < 40
    _, truth = simulate_percepts(types, X, M, np.random.default_rng(3), max_range=6.0, hfov_deg=90.0)
    assert sorted(truth.tolist()) == expected


def test_sigma_model_and_noise_statistics() -> None:
    types, X, M = scene(4, n=30)
    P = ego_coords(M, X)
    rho = np.sqrt((P**2).sum(axis=1))
    z = []
    for seed in range(40):
        percepts, truth = simulate_percepts(
            types, X, M, np.random.default_rng(seed), depth_factor=300.0, min_sigma=0.02, max_range=20.0
        )
        for p, i in zip(percepts, truth, strict=True):
            expected_sigma = max(0.02, rho[i] * rho[i] / 300.0)
            assert p.sigma == pytest.approx(expected_sigma, rel=1e-12)
            np.testing.assert_allclose(p.covariance, expected_sigma**2 * np.eye(3), rtol=1e-12)
            z.append((p.position - P[i]) / expected_sigma)
    z = np.array(z)
    assert z.shape == (1200, 3)
    np.testing.assert_allclose(z.mean(axis=0), 0.0, atol=0.1)
    np.testing.assert_allclose(z.std(axis=0), 1.0, atol=0.06)


def test_false_percepts_count_types_and_places() -> None:
    types, X, M = scene(5)
    percepts, truth = simulate_percepts(
        types, X, M, np.random.default_rng(6), n_false=25, false_types=["window"], max_range=5.0, hfov_deg=120
    )
    false = [p for p, i in zip(percepts, truth, strict=True) if i == -1]
    assert len(false) == 25
    assert all(p.type == "window" for p in false)
    for p in false:
        assert p.range <= 5.0 + 1e-12
        assert abs(np.degrees(np.arctan2(p.position[1], p.position[0]))) <= 60.0 + 1e-9
    # default false types: those present
    percepts, truth = simulate_percepts(types, X, M, np.random.default_rng(6), n_false=30)
    assert {p.type for p, i in zip(percepts, truth, strict=True) if i == -1} <= set(types)
    assert int((truth == -1).sum()) == 30


def test_misses_order_and_determinism() -> None:
    types, X, M = scene(7)
    a = simulate_percepts(types, X, M, np.random.default_rng(8), n_false=3, miss_rate=0.3, max_range=30.0)
    b = simulate_percepts(types, X, M, np.random.default_rng(8), n_false=3, miss_rate=0.3, max_range=30.0)
    assert a[0] == b[0]
    np.testing.assert_array_equal(a[1], b[1])
    none, truth = simulate_percepts(types, X, M, np.random.default_rng(8), miss_rate=1.0, max_range=30.0)
    assert none == [] and truth.shape == (0,)
    # the order is shuffled: over several seeds the true indices are not always sorted
    orders = [
        simulate_percepts(types, X, M, np.random.default_rng(s), max_range=30.0)[1].tolist() for s in range(5)
    ]
    assert any(o != sorted(o) for o in orders)


def test_simulate_percepts_bad_input() -> None:
    types, X, M = scene(9)
    rng = np.random.default_rng(0)
    with pytest.raises(PerceptionError, match=r"(?i)\(n, 3\)"):
        simulate_percepts(types, X[:, :2], M, rng)
    with pytest.raises(PerceptionError, match=r"types must have one entry per row of"):
        simulate_percepts(types[:-1], X, M, rng)
    with pytest.raises(PerceptionError, match=r"world_positions\[7, 1\] must be finite,.*nan"):
        simulate_percepts(types, np.where(X > 7, np.nan, X), M, rng)
    with pytest.raises(PerceptionError, match=r"world_from_ego must be a rigid transform"):
        simulate_percepts(types, X, 2 * M, rng)
    with pytest.raises(PerceptionError, match=r"types\[0\] must be a non\-empty string without.*''"):
        simulate_percepts([""] + types[1:], X, M, rng)
    with pytest.raises(PerceptionError, match=r"n_false > 0 needs false_types or at least one"):
        simulate_percepts([], np.zeros((0, 3)), M, rng, n_false=2)
    with pytest.raises(PerceptionError, match="miss_rate"):
        simulate_percepts(types, X, M, rng, miss_rate=1.5)
    with pytest.raises(PerceptionError, match="rng"):
        simulate_percepts(types, X, M, 42)  # type: ignore[arg-type]


def test_scan_noise_free_positions_and_view_counts() -> None:
    """Every detection of object i sits at its ego position; counts per object match an
    independent pinhole visibility computation over the same head poses."""
    types, X, M = scene(10, n=20)
    chain, rig = default_head(), StereoRig.default()
    percepts, truth = simulate_scan(
        types, X, M, np.random.default_rng(11), depth_factor=1e15, miss_rate=0.0, false_rate=0.0,
        return_truth=True, min_sigma=1e-12, n_views=12,
    )  # fmt: skip
    assert all(isinstance(p, Percept) and p.views == 1 for p in percepts)
    P = ego_coords(M, X)
    for p, i in zip(percepts, truth, strict=True):
        np.testing.assert_allclose(p.position, P[i], atol=1e-9)
    f, cx, cy = rig.K1[0, 0], rig.K1[0, 2], rig.K1[1, 2]
    w, h = rig.image_size
    counts = np.zeros(20, dtype=int)
    for q in scan_angles(chain, 12):
        cam_from_ego = np.linalg.inv(chain.ego_from_camera(q))
        for i, x in enumerate(P):
            c = (cam_from_ego @ np.append(x, 1.0))[:3]
            if c[2] <= 0.093 or np.linalg.norm(c) > 8.0:  # also in front of the right camera
                continue
            u, v = f * c[0] / c[2] + cx, f * c[1] / c[2] + cy
            counts[i] += int(0 <= u <= w and 0 <= v <= h)
    assert counts.sum() > 10
    np.testing.assert_array_equal(np.bincount(truth[truth >= 0], minlength=20), counts)


def test_scan_noise_false_and_misses() -> None:
    rng = np.random.default_rng(12)
    types = [["door", "handle"][i % 2] for i in range(80)]
    X = np.column_stack([rng.uniform(-5, 5, 80), rng.uniform(-5, 5, 80), rng.uniform(0, 2, 80)])
    M = yaw_pose(0.3, (0.2, 0.1, 1.2))
    kwargs = {"depth_factor": 500.0, "miss_rate": 0.2, "false_rate": 0.3}
    percepts, truth = simulate_scan(types, X, M, np.random.default_rng(13), return_truth=True, **kwargs)
    P = ego_coords(M, X)
    n_false = int((truth == -1).sum())
    n_true = int((truth >= 0).sum())
    assert n_true > 150
    # expected false / true = 0.3 / (1 - 0.2)
    assert n_false / n_true == pytest.approx(0.3 / 0.8, rel=0.25)
    z = np.array([(p.position - P[i]) / p.sigma for p, i in zip(percepts, truth, strict=True) if i >= 0])
    assert float((z**2).mean()) == pytest.approx(1.0, abs=0.15)
    assert {p.type for p in percepts} <= set(types)
    plain = simulate_scan(types, X, M, np.random.default_rng(13), **kwargs)
    assert plain == percepts
