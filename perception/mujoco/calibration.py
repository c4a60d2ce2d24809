"""Measuring the front ends' centre offsets and stereo disparity errors on a scene's exact
renders (methods of :class:`~perception.mujoco.MujocoScene`)."""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._checks import (
    check_transform,
    integer,
    real_array,
)
from ..errors import (
    PerceptionError,
)
from ..frontend.detection_percepts import (
    CENTRE_DEPTH_FLOOR,
    DEPTH_NOISE,
    CentreOffset,
    touches_border,
    visible_anchor,
)
from ..frontend.outline import DisparityError, outline_disparity, split_spread
from ..frontend.rgbd import depth_windows, rgbd_percepts
from ..frontend.stereo_pairs import DISPARITY_STD_PX, extent_middle, extents_differ, match_stereo
from ..head.chain import KinematicChain
from .records import CALIBRATION_POSES, CALIBRATION_SEED, CENTRE_LATERAL_FLOOR, StereoCalibration, _image_size
from .scanning import _view_rig

# The functions here are methods of MujocoScene (perception.mujoco.scene), documented there.
__all__: list[str] = []
def default_centre_offsets(self: Any) -> dict[str, CentreOffset]:
    """The centre offsets :meth:`scan` uses by default: :meth:`centre_offsets` measured on
    exact renders (320x240, 8 views each) from :data:`CALIBRATION_POSES` poses of
    :meth:`robot_poses` drawn with a fixed
    seed (:data:`CALIBRATION_SEED`), once per scene; types never seen whole fall back to
    :meth:`centre_depths`.  The analogue of measuring a detector's classes on its training
    objects: the poses are not those of any scan.  A scene with no free floor to stand on
    warns and uses :meth:`centre_depths` alone."""
    if self._default_offsets is None:
        fallback = {t: CentreOffset(d) for t, d in self.centre_depths().items()}
        try:
            poses = self.robot_poses(CALIBRATION_POSES, np.random.default_rng(CALIBRATION_SEED))
        except PerceptionError as exc:  # nowhere to stand: the geometry's guess alone, said aloud
            warnings.warn(f"centre offsets not measured ({exc}); using centre_depths()", stacklevel=2)
            measured = {}
        else:
            measured = self.centre_offsets(poses, n_views=8, image_size=(320, 240))
        self._default_offsets = fallback | measured
    return dict(self._default_offsets)


def centre_offsets(self: Any,
                   world_from_egos: Any, *, n_views: int = 20, image_size: Any = (320, 240),
                   chain: KinematicChain | None = None, min_pixels: int = 20) -> dict[str, CentreOffset]:
    """Measure on renders where each type's centre lies from its visible part.

    Exact scans (no noise, no degradation) from the given robot poses; for every object
    the depth front end keeps (:func:`perception.rgbd_percepts`: not cut off by the image
    border, not occluded, at least ``min_pixels`` pixels with depth), the visible part is its
    pixels back-projected with their depth, and the offset is the object's centre
    (:attr:`objects <perception.mujoco.MujocoScene.objects>`) minus the part's centroid, split as the front
    ends split it (:mod:`perception.frontend`): along the direction away from the camera
    (the visible surface's normal when it is flat, its smallest variance below
    :data:`~perception.frontend.detection_percepts.FLAT_RATIO` times the middle one, else the viewing ray)
    and across it.

    Parameters
    ----------
    world_from_egos : (4, 4) or (m, 4, 4) float
        Robot poses to scan from (in free space, seeing the objects as the robot would).
    n_views : int
        Views per pose (:meth:`scan`).
    image_size : (int, int)
        ``(width, height)``, pixels.
    chain : KinematicChain, optional
        The head; :func:`perception.default_head` by default.
    min_pixels : int
        Fewest pixels of a view of an object to measure it.

    Returns
    -------
    dict of str to CentreOffset
        Per type seen: ``depth`` the median of the offsets along the direction, ``depth_sd``
        their root mean square about it and ``lateral_sd`` the root mean square per axis of
        the offsets across it (the odd badly seen view included: a prior that covers the
        views the front end keeps, tails and all; at least
        :data:`~perception.frontend.detection_percepts.CENTRE_DEPTH_FLOOR` and :data:`CENTRE_LATERAL_FLOOR`).
        Types never measured are left out (the front ends then use the visible relief).

    Raises
    ------
    PerceptionError
        - A pose that is not a rigid transform.
        - A bad ``n_views``, ``image_size``, ``chain`` or ``min_pixels``.
    """
    checked = self._calibration_poses(world_from_egos)
    min_px = integer("min_pixels", min_pixels, minimum=1)
    along: dict[str, list[float]] = {}
    across: dict[str, list[float]] = {}
    for pose in checked:
        scan = self.scan(pose, "rgbd", n_views, rng=np.random.default_rng(0), image_size=image_size,
                         chain=chain, depth_noise=0.0, percepts=False, max_range=1e6)
        for view in scan.views:
            assert view.depth is not None
            h, w = view.depth.shape
            Kinv = np.linalg.inv(view.K)
            camera_from_world = np.linalg.inv(pose @ view.ego_from_camera)
            up = view.ego_from_camera[:3, :3].T @ np.array([0.0, 0.0, 1.0])
            # only what the front end keeps (not cut off, not occluded, enough depth)
            kept = set(rgbd_percepts(view.detections, view.depth, view.K, np.eye(4), centre_offset=0.0,
                                     min_pixels=min_px).sources)
            for i, (det, k) in enumerate(zip(view.detections, view.truth, strict=True)):
                if i not in kept or k < 0:
                    continue
                assert det.mask is not None  # the renderer's detections carry masks
                v, u = np.nonzero(det.mask)
                z = view.depth[v, u]
                ok = np.isfinite(z)
                if int(ok.sum()) < min_px:
                    continue
                box = np.array([u.min(), v.min(), u.max(), v.max()], dtype=np.float64)
                _, (lo, hi) = depth_windows(det.mask, box, view.depth, DEPTH_NOISE, z[ok])
                fg = ok & (z >= lo) & (z <= hi)  # the object's depths, as the front end takes them
                pts = (Kinv @ np.stack([u[fg], v[fg], np.ones(int(fg.sum()))])).T * z[fg, None]
                anchor, direction, _ = visible_anchor(pts, up)  # as the front end places it
                centre = camera_from_world[:3, :3] @ self._objects[k].position + camera_from_world[:3, 3]
                offset = centre - anchor
                d = float(offset @ direction)
                typ = self._objects[k].type
                along.setdefault(typ, []).append(d)
                across.setdefault(typ, []).append(float(np.linalg.norm(offset - d * direction)))
    out: dict[str, CentreOffset] = {}
    for typ in sorted(along):
        d_all = np.array(along[typ])
        median = float(np.median(d_all))
        depth_sd = float(np.sqrt(np.mean(np.square(d_all - median))))
        lateral = float(np.sqrt(np.mean(np.square(across[typ])) / 2.0))
        out[typ] = CentreOffset(median, max(depth_sd, CENTRE_DEPTH_FLOOR),
                                max(lateral, CENTRE_LATERAL_FLOOR))
    return out


def default_stereo_offsets(self: Any, image_size: Any = (640, 480), mask_jitter_px: int = 0
                           ) -> StereoCalibration:
    """The stereo front end's settings a stereo :meth:`scan` uses by default:
    :meth:`stereo_offsets` measured from the poses :meth:`default_centre_offsets` uses (8 views
    each) at the scan's image size and mask jitter (an outline's errors depend on both: the
    analogue of measuring a detector's classes on its training objects), once per scene and
    setting; types never measured take :meth:`default_centre_offsets` and the centroids."""
    key = (_image_size(image_size), integer("mask_jitter_px", mask_jitter_px, minimum=0, maximum=1000))
    if key not in self._default_stereo:
        try:
            poses = self.robot_poses(CALIBRATION_POSES, np.random.default_rng(CALIBRATION_SEED))
        except PerceptionError as exc:
            warnings.warn(f"stereo offsets not measured ({exc}); using default_centre_offsets()",
                          stacklevel=2)
            measured = StereoCalibration({}, {}, {})
        else:
            measured = self.stereo_offsets(poses, n_views=8, image_size=key[0], mask_jitter_px=key[1])
        self._default_stereo[key] = StereoCalibration(
            self.default_centre_offsets() | measured.centre_offset, measured.disparity_error,
            measured.disparity_from)
    return self._default_stereo[key]


def stereo_offsets(self: Any,
                   world_from_egos: Any, *, n_views: int = 20, image_size: Any = (320, 240),
                   chain: KinematicChain | None = None, min_pixels: int = 20, mask_jitter_px: int = 0
                   ) -> StereoCalibration:
    """Measure on stereo renders, per type, where its centre lies from the point the stereo
    front end triangulates, how the disparity errs, and which disparity (the centroids' or
    the outline's) places it better.

    Exact stereo scans from the given poses; every pair :func:`perception.stereo_percepts`
    would keep (same object in both images, not cut off, extents that agree, an outline
    disparity: :func:`perception.outline_disparity` at the middle of the left mask's extent)
    gives, for each source, the offset ``o`` of the object's centre from the triangulated
    point (outline: the extent's middle at the outline's disparity; centroids: the two
    centroids), along the viewing ray and across it.  Per type and source: the centre
    offset's ``depth`` is the median of ``o`` along the ray.  The residuals about it, in
    pixels of disparity, beyond what the front end already models (outline: each pair's
    standard error and :data:`~perception.DISPARITY_ENDS_FRACTION` times its ends'
    difference; centroids: ``DISPARITY_STD_PX``), split into the part the views of one
    object in one scan share (``depth_sd``, metres: it does not average out when the views
    are fused) and the part that varies from view to view (the outline's
    :class:`~perception.DisparityError` ``sd_px``; for the centroids it is counted as
    shared), each the spread at which the residuals' mean squared standard score is 1; with
    no object seen twice in a scan all of it is shared.  The ``lateral_sd`` is the root mean
    square per axis of ``o`` across the ray.  The source whose views place the centre with the
    smaller mean squared error (along the ray about the median, and across it) is the type's
    ``disparity_from``.

    Parameters and errors as :meth:`centre_offsets`; ``mask_jitter_px`` moves the masks' edges
    as :meth:`scan` does (the detector the offsets are for), with a fixed seed.

    Returns
    -------
    StereoCalibration
        Per type measured in at least two views.
    """
    checked = self._calibration_poses(world_from_egos)
    min_px = integer("min_pixels", min_pixels, minimum=1)
    # per type and source: (object-in-scan id, along, px per m, own sd px, ends px, across)
    rows: dict[tuple[str, str], list[tuple[int, float, float, float, float, float]]] = {}
    group = 0
    for pose in checked:
        scan = self.scan(pose, "stereo", n_views, rng=np.random.default_rng(0), image_size=image_size,
                         chain=chain, percepts=False, max_range=1e6, mask_jitter_px=mask_jitter_px)
        groups: dict[int, int] = {}
        for view in scan.views:
            h, w = view.segmentation.shape
            rig = _view_rig(view)
            rect = rig.rectify()
            camera_from_world = np.linalg.inv(pose @ view.ego_from_camera)
            for m in match_stereo(rig, view.detections, view.right_detections, min_depth=0.3):
                dl, dr = view.detections[m.left], view.right_detections[m.right]
                k = view.truth[m.left]
                if (k < 0 or k != view.right_truth[m.right] or dl.box is None or dr.box is None
                        or dl.area is None or dr.area is None or dl.area < min_px or dr.area < min_px
                        or touches_border(dl.box, w, h) or touches_border(dr.box, w, h)
                        or extents_differ(dl, dr)):
                    continue
                at = extent_middle(dl)
                od = outline_disparity(rig, dl, dr, rect, at=at)
                if od is None or od.disparity <= 0.0:
                    continue
                centre = camera_from_world[:3, :3] @ self._objects[k].position + camera_from_world[:3, 3]
                measured = []
                try:
                    for source, uv_l, uv_r, duv, sd, ends in (
                            ("outline", at, od.uv_right, od.duv_right, od.sd, od.ends_differ_px),
                            ("centroids", np.asarray(dl.centroid_uv), np.asarray(dr.centroid_uv),
                             od.duv_right, DISPARITY_STD_PX, 0.0)):
                        X = rig.triangulate(uv_l[None, :], uv_r[None, :])[0]
                        # pixels of disparity per metre along the ray, at this depth
                        X2 = rig.triangulate(uv_l[None, :], (uv_r + duv)[None, :])[0]
                        measured.append((source, X, 1.0 / float(np.linalg.norm(X - X2)), sd, ends))
                except PerceptionError:  # at infinity: nothing to learn from this pair
                    continue
                g = groups.setdefault(k, group + len(groups))
                for source, X, per_m, sd, ends in measured:
                    ray = X / np.linalg.norm(X)
                    offset = centre - X
                    along = float(offset @ ray)
                    rows.setdefault((self._objects[k].type, source), []).append(
                        (g, along, per_m, sd, ends, float(np.linalg.norm(offset - along * ray))))
        group += len(groups)
    offsets: dict[str, CentreOffset] = {}
    errors: dict[str, DisparityError] = {}
    sources: dict[str, str] = {}
    for typ in sorted({t for t, _ in rows}):
        best = None
        for source in ("outline", "centroids"):
            r = np.array(rows[typ, source])
            if len(r) < 2:
                continue
            g, along, per_m, sd, ends, across = r.T
            depth = float(np.median(along))
            res_px = (along - depth) * per_m  # the sign does not matter for the spreads
            sd_px, shared_px = split_spread(g.astype(np.int64), res_px, sd, ends)
            if source == "centroids":  # the front end adds nothing per view to the centroids
                sd_px, shared_px = 0.0, float(np.hypot(sd_px, shared_px))
            depth_sd = max(shared_px / float(np.median(per_m)), CENTRE_DEPTH_FLOOR)
            lateral = max(float(np.sqrt(np.mean(across ** 2) / 2.0)), CENTRE_LATERAL_FLOOR)
            # the views' mean squared error about the centre, along the ray and across it
            expected = float(np.mean((along - depth) ** 2 + across ** 2))
            if best is None or expected < best[0]:
                best = (expected, source, CentreOffset(depth, depth_sd, lateral),
                        DisparityError(0.0, sd_px))
        if best is not None:
            _, sources[typ], offsets[typ], errors[typ] = best
    return StereoCalibration(offsets, errors, sources)


def _calibration_poses(self: Any, world_from_egos: Any) -> list[NDArray[np.float64]]:
    poses = real_array("world_from_egos", world_from_egos)
    if poses.shape[-2:] != (4, 4) or poses.ndim not in (2, 3) or poses.size == 0:
        raise PerceptionError(f"world_from_egos must be a (4, 4) or (m, 4, 4) array, got shape "
                              f"{poses.shape}")
    return [check_transform(f"world_from_egos[{i}]", T) for i, T in enumerate(poses.reshape(-1, 4, 4))]
