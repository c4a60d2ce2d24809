"""Sphinx configuration of the gaussian-spheres documentation.

Build (from the repository root, after ``pip install -e ".[docs]"``)::

    python -m sphinx -W --keep-going -b html docs docs/_build/html

The example gallery runs every script in ``examples/`` and shows the figures each one saves.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "examples"))  # the examples import their _common helpers
sys.path.insert(0, str(ROOT / "docs"))  # _gallery: the gallery hooks

project = "gaussian-spheres"
author = "the gaussian-spheres authors"
copyright = "2026, the gaussian-spheres authors"
try:
    from importlib.metadata import version as _version

    release = _version("gaussian-spheres")
except Exception:  # a source tree that was never installed
    release = "0.1.0"

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build", "auto_examples/*.ipynb", "auto_examples/*.py",
                    "auto_examples/*.zip", "auto_examples/*.md5", "auto_examples/*.json"]

myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence"]
myst_heading_anchors = 3

# API reference: one page per module of the new homes (docs/api/*.rst list them)
autosummary_generate = True
autodoc_default_options = {"members": True, "show-inheritance": True}
autodoc_typehints = "none"  # numpydoc's Parameters sections say the types
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_validation_checks: set[str] = set()

html_theme = "pydata_sphinx_theme"
html_title = "gaussian-spheres"
html_theme_options = {
    "navigation_depth": 3,
    "show_toc_level": 2,
}


sphinx_gallery_conf = {
    "examples_dirs": str(ROOT / "examples"),
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"/\d\d_",  # run every numbered example
    "ignore_pattern": r"_common\.py",
    "image_scrapers": ("_gallery.saved_figures",),
    "reset_argv": "_gallery.reset_argv",
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "abort_on_example_error": True,
}
os.environ.setdefault("MPLBACKEND", "Agg")

import _api  # noqa: E402  (docs/_api.py: the API pages, written before Sphinx reads the sources)

_api.write_pages(ROOT / "docs" / "api")


def setup(app):
    """Fail the build when an example of the gallery shows no figure."""
    import _gallery

    app.connect("build-finished", _gallery.check_every_example_has_a_figure)
