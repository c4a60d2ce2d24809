"""Mean-shift fusion: the iteration budget of a huge input.

From the issue-12 audit of perception (hardening): each case failed before its fix.
"""

from __future__ import annotations

import numpy as np
import pytest

import perception as pc
import perception.frontend.fusion as fusion_module
from perception.errors import (
    TooManyNeighboursError,
)


# ------------------------------------------------------------------ 4: mean shift budget
def test_mean_shift_of_50000_normal_points_at_bandwidth_03_is_refused_after_one_iteration(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Before: 14 iterations (84 s) ran before the error. Now the run is refused once its first
    iteration shows that its cost does not shrink (kernel sums of one iteration only), while 100
    views of 500 objects (50,000 points that collapse onto their modes) are fused."""
    assert fusion_module.MAX_KERNEL_PAIRS == 100_000_000
    calls = []
    for name in ("_sparse_sums", "_dense_sums"):
        real = getattr(fusion_module, name)
        monkeypatch.setattr(fusion_module, name,
                            lambda *a, _real=real, **k: calls.append(1) or _real(*a, **k))
    X = np.random.default_rng(0).normal(size=(50_000, 3))
    with pytest.raises(TooManyNeighboursError, match=r"100,000,000.*50,000 points.*bandwidth"):
        pc.mean_shift_modes(X, 0.3)
    assert len(calls) <= 2  # the sparse and the crowded rows of the first iteration
    rng = np.random.default_rng(1)
    centres = rng.uniform(-10, 10, (500, 3))
    views = np.repeat(centres, 100, axis=0) + rng.normal(0, 0.01, (50_000, 3))
    modes, labels = pc.mean_shift_modes(views, 0.1)
    assert len(modes) == 500 and labels.shape == (50_000,)
    # the same points at a bandwidth holding a few points per kernel are fused
    modes, labels = pc.mean_shift_modes(X[:5_000], 0.02)
    assert labels.shape == (5_000,) and np.all((labels >= 0) & (labels < len(modes)))
