"""Shared pieces of the fuzz tests of worldgraph's later entry points (active validation, tiles,
scenes, type_tree, shared_range_covariance, sparse clique adjacency).

As in the other fuzz files: a call either raises the package's error with a message naming the
argument, or returns a finite answer that satisfies its status.
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import strategies as st

import worldgraph as wg

NASTY = [math.nan, math.inf, -math.inf, 1e308, -1e308, 1e-300, -1.0, 0.0, 0, -3, 10**30, True, False,
         None, "3", 1 + 2j, 2.5, [1.0], np.float32(2.0), b"x"]
nasty = st.sampled_from(NASTY)


def named_error(exc: Exception, *names: str) -> None:
    """``exc`` is worldgraph's error and its message names one of ``names``."""
    assert isinstance(exc, wg.WorldGraphError), repr(exc)
    assert any(n in str(exc) for n in names), str(exc)
