"""worldgraph.model.ring_join: the compiled ring and shell joins against a brute-force numpy reference.

The reference computes every pair with the documented expressions (``np.hypot(dx, dy)``,
``bz - az``, ``np.sqrt(dx*dx + dy*dy + dz*dz)``), so the sets must be identical, including
pairs exactly on the band edges.  numba is in the ``test`` extra, so the compiled path runs here.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from worldgraph.errors import (
    ImporterError,
    WorldGraphError,
)
from worldgraph.model import ring_join
from worldgraph.model.ring_join import ring_pairs, shell_pairs


def ring_reference(a, b, h_lo, h_hi, z_lo, z_hi):
    d = b[None, :, :] - a[:, None, :]
    h = np.hypot(d[..., 0], d[..., 1])
    dz = d[..., 2]
    i, j = np.nonzero((h_lo <= h) & (h <= h_hi) & (z_lo <= dz) & (dz <= z_hi))
    return set(zip(i.tolist(), j.tolist(), strict=True))


def shell_reference(a, b, r_lo, r_hi):
    d = b[None, :, :] - a[:, None, :]
    r = np.sqrt(d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1] + d[..., 2] * d[..., 2])
    i, j = np.nonzero((r_lo <= r) & (r <= r_hi))
    return set(zip(i.tolist(), j.tolist(), strict=True))


def as_set(i, j, n, m):
    assert i.dtype == np.int64 and j.dtype == np.int64
    assert i.shape == j.shape and i.ndim == 1
    if len(i):
        assert 0 <= i.min() and i.max() < n and 0 <= j.min() and j.max() < m
    pairs = set(zip(i.tolist(), j.tolist(), strict=True))
    assert len(pairs) == len(i), "a pair returned twice"
    return pairs


def points(rng, n, layout, offset):
    """``n`` points: uniform in a 40 x 40 x 12 m block, clustered, or on storeys 3.5 m apart."""
    if layout == "uniform":
        p = rng.uniform([-20, -20, 0], [20, 20, 12], (n, 3))
    elif layout == "clustered":
        centres = rng.uniform(-15, 15, (4, 3))
        p = centres[rng.integers(0, 4, n)] + rng.normal(0, 0.8, (n, 3))
    else:
        p = rng.uniform([0, 0, 0], [30, 20, 0.3], (n, 3))
        p[:, 2] += 3.5 * rng.integers(0, 4, n)
    return p + offset


@st.composite
def cases(draw, *, shell):
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    layout = draw(st.sampled_from(["uniform", "clustered", "storeys"]))
    offset = np.array([draw(st.sampled_from([0.0, 1e5, -3.3e5, 1e6])),
                       draw(st.sampled_from([0.0, 2.5e5, -1e6])), draw(st.sampled_from([0.0, 1e5]))])
    n = draw(st.sampled_from([0, 1, 2, 17, 150, 300]))
    a = points(rng, n, layout, offset)
    lo = draw(st.sampled_from([0.0, 0.5, 5.0, 6.0, 12.5, 20.0]))
    width = draw(st.sampled_from([0.0, 0.1, 0.3, 1.0, 5.0]))
    hi = min(lo + width, 20.0)
    z_lo = draw(st.sampled_from([-7.1, -3.6, -0.2, 0.0, 0.1, 3.4]))
    z_hi = z_lo + draw(st.sampled_from([0.0, 0.1, 0.3, 2.0, 8.0]))
    if draw(st.booleans()):
        b = a  # the same set: i == j pairs when the bands contain 0
    else:
        m = draw(st.sampled_from([0, 1, 23, 200]))
        b = points(rng, m, layout, offset)
    if n and draw(st.booleans()):
        # b on the band edges: offsets of exactly lo / hi (up to the rounding of the addition)
        k = min(n, 40)
        theta = rng.uniform(0, 2 * np.pi, k)
        radius = np.where(rng.random(k) < 0.5, lo, hi)
        dz = np.where(rng.random(k) < 0.5, z_lo, z_hi)
        if shell:
            edge = np.column_stack([radius * np.cos(theta), radius * np.sin(theta), np.zeros(k)])
            edge[: k // 2] = np.column_stack([np.zeros(k // 2), np.zeros(k // 2), radius[: k // 2]])
        else:
            edge = np.column_stack([radius * np.cos(theta), radius * np.sin(theta), dz])
            edge[: k // 2, 1] = 0.0  # axis-aligned: x offsets exactly +-lo / hi where rounding allows
            edge[: k // 2, 0] = radius[: k // 2]
        b = np.vstack([b, a[:k] + edge])
    return a, b, lo, hi, z_lo, z_hi


@given(cases(shell=False))
def test_ring_pairs_equal_the_brute_force_set(case):
    a, b, h_lo, h_hi, z_lo, z_hi = case
    i, j = ring_pairs(a, b, h_lo=h_lo, h_hi=h_hi, z_lo=z_lo, z_hi=z_hi)
    assert as_set(i, j, len(a), len(b)) == ring_reference(a, b, h_lo, h_hi, z_lo, z_hi)


@given(cases(shell=True))
def test_shell_pairs_equal_the_brute_force_set(case):
    a, b, r_lo, r_hi, _, _ = case
    i, j = shell_pairs(a, b, r_lo=r_lo, r_hi=r_hi)
    assert as_set(i, j, len(a), len(b)) == shell_reference(a, b, r_lo, r_hi)


def test_ring_edges_inclusive_hand_computed():
    # dyadic coordinates: every difference is exact, and hypot(3, 4) = 5, hypot(6, 8) = 10 exactly
    a = np.array([[1e6 + 0.5, -2e5 + 0.25, 10.0], [0.0, 0.0, 0.0]])
    b = np.array([
        [1e6 + 3.5, -2e5 + 4.25, 10.0 + 0.25],     # h = 5 = h_lo, dz = 0.25 = z_lo: in
        [1e6 + 6.5, -2e5 + 8.25, 10.0 + 0.75],     # h = 10 = h_hi, dz = 0.75 = z_hi: in
        [1e6 + 6.5, -2e5 + 8.25 + 2**-20, 10.5],   # h just above 10: out
        [1e6 + 3.5, -2e5 + 4.25, 10.0 + 0.75 + 2**-30],  # dz just above z_hi: out
        [1e6 + 0.5 - 7.0, -2e5 + 0.25, 10.5],      # h = 7, dz = 0.5: in
        [3.0, -4.0, 0.5],                          # in for a[1] only
    ])
    i, j = ring_pairs(a, b, h_lo=5.0, h_hi=10.0, z_lo=0.25, z_hi=0.75)
    assert as_set(i, j, 2, 6) == {(0, 0), (0, 1), (0, 4), (1, 5)}


def test_shell_edges_inclusive_hand_computed():
    a = np.array([[2.0**20, 0.5, -3.0]])
    b = a + np.array([[2.0, 3.0, 6.0],    # r = 7 = r_lo: in
                      [0.0, 0.0, -9.0],   # r = 9 = r_hi: in
                      [0.0, 0.0, 9.0 + 2**-20],  # out
                      [4.0, 4.0, 7.0],    # r = 9: in
                      [0.0, 6.0, 0.0]])   # r = 6: out
    i, j = shell_pairs(a, b, r_lo=7.0, r_hi=9.0)
    assert as_set(i, j, 1, 5) == {(0, 0), (0, 1), (0, 3)}


def test_identical_sets_give_self_pairs_when_the_bands_hold_zero():
    rng = np.random.default_rng(3)
    a = rng.uniform(0, 5, (50, 3))
    i, j = ring_pairs(a, a, h_lo=0.0, h_hi=0.5, z_lo=-0.1, z_hi=0.1)
    pairs = as_set(i, j, 50, 50)
    assert {(k, k) for k in range(50)} <= pairs
    assert pairs == ring_reference(a, a, 0.0, 0.5, -0.1, 0.1)
    i, j = shell_pairs(a, a, r_lo=0.0, r_hi=0.0)
    assert as_set(i, j, 50, 50) == {(k, k) for k in range(50)}


def test_wide_extent_and_many_rows(monkeypatch):
    # points spread over 1e4 m in x and 10 m in z with a thin ring: more grid rows than the
    # row table holds (binary search over all keys), and a far outlier at 1e9 m
    seen = []

    def spy(*args):
        out = sorted_b(*args)
        seen.append(out[-1])
        return out

    sorted_b = ring_join._sorted
    monkeypatch.setattr(ring_join, "_sorted", spy)
    rng = np.random.default_rng(7)
    a = np.column_stack([rng.uniform(0, 1e4, 400), rng.uniform(0, 2, 400), rng.uniform(0, 10, 400)])
    # as many points in b as in a, so that the grid is built on b (the smaller side when they differ)
    b = np.vstack([a[:399] + rng.normal(0, 0.5, (399, 3)), [[1e9, 0.0, 0.0]]])
    i, j = ring_pairs(a, b, h_lo=0.3, h_hi=0.8, z_lo=-0.05, z_hi=0.05)
    assert as_set(i, j, 400, 400) == ring_reference(a, b, 0.3, 0.8, -0.05, 0.05)
    i, j = shell_pairs(a, b, r_lo=0.2, r_hi=0.9)
    assert as_set(i, j, 400, 400) == shell_reference(a, b, 0.2, 0.9)
    assert seen == [False, False]  # both took the path without a row table


def test_empty_inputs_give_empty_int64_arrays():
    for a, b in [(np.empty((0, 3)), np.ones((4, 3))), (np.ones((4, 3)), [])]:
        b = np.reshape(b, (-1, 3))
        for i, j in [ring_pairs(a, b, h_lo=0, h_hi=1, z_lo=0, z_hi=1), shell_pairs(a, b, r_lo=0, r_hi=1)]:
            assert i.dtype == np.int64 and j.dtype == np.int64 and i.shape == j.shape == (0,)


GOOD = np.zeros((4, 3))
BAD_NAN = np.zeros((4, 3))
BAD_NAN[3, 1] = np.nan


@pytest.mark.parametrize(("kwargs", "error", "words"), [
    ({"a": BAD_NAN}, WorldGraphError, ["a[3, 1]", "nan"]),
    ({"b": np.full((2, 3), np.inf)}, WorldGraphError, ["b[0, 0]", "inf"]),
    ({"b": np.zeros((4, 2))}, WorldGraphError, ["b", "(4, 2)"]),
    ({"a": None}, WorldGraphError, ["a", "None"]),
    ({"a": np.ones((2, 3)) * (1 + 1j)}, WorldGraphError, ["a", "complex"]),
    ({"a": [[0.0, 0.0, 2e12]]}, WorldGraphError, ["a[0, 2]", "2000000000000"]),
    ({"h_lo": -1.0}, WorldGraphError, ["h_lo", "-1.0"]),
    ({"h_lo": 3.0, "h_hi": 2.0}, WorldGraphError, ["h_lo = 3.0", "h_hi = 2.0"]),
    ({"z_lo": 0.5, "z_hi": 0.25}, WorldGraphError, ["z_lo = 0.5", "z_hi = 0.25"]),
    ({"z_hi": float("inf")}, WorldGraphError, ["z_hi", "inf"]),
    ({"h_hi": float("nan")}, WorldGraphError, ["h_hi", "nan"]),
    ({"h_hi": True}, WorldGraphError, ["h_hi", "True"]),
    ({"z_lo": "0"}, WorldGraphError, ["z_lo", "'0'"]),
])
def test_ring_argument_errors(kwargs, error, words):
    args = {"a": GOOD, "b": GOOD, "h_lo": 1.0, "h_hi": 2.0, "z_lo": 0.0, "z_hi": 1.0} | kwargs
    with pytest.raises(error) as info:
        ring_pairs(args.pop("a"), args.pop("b"), **args)
    for word in words:
        assert word in str(info.value)


@pytest.mark.parametrize(("kwargs", "error", "words"), [
    ({"a": BAD_NAN}, WorldGraphError, ["a[3, 1]", "nan"]),
    ({"b": np.zeros((3,))}, WorldGraphError, ["b", "(3,)"]),
    ({"r_lo": -0.5}, WorldGraphError, ["r_lo", "-0.5"]),
    ({"r_lo": 2.0, "r_hi": 1.0}, WorldGraphError, ["r_lo = 2.0", "r_hi = 1.0"]),
    ({"r_hi": None}, WorldGraphError, ["r_hi", "None"]),
])
def test_shell_argument_errors(kwargs, error, words):
    args = {"a": GOOD, "b": GOOD, "r_lo": 1.0, "r_hi": 2.0} | kwargs
    with pytest.raises(error) as info:
        shell_pairs(args.pop("a"), args.pop("b"), **args)
    for word in words:
        assert word in str(info.value)


def test_missing_numba_names_the_extra(monkeypatch):
    monkeypatch.setattr(ring_join, "HAVE_NUMBA", False)
    monkeypatch.setitem(ring_join._COMPILED, "ring", None)
    monkeypatch.setitem(ring_join._COMPILED, "shell", None)
    for call in [lambda: ring_pairs(GOOD, GOOD, h_lo=0, h_hi=1, z_lo=0, z_hi=1),
                 lambda: shell_pairs(GOOD, GOOD, r_lo=0, r_hi=1)]:
        with pytest.raises(ImporterError) as info:
            call()
        assert isinstance(info.value, WorldGraphError)
        assert "pip install numba" in str(info.value)


def test_have_numba_true_where_the_test_extra_is_installed():
    # numba is in the test extra: the compiled path must be the one tested
    assert ring_join.HAVE_NUMBA


def test_importing_worldgraph_does_not_import_numba():
    code = "import sys, worldgraph, worldgraph.model.ring_join; print('numba' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_points_exactly_on_zero_width_rings_and_shells():
    # zero-width bands (r = 0: coincident points) with offsets along the axes: the pairs lie on
    # the reach of the grid ranges, where the rounding of the cell arithmetic drops some of them
    # without the margin (this test fails with _RANGE_ULPS = 0)
    rng = np.random.default_rng(11)
    for _ in range(300):
        off = rng.choice([0.0, 1e5, 1e6, -7.7e5]) + rng.uniform(0, 1)
        a = rng.uniform(-10, 10, (30, 3)) + off
        r = float(rng.choice([0.0, rng.uniform(0, 10)]))
        theta = rng.choice([0.0, np.pi / 2, np.pi, 1.5 * np.pi], 30)
        b = a + np.column_stack([r * np.cos(theta), r * np.sin(theta), np.zeros(30)])
        i, j = ring_pairs(a, b, h_lo=r, h_hi=r, z_lo=0.0, z_hi=0.0)
        assert as_set(i, j, 30, 30) == ring_reference(a, b, r, r, 0.0, 0.0)
        b = a + np.column_stack([np.zeros(30), r * np.sin(theta), r * np.cos(theta)])
        i, j = shell_pairs(a, b, r_lo=r, r_hi=r)
        assert as_set(i, j, 30, 30) == shell_reference(a, b, r, r)


@given(cases(shell=False), st.sampled_from([0.7, 2.0, 5.0]), st.sampled_from([0.1, 0.25, 1.0]),
       st.sampled_from([None, 0.0, 0.3, 1.0]))
def test_kept_grid_with_a_mask_equals_the_reference_on_the_chosen_points(case, cell, zcell, keep) -> None:
    """ring_pairs_in against a RingGrid kept for many calls (any cell sizes), with the grid's
    points restricted by a mask: the brute-force pairs whose b point is chosen."""
    a, b, h_lo, h_hi, z_lo, z_hi = case
    grid = ring_join.ring_grid(b, cell=cell, zcell=zcell)
    rng = np.random.default_rng(len(a) + len(b))
    mask = None if keep is None else rng.random(len(b)) < keep
    i, j = ring_join.ring_pairs_in(a, grid, h_lo=h_lo, h_hi=h_hi, z_lo=z_lo, z_hi=z_hi, b_mask=mask)
    want = ring_reference(a, b, h_lo, h_hi, z_lo, z_hi)
    if mask is not None:
        want = {(p, q) for p, q in want if mask[q]}
    assert as_set(i, j, len(a), len(b)) == want


def test_kept_grid_arguments_are_checked() -> None:
    grid = ring_join.ring_grid(np.zeros((3, 3)))
    with pytest.raises(WorldGraphError, match="grid must be a RingGrid, got ndarray"):
        ring_join.ring_pairs_in(np.zeros((1, 3)), np.zeros((3, 3)), h_lo=0, h_hi=1, z_lo=0, z_hi=1)
    with pytest.raises(WorldGraphError, match=r"b_mask must be a bool array of shape \(3,\), got dtype "
                                              r"int64"):
        ring_join.ring_pairs_in(np.zeros((1, 3)), grid, h_lo=0, h_hi=1, z_lo=0, z_hi=1,
                                b_mask=np.ones(3, dtype=np.int64))
    with pytest.raises(WorldGraphError, match=r"cell must be > 0, got 0\.0"):
        ring_join.ring_grid(np.zeros((3, 3)), cell=0.0)
    empty = ring_join.ring_grid(np.zeros((0, 3)))
    i, j = ring_join.ring_pairs_in(np.zeros((2, 3)), empty, h_lo=0, h_hi=1, z_lo=-1, z_hi=1)
    assert len(i) == len(j) == 0
