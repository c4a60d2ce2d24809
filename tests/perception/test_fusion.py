"""Mean-shift percept fusion: reference mean shift, recovery on simulated scans, order invariance."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import perception as pc
import perception.frontend.fusion as fusion_module
from perception import (
    Percept,
    PerceptionError,
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
    with pytest.raises(PerceptionError, match="'door'"):
        fuse_percepts([a, b], bandwidth={"handle": 0.1})
    with pytest.raises(PerceptionError, match=r"bandwidth must be > 0, got \-0\.1"):
        fuse_percepts([a, b], bandwidth=-0.1)
    with pytest.raises(PerceptionError, match="positive definite"):
        fuse_percepts([a, b], bandwidth=-long_x)
    with pytest.raises(PerceptionError, match="Percept"):
        fuse_percepts([a, (3.0, 0.0, 0.0)])  # type: ignore[list-item]
    assert fuse_percepts([]) == []


# ------------------------------------------------------------------------------------------
# The dense O(n^2) implementation the k-d tree version replaced, kept here as the reference.
# ------------------------------------------------------------------------------------------


def dense_mean_shift(X: np.ndarray, H: np.ndarray, w: np.ndarray, max_iter: int = 100, tol: float = 1e-6):
    """All-pairs mean shift (an (n, n) distance matrix per iteration) and all-pairs grouping."""
    n = len(X)
    L = np.linalg.cholesky(H)
    Z = np.linalg.solve(L, X.T).T
    Y = Z.copy()
    active = np.ones(n, dtype=bool)
    for _ in range(max_iter):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        d2 = np.sum((Y[idx][:, None, :] - Z[None, :, :]) ** 2, axis=2)
        W = (d2 < 1.0) * w[None, :]
        new = (W @ Z) / W.sum(axis=1, keepdims=True)
        moved = np.linalg.norm(new - Y[idx], axis=1)
        Y[idx] = new
        active[idx[moved < tol]] = False
    near = np.sum((Y[:, None, :] - Y[None, :, :]) ** 2, axis=2) < 0.25
    labels: list[int] = []
    reps: list[int] = []
    for i in range(n):
        for k, r in enumerate(reps):
            if near[i, r]:
                labels.append(k)
                break
        else:
            labels.append(len(reps))
            reps.append(i)
    lab = np.array(labels)
    modes = np.array([Y[lab == k].mean(axis=0) for k in range(len(reps))]) @ L.T
    return modes, lab


def dense_fuse(
    percepts: list[Percept], h: float, min_views: int
) -> list[tuple[str, np.ndarray, np.ndarray, int]]:
    """Fusion by the textbook formulas on the dense mean shift: (type, position, covariance, views)."""
    out = []
    for t in sorted({p.type for p in percepts}):
        group = sorted((p for p in percepts if p.type == t), key=lambda p: (*p.position, p.sigma, p.views))
        X = np.array([p.position for p in group])
        w = np.array([1.0 / p.sigma**2 for p in group])
        _, lab = dense_mean_shift(X, h**2 * np.eye(3), w)
        for k in range(lab.max() + 1):
            mem = [group[i] for i in np.flatnonzero(lab == k)]
            if sum(p.views for p in mem) < min_views:
                continue
            C = [p.covariance if p.covariance is not None else p.sigma**2 * np.eye(3) for p in mem]
            info = [np.linalg.inv(c) for c in C]
            S = np.linalg.inv(sum(info))
            m = S @ sum(i @ p.position for i, p in zip(info, mem, strict=True))
            if len(mem) > 1:
                chi2 = sum((p.position - m) @ i @ (p.position - m) for i, p in zip(info, mem, strict=True))
                S = S * max(1.0, chi2 / (3.0 * (len(mem) - 1)))
            out.append((t, m, S, sum(p.views for p in mem)))
    return sorted(out, key=lambda r: (r[0], *r[1]))


@st.composite
def small_percepts(draw: st.DrawFn) -> list[Percept]:
    rng = np.random.default_rng(draw(st.integers(0, 100_000)))
    n = draw(st.integers(1, 40))
    k = draw(st.integers(1, 6))
    centres = rng.uniform(-2.0, 2.0, (k, 3))
    out = []
    for _ in range(n):
        c = centres[rng.integers(k)]
        s = rng.uniform(0.005, 0.05)
        cov = None
        if rng.random() < 0.5:
            A = rng.normal(size=(3, 3)) * s
            cov = A @ A.T + s**2 * np.eye(3)
        out.append(Percept(str(rng.choice(["door", "handle"])), c + rng.normal(0, 0.03, 3), s, cov,
                           views=int(rng.integers(1, 3))))
    return out


@given(X=st.integers(0, 100_000).map(lambda s: np.random.default_rng(s).normal(0, 0.3, (30, 3))),
       h=st.sampled_from([0.05, 0.1, 0.3, 1.0]), crowded=st.sampled_from([0, 3, 256]))
def test_tree_mean_shift_equals_dense_reference(X: np.ndarray, h: float, crowded: int) -> None:
    """Both neighbour paths (per-row lists, and per-cell dense blocks for rows with more than
    ``_CROWDED`` neighbours) against the all-pairs reference."""
    w = np.random.default_rng(len(X)).uniform(0.2, 3.0, len(X))
    old = fusion_module._CROWDED
    fusion_module._CROWDED = crowded
    try:
        modes, labels = mean_shift_modes(X, h, w)
    finally:
        fusion_module._CROWDED = old
    ref_modes, ref_labels = dense_mean_shift(X, h**2 * np.eye(3), w)
    np.testing.assert_array_equal(labels, ref_labels)
    np.testing.assert_allclose(modes, ref_modes, rtol=0, atol=1e-9)


@given(ps=small_percepts(), h=st.sampled_from([0.05, 0.1, 0.2]), min_views=st.integers(1, 3))
def test_tree_fusion_equals_dense_reference(ps: list[Percept], h: float, min_views: int) -> None:
    fused = fuse_percepts(ps, bandwidth=h, min_views=min_views)
    ref = dense_fuse(ps, h, min_views)
    assert len(fused) == len(ref)
    for f, (t, m, S, views) in zip(fused, ref, strict=True):
        assert f.type == t and f.views == views
        np.testing.assert_allclose(f.position, m, rtol=0, atol=1e-9)
        np.testing.assert_allclose(f.covariance, S, rtol=1e-9, atol=1e-15)
        np.testing.assert_allclose(f.sigma, np.sqrt(m @ S @ m) / np.linalg.norm(m), rtol=1e-9)


def test_crowded_cluster_equals_dense_reference() -> None:
    """600 points in one kernel (the dense-block path at its default threshold) and 200 spread."""
    rng = np.random.default_rng(5)
    X = np.vstack([rng.normal(0, 0.02, (600, 3)), rng.uniform(-3, 3, (200, 3))])
    w = rng.uniform(0.5, 2.0, len(X))
    modes, labels = mean_shift_modes(X, 0.1, w)
    ref_modes, ref_labels = dense_mean_shift(X, 0.01 * np.eye(3), w)
    np.testing.assert_array_equal(labels, ref_labels)
    np.testing.assert_allclose(modes, ref_modes, rtol=0, atol=1e-9)


def test_fusion_extreme_sigmas_raise_named_or_fuse() -> None:
    tiny = [Percept("door", [1.0, 0.0, 0.0], 1e-300), Percept("door", [1.0, 0.0, 0.0], 1e-300)]
    with pytest.raises(PerceptionError, match=r"percepts\[0\]\.sigma.*1e-300"):
        fuse_percepts(tiny)
    with pytest.raises(PerceptionError, match="covariance"):
        Percept("door", [1.0, 0.0, 0.0], 0.1, covariance=np.zeros((3, 3)))
    # sigmas 1e-100 and 1e100 in one set: representable, the precise one dominates
    ps = [Percept("door", [1.0, 0.0, 0.0], 1e-100), Percept("door", [1.0, 0.0, 0.05], 1e100)]
    (f,) = fuse_percepts(ps, min_views=2)
    np.testing.assert_array_equal(f.position, [1.0, 0.0, 0.0])
    assert np.all(np.isfinite(f.covariance)) and 0 < f.sigma < 1e-90


def test_tiny_bandwidth_names_argument() -> None:
    with pytest.raises(PerceptionError, match="bandwidth"):
        fuse_percepts([Percept("door", [1.0, 0.0, 0.0], 0.1)], bandwidth=1e-300)
    with pytest.raises(PerceptionError, match=r"points\[0\]"):
        mean_shift_modes([[1e200, 0.0, 0.0]], 1e-100)


def test_mean_shift_refuses_a_bandwidth_that_holds_most_points_in_one_kernel() -> None:
    """100,000 points within a few bandwidths: exact kernel sums would take hours; the run stops
    at once with an error naming points and bandwidth, and the same points with a bandwidth 100
    times smaller (a few points per kernel) are fused."""
    from perception import TooManyNeighboursError

    X = np.random.default_rng(0).normal(0, 0.05, (100_000, 3))
    with pytest.raises(TooManyNeighboursError, match=r"points.*100,000 points.*bandwidth"):
        mean_shift_modes(X, 0.1)
    modes, labels = mean_shift_modes(X[:20_000], 0.001)
    assert labels.shape == (20_000,) and len(modes) > 1_000


def test_mean_shift_budget_counts_every_pair_it_evaluates(monkeypatch) -> None:
    """With the budget set just above the pairs a run really evaluates (counted by brute force
    per iteration from the reference), it finishes with the reference result; set below the
    first iteration's pairs, it raises."""
    from perception import TooManyNeighboursError

    rng = np.random.default_rng(3)
    X = np.vstack([rng.normal(0, 0.03, (60, 3)), rng.normal(1, 0.03, (40, 3))])
    first = int(np.sum(np.linalg.norm(X[:, None] - X[None], axis=2) < 0.1))  # iteration 1: all rows
    monkeypatch.setattr(fusion_module, "MAX_KERNEL_PAIRS", first - 1)
    with pytest.raises(TooManyNeighboursError):
        mean_shift_modes(X, 0.1)
    monkeypatch.setattr(fusion_module, "MAX_KERNEL_PAIRS", 100 * first)
    modes, labels = mean_shift_modes(X, 0.1)
    ref_modes, ref_labels = dense_mean_shift(X, 0.01 * np.eye(3), np.ones(len(X)))
    np.testing.assert_array_equal(labels, ref_labels)
    np.testing.assert_allclose(modes, ref_modes, rtol=0, atol=1e-9)


def test_the_fusion_report_names_what_min_views_left_out():
    rng = np.random.default_rng(12)
    # three doors seen in 3 views each, a knob seen once, a drawer seen twice
    raw = [pc.Percept("door", [2.0 + k, 0.0, 1.0] + 0.005 * rng.standard_normal(3), 0.01)
           for k in range(3) for _ in range(3)]
    raw += [pc.Percept("knob", [1.0, 1.0, 1.0], 0.01)]
    raw += [pc.Percept("drawer", [1.0, -1.0, 0.5] + 0.005 * rng.standard_normal(3), 0.01) for _ in range(2)]
    report = pc.fuse_percepts_report(raw, bandwidth=0.1, min_views=3)
    assert sorted(p.type for p in report.percepts) == ["door", "door", "door"]
    assert sorted((d.type, d.views, d.reason) for d in report.dropped) == [
        ("drawer", 2, "too_few_views"), ("knob", 1, "too_few_views")]
    knob = next(d for d in report.dropped if d.type == "knob")
    np.testing.assert_allclose(knob.position, [1.0, 1.0, 1.0])
    assert "min_views = 3" in knob.detail
    # fuse_percepts returns the same percepts
    plain = pc.fuse_percepts(raw, bandwidth=0.1, min_views=3)
    assert [p.position.tolist() for p in plain] == [p.position.tolist() for p in report.percepts]
    assert pc.fuse_percepts_report(raw, bandwidth=0.1, min_views=1).dropped == ()
