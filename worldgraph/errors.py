"""Exceptions of :mod:`worldgraph`: a base and the few subclasses a caller acts on.

Every error :mod:`worldgraph` raises is a :class:`WorldGraphError`, which is a
:class:`ValueError`. A bad argument (a wrong shape or kind, NaN, a non-positive length, a
transform that is not rigid, an unknown type, an empty world, two same-type objects at one
place, ...) raises the base itself, with a message that names the argument, the index and the
value. A subclass exists only where a caller does something different:

- :class:`MalformedFileError`: fix the world-model file the message names;
- :class:`ImporterError` (also an :class:`ImportError`): install the optional importer;
- :class:`TooFewPerceptsError`: gather more percepts (another view) before associating;
- :class:`PoseError`: the matches do not fix a pose (collinear points, singular information,
  no convergence, degenerate weights or covariances).

The classes that 0.1 had for each kind of bad argument (``ShapeError``, ``NonFiniteError``,
...) are deprecated names of :class:`WorldGraphError`; see :data:`DEPRECATED_NAMES`.
"""

from __future__ import annotations

import warnings

__all__ = [
    "ImporterError",
    "MalformedFileError",
    "PoseError",
    "TooFewPerceptsError",
    "WorldGraphError",
]


class WorldGraphError(ValueError):
    """Base of every error raised by :mod:`worldgraph`, and the error of a bad argument."""


class MalformedFileError(WorldGraphError):
    """A world-model file that cannot be read: bad JSON, wrong version, missing key, bad value."""


class ImporterError(WorldGraphError, ImportError):
    """An optional importer (e.g. the Franka kitchen of gymnasium-robotics) is not available."""


class TooFewPerceptsError(WorldGraphError):
    """Fewer percepts than association or localisation needs."""


class PoseError(WorldGraphError):
    """The matches do not fix a pose: collinear points, singular information, no convergence,
    degenerate weights or covariances, or a result without a pose."""


#: Names of 0.1's error classes, deprecated in 0.2 and removed in 0.3, and the class each now
#: is. An ``except`` clause that names one catches everything it caught before.
DEPRECATED_NAMES: dict[str, type[WorldGraphError]] = dict.fromkeys(
    ["ShapeError", "NonFiniteError", "NonPositiveError", "ArgumentTypeError", "UpAxisError",
     "GravityDirectionError", "OutOfRangeError", "NonRigidError", "EmptyWorldError",
     "UnknownTypeError", "UnknownGeometryError", "CoincidentObjectsError"],
    WorldGraphError,
)


def _deprecated(module: str, name: str,
                names: dict[str, type[WorldGraphError]] | None = None) -> type[WorldGraphError]:
    """The class the deprecated error name ``name`` of ``module`` stands for (``names``, by default
    :data:`DEPRECATED_NAMES`), with a :class:`DeprecationWarning`; else an :class:`AttributeError`."""
    names = DEPRECATED_NAMES if names is None else names
    if name not in names:
        raise AttributeError(f"module {module!r} has no attribute {name!r}")
    cls = names[name]
    home = f"{cls.__module__.split('.')[0]}.{cls.__name__}"
    warnings.warn(f"{module}.{name} is deprecated and will be removed in 0.3: catch {home}, the class "
                  "its errors are now raised as", DeprecationWarning, stacklevel=3)
    return cls


def __getattr__(name: str) -> type[WorldGraphError]:
    return _deprecated(__name__, name)
