"""Reading a URDF file's joint path (through the optional yourdfpy) for
:meth:`perception.KinematicChain.from_urdf`: plain data, no chain (so that :mod:`perception.head.chain`
reads URDF files without an import cycle; :mod:`perception.head.urdf` keeps the public function).

The URDF's joint tree is walked from the camera link up to the base link; the joints on that
path, from the base down, become the chain's joints. Revolute and continuous joints are kept,
fixed joints are folded into the next transform.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._checks import check_transform, file_path, name_string
from ..errors import MissingExtraError, RobotFileError
from ..tolerances import AXIS_TOL

_REVOLUTE = ("revolute", "continuous")


def _load(path: Path) -> Any:
    """The yourdfpy robot of ``path``, without meshes or scene graph."""
    try:
        import yourdfpy
    except ImportError as exc:
        raise MissingExtraError(
            "KinematicChain.from_urdf needs yourdfpy: pip install gaussian-spheres[urdf]"
        ) from exc
    if not path.is_file():
        raise RobotFileError(f"URDF file path={str(path)!r} does not exist")
    try:
        urdf = yourdfpy.URDF.load(
            str(path),
            build_scene_graph=False,
            build_collision_scene_graph=False,
            load_meshes=False,
            load_collision_meshes=False,
        )
    except Exception as exc:  # lxml, yourdfpy and OS errors alike: the file is not a usable URDF
        raise RobotFileError(f"URDF file path={str(path)!r} cannot be read: {type(exc).__name__}: "
                             f"{str(exc)[:300]}") from exc
    return urdf.robot


def _path_joints(robot: Any, base_link: str, camera_link: str, where: str) -> list[Any]:
    """The URDF joints from ``base_link`` down to ``camera_link``, base first."""
    links = [link.name for link in robot.links]
    for arg, name in (("base_link", base_link), ("camera_link", camera_link)):
        if name not in links:
            shown = ", ".join(repr(n) for n in sorted(links)[:40])
            more = f", ... ({len(links)} links)" if len(links) > 40 else ""
            raise RobotFileError(f"{arg} {name!r} is not a link of {where}; its links: {shown}{more}")
    parent_joint = {joint.child: joint for joint in robot.joints}
    path: list[Any] = []
    ancestors = [camera_link]
    link = camera_link
    while link != base_link:
        joint = parent_joint.get(link)
        if joint is None or joint.parent in ancestors:
            raise RobotFileError(
                f"no path from base_link {base_link!r} down to camera_link {camera_link!r} in {where}: "
                f"camera_link's ancestors are {ancestors[1:]} (base_link must be one of them)"
            )
        path.append(joint)
        link = joint.parent
        ancestors.append(link)
    return path[::-1]


def _axis_frame(joint_name: str, index: int, axis: Any) -> tuple[str, NDArray[np.float64]]:
    """The frame axis ``'x'``, ``'y'`` or ``'z'`` closest to the URDF ``axis``, and the rotation
    ``A`` (4x4) that takes it onto the axis: ``Rot(axis, q) = A @ Rot(letter, q) @ A^T``."""
    a = np.asarray([1.0, 0.0, 0.0] if axis is None else axis, dtype=np.float64).reshape(-1)
    norm = float(np.linalg.norm(a)) if a.shape == (3,) and np.all(np.isfinite(a)) else 0.0
    if norm == 0.0:
        raise RobotFileError(f"joint {joint_name!r} (index {index} on the path): axis must be a finite "
                             f"non-zero 3-vector, got {a.tolist()}")
    a = a / norm
    i = int(np.argmax(np.abs(a)))
    e = np.zeros(3)
    e[i] = 1.0
    A = np.eye(4)
    c = float(e @ a)
    if c > 1.0 - AXIS_TOL:
        return "xyz"[i], A
    if c < -1.0 + AXIS_TOL:
        # half turn about the next frame axis: e -> -e
        k = (i + 1) % 3
        A[:3, :3] = -np.eye(3)
        A[k, k] = 1.0
        return "xyz"[i], A
    # Rodrigues: the rotation about e x a that takes e onto a
    v = np.cross(e, a)
    V = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    A[:3, :3] = np.eye(3) + V + V @ V / (1.0 + c)
    return "xyz"[i], A


def _limits(joint: Any, index: int) -> tuple[float | None, float | None]:
    """``(lower, upper)`` of a revolute URDF joint (None where the URDF gives none)."""
    if joint.type == "continuous" or joint.limit is None:
        return None, None
    lower = None if joint.limit.lower is None else float(joint.limit.lower)
    upper = None if joint.limit.upper is None else float(joint.limit.upper)
    for side, value in (("lower", lower), ("upper", upper)):
        if value is not None and not np.isfinite(value):
            raise RobotFileError(f"joint {joint.name!r} (index {index} on the path): {side} limit must be "
                                 f"finite, got {value!r}")
    return lower, upper


#: One revolute joint of the path: name, frame axis letter, origin (4x4, with the fixed joints
#: before it and the axis rotation folded in), lower and upper limits (None: none), index on the
#: path.
JointSpec = tuple[str, str, NDArray[np.float64], "float | None", "float | None", int]


def urdf_joint_specs(
    path: str | os.PathLike[str],
    base_link: str,
    camera_link: str,
    link_from_camera: ArrayLike,
) -> tuple[list[JointSpec], NDArray[np.float64], str]:
    """The revolute joints of a URDF robot from ``base_link`` down to ``camera_link``, the tip's
    ``tip_from_camera`` and a description of the file for messages.

    See :meth:`perception.KinematicChain.from_urdf` (the public entry point) for the parameters
    and the errors.
    """
    file = Path(file_path("path", path, RobotFileError))
    base_link = name_string("base_link", base_link, RobotFileError)
    camera_link = name_string("camera_link", camera_link, RobotFileError)
    camera = check_transform("link_from_camera", link_from_camera)
    where = f"the URDF path={str(file)!r}"
    robot = _load(file)
    path_joints = _path_joints(robot, base_link, camera_link, where)
    specs: list[JointSpec] = []
    pending = np.eye(4)  # fixed transform not yet given to a joint
    for index, urdf_joint in enumerate(path_joints):
        origin = np.eye(4) if urdf_joint.origin is None else np.asarray(urdf_joint.origin, dtype=np.float64)
        origin = check_transform(f"origin of URDF joint {urdf_joint.name!r} (index {index} on the path)",
                                 origin)
        if urdf_joint.type == "fixed":
            pending = pending @ origin
            continue
        if urdf_joint.type not in _REVOLUTE:
            raise RobotFileError(
                f"joint {urdf_joint.name!r} (index {index} on the path from {base_link!r} to "
                f"{camera_link!r}) is {urdf_joint.type!r}: a KinematicChain holds revolute, continuous "
                "and fixed joints only"
            )
        if urdf_joint.mimic is not None:
            raise RobotFileError(
                f"joint {urdf_joint.name!r} (index {index} on the path) mimics joint "
                f"{urdf_joint.mimic.joint!r}: mimic joints are not supported; give it its own angle "
                "(remove the <mimic> element)"
            )
        letter, A = _axis_frame(urdf_joint.name, index, urdf_joint.axis)
        lower, upper = _limits(urdf_joint, index)
        specs.append((urdf_joint.name, letter, pending @ origin @ A, lower, upper, index))
        pending = A.T
    if not specs:
        raise RobotFileError(
            f"no revolute joint between base_link {base_link!r} and camera_link {camera_link!r} in "
            f"{where} (joints on the path: {[j.name for j in path_joints]})"
        )
    return specs, pending @ camera, where
