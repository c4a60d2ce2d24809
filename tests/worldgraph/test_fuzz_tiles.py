"""Fuzz tests of the tiles: ``split``, ``localize_tiled``.

As in the other fuzz files: a call either raises the package's error with a message naming the
argument, or returns a finite answer that satisfies its status.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import worldgraph as wg
from tests.fuzz import named_error as _named
from tests.fuzz import nasty
from tests.worlds import two_copied_rooms
from worldgraph.tiles import split

WORLD, PERCEPTS = two_copied_rooms()


@settings(max_examples=40)
@given(st.sampled_from(["labels", "halo"]), nasty)
def test_split_arguments(arg: str, value: object) -> None:
    kwargs = {"labels": np.repeat([0, 1], 30), "halo": 0.0}
    kwargs[arg] = value
    try:
        tiles = split(WORLD, **kwargs)
    except Exception as exc:  # noqa: BLE001
        _named(exc, arg)
        return
    assert sum(int(np.sum(t.own)) for t in tiles) == len(WORLD)


@settings(max_examples=30)
@given(st.sampled_from(["workers", "scheduler", "method", "rng", "region"]), nasty)
def test_localize_tiled_arguments(arg: str, value: object) -> None:
    tiles = split(WORLD, np.repeat([0, 1], 30))
    kwargs = {"workers": 1, arg: value}
    try:
        res = wg.localize_tiled(tiles, PERCEPTS, **kwargs)
    except Exception as exc:  # noqa: BLE001
        _named(exc, arg)
        return
    assert res.status in wg.LOCALIZE_STATUSES
    if res.status in ("ok", "weak", "ambiguous"):
        assert np.all(np.isfinite(res.transformation))
