"""The sphinx-gallery hooks of docs/conf.py, importable by name (so the configuration pickles).

The examples save their figures as PNG files into ``--out`` and close them, so the gallery runs
each with ``--out EXAMPLES_OUT`` and shows the files that appeared there.
"""

from __future__ import annotations

import shutil
from pathlib import Path

EXAMPLES_OUT = Path(__file__).resolve().parent / "_build" / "examples_out"
_shown: set[Path] = set()


def reset_argv(gallery_conf, script_vars):
    """Command-line arguments of every example: its figures go to :data:`EXAMPLES_OUT`."""
    EXAMPLES_OUT.mkdir(parents=True, exist_ok=True)
    return ["--out", str(EXAMPLES_OUT)]


def saved_figures(block, block_vars, gallery_conf):
    """Image scraper: the PNG files written into :data:`EXAMPLES_OUT` since the last block."""
    from sphinx_gallery.scrapers import figure_rst

    paths = []
    new = sorted(p for p in EXAMPLES_OUT.glob("*.png") if p not in _shown)
    for png, target in zip(new, block_vars["image_path_iterator"], strict=False):
        shutil.copyfile(png, target)
        _shown.add(png)
        paths.append(target)
    return figure_rst(paths, gallery_conf["src_dir"])
