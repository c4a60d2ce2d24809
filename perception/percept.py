"""The percept: a recognised, typed object located in the ego frame."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .errors import NonFiniteError, NonPositiveSigmaError, ShapeError, UnknownClassError


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
        Full position covariance in the ego frame, when known (triangulation Jacobian,
        joint-encoder noise, fusion).
    views : int
        Number of raw percepts fused into this one (1 for a raw percept).
    """

    type: str
    position: NDArray[np.float64]
    sigma: float
    covariance: NDArray[np.float64] | None = None
    views: int = 1

    def __post_init__(self) -> None:
        if not isinstance(self.type, str) or not self.type:
            raise UnknownClassError(f"type must be a non-empty string, got {self.type!r}")
        pos = np.array(self.position, dtype=np.float64)
        if pos.shape != (3,):
            raise ShapeError(f"position must have shape (3,), got shape {pos.shape}")
        if not np.all(np.isfinite(pos)):
            raise NonFiniteError(f"position must be finite, got {pos.tolist()}")
        try:
            sigma = float(self.sigma)
        except (TypeError, ValueError) as exc:
            raise ShapeError(f"sigma must be a real scalar, got {self.sigma!r}") from exc
        if not np.isfinite(sigma):
            raise NonFiniteError(f"sigma must be finite, got {sigma!r}")
        if sigma <= 0:
            raise NonPositiveSigmaError(f"sigma must be > 0, got {sigma!r}")
        pos.setflags(write=False)
        object.__setattr__(self, "position", pos)
        object.__setattr__(self, "sigma", sigma)
        if self.covariance is not None:
            cov = np.array(self.covariance, dtype=np.float64)
            if cov.shape != (3, 3):
                raise ShapeError(f"covariance must have shape (3, 3), got shape {cov.shape}")
            if not np.all(np.isfinite(cov)):
                raise NonFiniteError(f"covariance must be finite, got {cov.tolist()}")
            cov.setflags(write=False)
            object.__setattr__(self, "covariance", cov)
        if int(self.views) < 1:
            raise ShapeError(f"views must be >= 1, got {self.views!r}")
        object.__setattr__(self, "views", int(self.views))

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
