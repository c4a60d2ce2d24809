"""worldgraph.figures.plots: the top view's ellipse, colours, percept placement and legend, checked
against hand-computed values; the image view; bad input; matplotlib missing."""

import sys

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.colors import to_rgba  # noqa: E402

import perception as pc  # noqa: E402
import worldgraph as wg  # noqa: E402
from worldgraph.figures import plots  # noqa: E402


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


def _yaw_pose(yaw: float, x: float, y: float) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    pose = np.eye(4)
    pose[:3, :3] = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
    pose[:3, 3] = [x, y, 1.5]
    return pose


def _result(pose: np.ndarray, pose_covariance: np.ndarray, alternatives=()) -> wg.LocalizationResult:
    return wg.LocalizationResult(
        transformation=pose, position=pose[:3, 3].copy(), covariance=pose_covariance[:3, :3].copy(),
        correspondences=(), hypotheses=(), ambiguous=False, status="ok",
        pose_covariance=pose_covariance, alternatives=tuple(alternatives))


def _world() -> wg.WorldModel:
    types = ["door", "door", "handle", "handle", "lamp", "plinth", "plinth"]
    pos = [[0.0, 0.0, 1.0], [4.0, 0.0, 1.0], [0.5, 0.1, 1.0], [4.5, 0.1, 1.0], [2.0, 3.0, 2.5],
           [1.0, 3.0, 0.1], [3.0, 3.0, 0.1]]
    return wg.WorldModel.from_arrays(types, pos)


def _boundary_points(patch) -> np.ndarray:
    """Points of an ellipse patch's outline in data coordinates."""
    path = patch.get_path()
    t = np.linspace(0.0, 2.0 * np.pi, 361)
    unit = np.column_stack([np.cos(t), np.sin(t)])
    assert path.vertices.shape[1] == 2
    return patch.get_patch_transform().transform(unit)


def _by_gid(ax, gid):
    found = [c for c in ax.collections if c.get_gid() == gid]
    assert len(found) == 1, gid
    return found[0]


# ------------------------------------------------------------------------- the ellipse


@pytest.mark.parametrize("cov", [
    [[0.04, 0.0], [0.0, 0.01]],          # axis-aligned, major along x
    [[0.01, 0.0], [0.0, 0.09]],          # major along y
    [[0.05, 0.02], [0.02, 0.02]],        # tilted
    [[2e-5, -1.5e-5], [-1.5e-5, 3e-5]],  # centimetre scale, negative correlation
])
def test_covariance_ellipse_semi_axes_are_3_sqrt_eigenvalues(cov):
    cov = np.array(cov)
    a, b, c = cov[0, 0], cov[0, 1], cov[1, 1]
    # eigenvalues of a symmetric 2x2 matrix in closed form
    mid, rad = (a + c) / 2.0, np.hypot((a - c) / 2.0, b)
    lam_max, lam_min = mid + rad, mid - rad
    centre = np.array([1.0, -2.0])
    patch = plots.covariance_ellipse(centre, cov, n_sigma=3.0)
    pts = _boundary_points(patch)
    dist = np.linalg.norm(pts - centre, axis=1)
    assert dist.max() == pytest.approx(3.0 * np.sqrt(lam_max), rel=1e-4)
    assert dist.min() == pytest.approx(3.0 * np.sqrt(lam_min), rel=1e-3)
    # every outline point is at Mahalanobis distance 3 (x^T C^-1 x with the adjugate inverse)
    inv = np.array([[c, -b], [-b, a]]) / (a * c - b * b)
    d = pts - centre
    assert np.allclose(np.einsum("ij,jk,ik->i", d, inv, d), 9.0, rtol=1e-9)
    # the farthest point lies along the major eigenvector (b, lam_max - a), or (1, 0) when b = 0
    major = np.array([b, lam_max - a]) if abs(b) > 0 else np.array([1.0, 0.0] if a >= c else [0.0, 1.0])
    far = d[np.argmax(dist)]
    assert abs(far @ major) / (np.linalg.norm(far) * np.linalg.norm(major)) == pytest.approx(1.0, abs=1e-4)


def test_covariance_ellipse_scales_with_n_sigma():
    cov = np.diag([0.04, 0.01])
    one = plots.covariance_ellipse([0, 0], cov, n_sigma=1.0)
    three = plots.covariance_ellipse([0, 0], cov, n_sigma=3.0)
    assert (one.width, one.height) == pytest.approx((0.4, 0.2))
    assert (three.width, three.height) == pytest.approx((1.2, 0.6))


@pytest.mark.parametrize("cov, err, words", [
    ([[1.0, 0.5], [0.0, 1.0]], wg.WorldGraphError, "symmetric"),
    ([[1.0, 0.0], [0.0, -1.0]], wg.WorldGraphError, "semi-definite"),
    ([[1.0, 0.0, 0.0]], wg.WorldGraphError, r"covariance must have shape \(2, 2\)"),
    ([[np.nan, 0.0], [0.0, 1.0]], wg.WorldGraphError, r"covariance\[0, 0\] must be finite"),
])
def test_covariance_ellipse_rejects_bad_covariances(cov, err, words):
    with pytest.raises(err, match=words):
        plots.covariance_ellipse([0.0, 0.0], cov)


def test_top_view_ellipse_is_the_xy_block_of_pose_covariance():
    pose = _yaw_pose(0.3, 2.0, 1.0)
    pose_cov = np.diag([1.0, 1.0, 4.0, 1e-4, 1e-4, 1e-4]) * 1e-4
    pose_cov[0, 1] = pose_cov[1, 0] = 0.6e-4   # x-y correlation
    pose_cov[0, 2] = pose_cov[2, 0] = 1.5e-4   # x-z: must not change the x-y ellipse
    ax = plots.top_view(_world(), result=_result(pose, pose_cov))
    (patch,) = [p for p in ax.patches if p.get_gid() == "ellipse"]
    pts = _boundary_points(patch)
    # eigenvalues of [[1, .6], [.6, 1]] * 1e-4 are 1.6e-4 and 0.4e-4
    dist = np.linalg.norm(pts - pose[:2, 3], axis=1)
    assert dist.max() == pytest.approx(3.0 * np.sqrt(1.6e-4), rel=1e-4)
    assert dist.min() == pytest.approx(3.0 * np.sqrt(0.4e-4), rel=1e-3)
    # the legend gives the semi-axes in centimetres: 3 sqrt(1.6e-4) m = 3.8 cm, 3 sqrt(0.4e-4) = 1.9 cm
    assert "3.8" in patch.get_label() and "1.9" in patch.get_label()


def test_top_view_without_a_pose_draws_no_estimate():
    nan = np.full((4, 4), np.nan)
    res = wg.LocalizationResult(nan, np.full(3, np.nan), np.full((3, 3), np.nan), (), (), False,
                                "no_association")
    ax = plots.top_view(_world(), percepts=[pc.Percept("door", [1.0, 0.0, 0.0], 0.01)], result=res)
    assert not [p for p in ax.patches if p.get_gid() == "ellipse"]
    assert not [c for c in ax.collections if str(c.get_gid()).startswith("percepts:")]
    assert not [ln for ln in ax.lines if ln.get_label().startswith("estimate")]


# ------------------------------------------------------------------------- colours


def test_type_colours_fixed_distinct_and_independent_of_the_other_types():
    a = plots.type_colours(["door", "handle", "plinth", "book"])
    b = plots.type_colours(["door", "cup", "handle", "handle"])
    assert a["door"] == b["door"] == "#8c564b"
    assert a["handle"] == b["handle"] == "#1f77b4"
    assert len(set(a.values())) == 4
    assert len(set(b.values())) == 3
    many = plots.type_colours([f"type{k}" for k in range(16)] + ["door"])
    assert len(set(many.values())) == 17


def test_top_view_objects_and_percepts_share_their_type_colour():
    world = _world()
    pose = _yaw_pose(0.0, 2.0, -2.0)
    percepts = [pc.Percept("door", [2.0, 2.0, -0.5], 0.01), pc.Percept("handle", [2.5, 2.1, -0.5], 0.01),
                pc.Percept("lamp", [0.0, 5.0, 1.0], 0.02)]
    ax = plots.top_view(world, percepts=percepts, result=_result(pose, np.eye(6) * 1e-4))
    colours = {}
    for t in ("door", "handle", "lamp"):
        face = _by_gid(ax, f"objects:{t}").get_facecolor()
        edge = _by_gid(ax, f"percepts:{t}").get_edgecolor()
        assert np.allclose(face, edge)   # one colour per type, objects and percepts alike
        colours[t] = tuple(np.round(face[0], 6))
    assert len(set(colours.values())) == 3
    assert colours["door"] == tuple(np.round(to_rgba("#8c564b"), 6))
    # plinth is not a percept type: drawn grey among the other objects, not in colour
    assert not [c for c in ax.collections if c.get_gid() == "objects:plinth"]
    assert any(lab.startswith("other objects (2)") for lab in ax.get_legend_handles_labels()[1])


def test_top_view_places_percepts_by_the_estimated_pose():
    world = _world()
    pose = _yaw_pose(np.pi / 2, 1.0, 2.0)   # ego x -> world y, ego y -> world -x
    percepts = [pc.Percept("door", [1.0, 0.0, 0.0], 0.01), pc.Percept("door", [0.0, 2.0, 0.0], 0.01)]
    ax = plots.top_view(world, percepts=percepts, result=_result(pose, np.eye(6) * 1e-4))
    xy = _by_gid(ax, "percepts:door").get_offsets()
    assert np.allclose(xy, [[1.0, 3.0], [-1.0, 2.0]])
    # an explicit pose wins over the result's
    ax2 = plots.top_view(world, percepts=percepts, result=_result(pose, np.eye(6) * 1e-4),
                         pose=_yaw_pose(0.0, 0.0, 0.0))
    assert np.allclose(_by_gid(ax2, "percepts:door").get_offsets(), [[1.0, 0.0], [0.0, 2.0]])


def test_top_view_draws_the_alternatives_where_they_are():
    alt = _yaw_pose(0.0, 3.5, 0.5)
    ax = plots.top_view(_world(), result=_result(_yaw_pose(0.0, 1.0, 1.0), np.eye(6) * 1e-4, [alt]))
    (line,) = [ln for ln in ax.lines if ln.get_label().startswith("near-best alternatives (1)")]
    assert np.allclose(np.column_stack(line.get_data()), [[3.5, 0.5]])


# ------------------------------------------------------------------------- layout


def test_top_view_labels_aspect_and_legend_outside_the_axes():
    world = _world()
    percepts = [pc.Percept("door", [2.0, 2.0, -0.5], 0.01)]
    ax = plots.top_view(world, percepts=percepts, result=_result(_yaw_pose(0.0, 2.0, -2.0), np.eye(6) * 1e-4),
                        truth=_yaw_pose(0.1, 2.0, -2.0))
    assert ax.get_xlabel() == "x (m)" and ax.get_ylabel() == "y (m)"
    assert ax.get_aspect() == 1.0
    fig = ax.figure
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    box = ax.get_window_extent(renderer)
    leg = ax.get_legend().get_window_extent(renderer)
    assert leg.x0 >= box.x1   # entirely to the right of the axes box: hides no data
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert len(labels) == len(set(labels))
    for want in ("door (2)", "door percepts (1)", "estimate (ok)", "true pose", "world bounds"):
        assert want in labels


def test_top_view_draws_into_given_axes_without_a_legend():
    fig, ax = plt.subplots()
    out = plots.top_view(_world(), ax=ax, legend=False, title="t")
    assert out is ax and ax.get_legend() is None and ax.get_title() == "t"
    assert {c.get_gid() for c in ax.collections} >= {"objects:door", "objects:handle", "objects:plinth"}


# ------------------------------------------------------------------------- image view


def test_image_view_marks_detections_at_their_centroids_by_type():
    img = np.zeros((40, 60, 3), np.uint8)
    img[..., 2] = 200   # red in BGR
    dets = [pc.Detection("door", [10.0, 20.0], 30.0, np.zeros(3)),
            pc.Detection("handle", [50.0, 5.0], 15.0, np.zeros(3))]
    ax = plots.image_view(img, dets)
    assert np.allclose(_by_gid(ax, "detections:door").get_offsets(), [[10.0, 20.0]])
    assert np.allclose(_by_gid(ax, "detections:handle").get_edgecolor()[0], to_rgba("#1f77b4"))
    shown = ax.get_images()[0].get_array()
    assert tuple(shown[0, 0]) == (200, 0, 0)   # displayed as RGB
    assert ax.get_xlabel() == "u (px)" and ax.get_ylabel() == "v (px)"


# ------------------------------------------------------------------------- bad input


def test_top_view_rejects_bad_arguments():
    world = _world()
    with pytest.raises(wg.WorldGraphError, match=r"world must be a WorldModel, got 'kitchen'"):
        plots.top_view("kitchen")
    with pytest.raises(wg.WorldGraphError, match=r"percepts\[1\] must be a perception\.Percept, got"):
        plots.top_view(world, percepts=[pc.Percept("door", [1.0, 0, 0], 0.01), (1.0, 2.0)])
    with pytest.raises(wg.WorldGraphError, match="result"):
        plots.top_view(world, result=np.eye(4))
    with pytest.raises(wg.WorldGraphError, match=r"n_hypotheses must be an integer, got 2\.5"):
        plots.top_view(world, n_hypotheses=2.5)
    with pytest.raises(wg.WorldGraphError, match="truth must be rigid.*scaled or sheared"):
        plots.top_view(world, truth=np.diag([2.0, 2.0, 2.0, 1.0]))
    with pytest.raises(wg.WorldGraphError, match=r"image must be an"):
        plots.image_view(np.zeros((4, 4)))
    with pytest.raises(wg.WorldGraphError, match=r"types\[1\] must be a non\-empty string, got ''"):
        plots.type_colours(["door", ""])


def test_missing_matplotlib_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib.pyplot", None)   # import now raises ImportError
    with pytest.raises(wg.ImporterError, match=r"gaussian-spheres\[plots\]"):
        plots.top_view(_world())
    with pytest.raises(wg.WorldGraphError, match="matplotlib"):
        plots.covariance_ellipse([0, 0], np.eye(2))


def test_import_worldgraph_does_not_load_matplotlib():
    import subprocess

    code = "import sys, worldgraph, worldgraph.figures.plots; assert 'matplotlib' not in sys.modules"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-1000:]
