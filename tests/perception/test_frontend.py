"""The detection front ends: percepts from a depth image or a stereo pair of detections.

Scenes are axis-aligned boxes in front of a wall, ray-cast in the test (an independent
renderer: the slab method per pixel), so the true centre of every object is known.
"""

from __future__ import annotations

import numpy as np
import pytest

import perception as pc
from perception import frontend
from perception.frontend import detection_percepts

K = np.array([[500.0, 0.0, 319.5], [0.0, 500.0, 239.5], [0.0, 0.0, 1.0]])
SHAPE = (480, 640)
CHI2_3_999 = 16.27  # chi-square, 3 degrees of freedom, 99.9 %


def raycast(boxes, K=K, shape=SHAPE, wall=6.0, origin=(0.0, 0.0, 0.0)):
    """z-depth and box label per pixel of a camera at ``origin`` looking along +z (OpenCV)."""
    h, w = shape
    origin = np.asarray(origin, dtype=float)
    u, v = np.meshgrid(np.arange(w), np.arange(h))
    rays = np.stack([u, v, np.ones_like(u)], -1).reshape(-1, 3).astype(float) @ np.linalg.inv(K).T
    best = np.full(len(rays), wall)
    label = np.full(len(rays), -1)
    for k, (lo, hi) in enumerate(boxes):
        with np.errstate(divide="ignore", invalid="ignore"):
            t1, t2 = (lo - origin)[None] / rays, (hi - origin)[None] / rays
        tmin = np.nanmax(np.minimum(t1, t2), axis=1)
        tmax = np.nanmin(np.maximum(t1, t2), axis=1)
        hit = (tmax >= tmin) & (tmin > 0) & (tmin < best)
        best[hit] = tmin[hit]
        label[hit] = k
    return best.reshape(h, w), label.reshape(h, w)  # rays have z = 1: t is the z-depth


def door_boxes(rng, n=5):
    """Thin boxes (doors, drawer fronts) that do not overlap in the image."""
    boxes = []
    for k in range(n):
        c = np.array([-1.2 + 0.6 * k, rng.uniform(-0.3, 0.3), rng.uniform(1.5, 3.5)])
        c[0] *= c[2] / 3.5
        half = np.array([rng.uniform(0.05, 0.12), rng.uniform(0.05, 0.25), rng.uniform(0.008, 0.03)])
        boxes.append((c - half, c + half))
    return boxes


def centre(box):
    return 0.5 * (box[0] + box[1])


def noisy(Z, rng, c=frontend.DEPTH_NOISE, block=8):
    """Depth noise c z^2, constant over block x block patches (correlated, as the front end assumes)."""
    h, w = Z.shape
    e = np.kron(rng.standard_normal((h // block + 1, w // block + 1)), np.ones((block, block)))[:h, :w]
    return Z + c * Z**2 * e


def test_rgbd_percepts_lie_within_their_covariance_at_the_object_centre():
    rng = np.random.default_rng(1)
    boxes = door_boxes(rng)
    Z, lab = raycast(boxes)
    # one centre depth for the type, as a map gives it (the median half thickness): each door's
    # own differs by up to 1 cm, an error its views share
    typical = {"door": float(np.median([0.5 * (b[1][2] - b[0][2]) for b in boxes]))}
    nees, before, after, spread = [], [], [], []
    for _ in range(20):
        Zn = noisy(Z, rng)
        for k in range(len(boxes)):
            det = pc.Detection("door", mask=lab == k)
            res = pc.rgbd_percepts([det], Zn, K, np.eye(4), centre_offset=typical)
            assert res.sources == (0,) and not res.dropped
            p = res.percepts[0]
            e = p.position - centre(boxes[k])
            nees.append(float(e @ np.linalg.solve(p.covariance, e)))
            spread.append(float(np.sqrt(np.linalg.eigvalsh(p.covariance)[-1])))
            after.append(abs(e[2]))
            front = boxes[k][0][2]  # the visible face's depth: where an uncorrected percept sits
            before.append(abs(front - centre(boxes[k])[2]))
    assert max(nees) < CHI2_3_999 and np.mean(nees) < 4.5  # never overconfident (3 is exact)
    assert max(spread) < 0.03  # nor uselessly wide: a 3-sigma bound within 9 cm at 1.5-3.5 m
    assert np.mean(after) < 0.5 * np.mean(before)  # referred to the centre, not the face


def test_rgbd_percept_is_in_the_ego_frame_of_the_transform():
    rng = np.random.default_rng(2)
    boxes = door_boxes(rng, 2)
    Z, lab = raycast(boxes)
    ego_from_camera = np.eye(4)
    ego_from_camera[:3, :3] = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])  # REP 103
    ego_from_camera[:3, 3] = [0.1, 0.0, 1.5]
    det = [pc.Detection("door", mask=lab == 0)]
    ego = pc.rgbd_percepts(det, Z, K, ego_from_camera, centre_offset=0.0).percepts[0]
    # another ego frame with the same up (turned about z, moved): the percept moves with it (the
    # front end reads the ego frame's up, so a frame with another up is not a mere relabelling)
    A = np.eye(4)
    a = 0.7
    A[:3, :3] = [[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]]
    A[:3, 3] = [0.3, -0.2, 0.05]
    moved = pc.rgbd_percepts(det, Z, K, A @ ego_from_camera, centre_offset=0.0).percepts[0]
    R, t = A[:3, :3], A[:3, 3]
    np.testing.assert_allclose(moved.position, R @ ego.position + t, atol=1e-12)
    np.testing.assert_allclose(moved.covariance, R @ ego.covariance @ R.T, atol=1e-15)
    assert ego.position[0] > 1.0  # ahead of the robot: ego x is the camera's z


def test_a_box_detection_ignores_the_background_inside_the_box():
    # a narrow upright bar (a handle) in front of the wall; its box holds mostly wall
    bar = (np.array([-0.012, -0.15, 1.988]), np.array([0.012, 0.15, 2.012]))
    Z, lab = raycast([bar], wall=2.6)
    v, u = np.nonzero(lab == 0)
    box = (u.min() - 12, v.min() - 3, u.max() + 12, v.max() + 3)  # a loose detector box
    assert (lab[box[1]:box[3] + 1, box[0]:box[2] + 1] == -1).mean() > 0.5
    p = pc.rgbd_percepts([pc.Detection("handle", box=box)], Z, K, np.eye(4), centre_offset=0.012).percepts[0]
    np.testing.assert_allclose(p.position, centre(bar), atol=0.006)
    # the same box without the rejection would average bar and wall: far behind the bar
    naive = Z[box[1]:box[3] + 1, box[0]:box[2] + 1].mean()
    assert naive > 2.2


def test_occluded_and_cut_off_detections_are_dropped_with_their_reason():
    back = (np.array([-0.3, -0.3, 2.98]), np.array([0.3, 0.3, 3.02]))
    front = (np.array([-0.05, -0.5, 1.9]), np.array([0.05, 0.5, 1.95]))  # a bar across it
    edge = (np.array([1.0, -0.2, 1.98]), np.array([1.6, 0.2, 2.02]))  # beyond the right border
    Z, lab = raycast([back, front, edge])
    dets = [pc.Detection("door", mask=lab == k) for k in range(3)]
    res = pc.rgbd_percepts(dets, Z, K, np.eye(4))
    reasons = {d.index: d.reason for d in res.dropped}
    assert reasons == {0: "occluded", 1: "cut_off", 2: "cut_off"} or reasons == {0: "occluded", 2: "cut_off"}
    kept = pc.rgbd_percepts(dets[2:], Z, K, np.eye(4), keep_cut_off=True)
    assert kept.sources == (0,)
    wide = kept.percepts[0].covariance
    v, _ = np.linalg.eigh(wide)
    assert np.sqrt(v[-1]) > 0.05  # the centre may be anywhere along the cut side


def test_a_mask_bleeding_onto_its_occluder_is_still_occluded():
    # a detector's mask a pixel or two too wide takes in the edge of the nearer bar that hides
    # part of the door: those readings are not the door's own, so the bar still occludes it
    import cv2

    door = (np.array([-0.3, -0.3, 2.98]), np.array([0.3, 0.3, 3.02]))
    bar = (np.array([0.1, -0.5, 2.4]), np.array([0.2, 0.5, 2.45]))  # hides a strip of the door
    Z, lab = raycast([door, bar])
    exact = lab == 0
    cross = np.array([[0, 1, 0], [1, 1, 1], [0, 1, 0]], np.uint8)
    for grow in (0, 1, 2):
        mask = cv2.dilate(exact.astype(np.uint8), cross, iterations=grow).astype(bool) if grow else exact
        assert (mask & (lab == 1)).any() == (grow > 0)
        res = pc.rgbd_percepts([pc.Detection("door", mask=mask)], Z, K, np.eye(4))
        assert [d.reason for d in res.dropped] == ["occluded"], grow
    # the same mask with the bar gone (the strip visible) is kept
    Z2, lab2 = raycast([door])
    res = pc.rgbd_percepts([pc.Detection("door", mask=lab2 == 0)], Z2, K, np.eye(4))
    assert res.sources == (0,)


def test_a_slanted_face_is_placed_at_its_middle_not_at_its_pixel_centroid():
    # the side of a long thin box, seen at a slant: its near end fills more pixels than its far
    # end, so the pixels' centroid lies well before the face's middle; the percept does not
    side = (np.array([0.5, -0.2, 1.2]), np.array([0.51, 0.2, 3.2]))
    Z, lab = raycast([side])
    mask = lab == 0
    v, u = np.nonzero(mask)
    pts = (np.column_stack([u, v, np.ones(u.size)]) @ np.linalg.inv(K).T) * Z[v, u][:, None]
    middle = 0.5 * (side[0] + side[1])
    centroid_error = abs(pts.mean(axis=0)[2] - middle[2])
    assert centroid_error > 0.15  # what a centroid would give (computed here, independently)
    ego_from_camera = np.eye(4)
    ego_from_camera[:3, :3] = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])  # REP 103
    offset = {"door": pc.CentreOffset(depth=0.005, depth_sd=0.003, lateral_sd=0.01)}
    res = pc.rgbd_percepts([pc.Detection("door", mask=mask)], Z, K, ego_from_camera, centre_offset=offset)
    assert res.sources == (0,)
    p = res.percepts[0]
    truth = ego_from_camera[:3, :3] @ middle  # the box centre in the ego frame
    e = p.position - truth
    assert np.linalg.norm(e) < 0.02
    assert float(e @ np.linalg.solve(p.covariance, e)) < CHI2_3_999


def test_holes_in_the_depth_image_drop_the_detection_as_no_depth():
    Z, lab = raycast(door_boxes(np.random.default_rng(3), 1))
    Z = Z.copy()
    Z[lab == 0] = np.nan
    res = pc.rgbd_percepts([pc.Detection("door", mask=lab == 0)], Z, K, np.eye(4))
    assert res.percepts == () and res.dropped[0].reason == "no_depth"
    Z[lab == 0] = 0.0  # 0 is "no reading" too
    res = pc.rgbd_percepts([pc.Detection("door", mask=lab == 0)], Z, K, np.eye(4))
    assert res.dropped[0].reason == "no_depth"
    tiny = np.zeros(SHAPE, bool)
    tiny[100, 100:105] = True
    res = pc.rgbd_percepts([pc.Detection("knob", mask=tiny)], np.full(SHAPE, 2.0), K, np.eye(4))
    assert res.dropped[0].reason == "too_few_pixels"


def test_depth_in_millimetres_and_bad_images_get_clear_errors():
    Z, lab = raycast(door_boxes(np.random.default_rng(4), 1))
    det = [pc.Detection("door", mask=lab == 0)]
    with pytest.raises(pc.PerceptionError, match=r"depth has integer dtype uint16:.*millimetres.*1000"):
        pc.rgbd_percepts(det, (Z * 1000).astype(np.uint16), K, np.eye(4))
    with pytest.raises(pc.PerceptionError, match=r"depth readings have median 6000, beyond .*max_depth = 20 m"
                                                 r".*as millimetres 6 m \(pass depth / 1000\)") as info:
        pc.rgbd_percepts(det, Z * 1000.0, K, np.eye(4))
    assert "centimetres" not in str(info.value)  # 60 m is beyond the camera's range too
    # centimetres: named as centimetres (and millimetres, which would also be in range)
    with pytest.raises(pc.PerceptionError, match=r"median 600, .*as centimetres 6 m \(pass depth / 100\)"):
        pc.rgbd_percepts(det, Z * 100.0, K, np.eye(4))
    # close range in millimetres (median 90): not read as 90 m
    close = Z * (0.09 / float(np.nanmedian(Z[::4, ::4]))) * 1000.0
    with pytest.raises(pc.PerceptionError, match=r"median 90, .*as millimetres 0.09 m"):
        pc.rgbd_percepts(det, close, K, np.eye(4))
    # a camera that reaches farther says so
    assert pc.rgbd_percepts(det, Z * 10.0, K, np.eye(4), max_depth=100.0).percepts
    with pytest.raises(pc.PerceptionError, match=r"detections\[0\].mask has shape \(480, 640\).*240 x 320"):
        pc.rgbd_percepts(det, Z[::2, ::2], K, np.eye(4))
    bad = Z.copy()
    bad[7, 9] = -1.0
    with pytest.raises(pc.PerceptionError, match=r"depth\[7, 9\] = -1.0"):
        pc.rgbd_percepts(det, bad, K, np.eye(4))
    with pytest.raises(pc.PerceptionError, match=r"box = .* outside"):
        pc.rgbd_percepts([pc.Detection("door", box=(700, 10, 720, 30))], Z, K, np.eye(4))
    with pytest.raises(pc.PerceptionError, match="mask is empty"):
        pc.Detection("door", mask=np.zeros(SHAPE, bool))
    with pytest.raises(pc.PerceptionError, match="camera matrix"):
        pc.rgbd_percepts(det, Z, -K, np.eye(4))
    with pytest.raises(pc.PerceptionError, match=r"last row must be \[0, 0, 0, 1\]"):
        pc.rgbd_percepts(det, Z, K, 2 * np.eye(4))


def test_detection_from_a_mask_or_a_box_agree_on_a_rectangle():
    m = np.zeros((40, 50), bool)
    m[10:20, 5:30] = True
    a, b = pc.Detection("door", mask=m), pc.Detection("door", box=(5, 10, 29, 19))
    np.testing.assert_allclose(a.centroid_uv, b.centroid_uv)
    np.testing.assert_allclose(a.shape_covariance, b.shape_covariance)
    assert a.area == b.area == 250.0
    np.testing.assert_array_equal(a.box, [5, 10, 29, 19])
    with pytest.raises(pc.PerceptionError, match="score"):
        pc.Detection("door", box=(5, 10, 29, 19), score=1.5)
    with pytest.raises(pc.PerceptionError, match="needs a mask, a box or a centroid_uv"):
        pc.Detection("door")


def _stereo_scene(boxes, baseline=0.09):
    Zl, labl = raycast(boxes)
    Zr, labr = raycast(boxes, origin=np.array([baseline, 0.0, 0.0]))
    rig = pc.StereoRig(K1=K, D1=None, K2=K, D2=None, R=np.eye(3), T=np.array([-baseline, 0.0, 0.0]),
                       image_size=(SHAPE[1], SHAPE[0]))
    left = [pc.Detection("door", mask=labl == k) for k in range(len(boxes))]
    right = [pc.Detection("door", mask=labr == k) for k in range(len(boxes))]
    return rig, left, right


def test_stereo_percepts_triangulate_as_opencv_does():
    import cv2

    boxes = door_boxes(np.random.default_rng(5), 4)
    rig, left, right = _stereo_scene(boxes)
    res = pc.stereo_percepts(left, right, rig, np.eye(4), centre_offset=0.0)
    assert res.sources == (0, 1, 2, 3)
    P1 = K @ np.hstack([np.eye(3), np.zeros((3, 1))])
    P2 = K @ np.hstack([np.eye(3), np.array([[-0.09], [0.0], [0.0]])])
    for p, i in zip(res.percepts, res.sources, strict=True):
        uv_l, uv_r = left[i].centroid_uv.reshape(2, 1), right[i].centroid_uv.reshape(2, 1)
        X = cv2.triangulatePoints(P1, P2, uv_l, uv_r)
        np.testing.assert_allclose(p.position, X[:3, 0] / X[3, 0], atol=1e-9)


def test_stereo_percepts_cover_the_object_centre():
    rng = np.random.default_rng(6)
    nees = []
    for _ in range(6):
        boxes = door_boxes(rng, 4)
        rig, left, right = _stereo_scene(boxes)
        depth = {"door": float(np.mean([0.5 * (b[1][2] - b[0][2]) for b in boxes]))}
        res = pc.stereo_percepts(left, right, rig, np.eye(4), centre_offset=depth)
        for p, i in zip(res.percepts, res.sources, strict=True):
            e = p.position - centre(boxes[i])
            nees.append(float(e @ np.linalg.solve(p.covariance, e)))
    assert len(nees) >= 20
    assert max(nees) < CHI2_3_999 and np.mean(nees) < 4.5


def test_stereo_masks_of_another_size_and_a_transposed_rig_size_are_named():
    boxes = door_boxes(np.random.default_rng(7), 3)
    rig, left, right = _stereo_scene(boxes)
    small = [pc.Detection("door", mask=d.mask[::2, ::2]) for d in right]
    with pytest.raises(pc.PerceptionError, match=r"right\[0\].mask has shape \(240, 320\).*640 x 480"):
        pc.stereo_percepts(left, small, rig, np.eye(4))
    w, h = rig.image_size
    with pytest.raises(pc.PerceptionError, match=rf"image_size = \({h}, {w}\).*\(height, width\)"):
        pc.StereoRig(K1=rig.K1, D1=None, K2=rig.K2, D2=None, R=rig.R, T=rig.T, image_size=(h, w))
    # a square image cannot look transposed
    square = np.array([[500.0, 0.0, 199.5], [0.0, 500.0, 199.5], [0.0, 0.0, 1.0]])
    assert pc.StereoRig(K1=square, D1=None, K2=square, D2=None, R=rig.R, T=rig.T, image_size=(400, 400))


def test_stereo_notes_left_and_right_swapped():
    boxes = door_boxes(np.random.default_rng(8), 4)
    rig, left, right = _stereo_scene(boxes)
    straight = pc.stereo_percepts(left, right, rig, np.eye(4))
    assert len(straight.percepts) >= 3 and straight.notes == ()
    swapped = pc.stereo_percepts(right, left, rig, np.eye(4))
    assert not swapped.percepts
    assert len(swapped.notes) == 1 and "are left and right swapped?" in swapped.notes[0]
    assert "negative disparity" in swapped.notes[0]


def test_stereo_drops_unmatched_and_half_hidden_detections():
    boxes = door_boxes(np.random.default_rng(7), 3)
    rig, left, right = _stereo_scene(boxes)
    res = pc.stereo_percepts(left, right[:2], rig, np.eye(4))
    assert [(d.index, d.reason) for d in res.dropped] == [(2, "no_stereo_match")]
    m = right[1].mask.copy()
    v, u = np.nonzero(m)
    m[:, : int(np.median(u))] = False  # half of it hidden in the right image
    res = pc.stereo_percepts(left, [right[0], pc.Detection("door", mask=m), right[2]], rig, np.eye(4))
    assert {d.index: d.reason for d in res.dropped} == {1: "occluded"}


def test_fusion_keeps_an_objects_shared_offset_instead_of_averaging_it():
    S = np.diag([0.02, 0.01, 0.03])  # the object's centre offset, shared by every view
    own = 1e-6 * np.eye(3)
    raw = [pc.Percept("door", [2.0 + 1e-4 * k, 0.0, 1.0], 0.03, covariance=own + S @ S.T,
                      shared=((pc.OBJECT_VIEW, S),)) for k in range(10)]
    fused = pc.fuse_percepts(raw, bandwidth=0.3)
    assert len(fused) == 1
    # ten views of one object average the independent part only: S S^T + own / 10 (derived by hand)
    np.testing.assert_allclose(fused[0].covariance, S @ S.T + own / 10, rtol=1e-6)
    independent = [pc.Percept("door", p.position, 0.03, covariance=p.covariance) for p in raw]
    assert np.trace(pc.fuse_percepts(independent, bandwidth=0.3)[0].covariance) < 0.11 * np.trace(S @ S.T)


def test_localize_never_correlates_two_objects_through_the_object_id():
    from worldgraph.pose.validation import shared_view_covariance

    rng = np.random.default_rng(8)
    ego = rng.uniform(-3, 3, (5, 3))
    covs = np.array([0.01**2 * np.eye(3)] * 5)
    S = 0.005 * np.eye(3)
    with_object = [((pc.OBJECT_VIEW, S),)] * 5
    with_view = [((0, S),)] * 5
    np.testing.assert_array_equal(shared_view_covariance(np.eye(4), ego, covs, with_object), np.zeros((6, 6)))
    assert np.trace(shared_view_covariance(np.eye(4), ego, covs, with_view)) > 0


def test_a_centre_in_front_of_the_surface_and_a_lateral_prior():
    # a door leaf (3 cm) with a handle bar protruding 8 cm: one object whose box centre floats in
    # front of the leaf; the label map treats both as object 0
    leaf = (np.array([-0.2, -0.25, 2.0]), np.array([0.2, 0.25, 2.03]))
    bar = (np.array([0.12, -0.1, 1.92]), np.array([0.14, 0.1, 2.0]))
    Z, lab = raycast([leaf, bar])
    lab[lab == 1] = 0
    box_centre = 0.5 * (np.minimum(leaf[0], bar[0]) + np.maximum(leaf[1], bar[1]))
    det = [pc.Detection("door", mask=lab == 0)]
    visible = pc.rgbd_percepts(det, Z, K, np.eye(4), centre_offset=0.0).percepts[0].position
    d = box_centre[2] - visible[2]
    assert d < -0.01  # the centre lies in front of what is seen
    prior = pc.CentreOffset(depth=d, depth_sd=0.004, lateral_sd=0.02)
    p = pc.rgbd_percepts(det, Z, K, np.eye(4), centre_offset={"door": prior}).percepts[0]
    np.testing.assert_allclose(p.position[2], box_centre[2], atol=1e-3)
    # the covariance carries the prior: 2 cm across the view (x, y; the handle makes the visible part
    # round, so "across" is across the viewing ray, slightly oblique), 4 mm (plus noise) along z
    sd = np.sqrt(np.diag(p.covariance))
    assert 0.0199 <= sd[0] < 0.021 and 0.0199 <= sd[1] < 0.021 and 0.004 <= sd[2] < 0.006
    with pytest.raises(pc.PerceptionError, match="depth_sd"):
        pc.CentreOffset(depth=0.01, depth_sd=-1.0)
    with pytest.raises(pc.PerceptionError, match=r"centre_offset\['door'\]"):
        pc.rgbd_percepts(det, Z, K, np.eye(4), centre_offset={"door": "deep"})


def test_weighted_percentiles_equal_repeating_each_value_by_its_weight():
    rng = np.random.default_rng(7)
    for _ in range(50):
        n = int(rng.integers(1, 40))
        x = rng.normal(size=(n, 3)).round(1)  # ties included
        w = rng.integers(1, 6, size=n).astype(float)
        for q in (0.0, 1.0, 37.5, 50.0, 99.0, 100.0):
            got = detection_percepts._weighted_percentiles(x, w, q)
            want = [np.percentile(np.repeat(x[:, j], w.astype(int)), q, method="inverted_cdf")
                    for j in range(3)]
            np.testing.assert_array_equal(got, want)


def test_mask_moments_match_all_the_pixels_of_the_whole_mask():
    """A mask's centroid, area, second moments and box, read in its bounding box, equal those of
    every pixel of the whole image (sparse random masks, at the borders too)."""
    rng = np.random.default_rng(21)
    for _ in range(20):
        mask = np.zeros((48, 64), dtype=bool)
        r0, c0 = rng.integers(0, 48), rng.integers(0, 64)
        r1, c1 = rng.integers(r0, 48) + 1, rng.integers(c0, 64) + 1
        mask[r0:r1, c0:c1] = rng.random((r1 - r0, c1 - c0)) < 0.4
        mask[r0, c0] = True
        det = pc.Detection("door", mask=mask)
        v, u = np.nonzero(mask)
        uv = np.column_stack([u, v]).astype(float)
        c = uv.mean(axis=0)
        np.testing.assert_array_equal(det.centroid_uv, c)
        assert det.area == len(u)
        np.testing.assert_allclose(det.shape_covariance, (uv - c).T @ (uv - c) / len(u) + np.eye(2) / 12.0,
                                   rtol=1e-12, atol=1e-12)
        np.testing.assert_array_equal(det.box, [u.min(), v.min(), u.max(), v.max()])
