"""worldgraph.figures.rerun_log.log_rerun: a real kitchen localisation logged to an .rrd file and read
back with rerun's own reader (rerun.chunk.RrdReader), compared with the world, the percepts and
the result; bad input; rerun-sdk missing."""

import subprocess
import sys
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import perception as pc
import worldgraph as wg
from worldgraph.errors import (
    ImporterError,
    WorldGraphError,
)
from worldgraph.figures.rerun_log import log_rerun

if sys.version_info < (3, 11):  # rerun-sdk >= 0.41 has no Python 3.10 wheel; the test extra skips it there
    pytest.skip("rerun-sdk >= 0.41 needs Python >= 3.11", allow_module_level=True)

import rerun as rr  # noqa: E402 - in the test extra from Python 3.11 on: CI runs these tests
from rerun.chunk import RrdReader  # noqa: E402

RECOGNISED = ("door", "handle", "drawer", "knob")


def _read_back(path) -> dict[str, dict]:
    """Entity path -> {component name: list of values of its single row, "static": bool}."""
    out: dict[str, dict] = {}
    for chunk in RrdReader(path).stream().to_chunks():
        if chunk.entity_path.startswith("/__"):
            continue  # the recording's properties
        batch = chunk.to_record_batch()
        assert chunk.num_rows == 1, chunk.entity_path
        entry = out.setdefault(chunk.entity_path, {})
        entry["static"] = chunk.is_static
        for name in batch.schema.names:
            if ":" in name:  # an archetype's component, e.g. "Points3D:positions"
                entry[name] = batch.column(name).to_pylist()[0]
    return out


def _save_and_read(tmp_path, name, **kwargs):
    rec = rr.RecordingStream("gaussian_spheres_test")
    path = tmp_path / name
    rec.save(str(path))
    paths = log_rerun(recording=rec, **kwargs)
    rec.flush()
    rec.disconnect()
    return paths, _read_back(path)


def _packed_rgba(hex_colour: str) -> int:
    """rerun's packed 0xRRGGBBAA colour of an opaque '#rrggbb'."""
    return (int(hex_colour[1:], 16) << 8) | 0xFF


@pytest.fixture(scope="module")
def kitchen_log(tmp_path_factory):
    world = wg.scenes.kitchen(seed=0)
    rng = np.random.default_rng(7)
    seen = np.flatnonzero(np.isin(world.types, RECOGNISED))
    lower, upper = world.bounds
    truth = np.eye(4)
    truth[:3, :3] = Rotation.from_euler("z", 0.7).as_matrix()
    truth[:3, 3] = [*(0.5 * (lower[:2] + upper[:2])), 1.5]
    percepts, source = pc.simulate_percepts(world.types[seen].tolist(), world.positions[seen], truth, rng,
                                            max_range=6.0)
    result = wg.localize(world, percepts)
    assert result.status == "ok", result.message
    paths, logged = _save_and_read(tmp_path_factory.mktemp("rrd"), "kitchen.rrd", world=world,
                                   percepts=percepts, result=result)
    return world, percepts, seen[source], result, paths, logged


def test_entity_paths_are_one_per_type_plus_the_estimate(kitchen_log):
    world, percepts, _, _, paths, logged = kitchen_log
    want = ({f"/world/objects/{o.type}" for o in world.objects}
            | {f"/world/percepts/{p.type}" for p in percepts}
            | {"/world/estimate", "/world/estimate_3sigma"})
    assert set(logged) == want
    assert sorted(paths) == sorted(want)  # returned, each once


def test_world_points_per_type_count_positions_ids_and_colours(kitchen_log):
    world, _, _, _, _, logged = kitchen_log
    counts = Counter(o.type for o in world.objects)
    assert sum(counts.values()) == 753
    for t, n in counts.items():
        entry = logged[f"/world/objects/{t}"]
        assert entry["static"]
        pos = np.array(entry["Points3D:positions"])
        assert pos.shape == (n, 3), t
        mine = [o for o in world.objects if o.type == t]
        np.testing.assert_allclose(pos, [o.pose[:3, 3] for o in mine], rtol=0, atol=2e-6)
        assert entry["Points3D:labels"] == [o.id for o in mine]
    # the colours of worldgraph.figures.plots.TYPE_COLOURS, written out by hand
    for t, hex_colour in {"door": "#8c564b", "handle": "#1f77b4", "drawer": "#2ca02c",
                          "knob": "#9467bd"}.items():
        assert set(logged[f"/world/objects/{t}"]["Points3D:colors"]) == {_packed_rgba(hex_colour)}


def test_percepts_are_placed_in_the_world_next_to_their_objects(kitchen_log):
    world, percepts, source, result, _, logged = kitchen_log
    R, t = result.transformation[:3, :3], result.transformation[:3, 3]
    placed = {}
    for typ in {p.type for p in percepts}:
        entry = logged[f"/world/percepts/{typ}"]
        assert not entry["static"]
        idx = [i for i, p in enumerate(percepts) if p.type == typ]
        pos = np.array(entry["Points3D:positions"])
        assert pos.shape == (len(idx), 3)
        for i, x in zip(idx, pos, strict=True):
            placed[i] = x
        assert set(entry["Points3D:colors"]) == {_packed_rgba(wg.figures.plots.type_colours([typ])[typ])}
    assert len(placed) == len(percepts)
    for i, p in enumerate(percepts):
        np.testing.assert_allclose(placed[i], R @ p.position + t, atol=1e-5)
        # the simulated percept's true object: within a few centimetres after placement
        assert np.linalg.norm(placed[i] - world.positions[source[i]]) < 0.1


def test_estimate_transform_and_its_3sigma_ellipsoid(kitchen_log):
    _, _, _, result, _, logged = kitchen_log
    est = logged["/world/estimate"]
    np.testing.assert_allclose(est["Transform3D:translation"][0], result.transformation[:3, 3], atol=1e-5)
    # rerun stores a 3x3 matrix column by column
    mat = np.array(est["Transform3D:mat3x3"][0]).reshape(3, 3).T
    np.testing.assert_allclose(mat, result.transformation[:3, :3], atol=1e-6)
    assert est["TransformAxes3D:axis_length"] == [0.5]

    ell = logged["/world/estimate_3sigma"]
    np.testing.assert_allclose(ell["Ellipsoids3D:centers"][0], result.position, atol=1e-5)
    semi = np.array(ell["Ellipsoids3D:half_sizes"][0], dtype=np.float64)
    quat = np.array(ell["Ellipsoids3D:quaternions"][0], dtype=np.float64)  # x, y, z, w
    # the ellipsoid {x : x^T C^-1 x = 9}: its frame times (semi / 3)^2 rebuilds the covariance
    Q = Rotation.from_quat(quat / np.linalg.norm(quat)).as_matrix()
    rebuilt = Q @ np.diag((semi / 3.0) ** 2) @ Q.T
    scale = np.abs(result.covariance).max()
    np.testing.assert_allclose(rebuilt, result.covariance, atol=1e-4 * scale)
    assert "3σ" in ell["Ellipsoids3D:labels"][0]


def test_without_a_pose_the_percepts_stay_in_the_ego_frame(tmp_path):
    world = wg.WorldModel.from_arrays(["door", "door", "knob"], [[0, 0, 1], [3, 0, 1], [1, 2, 1]])
    percepts = [pc.Percept("knob", np.array([1.0, 2.0, 0.5]), 0.01),
                pc.Percept("door", np.array([-1.0, 0.5, 0.0]), 0.02),
                pc.Percept("knob", np.array([4.0, -2.0, 0.25]), 0.01)]
    truth = np.array([[0.0, -1.0, 0.0, 2.0], [1.0, 0.0, 0.0, -1.0], [0.0, 0.0, 1.0, 1.5], [0, 0, 0, 1]])
    paths, logged = _save_and_read(tmp_path, "ego.rrd", world=world, percepts=percepts, prefix="robot/map",
                                   truth=truth)
    assert sorted(paths) == sorted(logged) == ["/robot/map/objects/door", "/robot/map/objects/knob",
                                               "/robot/map/percepts_ego/door", "/robot/map/percepts_ego/knob",
                                               "/robot/map/truth"]
    np.testing.assert_allclose(logged["/robot/map/truth"]["Transform3D:translation"], [[2.0, -1.0, 1.5]])
    np.testing.assert_allclose(logged["/robot/map/truth"]["Transform3D:mat3x3"],
                               [[0.0, 1.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, 1.0]])  # columns of R
    np.testing.assert_allclose(logged["/robot/map/percepts_ego/knob"]["Points3D:positions"],
                               [[1.0, 2.0, 0.5], [4.0, -2.0, 0.25]])
    np.testing.assert_allclose(logged["/robot/map/objects/door"]["Points3D:positions"],
                               [[0, 0, 1], [3, 0, 1]])


def test_type_names_are_escaped_as_one_path_part(tmp_path):
    world = wg.WorldModel.from_arrays(["wall socket", "a/b", "a/b"], [[0, 0, 1], [1, 1, 1], [2, 1, 1]])
    paths, logged = _save_and_read(tmp_path, "escaped.rrd", world=world)
    assert sorted(paths) == sorted(logged) == ["/world/objects/a\\/b", "/world/objects/wall\\ socket"]
    assert len(logged["/world/objects/a\\/b"]["Points3D:positions"]) == 2


def test_the_active_recording_is_the_default(tmp_path):
    world = wg.WorldModel.from_arrays(["door", "knob", "knob"], [[0, 0, 1], [1, 2, 1], [2, 2, 1]])
    rec = rr.RecordingStream("gaussian_spheres_test")
    rec.save(str(tmp_path / "default.rrd"))
    previous = rr.set_thread_local_data_recording(rec)
    try:
        paths = log_rerun(world)
    finally:
        rr.set_thread_local_data_recording(previous)
    rec.flush()
    rec.disconnect()
    logged = _read_back(tmp_path / "default.rrd")
    assert paths == ["/world/objects/door", "/world/objects/knob"]
    assert len(logged["/world/objects/knob"]["Points3D:positions"]) == 2


def test_bad_input_names_the_argument():
    world = wg.WorldModel.from_arrays(["door", "knob"], [[0, 0, 1], [1, 2, 1]])
    rec = rr.RecordingStream("gaussian_spheres_test")  # no sink: logging goes nowhere
    ok = pc.Percept("knob", np.array([1.0, 0.0, 0.0]), 0.01)
    result = wg.LocalizationResult(transformation=np.eye(4), position=np.zeros(3), covariance=np.eye(3),
                                   correspondences=(), hypotheses=(), ambiguous=False, status="ok")
    cases = [
        ({"world": "kitchen"}, WorldGraphError, r"world must be a WorldModel, got 'kitchen'"),
        ({"world": world, "percepts": [ok, (1.0, 2.0, 3.0)]}, WorldGraphError,
         r"percepts\[1\] must be a perception.Percept, got tuple \(1.0, 2.0, 3.0\)"),
        ({"world": world, "percepts": ok}, WorldGraphError, r"percepts must be a sequence"),
        ({"world": world, "result": {"status": "ok"}}, WorldGraphError,
         r"result must be a LocalizationResult"),
        ({"world": world, "recording": "out.rrd"}, WorldGraphError,
         r"recording must be a rerun.RecordingStream or None, got 'out.rrd'"),
        ({"world": world, "prefix": ""}, WorldGraphError, r"prefix must be a non-empty string"),
        ({"world": world, "prefix": "a//b"}, WorldGraphError, r"'a//b' \(part 1 is empty\)"),
        ({"world": world, "result": result, "n_sigma": -1.0}, WorldGraphError,
         r"n_sigma must be > 0, got -1.0"),
        ({"world": world, "truth": np.eye(3)}, WorldGraphError, r"truth"),
        ({"world": world, "truth": np.diag([1.0, 1.0, -1.0, 1.0])}, WorldGraphError, r"truth"),
    ]
    for kwargs, error, match in cases:
        kwargs.setdefault("recording", rec)
        with pytest.raises(error, match=match):
            log_rerun(**kwargs)
        assert issubclass(error, WorldGraphError)


def test_no_active_recording_is_an_error():
    world = wg.WorldModel.from_arrays(["door", "knob"], [[0, 0, 1], [1, 2, 1]])
    assert rr.get_data_recording() is None  # nothing in this process called rerun.init
    with pytest.raises(WorldGraphError, match=r"no active rerun recording"):
        log_rerun(world)


def test_missing_rerun_names_the_extra(monkeypatch):
    world = wg.WorldModel.from_arrays(["door", "knob"], [[0, 0, 1], [1, 2, 1]])
    monkeypatch.setitem(sys.modules, "rerun", None)  # import rerun -> ImportError
    with pytest.raises(ImporterError, match=r"pip install gaussian-spheres\[rerun\]"):
        log_rerun(world)


def test_a_too_old_rerun_names_the_version(monkeypatch):
    world = wg.WorldModel.from_arrays(["door", "knob"], [[0, 0, 1], [1, 2, 1]])
    monkeypatch.setattr(rr, "__version__", "0.23.4")
    with pytest.raises(ImporterError, match=r"rerun-sdk >= 0.41, found 0.23.4"):
        log_rerun(world, recording=rr.RecordingStream("gaussian_spheres_test"))


def test_example_03_writes_a_recording(tmp_path, kitchen_log):
    world = kitchen_log[0]  # the example's kitchen too (seed 0)
    script = Path(__file__).resolve().parents[2] / "examples" / "03_localize_kitchen.py"
    rrd = tmp_path / "rec" / "kitchen.rrd"
    args = [sys.executable, str(script), "--smoke", "--out", str(tmp_path), "--rerun", str(rrd)]
    done = subprocess.run(args, capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    assert f"saved {rrd}" in done.stdout
    logged = _read_back(rrd)
    assert {"/world/objects/door", "/world/percepts/door", "/world/truth"} <= set(logged)
    for t, n in Counter(o.type for o in world.objects).items():
        assert len(logged[f"/world/objects/{t}"]["Points3D:positions"]) == n, t


def test_import_worldgraph_does_not_import_rerun():
    code = ("import sys, worldgraph, worldgraph.figures.rerun_log; "
            "assert 'rerun' not in sys.modules, 'rerun loaded'")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
