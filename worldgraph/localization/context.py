"""One :func:`~worldgraph.localize` call as its steps see it: its settings and generator, the
percepts of known types, the measurements the steps share, and what a pose step hands on
(``_Answer``, ``_Choice``)."""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

import radialopt as ro
from perception import Percept

from ..association.hypotheses import AssociationHypothesis
from ..model import WorldModel
from ..pose.gravity import TiltPrior
from ..pose.validation import NearestObjects
from .result import LocalizationResult, LocalizeStatus, poseless_result
from .settings import LocalizeSettings


def _remap(h: AssociationHypothesis, idx: NDArray[np.intp]) -> AssociationHypothesis:
    return AssociationHypothesis(
        pairs=tuple((int(idx[p]), o) for p, o in h.pairs), cost=h.cost, size=h.size,
        world_from_ego=h.world_from_ego, validated=tuple((int(idx[p]), o) for p, o in h.validated),
        inliers=h.inliers, complete=h.complete)


@dataclass
class _Call:
    """One call's settings, its percepts of known types and what it has noted and timed so far."""

    world: WorldModel
    settings: LocalizeSettings
    rng: np.random.Generator | None  # passed to the position estimator (extra random seeds)
    used: list[Percept]
    idx: NDArray[np.intp]               # used -> index in the percepts passed in
    n_all: int
    notes: list[str]
    timings: dict[str, float]
    t_start: float

    def remap(self, pairs: Sequence[tuple[int, int]]) -> tuple[tuple[int, int], ...]:
        return tuple((int(self.idx[p]), int(o)) for p, o in pairs)

    def failed(self, status: LocalizeStatus, message: str, hyps: tuple = (), ambiguous: bool = False
               ) -> LocalizationResult:
        self.timings["total"] = time.perf_counter() - self.t_start
        return poseless_result(status, "; ".join(self.notes + [message]), self.n_all, hyps, self.timings,
                               ambiguous)


@dataclass
class _Context(_Call):
    """A call with the measurements its steps share: the region, the percept positions and
    covariances in the ego frame and the nearest-object index."""

    region: ro.Region
    explicit_region: bool
    ego: NDArray[np.float64]
    covs: NDArray[np.float64]
    nearest: NearestObjects
    ranges: NDArray[np.float64]  # each percept's Gaussian-sphere radius (Percept.range)
    sigmas: NDArray[np.float64]  # and its sigma
    false_costs: NDArray[np.float64]  # what leaving each percept unexplained costs beyond the cap


@dataclass(frozen=True)
class _Choice:
    """What the runners-up say about the chosen hypothesis."""

    ambiguous: bool
    alternatives: tuple[NDArray[np.float64], ...] = ()
    llr: float = math.inf  # log-likelihood ratio to the best fit at a distinct pose
    near_best_costs: tuple[float, ...] = ()
    # (6, 6) ROS order: the likelihood-weighted spread of the fits at the same pose (see
    # _same_pose), added to the pose covariance
    spread: NDArray[np.float64] | None = None


@dataclass(frozen=True)
class _Answer:
    """A pose step's pose, before the answer checks itself (``finish._finish``)."""

    pose: NDArray[np.float64]
    cov6: NDArray[np.float64]
    pairs: tuple[tuple[int, int], ...]  # matches behind the pose (used-percept, object)
    est: ro.PositionEstimate | None = None  # the range-only position estimate, if any
    self_check: bool = True  # run the chi-square self-check of the matches
    status_hint: str = "ok"  # the position estimator's status
    tilt_prior: TiltPrior | None = None  # gravity's prior, when the pose was fitted with it
