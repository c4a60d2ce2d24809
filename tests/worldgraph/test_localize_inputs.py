"""localize: a rotation gate in degrees, check=True beyond the vertex-enumeration limit.

From the second adversarial audit of worldgraph: each case raised something else than
the package's error, or was accepted silently.
"""

from __future__ import annotations

import pytest

import worldgraph as wg
from tests.worlds import four_type_world_and_percepts


def test_rotation_gate_in_degrees_is_refused_with_a_hint() -> None:
    world, percepts = four_type_world_and_percepts()
    with pytest.raises(wg.WorldGraphError, match=r"max_rotation_3sigma = 45.0 .*radians.*np.radians"):
        wg.localize(world, percepts, max_rotation_3sigma=45.0)
    assert wg.localize(world, percepts, max_rotation_3sigma=0.5).status in wg.LOCALIZE_STATUSES


def test_localize_check_skips_hypotheses_beyond_the_enumeration_limit_and_says_so() -> None:
    """check=True with 10 matched percepts: vertex enumeration of 10 spheres would run for minutes;
    localize solves those unchecked and its message names the limit."""
    import radialopt as ro

    world, percepts = four_type_world_and_percepts()
    res = wg.localize(world, percepts, check=True)
    assert res.status in wg.LOCALIZE_STATUSES
    assert len(res.correspondences) > ro.MAX_VERTEX_SPHERES
    assert "MAX_VERTEX_SPHERES" in res.message
    small = wg.localize(world, percepts[:5], check=True)
    assert "MAX_VERTEX_SPHERES" not in small.message
