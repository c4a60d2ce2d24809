"""The paper's recognition: colour regions classified into typed detections (:func:`detect`,
with a classifier from :func:`train_classifier`), and detections of a stereo pair to percepts
(:func:`recognize`)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._checks import boolean, integer, real_scalar
from .._checks import generator as check_rng
from ..errors import (
    PerceptionError,
)
from ..frontend.detection import Detection
from ..frontend.percept import Percept
from ..frontend.stereo_pairs import DISPARITY_STD_PX, match_stereo
from ..head.chain import check_transform
from ..head.uncertainty import depth_sigma, triangulation_jacobian
from ..simulation.render import MAX_RENDER_PIXELS, random_scene, render_labels, render_stereo, rig_render_size
from ..tolerances import SIGMA_COVARIANCE_FACTOR
from .classifier import GaussianClassifier
from .segmentation import (
    COLOR_RANGES,
    FEATURE_NAMES,
    ColorRange,
    _check_image,
    _region_stats,
    region_features,
)

__all__ = ["CENTROID_OFFSET_SCALE", "detect", "recognize", "train_classifier"]


# --------------------------------------------------------------------------------------------
# Detection and classification (segmentation: perception.recognition.segmentation; classifier:
# perception.recognition.classifier)
# --------------------------------------------------------------------------------------------


def detect(
    image: NDArray[np.uint8],
    classifier: GaussianClassifier,
    *,
    color_ranges: Mapping[str, ColorRange] = COLOR_RANGES,
    min_area: int = 12,
    exclude_border: bool = True,
) -> list[Detection]:
    """Colour-segment, describe and classify the regions of one BGR image.

    Parameters
    ----------
    image : (height, width, 3) uint8
        BGR image.
    classifier : GaussianClassifier
    color_ranges : mapping of str to ColorRange
        HSV ranges segmented separately.
    min_area : int
        Smallest region kept, pixels.
    exclude_border : bool
        Drop regions touching the image border: their centroid is biased (cut off), which
        would corrupt the disparity.

    Returns
    -------
    list of Detection
        Accepted regions, in segmentation order.
    """
    if not isinstance(classifier, GaussianClassifier):
        raise PerceptionError(f"classifier must be a GaussianClassifier, got {type(classifier).__name__}")
    exclude_border = boolean("exclude_border", exclude_border)
    feats, cents, areas, border, moments = _region_stats(image, color_ranges, min_area)
    if exclude_border:
        feats, cents, areas, moments = feats[~border], cents[~border], areas[~border], moments[~border]
    if len(feats) == 0:
        return []
    labels, score = classifier.predict(feats)
    return [
        Detection(type=lab, centroid_uv=cents[i], area=float(areas[i]), features=feats[i],
                  log_likelihood=float(score[i]), shape_covariance=moments[i])
        for i, lab in enumerate(labels)
        if lab is not None
    ]


def _training_samples(
    rig: Any, rng: np.random.Generator, n_scenes: int, min_area: int
) -> tuple[NDArray[np.float64], list[str]]:
    feats_all, labels_all = [], []
    for _ in range(n_scenes):
        boxes, pose = random_scene(rng)
        images = render_stereo(rig, pose, boxes, rng)
        label_maps = render_labels(rig, pose, boxes)
        for image, lab_map in zip(images, label_maps, strict=True):
            feats, cents, _, border = region_features(image, min_area=min_area)
            for f, (u, v) in zip(feats[~border], cents[~border], strict=True):
                i = lab_map[int(round(v)), int(round(u))]
                if i >= 0 and boxes[i].type != "clutter":
                    feats_all.append(f)
                    labels_all.append(boxes[i].type)
    return np.array(feats_all).reshape(-1, len(FEATURE_NAMES)), labels_all


def train_classifier(
    rig: Any, rng: np.random.Generator, n_scenes: int = 30, *, min_area: int = 12, **fit_kwargs: Any
) -> GaussianClassifier:
    """Fit a :class:`GaussianClassifier` on rendered scenes with known labels.

    Renders ``n_scenes`` :func:`random_scene` stereo pairs, segments both images, labels each
    region by the box seen at its centroid in :func:`render_labels` (regions of clutter boxes
    or background are left out, so the threshold has to reject them; so are regions touching
    the image border, which :func:`detect` drops) and fits.

    Parameters
    ----------
    rig : StereoRig
    rng : numpy.random.Generator
    n_scenes : int
        Number of rendered scenes, >= 1.
    min_area : int
        Smallest region, pixels.
    **fit_kwargs
        Passed to :meth:`GaussianClassifier.fit`.
    """
    rig_render_size(rig)
    rng = check_rng("rng", rng)
    n_scenes = integer("n_scenes", n_scenes, minimum=1, maximum=100_000)
    min_area = integer("min_area", min_area, minimum=1, maximum=MAX_RENDER_PIXELS)
    feats, labels = _training_samples(rig, rng, n_scenes, min_area)
    try:
        return GaussianClassifier.fit(feats, labels, **fit_kwargs)
    except PerceptionError as exc:
        raise PerceptionError(
            f"training on n_scenes={n_scenes} scenes with min_area={min_area} px failed: {exc}"
        ) from exc


# --------------------------------------------------------------------------------------------
# Percepts from matched pairs
# --------------------------------------------------------------------------------------------


#: Standard deviation of the offset between a region's centroid and the projection of the
#: object's centre, as a fraction of the region's own pixel standard deviation (per axis of
#: its pixel covariance). The silhouette centroid is not the image of the box centre: the
#: image of an obliquely viewed face is compressed on its far side, so its centroid lies
#: towards the near side (perspective foreshortening: doors seen with the camera pitched by a
#: few degrees), side faces of the box's depth extent
#: are seen or not, and nearer objects occlude parts of it -- offsets that scale with the
#: region's extent and shift the centroid in the left and the right image alike (a lateral
#: offset of the 3D point, not a disparity error; measured: docs/design.md#defaults).
CENTROID_OFFSET_SCALE: float = 0.08



def _percept_covariances(
    rig: Any,
    uv_l: NDArray[np.float64],
    uv_r: NDArray[np.float64],
    shape: NDArray[np.float64],
    pixel_sigma: float,
    offset_scale: float,
) -> NDArray[np.float64]:
    """Covariances (n, 3, 3) of triangulated region centroids, left camera frame.

    Pixel covariance of ``(u_L, v_L, u_R, v_R)``: independent centroid noise ``pixel_sigma``
    per coordinate plus a centroid offset ``offset_scale**2 * shape`` (the region's pixel
    covariance, (n, 2, 2)) common to both images; mapped by the triangulation Jacobian.
    """
    J = triangulation_jacobian(rig, uv_l, uv_r)  # (n, 3, 4)
    common = J[:, :, :2] + J[:, :, 2:]  # effect of the same shift in both images
    return pixel_sigma**2 * np.einsum("nik,njk->nij", J, J) + offset_scale**2 * np.einsum(
        "nik,nkl,njl->nij", common, shape, common
    )


def _default_depth_factor(rig: Any, disparity_std_px: float) -> float:
    focal = float(np.asarray(rig.K1, np.float64)[0, 0])
    baseline = float(np.linalg.norm(np.asarray(rig.T, np.float64)))
    return focal * baseline / disparity_std_px


def recognize(
    rig: Any,
    left: NDArray[np.uint8],
    right: NDArray[np.uint8],
    classifier: GaussianClassifier,
    *,
    depth_factor: float | None = None,
    disparity_std_px: float = DISPARITY_STD_PX,
    pixel_sigma: float | None = None,
    centroid_offset_scale: float = CENTROID_OFFSET_SCALE,
    ego_from_camera: ArrayLike | None = None,
    max_epipolar_px: float = 2.0,
    min_area: int = 12,
) -> list[Percept]:
    """Percepts from a stereo pair: detect, match, triangulate, attach the eq. 6 sigma.

    The covariance of a percept is ``J P J^T`` with ``J`` the triangulation Jacobian w.r.t.
    ``(u_L, v_L, u_R, v_R)`` and the pixel covariance ``P = pixel_sigma^2 I_4 +
    centroid_offset_scale^2 [[S, S], [S, S]]``, ``S`` the mean pixel covariance of the two
    matched regions (:attr:`Detection.shape_covariance`). The first term is the centroid's own
    noise (the disparity error); the second the centroid's offset from the image of the
    object's centre (perspective foreshortening of oblique faces, visible side faces,
    occlusion), which moves the point across the viewing ray but hardly along it. On the
    :func:`random_scene` renders the defaults give a mean NEES ``e^T C^-1 e`` of the box
    centre of 2.3-2.6 with 96-99 % of percepts within 3 sigma (chi^2_3: 3 and 99.7 %);
    without the offset term it is 140-470 (tests/perception/test_recognition.py).

    Parameters
    ----------
    rig : StereoRig
    left, right : (height, width, 3) uint8
        BGR images of ``rig.image_size``.
    classifier : GaussianClassifier
    depth_factor : float, optional
        Eq. 6 factor, ``sigma = rho**2 / depth_factor`` with rho the depth along the left
        optical axis (eq. 7). Default: ``f b / disparity_std_px`` (the first-order depth
        error of a disparity error ``disparity_std_px``, eq. 8).
    disparity_std_px : float
        Disparity error assumed by the default depth factor, pixels; default
        :data:`DISPARITY_STD_PX` (centroid quantisation).
    pixel_sigma : float, optional
        Independent centroid error per image coordinate, pixels, for the full covariance.
        Default ``disparity_std_px / sqrt(2)``, so the disparity error is ``disparity_std_px``.
    centroid_offset_scale : float
        Standard deviation of the centroid's offset from the image of the object's centre, as
        a fraction of the region's pixel standard deviation, >= 0; default
        :data:`CENTROID_OFFSET_SCALE` (measured on renders). 0 treats the centroid as the
        image of the object's centre.
    ego_from_camera : (4, 4) float, optional
        Maps the left camera frame to the output frame; identity (left camera frame) if None.
    max_epipolar_px : float
        Passed to :func:`match_stereo`.
    min_area : int
        Smallest region, pixels.

    Returns
    -------
    list of Percept
        In the frame of ``ego_from_camera``, one per matched pair.

    Raises
    ------
    PerceptionError
        A bad ``depth_factor``, ``pixel_sigma``, ``disparity_std_px`` or
        ``centroid_offset_scale``, or an eq. 6 sigma that contradicts the triangulation
        covariance of its percept (ratio outside ``[1/F, F]``,
        ``F =`` :data:`~perception.tolerances.SIGMA_COVARIANCE_FACTOR`, as :class:`Percept`
        checks): ``depth_factor`` and ``pixel_sigma`` that describe different depth errors.
    """
    width, height = rig_render_size(rig)
    if not isinstance(classifier, GaussianClassifier):
        raise PerceptionError(f"classifier must be a GaussianClassifier, got {type(classifier).__name__}")
    min_area = integer("min_area", min_area, minimum=1)
    max_epipolar_px = real_scalar("max_epipolar_px", max_epipolar_px, positive=True)
    disparity_std_px = real_scalar("disparity_std_px", disparity_std_px, positive=True, maximum=1e6)
    if depth_factor is not None:
        depth_factor = real_scalar("depth_factor", depth_factor, positive=True, maximum=1e150)
    if pixel_sigma is not None:
        pixel_sigma = real_scalar("pixel_sigma", pixel_sigma, positive=True, maximum=1e6)
    centroid_offset_scale = real_scalar(
        "centroid_offset_scale", centroid_offset_scale, minimum=0.0, maximum=1e6
    )
    for name, img in (("left", left), ("right", right)):
        _check_image(name, img)
        if img.shape[:2] != (height, width):
            raise PerceptionError(
                f"{name} must have shape ({height}, {width}, 3) to match rig.image_size, "
                f"got shape {img.shape}"
            )
    derived = [n for n, v in (("depth_factor", depth_factor), ("pixel_sigma", pixel_sigma)) if v is None]
    if depth_factor is None:
        if not np.isfinite(disparity_std_px) or disparity_std_px <= 0:
            raise PerceptionError(f"disparity_std_px must be finite and > 0, got {disparity_std_px!r}")
        depth_factor = _default_depth_factor(rig, disparity_std_px)
        if not np.isfinite(depth_factor) or depth_factor > 1e150:
            raise PerceptionError(
                f"the default depth_factor f b / disparity_std_px = {depth_factor!r} is too large; "
                f"disparity_std_px = {disparity_std_px!r} is too small"
            )
    if not np.isfinite(depth_factor) or depth_factor <= 0:
        raise PerceptionError(f"depth_factor must be finite and > 0, got {depth_factor!r}")
    if pixel_sigma is None:
        pixel_sigma = disparity_std_px / np.sqrt(2.0)
    if not np.isfinite(pixel_sigma) or pixel_sigma <= 0:
        raise PerceptionError(f"pixel_sigma must be finite and > 0, got {pixel_sigma!r}")
    if not np.isfinite(centroid_offset_scale) or centroid_offset_scale < 0:
        raise PerceptionError(
            f"centroid_offset_scale must be finite and >= 0, got {centroid_offset_scale!r}"
        )
    transform = np.eye(4) if ego_from_camera is None else check_transform("ego_from_camera", ego_from_camera)
    dets_l = detect(left, classifier, min_area=min_area)
    dets_r = detect(right, classifier, min_area=min_area)
    matches = match_stereo(rig, dets_l, dets_r, max_epipolar_px)
    if not matches:
        return []
    uv_l = np.array([dets_l[m.left].centroid_uv for m in matches])
    uv_r = np.array([dets_r[m.right].centroid_uv for m in matches])
    points = np.asarray(rig.triangulate(uv_l, uv_r), dtype=np.float64).reshape(-1, 3)
    shape = 0.5 * np.array(
        [np.asarray(dets_l[m.left].shape_covariance) + np.asarray(dets_r[m.right].shape_covariance)
         for m in matches]  # never None after Detection.__post_init__
    )
    covs = _percept_covariances(rig, uv_l, uv_r, shape, pixel_sigma, centroid_offset_scale)
    rot = transform[:3, :3]
    covs = rot @ covs @ rot.T
    rho = points[:, 2]
    out_pts = points @ rot.T + transform[:3, 3]
    percepts = []
    for m, p, r, c in zip(matches, out_pts, rho, covs, strict=True):
        if not np.all(np.isfinite(p)) or r <= 0:
            continue
        try:
            plain = Percept(type=dets_l[m.left].type, position=p, covariance=c)
        except PerceptionError:  # degenerate geometry (e.g. a singular covariance): no percept
            continue
        sigma = float(depth_sigma(float(r), depth_factor))
        ratio = sigma / plain.sigma
        if not 1.0 / SIGMA_COVARIANCE_FACTOR <= ratio <= SIGMA_COVARIANCE_FACTOR:
            raise PerceptionError(
                f"the eq. 6 sigma rho**2 / depth_factor = {sigma:.3g} m of the {plain.type!r} percept at "
                f"depth rho = {float(r):.3g} m is {ratio:.3g} times the range standard deviation "
                f"{plain.sigma:.3g} m "
                f"of its triangulation covariance (pixel_sigma = {pixel_sigma!r} px, centroid_offset_scale = "
                f"{centroid_offset_scale!r}), outside [1/{SIGMA_COVARIANCE_FACTOR:g}, "
                f"{SIGMA_COVARIANCE_FACTOR:g}] (perception.tolerances.SIGMA_COVARIANCE_FACTOR): depth_factor "
                f"= {depth_factor!r} and pixel_sigma disagree about the depth error; "
                + (f"both come from disparity_std_px = {disparity_std_px!r}, a disparity error the centroid "
                   "term swamps: give a larger disparity_std_px, or depth_factor and pixel_sigma"
                   if len(derived) == 2 else
                   "make them describe the same disparity error (leave both at their defaults, or set "
                   "depth_factor = f b / (sqrt(2) pixel_sigma))"
                   + (f"; {derived[0]} came from disparity_std_px = {disparity_std_px!r}" if derived else ""))
            )
        percepts.append(Percept(type=plain.type, position=plain.position, sigma=sigma, covariance=c))
    return percepts
