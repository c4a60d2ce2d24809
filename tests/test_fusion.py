"""Mean-shift percept fusion: reference mean shift, recovery on simulated scans, order invariance."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from perception import (
    NonPositiveSigmaError,
    Percept,
    PerceptionError,
    UnknownClassError,
    fuse_percepts,
    mean_shift_modes,
    simulate_scan,
)


def slow_mean_shift(X: np.ndarray, H: np.ndarray, w: np.ndarray) -> tuple[list[np.ndarray], list[set[int]]]:
    """Fixed-point iteration of the flat-kernel mean, one point at a time, then grouping."""
    Hinv = np.linalg.inv(H)
    fixed = []
    for x in X:
        y = x.copy()
        for _ in range(1000):
            num, den = np.zeros(X.shape[1]), 0.0
            for xj, wj in zip(X, w, strict=True):
                d = xj - y
                if d @ Hinv @ d < 1.0:
                    num += wj * xj
                    den += wj
            new = num / den
            if np.array_equal(new, y):
                break
            y = new
        fixed.append(y)
    groups: list[set[int]] = []
    for i, y in enumerate(fixed):
        for g in groups:
            j = min(g)
            d = y - fixed[j]
            if d @ Hinv @ d < 0.25:
                g.add(i)
                break
        else:
            groups.append({i})
    modes = [np.mean([fixed[i] for i in sorted(g)], axis=0) for g in groups]
    return modes, groups


@st.composite
def clustered(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    seed = draw(st.integers(0, 10_000))
    rng = np.random.default_rng(seed)
    k = draw(st.integers(1, 4))
    centers = np.array([[2.0 * i, rng.uniform(-1, 1), rng.uniform(-1, 1)] for i in range(k)])
    sizes = rng.integers(1, 7, k)
    X = np.vstack([c + rng.normal(0, 0.04, (s, 3)) for c, s in zip(centers, sizes, strict=True)])
    X = X[rng.permutation(len(X))]
    if draw(st.booleans()):
        A = rng.normal(size=(3, 3))
        H = 0.05 * (A @ A.T) + 0.04 * np.eye(3)  # SPD, support radius ~0.2..0.6
    else:
        H = 0.25**2 * np.eye(3)
    w = rng.uniform(0.5, 2.0, len(X)) if draw(st.booleans()) else np.ones(len(X))
    return X, H, w


@given(data=clustered())
def test_mean_shift_matches_slow_reference(data) -> None:
    X, H, w = data
    modes, labels = mean_shift_modes(X, H, w)
    ref_modes, ref_groups = slow_mean_shift(X, H, w)
    groups = [set(np.flatnonzero(labels == k).tolist()) for k in range(len(modes))]
    assert sorted(map(sorted, groups)) == sorted(map(sorted, ref_groups))
    for g, m in zip(ref_groups, ref_modes, strict=True):
        np.testing.assert_allclose(modes[labels[min(g)]], m, atol=1e-9)


def test_mean_shift_scalar_bandwidth_in_metres() -> None:
    X = np.array([[0.0, 0, 0], [0.15, 0, 0], [0.5, 0, 0]])
    _, labels = mean_shift_modes(X, 0.2)
    assert labels[0] == labels[1] != labels[2]
    _, labels = mean_shift_modes(X, 0.1)
    assert len(set(labels.tolist())) == 3


def separated_scene(rng: np.random.Generator, n: int = 9) -> tuple[list[str], np.ndarray]:
    types = [["handle", "door", "knob"][i % 3] for i in range(n)]
    X = np.zeros((n, 3))
    for i in range(n):
        while True:  # same-type objects at least 0.6 m apart
            x = np.array([rng.uniform(1.0, 4.5), rng.uniform(-3.0, 3.0), rng.uniform(-0.4, 1.0)])
            if all(np.linalg.norm(x - X[j]) > 0.6 for j in range(i) if types[j] == types[i]):
                X[i] = x
                break
    return types, X


def test_fusion_recovers_object_count_on_simulated_scans() -> None:
    n_scans, hits = 40, 0
    for seed in range(n_scans):
        rng = np.random.default_rng(1000 + seed)
        types, X = separated_scene(rng)
        percepts, truth = simulate_scan(
            types, X, np.eye(4), rng, n_views=20, false_rate=0.02, return_truth=True
        )
        seen = np.flatnonzero(np.bincount(truth[truth >= 0], minlength=len(types)) >= 2)
        fused = fuse_percepts(percepts)
        if len(fused) != seen.size:
            continue
        # and every fused percept sits on a distinct true object of its type
        matched = set()
        for f in fused:
            d = [np.linalg.norm(f.position - X[i]) if types[i] == f.type else np.inf for i in seen]
            matched.add(int(seen[int(np.argmin(d))]))
            assert min(d) < 0.1
        hits += len(matched) == seen.size
    assert hits / n_scans >= 0.95


@pytest.fixture(scope="module")
def scan() -> list[Percept]:
    rng = np.random.default_rng(77)
    types, X = separated_scene(rng, n=6)
    return simulate_scan(types, X, np.eye(4), rng, n_views=10, false_rate=0.05)


@given(perm=st.randoms(use_true_random=False))
def test_fusion_is_order_invariant(scan: list[Percept], perm) -> None:
    shuffled = list(scan)
    perm.shuffle(shuffled)
    a, b = fuse_percepts(scan), fuse_percepts(shuffled)
    assert len(a) >= 2
    assert a == b
    for p, q in zip(a, b, strict=True):
        np.testing.assert_array_equal(p.covariance, q.covariance)


def test_melting_information_weighted_and_stragglers() -> None:
    p1 = Percept("handle", (2.0, 0.0, 0.0), 0.01)
    p2 = Percept("handle", (2.0, 0.03, 0.0), 0.02)
    lone = Percept("handle", (0.0, 3.0, 0.0), 0.01)
    other = Percept("door", (2.0, 0.01, 0.0), 0.01)
    fused = fuse_percepts([lone, p2, other, p1])
    assert [f.type for f in fused] == ["handle"]  # the lone handle and the lone door are rejected
    (f,) = fused
    w1, w2 = 1 / 0.01**2, 1 / 0.02**2
    expected = (w1 * np.array([2.0, 0.0, 0.0]) + w2 * np.array([2.0, 0.03, 0.0])) / (w1 + w2)
    np.testing.assert_allclose(f.position, expected, atol=1e-15)
    # chi^2 = sum w |x - m|^2 over 3 (k - 1) dof inflates (w1 + w2)^-1
    chi2 = w1 * np.sum((expected - [2, 0, 0]) ** 2) + w2 * np.sum((expected - [2, 0.03, 0]) ** 2)
    var = max(1.0, chi2 / 3.0) / (w1 + w2)
    np.testing.assert_allclose(f.covariance, var * np.eye(3), rtol=1e-12)
    assert f.sigma == pytest.approx(np.sqrt(var), rel=1e-12)
    assert f.views == 2
    assert len(fuse_percepts([lone, p2, other, p1], min_views=1)) == 3


def test_bandwidth_matrix_and_dict() -> None:
    a = Percept("door", (3.0, 0.0, 0.0), 0.01)
    b = Percept("door", (3.3, 0.0, 0.0), 0.01)
    c = Percept("door", (3.0, 0.3, 0.0), 0.01)
    long_x = np.diag([0.5**2, 0.05**2, 0.05**2])
    assert [f.views for f in fuse_percepts([a, b], bandwidth=long_x)] == [2]
    assert fuse_percepts([a, c], bandwidth=long_x) == []
    assert [f.views for f in fuse_percepts([a, c], bandwidth={"door": 0.5})] == [2]
    with pytest.raises(UnknownClassError, match="'door'"):
        fuse_percepts([a, b], bandwidth={"handle": 0.1})
    with pytest.raises(NonPositiveSigmaError, match="bandwidth"):
        fuse_percepts([a, b], bandwidth=-0.1)
    with pytest.raises(NonPositiveSigmaError, match="positive definite"):
        fuse_percepts([a, b], bandwidth=-long_x)
    with pytest.raises(PerceptionError, match="Percept"):
        fuse_percepts([a, (3.0, 0.0, 0.0)])  # type: ignore[list-item]
    assert fuse_percepts([]) == []
