"""Rigid transforms as arguments: :func:`rigid_transform` (apart from ``worldgraph._checks``
because its default tolerance lives in :mod:`worldgraph.tolerances`, which uses those checks)."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from perception.head.chain import rigid_defect

from ._checks import real_array
from .errors import WorldGraphError
from .tolerances import RIGID_TOLERANCE


def rigid_transform(name: str, value: Any, *, tol: float | None = None,
                    max_translation: float | None = None) -> NDArray[np.float64]:
    """A (4, 4) rigid transform as a new float64 array.

    Finite, last row ``[0, 0, 0, 1]`` (within ``tol``), rotation block ``R`` with
    ``max |R^T R - I| <= tol`` and ``|det R - 1| <= tol``, and ``|t_i| <= max_translation``;
    anything else raises :class:`WorldGraphError`, naming the determinant and the orthogonality
    error of a scaled, sheared or reflected transform.  ``tol`` defaults to
    :data:`~worldgraph.tolerances.RIGID_TOLERANCE`.
    """
    if tol is None:
        tol = RIGID_TOLERANCE
    m = real_array(name, value, (4, 4))
    defect = rigid_defect(m, tol)  # perception's rule, the one rigidity check of the packages
    if defect is not None:
        where, why = defect
        if where == "last row":
            raise WorldGraphError(f"{name}: {why}")
        raise WorldGraphError(f"{name} must be rigid (rotation with R^T R = I, det R = +1), but {why}")
    if max_translation is not None:
        over = np.abs(m[:3, 3]) > max_translation
        if over.any():
            i = int(np.argmax(over))
            raise WorldGraphError(f"{name}[{i}, 3] = {float(m[i, 3])!r} is out of range: "
                                  f"|translation| must be <= {max_translation:g}")
    return m

