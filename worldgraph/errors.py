"""Exceptions of :mod:`worldgraph`: one base, specific subclasses.

Every bad-input error is a :class:`WorldGraphError`, which is a :class:`ValueError`, so callers
can catch the whole family at once or a single case.
"""

from __future__ import annotations

__all__ = [
    "ArgumentTypeError",
    "CoincidentObjectsError",
    "EmptyWorldError",
    "GravityDirectionError",
    "ImporterError",
    "MalformedFileError",
    "NonFiniteError",
    "NonPositiveError",
    "NonRigidError",
    "OutOfRangeError",
    "PoseError",
    "ShapeError",
    "TooFewPerceptsError",
    "UnknownGeometryError",
    "UnknownTypeError",
    "UpAxisError",
    "WorldGraphError",
]


class WorldGraphError(ValueError):
    """Base of every error raised by :mod:`worldgraph`."""


class ShapeError(WorldGraphError):
    """An array does not have the expected shape."""


class NonFiniteError(WorldGraphError):
    """A value is NaN or infinite."""


class NonPositiveError(WorldGraphError):
    """A length that must be positive (or non-negative) is not."""


class ArgumentTypeError(WorldGraphError):
    """A value of the wrong kind: None, bool, str or complex where a number is meant, a float
    where an integer is meant, a non-Generator where a random generator is meant."""


class UpAxisError(ArgumentTypeError):
    """An ``up_axis`` that is not one of ``"+x"``, ``"-x"``, ``"+y"``, ``"-y"``, ``"+z"``, ``"-z"``."""


class GravityDirectionError(WorldGraphError):
    """An up vector (``localize(gravity=...)``) that points down in the ego frame (more than 90
    degrees from the ego +z axis): a gravity vector passed where the up vector is meant."""


class OutOfRangeError(WorldGraphError):
    """A value outside its documented range (e.g. a coordinate above 1e6 m, a negative count)."""


class NonRigidError(WorldGraphError):
    """A transform that must be rigid is scaled, sheared or reflected."""


class EmptyWorldError(WorldGraphError):
    """A world model without objects."""


class UnknownTypeError(WorldGraphError):
    """An object type that is not in the world model, or a type that is not a non-empty string."""


class UnknownGeometryError(WorldGraphError):
    """An object refers to a class geometry whose vertices the world model does not hold."""


class MalformedFileError(WorldGraphError):
    """A world-model file that cannot be read: bad JSON, wrong version, missing key, bad value."""


class CoincidentObjectsError(WorldGraphError):
    """Two objects of the same type at the same position: no percept can tell them apart."""


class TooFewPerceptsError(WorldGraphError):
    """Fewer percepts than association or localisation needs."""


class ImporterError(WorldGraphError, ImportError):
    """An optional importer (e.g. the Franka kitchen of gymnasium-robotics) is not available."""


class PoseError(WorldGraphError):
    """Degenerate input to a pose computation: collinear points, invalid weights.

    Wrong shapes raise :class:`~worldgraph.errors.ShapeError`, NaN/inf
    :class:`~worldgraph.errors.NonFiniteError`.
    """
