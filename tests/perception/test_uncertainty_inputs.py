"""triangulation_covariance: a bad pair reported first; chunks equal one block.

From the issue-12 audit of perception (hardening): each case failed before its fix.
"""

from __future__ import annotations

import numpy as np
import pytest

import perception as pc
import perception.head.uncertainty as uncertainty_module
from perception.errors import (
    BehindCameraError,
)


# ------------------------------------------------------------------ 5: triangulation covariance
def _pairs(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray, pc.StereoRig]:
    rig = pc.StereoRig.default((160, 120))
    X = np.random.default_rng(seed).uniform([-0.3, -0.2, 1.0], [0.3, 0.2, 3.0], (n, 3))
    u1, u2 = rig.project(X)
    return u1, u2, rig


def test_triangulation_covariance_reports_a_bad_pair_before_differentiating(
        monkeypatch: pytest.MonkeyPatch) -> None:
    u1, u2, rig = _pairs(40)
    u1[33] = u2[33] - [4.0, 0.0]  # negative disparity: behind the cameras
    calls = []
    real = uncertainty_module.triangulation_jacobian
    monkeypatch.setattr(uncertainty_module, "triangulation_jacobian",
                        lambda *a, **k: calls.append(len(a[1])) or real(*a, **k))
    monkeypatch.setattr(uncertainty_module, "COVARIANCE_CHUNK", 8)
    with pytest.raises(BehindCameraError, match=r"pixel pair 33 "):
        pc.triangulation_covariance(rig, u1, u2)
    assert calls == []  # no Jacobian (8 perturbed triangulations per pair) was computed


def test_triangulation_covariance_in_chunks_equals_one_block(monkeypatch: pytest.MonkeyPatch) -> None:
    """Reference: the Jacobian of all pairs at once, ``J diag(s^2) J^T`` by explicit loops."""
    u1, u2, rig = _pairs(37, seed=1)
    s = np.array([0.5, 0.4, 0.3, 0.6])
    J = uncertainty_module.triangulation_jacobian(rig, u1, u2)
    ref = np.array([sum(s[k] ** 2 * np.outer(Jn[:, k], Jn[:, k]) for k in range(4)) for Jn in J])
    sizes = []
    real = uncertainty_module.triangulation_jacobian
    monkeypatch.setattr(uncertainty_module, "triangulation_jacobian",
                        lambda *a, **k: sizes.append(len(a[1])) or real(*a, **k))
    monkeypatch.setattr(uncertainty_module, "COVARIANCE_CHUNK", 10)
    C = pc.triangulation_covariance(rig, u1, u2, s)
    assert sizes == [10, 10, 10, 7]
    np.testing.assert_allclose(C, ref, rtol=1e-12, atol=0)
