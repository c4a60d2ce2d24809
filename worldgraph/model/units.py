"""Hints when positions look like millimetres instead of metres (docs/design.md#units).

Everything in the packages is metres. Millimetres given by mistake are not an error the code can
prove (a campus is large, a lidar sees far), so these checks only produce a hint: a sentence that
:func:`worldgraph.localize` adds to its message, and a :class:`UnitsWarning` from
:func:`check_world_units`. Nothing here changes a status or an answer.

The tests are ratios of scales that cannot all hold in metres:

- percepts: their median range is above :data:`LONG_RANGE` (100 m) while the world spans less
  than that, or while the percepts spread over more than :data:`SPREAD_RATIO` times the world's
  extent (percepts of world objects cannot be spread wider than the world);
- world against percepts: the world spans more than :data:`LONG_RANGE` and more than
  :data:`SCALE_RATIO` (1000) times the larger of the percepts' median range and spread;
- world against its objects: the world spans more than :data:`LONG_RANGE` and neighbouring
  objects are typically more than :data:`SCALE_RATIO` times their own size apart (a world built
  from millimetre positions with sizes left at the metre default).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from perception import Percept

__all__ = [
    "LONG_RANGE",
    "SCALE_RATIO",
    "SPREAD_RATIO",
    "UnitsWarning",
    "check_world_units",
    "percept_units_hint",
    "units_hint",
    "world_units_hint",
]

#: Metres: a median percept range or a world extent above this is large enough to be suspect.
LONG_RANGE = 100.0
#: Scale ratio taken as the metre/millimetre factor 1000 (the test is ``>``).
SCALE_RATIO = 1000.0
#: Percepts spread over more than this many world extents cannot all be of that world.
SPREAD_RATIO = 10.0
#: Objects sampled (evenly, deterministically) for the spacing/size test of big worlds.
SAMPLE = 512


class UnitsWarning(UserWarning):
    """Positions whose scale looks like millimetres where metres are expected."""


class _WorldLike(Protocol):
    """What these hints read of a :class:`worldgraph.WorldModel` (a protocol, so that the model,
    which gives its own hint, does not import this module back)."""

    @property
    def bounds(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]: ...

    @property
    def objects(self) -> Sequence[Any]: ...

    @property
    def positions(self) -> NDArray[np.float64]: ...

    @property
    def tree(self) -> Any: ...

    @property
    def units_hint(self) -> str | None: ...


def _extent(points: np.ndarray) -> float:
    """Diagonal of the axis-aligned bounding box of ``points (n, 3)`` (0 for fewer than 2)."""
    if points.shape[0] < 2:
        return 0.0
    return float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))


def _world_extent(world: _WorldLike) -> float:
    lo, hi = world.bounds
    return float(np.linalg.norm(hi - lo))


def percept_units_hint(world: _WorldLike, percepts: Sequence[Percept]) -> str | None:
    """A sentence when the percepts and the world disagree in scale by about 1000, else None.

    Parameters
    ----------
    world : WorldModel
    percepts : sequence of perception.Percept
        Ego-frame percepts (metres expected).

    Returns
    -------
    str or None
        ``"percept positions look like millimetres ..."`` or ``"world positions look like
        millimetres ..."``, each ending with the suggestion to divide by 1000; None when the
        scales are plausible together (or there is nothing to compare).
    """
    if len(percepts) == 0:
        return None
    pos = np.array([p.position for p in percepts], dtype=np.float64).reshape(-1, 3)
    ranges = np.linalg.norm(pos, axis=1)
    median = float(np.median(ranges))
    spread = _extent(pos)
    span = _world_extent(world)
    if median > LONG_RANGE and (span < LONG_RANGE or spread > SPREAD_RATIO * span):
        return (f"percept positions look like millimetres: their median range is {median:.4g} m while the "
                f"world spans {span:.3g} m; divide the percept positions (and sigmas) by 1000?")
    scale = max(median, spread)
    if span > LONG_RANGE and span > SCALE_RATIO * scale:
        return (f"world positions look like millimetres next to the percepts: the world spans {span:.4g} m "
                f"while the percepts reach {median:.3g} m (spread {spread:.3g} m); divide the world's "
                f"positions (and sizes) by 1000?")
    return None


def world_units_hint(world: _WorldLike) -> str | None:
    """A sentence when a big world's objects sit about 1000 of their sizes apart, else None.

    Parameters
    ----------
    world : WorldModel

    Returns
    -------
    str or None
        ``"world positions look like millimetres ..."`` when the world spans more than
        :data:`LONG_RANGE` and the median distance from an object to its nearest neighbour is
        more than :data:`SCALE_RATIO` times the median object size (largest box extent; objects
        of size 0 are ignored); None otherwise.  Big worlds are judged on an even sample of
        :data:`SAMPLE` objects.
    """
    span = _world_extent(world)
    n = len(world.objects)
    if n < 2 or span <= LONG_RANGE:
        return None
    pick = np.unique(np.linspace(0, n - 1, min(n, SAMPLE)).astype(np.intp))
    sizes = np.array([float(np.max(world.objects[int(k)].size)) for k in pick])
    sizes = sizes[sizes > 0]
    if sizes.size == 0:
        return None
    dist = np.asarray(world.tree.query(world.positions[pick], k=2)[0], dtype=np.float64).reshape(-1, 2)
    gaps = dist[:, 1][dist[:, 1] > 0]
    if gaps.size == 0:
        return None
    spacing, size = float(np.median(gaps)), float(np.median(sizes))
    if spacing > SCALE_RATIO * size:
        return (f"world positions look like millimetres: neighbouring objects are typically {spacing:.4g} m "
                f"apart but only {size:.3g} m in size, and the world spans {span:.4g} m; divide the "
                f"positions by 1000 (or give the sizes in the same unit)?")
    return None


def units_hint(world: _WorldLike, percepts: Sequence[Percept]) -> str | None:
    """:func:`percept_units_hint`, else the world's own (:attr:`WorldModel.units_hint`, computed
    once per world): the one sentence ``localize`` and ``associate`` give when nothing matched."""
    return percept_units_hint(world, percepts) or world.units_hint


def check_world_units(world: _WorldLike) -> str | None:
    """Warn (:class:`UnitsWarning`) when :func:`world_units_hint` finds the world suspect.

    Parameters
    ----------
    world : WorldModel

    Returns
    -------
    str or None
        The hint that was warned, or None.
    """
    hint = world.units_hint  # world_units_hint, computed once per world
    if hint is not None:
        warnings.warn(hint, UnitsWarning, stacklevel=2)
    return hint
