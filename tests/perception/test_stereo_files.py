"""StereoRig.from_file / to_file: unusable paths, nested and oversized files are named, never a crash.

From the issue-12 audit of perception (hardening): each case failed before its fix.  Crashes (a
segfault inside OpenCV) are reproduced in a subprocess so that a regression fails the test instead
of killing the whole run.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import perception as pc
import perception.head.stereo as stereo_module
from perception.errors import (
    PerceptionError,
    RobotFileError,
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
        except pc.RobotFileError as exc:
            print('RAISED', exc)
        """, tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "RAISED path" in proc.stdout and "\\udcff" in proc.stdout


@pytest.mark.parametrize("bad", ["a\x00b.yaml", "x" * 5000, b"rig.yaml", 3, None, ""],
                         ids=["nul", "5000-chars", "bytes", "int", "none", "empty"])
def test_bad_paths_are_named_for_reading_and_writing(bad: object, tmp_path: Path) -> None:
    rig = pc.StereoRig.default()
    for call in (lambda: rig.to_file(bad), lambda: pc.StereoRig.from_file(bad)):  # type: ignore[arg-type]
        with pytest.raises(RobotFileError, match="path"):
            call()


def test_os_errors_of_a_path_become_calibration_file_errors(tmp_path: Path) -> None:
    """A path component longer than NAME_MAX gave a bare OSError (File name too long)."""
    long_name = str(tmp_path / ("x" * 300))
    with pytest.raises(RobotFileError, match=r"calibration file.*path='.*xxxx"):
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
        except pc.RobotFileError as exc:
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
    with pytest.raises(RobotFileError, match=rf"{name}.*depth {depth}\b"):
        pc.StereoRig.from_file(tmp_path / name)


def test_shallow_malformed_file_and_missing_key_name_the_path(tmp_path: Path) -> None:
    (tmp_path / "s.json").write_text("[" * 10 + "]" * 10)
    with pytest.raises(RobotFileError, match="s.json"):
        pc.StereoRig.from_file(tmp_path / "s.json")
    rig = pc.StereoRig.default()
    rig.to_file(tmp_path / "full.yaml")
    lines = (tmp_path / "full.yaml").read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("T:"))
    end = next(i for i in range(start + 1, len(lines)) if not lines[i].startswith(" "))
    (tmp_path / "no_t.yaml").write_text("\n".join(lines[:start] + lines[end:]) + "\n")
    with pytest.raises(RobotFileError, match=r"no_t.yaml.*lacks key 'T'"):
        pc.StereoRig.from_file(tmp_path / "no_t.yaml")
    # a valid file with a bad value: the error names the path as well as the value
    text = (tmp_path / "full.yaml").read_text()
    assert "0., 0., 0., 0., 0." in text
    (tmp_path / "big_d.yaml").write_text(text.replace("0., 0., 0., 0., 0.", "1.e+154, 0., 0., 0., 0.", 1))
    with pytest.raises(PerceptionError, match=r"calibration.*big_d.yaml.*D1\[0\]"):
        pc.StereoRig.from_file(tmp_path / "big_d.yaml")


def test_oversized_file_is_refused_before_parsing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    pc.StereoRig.default().to_file(tmp_path / "rig.yaml")
    size = (tmp_path / "rig.yaml").stat().st_size
    monkeypatch.setattr(stereo_module, "MAX_FILE_BYTES", size - 1)
    with pytest.raises(RobotFileError, match=rf"rig.yaml.*{size:,} bytes"):
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
