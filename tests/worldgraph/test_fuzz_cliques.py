"""Fuzz tests of sparse adjacency in ``maximum_cliques``.

As in the other fuzz files: a call either raises the package's error with a message naming the
argument, or returns a finite answer that satisfies its status.
"""

from __future__ import annotations

from hypothesis import given, settings

from tests.fuzz import named_error as _named
from tests.fuzz import nasty
from worldgraph.association.cliques import maximum_cliques


@settings(max_examples=40)
@given(nasty, nasty)
def test_maximum_cliques_sparse_pairs(rows: object, cols: object) -> None:
    try:
        res = maximum_cliques([2, 3], {(0, 1): (rows, cols)})
    except Exception as exc:  # noqa: BLE001
        _named(exc, "adjacency")
        return
    assert res.maximum in (0, 1, 2)
