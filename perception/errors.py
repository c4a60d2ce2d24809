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


class CalibrationError(PerceptionError):
    """A camera calibration is invalid (e.g. R is not a rotation, a focal length is not positive)."""


class CalibrationFileError(CalibrationError):
    """A calibration file is missing, unreadable or lacks a required key."""


class KinematicsError(PerceptionError):
    """A kinematic chain or its joint angles are invalid (unknown joint, bad axis)."""


class InvalidPoseError(KinematicsError):
    """A 4x4 transform that is not a rigid motion (bad rotation block or last row)."""


class JointLimitError(KinematicsError):
    """A joint angle outside the joint's limits (or limits with lower > upper)."""


class URDFError(KinematicsError):
    """A URDF file that cannot be read, or whose links do not form a usable chain (a missing link,
    no path from the base link down to the camera link, a joint type the chain cannot hold)."""


class TypeRuleError(PerceptionError):
    """A ``type_of`` argument that is not a name -> type rule (see :mod:`perception.type_rules`)."""


class SceneError(PerceptionError):
    """A simulated scene that cannot be built: an MJCF file MuJoCo cannot read, an argument that
    is neither a path nor a ``mujoco.MjModel``, a model without a typed object, no OpenGL context."""


class OptionError(PerceptionError):
    """An option outside its allowed values (an unknown sensor name, a rate outside [0, 1])."""


class MissingExtraError(PerceptionError, ImportError):
    """An optional dependency is not installed; the message names the extra to install."""


class ImageFormatError(ShapeError):
    """An image has the wrong shape, number of channels or dtype."""


class NotFittedError(PerceptionError):
    """A classifier cannot be fitted (too few samples of a class) or was given bad labels."""


class TooManyNeighboursError(PerceptionError):
    """Mean shift would evaluate more kernel pairs than its budget (a bandwidth that is large for
    the density of the points): lower the bandwidth or fuse in batches."""
