"""The percept: a recognised, typed object located in the ego frame."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .._checks import integer, name_string, real_array, real_scalar, spd, vector3
from ..errors import PerceptionError
from ..tolerances import SHARED_RTOL, SIGMA_COVARIANCE_FACTOR

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
    sigma : float, optional
        Standard deviation (m) of the range ``|position|`` (the Gaussian-sphere sigma, eq. 6);
        without ``covariance`` also the per-axis standard deviation of an isotropic position
        error (covariance ``sigma**2 I``).  Optional when ``covariance`` is given: it is then
        derived as the standard deviation of the range, ``sqrt(u^T C u)`` with ``u`` the unit
        vector of ``position`` (``sqrt(trace(C) / 3)`` at the origin), the rule of
        :func:`perception.fuse_percepts` and :func:`perception.simulate_scan`.  Always a float
        after construction.  Given together with ``covariance``, it must agree with that range
        standard deviation to within a factor
        :data:`~perception.tolerances.SIGMA_COVARIANCE_FACTOR` (5) either way (a sigma 10 times
        too small would make the range-only methods' bounds 10 times too tight).
    covariance : (3, 3) float, optional
        Full position covariance in the ego frame (m^2), when known (triangulation Jacobian,
        joint-encoder noise, fusion). Must be real, finite, symmetric (to a relative 1e-8) and
        positive definite (smallest eigenvalue > 1e-14 times the largest); stored symmetrised.
        At least one of ``sigma`` and ``covariance`` must be given.
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
        - Neither ``sigma`` nor ``covariance`` given, or a ``sigma`` that contradicts the
          covariance (ratio outside ``[1/F, F]``, ``F =``
          :data:`~perception.tolerances.SIGMA_COVARIANCE_FACTOR`).
        - Any other bad field, naming it and its value.

    Notes
    -----
    Which field :func:`worldgraph.localize` reads: the association (every method) gates
    distances with ``sigma``; the hypothesis validation (every method but ``"paper"``), the
    ``"ml"`` pose and its covariance, and the final chi-square check of every answer use
    ``covariance`` (``sigma**2 I`` when it is ``None``); the range-only methods (``"spheres"``,
    ``"paper"``, ``"srls"``, ``"gradient"``) put one Gaussian sphere of standard deviation
    ``sigma`` per match and weight the rotation fit by ``sigma``.  Hence the agreement check.
    """

    type: str
    position: NDArray[np.float64]
    # ``None`` is accepted (derived from ``covariance``); always a float after __post_init__,
    # so readers see ``float``
    sigma: float = None  # type: ignore[assignment]
    covariance: NDArray[np.float64] | None = None
    views: int = 1
    shared: tuple[tuple[int, NDArray[np.float64]], ...] = ()

    def __post_init__(self) -> None:
        name_string("type", self.type)
        pos = vector3("position", self.position)
        big = np.flatnonzero(np.abs(pos) > MAX_COORDINATE)
        if big.size:
            i = int(big[0])
            raise PerceptionError(
                f"position[{i}] = {float(pos[i])!r} must be at most {MAX_COORDINATE:g} m in magnitude"
            )
        if self.sigma is None and self.covariance is None:
            raise PerceptionError(
                "Percept needs sigma (the range standard deviation, m) or covariance (3x3, m^2), got "
                "sigma = None and covariance = None; pass at least one"
            )
        sigma = None if self.sigma is None else real_scalar("sigma", self.sigma, positive=True)
        views = integer("views", self.views, minimum=1, maximum=MAX_VIEWS)
        pos.setflags(write=False)
        object.__setattr__(self, "position", pos)
        range_sigma = float("nan")
        if self.covariance is not None:
            cov = spd("covariance", self.covariance)
            cov.setflags(write=False)
            object.__setattr__(self, "covariance", cov)
            range_sigma = _range_sigma(pos, cov)
        derived = sigma is None
        if sigma is None:  # then the covariance is given
            sigma = real_scalar("sigma derived from the covariance", range_sigma, positive=True)
        object.__setattr__(self, "sigma", sigma)
        object.__setattr__(self, "views", views)
        object.__setattr__(self, "shared", _shared(self.shared, self.covariance, sigma))
        if self.covariance is not None and not derived:
            _check_agreement(sigma, range_sigma)  # last: each field's own errors first

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


def _range_sigma(position: NDArray[np.float64], covariance: NDArray[np.float64]) -> float:
    """Standard deviation of the range ``|position|`` under ``covariance``: ``sqrt(u^T C u)``,
    ``u = position / |position|`` (computed scaled, so tiny or huge positions keep their
    direction); ``sqrt(trace(C) / 3)`` at the origin."""
    scale = float(np.max(np.abs(position)))
    if scale > 0:  # as fusion's _melt: any non-zero position has a direction
        u = position / scale
        u = u / np.linalg.norm(u)
        var = float(u @ covariance @ u)
    else:
        var = float(np.trace(covariance)) / 3.0
    return float(np.sqrt(max(var, 0.0)))


def _check_agreement(sigma: float, range_sigma: float) -> None:
    """:class:`PerceptionError` when ``sigma`` and the covariance's range standard
    deviation differ by more than :data:`SIGMA_COVARIANCE_FACTOR` either way."""
    f = SIGMA_COVARIANCE_FACTOR
    ratio = sigma / range_sigma if range_sigma > 0 else np.inf
    if not 1.0 / f <= ratio <= f:
        raise PerceptionError(
            f"sigma = {sigma!r} m contradicts the covariance: the standard deviation of the range "
            f"|position| it gives is sqrt(u^T C u) = {range_sigma!r} m (ratio sigma / that = {ratio:.3g}, "
            f"outside [1/{f:g}, {f:g}], perception.tolerances.SIGMA_COVARIANCE_FACTOR); pass sigma=None "
            "to derive it from the covariance, or fix whichever of the two is wrong"
        )


#: Largest number of shared error components (columns of one loading).
MAX_SHARED_COLUMNS = 64


def _shared(value: object, covariance: NDArray[np.float64] | None, sigma: float
            ) -> tuple[tuple[int, NDArray[np.float64]], ...]:
    """Validated ``shared`` loadings: distinct views, finite (3, k) blocks inside the total."""
    if value is None or (isinstance(value, tuple | list) and len(value) == 0):
        return ()
    if covariance is None and sigma > MAX_SHARED_SIGMA:
        raise PerceptionError(
            f"sigma = {sigma!r} must be at most {MAX_SHARED_SIGMA:g} m when shared loadings are given "
            "(sigma**2 overflows)"
        )
    if isinstance(value, str | bytes) or not isinstance(value, tuple | list):
        raise PerceptionError(f"shared must be a sequence of (view, (3, k) loading) pairs, got "
                              f"{type(value).__name__}")
    out = []
    seen: set[int] = set()
    for i, item in enumerate(value):
        if not isinstance(item, tuple | list) or len(item) != 2:
            raise PerceptionError(f"shared[{i}] must be a (view, loading) pair, got {item!r:.80}")
        view = integer(f"shared[{i}] view", item[0], minimum=OBJECT_VIEW)
        if view in seen:
            raise PerceptionError(f"shared[{i}] repeats view {view}")
        seen.add(view)
        S = real_array(f"shared[{i}] loading", item[1])
        if S.size and float(np.max(np.abs(S))) > MAX_SHARED_SIGMA:
            j = np.unravel_index(int(np.argmax(np.abs(S))), S.shape)
            raise PerceptionError(f"shared[{i}] loading[{j[0]}, {j[1]}] = {float(S[j])!r} must be at most "
                                  f"{MAX_SHARED_SIGMA:g} in magnitude")
        if S.ndim != 2 or S.shape[0] != 3 or not 1 <= S.shape[1] <= MAX_SHARED_COLUMNS:
            raise PerceptionError(f"shared[{i}] loading must have shape (3, k) with 1 <= k <= "
                                  f"{MAX_SHARED_COLUMNS}, got shape {S.shape}")
        S.setflags(write=False)
        out.append((view, S))
    total = np.eye(3) * sigma**2 if covariance is None else covariance
    part = sum(S @ S.T for _, S in out)
    gap = float(np.linalg.eigvalsh(total - part)[0])
    if gap < -SHARED_RTOL * float(np.linalg.eigvalsh(total)[-1]):
        raise PerceptionError(f"shared loadings exceed the covariance: covariance - sum S S^T has the "
                              f"eigenvalue {gap:.3g} (the covariance is the total error)")
    return tuple(out)
