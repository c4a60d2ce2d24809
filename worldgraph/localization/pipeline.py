"""Global self-localisation: association -> validation -> 6D pose with its covariance.

:func:`localize` runs the pipeline of the paper (sections 2.2-2.3, 4) on fused percepts:

1. association (:func:`worldgraph.association.matching`; ``method="paper"`` uses the paper's
   proximity and orientation filters, every other method the typed consistency-graph cliques);
2. hypothesis validation (:mod:`worldgraph.pose.validation`; every method but ``"paper"``): the
   best association hypotheses are fitted by maximum likelihood, every percept is re-associated
   to its nearest same-type object by Mahalanobis distance and the fit repeated on the inliers;
   the fits are ranked by their robust cost (a log-likelihood ratio), poses outside the region
   give way to poses inside it, and a runner-up within ``ambiguity_margin`` at another pose
   makes the answer ``"ambiguous"`` (its pose is in ``alternatives``); runners-up at the same
   pose (a percept matched to one of two neighbouring objects of its type; closer than a third
   of the tolerances) widen ``pose_covariance`` by their likelihood-weighted spread instead;
3. the pose of the chosen hypothesis: ``method="ml"`` (default) is the validated ML 6D pose of the
   matched percepts' full 3D positions and covariances; the range-only methods (``"spheres"``,
   ``"paper"``, ``"srls"``, ``"gradient"``) put one Gaussian sphere per matched pair (centre =
   model object, radius = ``|percept|``, sigma = percept sigma), estimate the position with
   ``radialopt.estimate_position`` and then the orientation (``"paper"``: eq. 5 from the
   best-conditioned matched triple; the others: the proper rotation minimising ``sum w_p |R x_p
   - (X_o - t)|^2``, ``w_p = 1 / (sigma_p^2 + var_t)``);
4. the 6x6 ``pose_covariance`` (ROS order): the inverse Fisher information for ``"ml"``, widened
   where the cost is flatter than its quadratic model (:func:`~worldgraph.pose.validation.laplace_inflate`),
   and the sandwich covariance of the two-stage estimator for the range-only methods;
5. the answer checks itself: a chi-square test of its matched percepts placed by its pose
   (``"inconsistent"`` when it fails), at least 3 inliers (counted in constrained directions,
   :data:`~worldgraph.tolerances.MIN_INLIER_DIRECTIONS` = 9: a needle-shaped percept counts two
   thirds), and the 3-sigma rotation and position bounds against ``max_rotation_3sigma`` and
   ``max_position_3sigma`` (``"weak"`` beyond them).

The default region is where the robot could stand and see what it saw: the room when the world
knows a plausible one (``world.room``, from an importer's floor and walls, holding the objects),
otherwise the objects' bounds grown sideways by the largest percept range and by
:data:`REGION_MARGIN` up and down.  The default region chooses between candidates (a pose inside
it beats a better-fitting one outside) but never fails a unique answer; a region given by the
caller also rejects poses outside it (``"outside_region"``).

Percepts whose type the world does not have are ignored (named in the result's message);
when no percept type is known, :class:`~worldgraph.errors.WorldGraphError` is raised.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import fields, replace

import numpy as np

import radialopt as ro
from perception import Percept

from .._checks import generator
from ..association.consistency import MAX_COORDINATE, check_world_and_percepts
from ..association.hypotheses import AssociationHypothesis
from ..association.matching import associate_searched
from ..errors import WorldGraphError
from ..model import WorldModel
from ..model.units import units_hint
from ..pose.gravity import (
    Gravity,
    SearchKind,
    SearchPlan,
    tilt_contradiction,
    unsupported_reason,
)
from ..pose.validation import CHI2_3_GATE, NearestObjects, false_percept_costs, percept_covariances
from ..tolerances import RIGID_TOLERANCE, AssociationTolerances
from .context import _Call, _Context
from .paper import _paper
from .result import _POSELESS_STATUSES, LOCALIZE_STATUSES, POSE_STATUSES, LocalizationResult, _without_pose
from .settings import MAX_POSITION_3SIGMA, MAX_ROTATION_3SIGMA, LocalizeSettings, settings_of
from .validate import ASSOCIATION_CANDIDATES, _validated

__all__ = [
    "MIN_ROOM_SIZE",
    "REGION_MARGIN",
    "default_region",
    "localize",
]

#: Metres added above and below the objects' bounds by the default region (sideways it grows by
#: the largest percept range).
REGION_MARGIN = 1.0
#: A room narrower than this (m) in x or y is no room (a lone wall node, a floor tile).
MIN_ROOM_SIZE = 1.5
def default_region(world: WorldModel, percepts: Sequence[Percept]) -> ro.Region:
    """Where the robot could stand and see ``percepts``: ``world.room`` when it is a plausible
    room (at least :data:`MIN_ROOM_SIZE` wide both ways and holding the objects' positions to
    within :data:`REGION_MARGIN`; a scene whose only "wall" node is one wall is not), else the
    objects' bounds grown sideways by the largest percept range and by :data:`REGION_MARGIN` up
    and down."""
    percepts = check_world_and_percepts(world, percepts)
    room = getattr(world, "room", None)
    if room is not None:
        size = room.upper - room.lower
        if size[0] >= MIN_ROOM_SIZE and size[1] >= MIN_ROOM_SIZE and bool(
                np.all(room.contains(world.positions, tol=REGION_MARGIN))):
            return room
    lo, hi = world.bounds
    reach = max((p.range for p in percepts), default=0.0)
    grow = np.array([reach + REGION_MARGIN, reach + REGION_MARGIN, REGION_MARGIN])
    return ro.Region(lo - grow, hi + grow)


def localize(world: WorldModel, percepts: Sequence[Percept], method: str = "ml", *,
             tol: AssociationTolerances | None = None, region: ro.Region | None = None,
             rng: np.random.Generator | None = None, max_position_3sigma: float = MAX_POSITION_3SIGMA,
             max_rotation_3sigma: float = MAX_ROTATION_3SIGMA, solver: str = "active_set",
             check: bool = False, certify: bool = False, gravity: Gravity = "auto",
             up_sigma: float | None = None, settings: LocalizeSettings | None = None) -> LocalizationResult:
    """Pose of the robot (``world_from_ego``) from percepts of known world objects.

    Parameters
    ----------
    world : WorldModel
    percepts : sequence of perception.Percept
        Fused percepts in the ego frame.
    method : {"ml", "spheres", "paper", "srls", "gradient"}
        ``"ml"`` (default): the maximum-likelihood 6D pose of the validated matches, using the
        percepts' full 3D positions and covariances.  ``"spheres"``: the range-only ML position
        of the Gaussian spheres (``radialopt`` ``"ml"``), then the rotation; right when the
        percept directions are unreliable (space-to-ego errors rotate percepts about the ego
        origin, ranges survive them).  ``"paper"``: the paper's proximity + orientation filters,
        its radial-projection position and eq. 5; ``"srls"``, ``"gradient"``: other range-only
        estimators, for comparison.
    tol : AssociationTolerances, optional
        Default :data:`~worldgraph.tolerances.ASSOCIATION_TOLERANCES`.
    region : radialopt.Region or (lower, upper), optional
        Valid robot positions (a box, metres; a pair of 3-vectors is turned into a Region);
        poses outside it are rejected.  Default :func:`default_region`.
    rng : numpy.random.Generator, optional
        Passed to the position estimator (extra random seeds).
    max_position_3sigma : float
        Metres; a unique pose whose 3-sigma position bound (worst direction) is larger is
        ``"weak"``.
    max_rotation_3sigma : float
        Radians; likewise for the rotation (worst axis).
    solver : str
        How every returned hypothesis' radial problem (the design card's convex problem: its
        Gaussian spheres projected onto their restriction polytope, kept as
        ``AssociationHypothesis.radial``) is solved: ``"active_set"`` (exact, default) or the
        name of an installed cvxpy solver (``"CLARABEL"``, ...), compiled once per sphere count.
        Every hypothesis in ``hypotheses`` carries its solution (None only when its matches
        have fewer than two distinct model positions).
    check : bool
        Verify the radial solutions the pose steps use (those of the validated hypotheses, the
        ones behind an ML fit; with ``method="paper"`` every hypothesis) of at most
        ``radialopt.MAX_VERTEX_SPHERES`` spheres against explicit vertex enumeration (raises
        :class:`~worldgraph.errors.WorldGraphError` from ``radialopt.VerificationError`` on
        disagreement); larger ones are solved unchecked and the message says so (enumeration
        grows combinatorially: 8 spheres take ~20 s).  The other hypotheses' solutions are
        solved by the same solver unchecked, so that ``check=True`` costs one enumeration per
        validated hypothesis, not one per hypothesis.
    certify : bool
        Fill ``certificate``: the rotation SDP's proof (or not) that the returned pose is the
        global minimum of the ML cost of its matched percepts.  With 3 or 4 matches the SDP is
        also the solver (``"ml"``).
    gravity : "auto", (3,) float or None
        Which way is up in the ego frame (:mod:`worldgraph.pose.gravity`).  ``"auto"`` (default): the
        storey-aware gravity search about the ego z axis, within ``tol.tilt_allowance`` (a level
        base); when its answer has no pose, explains fewer than
        :data:`~worldgraph.pose.gravity.MIN_GRAVITY_SUPPORT` (three quarters) of the percepts (its
        matches, or the percepts within the chi-square gate of an object of their type when
        more), or has a pose that tilts the ego z axis beyond the allowance (plus 1 degree), the
        free 3D search answers instead.  A (3,) up vector (an IMU's, in the ego frame): the gravity search
        about it, no fallback; it must point within 90 degrees of the ego +z axis (REP 103: z up),
        else :class:`~worldgraph.errors.WorldGraphError` is raised before any search (a
        gravity vector such as ``[0, 0, -9.81]`` passed for the up vector: pass its negative).
        ``None``: the free 3D search, any tilt.  :attr:`LocalizationResult.search` says which search
        answered.  The paper's method uses no gravity in its search, but its answer is checked
        like the others: with gravity known (``"auto"`` or an up vector), a pose that tilts the
        ego up vector more than :data:`~worldgraph.tolerances.MAX_EGO_TILT` (45 degrees) from
        world up, or, with an up vector given (or ``tol.gravity_aligned=True``), more than
        ``tol.tilt_allowance`` plus :data:`~worldgraph.pose.gravity.TILT_SLACK`, is
        ``"inconsistent"`` with a message naming the likely mistake (percepts in a camera
        frame, OpenCV: z ahead, y down, when world up is the ego -y axis: map them with
        ``perception.KinematicChain.ego_from_camera``).
    up_sigma : float, optional
        Radians: how well gravity fixes the pose's roll and pitch when the gravity search
        answers (``"auto"`` or an up vector; not the free search, not ``method="paper"``).  The
        ML pose (``"ml"``) is then fitted with the tilt as a prior
        (:class:`~worldgraph.pose.gravity.TiltPrior`: the up vector maps to world +z with this
        standard deviation about each horizontal axis), and ``pose_covariance`` carries it, so its
        roll and pitch are no wider than the prior's while yaw and position are the percepts'.
        Default ``tol.tilt_allowance / TILT_PRIOR_SIGMAS`` (5 / 3 = 1.7 degrees): the allowance
        as a 3-sigma bound; pass an IMU's stated accuracy with its up vector, ``math.inf`` for the
        6D fit of the percepts alone.  When the percepts' own tilt contradicts the prior (squared
        Mahalanobis distance above :data:`~worldgraph.pose.gravity.TILT_GATE`, 2 degrees of
        freedom) the 6D fit stands and the gravity checks above judge its tilt.
    settings : LocalizeSettings, optional
        All of the settings above in one checked object (a robot's, made once).  A keyword given
        with a value other than its default replaces that field for this call; one left at its
        default keeps the settings' value (``dataclasses.replace`` sets a field back).

    Returns
    -------
    LocalizationResult
        Never a silently wrong pose: "ok" only for a unique, well-determined pose that passes
        its own chi-square check with at least 3 inliers (9 constrained directions: a
        needle-shaped percept counts 2 of 3) and a tilt that agrees with ``gravity``; otherwise
        the status says why (the best pose is still returned for "ambiguous", "weak",
        "inconsistent" and "outside_region"; NaN when no pose can be determined).

    Raises
    ------
    WorldGraphError
        - The world has no objects.
        - Percepts were given but none has a type of the world.
        - An up vector ``gravity`` more than 90 degrees from the ego +z axis (a gravity vector).
        - Unknown method, something other than Percepts, a bad region or bound.
    radialopt.VerificationError
        ``check=True`` and a radial solution disagrees with the vertex-enumeration reference (a
        solver fault, not bad input: it is not converted into a :class:`WorldGraphError`).
    """
    t_start = time.perf_counter()
    settings = settings_of(settings, method=method, tol=tol, region=region,
                           max_position_3sigma=max_position_3sigma, max_rotation_3sigma=max_rotation_3sigma,
                           solver=solver, check=check, certify=certify, gravity=gravity, up_sigma=up_sigma)
    checked = check_world_and_percepts(world, percepts)
    gen = None if rng is None else generator("rng", rng)
    check_world_scale(world)
    n_used = sum(1 for p in checked if p.type in world.type_index)
    return searched(lambda s, _: [one_search(world, checked, s, gen, t_start)], settings, [n_used])[0]


def searched(run: Callable[[LocalizeSettings, list[int]], list[LocalizationResult]],
             settings: LocalizeSettings, n_used: Sequence[int]) -> list[LocalizationResult]:
    """The answers to ``len(n_used)`` queries of one localisation's ``settings``: the search the
    settings ask for, then, for each query whose gravity pass ``"auto"`` does not keep
    (:func:`gravity_unsupported`), the free 3D search (:func:`answered_by_free_search`), and
    every answer's tilt checked against the gravity given (:func:`tilt_checked`).

    ``run(settings, queries)`` answers the queries numbered ``queries`` with one search each (no
    fall-back of its own): one world, local tiles or a cluster's; ``n_used[q]`` is the number of
    query ``q``'s percepts of the world's types."""
    out = run(settings, list(range(len(n_used))))
    again = []
    for q, res in enumerate(out):
        why = gravity_unsupported(res, settings.plan, settings.tol, settings.method, n_used[q])
        if why:
            again.append((q, why))
    if again:
        free = run(settings.free_search(), [q for q, _ in again])
        for (q, why), res in zip(again, free, strict=True):
            out[q] = answered_by_free_search(res, out[q], why)
    return [tilt_checked(r, settings.plan, settings.tol) for r in out]


def one_search(world: WorldModel, percepts: list[Percept], settings: LocalizeSettings,
               rng: np.random.Generator | None, t_start: float) -> LocalizationResult:
    """The pipeline's answer from one search (the settings' plan; no fall-back), on checked
    percepts; a success status only with a finite rigid pose (``_sane``)."""
    return _sane(_localize(world, percepts, settings, rng, t_start), len(percepts))


def check_world_scale(world: WorldModel) -> None:
    """WorldGraphError when the world's coordinates are beyond what the fits handle."""
    big = float(np.max(np.abs(world.positions)))
    if not big <= MAX_COORDINATE:
        raise WorldGraphError(f"world positions reach {big:.3g} m; localize handles coordinates up to "
                              f"{MAX_COORDINATE:g} m (shift the world's origin)")


def tilt_checked(result: LocalizationResult, plan: SearchPlan,
                 tol: AssociationTolerances) -> LocalizationResult:
    """``result``, made ``"inconsistent"`` when its pose contradicts the gravity the call was
    given (``tilt_contradiction``; only statuses that trust their
    pose, ``"ok"``, ``"weak"``, ``"ambiguous"``, change; the pose stays for diagnosis)."""
    if result.status not in POSE_STATUSES:
        return result
    why = tilt_contradiction(result.transformation, plan, tol)
    if not why:
        return result
    return replace(result, status="inconsistent", ambiguous=False,
                   message="; ".join(m for m in (why, f"(was {result.status!r})", result.message) if m))


def gravity_unsupported(result: LocalizationResult, plan: SearchPlan, tol: AssociationTolerances, method: str,
                        n_used: int) -> str:
    """Why ``gravity="auto"`` falls back from the gravity pass's ``result`` (of ``n_used``
    percepts of known types) to the free search, "" when it keeps it
    (``unsupported_reason``, with the pass's status)."""
    if not plan.fallback or plan.up is None or method == "paper" or result.search != "gravity":
        return ""
    if result.status == "too_few_percepts":
        return ""  # the free search has no more percepts
    # support: the percepts the pose explains (chi-square inliers of the answer, whether or not
    # its fit rests on them: a percept between two neighbouring objects of its type is explained
    # but not matched), at least its matches
    explained = int(np.count_nonzero(result.residuals ** 2 <= CHI2_3_GATE))
    support = max(len(result.correspondences), explained)
    why = unsupported_reason(result.transformation, support, n_used, plan.up, tol)
    return f"{why} ({result.status})" if why else ""


def answered_by_free_search(free: LocalizationResult, gravity_pass: LocalizationResult, why: str
                            ) -> LocalizationResult:
    """The free search's answer, its message saying why the gravity pass was not kept and its
    timings holding the gravity pass's total as ``"gravity_pass"``."""
    note = f"gravity search: {why}; answered by the free 3D search"
    timings = dict(free.timings)
    timings["gravity_pass"] = gravity_pass.timings.get("total", math.nan)
    return replace(free, message="; ".join(m for m in (note, free.message) if m), timings=timings)


def _sane(result: LocalizationResult, n: int) -> LocalizationResult:
    """A success status only with a finite rigid pose and covariance; a listed status; no pose
    with a status that keeps none (``_POSELESS_STATUSES``: a
    pose that broke down here, e.g. "weak" with an infinite covariance, is not returned as a
    finite transformation under "degenerate")."""
    status = result.status
    if status not in LOCALIZE_STATUSES:
        note = f"{result.message}; internal status {status!r} is not a localisation status"
        result = replace(result, status="degenerate", message=note.lstrip("; "))
    elif status in POSE_STATUSES:
        T = result.transformation
        finite = bool(np.all(np.isfinite(T)) and np.all(np.isfinite(result.pose_covariance))
                      and np.all(np.isfinite(result.covariance)))
        rigid = finite and bool(np.allclose(T[:3, :3].T @ T[:3, :3], np.eye(3), atol=RIGID_TOLERANCE)
                                and np.linalg.det(T[:3, :3]) > 0)
        if not rigid:
            why = "non-finite pose or covariance" if not finite else "a pose that is not rigid"
            note = f"numerical breakdown: {why}"
            result = replace(result, status="degenerate", ambiguous=False,
                             message="; ".join(m for m in (result.message, note) if m))
    if result.status in _POSELESS_STATUSES and not np.all(np.isnan(result.transformation)):
        return _without_pose(result)
    return result


#: ``localize`` notes unfused percepts when at least this many are given, none fused
#: (``views == 1``), and at least :data:`UNFUSED_FRACTION` of them have a percept of their type
#: within 3 sigma (of the pair's combined range sigmas): the same object seen in several views.
UNFUSED_MIN_PERCEPTS = 4
#: The share of percepts with a close percept of their type that makes ``localize`` note them.
UNFUSED_FRACTION = 0.25


def unfused_hint(percepts: Sequence[Percept]) -> str | None:
    """A sentence for the message when percepts look like the raw per-view percepts of a scan
    rather than one per object (:data:`UNFUSED_MIN_PERCEPTS`, :data:`UNFUSED_FRACTION`), or
    ``None``."""
    if len(percepts) < UNFUSED_MIN_PERCEPTS or any(p.views > 1 for p in percepts):
        return None
    from scipy.spatial import cKDTree

    types = np.array([p.type for p in percepts])
    pos = np.array([p.position for p in percepts], dtype=np.float64)
    sig = np.array([p.sigma for p in percepts], dtype=np.float64)
    close = np.zeros(len(percepts), dtype=bool)
    for t in np.unique(types):
        idx = np.flatnonzero(types == t)
        if idx.size < 2:
            continue
        tree = cKDTree(pos[idx])
        reach = 3.0 * math.sqrt(2.0) * float(sig[idx].max())
        for a, b in tree.query_pairs(reach, output_type="ndarray"):
            i, j = idx[a], idx[b]
            if np.linalg.norm(pos[i] - pos[j]) <= 3.0 * math.hypot(sig[i], sig[j]):
                close[i] = close[j] = True
    if close.mean() < UNFUSED_FRACTION:
        return None
    return (f"{int(close.sum())} of {len(percepts)} percepts have a percept of their type within 3 sigma and "
            "none is fused (views == 1): these look like the raw percepts of several views; fuse them first "
            "(perception.fuse_percepts), or one object counts several times and the covariance is too small")


def _units_hints(world: WorldModel, used: list[Percept]) -> list[str]:
    """Sentences for the message when positions look like millimetres (docs/design.md#units)."""
    hint = units_hint(world, used)
    return [hint] if hint else []


def _localize(world: WorldModel, percepts: list[Percept], settings: LocalizeSettings,
              rng: np.random.Generator | None, t_start: float) -> LocalizationResult:
    """The pipeline on checked arguments: known percepts, association, measurements, then the
    validated pose (or the paper's)."""
    call = _known_percepts_step(world, percepts, settings, rng, t_start)
    need = max(3, settings.tol.min_clique_size)
    if len(call.used) < need:
        return call.failed("too_few_percepts", f"localisation needs at least {need} percepts of known types, "
                           f"got {len(call.used)}")
    search: SearchKind = "free" if settings.method == "paper" else settings.plan.search
    hyps_local = _associate_step(call)
    if not hyps_local:
        return replace(call.failed("no_association",
                                   "no consistent association of >= 3 percepts with the world model"),
                       search=search)
    ctx = _measurement_step(call)
    if settings.method == "paper":
        return _paper(ctx, hyps_local)
    return replace(_validated(ctx, hyps_local), search=search)


def _known_percepts_step(world: WorldModel, percepts: list[Percept], settings: LocalizeSettings,
                         rng: np.random.Generator | None, t_start: float) -> _Call:
    """Step 2: the percepts of types the world has (the others are named in a note)."""
    known = np.array([p.type in world.type_index for p in percepts], dtype=bool)
    unknown = sorted({p.type for p, ok in zip(percepts, known, strict=True) if not ok})
    if percepts and not known.any():
        raise WorldGraphError(f"no percept type is in the world model: percept types {unknown}, "
                              f"world types {list(world.type_index)}")
    notes = [f"ignored {int((~known).sum())} percept(s) of unknown type(s) {unknown}"] if unknown else []
    idx = np.flatnonzero(known)
    used = [percepts[i] for i in idx]
    notes += _units_hints(world, used)
    raw = unfused_hint(used)
    notes += [raw] if raw else []
    timings = {"association": 0.0, "validation": 0.0, "radial": 0.0, "position": 0.0, "orientation": 0.0}
    return _Call(world, settings, rng, used, idx, len(percepts), notes, timings, t_start)


def _associate_step(call: _Call) -> list[AssociationHypothesis]:
    """Step 3: association hypotheses (the paper's filters for ``"paper"``, else typed cliques)."""
    t0 = time.perf_counter()
    tol = call.settings.tol
    how = "paper" if call.settings.method == "paper" else "clique"
    hyps = associate_searched(call.world, call.used, tol, how,
                              max(int(tol.max_hypotheses), ASSOCIATION_CANDIDATES), call.settings.plan)
    call.timings["association"] = time.perf_counter() - t0
    return hyps


def _measurement_step(call: _Call) -> _Context:
    """Step 4: the region (the caller's or :func:`default_region`) and the percepts' positions,
    covariances and nearest same-type objects, shared by the steps after it."""
    given = call.settings.region
    explicit = given is not None
    region = given if given is not None else default_region(call.world, call.used)
    ego = np.array([p.position for p in call.used])
    covs = percept_covariances(call.used)
    nearest = NearestObjects(call.world, [p.type for p in call.used])
    return _Context(**{f.name: getattr(call, f.name) for f in fields(_Call)}, region=region,
                    explicit_region=explicit, ego=ego, covs=covs, nearest=nearest,
                    ranges=np.array([p.range for p in call.used], dtype=np.float64),
                    sigmas=np.array([p.sigma for p in call.used], dtype=np.float64),
                    false_costs=false_percept_costs(ego, covs))
