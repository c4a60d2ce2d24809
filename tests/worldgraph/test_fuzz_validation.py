"""Fuzz tests of ``shared_range_covariance`` (worldgraph.pose.validation).

As in the other fuzz files: a call either raises the package's error with a message naming the
argument, or returns a finite answer that satisfies its status.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.fuzz import named_error as _named
from tests.fuzz import nasty
from worldgraph.pose.validation import shared_range_covariance


@settings(max_examples=40)
@given(st.sampled_from(["pose", "ego", "covs", "centers", "sigmas", "weights", "shared"]), nasty)
def test_shared_range_covariance_arguments(arg: str, value: object) -> None:
    rng = np.random.default_rng(1)
    kwargs = {"pose": np.eye(4), "ego": rng.uniform(1, 3, (4, 3)),
              "covs": np.broadcast_to(1e-4 * np.eye(3), (4, 3, 3)).copy(),
              "centers": rng.uniform(4, 6, (4, 3)), "sigmas": np.full(4, 0.01), "weights": np.ones(4),
              "shared": [((0, np.eye(3)[:, :1] * 1e-3),)] * 4}
    kwargs[arg] = value
    names = {"pose": "world_from_ego"}
    try:
        out = shared_range_covariance(kwargs["pose"], kwargs["ego"], kwargs["covs"], kwargs["centers"],
                                      kwargs["sigmas"], kwargs["weights"], kwargs["shared"])
    except Exception as exc:  # noqa: BLE001
        _named(exc, names.get(arg, arg))
        return
    assert out.shape == (6, 6) and not np.any(np.isnan(out))
