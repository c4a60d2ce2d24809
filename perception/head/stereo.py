"""A calibrated stereo rig: projection, triangulation and rectification through OpenCV.

Conventions follow OpenCV's ``stereoCalibrate``: a point ``X1`` in the left camera frame is
``X2 = R X1 + T`` in the right camera frame. Camera frames are OpenCV frames (x right, y down,
z forward); pixels are ``(u, v)`` rows of an ``(N, 2)`` array.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._checks import file_path, image_size, real_array, real_scalar, rotation_defect
from ..errors import (
    BehindCameraError,
    PerceptionError,
    RobotFileError,
)
from ..tolerances import RIG_ROUND_TRIP_RTOL, RIGID_TOLERANCE, UNDISTORT_EPS

_DISTORTION_LENGTHS = (0, 4, 5, 8, 12, 14)
MAX_IMAGE_SIDE = 100_000
"""Largest image width or height accepted, pixels."""
MAX_PIXELS = 1e9
"""Largest camera-matrix entry (focal length, principal point), pixels."""
MAX_COORD = 1e150
"""Largest coordinate accepted for points (metres) and pixels."""
MAX_BASELINE = 100.0
"""Largest baseline of :meth:`StereoRig.default`, metres."""
MIN_BASELINE = 1e-6
"""Smallest baseline of :meth:`StereoRig.default`, metres: a micrometre; below it the two cameras
coincide to within rounding and the rig triangulates nothing."""
MAX_DISTORTION = 1e4
"""Largest magnitude of an OpenCV distortion coefficient."""
MAX_FILE_BYTES = 16 * 1024 * 1024
"""Largest calibration file read, bytes."""
MAX_FILE_DEPTH = 64
"""Deepest nesting accepted in a calibration file (``[``/``{`` depth, XML tag depth, YAML
indentation levels); OpenCV's recursive parser overflows its stack on deeply nested input."""

_FILE_KEYS = ("K1", "D1", "K2", "D2", "R", "T", "image_size")
# Iterative undistortion: OpenCV's default (5 iterations) is not enough for strong distortion;
# at most this many iterations, stopping earlier at a step below UNDISTORT_EPS (normalised units).
_UNDISTORT_ITERATIONS = 200


class Rectification(NamedTuple):
    """Output of :meth:`StereoRig.rectify` (``cv2.stereoRectify``).

    Attributes
    ----------
    R1, R2 : (3, 3) float
        Rectifying rotations of the left and right camera.
    P1, P2 : (3, 4) float
        Projection matrices in the rectified frames.
    Q : (4, 4) float
        Disparity-to-depth mapping.
    """

    R1: NDArray[np.float64]
    R2: NDArray[np.float64]
    P1: NDArray[np.float64]
    P2: NDArray[np.float64]
    Q: NDArray[np.float64]


def as_stereo_rig(rig: Any) -> Any:
    """``rig`` itself, which must be a :class:`StereoRig` (a :class:`PerceptionError` names what it is
    otherwise)."""
    if not isinstance(rig, StereoRig):
        raise PerceptionError(f"rig must be a perception.StereoRig, got {type(rig).__name__}")
    return rig


def _matrix(name: str, value: ArrayLike, shape: tuple[int, ...]) -> NDArray[np.float64]:
    return real_array(name, value, shape)


def _distortion(name: str, value: ArrayLike | None) -> NDArray[np.float64]:
    if value is None:
        return np.zeros(0)
    arr = real_array(name, value)
    if arr.ndim == 2 and 1 in arr.shape:
        arr = arr.ravel()
    if arr.ndim != 1 or arr.size not in _DISTORTION_LENGTHS:
        raise PerceptionError(
            f"{name} must hold {_DISTORTION_LENGTHS} coefficients (OpenCV), got shape {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise PerceptionError(f"{name} must be finite, got {arr.tolist()}")
    big = np.flatnonzero(np.abs(arr) > MAX_DISTORTION)
    if big.size:
        i = int(big[0])
        raise PerceptionError(
            f"{name}[{i}] = {float(arr[i])!r}: distortion coefficients must be at most {MAX_DISTORTION:g} in "
            "magnitude"
        )
    return arr


def _camera_matrix(name: str, value: ArrayLike) -> NDArray[np.float64]:
    K = _matrix(name, value, (3, 3))
    if K[0, 0] <= 0 or K[1, 1] <= 0:
        raise PerceptionError(f"{name} focal lengths must be > 0, got fx={K[0, 0]!r}, fy={K[1, 1]!r}")
    if max(abs(K[0, 0]), abs(K[1, 1]), abs(K[0, 1]), abs(K[0, 2]), abs(K[1, 2])) > MAX_PIXELS:
        raise PerceptionError(f"{name} entries must be at most {MAX_PIXELS:g} px, got {K.tolist()}")
    if K[1, 0] != 0 or K[2, 0] != 0 or K[2, 1] != 0 or K[2, 2] != 1:
        raise PerceptionError(f"{name} must be upper triangular with K[2, 2] = 1, got {K.tolist()}")
    return K


def _points(name: str, value: ArrayLike, width: int) -> NDArray[np.float64]:
    arr = real_array(name, value, (None, width))
    big = np.flatnonzero(np.any(np.abs(arr) > MAX_COORD, axis=1))
    if big.size:
        i = int(big[0])
        raise PerceptionError(f"{name}[{i}] = {arr[i].tolist()} exceeds {MAX_COORD:g} in magnitude")
    return arr


def _image_size(value: object) -> tuple[int, int]:
    return image_size(value, MAX_IMAGE_SIDE)


def _path(path: object) -> Path:
    return Path(file_path("path", path, RobotFileError))


def _flow_depth(data: bytes) -> int:
    """Deepest nesting of ``[``/``{`` brackets in ``data`` (a running count, vectorised)."""
    b = np.frombuffer(data, dtype=np.uint8)
    step = ((b == ord("[")).astype(np.int64) + (b == ord("{")) - (b == ord("]")) - (b == ord("}")))
    return int(np.max(np.cumsum(step), initial=0))


def _nesting_depth(data: bytes) -> tuple[int, str]:
    """Deepest nesting of ``data`` and what it counts: the depth of ``[``/``{`` (JSON, YAML flow
    style), of open XML tags, and the number of distinct indentation levels (YAML block style);
    the largest of the three."""
    import re

    flow = _flow_depth(data)
    tags = np.array([-1 if m.group(1) else (0 if m.group(2) else 1)
                     for m in re.finditer(rb"<(/?)[A-Za-z_][^<>]*?(/?)>", data)], dtype=np.int64)
    xml = int(np.max(np.cumsum(tags), initial=0))
    indents = {len(m.group(1)) for m in re.finditer(rb"^([ \t]*)[^ \t\r\n#%]", data, re.MULTILINE)}
    return max((flow, "[/{ nesting"), (xml, "XML tag nesting"), (len(indents), "YAML indentation levels"))


def _check_file(path: Path) -> None:
    """Refuse a calibration file that is missing, too large or too deeply nested for OpenCV's parser."""
    try:
        if not path.is_file():
            raise RobotFileError(f"calibration file path={str(path)!r} does not exist")
        size = path.stat().st_size
        if size > MAX_FILE_BYTES:
            raise RobotFileError(
                f"calibration file path={str(path)!r} has {size:,} bytes, more than {MAX_FILE_BYTES:,}"
            )
        with path.open("rb") as fh:
            data = fh.read(MAX_FILE_BYTES + 1)
    except OSError as exc:
        raise RobotFileError(f"calibration file path={str(path)!r} cannot be read: {exc}") from exc
    if len(data) > MAX_FILE_BYTES:
        raise RobotFileError(
            f"calibration file path={str(path)!r} has more than {MAX_FILE_BYTES:,} bytes"
        )
    depth, what = _nesting_depth(data)
    if depth > MAX_FILE_DEPTH:
        raise RobotFileError(
            f"calibration file path={str(path)!r} is nested too deeply: depth {depth} ({what}) exceeds "
            f"{MAX_FILE_DEPTH}"
        )


def _file_int(path: Path, value: float) -> int:
    if not np.isfinite(value) or value != int(value):
        raise RobotFileError(
            f"calibration file path={str(path)!r}: image_size must hold integers, got {value!r}"
        )
    return int(value)


def _check_triangulated(X: NDArray[np.float64], uv_left: ArrayLike, uv_right: ArrayLike, offset: int = 0
                        ) -> None:
    """:class:`BehindCameraError` naming the first pixel pair (index ``offset + i``) whose point is
    non-finite or behind the left camera."""
    bad = ~np.all(np.isfinite(X), axis=1) | (X[:, 2] <= 0)
    if np.any(bad):
        i = int(np.flatnonzero(bad)[0])
        raise BehindCameraError(
            f"pixel pair {offset + i} (uv_left {np.asarray(uv_left, dtype=float)[i].tolist()}, uv_right "
            f"{np.asarray(uv_right, dtype=float)[i].tolist()}) triangulates to {X[i].tolist()}, "
            "at infinity or behind the camera"
        )


@dataclass(frozen=True)
class StereoRig:
    """A calibrated stereo pair in the OpenCV convention ``X_right = R X_left + T``.

    Parameters
    ----------
    K1, K2 : (3, 3) float
        Camera matrices of the left and right camera (pixels).
    D1, D2 : (k,) float
        OpenCV distortion coefficients, k in {0, 4, 5, 8, 12, 14}; ``None`` means none.
    R : (3, 3) float
        Rotation from the left to the right camera frame.
    T : (3,) float
        Translation from the left to the right camera frame, metres.
    image_size : (int, int)
        ``(width, height)`` in pixels.
    """

    K1: NDArray[np.float64]
    D1: NDArray[np.float64]
    K2: NDArray[np.float64]
    D2: NDArray[np.float64]
    R: NDArray[np.float64]
    T: NDArray[np.float64]
    image_size: tuple[int, int]

    def __post_init__(self) -> None:
        K1 = _camera_matrix("K1", self.K1)
        K2 = _camera_matrix("K2", self.K2)
        D1 = _distortion("D1", self.D1)
        D2 = _distortion("D2", self.D2)
        R = _matrix("R", self.R, (3, 3))
        T = _matrix("T", self.T, (3,))
        why = rotation_defect(R, RIGID_TOLERANCE)
        if why is not None:
            raise PerceptionError(f"R must be a rotation matrix, but it {why}: {R.tolist()}")
        if np.linalg.norm(T) <= 0:
            raise PerceptionError(f"T must be a non-zero baseline, got {T.tolist()}")
        size = _image_size(self.image_size)
        if np.linalg.norm(T) > MAX_COORD:
            raise PerceptionError(f"T must be at most {MAX_COORD:g} m long, got {T.tolist()}")
        for name, arr in (("K1", K1), ("K2", K2), ("D1", D1), ("D2", D2), ("R", R), ("T", T)):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        object.__setattr__(self, "image_size", (size[0], size[1]))
        _check_not_transposed(size, K1, K2)
        self._check_usable()

    def _check_usable(self) -> None:
        """Refuse a rig that cannot triangulate a point on the left optical axis 2 m (or 20
        baselines) ahead back to itself, within :data:`RIG_ROUND_TRIP_RTOL`: one whose focal
        lengths or geometry leave no usable disparity (1e-300 px projects every point to the
        principal point).  The round trip is the pinhole model without distortion (zero on the
        left axis), in numpy: OpenCV stays unimported until a method needs it.  A point behind
        the right camera (a rig whose cameras do not share that view) is not tested."""
        depth = max(2.0, 20.0 * float(np.linalg.norm(self.T)))
        point = np.array([0.0, 0.0, depth])
        in_right = self.R @ point + self.T
        if not float(in_right[2]) > 0.0:
            return
        with np.errstate(all="ignore"):
            try:
                pix_left = self.K1 @ (point / point[2])
                pix_right = self.K2 @ (in_right / in_right[2])
                ray_left = np.linalg.solve(self.K1, pix_left)
                ray_right = self.R.T @ np.linalg.solve(self.K2, pix_right)
                centre_right = -self.R.T @ self.T
                # closest points of the two rays (midpoint triangulation)
                s, t = np.linalg.lstsq(np.column_stack([ray_left, -ray_right]), centre_right, rcond=None)[0]
                back = 0.5 * (s * ray_left + centre_right + t * ray_right)
                err = float(np.linalg.norm(back - point))
            except np.linalg.LinAlgError:
                err = math.inf
        if not err <= RIG_ROUND_TRIP_RTOL * depth:
            raise PerceptionError(
                f"the rig cannot triangulate the point {depth:g} m ahead of the left camera (it comes "
                f"back {err:.3g} m away); check the focal lengths K1[0, 0] = {float(self.K1[0, 0])!r}, "
                f"K2[0, 0] = {float(self.K2[0, 0])!r} (pixels), R and T = {self.T.tolist()} (metres)")

    # ------------------------------------------------------------------ constructors
    @classmethod
    def from_opencv(
        cls,
        K1: ArrayLike,
        D1: ArrayLike | None,
        K2: ArrayLike,
        D2: ArrayLike | None,
        R: ArrayLike,
        T: ArrayLike,
        image_size: tuple[int, int],
    ) -> StereoRig:
        """Build a rig from the outputs of ``cv2.stereoCalibrate`` (any array layout)."""
        T_arr = real_array("T", T)
        if T_arr.shape in ((3, 1), (1, 3)):
            T_arr = T_arr.ravel()
        return cls(K1=K1, D1=D1, K2=K2, D2=D2, R=R, T=T_arr, image_size=image_size)  # type: ignore[arg-type]

    @classmethod
    def default(
        cls, image_size: tuple[int, int] = (640, 480), baseline: float = 0.093, hfov_deg: float = 60.0
    ) -> StereoRig:
        """An ARMAR-like parallel rig without distortion.

        Parameters
        ----------
        image_size : (int, int)
            ``(width, height)`` in pixels.
        baseline : float
            Distance between the optical centres, metres, in [:data:`MIN_BASELINE`,
            :data:`MAX_BASELINE`].
        hfov_deg : float
            Horizontal field of view in degrees, in (0, 180).
        """
        w, h = _image_size(image_size)
        baseline = real_scalar("baseline", baseline, positive=True)
        if not MIN_BASELINE <= baseline <= MAX_BASELINE:
            raise PerceptionError(f"baseline must lie in [{MIN_BASELINE:g}, {MAX_BASELINE:g}] m, "
                                  f"got {baseline!r}")
        hfov_deg = real_scalar("hfov_deg", hfov_deg)
        if not 1e-6 <= hfov_deg <= 179.0:
            raise PerceptionError(f"hfov_deg must lie in [1e-6, 179], got {hfov_deg!r}")
        f = (w / 2.0) / np.tan(np.radians(hfov_deg) / 2.0)
        if f > MAX_PIXELS:
            raise PerceptionError(f"hfov_deg = {hfov_deg!r} gives a focal length of {f:.4g} px for an image "
                                  f"{w} px wide, more than {MAX_PIXELS:g} px: widen the field of view")
        K = np.array([[f, 0.0, w / 2.0], [0.0, f, h / 2.0], [0.0, 0.0, 1.0]])
        return cls(
            K1=K,
            D1=np.zeros(5),
            K2=K.copy(),
            D2=np.zeros(5),
            R=np.eye(3),
            T=np.array([-float(baseline), 0.0, 0.0]),
            image_size=(w, h),
        )

    @classmethod
    def from_file(cls, path: str | Path) -> StereoRig:
        """Read a rig from an OpenCV FileStorage file (YAML/XML/JSON) with keys
        ``K1, D1, K2, D2, R, T, image_size``.

        Raises
        ------
        RobotFileError
            The file is missing, unreadable, or lacks a key or holds a non-matrix under it.
        """
        import cv2
        path = _path(path)
        _check_file(path)
        try:
            return cls._read(path)
        except RobotFileError:
            raise
        except (PerceptionError, OSError, cv2.error) as exc:
            raise RobotFileError(f"calibration file path={str(path)!r} is invalid: {exc}") from exc

    @classmethod
    def _read(cls, path: Path) -> StereoRig:
        import cv2
        try:
            fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
        except (cv2.error, SystemError) as exc:  # the binding raises SystemError on parse errors
            raise RobotFileError(f"calibration file path={str(path)!r} is malformed: {exc}") from exc
        if not fs.isOpened():
            raise RobotFileError(f"calibration file path={str(path)!r} cannot be opened")
        values: dict[str, NDArray[np.float64]] = {}
        try:
            for key in _FILE_KEYS:
                node = fs.getNode(key)
                if node.empty() or node.isNone():
                    raise RobotFileError(f"calibration file path={str(path)!r} lacks key {key!r}")
                try:
                    mat = node.mat()
                except (cv2.error, SystemError) as exc:
                    raise RobotFileError(
                        f"calibration file path={str(path)!r}: key {key!r} is not an OpenCV matrix"
                    ) from exc
                if mat is None:
                    raise RobotFileError(
                        f"calibration file path={str(path)!r}: key {key!r} is not an OpenCV matrix"
                    )
                values[key] = np.asarray(mat, dtype=np.float64)
        finally:
            fs.release()
        size = values.pop("image_size").ravel()
        if size.size != 2:
            raise RobotFileError(
                f"calibration file path={str(path)!r}: image_size must hold 2 values, got {size.tolist()}"
            )
        try:
            return cls.from_opencv(
                values["K1"],
                values["D1"],
                values["K2"],
                values["D2"],
                values["R"],
                values["T"],
                (_file_int(path, size[0]), _file_int(path, size[1])),
            )
        except PerceptionError:
            raise
        except (ValueError, TypeError, OverflowError) as exc:
            raise RobotFileError(f"calibration file path={str(path)!r} is invalid: {exc}") from exc

    def to_file(self, path: str | Path) -> None:
        """Write the rig to an OpenCV FileStorage file (format from the suffix, e.g. ``.yaml``).

        No distortion (an empty ``D``) is written as five zeros, which OpenCV treats alike.
        """
        import cv2
        path = _path(path)
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
        if not fs.isOpened():
            raise RobotFileError(f"cannot write calibration file path={str(path)!r}")
        try:
            fs.write("K1", self.K1)
            fs.write("D1", self.D1.reshape(1, -1) if self.D1.size else np.zeros((1, 5)))
            fs.write("K2", self.K2)
            fs.write("D2", self.D2.reshape(1, -1) if self.D2.size else np.zeros((1, 5)))
            fs.write("R", self.R)
            fs.write("T", self.T.reshape(3, 1))
            fs.write("image_size", np.array([self.image_size], dtype=np.int32))
        finally:
            fs.release()

    # ------------------------------------------------------------------ properties
    @property
    def baseline(self) -> float:
        """Distance between the optical centres ``|C_L - C_R| = |T|``, metres."""
        return float(np.linalg.norm(self.T))

    @property
    def focal_px(self) -> float:
        """Horizontal focal length of the left camera ``K1[0, 0]``, pixels."""
        return float(self.K1[0, 0])

    @property
    def left_center(self) -> NDArray[np.float64]:
        """Optical centre of the left camera in the left camera frame (the origin)."""
        return np.zeros(3)

    @property
    def right_center(self) -> NDArray[np.float64]:
        """Optical centre of the right camera in the left camera frame, ``-R^T T``."""
        return -self.R.T @ self.T

    @property
    def viewing_direction(self) -> NDArray[np.float64]:
        """The left optical axis ``e_d`` in the left camera frame, ``(0, 0, 1)`` (eq. 7)."""
        return np.array([0.0, 0.0, 1.0])

    @property
    def hfov(self) -> float:
        """Horizontal field of view of the left pinhole camera, radians."""
        w = self.image_size[0]
        cx, fx = self.K1[0, 2], self.K1[0, 0]
        return float(np.arctan(cx / fx) + np.arctan((w - cx) / fx))

    @property
    def vfov(self) -> float:
        """Vertical field of view of the left pinhole camera, radians."""
        h = self.image_size[1]
        cy, fy = self.K1[1, 2], self.K1[1, 1]
        return float(np.arctan(cy / fy) + np.arctan((h - cy) / fy))

    @property
    def right_from_left(self) -> NDArray[np.float64]:
        """4x4 transform from the left to the right camera frame."""
        M = np.eye(4)
        M[:3, :3] = self.R
        M[:3, 3] = self.T
        return M

    # ------------------------------------------------------------------ geometry
    def project(self, points_left: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Project points given in the left camera frame into both images (``cv2.projectPoints``).

        Parameters
        ----------
        points_left : (N, 3) float
            Points in the left camera frame, metres.

        Returns
        -------
        uv_left, uv_right : (N, 2) float
            Distorted pixel coordinates.

        Raises
        ------
        BehindCameraError
            A point has depth <= 0 in the left or the right camera.
        """
        import cv2
        X = _points("points_left", points_left, 3)
        X2 = X @ self.R.T + self.T
        for name, Z in (("left", X[:, 2]), ("right", X2[:, 2])):
            bad = Z <= 0
            if np.any(bad):
                i = int(np.flatnonzero(bad)[0])
                raise BehindCameraError(
                    f"point {i} {X[i].tolist()} of points_left (shape {X.shape}) has depth {Z[i]!r} <= 0 "
                    f"in the {name} camera"
                )
        if X.shape[0] == 0:
            return np.zeros((0, 2)), np.zeros((0, 2))
        obj = X.reshape(-1, 1, 3)
        proj1, _ = cv2.projectPoints(obj, np.zeros(3), np.zeros(3), self.K1, self.D1)
        rvec, _ = cv2.Rodrigues(self.R)
        proj2, _ = cv2.projectPoints(obj, rvec, self.T, self.K2, self.D2)
        uv1 = proj1.reshape(-1, 2).astype(np.float64)
        uv2 = proj2.reshape(-1, 2).astype(np.float64)
        bad = ~(np.all(np.isfinite(uv1), axis=1) & np.all(np.isfinite(uv2), axis=1))
        if np.any(bad):
            i = int(np.flatnonzero(bad)[0])
            raise PerceptionError(
                f"points_left[{i}] = {X[i].tolist()} projects to non-finite pixels "
                f"(left {uv1[i].tolist()}, right {uv2[i].tolist()}): too far from the optical axis"
            )
        return uv1, uv2

    def in_view(self, points_left: ArrayLike) -> NDArray[np.bool_]:
        """Which points lie in front of both cameras and project inside the left image.

        Parameters
        ----------
        points_left : (N, 3) float

        Returns
        -------
        (N,) bool
        """
        X = _points("points_left", points_left, 3)
        X2 = X @ self.R.T + self.T
        front = (X[:, 2] > 0) & (X2[:, 2] > 0)
        mask = np.zeros(X.shape[0], dtype=bool)
        if np.any(front):
            uv, _ = self.project(X[front])
            w, h = self.image_size
            mask[front] = (uv[:, 0] >= 0) & (uv[:, 0] <= w) & (uv[:, 1] >= 0) & (uv[:, 1] <= h)
        return mask

    def normalized(
        self, uv_left: ArrayLike, uv_right: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Undistorted normalised image coordinates of both pixel sets (``cv2.undistortPoints``).

        Returns
        -------
        xy_left, xy_right : (N, 2) float
        """
        u1 = _points("uv_left", uv_left, 2)
        u2 = _points("uv_right", uv_right, 2)
        if u1.shape != u2.shape:
            raise PerceptionError(f"uv_left and uv_right must have the same shape, got {u1.shape} and "
                                  f"{u2.shape}")
        if u1.shape[0] == 0:
            return np.zeros((0, 2)), np.zeros((0, 2))
        return self._undistort(u1, self.K1, self.D1), self._undistort(u2, self.K2, self.D2)

    @staticmethod
    def _undistort(
        uv: NDArray[np.float64], K: NDArray[np.float64], D: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        import cv2
        src = uv.reshape(-1, 1, 2)
        if D.size == 0 or not np.any(D):
            out = cv2.undistortPoints(src, K, D)
        else:
            out = cv2.undistortPoints(src, K, D, criteria=(
                cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, _UNDISTORT_ITERATIONS, UNDISTORT_EPS))
        return out.reshape(-1, 2).astype(np.float64)

    def triangulate(self, uv_left: ArrayLike, uv_right: ArrayLike) -> NDArray[np.float64]:
        """Triangulate matched pixels into the left camera frame.

        Undistorts with ``cv2.undistortPoints`` (iterative variant) and triangulates the
        normalised coordinates with ``cv2.triangulatePoints`` using ``P1 = [I | 0]``,
        ``P2 = [R | T]``.

        Parameters
        ----------
        uv_left, uv_right : (N, 2) float
            Matched distorted pixel coordinates.

        Returns
        -------
        (N, 3) float
            Points in the left camera frame, metres.

        Raises
        ------
        PerceptionError
            A pixel coordinate is NaN or infinite.
        BehindCameraError
            A triangulated point is at infinity or behind the left camera.
        """
        xy1, xy2 = self.normalized(uv_left, uv_right)
        if xy1.shape[0] == 0:
            return np.zeros((0, 3))
        X = self._triangulate_normalized(xy1, xy2)
        _check_triangulated(X, uv_left, uv_right)
        return X

    def _triangulate_normalized(
        self, xy1: NDArray[np.float64], xy2: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """``cv2.triangulatePoints`` of normalised coordinates; rows may be non-finite or behind."""
        import cv2
        P1 = np.hstack([np.eye(3), np.zeros((3, 1))])
        P2 = np.hstack([self.R, self.T.reshape(3, 1)])
        Xh = cv2.triangulatePoints(P1, P2, xy1.T.copy(), xy2.T.copy()).astype(np.float64)
        w = Xh[3]
        with np.errstate(divide="ignore", invalid="ignore"):
            return (Xh[:3] / w).T

    def rectify(self, alpha: float = -1.0) -> Rectification:
        """Rectifying transforms from ``cv2.stereoRectify`` (``CALIB_ZERO_DISPARITY``).

        ``alpha``: -1 (OpenCV's default scaling) or a free scaling parameter in [0, 1].
        """
        import cv2
        alpha = real_scalar("alpha", alpha)
        if alpha != -1.0 and not 0.0 <= alpha <= 1.0:
            raise PerceptionError(f"alpha must be -1 or lie in [0, 1], got {alpha!r}")
        R1, R2, P1, P2, Q, _, _ = cv2.stereoRectify(
            self.K1,
            self.D1,
            self.K2,
            self.D2,
            self.image_size,
            self.R,
            self.T.reshape(3, 1),
            flags=cv2.CALIB_ZERO_DISPARITY,
            alpha=alpha,
        )
        return Rectification(*(np.asarray(m, dtype=np.float64) for m in (R1, R2, P1, P2, Q)))


#: A principal point more than this fraction of the image's side from its centre, on either axis,
#: where the transposed size puts it within it, makes :class:`StereoRig` refuse the size as given
#: as (height, width).
PRINCIPAL_POINT_FRACTION = 0.15


def _check_not_transposed(size: tuple[int, int], K1: NDArray[np.float64], K2: NDArray[np.float64]) -> None:
    """Refuse an ``image_size`` that only fits the camera matrices transposed (a (height, width)
    size for a (width, height) one)."""
    w, h = size
    if w == h:
        return

    def off(width: int, height: int) -> bool:
        return any(abs(K[0, 2] - (width - 1) / 2.0) > PRINCIPAL_POINT_FRACTION * width
                   or abs(K[1, 2] - (height - 1) / 2.0) > PRINCIPAL_POINT_FRACTION * height
                   for K in (K1, K2))

    if off(w, h) and not off(h, w):
        raise PerceptionError(
            f"image_size = ({w}, {h}) puts the principal point ({K1[0, 2]:g}, {K1[1, 2]:g}) far from "
            f"the image centre, which ({h}, {w}) fits: image_size is (width, height); did you give "
            "(height, width)?")
