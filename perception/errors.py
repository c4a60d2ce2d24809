"""Exceptions of :mod:`perception`: one base, specific subclasses."""

from __future__ import annotations


class PerceptionError(ValueError):
    """Base of every error raised by :mod:`perception`."""


class ShapeError(PerceptionError):
    """An array does not have the expected shape."""


class NonFiniteError(PerceptionError):
    """A value is NaN or infinite."""


class NonPositiveSigmaError(PerceptionError):
    """A standard deviation (or a depth factor) is zero or negative."""


class UnknownClassError(PerceptionError):
    """A percept type or object class that is not known."""


class BehindCameraError(PerceptionError):
    """A point lies behind the camera, or its depth is not positive."""
