"""Fuzz tests of the building and campus scenes: ``building_site``, ``campus_site``.

As in the other fuzz files: a call either raises the package's error with a message naming the
argument, or returns a finite answer that satisfies its status.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.fuzz import named_error as _named
from tests.fuzz import nasty
from worldgraph import scenes


@settings(max_examples=40)
@given(st.sampled_from(["storeys", "n_objects", "seed", "storey_height", "max_link_length", "link_margin"]),
       nasty)
def test_building_site_arguments(arg: str, value: object) -> None:
    kwargs = {"storeys": 2, "n_objects": 400}
    kwargs[arg] = value
    try:
        site = scenes.building_site(**kwargs)
    except Exception as exc:  # noqa: BLE001
        _named(exc, arg)
        return
    assert len(site.world) == len(site.storey) == len(site.building)
    assert np.all(np.isfinite(site.world.positions))


@settings(max_examples=30)
@given(st.sampled_from(["buildings", "gap"]), nasty)
def test_campus_site_arguments(arg: str, value: object) -> None:
    kwargs = {"buildings": 2, "storeys": 1, "n_objects": 400}
    kwargs[arg] = value
    try:
        site = scenes.campus_site(**kwargs)
    except Exception as exc:  # noqa: BLE001
        _named(exc, arg)
        return
    assert np.all(np.isfinite(site.world.positions))
