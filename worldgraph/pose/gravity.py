"""Gravity as a per-call fact: which way is up in the robot's ego frame, and which search answers.

Every entry point that associates percepts (:func:`~worldgraph.association.matching`,
:func:`~worldgraph.localize`, :func:`~worldgraph.active.active_localize`,
:func:`~worldgraph.tiles.localize_tiled`) takes ``gravity``:

``"auto"`` (default)
    The ego z axis is up within ``AssociationTolerances.tilt_allowance`` (a level base, REP 103):
    the *gravity search* compares the horizontal distance and the height difference of percept
    pairs separately (storeys drop out; the gates are widened by what a tilt up to the allowance
    can change, :func:`tilt_widening`).  When that pass finds no answer with enough support
    (it explains fewer than :data:`MIN_GRAVITY_SUPPORT` of the percepts, or no pose at all) or its
    pose tilts the ego z axis beyond the allowance (plus :data:`TILT_SLACK`), the *free search*
    (3D distances only, any rotation) answers instead.
a (3,) up vector in the ego frame
    From an IMU: the percepts are levelled (rotated so that this vector is z) for the gravity
    search, and the poses returned are of the ego frame as given: a tilted head or base still
    gets the storey-aware search.  No fallback.  The ego frame is z up (REP 103), so an up vector
    more than 90 degrees from the ego +z axis is refused
    (:class:`~worldgraph.errors.WorldGraphError`): it is a gravity vector (pointing down)
    passed where the up vector is meant; an accelerometer at rest reads +9.81 m/s^2 along up,
    so its raw reading is the up vector, and a gravity vector's negative is.
``None``
    The free 3D search.

With gravity known (``"auto"`` or an up vector), :func:`~worldgraph.localize` gives no
success (``"inconsistent"``, the message naming the likely mistake, e.g. percepts in a camera
frame) for a pose that tilts the ego up vector more than
:data:`~worldgraph.tolerances.MAX_EGO_TILT` (45 degrees) from world up, or, with an explicit up
vector, more than ``tilt_allowance`` plus :data:`TILT_SLACK` (``tilt_contradiction``).

The result says which search answered (``LocalizationResult.search``,
``AssociationHypothesis.search``).  ``AssociationTolerances.gravity_aligned`` (when not None)
still decides for ``"auto"``, as before: ``True`` is the gravity search about the ego z axis
without fallback, ``False`` the free search.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from perception import Percept

from .._checks import real_array
from ..errors import WorldGraphError
from ..tolerances import LEVEL_TOLERANCE, MAX_EGO_TILT, MIN_UP_NORM, TINY, AssociationTolerances

__all__ = ["GRAVITY_MODES", "MIN_GRAVITY_SUPPORT", "TILT_GATE", "TILT_PRIOR_SIGMAS", "TILT_SLACK", "Gravity",
           "SearchKind", "TiltPrior", "level_rotation", "tilt_angle", "tilt_widening"]

#: What ``gravity`` may be: ``"auto"``, a (3,) up vector in the ego frame, or ``None``.
Gravity = Literal["auto"] | ArrayLike | None
#: Which search answered: the storey-aware ``"gravity"`` search or the ``"free"`` 3D search.
SearchKind = Literal["gravity", "free"]
#: The string modes of ``gravity``.
GRAVITY_MODES = ("auto",)
#: ``gravity="auto"`` keeps the gravity pass's answer only when the percepts it explains (for
#: ``localize``: its matches, or more when more percepts lie within the 3-dof chi-square gate of
#: an object of their type, as a percept between two neighbouring objects does; for
#: ``associate``: the best hypothesis' inliers) are at least this
#: fraction of the percepts of known types (rounded up; and at least ``min_clique_size``): a
#: robot tilted beyond the allowance breaks most pair gates, so the gravity pass then explains
#: few percepts, while a level one explains all but its false percepts
#: (docs/design.md#defaults).
MIN_GRAVITY_SUPPORT = 0.75
#: ... and when its pose tilts the ego up vector at most ``tilt_allowance`` plus this (rad) from
#: the world z axis: the fitted rotation's own error (a pose from 3-8 percepts a few metres away
#: is good to a fraction of a degree).
TILT_SLACK = math.radians(1.0)

#: The tilt prior of the pose fit takes ``tilt_allowance`` as this many standard deviations of
#: the tilt about each horizontal axis (``up_sigma=None``): a level base's tilt, or an IMU's error,
#: stays inside the allowance with probability ``1 - exp(-9 / 2)`` (98.9 %, a 2D normal).
TILT_PRIOR_SIGMAS = 3.0
#: The tilt the percepts alone give, against the prior: when the squared Mahalanobis distance
#: between the two (2 degrees of freedom) exceeds this 3-sigma gate (probability 0.9973), the
#: percepts contradict gravity (a robot on a ramp, or a wrong up vector) and the fit is not an
#: answer of the gravity search.
TILT_GATE = float(-2.0 * math.log(1.0 - 0.9973002039))

#: The smallest default tilt prior (rad): a ``tilt_allowance`` of 0 asks for a level search, not
#: for a pose whose roll and pitch are known exactly.
MIN_TILT_SD = math.radians(0.1)

_EZ = np.array([0.0, 0.0, 1.0])


def check_up_sigma(up_sigma: object, tol: AssociationTolerances) -> float:
    """The tilt prior's standard deviation (rad) of a call: ``up_sigma``, or by default
    ``tol.tilt_allowance / TILT_PRIOR_SIGMAS`` (at least :data:`MIN_TILT_SD`); ``inf``: no prior."""
    if up_sigma is None:
        return max(tol.tilt_allowance / TILT_PRIOR_SIGMAS, MIN_TILT_SD)
    real = int | float | np.integer | np.floating
    if isinstance(up_sigma, bool | np.bool_) or not isinstance(up_sigma, real):
        raise WorldGraphError(f"up_sigma must be a float (radians), math.inf or None, got {up_sigma!r}")
    value = float(up_sigma)
    if not value > 0.0:
        raise WorldGraphError(f"up_sigma = {up_sigma!r} must be > 0 (radians; math.inf: no tilt prior)")
    if math.isfinite(value) and value > math.pi:
        raise WorldGraphError(f"up_sigma = {up_sigma!r} is an angle in radians and must be <= pi (or "
                              f"math.inf); did you mean degrees? np.radians({value:g}) = "
                              f"{math.radians(value):.4g}")
    return value


def _check_tilt_prior(tilt_prior: object) -> TiltPrior | None:
    """``tilt_prior`` when it is a :class:`TiltPrior` or None, else WorldGraphError."""
    if tilt_prior is not None and not isinstance(tilt_prior, TiltPrior):
        raise WorldGraphError(f"tilt_prior must be a TiltPrior or None, got {type(tilt_prior).__name__}")
    return tilt_prior


@dataclass(frozen=True)
class TiltPrior:
    """Gravity in the pose fit: the ego up vector ``up`` maps to the world +z axis up to an error
    of ``sd`` radians about each horizontal world axis (roll and pitch; yaw is free).

    The prior is a pseudo-measurement of the horizontal part of ``a = R up`` (zero for a level
    pose): residual ``a_xy / sd`` (2,), so a tilt ``theta`` costs ``sin(theta)^2 / sd^2``.  With the
    rotation perturbed on the left, ``R <- exp(dtheta) R`` (world axes), ``da = -skew(a) dtheta``;
    its information adds ``1 / sd^2`` to the roll and pitch of a level pose and nothing to its yaw.

    Attributes
    ----------
    up : (3,) float
        Unit up vector in the ego frame (``(0, 0, 1)`` for ``gravity="auto"``, an IMU's otherwise).
    sd : float
        Radians, > 0 and finite.
    """

    up: NDArray[np.float64]
    sd: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "up", _unit_up(self.up, "TiltPrior.up"))
        sd = float(self.sd) if isinstance(self.sd, int | float | np.floating | np.integer) else math.nan
        if isinstance(self.sd, bool | np.bool_) or not 0.0 < sd < math.inf:
            raise WorldGraphError(f"TiltPrior.sd must be a finite angle > 0 (radians), got {self.sd!r}")
        object.__setattr__(self, "sd", sd)

    def residual(self, rotation: NDArray[np.float64]) -> NDArray[np.float64]:
        """``(R up)_xy / sd``, (2,), for the rotation block ``R`` of ``world_from_ego``."""
        return (rotation @ self.up)[:2] / self.sd

    def jacobian(self, rotation: NDArray[np.float64]) -> NDArray[np.float64]:
        """(2, 3) derivative of :meth:`residual` by the left rotation vector (world axes)."""
        a = rotation @ self.up
        # -skew(a), first two rows
        return np.array([[0.0, a[2], -a[1]], [-a[2], 0.0, a[0]]]) / self.sd

    def cost(self, rotation: NDArray[np.float64]) -> float:
        """The prior's share of the ML cost, ``|residual|^2``."""
        r = self.residual(rotation)
        return float(r @ r)

    def information(self, rotation: NDArray[np.float64]) -> NDArray[np.float64]:
        """(6, 6) Fisher information of the prior in the ``(dtheta, dt)`` order of
        :func:`~worldgraph.pose.pose_information` (zero outside the rotation block)."""
        J = self.jacobian(rotation)
        out = np.zeros((6, 6))
        out[:3, :3] = J.T @ J
        return out


@dataclass(frozen=True)
class SearchPlan:
    """One call's search: ``up`` the unit up vector in the ego frame (None: the free search),
    ``level`` the rotation that takes ego vectors into the levelled frame (None: identity), and
    whether ``"auto"`` may fall back to the free search."""

    up: NDArray[np.float64] | None
    level: NDArray[np.float64] | None
    fallback: bool

    @property
    def search(self) -> SearchKind:
        return "free" if self.up is None else "gravity"


FREE_SEARCH = SearchPlan(None, None, False)


def level_rotation(up: ArrayLike) -> NDArray[np.float64]:
    """The smallest rotation ``L`` with ``L @ up / |up| = (0, 0, 1)``.

    Parameters
    ----------
    up : (3,) float
        The up direction in the ego frame (any length > 0).

    Returns
    -------
    (3, 3) float
        A proper rotation matrix (the identity when ``up`` is already z).

    Raises
    ------
    WorldGraphError
        ``up`` has a zero or non-finite length.
    """
    u = _unit_up(up)
    c = float(u[2])
    axis = np.cross(u, _EZ)
    s = float(np.linalg.norm(axis))
    if s < LEVEL_TOLERANCE:
        if c > 0:
            return np.eye(3)
        return np.diag([1.0, -1.0, -1.0])  # upside down: half a turn about x
    k = axis / s
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + s * kx + (1.0 - c) * (kx @ kx)


def _unit_up(up: object, name: str = "gravity") -> NDArray[np.float64]:
    u = real_array(name, up, (3,), max_abs=1e12)
    n = float(np.linalg.norm(u))
    if not n > MIN_UP_NORM:
        raise WorldGraphError(f"{name} = {u.tolist()} must be a non-zero up vector in the ego frame")
    return u / n


def tilt_angle(world_from_ego: ArrayLike, up: ArrayLike = (0.0, 0.0, 1.0)) -> float:
    """Angle (rad) between the ego frame's up vector, mapped into the world, and the world z axis.

    Parameters
    ----------
    world_from_ego : (4, 4) or (3, 3) float
        A pose (its rotation block is used).
    up : (3,) float
        The up direction in the ego frame (default its z axis).

    Returns
    -------
    float
        In ``[0, pi]``; NaN when the pose is not finite.
    """
    m = np.asarray(world_from_ego, dtype=np.float64)
    if m.shape not in ((4, 4), (3, 3)):
        raise WorldGraphError(f"world_from_ego must have shape (4, 4) or (3, 3), got {m.shape}")
    if not np.all(np.isfinite(m)):
        return math.nan
    z = m[:3, :3] @ _unit_up(up, "up")
    return math.acos(max(-1.0, min(1.0, float(z[2]) / max(float(np.linalg.norm(z)), TINY))))


def tilt_widening(h: float | NDArray, dz: float | NDArray, tilt: float
                  ) -> tuple[float | NDArray, float | NDArray]:
    """How much a tilt of the ego z axis by at most ``tilt`` (rad) can change a vector's
    horizontal length ``h`` and height difference ``dz``: ``(h (1 - cos t) + |dz| sin t,
    h sin t + |dz| (1 - cos t))``, exact bounds (the vector's elevation moves by at most ``t``)."""
    s, c1 = math.sin(tilt), 1.0 - math.cos(tilt)
    adz = np.abs(dz)
    return h * c1 + adz * s, h * s + adz * c1


def check_gravity(gravity: object, tol: AssociationTolerances) -> SearchPlan:
    """The search of a call from its ``gravity`` argument and ``tol.gravity_aligned``."""
    if isinstance(gravity, str):
        if gravity not in GRAVITY_MODES:
            raise WorldGraphError(f"gravity must be 'auto', a (3,) up vector in the ego frame or None, "
                                  f"got {gravity!r}")
        if tol.gravity_aligned is None:
            return SearchPlan(_EZ.copy(), None, True)
        return SearchPlan(_EZ.copy(), None, False) if tol.gravity_aligned else FREE_SEARCH
    if gravity is None:
        return FREE_SEARCH
    if isinstance(gravity, bool | np.bool_):
        raise WorldGraphError(f"gravity must be 'auto', a (3,) up vector in the ego frame or None, "
                              f"got {gravity!r} (True: use 'auto' or (0, 0, 1); False: None)")
    u = _unit_up(gravity)
    if u[2] < 0.0:
        given = real_array("gravity", gravity, (3,))
        angle = math.degrees(math.acos(max(-1.0, min(1.0, float(u[2])))))
        raise WorldGraphError(
            f"gravity = {given.tolist()} points {angle:.0f} deg from the ego +z axis (more than 90): "
            "gravity= wants the up vector in the ego frame (REP 103: z up), and this looks like a gravity "
            f"vector (pointing down); pass its negative, {(-given + 0.0).tolist()} (an accelerometer at "
            "rest reads +9.81 m/s^2 along up, so its raw reading is the up vector); for no gravity "
            "knowledge pass gravity=None"
        )
    level = None if math.hypot(u[0], u[1]) < LEVEL_TOLERANCE and u[2] > 0 else level_rotation(u)
    return SearchPlan(u, level, False)


#: OpenCV camera axes in the ego frame's place: world up is then the camera's -y axis.
_CAMERA_UP = np.array([0.0, -1.0, 0.0])
#: A pose whose ego direction of world up lies within this (rad) of the camera's -y axis looks
#: like percepts in a camera frame.
_CAMERA_LIKE = math.radians(20.0)


def tilt_contradiction(pose: NDArray[np.float64], plan: SearchPlan, tol: AssociationTolerances) -> str:
    """Why a pose contradicts the gravity a call was given ("" when it does not, or when the call
    knows no gravity): it tilts the ego up vector more than
    :data:`~worldgraph.tolerances.MAX_EGO_TILT` from world up (any search of ``"auto"``), or
    more than ``tol.tilt_allowance`` plus :data:`TILT_SLACK` when the up vector was given (or
    ``gravity_aligned=True``: no fallback, so the gravity search's own tilt is its answer's).
    The message names the likely mistake: percepts in a camera frame when world up is the
    ego's -y axis (OpenCV: y down), else the frame of the percepts in general."""
    if plan.up is None or not bool(np.all(np.isfinite(pose))):
        return ""
    limit = MAX_EGO_TILT if plan.fallback else min(MAX_EGO_TILT, tol.tilt_allowance + TILT_SLACK)
    tilt = tilt_angle(pose, plan.up)
    if tilt <= limit:
        return ""
    R = np.asarray(pose, dtype=np.float64)[:3, :3]
    up_in_ego = R.T @ _EZ + 0.0  # no -0.0 in the message
    given = "the ego z axis" if plan.fallback else f"the up vector given ({np.round(plan.up, 3).tolist()})"
    rule = (f"more than {math.degrees(limit):.0f} deg, worldgraph.tolerances.MAX_EGO_TILT" if plan.fallback
            else f"more than tilt_allowance + TILT_SLACK = {math.degrees(limit):.0f} deg")
    head = (f"the best pose tilts {given} {math.degrees(tilt):.0f} deg from world up ({rule}; world up is "
            f"the ego direction {np.round(up_in_ego, 2).tolist()})")
    camera = "map them into the ego frame with ego_from_camera (perception.KinematicChain.ego_from_camera)"
    if math.acos(max(-1.0, min(1.0, float(up_in_ego @ _CAMERA_UP)))) <= _CAMERA_LIKE:
        return (f"the percepts look like a camera frame (OpenCV: z ahead, y down): {head}; {camera}, "
                "or pass gravity=None to accept any tilt")
    return (f"{head}: are the percepts in the ego frame (REP 103: x ahead, y left, z up)? Percepts in a "
            f"camera frame (OpenCV: z ahead, y down) need ego_from_camera: {camera}; a robot that does tilt "
            "this much: pass its up vector (an IMU's) as gravity=, or gravity=None to accept any tilt")


def tolerances_for_plan(plan: SearchPlan, tol: AssociationTolerances) -> AssociationTolerances:
    """``tol`` with ``gravity_aligned`` set to the plan's search."""
    want = plan.up is not None
    return tol if tol.gravity_aligned is want else replace(tol, gravity_aligned=want)


def levelled_percepts(percepts: Sequence[Percept], level: NDArray[np.float64] | None) -> list[Percept]:
    """The percepts rotated by ``level`` (positions, covariances and shared loadings)."""
    if level is None:
        return list(percepts)
    out = []
    for p in percepts:
        cov = None if p.covariance is None else level @ p.covariance @ level.T
        shared = tuple((k, level @ s) for k, s in p.shared)
        out.append(Percept(p.type, level @ p.position, p.sigma, covariance=cov, views=p.views, shared=shared))
    return out


def unlevelled_pose(pose: NDArray[np.float64], level: NDArray[np.float64] | None) -> NDArray[np.float64]:
    """``world_from_level`` as ``world_from_ego``: ``x_level = L x_ego``."""
    if level is None:
        return pose
    out = np.array(pose, dtype=np.float64)
    out[:3, :3] = pose[:3, :3] @ level
    return out


def unsupported_reason(pose: NDArray[np.float64], n_inliers: int, n_used: int, up: NDArray[np.float64],
                       tol: AssociationTolerances) -> str:
    """Why ``gravity="auto"`` does not keep a gravity-pass answer (its pose and the number of
    percepts it explains, of ``n_used``), "" when it does: no pose, fewer explained than
    :data:`MIN_GRAVITY_SUPPORT` of the percepts (and than ``min_clique_size``), or a pose that
    tilts the ego up vector beyond ``tol.tilt_allowance`` plus :data:`TILT_SLACK`.  The one rule
    of :func:`~worldgraph.associate` (on its best hypothesis), :func:`~worldgraph.localize` and
    :func:`~worldgraph.localize_tiled` (on their answers)."""
    if not bool(np.all(np.isfinite(pose))):
        return "no pose"
    if n_inliers < max(int(tol.min_clique_size), math.ceil(MIN_GRAVITY_SUPPORT * n_used)):
        return f"{n_inliers} of {n_used} percepts explained"
    tilt = tilt_angle(pose, up)
    if not tilt <= tol.tilt_allowance + TILT_SLACK:
        allowance = math.degrees(tol.tilt_allowance)
        return (f"a pose tilted {math.degrees(tilt):.1f} deg (allowance {allowance:.1f} deg + "
                f"{math.degrees(TILT_SLACK):.0f} deg slack)")
    return ""
