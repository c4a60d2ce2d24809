"""The documentation build fails when an example shows no figure in the gallery (docs/_gallery.py;
the build itself runs in .ci/run)."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import SimpleNamespace

import pytest

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("_gallery", ROOT / "docs" / "_gallery.py")
assert _spec is not None and _spec.loader is not None
gallery = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(gallery)


def _site(tmp_path: Path, figures: list[str]) -> SimpleNamespace:
    (tmp_path / "examples").mkdir()
    for name in ("01_first.py", "02_second.py", "_common.py"):
        (tmp_path / "examples" / name).write_text("")
    images = tmp_path / "docs" / "auto_examples" / "images"
    images.mkdir(parents=True)
    for f in figures:
        (images / f).write_bytes(b"png")
    return SimpleNamespace(srcdir=str(tmp_path / "docs"), config=SimpleNamespace(plot_gallery=True))


def test_a_gallery_with_every_figure_passes(tmp_path: Path) -> None:
    app = _site(tmp_path, ["sphx_glr_01_first_001.png", "sphx_glr_02_second_001.png"])
    gallery.check_every_example_has_a_figure(app, None)


def test_an_example_without_its_figure_fails_the_build(tmp_path: Path) -> None:
    app = _site(tmp_path, ["sphx_glr_01_first_001.png"])
    with pytest.raises(RuntimeError, match="02_second.py"):
        gallery.check_every_example_has_a_figure(app, None)
    app.config.plot_gallery = "0"  # the examples were not run: nothing to check
    gallery.check_every_example_has_a_figure(app, None)


def test_the_repository_has_numbered_examples_for_the_gallery() -> None:
    assert len(sorted((ROOT / "examples").glob("[0-9][0-9]_*.py"))) >= 7


def test_figures_are_full_width_and_link_to_full_size(tmp_path: Path) -> None:
    """A scaled image (``:width: 100%``) links to its original in Sphinx's HTML."""
    src = tmp_path / "docs"
    rst = gallery.figures_rst([src / "auto_examples" / "images" / "sphx_glr_03_x_001.png"], src)
    assert ".. image:: /auto_examples/images/sphx_glr_03_x_001.png" in rst
    assert ":width: 100%" in rst
    assert gallery.figures_rst([], src) == ""
