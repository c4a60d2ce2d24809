"""Audit findings of issue 12 in :mod:`perception` (hardening): each case failed before its fix.

Crashes (a segfault inside OpenCV) are reproduced in a subprocess so that a regression fails the
test instead of killing the whole run.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import perception as pc
import perception.fusion as fusion_module
import perception.stereo as stereo_module
import perception.uncertainty as uncertainty_module
from perception.errors import (
    BehindCameraError,
    CalibrationError,
    CalibrationFileError,
    KinematicsError,
    NonPositiveSigmaError,
    PerceptionError,
    TooManyNeighboursError,
    UnknownClassError,
)

REPO = Path(__file__).resolve().parents[2]


def _run(code: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], cwd=cwd, capture_output=True,
                          text=True, timeout=120, env={"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin"})


# ------------------------------------------------------------------ 1, 3: file paths
def test_to_file_with_a_lone_surrogate_in_the_path_raises_instead_of_crashing(tmp_path: Path) -> None:
    proc = _run("""
        import perception as pc
        try:
            pc.StereoRig.default().to_file('r\\udcff.yaml')
        except pc.CalibrationFileError as exc:
            print('RAISED', exc)
        """, tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "RAISED path" in proc.stdout and "\\udcff" in proc.stdout


@pytest.mark.parametrize("bad", ["a\x00b.yaml", "x" * 5000, b"rig.yaml", 3, None, ""],
                         ids=["nul", "5000-chars", "bytes", "int", "none", "empty"])
def test_bad_paths_are_named_for_reading_and_writing(bad: object, tmp_path: Path) -> None:
    rig = pc.StereoRig.default()
    for call in (lambda: rig.to_file(bad), lambda: pc.StereoRig.from_file(bad)):  # type: ignore[arg-type]
        with pytest.raises(CalibrationFileError, match="path"):
            call()


def test_os_errors_of_a_path_become_calibration_file_errors(tmp_path: Path) -> None:
    """A path component longer than NAME_MAX gave a bare OSError (File name too long)."""
    long_name = str(tmp_path / ("x" * 300))
    with pytest.raises(CalibrationFileError, match=r"path='.*xxxx"):
        pc.StereoRig.from_file(long_name)


def test_legit_paths_still_round_trip(tmp_path: Path) -> None:
    rig = pc.StereoRig.from_opencv(pc.StereoRig.default().K1, [0.1, -0.2, 0.0, 0.0, 1e4],
                                   pc.StereoRig.default().K2, None, np.eye(3), [-0.1, 0, 0], (640, 480))
    for name in ("rig.yaml", "rig.xml", "rig.json", "ünïcode rig.yml"):
        rig.to_file(tmp_path / name)
        back = pc.StereoRig.from_file(str(tmp_path / name))
        for field in ("K1", "K2", "R", "T"):
            np.testing.assert_array_equal(getattr(back, field), getattr(rig, field))
        np.testing.assert_array_equal(back.D1, rig.D1)
        assert back.image_size == rig.image_size


# ------------------------------------------------------------------ 2: nested files
def test_deeply_nested_json_raises_instead_of_crashing(tmp_path: Path) -> None:
    proc = _run("""
        import perception as pc
        open('d.json', 'w').write('[' * 100000 + ']' * 100000)
        try:
            pc.StereoRig.from_file('d.json')
        except pc.CalibrationFileError as exc:
            print('RAISED', exc)
        """, tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "RAISED" in proc.stdout and "d.json" in proc.stdout and "100000" in proc.stdout


@pytest.mark.parametrize("name, text, depth", [
    ("a.json", "[" * 1000 + "]" * 1000, 1000),
    ("b.json", '{"K1": ' + "{" * 65 + "}" * 65 + "}", 66),
    ("c.yaml", "%YAML:1.0\nK1: " + "[" * 70 + "]" * 70 + "\n", 70),
    ("d.xml", '<?xml version="1.0"?>\n<opencv_storage>' + "<a>" * 80 + "</a>" * 80 + "</opencv_storage>\n",
     81),
    ("e.yaml", "%YAML:1.0\n" + "".join(" " * i + f"k{i}:\n" for i in range(70)) + " " * 70 + "x: 1\n", 71),
], ids=["json-1000", "json-66", "yaml-flow-70", "xml-81", "yaml-block-71"])
def test_nesting_deeper_than_64_is_refused_naming_path_and_depth(name: str, text: str, depth: int,
                                                                  tmp_path: Path) -> None:
    (tmp_path / name).write_text(text)
    with pytest.raises(CalibrationFileError, match=rf"{name}.*depth {depth}\b"):
        pc.StereoRig.from_file(tmp_path / name)


def test_shallow_malformed_file_and_missing_key_name_the_path(tmp_path: Path) -> None:
    (tmp_path / "s.json").write_text("[" * 10 + "]" * 10)
    with pytest.raises(CalibrationFileError, match="s.json"):
        pc.StereoRig.from_file(tmp_path / "s.json")
    rig = pc.StereoRig.default()
    rig.to_file(tmp_path / "full.yaml")
    lines = (tmp_path / "full.yaml").read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("T:"))
    end = next(i for i in range(start + 1, len(lines)) if not lines[i].startswith(" "))
    (tmp_path / "no_t.yaml").write_text("\n".join(lines[:start] + lines[end:]) + "\n")
    with pytest.raises(CalibrationFileError, match=r"no_t.yaml.*lacks key 'T'"):
        pc.StereoRig.from_file(tmp_path / "no_t.yaml")
    # a valid file with a bad value: the error names the path as well as the value
    text = (tmp_path / "full.yaml").read_text()
    assert "0., 0., 0., 0., 0." in text
    (tmp_path / "big_d.yaml").write_text(text.replace("0., 0., 0., 0., 0.", "1.e+154, 0., 0., 0., 0.", 1))
    with pytest.raises(CalibrationError, match=r"big_d.yaml.*D1\[0\]"):
        pc.StereoRig.from_file(tmp_path / "big_d.yaml")


def test_oversized_file_is_refused_before_parsing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    pc.StereoRig.default().to_file(tmp_path / "rig.yaml")
    size = (tmp_path / "rig.yaml").stat().st_size
    monkeypatch.setattr(stereo_module, "MAX_FILE_BYTES", size - 1)
    with pytest.raises(CalibrationFileError, match=rf"rig.yaml.*{size:,} bytes"):
        pc.StereoRig.from_file(tmp_path / "rig.yaml")
    monkeypatch.setattr(stereo_module, "MAX_FILE_BYTES", size)
    assert pc.StereoRig.from_file(tmp_path / "rig.yaml").image_size == (640, 480)


def _slow_depth(text: str) -> int:
    """Reference: the deepest [ / { nesting, one character at a time."""
    depth = best = 0
    for ch in text:
        depth += ch in "[{"
        depth -= ch in "]}"
        best = max(best, depth)
    return best


def test_bracket_depth_matches_a_character_loop() -> None:
    rng = np.random.default_rng(5)
    for _ in range(50):
        text = "".join(rng.choice(list("[]{}ab ,"), size=int(rng.integers(0, 300))))
        assert stereo_module._flow_depth(text.encode()) == _slow_depth(text)


# ------------------------------------------------------------------ 4: mean shift budget
def test_mean_shift_of_50000_normal_points_at_bandwidth_03_is_refused_after_one_iteration(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Before: 14 iterations (84 s) ran before the error. Now the run is refused once its first
    iteration shows that its cost does not shrink (kernel sums of one iteration only), while 100
    views of 500 objects (50,000 points that collapse onto their modes) are fused."""
    assert fusion_module.MAX_KERNEL_PAIRS == 100_000_000
    calls = []
    for name in ("_sparse_sums", "_dense_sums"):
        real = getattr(fusion_module, name)
        monkeypatch.setattr(fusion_module, name,
                            lambda *a, _real=real, **k: calls.append(1) or _real(*a, **k))
    X = np.random.default_rng(0).normal(size=(50_000, 3))
    with pytest.raises(TooManyNeighboursError, match=r"100,000,000.*50,000 points.*bandwidth"):
        pc.mean_shift_modes(X, 0.3)
    assert len(calls) <= 2  # the sparse and the crowded rows of the first iteration
    rng = np.random.default_rng(1)
    centres = rng.uniform(-10, 10, (500, 3))
    views = np.repeat(centres, 100, axis=0) + rng.normal(0, 0.01, (50_000, 3))
    modes, labels = pc.mean_shift_modes(views, 0.1)
    assert len(modes) == 500 and labels.shape == (50_000,)
    # the same points at a bandwidth holding a few points per kernel are fused
    modes, labels = pc.mean_shift_modes(X[:5_000], 0.02)
    assert labels.shape == (5_000,) and np.all((labels >= 0) & (labels < len(modes)))


# ------------------------------------------------------------------ 5: triangulation covariance
def _pairs(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray, pc.StereoRig]:
    rig = pc.StereoRig.default((160, 120))
    X = np.random.default_rng(seed).uniform([-0.3, -0.2, 1.0], [0.3, 0.2, 3.0], (n, 3))
    u1, u2 = rig.project(X)
    return u1, u2, rig


def test_triangulation_covariance_reports_a_bad_pair_before_differentiating(
        monkeypatch: pytest.MonkeyPatch) -> None:
    u1, u2, rig = _pairs(40)
    u1[33] = u2[33] - [4.0, 0.0]  # negative disparity: behind the cameras
    calls = []
    real = uncertainty_module.triangulation_jacobian
    monkeypatch.setattr(uncertainty_module, "triangulation_jacobian",
                        lambda *a, **k: calls.append(len(a[1])) or real(*a, **k))
    monkeypatch.setattr(uncertainty_module, "COVARIANCE_CHUNK", 8)
    with pytest.raises(BehindCameraError, match=r"pixel pair 33 "):
        pc.triangulation_covariance(rig, u1, u2)
    assert calls == []  # no Jacobian (8 perturbed triangulations per pair) was computed


def test_triangulation_covariance_in_chunks_equals_one_block(monkeypatch: pytest.MonkeyPatch) -> None:
    """Reference: the Jacobian of all pairs at once, ``J diag(s^2) J^T`` by explicit loops."""
    u1, u2, rig = _pairs(37, seed=1)
    s = np.array([0.5, 0.4, 0.3, 0.6])
    J = uncertainty_module.triangulation_jacobian(rig, u1, u2)
    ref = np.array([sum(s[k] ** 2 * np.outer(Jn[:, k], Jn[:, k]) for k in range(4)) for Jn in J])
    sizes = []
    real = uncertainty_module.triangulation_jacobian
    monkeypatch.setattr(uncertainty_module, "triangulation_jacobian",
                        lambda *a, **k: sizes.append(len(a[1])) or real(*a, **k))
    monkeypatch.setattr(uncertainty_module, "COVARIANCE_CHUNK", 10)
    C = pc.triangulation_covariance(rig, u1, u2, s)
    assert sizes == [10, 10, 10, 7]
    np.testing.assert_allclose(C, ref, rtol=1e-12, atol=0)


# ------------------------------------------------------------------ 6: percept bounds
def test_percept_position_and_views_are_bounded() -> None:
    with pytest.raises(PerceptionError, match=r"position\[2\] = 1e\+308"):
        pc.Percept("door", [1.0, 2.0, 1e308], 0.1)
    with pytest.raises(PerceptionError, match=r"position\[0\] = -2000000000.0"):
        pc.Percept("door", [-2e9, 2.0, 1.0], 0.1)
    with pytest.raises(PerceptionError, match=r"views .*1180591620717411303424"):
        pc.Percept("door", [1.0, 2.0, 3.0], 0.1, views=2**70)
    p = pc.Percept("door", [1e9, 0.0, 0.0], 0.1, views=2**31 - 1)
    assert p.range == 1e9 and p.views == 2**31 - 1


# ------------------------------------------------------------------ 7: units and absurd values
def test_encoder_sigma_in_degrees_is_refused_with_a_hint() -> None:
    head = pc.default_head()
    with pytest.raises(NonPositiveSigmaError, match=r"encoder_sigma\[0\] = 45.0.*degrees.*np.radians"):
        pc.percept_covariance(head, np.zeros(7), [0.1, 0.2, 2.0], np.eye(3) * 1e-4, 45.0)
    sig = np.zeros(7)
    sig[3] = 0.6
    with pytest.raises(NonPositiveSigmaError, match=r"encoder_sigma\[3\] = 0.6"):
        pc.percept_covariance(head, np.zeros(7), [0.1, 0.2, 2.0], np.eye(3) * 1e-4, sig)
    C = pc.percept_covariance(head, np.zeros(7), [0.1, 0.2, 2.0], np.eye(3) * 1e-4, 0.5)
    assert np.all(np.isfinite(C)) and np.linalg.eigvalsh(C)[0] > 0


def test_joint_angles_beyond_two_pi_are_refused_naming_the_joint() -> None:
    head = pc.default_head()
    with pytest.raises(KinematicsError, match=r"'neck_pitch'.*1e\+300.*radians.*degrees.*np.radians"):
        head.joints[0].transform(1e300)
    with pytest.raises(KinematicsError, match=r"'neck_pitch' \(index 0\) = 45.0.*np.radians"):
        head.ego_from_camera(np.full(7, 45.0))
    q = np.zeros(7)
    q[4] = -7.0
    with pytest.raises(KinematicsError, match=r"'eye_tilt' \(index 4\) = -7.0"):
        head.ego_from_camera(q)
    with pytest.raises(KinematicsError, match=r"'head_tilt'.*90"):
        head.ego_from_camera({j.name: (90.0 if j.name == "head_tilt" else 0.0) for j in head.joints})
    # 2 pi itself is one full turn: the same pose as zero
    np.testing.assert_allclose(head.joints[2].transform(2 * np.pi), head.joints[2].transform(0.0), atol=1e-12)


def test_baseline_and_distortion_are_bounded() -> None:
    with pytest.raises(CalibrationError, match=r"baseline.*1.18059162071741\d*e\+21"):
        pc.StereoRig.default((160, 120), baseline=2**70)
    assert pc.StereoRig.default((160, 120), baseline=100.0).baseline == 100.0
    K = pc.StereoRig.default((160, 120)).K1
    with pytest.raises(CalibrationError, match=r"D1\[0\] = 1e\+154"):
        pc.StereoRig.from_opencv(K, [1e154, 0, 0, 0, 0], K, None, np.eye(3), [-0.1, 0, 0], (160, 120))
    with pytest.raises(CalibrationError, match=r"D2\[4\] = -20000.0"):
        pc.StereoRig.from_opencv(K, None, K, [0, 0, 0, 0, -2e4], np.eye(3), [-0.1, 0, 0], (160, 120))


# ------------------------------------------------------------------ 8: names
@pytest.mark.parametrize("bad", ["a\x00b", "\udcff", "door\ud800"])
def test_names_reject_nul_and_lone_surrogates(bad: str) -> None:
    with pytest.raises(KinematicsError, match="joint name"):
        pc.Joint(bad, "z", np.eye(4))
    with pytest.raises(UnknownClassError, match="type"):
        pc.Percept(bad, [1.0, 2.0, 3.0], 0.1)
    with pytest.raises(UnknownClassError, match="type"):
        pc.Box(np.zeros(3), np.ones(3), np.eye(3), np.zeros(3), bad)
    with pytest.raises(UnknownClassError, match="type"):
        pc.Detection(bad, [1.0, 2.0], 3.0, np.zeros(2))


def test_non_ascii_names_stay_accepted() -> None:
    assert pc.Percept("tür", [1.0, 2.0, 3.0], 0.1).type == "tür"
    assert pc.Joint("gelenk_ä", "z", np.eye(4)).name == "gelenk_ä"


# ------------------------------------------------------------------ 9: sigma with shared loadings
def test_huge_sigma_with_shared_loadings_names_sigma() -> None:
    with pytest.raises(NonPositiveSigmaError, match=r"sigma = 1e\+308"):
        pc.Percept("door", [1.0, 2.0, 3.0], 1e308, shared=((0, np.eye(3) * 1e-4),))
    with pytest.raises(PerceptionError, match=r"shared\[0\] loading\[1, 1\] = 1e\+200"):
        pc.Percept("door", [1.0, 2.0, 3.0], 0.1, covariance=np.eye(3),
                   shared=((0, np.diag([0.0, 1e200, 0.0])),))
    p = pc.Percept("door", [1.0, 2.0, 3.0], 0.1, shared=((0, np.eye(3) * 1e-4),))
    assert p.shared[0][0] == 0
