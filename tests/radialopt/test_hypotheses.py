"""Level sets Phi_1..Phi_3 and location hypotheses (paper section 2.3)."""

from itertools import combinations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import radialopt as ro

# a well-spread, non-coplanar landmark set (every four of them span 3-D)
LANDMARKS = np.array([
    [0.0, 0.0, 0.0],
    [6.0, 0.5, 1.0],
    [1.0, 7.0, 2.0],
    [2.0, 1.5, 5.0],
    [7.0, 6.0, 4.0],
    [4.0, 8.0, 0.5],
])


@st.composite
def exact_scene(draw, n_min=4, n_max=6):
    n = draw(st.integers(n_min, n_max))
    perm = draw(st.permutations(range(6)))
    centers = LANDMARKS[list(perm[:n])]
    truth = np.array([draw(st.floats(0.5, 7.5)) for _ in range(3)])
    sigmas = np.array([draw(st.floats(0.01, 0.2)) for _ in range(n)])
    return centers, truth, sigmas


def spheres_for(centers, radii, sigmas):
    return ro.make_spheres(centers, radii, sigmas)


def test_counts_and_hypotheses_for_four_spheres_with_exact_radii():
    truth = np.array([3.0, 3.0, 2.5])
    c = LANDMARKS[:4]
    s = spheres_for(c, np.linalg.norm(c - truth, axis=1), 0.05)
    ls = ro.generate_hypotheses(s)
    assert [k for k, _ in ls.circles] == list(combinations(range(4), 2))
    assert [k for k, _ in ls.point_pairs] == list(combinations(range(4), 3))
    assert [k for k, _ in ls.points] == [(0, 1, 2, 3)]
    # every point pair has the quadruple as descendant: the only hypothesis is the Phi_3 point
    assert len(ls.hypotheses) == 1
    h = ls.hypotheses[0]
    assert h.spheres == (0, 1, 2, 3) and h.level == 3 and h.status == "real"
    np.testing.assert_allclose(h.position, truth, atol=1e-9)
    assert h.validation_density == 1.0 and h.validation_residual == 0.0  # no other spheres
    assert h.total_density == pytest.approx(1.0, abs=1e-12)


def test_coplanar_centres_leave_point_pairs_without_descendants():
    c = np.array([[0, 0, 1.0], [5, 0, 1.0], [0, 5, 1.0], [4, 4, 1.0]])
    truth = np.array([2.0, 1.5, 3.0])
    s = spheres_for(c, np.linalg.norm(c - truth, axis=1), 0.05)
    ls = ro.generate_hypotheses(s)
    assert ls.points == ()  # four coplanar centres have no radical centre
    assert len(ls.point_pairs) == 4 and len(ls.hypotheses) == 8
    mirror = truth * [1, 1, -1] + [0, 0, 2.0]
    for h in ls.hypotheses:
        assert h.level == 2 and len(h.spheres) == 3
        d = min(np.linalg.norm(h.position - truth), np.linalg.norm(h.position - mirror))
        assert d < 1e-9
        # validated by the one sphere not used: it passes through truth and mirror alike
        assert h.validation_density == pytest.approx(1.0, abs=1e-9)
    region = ro.Region([-1, -1, 1.0], [6, 6, 4])
    ls = ro.generate_hypotheses(s, region=region)
    inside = [h for h in ls.hypotheses if h.in_region]
    assert len(inside) == 4
    assert all(np.linalg.norm(h.position - truth) < 1e-9 for h in inside)
    assert [h.in_region for h in ls.hypotheses] == [True] * 4 + [False] * 4  # sorted first


@given(exact_scene(n_min=5, n_max=6))
def test_exact_radii_all_hypotheses_hit_the_truth(scene):
    centers, truth, sigmas = scene
    n = len(centers)
    s = spheres_for(centers, np.linalg.norm(centers - truth, axis=1), sigmas)
    ls = ro.generate_hypotheses(s)
    assert len(ls.circles) == n * (n - 1) // 2
    assert len(ls.points) == len(list(combinations(range(n), 4)))
    assert all(h.level == 3 for h in ls.hypotheses)  # every triple has a descendant
    for h in ls.hypotheses:
        assert np.linalg.norm(h.position - truth) < 1e-8
        assert h.validation_density == pytest.approx(1.0, abs=1e-8)
        assert h.validation_residual < 1e-6


def test_validation_uses_only_spheres_not_in_the_hypothesis():
    truth = np.array([3.0, 3.0, 2.5])
    c = LANDMARKS[:5]
    r = np.linalg.norm(c - truth, axis=1)
    sig = np.array([0.05, 0.05, 0.05, 0.05, 0.1])
    r[4] += 0.3  # sphere 4 is wrong by 3 sigma
    ls = ro.generate_hypotheses(spheres_for(c, r, sig))
    by_key = {h.spheres: h for h in ls.hypotheses}
    clean = by_key[(0, 1, 2, 3)]
    np.testing.assert_allclose(clean.position, truth, atol=1e-9)
    assert clean.validation_residual == pytest.approx(3.0, rel=1e-9)
    assert clean.validation_density == pytest.approx(np.exp(-4.5), rel=1e-9)
    assert clean.total_density == pytest.approx(np.exp(-4.5), rel=1e-9)
    # the other hypotheses use sphere 4 and are validated against one clean sphere
    for key, h in by_key.items():
        assert len(key) == 4
        if 4 in key:
            (other,) = set(range(5)) - set(key)
            z = (np.linalg.norm(h.position - c[other]) - r[other]) / sig[other]
            assert h.validation_residual == pytest.approx(abs(z), rel=1e-9, abs=1e-12)
    # the hypothesis with the highest total density is listed first
    dens = [h.total_density for h in ls.hypotheses]
    assert dens == sorted(dens, reverse=True)


def test_imaginary_triples_are_kept_only_on_request():
    h = np.sqrt(3.0)
    c = np.array([[0, 0, 0], [2, 0, 0], [1, h, 0]])
    s = spheres_for(c, [1.1, 1.1, 1.1], 0.1)  # pairs meet, the triple does not
    real_only = ro.generate_hypotheses(s, keep_imaginary=False)
    assert len(real_only.circles) == 3 and real_only.point_pairs == () and real_only.hypotheses == ()
    kept = ro.generate_hypotheses(s)
    assert len(kept.hypotheses) == 1  # the foot point, once
    hyp = kept.hypotheses[0]
    assert hyp.status == "imaginary" and hyp.residual < 0
    np.testing.assert_allclose(hyp.position, [1, h / 3, 0], atol=1e-12)


@given(exact_scene(n_min=4, n_max=6), st.integers(0, 2**31))
def test_hypotheses_are_invariant_to_sphere_order(scene, seed):
    centers, truth, sigmas = scene
    rng = np.random.default_rng(seed)
    r = np.abs(np.linalg.norm(centers - truth, axis=1) + rng.normal(0, 0.05, len(centers)))
    perm = rng.permutation(len(centers))
    a = ro.generate_hypotheses(spheres_for(centers, r, sigmas))
    b = ro.generate_hypotheses(spheres_for(centers[perm], r[perm], sigmas[perm]))
    assert len(a.hypotheses) == len(b.hypotheses)
    # same (sphere set, position) pairs after relabelling
    relabel = {int(new): int(old) for new, old in enumerate(perm)}
    keyed_a = sorted((h.spheres, tuple(np.round(h.position, 6))) for h in a.hypotheses)
    keyed_b = sorted((tuple(sorted(relabel[i] for i in h.spheres)), tuple(np.round(h.position, 6)))
                     for h in b.hypotheses)
    assert [k for k, _ in keyed_a] == [k for k, _ in keyed_b]
    pa = np.array([p for _, p in keyed_a])
    pb = np.array([p for _, p in keyed_b])
    np.testing.assert_allclose(pa, pb, atol=2e-6)


def test_region_validation_and_errors():
    region = ro.Region([0, 0, 0], [1, 2, 3])
    assert region.contains([0.5, 1, 3]) is True
    np.testing.assert_array_equal(region.contains([[0.5, 1, 3.1], [0, 0, 0]]), [False, True])
    with pytest.raises(ro.RadialError, match=r"Region lower \[0\.0, 3\.0, 0\.0\] must be <= upper"):
        ro.Region([0, 3, 0], [1, 2, 3])
    with pytest.raises(ro.RadialError, match=r"shape \(3,\)"):
        ro.Region([0, 0], [1, 2])
    with pytest.raises(ro.RadialError, match=r"Region.lower\[2\] must be finite, got -inf"):
        ro.Region([0, 0, -np.inf], [1, 2, 3])
    with pytest.raises(ro.RadialError, match="centres 0 and 1 coincide"):
        ro.generate_hypotheses(spheres_for(np.zeros((3, 3)), [1, 1, 1], 1.0))
    few = ro.generate_hypotheses(spheres_for(LANDMARKS[:2], [3, 3], 1.0))
    assert few.hypotheses == () and len(few.circles) == 1
