"""The tuning of the position estimators (:class:`EstimatorOptions`) and its defaults.

Used by :mod:`radialopt.position`, which re-exports both names, and by the Fisher-information and
SR-LS modules whose defaults come from :data:`ESTIMATOR_OPTIONS`.
"""

from __future__ import annotations

from dataclasses import dataclass

from ._checks import dataclass_fields


@dataclass(frozen=True)
class EstimatorOptions:
    """Tuning of the estimators, in one frozen place.

    Attributes
    ----------
    rank_tol : float
        Centres are collinear (coplanar) when the second (third) singular value of the
        centred centres is below ``rank_tol`` times the largest.
    fisher_rcond : float
        The Fisher information is singular when the smallest eigenvalue of
        ``sum_i u_i u_i^T / n`` (geometry only, independent of sigma) is below this.
    lm_max_iter : int
        Iteration cap of Levenberg-Marquardt.
    lm_step_tol : float
        LM stops when a step is shorter than this times the landmark spread.
    gradient_max_iter : int
        Iteration cap of the gradient-ascent baseline.
    gradient_step_tol : float
        Gradient ascent stops when every step is shorter than this times the spread.
    distinct_tol : float
        Candidates closer than this times the spread are the same candidate.
    ambiguity_ratio : float
        A distinct candidate whose density is at least this fraction of the best one's, and
        which lies more than ``ambiguity_sigmas`` standard deviations (of the CRLB, trace)
        away, makes the estimate ambiguous.
    ambiguity_sigmas : float
    random_seeds : int
        Extra uniformly drawn seeds for "ml" and "gradient" when an ``rng`` is passed.
    region_tol : float
        Slack (metres) of the region test.
    max_generation_spheres : int
        Candidates and seeds that grow combinatorially (the paper's level sets, the points
        and mirror planes of sphere triples) come from at most this many spheres, the most
        certain ones (smallest sigma); every sphere scores every candidate.  The paper: "the
        amount of spheres n is never greater than 6 while generating candidates".
    polish_candidates : int
        "ml": how many of the best distinct LM results get the trust-region polish.
    polish_max_nfev : int
        Evaluation cap of one trust-region polish; reaching it on the chosen point gives the
        status ``"not_converged"``.
    polish_recentre : int
        How many times a polish may re-centre its chart when it walks off its middle.
    max_range_ratio : float
        An estimate farther than this many landmark spreads from their centroid is
        ``"degenerate"`` (ranges that do not fit the landmarks' scale, e.g. shifted by 1e6 m).

    Every field is validated (integers must be ints, not bools or floats; floats finite and in
    range): a bad value raises :class:`~radialopt.errors.RadialError` naming the field.
    """

    rank_tol: float = 1e-9
    fisher_rcond: float = 1e-12
    lm_max_iter: int = 100
    lm_step_tol: float = 1e-13
    gradient_max_iter: int = 5000
    gradient_step_tol: float = 1e-13
    distinct_tol: float = 1e-6
    ambiguity_ratio: float = 0.5
    ambiguity_sigmas: float = 3.0
    random_seeds: int = 32
    region_tol: float = 1e-9
    max_generation_spheres: int = 6
    polish_candidates: int = 4
    polish_max_nfev: int = 400
    polish_recentre: int = 4
    max_range_ratio: float = 1e3

    def __post_init__(self) -> None:
        dataclass_fields(
            self,
            {"lm_max_iter": (0, 10**6), "gradient_max_iter": (0, 10**7), "random_seeds": (0, 10**5),
             "max_generation_spheres": (3, 12), "polish_candidates": (0, 1000),
             "polish_max_nfev": (1, 10**6), "polish_recentre": (1, 100)},
            {"rank_tol": (0.0, 1.0, False), "fisher_rcond": (0.0, 1.0, False),
             "lm_step_tol": (0.0, 1.0, False), "gradient_step_tol": (0.0, 1.0, False),
             "distinct_tol": (0.0, 1.0, False), "ambiguity_ratio": (0.0, 1.0, False),
             "ambiguity_sigmas": (0.0, 1e6, False), "region_tol": (0.0, 1e6, False),
             "max_range_ratio": (1.0, 1e12, False)})


ESTIMATOR_OPTIONS = EstimatorOptions()
