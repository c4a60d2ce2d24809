"""The documentation build fails when a page loads from another host or names a path of the
machine that built it (docs/_site_checks.py; the build itself runs in .ci/run with -W)."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import SimpleNamespace

import pytest

ROOT = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("_site_checks", ROOT / "docs" / "_site_checks.py")
assert _spec is not None and _spec.loader is not None
checks = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(checks)

CLEAN = """<html><head><link rel="stylesheet" href="_static/styles/theme.css">
<script defer="defer" src="_static/mathjax/tex-chtml.js"></script></head>
<body><a href="https://www.sphinx-doc.org/">Sphinx</a><img src="_images/top.png">
<pre>saved out/03_localize_kitchen.png</pre></body></html>"""


@pytest.mark.parametrize("tag", [
    '<script src="https://cdn.jsdelivr.net/npm/mathjax@4/tex-mml-chtml.js"></script>',
    '<script defer src="//code.jquery.com/jquery-3.7.0.js"></script>',
    '<link href="https://cdn.datatables.net/1.13.6/css/x.css" rel="stylesheet">',
    '<link rel="preload" as="font" href="https://fonts.example.org/a.woff2">',
    '<img alt="" src="http://example.org/figure.png">',
    '<div style="background: url(\'https://example.org/bg.png\')"></div>',
])
def test_resources_from_other_hosts_are_found(tag: str) -> None:
    assert checks.remote_loads(CLEAN) == []
    page = CLEAN.replace("</body>", tag + "</body>")
    assert len(checks.remote_loads(page)) == 1


@pytest.mark.parametrize("path", ["/work/main/docs/_build/examples_out/02.png", "/root/.cache/x",
                                  "/home/alice/gaussian-spheres/out", "/tmp/tmpab12/figure.png",
                                  "/usr/lib/python3.11/site-packages/numpy/__init__.py"])
def test_builder_paths_are_found(path: str) -> None:
    assert checks.builder_paths(CLEAN) == []
    assert checks.builder_paths(CLEAN.replace("out/03", path)) != []


def test_the_repository_directory_is_a_builder_path() -> None:
    page = CLEAN.replace("saved out/", "saved /srv/build/checkout/out/")
    assert checks.builder_paths(page) == []  # not one of the usual places ...
    assert checks.builder_paths(page, ("/srv/build/checkout",)) != []  # ... but the repository's own


def test_the_hook_fails_the_build_and_names_the_page(tmp_path: Path) -> None:
    (tmp_path / "docs").mkdir()
    out = tmp_path / "html"
    (out / "sub").mkdir(parents=True)
    (out / "index.html").write_text(CLEAN)
    app = SimpleNamespace(outdir=str(out), srcdir=str(tmp_path / "docs"),
                          builder=SimpleNamespace(format="html"))
    checks.check_built_site(app, None)  # a clean site passes
    remote = '<script src="https://x.org/a.js"></script></head>'
    (out / "sub" / "page.html").write_text(CLEAN.replace("</head>", remote))
    with pytest.raises(RuntimeError, match=r"sub/page.html: loads https://x.org/a.js"):
        checks.check_built_site(app, None)
    checks.check_built_site(app, RuntimeError("the build failed already"))  # then it stays out of the way
