"""Exceptions of :mod:`radialopt`: one base, specific subclasses.

Every bad-input error is a :class:`RadialError`, which is a :class:`ValueError`, so callers
can catch the whole family at once or a single case.
"""

from __future__ import annotations


class RadialError(ValueError):
    """Base of every error raised by :mod:`radialopt`."""


class ShapeError(RadialError):
    """An array does not have the expected shape."""


class NonFiniteError(RadialError):
    """A value is NaN or infinite."""


class NonPositiveSigmaError(RadialError):
    """A standard deviation is zero or negative."""


class NegativeRadiusError(RadialError):
    """A sphere radius is negative."""


class CoincidentCentersError(RadialError):
    """Two sphere centres coincide, so their pair gives no restriction."""


class TooFewSpheresError(RadialError):
    """Fewer spheres than the operation needs."""


class UnknownMethodError(RadialError):
    """A method or solver name that is not available."""


class SolverError(RadialError, RuntimeError):
    """A solver failed and no answer can be trusted."""


class VerificationError(SolverError):
    """``check=True`` found a disagreement with the vertex-enumeration reference."""


class NotASphereError(RadialError):
    """A conformal 5-vector that is not a (possibly imaginary) sphere, e.g. a plane."""


class TooManySpheresError(RadialError):
    """More spheres than the operation accepts (the meet takes at most four)."""


class InvalidRegionError(RadialError):
    """A region whose lower corner is not below its upper corner."""


class SingularFisherError(RadialError):
    """The Fisher information is singular: some direction of the position is unobservable."""


class OutOfRangeError(RadialError):
    """A finite number outside the range radialopt can compute with (e.g. ``sigma = 1e-300``
    with centres metres apart, a coordinate of 1e300 m, a negative tolerance)."""


class NotPointedError(RadialError):
    """The polyhedron contains a line (``rank(A) < n``), so it has no vertices."""


class TooLargeError(RadialError):
    """The requested method would need too many subsets; use ``"double_description"``."""


class EmptyPolyhedronError(RadialError):
    """An operation needs at least one vertex, but the polyhedron is empty."""
