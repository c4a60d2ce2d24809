"""The percept: a recognised, typed object located in the ego frame."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ._checks import guard, integer, name_str, real_array, real_scalar, spd, vector3
from .errors import NonFiniteError, NonPositiveSigmaError, ShapeError, UnknownClassError
from .tolerances import SHARED_RTOL

#: Largest magnitude of a position component accepted, metres (as worldgraph/radialopt bound
#: their coordinates); beyond it ranges and fused means overflow or lose all precision.
MAX_COORDINATE = 1e9
#: Largest ``views`` count accepted (a 32-bit signed integer).
MAX_VIEWS = 2**31 - 1
#: Largest ``sigma`` accepted together with ``shared`` loadings (``sigma**2`` stays finite).
MAX_SHARED_SIGMA = 1e150
#: The reserved ``shared`` id of an error that every view of one object shares and percepts of
#: different objects do not: the offset between the centroid of an object's visible part and its
#: centre (:mod:`perception.frontend`).  :func:`perception.fuse_percepts` adds such loadings
#: coherently over the views it fuses into one object; ``localize`` never correlates two percepts
#: through it (they stand for different objects).
OBJECT_VIEW = -1


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
    shared : tuple of (int, (3, k) float), optional
        The part of the position error this percept shares with other percepts: pairs
        ``(view, S)`` meaning an error ``S e_view`` with ``e_view ~ N(0, I_k)`` common to every
        percept carrying the same ``view`` id, e.g. the head's joint-encoder errors of one look,
        ``S = J diag(encoder_sigma)`` (:func:`perception.simulate_scan`); fusion sums the
        weighted loadings of its raw percepts.  Two percepts are then correlated,
        ``Cov(p_i, p_j) = sum over common views of S_i S_j^T``.  ``covariance`` is the total and
        must include ``sum S S^T`` (checked); view ids are distinct integers >= 0, or
        :data:`OBJECT_VIEW` (-1) for an error shared by the views of the same object only (the
        centre offset of the detection front ends).

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
    shared: tuple[tuple[int, NDArray[np.float64]], ...] = ()

    @guard
    def __post_init__(self) -> None:
        name_str("type", self.type, UnknownClassError)
        pos = vector3("position", self.position)
        big = np.flatnonzero(np.abs(pos) > MAX_COORDINATE)
        if big.size:
            i = int(big[0])
            raise NonFiniteError(
                f"position[{i}] = {float(pos[i])!r} must be at most {MAX_COORDINATE:g} m in magnitude"
            )
        sigma = real_scalar("sigma", self.sigma, positive=True)
        views = integer("views", self.views, minimum=1, maximum=MAX_VIEWS)
        pos.setflags(write=False)
        object.__setattr__(self, "position", pos)
        object.__setattr__(self, "sigma", sigma)
        if self.covariance is not None:
            cov = spd("covariance", self.covariance)
            cov.setflags(write=False)
            object.__setattr__(self, "covariance", cov)
        object.__setattr__(self, "views", views)
        object.__setattr__(self, "shared", _shared(self.shared, self.covariance, sigma))

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


#: Largest number of shared error components (columns of one loading).
MAX_SHARED_COLUMNS = 64


def _shared(value: object, covariance: NDArray[np.float64] | None, sigma: float
            ) -> tuple[tuple[int, NDArray[np.float64]], ...]:
    """Validated ``shared`` loadings: distinct views, finite (3, k) blocks inside the total."""
    if value is None or (isinstance(value, tuple | list) and len(value) == 0):
        return ()
    if covariance is None and sigma > MAX_SHARED_SIGMA:
        raise NonPositiveSigmaError(
            f"sigma = {sigma!r} must be at most {MAX_SHARED_SIGMA:g} m when shared loadings are given "
            "(sigma**2 overflows)"
        )
    if isinstance(value, str | bytes) or not isinstance(value, tuple | list):
        raise ShapeError(f"shared must be a sequence of (view, (3, k) loading) pairs, got "
                         f"{type(value).__name__}")
    out = []
    seen: set[int] = set()
    for i, item in enumerate(value):
        if not isinstance(item, tuple | list) or len(item) != 2:
            raise ShapeError(f"shared[{i}] must be a (view, loading) pair, got {item!r:.80}")
        view = integer(f"shared[{i}] view", item[0], minimum=OBJECT_VIEW)
        if view in seen:
            raise ShapeError(f"shared[{i}] repeats view {view}")
        seen.add(view)
        S = real_array(f"shared[{i}] loading", item[1])
        if S.size and float(np.max(np.abs(S))) > MAX_SHARED_SIGMA:
            j = np.unravel_index(int(np.argmax(np.abs(S))), S.shape)
            raise NonFiniteError(f"shared[{i}] loading[{j[0]}, {j[1]}] = {float(S[j])!r} must be at most "
                                 f"{MAX_SHARED_SIGMA:g} in magnitude")
        if S.ndim != 2 or S.shape[0] != 3 or not 1 <= S.shape[1] <= MAX_SHARED_COLUMNS:
            raise ShapeError(f"shared[{i}] loading must have shape (3, k) with 1 <= k <= "
                             f"{MAX_SHARED_COLUMNS}, got shape {S.shape}")
        S.setflags(write=False)
        out.append((view, S))
    total = np.eye(3) * sigma**2 if covariance is None else covariance
    part = sum(S @ S.T for _, S in out)
    gap = float(np.linalg.eigvalsh(total - part)[0])
    if gap < -SHARED_RTOL * float(np.linalg.eigvalsh(total)[-1]):
        raise ShapeError(f"shared loadings exceed the covariance: covariance - sum S S^T has the "
                         f"eigenvalue {gap:.3g} (the covariance is the total error)")
    return tuple(out)
