"""StereoRig: the baseline and the distortion coefficients are bounded.

From the issue-12 audit of perception (hardening): each case failed before its fix.
"""

from __future__ import annotations

import numpy as np
import pytest

import perception as pc
from perception.errors import (
    PerceptionError,
)


def test_baseline_and_distortion_are_bounded() -> None:
    with pytest.raises(PerceptionError, match=r"baseline.*1.18059162071741\d*e\+21"):
        pc.StereoRig.default((160, 120), baseline=2**70)
    assert pc.StereoRig.default((160, 120), baseline=100.0).baseline == 100.0
    K = pc.StereoRig.default((160, 120)).K1
    with pytest.raises(PerceptionError, match=r"D1\[0\] = 1e\+154"):
        pc.StereoRig.from_opencv(K, [1e154, 0, 0, 0, 0], K, None, np.eye(3), [-0.1, 0, 0], (160, 120))
    with pytest.raises(PerceptionError, match=r"D2\[4\] = -20000.0"):
        pc.StereoRig.from_opencv(K, None, K, [0, 0, 0, 0, -2e4], np.eye(3), [-0.1, 0, 0], (160, 120))
