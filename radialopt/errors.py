"""Exceptions of :mod:`radialopt`: a base and the few subclasses a caller acts on.

Every error :mod:`radialopt` raises is a :class:`RadialError`. A bad argument (a wrong shape,
NaN, a non-positive sigma, a negative radius, coincident centres, too few or too many spheres, an
unknown method, an empty region, a polyhedron without vertices, ...) raises
:class:`RadialArgumentError`, which is also a :class:`ValueError`, with a message that names the
argument, the index and the value. The other subclasses are failures on valid arguments, and none
of them is a :class:`ValueError`:

- :class:`SolverError` (also a :class:`RuntimeError`): the solver failed, no answer is trusted;
- :class:`VerificationError`: ``check=True`` found a disagreement with the reference;
- :class:`SingularFisherError`: some direction of the position is unobservable (no covariance).

The classes that 0.1 had for each kind of bad argument (``ShapeError``, ``NonFiniteError``,
...) are deprecated names of :class:`RadialArgumentError`; see :data:`DEPRECATED_NAMES`.
"""

from __future__ import annotations

import warnings

__all__ = ["RadialArgumentError", "RadialError", "SingularFisherError", "SolverError", "VerificationError"]


class RadialError(Exception):
    """Base of every error raised by :mod:`radialopt`."""


class RadialArgumentError(RadialError, ValueError):
    """A bad argument: a wrong type, shape or value, or an instance beyond a method's limits."""


class SolverError(RadialError, RuntimeError):
    """A solver failed and no answer can be trusted."""


class VerificationError(SolverError):
    """``check=True`` found a disagreement with the vertex-enumeration reference."""


class SingularFisherError(RadialError):
    """The Fisher information is singular: some direction of the position is unobservable.

    The arguments are well formed; the geometry they describe has no finite covariance.
    """


#: Names of 0.1's error classes, deprecated in 0.2 and removed in 0.3, and the class each now
#: is. An ``except`` clause that names one catches everything it caught before.
DEPRECATED_NAMES: dict[str, type[RadialError]] = dict.fromkeys(
    ["ShapeError", "NonFiniteError", "NonPositiveSigmaError", "NegativeRadiusError",
     "CoincidentCentersError", "TooFewSpheresError", "UnknownMethodError", "NotASphereError",
     "TooManySpheresError", "InvalidRegionError", "OutOfRangeError", "NotPointedError",
     "TooLargeError", "EmptyPolyhedronError"],
    RadialArgumentError,
)


def _deprecated(module: str, name: str,
                names: dict[str, type[RadialError]] | None = None) -> type[RadialError]:
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


def __getattr__(name: str) -> type[RadialError]:
    return _deprecated(__name__, name)
