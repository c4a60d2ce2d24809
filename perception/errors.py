"""Exceptions of :mod:`perception`: a base and the few subclasses a caller acts on.

Every error :mod:`perception` raises is a :class:`PerceptionError`, which is a
:class:`ValueError`. A bad argument (a wrong shape, NaN, a non-positive sigma, an unknown class,
a transform that is not rigid, a joint outside its limits, ...) raises the base itself, with a
message that names the argument, the index and the value. A subclass exists only where a
caller does something different:

- :class:`MissingExtraError` (also an :class:`ImportError`): install the named extra;
- :class:`RobotFileError`: fix the calibration, URDF or MJCF file the message names;
- :class:`BehindCameraError`: drop the point (it cannot be measured from this view);
- :class:`TooManyNeighboursError`: lower the bandwidth or fuse in batches.

The classes that 0.1 had for each kind of bad argument (``ShapeError``, ``NonFiniteError``,
...) are deprecated names of the class that replaced them; see :data:`DEPRECATED_NAMES`.
"""

from __future__ import annotations

import warnings

__all__ = [
    "BehindCameraError",
    "MissingExtraError",
    "PerceptionError",
    "RobotFileError",
    "TooManyNeighboursError",
]


class PerceptionError(ValueError):
    """Base of every error raised by :mod:`perception`, and the error of a bad argument."""


class MissingExtraError(PerceptionError, ImportError):
    """An optional dependency is not installed; the message names the extra to install."""


class RobotFileError(PerceptionError):
    """A robot or scene file that cannot be used: a stereo calibration, URDF or MJCF file that is
    missing, unreadable, lacks a key, or does not describe a usable rig, chain or scene (the
    message names the file)."""


class BehindCameraError(PerceptionError):
    """A point lies behind the camera, or its depth is not positive: it cannot be measured from
    this view."""


class TooManyNeighboursError(PerceptionError):
    """Mean shift would evaluate more kernel pairs than its budget (a bandwidth that is large for
    the density of the points): lower the bandwidth or fuse in batches."""


#: Names of 0.1's error classes, deprecated in 0.2 and removed in 0.3, and the class each now
#: is. An ``except`` clause that names one catches everything it caught before.
DEPRECATED_NAMES: dict[str, type[PerceptionError]] = {
    **dict.fromkeys(
        ["ShapeError", "NonFiniteError", "NonPositiveSigmaError", "UnknownClassError",
         "CalibrationError", "KinematicsError", "InvalidPoseError", "JointLimitError",
         "TypeRuleError", "OptionError", "ImageFormatError", "NotFittedError", "SceneError"],
        PerceptionError,
    ),
    "CalibrationFileError": RobotFileError,
    "URDFError": RobotFileError,
}


def _deprecated(module: str, name: str,
                names: dict[str, type[PerceptionError]] | None = None) -> type[PerceptionError]:
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


def __getattr__(name: str) -> type[PerceptionError]:
    return _deprecated(__name__, name)
