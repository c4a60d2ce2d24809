"""RestrictionPolytope: negative row indices, the coincident-centres message.

From the issue-12 audit of radialopt: each case failed without its fix.
"""

from __future__ import annotations

import numpy as np
import pytest

import radialopt as ro
from radialopt import errors


# ---------------------------------------------------------------- 6. negative indices do not wrap
def test_row_name_rejects_a_negative_index() -> None:
    poly = ro.RestrictionPolytope.from_centers(np.eye(3))
    with pytest.raises(errors.RadialError, match=r"k must be >= 0, got -1"):
        poly.row_name(-1)
    assert poly.row_name(len(poly.kinds) - 1).endswith("(1,2)")  # last pair of 3 spheres


def test_from_centers_coincident_message_uses_the_argument_name() -> None:
    with pytest.raises(errors.RadialError, match=r"centers\[0\] = \[0\.0, 0\.0, 0\.0\] and "
                       r"centers\[2\] = \[0\.0, 0\.0, 0\.0\]"):
        ro.RestrictionPolytope.from_centers([[0.0, 0, 0], [1.0, 0, 0], [0.0, 0, 0]])
