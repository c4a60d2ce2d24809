"""The sphinx-gallery hooks of docs/conf.py, importable by name (so the configuration pickles).

The examples save their figures as PNG files into ``--out`` and close them, so the gallery runs
each with ``--out out`` (relative to ``examples/``, where sphinx-gallery runs them: the pages show
``saved out/...``, as the README's commands print, and no path of the machine that built them)
and shows the files that appeared in :data:`EXAMPLES_OUT`.
"""

from __future__ import annotations

import shutil
from pathlib import Path

EXAMPLES_OUT = Path(__file__).resolve().parent.parent / "examples" / "out"  # ignored by git (out/)
_shown: set[Path] = set()


def reset_argv(gallery_conf, script_vars):
    """Command-line arguments of every example: its figures go to :data:`EXAMPLES_OUT`."""
    # the figures of an earlier build (or example) would pass for this one's: start empty
    shutil.rmtree(EXAMPLES_OUT, ignore_errors=True)
    EXAMPLES_OUT.mkdir(parents=True)
    _shown.clear()
    return ["--out", EXAMPLES_OUT.name]  # sphinx-gallery runs each example in its own directory


def saved_figures(block, block_vars, gallery_conf):
    """Image scraper: the PNG files written into :data:`EXAMPLES_OUT` since the last block, each
    at the full width of the page and linking to the image at full size (a scaled image links
    to its original: Sphinx's ``html_scaled_image_link``)."""
    paths = []
    new = sorted(p for p in EXAMPLES_OUT.glob("*.png") if p not in _shown)
    for png, target in zip(new, block_vars["image_path_iterator"], strict=False):
        shutil.copyfile(png, target)
        _shown.add(png)
        paths.append(target)
    return figures_rst(paths, gallery_conf["src_dir"])


def figures_rst(paths, src_dir) -> str:
    """reST of full-width figures (``paths`` under ``src_dir``, shown from the source root)."""
    out = []
    for path in paths:
        rel = Path(path).relative_to(src_dir).as_posix()
        out.append(f"\n.. image:: /{rel}\n   :alt: {Path(path).stem}\n   :class: sphx-glr-single-img\n"
                   "   :width: 100%\n")
    return "".join(out)


def check_every_example_has_a_figure(app, exception):
    """``build-finished`` hook: every numbered example of ``examples/`` has its figure in the
    gallery (an example that saved no PNG into ``--out`` would otherwise show none, silently)."""
    if exception is not None or str(getattr(app.config, "plot_gallery", True)).lower() in ("0", "false"):
        return  # a failed build, or one asked not to run the examples (-D plot_gallery=0)
    root = Path(app.srcdir)
    missing = [script.name for script in sorted((root.parent / "examples").glob("[0-9][0-9]_*.py"))
               if not (root / "auto_examples" / "images" / f"sphx_glr_{script.stem}_001.png").is_file()]
    if missing:
        raise RuntimeError(f"the gallery shows no figure for {', '.join(missing)}")
