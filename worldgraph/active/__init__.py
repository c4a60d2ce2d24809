"""Active validation: where to look next when the pose is ambiguous (paper, section 2.3).

The paper ends an ambiguous association with "an active validation [...] selecting objects from
the model and then localizing them in the visual space", choosing the object with the maximal
pose difference between two hypotheses (:func:`worldgraph.association.discriminator`).  A large
predicted difference does not make a look informative, though: under the other hypothesis the
same ego spot may hold another object of the same type, and then both hypotheses predict the
same sight.  :func:`plan_view` scores gaze directions by what would actually be seen:

1. The near-best hypotheses are the chosen pose and every ``alternatives`` pose of the
   :class:`~worldgraph.LocalizationResult` (all validated fits within the ambiguity
   margin, not only two), weighted ``w_h ∝ exp(-cost_h / 2)`` with their robust costs
   (``near_best_costs``, twice a negative log-likelihood).
2. Under hypothesis ``h`` every recognisable object ``o`` is predicted at the ego point
   ``p_ho = R_h^T (X_o - t_h)``.  It *tells h from j* when hypothesis ``j`` predicts no object
   of its type within the gate ``n_sigma sqrt(2) sigma(|p_ho|) + margin`` of ``p_ho`` (eq. 6
   noise ``sigma(rho) = max(min_sigma, rho^2 / depth_factor)``).  This flag does not depend on
   the gaze, so it is computed once per hypothesis pair (a k-d tree per hypothesis whose fourth
   coordinate separates the types).
3. A look in direction ``d`` sees the objects whose direction lies within ``fov_deg / 2`` of
   ``d`` and whose range is at most ``max_range``; each comes back with probability
   ``detection`` (with a cap of ``max_sights`` percepts per look, about ``min(detection,
   max_sights / n_in_view)``).  If ``h`` is true, the look rules out ``j`` when at least one
   object that tells h from j comes back.  The *score* is the probability that the look rules
   out every other hypothesis: ``sum_h w_h prod_{j != h} (1 - (1 - detection)^{n_hj(d)})``.
   The product is exact for two hypotheses and a lower bound for more (the events increase
   with the detections, so they are positively correlated: Harris' inequality).
4. The look also refines the pose.  Each sight of an object that would be matched to it alone
   (no other object of its type within the gate) adds the Fisher information
   ``J^T J / sigma^2`` about the 6D pose (:func:`sight_information`).  The planner maximises
   the *expected information* of the look (nats): the expected drop in half the log-determinant
   of the pose's covariance, the mixture of the hypotheses treated as one Gaussian (its
   covariance the result's ``pose_covariance`` plus the hypotheses' scatter), with the
   hypotheses ruled out with the score's probability (``_information``).  For a unique
   answer this is the D-optimal gain ``0.5 log det (I + C dI)``: a look at a tight cluster of
   objects pins the cluster's position but hardly the rotation, while objects spread across
   the view pin both.  For hypotheses far apart, telling them apart dominates; for close ones,
   refining the pose counts as much.
5. Candidates are the directions to every object that tells any two hypotheses apart, under
   every hypothesis, to every informative object under the chosen pose, a fixed set of
   directions spread over the sphere and any given by the caller; one matrix product per
   hypothesis scores them all.

:func:`active_localize` is the loop: localise, plan, look (a user callback returning new
percepts in the same ego frame), localise again with the old and new percepts, until the
answer is unique or the looks run out.
"""

# ruff: noqa: F401  (the constants and the helpers the tests use are re-exported beside __all__)
from __future__ import annotations

from .gaze import GAZE_TOLERANCE, gaze_angles
from .loop import (
    _LOOK_STATUSES,
    EXPLORE_STATUSES,
    GOAL_ROTATION_3SIGMA,
    MIN_CAP_EVIDENCE,
    MIN_FACTOR_RANGE,
    SCANNED_YAW_DEG,
    ActiveLocalization,
    ExploreStatus,
    LookReason,
    LookStatus,
    active_localize,
    depth_factor_of,
    explore_direction,
    merge_percepts,
)
from .plan import (
    N_FIXED_DIRECTIONS,
    N_RANDOM_DIRECTIONS,
    RECENTRE_STEPS,
    VIEW_STATUSES,
    ViewPlan,
    ViewStatus,
    plan_view,
    view_information,
    view_scores,
)
from .predict import (
    DEFAULT_DEPTH_FACTOR,
    MAX_VIEW_MARGIN,
    MERGE_FLOOR,
    MERGE_SIGMAS,
    NEVER_IN_VIEW,
    SIGMA_FLOOR,
    VAGUE_POSE_STD,
    VIEW_MARGIN_SIGMAS,
    _gate,
    _predict,
    sight_information,
    tells_apart,
)

__all__ = [
    "ActiveLocalization",
    "EXPLORE_STATUSES",
    "ExploreStatus",
    "LookReason",
    "SCANNED_YAW_DEG",
    "VIEW_STATUSES",
    "GOAL_ROTATION_3SIGMA",
    "ViewPlan",
    "LookStatus",
    "ViewStatus",
    "active_localize",
    "depth_factor_of",
    "explore_direction",
    "gaze_angles",
    "merge_percepts",
    "plan_view",
    "sight_information",
    "tells_apart",
    "view_information",
    "view_scores",
]
