"""A built distribution holds every package and subpackage of the source tree (the
subpackages of worldgraph would be left out of a wheel by a fixed package list)."""

from __future__ import annotations

import subprocess
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("perception", "worldgraph", "radialopt")


def _source_packages() -> set[str]:
    found = set()
    for pkg in PACKAGES:
        for init in (ROOT / pkg).rglob("__init__.py"):
            found.add(".".join(init.parent.relative_to(ROOT).parts))
    return found


def test_the_package_configuration_lists_every_subpackage() -> None:
    """setuptools' own reading of pyproject.toml names every package of the source tree (a package
    left out is installed only as data files, with a deprecation warning)."""
    import warnings

    from setuptools.config.pyprojecttoml import read_configuration

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        config = read_configuration(ROOT / "pyproject.toml", expand=True)
    listed = set(config["tool"]["setuptools"]["packages"])
    assert _source_packages() <= listed, sorted(_source_packages() - listed)


def test_the_wheel_holds_every_package_and_its_type_marker(tmp_path: Path) -> None:
    done = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps",
                           "-w", str(tmp_path), str(ROOT)], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    (wheel,) = tmp_path.glob("gaussian_spheres-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    in_wheel = {n[: -len("/__init__.py")].replace("/", ".") for n in names if n.endswith("/__init__.py")}
    assert _source_packages() <= in_wheel, sorted(_source_packages() - in_wheel)
    assert len(_source_packages()) > 3  # the subpackages are there to be checked
    for pkg in PACKAGES:
        assert f"{pkg}/py.typed" in names
    # nothing but the three packages (no tests, benchmarks or examples)
    assert {n.split("/")[0] for n in names if not n.startswith("gaussian_spheres-")} == set(PACKAGES)
