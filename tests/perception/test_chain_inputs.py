"""KinematicChain and percept_covariance: angles and encoder sigmas in degrees are refused.

From the issue-12 audit of perception (hardening): each case failed before its fix.
"""

from __future__ import annotations

import numpy as np
import pytest

import perception as pc
from perception.errors import (
    PerceptionError,
)


# ------------------------------------------------------------------ 7: units and absurd values
def test_encoder_sigma_in_degrees_is_refused_with_a_hint() -> None:
    head = pc.default_head()
    with pytest.raises(PerceptionError, match=r"encoder_sigma\[0\] = 45.0.*degrees.*np.radians"):
        pc.percept_covariance(head, np.zeros(7), [0.1, 0.2, 2.0], np.eye(3) * 1e-4, 45.0)
    sig = np.zeros(7)
    sig[3] = 0.6
    with pytest.raises(PerceptionError, match=r"encoder_sigma\[3\] = 0.6"):
        pc.percept_covariance(head, np.zeros(7), [0.1, 0.2, 2.0], np.eye(3) * 1e-4, sig)
    C = pc.percept_covariance(head, np.zeros(7), [0.1, 0.2, 2.0], np.eye(3) * 1e-4, 0.5)
    assert np.all(np.isfinite(C)) and np.linalg.eigvalsh(C)[0] > 0


def test_joint_angles_beyond_two_pi_are_refused_naming_the_joint() -> None:
    head = pc.default_head()
    with pytest.raises(PerceptionError, match=r"'neck_pitch'.*1e\+300.*radians.*degrees.*np.radians"):
        head.joints[0].transform(1e300)
    with pytest.raises(PerceptionError, match=r"'neck_pitch' \(index 0\) = 45.0.*np.radians"):
        head.ego_from_camera(np.full(7, 45.0))
    q = np.zeros(7)
    q[4] = -7.0
    with pytest.raises(PerceptionError, match=r"'eye_tilt' \(index 4\) = -7.0"):
        head.ego_from_camera(q)
    with pytest.raises(PerceptionError, match=r"angle of joint.*'head_tilt'.*90"):
        head.ego_from_camera({j.name: (90.0 if j.name == "head_tilt" else 0.0) for j in head.joints})
    # 2 pi itself is one full turn: the same pose as zero
    np.testing.assert_allclose(head.joints[2].transform(2 * np.pi), head.joints[2].transform(0.0), atol=1e-12)
