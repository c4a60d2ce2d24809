"""localize: a rotation gate in degrees, check=True beyond the vertex-enumeration limit.

From the second adversarial audit of worldgraph (issue 12): each case raised something else than
the package's error, or was accepted silently.
"""

from __future__ import annotations

import numpy as np
import pytest

import perception as pc
import worldgraph as wg


def _world() -> tuple[wg.WorldModel, list[pc.Percept]]:
    pos = np.random.default_rng(0).uniform([0, 0, 0], [6, 6, 2], (20, 3))
    world = wg.WorldModel.from_arrays([f"t{i % 4}" for i in range(20)], pos)
    return world, [pc.Percept(f"t{i % 4}", pos[i] - [2, 3, 0.5], 0.02) for i in range(10)]


def test_rotation_gate_in_degrees_is_refused_with_a_hint() -> None:
    world, percepts = _world()
    with pytest.raises(wg.OutOfRangeError, match=r"max_rotation_3sigma = 45.0 .*radians.*np.radians"):
        wg.localize(world, percepts, max_rotation_3sigma=45.0)
    assert wg.localize(world, percepts, max_rotation_3sigma=0.5).status in wg.LOCALIZE_STATUSES


def test_localize_check_skips_hypotheses_beyond_the_enumeration_limit_and_says_so() -> None:
    """check=True with 10 matched percepts: vertex enumeration of 10 spheres would run for minutes;
    localize solves those unchecked and its message names the limit."""
    import radialopt as ro

    world, percepts = _world()
    res = wg.localize(world, percepts, check=True)
    assert res.status in wg.LOCALIZE_STATUSES
    assert len(res.correspondences) > ro.MAX_VERTEX_SPHERES
    assert "MAX_VERTEX_SPHERES" in res.message
    small = wg.localize(world, percepts[:5], check=True)
    assert "MAX_VERTEX_SPHERES" not in small.message
