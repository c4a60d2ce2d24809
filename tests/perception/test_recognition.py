"""Tests of perception.recognition: rendering, segmentation features, classifier, matching, pipeline.

References are computed here independently: silhouettes by cv2.fillConvexPoly of the convex
hull of corners projected in the test, occlusion by ray casting against the boxes, region
features by numpy covariances, classifier densities by scipy.stats.multivariate_normal.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.stats import multivariate_normal

from perception.errors import (
    PerceptionError,
)
from perception.frontend import Detection, match_stereo
from perception.head.stereo import StereoRig
from perception.recognition import (
    CENTROID_OFFSET_SCALE,
    COLOR_RANGES,
    GaussianClassifier,
    detect,
    recognize,
    region_features,
    train_classifier,
)
from perception.recognition.pipeline import _percept_covariances
from perception.simulation.render import Box, random_scene, render_labels, render_stereo, scene_boxes

RIG = StereoRig.default()
WIDTH, HEIGHT = RIG.image_size


def rot_z(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rot_x(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def box_corners(box: Box) -> np.ndarray:
    """The 8 corners, written out independently of the module."""
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
    return box.center + (signs * box.size / 2) @ box.rotation.T


def views(camera_from_world: np.ndarray) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """(rotation, translation, K) of the left and right camera, from the rig matrices."""
    rot, t = camera_from_world[:3, :3], camera_from_world[:3, 3]
    return [(rot, t, RIG.K1), (RIG.R @ rot, RIG.R @ t + RIG.T, RIG.K2)]


# ------------------------------------------------------------------------------------ rendering


@st.composite
def single_box_poses(draw: st.DrawFn) -> Box:
    center = np.array(
        [
            draw(st.floats(-0.6, 0.6)),
            draw(st.floats(-0.4, 0.4)),
            draw(st.floats(1.5, 5.0)),
        ]
    )
    size = np.array([draw(st.floats(0.05, 0.8)) for _ in range(3)])
    rotation = rot_z(draw(st.floats(-np.pi, np.pi))) @ rot_x(draw(st.floats(-np.pi, np.pi)))
    return Box(center=center, size=size, rotation=rotation, color=(200, 100, 50), type="clutter")


def edge_band(mask: np.ndarray) -> np.ndarray:
    kernel = np.ones((3, 3), np.uint8)
    m = mask.astype(np.uint8)
    return (cv2.dilate(m, kernel) - cv2.erode(m, kernel)).astype(bool)


@given(single_box_poses())
def test_single_box_covers_its_projected_silhouette(box: Box) -> None:
    pose = np.eye(4)  # world = left camera frame
    labels = render_labels(RIG, pose, [box])
    image_l, image_r = render_stereo(
        RIG, pose, [box], np.random.default_rng(0), background=(0, 0, 0), light_noise=0.0, pixel_noise=0.0
    )
    corners = box_corners(box)
    for (rot, t, K), lab, image in zip(views(pose), labels, (image_l, image_r), strict=True):
        uv, _ = cv2.projectPoints(corners, cv2.Rodrigues(rot)[0], t, K, np.zeros(5))
        hull = cv2.convexHull(np.round(uv.reshape(-1, 2)).astype(np.int32))
        reference = np.zeros((HEIGHT, WIDTH), np.uint8)
        cv2.fillConvexPoly(reference, hull, 1)
        reference = reference.astype(bool)
        rendered = lab == 0
        differ = rendered ^ reference
        assert not np.any(differ & ~edge_band(reference)), "pixels differ away from the silhouette edge"
        assert rendered.sum() >= 0.8 * reference.sum()
        assert np.all(lab[~rendered] == -1)
        # the shaded image shows the box exactly where the label map does (dark faces aside)
        lit = image.max(axis=2) > 0
        assert np.all(lit <= rendered)
        assert lit.sum() >= 0.9 * rendered.sum()


def ray_cast_labels(boxes: list[Box], camera_from_world: np.ndarray, step: int = 3) -> tuple:
    """Nearest box along the ray of every step-th pixel of the left image (slab method)."""
    rot, t = camera_from_world[:3, :3], camera_from_world[:3, 3]
    centre_world = -rot.T @ t
    us, vs = np.meshgrid(np.arange(0, WIDTH, step), np.arange(0, HEIGHT, step))
    pix = np.stack([us.ravel(), vs.ravel(), np.ones(us.size)], axis=1)
    rays_world = (np.linalg.inv(RIG.K1) @ pix.T).T @ rot  # rows: R^T d
    best = np.full(len(pix), np.inf)
    label = np.full(len(pix), -1)
    for i, box in enumerate(boxes):
        o = box.rotation.T @ (centre_world - box.center)
        d = rays_world @ box.rotation
        with np.errstate(divide="ignore", invalid="ignore"):
            t1 = (-box.size / 2 - o) / d
            t2 = (box.size / 2 - o) / d
        tmin = np.nanmax(np.minimum(t1, t2), axis=1)
        tmax = np.nanmin(np.maximum(t1, t2), axis=1)
        hit = (tmax >= tmin) & (tmin > 0)
        closer = hit & (tmin < best)
        best[closer] = tmin[closer]
        label[closer] = i
    return us.ravel(), vs.ravel(), label


@pytest.mark.parametrize("seed", [3, 4, 5, 6])
def test_occlusion_order_matches_ray_casting(seed: int) -> None:
    rng = np.random.default_rng(seed)
    boxes, pose = random_scene(rng, n_doors=(2, 3), n_clutter=(2, 3), max_door_yaw_deg=60.0)
    lab, _ = render_labels(RIG, pose, boxes)
    us, vs, ref = ray_cast_labels(boxes, pose)
    edges = np.zeros(lab.shape, bool)
    for i in range(-1, len(boxes)):
        edges |= edge_band(lab == i)
    keep = ~edges[vs, us]
    assert keep.sum() > 0.8 * len(us)
    assert np.array_equal(lab[vs, us][keep], ref[keep])


def test_near_box_occludes_far_box_whatever_the_list_order() -> None:
    far = Box(center=(0, 0, 4.0), size=(1.0, 1.0, 0.1), rotation=np.eye(3), color=(50, 80, 150), type="door")
    near = Box(center=(0.1, 0, 3.0), size=(0.2, 0.2, 0.2), rotation=rot_z(0.4), color=(210, 210, 210),
               type="handle")
    for boxes, near_idx in (([far, near], 1), ([near, far], 0)):
        lab, _ = render_labels(RIG, np.eye(4), boxes)
        uv, _ = cv2.projectPoints(np.array([[0.1, 0, 3.0]]), np.zeros(3), np.zeros(3), RIG.K1, None)
        u, v = np.round(uv.ravel()).astype(int)
        assert lab[v, u] == near_idx
        assert np.any(lab == 1 - near_idx)


def test_rendering_is_deterministic_and_seeded() -> None:
    boxes, pose = random_scene(np.random.default_rng(11))
    a = render_stereo(RIG, pose, boxes, np.random.default_rng(5))
    b = render_stereo(RIG, pose, boxes, np.random.default_rng(5))
    c = render_stereo(RIG, pose, boxes, np.random.default_rng(6))
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    assert not np.array_equal(a[0], c[0])
    assert a[0].shape == (HEIGHT, WIDTH, 3) and a[0].dtype == np.uint8


def test_box_behind_the_camera_is_not_drawn() -> None:
    behind = Box(center=(0, 0, -2.0), size=(1, 1, 1), rotation=np.eye(3), color=(0, 0, 255), type="clutter")
    lab_l, lab_r = render_labels(RIG, np.eye(4), [behind])
    assert np.all(lab_l == -1) and np.all(lab_r == -1)


# ------------------------------------------------------------------------------ region features


@given(
    st.floats(20, 120),
    st.floats(4, 30),
    st.floats(-89, 89),
    st.floats(200, 440),
    st.floats(150, 330),
)
def test_region_features_match_numpy_covariance(length, width, angle, cu, cv) -> None:
    image = np.full((HEIGHT, WIDTH, 3), (150, 120, 95), np.uint8)
    corners = cv2.boxPoints(((cu, cv), (length, width), angle))
    cv2.fillConvexPoly(image, np.round(corners).astype(np.int32), (205, 205, 210))
    feats, cents, areas, border = region_features(image)
    mask = np.all(image == (205, 205, 210), axis=2)
    ys, xs = np.nonzero(mask)
    assert len(feats) == 1 and not border[0]
    cov = np.cov(np.stack([xs, ys]).astype(float), bias=True) + np.eye(2) / 12
    evals, evecs = np.linalg.eigh(cov)
    major = evecs[:, 1]
    assert areas[0] == mask.sum()
    np.testing.assert_allclose(cents[0], [xs.mean(), ys.mean()], atol=1e-9)
    np.testing.assert_allclose(feats[0, 0], np.log(mask.sum()), rtol=1e-12)
    np.testing.assert_allclose(feats[0, 1], 0.5 * np.log(evals[1] / evals[0]), rtol=1e-6, atol=1e-9)
    if evals[1] > 1.05 * evals[0]:  # orientation defined
        np.testing.assert_allclose(feats[0, 2], abs(major[0]), atol=1e-6)
    np.testing.assert_allclose(feats[0, 3], mask.sum() / (12 * np.sqrt(evals[0] * evals[1])), rtol=1e-6)
    h, s_, v = cv2.cvtColor(np.array([[[205, 205, 210]]], np.uint8), cv2.COLOR_BGR2HSV).ravel().astype(float)
    expected = [s_ / 255 * np.cos(np.radians(2 * h)), s_ / 255 * np.sin(np.radians(2 * h)), v / 255]
    np.testing.assert_allclose(feats[0, 4:], expected, atol=1e-6)


def test_color_ranges_separate_door_handle_and_background() -> None:
    bgr = np.array([[[40, 85, 150], [210, 210, 215], [150, 120, 95]]], np.uint8)
    hsv = cv2.cvtColor(bgr, cv2.COLOR_BGR2HSV)
    inside = {
        name: cv2.inRange(hsv, np.array(r.lower, np.uint8), np.array(r.upper, np.uint8)).ravel() > 0
        for name, r in COLOR_RANGES.items()
    }
    assert inside["wood"].tolist() == [True, False, False]
    assert inside["metal"].tolist() == [False, True, False]


# -------------------------------------------------------------------------------- classifier


def gaussian_data(rng: np.random.Generator, n: int = 300) -> tuple[np.ndarray, list[str]]:
    """Three fixed Gaussian classes (different full covariances); rng draws the samples."""
    means = np.array([[0.0, 0, 0, 0], [3.0, 0, 1, 0], [0.0, 3, 0, -2]])
    mixing = 0.6 * (np.eye(4) + 0.3 * np.random.default_rng(12345).normal(size=(3, 4, 4)))
    xs, ys = [], []
    for k, name in enumerate(["a", "b", "c"]):
        xs.append(means[k] + rng.normal(size=(n + 50 * k, 4)) @ mixing[k].T)
        ys += [name] * (n + 50 * k)
    return np.concatenate(xs), ys


@given(st.integers(0, 2**32 - 1))
def test_fit_and_predict_match_scipy_reference(seed: int) -> None:
    rng = np.random.default_rng(seed)
    x, y = gaussian_data(rng, 60)
    reg = 1e-3
    clf = GaussianClassifier.fit(x, y, regularization=reg)
    labels = np.array(y)
    queries = rng.normal(size=(40, 4)) * 3
    ref = np.empty((40, 3))
    priors = np.empty(3)
    for k, name in enumerate(["a", "b", "c"]):
        xk = x[labels == name]
        cov = np.cov(xk.T, bias=True) + reg * np.eye(4)
        ref[:, k] = multivariate_normal(xk.mean(axis=0), cov).logpdf(queries)
        priors[k] = len(xk) / len(x)
    assert clf.classes == ("a", "b", "c")
    np.testing.assert_allclose(clf.log_likelihood(queries), ref, rtol=1e-9, atol=1e-9)
    predicted, score = clf.predict(queries)
    best = np.argmax(ref + np.log(priors), axis=1)
    np.testing.assert_allclose(score, ref[np.arange(40), best], rtol=1e-9, atol=1e-9)
    for i, b in enumerate(best):
        expected = "abc"[b] if ref[i, b] >= clf.thresholds[b] else None
        assert predicted[i] == expected


def test_classifier_beats_chance_on_held_out_gaussians() -> None:
    x, y = gaussian_data(np.random.default_rng(1))
    xt, yt = gaussian_data(np.random.default_rng(2))
    clf = GaussianClassifier.fit(x, y)
    predicted, _ = clf.predict(xt)
    accuracy = np.mean([p == t for p, t in zip(predicted, yt, strict=True)])
    assert accuracy > 0.9  # chance is below 0.4


def test_threshold_rejects_far_outliers() -> None:
    x, y = gaussian_data(np.random.default_rng(3))
    clf = GaussianClassifier.fit(x, y)
    predicted, _ = clf.predict(np.full((5, 4), 40.0) + np.arange(5)[:, None])
    assert predicted == [None] * 5


@pytest.fixture(scope="module")
def trained() -> GaussianClassifier:
    return train_classifier(RIG, np.random.default_rng(100), n_scenes=20)


def labelled_regions(seed: int, n_scenes: int) -> tuple[np.ndarray, list[str]]:
    rng = np.random.default_rng(seed)
    feats_all, labels = [], []
    for _ in range(n_scenes):
        boxes, pose = random_scene(rng)
        image, _ = render_stereo(RIG, pose, boxes, rng)
        lab, _ = render_labels(RIG, pose, boxes)
        feats, cents, _, border = region_features(image)
        for f, (u, v), b in zip(feats, cents, border, strict=True):
            i = lab[int(round(v)), int(round(u))]
            if not b and i >= 0 and boxes[i].type in ("door", "handle"):
                feats_all.append(f)
                labels.append(boxes[i].type)
    return np.array(feats_all), labels


def test_trained_classifier_beats_chance_on_held_out_renders(trained: GaussianClassifier) -> None:
    x, y = labelled_regions(seed=200, n_scenes=10)
    assert len(y) >= 15
    predicted, _ = trained.predict(x)
    accuracy = np.mean([p == t for p, t in zip(predicted, y, strict=True)])
    chance = max(y.count("door"), y.count("handle")) / len(y)
    assert accuracy >= 0.9 and accuracy > chance + 0.2


# ---------------------------------------------------------------------------------- matching


def fake_detection(kind: str, uv: np.ndarray, area: float = 100.0) -> Detection:
    return Detection(type=kind, centroid_uv=np.asarray(uv, float), area=area, features=np.zeros(7))


@pytest.mark.parametrize("verged", [False, True])
def test_match_stereo_recovers_the_true_pairs(verged: bool) -> None:
    rng = np.random.default_rng(7)
    if verged:
        R = cv2.Rodrigues(np.array([0.02, -0.12, 0.01]))[0]
        T = np.array([-0.093, 0.004, 0.01])
        rig = StereoRig.from_opencv(RIG.K1, None, RIG.K2, None, R, T, (WIDTH, HEIGHT))
    else:
        rig = RIG
    pts = np.column_stack([rng.uniform(-1, 1, 8), rng.uniform(-0.6, 0.6, 8), rng.uniform(2, 6, 8)])
    uv_l, _ = cv2.projectPoints(pts, np.zeros(3), np.zeros(3), rig.K1, None)
    uv_r, _ = cv2.projectPoints(pts, cv2.Rodrigues(rig.R)[0], rig.T, rig.K2, None)
    uv_l, uv_r = uv_l.reshape(-1, 2), uv_r.reshape(-1, 2)
    kinds = ["handle", "door"] * 4
    left = [fake_detection(k, u) for k, u in zip(kinds, uv_l, strict=True)]
    perm = rng.permutation(8)
    right = [fake_detection(kinds[j], uv_r[j] + rng.normal(0, 0.2, 2)) for j in perm]
    right.append(fake_detection("handle", uv_l[0] + (5.0, 0.0)))  # negative disparity: impossible
    matches = match_stereo(rig, left, right)
    found = {m.left: m.right for m in matches}
    assert found == {int(j): i for i, j in enumerate(perm)}
    assert all(m.epipolar_px < 2.0 for m in matches)


def test_match_stereo_rejects_type_and_epipolar_mismatch() -> None:
    left = [fake_detection("handle", (300.0, 200.0))]
    assert match_stereo(RIG, left, [fake_detection("door", (290.0, 200.0))]) == []
    assert match_stereo(RIG, left, [fake_detection("handle", (290.0, 205.0))]) == []
    assert len(match_stereo(RIG, left, [fake_detection("handle", (290.0, 201.0))])) == 1


# ---------------------------------------------------------------------------------- pipeline


def camera_points(boxes: list[Box], pose: np.ndarray, kind: str) -> tuple[np.ndarray, np.ndarray]:
    idx = np.array([i for i, b in enumerate(boxes) if b.type == kind], dtype=int)
    if idx.size == 0:
        return idx, np.zeros((0, 3))
    centres = np.array([boxes[i].center for i in idx])
    return idx, centres @ pose[:3, :3].T + pose[:3, 3]


def visible_in_test(boxes: list[Box], pose: np.ndarray, idx: np.ndarray, cam: np.ndarray) -> np.ndarray:
    """Centre inside both images on a pixel of that box, and >= 20 px of the box in each."""
    labels = render_labels(RIG, pose, boxes)
    out = np.ones(len(idx), bool)
    for (rot, t, K), lab in zip(views(np.eye(4)), labels, strict=True):
        uv, _ = cv2.projectPoints(cam, cv2.Rodrigues(rot)[0], t, K, None)
        px = np.round(uv.reshape(-1, 2)).astype(int)
        for k, i in enumerate(idx):
            u, v = px[k]
            inside = 0 <= u < WIDTH and 0 <= v < HEIGHT
            out[k] &= inside and lab[v, u] == i and np.count_nonzero(lab == i) >= 20
    return out


def test_pipeline_finds_handles_with_few_false_detections(trained: GaussianClassifier) -> None:
    rng = np.random.default_rng(300)
    n_visible = n_found = n_handle_percepts = n_false = 0
    errors_in_sigma = []
    for _ in range(25):
        boxes, pose = random_scene(rng)
        left, right = render_stereo(RIG, pose, boxes, rng)
        percepts = recognize(RIG, left, right, trained)
        idx, truth = camera_points(boxes, pose, "handle")
        visible = visible_in_test(boxes, pose, idx, truth)
        claimed: set[int] = set()
        for p in percepts:
            if p.type != "handle":
                continue
            n_handle_percepts += 1
            dist = np.linalg.norm(truth - p.position, axis=1) if len(truth) else np.array([np.inf])
            k = int(np.argmin(dist))
            if dist[k] <= 3 * p.sigma and k not in claimed:
                claimed.add(k)
                errors_in_sigma.append(dist[k] / p.sigma)
            else:
                n_false += 1
        n_visible += int(visible.sum())
        n_found += sum(1 for k in claimed if visible[k])
    assert n_visible >= 30
    assert n_found >= 0.9 * n_visible
    assert n_false <= 0.05 * n_handle_percepts
    assert np.median(errors_in_sigma) < 1.0


def test_recognize_frames_and_sigma(trained: GaussianClassifier) -> None:
    rng = np.random.default_rng(400)
    boxes, pose = random_scene(rng, n_doors=(2, 2), n_clutter=(0, 0))
    left, right = render_stereo(RIG, pose, boxes, rng)
    in_camera = recognize(RIG, left, right, trained, depth_factor=250.0)
    assert len(in_camera) >= 2
    for p in in_camera:
        assert p.sigma == pytest.approx(p.position[2] ** 2 / 250.0, rel=1e-12)
    ego_from_camera = np.eye(4)
    ego_from_camera[:3, :3] = np.array([[0.0, 0, 1], [-1, 0, 0], [0, -1, 0]])  # REP 103 from OpenCV
    ego_from_camera[:3, 3] = (0.1, 0.05, 1.4)
    in_ego = recognize(RIG, left, right, trained, depth_factor=250.0, ego_from_camera=ego_from_camera)
    assert [p.type for p in in_ego] == [p.type for p in in_camera]
    for pe, pc in zip(in_ego, in_camera, strict=True):
        expected = ego_from_camera[:3, :3] @ pc.position + ego_from_camera[:3, 3]
        np.testing.assert_allclose(pe.position, expected, atol=1e-12)
        assert pe.sigma == pc.sigma
        rot = ego_from_camera[:3, :3]
        np.testing.assert_allclose(pe.covariance, rot @ pc.covariance @ rot.T, atol=1e-15)
    # depth variance to first order for the rectified rig: (z^2 / (f b))^2 * 2 pixel_sigma^2
    pixel_sigma = 0.4
    fb = RIG.K1[0, 0] * np.linalg.norm(RIG.T)
    for p in recognize(RIG, left, right, trained, pixel_sigma=pixel_sigma):
        z = p.position[2]
        assert p.covariance[2, 2] == pytest.approx((z**2 / fb) ** 2 * 2 * pixel_sigma**2, rel=0.05)
    # centroid offset common to both images: a lateral shift (z / f) * offset at fixed depth,
    # offset ~ N(0, scale^2 S) with S the mean pixel covariance of the two matched regions
    scale = 0.1
    dets_l, dets_r = detect(left, trained), detect(right, trained)
    matches = match_stereo(RIG, dets_l, dets_r)
    # (through the covariance helper: recognize refuses pixel_sigma=1e-6 with the default
    # depth_factor, whose eq. 6 sigma is then far larger than the covariance's range error)
    assert len(matches) >= 2
    uv_l = np.array([dets_l[m.left].centroid_uv for m in matches])
    uv_r = np.array([dets_r[m.right].centroid_uv for m in matches])
    shapes = np.array([(dets_l[m.left].shape_covariance + dets_r[m.right].shape_covariance) / 2
                       for m in matches])
    points = np.asarray(RIG.triangulate(uv_l, uv_r)).reshape(-1, 3)
    covs = _percept_covariances(RIG, uv_l, uv_r, shapes, 1e-6, scale)
    for point, cov, shape in zip(points, covs, shapes, strict=True):
        lateral = (point[2] / RIG.K1[0, 0]) ** 2 * scale**2 * shape
        np.testing.assert_allclose(cov[:2, :2], lateral, rtol=0.02, atol=1e-12)
        assert abs(cov[2, 2]) < 1e-6 * lateral[0, 0]
    with pytest.raises(PerceptionError, match=r"depth_factor = [\d.]+ and pixel_sigma disagree"):
        recognize(RIG, left, right, trained, pixel_sigma=1e-6, centroid_offset_scale=scale)


def test_detection_shape_covariance_matches_region_features(trained: GaussianClassifier) -> None:
    rng = np.random.default_rng(410)
    boxes, pose = random_scene(rng, n_doors=(2, 2), n_clutter=(0, 0))
    left, _ = render_stereo(RIG, pose, boxes, rng)
    dets = detect(left, trained)
    assert len(dets) >= 2
    for d in dets:
        log_area, elongation, horizontal, fill = d.features[:4]
        geometric_mean = np.exp(log_area) / (12 * fill)  # sqrt(l1 l2)
        evals, evecs = np.linalg.eigh(d.shape_covariance)
        np.testing.assert_allclose(
            evals, [geometric_mean * np.exp(-elongation), geometric_mean * np.exp(elongation)], rtol=1e-9
        )
        if evals[1] > 1.05 * evals[0]:
            assert abs(evecs[0, 1]) == pytest.approx(horizontal, abs=1e-9)
    square = Detection(type="handle", centroid_uv=(5.0, 5.0), area=48.0, features=np.zeros(7))
    np.testing.assert_array_equal(square.shape_covariance, 4.0 * np.eye(2))


def nees_on_rendered_scenes(
    classifier: GaussianClassifier, seed: int, n_scenes: int, **kwargs: float
) -> tuple[np.ndarray, np.ndarray, int]:
    """NEES ``e^T C^-1 e`` of every percept and ``|range error| / sigma``, and the number of
    false percepts. The truth of a percept is the box whose label covers its reprojection in
    the left image (render_labels); e = percept - box centre, both in the left camera frame."""
    rng = np.random.default_rng(seed)
    nees, range_ratio, false = [], [], 0
    for _ in range(n_scenes):
        boxes, pose = random_scene(rng)
        left, right = render_stereo(RIG, pose, boxes, rng)
        labels, _ = render_labels(RIG, pose, boxes)
        for p in recognize(RIG, left, right, classifier, **kwargs):
            uvw = RIG.K1 @ p.position
            u, v = np.round(uvw[:2] / uvw[2]).astype(int)
            i = labels[v, u] if 0 <= u < WIDTH and 0 <= v < HEIGHT else -1
            if i < 0 or boxes[i].type != p.type:
                false += 1
                continue
            truth = pose[:3, :3] @ boxes[i].center + pose[:3, 3]
            e = p.position - truth
            nees.append(e @ np.linalg.solve(p.covariance, e))
            range_ratio.append(abs(np.linalg.norm(p.position) - np.linalg.norm(truth)) / p.sigma)
    return np.array(nees), np.array(range_ratio), false


def test_percept_covariances_are_calibrated_on_rendered_scenes(trained: GaussianClassifier) -> None:
    # chi^2 with 3 degrees of freedom: mean 3, P(<= 14.16) = 0.9973 (3 sigma)
    nees, range_ratio, false = nees_on_rendered_scenes(trained, seed=700, n_scenes=120)
    assert len(nees) >= 300
    assert false <= 0.02 * len(nees)
    assert 2.0 <= nees.mean() <= 4.5
    assert np.mean(nees <= 14.16) >= 0.95
    # sigma = rho^2 / depth_factor bounds the range error (|N(0, 1)| has median 0.674)
    assert 0.3 <= np.median(range_ratio) <= 1.0
    # without the centroid offset the covariances are far too small (the symptom)
    few, _, _ = nees_on_rendered_scenes(trained, seed=700, n_scenes=30, centroid_offset_scale=0.0)
    assert few.mean() > 10 * nees.mean() and CENTROID_OFFSET_SCALE > 0


# ---------------------------------------------------------------------------------- bad input


def test_bad_images_raise_image_format_error(trained: GaussianClassifier) -> None:
    good = np.zeros((HEIGHT, WIDTH, 3), np.uint8)
    with pytest.raises(PerceptionError, match=r"image must have dtype uint8, got float32"):
        detect(good.astype(np.float32), trained)
    with pytest.raises(PerceptionError, match=r"\(480, 640\)"):
        detect(good[:, :, 0], trained)
    with pytest.raises(PerceptionError, match=r"right must have shape \(480, 640,.*rig.image_size"):
        recognize(RIG, good, good[:100], trained)
    with pytest.raises(PerceptionError, match="left must be a numpy array"):
        recognize(RIG, [[1, 2, 3]], good, trained)


def test_bad_poses_raise_specific_errors() -> None:
    boxes = scene_boxes(["door"], [[0.0, 0.0, 3.0]])
    bad = np.eye(4)
    bad[0, 3] = np.nan
    with pytest.raises(PerceptionError, match=r"camera_from_world\[0, 3\] must be finite, got"):
        render_stereo(RIG, bad, boxes, np.random.default_rng(0))
    with pytest.raises(PerceptionError, match=r"camera_from_world must be a rigid transform:.*rotation"):
        render_labels(RIG, np.diag([2.0, 1.0, 1.0, 1.0]), boxes)
    with pytest.raises(PerceptionError, match=r"\(4, 4\)"):
        render_labels(RIG, np.eye(3), boxes)
    with pytest.raises(PerceptionError, match="last row"):
        render_labels(RIG, np.ones((4, 4)) * 0 + np.eye(4) + np.eye(4, k=-3), boxes)


def test_bad_boxes_and_parameters_raise_specific_errors(trained: GaussianClassifier) -> None:
    with pytest.raises(PerceptionError, match=r"size must be > 0 along every axis, got \[0\.1,"):
        Box(center=(0, 0, 1), size=(0.1, 0.0, 0.1), rotation=np.eye(3), color=(1, 2, 3), type="door")
    with pytest.raises(PerceptionError, match=r"center\[1\] must be finite, got "):
        Box(center=(0, np.inf, 1), size=(0.1, 0.1, 0.1), rotation=np.eye(3), color=(1, 2, 3), type="door")
    with pytest.raises(PerceptionError, match=r"no default size/colour for box type 'window'"):
        scene_boxes(["window"], [[0, 0, 1]])
    with pytest.raises(PerceptionError, match=r"\(2, 3\)"):
        scene_boxes(["door", "handle"], [[0, 0, 1]])
    image = np.zeros((HEIGHT, WIDTH, 3), np.uint8)
    with pytest.raises(PerceptionError, match=r"depth_factor must be > 0, got \-1\.0"):
        recognize(RIG, image, image, trained, depth_factor=-1.0)
    with pytest.raises(PerceptionError, match=r"centroid_offset_scale must be >= 0, got \-0\.1"):
        recognize(RIG, image, image, trained, centroid_offset_scale=-0.1)
    with pytest.raises(PerceptionError, match=r"shape_covariance must be symmetric positive definite"):
        Detection(type="handle", centroid_uv=(1.0, 1.0), area=10.0, features=np.zeros(7),
                  shape_covariance=[[1.0, 2.0], [2.0, 1.0]])
    with pytest.raises(PerceptionError, match=r"max_epipolar_px must be > 0, got 0\.0"):
        match_stereo(RIG, [], [], max_epipolar_px=0.0)
    with pytest.raises(PerceptionError, match=r"features\[0, 0\] must be finite"):
        trained.log_likelihood(np.full((1, trained.n_features), np.nan))
    with pytest.raises(PerceptionError, match=r"\(n, 7\)"):
        trained.predict(np.zeros((2, 3)))
    with pytest.raises(PerceptionError, match=r"centroid_uv\[0\] must be finite, got"):
        Detection(type="handle", centroid_uv=(np.nan, 1.0), area=10.0, features=np.zeros(7))
    with pytest.raises(PerceptionError, match=r"area must be > 0, got 0\.0"):
        Detection(type="handle", centroid_uv=(1.0, 1.0), area=0.0, features=np.zeros(7))
    with pytest.raises(PerceptionError, match=r"class 'b' needs at least 2 samples, got 1"):
        GaussianClassifier.fit(np.zeros((3, 2)) + np.arange(3)[:, None], ["a", "a", "b"])


def test_renderer_names_live_in_simulation_and_the_package_only() -> None:
    # The renderer lives in perception.simulation.render; the package root gives the very same
    # objects, and perception.recognition (the paper's recognition) no longer re-exports them.
    import perception
    import perception.recognition as recognition
    import perception.simulation.render as render

    for name in ["Box", "random_scene", "render_stereo", "scene_boxes"]:
        assert getattr(perception, name) is getattr(render, name), name
    for name in render.__all__:
        assert not hasattr(recognition, name), name
    assert {"render_labels", "render_stereo", "visible_mask", "Box"} <= set(render.__all__)
    assert {"detect", "recognize", "train_classifier"} <= set(recognition.__all__)
