"""Fuzz tests of active validation: ``plan_view``, ``active_localize``.

As in the other fuzz files: a call either raises the package's error with a message naming the
argument, or returns a finite answer that satisfies its status.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import perception as pc
import worldgraph as wg
from tests.fuzz import named_error as _named
from tests.fuzz import nasty
from tests.worlds import two_copied_rooms

WORLD, PERCEPTS = two_copied_rooms()
RESULT = wg.localize(WORLD, PERCEPTS)


def test_two_room_result_is_ambiguous_with_a_pose() -> None:
    assert RESULT.status == "ambiguous" and np.all(np.isfinite(RESULT.transformation))


@settings(max_examples=60)
@given(st.sampled_from(["fov_deg", "max_range", "detection", "depth_factor", "min_sigma", "n_sigma",
                        "margin", "types", "candidates", "rng", "head", "joint_limits"]), nasty)
def test_plan_view_arguments(arg: str, value: object) -> None:
    try:
        plan = wg.plan_view(WORLD, RESULT, **{arg: value})
    except Exception as exc:  # noqa: BLE001 - the test is about which exceptions escape
        _named(exc, arg)
        return
    assert plan.status in ("ok", "not_discriminating", "single_hypothesis")
    assert np.all(np.isfinite(plan.direction)) and abs(np.linalg.norm(plan.direction) - 1.0) < 1e-9
    assert 0.0 <= plan.score <= 1.0


@pytest.mark.parametrize("world, result", [(None, RESULT), (WORLD, None), (WORLD, "ok"), ("w", RESULT)])
def test_plan_view_wrong_objects(world: object, result: object) -> None:
    with pytest.raises(wg.WorldGraphError, match="world|result"):
        wg.plan_view(world, result)


@settings(max_examples=40)
@given(nasty, st.sampled_from(["max_looks", "look_while", "fov_deg", "max_range", "planner"]))
def test_active_localize_arguments(value: object, arg: str) -> None:
    def look(direction: np.ndarray) -> list[pc.Percept]:
        return []

    try:
        out = wg.active_localize(WORLD, PERCEPTS, look, **{arg: value})
    except Exception as exc:  # noqa: BLE001
        _named(exc, arg, "planner(result)")
        return
    assert out.result.status in wg.LOCALIZE_STATUSES


@pytest.mark.parametrize("answer", [None, 3, "percepts", [None], [1.0, 2.0],
                                    [pc.Percept("sofa", [1, 2, 3], 0.1)]])
def test_active_localize_bad_look_answers_are_named(answer: object) -> None:
    try:
        out = wg.active_localize(WORLD, PERCEPTS, lambda d: answer, max_looks=1)
    except Exception as exc:  # noqa: BLE001
        _named(exc, "look(direction)", "percepts", "sofa")
        return
    assert out.result.status in wg.LOCALIZE_STATUSES
