"""Location hypotheses from level sets of meets (paper section 2.3, Fig. 7).

``Phi_0`` are the spheres; ``Phi_1`` the circles of the sphere pairs (upper-triangular);
``Phi_2`` the point pairs of circles met with spheres that are not their parents; ``Phi_3``
the points of point pairs met with a fourth sphere.  Location hypotheses are the points of
``Phi_2`` elements without descendants in ``Phi_3`` plus all ``Phi_3`` points, each with the
indices of the spheres that built it, validated against the spheres *not* used to build it.

Each element is identified by its sorted sphere indices, so a triple reached from three
different circles is computed once (the paper's "child primitives should not be combined with
their relatives").  A quadruple belongs to ``Phi_3`` when its centres are not coplanar and at
least one of its triples is in ``Phi_2``; a ``Phi_2`` element has descendants when one of the
quadruples containing it is in ``Phi_3``.  With noisy radii four spheres never share a point
exactly: the ``Phi_3`` point is their radical centre, its ``residual`` says how far off it is.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from itertools import combinations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._checks import MAX_LENGTH, instance, point3, real_scalar
from .conformal import (
    MEET_TOLERANCES,
    Circle,
    MeetStatus,
    MeetTolerances,
    Point,
    PointPair,
    meet2_batch,
    meet3_batch,
    meet4_batch,
)
from .errors import RadialArgumentError
from .spheres import GaussianSphere, as_points, sphere_arrays
from .tolerances import REGION_SLACK

#: Most spheres :func:`generate_hypotheses` accepts (C(12, 4) = 495 four-sphere meets).
MAX_HYPOTHESIS_SPHERES = 12

__all__ = ["Hypothesis", "LevelSets", "Region", "generate_hypotheses", "validate_positions"]


@dataclass(frozen=True)
class Region:
    """Axis-aligned box of valid robot positions (above the floor, inside the model).

    Parameters
    ----------
    lower, upper : (3,) float
        Opposite corners, ``lower <= upper`` component-wise (metres, world frame).
    """

    lower: NDArray[np.float64]
    upper: NDArray[np.float64]

    def __post_init__(self) -> None:
        lo = point3("Region.lower", self.lower)
        hi = point3("Region.upper", self.upper)
        if np.any(lo > hi):
            raise RadialArgumentError(f"Region lower {lo.tolist()} must be <= upper {hi.tolist()} "
                                      "in every coordinate")
        lo.setflags(write=False)
        hi.setflags(write=False)
        object.__setattr__(self, "lower", lo)
        object.__setattr__(self, "upper", hi)

    def contains(self, x: ArrayLike, tol: float = REGION_SLACK) -> bool | NDArray[np.bool_]:
        """Whether points ``(3,)`` or ``(k, 3)`` lie in the box (``tol`` metres of slack)."""
        pts, single = as_points(x)
        tol = real_scalar("tol", tol, minimum=0.0, maximum=MAX_LENGTH)
        inside = np.all((pts >= self.lower - tol) & (pts <= self.upper + tol), axis=1)
        return bool(inside[0]) if single else inside


@dataclass(frozen=True)
class Hypothesis:
    """One location hypothesis.

    Attributes
    ----------
    position : (3,) float
    spheres : tuple of int
        Indices of the spheres whose meet built it (3 or 4 of them).
    level : int
        2 for a point of a ``Phi_2`` point pair, 3 for a ``Phi_3`` point.
    status : str
        Status of the meet (``"real"``, ``"tangent"``, ``"imaginary"``, ``"inexact"``).
    residual : float
        Squared half distance of the point pair (level 2) or the power rho^2 of the radical
        centre (level 3).
    total_density : float
        Eq. 14 over all spheres.
    validation_density : float
        Product density over the spheres not used to build it (1.0 when there are none).
    validation_residual : float
        Largest normalised residual ``| |x - X_i| - r_i | / sigma_i`` over those spheres
        (0.0 when there are none).
    in_region : bool
        Inside the valid region (True when no region is given).
    """

    position: NDArray[np.float64]
    spheres: tuple[int, ...]
    level: int
    status: str
    residual: float
    total_density: float
    validation_density: float
    validation_residual: float
    in_region: bool


@dataclass(frozen=True)
class LevelSets:
    """The level sets and the hypotheses, each element keyed by its sorted sphere indices.

    Attributes
    ----------
    circles : tuple of ((i, j), Circle)
        ``Phi_1``.
    point_pairs : tuple of ((i, j, k), PointPair)
        ``Phi_2``.
    points : tuple of ((i, j, k, l), Point)
        ``Phi_3``.
    hypotheses : tuple of Hypothesis
        Sorted: inside the region first, then by decreasing total density.
    """

    circles: tuple[tuple[tuple[int, int], Circle], ...]
    point_pairs: tuple[tuple[tuple[int, int, int], PointPair], ...]
    points: tuple[tuple[tuple[int, int, int, int], Point], ...]
    hypotheses: tuple[Hypothesis, ...]

    @property
    def positions(self) -> NDArray[np.float64]:
        """Hypothesis positions ``(h, 3)`` in the order of :attr:`hypotheses`."""
        if not self.hypotheses:
            return np.zeros((0, 3))
        return np.stack([h.position for h in self.hypotheses])


def validate_positions(
    centers: NDArray[np.float64], radii: NDArray[np.float64], sigmas: NDArray[np.float64],
    positions: NDArray[np.float64], used: NDArray[np.bool_],
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Total density, validation density and validation residual of k positions.

    Parameters
    ----------
    centers : (n, 3) float
    radii, sigmas : (n,) float
    positions : (k, 3) float
    used : (k, n) bool
        Spheres that built each position (excluded from the validation).

    Returns
    -------
    total_density, validation_density, validation_residual : (k,) float each
    """
    z = (np.linalg.norm(positions[:, None, :] - centers[None], axis=2) - radii) / sigmas
    z2 = z * z
    total = np.exp(-0.5 * z2.sum(axis=1))
    others = np.where(used, 0.0, z2)
    valid_density = np.exp(-0.5 * others.sum(axis=1))
    valid_residual = np.sqrt(others.max(axis=1, initial=0.0))
    return total, valid_density, valid_residual


_KEEP_REAL = (MeetStatus.REAL, MeetStatus.TANGENT)


def generate_hypotheses(
    spheres: Sequence[GaussianSphere],
    region: Region | None = None,
    keep_imaginary: bool = True,
    tol: MeetTolerances = MEET_TOLERANCES,
) -> LevelSets:
    """Build ``Phi_1``, ``Phi_2``, ``Phi_3`` and the validated location hypotheses.

    Parameters
    ----------
    spheres : sequence of GaussianSphere
        ``Phi_0``.  Fewer than three spheres give no hypotheses.
    region : Region, optional
        Valid region; hypotheses outside it are kept but flagged and sorted last.
    keep_imaginary : bool
        Keep imaginary circles and point pairs (the point pair then contributes its foot
        point, the closest real point, on the plane of the centres).  With noisy radii three
        spheres often miss each other even when every pair meets (docs/design.md#m3); without
        this the paper's real-only rule can leave no hypothesis at all.
    tol : MeetTolerances

    Returns
    -------
    LevelSets

    Raises
    ------
    RadialError
        Two centres coincide.
    """
    if region is not None:
        instance("region", region, Region)
    if not isinstance(keep_imaginary, (bool, np.bool_)):
        raise RadialArgumentError(f"keep_imaginary must be a bool, got {keep_imaginary!r:.100}")
    instance("tol", tol, MeetTolerances)
    centers, radii, sigmas = sphere_arrays(spheres, min_count=1)
    if len(centers) > MAX_HYPOTHESIS_SPHERES:
        raise RadialArgumentError(
            f"spheres: n = {len(centers)} spheres; the level sets grow as C(n, 4) meets, at most "
            f"MAX_HYPOTHESIS_SPHERES = {MAX_HYPOTHESIS_SPHERES} are accepted (the paper uses <= 6)")
    n = len(centers)
    r2 = radii**2
    kept = (*_KEEP_REAL, MeetStatus.IMAGINARY) if keep_imaginary else _KEEP_REAL

    circles: list[tuple[tuple[int, int], Circle]] = []
    if n >= 2:
        pairs = np.array(list(combinations(range(n), 2)))
        cb = meet2_batch(centers[pairs], r2[pairs], tol)
        for idx, p in enumerate(pairs):
            code = MeetStatus(int(cb.status[idx]))
            if code in kept:
                circles.append(((int(p[0]), int(p[1])),
                                Circle(cb.center[idx], cb.normal[idx], float(cb.radius_sq[idx]),
                                       code.label)))
    circle_keys = {k for k, _ in circles}

    point_pairs: list[tuple[tuple[int, int, int], PointPair]] = []
    if n >= 3:
        triples = np.array([t for t in combinations(range(n), 3)
                            if (t[0], t[1]) in circle_keys])  # circle (i, j) met with sphere k
        if len(triples):
            pb = meet3_batch(centers[triples], r2[triples], tol)
            for idx, t in enumerate(triples):
                code = MeetStatus(int(pb.status[idx]))
                if code in kept:
                    point_pairs.append(((int(t[0]), int(t[1]), int(t[2])),
                                        PointPair(pb.points[idx], pb.center[idx], pb.axis[idx],
                                                  float(pb.half_distance_sq[idx]), code.label)))
    pair_keys = {k for k, _ in point_pairs}

    points: list[tuple[tuple[int, int, int, int], Point]] = []
    if n >= 4:
        quads = np.array([q for q in combinations(range(n), 4)
                          if any(t in pair_keys for t in combinations(q, 3))])
        if len(quads):
            qb = meet4_batch(centers[quads], r2[quads], tol)
            for idx, q in enumerate(quads):
                code = MeetStatus(int(qb.status[idx]))
                if code in (MeetStatus.REAL, MeetStatus.INEXACT):
                    points.append(((int(q[0]), int(q[1]), int(q[2]), int(q[3])),
                                   Point(qb.position[idx], float(qb.residual[idx]), code.label)))
    with_descendants = {t for q, _ in points for t in combinations(q, 3)}

    raw: list[tuple[NDArray, tuple[int, ...], int, str, float]] = []
    for key, pp in point_pairs:
        if key in with_descendants:
            continue
        distinct = pp.status == "real"
        for pt in (pp.points if distinct else pp.points[:1]):
            raw.append((pt, key, 2, pp.status, pp.half_distance_sq))
    for quad, p in points:
        raw.append((p.position, quad, 3, p.status, p.residual))
    hypotheses: list[Hypothesis] = []
    if raw:
        pos = np.stack([r[0] for r in raw])
        used = np.zeros((len(raw), n), dtype=bool)
        for row, r in enumerate(raw):
            used[row, list(r[1])] = True
        total, vdens, vres = validate_positions(centers, radii, sigmas, pos, used)
        inside = np.ones(len(raw), dtype=bool) if region is None else np.asarray(region.contains(pos))
        for row, r in enumerate(raw):
            hypotheses.append(Hypothesis(pos[row], r[1], r[2], r[3], float(r[4]),
                                         float(total[row]), float(vdens[row]), float(vres[row]),
                                         bool(inside[row])))
        hypotheses.sort(key=lambda h: (not h.in_region, -h.total_density, h.spheres,
                                       tuple(h.position)))
    return LevelSets(tuple(circles), tuple(point_pairs), tuple(points), tuple(hypotheses))
