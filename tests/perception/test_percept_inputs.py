"""Percept: bounded position, views and sigma; type names without NUL or lone surrogates.

From the issue-12 audit of perception (hardening): each case failed before its fix.
"""

from __future__ import annotations

import numpy as np
import pytest

import perception as pc
from perception.errors import (
    PerceptionError,
)


# ------------------------------------------------------------------ 6: percept bounds
def test_percept_position_and_views_are_bounded() -> None:
    with pytest.raises(PerceptionError, match=r"position\[2\] = 1e\+308"):
        pc.Percept("door", [1.0, 2.0, 1e308], 0.1)
    with pytest.raises(PerceptionError, match=r"position\[0\] = -2000000000.0"):
        pc.Percept("door", [-2e9, 2.0, 1.0], 0.1)
    with pytest.raises(PerceptionError, match=r"views .*1180591620717411303424"):
        pc.Percept("door", [1.0, 2.0, 3.0], 0.1, views=2**70)
    p = pc.Percept("door", [1e9, 0.0, 0.0], 0.1, views=2**31 - 1)
    assert p.range == 1e9 and p.views == 2**31 - 1


# ------------------------------------------------------------------ 8: names
@pytest.mark.parametrize("bad", ["a\x00b", "\udcff", "door\ud800"])
def test_names_reject_nul_and_lone_surrogates(bad: str) -> None:
    with pytest.raises(PerceptionError, match="joint name"):
        pc.Joint(bad, "z", np.eye(4))
    with pytest.raises(PerceptionError, match="type"):
        pc.Percept(bad, [1.0, 2.0, 3.0], 0.1)
    with pytest.raises(PerceptionError, match="type"):
        pc.Box(np.zeros(3), np.ones(3), np.eye(3), np.zeros(3), bad)
    with pytest.raises(PerceptionError, match="type"):
        pc.Detection(bad, [1.0, 2.0], 3.0, np.zeros(2))


def test_non_ascii_names_stay_accepted() -> None:
    assert pc.Percept("tür", [1.0, 2.0, 3.0], 0.1).type == "tür"
    assert pc.Joint("gelenk_ä", "z", np.eye(4)).name == "gelenk_ä"


# ------------------------------------------------------------------ 9: sigma with shared loadings
def test_huge_sigma_with_shared_loadings_names_sigma() -> None:
    with pytest.raises(PerceptionError, match=r"sigma = 1e\+308"):
        pc.Percept("door", [1.0, 2.0, 3.0], 1e308, shared=((0, np.eye(3) * 1e-4),))
    with pytest.raises(PerceptionError, match=r"shared\[0\] loading\[1, 1\] = 1e\+200"):
        pc.Percept("door", [1.0, 2.0, 3.0], 0.1, covariance=np.eye(3),
                   shared=((0, np.diag([0.0, 1e200, 0.0])),))
    p = pc.Percept("door", [1.0, 2.0, 3.0], 0.1, shared=((0, np.eye(3) * 1e-4),))
    assert p.shared[0][0] == 0
