"""Millimetre hints: localize says when percepts or the world look like millimetres."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import worldgraph as wg
from perception import Percept, simulate_percepts
from worldgraph.model.units import UnitsWarning, check_world_units, percept_units_hint, world_units_hint


@pytest.fixture(scope="module")
def kitchen_scan() -> tuple[wg.WorldModel, list[Percept]]:
    world = wg.scenes.kitchen(seed=0)
    pose = np.eye(4)
    pose[:3, 3] = [5.0, 4.0, 1.2]  # the middle of the 10 m x 8 m kitchen
    percepts, _ = simulate_percepts(list(world.types), world.positions, pose, np.random.default_rng(0),
                                    max_range=4.0)
    return world, percepts


def _scaled(percepts: list[Percept], factor: float) -> list[Percept]:
    return [Percept(p.type, p.position * factor, p.sigma * factor) for p in percepts]


def test_metre_kitchen_gets_no_hint(kitchen_scan) -> None:
    world, percepts = kitchen_scan
    assert percept_units_hint(world, percepts) is None
    assert world_units_hint(world) is None
    res = wg.localize(world, percepts)
    assert res.status == "ok"
    assert "millimetre" not in res.message


def test_millimetre_percepts_in_the_kitchen(kitchen_scan) -> None:
    world, percepts = kitchen_scan
    res = wg.localize(world, _scaled(percepts, 1000.0))
    assert res.status == "no_association"  # the status is what it was; the message now says why
    assert "percept positions look like millimetres" in res.message
    assert "divide" in res.message and "1000" in res.message
    assert not np.any(np.isfinite(res.position))


def test_millimetre_world_with_metre_percepts(kitchen_scan) -> None:
    world, percepts = kitchen_scan
    with pytest.warns(UnitsWarning):
        world_mm = wg.WorldModel.from_arrays(list(world.types), world.positions * 1000.0)
    res = wg.localize(world_mm, percepts)
    assert res.status == "no_association"
    assert "world positions look like millimetres" in res.message
    assert res.message.count("look like millimetres") == 1  # one hint, not two


def test_world_from_millimetre_arrays_warns(kitchen_scan) -> None:
    world, _ = kitchen_scan
    with pytest.warns(UnitsWarning):  # the builder warns too
        world_mm = wg.WorldModel.from_arrays(list(world.types), world.positions * 1000.0)  # sizes 0.05 m
    with pytest.warns(UnitsWarning, match="look like millimetres"):
        hint = check_world_units(world_mm)
    assert hint is not None and "0.05 m in size" in hint
    # the same positions in metres, and millimetre positions with millimetre sizes: no warning
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert check_world_units(wg.WorldModel.from_arrays(list(world.types), world.positions)) is None
        same_unit = wg.WorldModel.from_arrays(list(world.types), world.positions * 1000.0, sizes=[50.0] * 3)
        assert check_world_units(same_unit) is None


def _line_world(span: float) -> wg.WorldModel:
    x = np.linspace(0.0, span, 5)
    return wg.WorldModel.from_arrays(["a"] * 5, np.column_stack([x, np.zeros(5), np.zeros(5)]),
                                     max_link_length=span, sizes=[span / 10] * 3)


def _at_ranges(ranges: list[float]) -> list[Percept]:
    return [Percept("a", (r, 0.0, 0.0), 0.01) for r in ranges]


@pytest.mark.parametrize("span, ranges, expected", [
    # world 4 m: its bounds (0.4 m boxes) have a diagonal of sqrt(4.4^2 + 0.4^2 + 0.4^2) = 4.44 m
    (4.0, [150.0, 160.0, 170.0], "percept"),        # median 160 m > 100 m in a world below 100 m
    (4.0, [60.0, 70.0, 80.0], None),                # 70 m: long, but not over 100 m
    # world 2 km, 200 m boxes: diagonal sqrt(2200^2 + 200^2 + 200^2) = 2218 m; a far-seeing sensor is fine ...
    (2000.0, [150.0, 200.0, 250.0], None),
    # ... unless the percepts spread over more than 10 world extents (22 km)
    (2000.0, [150.0, 30000.0, 60000.0], "percept"),
    # percepts within 1.5 m (median 1 m): 2218 / 1 > 1000 x the percepts' scale
    (2000.0, [0.5, 1.0, 1.5], "world"),
    (2000.0, [1.0, 2.5, 3.0], None),                # 2218 / 2.5 = 887 < 1000
])
def test_percept_hint_thresholds(span: float, ranges: list[float], expected: str | None) -> None:
    hint = percept_units_hint(_line_world(span), _at_ranges(ranges))
    if expected is None:
        assert hint is None
    else:
        assert hint is not None and hint.startswith(f"{expected} positions look like millimetres")


def test_no_percepts_no_hint() -> None:
    assert percept_units_hint(_line_world(4.0), []) is None


def test_builders_and_associate_warn_about_millimetres(kitchen_scan) -> None:
    world, percepts = kitchen_scan
    with pytest.warns(UnitsWarning, match="world positions look like millimetres"):
        wg.WorldModel.from_arrays(list(world.types), world.positions * 1000.0)
    # associate: no hypothesis and millimetre percepts -> a warning with the hint
    with pytest.warns(UnitsWarning, match="no hypothesis; percept positions look like millimetres"):
        hyps = wg.associate(world, _scaled(percepts, 1000.0))
    assert hyps == []
    # metres: hypotheses and no warning; localize keeps the hint in its message, not a warning
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert wg.associate(world, percepts)
        res = wg.localize(world, _scaled(percepts, 1000.0))
    assert "look like millimetres" in res.message
