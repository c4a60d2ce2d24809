"""The restriction polytope in radial space (paper sections 4.3-4.4, docs/design.md#m2, #m3).

For spheres i < j with centre distance ``d = |X_i - X_j|`` the radii ``r`` of a configuration
in which the two spheres meet satisfy three half-spaces (the restriction lines of Fig. 14):

* ``L_chi``:   ``r_i + r_j >= d``   (the spheres are not apart),
* ``L_alpha``: ``r_j - r_i <= d``   (sphere j does not swallow sphere i),
* ``L_beta``:  ``r_i - r_j <= d``   (sphere i does not swallow sphere j).

Stacked over all pairs they give ``A r <= b`` (eq. 16) with ``3 C(n, 2)`` rows in Hesse normal
form (unit rows, ``b`` the signed distance of each hyperplane from the origin).  ``r >= 0``
follows (add ``L_chi`` and ``L_alpha``).  The polyhedron is unbounded; its only ray is
``(1, ..., 1)``.

Pairwise intersection is *necessary* for a common point of three or more spheres but *not
sufficient*: three centres on an equilateral triangle of side 2 with all radii 1.1 meet
pairwise, yet the circumradius of the triangle is 2/sqrt(3) = 1.1547 > 1.1, so no point lies
on all three spheres.  The polytope is the paper's relaxation; :func:`common_point_exists`
is the exact test (Cayley-Menger determinants).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ._checks import MAX_SIGMA, instance, integer, real_array, real_scalar, sigma_range
from .errors import RadialArgumentError
from .spheres import TOLERANCES, GaussianSphere, Tolerances, sphere_arrays
from .tolerances import COMMON_POINT_TOL, DEGENERATE_CENTRES, RANK_RTOL, ROUNDING_RTOL, TINY

#: Most spheres a restriction polytope is built for: it has 3 C(n, 2) dense rows of length n
#: (n = 128: 24,384 x 128, 25 MB); beyond it :class:`RadialError` names n.
MAX_POLYTOPE_SPHERES = 128

#: Row kinds, in the order they appear for each pair.
ROW_KINDS = ("chi", "alpha", "beta")

_SQRT_HALF = np.sqrt(0.5)


@dataclass(frozen=True)
class RestrictionPolytope:
    """The pairwise restriction polyhedron ``{x : A x <= b}`` in radial space.

    Attributes
    ----------
    A : (m, n) float
        Unit-norm outward normals (Hesse normal form), ``m = 3 C(n, 2)``.
    b : (m,) float
        Hesse distances of the hyperplanes.
    pairs : (m, 2) int
        The sphere pair ``(i, j)``, ``i < j``, of each row.
    kinds : (m,) str
        ``"chi"``, ``"alpha"`` or ``"beta"`` for each row (see the module docstring).
    distances : (m,) float
        Centre distance ``d`` of each row's pair.
    sigmas : (n,) float
        Standard deviations of the spheres (the homothety H = diag(1/sigma), eq. 19).
    space : str
        ``"S"`` for raw radii, ``"Sd"`` for normalised radii ``x = H r``.
    """

    A: NDArray[np.float64]
    b: NDArray[np.float64]
    pairs: NDArray[np.int64]
    kinds: tuple[str, ...]
    distances: NDArray[np.float64]
    sigmas: NDArray[np.float64]
    space: str = "S"

    def __post_init__(self) -> None:
        for name in ("A", "b", "distances", "sigmas"):
            arr = np.array(getattr(self, name), dtype=np.float64)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        pairs = np.array(self.pairs, dtype=np.int64).reshape(-1, 2)
        pairs.setflags(write=False)
        object.__setattr__(self, "pairs", pairs)
        m, n = self.A.shape
        if self.b.shape != (m,) or len(self.kinds) != m or pairs.shape != (m, 2):
            raise RadialArgumentError(f"inconsistent polytope shapes: A {self.A.shape}, b {self.b.shape}")
        if self.sigmas.shape != (n,):
            raise RadialArgumentError(f"sigmas must have shape ({n},), got {self.sigmas.shape}")
        if self.space not in ("S", "Sd"):
            raise RadialArgumentError(f"space must be 'S' or 'Sd', got {self.space!r}")

    @property
    def dim(self) -> int:
        """Number of spheres n (the dimension of radial space)."""
        return int(self.A.shape[1])

    @classmethod
    def from_spheres(
        cls, spheres: Sequence[GaussianSphere], tol: Tolerances = TOLERANCES
    ) -> RestrictionPolytope:
        """Build the polytope in raw radial space ``S^n`` from at least two spheres."""
        instance("tol", tol, Tolerances)
        centers, _, sigmas = sphere_arrays(spheres, min_count=2, tol=tol)
        return cls.from_centers(centers, sigmas, tol=tol)

    @classmethod
    def from_centers(
        cls,
        centers: ArrayLike,
        sigmas: ArrayLike | None = None,
        tol: Tolerances = TOLERANCES,
    ) -> RestrictionPolytope:
        """Build the polytope from sphere centres ``(n, 3)`` (the radii do not enter it)."""
        instance("tol", tol, Tolerances)
        c = real_array("centers", centers, shape=(None, 3))
        if c.shape[0] < 2:
            raise RadialArgumentError(f"centers must have shape (n, 3) with n >= 2, got shape {c.shape}")
        n = c.shape[0]
        s = np.ones(n) if sigmas is None else real_array("sigmas", sigmas, shape=(n,), max_abs=MAX_SIGMA)
        sigma_range("sigmas", s, float(np.abs(c).max()))
        iu, ju, A, b_sign = pair_pattern(n)
        d = np.linalg.norm(c[iu] - c[ju], axis=1)
        _raise_if_coincident(c, iu, ju, d, tol)
        b = b_sign * np.repeat(d, 3)
        pairs = np.repeat(np.stack([iu, ju], axis=1), 3, axis=0)
        return cls(
            A=A,
            b=b,
            pairs=pairs,
            kinds=ROW_KINDS * len(iu),
            distances=np.repeat(d, 3),
            sigmas=s,
            space="S",
        )

    def normalized(self) -> RestrictionPolytope:
        """The same set in normalised radial space ``Sd^n``: coordinates ``x = H r``, H = diag(1/sigma).

        ``A r <= b`` becomes ``(A diag(sigma)) x <= b``; rows are rescaled back to unit norm
        (Hesse form) in the new coordinates (eq. 19).
        """
        if self.space == "Sd":
            return self
        A = self.A * self.sigmas[None, :]
        norms = np.linalg.norm(A, axis=1)
        return RestrictionPolytope(
            A=A / norms[:, None],
            b=self.b / norms,
            pairs=self.pairs,
            kinds=self.kinds,
            distances=self.distances,
            sigmas=self.sigmas,
            space="Sd",
        )

    def slack(self, x: ArrayLike) -> NDArray[np.float64]:
        """``b - A x`` for a point (n,) or points (k, n) in this polytope's space."""
        arr = real_array("x", x, ndim=(1, 2), max_abs=None)
        if arr.shape[-1:] != (self.dim,):
            raise RadialArgumentError(f"x must have shape ({self.dim},) or (k, {self.dim}), got {arr.shape}")
        return self.b - arr @ self.A.T

    def contains(self, x: ArrayLike, tol: float = TOLERANCES.feasibility) -> bool | NDArray[np.bool_]:
        """Whether ``A x <= b + tol`` for a point (n,) (-> bool) or points (k, n) (-> (k,) bool).

        ``x`` is in this polytope's space: raw radii for ``space == "S"``, normalised radii
        ``r / sigma`` for ``space == "Sd"``.
        """
        s = self.slack(x)
        tol = real_scalar("tol", tol, minimum=0.0)
        ok = np.all(s >= -tol, axis=-1)
        return bool(ok) if np.ndim(ok) == 0 else ok

    def violated_rows(self, x: ArrayLike, tol: float = TOLERANCES.feasibility) -> list[str]:
        """Human-readable names of the rows that ``x`` violates, e.g. ``"chi(0,2)"``."""
        s = self.slack(x)
        tol = real_scalar("tol", tol, minimum=0.0)
        return [self.row_name(int(k)) for k in np.flatnonzero(s < -tol)]

    def row_name(self, k: int) -> str:
        """Name of row ``k``: kind and sphere pair, e.g. ``"beta(1,3)"``."""
        k = integer("k", k, minimum=0, maximum=len(self.kinds) - 1)  # no wrap-around: k = -1 is a bug
        i, j = self.pairs[k]
        return f"{self.kinds[k]}({i},{j})"


@lru_cache(maxsize=32)
def pair_pattern(n: int) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64],
                                  NDArray[np.float64]]:
    """Row structure for n spheres: pair indices ``iu, ju`` (C(n,2),), the Hesse-normalised
    ``A (3 C(n,2), n)`` and ``b_sign`` such that ``b = b_sign * repeat(d, 3)``.  Read-only.

    Raises :class:`RadialError` beyond :data:`MAX_POLYTOPE_SPHERES` spheres."""
    if n > MAX_POLYTOPE_SPHERES:
        raise RadialArgumentError(
            f"n = {n} spheres: the restriction polytope has 3 C(n, 2) = {3 * n * (n - 1) // 2} dense "
            f"rows; at most MAX_POLYTOPE_SPHERES = {MAX_POLYTOPE_SPHERES} spheres are accepted")
    iu, ju = np.triu_indices(n, k=1)
    p = len(iu)
    A = np.zeros((3 * p, n))
    rows = np.arange(p) * 3
    A[rows, iu] = -1.0  # chi: -r_i - r_j <= -d
    A[rows, ju] = -1.0
    A[rows + 1, iu] = -1.0  # alpha: r_j - r_i <= d
    A[rows + 1, ju] = 1.0
    A[rows + 2, iu] = 1.0  # beta: r_i - r_j <= d
    A[rows + 2, ju] = -1.0
    b_sign = np.tile([-1.0, 1.0, 1.0], p) * _SQRT_HALF
    A *= _SQRT_HALF
    for arr in (iu, ju, A, b_sign):
        arr.setflags(write=False)
    return iu, ju, A, b_sign


def _raise_if_coincident(
    c: NDArray[np.float64], iu: NDArray, ju: NDArray, d: NDArray[np.float64], tol: Tolerances
) -> None:
    bad = np.flatnonzero(d <= tol.coincident)
    if bad.size:
        i, j = int(iu[bad[0]]), int(ju[bad[0]])
        raise RadialArgumentError(
            f"centers[{i}] = {c[i].tolist()} and centers[{j}] = {c[j].tolist()} coincide (distance "
            f"{d[bad[0]]:.3g} <= {tol.coincident:g})"
        )


def common_point_exists(
    spheres: Sequence[GaussianSphere], tol: float = COMMON_POINT_TOL
) -> bool:
    """Exact test whether all spheres share a point (for 2, 3 and 4 spheres; any n >= 2 works).

    The pairwise polytope only tests each pair; this tests the whole set.  For three spheres
    with non-collinear centres the fourth point P (at distance r_i from X_i) exists in R^3 iff
    the squared height of P over the plane of the centres, from Cayley-Menger determinants,
    ``h^2 = 1/2 CM(X1, X2, X3, P) / -CM(X1, X2, X3)``, is >= 0.  For four spheres with
    non-coplanar centres P exists iff its squared height over the centres' hyperplane in R^4,
    ``h^2 = -1/2 CM(X1..X4, P) / CM(X1..X4)``, is 0.  Degenerate centre sets (collinear,
    coplanar) and n > 4 use the radical-plane reduction of ``_common_point_linear``.

    ``tol`` is relative to the squared scale of the configuration.
    """
    centers, radii, _ = sphere_arrays(spheres, min_count=2)
    tol = real_scalar("tol", tol, minimum=0.0, maximum=1.0)
    n = len(centers)
    scale = max(float(np.max(radii)), float(np.ptp(centers, axis=0).max()), TINY)
    atol = tol * scale**2
    if n == 2:
        d = float(np.linalg.norm(centers[0] - centers[1]))
        return bool(abs(radii[0] - radii[1]) <= d + tol * scale and d <= radii.sum() + tol * scale)
    if n in (3, 4):
        base = _cayley_menger(_squared_distances(centers))
        full_d2 = np.zeros((n + 1, n + 1))
        full_d2[:n, :n] = _squared_distances(centers)
        full_d2[:n, n] = full_d2[n, :n] = radii**2
        full = _cayley_menger(full_d2)
        # Degenerate centre sets (collinear for 3, coplanar for 4) fall through to the
        # radical-plane reduction below.
        if n == 3:
            area2 = -base / 16.0
            if area2 > (DEGENERATE_CENTRES * scale**2) ** 2:
                h2 = 0.5 * full / -base
                return bool(h2 >= -atol)
        else:
            vol2 = base / 288.0
            if vol2 > (DEGENERATE_CENTRES * scale**3) ** 2:
                h2 = -0.5 * full / base
                return bool(abs(h2) <= atol)
    return _common_point_linear(centers, radii, atol)


def _squared_distances(points: NDArray[np.float64]) -> NDArray[np.float64]:
    diff = points[:, None, :] - points[None, :, :]
    return np.einsum("ijk,ijk->ij", diff, diff)


def _cayley_menger(d2: NDArray[np.float64]) -> float:
    """Cayley-Menger determinant of a squared-distance matrix (k, k)."""
    k = d2.shape[0]
    M = np.ones((k + 1, k + 1))
    M[0, 0] = 0.0
    M[1:, 1:] = d2
    return float(np.linalg.det(M))


def _common_point_linear(
    centers: NDArray[np.float64], radii: NDArray[np.float64], atol: float
) -> bool:
    """Radical-plane reduction: subtract sphere 0's equation from the others.

    ``2 (X_j - X_0) . P = |X_j|^2 - |X_0|^2 - r_j^2 + r_0^2`` (re-centred at X_0).  The system
    must be consistent; the remaining squared height along the orthogonal complement of the
    centres' affine span must be >= 0 (and 0 when the span is all of R^3).
    """
    c = centers - centers[0]
    D = 2.0 * c[1:]
    rhs = np.sum(c[1:] ** 2, axis=1) - radii[1:] ** 2 + radii[0] ** 2
    U, s, Vt = np.linalg.svd(D, full_matrices=True)
    rank = int(np.sum(s > RANK_RTOL * max(s.max(), TINY)))
    coeff = U[:, :rank].T @ rhs / s[:rank]
    foot = Vt[:rank].T @ coeff
    resid = D @ foot - rhs
    # residual of the radical equations is in units of length^2
    if np.any(np.abs(resid) > 4 * atol + ROUNDING_RTOL * np.abs(rhs).max(initial=0.0)):
        return False
    h2 = radii[0] ** 2 - float(foot @ foot)
    if rank == 3:
        return bool(abs(h2) <= atol)
    return bool(h2 >= -atol)
