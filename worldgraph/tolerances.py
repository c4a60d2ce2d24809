"""Tolerances of the association (docs/design.md#association): :class:`AssociationTolerances`."""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, replace
from typing import cast

import numpy as np
from numpy.typing import NDArray

from ._checks import float_array, positive_float, strict_int
from .errors import (
    ArgumentTypeError,
    NonPositiveError,
    OutOfRangeError,
    ShapeError,
)
from .model import WorldModel


@dataclass(frozen=True)
class AssociationTolerances:
    """Tolerances of the association, in one frozen place.

    Attributes
    ----------
    n_sigma : float
        Gate width in standard deviations.
    pair_factor : float
        Extra factor on the pair gate, ``tau_pq = n_sigma * pair_factor * sqrt(s_p^2 + s_q^2)
        + min_tolerance``; sqrt(2) keeps a true pair inside the gate with probability
        ~1 - 2e-5 at 3 sigma, so that all ~45 pairs of ten percepts pass together.
    min_tolerance : float
        Floor (metres) added to every distance gate (model inaccuracy).
    kappa_max : float
        Orientation filter, eq. 3: maximal angle (rad) between signature vectors.
    mu_max : float or None
        Orientation filter, eq. 2: maximal length (m) of the signature difference; ``None``
        derives it per triple like ``tau`` from the three sigmas.
    gravity_aligned : bool or None
        The ego z axis is the world z axis (REP 103 ego with a levelled base): compare the
        horizontal distance and the height difference of pairs separately, so pairs across
        storeys drop out.  ``None`` (default) follows the world's
        :attr:`~worldgraph.model.WorldModel.gravity_aligned` (the building and campus scenes set
        it; the kitchen and ``from_*`` worlds do not unless asked).
    height_tolerance : float or None
        Gate (m) of the height difference when ``gravity_aligned``; ``None`` uses ``tau``.
    cost_cap : float
        Cap of a percept's squared normalised residual in the robust fit cost.
    residual_factor : float
        The residual of a percept under a fitted pose is normalised by ``residual_factor *
        sigma`` (the pose itself is uncertain).
    min_clique_size : int
        Smallest clique that makes a hypothesis (three points fix a pose).
    near_maximum : int
        Maximal cliques down to ``maximum size - near_maximum`` are kept.
    ambiguity_margin : float
        The best two (pose-distinct) hypotheses are ambiguous when their robust costs differ by
        less.  A cost difference is twice a log-likelihood ratio: the default 6 calls a runner-up
        ambiguous unless the best is 20 times as likely (at 4, chance fits of repeated cabinet
        modules were answered "ok" and wrong in our layouts).
    distinct_translation, distinct_angle : float
        Two hypotheses with translations closer than this (m) and rotations closer than this
        (rad) are the same pose: only the cheaper one is kept.
    chirality_sigmas : float
        A tetrahedron's signed volume decides chirality only when both volumes exceed this
        many standard deviations of the percept volume.
    max_nodes : int
        Node budget of one branch-and-bound search (the result says when it ran out).
    max_cliques : int
        At most this many cliques (largest first) are fitted and ranked.
    dense_pair_limit : int
        Percept pairs farther apart than the link table covers are matched by brute force when
        the two types have at most this many object pairs, otherwise by a k-d tree ball query.
    max_hypotheses : int
        Default number of hypotheses returned by :func:`associate`.
    max_search_percepts : int
        The clique search (and the paper's filters) use at most this many percepts, the most
        certain ones (smallest sigma); the others are validated against each hypothesis' pose
        and enter its cost (the paper generates candidates from at most 6 spheres and
        validates with the rest).
    """

    n_sigma: float = 3.0
    pair_factor: float = math.sqrt(2.0)
    min_tolerance: float = 0.01
    kappa_max: float = math.radians(20.0)
    mu_max: float | None = None
    gravity_aligned: bool | None = None
    height_tolerance: float | None = None
    cost_cap: float = 9.0
    residual_factor: float = math.sqrt(2.0)
    min_clique_size: int = 3
    near_maximum: int = 1
    ambiguity_margin: float = 6.0
    distinct_translation: float = 0.25
    distinct_angle: float = math.radians(5.0)
    chirality_sigmas: float = 3.0
    max_nodes: int = 50_000
    max_cliques: int = 2000
    dense_pair_limit: int = 250_000
    max_hypotheses: int = 16
    max_search_percepts: int = 10

    def __post_init__(self) -> None:
        def put(name: str, value: object) -> None:
            object.__setattr__(self, name, value)

        for name in ("n_sigma", "pair_factor", "cost_cap", "residual_factor", "distinct_translation"):
            put(name, positive_float(f"AssociationTolerances.{name}", getattr(self, name), maximum=1e12))
        for name in ("min_tolerance", "ambiguity_margin", "chirality_sigmas"):
            put(name, positive_float(f"AssociationTolerances.{name}", getattr(self, name), allow_zero=True,
                                     maximum=1e12))
        for name in ("kappa_max", "distinct_angle"):
            v = positive_float(f"AssociationTolerances.{name}", getattr(self, name))
            if v > math.pi:
                raise OutOfRangeError(f"AssociationTolerances.{name} = {v!r} is an angle in radians and must "
                                      f"be <= pi; degrees? use np.radians({v!r}) = {math.radians(v):.6g}")
            put(name, v)
        for name in ("mu_max", "height_tolerance"):
            v = getattr(self, name)
            if v is not None:
                put(name, positive_float(f"AssociationTolerances.{name}", v, maximum=1e12))
        if self.gravity_aligned is not None:
            if not isinstance(self.gravity_aligned, bool | np.bool_):
                raise ArgumentTypeError(f"AssociationTolerances.gravity_aligned must be a bool or None, "
                                        f"got {self.gravity_aligned!r}")
            put("gravity_aligned", bool(self.gravity_aligned))
        put("min_clique_size", strict_int("AssociationTolerances.min_clique_size", self.min_clique_size,
                                          minimum=2, maximum=64))
        put("max_search_percepts", strict_int("AssociationTolerances.max_search_percepts",
                                              self.max_search_percepts, minimum=2, maximum=100_000))
        if self.min_clique_size > self.max_search_percepts:
            raise OutOfRangeError(f"AssociationTolerances.min_clique_size = {self.min_clique_size} exceeds "
                                  f"max_search_percepts = {self.max_search_percepts} (the clique search "
                                  "looks at that many percepts at most): raise max_search_percepts too")
        for name, lo in (("near_maximum", 0), ("max_nodes", 1), ("max_cliques", 1), ("dense_pair_limit", 0),
                         ("max_hypotheses", 1)):
            put(name, strict_int(f"AssociationTolerances.{name}", getattr(self, name), minimum=lo,
                                 maximum=10**9))

    def pair_tolerance(self, sigma_p: float | NDArray, sigma_q: float | NDArray) -> float | NDArray:
        """``tau_pq = n_sigma * pair_factor * sqrt(s_p^2 + s_q^2) + min_tolerance`` (metres);
        sigmas are non-negative finite reals (scalars or arrays that broadcast)."""
        sp = float_array("sigma_p", sigma_p, None, max_abs=1e150)
        sq = float_array("sigma_q", sigma_q, None, max_abs=1e150)
        for name, arr in (("sigma_p", sp), ("sigma_q", sq)):
            if np.any(arr < 0):
                i = int(np.flatnonzero(np.ravel(arr) < 0)[0])
                raise NonPositiveError(f"{name}[{i}] must be >= 0, got {float(np.ravel(arr)[i])!r}"
                                       if arr.ndim else f"{name} must be >= 0, got {float(arr)!r}")
        try:
            out = self.n_sigma * self.pair_factor * np.hypot(sp, sq) + self.min_tolerance
        except ValueError as exc:
            raise ShapeError(f"sigma_p {sp.shape} and sigma_q {sq.shape} do not broadcast") from exc
        return float(out) if np.ndim(out) == 0 else out


ASSOCIATION_TOLERANCES = AssociationTolerances()


def _check_tolerances(tolerances: object, name: str = "tolerances", world: WorldModel | None = None
                      ) -> AssociationTolerances:
    """The tolerances, with ``gravity_aligned=None`` resolved to the world's flag when a world is
    given."""
    if not isinstance(tolerances, AssociationTolerances):
        raise ArgumentTypeError(f"{name} must be an AssociationTolerances, got {type(tolerances).__name__}")
    if world is not None and tolerances.gravity_aligned is None:
        return replace(tolerances, gravity_aligned=bool(world.gravity_aligned))
    return tolerances


def _tol_argument(function: str, tol: AssociationTolerances | None, tolerances: object,
                  stacklevel: int = 3) -> AssociationTolerances | None:
    """The ``tol`` argument of a public function, given as ``tol=`` or as the deprecated
    keyword ``tolerances=`` (a :class:`DeprecationWarning` naming ``tol``); both at once raise
    :class:`~worldgraph.errors.ArgumentTypeError`.  ``None`` when neither was given."""
    if tolerances is None:
        return tol
    if tol is not None:
        raise ArgumentTypeError(f"{function}() got both tol and tolerances (the deprecated name of tol): "
                                "pass tol only")
    warnings.warn(f"{function}(tolerances=...) is deprecated: pass tol=... instead", DeprecationWarning,
                  stacklevel=stacklevel)
    return cast(AssociationTolerances, tolerances)


def _resolved_tol(function: str, tol: AssociationTolerances | None, tolerances: object,
                  world: WorldModel | None = None) -> AssociationTolerances:
    """:func:`_tol_argument`, ``None`` as :data:`ASSOCIATION_TOLERANCES`, then checked (and
    ``gravity_aligned`` resolved against ``world``) by :func:`_check_tolerances`."""
    tol = _tol_argument(function, tol, tolerances, stacklevel=4)
    return _check_tolerances(ASSOCIATION_TOLERANCES if tol is None else tol, "tol", world=world)
