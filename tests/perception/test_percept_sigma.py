"""Percept: a covariance alone is enough (sigma derived as the range standard deviation), a
sigma that contradicts the covariance is refused, and one of the two is required."""

from __future__ import annotations

import numpy as np
import pytest

import perception as pc
import worldgraph as wg
from perception.errors import PerceptionError
from perception.tolerances import SIGMA_COVARIANCE_FACTOR


def _range_std_by_sampling(position: np.ndarray, covariance: np.ndarray, n: int = 400_000) -> float:
    """Standard deviation of |x| for x ~ N(position, covariance), by Monte Carlo (independent of
    the closed form the package uses)."""
    rng = np.random.default_rng(11)
    x = rng.multivariate_normal(position, covariance, size=n)
    return float(np.std(np.linalg.norm(x, axis=1)))


def test_covariance_alone_gives_the_range_standard_deviation() -> None:
    position = np.array([3.0, -4.0, 12.0])  # |p| = 13
    covariance = np.array([[4e-4, 1e-4, 0.0], [1e-4, 9e-4, 2e-4], [0.0, 2e-4, 1e-4]])
    p = pc.Percept("door", position, covariance=covariance)
    # by hand: u = (3, -4, 12) / 13
    u = np.array([3.0, -4.0, 12.0]) / 13.0
    by_hand = np.sqrt(sum(u[i] * covariance[i, j] * u[j] for i in range(3) for j in range(3)))
    assert isinstance(p.sigma, float)
    assert p.sigma == pytest.approx(by_hand, rel=1e-12)
    # and it is the spread of the range (far from the origin the range is linear in the error)
    assert p.sigma == pytest.approx(_range_std_by_sampling(position, covariance), rel=0.01)
    # keyword and positional forms agree
    assert pc.Percept("door", position, None, covariance) == p


def test_covariance_alone_at_the_origin_uses_the_mean_variance() -> None:
    covariance = np.diag([1e-4, 4e-4, 1.6e-3])
    p = pc.Percept("knob", np.zeros(3), covariance=covariance)
    assert p.sigma == pytest.approx(np.sqrt((1e-4 + 4e-4 + 1.6e-3) / 3.0), rel=1e-12)


def test_a_sigma_ten_times_off_the_covariance_is_refused() -> None:
    position = np.array([2.0, 0.0, 0.0])
    covariance = np.diag([0.01**2, 0.002**2, 0.002**2])  # range std 1 cm (along x)
    pc.Percept("handle", position, 0.01, covariance=covariance)  # agrees
    pc.Percept("handle", position, 0.0025, covariance=covariance)  # 4x off: within the factor 5
    with pytest.raises(PerceptionError, match=r"sigma = 0\.001 m contradicts the covariance.*"
                                                    r"0\.01 m.*ratio sigma / that = 0\.1.*sigma=None"):
        pc.Percept("handle", position, 0.001, covariance=covariance)
    with pytest.raises(PerceptionError, match=r"sigma = 0\.1 m contradicts.*ratio sigma / that = 10"):
        pc.Percept("handle", position, 0.1, covariance=covariance)
    assert 2.0 < SIGMA_COVARIANCE_FACTOR < 10.0


def test_neither_sigma_nor_covariance_is_refused() -> None:
    with pytest.raises(PerceptionError, match=r"sigma = None and covariance = None"):
        pc.Percept("door", [1.0, 0.0, 0.0])
    with pytest.raises(PerceptionError, match=r"needs sigma .* or covariance"):
        pc.Percept("door", [1.0, 0.0, 0.0], None, None)


def test_the_existing_constructions_still_work() -> None:
    plain = pc.Percept("door", [1.0, 2.0, 0.5], 0.02)
    assert plain.sigma == 0.02 and plain.covariance is None
    iso = pc.Percept("door", [1.0, 2.0, 0.5], 0.02, covariance=0.02**2 * np.eye(3))
    assert iso.sigma == 0.02
    # simulate_scan and fuse_percepts give percepts whose sigma is the covariance's range std
    world = wg.scenes.kitchen(seed=0)
    seen = np.isin(world.types, ("door", "handle", "drawer", "knob"))
    truth = np.eye(4)
    truth[:3, 3] = [*(world.bounds[0][:2] + world.bounds[1][:2]) / 2, 1.6]
    scan = pc.simulate_scan(world.types[seen].tolist(), world.positions[seen], truth,
                            np.random.default_rng(0), n_views=4, encoder_sigma=0.002)
    assert len(scan) > 10 and any(p.shared for p in scan)
    for p in list(scan) + list(pc.fuse_percepts(scan, min_views=1)):
        u = p.position / np.linalg.norm(p.position)
        assert p.sigma == pytest.approx(float(np.sqrt(u @ p.covariance @ u)), rel=1e-9)
