"""The percept: a recognised, typed object located in the ego frame."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ._checks import guard, integer, name_str, real_scalar, spd, vector3
from .errors import UnknownClassError


@dataclass(frozen=True)
class Percept:
    """A recognised object in the ego frame (ROS REP 103: x forward, y left, z up).

    Parameters
    ----------
    type : str
        Object class, e.g. ``"door"``, ``"handle"``, ``"drawer"``, ``"knob"``.
    position : (3,) float
        Position in the ego frame, metres.
    sigma : float
        Per-axis standard deviation (m) of an isotropic position error; the range
        ``|position|`` then has standard deviation ``sigma`` (the Gaussian-sphere sigma, eq. 6).
    covariance : (3, 3) float, optional
        Full position covariance in the ego frame (m^2), when known (triangulation Jacobian,
        joint-encoder noise, fusion). Must be real, finite, symmetric (to a relative 1e-8) and
        positive definite (smallest eigenvalue > 1e-14 times the largest); stored symmetrised.
    views : int
        Number of raw percepts fused into this one (>= 1; a Python or numpy integer, not a
        float or bool).

    Raises
    ------
    PerceptionError
        (a subclass) naming the field and the bad value.
    """

    type: str
    position: NDArray[np.float64]
    sigma: float
    covariance: NDArray[np.float64] | None = None
    views: int = 1

    @guard
    def __post_init__(self) -> None:
        name_str("type", self.type, UnknownClassError)
        pos = vector3("position", self.position)
        sigma = real_scalar("sigma", self.sigma, positive=True)
        views = integer("views", self.views, minimum=1)
        pos.setflags(write=False)
        object.__setattr__(self, "position", pos)
        object.__setattr__(self, "sigma", sigma)
        if self.covariance is not None:
            cov = spd("covariance", self.covariance)
            cov.setflags(write=False)
            object.__setattr__(self, "covariance", cov)
        object.__setattr__(self, "views", views)

    @property
    def range(self) -> float:
        """Distance from the ego origin, ``|position|`` (the Gaussian-sphere radius)."""
        return float(np.linalg.norm(self.position))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Percept):
            return NotImplemented
        return (
            self.type == other.type
            and bool(np.array_equal(self.position, other.position))
            and self.sigma == other.sigma
            and self.views == other.views
        )

    def __hash__(self) -> int:
        return hash((self.type, tuple(self.position.tolist()), self.sigma, self.views))
