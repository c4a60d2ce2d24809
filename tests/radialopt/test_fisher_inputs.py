"""crlb: a singular Fisher matrix names the centres and the position.

From the issue-12 audit of radialopt: each case failed without its fix.
"""

from __future__ import annotations

import numpy as np
import pytest

import radialopt as ro
from radialopt import errors


# ---------------------------------------------------------------- 9. messages name `centers`
def test_crlb_singular_names_centers_and_position() -> None:
    with pytest.raises(errors.SingularFisherError, match=r"position = \[1\.0, 1\.2, 1\.1\].*centers = "
                       r"\[\[-1\.0, -1\.0, -1\.0\]"):
        ro.crlb(np.full((4, 3), -1.0), [0.1] * 4, [1.0, 1.2, 1.1])
