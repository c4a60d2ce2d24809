"""Simulated percepts: already-fused percepts of a scene, or a raw scanning sequence.

Both functions take plain arrays (types and world positions) and a ``world_from_ego`` pose,
so no world model is needed. Positions in the ego frame (ROS REP 103), metres.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._checks import boolean, integer, name_string, real_array, real_scalar, sequence
from .._checks import generator as check_rng
from ..errors import PerceptionError
from ..frontend.percept import Percept
from ..head.chain import KinematicChain, check_transform, default_head
from ..head.stereo import StereoRig, as_stereo_rig
from ..head.uncertainty import depth_sigma
from ..tolerances import TINY

MAX_COORD = 1e150
"""Largest world coordinate accepted, metres."""
MAX_COUNT = 10_000_000
"""Largest ``n_false`` accepted."""
MAX_VIEWS = 100_000
"""Largest ``n_views`` accepted."""


def _types(types: Sequence[str], n: int) -> list[str]:
    if types is None or isinstance(types, (str, bytes)):
        raise PerceptionError(f"types must be a sequence of str, got {types!r}")
    try:
        out = list(types)
    except TypeError as exc:
        raise PerceptionError(f"types must be a sequence of str, got {type(types).__name__}") from exc
    if len(out) != n:
        raise PerceptionError(f"types must have one entry per row of world_positions ({n} rows), got "
                              f"{len(out)}")
    for i, t in enumerate(out):
        name_string(f"types[{i}]", t)
    return out


def _positions(world_positions: ArrayLike) -> NDArray[np.float64]:
    if isinstance(world_positions, (list, tuple)) and len(world_positions) == 0:
        return np.zeros((0, 3))
    X = real_array("world_positions", world_positions, (None, 3))
    big = np.flatnonzero(np.any(np.abs(X) > MAX_COORD, axis=1))
    if big.size:
        raise PerceptionError(f"world_positions[{big[0]}] = {X[big[0]].tolist()} exceeds {MAX_COORD:g} m")
    return X


def _positive(name: str, value: float) -> float:
    v = real_scalar(name, value, positive=True)
    if v > 1e150:
        raise PerceptionError(f"{name} must be at most 1e150, got {v!r}")
    return v


def _rate(name: str, value: float) -> float:
    return real_scalar(name, value, minimum=0.0, maximum=1.0)


def _rng(rng: np.random.Generator) -> np.random.Generator:
    return check_rng("rng", rng)


def _sigma_range_error(value: float) -> PerceptionError:
    return PerceptionError(
        f"simulated sigma {value!r} (from depth_factor, min_sigma and max_range) lies outside "
        "[1e-150, 1e150] m; choose depth_factor, min_sigma and max_range so that it does not"
    )


def _sigmas(sig: NDArray[np.float64]) -> None:
    """Simulated sigmas must have representable variances (for the covariance ``sigma^2 I``)."""
    bad = np.flatnonzero(~((sig >= 1e-150) & (sig <= 1e150)))
    if bad.size:
        raise _sigma_range_error(sig[bad[0]])


def _simulated_sigmas(rho: NDArray[np.float64], depth_factor: float, min_sigma: float) -> NDArray[np.float64]:
    """``max(min_sigma, rho^2 / depth_factor)`` (eq. 6, :func:`depth_sigma`) of the depths ``rho (k,)``,
    checked by ``_sigmas`` (an overflow is reported as a sigma outside the range, as before)."""
    with np.errstate(over="ignore", invalid="ignore"):
        if not np.all(np.isfinite(np.square(rho) / depth_factor)):  # eq. 6 overflows
            raise _sigma_range_error(np.inf)
    sig = np.asarray(depth_sigma(rho, depth_factor, min_sigma=min_sigma), dtype=np.float64)
    _sigmas(sig)
    return sig


def _bounded_positions(pos: NDArray[np.float64]) -> None:
    """Simulated positions must respect :data:`perception.frontend.percept.MAX_COORDINATE`."""
    from ..frontend.percept import MAX_COORDINATE

    bad = np.flatnonzero(np.any(~(np.abs(pos) <= MAX_COORDINATE), axis=1)) if pos.size else np.zeros(0, int)
    if bad.size:
        i = int(bad[0])
        raise PerceptionError(
            f"simulated position {pos[i].tolist()} (from world_positions, depth_factor, min_sigma and "
            f"max_range) exceeds {MAX_COORDINATE:g} m in magnitude; choose them so that it does not"
        )


def _false_type_pool(false_types: Sequence[str] | None, present: Sequence[str]) -> list[str]:
    if false_types is None:
        return sorted(set(present))
    return sequence("false_types", false_types)


def simulate_percepts(
    types: Sequence[str],
    world_positions: ArrayLike,
    world_from_ego: ArrayLike,
    rng: np.random.Generator,
    *,
    depth_factor: float = 1000.0,
    max_range: float = 8.0,
    hfov_deg: float | None = None,
    n_false: int = 0,
    false_types: Sequence[str] | None = None,
    miss_rate: float = 0.0,
    min_sigma: float = 1e-4,
) -> tuple[list[Percept], NDArray[np.int64]]:
    """Already-fused percepts of the visible objects of a scene (one per object).

    An object is visible when its distance ``rho`` from the ego origin is at most
    ``max_range`` and, if ``hfov_deg`` is given, its azimuth about ego +x lies within
    ``±hfov_deg / 2``. Each visible object that is not missed (probability ``miss_rate``)
    gives a percept at ``ego_from_world @ X + N(0, sigma^2 I)`` with
    ``sigma = max(min_sigma, rho^2 / depth_factor)`` (eq. 6). ``n_false`` false percepts of
    types drawn from ``false_types`` (default: the types present) are placed uniformly in
    the visible region. The order of the percepts is shuffled by ``rng``.

    Parameters
    ----------
    types : (n,) sequence of str
        Object class of each world position.
    world_positions : (n, 3) float
        Object positions in the world frame.
    world_from_ego : (4, 4) float
        Rigid pose of the ego frame in the world.
    rng : numpy.random.Generator
        Source of all randomness.
    depth_factor, max_range, min_sigma : float
        Noise model and visibility range, all > 0.
    hfov_deg : float, optional
        Horizontal field of view about ego +x, degrees, in (0, 360].
    n_false : int
        Number of false percepts (>= 0).
    false_types : sequence of str, optional
        Classes of the false percepts.
    miss_rate : float
        Probability that a visible object is not perceived, in [0, 1].

    Returns
    -------
    percepts : list of Percept
        Ego-frame percepts, ``views = 1``, ``covariance = sigma^2 I``.
    truth : (k,) int
        Index into ``world_positions`` of each percept, or -1 for a false percept.
    """
    X = _positions(world_positions)
    tps = _types(types, X.shape[0])
    M = check_transform("world_from_ego", world_from_ego)
    rng = _rng(rng)
    depth_factor = _positive("depth_factor", depth_factor)
    max_range = _positive("max_range", max_range)
    min_sigma = _positive("min_sigma", min_sigma)
    miss_rate = _rate("miss_rate", miss_rate)
    n_false = integer("n_false", n_false, minimum=0, maximum=MAX_COUNT)
    half_fov = None
    if hfov_deg is not None:
        h = real_scalar("hfov_deg", hfov_deg, positive=True, maximum=360.0)
        half_fov = np.radians(h) / 2.0

    R, t = M[:3, :3], M[:3, 3]
    P = (X - t) @ R  # ego_from_world applied to each row: R^T (X - t)
    rho = np.linalg.norm(P, axis=1)
    visible = rho <= max_range
    if half_fov is not None:
        visible &= np.abs(np.arctan2(P[:, 1], P[:, 0])) <= half_fov
    kept = visible & (rng.random(X.shape[0]) >= miss_rate)
    idx = np.flatnonzero(kept)
    sig = _simulated_sigmas(rho[idx], depth_factor, min_sigma)
    noisy = P[idx] + rng.standard_normal((idx.size, 3)) * sig[:, None]

    pool = _false_type_pool(false_types, tps)
    if n_false and not pool:
        raise PerceptionError("n_false > 0 needs false_types or at least one object type, got none")
    fpos = _uniform_visible(rng, n_false, max_range, half_fov)
    ftype = [pool[int(k)] for k in rng.integers(0, len(pool), n_false)] if n_false else []
    fsig = _simulated_sigmas(np.linalg.norm(fpos, axis=1), depth_factor, min_sigma)

    all_types = [tps[i] for i in idx] + ftype
    all_pos = np.vstack([noisy, fpos])
    _bounded_positions(all_pos)
    all_sig = np.concatenate([sig, fsig])
    all_truth = np.concatenate([idx, -np.ones(n_false, dtype=np.int64)]).astype(np.int64)
    order = rng.permutation(all_truth.size)
    percepts = [
        Percept(all_types[k], all_pos[k], float(all_sig[k]), covariance=all_sig[k] ** 2 * np.eye(3))
        for k in order
    ]
    return percepts, all_truth[order]


def _uniform_visible(
    rng: np.random.Generator, n: int, max_range: float, half_fov: float | None
) -> NDArray[np.float64]:
    """``n`` points uniform in the ball of radius ``max_range`` (azimuth limited by ``half_fov``)."""
    if n == 0:
        return np.zeros((0, 3))
    d = rng.standard_normal((n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    r = max_range * rng.random(n) ** (1.0 / 3.0)
    p = d * r[:, None]
    if half_fov is not None:
        # The ball is symmetric about z: redrawing the azimuth uniformly keeps the density uniform.
        az = rng.uniform(-half_fov, half_fov, n)
        horiz = np.hypot(p[:, 0], p[:, 1])
        p[:, 0] = horiz * np.cos(az)
        p[:, 1] = horiz * np.sin(az)
    return p


def _range_pair(name: str, value: tuple[float, float]) -> tuple[float, float]:
    arr = real_array(name, value, (2,))
    if np.any(np.abs(arr) > 360.0):
        raise PerceptionError(f"{name} must hold two angles in [-360, 360] degrees, got {arr.tolist()}")
    return float(arr[0]), float(arr[1])


def scan_angles(
    chain: KinematicChain,
    n_views: int,
    yaw_deg: tuple[float, float] = (-70.0, 70.0),
    pitch_deg: tuple[float, float] = (-10.0, 10.0),
) -> NDArray[np.float64]:
    """Joint angles of a scanning trajectory: a neck-yaw sweep with a neck-pitch zigzag.

    View ``k`` has neck yaw ``linspace(*yaw_deg, n_views)[k]`` and neck pitch alternating
    between the two ``pitch_deg`` values; all other joints are zero. Needs joints named
    ``neck_yaw`` and ``neck_pitch`` (as in :func:`default_head`).

    Returns
    -------
    (n_views, chain.n_joints) float
        Radians, in the order of ``chain.names``.
    """
    if not isinstance(chain, KinematicChain):
        raise PerceptionError(f"chain must be a KinematicChain, got {type(chain).__name__}")
    names = chain.names
    for need in ("neck_yaw", "neck_pitch"):
        if need not in names:
            raise PerceptionError(f"scan_angles needs a joint named {need!r}; the chain has {list(names)}")
    n_views = integer("n_views", n_views, minimum=1, maximum=MAX_VIEWS)
    yaw = _range_pair("yaw_deg", yaw_deg)
    pitch = _range_pair("pitch_deg", pitch_deg)
    Q = np.zeros((n_views, chain.n_joints))
    Q[:, names.index("neck_yaw")] = np.radians(np.linspace(yaw[0], yaw[1], n_views))
    pitch_rows = np.where(np.arange(n_views) % 2 == 0, pitch[0], pitch[1])
    Q[:, names.index("neck_pitch")] = np.radians(pitch_rows)
    return Q


def simulate_scan(
    types: Sequence[str],
    world_positions: ArrayLike,
    world_from_ego: ArrayLike,
    rng: np.random.Generator,
    *,
    chain: KinematicChain | None = None,
    rig: StereoRig | None = None,
    n_views: int = 20,
    depth_factor: float = 1000.0,
    miss_rate: float = 0.05,
    false_rate: float = 0.02,
    max_range: float = 8.0,
    return_truth: bool = False,
    min_sigma: float = 1e-4,
    yaw_deg: tuple[float, float] = (-70.0, 70.0),
    pitch_deg: tuple[float, float] = (-10.0, 10.0),
    encoder_sigma: float | ArrayLike = 0.0,
) -> list[Percept] | tuple[list[Percept], NDArray[np.int64]]:
    """Raw percepts of a scanning head (one :class:`Percept` per detection per view).

    For each head pose of :func:`scan_angles` the objects in front of both cameras, inside the
    left image and within ``max_range`` of the left camera are detected with probability
    ``1 - miss_rate``; each detection is ``x_cam + N(0, sigma^2 I)`` in the left camera frame
    with ``sigma = max(min_sigma, rho^2 / depth_factor)`` (eq. 6) and ``rho`` the depth along
    the optical axis (eq. 7), mapped to the ego frame by ``chain.ego_from_camera``. Per view,
    ``Binomial(n_visible, false_rate)`` false percepts of types present in the scene appear at
    uniform pixels and depths in ``[0.5, max_range]``.

    Parameters
    ----------
    types : (n,) sequence of str
    world_positions : (n, 3) float
    world_from_ego : (4, 4) float
    rng : numpy.random.Generator
    chain : KinematicChain, optional
        Default :func:`default_head`.
    rig : StereoRig, optional
        Default :meth:`StereoRig.default` (its left camera defines the field of view).
    n_views : int
    depth_factor, max_range, min_sigma : float
        > 0.
    miss_rate, false_rate : float
        In [0, 1].
    return_truth : bool
        Also return the index of the object behind each percept (-1: false percept).
    encoder_sigma : float or (n_joints,) float
        Standard deviation of each joint encoder (radians, >= 0; default 0: exact encoders).
        Per view the head really stands at the read angles plus ``N(0, encoder_sigma^2)``, one
        draw shared by every percept of the view; each percept then carries that shared part
        as ``shared=((view, J diag(encoder_sigma)),)`` (``J`` the chain's
        :meth:`~perception.KinematicChain.point_jacobian`) and its covariance is
        ``sigma^2 I + J diag(encoder_sigma^2) J^T``.

    Returns
    -------
    list of Percept, or (list of Percept, (k,) int)
    """
    X = _positions(world_positions)
    tps = _types(types, X.shape[0])
    M = check_transform("world_from_ego", world_from_ego)
    rng = _rng(rng)
    chain = default_head() if chain is None else chain
    rig = StereoRig.default() if rig is None else rig
    if not isinstance(chain, KinematicChain):
        raise PerceptionError(f"chain must be a KinematicChain, got {type(chain).__name__}")
    rig = as_stereo_rig(rig)
    return_truth = boolean("return_truth", return_truth)
    n_views = integer("n_views", n_views, minimum=1, maximum=MAX_VIEWS)
    depth_factor = _positive("depth_factor", depth_factor)
    max_range = _positive("max_range", max_range)
    min_sigma = _positive("min_sigma", min_sigma)
    miss_rate = _rate("miss_rate", miss_rate)
    false_rate = _rate("false_rate", false_rate)
    enc = real_array("encoder_sigma", encoder_sigma)
    enc = np.full(chain.n_joints, float(enc)) if enc.ndim == 0 else enc
    if enc.shape != (chain.n_joints,):
        raise PerceptionError(f"encoder_sigma must be a scalar or shape ({chain.n_joints},), "
                              f"got shape {enc.shape}")
    if np.any(enc < 0) or np.any(enc > 0.5):
        i = int(np.flatnonzero((enc < 0) | (enc > 0.5))[0])
        raise PerceptionError(f"encoder_sigma[{i}] = {float(enc[i])!r} must lie in [0, 0.5] rad")
    encoders_err = bool(np.any(enc > 0))  # draw nothing extra when exact: seeded scans stay as they were
    pool = sorted(set(tps))
    Kinv = np.linalg.inv(rig.K1)
    w, h = rig.image_size
    Xh = np.hstack([X, np.ones((X.shape[0], 1))])

    out_types: list[str] = []
    out_pos: list[NDArray[np.float64]] = []
    out_sig: list[NDArray[np.float64]] = []
    out_truth: list[NDArray[np.int64]] = []
    out_shared: list[list[tuple[tuple[int, NDArray[np.float64]], ...]]] = []
    for view, q in enumerate(scan_angles(chain, n_views, yaw_deg, pitch_deg)):
        ego_from_cam = chain.ego_from_camera(q)
        q_true = q + rng.standard_normal(q.shape) * enc if encoders_err else q
        cam_from_world = np.linalg.inv(M @ chain.ego_from_camera(q_true))
        P = (Xh @ cam_from_world.T)[:, :3]
        vis = (np.linalg.norm(P, axis=1) <= max_range) & rig.in_view(P)
        n_vis = int(vis.sum())
        detected = np.flatnonzero(vis & (rng.random(X.shape[0]) >= miss_rate))
        n_false = int(rng.binomial(n_vis, false_rate)) if pool else 0
        uv = np.column_stack([rng.uniform(0, w, n_false), rng.uniform(0, h, n_false), np.ones(n_false)])
        depth = rng.uniform(min(0.5, max_range), max_range, n_false)
        F = (uv @ Kinv.T) * depth[:, None]
        cam = np.vstack([P[detected], F])
        sig = _simulated_sigmas(cam[:, 2], depth_factor, min_sigma)
        noisy = cam + rng.standard_normal(cam.shape) * sig[:, None]
        ego = noisy @ ego_from_cam[:3, :3].T + ego_from_cam[:3, 3]
        out_types += [tps[i] for i in detected] + [pool[int(k)] for k in rng.integers(0, len(pool), n_false)]
        out_pos.append(ego)
        out_sig.append(sig)
        out_truth.append(np.concatenate([detected, -np.ones(n_false, dtype=np.int64)]).astype(np.int64))
        jacobians = chain.point_jacobians(q, cam) * enc if encoders_err else None
        out_shared.append([((view, jacobians[k]),) for k in range(cam.shape[0])] if jacobians is not None
                          else [()] * cam.shape[0])
    pos = np.vstack(out_pos) if out_pos else np.zeros((0, 3))
    _bounded_positions(pos)
    sigs = np.concatenate(out_sig) if out_sig else np.zeros(0)
    truth = np.concatenate(out_truth) if out_truth else np.zeros(0, dtype=np.int64)
    shared = [sh for view in out_shared for sh in view]
    percepts = []
    for t, p, s, sh in zip(out_types, pos, sigs, shared, strict=True):
        cov = s**2 * np.eye(3) + sum((S @ S.T for _, S in sh), np.zeros((3, 3)))
        u = p / max(float(np.linalg.norm(p)), TINY)
        range_sigma = float(np.sqrt(u @ cov @ u)) if sh else float(s)  # std of the range |p|
        percepts.append(Percept(t, p, range_sigma, covariance=cov, shared=sh))
    if return_truth:
        return percepts, truth
    return percepts
