"""Package-level contracts: imports without OpenCV, versions, licence, status literals."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _run(code: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, capture_output=True, text=True,
                          timeout=120)


def test_import_worldgraph_does_not_load_opencv():
    # a fresh interpreter: this test process has imported cv2 long ago
    proc = _run("import worldgraph, perception, radialopt, sys; "
                "print(sorted(m for m in sys.modules if m == 'cv2' or m.startswith('cv2.')))")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "[]"


def test_opencv_is_loaded_when_a_function_needs_it():
    # the lazy import still works: projecting through the rig imports cv2 and gives pixels
    proc = _run("import sys, numpy as np, perception; rig = perception.StereoRig.default(); "
                "assert 'cv2' not in sys.modules; uv1, uv2 = rig.project(np.array([[0.1, 0.0, 2.0]])); "
                "print('cv2' in sys.modules, np.isfinite(uv1).all())")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["True", "True"]


def test_guard_wraps_opencv_errors_without_importing_opencv():
    import cv2

    from perception._checks import guard
    from perception.errors import PerceptionError

    @guard
    def bad():
        raise cv2.error("synthetic OpenCV failure")

    @guard
    def other():
        raise RuntimeError("not an argument error")

    with pytest.raises(PerceptionError, match="bad: invalid arguments") as info:
        bad()
    assert isinstance(info.value.__cause__, cv2.error)
    with pytest.raises(RuntimeError, match="not an argument error") as info:
        other()
    assert not isinstance(info.value, PerceptionError)


def _pyproject() -> dict:
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10: the test extra installs tomli
        import tomli as tomllib
    with open(ROOT / "pyproject.toml", "rb") as fh:
        return tomllib.load(fh)


def test_version_matches_pyproject():
    import perception
    import radialopt
    import worldgraph

    expected = _pyproject()["project"]["version"]
    assert [perception.__version__, worldgraph.__version__, radialopt.__version__] == [expected] * 3


def test_version_fallback_without_installed_distribution():
    # the source tree alone (no installed metadata) must report pyproject's version too
    expected = _pyproject()["project"]["version"]
    proc = _run("import importlib.metadata as md\n"
                "def missing(name):\n"
                "    raise md.PackageNotFoundError(name)\n"
                "md.version = missing\n"
                "import perception, radialopt, worldgraph\n"
                "print(perception.__version__, worldgraph.__version__, radialopt.__version__)")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == [expected] * 3


def test_licence_file_and_metadata_agree():
    text = (ROOT / "LICENSE").read_text()
    assert text.startswith("MIT License")
    assert "Copyright (c) 2026 the gaussian-spheres developers" in text
    assert _pyproject()["project"]["license"] == {"text": "MIT"}
