"""The ego kinematic chain of an active head (paper section 3.2, eqs. 9-10, Fig. 10).

``ego_from_camera(angles)`` maps left-camera coordinates into the ego frame (the head base,
ROS REP 103), i.e. the inverse of the paper's ``M_ego^t = [T(t) N(t) H C_L]^-1``.
Joint-encoder noise propagates to percept covariance through the chain's Jacobian
(space-to-ego uncertainty).
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from .._checks import (
    MAX_TRANSLATION,
    check_transform,
    name_string,
    real_array,
    real_scalar,
    rigid_defect,
    rotation_defect,
    rotation_errors,
    vector3,
)
from ..errors import (
    PerceptionError,
    RobotFileError,
)
from ..tolerances import PSD_ATOL, SYM_RTOL, TINY
from ._urdf import urdf_joint_specs

_AXES = {"x": 0, "y": 1, "z": 2}
MAX_ANGLE = 2.0 * np.pi
"""Largest joint angle magnitude accepted, radians (larger values are almost surely degrees)."""
MAX_ENCODER_SIGMA = 0.5
"""Largest joint-encoder standard deviation accepted, radians (as :func:`perception.simulate_scan`)."""


def _check_angle(joint: str, index: int | None, value: float) -> float:
    if abs(value) > MAX_ANGLE:
        where = "" if index is None else f" (index {index})"
        raise PerceptionError(
            f"angle of joint {joint!r}{where} = {value!r} exceeds 2*pi in magnitude: angles are "
            "radians; did you pass degrees? use np.radians"
        )
    return value


def _check_limits(joint: Joint, index: int | None, value: float) -> float:
    """``value`` if it lies within the joint's limits, else a :class:`PerceptionError`."""
    lower = -np.inf if joint.lower is None else joint.lower
    upper = np.inf if joint.upper is None else joint.upper
    if not lower <= value <= upper:
        where = "" if index is None else f" (index {index})"
        raise PerceptionError(
            f"angle of joint {joint.name!r}{where} = {value!r} lies outside the joint limits "
            f"[{joint.lower!r}, {joint.upper!r}] rad"
        )
    return value


#: The left camera in the OpenCV convention (x right, y down, z ahead) seen from a URDF camera
#: link in the ROS convention (x ahead, y left, z up): the default ``link_from_camera``.
TIP_FROM_OPENCV = np.array(
    [[0.0, 0.0, 1.0, 0.0], [-1.0, 0.0, 0.0, 0.0], [0.0, -1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
)


def rotation(axis: str, angle: float) -> NDArray[np.float64]:
    """4x4 rotation by ``angle`` (radians) about the ``axis`` ('x', 'y' or 'z') of the frame
    (right-handed: a positive angle turns the next axis towards the one after it)."""
    M = np.eye(4)
    M[:3, :3] = Rotation.from_euler("xyz"[_AXES[axis]], angle).as_matrix()
    return M


def translation(x: float, y: float, z: float) -> NDArray[np.float64]:
    """4x4 translation by ``(x, y, z)``."""
    M = np.eye(4)
    M[:3, 3] = (x, y, z)
    return M


@dataclass(frozen=True)
class Joint:
    """A revolute joint.

    Parameters
    ----------
    name : str
        Unique name, used as the key of angle dictionaries.
    axis : {'x', 'y', 'z'}
        Rotation axis in the joint frame.
    origin : (4, 4) float
        ``parent_from_joint`` at zero angle; the joint transform is ``origin @ Rot(axis, q)``.
    lower, upper : float or None, optional
        Joint limits, radians (None: no limit on that side). An angle outside them raises
        :class:`~perception.PerceptionError`.
    """

    name: str
    axis: str
    origin: NDArray[np.float64]
    lower: float | None = None
    upper: float | None = None

    def __post_init__(self) -> None:
        name_string("joint name", self.name)
        if not isinstance(self.axis, str) or self.axis not in _AXES:
            raise PerceptionError(f"joint {self.name!r}: axis must be 'x', 'y' or 'z', got {self.axis!r}")
        M = check_transform(f"origin of joint {self.name!r}", self.origin)
        M.setflags(write=False)
        object.__setattr__(self, "origin", M)
        for side in ("lower", "upper"):
            value = getattr(self, side)
            if value is not None:
                try:
                    value = real_scalar(f"{side} limit of joint {self.name!r}", value)
                except PerceptionError as exc:
                    raise PerceptionError(str(exc)) from exc
                object.__setattr__(self, side, value)
        if self.lower is not None and self.upper is not None and self.lower > self.upper:
            raise PerceptionError(
                f"joint {self.name!r}: lower limit {self.lower!r} exceeds upper limit {self.upper!r}"
            )

    def transform(self, angle: float) -> NDArray[np.float64]:
        """``parent_from_joint`` at ``angle`` (radians, within the joint limits)."""
        q = _check_angle(self.name, None, real_scalar(f"angle of joint {self.name!r}", angle))
        return self.origin @ rotation(self.axis, _check_limits(self, None, q))


@dataclass(frozen=True)
class KinematicChain:
    """A serial chain of revolute joints from the ego frame to the left camera.

    Parameters
    ----------
    joints : sequence of Joint
        Joints from the base to the tip (the left camera's last joint).
    ego_from_base : (4, 4) float
        Fixed pose of the first joint's parent frame in the ego frame.
    tip_from_camera : (4, 4) float
        Fixed pose of the (OpenCV) left camera in the last joint's frame.
    right_eye : Joint, optional
        A sibling of the last joint (same parent) carrying the right camera, whose pose
        in its joint frame is also ``tip_from_camera``. Its angle defaults to the last
        joint's angle (parallel eyes).
    """

    joints: tuple[Joint, ...]
    ego_from_base: NDArray[np.float64]
    tip_from_camera: NDArray[np.float64]
    right_eye: Joint | None = None

    def __post_init__(self) -> None:
        if self.joints is None or isinstance(self.joints, (str, bytes, Joint)):
            raise PerceptionError(f"joints must be a non-empty sequence of Joint, got {self.joints!r}")
        try:
            joints = tuple(self.joints)
        except TypeError as exc:
            raise PerceptionError(
                f"joints must be a non-empty sequence of Joint, got {self.joints!r}"
            ) from exc
        if self.right_eye is not None and not isinstance(self.right_eye, Joint):
            raise PerceptionError(f"right_eye must be a Joint or None, got {type(self.right_eye).__name__}")
        if not joints or not all(isinstance(j, Joint) for j in joints):
            raise PerceptionError(f"joints must be a non-empty sequence of Joint, got {self.joints!r}")
        names = [j.name for j in joints] + ([self.right_eye.name] if self.right_eye is not None else [])
        if len(set(names)) != len(names):
            raise PerceptionError(f"joints (and right_eye): joint names must be unique, got {names}")
        E = check_transform("ego_from_base", self.ego_from_base)
        C = check_transform("tip_from_camera", self.tip_from_camera)
        E.setflags(write=False)
        C.setflags(write=False)
        object.__setattr__(self, "joints", joints)
        object.__setattr__(self, "ego_from_base", E)
        object.__setattr__(self, "tip_from_camera", C)

    @classmethod
    def from_urdf(
        cls,
        path: str | os.PathLike[str],
        base_link: str,
        camera_link: str,
        link_from_camera: ArrayLike = TIP_FROM_OPENCV,
    ) -> KinematicChain:
        """The chain of a URDF robot from ``base_link`` (the ego frame) down to ``camera_link``.

        Needs yourdfpy (``pip install gaussian-spheres[urdf]``). Revolute and continuous joints
        become :class:`Joint` s with the URDF's limits (continuous joints have none); fixed joints
        are folded into the next joint's origin (or, after the last joint, into
        ``tip_from_camera``). A joint axis other than +x, +y or +z is carried by a constant rotation
        folded into the joint's origin and undone in the next transform, so the forward
        kinematics are the URDF's while the joint frames of :meth:`joint_frames` may be turned
        about the axis.

        Parameters
        ----------
        path : str or os.PathLike
            The URDF file (meshes are not loaded).
        base_link : str
            Link whose frame is the ego frame (``ego_from_base`` is the identity).
        camera_link : str
            Link that carries the left camera; it must lie below ``base_link`` in the URDF tree.
        link_from_camera : (4, 4) float, optional
            Pose of the OpenCV camera (x right, y down, z forward) in ``camera_link``'s frame.
            The default :data:`TIP_FROM_OPENCV` suits a camera link that follows ROS REP 103
            (x forward, y left, z up), as the built-in head's eye frames; pass ``np.eye(4)`` for
            an optical frame (z forward).

        Returns
        -------
        KinematicChain
            Without a ``right_eye``; :meth:`ego_from_camera` is ``base_from_camera_link @
            link_from_camera``.

        Raises
        ------
        MissingExtraError
            yourdfpy is not installed.
        RobotFileError
            The file is missing or unreadable, a link is not in it, ``camera_link`` is not below
            ``base_link``, no revolute joint lies between them, or a joint on the way is
            prismatic, planar, floating or a mimic joint.
        """
        specs, tip_from_camera, where = urdf_joint_specs(path, base_link, camera_link, link_from_camera)
        joints: list[Joint] = []
        for name, letter, origin, lower, upper, index in specs:
            try:
                joints.append(Joint(name, letter, origin, lower, upper))
            except PerceptionError as exc:
                raise RobotFileError(f"joint {name!r} (index {index} on the path) of {where}: {exc}") from exc
        return cls(tuple(joints), np.eye(4), tip_from_camera)

    @property
    def names(self) -> tuple[str, ...]:
        """Joint names: the serial joints, then the right eye (if any)."""
        extra = (self.right_eye.name,) if self.right_eye is not None else ()
        return tuple(j.name for j in self.joints) + extra

    @property
    def n_joints(self) -> int:
        """Number of joints (including the right eye)."""
        return len(self.names)

    @property
    def limits(self) -> NDArray[np.float64]:
        """Joint limits in the order of :attr:`names`, shape (n_joints, 2): ``(lower, upper)``
        radians, ``-inf`` / ``inf`` where a joint has no limit."""
        joints = self.joints + ((self.right_eye,) if self.right_eye is not None else ())
        return np.array([[-np.inf if j.lower is None else j.lower, np.inf if j.upper is None else j.upper]
                         for j in joints])

    def angle_vector(self, angles: Mapping[str, float] | ArrayLike) -> NDArray[np.float64]:
        """Angles as a vector in the order of :attr:`names` (the right eye defaults to the left).

        ``angles`` is a dict ``name -> radians`` (every serial joint required) or an array of
        length ``len(joints)`` or ``n_joints``. An angle outside its joint's limits raises
        :class:`~perception.PerceptionError` naming the joint, its index and the angle.
        """
        n = len(self.joints)
        if isinstance(angles, Mapping):
            unknown = sorted(set(angles) - set(self.names))
            if unknown:
                raise PerceptionError(f"unknown joint names {unknown}; known: {list(self.names)}")
            missing = [j.name for j in self.joints if j.name not in angles]
            if missing:
                raise PerceptionError(f"angles lack joints {missing}")
            q = [real_scalar(f"angles[{j.name!r}]", angles[j.name]) for j in self.joints]
            if self.right_eye is not None:
                eye = self.right_eye.name
                q.append(real_scalar(f"angles[{eye!r}]", angles.get(eye, q[-1])))
            vec = np.array(q)
        else:
            vec = real_array("angles", angles)
            if vec.ndim != 1 or vec.size not in (n, self.n_joints):
                raise PerceptionError(
                    f"angles must have shape ({n},) or ({self.n_joints},), got shape {vec.shape}"
                )
            if vec.size < self.n_joints:
                vec = np.append(vec, vec[-1])
        big = np.flatnonzero(np.abs(vec) > MAX_ANGLE)
        if big.size:
            i = int(big[0])
            _check_angle(self.names[i], i, float(vec[i]))
        joints = self.joints + ((self.right_eye,) if self.right_eye is not None else ())
        for i, joint in enumerate(joints):
            _check_limits(joint, i, float(vec[i]))
        return vec

    def joint_frames(self, angles: Mapping[str, float] | ArrayLike) -> NDArray[np.float64]:
        """``ego_from_joint_i`` (after the joint rotation) for every serial joint, shape (n, 4, 4)."""
        q = self.angle_vector(angles)
        n = len(self.joints)
        # every joint's Rot(axis, q_i) in one call (the angles are checked by angle_vector)
        turns = np.zeros((n, 4, 4))
        turns[:, 3, 3] = 1.0
        axes = np.eye(3)[[_AXES[j.axis] for j in self.joints]]
        turns[:, :3, :3] = Rotation.from_rotvec(q[:n, None] * axes).as_matrix()
        out = np.empty((n, 4, 4))
        M = self.ego_from_base
        for i, j in enumerate(self.joints):
            M = M @ (j.origin @ turns[i])
            out[i] = M
        return out

    def ego_from_camera(self, angles: Mapping[str, float] | ArrayLike) -> NDArray[np.float64]:
        """Pose of the left camera in the ego frame: ``ego_from_base @ prod(joint_i(q_i)) @ tip_from_camera``.

        Returns
        -------
        (4, 4) float
        """
        return self.joint_frames(angles)[-1] @ self.tip_from_camera

    def ego_from_right_camera(
        self, angles: Mapping[str, float] | ArrayLike, baseline: float | None = None
    ) -> NDArray[np.float64]:
        """Pose of the right camera in the ego frame.

        With a ``right_eye`` joint the right camera hangs off the last joint's parent; without
        one (or when ``baseline`` is given) it is the left camera moved by ``baseline`` along
        the left camera's x axis.
        """
        if self.right_eye is None or baseline is not None:
            b = 0.093 if baseline is None else real_scalar("baseline", baseline, positive=True)
            return self.ego_from_camera(angles) @ translation(b, 0.0, 0.0)
        q = self.angle_vector(angles)
        frames = self.joint_frames(q)
        parent = frames[-2] if len(self.joints) > 1 else self.ego_from_base
        return parent @ self.right_eye.transform(q[-1]) @ self.tip_from_camera

    def point_jacobian(
        self, angles: Mapping[str, float] | ArrayLike, point_camera: ArrayLike
    ) -> NDArray[np.float64]:
        """Jacobian of the ego-frame position of a left-camera point w.r.t. the joint angles.

        For a revolute joint with ego-frame axis ``a`` through ``p``: ``dX/dq = a x (X - p)``.
        The right eye (if any) does not move the left camera: its column is zero.

        Returns
        -------
        (3, n_joints) float
        """
        x = _vector3("point_camera", point_camera)
        return self.point_jacobians(angles, x[None, :])[0]

    def point_jacobians(
        self, angles: Mapping[str, float] | ArrayLike, points_camera: ArrayLike
    ) -> NDArray[np.float64]:
        """:meth:`point_jacobian` of many left-camera points at one set of angles, at once.

        Parameters
        ----------
        angles
            The joint angles, as for :meth:`point_jacobian`.
        points_camera
            (n, 3) points in the left camera frame.

        Returns
        -------
        (n, 3, n_joints) float
            Entry ``k`` equals ``point_jacobian(angles, points_camera[k])``.

        Raises
        ------
        PerceptionError
            If ``points_camera`` is not a finite (n, 3) array.
        """
        x = real_array("points_camera", points_camera, shape=(None, 3))
        frames = self.joint_frames(angles)
        camera = frames[-1] @ self.tip_from_camera
        X = x @ camera[:3, :3].T + camera[:3, 3]
        J = np.zeros((x.shape[0], 3, self.n_joints))
        for i, j in enumerate(self.joints):
            axis = frames[i][:3, _AXES[j.axis]]
            J[:, :, i] = np.cross(axis, X - frames[i][:3, 3])
        return J


def _vector3(name: str, value: ArrayLike) -> NDArray[np.float64]:
    return vector3(name, value)


def default_head(baseline: float = 0.093) -> KinematicChain:
    """A Karlsruhe-like 7-DoF humanoid head (ARMAR-III-like geometry, made-up offsets).

    Joints (ego = head base, x forward, y left, z up): neck pitch (y), neck roll (x),
    neck yaw (z), head tilt (y), common eye tilt (y), left eye pan (z); the right eye pan (z)
    is a sibling of the left eye pan, ``baseline`` metres to the right. The left camera is the
    chain tip; at zero angles both cameras look along ego +x and the right camera is
    ``baseline`` along the left camera's x axis.
    """
    try:
        baseline = real_scalar("baseline", baseline, positive=True)
    except PerceptionError as exc:
        raise PerceptionError(str(exc)) from exc
    if baseline > MAX_TRANSLATION:
        raise PerceptionError(f"baseline must be at most {MAX_TRANSLATION:g} m, got {baseline!r}")
    half = baseline / 2.0
    joints = (
        Joint("neck_pitch", "y", np.eye(4)),
        Joint("neck_roll", "x", translation(0.0, 0.0, 0.02)),
        Joint("neck_yaw", "z", translation(0.0, 0.0, 0.03)),
        Joint("head_tilt", "y", translation(0.0, 0.0, 0.12)),
        Joint("eye_tilt", "y", translation(0.06, 0.0, 0.08)),
        Joint("left_eye_pan", "z", translation(0.02, half, 0.0)),
    )
    right = Joint("right_eye_pan", "z", translation(0.02, -half, 0.0))
    return KinematicChain(joints, np.eye(4), TIP_FROM_OPENCV.copy(), right_eye=right)


def percept_covariance(
    chain: KinematicChain,
    angles: Mapping[str, float] | ArrayLike,
    point_camera: ArrayLike,
    point_cov_camera: ArrayLike,
    encoder_sigma: float | ArrayLike,
) -> NDArray[np.float64]:
    """Ego-frame covariance of a left-camera point (space-to-ego uncertainty, section 3.2).

    ``R C R^T + J diag(encoder_sigma^2) J^T`` with ``R`` the rotation of ``ego_from_camera``
    and ``J`` the :meth:`KinematicChain.point_jacobian`.

    Parameters
    ----------
    chain : KinematicChain
    angles : dict or (n,) float
        Joint angles, radians.
    point_camera : (3,) float
        The point in the left camera frame.
    point_cov_camera : (3, 3) float
        Its covariance in the left camera frame (e.g. from triangulation).
    encoder_sigma : float or (n_joints,) float
        Standard deviation of each joint encoder, radians (>= 0).

    Returns
    -------
    (3, 3) float
    """
    if not isinstance(chain, KinematicChain):
        raise PerceptionError(f"chain must be a KinematicChain, got {type(chain).__name__}")
    C = real_array("point_cov_camera", point_cov_camera, (3, 3))
    scale = float(np.max(np.abs(C)))
    if float(np.max(np.abs(C / max(scale, TINY) - C.T / max(scale, TINY)))) > SYM_RTOL:
        raise PerceptionError(f"point_cov_camera must be symmetric, got {C.tolist()}")
    if scale > 0:
        low = float(np.linalg.eigvalsh(0.5 * (C / scale) + 0.5 * (C.T / scale))[0])
        if low < -PSD_ATOL:
            raise PerceptionError(
                f"point_cov_camera must be positive semidefinite (smallest eigenvalue {low * scale:.3g}), "
                f"got {C.tolist()}"
            )
    s = real_array("encoder_sigma", encoder_sigma)
    if s.ndim == 0:
        s = np.full(chain.n_joints, float(s))
    if s.shape != (chain.n_joints,):
        raise PerceptionError(f"encoder_sigma must be a scalar or shape ({chain.n_joints},), got shape "
                              f"{s.shape}")
    if not np.all(np.isfinite(s)):
        raise PerceptionError(f"encoder_sigma must be finite, got {s.tolist()}")
    if np.any(s < 0):
        raise PerceptionError(f"encoder_sigma must be >= 0, got {s.tolist()}")
    big = np.flatnonzero(s > MAX_ENCODER_SIGMA)
    if big.size:
        i = int(big[0])
        raise PerceptionError(
            f"encoder_sigma[{i}] = {float(s[i])!r} must lie in [0, {MAX_ENCODER_SIGMA:g}] rad: encoder "
            "noise is in radians; did you pass degrees? use np.radians"
        )
    R = chain.ego_from_camera(angles)[:3, :3]
    J = chain.point_jacobian(angles, point_camera)
    with np.errstate(over="ignore", invalid="ignore"):
        out = R @ C @ R.T + (J * s**2) @ J.T
        out = 0.5 * out + 0.5 * out.T
    if not np.all(np.isfinite(out)):
        raise PerceptionError(
            f"the covariance overflows for point_camera {np.asarray(point_camera).tolist()!r}, "
            f"encoder_sigma {s.tolist()} and point_cov_camera scale {scale!r}"
        )
    return out


__all__: Sequence[str] = [
    "Joint",
    "KinematicChain",
    "TIP_FROM_OPENCV",
    "check_transform",
    "rigid_defect",
    "rotation_defect",
    "rotation_errors",
    "default_head",
    "percept_covariance",
    "rotation",
    "translation",
]
