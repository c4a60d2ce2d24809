"""Fuzz tests of ``WorldModel.type_tree``.

As in the other fuzz files: a call either raises the package's error with a message naming the
argument, or returns a finite answer that satisfies its status.
"""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from tests.fuzz import named_error as _named
from tests.fuzz import nasty
from tests.worlds import two_copied_rooms

WORLD, PERCEPTS = two_copied_rooms()


@settings(max_examples=30)
@given(st.one_of(nasty, st.text(max_size=5)), nasty)
def test_type_tree_arguments(type_name: object, z_scale: object) -> None:
    try:
        tree = WORLD.type_tree(type_name, z_scale)
    except Exception as exc:  # noqa: BLE001
        _named(exc, "type_name", "z_scale")
        return
    assert tree.n == len(WORLD.indices_of(type_name))
