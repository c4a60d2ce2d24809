"""Head scans and looks of a MuJoCo scene: the views' renders, detections and percepts
(methods of :class:`~perception.mujoco.MujocoScene`)."""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from .._checks import (
    _short,
    boolean,
    check_transform,
    integer,
    name_string,
    real_array,
    real_scalar,
)
from .._checks import generator as check_rng
from ..errors import (
    PerceptionError,
)
from ..frontend.detection import Detection
from ..frontend.detection_percepts import DEPTH_NOISE, centre_offset_of
from ..frontend.fusion import fuse_percepts, percept_bandwidths
from ..frontend.percept import Percept
from ..frontend.rgbd import rgbd_percepts
from ..frontend.stereo_pairs import stereo_percepts
from ..head.chain import KinematicChain, default_head
from ..head.stereo import StereoRig
from ..simulation.simulate import scan_angles
from ..tolerances import ANGLE_SLACK
from .detector import _Degrade, _noisy_depth
from .records import (
    DEFAULT_DEPTH_NOISE,
    DEFAULT_MAX_RANGE,
    SENSORS,
    MujocoScan,
    ScanTimings,
    ScanView,
    Sensor,
    StereoCalibration,
    _image_size,
)

# The functions here are methods of MujocoScene (perception.mujoco.scene), documented there.
__all__: list[str] = []

#: Views of one :meth:`MujocoScene.look`.
LOOK_VIEWS = 3
#: Neck yaw of a look's outer views either side of its direction (degrees): with the default
#: camera's 58-degree horizontal field of view, three views cover about 80 degrees and see the middle
#: 38 in every view.
LOOK_SPREAD_DEG = 10.0
#: How far the neck yaws either side of the base (degrees) in :meth:`MujocoScene.look`: the reach
#: of :meth:`MujocoScene.scan`'s default sweep; beyond it the base turns.
NECK_REACH_DEG = 70.0


def scan(self: Any, world_from_ego: ArrayLike, sensor: str = "rgbd", n_views: int = 20, *,
         rng: np.random.Generator, image_size: Any = (640, 480), chain: KinematicChain | None = None,
         miss_rate: float = 0.0, false_rate: float = 0.0, mask_jitter_px: int = 0, min_pixels: int = 1,
         depth_noise: float = DEFAULT_DEPTH_NOISE, max_range: float = DEFAULT_MAX_RANGE,
         centre_offset: Mapping[str, Any] | None = None, percepts: bool = True,
         yaw_deg: tuple[float, float] = (-70.0, 70.0),
         pitch_deg: tuple[float, float] = (-10.0, 10.0)) -> MujocoScan:
    """Sweep a head over the scene and detect the typed objects in every view.

    Parameters
    ----------
    world_from_ego : (4, 4) float
        The robot pose (ego frame: x forward, y left, z up).
    sensor : {"rgbd", "stereo"}
        ``"rgbd"``: one camera with RGB, noisy depth and segmentation; ``"stereo"``: the left
        and right cameras of the head, RGB and segmentation each.
    n_views : int
        Views of the sweep, :func:`perception.simulation.simulate.scan_angles` (neck yaw from -70 to 70
        degrees, neck pitch alternating -10 / 10 degrees).
    rng : numpy.random.Generator
        Draws the depth noise and the degradations.
    image_size : (int, int)
        ``(width, height)``, pixels.
    chain : KinematicChain, optional
        The head; :func:`perception.default_head` by default.  The cameras are at
        ``world_from_ego @ chain.ego_from_camera(q)`` (and ``ego_from_right_camera``).
    miss_rate : float
        Probability that a visible object's detection is dropped.
    false_rate : float
        Per image, ``Binomial(n_visible, false_rate)`` false detections (truth -1): half of
        them (when there is another type in the scene) the mask of a true detection labelled
        with another type of the scene, the others an elliptic blob of pixels where no typed
        object is, labelled with a type of the scene.
    mask_jitter_px : int
        Every mask's edge moves by a random whole number of pixels in
        ``[-mask_jitter_px, mask_jitter_px]`` (erosion or dilation by a 3x3 cross).
    min_pixels : int
        Detections (true or false) with fewer pixels are dropped.
    depth_noise : float
        ``c`` (1/m) of the depth error ``sigma_z = c z^2`` (:data:`DEFAULT_DEPTH_NOISE`); 0
        for exact depth.  The normalised error is one draw per block of
        :data:`DEPTH_NOISE_BLOCK` pixels plus an independent part per pixel
        (:data:`DEPTH_NOISE_IID`).  The front end models the same ``c`` (the default
        :data:`perception.frontend.DEPTH_NOISE` for exact depth).
    max_range : float
        Depths beyond it are invalid (NaN), as are pixels where nothing is rendered.
    centre_offset : mapping, optional
        Type -> :class:`~perception.CentreOffset` (or its depth in metres) for the front end:
        where an object's centre lies from its visible part; by default
        :meth:`default_centre_offsets` (measured on renders from other poses; stereo:
        :meth:`default_stereo_offsets`, with the outline's disparity errors); pass
        :meth:`centre_depths` (half the thinnest extent, as the map's
        :meth:`worldgraph.WorldModel.centre_depths`) to use the geometry's guess alone.
    yaw_deg, pitch_deg : (float, float)
        The sweep (:func:`perception.simulation.simulate.scan_angles`): neck yaw from the first to the
        second value over the views, neck pitch alternating between the two (degrees;
        negative pitch looks up).  The defaults are the paper's scan.
    percepts : bool
        Run the front end (``False``: images and detections only): per view
        :func:`perception.rgbd_percepts` on the detections and the noisy depth, or
        :func:`perception.stereo_percepts` on the left and right detections with the rig of
        the two cameras (``X_right = R X_left + T`` from ``inv(ego_from_right) @
        ego_from_left``, both with ``K``, no distortion), ``disparity_from="outline"`` and
        the disparity errors :meth:`default_stereo_offsets` measures.

    Returns
    -------
    MujocoScan
        The views, the percepts of all views (ego frame, not fused), what the front end
        dropped per view, and the seconds spent per stage.

    Raises
    ------
    PerceptionError
        - ``world_from_ego`` is not a rigid transform.
        - An unknown ``sensor``.
        - A bad argument, named: ``n_views`` < 1, a bad ``image_size``, a rate
          outside [0, 1], a negative ``mask_jitter_px``, ``min_pixels`` < 1, a negative
          ``depth_noise``, a non-positive ``max_range``, ``rng`` not a Generator.
    """
    pose = check_transform("world_from_ego", world_from_ego)
    kind = _sensor(sensor)
    n = integer("n_views", n_views, minimum=1, maximum=100_000)
    gen, size, head, degrade, noise, far = self._sweep_arguments(
        rng, image_size, chain, miss_rate, false_rate, mask_jitter_px, min_pixels, depth_noise, max_range)
    run_front_end = boolean("percepts", percepts)
    centres = (self._centre_offset(centre_offset, kind, size, degrade.jitter)
               if run_front_end or centre_offset is not None else StereoCalibration({}, {}, {}))
    Q = scan_angles(head, n, yaw_deg, pitch_deg)
    return self._sweep(pose, Q, head, kind, gen, size, degrade, noise, far, run_front_end, centres)


def _sweep_arguments(self: Any,
                     rng: Any, image_size: Any, chain: Any, miss_rate: Any, false_rate: Any,
                     mask_jitter_px: Any, min_pixels: Any, depth_noise: Any, max_range: Any
                     ) -> tuple[np.random.Generator, tuple[int, int], KinematicChain, _Degrade, float,
                                float]:
    """The checked arguments :meth:`scan` and :meth:`look` share: the generator, the image size,
    the head, the detector model, the depth noise and the range."""
    gen = check_rng("rng", rng)
    size = _image_size(image_size)
    head = default_head() if chain is None else chain
    if not isinstance(head, KinematicChain):
        raise PerceptionError(f"chain must be a KinematicChain or None, got {type(chain).__name__}")
    degrade = _Degrade(self.types, gen, real_scalar("miss_rate", miss_rate, minimum=0.0, maximum=1.0),
                       real_scalar("false_rate", false_rate, minimum=0.0, maximum=1.0),
                       integer("mask_jitter_px", mask_jitter_px, minimum=0, maximum=1000),
                       integer("min_pixels", min_pixels, minimum=1))
    noise = real_scalar("depth_noise", depth_noise, minimum=0.0)
    far = real_scalar("max_range", max_range, positive=True)
    return gen, size, head, degrade, noise, far


def look(self: Any, world_from_ego: ArrayLike, direction: ArrayLike, *, sensor: str = "rgbd",
         rng: np.random.Generator, n_views: int = LOOK_VIEWS, spread_deg: float = LOOK_SPREAD_DEG,
         neck_reach_deg: float = NECK_REACH_DEG, image_size: Any = (640, 480),
         chain: KinematicChain | None = None, miss_rate: float = 0.0, false_rate: float = 0.0,
         mask_jitter_px: int = 0, min_pixels: int = 1, depth_noise: float = DEFAULT_DEPTH_NOISE,
         max_range: float = DEFAULT_MAX_RANGE, centre_offset: Mapping[str, Any] | None = None,
         pitch_deg: tuple[float, float] = (-10.0, 10.0), min_views: int = 1) -> list[Percept]:
    """The percepts of one look towards an ego-frame direction, fused, in the ego frame of
    ``world_from_ego``.

    The head turns its neck (yaw and pitch) towards ``direction``; ``n_views`` views fan out
    over neck yaws ``spread_deg`` either side of it, the pitch alternating by ``pitch_deg``
    about the direction's (as :meth:`scan` does), so that the look spans from low drawers to
    wall cabinets.  Where the fan reaches past
    ``neck_reach_deg`` (or the chain's ``neck_yaw`` limits, if tighter), the base turns in
    place about ego z by the least angle that brings every view within reach, and the
    percepts are rotated back into the ego frame the look started from (the turn taken as
    known exactly: a turn in place measured by the wheel encoders).  The views' percepts are
    fused (:func:`perception.fuse_percepts` with :func:`perception.percept_bandwidths`), so
    the list plugs into :func:`worldgraph.active_localize` as its ``look``::

        look = functools.partial(scene.look, world_from_ego, sensor="stereo", rng=rng)
        wg.active_localize(world, fused, look, max_looks=3)

    Parameters
    ----------
    world_from_ego : (4, 4) float
        The robot pose when the look starts.
    direction : (3,) float
        Where to look, ego frame (x forward, y left, z up); any non-zero length.
    sensor, rng, image_size, chain, miss_rate, false_rate, mask_jitter_px, min_pixels, \
depth_noise, max_range, centre_offset
        As for :meth:`scan` (the detector model and the front end are the same).
    n_views : int
        Views of the look (>= 1, default :data:`LOOK_VIEWS`).
    spread_deg : float
        Neck yaw of the outer views either side of the direction (degrees, >= 0, default
        :data:`LOOK_SPREAD_DEG`).
    neck_reach_deg : float
        How far the neck yaws either side of the base (degrees, > 0, default
        :data:`NECK_REACH_DEG`, the reach of :meth:`scan`'s sweep).
    pitch_deg : (float, float)
        The pitch zigzag about the direction's pitch (degrees; negative looks up).
    min_views : int
        Fusion keeps objects seen complete in at least this many of the look's views
        (default 1: near the fan's edges an object is seen whole once, and its percept's
        covariance says how well; 2 also drops false detections that do not repeat).

    Returns
    -------
    list of Percept
        Fused over the look's views, ego frame of ``world_from_ego``; empty when nothing
        typed was recognised.

    Raises
    ------
    PerceptionError
        Naming the argument: a zero or non-finite ``direction``, ``n_views`` < 1, a negative
        ``spread_deg``, a non-positive ``neck_reach_deg``, ``spread_deg`` beyond the reach
        (no base turn brings the fan within it), and every error of :meth:`scan`.
    """
    pose = check_transform("world_from_ego", world_from_ego)
    d = real_array("direction", direction, shape=(3,))
    if not float(np.linalg.norm(d)) > 0.0:
        raise PerceptionError(f"direction must be a non-zero ego-frame vector, got {d.tolist()}")
    kind = _sensor(sensor)
    n = integer("n_views", n_views, minimum=1, maximum=1000)
    spread = math.radians(real_scalar("spread_deg", spread_deg, minimum=0.0, maximum=180.0))
    reach = math.radians(real_scalar("neck_reach_deg", neck_reach_deg, positive=True, maximum=180.0))
    gen, size, head, degrade, noise, far = self._sweep_arguments(
        rng, image_size, chain, miss_rate, false_rate, mask_jitter_px, min_pixels, depth_noise, max_range)
    for need in ("neck_yaw", "neck_pitch"):
        if need not in head.names:
            raise PerceptionError(f"look needs a joint named {need!r}; the chain has {list(head.names)}")
    pitch = _pitch_pair(pitch_deg)
    centres = self._centre_offset(centre_offset, kind, size, degrade.jitter)
    fuse_min = integer("min_views", min_views, minimum=1, maximum=n)
    yaw_index, pitch_index = head.names.index("neck_yaw"), head.names.index("neck_pitch")
    lower, upper = head.limits[yaw_index]
    lo_reach, hi_reach = max(-reach, lower), min(reach, upper)
    target = math.atan2(d[1], d[0])
    yaws = target + (np.linspace(-spread, spread, n) if n > 1 else np.zeros(1))
    if yaws[-1] - yaws[0] > hi_reach - lo_reach + ANGLE_SLACK:
        fan = math.degrees(yaws[-1] - yaws[0])
        raise PerceptionError(f"spread_deg = {spread_deg!r}: a fan of {fan:g} degrees does not fit the "
                              f"neck's reach of "
                              f"{math.degrees(hi_reach - lo_reach):g} degrees")
    # the least base turn that brings every view's neck yaw into [lo_reach, hi_reach]
    base = min(max(0.0, yaws[-1] - hi_reach), yaws[0] - lo_reach)
    Q = np.zeros((n, head.n_joints))
    Q[:, yaw_index] = yaws - base
    up = math.atan2(d[2], math.hypot(d[0], d[1]))
    Q[:, pitch_index] = -up + np.radians(np.where(np.arange(n) % 2 == 0, pitch[0], pitch[1]))
    turn = np.eye(4)
    turn[:3, :3] = Rotation.from_euler("z", base).as_matrix()
    seen = self._sweep(pose @ turn, Q, head, kind, gen, size, degrade, noise, far, True, centres)
    raw = [_rotated(p, turn[:3, :3]) for p in seen.percepts] if base != 0.0 else list(seen.percepts)
    if not raw:
        return []
    return list(fuse_percepts(raw, bandwidth=percept_bandwidths(raw), min_views=fuse_min))


def _sweep(self: Any,
           pose: NDArray[np.float64], Q: NDArray[np.float64], head: KinematicChain, sensor: Sensor,
           gen: np.random.Generator, size: tuple[int, int], degrade: _Degrade, noise: float, far: float,
           run_front_end: bool, centres: StereoCalibration) -> MujocoScan:
    """Render, detect and (with ``run_front_end``) perceive the views of head angles ``Q`` (one row
    per view) from the robot pose ``pose``; the arguments checked by the caller."""
    kind = sensor
    n = Q.shape[0]
    K = self.camera_matrix(size)
    t_render = t_detect = t_percepts = 0.0
    views: list[ScanView] = []
    for q in Q:
        ego_left = head.ego_from_camera(q)
        ego_right = head.ego_from_right_camera(q) if sensor == "stereo" else None
        t0 = time.perf_counter()
        left = self._render(pose @ ego_left, size, True, sensor == "rgbd", True)
        right = self._render(pose @ ego_right, size, True, False, True) if ego_right is not None else None
        depth = None
        if left.depth is not None:
            depth = _noisy_depth(left.depth, noise, far, gen)
        t1 = time.perf_counter()
        assert left.objects is not None and left.rgb is not None
        dets, truth, missed = degrade(left.objects)
        r_dets: tuple[Detection, ...] = ()
        r_truth: tuple[int, ...] = ()
        r_missed: tuple[int, ...] = ()
        if right is not None:
            assert right.objects is not None
            r_dets, r_truth, r_missed = degrade(right.objects)
        t2 = time.perf_counter()
        t_render += t1 - t0
        t_detect += t2 - t1
        views.append(ScanView(
            head_angles=np.array(q, dtype=np.float64), ego_from_camera=ego_left, K=K.copy(), rgb=left.rgb,
            segmentation=left.objects, detections=dets, truth=truth, depth=depth,
            right_rgb=None if right is None else right.rgb,
            right_segmentation=None if right is None else right.objects,
            right_detections=r_dets, right_truth=r_truth, ego_from_right_camera=ego_right,
            missed=missed, right_missed=r_missed))
    out_percepts: list[Any] = []
    out_views: list[int] = []
    out_truth: list[int] = []
    dropped: list[tuple[Any, ...]] = []
    if run_front_end:
        t0 = time.perf_counter()
        for k, view in enumerate(views):
            found, sources, lost = self._percepts(view, sensor, centres, noise)
            out_percepts.extend(found)
            out_views.extend([k] * len(found))
            out_truth.extend(view.truth[i] for i in sources)
            dropped.append(lost)
        t_percepts = time.perf_counter() - t0
    return MujocoScan(kind, tuple(views), tuple(out_percepts), tuple(out_views), tuple(out_truth),
                      tuple(dropped), ScanTimings(t_render, t_detect, t_percepts, n))


def _centre_offset(self: Any,
                   centre_offset: Mapping[str, Any] | None, sensor: str, size: tuple[int, int],
                   jitter: int) -> StereoCalibration:
    """The front end's settings of a sweep: ``centre_offset`` (with the centroids, for stereo),
    else those measured for the sensor (:meth:`default_centre_offsets`,
    :meth:`default_stereo_offsets`)."""
    if centre_offset is None:
        if sensor == "stereo":
            return self.default_stereo_offsets(size, jitter)
        return StereoCalibration(self.default_centre_offsets(), {}, {})
    if not isinstance(centre_offset, Mapping):
        raise PerceptionError("centre_offset must be a mapping type -> CentreOffset or metres, or None, "
                              f"got {_short(centre_offset)}")
    given = {name_string("centre_offset key", k): centre_offset_of(f"centre_offset[{k!r}]", v)
             for k, v in centre_offset.items()}
    return StereoCalibration(given, {}, {})


def _percepts(self: Any, view: ScanView, sensor: str, settings: StereoCalibration, depth_noise: float
              ) -> tuple[tuple[Any, ...], tuple[int, ...], tuple[Any, ...]]:
    """The front end on one view: ``(percepts, detection index of each, dropped)``."""
    if sensor == "rgbd":
        assert view.depth is not None
        out = rgbd_percepts(view.detections, view.depth, view.K, view.ego_from_camera,
                            depth_noise=depth_noise if depth_noise > 0 else DEPTH_NOISE,
                            centre_offset=settings.centre_offset)
    else:
        out = stereo_percepts(view.detections, view.right_detections, _view_rig(view),
                              view.ego_from_camera, **settings.keywords())
    return out.percepts, out.sources, out.dropped


def _view_rig(view: ScanView) -> Any:
    """The stereo rig of a stereo view: both cameras with its ``K``, no distortion, the right one
    where ``ego_from_right_camera`` puts it (``X_right = R X_left + T``), its image size."""
    assert view.ego_from_right_camera is not None
    right_from_left = np.linalg.inv(view.ego_from_right_camera) @ view.ego_from_camera
    h, w = view.segmentation.shape
    return StereoRig(view.K, np.zeros(0), view.K, np.zeros(0), right_from_left[:3, :3],
                     right_from_left[:3, 3], (w, h))


def _sensor(value: Any) -> Sensor:
    if not isinstance(value, str) or value not in SENSORS:
        raise PerceptionError(f"sensor must be one of {SENSORS}, got {_short(value)}")
    return "rgbd" if value == "rgbd" else "stereo"


def _pitch_pair(value: Any) -> tuple[float, float]:
    arr = real_array("pitch_deg", value, shape=(2,))
    if np.any(np.abs(arr) > 90.0):
        raise PerceptionError(f"pitch_deg must lie within [-90, 90] degrees, got {arr.tolist()}")
    return float(arr[0]), float(arr[1])


def _rotated(p: Percept, R: NDArray[np.float64]) -> Percept:
    """``p`` seen from a frame turned by ``R`` (``x_old = R x_new``): position, covariance and
    shared loadings rotated; the range and its sigma are unchanged."""
    cov = None if p.covariance is None else R @ p.covariance @ R.T
    return Percept(p.type, R @ p.position, p.sigma, covariance=cov, views=p.views,
                   shared=tuple((v, R @ S) for v, S in p.shared))
