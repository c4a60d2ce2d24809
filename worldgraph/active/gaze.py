"""Pointing the head: the joint angles that aim the left camera's optical axis at an ego point."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from perception import KinematicChain

from .._checks import real_array
from ..errors import WorldGraphError
from ..tolerances import (
    AIM_LSQ_TOL,
    AIM_REGULARISATION,
    JOINT_LIMIT_MARGIN,
    NORM_FLOOR,
)

#: Largest pointing error (rad) of the head's optical axis at which ``gaze_reached`` is True.
GAZE_TOLERANCE = math.radians(1.0)



def _gaze_fk(head: KinematicChain, q: NDArray[np.float64]) -> NDArray[np.float64]:
    """``ego_from_camera`` of the left camera for the serial angles q (plain numpy)."""
    M = np.array(head.ego_from_base, dtype=np.float64)
    for joint, angle in zip(head.joints, q, strict=True):
        c, s = math.cos(angle), math.sin(angle)
        i = "xyz".index(joint.axis)
        j, k = (i + 1) % 3, (i + 2) % 3
        rot = np.eye(4)
        rot[j, j], rot[j, k], rot[k, j], rot[k, k] = c, -s, s, c
        M = M @ joint.origin @ rot
    return M @ head.tip_from_camera


def _check_limits(head: KinematicChain, joint_limits: object) -> tuple[NDArray, NDArray] | None:
    """``(lower, upper)`` of the serial joints: the chain's own limits narrowed by ``joint_limits``;
    None when neither gives any."""
    n = len(head.joints)
    own_lo, own_hi = head.limits[:n].T
    if joint_limits is None:
        if np.all(np.isinf(own_lo)) and np.all(np.isinf(own_hi)):
            return None
        return own_lo.copy(), own_hi.copy()
    if not isinstance(joint_limits, Mapping):
        raise WorldGraphError(f"joint_limits must be a mapping joint name -> (lower, upper) radians, got "
                              f"{type(joint_limits).__name__}")
    names = [j.name for j in head.joints]
    unknown = sorted(set(joint_limits) - set(head.names))
    if unknown:
        raise WorldGraphError(f"joint_limits names unknown joints {unknown}; the head has "
                              f"{list(head.names)}")
    lo = np.full(len(names), -np.inf)
    hi = np.full(len(names), np.inf)
    for i, name in enumerate(names):
        if name in joint_limits:
            pair = real_array(f"joint_limits[{name!r}]", joint_limits[name], (2,))
            if not pair[0] < pair[1]:
                raise WorldGraphError(f"joint_limits[{name!r}] must be (lower, upper) with lower < upper, "
                                      f"got {pair.tolist()}")
            lo[i], hi[i] = pair
            if not max(lo[i], own_lo[i]) <= min(hi[i], own_hi[i]):
                raise WorldGraphError(f"joint_limits[{name!r}] = {pair.tolist()} does not meet the joint's "
                                      f"own limits {[float(own_lo[i]), float(own_hi[i])]}")
    return np.maximum(lo, own_lo), np.minimum(hi, own_hi)


def gaze_angles(head: KinematicChain, target: object, *, joint_limits: Mapping[str, Any] | None = None
                ) -> tuple[NDArray[np.float64], float, bool | None]:
    """Joint angles pointing the left camera's optical axis at an ego point.

    The optical axis is +z of the OpenCV left camera frame, ``head.ego_from_camera(q)[:3, 2]``;
    the angles minimise ``|axis(q) - unit(target - centre(q))|^2 + 1e-6 |q|^2`` (the small
    term picks the solution nearest the zero pose) by bounded least squares from a few starts
    (zero; the first yaw joint at the target's azimuth with the next pitch joint at its
    elevation).

    Parameters
    ----------
    head : perception.KinematicChain
    target : (3,) float
        Ego point (m).
    joint_limits : mapping joint name -> (lower, upper), optional
        Radians; they narrow the chain's own limits (``head.limits``, e.g. from a URDF), and
        joints named in neither are free.

    Returns
    -------
    angles : (n_joints,) float
        In ``head.names`` order (the right eye parallel to the left).
    pointing_error : float
        Angle (rad) between the optical axis and the ray from the camera centre to ``target``,
        measured with ``head.ego_from_camera``.
    within_limits : bool or None
        None when no limits were given.
    """
    if not isinstance(head, KinematicChain):
        raise WorldGraphError(f"head must be a perception.KinematicChain, got {type(head).__name__}")
    tgt = real_array("target", target, (3,), max_abs=1e6)
    bounds = _check_limits(head, joint_limits)
    n = len(head.joints)
    lo, hi = bounds if bounds is not None else (np.full(n, -np.inf), np.full(n, np.inf))

    def residual(q: NDArray[np.float64]) -> NDArray[np.float64]:
        M = _gaze_fk(head, q)
        ray = tgt - M[:3, 3]
        norm = np.linalg.norm(ray)
        return np.concatenate([M[:3, 2] - ray / max(float(norm), NORM_FLOOR), AIM_REGULARISATION * q])

    starts = [np.zeros(n)]
    axes = [j.axis for j in head.joints]
    if "z" in axes:
        iz = axes.index("z")
        q0 = np.zeros(n)
        q0[iz] = math.atan2(tgt[1], tgt[0])
        if "y" in axes[iz + 1:]:
            iy = iz + 1 + axes[iz + 1:].index("y")
            q0[iy] = -math.atan2(tgt[2], math.hypot(tgt[0], tgt[1]))
        starts.insert(0, q0)
    best_q, best_err = None, math.inf
    for q0 in starts:
        q0 = np.clip(q0, np.where(np.isfinite(lo), lo + JOINT_LIMIT_MARGIN, -np.inf),
                     np.where(np.isfinite(hi), hi - JOINT_LIMIT_MARGIN, np.inf))
        sol = least_squares(residual, q0, bounds=(lo, hi), xtol=AIM_LSQ_TOL, ftol=AIM_LSQ_TOL,
                            gtol=AIM_LSQ_TOL)
        q = sol.x
        M = head.ego_from_camera(q)
        ray = tgt - M[:3, 3]
        cosang = float(M[:3, 2] @ ray / max(float(np.linalg.norm(ray)), NORM_FLOOR))
        err = math.acos(min(1.0, max(-1.0, cosang)))
        if err < best_err:
            best_q, best_err = q, err
        if best_err < 0.01 * GAZE_TOLERANCE:  # good enough: skip the other starts
            break
    assert best_q is not None
    within = None if bounds is None else bool(np.all((best_q >= lo - JOINT_LIMIT_MARGIN)
                                                      & (best_q <= hi + JOINT_LIMIT_MARGIN)))
    return head.angle_vector(np.clip(best_q, lo, hi)), best_err, within


