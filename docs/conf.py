"""Sphinx configuration of the gaussian-spheres documentation.

Build (from the repository root, after ``pip install -e ".[docs]"``)::

    python -m sphinx -W --keep-going -b html docs docs/_build/html

The example gallery runs every script in ``examples/`` and shows the figures each one saves.
"""

from __future__ import annotations

import inspect
import os
import sys
from pathlib import Path

from sphinx.errors import PycodeError
from sphinx.pycode import ModuleAnalyzer

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
    "sphinx.ext.intersphinx",
    "sphinx.ext.mathjax",
    "sphinx-mathjax-offline",  # a copy of MathJax 3 served by the site itself: maths render offline
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
# a class page documents every method and field (each a link target), without tables of them
templates_path = ["_templates"]
autodoc_default_options = {"members": True, "show-inheritance": True}
autodoc_typehints = "none"  # numpydoc's Parameters sections say the types
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_validation_checks: set[str] = set()

# every reference must resolve: the library's own names through docs/_xref.py, the other
# projects' through the inventories kept in docs/inventories (the build has no network)
nitpicky = True
import _inventories  # noqa: E402  (docs/_inventories.py)

intersphinx_mapping = _inventories.write_inventories(ROOT / "docs" / "inventories",
                                                     ROOT / "docs" / "_build" / "inventories")
# numpy's own private names, in the expansion of ``ArrayLike`` that autodoc prints for a type alias
nitpick_ignore = [("py:class", "numpy._typing._array_like._SupportsArray"),
                  ("py:class", "numpy._typing._array_like._Buffer"),
                  ("py:class", "numpy._typing._nested_sequence._NestedSequence")]
# parameter types link: numpydoc's usual names (float, ndarray, array_like, ...) and the
# library's own classes; other words in a type stay text
numpydoc_xref_param_type = True
numpydoc_xref_ignore = "all"

html_theme = "pydata_sphinx_theme"
html_title = "gaussian-spheres"
html_theme_options = {
    "navigation_depth": 3,
    "show_toc_level": 2,
    # an example's page has one section: its code gets the right-hand column's width instead
    "secondary_sidebar_items": {**dict.fromkeys(("*", "results/*", "api/**"), ["page-toc", "sourcelink"]),
                                "auto_examples/*": []},
}
# the top-level pages have no sub-pages: no empty "Section Navigation" column beside them (the
# results, the API reference and the gallery keep theirs, which list their pages)
html_sidebars = {"*": []}
html_static_path = ["_static"]
html_css_files = ["wide.css"]  # code and tables at full width: no line cut off at 1400 px


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
    "write_computation_times": False,  # its pages load jQuery and DataTables from CDNs
}
os.environ.setdefault("MPLBACKEND", "Agg")

import _api  # noqa: E402  (docs/_api.py: the API pages, written before Sphinx reads the sources)

_api.write_pages(ROOT / "docs" / "api")
# "WorldModel" in a parameter type links to worldgraph.WorldModel, "numpy.random.Generator" to
# NumPy's page (the classes of docs/inventories, written in full)
numpydoc_xref_aliases = {**_inventories.class_names(ROOT / "docs" / "inventories"), **_api.class_aliases()}


def _data_docstring(app, what, name, obj, options, lines):
    """A constant's own ``#:`` comment, also where a package re-exports it, never the docstring of
    its type (autodoc shows ``tuple``'s or ``ndarray``'s otherwise): the comment is looked up in
    every loaded module of the three packages that holds the same object under the same name."""
    if what not in ("data", "attribute"):
        return
    type_doc = (inspect.getdoc(type(obj)) or "").strip()
    if lines and "\n".join(lines).strip() != type_doc:
        return  # the constant has a documentation of its own
    short = name.rsplit(".", 1)[-1]
    for modname, module in sorted(sys.modules.items()):
        if modname.split(".")[0] not in _api.PACKAGES:
            continue
        if getattr(module, short, None) is not obj:
            continue
        try:
            found = ModuleAnalyzer.for_module(modname).find_attr_docs().get(("", short))
        except PycodeError:
            continue
        if found:
            lines[:] = list(found)
            return
    lines[:] = []


def setup(app):
    """Constants documented by their own comments; the build fails when an example of the
    gallery shows no figure, or when a page loads from another host or names a builder path."""
    import _gallery
    import _site_checks
    import _xref

    _xref.setup(app)

    app.connect("autodoc-process-docstring", _data_docstring, priority=100)  # before numpydoc (500)
    app.connect("build-finished", _gallery.check_every_example_has_a_figure)
    app.connect("build-finished", _site_checks.check_built_site)
